"""The inference examples of examples/inference/ as studies of the report: system
identification and trajectory optimization through the t_push FMU (each also runs alone, see
its docstring)."""
import sys

from .common import ROOT

sys.path.insert(0, str(ROOT / "examples" / "inference"))


def system_identification(ctx):
    import sysid
    sysid.run(sysid.default_pushes(ctx.quick), quick=ctx.quick, out=ctx.out)


def trajectory_optimization(ctx):
    import trajopt
    if ctx.quick:  # a smoke run: tests/python/test_inference.py holds the converging one
        trajopt.run(knots=6, duration=1.2, out=ctx.out,
                    budget=dict(iterations=3, cem_iterations=2, population=8, elites=2, sigma=0.03))
    else:
        trajopt.run(**trajopt.settings(False), out=ctx.out)
