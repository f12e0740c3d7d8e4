"""Dynamics differential test: each gymnasium MuJoCo model and each model of dm_control's suite
that SCM loads, with contacts, limits, equalities and
friction loss switched off by <option><flag>, simulates 0.2 s through its FMU in fmpy, and every
joint coordinate matches MuJoCo's run of the same copy within 1e-5 (same integrator, same step).
Every actuator gets a constant control (half its range, signs alternating), so that the joints
move in every file, also those without gravity.

What remains then is rigid-body dynamics: gravity, the mass matrix and bias forces, armature,
joint springs and damping, and the integrators (RK4; MuJoCo's Euler with implicit damping).
"""
import json
import pathlib
import re
import subprocess
import xml.etree.ElementTree as ET

import gymnasium
import mujoco
import numpy as np
import pytest
from fmpy import simulate_fmu

from conftest import DM_CONTROL, DM_CONTROL_REFUSED, ROBOTICS, ROBOTICS_REFUSED, SCM, dm_id, robotics_id

CORPUS_DIR = pathlib.Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"
CORPUS = sorted(CORPUS_DIR.glob("*.xml"))
#: Files SCM refuses even with those flags, and why (the test checks the refusal says so).
REFUSED = {}
DURATION = 0.2
TOL = 1e-5


def contact_free_copy(path, folder, off=("contact", "limit", "equality", "frictionloss")):
    """The file with contact, limit, equality and frictionloss (or the flags `off`) switched
    off."""
    tree = ET.parse(path)
    root = tree.getroot()
    option = root.find("option")
    if option is None:
        option = ET.SubElement(root, "option")
    flag = option.find("flag")
    if flag is None:
        flag = ET.SubElement(option, "flag")
    for key in off:
        flag.set(key, "disable")
    # Beside the original, so that what it reads by relative paths (included files, meshes,
    # `meshdir="../stls"`) is found from the copy too; named after the test's folder, and
    # removed by the caller.
    out = path.parent / f".{folder.name}.{path.name}"
    tree.write(out)
    return out


def fmu_name(name):
    """An MJCF name as an FMU name component: as it is if an identifier, else quoted (FMI 2.0's
    structured naming; the printable ASCII names of these corpora need no other escape)."""
    if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
        return name
    return "'" + name.replace("\\", "\\\\").replace("'", "\\'") + "'"


def coordinate_names(m):
    """scm's FMU variable of every entry of MuJoCo's qpos, in qpos order."""
    names = []
    for j in range(m.njnt):
        name = fmu_name(m.joint(j).name or m.body(m.jnt_bodyid[j]).name)
        kind = m.jnt_type[j]
        if kind == mujoco.mjtJoint.mjJNT_FREE:
            names += [f"{name}.pos.{a}" for a in "xyz"] + [f"{name}.quat.{a}" for a in "wxyz"]
        elif kind == mujoco.mjtJoint.mjJNT_BALL:
            names += [f"{name}.quat.{a}" for a in "wxyz"]
        else:
            names.append(f"{name}.q")
    return names


#: dm_control files where nothing moves as written: templates the suite completes in Python, and
#: an arena.
DM_STILL = {
    "lqr": "no joints (the suite builds its chain in Python)",
    "swimmer": "only the head's planar joints, no actuator, gravity across the plane (the suite adds the segments)",
    "arena": "no joints (composer's arena: a floor and its lights)",
    "duplo2x4": "no joints (a prop: composer gives it a free joint when it places it)",
    "testing_sphere": "no joints (a static sphere for dm_control's own tests)",
    "jaco_arm": "no actuators, and its joints move 1e-6 rad in 0.2 s as written (measured in both)",
}
DM_LOADED = [p for p in DM_CONTROL if dm_id(p) not in DM_CONTROL_REFUSED and dm_id(p) not in DM_STILL]


@pytest.mark.parametrize("path", CORPUS + DM_LOADED,
                         ids=[p.stem for p in CORPUS] + [f"dm_control-{dm_id(p)}" for p in DM_LOADED])
def test_contact_free_motion_matches_mujoco(path, tmp_path):
    matches_mujoco(path, tmp_path)


ROBOTICS_LOADED = [p for p in ROBOTICS if robotics_id(p) not in ROBOTICS_REFUSED]


@pytest.mark.parametrize("path", ROBOTICS_LOADED, ids=[f"robotics-{robotics_id(p)}" for p in ROBOTICS_LOADED])
def test_robotics_contact_free_motion_matches_mujoco(path, tmp_path):
    """gymnasium-robotics' hands, the Franka kitchen and the point maze, without contact."""
    matches_mujoco(path, tmp_path)


def test_fetch_gripper_follows_its_mocap_as_in_mujoco(tmp_path):
    """Fetch's gripper hangs from a mocap body by a weld (gymnasium-robotics drives the arm this
    way). Without contact, the mocap input lowered 10 cm over 1 s through the FMU, the gripper
    follows as in MuJoCo (its mocap moved at the same times): it ends within 5 mm and 2
    degrees of MuJoCo's. SCM's weld is a spring of the file's solref (0.02 s), so the gripper
    hangs lower by its deflection (3 mm at rest); MuJoCo's soft constraint holds it tighter."""
    path = next(p for p in ROBOTICS if robotics_id(p) == "reach_fetch")
    copy = contact_free_copy(path, tmp_path, off=("contact",))
    try:
        fmu = tmp_path / "fetch.fmu"
        subprocess.run([str(SCM), "pack", str(copy), "-o", str(fmu)], capture_output=True, check=True)
        m = mujoco.MjModel.from_xml_path(str(copy))
    finally:
        copy.unlink()
    target = lambda t: -0.1 * np.clip(t, 0.0, 1.0)
    t = np.linspace(0.0, 1.5, 151)
    signal = np.zeros(len(t), dtype=[("time", np.float64), ("'robot0:mocap'.pos.z", np.float64)])
    signal["time"], signal["'robot0:mocap'.pos.z"] = t, target(t)
    names = coordinate_names(m)
    res = simulate_fmu(str(fmu), stop_time=1.5, output_interval=0.01, input=signal, output=names)
    d = mujoco.MjData(m)
    gripper = m.body("robot0:gripper_link").id
    mujoco.mj_forward(m, d)
    start = d.xpos[gripper].copy()
    while d.time < 1.5 - 1e-9:
        # The FMU's mocap reaches the pose set at a communication point at the next one, moving
        # there at constant velocity: MuJoCo's mocap is placed on the same straight path.
        d.mocap_pos[0, 2] = target(d.time + m.opt.timestep - 0.01)
        mujoco.mj_step(m, d)
    ours = mujoco.MjData(m)
    ours.qpos[:] = [res[-1][n] for n in names]
    mujoco.mj_forward(m, ours)
    gap = np.linalg.norm(ours.xpos[gripper] - d.xpos[gripper])
    turn = np.degrees(2 * np.arccos(min(1.0, abs(ours.xquat[gripper] @ d.xquat[gripper]))))
    print(f"Fetch gripper lowered by MuJoCo {start[2] - d.xpos[gripper][2]:.4f} m, SCM "
          f"{start[2] - ours.xpos[gripper][2]:.4f} m; apart {gap * 1e3:.2f} mm, {turn:.2f} deg")
    assert start[2] - d.xpos[gripper][2] > 0.09, "MuJoCo's gripper follows the mocap down"
    assert gap < 5e-3 and turn < 2.0


def test_joint_actuator_force_ranges_clamp_as_in_mujoco(tmp_path):
    """`actuatorfrcrange` clamps the total actuator force on a joint (two motors on one hinge,
    one through a tendon; a gear on the slider): the motion matches MuJoCo's while the sums
    exceed the ranges."""
    path = tmp_path / "frcrange.xml"
    path.write_text("""<mujoco>
  <compiler autolimits="true"/>
  <worldbody>
    <body name="cart" pos="0 0 1">
      <joint name="s" type="slide" axis="1 0 0" actuatorfrcrange="-0.3 0.2"/>
      <geom type="box" size=".1 .1 .1"/>
      <body name="arm">
        <joint name="h" axis="0 1 0" actuatorfrcrange="-0.05 0.1"/>
        <geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>
      </body>
    </body>
  </worldbody>
  <tendon><fixed name="t"><joint joint="h" coef="2"/></fixed></tendon>
  <actuator>
    <motor joint="s" gear="3" ctrlrange="-1 1"/>
    <motor joint="h" ctrlrange="-1 1"/>
    <motor tendon="t" ctrlrange="-1 1"/>
  </actuator>
</mujoco>
""")
    matches_mujoco(path, tmp_path)


def matches_mujoco(path, tmp_path):
    """The body of the differential test: `path`'s contact-free copy through its FMU in fmpy
    against MuJoCo's run of the same copy."""
    copy = contact_free_copy(path, tmp_path)
    try:
        compare_runs(path, copy, tmp_path)
    finally:
        copy.unlink()


def compare_runs(path, copy, tmp_path):
    """`copy` of `path` through its FMU in fmpy against MuJoCo's run of it."""
    fmu = tmp_path / f"{path.stem}.fmu"
    packed = subprocess.run([str(SCM), "pack", str(copy), "-o", str(fmu)], capture_output=True, text=True)
    if path.stem in REFUSED:
        assert packed.returncode != 0 and REFUSED[path.stem] in packed.stderr, packed.stderr
        return
    assert packed.returncode == 0, packed.stderr

    m = mujoco.MjModel.from_xml_path(str(copy))
    d = mujoco.MjData(m)
    actuators = json.loads(subprocess.run([str(SCM), "compile", str(copy)], capture_output=True, text=True,
                                          check=True).stdout)["actuators"]
    start = {}
    for a, act in enumerate(actuators):
        lo, hi = act["ctrlrange"] if act["ctrllimited"] else (-1.0, 1.0)
        d.ctrl[a] = 0.5 * (hi if a % 2 == 0 else lo)
        start[f"{fmu_name(act['name'])}.ctrl"] = d.ctrl[a]
    steps = round(DURATION / m.opt.timestep)
    every = max(1, round(0.01 / m.opt.timestep))
    names = coordinate_names(m)
    res = simulate_fmu(str(fmu), stop_time=steps * m.opt.timestep, output_interval=every * m.opt.timestep,
                       output=names, start_values=start)
    worst = 0.0
    for row in res:
        n = round(row["time"] / m.opt.timestep)
        while round(d.time / m.opt.timestep) < n:
            mujoco.mj_step(m, d)
        ours = np.array([row[v] for v in names])
        err = np.max(np.abs(ours - d.qpos))
        worst = max(worst, err)
        assert err < TOL, f"t = {row['time']:.3f}: |scm - MuJoCo| = {err:.2e} at {names[int(np.argmax(np.abs(ours - d.qpos)))]}"
    assert round(d.time / m.opt.timestep) == steps
    moved = np.max(np.abs(d.qpos - m.qpos0))
    assert moved > 1e-4, "the joints must move for the comparison to mean something"
    print(f"{path.stem}: largest difference {worst:.2e} over {steps} steps, motion {moved:.3e}")


def test_massless_welded_bodies_move_as_in_mujoco(tmp_path):
    """MuJoCo's mass rule is per weld body: a free body whose mass is in a jointless child
    (gymnasium-robotics' kettle), and a body that only holds a site, both load and move as
    MuJoCo's; a massless hinge whose child has its own joint is refused by both."""
    path = tmp_path / "welded.xml"
    path.write_text("""<mujoco>
  <option gravity="0 -3 -9.81"/>
  <worldbody>
    <body name="kettle" pos="0 0 1">
      <freejoint name="kettle"/>
      <body name="kettleroot" pos="0.1 0 0" euler="0 30 0">
        <geom type="box" size="0.1 0.05 0.02" mass="0.8"/>
        <geom type="capsule" fromto="0 0 0 0 0.1 0.1" size="0.02" mass="0.1"/>
      </body>
    </body>
    <body name="arm" pos="0 0 2">
      <joint name="hinge" axis="0 1 0" damping="0.01"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      <body name="marker" pos="0.3 0 0"><site name="tip"/></body>
    </body>
  </worldbody>
</mujoco>
""")
    matches_mujoco(path, tmp_path)
    refused = tmp_path / "massless_chain.xml"
    refused.write_text("""<mujoco>
  <worldbody>
    <body name="link"><joint axis="0 1 0"/>
      <body name="tip" pos=".3 0 0"><joint axis="0 1 0"/><geom size=".1"/></body>
    </body>
  </worldbody>
</mujoco>
""")
    with pytest.raises(ValueError):
        mujoco.MjModel.from_xml_path(str(refused))
    out = subprocess.run([str(SCM), "check", str(refused)], capture_output=True, text=True)
    assert out.returncode != 0 and "body 'link' moves but has no mass" in out.stderr, out.stderr


ACTIVATION_SCENE = """<mujoco>
  <custom><text name="scm_keyframe" data="start"/></custom>
  <option timestep="0.002" integrator="INTEGRATOR"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="h" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>
      <body name="slider" pos=".3 0 0">
        <joint name="s" type="slide" axis="1 0 0"/>
        <geom type="box" size=".05 .05 .05"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <general name="filt" joint="h" dyntype="filter" dynprm="0.05" gainprm="2" ctrlrange="-1 1"
             ctrllimited="true"/>
    <general name="integ" joint="s" dyntype="integrator" gainprm="3" biastype="affine"
             biasprm="0 -3 -0.5" actlimited="true" actrange="-0.2 0.3" ctrlrange="-1 1"
             ctrllimited="true"/>
    <position name="pos" joint="h" kp="4" timeconst="0.03"/>
    <general name="early" joint="s" dyntype="filterexact" dynprm="0.02" actearly="true"
             gaintype="affine" gainprm="1.5 2 0"/>
    <motor name="plain" joint="h"/>
  </actuator>
  <keyframe><key name="start" act="0.1 -0.05 0.2 0" ctrl="0.7 0.8 0.5 -0.9 0.1"/></keyframe>
</mujoco>
"""


SHORTCUTS_SCENE = """<mujoco>
  <option timestep="0.002"/>
  <default>
    <default class="ram"><cylinder timeconst="0.04" diameter="0.1" bias="2 -5 -1"/></default>
  </default>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="h" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>
      <body name="slider" pos=".3 0 0">
        <joint name="s" type="slide" axis="1 0 0"/>
        <geom type="box" size=".05 .05 .05"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <intvelocity name="iv" joint="h" kp="6" kv="0.4" actrange="-0.5 0.4" ctrlrange="-1 1"/>
    <intvelocity name="ivz" joint="s" kp="20" dampratio="0.7" actrange="-0.1 0.1"/>
    <cylinder name="ram" class="ram" joint="s" ctrlrange="0 1"/>
    <cylinder name="piston" joint="h" area="0.02" timeconst="0.1"/>
  </actuator>
</mujoco>
"""


def test_intvelocity_and_cylinder_actuators_follow_mujoco(tmp_path):
    """MuJoCo's <intvelocity> (a position servo on an activation that integrates the control,
    clamped by its actrange; with kv and with a dampratio) and <cylinder> (a filtered control
    times the piston's area, from its diameter in a default class, with an affine bias): the
    FMU's run from constant controls matches MuJoCo's Euler run within 1e-12 over 0.5 s, the
    first servo's activation stopping at the top of its range."""
    path = tmp_path / "shortcuts.xml"
    path.write_text(SHORTCUTS_SCENE)
    fmu = tmp_path / "shortcuts.fmu"
    subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], check=True)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    ctrl = {"iv.ctrl": 0.9, "ivz.ctrl": -0.4, "ram.ctrl": 0.6, "piston.ctrl": -0.8}
    d.ctrl[:] = list(ctrl.values())
    outputs = ["h.q", "s.q", "iv.act", "ivz.act", "ram.act", "piston.act"]
    res = simulate_fmu(str(fmu), stop_time=0.5, output_interval=0.01, output=outputs, start_values=ctrl)
    worst = 0.0
    for row in res:
        n = round(row["time"] / m.opt.timestep)
        while round(d.time / m.opt.timestep) < n:
            mujoco.mj_step(m, d)
        err = np.max(np.abs(np.array([row[o] for o in outputs]) - np.concatenate([d.qpos, d.act])))
        worst = max(worst, err)
        assert err < 1e-12, f"t = {row['time']:.2f}: {[row[o] for o in outputs]} vs {d.qpos}, {d.act}"
    assert d.act[0] == 0.4, "the servo's integrated control stops at the top of its actrange"
    print(f"largest difference {worst:.2e}; activations {d.act}")


def test_inheritrange_on_an_intvelocity_is_refused(tmp_path):
    """MuJoCo derives an <intvelocity>'s activation range from inheritrange; SCM does not, and
    says what to write instead."""
    path = tmp_path / "inherit.xml"
    xml = SHORTCUTS_SCENE.replace('damping="0.05"/>', 'damping="0.05" range="-1 1"/>')
    path.write_text(xml.replace('kv="0.4" actrange="-0.5 0.4"', 'kv="0.4" inheritrange="1"'))
    mujoco.MjModel.from_xml_path(str(path))
    out = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True)
    assert out.returncode != 0 and "give its actrange" in out.stderr, out.stderr
    # Also where a default class gives it.
    classed = xml.replace("<default>", '<default><default class="inherit"><intvelocity inheritrange="1"/></default>')
    path.write_text(classed.replace('kv="0.4" actrange="-0.5 0.4"', 'kv="0.4" class="inherit"'))
    mujoco.MjModel.from_xml_path(str(path))
    out = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True)
    assert out.returncode != 0 and "give its actrange" in out.stderr, out.stderr


@pytest.mark.parametrize("integrator", ["Euler", "RK4"])
def test_activation_dynamics_follow_mujoco(integrator, tmp_path):
    """Activation states (a filter, an integrator clamped by its actrange, a position servo's
    timeconst, an actearly filterexact with a gain that grows with length, beside a motor)
    from a keyframe's act: joints and activations through the FMU in fmpy match MuJoCo's run
    within 1e-12 over 0.5 s (the integrator's activation reaches its range's top and stays)."""
    path = tmp_path / "activation.xml"
    path.write_text(ACTIVATION_SCENE.replace("INTEGRATOR", integrator))
    fmu = tmp_path / "activation.fmu"
    subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], check=True)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    outputs = ["h.q", "s.q", "filt.act", "integ.act", "pos.act", "early.act"]
    res = simulate_fmu(str(fmu), stop_time=0.5, output_interval=0.01, output=outputs)
    worst = 0.0
    for row in res:
        n = round(row["time"] / m.opt.timestep)
        while round(d.time / m.opt.timestep) < n:
            mujoco.mj_step(m, d)
        ours = np.array([row[o] for o in outputs])
        err = np.max(np.abs(ours - np.concatenate([d.qpos, d.act])))
        worst = max(worst, err)
        assert err < 1e-12, f"t = {row['time']:.2f}: {ours} vs {d.qpos}, {d.act}"
    assert d.act[1] == 0.3, "the integrator's activation stops at the top of its range"
    print(f"{integrator}: largest difference {worst:.2e}; activations {d.act}")


def test_activation_rates_and_accelerations_are_mujocos_in_model_exchange(tmp_path):
    """In Model Exchange the activations are continuous states: at the keyframe's state the
    FMU's derivatives `der(<name>.act)` are MuJoCo's act_dot and its accelerations MuJoCo's
    qacc (without actearly, which MuJoCo's forward dynamics reads at the next step)."""
    from hosts import Opened, get_dx, get_x
    path = tmp_path / "activation_me.xml"
    path.write_text(ACTIVATION_SCENE.replace(' actearly="true"', "").replace("INTEGRATOR", "Euler"))
    fmu = tmp_path / "activation_me.fmu"
    subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], check=True)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    opened = Opened(str(fmu))
    model = opened.instance("ME")
    n = opened.md.numberOfContinuousStates
    assert n == m.nq + m.nv + m.na
    x = get_x(model, n)
    assert list(x[m.nq + m.nv:]) == list(d.act)
    dx = get_dx(model, n)
    assert np.allclose(dx[m.nq:m.nq + m.nv], d.qacc, rtol=1e-12, atol=1e-12), (dx, d.qacc)
    assert np.allclose(dx[m.nq + m.nv:], d.act_dot, rtol=1e-12, atol=1e-12), (dx, d.act_dot)
    assert opened.var["der(filt.act)"].derivative is opened.var["filt.act"]
    model.terminate()
    model.freeInstance()


SLIDER_CRANK = """<mujoco>
  <option gravity="0 0 -9.81"/>
  <default><position ctrllimited="true" ctrlrange="-.1 .1" kp="30"/></default>
  <worldbody>
    <site name="slider" pos="0 -.1 0" zaxis="1 .5 0"/>
    <body>
      <joint name="a" axis="0 0 1" damping=".1"/>
      <geom type="capsule" size=".01" fromto="0 0 0 .2 0 0"/>
      <site name="crank" pos=".1 0 0"/>
      <site name="crank2" pos=".2 0 0"/>
      <body pos=".15 0 0">
        <joint name="b" axis="0 0 1" damping=".1"/>
        <geom type="capsule" size=".01" fromto="0 -.15 0 0 0 0"/>
        <site name="slider2" pos=".02 -.1 0" zaxis="1 2 0"/>
      </body>
    </body>
    <site name="slider3" pos="0 .1 0" zaxis="1 .2 0"/>
    <body pos="0 .2 0">
      <joint name="c" axis="0 1 1" damping=".1"/>
      <geom type="capsule" size=".01" fromto="0 0 0 .15 0 0"/>
      <site name="crank3" pos=".1 0 0"/>
    </body>
  </worldbody>
  <actuator>
    <position name="forward" cranksite="crank" slidersite="slider" cranklength=".08" gear="2"/>
    <position name="backward" cranksite="crank2" slidersite="slider2" cranklength=".06" dampratio="0.5"/>
    <general name="broken" cranksite="crank3" slidersite="slider3" cranklength=".05" gaintype="affine"
             gainprm="2 1 0.5" biastype="affine" biasprm="0 -1 -0.2" ctrlrange="-1 1" ctrllimited="true"/>
  </actuator>
</mujoco>
"""


def test_slider_crank_transmissions_move_as_in_mujoco(tmp_path):
    """Slider-crank transmissions (`cranksite`, `slidersite`, `cranklength`): a crank driven
    from a slider site on the world, one whose slider site rides on the driven link itself,
    one whose rod is too short to reach (MuJoCo's broken crank: length `a·v`), with a gear, a
    damping ratio and a `<general>` with an affine gain: joints as MuJoCo's Euler run to 1e-5,
    compiled kv as MuJoCo's (test_mjcf_compiler compares the rest)."""
    path = tmp_path / "slider_crank.xml"
    path.write_text(SLIDER_CRANK)
    compare_runs(path, path, tmp_path)


PID_SCENE = """<mujoco>
  <extension>
    <plugin plugin="mujoco.pid">
      <instance name="p"><config key="kp" value="40"/></instance>
      <instance name="pd"><config key="kp" value="2"/><config key="kd" value="0.02"/><config key="ki" value="0"/></instance>
    </plugin>
  </extension>
  <worldbody>
    <body><joint name="j1" type="slide" axis="0 0 1"/><geom size="0.05" mass="1" contype="0" conaffinity="0"/></body>
    <body pos="0.2 0 0"><joint name="j2" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.5" contype="0" conaffinity="0"/></body>
    <body pos="0.4 0 0"><joint name="j3" type="slide" axis="0 0 1"/><geom size="0.05" mass="2" contype="0" conaffinity="0"/></body>
  </worldbody>
  <actuator>
    <plugin name="a1" joint="j1" plugin="mujoco.pid" instance="p" ctrlrange="0 0.3"/>
    <plugin name="a2" joint="j2" plugin="mujoco.pid" instance="pd" gear="2" forcerange="-0.5 0.5"/>
    <plugin name="a3" joint="j3" plugin="mujoco.pid"><config key="kp" value="10"/><config key="kd" value="1"/></plugin>
  </actuator>
</mujoco>
"""


def test_pid_plugin_actuators_without_state_follow_mujoco(tmp_path):
    """MuJoCo's `mujoco.pid` actuator plugin as a PD controller (kp; kp and kd; its instance
    declared in <extension> or its configuration on the actuator), with a control range, a gear
    and a force range that clamps: the FMU's run matches MuJoCo's (Euler, 2 ms) within 1e-12 over
    0.5 s. A PID with an integral (ki) keeps one activation, which MuJoCo asks for with
    actdim="1": without it, refused as MuJoCo refuses it."""
    path = tmp_path / "pid.xml"
    path.write_text(PID_SCENE)
    fmu = tmp_path / "pid.fmu"
    subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], check=True)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    ctrl = {"a1.ctrl": 0.5, "a2.ctrl": 0.4, "a3.ctrl": -0.2}
    d.ctrl[:] = list(ctrl.values())
    outputs = ["j1.q", "j2.q", "j3.q"]
    res = simulate_fmu(str(fmu), stop_time=0.5, output_interval=0.01, output=outputs, start_values=ctrl)
    clamped = False
    for row in res:
        n = round(row["time"] / m.opt.timestep)
        while round(d.time / m.opt.timestep) < n:
            mujoco.mj_step(m, d)
            clamped |= abs(d.actuator_force[1]) == 0.5
        err = np.max(np.abs(np.array([row[o] for o in outputs]) - d.qpos))
        assert err < 1e-12, f"t = {row['time']:.2f}: {[row[o] for o in outputs]} vs {d.qpos}"
    assert clamped, "the force range must act for the comparison to cover it"
    assert d.qpos[0] == pytest.approx(0.3, abs=0.2), "the first servo moves toward its clamped control"

    integral = PID_SCENE.replace('<config key="ki" value="0"/>', '<config key="ki" value="4"/>')
    path.write_text(integral)
    with pytest.raises(ValueError, match="expected 1"):
        mujoco.MjModel.from_xml_path(str(path))
    out = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True)
    assert out.returncode != 0 and ":16: <plugin>" in out.stderr and 'write actdim="1"' in out.stderr, out.stderr
    # MuJoCo gives a plugin actuator its class's actuator defaults (a gear here): SCM does not
    # apply them to one yet, and refuses rather than drop them; activation dynamics likewise.
    for changed, wanted in [
        (PID_SCENE.replace("<worldbody>", '<default><general gear="3"/></default>\n  <worldbody>'),
         "default class 'main' gives actuators defaults"),
        (PID_SCENE.replace('instance="p" ctrlrange', 'instance="p" dyntype="filter" ctrlrange'),
         "activation dynamics (dyntype)"),
    ]:
        path.write_text(changed)
        out = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True)
        assert out.returncode != 0 and wanted in out.stderr and "<plugin>" in out.stderr, out.stderr


PID_INTEGRAL_SCENE = """<mujoco>
  <option integrator="INTEGRATOR"/>
  <extension>
    <plugin plugin="mujoco.pid">
      <instance name="pid"><config key="kp" value="4"/><config key="ki" value="4"/><config key="kd" value="0.4"/></instance>
      <instance name="clamped"><config key="kp" value="2"/><config key="ki" value="8"/><config key="kd" value="0.1"/><config key="imax" value="0.1"/></instance>
    </plugin>
  </extension>
  <worldbody>
    <body><joint name="j1" type="slide" axis="0 0 1"/><geom size="0.05" mass="0.5" contype="0" conaffinity="0"/></body>
    <body pos="0.2 0 0"><joint name="j2" axis="0 1 0" damping="0.01"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.5" contype="0" conaffinity="0"/></body>
    <body pos="0.4 0 0"><joint name="j3" type="slide" axis="0 0 1"/><geom size="0.05" mass="2" contype="0" conaffinity="0"/></body>
  </worldbody>
  <tendon><fixed name="t"><joint joint="j3" coef="1.5"/></fixed></tendon>
  <actuator>
    <plugin name="a1" joint="j1" plugin="mujoco.pid" instance="pid" ctrlrange="0 0.15" actdim="1"/>
    <plugin name="a2" joint="j2" plugin="mujoco.pid" instance="clamped" gear="2" actdim="1"/>
    <plugin name="a3" tendon="t" plugin="mujoco.pid" actdim="1">
      <config key="kp" value="30"/><config key="ki" value="40"/><config key="kd" value="3"/></plugin>
  </actuator>
</mujoco>
"""


@pytest.mark.parametrize("integrator", ["Euler", "RK4"])
def test_pid_plugin_integrals_follow_mujoco(integrator, tmp_path):
    """MuJoCo's PID plugin with its integral (ki; the gallery's `plugin/actuator/pid.xml`): the
    error integral is an activation whose next value is clamp(I + e h, ±imax/ki) at the file's
    step h, and the force is kp e + kd ė + ki times that. Three PIDs under gravity (one whose
    control range clamps, one whose imax clamps its integral, one on a fixed tendon): joints and
    integrals through the FMU in fmpy follow MuJoCo's run within 1e-12 over 1 s, under Euler
    and under RK4 (whose stages read the integral's rate at their own configuration)."""
    path = tmp_path / "pid_integral.xml"
    path.write_text(PID_INTEGRAL_SCENE.replace("INTEGRATOR", integrator))
    fmu = tmp_path / "pid_integral.fmu"
    subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], check=True)
    m = mujoco.MjModel.from_xml_path(str(path))
    assert m.na == 3
    d = mujoco.MjData(m)
    ctrl = {"a1.ctrl": 0.5, "a2.ctrl": 0.4, "a3.ctrl": 0.1}
    d.ctrl[:] = list(ctrl.values())
    outputs = ["j1.q", "j2.q", "j3.q", "a1.act", "a2.act", "a3.act"]
    res = simulate_fmu(str(fmu), stop_time=1.0, output_interval=0.01, output=outputs, start_values=ctrl)
    worst, clamped = 0.0, False
    bound = 0.1 / 8
    for row in res:
        n = round(row["time"] / m.opt.timestep)
        while round(d.time / m.opt.timestep) < n:
            mujoco.mj_step(m, d)
            clamped |= abs(d.act[1]) == bound
        ours = np.array([row[o] for o in outputs])
        err = np.max(np.abs(ours - np.concatenate([d.qpos, d.act])))
        worst = max(worst, err)
        assert err < 1e-12, f"t = {row['time']:.2f}: {ours} vs {d.qpos}, {d.act}"
    assert clamped, "imax must clamp the second integral for the comparison to cover it"
    assert d.act[0] > 0.5, "the first integral grows while gravity holds its body below the set point"
    print(f"{integrator}: largest difference {worst:.2e}; integrals {d.act}")


def test_pid_integral_rates_and_derivatives_are_mujocos(tmp_path):
    """In Model Exchange a PID's integral is a continuous state: at a state off equilibrium the
    FMU's der(a.act) are MuJoCo's act_dot and its accelerations MuJoCo's qacc; the exact
    directional derivatives of both with respect to the joints, the integrals and the controls
    match central differences of MuJoCo's, and the model structure declares what the integral's
    rate reads (its control, itself and its joint's position)."""
    from hosts import Opened, get_dx, get_x, set_x
    path = tmp_path / "pid_integral_me.xml"
    path.write_text(PID_INTEGRAL_SCENE.replace("INTEGRATOR", "Euler"))
    fmu = tmp_path / "pid_integral_me.fmu"
    subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], check=True)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    x0 = np.array([0.03, 0.2, -0.05, 0.1, -0.3, 0.2, 0.004, 0.01, -0.002])
    u0 = np.array([0.12, 0.4, 0.1])

    def mujoco_dx(x, u):
        d.qpos[:], d.qvel[:], d.act[:] = x[:3], x[3:6], x[6:]
        d.ctrl[:] = u
        mujoco.mj_forward(m, d)
        return np.concatenate([d.qvel, d.qacc, d.act_dot])

    opened = Opened(str(fmu))
    model = opened.instance("ME")
    n = opened.md.numberOfContinuousStates
    assert n == 9
    for k, name in enumerate(["a1.ctrl", "a2.ctrl", "a3.ctrl"]):
        model.setReal([opened.var[name].valueReference], [u0[k]])
    set_x(model, x0)
    assert np.allclose(get_x(model, n), x0)
    dx = get_dx(model, n)
    assert np.allclose(dx, mujoco_dx(x0, u0), rtol=1e-12, atol=1e-12), (dx, mujoco_dx(x0, u0))
    states = [u.variable.derivative.valueReference for u in opened.md.derivatives]
    ders = [u.variable.valueReference for u in opened.md.derivatives]
    ctrls = [opened.var[f"a{k}.ctrl"].valueReference for k in (1, 2, 3)]
    step = 1e-6
    for j, known in enumerate(states + ctrls):
        seed = np.zeros(n + 3)
        seed[j] = step
        fd = (mujoco_dx(x0 + seed[:n], u0 + seed[n:]) - mujoco_dx(x0 - seed[:n], u0 - seed[n:])) / (2 * step)
        exact = np.array(model.getDirectionalDerivative(ders, [known], [1.0]))
        assert np.allclose(exact, fd, rtol=1e-6, atol=1e-6), (j, exact, fd)
    # The integral's rate of a2 (on j2): its control, itself and j2's position.
    (der,) = [u for u in opened.md.derivatives if u.variable.name == "der(a2.act)"]
    deps = {k.name for k in der.dependencies}
    assert deps == {"a2.ctrl", "a2.act", "j2.q"}, deps
    model.terminate()
    model.freeInstance()


def test_a_blow_up_the_energy_balance_credits_to_an_actuator_is_refused_where_mujoco_warns(tmp_path):
    """A servo whose damping explicit Euler cannot carry at the file's step (kv gear² h / I ≈ 5)
    pumps energy that the guard's balance books as the actuator's work. MuJoCo warns that the
    simulation is unstable (its acceleration past 1e10) and resets; SCM refuses the run where a
    coordinate passes that size, naming it, instead of writing 1e133 rad and exit status 0."""
    path = tmp_path / "unstable_servo.xml"
    path.write_text("""<mujoco>
  <worldbody>
    <body pos="0.2 0 0"><joint name="j2" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.5" contype="0" conaffinity="0"/></body>
  </worldbody>
  <actuator><general name="a2" joint="j2" gear="2" gainprm="40" biasprm="0 -40 -4" biastype="affine"/></actuator>
</mujoco>
""")
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    d.ctrl[0] = 0.4
    for _ in range(250):  # 0.5 s (MuJoCo resets its time with the state when it warns)
        mujoco.mj_step(m, d)
    assert d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0
    out = subprocess.run([str(SCM), "simulate", str(path), "--duration", "0.5", "--set", "a2.ctrl=0.4"],
                         capture_output=True, text=True)
    assert out.returncode != 0, out.stdout[-300:]
    assert "the velocity of joint j2" in out.stderr and "larger than 1e10" in out.stderr, out.stderr
