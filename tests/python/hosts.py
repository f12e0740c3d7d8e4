"""Helpers shared by the host tests: instantiate an FMU through fmpy's low-level classes."""
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Model, FMU2Slave


class Opened:
    """An extracted FMU, its model description and its variables by name."""

    def __init__(self, path):
        self.path = path
        self.md = read_model_description(path)
        self.dir = extract(path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.var = {v.name: v for v in self.md.modelVariables}

    def instance(self, kind="CS", name="inst", start_values=None, logger=None):
        """An initialized instance (`FMU2Slave` for "CS", `FMU2Model` in continuous-time mode
        for "ME"); `start_values` are set before initialization."""
        cls = FMU2Slave if kind == "CS" else FMU2Model
        fmu = cls(guid=self.md.guid, unzipDirectory=self.dir, modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        kwargs = {} if logger is None else {"loggingOn": True}
        fmu.instantiate(**kwargs)
        fmu.setupExperiment(startTime=0.0)
        for k, v in (start_values or {}).items():
            if isinstance(v, str):
                fmu.setString([self.vr[k]], [v.encode()])
            else:
                fmu.setReal([self.vr[k]], [v])
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        if kind == "ME":
            fmu.newDiscreteStates()
            fmu.enterContinuousTimeMode()
        return fmu


def _ptr(a):
    from ctypes import POINTER, c_double
    return a.ctypes.data_as(POINTER(c_double))


def get_x(model, nx):
    """fmi2GetContinuousStates as a numpy array."""
    import numpy as np
    x = np.zeros(nx)
    model.getContinuousStates(_ptr(x), nx)
    return x


def set_x(model, x):
    """fmi2SetContinuousStates from a sequence."""
    import numpy as np
    x = np.ascontiguousarray(x, dtype=float)
    model.setContinuousStates(_ptr(x), len(x))


def get_dx(model, nx):
    """fmi2GetDerivatives as a numpy array."""
    import numpy as np
    dx = np.zeros(nx)
    model.getDerivatives(_ptr(dx), nx)
    return dx


def derivative_and_central_difference(model, states, x0, unknown, known):
    """A Model Exchange instance's exact directional derivative of `unknown` along `known` (a
    state of `states`, or an input) at the continuous states `x0`, with its central difference
    (steps of 1e-8 on a state, 1e-7 on an input) and the unknown's value there: `(exact, fd, y,
    h)`. Leaves the instance at `x0` with the input as it was."""
    (exact,) = model.getDirectionalDerivative([unknown.valueReference], [known.valueReference], [1.0])
    if known in states:
        j, h = states.index(known), 1e-8

        def at(xj):
            x = x0.copy()
            x[j] = xj
            set_x(model, x)
            (y,) = model.getReal([unknown.valueReference])
            return y
        fd = (at(x0[j] + h) - at(x0[j] - h)) / (2 * h)
        set_x(model, x0)
    else:
        h = 1e-7
        (u0,) = model.getReal([known.valueReference])

        def at(u):
            model.setReal([known.valueReference], [u])
            (y,) = model.getReal([unknown.valueReference])
            return y
        fd = (at(u0 + h) - at(u0 - h)) / (2 * h)
        model.setReal([known.valueReference], [u0])
    (y,) = model.getReal([unknown.valueReference])
    return exact, fd, y, h
