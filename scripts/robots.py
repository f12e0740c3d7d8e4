"""Robots as their files are written, in SCM and in MuJoCo, measured in one run (issue 41's
speed and memory targets): each file run with its own integrator, step and contact settings,
from its initial state with no control, SCM through `scm simulate` (one CSV row at the start and
one at the end, of one output: the contact outputs' distances, which evaluate every pair in full,
are left out as MuJoCo's timing leaves out everything but `mj_step`) in a child process whose
peak resident set is read from the kernel (RUSAGE_CHILDREN), MuJoCo through `mj_step` on the
same file for the same number of steps.

The ratio is SCM's wall time per internal step over MuJoCo's; the real-time factor is simulated
time over wall time (above 1: faster than real time). SCM's time is the stepping alone (what
`scm simulate` reports as its wall time: the scene's loading and sampling are left out, and
given apart). MuJoCo's is the median of 5 runs of the same steps from its initial state.

The files come from the wheels scripts/setup.sh unpacks (robosuite 1.5.2, gymnasium-robotics
1.4.2, gymnasium). Writes reports/robots.md, or --out FILE. Nothing here is a pass/fail test.
"""
import argparse
import importlib.util
import pathlib
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from report.common import with_setting  # noqa: E402  (shared with the report and the benchmark)

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCM = ROOT / "target" / "release" / "scm"
ROBOSUITE = ROOT / ".venv" / "robosuite_assets" / "robosuite" / "models" / "assets"
ROBOTICS = ROOT / ".venv" / "gymnasium_robotics_assets" / "gymnasium_robotics" / "envs" / "assets"
GYM_SPEC = importlib.util.find_spec("gymnasium")
GYMNASIUM = pathlib.Path(GYM_SPEC.origin).parent / "envs" / "mujoco" / "assets" if GYM_SPEC else None

# (label, file, simulated seconds): durations sized so that the slowest runs take about a minute.
ROBOTS = [
    ("Franka (robosuite)", ROBOSUITE / "robots/panda/robot.xml", 0.1),
    ("xArm7 (robosuite)", ROBOSUITE / "robots/xarm7/robot.xml", 0.1),
    ("Spot (robosuite)", ROBOSUITE / "robots/spot/robot.xml", 0.05),
    ("TIAGo (robosuite)", ROBOSUITE / "robots/tiago/robot.xml", 0.05),
    ("Jaco (robosuite)", ROBOSUITE / "robots/jaco/robot.xml", 0.02),
    ("Fourier hand (robosuite)", ROBOSUITE / "grippers/fourier_left_hand.xml", 0.02),
    ("Inspire hand (robosuite)", ROBOSUITE / "grippers/inspire_right_hand.xml", 0.05),
    ("Robotiq 140 (robosuite)", ROBOSUITE / "grippers/robotiq_gripper_140.xml", 0.05),
    ("Shadow hand reach (gymnasium-robotics)", ROBOTICS / "hand/reach.xml", 0.2),
]
if GYMNASIUM:
    ROBOTS += [(f"{n} (gymnasium)", GYMNASIUM / f"{n}.xml", 1.0) for n in ("hopper", "ant", "humanoid")]

# A fresh Python whose only child is scm, so RUSAGE_CHILDREN is scm's own peak.
PEAK = """
import resource, subprocess, sys, time
t0 = time.perf_counter()
r = subprocess.run(sys.argv[1:], capture_output=True, text=True)
t1 = time.perf_counter()
print(r.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, t1 - t0)
sys.stderr.write(r.stderr[-3000:])
"""


def first_output(scm, xml, timeout):
    """The name of the scene's first Real output (`scm variables`), or None where it lists none
    or fails (the run then reports why)."""
    try:
        p = subprocess.run([str(scm), "variables", str(xml)], capture_output=True, text=True,
                           timeout=timeout)
    except subprocess.TimeoutExpired:
        return None
    for line in p.stdout.splitlines()[1:]:
        fields = line.split("\t")
        if len(fields) > 3 and fields[2] == "Real" and fields[3] == "output":
            # As a glob pattern that matches itself only.
            return "".join(f"[{c}]" if c in "[]*?" else c for c in fields[1])
    return None


def pairs_across_gaps(xml, rows, gap=0.003):
    """The contact pairs of an `scm simulate` CSV (`rows`: its lines, the header and the row at
    t = 0 first) whose bodies MuJoCo puts more than `gap` (m) apart at the file's initial state
    (the least `mj_geomDistance` between their colliding geoms): (pair, SCM's distance, SCM's
    force components) each. A pair whose bodies MuJoCo's model lacks fails an assertion."""
    import mujoco
    m = mujoco.MjModel.from_xml_path(str(xml))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    names = [m.body(b).name for b in range(m.nbody)]
    # A variable's name quotes a body name that is not a plain identifier ('robot0:base_link');
    # SCM names an unnamed body `body<its index>`, the index in document order that MuJoCo's
    # ids follow (gymnasium's ant's lower legs).
    alias = {}
    for b, n in enumerate(names):
        for key in ([n, f"'{n}'"] if n else [f"body{b}"]):
            alias.setdefault(key, b)
    colliding = [g for g in range(m.ngeom) if m.geom_contype[g] or m.geom_conaffinity[g]]
    fromto = np.zeros(6)
    row = dict(zip(rows[0].split(","), rows[1].split(",")))
    found = []
    for col in row:
        if not (col.startswith("contact.") and col.endswith(".distance")):
            continue
        pair = col[len("contact."):-len(".distance")]
        split = [(pair[:i], pair[i + 1:]) for i in range(len(pair))
                 if pair[i] == "." and pair[:i] in alias and pair[i + 1:] in alias]
        assert len(split) == 1, f"{col}: bodies not found in MuJoCo's model"
        a, b = (alias[x] for x in split[0])
        ga = [g for g in colliding if m.geom_bodyid[g] == a]
        gb = [g for g in colliding if m.geom_bodyid[g] == b]
        if min((mujoco.mj_geomDistance(m, d, i, j, 1.0, fromto) for i in ga for j in gb),
               default=1.0) > gap:
            force = [float(row[f"contact.{pair}.force.{x}"]) for x in "xyz"]
            found.append((pair, float(row[col]), force))
    return found


def across_gaps(scm, xml, timeout, gap=0.003):
    """At the file's initial state: how many of SCM's contact pairs MuJoCo puts more than `gap`
    (m) apart ([`pairs_across_gaps`]), the largest force component any of them gives in SCM
    (N): a pair pushing where MuJoCo sees a gap, and of the pairs MuJoCo puts apart by any gap
    the one whose force is largest in SCM, with that force's size (N). `None` where the run
    fails."""
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "start.csv"
        try:
            p = subprocess.run([str(scm), "simulate", str(xml), "--duration", "0.002", "-o", str(out)],
                               capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return None
        if p.returncode != 0 or not out.exists():
            return None
        rows = out.read_text().splitlines()
    found = pairs_across_gaps(xml, rows, gap)
    # Bodies MuJoCo puts apart by any gap: the pair pushing most in SCM (name, force's norm).
    pushing = ((pair, float(np.linalg.norm(force))) for pair, _, force in pairs_across_gaps(xml, rows, 0.0))
    apart = max((p for p in pushing if p[1] > 0), key=lambda x: x[1], default=("none", 0.0))
    return len(found), max((abs(f) for _, _, force in found for f in force), default=0.0), apart


def with_tolerance(xml, tolerance):
    """A copy of `xml` beside it (so that its meshes and includes resolve) whose `<custom>` sets
    `scm_prune_tolerance`; the caller removes it."""
    out = xml.with_name(f".{xml.stem}.prune_tolerance{xml.suffix}")
    out.write_text(with_setting(xml.read_text(), "scm_prune_tolerance", tolerance))
    return out


def scm_run(scm, xml, duration, timeout):
    """SCM's stepping wall time (s), its whole run's (s), peak resident set (MB), an error text
    or None, and the last row of the one output it wrote (or None)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "run.csv"
        cmd = [sys.executable, "-c", PEAK, str(scm), "simulate", str(xml), "--duration", repr(duration),
               "--output-interval", repr(duration), "-o", str(out)]
        one = first_output(scm, xml, timeout)
        if one is not None:
            cmd += ["--outputs", one]
        try:
            p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return None, None, None, f"not done within {timeout} s", None
        rows = out.read_text().splitlines() if out.exists() else []
        last = float(rows[-1].split(",")[-1]) if len(rows) > 1 and one is not None else None
    code, peak_kb, whole = p.stdout.split()
    m = re.search(r"in ([0-9.]+) s wall time", p.stderr)
    if int(code) != 0 or not m:
        tail = [line for line in p.stderr.splitlines() if line.strip()][-1:] or ["(no message)"]
        return None, float(whole), int(peak_kb) / 1024, f"exit {code}: {tail[0][:200]}", None
    if float(m.group(1)) == 0:
        return None, float(whole), int(peak_kb) / 1024, "stepped in under 1 ms of wall time (scm's resolution): give a longer duration", None
    return float(m.group(1)), float(whole), int(peak_kb) / 1024, None, last


def mujoco_run(xml, steps):
    """MuJoCo's time per step (s) over `steps` from the initial state (median of 5), its
    integrator's name and step (s), and its contacts at the initial state and at the end."""
    import mujoco
    m = mujoco.MjModel.from_xml_path(str(xml))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    start = int(d.ncon)
    samples = []
    for _ in range(5):
        mujoco.mj_resetData(m, d)
        t0 = time.perf_counter()
        mujoco.mj_step(m, d, nstep=steps)
        samples.append((time.perf_counter() - t0) / steps)
    name = mujoco.mjtIntegrator(m.opt.integrator).name
    return float(np.median(samples)), name, m.opt.timestep, (start, int(d.ncon))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "reports" / "robots.md")
    ap.add_argument("--timeout", type=float, default=600.0, help="per SCM run (s)")
    ap.add_argument("--only", help="labels containing this text")
    ap.add_argument("--scm", type=pathlib.Path, default=SCM, help="the scm binary (another build's, to compare)")
    ap.add_argument("--file", type=pathlib.Path, action="append", default=[],
                    help="time this MJCF file instead of the list (repeatable; with --duration)")
    ap.add_argument("--duration", type=float, default=0.02, help="simulated time of each --file (s)")
    ap.add_argument("--tolerance", type=float, default=1e-9,
                    help="also time each file at this scm_prune_tolerance (0: not)")
    a = ap.parse_args()
    robots = [(f.stem, f, a.duration) for f in a.file] if a.file else ROBOTS
    rows = []
    for label, xml, duration in robots:
        if a.only and a.only not in label:
            continue
        if not xml.exists():
            raise SystemExit(f"robots: {xml} missing: run scripts/setup.sh")
        t_mj, integrator, h, ncon = mujoco_run(xml, max(1, round(duration / 0.002)))
        steps = max(1, round(duration / h))
        wall, whole, peak, err, end = scm_run(a.scm, xml, steps * h, a.timeout)
        loose = None
        if a.tolerance > 0 and not err:
            variant = with_tolerance(xml, a.tolerance)
            try:
                loose = scm_run(a.scm, variant, steps * h, a.timeout)
            finally:
                variant.unlink()
        gaps = across_gaps(a.scm, xml, a.timeout)
        print(f"{label}: {integrator} h={h}: SCM {wall} s stepping ({whole} s in all), {peak} MB; "
              f"MuJoCo {t_mj * 1e6:.1f} us/step; {err or ''}; at the looser tolerance {loose}", file=sys.stderr)
        rows.append((label, xml, integrator, h, steps, wall, whole, peak, t_mj, ncon, err, end, loose, gaps))
    lines = [
        "# Robots as written, against MuJoCo",
        "",
        "Written by `scripts/robots.py` (one run). Each file with its own integrator, step and contact"
        " settings, from its initial state with no control: SCM by `scm simulate` (stepping time, one"
        " CSV row at each end with one output: no contact distance, which evaluates every pair in full;"
        " peak resident set of the whole process), MuJoCo by `mj_step` on the same"
        " file for the same steps (median of 5 runs). Real-time factor: simulated time over wall time."
        " MuJoCo's contacts at the file's initial state and after the run: robosuite's files start at"
        " every joint's zero, where some arms fold through themselves (robosuite sets its own initial"
        " pose before a run), so their steps are timed in deep self-contact on both sides."
        + (f" Columns 14 to 16: the same SCM run with the scene's pruning tolerance at {a.tolerance:g}"
           " (`scm_prune_tolerance`, default 1e-15: docs/method.md, \"Numerical rules\"), and how far the"
           " run's one output (the file's first) ended from the default's." if a.tolerance > 0 else "")
        + " Across MuJoCo's gaps: at the initial state, SCM's contact pairs whose bodies MuJoCo puts more"
          " than 3 mm apart (`mj_geomDistance` between their colliding geoms) and the largest force"
          " component any of them gives in SCM (a pair pushing where MuJoCo sees a gap; one step with"
          " every contact output, apart from the timed run). The last column: of the pairs MuJoCo puts"
          " apart by any gap at the initial state, the one pushing most in SCM and its force (N; xArm7's"
          " base and link 1, 0.2 mm apart in MuJoCo: docs/mjcf.md, \"Contact on, against MuJoCo's spread\").",
        "",
        "| robot | file's integrator, step | steps | SCM per step (ms) | MuJoCo per step (µs) | SCM / MuJoCo |"
        " SCM real-time factor | MuJoCo real-time factor | SCM load (s) | SCM peak (MB) | MuJoCo contacts (start, end) |"
        " pairs across MuJoCo's gaps | largest force across them (N) |"
        + (f" SCM per step at τ = {a.tolerance:g} (ms) | SCM / MuJoCo at τ = {a.tolerance:g} | output's end apart |"
           if a.tolerance > 0 else "")
        + " pushing most where MuJoCo's bodies are apart (N) |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
        + (" ---: | ---: | ---: |" if a.tolerance > 0 else "") + " --- |",
    ]
    notes = []
    for label, xml, integrator, h, steps, wall, whole, peak, t_mj, ncon, err, end, loose, gaps in rows:
        across = f" {gaps[0]} | {gaps[1]:.2g} |" if gaps else " — | — |"
        pushing = f" {gaps[2][0]}, {gaps[2][1]:.2g} |" if gaps else " — |"
        mj = f"{t_mj * 1e6:.1f}"
        mj_rtf = f"{h / t_mj:.0f}"
        if err:
            notes.append(f"- {label}: {err}")
            lines.append(f"| {label} | {integrator}, {h} s | {steps} | — | {mj} | — | — | {mj_rtf} | — |"
                         f" {peak and f'{peak:.0f}' or '—'} | {ncon[0]}, {ncon[1]} |{across}"
                         + (" — | — | — |" if a.tolerance > 0 else "") + pushing)
            continue
        per = wall / steps
        extra = ""
        if a.tolerance > 0:
            if loose is None or loose[3]:
                extra = f" — | — | {loose[3] if loose else '—'} |"
            else:
                lper = loose[0] / steps
                apart = f"{abs(loose[4] - end):.1e}" if end is not None and loose[4] is not None else "—"
                extra = f" {lper * 1e3:.4g} | {lper / t_mj:.0f} | {apart} |"
        lines.append(f"| {label} | {integrator}, {h} s | {steps} | {per * 1e3:.4g} | {mj} | {per / t_mj:.0f} |"
                     f" {h / per:.4g} | {mj_rtf} | {whole - wall:.1f} | {peak:.0f} | {ncon[0]}, {ncon[1]} |{across}"
                     + extra + pushing)
    if notes:
        lines += ["", "Runs that did not finish:", *notes]
    lines.append("")
    a.out.write_text("\n".join(lines))
    print(f"wrote {a.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
