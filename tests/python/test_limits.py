"""Joint limits against MuJoCo's on the same file (docs/mjcf.md, "Joint limits").

MuJoCo's limit is a unilateral soft constraint: its force pushes a joint back into its range and
is never negative. A joint that starts outside its range (gymnasium's ant starts with its ankles
0.52 rad outside) is thrown back in along MuJoCo's reference motion, a critically damped spring
at the default `solreflimit`, and let go where that motion would start to brake, at its peak
speed `r₀ / (τ e)`: it swings on through the range. A damper that may pull would instead stop it
on the limit.
"""
import csv
import io
import json
import math
import pathlib
import re
import subprocess

import gymnasium
import mujoco
import pytest

from conftest import SCM

#: Each joint starts at 0, outside its range: the hinge 0.5 rad below, the slide 0.1 m above,
#: the second hinge 0.3 rad below with a time constant of its own.
SCENE = """<mujoco>
  <compiler angle="radian"/>
  <option timestep="0.001" integrator="RK4" gravity="0 0 0"><flag contact="disable"/></option>
  <worldbody>
    <body name="wheel">
      <joint name="hinge" type="hinge" axis="0 0 1" range="0.5 4" armature="0.1"/>
      <geom type="cylinder" size="0.1 0.02" mass="1"/>
    </body>
    <body name="slider" pos="1 0 0">
      <joint name="slide" type="slide" axis="1 0 0" range="-1 -0.1"/>
      <geom type="box" size="0.05 0.05 0.05" mass="2"/>
    </body>
    <body name="flap" pos="0 1 0">
      <joint name="slow" type="hinge" axis="0 1 0" range="0.3 2.5" solreflimit="0.05 1"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="0.5"/>
    </body>
  </worldbody>
</mujoco>
"""
DURATION = 0.3
JOINTS = {"hinge": (0.5, 0.02), "slide": (0.1, 0.02), "slow": (0.3, 0.05)}


def test_a_joint_outside_its_range_is_thrown_back_in_and_let_go_as_in_mujoco(tmp_path):
    path = tmp_path / "outside.xml"
    path.write_text(SCENE)
    run = subprocess.run([str(SCM), "simulate", str(path), "--duration", str(DURATION),
                          "--output-interval", "0.01"], capture_output=True, text=True, check=True)
    rows = list(csv.reader(io.StringIO(run.stdout)))
    ours = [dict(zip(rows[0], map(float, r))) for r in rows[1:]]

    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    # SCM's spring past the 1 mm (1 mrad) onset reads the violation less half the onset, so it
    # lets go at (r₀ - w/2) / (τ e): slower by that much, and its position falls behind by the
    # difference times the time since.
    w = 1e-3
    worst = {name: (0.0, 0.0) for name in JOINTS}
    for row in ours:
        while d.time < row["time"] - 0.5 * m.opt.timestep:
            mujoco.mj_step(m, d)
        for name, (r0, tau) in JOINTS.items():
            j = m.joint(name)
            dq = abs(row[f"{name}.q"] - d.qpos[j.qposadr[0]])
            allowed = 0.01 * r0 + row["time"] * 0.5 * w / (tau * math.e)
            assert dq < allowed, (name, row["time"], dq, allowed)
            dv = abs(row[f"{name}.v"] - d.qvel[j.dofadr[0]])
            worst[name] = (max(worst[name][0], dq), max(worst[name][1], dv))
    for name, (r0, tau) in JOINTS.items():
        j = m.joint(name)
        # Let go at the reference motion's peak speed, and coasting at it (nothing else acts
        # until the far limit).
        v_mujoco, v_ours = abs(d.qvel[j.dofadr[0]]), abs(ours[-1][f"{name}.v"])
        print(f"{name}: speed {v_ours:.4f} (MuJoCo {v_mujoco:.4f}, predicted {r0 / (tau * math.e):.4f}); "
              f"largest differences {worst[name][0]:.2e} in position, {worst[name][1]:.2e} in speed")
        assert abs(v_mujoco - r0 / (tau * math.e)) < 1e-3 * v_mujoco, "MuJoCo lets go at the peak"
        assert abs(v_ours - (r0 - 0.5 * w) / (tau * math.e)) < 1e-3 * v_ours
        assert m.jnt_range[j.id][0] < ours[-1][f"{name}.q"] < m.jnt_range[j.id][1]


GYM = pathlib.Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"


def scm_run(path, seconds, interval, *options):
    run = subprocess.run([str(SCM), "simulate", str(path), "--duration", str(seconds),
                          "--output-interval", str(interval), *options],
                         capture_output=True, text=True, check=True)
    rows = list(csv.reader(io.StringIO(run.stdout)))
    return [dict(zip(rows[0], map(float, r))) for r in rows[1:]]


def mujoco_run(path, times):
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    out = []
    for t in times:
        while d.time < t - 0.5 * m.opt.timestep:
            mujoco.mj_step(m, d)
        out.append(d.qpos.copy())
    return m, out


def test_gymnasiums_ant_throws_its_ankles_into_their_range_as_mujoco_does():
    """The ant as written (RK4, 10 ms) starts with its ankles 0.52 rad outside their range:
    MuJoCo's limits throw them in at about 9.6 rad/s, the legs swing up and the body drops
    onto them at 0.2 s. SCM follows (measured: 0.765 m and 0.874 rad at 0.1 s against
    MuJoCo's 0.766 m and 0.881 rad; 0.633 m and 1.249 rad at 0.2 s against 0.633 m and
    1.242 rad). Its limits' damper, when it could pull, held the ankles on the limit (0.523 rad)
    and the body fell straight onto the floor."""
    path = GYM / "ant.xml"
    times = [0.1, 0.2]
    ours = scm_run(path, 0.2, 0.1)[1:]
    m, theirs = mujoco_run(path, times)
    for row, qpos, t in zip(ours, theirs, times):
        assert abs(row["root.pos.z"] - qpos[2]) < 0.005, t
        for k in range(1, 5):
            a = m.joint(f"ankle_{k}").qposadr[0]
            assert abs(row[f"ankle_{k}.q"] - qpos[a]) < 0.02, (t, k, row[f"ankle_{k}.q"], qpos[a])


def test_gymnasiums_humanoid_falls_at_mujocos_pace():
    """gymnasium's humanoid as written (RK4, 3 ms) starts with its knees 0.035 rad outside
    their range (`-160 -2` degrees, at 0): MuJoCo's limits throw them in, they fold, and the
    body falls (pelvis height 1.20 m at 0.45 s, 1.00 m at 0.6 s). With a limit damper that
    could pull, SCM's knees stayed on the limit and the body stood until 1.5 s (1.20 m at 0.6 s,
    knee -0.02 rad). Measured now: 1.21 m and 1.03 m, the left knee -0.76 and -1.57 rad against
    MuJoCo's -0.85 and -1.68."""
    path = GYM / "humanoid.xml"
    times = [0.45, 0.6]
    # Outputs every 0.15 s keep the file's 3 ms step (the strike on the floor: the next test).
    ours = [r for r in scm_run(path, 0.6, 0.15, "--step", "0.003") if r["time"] > 0.4]
    m, theirs = mujoco_run(path, times)
    knee = m.joint("left_knee").qposadr[0]
    for row, qpos, t in zip(ours, theirs, times):
        assert abs(row["root.pos.z"] - qpos[2]) < 0.05, (t, row["root.pos.z"], qpos[2])
        assert abs(row["left_knee.q"] - qpos[knee]) < 0.15, (t, row["left_knee.q"], qpos[knee])


def test_the_humanoid_lies_where_mujocos_does_and_explicit_damping_of_the_papers_law_is_refused(tmp_path):
    """gymnasium's humanoid as written (MuJoCo's RK4, SCM's damped_rk4, 3 ms) runs through its
    knees' strike on the floor at 0.79 s and lies where MuJoCo's does (pelvis at 0.080 m from
    1.2 s to 2.1 s). Its pairs' damping is bounded at eight times the resting force, and the
    stages take it implicitly. The paper's damping, which grows with the depth (the scene's
    `scm_dissipation_force` 0), taken explicitly (`--integrator rk4`) is past what RK4 carries at
    3 ms, and the energy guard refuses the run at the strike; a scene that names rk4 gets the
    bound RK4 carries (`scm_dissipation_force` 4, docs/method.md, departure 4)."""
    papers = tmp_path / "papers.xml"
    setting = '<custom><numeric name="scm_dissipation_force" data="0"/></custom>'
    papers.write_text(re.sub(r"(<mujoco[^>]*>)", r"\1" + setting, (GYM / "humanoid.xml").read_text(), count=1))
    refused = subprocess.run([str(SCM), "simulate", str(papers), "--duration", "1",
                              "--step", "0.003", "--integrator", "rk4", "--output-interval", "0.15",
                              "-o", "/dev/null"], capture_output=True, text=True)
    assert refused.returncode == 1 and "the integration is unstable" in refused.stderr, refused.stderr
    bounded = tmp_path / "humanoid.xml"
    setting = '<custom><text name="scm_integrator" data="rk4"/></custom>'
    bounded.write_text(re.sub(r"(<mujoco[^>]*>)", r"\1" + setting, (GYM / "humanoid.xml").read_text(), count=1))
    assert bounded.read_text() != (GYM / "humanoid.xml").read_text()
    assert scm_run(bounded, 1.0, 0.15, "--step", "0.003")[-1]["time"] == pytest.approx(1.0)
    times = [0.45, 0.6] + [1.2 + 0.15 * k for k in range(7)]
    ours = [r for r in scm_run(GYM / "humanoid.xml", 2.1, 0.15, "--step", "0.003") if r["time"] > 0.4]
    ours = ours[:2] + ours[-7:]
    m, theirs = mujoco_run(GYM / "humanoid.xml", times)
    for row, qpos, t in zip(ours, theirs, times):
        assert abs(row["time"] - t) < 1e-9
        if t < 1.0:
            assert abs(row["root.pos.z"] - qpos[2]) < 0.05, (t, row["root.pos.z"], qpos[2])
        else:
            # Lying: within 5 mm of MuJoCo's pelvis height (SCM's resting contacts sink up to
            # about a millimetre deeper than MuJoCo's, docs/mjcf.md).
            assert abs(row["root.pos.z"] - qpos[2]) < 0.005, (t, row["root.pos.z"], qpos[2])


def test_without_limits_the_ant_rests_where_mujocos_does_margin_included(tmp_path):
    """Where the ant rests (issue 40 asks which of its limits and its contacts it owes that to):
    with its limits switched off (`<flag limit="disable"/>`) in both engines its legs splay until
    the ankles stand at 12 degrees, and its torso rests on its feet and the margin. The ant's
    geoms have `margin="0.01"`; MuJoCo adds the two (0.02) and holds its feet 19.66 mm above
    the floor, and so does SCM, whose springs rest at the pair's margin (docs/mjcf.md). Measured
    at 2 s before the margin was read: SCM 0.2490 m, MuJoCo 0.2696 m, and with the margins set
    to 0 MuJoCo 0.2496 m. Both engines are compared with the margin and without it.

    As written, the two follow each other until the landing at 0.2 s; then the legs splay
    against the feet's friction, MuJoCo's slowly (ankles 55.5 degrees at 1 s, 47.7 at 8 s),
    SCM's faster, its feet sliding at the full mu N (docs/mjcf.md)."""
    text = (GYM / "ant.xml").read_text()
    free = tmp_path / "ant.xml"
    free.write_text(text.replace('<option integrator="RK4" timestep="0.01"/>',
                                 '<option integrator="RK4" timestep="0.01"><flag limit="disable"/></option>'))
    no_margin = tmp_path / "ant_no_margin.xml"
    no_margin.write_text(free.read_text().replace('friction="1 0.5 0.5" margin="0.01"', 'friction="1 0.5 0.5" margin="0"'))
    assert free.read_text() != text and no_margin.read_text() != free.read_text()
    ours = scm_run(free, 2.0, 0.5)[-1]
    ours_at_zero_margin = scm_run(no_margin, 2.0, 0.5)[-1]
    m, (theirs,) = mujoco_run(free, [2.0])
    m0, (theirs_at_zero_margin,) = mujoco_run(no_margin, [2.0])
    assert m.geom_margin.min() == 0.01 and m0.geom_margin.max() == 0.0
    # The margin lifts each engine's ant by the two geoms' margins, less its contacts' own depth.
    for name, lift in (("MuJoCo", theirs[2] - theirs_at_zero_margin[2]),
                       ("SCM", ours["root.pos.z"] - ours_at_zero_margin["root.pos.z"])):
        assert 0.018 < lift < 0.021, (name, lift)
    # SCM's ant rests within 3 mm of MuJoCo's either way (resting depths differ by about 1 mm).
    for o, t in ((ours, theirs), (ours_at_zero_margin, theirs_at_zero_margin)):
        assert abs(o["root.pos.z"] - t[2]) < 0.003, (o["root.pos.z"], t[2])
        for k in range(1, 5):
            a = m.joint(f"ankle_{k}").qposadr[0]
            assert abs(o[f"ankle_{k}.q"] - t[a]) < 0.01, (k, o[f"ankle_{k}.q"], t[a])


def test_the_ant_as_written_creeps_down_with_mujocos_for_8_s(tmp_path):
    """The ant as written (MuJoCo's RK4, SCM's damped_rk4, 10 ms) at rest on its feet: its
    friction implicit in velocity at every stage and its limits with MuJoCo's statics and
    impedance (docs/mjcf.md, "Joint limits"), its legs splay slowly against the feet's
    friction as MuJoCo's do (measured: torso 0.568 m at 2 s and 0.546 m at 8 s, MuJoCo's 0.561
    and 0.518 m), without turning or sliding sideways. Under SCM's rk4 the friction's slope at
    zero slip, mu N / v_s, is explicit, and at the default stiction velocity (1 cm/s) RK4 does
    not carry it at 10 ms: a host that switches to rk4 (keeping the file's pair law, which has
    no stiction floor) is refused by the energy guard as the ant settles (measured at 0.77 s;
    a scene that names rk4 gets the floor, docs/mjcf.md "Stiction floor")."""
    seconds = list(range(1, 9))
    rows = scm_run(GYM / "ant.xml", 8.0, 1.0)[1:]
    m, theirs = mujoco_run(GYM / "ant.xml", seconds)
    for row, qpos, t in zip(rows, theirs, seconds):
        print(f"{t} s: torso SCM {row['root.pos.z']:.4f} m, MuJoCo {qpos[2]:.4f} m")
        assert abs(row["time"] - t) < 1e-9
        assert abs(row["root.pos.z"] - qpos[2]) < 0.03, (t, row["root.pos.z"], qpos[2])
        # No turn about the vertical (the quaternion's z part is half the yaw), no sliding.
        assert abs(row["root.quat.z"]) < 1e-4 and abs(qpos[6]) < 1e-4
        assert abs(row["root.linvel.x"]) < 1e-6 and abs(row["root.linvel.y"]) < 1e-6
    # Creeping down in both, by no more than a few centimetres a second.
    heights = [r["root.pos.z"] for r in rows]
    assert all(0 < a - b < 0.01 for a, b in zip(heights[1:], heights[2:])), heights
    run = subprocess.run([str(SCM), "simulate", str(GYM / "ant.xml"), "--duration", "8",
                          "--integrator", "rk4", "-o", "/dev/null"], capture_output=True, text=True)
    assert run.returncode == 1, run.stderr
    assert re.search(r"the integration is unstable: .* at t = \d\.\d+ s", run.stderr), run.stderr


def test_the_ants_blow_up_under_semi_implicit_euler_is_refused():
    """Issue 40's silent blow-up, kept reproducible: the ant with semi-implicit Euler at its
    10 ms step gains energy at its first strike on the floor (a leg's tip weighs 0.078 kg
    against the 0.25 kg its contact law is sized on) and is refused by the energy guard."""
    run = subprocess.run([str(SCM), "simulate", str(GYM / "ant.xml"), "--duration", "1",
                          "--integrator", "semi_implicit_euler", "-o", "/dev/null"],
                         capture_output=True, text=True)
    assert run.returncode == 1 and "the integration is unstable" in run.stderr, run.stderr
    # Its first strike, where the leg tips land (measured: from 7.59 J at 0.2 s to 588 J by 0.22 s).
    assert "at t = 0.2 s" in run.stderr, run.stderr


def test_refsafe_holds_a_limits_time_constant_at_twice_the_step(tmp_path):
    """MuJoCo's refsafe holds every constraint's time constant at twice the step or more,
    limits included: a pendulum resting on a limit of `solreflimit="0.001 1"` at 2 ms rests in
    MuJoCo, whose run with `<flag refsafe="disable"/>` goes unstable. SCM's limit spring is
    sized on the held 4 ms (16 times softer than on 1 ms), the run rests, and without the
    flag the guard refuses it: under this file's Euler the limit has MuJoCo's statics, its
    damping implicit and its spring explicit in position, and at 1 ms its spring (h ω ≈ 9 at
    2 ms) gains energy on the step that enters the limit (9.2 J before, 11.4 J after, measured),
    which the guard refuses."""
    def scene(flag):
        return f"""<mujoco>
  <compiler angle="radian"/>
  <option timestep="0.002">{flag}</option>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="h" axis="0 1 0" range="-0.1 0.5" solreflimit="0.001 1" damping="0.5"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.02" mass="1"/>
    </body>
  </worldbody>
</mujoco>
"""
    stiffness, final = {}, {}
    for name, flag in (("held", ""), ("raw", '<flag refsafe="disable"/>')):
        path = tmp_path / f"{name}.xml"
        path.write_text(scene(flag))
        compiled = json.loads(subprocess.run([str(SCM), "compile", str(path)], capture_output=True,
                                             text=True, check=True).stdout)
        stiffness[name] = next(j for j in compiled["joints"] if j["name"] == "h")["limit_stiffness"]
        m = mujoco.MjModel.from_xml_path(str(path))
        d = mujoco.MjData(m)
        mujoco.mj_step(m, d, 1500)
        # MuJoCo warns and resets on a position, velocity or acceleration it cannot take.
        final[name] = not any(d.warning[w].number for w in (mujoco.mjtWarning.mjWARN_BADQPOS,
                                                            mujoco.mjtWarning.mjWARN_BADQVEL,
                                                            mujoco.mjtWarning.mjWARN_BADQACC))
        run = subprocess.run([str(SCM), "simulate", str(path), "--duration", "3", "-o", str(tmp_path / "run.csv")],
                             capture_output=True, text=True)
        if name == "held":
            assert final[name], "MuJoCo rests with refsafe on"
            assert run.returncode == 0, run.stderr
            rows = list(csv.reader((tmp_path / "run.csv").open()))
            last = dict(zip(rows[0], map(float, rows[-1])))
            assert abs(last["h.v"]) < 1e-6 and 0.5 < last["h.q"] < 0.51, last
        else:
            assert not final[name], "MuJoCo goes unstable without refsafe"
            assert run.returncode == 1 and "the integration is unstable" in run.stderr, run.stderr
    assert abs(stiffness["raw"] / stiffness["held"] - 16.0) < 1e-9, stiffness


def test_a_load_rests_on_a_limit_at_mujocos_static_deflection_under_its_euler_and_implicit(tmp_path):
    """MuJoCo's limit is a constraint whose reference spring carries only 1 - d of a load
    (docs/mjcf.md, "Joint limits"): statically it is 1 / (1 - dmax) times stiffer than its
    reference gains, 20 times at the default solimplimit. Under the integrators that take the
    limit's damping implicitly (damped_euler for MuJoCo's Euler, implicit_euler for its
    implicit), SCM's limit is that stiff: an arm and a hanging block resting on their limits
    sit past them by MuJoCo's static deflection, plus the half onset width w/2 by which SCM's
    C² spring trails the violation, to 0.1 % (measured: 1e-4 mm or mrad on 3 to 18). Under RK4
    (damped_rk4) the limit has the same gains and MuJoCo's impedance as an added inertia, which
    gives it MuJoCo's dynamics at an explicit step: it rests at MuJoCo's deflection too, and so
    does each file run under the other integrator by the host's `solver.integrator` (implicit
    Euler for the RK4 file, rk4 for the Euler file). Before the added inertia RK4 kept the
    reference gains and rested 1 / (1 - dmax) times deeper. dmax 0.95 and 0.8 are both tried."""
    def scene(integrator, solimp):
        return f"""<mujoco>
  <compiler angle="radian"/>
  <option timestep="0.002" integrator="{integrator}"><flag contact="disable"/></option>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="hinge" axis="0 1 0" range="-1 0" solreflimit="0.05 1" {solimp} damping="0.2"/>
      <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.02" mass="2"/>
    </body>
    <body name="block" pos="1 0 1">
      <joint name="slide" type="slide" axis="0 0 1" range="0 1" solreflimit="0.08 1" {solimp} damping="5"/>
      <geom type="box" size="0.05 0.05 0.05" mass="3"/>
    </body>
  </worldbody>
</mujoco>
"""
    w = 1e-3
    for solimp, dmax in (("", 0.95), ('solimplimit="0.9 0.8 0.001"', 0.8)):
        for integrator, ours_name in (("Euler", "damped_euler"), ("implicit", "implicit_euler"), ("RK4", "damped_rk4")):
            path = tmp_path / f"rest_{integrator}_{dmax}.xml"
            path.write_text(scene(integrator, solimp))
            rows = scm_run(path, 3.0, 0.5)
            m = mujoco.MjModel.from_xml_path(str(path))
            d = mujoco.MjData(m)
            mujoco.mj_step(m, d, 1500)
            for name, past in (("hinge", lambda q: q), ("slide", lambda q: -q)):
                j = m.joint(name)
                theirs = past(d.qpos[j.qposadr[0]])
                ours = past(rows[-1][f"{name}.q"])
                assert abs(d.qvel[j.dofadr[0]]) < 1e-6 and abs(rows[-1][f"{name}.v"]) < 1e-6
                # MuJoCo's deflection is past its solimp width (1 mm, 1 mrad): its impedance is dmax.
                assert theirs > 1.5e-3, (name, theirs)
                expected = theirs
                print(f"{integrator} ({ours_name}), dmax {dmax}, {name}: SCM {ours * 1e3:.4f} "
                      f"(less w/2: {(ours - w / 2) * 1e3:.4f}), MuJoCo {theirs * 1e3:.4f}, "
                      f"predicted {expected * 1e3:.4f} (1e-3 m or rad)")
                assert abs((ours - w / 2) - expected) < 1e-3 * expected, (integrator, name, ours, theirs)
            # A host's integrator brings its own limits (`solver.integrator`): the RK4 file run
            # under implicit Euler and the Euler file under rk4 rest at MuJoCo's deflection.
            if integrator in ("RK4", "Euler"):
                switched = scm_run(path, 3.0, 0.5, "--integrator",
                                   "implicit_euler" if integrator == "RK4" else "rk4")
                for name, sign in (("hinge", 1.0), ("slide", -1.0)):
                    j = m.joint(name)
                    theirs = sign * d.qpos[j.qposadr[0]]
                    ours = sign * switched[-1][f"{name}.q"]
                    assert abs((ours - w / 2) - theirs) < 1e-3 * theirs, (integrator, name, ours, theirs)


@pytest.mark.parametrize("integrator,step", [("Euler", 0.002), ("Euler", 0.005), ("implicit", 0.002),
                                             ("implicit", 0.005)])
def test_the_stiffened_limit_throws_a_joint_back_overdamped_at_mujocos_steps(tmp_path, integrator, step):
    """Under the integrators that give the limit MuJoCo's statics (docs/mjcf.md, "Joint
    limits") the limit is overdamped: the joints of SCENE, started outside their ranges, are
    thrown back in at about r0 / (2 tau) instead of MuJoCo's r0 / (tau e), measured between the
    two. Implicit Euler's Newton matrix can turn singular where a limit lets go at these steps
    (src/dynamics/limit.rs, `one_sided`): the run still completes (the step is halved there)."""
    path = tmp_path / "outside.xml"
    path.write_text(SCENE.replace('integrator="RK4"', f'integrator="{integrator}"')
                    .replace('timestep="0.001"', f'timestep="{step}"'))
    ours = scm_run(path, DURATION, 0.01)[-1]
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_step(m, d, round(DURATION / step))
    for name, (r0, tau) in JOINTS.items():
        j = m.joint(name)
        v_ours, v_mujoco = abs(ours[f"{name}.v"]), abs(d.qvel[j.dofadr[0]])
        print(f"{integrator} {step}: {name} SCM {v_ours:.3f}, MuJoCo {v_mujoco:.3f}, r0/(2 tau) {r0 / (2 * tau):.3f}")
        assert v_mujoco < v_ours <= r0 / (2 * tau), (name, v_ours, v_mujoco)
        assert m.jnt_range[j.id][0] < ours[f"{name}.q"] < m.jnt_range[j.id][1]


def test_a_pendulum_settles_on_its_limit_under_eulers_without_eulerdamp_as_in_mujoco(tmp_path):
    """MJCF's Euler with `eulerdamp` disabled is SCM's semi-implicit Euler, under which a limit
    has MuJoCo's impedance as an added inertia and counts its spring's energy at the reference
    stiffness. Under a load that count drifts by (1 - 1/statics) G Δr: a pendulum that falls
    onto its limit, swings in deep and settles back to rest raised its count by 1.7 mJ of
    3.85 J, and the guard, its balance restarted at the deepest swing, refused the run at
    0.3 s (joint and tendon alike) where MuJoCo runs it. The guard now counts that drift as
    stored energy (`JointLimit::load_drift`): both run 2 s and rest where MuJoCo's do, past the
    limit by at most MuJoCo's deflection plus the half onset (0.5 mrad on the hinge)."""
    arm = """<body name="arm" pos="0 0 1">
      <joint name="hinge" type="hinge" axis="0 1 0" damping="0.2" {range}/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" contype="0" conaffinity="0"/>
    </body>"""
    scenes = {
        "joint": (arm.format(range='range="-1 0.3"'), ""),
        "tendon": (arm.format(range=""), '<tendon><fixed name="strap" range="-1 0.6">'
                   '<joint joint="hinge" coef="2"/></fixed></tendon>'),
    }
    for name, (body, tendon) in scenes.items():
        path = tmp_path / f"{name}.xml"
        path.write_text(f"""<mujoco>
  <compiler angle="radian"/>
  <option timestep="0.002"><flag eulerdamp="disable"/></option>
  <worldbody>{body}</worldbody>{tendon}
</mujoco>""")
        run = subprocess.run([str(SCM), "simulate", str(path), "--duration", "2",
                              "-o", str(tmp_path / "run.csv")], capture_output=True, text=True)
        assert run.returncode == 0, (name, run.stderr)
        rows = list(csv.reader((tmp_path / "run.csv").open()))
        last = dict(zip(rows[0], map(float, rows[-1])))
        m = mujoco.MjModel.from_xml_path(str(path))
        d = mujoco.MjData(m)
        mujoco.mj_step(m, d, 1000)
        assert abs(d.qpos[0] - 0.3) < 2e-3, (name, d.qpos[0])
        assert abs(last["hinge.v"]) < 1e-6, (name, last)
        assert 0.0 <= last["hinge.q"] - d.qpos[0] < 0.6e-3, (name, last["hinge.q"], d.qpos[0])
