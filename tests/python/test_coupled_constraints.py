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
