"""Many simulations of one FMU on `dask.distributed`: parameter sweeps, randomised rollouts, the
runs of a system identification's data, from a laptop's local cluster to several machines
(docs/scale-out.md).

Each worker receives the FMU's bytes once, unpacks them once into its own folder and keeps one
instance per worker thread (`FmuPlugin`, a Dask worker plugin); a run resets that instance
(`fmi2Reset`, which puts every variable back to its start value) instead of loading the library
again. The plugin stays on the workers for later sweeps of the same FMU until `release` (or the
worker's end) removes it: instances idle then are freed at once, a running one when its run
ends, and the unpacked files after the last. A run's result is the same bits as `simulate_fmu`
on a fresh instance (`simulate_serial`): tests/python/test_dask.py checks it on a local cluster
of 2 workers and on a scheduler and workers started by hand.

This module travels to the workers by value (cloudpickle), so they need only `fmpy` and
`dask[distributed]` installed, not this file.

    from distributed import Client, LocalCluster
    import scm_dask
    runs = [scm_dask.Run(stop_time=1.0, start_values={"scm.friction": mu}) for mu in (0.2, 0.4)]
    with LocalCluster(n_workers=2, threads_per_worker=1) as cluster, Client(cluster) as client:
        results = scm_dask.sweep(client, "t_push.fmu", runs)

`python scm_dask.py --help` runs the T-push sweep of the docs and measures its throughput.
"""
import argparse
import contextlib
import dataclasses
import hashlib
import pathlib
import shutil
import sys
import tempfile
import threading
import time
from typing import Optional

import cloudpickle
import numpy as np
from distributed import WorkerPlugin, get_worker, wait
from fmpy import extract, instantiate_fmu, read_model_description, simulate_fmu

if __name__ != "__main__":
    # Functions and classes of `__main__` go by value already; those of an imported module would
    # go by reference, and the scheduler and workers would have to import it.
    cloudpickle.register_pickle_by_value(sys.modules[__name__])

@dataclasses.dataclass(frozen=True)
class Run:
    """One simulation: fmpy's `simulate_fmu` arguments that vary between runs."""
    stop_time: float
    output_interval: Optional[float] = None
    start_values: dict = dataclasses.field(default_factory=dict)
    #: fmpy's input: a structured array with a `time` column and one column per input.
    input: Optional[np.ndarray] = None
    output: Optional[tuple] = None

    def arguments(self):
        return dict(stop_time=self.stop_time, output_interval=self.output_interval,
                    start_values=dict(self.start_values), input=self.input,
                    output=None if self.output is None else list(self.output))


def simulate_serial(fmu_path, run):
    """`run` on a fresh instance of the FMU, in this process: the reference of the sweep."""
    return simulate_fmu(str(fmu_path), **run.arguments())


def plugin_name(fmu_bytes):
    """The name of an FMU's plugin on the workers: one per FMU content, shared by its sweeps."""
    return "scm-fmu-" + hashlib.sha256(fmu_bytes).hexdigest()[:16]


class FmuPlugin(WorkerPlugin):
    """One FMU on a worker: unpacked once, one instance per thread, reset between runs."""

    #: Registering the same FMU again keeps the plugin (and its instances) already there.
    idempotent = True

    def __init__(self, fmu_bytes):
        self.fmu_bytes = fmu_bytes
        self.name = plugin_name(fmu_bytes)

    def setup(self, worker):
        # fmpy changes the process's working directory while it loads an FMU's library: one load
        # at a time per worker (of every FMU's plugin there), so two threads instantiating at
        # once cannot leave it elsewhere. Kept on the worker: this module's globals are not
        # shared between tasks, as it travels by value.
        self._loading = worker.__dict__.setdefault("_scm_fmu_loading", threading.Lock())
        self._lock = threading.Lock()
        self._idle = {}  # thread id -> an instance no run is using
        self._busy = set()  # thread ids whose run is under way
        self._closing = False
        self.instantiations = 0
        self.directory = None
        try:
            self.directory = pathlib.Path(tempfile.mkdtemp(prefix=self.name + "-", dir=worker.local_directory))
            fmu = self.directory / "model.fmu"
            fmu.write_bytes(self.fmu_bytes)
            self.unzipdir = extract(str(fmu), unzipdir=str(self.directory / "unzipped"))
            self.model_description = read_model_description(self.unzipdir)
        except BaseException:
            self._remove_files()
            raise

    def run(self, arguments):
        """A run (`Run.arguments`) on this thread's instance (instantiated on first use, reset
        after)."""
        key = threading.get_ident()
        with self._lock:
            if self._closing:
                raise RuntimeError(f"the FMU's plugin {self.name} is being removed from this worker")
            fmu = self._idle.pop(key, None)
            self._busy.add(key)
        keep = False
        try:
            if fmu is None:
                with self._loading:
                    fmu = instantiate_fmu(self.unzipdir, self.model_description, fmi_type="CoSimulation")
                with self._lock:
                    self.instantiations += 1
            else:
                fmu.reset()
            result = simulate_fmu(self.unzipdir, model_description=self.model_description,
                                  fmu_instance=fmu, **arguments)
            keep = True  # an instance whose run raised is in an unknown state: not reused
            return result
        finally:
            with self._lock:
                self._busy.discard(key)
                keep = keep and not self._closing
                if keep:
                    self._idle[key] = fmu
                last = self._closing and not self._busy
            if fmu is not None and not keep:
                _free(fmu)
            if last:
                self._remove_files()

    def teardown(self, worker):
        with self._lock:
            self._closing = True
            idle, self._idle = list(self._idle.values()), {}
            last = not self._busy
        for fmu in idle:
            _free(fmu)
        if last:
            self._remove_files()

    def _remove_files(self):
        if self.directory is not None:
            shutil.rmtree(self.directory, ignore_errors=True)


def _free(fmu):
    # fmi2FreeInstance is allowed in every state but a fatal one; fmpy then closes its handle on
    # the library.
    fmu.freeInstance()


def _run_on_worker(name, arguments):
    plugin = get_worker().plugins.get(name)
    if plugin is None:
        raise RuntimeError(f"the FMU's plugin {name} is not on this worker: released while its sweep ran?")
    return plugin.run(arguments)


def sweep(client, fmu_path, runs):
    """Every run of `runs` on the cluster of `client`, results in the order of `runs`.

    The FMU goes to each worker once (a worker plugin, also sent to workers that join later) and
    stays there for later sweeps of it until `release`. If a run fails, the others are waited
    for before its error is raised."""
    plugin = FmuPlugin(pathlib.Path(fmu_path).read_bytes())
    try:
        client.register_plugin(plugin, name=plugin.name)
    except BaseException:
        # A worker could not unpack it (its disk, a corrupt file): no half-made plugin stays
        # registered for the next sweep to find.
        with contextlib.suppress(Exception):
            client.unregister_worker_plugin(plugin.name)
        raise
    name = plugin.name

    def task(arguments):
        # A closure, which Dask pickles with cloudpickle, by value with what it calls: the
        # scheduler and the workers need not import this module.
        return _run_on_worker(name, arguments)

    futures = client.map(task, [r.arguments() for r in runs], pure=False)
    try:
        return client.gather(futures)
    except BaseException:
        wait(futures)  # erred futures count as done: no run is left under way
        raise
    finally:
        client.cancel(futures)  # the results are here: the workers need not keep them


def release(client, fmu_path):
    """Removes the FMU's plugin from the workers: idle instances are freed, a running one when
    its run ends, and the unpacked files after the last. A sweep of the same FMU still under way
    (from another client) then fails with a clear error for the runs not yet started."""
    client.unregister_worker_plugin(plugin_name(pathlib.Path(fmu_path).read_bytes()))


def push_sweep(frictions, angles, stop_time=2.0):
    """The T-push sweep of the docs: the finger's target moves 0.1 m/s at each angle from +y
    (radians), under each contact friction coefficient (`scm.friction`)."""
    t = np.linspace(0.0, stop_time, int(round(stop_time / 0.01)) + 1)
    runs = []
    for mu in frictions:
        for angle in angles:
            inputs = np.array([(ti, 0.1 * ti * np.sin(angle), 0.1 * ti * np.cos(angle)) for ti in t],
                              dtype=[("time", float), ("act_x.ctrl", float), ("act_y.ctrl", float)])
            runs.append(Run(stop_time=stop_time, output_interval=0.01, start_values={"scm.friction": mu},
                            input=inputs, output=("t_x.q", "t_y.q", "t_yaw.q", "contact.tblock.finger.force.y")))
    return runs


def throughput(fmu_path, runs, workers=(1, 2)):
    """The runs timed one after the other here (fresh instances, as `simulate_fmu` alone does),
    then as a sweep on a local cluster of each size in `workers` (worker processes of one thread;
    the cluster's start is not timed): rows of (label, seconds, runs per second, results equal to
    the serial ones bit for bit)."""
    from distributed import Client, LocalCluster

    start = time.perf_counter()
    reference = [simulate_serial(fmu_path, r) for r in runs]
    wall = time.perf_counter() - start
    rows = [("serial (fmpy, a fresh instance per run)", wall, len(runs) / wall, True)]
    for n in workers:
        with LocalCluster(n_workers=n, threads_per_worker=1, dashboard_address=None) as cluster, \
                Client(cluster) as client:
            client.wait_for_workers(n, timeout=120)
            start = time.perf_counter()
            results = sweep(client, fmu_path, runs)
            wall = time.perf_counter() - start
        rows.append((f"dask, {n} worker{'s' if n > 1 else ''}", wall, len(runs) / wall,
                     all(_same(a, b) for a, b in zip(results, reference))))
    return rows


def _same(a, b):
    return a.dtype.names == b.dtype.names and all(np.array_equal(a[n], b[n]) for n in a.dtype.names)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("fmu", help="the T-push FMU (scm pack resources/scenes/t_push.xml -o t_push.fmu)")
    parser.add_argument("--scheduler", help="a running scheduler's address (tcp://host:8786): run the sweep there, "
                                            "print the final block poses; without it, time serial and local clusters")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2],
                        help="local cluster sizes to time (default 1 2)")
    parser.add_argument("--runs", type=int, default=16, help="runs in the sweep (default 16)")
    parser.add_argument("--stop-time", type=float, default=2.0, help="simulated seconds per run (default 2)")
    args = parser.parse_args()

    side = max(1, int(np.ceil(np.sqrt(args.runs))))
    runs = push_sweep(np.linspace(0.2, 0.6, side), np.linspace(-0.3, 0.3, side), args.stop_time)[:args.runs]
    if args.scheduler:
        from distributed import Client

        with Client(args.scheduler) as client:
            for run, result in zip(runs, sweep(client, args.fmu, runs)):
                print(f"friction {run.start_values['scm.friction']:.3f}: block at x {result['t_x.q'][-1]:+.4f} m, "
                      f"y {result['t_y.q'][-1]:+.4f} m, yaw {result['t_yaw.q'][-1]:+.4f} rad")
        return
    for label, wall, rate, same in throughput(args.fmu, runs, args.workers):
        print(f"{label}: {len(runs)} runs in {wall:.2f} s, {rate:.2f} runs/s"
              f"{'' if same else ', DIFFERENT from the serial runs'}")


if __name__ == "__main__":
    main()
