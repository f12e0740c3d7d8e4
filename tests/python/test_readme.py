"""The README's examples run as written: its Python block (fmpy on the T-push FMU), its Rust
lines, and the C host it points to (examples/c/push.c on the T-push FMU, built by its Makefile
against fmpy's standard fmi2 headers, with the GUID and value references `scm variables`
prints), so the front door never shows code that does not work."""
import re
import shutil
import subprocess
import sys

import numpy as np
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


def test_the_c_example_sets_an_input_and_reads_a_contact_force_as_fmpy_does(fmu, tmp_path):
    """examples/c/push.c, built by its Makefile, pushes the T-block: it sets the finger's target
    act_y.ctrl = 0.1 t before each 10 ms step and prints the contact force on the block, with
    the GUID and value references `scm variables` lists; fmpy's run of the same FMU with the
    same input gives the same forces."""
    assert shutil.which("gcc") and shutil.which("make"), "gcc and make are needed (scripts/setup.sh)"
    subprocess.run(["make", "-s", "-C", str(ROOT / "examples" / "c"), f"FMI_HEADERS={fmi2_headers()}",
                    f"OUT={tmp_path}"], check=True)
    exe = tmp_path / "push"
    path = fmu("t_push")
    md = read_model_description(path)
    # `scm variables` gives the GUID and the value references the packed FMU declares.
    listed = subprocess.run([str(SCM), "variables", str(ROOT / "resources" / "scenes" / "t_push.xml")],
                            capture_output=True, text=True, check=True).stdout.splitlines()
    assert listed[0] == f"guid\t{md.guid}", listed[0]
    header = listed[1].split("\t")
    declared = {r.split("\t")[1]: dict(zip(header, r.split("\t"))) for r in listed[2:]}
    assert len(declared) == len(md.modelVariables)
    for v in md.modelVariables:
        row = declared[v.name]
        assert (int(row["value reference"]), row["type"], row["causality"], row["variability"]) == \
            (v.valueReference, v.type, v.causality, v.variability), (v.name, row)
    force = "contact.tblock.finger.force.y"
    vrs = [declared[n]["value reference"] for n in ("act_y.ctrl", force)]
    unzipped = extract(path, unzipdir=str(tmp_path / "t_push"))
    out = subprocess.run([str(exe), unzipped, md.guid, *vrs], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    rows = [line.split() for line in out.stdout.splitlines()]
    assert len(rows) == 200
    t = np.array([k * 0.01 for k in range(201)])
    inputs = np.array([(ti, 0.0, 0.1 * ti) for ti in t],
                      dtype=[("time", float), ("act_x.ctrl", float), ("act_y.ctrl", float)])
    ref = simulate_fmu(path, stop_time=2.0, output_interval=0.01, input=inputs, output=[force])
    worst = 0.0
    for (t, f), r in zip(rows, ref[1:]):
        assert abs(float(t) - r["time"]) < 1e-9
        worst = max(worst, abs(float(f) - r[force]))
    print(f"largest force difference from fmpy's run: {worst:.3g} N; largest push "
          f"{max(float(f) for _, f in rows):.2f} N")
    assert max(float(f) for _, f in rows) > 4.0, "the finger reaches the block and pushes it"
    # The same run up to the last bits of the time grid and of the input's interpolation:
    assert worst < 1e-10, worst  # measured 4.3e-13 N on a 5.8 N push
