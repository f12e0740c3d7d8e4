"""Each contact pair's parameters as MuJoCo's files mean them (docs/mjcf.md, "Contact stiffness
from solref and solimp"), compared with MuJoCo on the same file: the solref and solimp MuJoCo's
collision driver gives each contact (d.contact after mj_forward: geoms mixed by solmix, the higher
priority winning, negative solref by the smaller entry, a <pair>'s own values and its default
class's) against `scm compile`'s pairs, each pair's effective mass against MuJoCo's
body_invweight0, and the share of its pyramidal friction cone against the friction and condim
MuJoCo's driver gives the contact. A host's setting of a contact parameter that no pair uses is refused with why."""
import json
import subprocess

import mujoco
import numpy as np
import pytest

from conftest import SCM

# One pytest-xdist worker runs this module's tests: MuJoCo's contacts are computed once, in a module fixture.
pytestmark = pytest.mark.xdist_group("contact_params")

SCENE = """<mujoco>
  <option timestep="0.002"/>
  <default><pair solimp="0.85 0.9 0.003 0.5 2"/></default>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1" solref="0.01 1" solmix="3"/>
    <body name="mixed" pos="0 0 0.049"><freejoint/>
      <geom type="sphere" size="0.05" solref="0.03 0.5" solimp="0.8 0.9 0.002 0.4 3"/></body>
    <body name="priority" pos="0.2 0 0.049"><freejoint/>
      <geom type="sphere" size="0.05" priority="1" solref="0.04 1.2" mass="3" friction="0.5"/></body>
    <body name="direct" pos="0.4 0 0.049"><freejoint/>
      <geom type="sphere" size="0.05" solref="-20000 -50"/></body>
    <body name="solmix0" pos="0.6 0 0.049"><freejoint/>
      <geom type="sphere" size="0.05" solmix="0" solimp="0.7 0.8 0.01" condim="4" friction="1.3"/></body>
    <body name="explicit" pos="0.8 0 0.049"><freejoint/>
      <geom name="alone" type="sphere" size="0.05" contype="0" conaffinity="0"/></body>
    <body name="arm" pos="1.2 0 0.3">
      <joint name="hinge" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.27" size="0.03" mass="0.5"/>
      <body name="hand" pos="0 0 -0.27"><joint type="hinge" axis="0 1 0"/>
        <geom type="sphere" size="0.031" mass="0.2"/></body>
    </body>
  </worldbody>
  <contact><pair geom1="floor" geom2="alone" solref="0.06 1" condim="6" friction="0.8 0.8 0.005 0.0001 0.0001"/></contact>
</mujoco>
"""


@pytest.fixture(scope="module")
def both(tmp_path_factory):
    path = tmp_path_factory.mktemp("params") / "params.xml"
    path.write_text(SCENE)
    out = subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True,
                         check=True).stdout
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    return path, json.loads(out), m, d


def test_pairs_mix_solref_and_solimp_as_mujoco_does(both):
    _, compiled, m, d = both
    ours = {(p["body1"], p["body2"]): p for p in compiled["pairs"]}
    seen = set()
    for c in d.contact[:d.ncon]:
        bodies = tuple(sorted((m.body(m.geom_bodyid[g]).name for g in c.geom), key=lambda n:
                              [b["name"] for b in compiled["bodies"]].index(n)))
        pair = ours[bodies]
        np.testing.assert_allclose(pair["solref"], c.solref, rtol=1e-12, err_msg=str(bodies))
        np.testing.assert_allclose(pair["solimp"], c.solimp, rtol=1e-12, err_msg=str(bodies))
        b1, b2 = (m.body(n).id for n in bodies)
        mass = 1.0 / (m.body_invweight0[b1, 0] + m.body_invweight0[b2, 0])
        assert pair["mass"] == pytest.approx(mass, rel=1e-9), bodies
        # The share of MuJoCo's pyramidal cone in the normal, from the friction and condim its
        # collision driver gave the contact (docs/mjcf.md, "The friction cone").
        mu = c.friction[0]
        share = (c.dim - 1) * m.opt.impratio / (mu * mu * (1 + mu * mu)) if c.dim > 1 else 1.0
        assert pair["cone_share"] == pytest.approx(share, rel=1e-12), (bodies, mu, c.dim)
        seen.add(bodies)
    # Every body touches the floor in MuJoCo, the two arm links and the pair's sphere included.
    assert len(seen) == 7, seen
    explicit = ours[("world", "explicit")]
    assert explicit["solref"] == [0.06, 1.0] and explicit["solimp"] == [0.85, 0.9, 0.003, 0.5, 2.0]


def test_check_shows_each_pairs_law(both):
    path, _, _, _ = both
    out = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True).stdout
    line = next(l for l in out.splitlines() if l.startswith("pair world - priority"))
    assert "solref [0.04, 1.2]" in line and "effective mass 3.0000e0 kg" in line, line
    assert "stiffness" in line and "dissipation velocity" in line, line
    # A finite dissipation force says whether it holds a separation (docs/method.md, departure 4).
    for extra, held in (('<custom><numeric name="scm_dissipation_force" data="2.5"/></custom>', True),
                        ('<custom><text name="scm_integrator" data="rk4"/></custom>', False)):
        compile_with(path, extra)
        out = subprocess.run([str(SCM), "check", str(path.parent / "variant.xml")], capture_output=True,
                             text=True).stdout
        line = next(l for l in out.splitlines() if l.startswith("pair world - priority"))
        assert "dissipation force" in line and ("a separation held" in line) is held, line


def test_a_parameter_no_pair_uses_is_refused_with_why(both):
    path, _, _, _ = both
    for name in ["scm.stiffness", "scm.dissipation_velocity", "scm.friction"]:
        run = subprocess.run([str(SCM), "simulate", str(path), "--duration", "0.01",
                              "--set", f"{name}=0.3"], capture_output=True, text=True)
        assert run.returncode != 0, name
        assert f"{name} = 0.3 refused: no contact pair uses it" in run.stderr, run.stderr
        assert f"scm_{name[4:]}" in run.stderr, run.stderr
    # Setting it to the value it has (as a host that writes every start value does) is no change.
    run = subprocess.run([str(SCM), "simulate", str(path), "--duration", "0.01", "--set",
                          "scm.stiffness=10000"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    # With scm_stiffness in the scene every pair takes it, and the parameter acts.
    text = SCENE.replace("<worldbody>", '<custom><numeric name="scm_stiffness" data="1e4"/>'
                         '</custom><worldbody>')
    scene = path.parent / "global.xml"
    scene.write_text(text)
    runs = [subprocess.run([str(SCM), "simulate", str(scene), "--duration", "0.05", "--set",
                            f"scm.stiffness={k}"], capture_output=True, text=True, check=True).stdout
            for k in (1e4, 3e4)]
    assert runs[0] != runs[1]


def compile_with(path, before_worldbody):
    scene = path.parent / "variant.xml"
    scene.write_text(SCENE.replace("<worldbody>", before_worldbody + "<worldbody>"))
    return subprocess.run([str(SCM), "compile", str(scene)], capture_output=True, text=True)


def test_the_dissipation_force_follows_the_integrator_and_the_setting(both):
    """Each pair's dissipation force (docs/method.md, departure 4) is four times its resting
    force m̂ g under an integrator that takes the contact's damping explicitly (rk4, named by the
    scene's scm_integrator), eight times under MuJoCo's Euler (damped_euler), RK4 (damped_rk4)
    and implicit integrators, and f m̂ g where the scene sets scm_dissipation_force f (0: none,
    the paper's law, null in the JSON). The damping at rest, F/V at the resting force, is
    MuJoCo's m̂ d B in every case. A finite force holds a separation to a few v_d where the
    integrator takes the damping implicitly (`hold_separation`, docs/method.md, departure 4):
    the defaults' 8 and the scene's 2.5 under MuJoCo's integrators, not rk4's 4."""
    path, compiled, m, d = both
    g = 9.81
    settings = {  # the scene's addition: the dissipation force over m̂ g, and whether it holds
        "": (8.0, True),
        '<option integrator="implicitfast"/>': (8.0, True),
        '<option integrator="RK4"/>': (8.0, True),
        '<custom><text name="scm_integrator" data="rk4"/></custom>': (4.0, False),
        '<custom><numeric name="scm_dissipation_force" data="2.5"/></custom>': (2.5, True),
        '<option integrator="RK4"/><custom><numeric name="scm_dissipation_force" data="0"/></custom>': (None, False),
    }
    for extra, (f, hold) in settings.items():
        run = compile_with(path, extra)
        assert run.returncode == 0, run.stderr
        for pair in json.loads(run.stdout)["pairs"]:
            weight = pair["mass"] * g
            if f is None:
                assert pair["dissipation_force"] is None, (extra, pair)
                rest = weight / pair["dissipation_velocity"]
            else:
                assert pair["dissipation_force"] == pytest.approx(f * weight, rel=1e-12), (extra, pair)
                rest = weight / (pair["dissipation_velocity"] * (1 + 1 / f))
            # MuJoCo's damping at rest, m̂ d(r) B: the same whatever the bound.
            reference = next(p for p in compiled["pairs"] if p["body1"] == pair["body1"]
                             and p["body2"] == pair["body2"])
            assert reference["dissipation_force"] == pytest.approx(8.0 * weight, rel=1e-12)
            assert rest == pytest.approx(weight / (reference["dissipation_velocity"] * (1 + 1 / 8.0)), rel=1e-12)
            assert pair["hold_separation"] is hold, (extra, pair)


def test_a_dissipation_force_out_of_range_or_without_effect_is_said(both):
    path, _, _, _ = both
    bad = path.parent / "bad.xml"
    bad.write_text(SCENE.replace("<worldbody>", '<custom><numeric name="scm_dissipation_force" '
                                 'data="-1"/></custom><worldbody>'))
    for command in ("check", "pack"):
        run = subprocess.run([str(SCM), command, str(bad), "-o", str(path.parent / "bad.fmu")]
                             if command == "pack" else [str(SCM), command, str(bad)],
                             capture_output=True, text=True)
        assert run.returncode != 0, command
        assert "scm_dissipation_force" in run.stderr and "out of range" in run.stderr, run.stderr
    run = compile_with(path, '<custom><numeric name="scm_dissipation_force" data="4"/>'
                             '<numeric name="scm_stiffness" data="1e4"/></custom>')
    assert run.returncode == 0, run.stderr
    warnings = json.loads(run.stdout)["warnings"]
    assert any("scm_dissipation_force" in w and "no effect" in w for w in warnings), warnings


MARGINS = """<mujoco>
  <option timestep="0.002" {option}>{flag}</option>
  <default><pair margin="0.003"/></default>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1" margin="0.002" gap="0.001"/>
    <body name="summed" pos="0 0 0.05"><freejoint/>
      <geom type="sphere" size="0.05" margin="0.004"/></body>
    <body name="priority" pos="0.2 0 0.05"><freejoint/>
      <geom type="sphere" size="0.05" priority="2" solmix="5" margin="0.001"/></body>
    <body name="explicit" pos="0.4 0 0.05"><freejoint/>
      <geom name="alone" type="sphere" size="0.05" margin="0.02" contype="0" conaffinity="0"/></body>
    <body name="own" pos="0.6 0 0.05"><freejoint/>
      <geom name="own" type="sphere" size="0.05" margin="0.02" contype="0" conaffinity="0"/></body>
  </worldbody>
  <contact><pair geom1="floor" geom2="alone"/><pair geom1="floor" geom2="own" margin="0.007" condim="1"/></contact>
</mujoco>
"""


@pytest.mark.parametrize("override", [False, True])
def test_pairs_margins_are_mujocos(override, tmp_path):
    """Each pair's margin is MuJoCo's `includemargin` on the same file: the sum of the two geoms'
    `margin` whatever their priority or solmix, a `<pair>`'s own (its default class's, not its
    geoms'), and under `<flag override="enable">` the option's `o_margin` for every contact, a
    pair's included (with `o_solref`, `o_solimp` and `o_friction`). A geom's `gap` changes
    nothing MuJoCo's solver sees (its inactive contacts only)."""
    option, flag = ('o_margin="0.005" o_solref="0.03 1.1" o_friction="0.4"',
                    '<flag override="enable"/>') if override else ("", "")
    path = tmp_path / "margins.xml"
    path.write_text(MARGINS.format(option=option, flag=flag))
    compiled = json.loads(subprocess.run([str(SCM), "compile", str(path)], capture_output=True,
                                         text=True, check=True).stdout)
    ours = {p["body2"]: p for p in compiled["pairs"] if p["body1"] == "world"}
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    seen = set()
    for c in d.contact[:d.ncon]:
        body = m.body(max(m.geom_bodyid[g] for g in c.geom)).name
        assert ours[body]["margin"] == pytest.approx(c.includemargin, abs=1e-15), body
        np.testing.assert_allclose(ours[body]["solref"], c.solref, rtol=1e-12, err_msg=body)
        seen.add(body)
    assert seen == {"summed", "priority", "explicit", "own"}, seen
    expected = {"summed": 0.006, "priority": 0.003, "explicit": 0.003, "own": 0.007}
    for body, margin in expected.items():
        assert ours[body]["margin"] == pytest.approx(0.005 if override else margin), body
    check = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True).stdout
    line = next(l for l in check.splitlines() if l.startswith("pair world - summed"))
    assert f"margin {0.005 if override else 0.006} m" in line, line
    assert ("friction 0.4" in line) == override, line
    # A pair's own condim="1" keeps it frictionless under override too, as MuJoCo's pair_dim.
    own = next(l for l in check.splitlines() if l.startswith("pair world - own"))
    assert own.startswith("pair world - own: friction 0,"), own
    assert next(c.dim for c in d.contact[:d.ncon] if m.body(max(m.geom_bodyid[g] for g in c.geom)).name == "own") == 1


def test_the_stiction_floor_follows_the_integrator_and_a_setting_below_it_is_refused(tmp_path):
    """Under an integrator that takes the friction explicitly each pair's stiction velocity is at
    least 2 h mu g (h the file's step; docs/mjcf.md, "Stiction floor"); `scm check` and `scm
    compile` show it; a host's scm.stiction_velocity acts above it and is refused below every
    pair's, saying why; `scm_stiction_floor` sets the multiple (0: none) whatever the
    integrator, and a negative one is refused; a scene's own `scm_stiction_velocity` means no
    floor unless it sets one."""
    def scene(option, custom="", more=""):
        path = tmp_path / "floor.xml"
        path.write_text(f"""<mujoco><option timestep="0.005" {option}/>{custom}<worldbody>
<geom name="floor" type="plane" size="1 1 0.1" friction="0.6"/>
<body name="a" pos="0 0 0.05"><freejoint/><geom type="box" size="0.05 0.05 0.05" friction="0.6"/></body>
{more}</worldbody></mujoco>""")
        return path

    def floor(path):
        out = subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        return json.loads(out.stdout)["pairs"][0]["stiction_floor"]

    # SCM's rk4, named by the scene, takes the friction explicitly.
    rk4 = '<text name="scm_integrator" data="rk4"/>'
    assert floor(scene("", f"<custom>{rk4}</custom>")) == pytest.approx(2 * 0.005 * 0.6 * 9.81, rel=1e-12)
    assert floor(scene('integrator="RK4"')) == 0.0  # MuJoCo's RK4: SCM's damped_rk4, friction implicit
    assert floor(scene("")) == 0.0  # MuJoCo's Euler: SCM's damped_euler, friction implicit
    assert floor(scene('integrator="implicitfast"')) == 0.0
    custom = '<custom><numeric name="scm_stiction_floor" data="{}"/></custom>'
    assert floor(scene("", custom.format(3))) == pytest.approx(3 * 0.005 * 0.6 * 9.81, rel=1e-12)
    assert floor(scene("", f'<custom>{rk4}<numeric name="scm_stiction_floor" data="0"/></custom>')) == 0.0
    # A scene that sets its own stiction velocity chose it: no floor, unless it sets one too.
    own = '<custom>' + rk4 + '<numeric name="scm_stiction_velocity" data="0.002"/>{}</custom>'
    assert floor(scene("", own.format(""))) == 0.0
    both = own.format('<numeric name="scm_stiction_floor" data="1"/>')
    assert floor(scene("", both)) == pytest.approx(0.005 * 0.6 * 9.81, rel=1e-12)
    bad = subprocess.run([str(SCM), "check", str(scene("", custom.format(-1)))], capture_output=True,
                         text=True)
    assert bad.returncode != 0 and "scm_stiction_floor" in bad.stdout + bad.stderr
    path = scene("", f"<custom>{rk4}</custom>")
    line = next(l for l in subprocess.run([str(SCM), "check", str(path)], capture_output=True,
                                          text=True).stdout.splitlines() if l.startswith("pair"))
    assert "stiction velocity at least 5.8860e-2 m/s (its stiction floor)" in line, line

    def run(value):
        return subprocess.run([str(SCM), "simulate", str(path), "--duration", "0.05", "--set",
                               f"scm.stiction_velocity={value}"], capture_output=True, text=True)
    below = run(0.05)
    assert below.returncode != 0 and "held at 5.8860e-2 m/s or more" in below.stderr, below.stderr
    assert "scm_stiction_floor" in below.stderr
    assert run(0.01).returncode == 0  # the start value, unchanged: accepted
    assert run(0.2).returncode == 0 and run(0.2).stdout != run(0.1).stdout
    # A joint's dry friction reads the same parameter: there a value under the floor acts.
    path = scene('integrator="RK4"', more='<body name="arm" pos="1 0 1"><joint name="h" axis="0 1 0" '
                 'frictionloss="0.5"/><geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" '
                 'contype="0" conaffinity="0"/></body>')
    below = run(0.05)
    assert below.returncode == 0, below.stderr
    assert below.stdout != run(0.01).stdout


def test_under_rk4_a_loaded_box_creeps_at_the_stiction_floors_scale_where_mujocos_holds(tmp_path):
    """The ant's splay when MJCF's RK4 was SCM's rk4 (docs/mjcf.md, "Stiction floor"), in a small
    scene: a 1 kg box on a floor under a sideways load of 0.3 times its weight (gravity tilted),
    10 ms. SCM's regularized friction lets a foot under a tangential load F_t slide at about
    v_s F_t / (mu N): under rk4 (named by the scene), whose stiction velocity is held at
    2 h mu g (19.6 cm/s here), about 6 cm/s; under damped_euler (MuJoCo's Euler), damped_rk4
    (its RK4: RK4 with the friction implicit at every stage, as MuJoCo's solver makes it) and
    implicit_euler (its implicitfast), where the friction is implicit in velocity and the default
    1 cm/s stands, 3 mm/s. MuJoCo's friction is an acceleration-level constraint whatever the
    integrator: its box creeps at 1.5 mm/s under Euler, RK4 and implicitfast alike (measured)."""
    def scene(integrator, ours=None):
        custom = f'<custom><text name="scm_integrator" data="{ours}"/></custom>' if ours else ""
        return f"""<mujoco><option timestep="0.01" integrator="{integrator}" gravity="{0.3 * 9.81} 0 -9.81"/>
{custom}<worldbody><geom name="floor" type="plane" size="5 5 0.1"/>
<body name="a" pos="0 0 0.0496"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="1"/></body>
</worldbody></mujoco>"""

    def mujoco_speed(integrator):
        m = mujoco.MjModel.from_xml_string(scene(integrator))
        d = mujoco.MjData(m)
        while d.time < 1 - 1e-9:
            mujoco.mj_step(m, d)
        x1 = d.qpos[0]
        while d.time < 2 - 1e-9:
            mujoco.mj_step(m, d)
        return d.qpos[0] - x1

    def scm_speed(integrator, ours=None):
        path = tmp_path / "creep.xml"
        path.write_text(scene(integrator, ours))
        out = subprocess.run([str(SCM), "simulate", str(path), "--duration", "2", "--output-interval", "1",
                              "--outputs", "a.pos.x"], capture_output=True, text=True, check=True).stdout
        x = [float(line.split(",")[1]) for line in out.splitlines()[1:]]
        return x[2] - x[1]

    speeds = {i: (mujoco_speed(i), scm_speed(i)) for i in ("RK4", "Euler", "implicitfast")}
    print({i: f"MuJoCo {a * 1e3:.2f} mm/s, SCM {b * 1e3:.2f} mm/s" for i, (a, b) in speeds.items()})
    for integrator, (theirs, _) in speeds.items():
        assert 0 < theirs < 3e-3, (integrator, theirs)
    # The regularized friction mu N v / sqrt(v_s^2 + v^2) balances F_t = 0.3 N at
    # v = v_s 0.3 / sqrt(1 - 0.09): 3.145 mm/s at 1 cm/s (measured 3.14), 61.7 mm/s at the floor
    # (measured 64.4 under RK4: 4.4 % more, not explained yet).
    ratio = 0.3 / np.sqrt(1 - 0.09)
    assert scm_speed("RK4", "rk4") == pytest.approx(ratio * 2 * 0.01 * 9.81, rel=0.06)
    for integrator in ("RK4", "Euler", "implicitfast"):
        assert speeds[integrator][1] == pytest.approx(ratio * 0.01, rel=0.01), integrator


def test_a_hosts_eps3_sizes_each_pairs_stiffness_as_the_scenes_does(tmp_path):
    """Each pair's stiffness from the file is `m̂ g / s⁺_ε3(r_g)`. A host's `scm.eps3` sizes it
    as the scene's `scm_eps3` does. This matters where MuJoCo's resting depth `r_g` is below
    `ε3`: here `solimp` 0.99 to 0.999 puts it at 0.04 mm. Before, the host's setting kept the
    stiffness sized at the scene's 1e-4: the nut on its bolt turned 0.1877 rad under the
    host's 2e-5 against 0.1546 under the scene's (docs/mjcf.md)."""
    body = """<worldbody><geom type="plane" size="1 1 0.1" solimp="0.99 0.999 0.001"/>
<body name="box" pos="0 0 0.05"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="2" solimp="0.99 0.999 0.001"/></body>
</worldbody></mujoco>"""
    runs = {}
    for name, custom, sets in (("default", "", []), ("host", "", ["--set", "scm.eps3=2e-5"]),
                               ("scene", '<custom><numeric name="scm_eps3" data="2e-5"/></custom>', [])):
        path = tmp_path / f"{name}.xml"
        path.write_text(f'<mujoco><option timestep="0.002"/>{custom}{body}')
        law = json.loads(subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True,
                                        check=True).stdout)["pairs"][0]
        out = subprocess.run([str(SCM), "simulate", str(path), "--duration", "0.3", "--output-interval", "0.3",
                              "--outputs", "box.pos.z"] + sets, capture_output=True, text=True, check=True).stdout
        runs[name] = (law, float(out.strip().splitlines()[-1].split(",")[1]))
    (law, default), (_, host), (scene_law, scene) = runs["default"], runs["host"], runs["scene"]
    assert law["mujoco_depth"] < 1e-4
    # The scene's law is stiffer (the softplus at 2e-5 is smaller at that depth).
    assert scene_law["stiffness"] > 1.5 * law["stiffness"], (law, scene_law)
    # Both laws rest at MuJoCo's depth, so the box ends 0.28 µm apart (measured) from the run at
    # the default; the host's ε3 gives the scene's run to the bit (before, it kept the 1e-4 law).
    assert abs(scene - default) > 1e-8 and host == scene, (default, host, scene)
