"""Scale-out: the T-push sweep of examples/dask/scm_dask.py timed serially in fmpy and on local
dask.distributed clusters of 1 and 2 worker processes (docs/scale-out.md)."""
import sys

from .common import ROOT, log, machine_line, table, write

sys.path.insert(0, str(ROOT / "examples" / "dask"))


def run(ctx):
    import numpy as np
    import scm_dask

    fmu = ctx.variant("t_push").fmu
    side, stops = (2, (0.5,)) if ctx.quick else (4, (2.0, 6.0))
    rows = []
    for stop in stops:
        runs = scm_dask.push_sweep(np.linspace(0.2, 0.6, side), np.linspace(-0.3, 0.3, side), stop)
        log(f"scale_out: {len(runs)} runs of {stop:g} s, serial then 1 and 2 workers")
        timed = scm_dask.throughput(fmu, runs, workers=(1, 2))
        serial_rate = timed[0][2]
        rows += [(f"{stop:g} s", label, wall, rate, f"{rate / serial_rate:.2f}x",
                  "the reference" if k == 0 else "equal bit for bit" if same else "DIFFERENT")
                 for k, (label, wall, rate, same) in enumerate(timed)]
    body = table(["run", "how", "wall (s)", "runs/s", "against serial", "results"], rows)
    write(ctx, "scale_out.md", f"""# Scale-out on dask.distributed

{machine_line()}. The sweep of `examples/dask/scm_dask.py` on `t_push`: {side * side} runs (the
finger pushes at {side} angles under {side} friction coefficients) of each length, timed one after
the other in fmpy (a fresh instance per run, as `simulate_fmu` alone makes), then on local
clusters of worker processes with one thread each (the cluster's start is not timed; each worker
unpacks and instantiates the FMU once and resets it between runs). "results" compares every
output of every run with the serial run's.

{body}

The worker processes share this machine's cores with the client, the scheduler and whatever else
runs (the load average above). See docs/scale-out.md for several machines.
""")
