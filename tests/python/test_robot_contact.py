"""A robot's contact where MuJoCo sees a gap (docs/mjcf.md, "Contact on, against MuJoCo's
spread"): robosuite's xArm7 as written (implicitfast, 2 ms), its base joint driven by 3 N·m
(above its frictionloss of 1 N·m) for 0.1 s while the arm starts to fall.

Its base and link 1, a parent welded to the world and its child, collide in MuJoCo as in SCM,
and lie 0.2 mm apart by MuJoCo's hulls: no contact there. Under departure 3's margin, SCM's
clouds, sampled at the file's default 1 cm, read 1.36 mm into each other and pushed with 66 N,
whose friction braked joint 1 (0.0069 rad where MuJoCo turns 0.285 rad, 0.283 rad with that
pair excluded). A mesh's cloud now has the tight floor, and the pair pushes 11 N across the gap
by the contact law's `ε3` tail: 0.178 rad, 0.2828 at `ε3` = 2e-5 m. The first test holds the
cause (the arm turns as MuJoCo's without that pair); the second is a strict expected failure
(of its assertion only: an error of the run is not expected) that passes the day the pair
stops braking the joint at the defaults. `scm check` warns about such pairs
(src/bin/scm/misread.rs): the third test holds what it reports against MuJoCo's distance.
"""
import math
import pathlib
import subprocess

import mujoco
import pytest

from conftest import ROOT, SCM

XARM = ROOT / ".venv" / "robosuite_assets" / "robosuite" / "models" / "assets" / "robots" / "xarm7" / "robot.xml"
TORQUE, SECONDS = 3.0, 0.1


def mujoco_turn(path=XARM):
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    d.ctrl[m.actuator("torq_j1").id] = TORQUE
    for _ in range(round(SECONDS / m.opt.timestep)):
        mujoco.mj_step(m, d)
    return d.qpos[m.joint("joint1").qposadr[0]]


def scm_turn(path, actuator="torq_j1", joint="joint1", torque=TORQUE, sets=()):
    run = subprocess.run([str(SCM), "simulate", str(path), "--duration", str(SECONDS), "--output-interval",
                          str(SECONDS), "--set", f"{actuator}.ctrl={torque}", "--outputs", f"{joint}.q"]
                         + [a for s in sets for a in ("--set", s)], capture_output=True, text=True)
    if run.returncode != 0:  # an error, not the expected failure below
        raise RuntimeError(run.stderr)
    return float(run.stdout.strip().splitlines()[-1].split(",")[1])


def test_without_the_base_pair_the_base_joint_turns_as_mujocos(tmp_path):
    # The copy sits beside the file, whose meshes it names relative to its folder.
    copy = XARM.parent / f".{tmp_path.name}.robot.xml"
    copy.write_text(XARM.read_text().replace(
        "</mujoco>", '<contact><exclude body1="base" body2="link1"/></contact></mujoco>'))
    try:
        ours = scm_turn(copy)
    finally:
        copy.unlink()
    theirs = mujoco_turn()
    assert theirs > 0.2, theirs
    # Measured 0.283 against 0.285 rad (0.7 % apart: SCM's smooth frictionloss against
    # MuJoCo's constraint on the same 1 N·m); 5 % leaves room for that model difference and
    # fails by far where the pair still brakes (0.0069 rad).
    assert abs(ours - theirs) <= 0.05 * theirs, (ours, theirs)


@pytest.mark.xfail(strict=True, raises=AssertionError, reason="base and link 1, 0.2 mm apart in MuJoCo, push with 11 N in SCM "
                   "across the gap by the default ε3's tail and brake joint 1 (0.178 rad against MuJoCo's 0.285)")
def test_the_base_joint_turns_as_mujocos():
    ours, theirs = scm_turn(XARM), mujoco_turn()
    assert abs(ours - theirs) <= 0.05 * theirs, (ours, theirs)


def mujoco_distance(path, a, b):
    """MuJoCo's distance between bodies `a` and `b`'s colliding geoms (their hulls)."""
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    geoms = [[g for g in range(m.ngeom) if m.geom_bodyid[g] == m.body(n).id and (m.geom_contype[g] or m.geom_conaffinity[g])]
             for n in (a, b)]
    return min(mujoco.mj_geomDistance(m, d, i, j, 0.1, None) for i in geoms[0] for j in geoms[1])


def check_warnings(path):
    run = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    return [l for l in run.stdout.splitlines() if "every point of its band lies" in l]


def figure(line, before, unit):
    return float(line.split(before)[1].split(unit)[0])


MARGIN = '<custom><text name="scm_floor" data="margin"/></custom>'


def test_scm_check_reports_pairs_pushing_where_their_surfaces_are_apart():
    """`scm check` warns where every point of a pair's band lies outside the convex hull of the
    other body's mesh vertices (which holds its sampled surface) at the initial pose but the
    pair pushes. Under the margin (the scene's `scm_floor`) a point near enough to push reads
    nearer: xArm7's base and link 1, Franka's link 0 and link 1. As written (a mesh's tight
    floor), xArm7's pair pushes by the `ε3` tail across its 0.2 mm, 11.1 N measured, and
    Franka's, 1 mm apart, by 1.7e-3 N: no warning. The least distance it reports, over the
    band's sample points, is neither bound of the hulls' distance in general; here, where the
    nearest faces are flat and parallel, it is MuJoCo's distance between the files' hulls:
    measured 0.200 against 0.1998 mm and 0.997 against 0.997 mm. The humanoid has no mesh and
    gets no such warning."""
    assets = XARM.parents[2]
    panda = assets / "robots" / "panda" / "robot.xml"
    for path, a, b in ((XARM, "base", "link1"), (panda, "link0", "link1")):
        theirs = mujoco_distance(path, a, b)
        copy = path.parent / ".margin.robot.xml"
        copy.write_text(path.read_text().replace("</mujoco>", MARGIN + "</mujoco>"))
        try:
            lines = check_warnings(copy)
        finally:
            copy.unlink()
        assert [l.split(" at the initial pose")[0] for l in lines][:1] == [f"warning: pair {a} - {b}"], lines
        assert "read past their faces' edges" in lines[0], lines[0]
        # Measured 0.2 µm and 0.2 µm apart (the printed figure rounds to 1 µm); 0.05 mm, a
        # quarter of the smaller gap, fails a bound read off the wrong body or a wrong hull.
        assert abs(figure(lines[0], "at least ", " mm") * 1e-3 - theirs) <= 5e-5, (lines[0], theirs)
        assert figure(lines[0], "pushes with ", " N") > 1.0, lines[0]
    # As written: the tail across xArm7's gap, nothing across Franka's.
    (line,) = [l for l in check_warnings(XARM) if l.startswith("warning: pair base - link1 ")]
    assert "tail" in line and abs(figure(line, "at least ", " mm") * 1e-3 - mujoco_distance(XARM, "base", "link1")) <= 5e-5, line
    # The law's tail at a uniform 0.2 mm would be k ε3 s⁺(-2) = 11.6 N; the faces are not all
    # that near (measured 11.1 N).
    assert 5.0 < figure(line, "pushes with ", " N") < 11.7, line
    assert not [l for l in check_warnings(panda) if "link0 - link1 " in l]
    gym = pathlib.Path(mujoco.__file__).parents[1] / "gymnasium" / "envs" / "mujoco" / "assets" / "humanoid.xml"
    assert not check_warnings(gym)


# Two bodies stacked axis on axis 0.2 mm apart, the upper one turned about the axis by a motor
# (0.1 N·m for 0.1 s, implicitfast, 2 ms; friction 1): the xArm7's base and link 1 in a small
# scene, as cylinders and as 48-sided prisms from a mesh. MuJoCo puts no contact between them.
TIGHT = '<custom><text name="scm_floor" data="tight"/></custom>'


def stacked(tmp_path, shape, floor=""):
    if shape == "mesh":
        sides, ring = 48, []
        for z in (0.0, 0.1):
            ring += [(0.045 * math.cos(2 * math.pi * i / sides), 0.045 * math.sin(2 * math.pi * i / sides), z)
                     for i in range(sides)]
        faces = []
        for i in range(sides):
            j = (i + 1) % sides
            faces += [(i, j, sides + j), (i, sides + j, sides + i), (2 * sides, j, i), (2 * sides + 1, sides + i, sides + j)]
        lines = [f"v {x} {y} {z}" for x, y, z in ring + [(0, 0, 0), (0, 0, 0.1)]]
        (tmp_path / "prism.obj").write_text("\n".join(lines + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]) + "\n")
        asset, geom = '<asset><mesh name="prism" file="prism.obj"/></asset>', 'type="mesh" mesh="prism"'
    else:
        asset, geom = "", 'type="cylinder" size="0.045 0.05" pos="0 0 0.05"'
    path = tmp_path / f"stacked_{shape}.xml"
    path.write_text(f"""<mujoco><option timestep="0.002" integrator="implicitfast"/>{asset}<worldbody>
  <body name="base"><geom {geom} friction="1"/>
    <body name="top" pos="0 0 0.1002"><joint name="turn" axis="0 0 1"/><geom {geom} mass="2" friction="1"/></body>
  </body></worldbody><actuator><motor name="motor" joint="turn"/></actuator>{floor}</mujoco>""")
    return path


def mujoco_stacked_turn(path):
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    d.ctrl[0], most = 0.1, 0
    for _ in range(round(SECONDS / m.opt.timestep)):
        mujoco.mj_step(m, d)
        most = max(most, d.ncon)
    assert most == 0  # 0.2 mm apart: no contact in MuJoCo
    return d.qpos[0]


def test_stacked_cylinders_turn_as_mujocos_where_the_smoothing_is_below_their_gap(tmp_path):
    """With `ε1` = 3e-6 m² (1.7 mm) and `ε3` = 2e-5 m the cylinders' caps push 5e-5 N across
    the gap and the upper one turns as MuJoCo's: measured 0.251848 against 0.251852 rad."""
    path = stacked(tmp_path, "cylinder")
    ours = scm_turn(path, "motor", "turn", 0.1, ("scm.eps1=3e-6", "scm.eps3=2e-5"))
    theirs = mujoco_stacked_turn(path)
    assert abs(ours - theirs) <= 1e-3 * theirs, (ours, theirs)


@pytest.mark.xfail(strict=True, raises=AssertionError, reason="stacked 0.2 mm apart, SCM's bodies push each other "
                   "at the default smoothing and their friction brakes the turn: cylinders 0.171 rad, prisms 0.199 "
                   "against MuJoCo's 0.252 (docs/mjcf.md, \"Contact on, against MuJoCo's spread\")")
@pytest.mark.parametrize("shape", ["cylinder", "mesh"])
def test_stacked_bodies_turn_as_mujocos(tmp_path, shape):
    path = stacked(tmp_path, shape)
    ours, theirs = scm_turn(path, "motor", "turn", 0.1), mujoco_stacked_turn(path)
    assert abs(ours - theirs) <= 0.05 * theirs, (ours, theirs)


def test_scm_check_reports_the_stacked_prisms_pressing_more_than_they_push(tmp_path):
    """Under the margin (the scene's `scm_floor`) the prisms' pair, 0.2 mm apart by their
    hulls, pushes with 6.0 N at the default 1 cm spacing, and its point forces add up to 18.5 N,
    most of them sideways round the edges: what the friction brakes the turn with. Under a
    mesh's own tight floor the caps push across the gap by the law's tail: no point reads
    nearer than 0.2 mm (less the floor's `T_p ln 26`, under 1 µm here), so no point force is
    larger than `k ε3 s⁺(-2)` = 0.673 N and, their weights adding up to one, neither is their
    sum of sizes (measured 0.647 N); the net force is 0.594 N, some point forces near the rims
    leaning off the caps' normal (1.09 times the net, against 3.1 under the margin)."""
    (line,) = check_warnings(stacked(tmp_path, "mesh", MARGIN))
    apart, force = figure(line, "at least ", " mm"), figure(line, "pushes with ", " N")
    assert abs(apart - 0.2) <= 0.01 and force > 1.0 and figure(line, "adding up to ", " N") > 2 * force, line
    (line,) = check_warnings(stacked(tmp_path, "mesh"))
    assert "tail" in line, line
    k, eps3, force = figure(line, "k = ", " N/m"), figure(line, "ε3 = ", " m"), figure(line, "pushes with ", " N")
    tail = k * eps3 * math.log1p(math.exp(-2e-4 / eps3))
    pressing = figure(line, "adding up to ", " N")
    # 1 % above the bound: the floor's `T_p ln 26` (under 1 µm, 1 % of the tail at ε3 = 1e-4).
    assert 0.8 * tail < force <= pressing <= 1.01 * tail and pressing <= 1.2 * force, (line, tail)


@pytest.mark.parametrize("shape", ["cylinder", "mesh"])
def test_stacked_bodies_turn_as_mujocos_under_the_tight_floor(tmp_path, shape):
    """Under the tight floor no plane reads the other body nearer than its polytope proves, and
    with `ε3` = 2e-5 m the caps' tail across the 0.2 mm is small: measured 0.251849 against
    0.251852 rad (cylinders) and 0.252559 against 0.252572 (prisms; 0.0034 under the default
    floor at the default `ε1`, 0.0015 at 1e-6 m²)."""
    path = stacked(tmp_path, shape, TIGHT)
    ours = scm_turn(path, "motor", "turn", 0.1, ("scm.eps3=2e-5",))
    theirs = mujoco_stacked_turn(path)
    assert abs(ours - theirs) <= 1e-3 * theirs, (ours, theirs)


@pytest.mark.parametrize("arm, eps3", [("xarm7", "2e-5"), ("panda", "1e-4")])
def test_the_arms_base_joints_turn_as_mujocos_under_a_meshs_tight_floor(arm, eps3):
    """robosuite's xArm7 and Franka as written (their meshes' clouds have the tight floor),
    joint 1 driven by 3 N·m for 0.1 s: measured 0.2828 against MuJoCo's 0.285 rad (xArm7,
    `ε3` = 2e-5 m: at the default 1e-4 the tail across its 0.2 mm still brakes, 0.178 rad) and
    0.02510 against 0.02517 (Franka, whose link 0 and link 1 are 1 mm apart: the default `ε3`;
    0.0207 under the margin)."""
    path = XARM.parents[1] / arm / "robot.xml"
    ours = scm_turn(path, sets=(f"scm.eps3={eps3}",))
    theirs = mujoco_turn(path)
    assert abs(ours - theirs) <= 0.05 * theirs, (ours, theirs)
