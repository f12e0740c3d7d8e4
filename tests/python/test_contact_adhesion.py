"""Adhesion as MuJoCo's files mean it (docs/method.md, departure 7; docs/mjcf.md, "Adhesion"):
a geom's `adhesion` δ lets its contacts pull with up to δ newtons within its `gap` past the
margin. A sphere and a box hang from a ceiling plane (1 N within 2 mm), under weights on both
sides of what MuJoCo holds, run 1 s at 2 ms in MuJoCo and in SCM.

Measured (MuJoCo 4.0): the sphere (one contact) holds 0.9 N and drops at 1.1 N, hanging
0.367 mm off the ceiling whatever it weighs; the box (four contacts, 1 N each) holds 3.8 N and
drops at 4.2 N. With gap 0 nothing is held. SCM's contact is one per body pair, its pull at
most δ: the box holds 0.9 N and drops at 1.1 N (the same count difference as the resting
stiffness's, docs/mjcf.md). At the default eps2 (1 mm) a sphere sampled at 1 cm holds 0.5 N
but not 0.8 N: its pull is an average over its points weighted across a band about eps2 thick,
and the points past the gap pull nothing (the band's effect on resting depth, seen in
test_contact_rest.py); at eps2 = 0.1 mm and 5 mm spacing it holds 0.9 N, 0.25 to 0.35 mm off.
"""
import csv
import io
import subprocess

import mujoco
import pytest

from conftest import SCM

STEP = 0.002
DURATION = 1.0
CEILING = 0.3
FINE = ('<custom><numeric name="scm_spacing" data="0.005"/>'
        '<numeric name="scm_eps2" data="1e-4"/></custom>')
SHAPES = {"sphere": 'type="sphere" size="0.05"', "box": 'type="box" size="0.05 0.05 0.05"'}


def scene(shape, weight, gap=0.002, extra=""):
    """A 5 cm sphere or box touching a downward-facing plane, with adhesion 1 N."""
    return f"""<mujoco><option timestep="{STEP}"/>{extra}
<worldbody><geom name="ceiling" type="plane" size="1 1 0.1" pos="0 0 {CEILING}" zaxis="0 0 -1"/>
<body name="a" pos="0 0 {CEILING - 0.05}"><freejoint/>
<geom {SHAPES[shape]} mass="{weight / 9.81}" adhesion="1" gap="{gap}"/></body>
</worldbody></mujoco>"""


def mujoco_offset(xml):
    """How far below its start the body hangs after DURATION (m), and the contacts then."""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    while d.time < DURATION - 1e-9:
        mujoco.mj_step(m, d)
    return CEILING - 0.05 - d.qpos[2], d.ncon


def scm_offset(xml, tmp_path):
    path = tmp_path / "hang.xml"
    path.write_text(xml)
    out = subprocess.run([str(SCM), "simulate", str(path), "--duration", str(DURATION),
                          "--output-interval", "0.1"],
                         capture_output=True, text=True, check=True).stdout
    rows = list(csv.reader(io.StringIO(out)))
    return CEILING - 0.05 - float(rows[-1][rows[0].index("a.pos.z")])


HELD = 0.002  # hanging within 2 mm of the start after 1 s; a dropped body has fallen metres


def test_a_sphere_hangs_under_the_weight_mujoco_holds_and_drops_past_it(tmp_path):
    for weight, held in [(0.9, True), (1.1, False)]:
        mj, ncon = mujoco_offset(scene("sphere", weight))
        ours = scm_offset(scene("sphere", weight, extra=FINE), tmp_path)
        print(f"sphere {weight} N: SCM {ours * 1e3:.3f} mm, MuJoCo {mj * 1e3:.3f} mm ({ncon})")
        assert (abs(mj) < HELD) == held and (abs(ours) < HELD) == held, (weight, mj, ours)
        if held:
            # Off by the stretch that pulls the weight (its contact stiffness is MuJoCo's at
            # rest, test_contact_rest.py): within the resting test's tolerance of MuJoCo's.
            assert ncon == 1 and ours > 0
            assert abs(ours - mj) <= max(0.2 * mj, 3e-4), (ours, mj)


def test_without_a_gap_nothing_is_held(tmp_path):
    mj, _ = mujoco_offset(scene("sphere", 0.5, gap=0.0))
    ours = scm_offset(scene("sphere", 0.5, gap=0.0, extra=FINE), tmp_path)
    assert mj > 1.0 and ours > 1.0, (mj, ours)


def test_a_box_holds_one_adhesion_where_mujoco_holds_one_per_contact(tmp_path):
    for weight, mj_held, ours_held in [(0.9, True, True), (1.1, True, False),
                                       (3.8, True, False), (4.2, False, False)]:
        mj, ncon = mujoco_offset(scene("box", weight))
        ours = scm_offset(scene("box", weight), tmp_path)
        print(f"box {weight} N: SCM {ours * 1e3:.3f} mm, MuJoCo {mj * 1e3:.3f} mm ({ncon})")
        assert (abs(mj) < HELD) == mj_held and (abs(ours) < HELD) == ours_held, (weight, mj, ours)
        if mj_held:
            assert ncon == 4


def test_at_the_default_eps2_a_sphere_holds_less_than_its_adhesion(tmp_path):
    # At 1 cm, as measured (docs/mjcf.md): the defaults would sample the 5 cm sphere to its
    # curvature, 1.41 cm, whose fewer points near the ceiling hold 0.8 N as well.
    at_1cm = '<custom><numeric name="scm_spacing" data="0.01"/></custom>'
    assert abs(scm_offset(scene("sphere", 0.5, extra=at_1cm), tmp_path)) < HELD
    assert scm_offset(scene("sphere", 0.8, extra=at_1cm), tmp_path) > 1.0
