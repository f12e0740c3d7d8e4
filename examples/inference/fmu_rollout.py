"""Trajectories of a scene's Model Exchange FMU, stepped here by semi-implicit Euler, with their
exact sensitivities from the FMU's `fmi2GetDirectionalDerivative`.

The FMU gives the state derivatives `der(x) = f(x, u, p)` and their directional derivatives; the
step is the one the Co-Simulation FMU takes under `semi_implicit_euler` on hinge and slide
joints (q, v per joint):

    v' = v + h a(q, v, u, p),    q' = q + h v'

so a trajectory here equals the Co-Simulation FMU's to rounding (the example's test checks it),
and its derivatives are those of the discrete map, exactly: with `D a = da/d(q, v, u, p) · seed`
from one directional derivative per seed,

    dv' = dv + h D a,    dq' = dq + h dv'.

Two ways to use them: `rollout(..., sensitivities=params)` carries dx/dp forward (one
directional derivative per parameter per step, seeded with the current sensitivities, so the
whole trajectory's Jacobian costs one pass); `rollout(..., jacobians=True)` keeps each step's
full Jacobian (one directional derivative per state and input) for a backward (adjoint) pass.
"""
import ctypes
import pathlib
import shutil
import subprocess
import tempfile
import zipfile

import numpy as np
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Model, FMU2Slave

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCM = ROOT / "target" / "release" / "scm"

_Real = ctypes.c_double
_Ref = ctypes.c_uint


def pack(xml_text, out_dir, name):
    """Packs an MJCF text into `out_dir/name.fmu` with `scm pack`; returns the FMU's path."""
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    xml, fmu = out_dir / f"{name}.xml", out_dir / f"{name}.fmu"
    xml.write_text(xml_text)
    subprocess.run([str(SCM), "pack", str(xml), "-o", str(fmu)], check=True, capture_output=True)
    return fmu


def _ptr(a):
    return a.ctypes.data_as(ctypes.POINTER(_Real))


def _arr(kind, values):
    values = list(values)
    return (kind * max(len(values), 1))(*values)


class Rollout:
    """A Model Exchange instance of `fmu`, stepped by semi-implicit Euler at step `h`."""

    def __init__(self, fmu, h):
        self.h = h
        self.dir = pathlib.Path(tempfile.mkdtemp(prefix="scm_rollout_"))
        with zipfile.ZipFile(fmu) as z:
            z.extractall(self.dir)
        md = read_model_description(str(self.dir))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.start = {v.name: v.start for v in md.modelVariables}
        self.states = [d.variable.derivative.name for d in md.derivatives]
        self.inputs = [v.name for v in md.modelVariables if v.causality == "input"]
        self.nx, self.nu = len(self.states), len(self.inputs)
        # Hinge and slide joints only: each position `J.q` has its velocity `J.v` as derivative.
        self.iq = [k for k, n in enumerate(self.states) if n.endswith(".q")]
        self.iv = [self.states.index(self.states[k][:-2] + ".v") for k in self.iq]
        assert len(self.iq) * 2 == self.nx, f"only hinge and slide joints: {self.states}"
        self.fmu = FMU2Model(guid=md.guid, unzipDirectory=str(self.dir),
                             modelIdentifier=md.modelExchange.modelIdentifier, instanceName="rollout")
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.fmu.enterContinuousTimeMode()
        self.c = self.fmu.component
        # Buffers the FMU reads and writes through pointers (no per-call conversion).
        self._x, self._dx, self._u = np.zeros(self.nx), np.zeros(self.nx), np.zeros(max(self.nu, 1))
        self._u_vr = _arr(_Ref, [self.vr[n] for n in self.inputs])
        # The unknowns of every directional derivative: the accelerations der(J.v).
        self._acc_vr = _arr(_Ref, [self.vr[f"der({self.states[k]})"] for k in self.iv])
        self._acc = np.zeros(len(self.iv))
        self.calls = {"derivatives": 0, "directional": 0}

    def x0(self):
        """The start state (the FMU's start values)."""
        return np.array([float(self.start[n]) for n in self.states])

    def set_parameters(self, values):
        """Sets tunable parameters {name: value} (in Event Mode, then back to continuous time)."""
        self.fmu.enterEventMode()
        self.fmu.setReal([self.vr[n] for n in values], [float(v) for v in values.values()])
        self.fmu.enterContinuousTimeMode()

    def _accelerations(self, t, x, u):
        self.fmu.fmi2SetTime(self.c, t)
        self._x[:] = x
        self.fmu.fmi2SetContinuousStates(self.c, _ptr(self._x), self.nx)
        if self.nu:
            self._u[: self.nu] = u
            self.fmu.fmi2SetReal(self.c, self._u_vr, self.nu, _ptr(self._u))
        self.fmu.fmi2GetDerivatives(self.c, _ptr(self._dx), self.nx)
        self.calls["derivatives"] += 1
        return self._dx[self.iv]

    def _directional(self, known_vr, seed):
        seed = np.ascontiguousarray(seed, dtype=float)
        self.fmu.fmi2GetDirectionalDerivative(self.c, self._acc_vr, len(self.iv), known_vr,
                                              len(seed), _ptr(seed), _ptr(self._acc))
        self.calls["directional"] += 1
        return self._acc.copy()

    def rollout(self, x0, controls, sensitivities=(), jacobians=False):
        """Steps from `x0` under `controls` (one row of inputs per step).

        Returns (X, S, J): X[k] the state after k steps (len(controls) + 1 rows); S[k] the
        sensitivity dX[k]/dp of the parameters named in `sensitivities` (nx × np, None without
        them); J[k] the full Jacobian of step k, d(x_{k+1})/d(x_k, u_k) (nx × (nx + nu)), when
        `jacobians`."""
        h, nx, nu = self.h, self.nx, self.nu
        iq, iv = np.array(self.iq), np.array(self.iv)
        controls = np.asarray(controls, dtype=float).reshape(len(controls), nu)
        n = len(controls)
        X = np.empty((n + 1, nx))
        X[0] = x0
        npar = len(sensitivities)
        state_vr = [self.vr[s] for s in self.states]
        S = np.zeros((n + 1, nx, npar)) if npar else None
        known_p = _arr(_Ref, state_vr + [self.vr[p] for p in sensitivities])
        known_xu = _arr(_Ref, state_vr + [self.vr[i] for i in self.inputs])
        J = np.empty((n, nx, nx + nu)) if jacobians else None
        for k in range(n):
            x = X[k]
            a = self._accelerations(k * h, x, controls[k])
            nxt = x.copy()
            nxt[iv] = x[iv] + h * a
            nxt[iq] = x[iq] + h * nxt[iv]
            X[k + 1] = nxt
            seed = np.zeros(nx + npar)
            for j in range(npar):
                seed[:nx], seed[nx:] = S[k, :, j], 0.0
                seed[nx + j] = 1.0
                da = self._directional(known_p, seed)
                S[k + 1, iv, j] = S[k, iv, j] + h * da
                S[k + 1, iq, j] = S[k, iq, j] + h * S[k + 1, iv, j]
            if jacobians:
                unit = np.eye(nx + nu)
                for j in range(nx + nu):
                    da = self._directional(known_xu, unit[j])
                    col = np.zeros(nx)
                    if j < nx:
                        col[j] = 1.0
                    col[iv] += h * da
                    col[iq] += h * col[iv]
                    J[k, :, j] = col
        return X, S, J

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


def co_simulation(fmu, h, controls, parameters=None, outputs=None):
    """The same run through the Co-Simulation FMU (its own semi_implicit_euler, one internal
    step per communication step of `h`): the states after every step."""
    d = pathlib.Path(tempfile.mkdtemp(prefix="scm_cs_"))
    try:
        with zipfile.ZipFile(fmu) as z:
            z.extractall(d)
        md = read_model_description(str(d))
        vr = {v.name: v.valueReference for v in md.modelVariables}
        states = outputs or [x.variable.derivative.name for x in md.derivatives]
        inputs = [v.name for v in md.modelVariables if v.causality == "input"]
        s = FMU2Slave(guid=md.guid, unzipDirectory=str(d),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="cs")
        s.instantiate()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.setReal([vr["solver.step"]], [h])
        if parameters:
            s.setReal([vr[n] for n in parameters], list(parameters.values()))
        s.exitInitializationMode()
        out_vr = [vr[n] for n in states]
        X = [s.getReal(out_vr)]
        in_vr = [vr[n] for n in inputs]
        for k, u in enumerate(np.asarray(controls, dtype=float)):
            if in_vr:
                s.setReal(in_vr, list(u))
            s.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
            X.append(s.getReal(out_vr))
        s.terminate()
        s.freeInstance()
        return np.array(X)
    finally:
        shutil.rmtree(d, ignore_errors=True)
