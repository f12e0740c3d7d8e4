"""MJCF idioms of everyday MuJoCo files behave as in MuJoCo: each is a small file run through
its FMU in fmpy and in MuJoCo (the oracle), compared on what the idiom is about.

Contact differs by design (SCM's soft contact against MuJoCo's constraint solver): resting
heights and angles agree within a few millimetres or hundredths of a radian, which is what the
SCM contact's own compliance at its default stiffness allows; contact-free motion agrees to
rounding.
"""
import json
import pathlib
import re
import subprocess

import mujoco
import pytest
import numpy as np
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

from conftest import SCM


def run(tmp_path, xml, outputs, stop, name="scene"):
    """Packs `xml`, simulates its FMU in fmpy and the same file in MuJoCo; returns fmpy's last
    row and MuJoCo's MjModel and MjData at `stop`."""
    path = tmp_path / f"{name}.xml"
    path.write_text(xml)
    fmu = tmp_path / f"{name}.fmu"
    out = subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert validate_fmu(str(fmu)) == []
    res = simulate_fmu(str(fmu), stop_time=stop, output_interval=0.01, output=outputs)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    while d.time < stop - 1e-9:
        mujoco.mj_step(m, d)
    return res[-1], m, d


def test_a_visual_geom_does_not_collide(tmp_path):
    # A 5 cm box carrying a 15 cm visual sphere (contype = conaffinity = 0) rests on its box.
    xml = """<mujoco model="visual">
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="box" pos="0 0 0.3">
      <freejoint/>
      <geom type="box" size="0.05 0.05 0.05" mass="1"/>
      <geom type="sphere" size="0.15" contype="0" conaffinity="0" mass="0.001"/>
    </body>
  </worldbody>
</mujoco>"""
    ours, m, d = run(tmp_path, xml, ["box.pos.z"], 1.5)
    assert abs(d.qpos[2] - 0.05) < 2e-3
    assert abs(ours["box.pos.z"] - d.qpos[2]) < 5e-3, (ours["box.pos.z"], d.qpos[2])


def test_a_ground_whose_bits_do_not_match_lets_the_block_through(tmp_path):
    xml = """<mujoco model="bits">
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1" contype="2" conaffinity="2"/>
    <body name="block" pos="0 0 0.3">
      <freejoint/>
      <geom type="box" size="0.05 0.05 0.05" mass="1"/>
    </body>
  </worldbody>
</mujoco>"""
    ours, m, d = run(tmp_path, xml, ["block.pos.z"], 0.4)
    assert d.qpos[2] < -0.4
    assert abs(ours["block.pos.z"] - d.qpos[2]) < 1e-9, (ours["block.pos.z"], d.qpos[2])


def test_a_lever_rests_on_a_support_of_its_jointless_parent(tmp_path):
    # The stand has no joint: MuJoCo welds it to the world, so the parent filter does not keep
    # the hinged lever off the stand's support.
    xml = """<mujoco model="lever">
  <option timestep="0.002"/>
  <worldbody>
    <body name="stand" pos="0 0 0.5">
      <geom name="support" type="box" size="0.05 0.05 0.02" pos="0.3 0 -0.05"/>
      <body name="lever">
        <joint name="hinge" type="hinge" axis="0 1 0" damping="0.02"/>
        <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.01" mass="0.2"/>
      </body>
    </body>
  </worldbody>
</mujoco>"""
    ours, m, d = run(tmp_path, xml, ["hinge.q"], 2.0)
    assert 0.04 < d.qpos[0] < 0.12, d.qpos[0]
    assert abs(ours["hinge.q"] - d.qpos[0]) < 0.02, (ours["hinge.q"], d.qpos[0])


def test_gravity_switched_off_by_a_flag(tmp_path):
    xml = """<mujoco model="nograv">
  <option timestep="0.002"><flag gravity="disable"/></option>
  <worldbody>
    <body name="ball" pos="0 0 1">
      <freejoint/>
      <geom type="sphere" size="0.05"/>
    </body>
  </worldbody>
</mujoco>"""
    ours, m, d = run(tmp_path, xml, ["ball.pos.z"], 0.5)
    assert d.qpos[2] == 1.0
    assert ours["ball.pos.z"] == 1.0


def test_a_floor_and_fixed_obstacles_share_the_worldbody(tmp_path):
    # The usual layout: the floor plane and a fixed step both in the worldbody; a box lands on
    # the step.
    xml = """<mujoco model="step">
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <geom name="step" type="box" size="0.2 0.2 0.05" pos="0 0 0.05"/>
    <body name="box" pos="0 0 0.4">
      <freejoint/>
      <geom type="box" size="0.05 0.05 0.05" mass="1"/>
    </body>
    <body name="other" pos="0.5 0 0.3">
      <freejoint/>
      <geom type="box" size="0.05 0.05 0.05" mass="1"/>
    </body>
  </worldbody>
</mujoco>"""
    ours, m, d = run(tmp_path, xml, ["box.pos.z", "other.pos.z"], 1.5)
    assert abs(d.qpos[2] - 0.15) < 2e-3 and abs(d.qpos[9] - 0.05) < 2e-3
    assert abs(ours["box.pos.z"] - d.qpos[2]) < 5e-3, (ours["box.pos.z"], d.qpos[2])
    assert abs(ours["other.pos.z"] - d.qpos[9]) < 5e-3, (ours["other.pos.z"], d.qpos[9])


def test_geom_friction_sets_the_pair_friction_as_in_mujoco(tmp_path):
    # A box on a 15 degree incline, both geoms with friction 0.2 (MuJoCo takes the larger of
    # the two): it slides down at g (sin 15 - 0.2 cos 15) = 0.644 m/s2, about 0.3 m in 1 s.
    # With friction 1 (MuJoCo's default) it would stick.
    xml = """<mujoco model="incline">
  <option timestep="0.001"/>
  <worldbody>
    <geom name="slope" type="plane" size="2 2 0.1" euler="0 15 0" friction="0.2"/>
    <body name="box" pos="0.01320 0 0.04926" euler="0 15 0">
      <freejoint/>
      <geom type="box" size="0.05 0.05 0.05" mass="1" friction="0.2"/>
    </body>
  </worldbody>
</mujoco>"""
    outputs = ["box.pos.x", "box.pos.z"]
    ours, m, d = run(tmp_path, xml, outputs, 1.0)
    start = np.array([0.01320, 0.04926])
    slid_mujoco = np.linalg.norm(d.qpos[[0, 2]] - start)
    slid_ours = np.linalg.norm(np.array([ours["box.pos.x"], ours["box.pos.z"]]) - start)
    theta = np.radians(15)
    analytic = 0.5 * 9.81 * (np.sin(theta) - 0.2 * np.cos(theta)) * 1.0**2
    assert abs(slid_mujoco - analytic) < 0.1 * analytic, (slid_mujoco, analytic)
    assert abs(slid_ours - slid_mujoco) < 0.1 * slid_mujoco, (slid_ours, slid_mujoco)


def test_t_push_written_mujocos_way_ignores_the_excluded_table(tmp_path):
    # The bundled T-push with a table added the way MuJoCo files do: a plane whose contype and
    # conaffinity share no bit with the block's and the finger's. It must change nothing: the
    # pushes through the FMU equal those of the file without the table, and the block ends
    # where MuJoCo's run of the same file ends, within what the two contact models allow.
    from conftest import SCENES
    base = (SCENES / "t_push.xml").read_text()
    table = '<geom name="table" type="plane" size="1 1 0.1" pos="0 0 -0.02" contype="2" conaffinity="2"/>'
    with_table = base.replace("<worldbody>", "<worldbody>\n    " + table, 1)
    outputs = ["t_x.q", "t_y.q", "t_yaw.q", "finger_y.q"]
    pushes = {"act_x.ctrl": 0.01, "act_y.ctrl": 0.2}
    runs = {}
    for name, xml in (("plain", base), ("table", with_table)):
        path = tmp_path / f"{name}.xml"
        path.write_text(xml)
        fmu = tmp_path / f"{name}.fmu"
        subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], check=True, capture_output=True)
        runs[name] = simulate_fmu(str(fmu), stop_time=2.0, output_interval=0.01, output=outputs,
                                  start_values=pushes)
    for v in outputs:
        assert np.array_equal(runs["plain"][v], runs["table"][v]), v
    m = mujoco.MjModel.from_xml_string(with_table)
    d = mujoco.MjData(m)
    d.ctrl[:] = [pushes["act_x.ctrl"], pushes["act_y.ctrl"]]
    while d.time < 2.0 - 1e-9:
        mujoco.mj_step(m, d)
    ours = runs["table"][-1]
    pushed = ours["t_y.q"]
    print(f"T-push with an excluded table, after 2 s: scm x {ours['t_x.q']:.4f} y {pushed:.4f} "
          f"yaw {ours['t_yaw.q']:.4f}; MuJoCo x {d.qpos[0]:.4f} y {d.qpos[1]:.4f} yaw {d.qpos[2]:.4f}")
    assert pushed > 0.05 and d.qpos[1] > 0.05, "both push the block forward"
    assert abs(pushed - d.qpos[1]) < 0.2 * d.qpos[1]


GRAVCOMP_ARM = """<mujoco model="gravcomp">
  <option timestep="0.002">{flags}</option>
  <worldbody>
    <body name="upper" pos="0 0 1" gravcomp="1">
      <joint name="shoulder" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0.1" size="0.03"/>
      <body name="lower" pos="0.3 0 0.1" gravcomp="0.5">
        <joint name="elbow" type="hinge" axis="0.3 1 0"/>
        <geom type="box" size="0.1 0.02 0.03" pos="0.12 0.02 0"/>
      </body>
    </body>
    <body name="balloon" pos="1 0 1" gravcomp="1">
      <freejoint/>
      <geom type="sphere" size="0.05" pos="0.02 0 0"/>
    </body>
  </worldbody>
</mujoco>"""


def test_gravcomp_as_in_mujoco(tmp_path):
    # Gravity compensation is a force -gravcomp m g at each body's centre of mass: the fully
    # compensated balloon (centre of mass off its frame's origin) stays where it is, the arm
    # moves under the half-compensated lower link only; no contact, so it agrees to rounding.
    outputs = ["shoulder.q", "elbow.q", "balloon.pos.z"]
    ours, m, d = run(tmp_path, GRAVCOMP_ARM.format(flags=""), outputs, 0.5)
    assert abs(d.qpos[0]) > 0.05, "the half-compensated link moves the arm"
    assert abs(ours["balloon.pos.z"] - 1.0) < 1e-12
    assert abs(ours["shoulder.q"] - d.qpos[0]) < 1e-6, (ours["shoulder.q"], d.qpos[0])
    assert abs(ours["elbow.q"] - d.qpos[1]) < 1e-6, (ours["elbow.q"], d.qpos[1])


def test_gravcomp_off_with_springs_and_dampers(tmp_path):
    # MuJoCo computes gravity compensation with the passive forces, all skipped when both
    # springs and dampers are disabled.
    xml = GRAVCOMP_ARM.format(flags='<flag spring="disable" damper="disable"/>')
    ours, m, d = run(tmp_path, xml, ["shoulder.q", "balloon.pos.z"], 0.3)
    assert d.qpos[4] < 0.6, "MuJoCo drops the balloon"
    assert abs(ours["balloon.pos.z"] - d.qpos[4]) < 1e-6
    assert abs(ours["shoulder.q"] - d.qpos[0]) < 1e-6


def test_fluid_forces_as_in_mujoco(tmp_path):
    # MuJoCo's inertia-box fluid model: a free body of two geoms (its box in the eigenvectors
    # of its inertia) thrown through the medium, and a pendulum whose <inertial> gives its
    # principal axes, swinging. No contact: the runs agree to rounding.
    xml = """<mujoco model="fluid">
  <option timestep="0.002" density="1200" viscosity="0.3"/>
  <worldbody>
    <body name="fish" pos="0 0 1" euler="10 20 30">
      <freejoint/>
      <geom type="box" size="0.2 0.05 0.03"/>
      <geom type="sphere" size="0.06" pos="0.2 0.03 0.01"/>
    </body>
    <body name="bob" pos="1 0 1">
      <joint name="swing" type="hinge" axis="0 1 0.3"/>
      <inertial pos="0.3 0 0" quat="0.9 0.1 0.3 0.2" mass="2" diaginertia="0.05 0.04 0.02"/>
      <geom type="sphere" size="0.05" pos="0.3 0 0" mass="0"/>
    </body>
  </worldbody>
</mujoco>"""
    path = tmp_path / "fluid.xml"
    path.write_text(xml)
    fmu = tmp_path / "fluid.fmu"
    out = subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    start = {"fish.linvel.x": 2.0, "fish.linvel.y": -1.0, "fish.linvel.z": 3.0, "fish.angvel.x": 4.0,
             "fish.angvel.y": -2.0, "fish.angvel.z": 5.0, "swing.v": 3.0}
    names = ["fish.pos.x", "fish.pos.y", "fish.pos.z", "fish.quat.w", "fish.quat.x", "fish.quat.y",
             "fish.quat.z", "swing.q"]
    res = simulate_fmu(str(fmu), stop_time=0.5, output_interval=0.01, output=names, start_values=start)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    d.qvel[:] = [2.0, -1.0, 3.0, 4.0, -2.0, 5.0, 3.0]
    still = mujoco.MjModel.from_xml_path(str(path))
    still.opt.density = still.opt.viscosity = 0.0
    ds = mujoco.MjData(still)
    ds.qvel[:] = d.qvel
    while d.time < 0.5 - 1e-9:
        mujoco.mj_step(m, d)
        mujoco.mj_step(still, ds)
    assert np.max(np.abs(d.qpos - ds.qpos)) > 0.05, "the fluid matters"
    ours = np.array([res[-1][n] for n in names])
    assert np.max(np.abs(ours - d.qpos)) < 1e-6, (ours, d.qpos)


LIGHT_FINGER = """<mujoco model="light_finger">
  <option timestep="0.002" integrator="{integrator}"/>
  <worldbody>
    <body name="finger">
      <joint name="finger_y" type="slide" axis="0 1 0"/>
      <geom type="sphere" size="0.015" mass="0.1"/>
    </body>
  </worldbody>
  <actuator>
    <position name="act_y" joint="finger_y" kp="2000" kv="30"/>
  </actuator>
  <keyframe><key name="go" ctrl="0.2"/></keyframe>
  <custom><text name="scm_keyframe" data="go"/></custom>
</mujoco>"""


def test_a_stiff_position_actuator_on_a_light_body_is_not_refused(tmp_path):
    # MuJoCo's default-looking position actuator (kp 2000, kv 30) stepping a 0.1 kg finger by
    # 20 cm: 400 N at the start of the first 2 ms step, 128 N at its end. The guard once
    # estimated the actuators' work by the trapezoid of the power and refused the first step
    # (3.2 J of motion against 1.0 J of counted work); the work is now the integrator's own.
    # Contact-free, so the motion equals MuJoCo's to rounding at every output point.
    for integrator in ("Euler", "RK4", "implicitfast"):
        path = tmp_path / f"{integrator}.xml"
        path.write_text(LIGHT_FINGER.format(integrator=integrator))
        fmu = tmp_path / f"{integrator}.fmu"
        subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], check=True, capture_output=True)
        res = simulate_fmu(str(fmu), stop_time=0.5, output_interval=0.01, output=["finger_y.q"])
        assert res["time"][-1] == 0.5 and abs(res["finger_y.q"][-1] - 0.2) < 1e-3, integrator
        if integrator == "implicitfast":  # SCM's implicit_euler is not MuJoCo's implicitfast
            continue
        m = mujoco.MjModel.from_xml_path(str(path))
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, 0)
        theirs = []
        while d.time < 0.5 - 1e-9:
            mujoco.mj_step(m, d)
            if abs(d.time / 0.01 - round(d.time / 0.01)) < 1e-6:
                theirs.append(d.qpos[0])
        assert np.max(np.abs(res["finger_y.q"][1:] - theirs)) < 1e-9, integrator


def t_push_mujocos_way(integrator=None):
    """The bundled T-push as a MuJoCo user writes it: no scm_* settings (SCM's contact at its
    defaults, friction from the geoms, MuJoCo's default Euler), a 0.1 kg finger on position
    actuators with kp 2000 and kv 30."""
    import re
    from conftest import SCENES
    xml = re.sub(r"<custom>.*?</custom>\s*", "", (SCENES / "t_push.xml").read_text(), flags=re.S)
    xml = xml.replace('mass="1"/>', 'mass="0.1"/>').replace('kp="500" kv="40"', 'kp="2000" kv="30"')
    if integrator:
        xml = xml.replace("<worldbody>", f'<custom><text name="scm_integrator" data="{integrator}"/></custom>\n  <worldbody>', 1)
    return xml


FINGER_PATHS = [(0.0, 0.2), (0.05, 0.2), (-0.05, 0.2), (0.1, 0.25), (0.02, 0.15)]


def test_t_push_mujocos_way_runs_every_finger_path(tmp_path):
    # Five finger paths, 2 s each, under MuJoCo's Euler (damped_euler, contact implicit in
    # velocity). The finger reaches 8.8 m/s before it strikes the block; with the contact
    # explicit (semi_implicit_euler) its friction, mu F / (v_s m) in the thousands per second,
    # is not resolved at 2 ms: while the damping grew with the depth the runs blew up and the
    # guard refused them; with the damping bounded under explicit integrators (docs/method.md,
    # departure 4) they ran, but the straight push turned the T by 0.60 rad where the symmetric
    # push must not turn it at all (below: with the stiction floor, 0.010 rad). MuJoCo runs every
    # path; at its default solref its contact is too soft for this actuator and the finger sinks
    # into the stem. So does SCM's under the implicit integrators' bound (8 m^ g, docs/method.md,
    # departure 4), and the straight push moves the T about as far as MuJoCo's (measured
    # 2026-12-07: 4.8 cm against 3.2; under the paper's law, whose damping grows with the depth,
    # the finger stayed behind the stem and threw the T 38.5 cm).
    outputs = ["t_x.q", "t_y.q", "t_yaw.q", "finger_x.q", "finger_y.q"]

    def runs(integrator):
        path = tmp_path / f"t_push_{integrator}.xml"
        path.write_text(t_push_mujocos_way(integrator))
        fmu = tmp_path / f"t_push_{integrator}.fmu"
        subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], check=True, capture_output=True)
        return [simulate_fmu(str(fmu), stop_time=2.0, output_interval=0.01, output=outputs,
                             start_values={"act_x.ctrl": ux, "act_y.ctrl": uy})
                for ux, uy in FINGER_PATHS]

    ours = runs("damped_euler")
    for (ux, uy), res in zip(FINGER_PATHS, ours):
        end = res[-1]
        assert res["time"][-1] == pytest.approx(2.0), (ux, uy)
        assert abs(end["finger_x.q"] - ux) < 5e-3 and abs(end["finger_y.q"] - uy) < 5e-3, (ux, uy)
    # Straight on, the T moves straight ahead, about as far as MuJoCo's.
    straight = ours[0][-1]
    assert abs(straight["t_x.q"]) < 1e-6 and abs(straight["t_yaw.q"]) < 1e-6
    m = mujoco.MjModel.from_xml_string(t_push_mujocos_way())
    d = mujoco.MjData(m)
    d.ctrl[:] = FINGER_PATHS[0]
    while d.time < 2.0 - 1e-9:
        mujoco.mj_step(m, d)
    assert d.qpos[1] > 0.01 and abs(straight["t_y.q"] - d.qpos[1]) < 0.025, (straight["t_y.q"], d.qpos[1])
    # Mirrored paths, mirrored pushes (the T is symmetric about x = 0).
    left, right = ours[1][-1], ours[2][-1]
    assert abs(left["t_y.q"] - right["t_y.q"]) < 1e-6
    assert abs(left["t_x.q"] + right["t_x.q"]) < 1e-6 and abs(left["t_yaw.q"] + right["t_yaw.q"]) < 1e-6
    assert abs(left["t_yaw.q"]) > 0.01, "an off-centre push turns the T"
    # With the contact explicit its friction at 2 ms is held by the stiction floor (2 h mu g
    # under the explicit integrators, docs/mjcf.md): the run goes on and the straight push turns
    # the T by 0.010 rad (measured; 0.60 rad before the floor), where damped Euler's keeps it
    # straight to 1e-6.
    explicit = runs("semi_implicit_euler")[0]
    assert explicit["time"][-1] == pytest.approx(2.0)
    assert 1e-4 < abs(explicit[-1]["t_yaw.q"]) < 0.05, explicit[-1]["t_yaw.q"]


GENERAL_ACTUATORS = """<mujoco model="general">
  <option timestep="0.002"/>
  <worldbody>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" type="hinge" axis="0 1 0" damping="0.1"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" contype="0" conaffinity="0"/>
      <body name="lower" pos="0.3 0 0">
        <joint name="elbow" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.025" contype="0" conaffinity="0"/>
        <body name="tip" pos="0.25 0 0">
          <joint name="reach" type="slide" axis="1 0 0" ref="0.02"/>
          <geom type="sphere" size="0.03" contype="0" conaffinity="0"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <general name="servo" joint="shoulder" gainprm="50" biastype="affine" biasprm="0 -50 -5"
             ctrlrange="-1 1" forcerange="-3 3"/>
    <general name="affine" joint="elbow" gear="1.5" gaintype="affine" gainprm="2 0.5 0.1"
             biastype="affine" biasprm="0.1 -1 -0.2"/>
    <motor name="push" joint="reach" forcerange="-0.5 0.5"/>
  </actuator>
  <keyframe><key name="go" ctrl="0.8 -0.4 2"/></keyframe>
  <custom><text name="scm_keyframe" data="go"/></custom>
</mujoco>"""


def test_general_actuators_and_force_ranges_as_in_mujoco(tmp_path):
    # MuJoCo's <general> actuators without activation (a servo written as an affine bias, an
    # affine gain and bias on a geared joint) and force ranges that clamp (3 N m on the servo,
    # which asks 40 N m at the start; 0.5 N on a motor asked for 2 N): contact-free, so the
    # motion equals MuJoCo's Euler to rounding at every output point.
    path = tmp_path / "general.xml"
    path.write_text(GENERAL_ACTUATORS)
    fmu = tmp_path / "general.fmu"
    out = subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert validate_fmu(str(fmu)) == []
    names = ["shoulder.q", "elbow.q", "reach.q"]
    res = simulate_fmu(str(fmu), stop_time=0.5, output_interval=0.01, output=names)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    theirs, clamped = [], set()
    while d.time < 0.5 - 1e-9:
        mujoco.mj_step(m, d)
        clamped |= {a for a in range(m.nu) if abs(abs(d.actuator_force[a]) - m.actuator_forcerange[a, 1]) < 1e-12}
        if abs(d.time / 0.01 - round(d.time / 0.01)) < 1e-6:
            theirs.append(d.qpos.copy())
    assert clamped == {0, 2}, "both force ranges clamp in MuJoCo's run"
    ours = np.column_stack([res[n] for n in names])[1:]
    assert np.max(np.abs(ours - np.array(theirs))) < 1e-9


def test_general_actuator_with_muscle_dynamics_is_refused(tmp_path):
    """Muscle activation (with its muscle gain and bias) is not modelled: refused at its line,
    naming the dynamics SCM has."""
    xml = GENERAL_ACTUATORS.replace('name="servo" joint="shoulder"', 'name="servo" joint="shoulder" dyntype="muscle"')
    path = tmp_path / "muscle.xml"
    path.write_text(xml)
    out = subprocess.run([str(SCM), "pack", str(path), "-o", str(tmp_path / "f.fmu")], capture_output=True, text=True)
    assert out.returncode != 0
    assert "muscle.xml:18" in out.stderr and "dyntype" in out.stderr and "filterexact" in out.stderr, out.stderr


TENDONS = """<mujoco model="tendons">
  <option timestep="0.002" integrator="{integrator}"/>
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="ja" type="hinge" axis="0 1 0" ref="0.1"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" contype="0" conaffinity="0"/>
    </body>
    <body name="b" pos="0.5 0 1">
      <joint name="jb" type="hinge" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.02" contype="0" conaffinity="0"/>
      <body name="c" pos="0.25 0 0">
        <joint name="jc" type="slide" axis="1 0 0"/>
        <geom type="sphere" size="0.03" contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="servo" tendon="couple" kp="3" kv="0.2"/>
    <motor name="pull" tendon="band" gear="2" forcerange="-0.1 0.1"/>
  </actuator>
  <keyframe><key name="k" ctrl="0.2 0.3"/></keyframe>
  <custom><text name="scm_keyframe" data="k"/></custom>
  <tendon>
    <fixed name="couple" stiffness="5" damping="0.3" springlength="0.05">
      <joint joint="ja" coef="1"/>
      <joint joint="jb" coef="-0.5"/>
    </fixed>
    <fixed name="band" stiffness="20" springlength="0 0.02">
      <joint joint="jc" coef="2"/>
      <joint joint="jb" coef="0.3"/>
    </fixed>
    <fixed name="rest" stiffness="3">
      <joint joint="ja" coef="0.5"/>
    </fixed>
  </tendon>
</mujoco>"""


def test_fixed_tendons_with_springs_and_dampers_as_in_mujoco(tmp_path):
    # Two arms in separate subtrees tied by a tendon spring and damper, a spring with MuJoCo's
    # deadband (springlength "0 0.02") across a hinge and a slide, and one resting at the
    # length of the springs' rest configuration (no springlength); a position servo and a
    # geared, force-limited motor on tendons (declared before the tendons, as MuJoCo allows):
    # contact-free, so the motion equals MuJoCo's to rounding with Euler and RK4.
    names = ["ja.q", "jb.q", "jc.q"]
    for integrator in ("Euler", "RK4"):
        path = tmp_path / f"tendons_{integrator}.xml"
        path.write_text(TENDONS.format(integrator=integrator))
        fmu = tmp_path / f"tendons_{integrator}.fmu"
        out = subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        assert validate_fmu(str(fmu)) == []
        res = simulate_fmu(str(fmu), stop_time=1.0, output_interval=0.01, output=names)
        m = mujoco.MjModel.from_xml_path(str(path))
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, 0)
        theirs = []
        while d.time < 1.0 - 1e-9:
            mujoco.mj_step(m, d)
            if abs(d.time / 0.01 - round(d.time / 0.01)) < 1e-6:
                theirs.append(d.qpos.copy())
        ours = np.column_stack([res[n] for n in names])[1:]
        # The tendons act: the arms move apart from where they would fall alone.
        assert np.max(np.abs(np.array(theirs)[:, 2])) > 1e-3
        assert np.max(np.abs(ours - np.array(theirs))) < 1e-9, integrator


def test_a_tendon_limit_holds_a_pendulum_as_in_mujoco(tmp_path):
    # A pendulum whose tendon (coefficient 2 on its hinge) may not exceed 0.6: it falls from
    # horizontal and comes to rest against the limit, at q = 0.3 rad, in MuJoCo (a constraint)
    # and in SCM (a smooth spring of MuJoCo's solreflimit time constant on the tendon's
    # inertia 1 / tendon_invweight0, raised to MuJoCo's statics by 1 / (1 - dmax) = 20, past
    # the limit by its static deflection F/k + w/2: MuJoCo's deflection plus the half onset).
    xml = """<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="hinge" type="hinge" axis="0 1 0" damping="0.2"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <tendon>
    <fixed name="strap" range="-1 0.6"><joint joint="hinge" coef="2"/></fixed>
  </tendon>
</mujoco>"""
    ours, m, d = run(tmp_path, xml, ["hinge.q", "tendon.strap.limit.force"], 2.0, name="strap")
    assert abs(d.qpos[0] - 0.3) < 0.01, d.qpos[0]
    theirs = d.qpos[0]
    k = (1.0 / m.tendon_invweight0[0]) / 0.02 ** 2 / (1.0 - 0.95)
    d.qpos[0] = ours["hinge.q"]
    d.qvel[0] = 0.0
    mujoco.mj_forward(m, d)
    force = abs(d.qfrc_bias[0]) / 2.0  # the weight's torque, carried by the tendon (coefficient 2)
    past = (force / k + 0.5e-3) / 2.0
    assert abs(ours["hinge.q"] - (0.3 + past)) < 1e-4, (ours["hinge.q"], 0.3 + past)
    # MuJoCo's rest: its deflection, without the half onset (0.25 mrad on the hinge).
    assert abs(ours["hinge.q"] - 0.25e-3 - theirs) < 2e-4, (ours["hinge.q"], theirs)
    # The limit's force, an FMU output, carries the weight (pushing the tendon shorter).
    limit = ours["tendon.strap.limit.force"]
    assert abs(limit + force) < 0.02 * force, (limit, force)


SPATIAL_TENDONS = """<mujoco model="strings">
  <option timestep="0.002" integrator="{integrator}" gravity="0 0 -3"/>
  <worldbody>
    <site name="hook" pos="0.2 0 1.6"/>
    <site name="hook2" pos="0.9 0 1.5"/>
    <body name="a" pos="0 0 1">
      <joint name="ja" type="hinge" axis="0 1 0" ref="0.1"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" contype="0" conaffinity="0"/>
      <site name="a_tip" pos="0.3 0 0"/>
    </body>
    <body name="b" pos="0.6 0 1">
      <joint name="jb" type="hinge" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.02" contype="0" conaffinity="0"/>
      <site name="b_mid" pos="0.1 0 0.02"/>
      <site name="b_tip" pos="0.25 0 0"/>
      <body name="c" pos="0.25 0 0">
        <joint name="jc" type="slide" axis="1 0 0"/>
        <geom type="sphere" size="0.03" contype="0" conaffinity="0"/>
        <site name="c_site" pos="0.03 0 0"/>
      </body>
    </body>
    <body name="ball" pos="1.3 0.1 1.2">
      <freejoint/>
      <geom type="sphere" size="0.04" contype="0" conaffinity="0"/>
      <site name="ball_top" pos="0 0.01 0.04"/>
    </body>
  </worldbody>
  <tendon>
    <spatial name="rope" stiffness="5" damping="0.3" springlength="0.6 0.7">
      <site site="a_tip"/>
      <site site="hook"/>
      <pulley divisor="2"/>
      <site site="hook2"/>
      <site site="b_tip"/>
    </spatial>
    <fixed name="couple" stiffness="2"><joint joint="ja" coef="1"/><joint joint="jb" coef="-0.5"/></fixed>
    <spatial name="band" stiffness="20" springlength="0.15">
      <site site="c_site"/>
      <site site="b_mid"/>
    </spatial>
    <spatial name="rest" stiffness="3">
      <site site="hook"/>
      <site site="a_tip"/>
    </spatial>
    <spatial name="cord" stiffness="40" damping="0.5" springlength="0.25">
      <site site="hook2"/>
      <site site="ball_top"/>
    </spatial>
  </tendon>
  <actuator>
    <motor name="pull" tendon="rope" gear="2" ctrlrange="-1 1"/>
    <position name="servo" tendon="band" kp="30" dampratio="0.5"/>
    <general name="winch" tendon="cord" gainprm="3" biasprm="0 -1 -0.2"/>
  </actuator>
  <keyframe><key name="k" ctrl="-0.4 0.2 0.1"/></keyframe>
  <custom><text name="scm_keyframe" data="k"/></custom>
</mujoco>"""


def test_spatial_tendons_with_springs_and_dampers_as_in_mujoco(tmp_path):
    # Spatial tendons through sites: a rope from one arm over a pulley (divisor 2) to another
    # with a deadband spring and a damper, a band between a slider and its parent arm, one
    # resting at the length of the springs' rest pose (no springlength), a free ball on a damped
    # cord, and a fixed tendon numbered between them; a motor, a position servo (dampratio) and
    # an affine <general> drive three of them, at constant controls. MuJoCo's tendon springs and
    # dampers are passive forces J^T F and its actuators on tendons J^T (gear force), as SCM's
    # are: contact-free, the motion equals MuJoCo's to rounding
    # with Euler. With RK4 the cord's torque makes the ball's orientation at the inner stages
    # matter, which the two RK4s form differently (both fourth order: measured 4.5e-6 and
    # 5.5e-6 from a reference at h/32 after 0.5 s, 16 times less at each halving, the two
    # references within 4e-13): against MuJoCo's RK4 at h/8, SCM's error is MuJoCo's own.
    names = ["ja.q", "jb.q", "jc.q"] + [f"ball.pos.{a}" for a in "xyz"] + [f"ball.quat.{a}" for a in "wxyz"]
    for integrator in ("Euler", "RK4"):
        path = tmp_path / f"strings_{integrator}.xml"
        path.write_text(SPATIAL_TENDONS.format(integrator=integrator))
        fmu = tmp_path / f"strings_{integrator}.fmu"
        out = subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        assert validate_fmu(str(fmu)) == []
        res = simulate_fmu(str(fmu), stop_time=1.0, output_interval=0.01, output=names)
        m = mujoco.MjModel.from_xml_path(str(path))
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, 0)
        theirs, lengths = [], []
        while d.time < 1.0 - 1e-9:
            mujoco.mj_step(m, d)
            if abs(d.time / 0.01 - round(d.time / 0.01)) < 1e-6:
                theirs.append(d.qpos.copy())
                lengths.append(d.ten_length.copy())
        ours = np.column_stack([res[n] for n in names])[1:]
        theirs = np.array(theirs)
        # The strings act: the rope passes through its deadband, the cord swings the ball.
        rope = np.array(lengths)[:, 0]
        assert rope.min() < 0.6 or rope.max() > 0.7, (rope.min(), rope.max())
        assert np.ptp(theirs[:, 3]) > 0.05, "the ball swings on its cord"
        if integrator == "Euler":
            assert np.max(np.abs(ours - theirs)) < 1e-9, np.max(np.abs(ours - theirs))
            continue
        fine = mujoco.MjModel.from_xml_string(SPATIAL_TENDONS.format(integrator=integrator).replace(
            'timestep="0.002"', 'timestep="0.00025"'))
        df = mujoco.MjData(fine)
        mujoco.mj_resetDataKeyframe(fine, df, 0)
        while df.time < 1.0 - 1e-9:
            mujoco.mj_step(fine, df)
        ours_err, theirs_err = np.max(np.abs(ours[-1] - df.qpos)), np.max(np.abs(theirs[-1] - df.qpos))
        assert theirs_err > 1e-8, "the comparison needs an error to compare"
        assert ours_err < 2.0 * theirs_err, (ours_err, theirs_err)
        assert np.max(np.abs(ours - theirs)) < 1e-5, np.max(np.abs(ours - theirs))


def test_a_string_holds_a_ball_as_in_mujoco(tmp_path):
    # dm_control's ball in a cup, reduced: a ball on two slides hangs from a world site by a
    # spatial tendon that may not exceed 0.3 m. Released 0.25 m out at the site's height, it
    # falls, the string catches it and it swings; damped, it comes to rest straight below. In
    # MuJoCo the limit is a constraint; in SCM a smooth spring of MuJoCo's solreflimit time
    # constant on the tendon's inertia 1 / tendon_invweight0 (the ball's mass here), raised to
    # MuJoCo's statics by 1 / (1 - dmax) = 20, so the string is longer at rest by its static
    # deflection (1 - dmax) g tau^2 + w/2 (w = 1 mm, the limit's smoothing width), and the
    # limit force, an FMU output, carries the weight.
    xml = """<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <site name="hook" pos="0 0 1"/>
    <body name="ball" pos="0.25 0 1">
      <joint name="bx" type="slide" axis="1 0 0" damping="0.4"/>
      <joint name="bz" type="slide" axis="0 0 1" damping="0.4"/>
      <site name="bead"/>
      <geom type="sphere" size="0.02" mass="0.1" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <tendon>
    <spatial name="string" range="0 0.3">
      <site site="hook"/>
      <site site="bead"/>
    </spatial>
  </tendon>
</mujoco>"""
    ours, m, d = run(tmp_path, xml, ["bx.q", "bz.q", "tendon.string.limit.force"], 0.6, name="string")
    # Mid-swing (0.6 s): the ball swings on the string in both, within 1.5 cm of each other.
    print("mid-swing: scm", ours["bx.q"], ours["bz.q"], "MuJoCo", d.qpos)
    assert abs(ours["bx.q"] - d.qpos[0]) < 0.015 and abs(ours["bz.q"] - d.qpos[1]) < 0.015, (ours, d.qpos)
    assert np.hypot(0.25 + d.qpos[0], d.qpos[1]) > 0.29, "MuJoCo's string is taut"
    ours, m, d = run(tmp_path, xml, ["bx.q", "bz.q", "tendon.string.limit.force"], 8.0, name="string")
    tau = m.tendon_solref_lim[0][0]
    assert abs(1.0 / m.tendon_invweight0[0] - 0.1) < 1e-9, "the tendon's inertia is the ball's mass"
    stretch = (1.0 - 0.95) * 9.81 * tau ** 2 + 0.5e-3
    # At rest straight below the hook, 0.3 m plus the deflection down (MuJoCo: within 1 mm).
    assert abs(ours["bx.q"] + 0.25) < 1e-4, ours["bx.q"]
    assert abs(ours["bz.q"] + 0.3 + stretch) < 1e-4, (ours["bz.q"], -0.3 - stretch)
    assert abs(d.qpos[0] + 0.25) < 1e-3 and abs(d.qpos[1] + 0.3) < 1e-3, d.qpos
    assert abs(ours["tendon.string.limit.force"] + 0.1 * 9.81) < 1e-3, ours["tendon.string.limit.force"]


SITE_ACTUATORS = (pathlib.Path(__file__).parent.parent / "fixtures" / "site_actuators.xml").read_text()


def test_site_actuators_move_as_in_mujoco(tmp_path):
    # Actuators on sites, MuJoCo's site transmission (no refsite): a quadrotor's four motors
    # push along their sites' z axes with a yaw torque each (gear 0 0 1 0 0 +-0.006, one site
    # tilted), a position servo (dampratio) and an affine general on a tilted site of an arm,
    # and a velocity actuator on a slider's site. MuJoCo applies J^T (R g_f, R g_t) F with a zero
    # length and the moment's velocity; so does SCM: contact-free, the motion equals MuJoCo's
    # Euler run to rounding.
    path = tmp_path / "drone.xml"
    path.write_text(SITE_ACTUATORS)
    fmu = tmp_path / "drone.fmu"
    out = subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert validate_fmu(str(fmu)) == []
    names = [f"drone.pos.{a}" for a in "xyz"] + [f"drone.quat.{a}" for a in "wxyz"] + ["hinge.q", "slide.q"]
    res = simulate_fmu(str(fmu), stop_time=1.0, output_interval=0.01, output=names)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    worst = 0.0
    for row in res[1:]:
        while d.time < row["time"] - 1e-9:
            mujoco.mj_step(m, d)
        worst = max(worst, np.max(np.abs(np.array([row[n] for n in names]) - d.qpos)))
    # The thrust holds the drone up against most of its fall (free fall: z = 1 - g/2 = -3.9 m
    # after 1 s) and turns it; the arm's actuators move the arm.
    assert d.qpos[2] > -2.0 and abs(d.qpos[7]) > 0.1, d.qpos
    assert worst < 1e-9, worst


GEARED_PENDULUMS = """<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="ja" type="hinge" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" contype="0" conaffinity="0"/>
    </body>
    <body name="b" pos="0.6 0 1">
      <joint name="jb" type="hinge" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <equality><joint name="gear" joint1="ja" joint2="jb" polycoef="0 0.5 0 0 0"/></equality>
</mujoco>"""


def test_a_joint_equality_gears_two_pendulums_as_in_mujoco(tmp_path):
    # ja = 0.5 jb: two pendulums in separate subtrees geared by a joint equality fall and
    # settle together. MuJoCo solves the equality as a soft constraint; SCM applies a spring and
    # damper of MuJoCo's solref on the constraint's inertia 1 / (dof_invweight0 of both), raised
    # by the factor of MuJoCo's statics at g (`statics` in `scm compile`, 10.7 here), so at rest
    # its error is the static deflection G/(statics k) (G: the weight's torque on ja that the
    # coupling carries; the reference spring's G/k is 0.036 rad here). MuJoCo's impedance (0.9
    # to 0.95 as the error grows) makes its own error between 10 and 20 times smaller than
    # G/k: SCM's lies within the factor 2 that spans, and the settled angles agree.
    ours, m, d = run(tmp_path, GEARED_PENDULUMS, ["ja.q", "jb.q"], 4.0, name="gear")
    mj_error = d.qpos[0] - 0.5 * d.qpos[1]
    assert abs(mj_error) < 5e-3, d.qpos
    compiled = json.loads(subprocess.run([str(SCM), "compile", str(tmp_path / "gear.xml")],
                                         capture_output=True, text=True, check=True).stdout)
    statics = compiled["equalities"][0]["statics"]
    k = 1.0 / (m.dof_invweight0[0] + m.dof_invweight0[1]) / 0.02 ** 2
    d.qpos[:] = [ours["ja.q"], ours["jb.q"]]
    d.qvel[:] = 0.0
    mujoco.mj_forward(m, d)
    deflection = -d.qfrc_bias[0] / k
    error = ours["ja.q"] - 0.5 * ours["jb.q"]
    assert abs(deflection) > 0.01, "a deflection this test can see"
    assert abs(error - deflection / statics) < 2e-4, (error, deflection / statics)
    assert 0.5 < error / mj_error < 2.0, (error, mj_error)
    theirs = mujoco.MjData(m)
    while theirs.time < 4.0 - 1e-9:
        mujoco.mj_step(m, theirs)
    assert np.max(np.abs(theirs.qpos - [ours["ja.q"], ours["jb.q"]])) < 0.01


FOUR_BAR = """<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <body name="crank" pos="0 0 1">
      <joint name="j1" type="hinge" axis="0 1 0" damping="0.02"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.015" contype="0" conaffinity="0"/>
      <body name="coupler" pos="0.2 0 0">
        <joint name="j2" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.015" contype="0" conaffinity="0"/>
      </body>
    </body>
    <body name="rocker" pos="0.4 0 1">
      <joint name="j3" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.015" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <equality><connect name="pin" body1="coupler" body2="rocker" anchor="0 0 -0.3"/></equality>
</mujoco>"""


def test_a_connect_closes_a_four_bar_linkage_as_in_mujoco(tmp_path):
    # A crank and a rocker from the world, joined by a coupler whose end a connect pins to the
    # rocker, at the point of the rocker where that end is at qpos0 (MuJoCo's compiler puts
    # body 2's anchor there). MuJoCo's soft constraint and SCM's spring of its solref on
    # 1 / (body_invweight0 of both) close the loop while the linkage swings under gravity: the
    # pin opens by millimetres at most in both, and the crank moves alike.
    names = ["j1.q", "j2.q", "j3.q"]
    ours, m, d = run(tmp_path, FOUR_BAR, names, 1.0, name="four_bar")

    def gap(data):
        p1 = data.xpos[2] + data.xmat[2].reshape(3, 3) @ m.eq_data[0, 0:3]
        p2 = data.xpos[3] + data.xmat[3].reshape(3, 3) @ m.eq_data[0, 3:6]
        return np.linalg.norm(p1 - p2)

    mine = mujoco.MjData(m)
    mine.qpos[:] = [ours[n] for n in names]
    mujoco.mj_kinematics(m, mine)
    print(f"four-bar after 1 s: pin gap MuJoCo {gap(d):.2e} m, SCM {gap(mine):.2e} m; "
          f"crank MuJoCo {d.qpos[0]:.4f}, SCM {ours['j1.q']:.4f} rad")
    assert abs(d.qpos[0]) > 0.5, "the linkage swings"
    assert gap(d) < 5e-3 and gap(mine) < 5e-3
    assert abs(ours["j1.q"] - d.qpos[0]) < 0.05


HANGING_BOX = """<mujoco model="hang">
  <option timestep="0.002"/>
  <worldbody>
    <body name="box" pos="0.3 0 1">
      <freejoint/>
      <geom type="box" size="0.06 0.04 0.03" pos="0.05 0 0" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <equality><weld name="grip" body1="box" anchor="0.3 0 1"/></equality>
</mujoco>"""


def test_a_weld_holds_a_box_where_its_springs_put_it(tmp_path):
    # A box welded to the world at its origin, its centre of mass 5 cm out along x. SCM's weld
    # is a spring and damper of solref (0.02 s, critically damped) on MuJoCo's inverse
    # weights, raised by the factor of MuJoCo's statics at g (`statics` in `scm compile`): at
    # rest the point sags by the weight over k = statics/(w_t τ²), i.e. g τ²/statics, and the
    # box tips until the rotational spring κ sin θ carries the weight's torque m g d cos θ,
    # κ = statics/(w_r τ²): tan θ = m g d w_r τ²/statics. Both exactly, to the settling left
    # after 1 s. MuJoCo's soft constraint holds the point tighter (one six-row constraint whose
    # impedance reads the whole residual) and lets the box tip further: printed.
    names = ["box.pos.z", "box.quat.w", "box.quat.y"]
    ours, m, d = run(tmp_path, HANGING_BOX, names, 1.0, name="hang")
    compiled = json.loads(subprocess.run([str(SCM), "compile", str(tmp_path / "hang.xml")],
                                         capture_output=True, text=True, check=True).stdout)
    weld = compiled["connects"][0]
    statics, turning = weld["statics"], weld["orientation"]["statics"]
    tau, g, arm = 0.02, 9.81, 0.05
    sag = 1.0 - ours["box.pos.z"]
    theta = 2 * np.arctan2(ours["box.quat.y"], ours["box.quat.w"])
    predicted = np.arctan(m.body_mass[1] * g * arm * m.body_invweight0[1, 1] * tau ** 2 / turning)
    mj_theta = 2 * np.arctan2(d.qpos[5], d.qpos[3])
    print(f"hanging weld: sag SCM {sag * 1e3:.3f} mm (g τ²/statics {g * tau ** 2 / statics * 1e3:.3f}), "
          f"MuJoCo {(1 - d.qpos[2]) * 1e3:.3f} mm; tilt SCM {theta:.4f} rad (predicted {predicted:.4f}), "
          f"MuJoCo {mj_theta:.4f}")
    assert sag == pytest.approx(g * tau ** 2 / statics, rel=1e-3)
    assert theta == pytest.approx(predicted, rel=1e-3)
    assert 0 < 1.0 - d.qpos[2] < sag and mj_theta > 0, "MuJoCo sags the same way, less"


SWINGING_WELD = """<mujoco model="swing">
  <option timestep="0.002"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="shoulder" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03" contype="0" conaffinity="0"/>
    </body>
    <body name="box" pos="0.45 0 1.02" euler="0 0 20">
      <freejoint/>
      <geom type="box" size="0.06 0.04 0.03" pos="0.02 0 0" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <equality><weld name="grip" body1="arm" body2="box"/></equality>
</mujoco>"""


def test_a_weld_carries_a_box_on_a_swinging_arm_as_in_mujoco(tmp_path):
    # A free box welded to a pendulum arm (the pose at qpos0 held) swings with it: the arm
    # moves as in MuJoCo, and the weld's errors (MuJoCo's residual: the gap between the
    # points, the vector part of the error quaternion) stay within the spring's deflection
    # under the swing's loads (g τ² = 4 mm at rest) in SCM, tighter in MuJoCo.
    names = ["shoulder.q"] + [f"box.pos.{a}" for a in "xyz"] + [f"box.quat.{a}" for a in "wxyz"]
    ours, m, d = run(tmp_path, SWINGING_WELD, names, 1.0, name="swing")

    def residual(qpos):
        data = mujoco.MjData(m)
        data.qpos[:] = qpos
        mujoco.mj_forward(m, data)
        return np.linalg.norm(data.efc_pos[0:3]), np.linalg.norm(data.efc_pos[3:6])

    (gap, turn), (mj_gap, mj_turn) = residual([ours[n] for n in names]), residual(d.qpos)
    print(f"swinging weld after 1 s: shoulder SCM {ours['shoulder.q']:.4f}, MuJoCo {d.qpos[0]:.4f} rad; "
          f"gap SCM {gap * 1e3:.2f} mm, MuJoCo {mj_gap * 1e3:.3f} mm; quaternion residual SCM {turn:.4f}, "
          f"MuJoCo {mj_turn:.4f}")
    assert abs(d.qpos[0]) > 1.0, "the arm swings"
    assert abs(ours["shoulder.q"] - d.qpos[0]) < 0.05
    assert gap < 0.015 and turn < 0.05
    assert mj_gap < 1e-3 and mj_turn < 0.02


def test_equalities_scm_cannot_place_are_refused_with_what_to_do(tmp_path):
    # A connect between bodies without an anchor (MuJoCo would read it as between sites and
    # fail), and a weld to a site placed by fromto: refused at their line, saying what to give.
    cases = [
        ('<connect body1="a" body2="b"/>', "needs an anchor"),
        ('<weld site1="s" site2="t"/>', "placed by fromto"),
        ('<weld body1="a" site1="s"/>', "give bodies or sites, not both"),
    ]
    for i, (element, why) in enumerate(cases):
        xml = GEARED_PENDULUMS.replace(
            '<joint name="gear" joint1="ja" joint2="jb" polycoef="0 0.5 0 0 0"/>', element).replace(
            '<geom type="capsule" fromto="0 0 0 0.3 0 0"',
            '<site name="s" pos="0.1 0 0"/><site name="t" type="capsule" size="0.01" fromto="0 0 0 0 0 1"/>'
            '<geom type="capsule" fromto="0 0 0 0.3 0 0"')
        path = tmp_path / f"equality{i}.xml"
        path.write_text(xml)
        out = subprocess.run([str(SCM), "pack", str(path), "-o", str(tmp_path / "c.fmu")], capture_output=True, text=True)
        assert out.returncode != 0, element
        assert f"equality{i}.xml:13" in out.stderr and why in out.stderr, out.stderr
#: MuJoCo's ellipsoid fluid model on every geom type it sizes: a leaf-like ellipsoid and a
#: capsule thrown spinning, a box swinging on a hinge, a cylinder beside a geom of the
#: inertia-box default on one body (the body then feels the ellipsoid geoms only), and an
#: inline mesh (its ellipsoid in the mesh's inertia frame, sized by its vertices' reach there).
#: Air, light bodies, no contact.
ELLIPSOID_FLUID = """<mujoco>
  <option density="1.2" viscosity="1.8e-5" timestep="0.002"><flag contact="disable"/></option>
  <default><geom fluidshape="ellipsoid"/></default>
  <asset><mesh name="tet" vertex="0 0 0 0.2 0 0 0 0.1 0 0 0 0.05"/></asset>
  <worldbody>
    <body name="leaf" pos="0 0 1" euler="10 20 30"><freejoint/>
      <geom type="ellipsoid" size="0.1 0.04 0.005" mass="0.002"/>
    </body>
    <body name="rod" pos="1 0 1"><freejoint/>
      <geom type="capsule" size="0.02 0.1" mass="0.005" fluidcoef="0.4 0.3 1.0 2.0 0.5"/>
    </body>
    <body name="flap" pos="2 0 1">
      <joint name="swing" type="hinge" axis="0 1 0.3"/>
      <geom type="box" size="0.1 0.05 0.01" pos="0.15 0 0" mass="0.003"/>
    </body>
    <body name="pair" pos="3 0 1"><freejoint/>
      <geom type="cylinder" size="0.05 0.02" mass="0.004"/>
      <geom type="sphere" size="0.03" pos="0 0 0.1" mass="0.001" fluidshape="none"/>
    </body>
    <body name="tet" pos="4 0 1" euler="30 0 10"><freejoint/>
      <geom type="mesh" mesh="tet" pos="0.01 0.02 0" euler="0 10 0" mass="0.002"/>
    </body>
  </worldbody>
</mujoco>"""


def test_fluidshape_none_is_mujocos_default_and_the_ellipsoid_model_moves_bodies_as_mujocos(tmp_path):
    # MuJoCo's own balloons, cards and leaves write fluidshape="ellipsoid" on their geoms;
    # "none" (the default, the inertia-box model) runs as MuJoCo's too.
    xml = """<mujoco>
  <option density="1.2" viscosity="1e-3" timestep="0.002"/>
  <worldbody>
    <body name="ball" pos="0 0 1"><freejoint/>
      <geom type="sphere" size="0.1" mass="0.05" fluidshape="none" fluidcoef="0.5 0.25 1.5 1 1"/>
    </body>
  </worldbody>
</mujoco>"""
    ours, m, d = run(tmp_path, xml, ["ball.pos.z"], 0.5, name="none")
    assert abs(ours["ball.pos.z"] - d.qpos[2]) < 1e-6, (ours["ball.pos.z"], d.qpos[2])
    assert 1.0 - d.qpos[2] < 0.5 * 9.81 * 0.25 * 0.99, "the air slows the fall"
    # The ellipsoid model: each free body thrown with a spin, the flap swung; 0.5 s.
    path = tmp_path / "ellipsoid.xml"
    path.write_text(ELLIPSOID_FLUID)
    fmu = tmp_path / "ellipsoid.fmu"
    out = subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    start, names = {"swing.v": 3.0}, []
    kick = [1.0, -0.5, 2.0, 4.0, -3.0, 6.0]
    for body in ["leaf", "rod", "flap", "pair", "tet"]:
        j = m.body(body).jntadr[0]
        if body == "flap":
            names.append("swing.q")
            d.qvel[m.jnt_dofadr[j]] = 3.0
            continue
        for k, axis in enumerate("xyz"):
            start[f"{body}.linvel.{axis}"] = kick[k]
            start[f"{body}.angvel.{axis}"] = kick[3 + k]
        names += [f"{body}.pos.{a}" for a in "xyz"] + [f"{body}.quat.{a}" for a in "wxyz"]
        d.qvel[m.jnt_dofadr[j]:m.jnt_dofadr[j] + 6] = kick
    res = simulate_fmu(str(fmu), stop_time=0.5, output_interval=0.01, output=names, start_values=start)
    still = mujoco.MjModel.from_xml_path(str(path))
    still.opt.density = still.opt.viscosity = 0.0
    ds = mujoco.MjData(still)
    ds.qvel[:] = d.qvel
    while d.time < 0.5 - 1e-9:
        mujoco.mj_step(m, d)
        mujoco.mj_step(still, ds)
    assert np.max(np.abs(d.qpos - ds.qpos)) > 0.05, "the fluid matters"
    ours = np.array([res[-1][n] for n in names])
    assert np.max(np.abs(ours - d.qpos)) < 1e-6, (ours - d.qpos)
    # The virtual masses and inertias the compiler gives each geom, as MuJoCo's: to 1e-5, as
    # MuJoCo takes the integrals κ by a 15-point quadrature, 2.3e-6 off the exact value for the
    # leaf's flattest axis (20:1; SCM's Carlson integral agrees with an adaptive quadrature to
    # 1e-13 there), and the runs above agree to 1e-6 all the same.
    fluid = json.loads(subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True,
                                      check=True).stdout)["fluid"]["ellipsoids"]
    geoms = [g for g in range(m.ngeom) if m.geom_fluid[g, 0] > 0]
    assert len(fluid) == len(geoms)
    for e, g in zip(fluid, geoms):
        for key, theirs in [("virtual_mass", m.geom_fluid[g, 6:9]), ("virtual_inertia", m.geom_fluid[g, 9:12])]:
            assert np.max(np.abs(np.asarray(e[key]) - theirs)) <= 1e-5 * np.max(np.abs(theirs)), (g, key, e[key], theirs)


SDF_SHAPES = """<mujoco>
  <option timestep="0.002"/>
  <extension>
    <plugin plugin="mujoco.sdf.torus">
      <instance name="ring"><config key="radius1" value="0.1"/><config key="radius2" value="0.03"/></instance>
    </plugin>
    <plugin plugin="mujoco.sdf.bowl">
      <instance name="bowl">
        <config key="height" value="0.2"/><config key="radius" value="0.5"/><config key="thickness" value="0.02"/>
      </instance>
    </plugin>
  </extension>
  <asset>
    <mesh name="ring"><plugin instance="ring"/></mesh>
    <mesh name="bowl"><plugin instance="bowl"/></mesh>
  </asset>
  <worldbody>
    <geom type="plane" size="2 2 .1"/>
    <body name="bowl" pos="2 0 0.6"><freejoint/>
      <geom type="sdf" mesh="bowl" density="500"><plugin instance="bowl"/></geom>
    </body>
    <body name="ring" pos="0 0 0.1" euler="30 20 0"><freejoint/>
      <geom type="sdf" mesh="ring"><plugin instance="ring"/></geom>
    </body>
  </worldbody>
</mujoco>
"""


def test_sdf_plugin_shapes_weigh_as_mujoco_weighs_them(tmp_path):
    """MuJoCo's torus and bowl SDF plugins: SCM makes the closed surface of the plugin's
    distance on MuJoCo's grid (marching tetrahedra where MuJoCo runs marching cubes) and weighs
    it by MuJoCo's default mesh rule: masses within 5e-4 and inertias within 1e-3 of MuJoCo's
    (measured 3e-5 and 3e-4 for the ring, 3e-4 for the bowl). MuJoCo puts such a mesh's
    centre of mass at its origin and its principal moments, largest first, along its own axes
    (the bowl's centre of mass is 12 cm below its origin): SCM's compiled bodies are MuJoCo's.
    The packed FMU carries no mesh file."""
    path = tmp_path / "sdf.xml"
    path.write_text(SDF_SHAPES)
    ours = json.loads(subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True,
                                     check=True).stdout)
    m = mujoco.MjModel.from_xml_path(str(path))
    for b in (1, 2):
        body = ours["bodies"][b]
        assert body["name"] == m.body(b).name
        assert abs(body["mass"] - m.body_mass[b]) < 5e-4 * m.body_mass[b], (body["mass"], m.body_mass[b])
        # The inertia in the body frame, as MuJoCo places it: its principal moments, largest
        # first, along the mesh's own axes (iquat identity), whatever axis the shape's largest
        # moment is about.
        ours_inertia = np.reshape(body["inertia"], (3, 3))
        r = np.zeros(9)
        mujoco.mju_quat2Mat(r, m.body_iquat[b])
        r = r.reshape(3, 3)
        theirs = r @ np.diag(m.body_inertia[b]) @ r.T
        assert np.max(np.abs(ours_inertia - theirs)) < 1e-3 * theirs.max(), (ours_inertia, theirs)
        com = np.asarray(body["ipos"])
        assert np.linalg.norm(com - m.body_ipos[b]) < 1e-4, (com, m.body_ipos[b])
    fmu = tmp_path / "sdf.fmu"
    subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], check=True, capture_output=True)
    import zipfile
    assert not [n for n in zipfile.ZipFile(fmu).namelist() if n.endswith((".obj", ".stl"))]


def test_sdf_torus_dropped_on_a_floor_lands_flat_as_in_mujoco(tmp_path):
    """A torus of MuJoCo's SDF plugin (r 0.1 m, tube 0.03 m) dropped tilted onto a floor,
    through its FMU: after 1 s it lies flat and at rest on its tube (height within 1 mm of the
    tube's radius), where MuJoCo's SDF collision lays it too (measured: 6 mm apart, MuJoCo's
    3.7 mm deeper and still sliding at 3 cm/s)."""
    xml = SDF_SHAPES.replace("""    <body name="bowl" pos="2 0 0.6"><freejoint/>
      <geom type="sdf" mesh="bowl" density="500"><plugin instance="bowl"/></geom>
    </body>
""", "")
    path = tmp_path / "ring.xml"
    path.write_text(xml)
    fmu = tmp_path / "ring.fmu"
    subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], check=True, capture_output=True)
    names = [f"ring.pos.{a}" for a in "xyz"] + [f"ring.quat.{a}" for a in "wxyz"] + ["ring.linvel.z"]
    res = simulate_fmu(str(fmu), stop_time=1.0, output_interval=0.01, output=names)
    ours = np.array([res[-1][n] for n in names])
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    while d.time < 1.0 - 1e-9:
        mujoco.mj_step(m, d)
    tilt = lambda q: np.degrees(2 * np.arcsin(min(1.0, np.hypot(q[1], q[2]) / np.linalg.norm(q))))
    print(f"SCM {ours[:3]} tilt {tilt(ours[3:7]):.2f} deg; MuJoCo {d.qpos[:3]} tilt {tilt(d.qpos[3:7]):.2f} deg")
    assert abs(ours[2] - 0.03) < 1e-3 and tilt(ours[3:7]) < 1.0 and abs(ours[7]) < 1e-3
    assert abs(d.qpos[2] - 0.03) < 5e-3 and tilt(d.qpos[3:7]) < 2.0
    assert np.linalg.norm(ours[:2] - d.qpos[:2]) < 0.01


@pytest.mark.parametrize("change, where, why", [
    (('plugin="mujoco.sdf.torus"', 'plugin="mujoco.pid"'), "<mesh>", "mujoco.pid', which SCM does not run"),
    (('<mesh name="ring">', '<mesh name="ring" scale="2 2 2">'), "<mesh>", "scale is not compatible"),
    (('<mesh name="ring">', '<mesh name="ring" refpos="0 0 0.1">'), "<mesh>", "refpos on a mesh made by an SDF plugin"),
    (('<mesh name="ring"><plugin instance="ring"/>', '<mesh name="ring"><plugin instance="ringo"/>'), "<plugin>",
     "no plugin instance named 'ringo'"),
    (('<config key="radius2" value="0.03"/>', '<config key="radius2" value="-1"/>'), "<config>",
     "expected a positive number"),
])
def test_sdf_plugin_mistakes_are_refused_saying_why(change, where, why, tmp_path):
    """A plugin SCM does not run, a scaled plugin mesh (MuJoCo refuses it too), an unknown
    instance and a bad configuration are refused at their element, saying why."""
    path = tmp_path / "bad.xml"
    path.write_text(SDF_SHAPES.replace(*change))
    out = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True)
    assert out.returncode != 0 and where in out.stderr and why in out.stderr, out.stderr


NUT_AND_BOLT = """<mujoco>
  <extension>
    <plugin plugin="mujoco.sdf.nut"><instance name="nut"><config key="radius" value="0.26"/></instance></plugin>
    <plugin plugin="mujoco.sdf.bolt"><instance name="bolt"><config key="radius" value="0.255"/></instance></plugin>
  </extension>
  <asset>
    <mesh name="nut"><plugin instance="nut"/></mesh>
    <mesh name="bolt"><plugin instance="bolt"/></mesh>
  </asset>
  <worldbody>
    <body name="nut" pos="0 0 0.83"><freejoint/>
      <geom type="sdf" mesh="nut"><plugin instance="nut"/></geom>
    </body>
    <body name="bolt" euler="180 0 0">
      <geom type="sdf" mesh="bolt"><plugin instance="bolt"/></geom>
    </body>
  </worldbody>
</mujoco>
"""


def test_sdf_nut_and_bolt_weigh_as_mujoco_weighs_them(tmp_path):
    """MuJoCo's nut and bolt SDF plugins (a hexagonal head, a single-start thread of pitch
    1/12 m) on MuJoCo's grid of 15 mm cells: the surfaces enclose MuJoCo's volumes to 3.3e-4
    (nut 0.30403 against 0.30393 m³, bolt 0.54701 against 0.54698, measured from MuJoCo's mesh),
    and the nut weighs as MuJoCo's within 5e-3 (measured 3.5e-3): MuJoCo's default rule counts
    each triangle's pyramid from the centroid without sign, which on the thread's folds depends
    on how the surface is cut into triangles (marching tetrahedra here, marching cubes there),
    not only on the surface. The bolt, welded to the world, gives no body mass."""
    path = tmp_path / "nutbolt.xml"
    path.write_text(NUT_AND_BOLT)
    ours = json.loads(subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True,
                                     check=True).stdout)
    m = mujoco.MjModel.from_xml_path(str(path))
    body = ours["bodies"][1]
    assert body["name"] == "nut"
    print(f"nut: mass {body['mass']} against MuJoCo's {m.body_mass[1]}")
    assert abs(body["mass"] - m.body_mass[1]) < 5e-3 * m.body_mass[1]
    r = np.zeros(9)
    mujoco.mju_quat2Mat(r, m.body_iquat[1])
    r = r.reshape(3, 3)
    theirs = r @ np.diag(m.body_inertia[1]) @ r.T
    ours_inertia = np.reshape(body["inertia"], (3, 3))
    assert np.max(np.abs(ours_inertia - theirs)) < 5e-3 * theirs.max(), (ours_inertia, theirs)
    checked = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True, check=True).stdout
    volumes = dict(re.findall(r"mesh (\w+) \(made by the mujoco.sdf.\w+ plugin\): .* volume ([0-9.e+-]+) m³", checked))
    for k in range(m.nmesh):
        # The volume MuJoCo's own mesh encloses (its signed pyramids from any point).
        v, f = m.mesh_vert[m.mesh_vertadr[k]:][:m.mesh_vertnum[k]], m.mesh_face[m.mesh_faceadr[k]:][:m.mesh_facenum[k]]
        t = v[f]
        theirs = np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() / 6
        assert abs(float(volumes[m.mesh(k).name]) - theirs) < 5e-4 * theirs, (volumes, m.mesh(k).name, theirs)


#: A nut threaded on a bolt, in the spirit of MuJoCo's nutbolt.xml (the same plugins, contact
#: parameters and damping), the bolt standing on its head and the nut on its thread, both turned
#: over as MuJoCo's file turns them. The thread needs points finer than the default 1 cm
#: (docs/geometry.md, "Shapes given by a distance function"): `scm_spacing` is 5 mm.
NUT_ON_BOLT = """<mujoco model="nut on bolt">
  <extension>
    <plugin plugin="mujoco.sdf.nut"><instance name="nut"><config key="radius" value="0.26"/></instance></plugin>
    <plugin plugin="mujoco.sdf.bolt"><instance name="bolt"><config key="radius" value="0.255"/></instance></plugin>
  </extension>
  <custom><numeric name="scm_spacing" data="0.005"/></custom>
  <asset>
    <mesh name="nut"><plugin instance="nut"/></mesh>
    <mesh name="bolt"><plugin instance="bolt"/></mesh>
  </asset>
  <default>
    <geom solref="0.01 1" solimp=".95 .99 .0001" friction="0.01"/>
  </default>
  <worldbody>
    <body name="nut" pos="0 0 0.83" euler="180 0 0">
      <joint name="nut" type="free" damping="30"/>
      <geom type="sdf" mesh="nut"><plugin instance="nut"/></geom>
    </body>
    <body name="bolt" euler="180 0 0">
      <geom type="sdf" mesh="bolt"><plugin instance="bolt"/></geom>
    </body>
  </worldbody>
</mujoco>
"""

#: The thread's lead: the nut turns 2π per 1/12 m along the bolt (the plugins' pitch).
RADIANS_PER_METRE = 2 * np.pi * 12


def yaw(q):
    r = np.zeros(9)
    mujoco.mju_quat2Mat(r, np.asarray(q, dtype=float))
    return np.arctan2(r[3], r[0])


def test_a_nut_screws_down_its_bolt_as_the_thread_demands(tmp_path):
    """The nut, spun at 2 rad/s about the bolt (the way it screws down) from where it rests on
    the thread (z 0.8283 m: MuJoCo's nut there turns and descends steadily from the start), under
    gravity: from 0.02 to 0.12 s it turns 24π radians per metre it descends (the thread's lead)
    within 3 %, and turns as far as MuJoCo's nut does (MuJoCo colliding the plugins' distance
    functions) within 5 %. Measured (2026-12-06, each cloud's ε1 following its 5 mm spacing,
    docs/method.md, "ε1 follows the spacing"): SCM 73.5 rad/m and 0.1877 rad, MuJoCo 75.4 rad/m
    and 0.1969 rad, 4.7 % apart, near the tolerance (with ε1 = 1e-5 m² for both clouds, before:
    74.9 rad/m and 0.1917 rad). Started at MuJoCo's file's height (every point settled), with
    that fixed ε1, at the default 1 cm spacing SCM's nut lost 45 % of its spin in 0.2 s (the
    thread's crests read a few millimetres wrong at that spacing, and the friction of the
    flanks they squeeze together brakes it), at 5 mm 10 % against MuJoCo's 4 %."""
    path = tmp_path / "nut_on_bolt.xml"
    path.write_text(NUT_ON_BOLT)
    start = {"nut.pos.z": 0.8283, "nut.angvel.z": 2.0, "nut.linvel.z": -2.0 / RADIANS_PER_METRE}
    csv = tmp_path / "run.csv"
    sets = [a for k, v in start.items() for a in ("--set", f"{k}={v!r}")]
    subprocess.run([str(SCM), "simulate", str(path), "--duration", "0.12", "--output-interval", "0.02",
                    *sets, "-o", str(csv)], check=True, capture_output=True)
    rows = np.genfromtxt(csv, delimiter=",", names=True)
    ours = [(r["nutposz"], yaw([r["nutquatw"], r["nutquatx"], r["nutquaty"], r["nutquatz"]])) for r in rows]
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    d.qpos[2], d.qvel[5], d.qvel[2] = start["nut.pos.z"], start["nut.angvel.z"], start["nut.linvel.z"]
    theirs = [(d.qpos[2], yaw(d.qpos[3:7]))]
    while d.time < 0.12 - 1e-9:
        mujoco.mj_step(m, d)
        if round(d.time / 0.002) % 10 == 0:
            theirs.append((d.qpos[2], yaw(d.qpos[3:7])))
    window = []
    for label, run in (("SCM", ours), ("MuJoCo", theirs)):
        z, turn = np.array([a for a, _ in run]), np.unwrap([b for _, b in run])
        descent, turned = z[1] - z[-1], turn[1] - turn[-1]
        print(f"{label}: descends {descent * 1e3:.3f} mm and turns {turned:.4f} rad: {turned / descent:.2f} rad/m")
        # It descends, turning the way the thread winds (clockwise seen from above).
        assert descent > 2e-3 and turned > 0.15
        assert abs(turned / descent - RADIANS_PER_METRE) < 0.03 * RADIANS_PER_METRE
        window.append(turned)
    assert abs(window[0] - window[1]) < 0.05 * window[1]


def test_nut_on_bolt_derivatives_are_exact_in_the_thread(tmp_path):
    """Model Exchange's directional derivatives of the nut's accelerations with respect to its
    13 states, where its thread bears on the bolt's (at the default 1 cm spacing), against central
    differences of the same FMU (test_directional_derivatives.py's steps and tolerance)."""
    path = tmp_path / "nut_on_bolt.xml"
    path.write_text(NUT_ON_BOLT.replace('<custom><numeric name="scm_spacing" data="0.005"/></custom>', ""))
    fmu = tmp_path / "nut_on_bolt.fmu"
    subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], check=True, capture_output=True)
    from hosts import Opened, get_x, set_x
    f = Opened(str(fmu))
    model = f.instance("ME")
    states = [d.variable.derivative for d in f.md.derivatives]
    x0 = get_x(model, len(states))
    x0[states.index(f.var["nut.pos.z"])] = 0.8275
    rng = np.random.default_rng(5)
    for i, s in enumerate(states):
        if s.unit in ("m/s", "rad/s"):
            x0[i] += rng.uniform(-0.02, 0.02)
    set_x(model, x0)
    (dist,) = model.getReal([f.vr["contact.nut.bolt.distance"]])
    assert dist < 0, dist
    rows = [d.variable for d in f.md.derivatives if d.variable.name.startswith("der(nut.") and "vel" in d.variable.name]
    assert len(rows) == 6
    vrs = [r.valueReference for r in rows]
    eps = np.finfo(float).eps
    for j, known in enumerate(states):
        exact = model.getDirectionalDerivative(vrs, [known.valueReference], [1.0])
        h = 1e-8
        def at(xj):
            x = x0.copy()
            x[j] = xj
            set_x(model, x)
            return np.array(model.getReal(vrs))
        fd = (at(x0[j] + h) - at(x0[j] - h)) / (2 * h)
        set_x(model, x0)
        y = np.array(model.getReal(vrs))
        if known.name == "nut.pos.z":
            # The thread is a stiff spring along the axis: the weight on the flanks rises by
            # thousands of g per metre pressed.
            stiff = exact[[r.name for r in rows].index("der(nut.linvel.z)")]
            print(f"d(der(nut.linvel.z))/d(nut.pos.z) = {stiff:.4g} 1/s²")
            assert stiff < -1e4
        for r, e, c, yy in zip(rows, exact, fd, y):
            assert abs(e - c) <= 1e-5 * max(abs(e), abs(c)) + 64 * eps * max(abs(yy), 1.0) / h, (r.name, known.name, e, c)
    model.terminate()
    model.freeInstance()


#: Two gears of MuJoCo's gear plugin meshing, in the spirit of MuJoCo's gear.xml (its gears,
#: hinges, damping, motor, contact parameters and SDF collision settings; no floor): the driven
#: gear turns the other.
#: Weighed by their exact volume (`inertia="exact"`): MuJoCo's default rule counts each
#: triangle's pyramid without sign, which depends on the triangles (marching cubes there,
#: marching tetrahedra here): 1372.0 kg here against MuJoCo's 1359.4.
GEAR_PAIR = """<mujoco model="gear pair">
  <extension>
    <plugin plugin="mujoco.sdf.gear">
      <instance name="gear1"><config key="alpha" value="0"/></instance>
      <instance name="gear2"><config key="alpha" value="15"/></instance>
    </plugin>
  </extension>
  <option sdf_iterations="5" sdf_initpoints="20"/>
  <asset>
    <mesh name="gear1" inertia="exact"><plugin instance="gear1"/></mesh>
    <mesh name="gear2" inertia="exact"><plugin instance="gear2"/></mesh>
  </asset>
  <default>
    <geom solref="0.01 1" solimp=".95 .99 .0001" friction="0.2"/>
  </default>
  <worldbody>
    <body name="driven" pos="0 0 .2">
      <joint name="freewheel" type="hinge" damping="1000" axis="0 0 1"/>
      <geom type="sdf" mesh="gear1"><plugin instance="gear1"/></geom>
    </body>
    <body name="driver" pos="2.85 0 .2">
      <joint name="drive" type="hinge" damping=".1" axis="0 0 1"/>
      <geom type="sdf" mesh="gear2"><plugin instance="gear2"/></geom>
    </body>
  </worldbody>
  <actuator>
    <motor name="drive" joint="drive" ctrlrange="-1 1" gear="1500"/>
  </actuator>
</mujoco>
"""


def hinge_inertia(m, k):
    """Body k's moment of inertia about its hinge's axis (MuJoCo's compiled model)."""
    r = np.zeros(9)
    mujoco.mju_quat2Mat(r, m.body_iquat[k])
    r = r.reshape(3, 3)
    axis = m.jnt_axis[m.body_jntadr[k]]
    return axis @ (r @ np.diag(m.body_inertia[k]) @ r.T) @ axis


def test_gears_of_the_gear_plugin_weigh_and_mesh_as_in_mujoco(tmp_path):
    """MuJoCo's gear plugin (25 involute teeth on a 2.8 m pitch circle, 0.2 m thick): SCM's
    gears weigh as MuJoCo's within 3e-3 (measured: mass 1.3e-3, moments 1.6e-3, the two grids'
    surfaces). Driven at half its motor's torque (750 N m) against the other's damping, the
    driver turns the driven gear the other way. After the teeth meet (0.15 s), from 0.3 to 0.6 s:
    the driven gear turns as far as the driver within 2 % (equal gears); at every 0.02 s its
    speed is the driver's within 5 % (the teeth roll on each other without chatter; measured
    1.9 %); the pair speeds up as one rigid body of both gears' moments about their axles
    against the motor and both dampers, within 3 % at 0.6 s (measured 2.0 % slower: the teeth's
    friction). At 0.6 s both angles are MuJoCo's within 5 % (measured 1.1 %) with the file's SDF
    collision settings (5 iterations from 20 points, as MuJoCo's gear.xml); MuJoCo's own spread
    is wide: at its defaults (10 from 40) or at 20 from 40 its gears bounce apart and its driver
    is at 0.052 or 0.068 rad at 0.6 s where it is at 0.116 with the file's settings."""
    path = tmp_path / "gears.xml"
    path.write_text(GEAR_PAIR)
    m = mujoco.MjModel.from_xml_path(str(path))
    ours = json.loads(subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True,
                                     check=True).stdout)
    for k in (1, 2):
        body = ours["bodies"][k]
        assert abs(body["mass"] - m.body_mass[k]) < 3e-3 * m.body_mass[k], (body["mass"], m.body_mass[k])
        assert np.allclose(sorted(np.diag(np.reshape(body["inertia"], (3, 3)))), sorted(m.body_inertia[k]),
                           rtol=3e-3), (body["inertia"], m.body_inertia[k])
    csv = tmp_path / "run.csv"
    subprocess.run([str(SCM), "simulate", str(path), "--duration", "0.6", "--output-interval", "0.02",
                    "--set", "drive.ctrl=0.5", "-o", str(csv)], check=True, capture_output=True)
    rows = np.genfromtxt(csv, delimiter=",", names=True)
    d = mujoco.MjData(m)
    d.ctrl[0] = 0.5
    while d.time < 0.6 - 1e-9:
        mujoco.mj_step(m, d)
    late = rows["time"] >= 0.3 - 1e-9
    t, q1, q2, w1, w2 = (rows[n][late] for n in ("time", "freewheelq", "driveq", "freewheelv", "drivev"))
    gap = np.max(np.abs(w1 + w2) / np.abs(w2))
    # One rigid body: (I1 + I2) w' = 750 - (1000 + 0.1) w, from the driver's speed at 0.3 s.
    inertia = hinge_inertia(m, 1) + hinge_inertia(m, 2)
    settle, tau = 750 / 1000.1, inertia / 1000.1
    rigid = settle + (w2[0] - settle) * np.exp(-(t[-1] - t[0]) / tau)
    print(f"SCM: turns {q1[-1] - q1[0]:.4f} and {q2[-1] - q2[0]:.4f} rad, speeds apart by {gap:.2%} at most, "
          f"{w2[-1]:.4f} rad/s at 0.6 s (one rigid body: {rigid:.4f}); at 0.6 s {q1[-1]:.4f}, {q2[-1]:.4f} "
          f"against MuJoCo's {d.qpos[0]:.4f}, {d.qpos[1]:.4f}")
    assert q2[-1] - q2[0] > 0.05 and q1[-1] - q1[0] < -0.05
    assert abs((q1[-1] - q1[0]) + (q2[-1] - q2[0])) < 0.02 * (q2[-1] - q2[0])
    assert gap < 0.05
    assert abs(w2[-1] - rigid) < 0.03 * rigid
    assert abs(q1[-1] - d.qpos[0]) < 0.05 * abs(d.qpos[0])
    assert abs(q2[-1] - d.qpos[1]) < 0.05 * abs(d.qpos[1])


def u_and_ball(tmp_path, custom=""):
    """A 1 cm ball dropped from 6 cm into the notch of a U-shaped block fixed to the world
    (tests/fixtures/u_block.obj: 6 x 4 x 3 cm, its notch 2 cm wide from z = 1 cm to its top at
    3 cm), with `custom` in the file's <custom>."""
    fixture = pathlib.Path(__file__).resolve().parents[1] / "fixtures" / "u_block.obj"
    (tmp_path / "u_block.obj").write_bytes(fixture.read_bytes())
    return f"""<mujoco model="u_and_ball">
  <option timestep="0.002"/>
  <custom>{custom}</custom>
  <asset><mesh name="u" file="u_block.obj"/></asset>
  <worldbody>
    <geom name="u" type="mesh" mesh="u"/>
    <body name="ball" pos="0 0 0.06">
      <freejoint/>
      <geom type="sphere" size="0.005" mass="0.01"/>
    </body>
  </worldbody>
</mujoco>"""


def test_a_ball_dropped_into_a_concave_mesh_rests_on_its_hull_as_in_mujoco(tmp_path):
    """MuJoCo collides a mesh by its convex hull, and so does SCM by default (docs/mjcf.md,
    "How a mesh collides"): the ball rests on the hull's top, its centre 3.5 cm up, not in the
    notch. Asked to collide by the surface (scm_mesh_collision), SCM lets it fall into the
    notch onto its floor (centre at 1.5 cm), which MuJoCo cannot do with this file."""
    ours, m, d = run(tmp_path, u_and_ball(tmp_path), ["ball.pos.z"], 1.0)
    assert abs(d.qpos[2] - 0.035) < 1e-3, d.qpos[2]
    assert abs(ours["ball.pos.z"] - d.qpos[2]) < 2e-3, (ours["ball.pos.z"], d.qpos[2])
    surface = '<text name="scm_mesh_collision" data="surface"/>'
    ours, _, _ = run(tmp_path, u_and_ball(tmp_path, surface), ["ball.pos.z"], 1.0, name="surface")
    assert abs(ours["ball.pos.z"] - 0.015) < 2e-3, ours["ball.pos.z"]
