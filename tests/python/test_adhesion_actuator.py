"""MuJoCo's adhesion actuator (`<adhesion body=... gain=...>`, a body transmission;
docs/method.md, departure 9; docs/mjcf.md, "Adhesion actuators") against MuJoCo 4.0 on files
written here: a 1 kg sphere or box under a ceiling plane, driven by an adhesion of 20 N at
full control, with a 5 mm gap on its geom, run 1 s at 2 ms in both; and the bundled pick
scene (a pad lifts a box and lets it go) with the inputs of its regression reference.

MuJoCo spreads the force over the body's contacts within their gap (the average of their
normal Jacobians); SCM pulls each pair of the body within its gap with it, one pair per body
pair. Measured (MuJoCo 4.0 / SCM): at full control the sphere, pulled in from 3 mm off, is
held pressed 0.38 / 0.51 mm into the ceiling (5 mm spacing, eps2 0.1 mm, as the resting tests
of test_contact_rest.py); at 8 N (0.4) both drop it; from 8 mm off (past the gap) neither
reaches it. A box at the default eps2 is held too (0.11 / 0.38 mm: MuJoCo's four contacts,
as for resting, docs/mjcf.md); at eps2 0.1 mm SCM's box tips over and falls within 0.5 s,
as a box held by its geoms' adhesion does (the pull concentrates where the separation
weights do, at the deepest points: docs/mjcf.md, "Adhesion").
"""
import csv
import io
import json
import subprocess

import mujoco
import numpy as np

import references as R
from conftest import SCENES, SCM
# The geoms' adhesion's ceiling, step, shapes, fine sampling and what counts as held.
from test_contact_adhesion import CEILING, DURATION, FINE, HELD, SHAPES, STEP


def scene(shape, below, extra=""):
    """A 1 kg sphere or box, 5 cm across, `below` (m) under a downward-facing plane, with an
    adhesion of gain 20 N on its body and a 5 mm gap on its geom."""
    return f"""<mujoco><option timestep="{STEP}"/>{extra}
<worldbody><geom name="ceiling" type="plane" size="1 1 0.1" pos="0 0 {CEILING}" zaxis="0 0 -1"/>
<body name="a" pos="0 0 {CEILING - 0.05 - below}"><freejoint/><geom {SHAPES[shape]} mass="1" gap="0.005"/></body>
</worldbody><actuator><adhesion name="grip" body="a" ctrlrange="0 1" gain="20"/></actuator></mujoco>"""


def mujoco_offset(xml, ctrl):
    """How far below the ceiling's touch the body is after DURATION (m; negative: pressed in),
    and MuJoCo's contact count then."""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.ctrl[0] = ctrl
    while d.time < DURATION - 1e-9:
        mujoco.mj_step(m, d)
    return CEILING - 0.05 - d.qpos[2], d.ncon


def scm_offset(xml, ctrl, tmp_path):
    path = tmp_path / "hang.xml"
    path.write_text(xml)
    out = subprocess.run([str(SCM), "simulate", str(path), "--duration", str(DURATION),
                          "--output-interval", "0.1", "--set", f"grip.ctrl={ctrl}", "--outputs", "a.pos.z"],
                         capture_output=True, text=True, check=True).stdout
    rows = list(csv.reader(io.StringIO(out)))
    return CEILING - 0.05 - float(rows[-1][1])


def test_a_pull_above_the_weight_holds_a_sphere_under_a_ceiling_and_one_below_drops_it(tmp_path):
    for ctrl, held in [(1.0, True), (0.4, False)]:
        xml = scene("sphere", 0.003)
        mj, ncon = mujoco_offset(xml, ctrl)
        ours = scm_offset(scene("sphere", 0.003, FINE), ctrl, tmp_path)
        print(f"sphere at {20 * ctrl} N: SCM {ours * 1e3:.3f} mm, MuJoCo {mj * 1e3:.3f} mm ({ncon})")
        assert (abs(mj) < HELD) == held and (abs(ours) < HELD) == held, (ctrl, mj, ours)
        if held:
            # Pressed in by the pull less the weight (10.2 N, about the weight the stiffness is
            # set from): within the resting test's tolerance of MuJoCo's depth.
            assert ncon == 1 and ours < 0 and mj < 0
            assert abs(ours - mj) <= max(0.2 * abs(mj), 3e-4), (ours, mj)


def test_the_pull_reaches_across_the_gap_and_not_past_it(tmp_path):
    for below, held in [(0.003, True), (0.008, False)]:
        mj, _ = mujoco_offset(scene("sphere", below), 1.0)
        ours = scm_offset(scene("sphere", below, FINE), 1.0, tmp_path)
        assert (abs(mj) < HELD) == held and (abs(ours) < HELD) == held, (below, mj, ours)


def test_a_box_is_held_by_its_pair_as_by_mujocos_four_contacts(tmp_path):
    for ctrl, held in [(1.0, True), (0.4, False)]:
        mj, ncon = mujoco_offset(scene("box", 0.003), ctrl)
        ours = scm_offset(scene("box", 0.003), ctrl, tmp_path)
        print(f"box at {20 * ctrl} N: SCM {ours * 1e3:.3f} mm, MuJoCo {mj * 1e3:.3f} mm ({ncon})")
        assert (abs(mj) < HELD) == held and (abs(ours) < HELD) == held, (ctrl, mj, ours)
        if held:
            assert ncon == 4


def test_the_pad_lifts_the_box_and_lets_it_go_as_mujocos(fmu):
    """The bundled pick scene with its reference inputs (tests/python/references.py): the pad
    comes down the millimetre to the box, lifts it 3.5 cm by 1.4 s and lets it go at 1.5 s."""
    result = R.simulate(fmu("adhesion_pick"), "adhesion_pick")
    m = mujoco.MjModel.from_xml_path(str(SCENES / "adhesion_pick.xml"))
    d = mujoco.MjData(m)
    signals = R.SIGNALS["adhesion_pick"]
    theirs = []
    for t in result["time"]:
        while d.time < t - 1e-9:
            # fmpy holds each input over the communication step that starts at its sample.
            k = np.floor(d.time / R.OUTPUT_INTERVAL + 1e-9) * R.OUTPUT_INTERVAL
            d.ctrl[:] = [signals["lift.ctrl"](k), signals["grip.ctrl"](k)]
            mujoco.mj_step(m, d)
        theirs.append(d.qpos[2])
    theirs, ours, t = np.array(theirs), result["box.pos.z"], result["time"]
    at = lambda x, s: x[int(np.argmin(np.abs(t - s)))]
    for z in (ours, theirs):
        assert at(z, 0.4) < 0.031  # the pad came down to the box, not the box up to the pad
        assert at(z, 1.4) > 0.03 + 0.03  # lifted with the pad
        assert abs(at(z, 2.0) - 0.03) < 1e-3  # let go: back on the floor
    print(f"box height at 1.4 s: SCM {at(ours, 1.4):.4f} m, MuJoCo {at(theirs, 1.4):.4f} m; "
          f"largest difference {np.max(np.abs(ours - theirs)) * 1e3:.2f} mm")


def test_adhesion_defaults_compile_as_mujoco_compiles_them(tmp_path):
    """An adhesion's gain from its own attribute, its class's adhesion or `<general>` default,
    past a class whose last default is a position; its control always limited; other kinds
    beside it in the same classes: gains, biases and control ranges as MuJoCo 4.0 compiles
    them."""
    xml = """<mujoco><default><adhesion gain="5" ctrlrange="0 1"/>
<default class="c"><position kp="3"/></default><default class="d"><general gainprm="7"/></default></default>
<worldbody><body name="b"><joint name="j" type="slide"/><geom size="0.1"/></body></worldbody>
<actuator><general joint="j"/><position joint="j"/><adhesion body="b"/><adhesion class="c" body="b"/>
<adhesion class="d" body="b"/><adhesion body="b" gain="2" ctrlrange="0 0.5"/><motor joint="j"/></actuator></mujoco>"""
    path = tmp_path / "defaults.xml"
    path.write_text(xml)
    m = mujoco.MjModel.from_xml_string(xml)
    ours = json.loads(subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True,
                                     check=True).stdout)["actuators"]
    assert len(ours) == m.nu
    for a, act in enumerate(ours):
        body = int(m.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_BODY)
        assert (act["body"] is not None) == body, a
        assert np.allclose(act["gainprm"], m.actuator_gainprm[a, :3]), (a, act["gainprm"])
        assert np.allclose(act["biasprm"], m.actuator_biasprm[a, :3]), (a, act["biasprm"])
        assert act["ctrllimited"] == bool(m.actuator_ctrllimited[a]), a
        assert np.allclose(act["ctrlrange"], m.actuator_ctrlrange[a]), a
