"""The README's examples run as written: its Python block (fmpy on the T-push FMU), its Rust
lines, and the C host it points to (docs/c/drop.c on the sphere_drop FMU, compiled with gcc
against fmpy's standard fmi2 headers, with the GUID and value reference `scm variables`
prints), so the front door never shows code that does not work."""
import re
import shutil
import subprocess
import sys

from fmpy import extract, read_model_description, simulate_fmu

from conftest import ROOT, SCM
from test_c_host import fmi2_headers


def block(language):
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(rf"```{language}\n(.*?)```", text, re.S)
    assert len(blocks) == 1, f"expected one {language} block in README.md"
    return blocks[0]


def test_the_python_example_runs(tmp_path):
    # Run where a fresh clone after scripts/setup.sh stands: the build and the scenes, no out/
    # (the block once failed there, writing into a folder it had not made).
    for name in ("target", "resources"):
        (tmp_path / name).symlink_to(ROOT / name)
    script = tmp_path / "example.py"
    script.write_text(block("python"))
    out = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    m = re.search(r"pushed (\S+) m, turned (\S+) rad, largest push (\S+) N", out.stdout)
    assert m, out.stdout
    pushed, turned, force = map(float, m.groups())
    # The finger's target moves 0.2 m forward (+y) from 25 cm below the block: it reaches the
    # stem and pushes the block forward along +y, about straight (the push is centred), more
    # than the block's 4 N of table friction.
    assert 0.0 < pushed < 0.2, pushed
    assert abs(turned) < 0.05, turned
    assert force > 4.0, force


def test_the_rust_example_is_the_doc_test_of_simulation():
    # The README's Rust lines are taken from the documentation example of `Simulation`, which
    # `cargo test --doc` runs: each must still be there, word for word.
    doc = [l.strip()[4:] for l in (ROOT / "src" / "sim.rs").read_text().splitlines() if l.strip().startswith("/// ")]
    lines = [l for l in block("rust").splitlines() if l.strip()]
    assert len(lines) >= 4
    for line in lines:
        assert line in doc, f"README.md's Rust line is not in the doc test of Simulation: {line}"


def test_the_c_example_runs_like_fmpy(fmu, tmp_path):
    gcc = shutil.which("gcc")
    assert gcc, "gcc is needed (scripts/setup.sh installs it)"
    source = ROOT / "docs" / "c" / "drop.c"
    exe = tmp_path / "drop"
    subprocess.run([gcc, "-std=c99", "-D_POSIX_C_SOURCE=200809L", "-Wall", "-Wextra", "-Werror", "-I",
                    str(fmi2_headers()), str(source), "-o", str(exe), "-ldl"], check=True)
    path = fmu("sphere_drop")
    md = read_model_description(path)
    # `scm variables` gives the GUID and the value reference the packed FMU declares.
    listed = subprocess.run([str(SCM), "variables", str(ROOT / "resources" / "scenes" / "sphere_drop.xml")],
                            capture_output=True, text=True, check=True).stdout.splitlines()
    assert listed[0] == f"guid\t{md.guid}", listed[0]
    header = listed[1].split("\t")
    declared = {r.split("\t")[1]: dict(zip(header, r.split("\t"))) for r in listed[2:]}
    assert len(declared) == len(md.modelVariables)
    for v in md.modelVariables:
        row = declared[v.name]
        assert (int(row["value reference"]), row["type"], row["causality"], row["variability"]) == \
            (v.valueReference, v.type, v.causality, v.variability), (v.name, row)
    vr = int(declared["ball.pos.z"]["value reference"])
    unzipped = extract(path, unzipdir=str(tmp_path / "sphere_drop"))
    out = subprocess.run([str(exe), unzipped, md.guid, str(vr)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    rows = [line.split() for line in out.stdout.splitlines()]
    assert len(rows) == 100
    ref = simulate_fmu(path, stop_time=1.0, output_interval=0.01, output=["ball.pos.z"])
    for (t, z), r in zip(rows, ref[1:]):
        assert abs(float(t) - r["time"]) < 1e-9
        # fmpy's communication points are k * 0.01 with steps t_(k+1) - t_k, the example's steps
        # are 0.01: the same run up to the last bits of the time grid.
        assert abs(float(z) - r["ball.pos.z"]) < 1e-12, (t, z, r["ball.pos.z"])
