"""The inference examples (issue 21) in small deterministic versions: system identification
(examples/inference/sysid.py) and trajectory optimization (examples/inference/trajopt.py), both
through the t_push FMU, and the exact sensitivities they stand on."""
import pathlib
import sys

import numpy as np
import pytest

pytest.importorskip("scipy")
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "examples" / "inference"))
import fmu_rollout  # noqa: E402
import sysid  # noqa: E402

# One pytest-xdist worker runs this module's tests: the packed T-push FMU is a module fixture.
pytestmark = pytest.mark.xdist_group("inference")


@pytest.fixture(scope="module")
def t_push(tmp_path_factory):
    return fmu_rollout.pack(sysid.scene_xml(), tmp_path_factory.mktemp("inference"), "t_push")


def test_the_rollout_is_the_co_simulation_step_and_its_sensitivities_are_exact(t_push):
    # The example's semi-implicit Euler on the Model Exchange FMU is the Co-Simulation FMU's
    # own step: the same trajectory to rounding (equal here, bit for bit, on this machine).
    U = sysid.controls(sysid.PUSHES["stem, sideways"], 1.6)
    r = fmu_rollout.Rollout(t_push, sysid.H)
    X, S, _ = r.rollout(r.x0(), U, sensitivities=sysid.PARAMS)
    cs = fmu_rollout.co_simulation(t_push, sysid.H, U, outputs=r.states)
    assert np.abs(X - cs).max() <= 1e-12
    assert np.abs(X[-1, :3]).max() > 0.1, "the finger turned the block"
    assert r.calls["directional"] == len(sysid.PARAMS) * len(U)
    # dX/dp against central differences of whole trajectories (relative step 1e-5): the
    # truncation error is O(1e-10) relative, well inside 1e-6 of each column's size.
    for j, name in enumerate(sysid.PARAMS):
        p = float(r.start[name])
        d = 1e-5 * p
        r.set_parameters({name: p + d})
        hi = r.rollout(r.x0(), U)[0]
        r.set_parameters({name: p - d})
        lo = r.rollout(r.x0(), U)[0]
        r.set_parameters({name: p})
        fd = (hi - lo) / (2 * d)
        # State by state (positions and velocities have their own sizes).
        floor = 1e-9 * np.abs(S[:, :, j]).max()
        for i, state in enumerate(r.states):
            err = np.abs(fd[:, i] - S[:, i, j]).max()
            assert err <= 1e-6 * np.abs(S[:, i, j]).max() + floor, (name, state, err)
    # A full step Jacobian, the adjoint's input, is the same derivative.
    k = 650  # 1.3 s: the finger presses on the stem
    x = r.rollout(r.x0(), U[:k])[0][-1]
    J = r.rollout(x, U[k:k + 1], jacobians=True)[2][0]
    block_v, finger_q = [r.states.index(n) for n in ("t_x.v", "t_y.v", "t_yaw.v")], [3, 4]
    assert r.states[3:5] == ["finger_x.q", "finger_y.q"]
    assert np.abs(J[np.ix_(block_v, finger_q)]).max() > 1e-3, "the contact couples finger and block"
    for j in range(r.nx + r.nu):
        e = 1e-7 * max(1.0, abs(x[j])) if j < r.nx else 1e-7
        def step(dx):
            xs, us = x.copy(), U[k].copy()
            if j < r.nx:
                xs[j] += dx
            else:
                us[j - r.nx] += dx
            return r.rollout(xs, us[None, :])[0][-1]
        fd = (step(e) - step(-e)) / (2 * e)
        assert np.abs(fd - J[:, j]).max() <= 1e-6 * max(np.abs(J).max(), 1.0), j
    r.close()


@pytest.mark.slow
def test_system_identification_recovers_known_parameters():
    # One push of the T, data from the Co-Simulation FMU at known parameters, fitted from the
    # scene's (0.5, 1e4 N/m, 0.05 m/s): least squares on the exact Jacobian and on finite
    # differences both reach the truth to 1e-6 relative (the data has no noise; the residual
    # at the answer is rounding, below 1e-9 m); Nelder-Mead reaches it to 1e-4.
    res = sysid.run([(sysid.PUSHES["stem, sideways"], 1.6)], quick=True)
    (name, r), = res.items()
    assert r["start_rms"] > 1e-4, "the scene's parameters do not fit the data"
    rows = {row["method"]: row for row in r["rows"]}
    for method, tol in [("exact", 1e-6), ("finite differences (2-point)", 1e-6),
                        ("finite differences (3-point)", 1e-6), ("Nelder-Mead", 1e-4)]:
        row = rows[method]
        for p, truth in sysid.TRUTH.items():
            assert row["params"][p] == pytest.approx(truth, rel=tol), (method, p)
        if tol == 1e-6:
            assert row["rms"] < 1e-9, method
    exact = rows["exact"]
    assert exact["calls"]["directional"] > 0 and exact["rollouts"]["with sensitivities"] > 0
    assert rows["finite differences (2-point)"]["calls"]["directional"] == 0


def test_the_adjoint_gradient_of_a_plan_is_exact(t_push):
    # The trajectory optimizer's gradient (one rollout with step Jacobians, then the adjoint
    # pass) against central differences of the cost over whole rollouts, in every unknown of a
    # plan that pushes the block (step 1e-6 m: truncation and rounding both near 1e-10 relative).
    import trajopt
    r = fmu_rollout.Rollout(t_push, sysid.H)
    planner = trajopt.Planner(r, knots=6, duration=1.2)
    z = trajopt.initial_plan(6).ravel() + 0.01 * np.sin(np.arange(12))
    c, g = planner.cost_and_gradient(z)
    assert c == pytest.approx(planner.cost(z), rel=1e-14)
    e = 1e-6
    fd = np.array([(planner.cost(z + e * d) - planner.cost(z - e * d)) / (2 * e) for d in np.eye(len(z))])
    assert np.abs(g).max() > 1e-3, "the plan moves the block"
    assert np.abs(g - fd).max() <= 1e-6 * np.abs(g).max()
    r.close()


@pytest.mark.slow
def test_trajectory_optimization_reaches_the_target_pose():
    # The quick plan (12 knots over 1.6 s, at most 30 L-BFGS-B iterations on the adjoint
    # gradient) takes the block from where a straight push leaves it (8.6 cm from the start,
    # yaw 0) to the target pose within 5 mm and 0.02 rad; the Co-Simulation FMU, stepping the
    # plan itself, lands it in the same place (1e-9). The cross-entropy method, 6 iterations of
    # 16 plans, improves on its start.
    import trajopt
    rows, start = trajopt.run(**trajopt.settings(True), methods=["exact gradient (adjoint)", "cross-entropy method"])
    exact, cem = rows
    start_err = np.linalg.norm((start - np.array(trajopt.TARGET))[:2])
    assert start_err > 0.03
    assert exact["error"] < 5e-3 and exact["yaw_error"] < 0.02, exact
    assert exact["replay_gap"] < 1e-9
    assert exact["calls"]["directional"] == exact["rollouts"]["with Jacobians"] * 800 * 12
    assert cem["error"] < start_err and cem["calls"]["directional"] == 0
