"""Work–precision: error against run time, per scene, every integrator × internal step × spacing."""
import numpy as np

from . import scenes as S
from .common import (fmt, integrators, log, machine_line, pose_error, pose_groups, progress,
                     reference_integrator, savefig, scene_exists, table, write)

ADAPTIVE_TOLERANCES = (1e-2, 1e-4, 1e-6, 1e-8)
# Model Exchange under fmpy's CVode (SUNDIALS BDF, variable order and step), relative tolerances.
CVODE_TOLERANCES = (1e-4, 1e-6, 1e-8)
CVODE = "cvode (ME)"


def _fmpy_input(inputs, comm):
    """The report's input rows (row k held during communication step k) as fmpy's input table:
    each change at a repeated time point, so fmpy applies a step, not a ramp."""
    if inputs is None:
        return None
    names, rows = inputs
    times, values = [0.0], [rows[0]]
    for k in range(1, len(rows)):
        times += [k * comm, k * comm]
        values += [rows[k - 1], rows[k]]
    table = np.zeros(len(times), dtype=[("time", np.float64)] + [(n, np.float64) for n in names])
    table["time"] = times
    for j, n in enumerate(names):
        table[n] = [v[j] for v in values]
    return table


def _cvode_run(v, dur, comm, rtol, inputs, outputs):
    """One Model Exchange run under fmpy's CVode: (status, message, wall time, outputs at every
    communication point). The time is the whole call, fmpy's Python loop included."""
    import time
    from fmpy import simulate_fmu
    started = time.perf_counter()
    try:
        res = simulate_fmu(str(v.dir), fmi_type="ModelExchange", solver="CVode", relative_tolerance=rtol,
                           stop_time=dur, output_interval=comm, record_events=False,
                           input=_fmpy_input(inputs, comm), output=outputs)
    except Exception as e:  # a refused step, or CVode giving up: listed, not plotted
        return "error", str(e).splitlines()[0], time.perf_counter() - started, None
    wall = time.perf_counter() - started
    n = int(round(dur / comm))
    at = {int(round(t / comm)): i for i, t in enumerate(res["time"]) if abs(t / comm - round(t / comm)) < 1e-6}
    if any(k not in at for k in range(n + 1)):
        return "error", "fmpy did not return every communication point", wall, None
    return "ok", "", wall, [[float(res[o][at[k]]) for o in outputs] for k in range(n + 1)]


def _settings(ctx, integ, adaptive):
    """(label, solver sets) of the grid of one integrator."""
    steps = S.STEPS_MS if not ctx.quick else (2.0, 16.0)
    if adaptive:
        tols = ADAPTIVE_TOLERANCES if not ctx.quick else ADAPTIVE_TOLERANCES[::3]
        return [(f"tol {t:g}", {"solver.step": max(steps) / 1000, "solver.tolerance": t}) for t in tols]
    return [(f"{h:g} ms", {"solver.step": h / 1000}) for h in steps]


def run(ctx):
    spec_list = [s for s in S.WORK_PRECISION if scene_exists(s["scene"])]
    for s in S.WORK_PRECISION:
        if not scene_exists(s["scene"]):
            ctx.note(f"work–precision: scene {s['scene']} is not in resources/scenes yet: skipped")
    if ctx.quick:
        spec_list = [dict(s, duration=min(s["duration"], 0.5), spacings=s["spacings"][:2]) for s in spec_list]
    ints = integrators(ctx)
    ref_name, ref_adaptive, ref_text = reference_integrator(ctx)
    ref_step = min(S.STEPS_MS) / 1000 / 2
    sections, summary = [], []
    for spec in spec_list:
        scene = spec["scene"]
        dur, comm = spec["duration"], S.COMM
        dur = round(dur / comm) * comm
        inputs = S.input_rows(spec.get("inputs"), dur, comm)
        variants = [ctx.variant(scene, sp) for sp in spec["spacings"]]
        groups = pose_groups(variants[0].variables())
        outputs = groups[0] + groups[1] + [c for q in groups[2] for c in q]

        def go(v, integ, sets, timed=False):
            return ctx.host_run(v, dur, comm, sets=sets, strings={"solver.integrator": integ}, inputs=inputs, outputs=outputs, timed=timed)

        # References (untimed, in parallel): per spacing, the reference and its halving check.
        if ref_adaptive:
            ref_sets = {"solver.step": ref_step * 2, "solver.tolerance": 1e-10}
            chk_sets = {"solver.step": ref_step, "solver.tolerance": 1e-11}
        else:
            ref_sets, chk_sets = {"solver.step": ref_step}, {"solver.step": ref_step * 2}
        jobs = [(v, ref_name, st) for v in variants for st in (ref_sets, chk_sets)]
        res = ctx.parallel(lambda j: go(*j), jobs, f"{scene}: references")
        refs = {}
        for i, v in enumerate(variants):
            ref, chk = res[2 * i], res[2 * i + 1]
            for r, what in ((ref, "reference"), (chk, "halving check")):
                if r["status"] != "ok":
                    raise RuntimeError(f"the {what} run of {v.name} was refused: {r['message']}")
            dpos, drot = pose_error(outputs, chk["y"], outputs, ref["y"], groups)
            refs[v.name] = (ref, float(dpos[-1]), float(drot[-1]), float(np.sqrt(np.mean(dpos ** 2))))

        # The grid (timed, one at a time).
        grid = [(v, i["name"], label, sets) for v in variants for i in ints for label, sets in _settings(ctx, i["name"], i["adaptive"])]
        rows, points = [], []
        for v, integ, label, sets in progress(grid, f"{scene}: grid (timed)"):
            r = go(v, integ, sets, timed=True)
            ref = refs[v.name][0]
            pts = v.total_points()
            per_s = r["wall_step_s"] / dur
            if r["status"] == "discard":
                rows.append([integ, f"{v.spacing:g} ({pts})", label, f"refused (fmi2Discard, t ≈ {r['t'][-1]:.3g} s)", per_s, "–", "–", "–"])
                continue
            dpos, drot = pose_error(outputs, r["y"], outputs, ref["y"], groups)
            rms = float(np.sqrt(np.mean(dpos ** 2)))
            rows.append([integ, f"{v.spacing:g} ({pts})", label, "ok", per_s, float(dpos[-1]), float(drot[-1]), rms])
            points.append((integ, v.spacing, label, per_s, rms, float(dpos[-1])))

        # Model Exchange under a host's own solver (fmpy's CVode), timed one at a time.
        tols = CVODE_TOLERANCES if not ctx.quick else CVODE_TOLERANCES[1:2]
        for v, rtol in progress([(v, t) for v in variants for t in tols], f"{scene}: CVode (ME)"):
            status, message, wall, y = _cvode_run(v, dur, comm, rtol, inputs, outputs)
            pts, label, per_s = v.total_points(), f"rtol {rtol:g}", wall / dur
            if status != "ok":
                rows.append([CVODE, f"{v.spacing:g} ({pts})", label, f"failed ({message})", per_s, "–", "–", "–"])
                continue
            dpos, drot = pose_error(outputs, np.array(y), outputs, refs[v.name][0]["y"], groups)
            rms = float(np.sqrt(np.mean(dpos ** 2)))
            rows.append([CVODE, f"{v.spacing:g} ({pts})", label, "ok", per_s, float(dpos[-1]), float(drot[-1]), rms])
            points.append((CVODE, v.spacing, label, per_s, rms, float(dpos[-1])))

        # Model (spacing) error: each spacing's reference against the finest one's.
        finest = refs[variants[-1].name][0]
        model_rows = []
        for v in variants:
            ref = refs[v.name]
            dpos, drot = pose_error(outputs, ref[0]["y"], outputs, finest["y"], groups)
            model_rows.append([f"{v.spacing:g}", v.total_points(), ref[1], ref[3], float(dpos[-1]), float(drot[-1]), float(np.sqrt(np.mean(dpos ** 2)))])

        png = f"work_precision_{scene}.png"
        _plot(ctx, scene, points, refs, variants, png)
        sections.append(f"## {scene}\n\n{dur:g} s simulated"
                        + (f", finger {spec['inputs'].replace('_', ' ')} of the pushing study" if spec.get("inputs") else "")
                        + f"; outputs compared every {comm * 1000:g} ms: {', '.join('`' + o + '`' for o in outputs)}.\n\n"
                        + f"![work–precision {scene}]({png})\n\n"
                        + table(["integrator", "spacing m (points)", "step", "status", "time per simulated s (s)",
                                 "final position error (m)", "final rotation error (rad)", "trajectory RMS position error (m)"], rows)
                        + "\n\nReference per spacing, and the spacing (model) error against the finest spacing's reference:\n\n"
                        + table(["spacing m", "points", "reference check: final position diff (m)", "reference check: RMS diff (m)",
                                 "vs finest spacing: final position (m)", "vs finest: final rotation (rad)", "vs finest: RMS position (m)"], model_rows))
        ok = [p for p in points]
        if ok:
            fastest = min(ok, key=lambda p: p[3])
            best = min(ok, key=lambda p: p[4] if p[4] > 0 else np.inf)
            summary.append(f"{scene}: fastest run {fmt(fastest[3])} s per simulated s ({fastest[0]}, {fastest[2]}, spacing {fastest[1]:g}, RMS error {fmt(fastest[4])} m); "
                           f"smallest error {fmt(best[4])} m ({best[0]}, {best[2]}, spacing {best[1]:g}, {fmt(best[3])} s per simulated s)")
    text = ["# Work–precision: error against run time", "",
            f"Machine: {machine_line()}; other builds may have shared the cores (the times are indicative; the ratios between rows are what to read).",
            "",
            "Each run goes through the FMU's C ABI (`examples/report_host.rs` calls the crate's exported `fmi2*` functions; "
            "time = wall time inside `fmi2DoStep` only, per simulated second). Errors are against a reference on the same scene and spacing: "
            f"{ref_text}, checked by halving (the reference check columns give the difference between the reference and the run at twice its step / ten times its tolerance: "
            "errors below that level are not resolved). Position error: Euclidean norm over every translational coordinate (slide joints, free-joint positions); "
            "rotation error: the largest hinge-angle or quaternion-angle difference. "
            "A run refused with `fmi2Discard` is listed but not plotted.",
            "",
            "Adaptive integrators (found by the report: their result depends on `solver.tolerance` and, at a tight tolerance, hardly on `solver.step`) are run at tolerances "
            f"{', '.join(f'{t:g}' for t in ADAPTIVE_TOLERANCES)} with `solver.step` = {max(S.STEPS_MS):g} ms, instead of the fixed steps.",
            "",
            f"`{CVODE}`: the same FMU in Model Exchange, integrated by the host: fmpy's CVode (SUNDIALS, BDF of variable order and step, "
            f"Newton on its own difference Jacobian) at relative tolerances {', '.join(f'{t:g}' for t in CVODE_TOLERANCES)}, outputs every communication step; "
            "its time is the whole `simulate_fmu` call, fmpy's Python loop and every `fmi2*` call through ctypes included, "
            "so it is an upper bound of what a compiled host would spend.",
            ""] + [x + "\n" for x in sections]
    write(ctx, "work_precision.md", "\n".join(text))
    ctx.figures["work_precision"] = summary
    return summary


def _plot(ctx, scene, points, refs, variants, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.5, 5))
    markers = ["o", "s", "^", "D", "v"]
    names = sorted({p[0] for p in points})
    colors = {n: f"C{i}" for i, n in enumerate(names)}
    floor = 1e-12
    for n in names:
        for k, v in enumerate(variants):
            pts = [p for p in points if p[0] == n and p[1] == v.spacing]
            if not pts:
                continue
            pts.sort(key=lambda p: p[3])
            ax.plot([p[3] for p in pts], [max(p[4], floor) for p in pts], marker=markers[k % len(markers)], color=colors[n],
                    ls="-", lw=1, label=f"{n}, spacing {v.spacing:g} m ({v.total_points()} pts)")
    for k, v in enumerate(variants):
        ax.axhline(max(refs[v.name][3], floor), color="gray", lw=0.6, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time per simulated second (s)")
    ax.set_ylabel("trajectory RMS position error (m)")
    ax.set_title(f"{scene}: error against run time (dotted: reference check level)")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(True, which="both", lw=0.3)
    fig.tight_layout()
    savefig(ctx, fig, png)
    log(f"{scene}: {len(points)} points plotted")
