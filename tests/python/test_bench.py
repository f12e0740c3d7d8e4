"""The benchmark against MuJoCo (scripts/bench.py) runs and measures every scene: a smoke test of
the command, not of its figures (timings are never asserted: machines here are noisy)."""
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_bench_times_every_scene_against_mujoco(tmp_path):
    p = subprocess.run([sys.executable, str(ROOT / "scripts" / "bench.py"), "--out", str(tmp_path), "--boxes", "2"],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    table = (tmp_path / "bench.md").read_text()
    rows = [l.split("|")[1:-1] for l in table.splitlines() if l.startswith("| ") and "---" not in l][1:]
    names = [r[0].strip() for r in rows]
    assert names == ["sphere_drop", "box_stack", "t_push", "arm_push", "horseshoe", "floating3", "boxes2"]
    for r in rows:
        ours, theirs = float(r[1]), float(r[2])
        assert ours > 0 and theirs > 0, r
    assert (tmp_path / "bench.png").stat().st_size > 0
