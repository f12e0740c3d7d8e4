"""The dynamics scenes as FMUs in fmpy: they validate, the box stack stays at rest, the arm and
the mocap paddle push their boxes through the FMU inputs, every integrator can be chosen
through solver.integrator, and a diverging explicit step is refused (not NaN)."""
import pathlib
import subprocess
import sys

import numpy as np
import pytest
from ctypes import byref

from fmpy import calloc, extract, free, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions,
                       fmi2CallbackLoggerTYPE, fmi2Discard)
from fmpy.logging import addLoggerProxy
from fmpy.validation import validate_fmu

from conftest import SCENES, SCM

DYNAMICS_SCENES = ["box_stack", "arm_push", "t_push", "mocap_push"]
INTEGRATORS = ["euler", "semi_implicit_euler", "rk4", "implicit_euler", "dopri5"]


@pytest.mark.parametrize("name", DYNAMICS_SCENES)
def test_fmu_validates(fmu, name):
    problems = validate_fmu(fmu(name))
    assert problems == [], problems


def test_solver_integrator_lists_every_integrator(fmu):
    md = read_model_description(fmu("box_stack"))
    v = next(v for v in md.modelVariables if v.name == "solver.integrator")
    assert v.start == "semi_implicit_euler"
    assert all(name in v.description for name in INTEGRATORS), v.description


def test_box_stack_stays_at_rest(fmu):
    names = [f"{b}.{k}" for b in ("bottom", "middle", "top") for k in ("pos.z", "linvel.z", "angvel.x")]
    res = simulate_fmu(fmu("box_stack"), stop_time=3.0, output_interval=0.05, output=names)
    # Settled within the first second, then still: no drift, no jitter (SCM's own test runs 10 s).
    late = res["time"] > 1.0
    for b, rest in (("bottom", 0.0596822), ("middle", 0.1695338), ("top", 0.2594837)):
        z = res[f"{b}.pos.z"][late]
        assert np.ptp(z) < 1e-7 and abs(z[-1] - rest) < 1e-6, (b, z[-1])
        assert np.max(np.abs(res[f"{b}.linvel.z"][late])) < 1e-6
        assert np.max(np.abs(res[f"{b}.angvel.x"][late])) < 1e-6


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_every_integrator_runs_through_the_fmu(fmu, integrator):
    # The sphere dropped on the floor: every integrator brings it to rest at the same height.
    res = simulate_fmu(fmu("sphere_drop"), stop_time=1.5, output_interval=0.01, output=["ball.pos.z", "ball.linvel.z"],
                       start_values={"solver.integrator": integrator})
    assert abs(res["ball.linvel.z"][-1]) < 1e-4, integrator
    assert res["ball.pos.z"][-1] == pytest.approx(0.04854, abs=2e-5), integrator


def test_arm_pushes_the_box_through_its_motor_inputs(fmu):
    # Constant torques: 0.3 N m at the shoulder swings the tip into the box after about 2.4 s;
    # 0.5 N m at the elbow (gear 1, within the ctrlrange of +-2) keeps it from folding back.
    signals = np.array([(0.0, 0.3, 0.0), (4.0, 0.3, 0.0)],
                       dtype=[("time", np.float64), ("shoulder_motor.ctrl", np.float64), ("elbow_motor.ctrl", np.float64)])
    res = simulate_fmu(fmu("arm_push"), stop_time=4.0, output_interval=0.01, input=signals,
                       output=["shoulder.q", "box_x.q", "box_y.q", "contact.tip.box.force.x"])
    touched = np.nonzero(np.abs(res["contact.tip.box.force.x"]) > 0.1)[0]
    assert len(touched) > 0, "the tip never reached the box"
    # Before contact the box did not move; after it, it was pushed towards -x.
    assert np.all(np.abs(res["box_x.q"][:touched[0] - 1]) < 1e-9)
    assert res["box_x.q"][-1] < -0.005, res["box_x.q"][-1]
    # Contact happens where the tip's circle meets the box's face: shoulder ≈ 1.44 rad.
    assert res["shoulder.q"][touched[0]] == pytest.approx(1.443, abs=0.05)


def test_mocap_paddle_pushes_the_box(fmu):
    # The paddle moves +x at 0.1 m/s for 1.5 s; the box starts 3 cm ahead of it.
    t = np.linspace(0.0, 1.5, 151)
    signals = np.zeros(len(t), dtype=[("time", np.float64), ("paddle.pos.x", np.float64)])
    signals["time"] = t
    signals["paddle.pos.x"] = -0.11 + 0.1 * t
    res = simulate_fmu(fmu("mocap_push"), stop_time=1.5, output_interval=0.01, input=signals,
                       output=["box.pos.x", "box.linvel.x", "contact.box.paddle.force.x"])
    # fmpy sets the input at each communication point; the paddle reaches it one step later.
    assert res["box.pos.x"][-1] == pytest.approx(0.12, abs=0.01)
    assert res["box.linvel.x"][-1] == pytest.approx(0.1, rel=0.02)
    # Sliding at 0.1 m/s, the paddle pushes against the floor's friction, about 2.4 N.
    assert np.mean(res["contact.box.paddle.force.x"][-50:]) == pytest.approx(2.41, rel=0.02)


STIFF = """<mujoco model="stiff">
  <option timestep="0.016"/>
  <custom>
    <numeric name="scm_stiffness" data="1e6"/>
    <numeric name="scm_eps2" data="2e-4"/>
    <numeric name="scm_eps3" data="1e-6"/>
    <numeric name="scm_stiction_velocity" data="0.05"/>
    <numeric name="scm_spacing" data="0.01"/>
  </custom>
  <worldbody>
    <geom name="ground" type="plane" size="1 1 0.1"/>
    <body name="ball" pos="0 0 0.06"><freejoint/><geom name="ball" type="sphere" size="0.05" mass="1"/></body>
  </worldbody>
</mujoco>
"""


#: fmpy's native logger proxy keeps one process-wide pointer to the last Python logger given to
#: addLoggerProxy, and fmpy's default callbacks log through it; a logger freed after its run
#: would leave that pointer dangling for every later FMU in the process (a segfault at the next
#: log message, as soon as the memory is reused). So the loggers given to it live for the session.
_LOGGERS_KEPT_ALIVE = []


def run_stiff(path, integrator, steps):
    """Drives the FMU step by step (to see the refused step itself: simulate_fmu ends the run
    there, see the last test). Returns the heights reached, the exception of a refused step (or
    None), the state read after it, and the log messages."""
    md = read_model_description(path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    messages = []

    def logger(component, instance, status, category, message):
        messages.append(message.decode())

    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(logger)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    addLoggerProxy(byref(callbacks))
    _LOGGERS_KEPT_ALIVE.append((callbacks, logger))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier, instanceName="stiff")
    fmu.instantiate(callbacks=callbacks, loggingOn=True)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setString([vr["solver.integrator"]], [integrator])
    fmu.exitInitializationMode()
    z, refused, after = [], None, None
    h = 0.016
    for k in range(steps):
        try:
            fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
        except FMICallException as e:
            refused = (k * h, e)
            after = fmu.getReal([vr["ball.pos.z"], vr["ball.linvel.z"]])
            break
        z.append(fmu.getReal([vr["ball.pos.z"], vr["ball.linvel.z"]]))
    fmu.terminate()
    fmu.freeInstance()
    return np.array(z), refused, after, messages


def test_stiff_contact_implicit_settles_explicit_refused(tmp_path):
    scene = tmp_path / "stiff.xml"
    scene.write_text(STIFF)
    out = tmp_path / "stiff.fmu"
    subprocess.run([str(SCM), "pack", str(scene), "-o", str(out)], check=True)
    # k = 1e6 N/m on 1 kg at h = 16 ms: h ω = 16. The implicit method settles at rest.
    z, refused, _, _ = run_stiff(str(out), "implicit_euler", 63)
    assert refused is None, refused
    assert np.all(np.isfinite(z)) and abs(z[-1, 1]) < 1e-8
    assert z[-1, 0] == pytest.approx(0.0495121, abs=1e-6)
    # An explicit one is refused with fmi2Discard before anything overflows, keeping the last
    # good state, and says why and when.
    z, refused, after, messages = run_stiff(str(out), "semi_implicit_euler", 63)
    assert refused is not None, "the explicit step was not refused"
    t, e = refused
    assert e.status == fmi2Discard, e
    assert after == pytest.approx(list(z[-1])), (after, z[-1])
    assert np.all(np.isfinite(after))
    text = " ".join(messages)
    # "... the state is kept at t = <start of the refused step> s ...".
    assert "unstable" in text and f"t = {t!r} s" in text, text


def test_simulate_fmu_stops_cleanly_at_a_discarded_step(tmp_path):
    """fmpy's simulate_fmu retries a discarded step for as long as fmi2Terminated is false; the
    FMU reports fmi2Terminated after a discard, so the run ends at the last good time with
    finite results instead of looping (run in a subprocess with a timeout, so a regression
    fails instead of hanging the suite)."""
    scene = tmp_path / "stiff.xml"
    scene.write_text(STIFF)
    out = tmp_path / "stiff.fmu"
    subprocess.run([str(SCM), "pack", str(scene), "-o", str(out)], check=True)
    script = f"""
import numpy as np
from fmpy import simulate_fmu
res = simulate_fmu({str(out)!r}, stop_time=1.0, output_interval=0.016,
                   start_values={{"solver.integrator": "semi_implicit_euler"}}, output=["ball.pos.z"])
assert np.all(np.isfinite(res["ball.pos.z"])), res
print("RESULT", len(res), res["time"][-1])
"""
    p = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    n, t_end = p.stdout.split("RESULT")[-1].split()
    # Refused at t ≈ 0.03-0.06 s (see the test above): the run ends there, well before 1 s,
    # with a handful of samples (not thousands of repeated ones).
    assert float(t_end) < 0.2 and int(n) < 20, p.stdout


def test_mocap_paddle_pushes_the_box_in_model_exchange_as_in_co_simulation(fmu):
    """In Model Exchange a mocap input is the pose now and its velocity the input's rate over
    the last completed solver step; in Co-Simulation the pose set at a communication point is
    reached at the end of the next step. fmpy's CVode applies inputs only at its communication
    points (its right-hand side does not call input.apply), so in ME the paddle advances in
    1 mm jumps every 10 ms, pushing the box by short pulses instead of steadily; the box still
    travels with the paddle."""
    t = np.linspace(0.0, 1.5, 151)
    signals = np.zeros(len(t), dtype=[("time", np.float64), ("paddle.pos.x", np.float64)])
    signals["time"] = t
    signals["paddle.pos.x"] = -0.11 + 0.1 * t
    out = ["box.pos.x", "box.linvel.x", "contact.box.paddle.force.x"]
    cs = simulate_fmu(fmu("mocap_push"), stop_time=1.5, output_interval=0.01, input=signals, output=out)
    me = simulate_fmu(fmu("mocap_push"), fmi_type="ModelExchange", stop_time=1.5, output_interval=0.01,
                      input=signals, output=out)
    # Same distance: one communication step of lag in CS (1 mm at 0.1 m/s) plus the ~1 mm the
    # pulses let the box trail the paddle (the contact's compression at a few N).
    assert me["box.pos.x"][-1] == pytest.approx(0.12, abs=0.01)
    assert me["box.pos.x"][-1] == pytest.approx(cs["box.pos.x"][-1], abs=3e-3)
    # Over the last half second the box keeps the paddle's pace on average.
    pace = (me["box.pos.x"][-1] - me["box.pos.x"][-51]) / (me["time"][-1] - me["time"][-51])
    assert pace == pytest.approx(0.1, rel=0.03)


def test_a_hosts_pruning_tolerance_runs_as_the_scenes(fmu, tmp_path):
    """`scm.prune_tolerance`, set by fmpy before initialization, runs t_push's finger through
    the T as the same scene with `scm_prune_tolerance` does, to the last digit; its push ends
    within the tolerance's bound of the default's, and fmpy's setReal of a value out of range
    is refused."""
    loose = 1e-9
    names = ["t_x.q", "t_y.q", "t_yaw.q", "contact.tblock.finger.force.y"]
    run = dict(stop_time=1.5, output_interval=0.01, output=names)
    start = {"act_x.ctrl": 0.0, "act_y.ctrl": 0.13}
    by_host = simulate_fmu(fmu("t_push"), start_values={**start, "scm.prune_tolerance": loose}, **run)
    text = (SCENES / "t_push.xml").read_text()
    in_scene = tmp_path / "t_push.xml"
    in_scene.write_text(text.replace(
        "<worldbody>", f'<custom><numeric name="scm_prune_tolerance" data="{loose:g}"/></custom>\n  <worldbody>', 1))
    packed = tmp_path / "t_push_loose.fmu"
    subprocess.run([str(SCM), "pack", str(in_scene), "-o", str(packed)], check=True, capture_output=True)
    md = read_model_description(str(packed))
    assert float(next(v for v in md.modelVariables if v.name == "scm.prune_tolerance").start) == loose
    by_scene = simulate_fmu(str(packed), start_values=start, **run)
    by_default = simulate_fmu(fmu("t_push"), start_values=start, **run)
    force = "contact.tblock.finger.force.y"
    assert np.max(np.abs(by_default[force])) > 0.1, "the finger never pushed"
    for n in names:
        assert np.array_equal(by_host[n], by_scene[n]), n
        # Pruned terms weigh less than 1000 tau of the largest (docs/method.md), so over 1.5 s
        # of pushing the two runs stay far closer than the push itself moves the T.
        scale = max(1.0, float(np.max(np.abs(by_default[n]))))
        assert np.max(np.abs(by_host[n] - by_default[n])) < 1e-6 * scale, n
    assert any(not np.array_equal(by_host[n], by_default[n]) for n in names), "the tolerance changed nothing"

    from hosts import Opened
    from fmpy.fmi2 import FMU2Slave
    opened = Opened(fmu("t_push"))
    inst = FMU2Slave(guid=opened.md.guid, unzipDirectory=opened.dir,
                     modelIdentifier=opened.md.coSimulation.modelIdentifier, instanceName="bad")
    inst.instantiate()
    inst.setupExperiment(startTime=0.0)
    with pytest.raises(FMICallException):
        inst.setReal([opened.vr["scm.prune_tolerance"]], [0.01])
    inst.freeInstance()
