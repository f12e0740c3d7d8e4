"""Contact on, SCM against MuJoCo's own spread (issue 40, item 4; docs/mjcf.md, "Contact on,
against MuJoCo's spread"): every gymnasium file, dm_control suite file and gymnasium-robotics
file its environments load, run as written with
zero controls, 1 s (2 s for the legged ones), in SCM (`scm simulate`) and in MuJoCo under
plausible contact parameters: solref's time constant x0.5, x1, x2, friction x0.8, x1, x1.2, with
Euler, RK4 and implicitfast (27 runs). A file passes when SCM's final pose lies inside MuJoCo's
envelope: each slide and hinge coordinate and each free body's position within the runs' range
widened by 2 cm (or 0.1 rad), each free body's and ball joint's orientation within 0.1 rad of
one of the runs'.

    .venv/bin/python scripts/contact_envelope.py [--only NAME,...] [--out FILE.md] [--stiffness K]

`--stiffness K` runs SCM on a copy of each file (beside it, removed after) that sets
`scm_stiffness` K and `scm_dissipation_velocity` 0.1 m/s for every pair: SCM's contact before its
pairs took their law from solref and solimp (K = 1e4).

Needs scripts/setup.sh (the corpora, the venv with mujoco) and a release build. Prints a Markdown
table, one row per file.
"""
import argparse
import csv
import io
import pathlib
import re
import subprocess
import sys
import time

import mujoco
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "python"))
from conftest import DM_CONTROL_DIR, DM_CONTROL_REFUSED, ROBOTICS, SCM, robotics_id  # noqa: E402

import gymnasium  # noqa: E402

GYM = sorted((pathlib.Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets").glob("*.xml"))
DM = sorted(DM_CONTROL_DIR.glob("*.xml"))
#: Legged models run 2 s (they fall or settle on their legs).
LEGGED = re.compile(r"ant|humanoid|walker|hopper|cheetah|quadruped|dog")
INTEGRATORS = {"Euler": mujoco.mjtIntegrator.mjINT_EULER, "RK4": mujoco.mjtIntegrator.mjINT_RK4,
               "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST}
POSITION, ANGLE = 0.02, 0.1


def fmu_name(name):
    return name if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name) else \
        "'" + name.replace("\\", "\\\\").replace("'", "\\'") + "'"


def coordinates(m):
    """(kind, FMU names, qpos address) for every joint."""
    out = []
    for j in range(m.njnt):
        name = fmu_name(m.joint(j).name or m.body(m.jnt_bodyid[j]).name)
        a = m.jnt_qposadr[j]
        kind = m.jnt_type[j]
        if kind == mujoco.mjtJoint.mjJNT_FREE:
            out.append(("pos", [f"{name}.pos.{c}" for c in "xyz"], a))
            out.append(("quat", [f"{name}.quat.{c}" for c in "wxyz"], a + 3))
        elif kind == mujoco.mjtJoint.mjJNT_BALL:
            out.append(("quat", [f"{name}.quat.{c}" for c in "wxyz"], a))
        else:
            out.append(("slide" if kind == mujoco.mjtJoint.mjJNT_SLIDE else "hinge", [f"{name}.q"], a))
    return out


#: MuJoCo's warnings that it found a run unstable and reset its state.
UNSTABLE = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)


def mujoco_finals(path, seconds):
    finals = []
    for integrator in INTEGRATORS.values():
        for tau in (0.5, 1.0, 2.0):
            for mu in (0.8, 1.0, 1.2):
                m = mujoco.MjModel.from_xml_path(str(path))
                m.opt.integrator = integrator
                for solref in (m.geom_solref, m.pair_solref):
                    solref[solref[:, 0] > 0, 0] *= tau
                m.geom_friction[:, 0] *= mu
                m.pair_friction[:, 0] *= mu
                d = mujoco.MjData(m)
                for _ in range(round(seconds / m.opt.timestep)):
                    mujoco.mj_step(m, d)
                # A run MuJoCo finds unstable (a position, velocity or acceleration it cannot
                # take: it resets its state and warns) is no outcome.
                if not any(d.warning[w].number for w in UNSTABLE):
                    finals.append(d.qpos.copy())
    return m, np.array(finals)


def scm_final(path, seconds, stiffness=None, sets=()):
    """SCM's final values of every output after `seconds`, or (None, why it stopped); `sets`:
    FMU variables set before the run (`scm.eps2=1e-4`)."""
    copy = None
    if stiffness is not None:
        text = path.read_text()
        custom = (f'<custom><numeric name="scm_stiffness" data="{stiffness}"/>'
                  '<numeric name="scm_dissipation_velocity" data="0.1"/></custom>')
        copy = path.parent / f".envelope.{path.name}"
        copy.write_text(re.sub(r"(<mujoco[^>]*>)", r"\1" + custom, text, count=1))
    try:
        run = subprocess.run([str(SCM), "simulate", str(copy or path), "--duration", str(seconds),
                              "--output-interval", str(seconds)] + [f"--set={x}" for x in sets],
                             capture_output=True, text=True)
    finally:
        if copy is not None:
            copy.unlink()
    if run.returncode != 0:
        return None, run.stderr.strip().splitlines()[-1] if run.stderr.strip() else "failed"
    rows = list(csv.reader(io.StringIO(run.stdout)))
    return dict(zip(rows[0], map(float, rows[-1]))), None


def angle(q1, q2):
    q1, q2 = q1 / np.linalg.norm(q1), q2 / np.linalg.norm(q2)
    return 2 * np.arccos(min(1.0, abs(float(np.dot(q1, q2)))))


def compare(m, finals, ours):
    """(inside, worst excess (m or rad), where)."""
    worst, where = 0.0, ""
    for kind, names, a in coordinates(m):
        if kind == "quat":
            q = np.array([ours[n] for n in names])
            excess = min(angle(q, f[a:a + 4]) for f in finals) - ANGLE
            if excess > worst:
                worst, where = excess, names[0].rsplit(".", 2)[0] + " orientation"
            continue
        pad = ANGLE if kind == "hinge" else POSITION
        for k, n in enumerate(names):
            x = ours[n]
            lo, hi = finals[:, a + k].min() - pad, finals[:, a + k].max() + pad
            excess = max(lo - x, x - hi)
            if excess > worst:
                worst, where = excess, n
    return worst <= 0.0, worst, where


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", default="")
    ap.add_argument("--out")
    ap.add_argument("--stiffness", type=float)
    args = ap.parse_args()
    only = set(filter(None, args.only.split(",")))
    rows = ["| file | s | SCM | inside MuJoCo's envelope | worst excess | where | SCM wall (s) |",
            "|---|---|---|---|---|---|---|"]
    inside = total = 0
    for corpus, files in (("gymnasium", GYM), ("dm_control", DM), ("gymnasium-robotics", ROBOTICS)):
        for path in files:
            # A test id (gymnasium-robotics has two reach.xml: Fetch's is reach_fetch).
            name = robotics_id(path) if corpus == "gymnasium-robotics" else path.stem
            if only and name not in only:
                continue
            if corpus == "dm_control" and path.stem in DM_CONTROL_REFUSED:
                continue
            try:
                m, finals = mujoco_finals(path, 2.0 if LEGGED.search(path.stem) else 1.0)
            except Exception as e:  # not a model MuJoCo loads on its own (a template)
                print(f"skipped {corpus}/{path.name}: {e}", file=sys.stderr)
                continue
            seconds = 2.0 if LEGGED.search(path.stem) else 1.0
            if m.njnt == 0:
                continue
            t0 = time.time()
            ours, error = scm_final(path, seconds, args.stiffness)
            wall = time.time() - t0
            total += 1
            if ours is None:
                rows.append(f"| {corpus}/{name} | {seconds:g} | {error} | no | | | {wall:.1f} |")
            else:
                ok, worst, where = compare(m, finals, ours)
                inside += ok
                rows.append(f"| {corpus}/{name} | {seconds:g} | ran | {'yes' if ok else 'no'} | "
                            f"{max(worst, 0.0):.3g} | {where} | {wall:.1f} |")
            print(rows[-1], flush=True)
    rows.append(f"\n{inside} of {total} files inside MuJoCo's envelope.")
    text = "\n".join(rows)
    print(text)
    if args.out:
        pathlib.Path(args.out).write_text(text + "\n")


if __name__ == "__main__":
    main()
