"""Peak memory of robots with dense collision meshes, run as written (issue 41, item 1).

robosuite's robot and gripper files (unpacked from its wheel by scripts/setup.sh) have CAD
collision meshes of thousands of triangles and dozens of self-collision pairs: before a pair's
memory was bounded by design (docs/geometry.md, "What a pair keeps, and its budget") and meshes
were brought nearer the spacing ("Meshes finer than the spacing"), five of them exhausted 8 GB
within their first steps and Franka's arm took 3.1 GB for one. Each runs here for two steps of
its own 2 ms (contact, self-collision, its default integrator) in a process of its own, whose
peak resident set (the kernel's count for that child alone, not a timing) stays under 500 MB.
Measured (KB, two steps, 2026-12-05): fourier hand 47,644, inspire hand 45,540, spot 33,844,
tiago 52,516, xarm7 15,528, panda 23,004, jaco gripper 16,848 (before a pair's memory was
bounded: fourier hand 260,652, spot 120,760, tiago 250,580, xarm7 89,516, panda 50,188; the
inspire hand peaked at 468 to 478 MB, its first step about two minutes). At their first row, no pair pushes where MuJoCo measures more than 2 cm between its bodies
(nearer, xArm7's base and link 1 push with 66 N 0.2 mm apart: tests/python/test_robot_contact.py).
"""
import functools
import pathlib
import subprocess
import sys
import tempfile

import pytest

from conftest import ROOT, SCM

sys.path.insert(0, str(ROOT / "scripts"))
from robots import pairs_across_gaps  # noqa: E402  (shared with reports/robots.md)

# One pytest-xdist worker runs this module's tests: each robot's first steps are run once and shared by two tests.
pytestmark = pytest.mark.xdist_group("robot_memory")

ASSETS = ROOT / ".venv" / "robosuite_assets" / "robosuite" / "models" / "assets"
# The Jaco gripper's thumb has its centre of mass on its hinge: MuJoCo's inverse weight made
# its pairs' stiffness 8.6e36 N/m until the effective mass was capped (docs/mjcf.md).
ROBOTS = ["grippers/fourier_left_hand.xml", "grippers/inspire_right_hand.xml",
          "robots/spot/robot.xml", "robots/tiago/robot.xml", "robots/xarm7/robot.xml",
          "robots/panda/robot.xml", "grippers/jaco_three_finger_gripper.xml"]
LIMIT_KB = 500_000
# The child's own peak: a fresh Python whose only child is scm, so RUSAGE_CHILDREN is scm's.
PEAK = """
import resource, subprocess, sys
r = subprocess.run(sys.argv[1:], capture_output=True, text=True)
print(r.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
sys.stderr.write(r.stderr[-2000:])
"""


IDS = [r.split("/")[-2] if r.endswith("robot.xml") else r.split("/")[-1][:-4] for r in ROBOTS]


@functools.lru_cache(maxsize=None)
def first_steps(robot):
    """Runs `robot` for two steps, once per session: its exit status, peak resident set (KB),
    stderr and CSV rows."""
    scene = ASSETS / robot
    assert scene.exists(), f"{scene}: run scripts/setup.sh (it unpacks robosuite's wheel)"
    with tempfile.TemporaryDirectory() as tmp:
        csv = pathlib.Path(tmp) / "run.csv"
        out = subprocess.run(
            [sys.executable, "-c", PEAK, str(SCM), "simulate", str(scene), "--duration", "0.004",
             "-o", str(csv)],
            capture_output=True, text=True, check=True)
        rows = csv.read_text().splitlines() if csv.exists() else []
    code, peak_kb = (int(x) for x in out.stdout.split())
    return code, peak_kb, out.stderr, rows


@pytest.mark.parametrize("robot", ROBOTS, ids=IDS)
def test_a_robot_with_dense_meshes_runs_its_first_steps_in_bounded_memory(robot):
    code, peak_kb, stderr, rows = first_steps(robot)
    assert code == 0, f"scm simulate {robot} failed:\n{stderr}"
    assert len(rows) >= 2, "no row written"
    print(f"{robot}: peak {peak_kb} KB")
    assert peak_kb < LIMIT_KB, f"{robot}: peak resident {peak_kb} KB"


#: A gap MuJoCo measures between two bodies beyond which SCM's pair must push with no more
#: than the smooth law's tail (a micronewton): MuJoCo's mesh distances are to convex hulls,
#: never farther than the surfaces SCM samples.
GAP = 0.02
# Far from a part, the SSDF is the plane of its nearest point, and beside the edge of a flat
# face that plane passes close to the query. The plane body's polytope bounds every reading
# from below (docs/method.md, departure 3), which ended xArm7's 164 N across 4.25 cm. Its
# margin was the cloud's largest face's cover radius for every plane, and meshes in patches
# have faces as large as their patches: the Fourier hand's palm pushed its index intermediate
# link with 5.5e-3 N where MuJoCo measures 27 mm, until each plane read against its own
# face's margin ("Each plane's own margin").
@pytest.mark.parametrize("robot", ROBOTS, ids=IDS)
def test_no_pair_pushes_where_mujoco_sees_a_gap(robot):
    code, _, stderr, rows = first_steps(robot)
    assert code == 0, f"scm simulate {robot} failed:\n{stderr}"
    assert_no_contact_where_mujoco_sees_a_gap(ASSETS / robot, rows)


def assert_no_contact_where_mujoco_sees_a_gap(scene, rows, gap=GAP, tail=1e-6):
    """At t = 0, every SCM pair whose bodies MuJoCo puts more than `gap` apart has a positive
    distance and, with `tail`, no contact force beyond the smooth law's tail (a micronewton;
    measured up to 6e-9 N on the Fourier hand). A mesh simplified with a triangle folded into
    the part made TIAGo's arm link push its base with 450 kN from 0.34 m away
    (docs/geometry.md)."""
    checked = 0
    for pair, distance, force in pairs_across_gaps(scene, rows, gap):
        checked += 1
        assert distance > 0, f"{pair}: distance {distance} where MuJoCo sees a gap"
        if tail is not None:
            assert max(map(abs, force)) < tail, f"{pair}: force {force} N where MuJoCo sees a gap"
    assert checked > 0


def test_fingers_do_not_read_inside_each_other_where_mujoco_sees_a_gap():
    """robosuite's inspire hand at its initial pose: its finger links are 9.8 to 15.9 mm thin,
    and sampled in patches of 1 cm eight pairs read each other up to 3.3 mm deep where MuJoCo's
    hull distances are 4.7 to 8.3 mm, pushing with up to 20 N. With five points across each
    thin mesh and each pair's ε1 scaled to its spacing (docs/geometry.md, "Thin meshes";
    docs/method.md, "ε1 follows the spacing") every pair MuJoCo puts more than 3 mm apart had
    a positive smooth distance by the meshes' surfaces (the least, 0.6 mm, between proximal
    links 4.7 mm apart by MuJoCo) and pushed with up to 0.010 N; by the convex hulls MuJoCo
    collides meshes by (docs/mjcf.md, "How a mesh collides") the least is 5.9 mm and the
    largest push 1.3e-10 N, and none may push with 1 mN. At three points
    across with ε1 = 1e-5 m² for every pair, the proximal links side by side pushed each other
    with up to 1.44 N across those 4.7 mm (the planes round their patches' edges weighing
    e^(-g s/ε1) there), and the index proximal link once pushed the middle distal one with
    11.7 N across MuJoCo's 7.85 mm, when every plane had the cloud's largest margin."""
    robot = "grippers/inspire_right_hand.xml"
    code, _, stderr, rows = first_steps(robot)
    assert code == 0, f"scm simulate {robot} failed:\n{stderr}"
    assert_no_contact_where_mujoco_sees_a_gap(ASSETS / robot, rows, gap=0.003, tail=1e-3)


def test_a_robot_runs_the_same_bits_every_time(tmp_path):
    """TIAGo's arm meshes are open, so they collide by their convex hulls, many of whose
    vertices are coplanar: the hull once depended on a hash set's order, which changes from run
    to run, and with it the contacts (and whether the first step's Newton iterations converged).
    Two runs of the same file give the same bytes."""
    scene = ASSETS / "robots/tiago/robot.xml"
    out = []
    for k in range(2):
        csv = tmp_path / f"run{k}.csv"
        subprocess.run([str(SCM), "simulate", str(scene), "--duration", "0.004", "-o", str(csv)],
                       capture_output=True, text=True, check=True)
        out.append(csv.read_bytes())
    assert out[0] == out[1]


def test_fetch_runs_and_no_pair_pushes_where_mujoco_sees_a_gap(tmp_path):
    """gymnasium-robotics' Fetch: at t = 0 its shoulder lift link read the laser link 5.5 cm
    inside it (the SSDF's far field beside a flat face's edge) where MuJoCo measures 47.8 cm
    between them, and pushed with 2.6e5 N: the first implicit step's Newton iterations failed.
    With the polytope's floor no pair pushes across a gap, and two steps run."""
    from conftest import ROBOTICS_DIR
    scene = ROBOTICS_DIR / "fetch" / "reach.xml"
    csv = tmp_path / "fetch.csv"
    run = subprocess.run([str(SCM), "simulate", str(scene), "--duration", "0.004", "-o", str(csv)],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert_no_contact_where_mujoco_sees_a_gap(scene, csv.read_text().splitlines())


def test_the_fourier_hands_palm_does_not_push_its_thumb_across_mujocos_gap():
    """robosuite's Fourier hand at its initial pose: its palm and its thumb's proximal link are
    3.43 mm apart (MuJoCo's hull distance, and the two meshes' least point-to-triangle
    distance). By the meshes' surfaces SCM's pair read -0.89 mm and pushed with 5.6 N: thumb
    points 10 to 29 mm from the palm's mesh read a palm patch's plane past its face's edge,
    inside the palm's bounding polytope (docs/method.md, departure 3, "Where the floor does not
    reach"). By the convex hulls MuJoCo collides meshes by (docs/mjcf.md, "How a mesh
    collides") it reads +5.05 mm and pushes with 1.8e-5 N, and every pair MuJoCo puts more
    than 3 mm apart pushes with less than 1 mN (measured 2026-12-06)."""
    robot = "grippers/fourier_left_hand.xml"
    code, _, stderr, rows = first_steps(robot)
    if code != 0:
        pytest.fail(f"scm simulate {robot} failed:\n{stderr}")
    assert_no_contact_where_mujoco_sees_a_gap(ASSETS / robot, rows, gap=0.003, tail=1e-3)
