"""Names from MJCF files give FMU variable names that FMI hosts accept: quoted where they are not
plain identifiers, unique by construction, never a panic. fmpy's validate_fmu checks the
structured naming convention."""
import functools
import random
import subprocess
from types import SimpleNamespace
from xml.sax.saxutils import quoteattr

import lark
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from conftest import SCM


def pack(tmp_path, xml, name="scene"):
    path = tmp_path / f"{name}.xml"
    path.write_text(xml, encoding="utf-8")
    fmu = tmp_path / f"{name}.fmu"
    out = subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "panicked" not in out.stderr
    return str(fmu)


def arm(upper, lower, j1, j2, motor):
    return f"""<mujoco model="arm">
  <worldbody>
    <body name={quoteattr(upper)} pos="0 0 1">
      <joint name={quoteattr(j1)} axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      <body name={quoteattr(lower)} pos="0.3 0 0">
        <joint name={quoteattr(j2)} axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      </body>
    </body>
  </worldbody>
  <actuator><motor name={quoteattr(motor)} joint={quoteattr(j1)}/></actuator>
</mujoco>"""


def test_spaces_and_hyphens_give_names_that_validate(tmp_path):
    fmu = pack(tmp_path, arm("left arm", "fore-arm", "hinge-1", "elbow joint", "motor 1"))
    assert validate_fmu(fmu) == []
    names = {v.name for v in read_model_description(fmu).modelVariables}
    assert {"'hinge-1'.q", "'elbow joint'.v", "'motor 1'.ctrl"} <= names


def test_dotted_body_names_do_not_collide(tmp_path):
    # Bodies a.b and c beside a and b.c: their contact outputs stay apart.
    xml = """<mujoco model="dots">
  <worldbody>
    <body name="a.b" pos="0 0 1"><freejoint/><geom type="sphere" size="0.1"/></body>
    <body name="c" pos="0 0 2"><freejoint/><geom type="sphere" size="0.1"/></body>
    <body name="a" pos="1 0 1"><freejoint/><geom type="sphere" size="0.1"/></body>
    <body name="b.c" pos="1 0 2"><freejoint/><geom type="sphere" size="0.1"/></body>
  </worldbody>
</mujoco>"""
    fmu = pack(tmp_path, xml)
    assert validate_fmu(fmu) == []
    names = [v.name for v in read_model_description(fmu).modelVariables]
    assert len(names) == len(set(names))
    assert "contact.'a.b'.c.distance" in names and "contact.a.'b.c'.distance" in names


def test_an_unnamed_free_joint_is_named_after_its_body_either_way(tmp_path):
    xml = """<mujoco model="free">
  <worldbody>
    <body name="one" pos="0 0 1"><freejoint/><geom type="sphere" size="0.1"/></body>
    <body name="two" pos="1 0 1"><joint type="free"/><geom type="sphere" size="0.1"/></body>
  </worldbody>
</mujoco>"""
    names = {v.name for v in read_model_description(pack(tmp_path, xml)).modelVariables}
    assert {"one.pos.x", "two.pos.x"} <= names


ALPHABET = "ab_Z09 .-'\\\"&<>äöλ日本→"


def random_name(rng):
    return "".join(rng.choice(ALPHABET) for _ in range(rng.randint(1, 6)))


def test_generated_names_never_panic_and_always_validate(tmp_path):
    rng = random.Random(20261125)
    for case in range(12):
        # Body, joint and actuator names from the same small pool, so that names repeat across
        # kinds; a free joint and a mocap body share a name in every case.
        pool = [random_name(rng) for _ in range(3)]
        upper, lower = pool[0], pool[0] + "x" if rng.random() < 0.5 else pool[1]
        shared = random_name(rng)
        xml = f"""<mujoco model="names{case}">
  <worldbody>
    <body name={quoteattr(upper)} pos="0 0 1">
      <joint name={quoteattr(pool[1])} axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      <body name={quoteattr(lower)} pos="0.3 0 0">
        <joint name={quoteattr(pool[2])} axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      </body>
    </body>
    <body name={quoteattr(shared + "_free")} pos="2 0 1"><joint type="free" name={quoteattr(shared)}/><geom type="sphere" size="0.1"/></body>
    <body name={quoteattr(shared)} mocap="true" pos="3 0 1"><geom type="box" size="0.1 0.1 0.1"/></body>
  </worldbody>
  <actuator><motor name={quoteattr(pool[0])} joint={quoteattr(pool[1])}/></actuator>
</mujoco>"""
        if upper == lower or pool[1] == pool[2]:
            continue  # MuJoCo refuses repeated names of one kind; so does scm
        fmu = pack(tmp_path, xml, f"names{case}")
        problems = validate_fmu(fmu)
        assert problems == [], (case, [upper, lower, pool, shared], problems)
        names = [v.name for v in read_model_description(fmu).modelVariables]
        assert len(names) == len(set(names)), case


def test_the_suites_lalr_name_check_gives_fmpys_verdicts(tmp_path):
    """conftest.py has fmpy check structured names by an LALR parse of its grammar first (40
    times faster on rodent), Earley deciding what LALR refuses; on names SCM writes and on
    strings of the names' alphabet, good or bad, the verdicts are fmpy's own."""
    from conftest import FMPY_NAME_CHECK, name_check_by_lalr
    rng = random.Random(20261203)
    scene = arm("up per", "lo\\wer", "j.1", "j'2", 'm "1"')
    written = [v.name for v in read_model_description(pack(tmp_path, scene)).modelVariables]
    symbols = ALPHABET + "()[],.'\\\"0123456789?"
    strings = ["".join(rng.choice(symbols) for _ in range(rng.randint(1, 12))) for _ in range(400)]
    strings += ["der(x)", "der(a.b[1],2)", "der(x", "a..b", "a[", "a[1,2].b", "'x y'", "'x", "_1", "1a", "'\\q'", "'\\\\'.ctrl"]
    names = written + strings
    model = SimpleNamespace(variableNamingConvention="structured",
                            modelVariables=[SimpleNamespace(name=n, sourceline=i) for i, n in enumerate(names)])
    earley, lalr = FMPY_NAME_CHECK(model), name_check_by_lalr(model)
    assert [p.split(" (line ")[0] for p in earley] == [p.split(" (line ")[0] for p in lalr]
    # Both tell good from bad: SCM's names pass, and some of the random strings do not.
    refused = {int(p.split(" (line ")[1].split(")")[0]) for p in lalr}
    assert refused and min(refused) >= len(written), earley[:3]
    assert len(refused) < len(names) - len(written)
    # LALR alone refuses names fmpy takes (backslashes in quotes): Earley's second look counts.
    lalr_alone = functools.partial(lark.Lark, parser="lalr")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(lark, "Lark", lalr_alone)
        assert len(FMPY_NAME_CHECK(model)) > len(lalr)


BALL = '<body pos="0 0 1"><freejoint/><geom type="sphere" size="0.1"/></body>'
HINGE = '<body name="arm" pos="0 0 1"><joint name="h" axis="0 1 0"/><geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/></body>'
# Each case: a file, and whether MuJoCo's compiler takes it (asserted below, so the table
# cannot drift from MuJoCo).
NAME_CASES = {
    "repeated geom": (f'<worldbody><geom name="a" type="plane" size="1 1 .1"/><body pos="0 0 1"><freejoint/><geom name="a" size=".1"/></body></worldbody>', False),
    "repeated site": (f'<worldbody><site name="s"/><site name="s"/>{BALL}</worldbody>', False),
    "repeated body in a frame": (f'<worldbody><body name="b"><geom size=".1"/></body><frame><body name="b"><geom size=".1"/></body></frame></worldbody>', False),
    "a body named world": ('<worldbody><body name="world"><geom size=".1"/></body></worldbody>', False),
    "repeated tendon": (f'<worldbody>{HINGE}</worldbody><tendon><fixed name="t"><joint joint="h" coef="1"/></fixed><fixed name="t"><joint joint="h" coef="2"/></fixed></tendon>', False),
    "repeated equality": (f'<worldbody>{HINGE}</worldbody><equality><joint name="q" joint1="h"/><joint name="q" joint1="h"/></equality>', False),
    "repeated numeric": (f'<custom><numeric name="n" data="1"/><numeric name="n" data="2"/></custom><worldbody>{BALL}</worldbody>', False),
    "repeated sensor": (f'<worldbody>{HINGE}</worldbody><sensor><jointpos name="s" joint="h"/><jointvel name="s" joint="h"/></sensor>', False),
    "a tendon joint without coef": (f'<worldbody>{HINGE}</worldbody><tendon><fixed><joint joint="h"/></fixed></tendon>', False),
    "one name across kinds": ('<worldbody><body name="x" pos="0 0 1"><joint name="x" axis="0 1 0"/><geom name="x" size=".1"/><site name="x"/></body></worldbody><actuator><motor name="x" joint="x"/></actuator>', True),
    "empty names are no names": (f'<worldbody><geom name="" type="plane" size="1 1 .1"/><body name="" pos="0 0 1"><freejoint name=""/><geom name="" size=".1"/></body></worldbody>', True),
    "a given name that SCM would make up": ('<worldbody><body pos="0 0 1"><joint axis="0 1 0"/><geom size=".1"/></body><body name="body1" pos="1 0 1"><joint name="body1_joint0" axis="0 1 0"/><geom name="body1_geom0" size=".1"/></body></worldbody><actuator><motor joint="body1_joint0"/><motor name="actuator0" joint="body1_joint0"/></actuator>', True),
}


def test_names_are_refused_and_accepted_as_mujoco_does(tmp_path):
    import mujoco
    for label, (body, accepted) in NAME_CASES.items():
        xml = f'<mujoco model="names">\n  {body}\n</mujoco>\n'
        try:
            mujoco.MjModel.from_xml_string(xml)
            theirs = True
        except ValueError:
            theirs = False
        assert theirs == accepted, f"{label}: MuJoCo {'takes' if theirs else 'refuses'} it"
        path = tmp_path / "names.xml"
        path.write_text(xml)
        out = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True)
        assert (out.returncode == 0) == accepted, (label, out.stderr)
        assert "panicked" not in out.stderr
        if not accepted:
            # The refusal names the file and the element's line.
            assert f"{path}:2:" in out.stderr, (label, out.stderr)
        else:
            # Accepted: the FMU's variable names are unique and validate.
            fmu = pack(tmp_path, xml, "accepted")
            assert validate_fmu(fmu) == [], label
            names = [v.name for v in read_model_description(fmu).modelVariables]
            assert len(names) == len(set(names)), label
