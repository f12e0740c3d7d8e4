"""Scale-out on dask.distributed (examples/dask/scm_dask.py, docs/scale-out.md): a sweep of the
T-push FMU on a local cluster of 2 worker processes gives every run's result bit for bit as a
fresh instance run here does; each worker unpacks and instantiates the FMU once whatever the
number of runs or sweeps, a failed run raises its error, and releasing the FMU frees the
instances and removes the files. The several-machines route runs on a scheduler and workers
started by hand, where the example module is not importable."""
import os
import pathlib
import re
import signal
import subprocess
import sys

import distributed
import numpy as np
import pytest

from conftest import ROOT, SCENES, SCM

sys.path.insert(0, str(ROOT / "examples" / "dask"))
import scm_dask  # noqa: E402

# One worker runs these: each starts a cluster of its own (2 worker processes).
pytestmark = pytest.mark.xdist_group("dask")


@pytest.fixture(scope="module")
def t_push(tmp_path_factory):
    fmu = tmp_path_factory.mktemp("dask") / "t_push.fmu"
    subprocess.run([str(SCM), "pack", str(SCENES / "t_push.xml"), "-o", str(fmu)], check=True,
                   capture_output=True)
    return fmu


def test_a_sweep_on_two_workers_equals_the_serial_runs(t_push):
    # Three frictions by two push directions, 2 s each: the finger reaches the block at about
    # 1.2 s and pushes it, so the runs differ from one another.
    runs = scm_dask.push_sweep([0.2, 0.4, 0.6], [-0.3, 0.3], stop_time=2.0)
    serial = [scm_dask.simulate_serial(t_push, r) for r in runs]
    name = scm_dask.plugin_name(t_push.read_bytes())

    def plugin_state(dask_worker):
        plugin = dask_worker.plugins[name]
        return plugin.instantiations, str(plugin.directory)

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        results = scm_dask.sweep(client, t_push, runs)
        first = client.run(plugin_state)
        # A second sweep of the same FMU finds the plugin there: the same files and instances,
        # reset between runs.
        again = scm_dask.sweep(client, t_push, runs[:2])
        second = client.run(plugin_state)
        scm_dask.release(client, t_push)
        gone = client.run(lambda dask_worker: name in dask_worker.plugins)
        # A run that fails (an unknown variable) raises its error, after the others ended.
        bad = [runs[0], scm_dask.Run(stop_time=0.1, start_values={"no.such.variable": 1.0})]
        with pytest.raises(Exception, match="no.such.variable"):
            scm_dask.sweep(client, t_push, bad)
        scm_dask.release(client, t_push)

    assert len(results) == len(runs)
    for a, b in zip(results + again, serial + serial[:2]):
        assert a.dtype.names == b.dtype.names
        for column in a.dtype.names:
            assert np.array_equal(a[column], b[column]), column
    # The runs are not one run six times: the direction turns the block (the two directions
    # mirror each other), friction slows it.
    final_yaw = [r["t_yaw.q"][-1] for r in serial]
    assert final_yaw[0] * final_yaw[1] < 0, final_yaw
    assert len({(r["t_x.q"][-1], r["t_y.q"][-1]) for r in serial}) == len(runs)
    assert max(r["contact.tblock.finger.force.y"].max() for r in serial) > 0.1

    # Once per worker, however many runs each took; the second sweep used the same files and
    # instances (a worker idle in the first may instantiate in the second).
    counts = [c for c, _ in first.values()]
    assert len(counts) == 2 and all(c <= 1 for c in counts) and sum(counts) >= 1, first
    for worker, (count, directory) in second.items():
        assert directory == first[worker][1] and count <= 1, (second, first)
        assert count == first[worker][0] or first[worker][0] == 0, (second, first)
    # Released: the plugin is off every worker and its unpacked files are removed.
    assert not any(gone.values()), gone
    for _, directory in first.values():
        assert not pathlib.Path(directory).exists(), directory


def test_the_docs_laptop_example_runs(t_push, tmp_path):
    # As a script of its own (worker processes start by `spawn`, which imports the script).
    text = (ROOT / "docs" / "scale-out.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) == 1
    (tmp_path / "t_push.fmu").symlink_to(t_push)
    script = tmp_path / "laptop.py"
    script.write_text(blocks[0])
    env = dict(os.environ, PYTHONPATH=str(ROOT / "examples" / "dask"))
    run = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    finals = [float(x) for x in re.findall(r"-?\d+\.\d+(?:e-?\d+)?", run.stdout.splitlines()[-1])]
    # Sixteen pushes, each moving the block forward (+y) by millimetres to centimetres.
    assert len(finals) == 16 and all(0.001 < y < 0.2 for y in finals), run.stdout


DRIVER = """
import sys
from distributed import Client
import scm_dask

with Client(scheduler_file=sys.argv[1], timeout=60) as client:
    runs = scm_dask.push_sweep([0.2, 0.6], [-0.3, 0.3], stop_time=2.0)
    for r in scm_dask.sweep(client, sys.argv[2], runs):
        print(repr(float(r["t_y.q"][-1])))
    scm_dask.release(client, sys.argv[2])
"""


def test_a_scheduler_and_workers_started_by_hand(t_push, tmp_path):
    # The several-machines route on one machine: `dask scheduler` and `dask worker` as processes
    # of their own, started where scm_dask is not importable; a program of one's own imports it
    # and sweeps (the module travels by value), and the example's command line does the same.
    dask = pathlib.Path(sys.executable).parent / "dask"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    scheduler_file = tmp_path / "scheduler.json"
    (tmp_path / "driver.py").write_text(DRIVER)
    procs = []

    def start(*args):
        procs.append(subprocess.Popen([str(dask), *args, "--scheduler-file", str(scheduler_file), "--no-dashboard"],
                                      cwd=tmp_path, env=env, start_new_session=True,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
    try:
        start("scheduler", "--port", "0")
        start("worker", "--nworkers", "2", "--nthreads", "1")
        with distributed.Client(scheduler_file=str(scheduler_file), timeout=60) as client:
            client.wait_for_workers(2, timeout=60)
            address = client.scheduler.address
        own = subprocess.run([sys.executable, "driver.py", str(scheduler_file), str(t_push)], cwd=tmp_path,
                             env=dict(env, PYTHONPATH=str(ROOT / "examples" / "dask")),
                             capture_output=True, text=True, timeout=300)
        cli = subprocess.run([sys.executable, str(ROOT / "examples" / "dask" / "scm_dask.py"), str(t_push),
                              "--scheduler", address, "--runs", "4", "--stop-time", "2"],
                             cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    finally:
        for p in reversed(procs):  # workers first, then the scheduler
            os.killpg(p.pid, signal.SIGTERM)
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()
    assert own.returncode == 0, own.stderr[-3000:]
    assert cli.returncode == 0, cli.stderr[-3000:]
    # The same four runs here, serially: both programs printed their results.
    serial = [scm_dask.simulate_serial(t_push, r)["t_y.q"][-1]
              for r in scm_dask.push_sweep([0.2, 0.6], [-0.3, 0.3], stop_time=2.0)]
    assert [float(x) for x in own.stdout.split()] == serial, own.stdout
    lines = cli.stdout.strip().splitlines()
    assert len(lines) == 4 and all(l.startswith("friction ") for l in lines), cli.stdout
    for line, y in zip(lines, serial):
        assert f"y {y:+.4f} m" in line, (line, y)
