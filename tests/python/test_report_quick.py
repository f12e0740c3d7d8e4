"""Smoke test of the report (scripts/report.sh): `--quick` runs every study on a small grid into a
temporary folder; every table and plot must be there and every cell a classified result.

It runs in the test venv, which has no `mujoco` (MuJoCo stays in .venv-report): the report then
writes its MuJoCo columns as "n/a (mujoco not installed ...)" and this test checks exactly that.
When mujoco is importable, the MuJoCo columns must hold numbers instead."""
import importlib.util
import os
import pathlib
import re
import subprocess
import sys

import pytest

# One pytest-xdist worker runs this module's tests: its studies run once, in a module fixture.
pytestmark = [pytest.mark.xdist_group("report_quick"), pytest.mark.slow]

ROOT = pathlib.Path(__file__).resolve().parents[2]
HAVE_MUJOCO = importlib.util.find_spec("mujoco") is not None

STUDY_FILES = ["derivatives_and_speed.md", "force_profile.md", "planar_pushing.md", "work_precision.md", "stability.md",
               "system_identification.md", "trajectory_optimization.md", "scale_out.md"]
ALWAYS_PNG = ["force_profile.png", "pushing_top_view.png", "work_precision_sphere_drop.png", "work_precision_t_push.png",
              "system_identification.png", "trajectory_optimization.png"]


@pytest.fixture(scope="module")
def quick_report(tmp_path_factory):
    subprocess.run(["cargo", "build", "--release", "-q", "--example", "report_host", "--example", "step_cost"], cwd=ROOT, check=True)
    if not (ROOT / "target" / "release" / "scm").exists():
        subprocess.run(["cargo", "build", "--release", "-q"], cwd=ROOT, check=True)
    out = tmp_path_factory.mktemp("report")
    env = dict(os.environ, PYTHONPATH=str(ROOT / "scripts"), MPLBACKEND="Agg")
    p = subprocess.run([sys.executable, "-m", "report", "--quick", "--out", str(out), "--jobs", "2"],
                       cwd=ROOT, env=env, capture_output=True, text=True, timeout=1200)
    assert p.returncode == 0, p.stderr[-4000:]
    return out, p.stderr


def tables(text):
    """Every Markdown table as a list of rows (lists of cell strings), header first."""
    found, cur = [], []
    for line in text.splitlines():
        if line.startswith("|"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if not all(re.fullmatch(r"-+", c) for c in cells):
                cur.append(cells)
        elif cur:
            found.append(cur)
            cur = []
    if cur:
        found.append(cur)
    return found


def test_every_study_writes_its_tables_and_plots(quick_report):
    out, _ = quick_report
    index = (out / "README.md").read_text()
    for f in STUDY_FILES:
        assert (out / f).exists(), f
        assert f"({f})" in index, f"the index does not link {f}"
    for f in ALWAYS_PNG:
        assert (out / f).stat().st_size > 10_000, f
    stability_png = list(out.glob("stability_*.png"))
    # Two scenes × (stiffness, eps1, eps2, eps3).
    assert len(stability_png) == 8, sorted(p.name for p in stability_png)
    for f in STUDY_FILES:
        text = (out / f).read_text()
        for png in re.findall(r"\]\(([^)]+\.png)\)", text):
            assert (out / png).exists(), f"{f} links {png}, which was not written"


def test_no_cell_is_a_nan_or_empty(quick_report):
    out, _ = quick_report
    for f in STUDY_FILES:
        for t in tables((out / f).read_text()):
            width = len(t[0])
            for row in t:
                assert len(row) == width, (f, row)
                for cell in row:
                    assert cell != "", (f, row)
                    assert not re.search(r"\bnan\b|\binf\b", cell, re.I), (f, row)


def test_every_stability_cell_is_classified(quick_report):
    out, _ = quick_report
    text = (out / "stability.md").read_text()
    n_tables = 0
    for t in tables(text):
        n_tables += 1
        header = t[0]
        steps = [i for i, h in enumerate(header) if h.endswith(" ms") and i > 0]
        assert steps, header
        for row in t[1:]:
            for i in steps:
                codes = row[i].split()
                # one code per integrator, each stable / wrong / refused
                assert codes and all(c in ("S", "W", "R") for c in codes), row
    assert n_tables == 8


def test_mujoco_columns_are_numbers_or_say_why_not(quick_report):
    out, _ = quick_report
    push = tables((out / "planar_pushing.md").read_text())[0]
    col = push[0].index("MuJoCo step time (ms)")
    for row in push[1:]:
        if HAVE_MUJOCO:
            assert re.match(r"[\d.e+-]+ ± ", row[col]), row
        else:
            assert "mujoco not installed" in row[col], row
    force = tables((out / "force_profile.md").read_text())[0]
    assert force[1][0] == "SCM" and re.match(r"-?[\d.]", force[1][1])
    if not HAVE_MUJOCO:
        assert "mujoco not installed" in force[2][1]


def test_speed_targets_have_a_verdict(quick_report):
    out, _ = quick_report
    targets = tables((out / "derivatives_and_speed.md").read_text())[0]
    assert targets[0] == ["target", "goal", "measured", "verdict"]
    assert len(targets) == 4
    for row in targets[1:]:
        assert row[3] == "met" or row[3].startswith("missed by") or (not HAVE_MUJOCO and row[3] == "not measured"), row


def test_scale_out_runs_equal_the_serial_ones(quick_report):
    out, _ = quick_report
    rows = tables((out / "scale_out.md").read_text())[0]
    assert rows[0] == ["run", "how", "wall (s)", "runs/s", "against serial", "results"]
    assert [r[1] for r in rows[1:]] == ["serial (fmpy, a fresh instance per run)", "dask, 1 worker", "dask, 2 workers"]
    assert rows[1][5] == "the reference"
    for row in rows[2:]:
        assert row[5] == "equal bit for bit", row
    for row in rows[1:]:
        assert float(row[3]) > 0, row


def test_work_precision_has_the_model_exchange_line(quick_report):
    # Every scene of the study is also run in Model Exchange under fmpy's CVode; at rtol 1e-6 on
    # positions of 0.1-1 m its local errors are 1e-7-1e-6 m, and its trajectory stays within
    # 1e-4 m of the converged Co-Simulation reference (measured: 2e-7-5e-7 m RMS).
    out, _ = quick_report
    text = (out / "work_precision.md").read_text()
    grids = [t for t in tables(text) if t[0][0] == "integrator"]
    assert len(grids) == 4, [t[0] for t in grids]
    for t in grids:
        header = t[0]
        rms = header.index("trajectory RMS position error (m)")
        cvode = [r for r in t[1:] if r[0] == "cvode (ME)"]
        assert cvode, "no CVode (ME) row"
        for row in cvode:
            assert row[3] == "ok", row
            assert float(row[rms]) < 1e-4, row
