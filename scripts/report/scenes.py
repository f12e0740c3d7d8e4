"""The scenes the studies run on, and the finger trajectories of planar pushing.

Add a scene here (or let a helper's scene land in resources/scenes/) and every study picks it
up; a scene listed here whose file does not exist yet is skipped with a printed note."""
import numpy as np

# Work–precision: every integrator × internal step × spacing, error against a reference.
#   duration (s), comm (s): the communication step at which outputs are compared;
#   spacings: the three scm_spacing values (m); sets: start values / inputs; inputs: a
#   function of the time array returning {input name: values} (zero-order hold per comm step).
WORK_PRECISION = [
    dict(scene="sphere_drop", duration=0.8, spacings=(0.02, 0.01, 0.005)),
    dict(scene="t_push", duration=3.2, spacings=(0.05, 0.025, 0.01), inputs="trajectory_1"),
    dict(scene="box_stack", duration=0.8, spacings=(0.04, 0.02, 0.01)),
    dict(scene="horseshoe", duration=0.8, spacings=(0.02, 0.01, 0.005)),
]
STEPS_MS = (0.5, 2.0, 8.0, 16.0)
COMM = 0.016  # a multiple of every internal step above

# Stability maps: a stiff drop (the sphere 1 cm above the plane) and t_push with the finger
# 2 mm below the T's stem, its target 5 cm further in (so it presses and pushes at once).
# spacing: scm_spacing of the runs (None: the scene's). t_push runs at 2.5 cm (164 points): at
# large ε nothing can be pruned and a pair costs O(I1·I2), so the scene's 1 cm (876 points) would
# take about half an hour for the ε maps alone before the geometry issue's BVH pruning.
STABILITY = [
    dict(scene="sphere_drop", label="stiff drop", duration=0.5,
         sets={"ball.pos.z": 0.06}, tol_pos=1e-3, tol_rot=0.05),
    dict(scene="t_push", label="t_push", duration=0.3, spacing=0.025,
         sets={"finger_y.q": 0.0955, "act_y.ctrl": 0.1475}, tol_pos=5e-3, tol_rot=0.05),
]
STIFFNESS = [1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9]
STIFF_STEPS_MS = [0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 50]
EPS_VALUES = [1e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0, 10.0]
EPS_STEPS_MS = [0.1, 0.5, 2, 8, 16, 50]

# Planar pushing against MuJoCo (the paper's Table I): internal steps, spacings.
PUSH_STEPS_MS = (2.0, 8.0, 16.0)
PUSH_SPACINGS = (0.05, 0.025, 0.01)
PUSH_DURATION = 3.2  # 200 communication steps of 16 ms

# The finger starts at (0, -0.25) m; the T's centre of mass is at the origin, its stem points to
# -y (stem x ∈ [-2.5, 2.5] cm, y ∈ [-13.75, 3.25] cm; bar x ∈ [-12.5, 12.5] cm,
# y ∈ [1.25, 6.25] cm); the finger's radius is 1.5 cm. Waypoints (t s, x m, y m) of the finger's
# target, linearly interpolated; each makes and breaks contact at least twice (checked).
FINGER_START = (0.0, -0.25)
TRAJECTORIES = {
    "trajectory_1": [  # push the stem straight up, back off, push again
        (0.0, 0.0, -0.25), (0.4, 0.0, -0.16), (1.0, 0.0, -0.10), (1.4, 0.0, -0.20),
        (1.6, 0.0, -0.20), (2.4, 0.0, -0.06), (2.8, 0.0, -0.20), (3.0, 0.0, -0.20)],
    "trajectory_2": [  # off-centre pushes on the stem, right then left: turns the T both ways
        (0.0, 0.0, -0.25), (0.3, 0.02, -0.20), (0.5, 0.02, -0.16), (1.1, 0.02, -0.09),
        (1.4, 0.02, -0.21), (1.7, -0.02, -0.21), (2.5, -0.02, -0.08), (2.9, -0.02, -0.21),
        (3.0, -0.02, -0.21)],
    "trajectory_3": [  # from the right, push the stem sideways twice
        (0.0, 0.0, -0.25), (0.4, 0.10, -0.25), (0.7, 0.10, -0.08), (1.3, 0.0, -0.08),
        (1.6, 0.10, -0.08), (1.8, 0.10, -0.06), (2.4, -0.05, -0.06), (2.8, 0.10, -0.06),
        (3.0, 0.10, -0.06)],
    "trajectory_4": [  # under the left wing of the bar, push up twice (turns the T)
        (0.0, 0.0, -0.25), (0.4, -0.09, -0.20), (0.7, -0.09, -0.05), (1.2, -0.09, 0.03),
        (1.5, -0.09, -0.06), (1.7, -0.07, -0.06), (2.3, -0.07, 0.045), (2.7, -0.07, -0.06),
        (3.0, -0.07, -0.06)],
    "trajectory_5": [  # push the stem, then go round and lift the right wing
        (0.0, 0.0, -0.25), (0.4, 0.0, -0.16), (0.9, 0.0, -0.11), (1.2, 0.0, -0.20),
        (1.5, 0.09, -0.20), (1.9, 0.09, -0.04), (2.4, 0.09, 0.07), (2.8, 0.09, -0.06),
        (3.0, 0.09, -0.06)],
}


def finger_controls(name, t):
    """Controls (act_x.ctrl, act_y.ctrl): the target displacement of the finger from its start."""
    w = np.array(TRAJECTORIES[name])
    x = np.interp(t, w[:, 0], w[:, 1]) - FINGER_START[0]
    y = np.interp(t, w[:, 0], w[:, 2]) - FINGER_START[1]
    return {"act_x.ctrl": x, "act_y.ctrl": y}


def input_rows(inputs, duration, comm):
    """(names, rows) for report_host: row k holds the inputs during communication step k."""
    if inputs is None:
        return None
    n = int(round(duration / comm))
    t = np.arange(n + 1) * comm
    ctrl = finger_controls(inputs, t)
    names = sorted(ctrl)
    return names, np.stack([ctrl[k] for k in names], 1).tolist()
