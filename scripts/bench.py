"""Step cost against MuJoCo, measured in one run (issue 20's benchmark): every bundled scene, a
few generated ones and MuJoCo's own model files (the ones gymnasium ships), each through the
FMU's C ABI (`fmi2DoStep` of one internal step, in examples/step_cost.rs) and through MuJoCo's
`mj_step` on the same file, from the same start and warm-up time, at the same step and with the
same time stepping: semi-implicit Euler (MuJoCo's `Euler` with its implicit joint damping
switched off). The contact models differ (SCM's forces against MuJoCo's constraint solver), and
so do the warm-ups' integrators (SCM's scene integrator at 1 ms, MuJoCo's Euler at the step).

With each time, the error of the run: the largest error of a body's position and orientation
after ERROR_T s from the warmed-up state at the benchmark's step, against a converged reference
of the same engine from the same state (SCM: `rk4` at h/16, examples/step_cost.rs; MuJoCo: its
`RK4` at h/16), with the distance of each reference from the same at h/8 as its check. Also SCM's
implicit Euler step (a step in a running simulation, its Newton Jacobian carried over) against
its explicit one.

Run by scripts/bench.sh. Writes reports/bench.md (table) and reports/bench.png (plot), or
--out DIR. Times are medians over interleaved rounds on each side, the two engines timed in turn
--rounds times per scene (medians of those); the ratio is SCM / MuJoCo.
Nothing here is a pass/fail test: the figures are what the targets of issue 20 are read from.
"""
import argparse
import copy
import importlib.util
import json
import pathlib
import subprocess
import sys
import tempfile
import zipfile

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from report.common import with_setting  # noqa: E402
from report.speed import mujoco_step_time, mujoco_warmed  # noqa: E402  (shared with the report)

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCM = ROOT / "target" / "release" / "scm"
STEP_COST = ROOT / "target" / "release" / "examples" / "step_cost"
H = 0.002
# The error of a run is measured ERROR_T s after the warm-up, against the same engine's RK4 at
# H / n, n as step_cost reports it (`reference_divisions`).
ERROR_T = 0.1
GYMNASIUM_SPEC = importlib.util.find_spec("gymnasium")
GYMNASIUM = pathlib.Path(GYMNASIUM_SPEC.origin).parent / "envs" / "mujoco" / "assets" if GYMNASIUM_SPEC else None
# MuJoCo's own files (gymnasium's models, unchanged: their timestep and integrator are replaced by
# the benchmark's, both engines alike), from their initial pose: those that stand on a floor fall
# onto it without control, so their steps are timed in contact; the pendulum falls from its top;
# the reacher and the swimmer, which nothing moves in their plane, get every actuator at half its
# upper control limit (CONTROLLED).
CONTROLLED = {"reacher", "swimmer"}
FILES = ["inverted_pendulum", "reacher", "swimmer", "hopper", "walker2d", "half_cheetah", "ant",
         "humanoid"]

# Bundled scenes: (scene, --set values that put it in contact, warm-up s).
BUNDLED = [
    ("sphere_drop", {"ball.pos.z": 0.06}, 0.3),
    ("box_stack", {}, 0.3),
    ("t_push", {"act_y.ctrl": 0.13}, 0.5),
    ("arm_push", {"shoulder.q": 1.42, "shoulder_motor.ctrl": 0.5}, 0.4),
    ("horseshoe", {}, 0.3),
]


# The files also timed at a looser pruning tolerance (`--tolerance`).
TOLERANCE_ROWS = ("t_push", "humanoid")


def floating(n=3, gravity=False):
    """Bodies 0.5 m apart, 0.5 m above a floor: without gravity nothing is ever in reach; with
    it they fall, out of reach for the first 0.3 s."""
    shapes = ['type="box" size="0.05 0.05 0.05"', 'type="sphere" size="0.05"',
              'type="capsule" size="0.03 0.05"']
    bodies = "\n".join(
        f'    <body name="b{i}" pos="{0.5 * (i % 2)} {0.5 * (i // 2)} 0.5"><freejoint/>'
        f'<geom {shapes[i % 3]} mass="1"/></body>' for i in range(n))
    return f"""<mujoco model="floating{n}">
  <option{"" if gravity else ' gravity="0 0 0"'} timestep="{H}" integrator="Euler"/>
  <worldbody>
    <geom name="floor" type="plane" size="3 3 0.1"/>
{bodies}
  </worldbody>
</mujoco>
"""


def resting_boxes(n):
    """n 10 cm boxes resting on a floor, 30 cm apart on a grid."""
    side = int(np.ceil(np.sqrt(n)))
    bodies = "\n".join(
        f'    <body name="box{i}" pos="{0.3 * (i % side)} {0.3 * (i // side)} 0.0499"><freejoint/>'
        f'<geom type="box" size="0.05 0.05 0.05" mass="1"/></body>' for i in range(n))
    return f"""<mujoco model="boxes{n}">
  <option timestep="{H}" integrator="Euler"/>
  <worldbody>
    <geom name="floor" type="plane" size="10 10 0.1"/>
{bodies}
  </worldbody>
</mujoco>
"""


def scm_step(xml, sets, warmup, work, error=True, integrators=("semi_implicit_euler", "implicit_euler")):
    """SCM's step times (s) under `integrators`, and with `error` its errors: {integrator: result
    of step_cost}."""
    unpacked = work / xml.stem
    if not unpacked.exists():
        fmu = work / (xml.stem + ".fmu")
        p = subprocess.run([str(SCM), "pack", str(xml), "-o", str(fmu)], capture_output=True, text=True)
        if p.returncode != 0:
            raise SystemExit(f"bench: scm pack {xml}: {p.stderr.strip()}")
        with zipfile.ZipFile(fmu) as z:
            z.extractall(unpacked)
    args = [str(STEP_COST), str(unpacked), "--h", repr(H), "--warmup", repr(warmup),
            "--integrators", ",".join(integrators), "--steps-only", "--budget", "0.3"]
    if error:
        args += ["--error", repr(ERROR_T)]
    for n, x in sets.items():
        args += ["--set", f"{n}={x!r}"]
    p = subprocess.run(args, capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"bench: step_cost {xml}: {p.stderr.strip()}")
    return {r["integrator"]: r for r in json.loads(p.stdout)["results"]}


def file_controls(xml):
    """Every actuator of a MuJoCo file at half its upper control limit (1 where unlimited), by
    SCM's names for them (`actuatorN` where the file names none)."""
    import mujoco
    m = mujoco.MjModel.from_xml_path(str(xml))
    sets = {}
    for i in range(m.nu):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, i) or f"actuator{i}"
        sets[f"{name}.ctrl"] = 0.5 * float(m.actuator_ctrlrange[i][1]) if m.actuator_ctrllimited[i] else 1.0
    return sets


# Every MuJoCo integrator against the SCM method its MJCF name maps to (docs/mjcf.md,
# `<option integrator>`), with MuJoCo's `Euler` as written (its implicit joint damping on), and
# semi-implicit Euler on both sides: (MuJoCo's name, `mjtIntegrator`, `eulerdamp`, SCM's
# integrator).
REACH_METHODS = [("Euler", "EULER", True, "damped_euler"), ("RK4", "RK4", True, "damped_rk4"),
                 ("implicitfast", "IMPLICITFAST", True, "implicit_euler"),
                 ("Euler, eulerdamp off", "EULER", False, "semi_implicit_euler")]
# The warm-up of the bodies out of reach: with gravity on, they have fallen 1.2 cm of their 0.5 m.
REACH_WARMUP = 0.05
# The bundled scenes in contact timed under every integrator too (names of BUNDLED): the T pushed
# MuJoCo's way (its `Euler`, SCM's `damped_euler`) is one of the speed targets.
CONTACT_EVERY_INTEGRATOR = ("box_stack", "t_push")
# The speed targets, SCM / MuJoCo in this run: (what, the rows' scene, the MuJoCo integrators of
# its rows in the every-integrator table (None: all of them; "first": the first table's
# semi-implicit row instead), the largest ratio allowed). The robots as written are timed over
# whole runs by scripts/robots.py (reports/robots.md).
TARGETS = [("`box_stack`, semi-implicit Euler", "box_stack", "first", 1.5),
           ("`t_push` pushing, MuJoCo's `Euler` (`damped_euler`)", "t_push", ("Euler",), 5.0),
           ("bodies out of reach, gravity off, every integrator", "floating3_weightless", None, 1.2),
           ("bodies out of reach, gravity on, every integrator", "floating3_gravity", None, 1.2)]


def every_integrator_rows(work, rounds):
    """The every-integrator table's rows: `floating3` with gravity off and on (nothing in reach:
    MuJoCo must count no contact) and the scenes of CONTACT_EVERY_INTEGRATOR (in contact: MuJoCo
    must count one at least), per method of REACH_METHODS, SCM's step and MuJoCo's (s), each the
    median of `rounds` timings in turn."""
    cases = []
    for gravity in (False, True):
        name = f"floating3_{'gravity' if gravity else 'weightless'}"
        path = work / f"{name}.xml"
        path.write_text(floating(3, gravity))
        cases.append((name, path, {}, REACH_WARMUP, False))
    cases += [(s, ROOT / "resources" / "scenes" / f"{s}.xml", sets, w, True)
              for s, sets, w in BUNDLED if s in CONTACT_EVERY_INTEGRATOR]
    rows = []
    for name, path, sets, warmup, contact in cases:
        print(f"bench: {name}, every integrator", file=sys.stderr, flush=True)
        ours, theirs = {m[3]: [] for m in REACH_METHODS}, {m[0]: [] for m in REACH_METHODS}
        for _ in range(max(1, rounds)):
            timed = scm_step(path, sets, warmup, work, error=False, integrators=list(ours))
            for method, r in timed.items():
                ours[method].append(r["ffi_step_s"])
            for label, integrator, damp, _ in REACH_METHODS:
                t, ncon = mujoco_step_time(path, sets, warmup, h=H, eulerdamp=damp, integrator=integrator)
                if bool(ncon) != contact:
                    raise SystemExit(f"bench: {name}: MuJoCo has {ncon} contacts after the warm-up "
                                     f"under {label}")
                theirs[label].append(t)
        for label, _, _, method in REACH_METHODS:
            rows.append((name, label, method, float(np.median(ours[method])), float(np.median(theirs[label]))))
    return rows


def target_lines(rows, every):
    """The speed targets' table (TARGETS) from this run's rows: the first table's (`rows`) and
    the every-integrator table's (`every`)."""
    first = {r["name"]: r["ours"]["semi_implicit_euler"]["ffi_step_s"] / r["theirs"] for r in rows}
    lines = []
    for what, scene, labels, most in TARGETS:
        if labels == "first":
            ratios = [first[scene]] if scene in first else []
        else:
            ratios = [o / t for n, label, _, o, t in every if n == scene and (labels is None or label in labels)]
        if not ratios:
            continue
        # Rounded as printed, so the verdict is the one the printed figure gives.
        worst = round(max(ratios), 2)
        lines.append(f"| {what} | ≤ {most:g} | {worst:.2f} | {'met' if worst <= most else 'not met'} |")
    return lines


def pose_difference(m, a, b):
    """The largest difference of a body's pose between two MjData: (position (m), rotation angle
    (rad)), from the poses of their current states."""
    import mujoco
    for x in (a, b):  # the poses of the final state (mj_step leaves those of the one before)
        mujoco.mj_kinematics(m, x)
    pos = float(np.max(np.linalg.norm(a.xpos - b.xpos, axis=1)))
    rot = 0.0
    for p, q in zip(a.xmat.reshape(-1, 3, 3), b.xmat.reshape(-1, 3, 3)):
        r = p.T @ q  # the angle from its sine and cosine, exact down to small angles
        axial = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
        rot = max(rot, float(np.arctan2(np.linalg.norm(axial), np.trace(r) - 1.0)))
    return pos, rot


def mujoco_error(xml, sets, warmup, divisions):
    """MuJoCo's error after ERROR_T s from its warmed-up state (semi-implicit Euler at H) against
    its RK4 at H / divisions from the same state, and that reference's distance from the same at
    H / (divisions / 2): two (position (m), rotation angle (rad)), the largest over bodies."""
    import mujoco
    m, d = mujoco_warmed(xml, sets, warmup, H, eulerdamp=False)
    ref, coarse = copy.deepcopy(d), copy.deepcopy(d)
    n = int(round(ERROR_T / H))
    mujoco.mj_step(m, d, nstep=n)
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    for x, k in ((ref, divisions), (coarse, divisions // 2)):
        m.opt.timestep = H / k
        mujoco.mj_step(m, x, nstep=n * k)
    return pose_difference(m, d, ref), pose_difference(m, coarse, ref)


def error_cell(pos, rot):
    """A pose error for the table: position in µm, rotation in µrad."""
    return f"{pos * 1e6:.3g} µm, {rot * 1e6:.3g} µrad"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "reports")
    ap.add_argument("--boxes", default="2,8,32", help="numbers of resting boxes (scaling)")
    ap.add_argument("--rounds", type=int, default=3,
                    help="SCM and MuJoCo timed in turn this many times per scene (medians)")
    ap.add_argument("--files", default=",".join(FILES),
                    help="MuJoCo model files among gymnasium's (names without .xml), or 'none'")
    ap.add_argument("--tolerance", type=float, default=1e-9,
                    help="also time t_push and the humanoid (where run) at this scm_prune_tolerance (0: not)")
    ap.add_argument("--no-reach", dest="reach", action="store_false",
                    help="leave out the table of every integrator (bodies out of reach, and in contact)")
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    files = [] if a.files == "none" else a.files.split(",")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        work = pathlib.Path(tmp)
        cases = [(ROOT / "resources" / "scenes" / f"{s}.xml", sets, w, s) for s, sets, w in BUNDLED]
        gen = [("floating3", floating(3), 0.05)] + [
            (f"boxes{n}", resting_boxes(int(n)), 0.3) for n in a.boxes.split(",")]
        for name, text, w in gen:
            path = work / f"{name}.xml"
            path.write_text(text)
            cases.append((path, {}, w, name))
        for f in files:
            if GYMNASIUM is None:
                raise SystemExit("bench: gymnasium is not installed (scripts/setup.sh installs it): "
                                 "no MuJoCo model files; --files none runs without them")
            path = GYMNASIUM / f"{f}.xml"
            if not path.exists():
                raise SystemExit(f"bench: {path}: no such MuJoCo model (gymnasium's assets)")
            cases.append((path, file_controls(path) if f in CONTROLLED else {}, 0.3, f))
        # The same files at a looser pruning tolerance (docs/method.md, "Numerical rules"):
        # what it buys, in the same run.
        if a.tolerance > 0:
            for xml, sets, w, name in list(cases):
                if name in TOLERANCE_ROWS:
                    path = work / f"{name}_prune_tolerance.xml"
                    path.write_text(with_setting(xml.read_text(), "scm_prune_tolerance", a.tolerance))
                    cases.append((path, sets, w, f"{name} at τ = {a.tolerance:g}"))
        for xml, sets, warmup, name in cases:
            print(f"bench: {name}", file=sys.stderr, flush=True)
            # The two engines timed in turn, a.rounds times each, and the medians kept: a change
            # of the machine's load between the two timings (which moved single-round ratios by
            # 2x on this machine) then weighs on both sides alike.
            ours = scm_step(xml, sets, warmup, work)
            times = {k: [v["ffi_step_s"]] for k, v in ours.items()}
            mj = []
            for r in range(max(1, a.rounds)):
                t, ncon = mujoco_step_time(xml, sets, warmup, h=H, eulerdamp=False)
                mj.append(t)
                if r + 1 < a.rounds:
                    for k, v in scm_step(xml, sets, warmup, work, error=False).items():
                        times[k].append(v["ffi_step_s"])
            for k, v in times.items():
                ours[k]["ffi_step_s"] = float(np.median(v))
            theirs = float(np.median(mj))
            divisions = int(ours["semi_implicit_euler"]["reference_divisions"])
            error, check = mujoco_error(xml, sets, warmup, divisions)
            rows.append(dict(name=name, ours=ours, theirs=theirs, ncon=ncon, theirs_error=error,
                             theirs_check=check))
        reach = every_integrator_rows(work, a.rounds) if a.reach else []
    lines = ["# Step cost against MuJoCo", "",
             "Written by `scripts/bench.sh` (one run; medians of interleaved rounds, the two engines timed in "
             f"turn {a.rounds} times per scene). One internal step of "
             f"{H * 1e3:g} ms, semi-implicit Euler: SCM through the FMU's C ABI (`fmi2DoStep`, a step in a running "
             "simulation), MuJoCo 4's `mj_step` (`Euler` with `eulerdamp` disabled: the same method) on the same file "
             "from the same warm-up. `floating3`: three bodies 0.5 m apart above a floor, nothing in reach; "
             "`boxesN`: N boxes resting on a floor 30 cm apart; below them, MuJoCo's model files that gymnasium ships, "
             "unchanged but for the step and the method, from rest with no control.", "",
             f"Error: the largest error of a body's position and orientation {ERROR_T:g} s after the warm-up, "
             "against the same engine's RK4 at h/16 from the same state (each engine's own "
             "reference: the two models differ in their contact, so this is how well each integrates its own "
             "model); `reference check`: the largest position difference of each reference (SCM, MuJoCo) from "
             "the same at h/8 (a fourth-order reference's own error is about a fifteenth of it). "
             "`implicit_euler`: SCM's implicit Euler step at the same state and step, its Newton Jacobian "
             "carried from step to step; `impl. / expl.` divides it by SCM's semi-implicit Euler step. "
             "MuJoCo's steps are timed in runs of 100 from its warmed-up state, where its contacts are counted. "
             "Gymnasium's robots fall onto their floor without control; the reacher and the swimmer run with "
             "every actuator at half its upper control limit.", "",
             "| scene | SCM step (µs) | MuJoCo step (µs) | SCM / MuJoCo | SCM error | MuJoCo error "
             "| reference check (µm) | SCM implicit_euler (µs) | impl. / expl. | MuJoCo contacts |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    refused = []
    for r in rows:
        e, i = r["ours"]["semi_implicit_euler"], r["ours"]["implicit_euler"]
        check = f"{e['reference_check_pos_m'] * 1e6:.2g}, {r['theirs_check'][0] * 1e6:.2g}"
        if "error_refused" in e:
            # The error run was refused by SCM's energy guard (a blow-up caught): said, not hidden.
            refused.append(f"- {r['name']}: {e['error_refused']}")
            ours_error = f"refused ({len(refused)})"
        else:
            ours_error = error_cell(e['error_pos_m'], e['error_rot_rad'])
        lines.append(f"| {r['name']} | {e['ffi_step_s'] * 1e6:.1f} | {r['theirs'] * 1e6:.2f} | "
                     f"{e['ffi_step_s'] / r['theirs']:.1f} | {ours_error} | "
                     f"{error_cell(*r['theirs_error'])} | {check} | {i['ffi_step_s'] * 1e6:.1f} | "
                     f"{i['ffi_step_s'] / e['ffi_step_s']:.1f} | {r['ncon']} |")
    if refused:
        lines += ["", f"SCM error runs refused ({H * 1e3:g} ms semi-implicit Euler, {ERROR_T:g} s from the warm-up; "
                  "numbered as in the table; the step times stand, measured from the warm-up state):"] + refused
    boxes = [(int(r["name"][5:]), r["ours"]["semi_implicit_euler"]["ffi_step_s"], r["theirs"])
             for r in rows if r["name"].startswith("boxes")]
    if boxes:
        lines += ["", "Cost per body (resting boxes): " + ", ".join(
            f"{n}: SCM {o / n * 1e6:.1f} µs, MuJoCo {t / n * 1e6:.2f} µs" for n, o, t in boxes) + "."]
    if reach:
        lines += ["", "## Every integrator: bodies out of reach, and in contact", "",
                  f"`floating3` (above) without and with gravity ({REACH_WARMUP:g} s after the start: "
                  "fallen 1.2 cm of their 0.5 m, nothing in reach on either side), and "
                  + " and ".join(f"`{s}`" for s in CONTACT_EVERY_INTEGRATOR) + " in contact (from the first "
                  "table's warm-up, each engine under each integrator), one step of "
                  f"{H * 1e3:g} ms under each of MuJoCo's integrators against the SCM method its MJCF name "
                  "maps to (docs/mjcf.md), MuJoCo's `Euler` as written (its implicit joint damping on); "
                  "the last row of each scene semi-implicit Euler on both sides. Medians of the rounds above.", "",
                  "| scene | MuJoCo integrator | SCM method | SCM step (µs) | MuJoCo step (µs) | SCM / MuJoCo |",
                  "| --- | --- | --- | ---: | ---: | ---: |"]
        lines += [f"| {n} | {label} | `{method}` | {o * 1e6:.2f} | {t * 1e6:.2f} | {o / t:.2f} |"
                  for n, label, method, o, t in reach]
    targets = target_lines(rows, reach)
    if targets:
        lines += ["", "## Speed targets", "",
                  "SCM's step over MuJoCo's in this run, the largest of the rows above that each target covers "
                  "(where the time goes: docs/performance.md). Gymnasium's humanoid, hopper and ant as written, "
                  "robosuite's Franka arm and the shadow hand are timed over whole runs as their files are "
                  "written, by `scripts/robots.py` (reports/robots.md).", "",
                  "| target | SCM / MuJoCo at most | this run | |", "| --- | ---: | ---: | --- |"] + targets
    (a.out / "bench.md").write_text("\n".join(lines) + "\n")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, (ax, bx) = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
        x = np.arange(len(rows))
        ax.bar(x - 0.2, [r["ours"]["semi_implicit_euler"]["ffi_step_s"] * 1e6 for r in rows], 0.4,
               label="SCM (fmi2DoStep)")
        ax.bar(x + 0.2, [r["theirs"] * 1e6 for r in rows], 0.4, label="MuJoCo (mj_step)")
        ax.set_yscale("log")
        ax.set_ylabel("time per step (µs)")
        ax.legend()
        # Errors below 1 nm are drawn at 1 nm (the bottom of the axis): at rest both are rounding.
        floor = 1e-9
        # A refused run has no error: no bar.
        bx.bar(x - 0.2, [max(r["ours"]["semi_implicit_euler"].get("error_pos_m", np.nan), floor) * 1e6
                         for r in rows],
               0.4, label="SCM")
        bx.bar(x + 0.2, [max(r["theirs_error"][0], floor) * 1e6 for r in rows], 0.4, label="MuJoCo")
        bx.set_yscale("log")
        bx.set_ylim(bottom=floor * 1e6)
        bx.set_ylabel(f"position error after {ERROR_T:g} s (µm)")
        bx.set_xticks(x, [r["name"] for r in rows], rotation=30, ha="right")
        bx.legend()
        fig.tight_layout()
        fig.savefig(a.out / "bench.png", dpi=120)
    except ImportError:
        print("bench: matplotlib missing: no plot", file=sys.stderr)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
