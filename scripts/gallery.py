"""MuJoCo's own gallery (the `model/` directory of its repository), run as written: every file
MuJoCo's Python package compiles is given to `scm simulate` for a short run, and the outcome is
tabulated (runs, refused with SCM's message, or not done within the time allowed).

The directory is not fetched here (CI cannot reach it): give its path, e.g. from a clone of
google-deepmind/mujoco. Writes a markdown table (default reports/gallery.md). Nothing here is a
pass/fail test.
"""
import argparse
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCM = ROOT / "target" / "release" / "scm"


def mujoco_compiles(path):
    """Whether MuJoCo compiles `path` (files meant to be included alone do not)."""
    import mujoco
    try:
        mujoco.MjModel.from_xml_path(str(path))
        return True
    except Exception:  # noqa: BLE001  (MuJoCo raises ValueError, or others from plugins)
        return False


def run(path, duration, timeout):
    """('runs', wall s) or ('refused', message) or ('timeout', None)."""
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [str(SCM), "simulate", str(path), "--duration", repr(duration), "--output-interval", repr(duration),
               "-o", str(pathlib.Path(tmp) / "run.csv")]
        try:
            p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return "timeout", None
    if p.returncode == 0:
        wall = p.stderr.rsplit(" in ", 1)[-1].split(" s wall")[0]
        return "runs", float(wall)
    lines = [line for line in p.stderr.splitlines() if line.strip()]
    message = lines[-1] if lines else f"exit {p.returncode}"
    return "refused", message.split(": ", 1)[-1][:300]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("model_dir", type=pathlib.Path, help="MuJoCo's model/ directory")
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "reports" / "gallery.md")
    ap.add_argument("--duration", type=float, default=0.2, help="simulated time (s)")
    ap.add_argument("--timeout", type=float, default=60.0, help="wall time allowed per file (s)")
    a = ap.parse_args()
    files = sorted(p for p in a.model_dir.rglob("*.xml") if mujoco_compiles(p))
    rows, counts = [], {"runs": 0, "refused": 0, "timeout": 0}
    for p in files:
        outcome, detail = run(p, a.duration, a.timeout)
        counts[outcome] += 1
        rel = p.relative_to(a.model_dir)
        if outcome == "runs":
            shown = f"runs ({detail:.1f} s wall)"
        elif outcome == "timeout":
            shown = f"not done within {a.timeout:.0f} s"
        else:
            shown = f"refused: {detail}"
        print(f"{rel}: {shown}", file=sys.stderr)
        rows.append(f"| `{rel}` | {shown.replace('|', '/')} |")
    lines = [
        "# MuJoCo's gallery as written",
        "",
        f"Written by `scripts/gallery.py`: every file of MuJoCo's `model/` directory that MuJoCo compiles"
        f" ({len(files)}), run {a.duration} s with `scm simulate` as written, {a.timeout:.0f} s of wall time"
        f" allowed each. {counts['runs']} run, {counts['refused']} are refused, {counts['timeout']} are"
        " not done in time.",
        "",
        "| file | SCM |",
        "| --- | --- |",
        *rows,
        "",
    ]
    a.out.write_text("\n".join(lines))
    print(f"wrote {a.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
