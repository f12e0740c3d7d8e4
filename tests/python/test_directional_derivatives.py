"""fmi2GetDirectionalDerivative through fmpy's FMU2Slave (Co-Simulation) and FMU2Model
(Model Exchange), for every pair ModelStructure declares, against central differences of the
same FMU.

Central differences: positions and velocities are stepped by 1e-8 (contact varies on the
scale of ε3 = 1e-4 m and of the stiction velocity, 1e-2 m/s, so the truncation error is about
(1e-4)² relative), controls by 1e-7. Round-off is about ε·|y|/h: 2e-16 x 10 N / 1e-8 m = 2e-7
N/m against partials of 1e2..1e4, amplified by the cancellations inside the model; the
tolerance is 1e-5 relative plus 64 ε |y| / h absolute.
"""
import numpy as np
import pytest

from hosts import Opened, derivative_and_central_difference, get_dx, get_x, set_x

EPS = np.finfo(float).eps


def close(exact, fd, y, h):
    return abs(exact - fd) <= 1e-5 * max(abs(exact), abs(fd)) + 64 * EPS * max(abs(y), 1.0) / h


def test_co_simulation_feedthrough_matches_central_differences(fmu):
    """CS: the outputs with direct feedthrough from the inputs (the finger's accelerations
    with respect to its position-actuator targets), at a state where the finger pushes the T."""
    f = Opened(fmu("t_push"))
    slave = f.instance("CS", start_values={"act_y.ctrl": 0.16, "act_x.ctrl": 0.01})
    for k in range(35):
        slave.doStep(currentCommunicationPoint=k * 0.01, communicationStepSize=0.01)
    inputs = [v for v in f.md.modelVariables if v.causality == "input"]
    pairs = [(u.variable, k) for u in f.md.outputs for k in (u.dependencies or []) if k.causality == "input"]
    assert {u.name for u, _ in pairs} == {"finger_x.a", "finger_y.a"}
    u0 = slave.getReal([k.valueReference for k in inputs])
    for unknown, known in pairs:
        (exact,) = slave.getDirectionalDerivative([unknown.valueReference], [known.valueReference], [1.0])
        h = 1e-7
        i = inputs.index(known)
        def at(x):
            slave.setReal([known.valueReference], [x])
            (y,) = slave.getReal([unknown.valueReference])
            slave.setReal([known.valueReference], [u0[i]])
            return y
        fd = (at(u0[i] + h) - at(u0[i] - h)) / (2 * h)
        (y,) = slave.getReal([unknown.valueReference])
        assert close(exact, fd, y, h), (unknown.name, known.name, exact, fd)
        # The position actuator: ∂v̇/∂u = kp / m on its own joint (kp = 500 N/m, m = 1 kg).
        if unknown.name == f"finger_{known.name[4]}.a":
            assert exact == pytest.approx(500.0, rel=1e-9)
    # A vector of directions in one call: the Jacobian times the direction.
    unknowns = [f.vr["finger_x.a"], f.vr["finger_y.a"], f.vr["contact.tblock.finger.force.y"]]
    knowns = [k.valueReference for k in inputs]
    d = slave.getDirectionalDerivative(unknowns, knowns, [0.3, -0.7])
    cols = [slave.getDirectionalDerivative(unknowns, [k], [1.0]) for k in knowns]
    assert np.allclose(d, 0.3 * np.array(cols[0]) - 0.7 * np.array(cols[1]), rtol=1e-12, atol=1e-12)
    assert d[2] == 0.0, "a contact force has no direct feedthrough from the controls"
    slave.terminate()
    slave.freeInstance()


def in_contact_state(f, name):
    """States of `name` in contact with some velocity on every coordinate."""
    rng = np.random.default_rng(3)
    if name == "sphere_drop":
        x = {"ball.pos.z": 0.05 - 5e-4, "ball.quat.w": np.cos(0.2), "ball.quat.x": np.sin(0.2)}
    elif name == "sphere_pair":
        x = {}
    elif name == "adhesion_pick":
        # The box pressed into the floor, the pad 1 mm above it, within its gap: the pull acts.
        x = {"box.pos.z": 0.03 - 5e-4}
    else:
        x = {"finger_y.q": 0.25 - 0.1375 - 0.015 + 2e-3, "finger_x.q": 0.01}
    return x, rng


START = {"t_push": {"act_y.ctrl": 0.1}, "adhesion_pick": {"grip.ctrl": 0.6, "lift.ctrl": 0.01}}


@pytest.mark.parametrize("name", ["sphere_drop", "sphere_pair", "t_push", "adhesion_pick"])
def test_model_exchange_jacobians_match_central_differences(fmu, name):
    """ME: ∂ẋ/∂x, ∂ẋ/∂u, ∂y/∂x, ∂y/∂u for every pair declared in Derivatives and Outputs."""
    f = Opened(fmu(name))
    model = f.instance("ME", start_values=START.get(name))
    states = [d.variable.derivative for d in f.md.derivatives]
    nx = len(states)
    x0 = get_x(model, nx)
    assert np.array_equal(x0, model.getReal([s.valueReference for s in states]))
    pos, rng = in_contact_state(f, name)
    for k, v in pos.items():
        x0[states.index(f.var[k])] = v
    for i, s in enumerate(states):
        if s.unit in ("m/s", "rad/s"):
            x0[i] += rng.uniform(-0.02, 0.02)
    set_x(model, x0)
    (dist,) = model.getReal([next(v.valueReference for v in f.md.modelVariables if v.name.endswith(".distance"))])
    assert dist < 0, f"{name}: not in contact ({dist})"
    declared = [(u.variable, k) for u in list(f.md.derivatives) + list(f.md.outputs) for k in (u.dependencies or [])]
    assert declared
    checked = 0
    for unknown, known in declared:
        exact, fd, y, h = derivative_and_central_difference(model, states, x0, unknown, known)
        assert close(exact, fd, y, h), (name, unknown.name, known.name, exact, fd)
        checked += 1
    # The derivatives read through fmi2GetDerivatives are the der(...) variables.
    dx = get_dx(model, nx)
    assert np.array_equal(dx, model.getReal([d.variable.valueReference for d in f.md.derivatives]))
    model.terminate()
    model.freeInstance()
