"""The MuJoCo models that ship with gymnasium, as a user brings them: each packs into an FMU that
passes fmpy's validation, and simulates 1 s with zero inputs, contact and joint limits on,
without refusal or NaN (swimmer with its fluid forces); where SCM refuses, the test holds the
reason.

Every file runs at its own integrator and step: the outputs come every whole number of the
file's steps (10 ms or just above), so the FMU's internal step is the file's. Measured (see
docs/mjcf.md): every file runs its 1 s, walker2d and walker2d_v5 with RK4 at their 2 ms,
humanoid and humanoidstandup with RK4 at their 3 ms (13 bodies, about 60 body pairs). Until the
joint limits' stiffness took MuJoCo's effective inertia (1 / dof_invweight0) instead of the mass
matrix's diagonal, the walkers' and humanoid's hip limits were up to 56 times too stiff for RK4
at their step and the guard refused the runs, rightly. The ant, which the guard refused at
0.3 s while SCM's limit dampers held its ankles on their limit, runs as MuJoCo's since the
limits only push (tests/python/test_limits.py). Until a contact's damping stopped growing with
its depth under RK4 (docs/method.md, departure 4), the guard refused gymnasium's humanoid at its
3 ms when its knees strike the floor at 0.79 s, and this test ran it at 2.5 ms.

On every file of the three corpora `scm check` fails exactly where `scm pack` refuses, and names
the same reason.
"""
import pathlib
import subprocess

import gymnasium
import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

from conftest import DM_CONTROL, DM_CONTROL_REFUSED, DM_CONTROL_ROOT, ROBOTICS, ROBOTICS_REFUSED, SCM, dm_id, robotics_id

CORPUS_DIR = pathlib.Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"
CORPUS = sorted(CORPUS_DIR.glob("*.xml"))
REFUSED = {}


def states(fmu):
    from fmpy import read_model_description
    md = read_model_description(fmu)
    return [v.name for v in md.modelVariables if v.causality == "output" and v.initial == "exact"]


def md_step(fmu):
    """The FMU's internal step, `solver.step` (the file's `timestep`)."""
    from fmpy import read_model_description
    md = read_model_description(fmu)
    return next(v.start for v in md.modelVariables if v.name == "solver.step")


@pytest.mark.parametrize("path", CORPUS, ids=[p.stem for p in CORPUS])
def test_corpus_file_packs_validates_and_runs(path, tmp_path):
    refusal = (f"{path.name}:", REFUSED[path.stem]) if path.stem in REFUSED else None
    packs_validates_and_runs(path, tmp_path, 1.0, refusal)


#: dm_control files packed and validated but not run here, and why.
DM_NOT_RUN = {
    "jaco_hand": "136 s for 0.1 s with contact on (measured, one core): issue 20's",
}


@pytest.mark.slow
@pytest.mark.parametrize("path", DM_CONTROL, ids=[dm_id(p) for p in DM_CONTROL])
def test_dm_control_file_packs_validates_and_runs(path, tmp_path):
    """dm_control's files the same way, for 0.1 s (the suite's humanoid_CMU takes 15 s for that
    on one core: 31 bodies besides the world, contact on); the refused files name file, line and
    reason."""
    seconds = None if dm_id(path) in DM_NOT_RUN else 0.1
    packs_validates_and_runs(path, tmp_path, seconds, DM_CONTROL_REFUSED.get(dm_id(path)))


@pytest.mark.parametrize("name, seconds", [("cheetah", 0.3), ("manipulator", 0.3)])
def test_a_damped_euler_step_whose_newton_iterations_fail_is_subdivided(name, seconds):
    """Damped Euler (MuJoCo's Euler) solves each step in contact for its end velocity by
    Newton's iterations. dm_control's cheetah (10 ms) and manipulator (1 ms) stopped there at
    0.15 s and 0.167 s ("did not converge"), where MuJoCo runs on. Such a step is now done as two
    halves of the same method, recursively (docs/dynamics.md), as implicit Euler's are: both run,
    and end inside MuJoCo's spread (tests/python/test_contact_envelope.py)."""
    path = DM_CONTROL_ROOT / "suite" / f"{name}.xml"
    run = subprocess.run([str(SCM), "simulate", str(path), "--duration", str(seconds),
                          "--output-interval", str(seconds), "-o", "/dev/null"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr


@pytest.mark.slow
@pytest.mark.parametrize("path", ROBOTICS, ids=[robotics_id(p) for p in ROBOTICS])
def test_robotics_file_packs_and_validates(path, tmp_path):
    """gymnasium-robotics' files pack (the Franka kitchen's meshes and includes named through
    `..` out of their folders too) and fmpy validates them, Fetch's weld to its mocap body too.
    Only the point maze is run: with contact on, a step of the shadow hand takes seconds and
    the Adroit hand's first steps blow up (measured, in docs/mjcf.md), which is issue 20's."""
    packs_validates_and_runs(path, tmp_path, 0.1 if path.stem == "point" else None,
                             ROBOTICS_REFUSED.get(robotics_id(path)))


def packs_validates_and_runs(path, tmp_path, seconds, refusal):
    """`path` packs into an FMU that fmpy validates and simulates for `seconds` (unless None)
    with finite states; or, with `refusal` = (where, why), the packing is refused saying both."""
    fmu = str(tmp_path / f"{path.stem}.fmu")
    packed = subprocess.run([str(SCM), "pack", str(path), "-o", fmu], capture_output=True, text=True)
    # `scm check` reports what `pack` would refuse, no more and no less (it once failed files
    # that pack took, gymnasium-robotics' manipulate_block among them).
    checked = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True)
    assert (checked.returncode == 0) == (packed.returncode == 0), (checked.stdout[-2000:], checked.stderr)
    if refusal is not None:
        where, why = refusal
        assert packed.returncode != 0 and where in packed.stderr and why in packed.stderr, packed.stderr
        assert where in checked.stderr and why in checked.stderr, checked.stderr
        return
    assert packed.returncode == 0, packed.stderr
    assert validate_fmu(fmu) == []
    if seconds is None:
        return
    outputs = states(fmu)
    # Every whole number of the file's steps, 10 ms or just above: the internal step is the file's.
    step = float(md_step(fmu))
    interval = step * np.ceil(0.01 / step - 1e-9)
    res = simulate_fmu(fmu, stop_time=seconds, output_interval=interval, output=outputs)
    assert res["time"][-1] == pytest.approx(seconds)
    for name in outputs:
        assert np.all(np.isfinite(res[name])), name
