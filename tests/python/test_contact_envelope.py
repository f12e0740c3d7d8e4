"""Contact on, SCM against MuJoCo's own spread (docs/mjcf.md, "Contact on, against MuJoCo's
spread"): every gymnasium file, dm_control suite file and gymnasium-robotics file that moves
(the 17 its environments load), run as written (its own
integrator and step) with zero controls for 1 s (2 s for the legged ones), ends inside the
envelope of MuJoCo's final poses under plausible contact parameters (solref's time constant
x0.5, x1, x2, friction x0.8, x1, x1.2, with Euler, RK4 and implicitfast), widened by 2 cm and
0.1 rad. The runs and the comparison are scripts/contact_envelope.py's, which prints the table.
robosuite's Franka, xArm7 and TIAGo arms as written are held the same way (below).

A file SCM does not bring inside is a strict xfail with what was measured about it (OUT): it fails
the day it comes inside, so the list stays true. Since MJCF's RK4 maps to damped_rk4 and the
joints' limits have MuJoCo's impedance (docs/mjcf.md, "Joint limits") no gymnasium or dm_control
file was out but one MuJoCo's own reset runs had let in (manipulator), and none of
gymnasium-robotics' but one (adroit_pen); the implicit integrators' damping bound (docs/method.md,
departure 4) moved humanoid_CMU 1.7 mm out and manipulator in: two files, each explained by
tests of its own (below), and a rolling ball's difference tested too. dm_control's humanoid_CMU (57 joints, 2 s),
once left to the script for SCM's 320 s on it, is run here: SCM now takes 1.6 s.
"""
import csv
import io
import json
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))
import contact_envelope as envelope  # noqa: E402

from conftest import DM_CONTROL_REFUSED, ROBOTICS, robotics_id  # noqa: E402

pytestmark = pytest.mark.slow

#: Not run here, and why.
NOT_HERE = {
    "dm_control/lqr": "no joint: nothing moves",
}

#: Files SCM's final pose is outside MuJoCo's envelope on: whether SCM runs and ends outside
#: ("outside") or stops ("stopped", the implicit step's Newton iterations), and what was measured
#: (docs/mjcf.md).
OUT = {
    "dm_control/humanoid_CMU": (
        "outside", "root y 1.7 mm past the widened envelope at 2 s: it lands on a contact stiffer than "
        "MuJoCo's and falls on a friction circle where the file's cone is a pyramid (tests below; docs/mjcf.md)"),
    "gymnasium-robotics/adroit_pen": (
        "outside", "the pen spins on the hand, 0.95 rad at 1 s where MuJoCo's turns 0.086: the "
        "torsional friction (condim 4, 0.5) of the pen and the fingertips, which SCM leaves out, holds it (test below; docs/mjcf.md)"),
}

#: The corpora, each file's test id named by its corpus.
CORPORA = (("gymnasium", envelope.GYM, lambda p: p.stem), ("dm_control", envelope.DM, lambda p: p.stem),
           ("gymnasium-robotics", ROBOTICS, robotics_id))


def files():
    out = []
    for corpus, paths, stem in CORPORA:
        for path in paths:
            name = f"{corpus}/{stem(path)}"
            if corpus == "dm_control" and path.stem in DM_CONTROL_REFUSED or name in NOT_HERE:
                continue
            marks = [pytest.mark.xfail(strict=True, raises=AssertionError, reason=OUT[name][1])] if name in OUT else []
            out.append(pytest.param(path, name, id=name, marks=marks))
    return out


def test_the_lists_name_files_that_exist():
    listed = [f"{c}/{stem(p)}" for c, ps, stem in CORPORA for p in ps]
    names = set(listed)
    assert len(names) == len(listed), "two files of a corpus share a test id"
    assert set(OUT) <= names and set(NOT_HERE) <= names, (set(OUT) | set(NOT_HERE)) - names
    assert all(kind in ("outside", "stopped") for kind, _ in OUT.values())


@pytest.mark.parametrize("path, name", files())
def test_contact_on_ends_inside_mujocos_envelope(path, name):
    seconds = 2.0 if envelope.LEGGED.search(path.stem) else 1.0
    model, finals = envelope.mujoco_finals(path, seconds)
    # MuJoCo leaves out a run it finds unstable; most of the 27 must be there to make a spread.
    # (Not the expected failure of a file in OUT: a RuntimeError fails the test outright.)
    if len(finals) < 18:
        raise RuntimeError(f"only {len(finals)} of MuJoCo's 27 runs are stable")
    ours, error = envelope.scm_final(path, seconds)
    kind = OUT.get(name, ("inside", ""))[0]
    if error is not None and kind == "outside":
        raise RuntimeError(f"SCM stopped where it was measured to run: {error}")
    if error is not None and kind == "stopped" and "Newton iterations did not converge" not in error:
        raise RuntimeError(f"SCM stopped otherwise than measured: {error}")
    assert error is None, f"SCM stopped: {error}"
    inside, worst, where = envelope.compare(model, finals, ours)
    assert inside, f"{worst:.3g} (m or rad) outside MuJoCo's envelope at {where}"


def test_walker2d_topples_over_its_softer_foot_as_in_mujoco_and_folds_at_its_knees_without(tmp_path):
    """Why gymnasium's walker2d falls as it does (docs/mjcf.md, "The friction cone"): its feet's friction, 0.9 and 1.9, has
    MuJoCo's default pyramidal cone hold the left foot 5.7 times deeper than the right; the
    walker tips towards it and flexes its hips. Under the elliptic cone, whose normal does not
    depend on the friction, MuJoCo's walker folds at the knees instead, hips on their limits.
    SCM's pair law takes the cone's share (docs/mjcf.md, "The friction cone"): its walker
    flexes its hips as MuJoCo's does as written, and folds at its knees as MuJoCo's does under
    the elliptic cone. Compared at 1 s (RK4, 2 ms, zero controls)."""
    import csv
    import io
    import subprocess

    import mujoco

    from conftest import SCM

    path = next(p for p in envelope.GYM if p.stem == "walker2d")
    elliptic = tmp_path / "walker2d_elliptic.xml"
    elliptic.write_text(path.read_text().replace('<option integrator="RK4"',
                                                 '<option cone="elliptic" integrator="RK4"'))
    hips = ["thigh_joint", "thigh_left_joint"]
    for xml, flexed in [(path, True), (elliptic, False)]:
        m = mujoco.MjModel.from_xml_path(str(xml))
        d = mujoco.MjData(m)
        for _ in range(500):
            mujoco.mj_step(m, d)
        theirs = [d.qpos[m.jnt_qposadr[m.joint(h).id]] for h in hips]
        out = subprocess.run([str(SCM), "simulate", str(xml), "--duration", "1", "--output-interval", "1",
                              "--outputs", ",".join(f"{h}.q" for h in hips)],
                             capture_output=True, text=True, check=True).stdout
        ours = [float(x) for x in list(csv.reader(io.StringIO(out)))[-1][1:]]
        print(f"{xml.name}: hips at 1 s, MuJoCo {theirs}, SCM {ours}")
        for q in theirs + ours:
            assert (q < -0.3) if flexed else (abs(q) < 0.02), (xml.name, theirs, ours)


def test_walker2d_ends_inside_mujocos_envelope_when_its_feet_push_at_their_deepest_points():
    """What kept gymnasium's walker2d outside when MJCF's RK4 was SCM's rk4 (as damped_rk4 it ends
    inside as written) was SCM's separation smoothing: at the
    default eps2 = 1 mm a foot's force acts at the weighted mean of its points within about a
    millimetre of the deepest, so a foot landing flat is pushed at its middle, 10 cm ahead of
    its ankle, and tips (the right foot 0.27 rad at 0.2 s, 0.015 at eps2 = 0.1 mm, MuJoCo's 0.002).
    At eps2 = 0.1 mm the force
    acts at the deepest points, as MuJoCo's contacts do at a capsule's ends, and the walker's
    fall ends inside MuJoCo's envelope (pitch -3.41 rad, x 0.094 m)."""
    path = next(p for p in envelope.GYM if p.stem == "walker2d")
    model, finals = envelope.mujoco_finals(path, 2.0)
    ours, error = envelope.scm_final(path, 2.0, sets=["scm.eps2=1e-4"])
    assert error is None, error
    inside, worst, where = envelope.compare(model, finals, ours)
    assert inside, f"{worst:.3g} (m or rad) outside MuJoCo's envelope at {where}"


#: robosuite's arms as written (unpacked from its wheel by scripts/setup.sh), zero controls
#: from every joint at zero: each falls onto its own base or torso (MuJoCo: up to 4, 5 and 4
#: contacts on the way; joints moving up to 1.27, 2.10 and 0.29 rad).
ROBOSUITE_ARMS = ["robots/panda/robot.xml", "robots/xarm7/robot.xml", "robots/tiago/robot.xml"]


@pytest.mark.parametrize("arm", ROBOSUITE_ARMS)
def test_robosuite_arms_end_inside_mujocos_envelope(arm):
    """The arms users bring, as their files are written, 1 s: each ends inside MuJoCo's 27-run
    envelope (measured 2026-12-07: all three). With SCM's contact disabled Franka ends 0.034
    rad and xArm7 0.36 rad outside (joint 6), TIAGo still inside: the test holds the first two
    to their contact. Half way too (below), where under the paper's law xArm7's wrist stays on
    its base for 100 ms while MuJoCo's bounces off in 8 to 10 ms (docs/mjcf.md, "Contact on,
    against MuJoCo's spread")."""
    path = ROOT / ".venv" / "robosuite_assets" / "robosuite" / "models" / "assets" / arm
    model, finals = envelope.mujoco_finals(path, 1.0)
    assert len(finals) >= 18, f"only {len(finals)} of MuJoCo's 27 runs are stable"
    ours, error = envelope.scm_final(path, 1.0)
    assert error is None, f"SCM stopped: {error}"
    inside, worst, where = envelope.compare(model, finals, ours)
    assert inside, f"{worst:.3g} (m or rad) outside MuJoCo's envelope at {where}"


XARM7 = ROOT / ".venv" / "robosuite_assets" / "robosuite" / "models" / "assets" / "robots" / "xarm7" / "robot.xml"


def xarm7_at_half_a_second(custom=""):
    """xArm7 at 0.5 s against MuJoCo's envelope: (inside, worst, where); `custom`, SCM settings
    put in a copy beside the file (its meshes are named relative to its folder)."""
    model, finals = envelope.mujoco_finals(XARM7, 0.5)
    copy = XARM7.parent / f".half{abs(hash(custom))}.robot.xml"
    copy.write_text(XARM7.read_text().replace("</mujoco>", f"<custom>{custom}</custom></mujoco>"))
    try:
        ours, error = envelope.scm_final(copy, 0.5)
    finally:
        copy.unlink()
    if error is not None:  # an error, not an outcome to compare
        raise RuntimeError(f"SCM stopped: {error}")
    return envelope.compare(model, finals, ours)


def test_xarm7_falls_inside_mujocos_envelope_half_way():
    inside, worst, where = xarm7_at_half_a_second()
    assert inside, f"{worst:.3g} (m or rad) outside MuJoCo's envelope at {where}"


def test_xarm7_stays_on_its_base_under_the_papers_damping():
    """Why the implicit integrators bound the contact's damping (docs/method.md, departure 4):
    under `implicitfast` (SCM's implicit_euler) with the paper's law (the scene's
    `scm_dissipation_force` 0) the damping grows with the depth; the wrist strikes the base
    2.2 mm deep and is held there 100 ms where MuJoCo's bounces off in 8 to 10 ms, and joint 4
    ends 0.10 rad outside MuJoCo's envelope at 0.5 s (1.143 rad against 1.346 to 1.806, widened
    by 0.1). With the default bound (8 m̂ g, a separation held to a few v_d) it is inside, as
    with 4 (1.311 rad; 1.206 at 20; measured 2026-12-07)."""
    inside, worst, where = xarm7_at_half_a_second('<numeric name="scm_dissipation_force" data="0"/>')
    assert not inside and where.startswith("joint4") and 0.05 < worst < 0.15, (inside, worst, where)


def test_humanoid_cmu_falls_as_mujocos_until_its_toes_touch_down():
    """Where dm_control's humanoid_CMU starts to fall ahead of MuJoCo's (docs/mjcf.md, "Contact
    on, against MuJoCo's spread"): not in its free fall. Released with its root at 1 m and its
    toes 8.5 cm above the floor, its 56 joints under their springs, dampers and limits (each
    knee starts 17.5 mrad outside its 1° bound), SCM's body follows MuJoCo's for the 0.12 s
    before any geom touches anything: the root within 0.1 mm (measured at most 0.045 mm), every
    joint within 2.5 mrad (measured 1.75, a knee leaving its limit: below the `solimplimit`
    width MuJoCo's impedance starts at this file's `d0` = 0 where SCM's limit takes `dmax`).
    MuJoCo's toes touch the floor between 0.130 and 0.132 s; from there the two part ways."""
    import mujoco
    import numpy as np

    path = next(p for p in envelope.DM if p.stem == "humanoid_CMU")
    run = subprocess.run([str(envelope.SCM), "simulate", str(path), "--duration", "0.12",
                          "--output-interval", "0.02"], capture_output=True, text=True, check=True)
    rows = list(csv.reader(io.StringIO(run.stdout)))
    ours = [dict(zip(rows[0], map(float, row))) for row in rows[1:]]
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    joints = [(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j), model.jnt_qposadr[j])
              for j in range(1, model.njnt)]
    assert len(ours) == 7 and len(joints) == 56
    for k, row in enumerate(ours[1:], start=1):
        while data.time < 0.02 * k - 1e-9:
            mujoco.mj_step(model, data)
        assert row["time"] == pytest.approx(data.time, abs=1e-9)
        mujoco.mj_forward(model, data)
        assert data.ncon == 0, data.time
        root = np.array([row[f"root.pos.{c}"] for c in "xyz"])
        assert np.abs(root - data.qpos[:3]).max() < 1e-4, (data.time, root, data.qpos[:3])
        worst = max((abs(row[f"{name}.q"] - data.qpos[adr]), name) for name, adr in joints)
        assert worst[0] < 2.5e-3, (data.time, worst)
    toes = {mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in ("ltoes", "rtoes")}
    for until, touching in ((0.130, False), (0.132, True)):
        while data.time < until - 1e-9:
            mujoco.mj_step(model, data)
        mujoco.mj_forward(model, data)
        bodies = {model.geom_bodyid[g] for c in data.contact[:data.ncon] for g in (c.geom1, c.geom2)}
        assert (data.ncon > 0 and bodies - {0} <= toes) if touching else data.ncon == 0, (until, bodies)


def test_humanoid_cmu_lands_as_mujocos_stiffest_contact_does():
    """Why humanoid_CMU falls ahead of MuJoCo's (docs/mjcf.md, "Contact on, against MuJoCo's
    spread"): its landing. SCM's contact spring holds MuJoCo's static depth, so it is 1/(1 - d)
    times MuJoCo's reference stiffness (100 times at this file's `solimp` 0.99). Landing at
    1.3 m/s, SCM's toes sink 5.3 mm (3.6 under the paper's law) where MuJoCo's, whose 15 ms time
    constant spreads the impact, sink 10.9 mm. With its time constant at 4 ms (the least
    `refsafe` allows at the file's 2 ms step) MuJoCo's toes sink 3.1 mm and its root lands as
    SCM's does: root y 13.6 and 32.1 mm at 0.2 and 0.3 s, SCM's 13.7 and 32.5 (13.6 and 32.5
    under the paper's law), MuJoCo's as written 12.0 and 29.3 (measured 2026-12-07). That is the
    landing. In the fall that follows, on its feet, SCM draws further ahead of the stiff MuJoCo
    (145.4 against 133.7 mm at 0.75 s; 145.2 under the paper's law), and the friction cone
    is the rest: with the elliptic cone in place of the file's pyramid the stiff MuJoCo is at
    142.9 mm (SCM's friction, whatever the cone, is a circle of radius mu N)."""
    import mujoco

    path = next(p for p in envelope.DM if p.stem == "humanoid_CMU")
    run = subprocess.run([str(envelope.SCM), "simulate", str(path), "--duration", "0.75",
                          "--output-interval", "0.002", "--outputs",
                          "root.pos.y,contact.world.ltoes.distance"],
                         capture_output=True, text=True, check=True)
    rows = list(csv.reader(io.StringIO(run.stdout)))
    ours = {round(float(t), 3): (float(y), float(dist)) for t, y, dist in rows[1:]}
    toes_ours = min(dist for _, dist in ours.values())

    def mujoco_landing(time_constant, cone=None):
        model = mujoco.MjModel.from_xml_path(str(path))
        if time_constant is not None:
            model.geom_solref[:, 0] = time_constant
        if cone is not None:
            model.opt.cone = cone
        data = mujoco.MjData(model)
        toes = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "ltoes")
        root_y, deepest = {}, 0.0
        while data.time < 0.75 - 1e-9:
            mujoco.mj_step(model, data)
            deepest = min([deepest] + [c.dist for c in data.contact[:data.ncon]
                                       if toes in (model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2])])
            root_y[round(data.time, 3)] = data.qpos[1]
        return root_y, deepest

    written, toes_written = mujoco_landing(None)
    stiff, toes_stiff = mujoco_landing(0.004)
    assert -6.5e-3 < toes_ours < -2.5e-3 and -3.5e-3 < toes_stiff < -2.5e-3 and toes_written < -9e-3
    for t in (0.2, 0.3):
        assert abs(ours[t][0] - stiff[t]) < 1e-3, (t, ours[t][0], stiff[t])
        assert ours[t][0] - written[t] > 1.0e-3, (t, ours[t][0], written[t])
    elliptic, _ = mujoco_landing(0.004, mujoco.mjtCone.mjCONE_ELLIPTIC)
    assert ours[0.75][0] - stiff[0.75] > 8e-3 and abs(ours[0.75][0] - elliptic[0.75]) < 4e-3, \
        (ours[0.75][0], stiff[0.75], elliptic[0.75])


def test_adroit_pen_is_held_by_mujocos_torsional_friction_which_scm_leaves_out():
    """Why gymnasium-robotics' adroit_pen ends outside MuJoCo's envelope: its pen (a cylinder
    with `condim="4"`, as the fingertips have, and the file's torsional friction of 0.5) falls
    onto the hand and MuJoCo's torsional friction holds its spin (OBJRz -0.086 rad at 1 s). SCM
    uses only the sliding friction (docs/mjcf.md, "Geom friction"), and without the torsional
    rows (every `condim` 4 made 3) MuJoCo's own pen spins too, further than SCM's (measured
    2026-12-07: SCM -0.95 rad, MuJoCo without the rows below -1 rad)."""
    import mujoco

    path = next(p for p in ROBOTICS if p.stem == "adroit_pen")

    def mujoco_spin(condim):
        model = mujoco.MjModel.from_xml_path(str(path))
        pen = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "pen")
        assert model.geom_condim[pen] == 4 and model.geom_friction[pen][1] == 0.5
        model.geom_condim[model.geom_condim == 4] = condim
        data = mujoco.MjData(model)
        while data.time < 1.0 - 1e-9:
            mujoco.mj_step(model, data)
        return data.qpos[model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "OBJRz")]]

    ours, error = envelope.scm_final(path, 1.0)
    assert error is None, error
    held, free = mujoco_spin(4), mujoco_spin(3)
    assert abs(held) < 0.15 and free < -1.0 and free < ours["OBJRz.q"] < -0.5, (held, free, ours["OBJRz.q"])


ROLLING_BALL = """<mujoco>{custom}<option timestep="0.001" cone="elliptic"/>
  <default><geom friction=".7" solimp="0.9 0.97 0.001" solref=".005 1"/></default>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 .1"/>
    <body name="ball" pos="0 0 0.0218">
      <joint name="bx" type="slide" axis="1 0 0"/><joint name="bz" type="slide" axis="0 0 1"/>
      <joint name="by" type="hinge" axis="0 1 0"/>
      <geom name="ball" type="sphere" size=".022"/>
    </body>
  </worldbody>
</mujoco>"""


def test_a_rolling_ball_keeps_its_speed_in_mujoco_and_slows_under_scms_damping(tmp_path):
    """What SCM's damping does to a rolling ball, and why dm_control's manipulator ended outside
    MuJoCo's envelope under the paper's law: its ball (22 mm, `solref` 0.005) lands and rolls
    along the floor, at a steady 1.183 m/s in MuJoCo, slowing from 0.95 to 0.49 m/s in SCM, and
    strikes the arm later (under the implicit integrators' bound it lands at 1.05 m/s, slows as
    much and ends inside). A ball as the file's (its size, density,
    `solref`, `solimp`, friction, elliptic cone, Euler at 1 ms) alone on a floor, rolling at
    1.18 m/s: MuJoCo damps the bodies' approach at one contact point, which rolling does not
    change, and keeps its speed; SCM damps each surface point by its own normal speed, and on a
    rolling ball the points entering the contact approach the floor while those leaving it
    recede, so the front pushes harder than the back: a rolling resistance (0.51 m/s after 1 s,
    0.52 under the paper's law, measured 2026-12-07). With the same stiffness and almost no damping (`v_d` = 100 m/s) SCM's
    ball keeps 1.17 m/s: the damping is the cause."""
    import mujoco

    def scm_speed(custom):
        path = tmp_path / "ball.xml"
        path.write_text(ROLLING_BALL.format(custom=custom))
        run = subprocess.run([str(envelope.SCM), "simulate", str(path), "--duration", "1", "--output-interval", "1",
                              "--outputs", "bx.v", "--set", "bx.v=-1.18", "--set", "by.v=-53.636"],
                             capture_output=True, text=True, check=True)
        return float(run.stdout.splitlines()[-1].split(",")[1])

    model = mujoco.MjModel.from_xml_string(ROLLING_BALL.format(custom=""))
    data = mujoco.MjData(model)
    data.qvel[:] = [-1.18, 0.0, -1.18 / 0.022]
    while data.time < 1.0 - 1e-9:
        mujoco.mj_step(model, data)
    assert abs(data.qvel[0] + 1.18) < 5e-3, data.qvel
    as_written = scm_speed("")
    compiled = subprocess.run([str(envelope.SCM), "compile", str(tmp_path / "ball.xml")], capture_output=True,
                              text=True, check=True)
    (pair,) = json.loads(compiled.stdout)["pairs"]
    undamped = scm_speed(f'<custom><numeric name="scm_stiffness" data="{pair["stiffness"]!r}"/>'
                         '<numeric name="scm_dissipation_velocity" data="100"/></custom>')
    assert -0.7 < as_written < -0.3 and undamped < -1.0, (as_written, undamped)


SPUN_SPHERE = """<mujoco><option timestep="0.002"/>
  <default><geom friction="1 0.05 0.0001" condim="{condim}"/></default>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 .1"/>
    <body name="ball" pos="0 0 0.05"><freejoint name="ball"/><geom type="sphere" size="0.05" mass="1"/></body>
  </worldbody>
</mujoco>"""


def test_scms_friction_over_a_contacts_points_stops_a_spin_as_mujocos_torsional_row_does(tmp_path):
    """What SCM has in place of MuJoCo's torsional friction (docs/mjcf.md, "Contact on, against
    MuJoCo's spread", adroit_pen): its sliding friction acts at each of a contact's points, and
    over the patch it resists a spin about the normal. A 1 kg sphere of 5 cm spun at 10 rad/s on
    a floor stops within 0.25 s in SCM and in MuJoCo with `condim="4"`; with `condim="3"` (no
    torsional row, one contact point) MuJoCo's spins on. The patch is millimetres across, so the
    resisting torque is far below that of a torsional coefficient of 0.5 m (the Adroit pen's)."""
    import mujoco

    spins = {}
    for condim in (3, 4):
        model = mujoco.MjModel.from_xml_string(SPUN_SPHERE.format(condim=condim))
        data = mujoco.MjData(model)
        data.qvel[5] = 10.0
        while data.time < 0.25 - 1e-9:
            mujoco.mj_step(model, data)
        spins[condim] = data.qvel[5]
    path = tmp_path / "spun.xml"
    path.write_text(SPUN_SPHERE.format(condim=4))
    run = subprocess.run([str(envelope.SCM), "simulate", str(path), "--duration", "0.25", "--output-interval",
                          "0.25", "--outputs", "ball.angvel.z", "--set", "ball.angvel.z=10"],
                         capture_output=True, text=True, check=True)
    ours = float(run.stdout.splitlines()[-1].split(",")[1])
    assert abs(spins[3] - 10.0) < 1e-3 and abs(spins[4]) < 0.01 and abs(ours) < 0.01, (spins, ours)


DROPPED_BOX = """<mujoco><option timestep="0.002"/>
  <default><geom friction="0.7" solref="{tau} 1" solimp="0.95 0.99 0.003"/></default>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 .1"/>
    <body name="b" pos="0 0 0.06"><freejoint name="b"/><geom type="box" size="0.05 0.05 0.02" mass="1"/></body>
  </worldbody>
</mujoco>"""


def test_a_box_landing_at_a_humanoids_speed_sinks_less_in_scm_than_in_mujoco(tmp_path):
    """The landing of humanoid_CMU (above) in a small scene: a 1 kg box with the file's `solref`
    (15 ms) and `solimp` (0.99) dropped flat onto a floor at 1.3 m/s. MuJoCo's contact spreads
    the impact over its time constant and the box sinks 6.9 mm before it rises to rest; SCM's
    spring, which holds MuJoCo's static depth and so is 1/(1 - d) times MuJoCo's reference
    stiffness, stops it within 2.7 mm (measured 2026-12-07; MuJoCo at a 4 ms time constant:
    0.52 mm)."""
    import mujoco

    path = tmp_path / "box.xml"
    path.write_text(DROPPED_BOX.format(tau=0.015))
    run = subprocess.run([str(envelope.SCM), "simulate", str(path), "--duration", "0.06", "--output-interval",
                          "0.002", "--outputs", "b.pos.z", "--set", "b.linvel.z=-1.3"],
                         capture_output=True, text=True, check=True)
    ours = 0.02 - min(float(row.split(",")[1]) for row in run.stdout.splitlines()[1:])
    model = mujoco.MjModel.from_xml_string(DROPPED_BOX.format(tau=0.015))
    data = mujoco.MjData(model)
    data.qvel[2] = -1.3
    lowest = 1.0
    while data.time < 0.06 - 1e-9:
        mujoco.mj_step(model, data)
        lowest = min(lowest, data.qpos[2])
    theirs = 0.02 - lowest
    assert 1.5e-3 < ours < 4e-3 and theirs > 6e-3 and ours < 0.5 * theirs, (ours, theirs)
