"""Trajectory optimization through the FMU: the finger's path that pushes `t_push`'s T-block to a
target pose, by a gradient method on the exact step Jacobians of the Model Exchange FMU.

    .venv/bin/python examples/inference/trajopt.py            # after scripts/setup.sh
    .venv/bin/python examples/inference/trajopt.py --quick    # a shorter plan, fewer iterations

The plan is the finger's target (act_x.ctrl, act_y.ctrl) at K knots, linearly interpolated in
time (2K unknowns). The cost is the block's final pose error, x and y in metres and 0.1 m × yaw,
squared, plus a small penalty on the plan's second differences and on the block's final speed.
Its gradient comes by one backward (adjoint) pass over the step Jacobians d(x_{k+1})/d(x_k, u_k)
that fmu_rollout.py assembles from `fmi2GetDirectionalDerivative` (one call per state and input
per step, however many knots), and L-BFGS-B (scipy) descends on it. Compared with the same
L-BFGS-B on finite-difference gradients (scipy's, one rollout per unknown) and with the
cross-entropy method (zeroth order: sample plans, keep the best, refit a Gaussian).

Why not direct multiple shooting in CasADi/IPOPT: CasADi evaluates the FMU's right-hand side,
not its step, so every 2 ms step of the horizon becomes a shooting node (hundreds of nodes of 10
states, with contact making each a nonconvex constraint); single shooting on the exact discrete
trajectory needs only its gradient, which the adjoint gives at the cost of about a dozen
evaluations per step. The plan found is replayed in the Co-Simulation FMU (its own step), which
must land the block where the optimizer says.

Writes reports/trajectory_optimization.md and reports/trajectory_optimization.png (or to --out).
"""
import argparse
import pathlib
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from fmu_rollout import ROOT, Rollout, co_simulation, pack  # noqa: E402
from sysid import H, YAW_ARM, scene_xml  # noqa: E402

#: The target pose of the block (x m, y m, yaw rad) from its start at (0, 0, 0).
TARGET = (0.02, 0.05, 0.15)
SMOOTH = 1e-3  # weight of the plan's second differences (m² per m² of target change)
STILL = 1e-3  # weight of the block's final speed (s² m² per m²)
REACH = 0.35  # |target displacement| bound of every knot, m


def interpolation(n_steps, knots, duration):
    """W (steps × knots): control at step k = W[k] @ knot values (linear in time, held at the
    last knot)."""
    tk = np.linspace(0.0, duration, knots)
    t = np.arange(n_steps) * H
    W = np.zeros((n_steps, knots))
    for j in range(knots):
        e = np.zeros(knots)
        e[j] = 1.0
        W[:, j] = np.interp(t, tk, e)
    return W


def initial_plan(knots):
    """A straight push up the stem: the finger's target reaches the stem's tip (10 cm up) in the
    first quarter of the horizon, then rises 10 cm more."""
    s = np.linspace(0.0, 1.0, knots)
    return np.stack([0.0 * s, np.interp(s, [0.0, 0.25, 1.0], [0.0, 0.1, 0.2])], 1)


class Planner:
    """The cost of a plan and its exact gradient, counting rollouts and FMU calls."""

    def __init__(self, rollout, knots, duration):
        self.r, self.knots, self.duration = rollout, knots, duration
        self.n = int(round(duration / H))
        self.W = interpolation(self.n, knots, duration)
        self.x0 = rollout.x0()
        self.rollouts = {"plain": 0, "with Jacobians": 0}
        self.history = []  # (perf_counter, cost) of every evaluation
        # The block's pose and velocity in the state vector.
        self.pose = [rollout.states.index(n) for n in ("t_x.q", "t_y.q", "t_yaw.q")]
        self.vel = [rollout.states.index(n) for n in ("t_x.v", "t_y.v", "t_yaw.v")]
        self.scale = np.array([1.0, 1.0, YAW_ARM])

    def controls(self, z):
        return self.W @ z.reshape(self.knots, 2)

    def _terminal(self, x):
        """Terminal cost and its gradient in the final state."""
        e = (x[self.pose] - np.array(TARGET)) * self.scale
        w = x[self.vel] * self.scale
        g = np.zeros_like(x)
        g[self.pose] = 2 * e * self.scale
        g[self.vel] = 2 * STILL * w * self.scale
        return float(e @ e + STILL * w @ w), g

    def _smooth(self, z):
        P = z.reshape(self.knots, 2)
        d2 = P[2:] - 2 * P[1:-1] + P[:-2]
        g = np.zeros_like(P)
        g[2:] += 2 * SMOOTH * d2
        g[1:-1] -= 4 * SMOOTH * d2
        g[:-2] += 2 * SMOOTH * d2
        return float(SMOOTH * np.sum(d2 ** 2)), g.ravel()

    def cost(self, z):
        X, _, _ = self.r.rollout(self.x0, self.controls(z))
        self.rollouts["plain"] += 1
        c = self._terminal(X[-1])[0] + self._smooth(z)[0]
        self.history.append((time.perf_counter(), c))
        return c

    def cost_and_gradient(self, z):
        """The exact gradient: one rollout with step Jacobians, then the adjoint pass
        lam_k = A_k^T lam_{k+1}, dC/du_k = B_k^T lam_{k+1}."""
        X, _, J = self.r.rollout(self.x0, self.controls(z), jacobians=True)
        self.rollouts["with Jacobians"] += 1
        c, lam = self._terminal(X[-1])
        nx = self.r.nx
        dU = np.empty((self.n, self.r.nu))
        for k in range(self.n - 1, -1, -1):
            dU[k] = J[k, :, nx:].T @ lam
            lam = J[k, :, :nx].T @ lam
        cs, gs = self._smooth(z)
        self.history.append((time.perf_counter(), c + cs))
        return c + cs, (self.W.T @ dU).ravel() + gs

    def final_pose(self, z):
        return self.r.rollout(self.x0, self.controls(z))[0][-1][self.pose]


def cem(planner, z0, iterations, population, elites, sigma, seed=0):
    """The cross-entropy method: sample plans around a Gaussian, refit it to the best."""
    rng = np.random.default_rng(seed)
    mean, std = z0.copy(), np.full_like(z0, sigma)
    best, best_cost = z0.copy(), planner.cost(z0)
    for _ in range(iterations):
        Z = np.clip(mean + std * rng.standard_normal((population, len(z0))), -REACH, REACH)
        costs = np.array([planner.cost(z) for z in Z])
        order = np.argsort(costs)[:elites]
        if costs[order[0]] < best_cost:
            best, best_cost = Z[order[0]].copy(), costs[order[0]]
        mean, std = Z[order].mean(0), Z[order].std(0) + 1e-4
    return best, iterations


def solve(planner, method, z0, budget):
    """Runs one method; returns its row (the plan included)."""
    from scipy.optimize import minimize
    planner.rollouts = {"plain": 0, "with Jacobians": 0}
    planner.history = []
    calls0 = dict(planner.r.calls)
    bounds = [(-REACH, REACH)] * len(z0)
    t0 = time.perf_counter()
    if method == "exact gradient (adjoint)":
        res = minimize(planner.cost_and_gradient, z0, jac=True, method="L-BFGS-B", bounds=bounds,
                       options=dict(maxiter=budget["iterations"], ftol=1e-12, gtol=1e-10))
        z, iters = res.x, res.nit
    elif method == "finite-difference gradient":
        res = minimize(planner.cost, z0, method="L-BFGS-B", bounds=bounds,
                       options=dict(maxiter=budget["iterations"], ftol=1e-12, gtol=1e-10))
        z, iters = res.x, res.nit
    else:
        z, iters = cem(planner, z0, budget["cem_iterations"], budget["population"], budget["elites"],
                       budget["sigma"])
    wall = time.perf_counter() - t0
    calls = {k: planner.r.calls[k] - calls0[k] for k in calls0}
    rollouts = dict(planner.rollouts)
    # The best cost so far against the time it took.
    t, c = np.array(planner.history).T
    history = np.stack([t - t0, np.minimum.accumulate(c)], 1)
    pose = planner.final_pose(z)
    err = (pose - np.array(TARGET)) * planner.scale
    return dict(method=method, iterations=int(iters), rollouts=rollouts, calls=calls, wall=wall,
                cost=planner.cost(z), pose=pose, error=float(np.linalg.norm(err[:2])),
                yaw_error=float(abs(pose[2] - TARGET[2])), plan=z, history=history)


def time_to(row, cost):
    """Seconds until `row`'s method first reached `cost` (None: never)."""
    hit = row["history"][row["history"][:, 1] <= cost]
    return float(hit[0, 0]) if len(hit) else None


BUDGET = dict(iterations=80, cem_iterations=30, population=40, elites=6, sigma=0.03)
QUICK = dict(iterations=30, cem_iterations=6, population=16, elites=4, sigma=0.03)


def settings(quick):
    """The plan's resolution and horizon: 24 knots (one per 70 ms) over 1.6 s; 12 with `quick`."""
    return dict(knots=12 if quick else 24, duration=1.6, quick=quick)


def run(knots=24, duration=1.6, quick=False, out=None, methods=None, budget=None):
    """Plans with every method (`budget`: BUDGET, or QUICK with `quick`, unless given);
    returns (rows, the pose the initial plan reaches)."""
    work = pathlib.Path(__import__("tempfile").mkdtemp(prefix="scm_trajopt_"))
    fmu = pack(scene_xml(), work, "t_push_trajopt")
    r = Rollout(fmu, H)
    planner = Planner(r, knots, duration)
    z0 = initial_plan(knots).ravel()
    budget = budget or (QUICK if quick else BUDGET)
    rows = []
    start_pose = planner.final_pose(z0)
    for m in methods or ["exact gradient (adjoint)", "finite-difference gradient", "cross-entropy method"]:
        row = solve(planner, m, z0, budget)
        # The plan replayed by the Co-Simulation FMU, stepping itself.
        cs = co_simulation(fmu, H, planner.controls(row["plan"]), outputs=r.states)
        row["replay"] = cs
        row["replay_gap"] = float(np.abs(cs[-1][planner.pose] - row["pose"]).max())
        rows.append(row)
        print(f"{m}: {row['iterations']} it, {row['wall']:.2f} s, cost {row['cost']:.3g}, pose "
              f"{np.round(row['pose'], 4)}, |xy error| {row['error']:.3g} m, yaw error "
              f"{row['yaw_error']:.3g} rad", flush=True)
    r.close()
    if out:
        write_report(rows, pathlib.Path(out), knots, duration, start_pose, planner, budget)
    return rows, start_pose


def t_outline(x, y, yaw):
    """The T's outline (bar and stem) in the plane at pose (x, y, yaw)."""
    bar = np.array([(-0.125, 0.0125), (0.125, 0.0125), (0.125, 0.0625), (-0.125, 0.0625), (-0.125, 0.0125)])
    stem = np.array([(-0.025, -0.1375), (0.025, -0.1375), (0.025, 0.0325), (-0.025, 0.0325), (-0.025, -0.1375)])
    c, s = np.cos(yaw), np.sin(yaw)
    R = np.array([[c, -s], [s, c]])
    return [p @ R.T + (x, y) for p in (bar, stem)]


def _f(v):
    return f"{0.0 if abs(v) < 5e-5 else v:.4f}"


def write_report(rows, out, knots, duration, start_pose, planner, budget):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    out.mkdir(parents=True, exist_ok=True)
    exact = rows[0]
    lines = ["# Trajectory optimization through the FMU", "",
             "Generated by `examples/inference/trajopt.py` (see its docstring for the method). Scene: "
             "`resources/scenes/t_push.xml` at 2.5 cm point spacing, semi-implicit Euler at 2 ms, "
             f"horizon {duration} s ({planner.n} steps); plan: the finger's target at {knots} knots "
             f"({2 * knots} unknowns, within ±{REACH} m); target pose of the block: x {TARGET[0]} m, "
             f"y {TARGET[1]} m, yaw {TARGET[2]} rad; cost: squared pose error (yaw × {YAW_ARM} m) + "
             f"{SMOOTH} × the plan's squared second differences + {STILL} × the block's final speed "
             "squared. Start: a straight push up the stem, which leaves the block at "
             f"({start_pose[0]:.4f}, {start_pose[1]:.4f}, {start_pose[2]:.4f}). "
             f"Budgets: L-BFGS-B at most {budget['iterations']} iterations; cross-entropy method "
             f"{budget['cem_iterations']} iterations of {budget['population']} plans, {budget['elites']} "
             f"elites, initial σ {budget['sigma']} m. Wall time on this machine (2 cores, other work "
             "possibly running), in one run. The replay gap is the largest difference of the final "
             "pose when the Co-Simulation FMU steps the plan itself.", "",
             "| method | iterations | rollouts (plain + with Jacobians) | FMU calls (derivatives + directional) "
             "| wall time (s) | final cost | final pose (x, y, yaw) | xy error (m) | yaw error (rad) | replay gap |",
             "|" + " --- |" * 10]
    for row in rows:
        ro, ca = row["rollouts"], row["calls"]
        lines.append(f"| {row['method']} | {row['iterations']} | {ro['plain']} + {ro['with Jacobians']} | "
                     f"{ca['derivatives']} + {ca['directional']} | {row['wall']:.2f} | {row['cost']:.3g} | "
                     f"({row['pose'][0]:.4f}, {row['pose'][1]:.4f}, {row['pose'][2]:.4f}) | {row['error']:.3g} | "
                     f"{row['yaw_error']:.3g} | {row['replay_gap']:.2g} |")
    lines.append("")
    for row in rows[1:]:
        lines.append(f"- speed-up of the exact gradient over the {row['method']}: "
                     f"{row['wall'] / exact['wall']:.2f} in wall time (its time over the exact run's), "
                     f"final cost {row['cost']:.3g} against {exact['cost']:.3g}.")
    for row in rows[1:]:
        # Time to quality: both runs' first time at or below the worse of their final costs.
        goal = max(row["cost"], exact["cost"])
        t_exact, t_other = time_to(exact, goal), time_to(row, goal)
        if t_exact is not None and t_other is not None:
            lines.append(f"- to a cost of {goal:.3g} (the worse of the two final costs): exact gradient "
                         f"{t_exact:.2f} s, {row['method']} {t_other:.2f} s, a speed-up of "
                         f"{t_other / max(t_exact, 1e-9):.1f}.")
    lines += ["", "![the pushes seen from above, and the best cost against wall time](trajectory_optimization.png)", ""]
    (out / "trajectory_optimization.md").write_text("\n".join(lines))
    fig, axes = plt.subplots(1, len(rows) + 1, figsize=(5 * (len(rows) + 1), 5), squeeze=False)
    conv = axes[0][-1]
    for row in rows:
        conv.semilogy(row["history"][:, 0], row["history"][:, 1], label=row["method"])
    conv.set_xlabel("wall time (s)")
    conv.set_ylabel("best cost so far")
    conv.legend(fontsize=8)
    conv.set_title("convergence", fontsize=9)
    for ax, row in zip(axes[0], rows):
        for poly in t_outline(0, 0, 0):
            ax.fill(poly[:, 0], poly[:, 1], color="0.85")
        for poly in t_outline(*TARGET):
            ax.plot(poly[:, 0], poly[:, 1], "g--", lw=1.5)
        X = row["replay"]
        for poly in t_outline(*X[-1][planner.pose]):
            ax.plot(poly[:, 0], poly[:, 1], "C0-", lw=1.5)
        fx, fy = X[:, 3], X[:, 4] - 0.25
        ax.plot(fx, fy, "C3-", lw=1, label="finger")
        ax.plot(X[:, 0], X[:, 1], "C0-", lw=1, label="block's centre")
        ax.set_aspect("equal")
        ax.set_title(f"{row['method']}\nxy error {row['error'] * 100:.2g} cm, yaw error {row['yaw_error']:.2g} rad",
                     fontsize=9)
        ax.legend(fontsize=8, loc="lower right")
    fig.suptitle("grey: start, green dashed: target, blue: reached (Co-Simulation replay)", fontsize=9)
    fig.tight_layout()
    fig.savefig(out / "trajectory_optimization.png", dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="a shorter plan, fewer iterations")
    ap.add_argument("--out", default=str(ROOT / "reports"), help="folder of the report (default reports/)")
    args = ap.parse_args()
    run(**settings(args.quick), out=args.out)


if __name__ == "__main__":
    main()
