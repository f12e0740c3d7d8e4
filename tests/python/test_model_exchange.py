"""Co-Simulation (the FMU's own integrator) and Model Exchange (fmpy's CVode integrating the
FMU's derivatives) give the same trajectories, within the Co-Simulation discretization error.

Why this tolerance: the bundled scenes integrate with semi-implicit Euler, which is first
order, while CVode (BDF, relative tolerance 1e-8) is accurate to far better than that. So the
error of a Co-Simulation run with internal step h is, to leading order, C·h, and step halving
estimates it (Richardson): max_t |x_CS(h) - x| ≈ 2 max_t |x_CS(h) - x_CS(h/2)|. The test
asserts max_t |x_CS(h) - x_ME| <= 3 max_t |x_CS(h) - x_CS(h/2)| + 1e-6 for every position
coordinate over the output points (in the max norm over time: pointwise, the two differences
are shifted in phase around each bounce; the factor 3 leaves room for the higher-order part of
the error; the 1e-6 covers
coordinates that stay at zero, where both runs carry only round-off and solver noise, measured
below 1e-8). Measured (2 s, h = 1 ms / 2 ms): sphere_drop ball.pos.z differs by 1.08e-3 m
while the step-halving estimate is 2 x 5.4e-4 m: exactly the first-order free-fall error
g t h / 2 = 9.81 x 0.22 x 0.0005 m. On top of that, bounds in physical terms: both runs rest
at the same height (1e-6 m), and the T-block of t_push ends within 2 mm of the same place.
Velocities are not compared point by point: the T-block's smoothed dry friction makes them
chatter at the scale of the stiction velocity, which does not converge with h.
"""
import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

#: Every bundled scene but mocap_push (fmpy's CVode sets inputs only at its output points, so a
#: moving mocap body jumps in ME: tests/python/test_dynamics_scenes.py allows for it), with
#: inputs held constant from t = 0 (so both interfaces see exactly the same input) and the
#: duration run: the finger of t_push is driven 16 cm forward (into the T) and 1 cm sideways,
#: so it pushes and turns the T-block; the arm of arm_push swings into the box under a constant
#: 0.3 N m at the shoulder and pushes it 9 cm by 3 s. Measured (largest error / bound, over the
#: positions): box_stack 9.8e-5 / 1.5e-4 m, sphere_pair 2.1e-3 / 5.0e-3, mesh_drop 0.070 / 0.153
#: (a quaternion component), horseshoe 4.9e-4 / 7.4e-4 m, arm_push 6.1e-3 / 8.4e-3 rad.
CASES = {
    "sphere_drop": ({}, 2.0),
    "t_push": ({"act_y.ctrl": 0.16, "act_x.ctrl": 0.01}, 2.0),
    "box_stack": ({}, 1.0),
    "sphere_pair": ({}, 1.0),
    "mesh_drop": ({}, 1.0),
    "horseshoe": ({}, 1.0),
    "arm_push": ({"shoulder_motor.ctrl": 0.3}, 3.0),
}


def positions(md):
    return [v.name for v in md.modelVariables if v.causality == "output" and v.unit in ("m", "rad", "1") and not v.name.startswith(("contact.", "der("))]


@pytest.mark.parametrize("name", sorted(CASES))
def test_co_simulation_and_model_exchange_agree(fmu, name):
    path = fmu(name)
    md = read_model_description(path)
    h = float(next(v.start for v in md.modelVariables if v.name == "solver.step"))
    inputs, stop = CASES[name]
    cs = simulate_fmu(path, stop_time=stop, output_interval=0.01, start_values=inputs)
    cs_half = simulate_fmu(path, stop_time=stop, output_interval=0.01, start_values={**inputs, "solver.step": h / 2})
    me = simulate_fmu(path, fmi_type="ModelExchange", stop_time=stop, output_interval=0.01, relative_tolerance=1e-8, start_values=inputs)
    assert len(cs) == len(me) and np.array_equal(cs["time"], me["time"])
    for n in positions(md):
        err = np.max(np.abs(cs[n] - me[n]))
        bound = 3.0 * np.max(np.abs(cs[n] - cs_half[n])) + 1e-6
        assert err <= bound, f"{name}: {n}: CS and ME differ by up to {err}, the CS error estimate is {bound}"
    if name == "sphere_drop":
        # Free fall, then rest: the first-order free-fall error g t h / 2 at impact (t = 0.22 s)
        # bounds the height difference, and at rest both sit at the same equilibrium.
        assert np.max(np.abs(cs["ball.pos.z"] - me["ball.pos.z"])) <= 9.81 * 0.23 * h / 2
        assert abs(cs["ball.pos.z"][-1] - me["ball.pos.z"][-1]) < 1e-6
        assert abs(me["ball.linvel.z"][-1]) < 1e-6
    elif name == "arm_push":
        assert cs["box_x.q"][-1] < -0.05 and me["box_x.q"][-1] < -0.05, "the arm did not push the box"
    elif name == "t_push":
        # The T-block was pushed several centimetres; both runs leave it within 2 mm.
        assert me["t_y.q"][-1] > 0.03, "the finger did not push the T-block"
        for n in ["t_x.q", "t_y.q"]:
            assert abs(cs[n][-1] - me[n][-1]) < 2e-3, n


def test_model_exchange_keeps_a_tumbling_bodys_quaternion_unit(fmu):
    """A sphere spinning at |ω| = 6.2 rad/s integrated by CVode: the FMU asks for an event when
    the quaternion's norm drifts by more than 1e-6 and projects it back, so at every output
    point the norm is 1 within that tolerance. In free flight (before it lands at 0.22 s) the
    rotation of a sphere is exact rotation at constant ω, which Co-Simulation's rotation-group
    update reproduces to rounding; CVode's (relative tolerance 1e-6) quaternion agrees with it to
    1e-5 (measured 3e-6)."""
    path = fmu("sphere_drop")
    spin = {"ball.angvel.x": 3.0, "ball.angvel.y": -2.0, "ball.angvel.z": 5.0}
    # record_events=False: fmpy would also record the state at each event before the FMU's
    # projection (by construction up to one solver step past the tolerance; measured 5e-6).
    me = simulate_fmu(path, fmi_type="ModelExchange", stop_time=1.0, output_interval=0.01, relative_tolerance=1e-6, start_values=spin, record_events=False)
    cs = simulate_fmu(path, stop_time=1.0, output_interval=0.01, start_values=spin)
    norm = np.sqrt(sum(me[f"ball.quat.{c}"] ** 2 for c in "wxyz"))
    assert np.max(np.abs(norm - 1.0)) <= 1e-6 + 1e-12
    flight = me["time"] < 0.2
    for c in "wxyz":
        q = f"ball.quat.{c}"
        assert np.max(np.abs(me[q][flight] - cs[q][flight])) < 1e-5, q
    assert np.ptp(me["ball.quat.x"][flight]) > 0.2, "the sphere did not turn (1.2 rad in flight)"
