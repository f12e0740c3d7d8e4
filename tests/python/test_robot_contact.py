"""A robot's contact where MuJoCo sees a gap (docs/mjcf.md, "Contact on, against MuJoCo's
spread"): robosuite's xArm7 as written (implicitfast, 2 ms), its base joint driven by 3 N·m
(above its frictionloss of 1 N·m) for 0.1 s while the arm starts to fall.

Its base and link 1, a parent welded to the world and its child, collide in MuJoCo as in SCM,
and lie 0.2 mm apart by MuJoCo's hulls: no contact there. SCM's clouds, sampled at the file's
default 1 cm, read 1.36 mm into each other and push with 66 N, whose friction brakes joint 1:
measured (2026-12-07) 0.0069 rad where MuJoCo turns 0.285 rad, 0.283 rad with that pair
excluded. The first test holds the cause (the arm turns as MuJoCo's without that pair); the
second is a strict expected failure that passes the day the pair stops braking the joint.
"""
import pathlib
import subprocess

import mujoco
import pytest

from conftest import ROOT, SCM

XARM = ROOT / ".venv" / "robosuite_assets" / "robosuite" / "models" / "assets" / "robots" / "xarm7" / "robot.xml"
TORQUE, SECONDS = 3.0, 0.1


def mujoco_turn():
    m = mujoco.MjModel.from_xml_path(str(XARM))
    d = mujoco.MjData(m)
    d.ctrl[m.actuator("torq_j1").id] = TORQUE
    for _ in range(round(SECONDS / m.opt.timestep)):
        mujoco.mj_step(m, d)
    return d.qpos[m.joint("joint1").qposadr[0]]


def scm_turn(path):
    run = subprocess.run([str(SCM), "simulate", str(path), "--duration", str(SECONDS), "--output-interval",
                          str(SECONDS), "--set", f"torq_j1.ctrl={TORQUE}", "--outputs", "joint1.q"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
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
    # Measured 0.283 against 0.285 rad; 5 % holds the joint's friction model's difference.
    assert abs(ours - theirs) <= 0.05 * theirs, (ours, theirs)


@pytest.mark.xfail(strict=True, reason="base and link 1, 0.2 mm apart in MuJoCo, push with 66 N in SCM at "
                   "the file's 1 cm spacing and brake joint 1 (0.0069 rad against MuJoCo's 0.285)")
def test_the_base_joint_turns_as_mujocos():
    ours, theirs = scm_turn(XARM), mujoco_turn()
    assert abs(ours - theirs) <= 0.05 * theirs, (ours, theirs)
