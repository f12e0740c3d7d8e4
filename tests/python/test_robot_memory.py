"""Peak memory of robots with dense collision meshes, run as written (issue 41, item 1).

robosuite's robot and gripper files (unpacked from its wheel by scripts/setup.sh) have CAD
collision meshes of thousands of triangles and dozens of self-collision pairs: before a pair's
memory was bounded by design (docs/geometry.md, "What a pair keeps, and its budget") and meshes
were brought nearer the spacing ("Meshes finer than the spacing"), five of them exhausted 8 GB
within their first steps and Franka's arm took 3.1 GB for one. Each runs here for two steps of
its own 2 ms (contact, self-collision, its default integrator) in a process of its own, whose
peak resident set (the kernel's count for that child alone, not a timing) stays under 500 MB.
Measured (KB, two steps): fourier hand 260,652, spot 120,760, tiago 250,580, xarm7 89,516,
panda 50,188.
"""
import subprocess
import sys

import pytest

from conftest import ROOT, SCM

ASSETS = ROOT / ".venv" / "robosuite_assets" / "robosuite" / "models" / "assets"
# The inspire hand is left out: it peaks at 468 to 478 MB (one or two steps), too near the
# limit to assert with a margin, and its first step takes about two minutes (its 13 links are
# sampled at 0.2 to 1 mm, all within one another's SSDF reach); see docs/geometry.md.
ROBOTS = ["grippers/fourier_left_hand.xml",
          "robots/spot/robot.xml", "robots/tiago/robot.xml", "robots/xarm7/robot.xml",
          "robots/panda/robot.xml"]
LIMIT_KB = 500_000
#: Robots run with another integrator than their own, and why. TIAGo's own is implicit Euler:
#: since its pairs took their stiffness from solref (docs/mjcf.md) its first step's Newton
#: iterations fail in some runs and not in others of the same build (measured: 1 of 2 locally,
#: and in CI), a run-to-run difference that is a defect of its own (issue 41, item 5); its memory
#: is measured on damped Euler, which passed 3 of 3.
INTEGRATOR = {"robots/tiago/robot.xml": "damped_euler"}

# The child's own peak: a fresh Python whose only child is scm, so RUSAGE_CHILDREN is scm's.
PEAK = """
import resource, subprocess, sys
r = subprocess.run(sys.argv[1:], capture_output=True, text=True)
print(r.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
sys.stderr.write(r.stderr[-2000:])
"""


@pytest.mark.parametrize("robot", ROBOTS, ids=[r.split("/")[-2] if r.endswith("robot.xml")
                                                else r.split("/")[-1][:-4] for r in ROBOTS])
def test_a_robot_with_dense_meshes_runs_its_first_steps_in_bounded_memory(robot, tmp_path):
    scene = ASSETS / robot
    assert scene.exists(), f"{scene}: run scripts/setup.sh (it unpacks robosuite's wheel)"
    out = subprocess.run(
        [sys.executable, "-c", PEAK, str(SCM), "simulate", str(scene), "--duration", "0.004",
         "-o", str(tmp_path / "run.csv")]
        + (["--integrator", INTEGRATOR[robot]] if robot in INTEGRATOR else []),
        capture_output=True, text=True, check=True)
    code, peak_kb = (int(x) for x in out.stdout.split())
    assert code == 0, f"scm simulate {robot} failed:\n{out.stderr}"
    rows = (tmp_path / "run.csv").read_text().splitlines()
    assert len(rows) >= 2, "no row written"
    print(f"{robot}: peak {peak_kb} KB")
    assert peak_kb < LIMIT_KB, f"{robot}: peak resident {peak_kb} KB"
