"""Scale-out on dask.distributed (examples/dask/scm_dask.py, docs/scale-out.md): a sweep of the
T-push FMU on a local cluster of 2 worker processes gives every run's result bit for bit as a
fresh instance run here does; each worker unpacks and instantiates the FMU once whatever the
number of runs it takes, and unregistering the plugin frees the instances and removes its files."""
import json
import os
import pathlib
import re
import subprocess
import sys
import time

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
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        results = scm_dask.sweep(client, t_push, runs, keep_plugin=True)
        name = scm_dask.FmuPlugin(t_push.read_bytes()).name
        per_worker = client.run(lambda dask_worker: (dask_worker.plugins[name].instantiations,
                                                     str(dask_worker.plugins[name].directory)))
        # A second sweep on the same workers reuses the kept plugin's instances (reset between runs).
        again = scm_dask.sweep(client, t_push, runs[:2], keep_plugin=True)
        after = client.run(lambda dask_worker: (dask_worker.plugins[name].instantiations,
                                                 str(dask_worker.plugins[name].directory)))
        client.unregister_worker_plugin(name)

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

    # Once per worker, however many runs each took, and the kept plugin served the second sweep
    # with the same files and instances (a worker idle in the first may instantiate in the second).
    counts = [c for c, _ in per_worker.values()]
    assert len(counts) == 2 and all(c <= 1 for c in counts) and sum(counts) >= 1, per_worker
    for worker, (count, directory) in after.items():
        assert directory == per_worker[worker][1] and count <= 1, (after, per_worker)
        assert count == per_worker[worker][0] or per_worker[worker][0] == 0, (after, per_worker)
    # Teardown removed each worker's unpacked FMU.
    for _, directory in per_worker.values():
        assert not pathlib.Path(directory).exists(), directory


def test_the_docs_laptop_example_runs(t_push, tmp_path):
    text = (ROOT / "docs" / "scale-out.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) == 1
    (tmp_path / "t_push.fmu").symlink_to(t_push)
    env = dict(os.environ, PYTHONPATH=str(ROOT / "examples" / "dask"))
    run = subprocess.run([sys.executable, "-c", blocks[0]], cwd=tmp_path, env=env, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    finals = [float(x) for x in re.findall(r"-?\d+\.\d+(?:e-?\d+)?", run.stdout.splitlines()[-1])]
    # Sixteen pushes, each moving the block forward (+y) by millimetres to centimetres.
    assert len(finals) == 16 and all(0.001 < y < 0.2 for y in finals), run.stdout


def test_a_scheduler_and_workers_started_by_hand(t_push, tmp_path):
    # The several-machines route on one machine: `dask scheduler` and `dask worker` as their own
    # processes, started where the example module is not importable, the example connecting by
    # address (it uploads itself to the workers).
    dask = pathlib.Path(sys.executable).parent / "dask"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    scheduler_file = tmp_path / "scheduler.json"
    procs = [subprocess.Popen([str(dask), "scheduler", "--scheduler-file", str(scheduler_file), "--port", "0",
                               "--no-dashboard"], cwd=tmp_path, env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        deadline = time.time() + 60
        while not scheduler_file.exists() and time.time() < deadline:
            time.sleep(0.2)
        procs.append(subprocess.Popen([str(dask), "worker", "--scheduler-file", str(scheduler_file), "--nworkers",
                                       "2", "--nthreads", "1", "--no-dashboard"], cwd=tmp_path, env=env,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        address = json.loads(scheduler_file.read_text())["address"]
        with distributed.Client(address) as client:
            client.wait_for_workers(2, timeout=60)
        run = subprocess.run([sys.executable, str(ROOT / "examples" / "dask" / "scm_dask.py"), str(t_push),
                              "--scheduler", address, "--runs", "4", "--stop-time", "2"],
                             cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stderr[-3000:]
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            p.wait(timeout=60)
    lines = run.stdout.strip().splitlines()
    assert len(lines) == 4 and all(l.startswith("friction ") for l in lines), run.stdout
    # The same four runs here, serially: the printed poses are theirs.
    side_runs = scm_dask.push_sweep([0.2, 0.6], [-0.3, 0.3], stop_time=2.0)
    for line, r in zip(lines, side_runs):
        y = scm_dask.simulate_serial(t_push, r)["t_y.q"][-1]
        assert f"y {y:+.4f} m" in line, (line, y)
