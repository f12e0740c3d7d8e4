"""System identification through the FMU: the contact parameters of `t_push` from the T-block's
trajectories, by least squares on the FMU's exact sensitivities.

    .venv/bin/python examples/inference/sysid.py            # after scripts/setup.sh
    .venv/bin/python examples/inference/sysid.py --quick    # one push, SCM's own data only

Two problems, each solved four ways:
- *SCM's own data*: trajectories of the Co-Simulation FMU at known parameters (friction 0.35,
  stiffness 5000 N/m, stiction velocity 0.07 m/s), fitted from the scene's values (0.5, 1e4,
  0.05): the answer is known, so every method's error in the parameters is measured.
- *MuJoCo's data*: the same pushes of the same file (`resources/scenes/t_push.xml`) in MuJoCo
  (its Euler, 2 ms): the SCM parameters that best reproduce MuJoCo's block.

The residual is the block's x, y and 0.1 m × yaw (a point 10 cm from its centre) at every 2 ms
step of every push; the unknowns are the logarithms of `scm.friction`, `scm.stiffness` and
`scm.stiction_velocity`, within bounds that keep the explicit step stable. Methods: scipy's
trust-region least squares (`least_squares`, method "trf") on the exact Jacobian of the
discrete trajectory (fmu_rollout.py: forward sensitivities from `fmi2GetDirectionalDerivative`),
the same solver on finite differences of the same trajectories (scipy's "2-point" and
"3-point"), and Nelder-Mead on the sum of squares. Every method steps the same Model Exchange
instance the same way, so their counts and times compare derivative sources, not simulators.

Writes reports/system_identification.md and reports/system_identification.png (or to --out).
"""
import argparse
import pathlib
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from fmu_rollout import ROOT, Rollout, co_simulation, pack  # noqa: E402

H = 0.002  # the scene's step (s)
PARAMS = ["scm.friction", "scm.stiffness", "scm.stiction_velocity"]
#: Bounds (friction, stiffness N/m, stiction velocity m/s), where the explicit 2 ms step stays
#: stable: the T's smoothed yaw friction is a damper F / v_s on its inertia I, inside
#: semi-implicit Euler's limit h F / (v_s I) < 2 for v_s > 0.039 m/s (0.2 N m, 5.2e-3 kg m²);
#: the contact spring on the 1 kg finger has h sqrt(k / m) = 0.63 at 1e5 N/m (limit 2). The
#: friction's range is a choice (materials between 0.05 and 2), not a stability limit.
BOUNDS = [(0.05, 2.0), (1e3, 1e5), (0.04, 0.5)]
TRUTH = {"scm.friction": 0.35, "scm.stiffness": 5000.0, "scm.stiction_velocity": 0.07}
YAW_ARM = 0.1  # m: the yaw residual is the motion of a point this far from the centre

#: Finger target waypoints (t s, x m, y m), the finger starting at (0, -0.25) below the T's
#: centre; linearly interpolated. A straight push would leave friction unseen: these slide the
#: finger along the T's faces.
PUSHES = {
    "stem, off-centre": [(0.0, 0.0, -0.25), (0.3, 0.015, -0.18), (1.2, 0.015, -0.07),
                         (1.6, 0.015, -0.07)],
    "stem, sideways": [(0.0, 0.0, -0.25), (0.4, 0.09, -0.25), (0.7, 0.09, -0.09),
                       (1.4, -0.01, -0.09), (1.6, -0.01, -0.09)],
    "left wing, up": [(0.0, 0.0, -0.25), (0.4, -0.085, -0.2), (0.7, -0.085, -0.05),
                      (1.4, -0.085, 0.05), (1.6, -0.085, 0.05)],
}


def scene_xml():
    """The bundled t_push at 2.5 cm point spacing (160 points instead of 856: the examples run
    many trajectories; the method and every other setting are the scene's)."""
    xml = (ROOT / "resources" / "scenes" / "t_push.xml").read_text()
    fine = '<numeric name="scm_spacing" data="0.01"/>'
    assert fine in xml, "t_push.xml no longer sets scm_spacing to 0.01"
    return xml.replace(fine, '<numeric name="scm_spacing" data="0.025"/>')


def controls(waypoints, duration):
    """One row (act_x.ctrl, act_y.ctrl) per step: the finger's target displacement from its start."""
    w = np.array(waypoints)
    t = np.arange(int(round(duration / H))) * H
    return np.stack([np.interp(t, w[:, 0], w[:, 1]), np.interp(t, w[:, 0], w[:, 2]) + 0.25], 1)


def observed(X):
    """The block's x, y and arm × yaw, from states or MuJoCo's qpos (both t_x, t_y, t_yaw first)."""
    return np.stack([X[:, 0], X[:, 1], YAW_ARM * X[:, 2]], 1)


def mujoco_data(pushes):
    """The block's observed trajectory under each push in MuJoCo (the scene's file, 2 ms Euler)."""
    import mujoco
    model = mujoco.MjModel.from_xml_path(str(ROOT / "resources" / "scenes" / "t_push.xml"))
    assert model.opt.timestep == H and model.nu == 2
    out = []
    for U in pushes:
        data = mujoco.MjData(model)
        Q = [data.qpos.copy()]
        for u in U:
            data.ctrl[:] = u
            mujoco.mj_step(model, data)
            Q.append(data.qpos.copy())
        out.append(observed(np.array(Q)))
    return out


class Problem:
    """Residuals and their Jacobian in the log-parameters, counting what each costs."""

    def __init__(self, rollout, pushes, data):
        self.r, self.pushes, self.data = rollout, pushes, data
        self.x0 = rollout.x0()
        self.rollouts = {"plain": 0, "with sensitivities": 0}

    def _set(self, theta):
        self.r.set_parameters(dict(zip(PARAMS, np.exp(theta))))

    def residual(self, theta):
        self._set(theta)
        res = []
        for U, Y in zip(self.pushes, self.data):
            X, _, _ = self.r.rollout(self.x0, U)
            self.rollouts["plain"] += 1
            res.append((observed(X) - Y).ravel())
        return np.concatenate(res)

    def jacobian(self, theta):
        """d residual / d log p, exactly: the trajectories' sensitivities times p."""
        self._set(theta)
        p = np.exp(theta)
        cols = []
        for U in self.pushes:
            _, S, _ = self.r.rollout(self.x0, U, sensitivities=PARAMS)
            self.rollouts["with sensitivities"] += 1
            dobs = np.stack([S[:, 0, :], S[:, 1, :], YAW_ARM * S[:, 2, :]], 1)  # steps × 3 × np
            cols.append((dobs * p).reshape(-1, len(PARAMS)))
        return np.concatenate(cols)


def solve(problem, method, theta0):
    """Runs one method from theta0; returns its row of the table."""
    from scipy.optimize import least_squares, minimize
    lo, hi = np.log(np.array(BOUNDS)).T
    problem.rollouts = {"plain": 0, "with sensitivities": 0}
    calls0 = dict(problem.r.calls)
    t0 = time.perf_counter()
    if method == "Nelder-Mead":
        def cost(th):
            return 0.5 * float(np.sum(problem.residual(th) ** 2))

        res = minimize(cost, theta0, method="Nelder-Mead", bounds=list(zip(lo, hi)),
                       options=dict(xatol=1e-7, fatol=1e-16, maxfev=800))
        theta, iters = res.x, res.nit
    else:
        jac = {"exact": problem.jacobian, "finite differences (2-point)": "2-point",
               "finite differences (3-point)": "3-point"}[method]
        res = least_squares(problem.residual, theta0, jac=jac, bounds=(lo, hi), method="trf",
                            xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=100)
        theta, iters = res.x, res.njev
    wall = time.perf_counter() - t0
    r = problem.residual(theta)  # the final error, not counted
    calls = {k: problem.r.calls[k] - calls0[k] for k in calls0}
    return dict(method=method, iterations=int(iters), rollouts=dict(problem.rollouts), calls=calls,
                wall=wall, rms=float(np.sqrt(np.mean(r ** 2))), params=dict(zip(PARAMS, np.exp(theta))))


def run(pushes, quick=False, out=None):
    """Both problems (SCM's own data only with `quick`); returns {problem: [rows]}."""
    out = pathlib.Path(out) if out else None
    work = pathlib.Path(__import__("tempfile").mkdtemp(prefix="scm_sysid_"))
    fmu = pack(scene_xml(), work, "t_push_sysid")
    r = Rollout(fmu, H)
    theta0 = np.log([float(r.start[p]) for p in PARAMS])
    Us = [controls(w, duration) for w, duration in pushes]
    own = [observed(co_simulation(fmu, H, U, parameters=TRUTH, outputs=r.states)) for U in Us]
    problems = {"SCM's own data (known parameters)": own}
    if not quick:
        problems["MuJoCo's data"] = mujoco_data(Us)
    results = {}
    for name, data in problems.items():
        prob = Problem(r, Us, data)
        results[name] = dict(start_rms=float(np.sqrt(np.mean(prob.residual(theta0) ** 2))), rows=[])
        methods = ["exact", "finite differences (2-point)", "finite differences (3-point)", "Nelder-Mead"]
        for m in methods:
            row = solve(prob, m, theta0)
            results[name]["rows"].append(row)
            print(f"{name}: {m}: {row['iterations']} it, {row['wall']:.2f} s, rms {row['rms']:.3g} m, "
                  f"{ {k: round(v, 5) for k, v in row['params'].items()} }", flush=True)
        results[name]["data"] = data
        results[name]["fits"] = {}
        for row in results[name]["rows"]:
            r.set_parameters(row["params"])
            results[name]["fits"][row["method"]] = [observed(r.rollout(r.x0(), U)[0]) for U in Us]
        r.set_parameters({p: float(r.start[p]) for p in PARAMS})
        results[name]["initial"] = [observed(r.rollout(r.x0(), U)[0]) for U in Us]
    r.close()
    if out:
        write_report(results, out, pushes)
    return results


def write_report(results, out, pushes):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    out.mkdir(parents=True, exist_ok=True)
    lines = ["# System identification through the FMU", "",
             "Generated by `examples/inference/sysid.py` (see its docstring for the method). Scene: "
             "`resources/scenes/t_push.xml` at 2.5 cm point spacing, semi-implicit Euler at 2 ms, "
             f"{len(pushes)} pushes of {pushes[0][1]} s ({', '.join(PUSHES)}). Unknowns: log of "
             f"{', '.join(f'`{p}`' for p in PARAMS)}, bounded by {BOUNDS}. Residual: block x, y "
             f"and {YAW_ARM} m × yaw at every step. Rollouts: trajectories simulated (a rollout "
             "with sensitivities also calls `fmi2GetDirectionalDerivative` once per parameter "
             "per step). FMU calls: `fmi2GetDerivatives` + `fmi2GetDirectionalDerivative`. "
             "Wall time on this machine (2 cores, other work possibly running), in one run.", ""]
    for name, res in results.items():
        lines += [f"## {name}", "", f"RMS error at the scene's parameters: {res['start_rms']:.3g} m.", ""]
        head = "| method | iterations | rollouts (plain + with sensitivities) | FMU calls | wall time (s) | final RMS error (m) | " + \
            " | ".join(PARAMS) + " |"
        lines += [head, "|" + " --- |" * (6 + len(PARAMS))]
        for row in res["rows"]:
            ro = row["rollouts"]
            lines.append(f"| {row['method']} | {row['iterations']} | {ro['plain']} + {ro['with sensitivities']} | "
                         f"{row['calls']['derivatives']} + {row['calls']['directional']} | {row['wall']:.2f} | "
                         f"{row['rms']:.3g} | " + " | ".join(f"{row['params'][p]:.6g}" for p in PARAMS) + " |")
        if "known" in name:
            lines.append("| (truth) | – | – | – | – | – | " + " | ".join(f"{TRUTH[p]:.6g}" for p in PARAMS) + " |")
        exact = res["rows"][0]
        lines.append("")
        for row in res["rows"][1:]:
            lines.append(f"- speed-up of the exact Jacobian over {row['method']}: "
                         f"{row['wall'] / exact['wall']:.2f} (its wall time over the exact one's; "
                         f"below 1 the exact run was slower), final error {row['rms']:.3g} m against "
                         f"{exact['rms']:.3g} m.")
        lines.append("")
    fig, axes = plt.subplots(len(results), 3, figsize=(13, 3.6 * len(results)), squeeze=False)
    for i, (name, res) in enumerate(results.items()):
        for j, label in enumerate(["x (m)", "y (m)", f"{YAW_ARM} m × yaw (m)"]):
            ax = axes[i][j]
            for k in range(len(res["data"])):
                t = np.arange(len(res["data"][k])) * H
                ax.plot(t, res["data"][k][:, j], "k-", lw=2, label="data" if k == 0 else None)
                ax.plot(t, res["initial"][k][:, j], "C1--", label="scene's parameters" if k == 0 else None)
                ax.plot(t, res["fits"]["exact"][k][:, j], "C0:", lw=2, label="fitted (exact)" if k == 0 else None)
            ax.set_title(f"{name}: {label}", fontsize=9)
            ax.set_xlabel("t (s) within each push")
            if j == 0:
                ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "system_identification.png", dpi=110)
    lines += ["![data, the scene's parameters and the exact fit](system_identification.png)", ""]
    (out / "system_identification.md").write_text("\n".join(lines))


def default_pushes(quick):
    """(waypoints, duration) of every push; with `quick`, the sideways push alone."""
    pushes = [(w, 1.6) for w in PUSHES.values()]
    return pushes[1:2] if quick else pushes


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="one push, SCM's own data only")
    ap.add_argument("--out", default=str(ROOT / "reports"), help="folder of the report (default reports/)")
    args = ap.parse_args()
    run(default_pushes(args.quick), quick=args.quick, out=args.out)


if __name__ == "__main__":
    main()
