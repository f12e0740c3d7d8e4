"""Constraints whose coordinates couple joints across the tree's branches (tendon limits,
equalities) against MuJoCo on the same file (docs/mjcf.md, "Equality constraints").

SCM gives each MuJoCo's statics (its gains raised by `statics`) and MuJoCo's pace (the inertia
MuJoCo's impedance adds, `(statics - 1) I`, along each of its rows, taken into the tree's
factor by Woodbury's identity) under every integrator. `tests/fixtures/coupled.xml` swings two
arms through a fixed tendon's and a spatial tendon's limits, a third body following the first
arm through a joint equality, a fourth held by a connect and a free body by a weld.
"""
import csv
import io
import subprocess
from pathlib import Path

import mujoco
import pytest

from conftest import SCM

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "coupled.xml"
JOINTS = ["ha", "hb", "sc", "hc", "he"]


@pytest.mark.parametrize("integrator", ["RK4", "Euler", "implicitfast"])
def test_coupled_constraints_follow_mujoco_under_every_integrator(tmp_path, integrator):
    """3 s as written under each of MuJoCo's integrators: every joint within 0.012 rad (or m) of
    MuJoCo's at each half second, the welded body within 0.1 mm of MuJoCo's height (measured,
    at most: 0.0077 rad under RK4, 0.0105 under Euler, whose tendon limits' damping is implicit
    along their rows, 0.0073 under implicitfast; the welded body to 1e-11 m). Before, SCM's
    reference gains under RK4 and Euler
    made the connect's spring, sized on the tip's mean inertia, too stiff for the step along its
    lightest direction: the guard refused the RK4 run at its first step (5.0e4 J from 23.5 J)
    and the Euler run at its second; under implicit Euler (raised gains alone) the second arm
    was 0.034 rad from MuJoCo's at 0.75 s."""
    path = tmp_path / f"coupled_{integrator}.xml"
    path.write_text(FIXTURE.read_text().replace('integrator="RK4"', f'integrator="{integrator}"'))
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    columns = [f"{j}.q" for j in JOINTS] + ["d.pos.z"]
    out = subprocess.run([str(SCM), "simulate", str(path), "--duration", "3", "--output-interval", "0.5",
                          "--outputs", ",".join(columns)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    rows = list(csv.DictReader(io.StringIO(out.stdout)))[1:]
    assert len(rows) == 6
    for r in rows:
        t = float(r["time"])
        while d.time < t - 1e-9:
            mujoco.mj_step(m, d)
        theirs = [d.joint(j).qpos[0] for j in JOINTS]
        for j, x in zip(JOINTS, theirs):
            assert abs(float(r[f"{j}.q"]) - x) < 0.012, (t, j, float(r[f"{j}.q"]), x)
        assert abs(float(r["d.pos.z"]) - d.body("d").xpos[2]) < 1e-4, (t, float(r["d.pos.z"]), d.body("d").xpos[2])


def test_an_undamped_joint_equality_and_connect_on_one_body_keep_their_energy(tmp_path):
    """The fixture without its dampers, tendons, weld and free body, its joint equality and
    connect both holding the third body with MuJoCo's undamped `solref="-2500 0"`, 2 s of RK4
    at 0.25 ms. MuJoCo runs it, its bodies' kinetic and gravitational energy never above the
    start's. SCM's added inertia resists each row's whole acceleration, its turning `J̇ v`
    included (docs/mjcf.md, "Equality constraints"), so its energy count (bodies, springs and
    added inertia) is conserved, and the bodies' energy alone, read by MuJoCo at SCM's states,
    stays at or below the start's too. Without the turning SCM pumped 6.6 J into the 19.6 J
    swing in 1 s and the guard refused the run at 0.39 s."""
    import re
    xml = FIXTURE.read_text().replace('timestep="0.002"', 'timestep="0.00025"').replace('damping="0.05"', "")
    xml = re.sub(r"<tendon>.*?</tendon>", "", xml, flags=re.S)
    xml = re.sub(r'<body name="d".*?</body>', "", xml, flags=re.S)
    xml = re.sub(r"<weld [^>]*/>", "", xml)
    xml = xml.replace('polycoef="0 0.5 0.2 0 0"/>', 'polycoef="0 0.5 0.2 0 0" solref="-2500 0"/>')
    xml = xml.replace('anchor="0.2 0 0"/>', 'anchor="0.2 0 0" solref="-2500 0"/>')
    path = tmp_path / "undamped.xml"
    path.write_text(xml)
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    start = d.energy.sum()
    theirs = []
    for _ in range(8000):
        mujoco.mj_step(m, d)
        theirs.append(d.energy.sum() - start)
    assert max(theirs) < 1e-3, max(theirs)
    columns = [f"{j}.{x}" for j in JOINTS for x in "qv"]
    out = subprocess.run([str(SCM), "simulate", str(path), "--duration", "2", "--outputs", ",".join(columns)],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    rows = list(csv.DictReader(io.StringIO(out.stdout)))
    assert float(rows[-1]["time"]) == 2.0
    ours = []
    for r in rows:
        d.qpos[:] = [float(r[f"{j}.q"]) for j in JOINTS]
        d.qvel[:] = [float(r[f"{j}.v"]) for j in JOINTS]
        mujoco.mj_forward(m, d)
        ours.append(d.energy.sum() - start)
    assert max(ours) < 1e-3, max(ours)
    # The bodies move (the swing is not trivially at rest): they exchange energy with the springs.
    assert min(ours) < -0.05, min(ours)
