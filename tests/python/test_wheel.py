"""The wheel (issue 44, docs/wheel.md): scripts/wheel.sh builds it, `pip install` puts it into a
fresh venv with no Rust on PATH and no package index, and the `scm` it installs packs a scene
with the FMU binary it installed beside it; fmpy simulates that FMU to the same bits as the one
the build tree's `scm` packs."""
import shutil
import subprocess
import sys
import time
import zipfile

import numpy as np
import pytest
from fmpy import simulate_fmu

from conftest import ROOT, SCENES, SCM

# One worker builds the wheel once (scripts/wheel.sh stages into one folder of the build tree);
# the build takes about a minute, so the quick tier leaves it to CI.
pytestmark = [pytest.mark.xdist_group("wheel"), pytest.mark.slow]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    out = tmp_path_factory.mktemp("wheels")
    run = subprocess.run([str(ROOT / "scripts" / "wheel.sh"), str(out)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    path = out / run.stdout.strip().splitlines()[-1].split("/")[-1]
    assert path.is_file(), run.stdout
    return path


def test_the_wheel_holds_the_command_and_the_fmu_binary(wheel):
    # A binary wheel for Linux x86-64 that needs no particular Python: a command, a library.
    assert wheel.name.startswith("scm_fmu-") and wheel.name.endswith("_x86_64.whl"), wheel.name
    assert "-py3-none-manylinux_" in wheel.name, wheel.name
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
    version = wheel.name.split("-")[1]
    data = f"scm_fmu-{version}.data"
    assert f"{data}/scripts/scm" in names
    assert f"{data}/data/lib/scm/libscm.so" in names
    # Nothing of the build tree rides along: the two binaries and the metadata.
    assert all(n.startswith((data + "/", f"scm_fmu-{version}.dist-info/")) for n in names), names
    print(f"wheel {wheel.name}: {wheel.stat().st_size / 1e6:.2f} MB")


def test_a_fresh_venv_packs_and_fmpy_simulates(wheel, tmp_path):
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    start = time.perf_counter()
    subprocess.run([str(venv / "bin" / "pip"), "install", "-q", "--no-index", str(wheel)], check=True)
    print(f"pip install into a fresh venv: {time.perf_counter() - start:.2f} s")
    scm = venv / "bin" / "scm"
    lib = venv / "lib" / "scm" / "libscm.so"
    assert scm.is_file() and lib.is_file()

    # No Rust, no cargo, no build tree: only the venv's own bin and the system's.
    env = {"PATH": f"{venv / 'bin'}:/usr/bin:/bin", "HOME": str(tmp_path)}
    assert subprocess.run(["which", "cargo"], env=env, capture_output=True).returncode != 0
    fmu = tmp_path / "t_push.fmu"
    run = subprocess.run(["scm", "pack", str(SCENES / "t_push.xml"), "-o", str(fmu)],
                         env=env, cwd=tmp_path, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    # The FMU carries the library the wheel installed (stripped), not the build tree's.
    with zipfile.ZipFile(fmu) as z:
        packed = z.read("binaries/linux64/scm.so")
    assert packed == lib.read_bytes()
    assert packed != (ROOT / "target" / "release" / "libscm.so").read_bytes()

    reference = tmp_path / "t_push_tree.fmu"
    subprocess.run([str(SCM), "pack", str(SCENES / "t_push.xml"), "-o", str(reference)], check=True)
    # The README's push: the finger's target moves forward 0.1 m/s for 2 s.
    t = np.linspace(0.0, 2.0, 201)
    inputs = np.array([(ti, 0.0, 0.1 * ti) for ti in t],
                      dtype=[("time", float), ("act_x.ctrl", float), ("act_y.ctrl", float)])
    outputs = ["t_x.q", "t_y.q", "t_yaw.q", "contact.tblock.finger.force.y"]
    a, b = (simulate_fmu(str(f), stop_time=2.0, output_interval=0.01, input=inputs, output=outputs)
            for f in (fmu, reference))
    for name in outputs:
        assert np.array_equal(a[name], b[name]), name
    # The run did something: the finger reached the block and pushed it.
    assert np.max(a["contact.tblock.finger.force.y"]) > 0.1


def test_an_scm_without_its_library_says_where_it_looked(tmp_path):
    # A copy of the command alone: neither beside it nor in ../lib/scm/ is there a library.
    (tmp_path / "bin").mkdir()
    scm = tmp_path / "bin" / "scm"
    shutil.copy(SCM, scm)
    run = subprocess.run([str(scm), "pack", str(SCENES / "t_push.xml"), "-o", str(tmp_path / "x.fmu")],
                         capture_output=True, text=True)
    assert run.returncode != 0
    assert str(tmp_path / "bin" / "libscm.so") in run.stderr, run.stderr
    assert str(tmp_path / "bin" / ".." / "lib" / "scm" / "libscm.so") in run.stderr \
        or str(tmp_path / "lib" / "scm" / "libscm.so") in run.stderr, run.stderr
    assert "--lib" in run.stderr and not (tmp_path / "x.fmu").exists()
