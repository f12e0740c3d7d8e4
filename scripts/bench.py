"""Step cost against MuJoCo, measured in one run (issue 20's benchmark): every bundled scene and
a few generated ones, each through the FMU's C ABI (`fmi2DoStep` of one internal step, in
examples/step_cost.rs) and through MuJoCo's `mj_step` on the same file, from the same warm-up,
at the same step and with the same kind of integrator (semi-implicit Euler; MuJoCo's `Euler`).

Run by scripts/bench.sh. Writes reports/bench.md (table) and reports/bench.png (plot), or
--out DIR. Times are medians over interleaved rounds on each side; the ratio is SCM / MuJoCo.
Nothing here is a pass/fail test: the figures are what the targets of issue 20 are read from.
"""
import argparse
import json
import pathlib
import subprocess
import sys
import tempfile
import zipfile

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from report.speed import mujoco_step_time  # noqa: E402  (one MuJoCo timing, shared with the report)

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCM = ROOT / "target" / "release" / "scm"
STEP_COST = ROOT / "target" / "release" / "examples" / "step_cost"
H = 0.002

# Bundled scenes: (scene, --set values that put it in contact, warm-up s).
BUNDLED = [
    ("sphere_drop", {"ball.pos.z": 0.06}, 0.3),
    ("box_stack", {}, 0.3),
    ("t_push", {"act_y.ctrl": 0.13}, 0.5),
    ("arm_push", {"shoulder.q": 1.42, "shoulder_motor.ctrl": 0.5}, 0.4),
    ("horseshoe", {}, 0.3),
]


def floating(n=3):
    """Bodies 0.5 m apart above a floor, no gravity: nothing is ever in reach."""
    shapes = ['type="box" size="0.05 0.05 0.05"', 'type="sphere" size="0.05"',
              'type="capsule" size="0.03 0.05"']
    bodies = "\n".join(
        f'    <body name="b{i}" pos="{0.5 * (i % 2)} {0.5 * (i // 2)} 0.5"><freejoint/>'
        f'<geom {shapes[i % 3]} mass="1"/></body>' for i in range(n))
    return f"""<mujoco model="floating{n}">
  <option gravity="0 0 0" timestep="{H}" integrator="Euler"/>
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


def scm_step(xml, sets, warmup, work):
    fmu = work / (xml.stem + ".fmu")
    p = subprocess.run([str(SCM), "pack", str(xml), "-o", str(fmu)], capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"bench: scm pack {xml}: {p.stderr.strip()}")
    unpacked = work / xml.stem
    with zipfile.ZipFile(fmu) as z:
        z.extractall(unpacked)
    args = [str(STEP_COST), str(unpacked), "--h", repr(H), "--warmup", repr(warmup),
            "--integrators", "semi_implicit_euler", "--steps-only", "--budget", "0.3"]
    for n, x in sets.items():
        args += ["--set", f"{n}={x!r}"]
    p = subprocess.run(args, capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"bench: step_cost {xml}: {p.stderr.strip()}")
    r = json.loads(p.stdout)["results"][0]
    return r["ffi_step_s"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "reports")
    ap.add_argument("--boxes", default="2,8,32", help="numbers of resting boxes (scaling)")
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
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
        for xml, sets, warmup, name in cases:
            print(f"bench: {name}", file=sys.stderr, flush=True)
            ours = scm_step(xml, sets, warmup, work)
            theirs, ncon = mujoco_step_time(xml, sets, warmup, h=H)
            rows.append((name, ours, theirs, ncon))
    lines = ["# Step cost against MuJoCo", "",
             "Written by `scripts/bench.sh` (one run; medians of interleaved rounds). One internal step of "
             f"{H * 1e3:g} ms, semi-implicit Euler: SCM through the FMU's C ABI (`fmi2DoStep`), MuJoCo 4's "
             "`mj_step` (`Euler`) on the same file from the same warm-up. `floating3`: three bodies 0.5 m apart "
             "above a floor, nothing in reach; `boxesN`: N boxes resting on a floor 30 cm apart.", "",
             "| scene | SCM step (µs) | MuJoCo step (µs) | SCM / MuJoCo | MuJoCo contacts |",
             "| --- | --- | --- | --- | --- |"]
    for name, ours, theirs, ncon in rows:
        lines.append(f"| {name} | {ours * 1e6:.1f} | {theirs * 1e6:.2f} | {ours / theirs:.1f} | {ncon} |")
    boxes = [(int(r[0][5:]), r[1], r[2]) for r in rows if r[0].startswith("boxes")]
    if boxes:
        lines += ["", "Cost per body (resting boxes): " + ", ".join(
            f"{n}: SCM {o / n * 1e6:.1f} µs, MuJoCo {t / n * 1e6:.2f} µs" for n, o, t in boxes) + "."]
    (a.out / "bench.md").write_text("\n".join(lines) + "\n")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(8, 4))
        x = np.arange(len(rows))
        ax.bar(x - 0.2, [r[1] * 1e6 for r in rows], 0.4, label="SCM (fmi2DoStep)")
        ax.bar(x + 0.2, [r[2] * 1e6 for r in rows], 0.4, label="MuJoCo (mj_step)")
        ax.set_yscale("log")
        ax.set_xticks(x, [r[0] for r in rows], rotation=30, ha="right")
        ax.set_ylabel("time per step (µs)")
        ax.legend()
        fig.tight_layout()
        fig.savefig(a.out / "bench.png", dpi=120)
    except ImportError:
        print("bench: matplotlib missing: no plot", file=sys.stderr)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
