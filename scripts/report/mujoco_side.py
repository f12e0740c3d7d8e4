"""Side by side with MuJoCo: the two-sphere force profile (the paper's Fig. 1) and planar
pushing (the paper's Table I), from the same MJCF files. SCM runs through its FMU in fmpy."""
import time

import numpy as np

from . import scenes as S
from .common import (HAVE_MUJOCO, fmt, integrators, log, machine_line, mujoco_integrator, progress,
                     savefig, scene_exists, table, write)

NO_MUJOCO = "n/a (mujoco not installed in this environment)"


class Fmu:
    """An FMU instantiated once in fmpy (Co-Simulation), reset between runs."""

    def __init__(self, variant, name):
        from fmpy.fmi2 import FMU2Slave
        self.md = variant.variables()
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=str(variant.dir),
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate()
        self.fresh = True

    def start(self, reals=None, strings=None, stop=None):
        if not self.fresh:
            self.fmu.reset()
        self.fresh = False
        self.fmu.setupExperiment(startTime=0.0, stopTime=stop)
        for n, x in (strings or {}).items():
            self.fmu.setString([self.vr[n]], [x])
        for n, x in (reals or {}).items():
            self.fmu.setReal([self.vr[n]], [float(x)])
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def get(self, names):
        return self.fmu.getReal([self.vr[n] for n in names])

    def set(self, values):
        self.fmu.setReal([self.vr[n] for n in values], [float(x) for x in values.values()])

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


# ---- Fig. 1: the two-sphere force profile --------------------------------------------------------
def force_profile(ctx):
    if not scene_exists("sphere_pair"):
        ctx.note("force profile: sphere_pair.xml missing: skipped")
        return None
    v = ctx.variant("sphere_pair")
    fmu = Fmu(v, "fig1")
    pair = [n[: -len(".force.x")] for n in fmu.vr if n.startswith("contact.") and n.endswith(".force.x")][0]
    n = 21 if ctx.quick else 161
    y0 = 0.14  # the small sphere's body position along y (centres 0.14 m apart at q = 0)
    # (a) straight through: centre distance from 0.20 m down to 0.005 m; (b) past: x offset at
    # centre distance 0.14 m along y (1 cm overlap when aligned).
    paths = {
        "through": [(0.0, dist - y0) for dist in np.unique(np.r_[np.linspace(0.20, 0.005, n), 0.16, 0.15, 0.14])[::-1]],
        "past": [(x, 0.0) for x in np.linspace(-0.12, 0.12, n)],
    }
    scm = {}
    for name, pts in paths.items():
        out = []
        for x, y in progress(pts, f"force profile ({name}): SCM"):
            fmu.start(reals={"x.q": x, "y.q": y, "z.q": 0.0})
            fx, fy, fz, dist = fmu.get([f"{pair}.force.x", f"{pair}.force.y", f"{pair}.force.z", f"{pair}.distance"])
            out.append((-fx, -fy, -fz, dist))  # the FMU gives the force on the big sphere (first body)
        scm[name] = np.array(out)
    fmu.close()
    mj = {}
    if HAVE_MUJOCO:
        import mujoco
        m = mujoco.MjModel.from_xml_path(str(v.xml))
        d = mujoco.MjData(m)
        adr = [m.joint(j).qposadr[0] for j in ("x", "y", "z")]
        dof = [m.joint(j).dofadr[0] for j in ("x", "y", "z")]
        for name, pts in paths.items():
            out = []
            for x, y in pts:
                mujoco.mj_resetData(m, d)
                d.qpos[adr] = [x, y, 0.0]
                mujoco.mj_forward(m, d)
                f = d.qfrc_constraint[dof]  # slide axes are the world axes: the force on the small sphere
                out.append((f[0], f[1], f[2], 0.0))
            mj[name] = np.array(out)
    else:
        ctx.note("force profile: mujoco is not importable here: SCM curves only")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    dist = np.array([y0 + y for _, y in paths["through"]])
    a.plot(dist * 100, scm["through"][:, 1], label="SCM: force y on the small sphere")
    if mj:
        a.plot(dist * 100, mj["through"][:, 1], label="MuJoCo: force y", ls="--")
    a.axvline(15, color="gray", lw=0.5, ls=":")
    a.set_xlabel("centre distance (cm)   [touching at 15 cm; concentric at 0]")
    a.set_ylabel("force (N)")
    a.set_title("(a) moved straight in along y")
    a.legend(fontsize=8)
    xs = np.array([x for x, _ in paths["past"]])
    for k, (lab, ls) in enumerate((("x", "-"), ("y", "-"))):
        b.plot(xs * 100, scm["past"][:, k], label=f"SCM: force {lab}", color=f"C{k}")
        if mj:
            b.plot(xs * 100, mj["past"][:, k], label=f"MuJoCo: force {lab}", color=f"C{k}", ls="--")
    b.set_xlabel("x offset of the small sphere (cm), centres 14 cm apart along y")
    b.set_title("(b) moved past, 1 cm overlap at x = 0")
    b.legend(fontsize=8)
    fig.suptitle("sphere_pair.xml: force on the small sphere (r = 5 cm) near the fixed one (r = 10 cm), SCM (FMU) and MuJoCo")
    fig.tight_layout()
    savefig(ctx, fig, "force_profile.png")

    def row(label, arr):
        ti, pa = arr["through"], arr["past"]
        i14 = int(np.argmin(np.abs(dist - 0.14)))
        i15 = int(np.argmin(np.abs(dist - 0.15)))
        i16 = int(np.argmin(np.abs(dist - 0.16)))
        return [label, ti[i16, 1], ti[i15, 1], ti[i14, 1], float(np.max(np.abs(ti[:, 1]))), float(dist[np.argmax(np.abs(ti[:, 1]))] * 100),
                ti[-1, 1], float(np.max(np.abs(pa[:, 0]))), float(np.max(pa[:, 1]))]
    rows = [row("SCM", scm)] + ([row(f"MuJoCo {mujoco_version()}", mj)] if mj else [[f"MuJoCo"] + [NO_MUJOCO] * 8])
    text = ["# Two-sphere force profile (the paper's Fig. 1)", "",
            "The same `resources/scenes/sphere_pair.xml` is packed by `scm` and loaded by MuJoCo. The small sphere is placed by its slide joints "
            "(`x.q`, `y.q`, `z.q`; zero velocity) and the force on it is read without stepping: in SCM from the FMU's "
            "`contact.big.small.force.*` after initialization (negated: the FMU reports the force on the first body), in MuJoCo from "
            "`qfrc_constraint` of the three slide joints after `mj_forward` (their axes are the world axes).",
            "", "![force profile](force_profile.png)", "",
            table(["model", "Fy at 16 cm (N)", "Fy at 15 cm, touching (N)", "Fy at 14 cm, 1 cm overlap (N)", "largest Fy magnitude, straight in (N)",
                   "at distance (cm)", "Fy at 0.5 cm, nearly concentric (N)", "largest Fx magnitude, moving past (N)", "max Fy moving past (N)"], rows),
            "",
            reading(dist, scm["through"][:, 1])]
    write(ctx, "force_profile.md", "\n".join(text))
    ctx.figures["force_profile"] = rows
    return rows


def reading(dist, fy):
    """What the SCM profile shows, from the numbers (not assumed)."""
    inside = dist < 0.15
    sign_change = [float(dist[i]) for i in range(len(dist) - 1) if inside[i] and fy[i] > 0 >= fy[i + 1]]
    near = fy[-1]
    text = ("How to read it: SCM's force is a smooth function of the offset. It rises over a few ε3 (0.1 mm here) around the AOPC "
            "surfaces (whose face centres sit slightly inside the true spheres, so at the true touching distance it is still small) and "
            "grows with the overlap as k times the penetration of the deepest points. MuJoCo's is exactly zero until the spheres touch, has "
            "a kink there, and its size comes from its soft-constraint solver (solref/solimp defaults, scaled by the sphere's mass), not from "
            "a stiffness: the two agree in direction and in where the force starts, not in magnitude. ")
    if sign_change and near < 0:
        text += (f"Deeper than R − r = 5 cm (the small sphere wholly inside the big one) SCM's force reverses: it changes sign at a "
                 f"centre distance of about {sign_change[0] * 100:.2g} cm and then pulls the small sphere toward the centre "
                 f"({near:.3g} N at {dist[-1] * 100:.2g} cm): the deepest points of the small sphere are then on the far side of the big "
                 "sphere's centre, and their nearest planes face the other way. So the concentric state attracts from within about 5 cm, and "
                 f"the unstable equilibrium is the sign change near {sign_change[0] * 100:.2g} cm; the paper calls the concentric state the "
                 "unstable one. MuJoCo keeps pushing outward all the way in.")
    elif abs(near) < 0.05 * np.max(np.abs(fy)):
        text += "As the spheres become concentric, SCM's force falls back towards zero (the paper's unstable equilibrium)."
    return text


def mujoco_version():
    import mujoco
    return mujoco.__version__


# ---- planar pushing: the paper's Table I ---------------------------------------------------------
def _contacts(force, on=1.0, off=0.2):
    """Number of contact episodes (force rises above `on` after having been below `off`)."""
    n, inside = 0, False
    for f in force:
        if not inside and f > on:
            n, inside = n + 1, True
        elif inside and f < off:
            inside = False
    return n, inside


def _t_world(tx, ty, yaw):
    """The T's outline (m) in the world at pose (tx, ty, yaw)."""
    body = np.array([(-0.025, -0.1375), (0.025, -0.1375), (0.025, 0.0125), (0.125, 0.0125), (0.125, 0.0625),
                     (-0.125, 0.0625), (-0.125, 0.0125), (-0.025, 0.0125), (-0.025, -0.1375)])
    c, s = np.cos(yaw), np.sin(yaw)
    return body @ np.array([[c, s], [-s, c]]) + [tx, ty]


def pushing(ctx):
    if not scene_exists("t_push"):
        ctx.note("planar pushing: t_push.xml missing: skipped")
        return None
    names = [i["name"] for i in integrators(ctx)]
    steps = S.PUSH_STEPS_MS if not ctx.quick else (8.0, 16.0)
    spacings = S.PUSH_SPACINGS if not ctx.quick else S.PUSH_SPACINGS[:1]
    trajs = list(S.TRAJECTORIES)
    dur, comm = S.PUSH_DURATION, S.COMM
    n_comm = int(round(dur / comm))
    dur = n_comm * comm
    tgrid = np.arange(n_comm + 1) * comm
    ctrls = {tr: S.finger_controls(tr, tgrid) for tr in trajs}
    pose = ["t_x.q", "t_y.q", "t_yaw.q", "finger_x.q", "finger_y.q"]

    mj_model = None
    if HAVE_MUJOCO:
        import mujoco
        mj_model = mujoco.MjModel.from_xml_path(str(ctx.variant("t_push").xml))
        mj_data = mujoco.MjData(mj_model)
        qadr = [mj_model.joint(j.split(".")[0]).qposadr[0] for j in pose]
        finger_geom = mj_model.geom("finger").id
        act = {n: mj_model.actuator(n.split(".")[0]).id for n in ("act_x.ctrl", "act_y.ctrl")}
    else:
        ctx.note("planar pushing: mujoco is not importable here: SCM columns only")

    def run_mujoco(tr, h, integ):
        m, d = mj_model, mj_data
        mujoco.mj_resetData(m, d)
        m.opt.timestep = h
        m.opt.integrator = getattr(mujoco.mjtIntegrator, "mjINT_" + integ.upper())
        k = int(round(comm / h))
        traj, force, wall = [], [], 0.0
        f6 = np.zeros(6)
        for i in range(n_comm + 1):
            traj.append(d.qpos[qadr].copy())
            fn = 0.0
            for c in range(d.ncon):
                con = d.contact[c]
                if finger_geom in (con.geom1, con.geom2):
                    mujoco.mj_contactForce(m, d, c, f6)
                    fn += f6[0]
            force.append(fn)
            if i == n_comm:
                break
            for name, idx in act.items():
                d.ctrl[idx] = ctrls[tr][name][i]
            t0 = time.perf_counter()
            mujoco.mj_step(m, d, nstep=k)
            wall += time.perf_counter() - t0
        return np.array(traj), np.array(force), wall / (n_comm * k)

    results = {}  # (spacing, h, integ) -> list per trajectory of dict
    configs = [(sp, h, integ) for sp in spacings for h in steps for integ in names]
    for sp in spacings:
        v = ctx.variant("t_push", sp)
        fmu = Fmu(v, "push")
        pair = [n[: -len(".force.x")] for n in fmu.vr if n.startswith("contact.") and n.endswith(".force.x")][0]
        fnames = [f"{pair}.force.{a}" for a in "xyz"]
        for h_ms in steps:
            h = h_ms / 1000
            k = int(round(comm / h))
            for integ in progress(names, f"pushing spacing {sp:g}, {h_ms:g} ms"):
                per = []
                for tr in trajs:
                    fmu.start(reals={"solver.step": h}, strings={"solver.integrator": integ}, stop=dur)
                    traj, force, wall, status = [], [], 0.0, "ok"
                    for i in range(n_comm + 1):
                        vals = fmu.get(pose + fnames)
                        if any(not np.isfinite(x) for x in vals):
                            raise RuntimeError(f"NaN output in t_push ({tr}, {integ}, {h_ms} ms): a bug")
                        traj.append(vals[:5])
                        force.append(float(np.linalg.norm(vals[5:])))
                        if i == n_comm:
                            break
                        fmu.set({n: ctrls[tr][n][i] for n in ("act_x.ctrl", "act_y.ctrl")})
                        t0 = time.perf_counter()
                        try:
                            fmu.fmu.doStep(currentCommunicationPoint=i * comm, communicationStepSize=comm)
                        except Exception as e:  # fmpy raises on fmi2Discard
                            if getattr(e, "status", None) == 2:
                                status = f"refused at t = {i * comm:.3g} s"
                                break
                            raise
                        wall += time.perf_counter() - t0
                    item = dict(scm=np.array(traj), scm_force=np.array(force), scm_step=wall / (max(len(traj) - 1, 1) * k), status=status)
                    if mj_model is not None:
                        mt, mf, ms = run_mujoco(tr, h, mujoco_integrator(integ))
                        item.update(mj=mt, mj_force=mf, mj_step=ms)
                    per.append(item)
                results[(sp, h_ms, integ)] = per
        fmu.close()

    # Table I (transposed: one row per configuration).
    rows = []
    for sp, h_ms, integ in configs:
        per = results[(sp, h_ms, integ)]
        pts = ctx.variant("t_push", sp).total_points()
        ok = [p for p in per if p["status"] == "ok"]
        scm_t = np.array([p["scm_step"] for p in per]) * 1000
        row = [f"{h_ms:g}", integ, pts, f"{scm_t.mean():.3g} ± {scm_t.std():.2g}"]
        if mj_model is not None:
            mj_t = np.array([p["mj_step"] for p in per]) * 1000
            dd = np.array([np.hypot(*(p["scm"][-1, :2] - p["mj"][-1, :2])) for p in ok]) * 100
            dth = np.array([abs(p["scm"][-1, 2] - p["mj"][-1, 2]) for p in ok]) * 180 / np.pi
            row += [mujoco_integrator(integ), f"{mj_t.mean():.3g} ± {mj_t.std():.2g}", f"{scm_t.mean() / mj_t.mean():.3g}",
                    f"{dd.mean():.3g} ± {dd.std():.2g}" if len(ok) else "–", f"{dth.mean():.3g} ± {dth.std():.2g}" if len(ok) else "–"]
        else:
            row += [NO_MUJOCO] * 5
        row.append(f"{len(per) - len(ok)} of {len(per)}")
        rows.append(row)

    # Contacts made and broken, and the top view, at 2 ms (or the smallest step), the scene's
    # integrator (the first in the list if absent) and the finest spacing.
    h_view = min(steps)
    integ_view = "semi_implicit_euler" if "semi_implicit_euler" in names else names[0]
    view = results[(spacings[-1], h_view, integ_view)]
    crow = []
    for tr, p in zip(trajs, view):
        n_scm, _ = _contacts(p["scm_force"])
        cells = [tr, n_scm]
        if mj_model is not None:
            n_mj, _ = _contacts(p["mj_force"])
            cells += [n_mj]
            enough = n_scm >= 2 and n_mj >= 2
        else:
            cells += [NO_MUJOCO]
            enough = n_scm >= 2
        cells.append("yes" if enough else "NO")
        if not enough and not ctx.quick:
            ctx.note(f"planar pushing: {tr} makes contact fewer than twice in one simulator (see the table)")
        crow.append(cells)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(trajs), figsize=(3.6 * len(trajs), 4.4), squeeze=False)
    for ax, tr, p in zip(axes[0], trajs, view):
        ax.fill(*_t_world(0, 0, 0).T, color="0.85", label="T at start")
        ax.plot(*_t_world(*p["scm"][-1, :3]).T, color="C0", label="SCM, end")
        ax.plot(p["scm"][:, 0], p["scm"][:, 1], color="C0", lw=0.8, ls=":")
        ax.plot(p["scm"][:, 3], p["scm"][:, 4] - 0.25, color="C0", lw=0.8, ls="--", label="finger, SCM")
        if mj_model is not None:
            ax.plot(*_t_world(*p["mj"][-1, :3]).T, color="C1", label="MuJoCo, end")
            ax.plot(p["mj"][:, 0], p["mj"][:, 1], color="C1", lw=0.8, ls=":")
            ax.plot(p["mj"][:, 3], p["mj"][:, 4] - 0.25, color="C1", lw=0.8, ls="--", label="finger, MuJoCo")
        ax.set_aspect("equal")
        ax.set_title(tr.replace("_", " "), fontsize=9)
        ax.set_xlabel("x (m)")
    axes[0][0].set_ylabel("y (m)")
    axes[0][0].legend(fontsize=6, loc="lower left")
    fig.suptitle(f"t_push seen from above: {h_view:g} ms, {integ_view}, {ctx.variant('t_push', spacings[-1]).total_points()} points "
                 "(dotted: T's centre path; dashed: finger)", fontsize=10)
    fig.tight_layout()
    savefig(ctx, fig, "pushing_top_view.png")

    head = ["step (ms)", "integrator", "AOPC points", "SCM step time (ms)", "MuJoCo integrator", "MuJoCo step time (ms)",
            "ratio SCM / MuJoCo", "Δd (cm)", "Δθ (deg)", "runs refused"]
    text = ["# Planar pushing against MuJoCo (the paper's Table I)", "",
            f"Machine: {machine_line()}; other builds may have shared the cores.", "",
            f"Five finger trajectories of our own (`scripts/report/scenes.py`: waypoints of the position targets, {dur:g} s each, "
            f"zero-order hold every {comm * 1000:g} ms) are replayed open-loop in the `t_push` FMU (fmpy, Co-Simulation, `solver.step` = the step) "
            "and in MuJoCo from the same `resources/scenes/t_push.xml` (its timestep set to the step, its integrator matched to ours: "
            "Euler for the Euler methods, RK4 for RK4, implicitfast for an implicit one). Step time = wall time of `fmi2DoStep` / `mj_step(nstep)` "
            "per internal step, both measured in this run, one after the other; mean ± std over the five trajectories. "
            "Δd: distance between the T's final centres of mass; Δθ: difference of its final yaw; mean ± std over the trajectories that were not refused. "
            "The paper's Table I has one column per configuration; here each configuration is a row.", "",
            table(head, rows), "",
            f"Contacts made (finger–T force rising above 1 N) per trajectory at {h_view:g} ms, `{integ_view}`, finest spacing:", "",
            table(["trajectory", "SCM", "MuJoCo", "made and broken at least twice in both"], crow), "",
            "![top view](pushing_top_view.png)"]
    write(ctx, "planar_pushing.md", "\n".join(text))
    ctx.figures["pushing"] = (head, rows, crow)
    return rows
