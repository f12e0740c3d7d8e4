"""Stability maps: stiffness and ε1..3 × internal step × integrator, each cell classified as
stable, refused (fmi2Discard) or wrong (finished, but far from the converged reference)."""
import numpy as np

from . import scenes as S
from .common import (integrators, machine_line, pose_error, pose_groups, reference_integrator,
                     savefig, scene_exists, table, write)

CODES = {"stable": "S", "wrong": "W", "refused": "R"}
COLORS = {"stable": "#4caf50", "wrong": "#ff9800", "refused": "#e53935"}
BOUND = 1e3  # m or rad: a coordinate beyond this is wrong whatever the reference says


def _grid(ctx):
    if ctx.quick:
        return dict(stiffness=[1e3, 1e9], stiff_steps=[1, 50], eps=[1e-9, 10.0], eps_steps=[2, 50])
    return dict(stiffness=S.STIFFNESS, stiff_steps=S.STIFF_STEPS_MS, eps=S.EPS_VALUES, eps_steps=S.EPS_STEPS_MS)


def run(ctx):
    ints = integrators(ctx)
    names = [i["name"] for i in ints]
    ref_name, ref_adaptive, ref_text = reference_integrator(ctx)
    g = _grid(ctx)
    sections, summary = [], []
    for spec in S.STABILITY:
        if not scene_exists(spec["scene"]):
            ctx.note(f"stability: scene {spec['scene']} is not in resources/scenes yet: skipped")
            continue
        v = ctx.variant(spec["scene"], spec.get("spacing"))
        groups = pose_groups(v.variables())
        outputs = groups[0] + groups[1] + [c for q in groups[2] for c in q]
        dur = spec["duration"] if not ctx.quick else min(spec["duration"], 0.15)
        for param, values, steps in (("stiffness", g["stiffness"], g["stiff_steps"]),
                                     ("eps1", g["eps"], g["eps_steps"]),
                                     ("eps2", g["eps"], g["eps_steps"]),
                                     ("eps3", g["eps"], g["eps_steps"])):
            def sim(value, integ, h_ms, extra=None):
                h = h_ms / 1000
                comm = h * max(1, int(np.ceil(0.01 / h - 1e-9)))
                d = comm * max(1, int(np.ceil(dur / comm - 1e-9)))
                sets = dict(spec["sets"], **{f"scm.{param}": value, "solver.step": h}, **(extra or {}))
                r = ctx.host_run(v, d, comm, sets=sets, strings={"solver.integrator": integ}, outputs=outputs)
                r["duration"] = d
                return r

            # References: halve the step of the reference integrator until two runs agree.
            def reference(value):
                h, prev, history = 0.5, None, []
                floor = 0.5 / 2 ** (1 if ctx.quick else (5 if spec["scene"] != "t_push" else 4))
                extra = {"solver.tolerance": 1e-10} if ref_adaptive else None
                while True:
                    r = sim(value, ref_name, h, extra)
                    if r["status"] == "ok" and prev is not None and abs(r["duration"] - prev["duration"]) < 1e-12:
                        dpos, drot = pose_error(outputs, r["y"], outputs, prev["y"], groups)
                        history.append((h, float(dpos[-1]), float(drot[-1])))
                        if dpos[-1] < spec["tol_pos"] / 10 and drot[-1] < spec["tol_rot"] / 10:
                            return r, h, True, history
                    if h / 2 < floor:
                        return (r if r["status"] == "ok" else prev), h, False, history
                    prev = r if r["status"] == "ok" else None
                    h /= 2

            refs = ctx.parallel(reference, values, f"{spec['label']} {param}: references")
            cells = [(vi, integ, h) for vi in range(len(values)) for integ in names for h in steps]

            def classify(cell):
                vi, integ, h = cell
                r = sim(values[vi], integ, h)
                if r["status"] == "discard":
                    return "refused"
                ref = refs[vi][0]
                if ref is None:
                    raise RuntimeError(f"{spec['label']}: no reference for {param} = {values[vi]:g} (every reference run was refused)")
                if np.max(np.abs(r["y"])) > BOUND:
                    return "wrong"
                # Compare at the last output time both runs share, up to the reference's end: a
                # step of 8 or 16 ms communicates every 16 ms and the reference every 10 ms, so
                # they meet every 80 ms (0.48 s of a 0.5 s drop); a cell longer than the
                # reference (h > duration) is compared at the reference's end.
                shared = [(i, int(np.argmin(np.abs(ref["t"] - t)))) for i, t in enumerate(r["t"]) if t <= ref["t"][-1] + 1e-9]
                shared = [(i, j) for i, j in shared if abs(ref["t"][j] - r["t"][i]) <= 1e-9 and r["t"][i] > 0]
                if not shared:
                    raise RuntimeError(f"{spec['label']}: no output time shared with the reference ({integ}, {h} ms)")
                k, j = shared[-1]
                dpos, drot = pose_error(outputs, r["y"][k:k + 1], outputs, ref["y"][j:j + 1], groups)
                return "stable" if dpos[-1] <= spec["tol_pos"] and drot[-1] <= spec["tol_rot"] else "wrong"

            cls = ctx.parallel(classify, cells, f"{spec['label']} {param}: cells")
            grid = {c: k for c, k in zip(cells, cls)}
            png = f"stability_{spec['scene']}_{param}.png"
            _plot(ctx, spec, param, values, steps, names, grid, png)
            unit = {"stiffness": "N/m", "eps1": "m²", "eps2": "m", "eps3": "m"}[param]
            rows = [[f"{val:g}"] + [" ".join(CODES[grid[(vi, n, h)]] for n in names) for h in steps]
                    + [f"{refs[vi][1]:g} ms" + ("" if refs[vi][2] else " (not converged)")]
                    for vi, val in enumerate(values)]
            counts = {k: sum(1 for c in cls if c == k) for k in CODES}
            sections.append(f"## {spec['label']}: {param} ({unit}) × internal step\n\n![{png}]({png})\n\n"
                            f"Cells: {counts['stable']} stable, {counts['refused']} refused, {counts['wrong']} wrong. "
                            f"Each cell lists the integrators in the order {', '.join('`' + n + '`' for n in names)}.\n\n"
                            + table([f"{param} ({unit})"] + [f"{h:g} ms" for h in steps] + ["reference step"], rows))
            summary.append((spec["label"], param, counts, grid, values, steps, names))
    text = ["# Stability on stiff and extreme cases", "",
            f"Machine: {machine_line()}.", "",
            "Scenes: **stiff drop** = `sphere_drop` with the 1 kg sphere 1 cm above the plane (start `ball.pos.z` = 0.06 m); "
            "**t_push** = the finger 2 mm below the T's stem, its position target 5 cm further in, so it strikes and pushes "
            "(at spacing 2.5 cm, 160 points, to keep the ε maps short: at large ε nothing can be pruned and a pair costs O(I1·I2); see `scripts/report/scenes.py`). "
            "Each cell is one run through the FMU's C ABI with that parameter (the others at the scene's values), internal step and integrator, "
            "classified as **S** stable (finished, pose within tolerance of the reference at the last output time both share, at least 0.24 s in: "
            + "; ".join(f"{s['label']}: {s['tol_pos'] * 1000:g} mm and {s['tol_rot']:g} rad" for s in S.STABILITY)
            + "), **R** refused (`fmi2DoStep` returned `fmi2Discard`: the state went non-finite, or its energy grew by more than its inputs and losses explain, and the FMU kept its last good state), "
            f"**W** wrong (finished, but far from the reference or beyond {BOUND:g} m). A NaN reaching the host would stop the report as a bug; none did. "
            f"The reference at each parameter value is {ref_text}, starting at 0.5 ms and halved until two successive runs agree "
            "to a tenth of the tolerance (its step is in the last column).", ""] + [x + "\n" for x in sections]
    write(ctx, "stability.md", "\n".join(text))
    ctx.figures["stability"] = summary
    return summary


def _plot(ctx, spec, param, values, steps, names, grid, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch
    order = ["stable", "wrong", "refused"]
    cmap = ListedColormap([COLORS[k] for k in order])
    fig, axes = plt.subplots(1, len(names), figsize=(3.2 * len(names) + 1, 3.6), squeeze=False, sharey=True)
    for ax, n in zip(axes[0], names):
        m = np.array([[order.index(grid[(vi, n, h)]) for h in steps] for vi in range(len(values))])
        ax.imshow(m, cmap=cmap, vmin=0, vmax=2, origin="lower", aspect="auto")
        ax.set_xticks(range(len(steps)), [f"{h:g}" for h in steps], fontsize=7)
        ax.set_yticks(range(len(values)), [f"{x:.0e}" for x in values], fontsize=7)
        ax.set_xlabel("internal step (ms)")
        ax.set_title(n, fontsize=9)
    axes[0][0].set_ylabel(param)
    fig.legend(handles=[Patch(color=COLORS[k], label=k) for k in order], loc="upper right", fontsize=8)
    fig.suptitle(f"{spec['label']}: {param} × step", fontsize=10)
    fig.tight_layout(rect=(0, 0, 0.93, 1))
    savefig(ctx, fig, png)
