"""Shared machinery of the report: paths, scene variants and FMUs, the Rust host and benches,
a result cache, integrator discovery, progress bars, Markdown tables and the NaN guard."""
from __future__ import annotations

import concurrent.futures
import hashlib
import json
import math
import os
import pathlib
import re
import shutil
import subprocess
import sys
import zipfile

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENES = ROOT / "resources" / "scenes"
RELEASE = ROOT / "target" / "release"
SCM = RELEASE / "scm"
LIB = RELEASE / "libscm.so"
HOST = RELEASE / "examples" / "report_host"
STEP_COST = RELEASE / "examples" / "step_cost"

try:  # the report's venv has tqdm; the test venv may not: then a plain line per task
    from tqdm import tqdm as _tqdm
except ImportError:  # pragma: no cover - depends on the venv
    _tqdm = None

try:
    import mujoco  # noqa: F401
    HAVE_MUJOCO = True
except ImportError:
    HAVE_MUJOCO = False


class ReportBug(RuntimeError):
    """Something that must not happen (a NaN, an fmi2Error): the report stops loudly."""


def progress(iterable, desc, total=None):
    """A progress bar over `iterable` (tqdm when installed)."""
    if _tqdm is not None:
        return _tqdm(iterable, desc=desc, total=total, leave=False, file=sys.stderr, dynamic_ncols=True)
    print(f"  {desc} ...", file=sys.stderr, flush=True)
    return iterable


def log(msg):
    print(msg, file=sys.stderr, flush=True)


class Context:
    """What every study needs: the output folder, a work folder, the cache, the mode."""

    def __init__(self, out: pathlib.Path, work: pathlib.Path, quick: bool, jobs: int):
        self.out = out
        self.work = work
        self.quick = quick
        self.jobs = jobs
        self.out.mkdir(parents=True, exist_ok=True)
        self.work.mkdir(parents=True, exist_ok=True)
        self.cache = work / "cache"
        self.cache.mkdir(exist_ok=True)
        self._host_digest = file_digest(HOST) if HOST.exists() else "missing"
        self._variants = {}
        self.notes = []  # printed notes (skipped scenes, missing packages) for the index
        self.figures = {}  # headline numbers the index summarizes

    def note(self, text):
        log(f"note: {text}")
        self.notes.append(text)

    # ---- scenes and FMUs -------------------------------------------------------------------
    def variant(self, scene: str, spacing: float | None = None) -> "Variant":
        """The scene (optionally at another `scm_spacing`), packed and unpacked."""
        key = (scene, spacing)
        if key not in self._variants:
            self._variants[key] = Variant(self, scene, spacing)
        return self._variants[key]

    # ---- the Rust host -----------------------------------------------------------------------
    def host_run(self, variant: "Variant", duration: float, comm: float, sets=None, strings=None,
                 inputs=None, outputs=(), timed=False):
        """Runs `report_host run` (cached by the host binary, the scene and the arguments).

        inputs: (names, rows) applied per communication step. Returns the parsed JSON with
        numpy arrays `t` and `y`."""
        import numpy as np
        args = [str(variant.dir), "--duration", repr(duration), "--comm", repr(comm)]
        for name, value in sorted((sets or {}).items()):
            args += ["--set", f"{name}={value!r}"]
        for name, value in sorted((strings or {}).items()):
            args += ["--set-string", f"{name}={value}"]
        if outputs:
            args += ["--outputs", ",".join(outputs)]
        input_text = None
        if inputs is not None:
            names, rows = inputs
            input_text = ",".join(names) + "\n" + "\n".join(",".join(repr(float(x)) for x in r) for r in rows) + "\n"
        key = hashlib.sha256(json.dumps([self._host_digest, variant.digest, args[1:], input_text]).encode()).hexdigest()[:32]
        cached = self.cache / f"run-{key}.json"
        if cached.exists():
            res = json.loads(cached.read_text())
        else:
            if input_text is not None:
                inp = self.work / "inputs" / f"{key}.csv"
                inp.parent.mkdir(exist_ok=True)
                inp.write_text(input_text)
                args += ["--inputs", str(inp)]
            p = subprocess.run([str(HOST), "run", *args], capture_output=True, text=True)
            if p.returncode != 0:
                raise ReportBug(f"report_host failed ({' '.join(args)}): {p.stderr.strip()}")
            res = json.loads(p.stdout)
            tmp = cached.with_suffix(".tmp")
            tmp.write_text(p.stdout)
            tmp.replace(cached)
        if res["status"] == "error":
            raise ReportBug(f"fmi2DoStep returned fmi2Error on {variant.name} {args}: {res['message']}")
        y = res["y"]
        if any(v is None for row in y for v in row):
            raise ReportBug(f"a NaN/Inf output on {variant.name} with {args}: this is a bug (a diverged step must be refused with fmi2Discard)")
        res["t"] = np.array(res["t"], dtype=float)
        res["y"] = np.array(y, dtype=float).reshape(len(res["t"]), len(outputs))
        res["args"] = args
        return res

    def parallel(self, fn, items, desc):
        """Runs fn over items on `jobs` threads (the work is in subprocesses), with a progress
        bar; returns results in order. Never used for timed runs."""
        results = [None] * len(items)
        with concurrent.futures.ThreadPoolExecutor(max_workers=self.jobs) as pool:
            futures = {pool.submit(fn, item): i for i, item in enumerate(items)}
            for f in progress(concurrent.futures.as_completed(futures), desc, total=len(items)):
                results[futures[f]] = f.result()
        return results


def file_digest(path: pathlib.Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def with_setting(text: str, name: str, value: float) -> str:
    """The scene text with SCM's numeric setting `name` (`scm_spacing`, `scm_prune_tolerance`...)
    set to `value` (added to <custom> if absent; MuJoCo ignores it)."""
    entry = f'<numeric name="{name}" data="{value!r}"/>'
    pat = re.compile(r'<numeric\s+name="' + re.escape(name) + r'"\s+data="[^"]*"\s*/>')
    if pat.search(text):
        return pat.sub(entry, text)
    if re.search(r"<custom>", text):
        return re.sub(r"<custom>", "<custom>\n    " + entry, text, count=1)
    return re.sub(r"(<mujoco[^>]*>)", r"\1\n  <custom>" + entry + "</custom>", text, count=1)


def with_spacing(text: str, spacing: float) -> str:
    """The scene text with its `scm_spacing` set to `spacing` (added to <custom> if absent)."""
    return with_setting(text, "scm_spacing", spacing)


class Variant:
    """A scene file (maybe at another spacing), its FMU and the unpacked FMU folder."""

    def __init__(self, ctx: Context, scene: str, spacing: float | None):
        self.scene = scene
        self.spacing = spacing
        self.name = scene if spacing is None else f"{scene}@{spacing:g}"
        src = SCENES / f"{scene}.xml"
        text = src.read_text()
        if spacing is not None:
            text = with_spacing(text, spacing)
        # A copy of resources/ keeps relative mesh paths valid for the variant.
        res = ctx.work / "resources"
        if not res.exists():
            shutil.copytree(ROOT / "resources", res)
        tag = scene if spacing is None else f"{scene}__s{spacing:g}"
        self.xml = res / "scenes" / f"{tag}.xml"
        if not self.xml.exists() or self.xml.read_text() != text:
            self.xml.write_text(text)
        self.fmu = ctx.work / "fmus" / f"{tag}.fmu"
        self.dir = ctx.work / "fmus" / tag
        self.fmu.parent.mkdir(exist_ok=True)
        self.digest = hashlib.sha256((text + file_digest(LIB)).encode()).hexdigest()
        stamp = self.dir / ".digest"
        if not (stamp.exists() and stamp.read_text() == self.digest and self.fmu.exists()):
            p = subprocess.run([str(SCM), "pack", str(self.xml), "-o", str(self.fmu), "--lib", str(LIB)], capture_output=True, text=True)
            if p.returncode != 0:
                raise ReportBug(f"scm pack {self.xml} failed: {p.stderr.strip()}")
            if self.dir.exists():
                shutil.rmtree(self.dir)
            with zipfile.ZipFile(self.fmu) as z:
                z.extractall(self.dir)
            stamp.write_text(self.digest)
        self._points = None

    def points(self) -> dict:
        """AOPC point count per body (from `scm check`)."""
        if self._points is None:
            p = subprocess.run([str(SCM), "check", str(self.xml)], capture_output=True, text=True)
            if p.returncode != 0:
                raise ReportBug(f"scm check {self.xml}: {p.stderr.strip()}")
            self._points = {m.group(1): int(m.group(2)) for m in re.finditer(r"body (\S+): (?:\d+ geom\(s\)(?: \(sampled at: [^)]*\))?, )?(\d+) points", p.stdout)}
            if not self._points:
                raise ReportBug(f"cannot read point counts from `scm check {self.xml}`:\n{p.stdout}")
        return self._points

    def total_points(self) -> int:
        return sum(self.points().values())

    def variables(self):
        """fmpy's model description of the FMU."""
        from fmpy import read_model_description
        return read_model_description(str(self.fmu))


def scene_exists(scene: str) -> bool:
    return (SCENES / f"{scene}.xml").exists()


def integrators(ctx: Context):
    """The crate's integrators (its one enumeration, through `report_host integrators`), each
    with whether it is adaptive (its result depends on solver.tolerance)."""
    cached = ctx.cache / f"integrators-{ctx._host_digest[:16]}.json"
    if cached.exists():
        return json.loads(cached.read_text())
    p = subprocess.run([str(HOST), "integrators", str(SCENES / "sphere_drop.xml")], capture_output=True, text=True)
    if p.returncode != 0:
        raise ReportBug(f"report_host integrators: {p.stderr.strip()}")
    items = json.loads(p.stdout)
    cached.write_text(json.dumps(items))
    return items


def reference_integrator(ctx: Context):
    """(name, adaptive, explanation) of the integrator references are computed with: the
    adaptive one at a tight tolerance once it exists, else the highest-order fixed-step one."""
    items = integrators(ctx)
    adaptive = [i["name"] for i in items if i["adaptive"]]
    if adaptive:
        return adaptive[0], True, f"`{adaptive[0]}` (adaptive) at solver.tolerance = 1e-10"
    names = [i["name"] for i in items]
    best = "rk4" if "rk4" in names else names[-1]
    return best, False, (f"`{best}` at the finest internal step (no adaptive integrator exists yet in this build; "
                         "once one does, the report uses it at a tight tolerance instead)")


def mujoco_integrator(name: str) -> str:
    """MuJoCo's integrator matching one of ours (Table I pairs them as the paper does)."""
    if "rk4" in name or "runge" in name or "adaptive" in name or "rk45" in name or "dopri" in name:
        return "RK4"
    if "implicit" in name and "semi" not in name:
        return "implicitfast"
    return "Euler"


# ---- pose errors ------------------------------------------------------------------------------
def pose_groups(md):
    """From the model description: translational coordinates (unit m: slide `.q`, free `.pos.*`),
    hinge angles (rad) and quaternions (groups of w, x, y, z) among the state outputs."""
    names = [v.name for v in md.modelVariables if v.causality == "output"]
    units = {v.name: v.unit for v in md.modelVariables}
    trans = [n for n in names if units.get(n) == "m" and (n.endswith(".q") or ".pos." in n)]
    hinges = [n for n in names if units.get(n) == "rad" and n.endswith(".q")]
    quats = sorted({n.rsplit(".", 1)[0] for n in names if ".quat." in n})
    quats = [[f"{q}.{c}" for c in "wxyz"] for q in quats]
    return trans, hinges, quats


def pose_error(names, y, ref_names, yref, groups):
    """Per time sample: (position error norm (m), rotation error (rad), max of both groups)."""
    import numpy as np
    trans, hinges, quats = groups
    ix = {n: i for i, n in enumerate(names)}
    jx = {n: i for i, n in enumerate(ref_names)}
    dpos = np.zeros(len(y))
    for n in trans:
        dpos += (y[:, ix[n]] - yref[:, jx[n]]) ** 2
    dpos = np.sqrt(dpos)
    drot = np.zeros(len(y))
    for n in hinges:
        drot = np.maximum(drot, np.abs(y[:, ix[n]] - yref[:, jx[n]]))
    for q in quats:
        a = np.stack([y[:, ix[c]] for c in q], 1)
        b = np.stack([yref[:, jx[c]] for c in q], 1)
        dot = np.abs(np.sum(a * b, 1)) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
        drot = np.maximum(drot, 2 * np.arccos(np.clip(dot, 0, 1)))
    return dpos, drot


# ---- Markdown ---------------------------------------------------------------------------------
def fmt(x, digits=3):
    """A number for a table; a NaN here is a bug of the report."""
    if isinstance(x, str):
        return x
    if isinstance(x, (int,)) and not isinstance(x, bool):
        return str(x)
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        raise ReportBug(f"a non-finite number ({x}) reached a table")
    if x == 0:
        return "0"
    a = abs(x)
    if 1e-3 <= a < 1e5:
        return f"{x:.{digits}g}"
    return f"{x:.{max(digits - 1, 1)}e}"


def table(header, rows):
    """A Markdown table; a '|' inside a cell would break it, so it is a bug of the report."""
    for c in list(header) + [c for r in rows for c in r if isinstance(c, str)]:
        if "|" in c:
            raise ReportBug(f"a table cell contains '|': {c!r}")
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(" --- " for _ in header) + "|"]
    for r in rows:
        lines.append("| " + " | ".join(fmt(c) for c in r) + " |")
    return "\n".join(lines)


def write(ctx: Context, name: str, text: str):
    (ctx.out / name).write_text(text.rstrip() + "\n")
    log(f"wrote {ctx.out / name}")


def savefig(ctx: Context, fig, name: str):
    fig.savefig(ctx.out / name, dpi=110)
    import matplotlib.pyplot as plt
    plt.close(fig)
    log(f"wrote {ctx.out / name}")


def machine_line():
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return f"{os.cpu_count()} cores, load average {load:.2f} when this study started"
