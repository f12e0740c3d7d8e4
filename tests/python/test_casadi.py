"""CasADi as a host (issue 21): `casadi.DaeBuilder` imports the FMU (Model Exchange), evaluates
the right-hand side at states it sets with `fmi2SetReal` in Event Mode, and takes Jacobians from
`fmi2GetDirectionalDerivative`, with `dae.create('f', ['x', 'u', 'p'], ['ode', 'y'])` as a
user writes it (the accelerations are outputs of their own, not the state derivatives, which
CasADi could not list twice).
"""
import zipfile

import numpy as np
import pytest

casadi = pytest.importorskip("casadi")
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Model

#: Every bundled scene.
SCENES = ["arm_push", "box_stack", "horseshoe", "mesh_drop", "mocap_push", "sphere_drop", "sphere_pair", "t_push"]


def unpacked(fmu, tmp_path, name):
    d = tmp_path / name
    with zipfile.ZipFile(fmu(name)) as z:
        z.extractall(d)
    return d


def start(dae, names):
    return np.array(dae.start(names), dtype=float) if names else np.zeros(0)


def in_contact(dae):
    """The start state, moved so that the bodies press on each other and move."""
    x = start(dae, dae.x())
    names = dae.x()
    if "ball.pos.z" in names:  # sphere_drop: the ball 1 mm into the ground, sliding and spinning
        x[names.index("ball.pos.z")] = 0.049
        x[names.index("ball.linvel.x")] = 0.2
        x[names.index("ball.angvel.y")] = 1.0
    return x


@pytest.mark.parametrize("scene", SCENES)
def test_casadi_evaluates_the_fmu_and_its_exact_jacobians(fmu, tmp_path, scene):
    d = unpacked(fmu, tmp_path, scene)
    dae = casadi.DaeBuilder(scene, str(d))
    f = dae.create("f", ["x", "u", "p"], ["ode", "y"])
    x, u, p = in_contact(dae), start(dae, dae.u()), start(dae, dae.p())
    out = f(x=x, u=u, p=p)
    ode, y = np.array(out["ode"]).ravel(), np.array(out["y"]).ravel()
    assert np.all(np.isfinite(ode)) and np.all(np.isfinite(y))
    # The positions' derivatives are the velocities (free joints' linear part), the state it set.
    names = dae.x()
    for k, n in enumerate(names):
        if n.endswith(".pos.x"):
            assert ode[k] == pytest.approx(x[names.index(n.replace(".pos.", ".linvel."))], abs=1e-15)
    # The outputs read the states CasADi set, not the start values.
    for k, n in enumerate(dae.y()):
        if n in names:
            assert y[k] == x[names.index(n)], n
        if n.endswith(".linvel.z"):  # its acceleration output is its state derivative
            assert y[list(dae.y()).index(n.replace("linvel", "linacc"))] == ode[names.index(n)]
    if scene == "sphere_drop":
        assert ode[names.index("ball.linvel.z")] > -9.81 + 1.0, "the ground pushes the ball up"

    outs = ["jac:ode:x", "jac:ode:p"] + (["jac:ode:u"] if len(u) else [])
    jac = f.factory("jacobians", ["x", "u", "p"], outs)
    J = {k.replace(":", "_"): np.array(v) for k, v in zip(outs, jac(x, u, p))}

    def fd(which, k, h):
        args = {"x": x.copy(), "u": u.copy(), "p": p.copy()}
        step = h * max(1.0, abs(args[which][k]))
        args[which][k] += step
        hi = np.array(f(**args)["ode"]).ravel()
        args[which][k] -= 2 * step
        lo = np.array(f(**args)["ode"]).ravel()
        return (hi - lo) / (2 * step)

    for which, key, h in [("x", "jac_ode_x", 1e-7), ("u", "jac_ode_u", 1e-7), ("p", "jac_ode_p", 1e-7)]:
        n = {"x": len(x), "u": len(u), "p": len(p)}[which]
        if n == 0:
            continue
        exact = J[key]
        assert exact.shape == (len(ode), n)
        # Parameters span decades (stiffness 1e4, eps1 1e-5): relative steps on each, and the
        # sensitivities compared as p ∂ode/∂p, whose central difference carries a rounding
        # error of about 1e-10 |ode| (ε_mach |ode| / 2e-6): held to 1e-5 relative plus 1e-9 |ode|.
        if which == "p":
            floor = 1e-9 * max(np.abs(ode).max(), 1.0)
            for k in range(n):
                step = 1e-6 * abs(p[k])
                args_hi, args_lo = p.copy(), p.copy()
                args_hi[k] += step
                args_lo[k] -= step
                col = (np.array(f(x=x, u=u, p=args_hi)["ode"]).ravel()
                       - np.array(f(x=x, u=u, p=args_lo)["ode"]).ravel()) / (2 * step)
                ex, fdc = exact[:, k] * p[k], col * p[k]
                assert np.abs(ex - fdc).max() <= 1e-5 * np.abs(ex).max() + floor, (dae.p()[k], ex, fdc)
            continue
        for k in range(n):
            col = fd(which, k, h)
            scale = max(np.abs(exact).max(), 1.0)
            assert np.abs(exact[:, k] - col).max() <= 1e-6 * scale, (which, k, exact[:, k], col)

    # The Jacobian is the FMU's own directional derivative (CasADi calls
    # fmi2GetDirectionalDerivative): the same numbers, to rounding, as an FMI call made here with
    # the same pattern (Model Exchange, Event Mode, states set by value reference).
    md = read_model_description(str(d))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    m = FMU2Model(guid=md.guid, unzipDirectory=str(d), modelIdentifier=md.modelExchange.modelIdentifier,
                  instanceName="direct")
    m.instantiate()
    m.setupExperiment(startTime=0.0)
    m.enterInitializationMode()
    m.exitInitializationMode()
    m.setReal([vr[n] for n in names], list(x))
    ders = [vr[f"der({n})"] for n in names]  # in the order of CasADi's x and ode
    for k, n in enumerate(names):
        col = np.array(m.getDirectionalDerivative(ders, [vr[n]], [1.0]))
        assert np.abs(J["jac_ode_x"][:, k] - col).max() <= 1e-12 * max(np.abs(col).max(), 1.0), n
    m.terminate()
    m.freeInstance()
