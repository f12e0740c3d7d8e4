"""A C host (tests/c_host/cs_host.c), compiled with gcc against the standard fmi2 headers that
fmpy ships (fmpy/c-code/), loads scm.so with dlopen and runs t_push for 2 s through the
Co-Simulation interface; its outputs equal fmpy's run of the same FMU bit for bit (same binary,
same calls, same communication points: there is nothing to differ). The C program also checks
the "%s" logger format and a serialize/deserialize/rerun round trip on its own."""
import pathlib
import shutil
import subprocess

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu

from conftest import ROOT

# One pytest-xdist worker runs this module's tests: the compiled C host is a module fixture.
pytestmark = pytest.mark.xdist_group("c_host")

SOURCE = ROOT / "tests" / "c_host" / "cs_host.c"
INPUTS = {"act_y.ctrl": 0.16, "act_x.ctrl": 0.01}


def fmi2_headers():
    import fmpy
    return pathlib.Path(fmpy.__file__).parent / "c-code"


@pytest.fixture(scope="module")
def cs_host(tmp_path_factory):
    gcc = shutil.which("gcc")
    assert gcc, "gcc is needed for the C host test (scripts/setup.sh installs it)"
    exe = tmp_path_factory.mktemp("c_host") / "cs_host"
    subprocess.run([gcc, "-std=c99", "-D_POSIX_C_SOURCE=200809L", "-Wall", "-Wextra", "-Werror", "-O2", "-I", str(fmi2_headers()), str(SOURCE), "-o", str(exe), "-ldl"], check=True)
    return exe


def test_c_host_runs_t_push_like_fmpy(fmu, cs_host, tmp_path):
    path = fmu("t_push")
    md = read_model_description(path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    unzipped = extract(path, unzipdir=str(tmp_path / "t_push"))
    csv = tmp_path / "c_host.csv"
    inputs = ",".join(f"{vr[k]}={v!r}" for k, v in INPUTS.items())
    run = subprocess.run([str(cs_host), unzipped, md.guid, "2.0", "0.01", str(csv), inputs, ",".join(str(vr[n]) for n in outputs)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    assert "log messages" in run.stderr and "fmi2ExitInitializationMode" in run.stderr, run.stderr[-2000:]
    c = np.loadtxt(csv, delimiter=",", ndmin=2)
    ref = simulate_fmu(path, stop_time=2.0, output_interval=0.01, output=outputs, start_values=INPUTS)
    assert c.shape == (len(ref), len(outputs) + 1)
    assert np.array_equal(c[:, 0], ref["time"])
    assert ref["t_y.q"][-1] > 0.03, "the finger did not push the T-block"
    for j, n in enumerate(outputs):
        assert np.array_equal(c[:, j + 1], ref[n]), f"{n}: the C host and fmpy differ (max {np.max(np.abs(c[:, j + 1] - ref[n]))})"
