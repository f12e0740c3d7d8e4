"""Contact on, SCM against MuJoCo's own spread (docs/mjcf.md, "Contact on, against MuJoCo's
spread"): every gymnasium file and dm_control suite file that moves, run as written (its own
integrator and step) with zero controls for 1 s (2 s for the legged ones), ends inside the
envelope of MuJoCo's final poses under plausible contact parameters (solref's time constant
x0.5, x1, x2, friction x0.8, x1, x1.2, with Euler, RK4 and implicitfast), widened by 2 cm and
0.1 rad. The runs and the comparison are scripts/contact_envelope.py's, which prints the table.

A file SCM does not bring inside yet is a strict xfail with what was measured about it: it fails
the day it comes inside, so the list stays true. dm_control's humanoid_CMU (57 joints, 2 s) is
left to the script: SCM takes 320 s on it on one core, more than this whole module.
"""
import pathlib
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))
import contact_envelope as envelope  # noqa: E402

from conftest import DM_CONTROL_REFUSED  # noqa: E402

pytestmark = pytest.mark.slow

#: Not run here, and why.
NOT_HERE = {
    "dm_control/humanoid_CMU": "SCM takes 320 s for its 2 s (one core); scripts/contact_envelope.py runs it "
                               "(0.067 rad out on a foot)",
    "dm_control/lqr": "no joint: nothing moves",
}

#: Files SCM's final pose is outside MuJoCo's envelope on: whether SCM runs and ends outside
#: ("outside") or stops ("stopped", the implicit step's Newton iterations), and what was measured
#: (docs/mjcf.md).
OUT = {
    "gymnasium/ant": (
        "outside",
        "0.15 rad out on an ankle: its legs splay onto their limits by 2 s (torso 0.382 m; MuJoCo's 27 runs "
        "end between 0.495 and 0.619 m). Under RK4 at 10 ms its feet creep at the stiction floor (2 h mu g, "
        "20 cm/s) that keeps RK4 stable at rest; with its friction implicit in velocity at 1 cm/s (damped_euler, "
        "no floor) its feet hold where MuJoCo's creep (torso 0.625 m at 2 s against 0.561). Under implicit_euler, "
        "whose limits have MuJoCo's statics, it ends inside (docs/mjcf.md)"),
    "gymnasium/humanoidstandup": (
        "outside", "3.0 mm out in x, lying on the floor (RK4, 3 ms; inside from a stiction floor of 3 h mu g, "
                   "and under damped_euler or implicit_euler)"),
    "gymnasium/walker2d": (
        "outside",
        "1.30 rad out on a thigh (RK4, 2 ms): it lands as MuJoCo's (torso 1.205 m at 0.1 s) but its feet "
        "tip up to 0.14 rad at 0.2 s (MuJoCo's 0.002) and its knees buckle first (-0.20 rad at 0.6 s against "
        "-0.09), so it folds where MuJoCo's topples over backwards (pitch -2.19 rad at 2 s against -4.05). "
        "With eps2 = 0.1 mm its feet stay within 0.01 rad yet it still ends out (1.11 rad); under implicit_euler, "
        "limits with MuJoCo's statics, 0.82 rad: not explained yet"),
    "gymnasium/walker2d_v5": (
        "outside", "0.011 rad out on a foot after its fall (RK4, 2 ms; 0.21 to 0.49 rad at stiction floors of "
        "1 to 2.5 h mu g: the pose it falls into turns on small differences; inside under damped_euler and "
        "implicit_euler, whose limits have MuJoCo's statics)"),
}


def files():
    out = []
    for corpus, paths in (("gymnasium", envelope.GYM), ("dm_control", envelope.DM)):
        for path in paths:
            name = f"{corpus}/{path.stem}"
            if corpus == "dm_control" and path.stem in DM_CONTROL_REFUSED or name in NOT_HERE:
                continue
            marks = [pytest.mark.xfail(strict=True, raises=AssertionError, reason=OUT[name][1])] if name in OUT else []
            out.append(pytest.param(path, name, id=name, marks=marks))
    return out


def test_the_lists_name_files_that_exist():
    names = {f"{c}/{p.stem}" for c, ps in (("gymnasium", envelope.GYM), ("dm_control", envelope.DM)) for p in ps}
    assert set(OUT) <= names and set(NOT_HERE) <= names, (set(OUT) | set(NOT_HERE)) - names
    assert all(kind in ("outside", "stopped") for kind, _ in OUT.values())


@pytest.mark.parametrize("path, name", files())
def test_contact_on_ends_inside_mujocos_envelope(path, name):
    seconds = 2.0 if envelope.LEGGED.search(path.stem) else 1.0
    model, finals = envelope.mujoco_finals(path, seconds)
    # MuJoCo leaves out a run it finds unstable; most of the 27 must be there to make a spread.
    # (Not the expected failure of a file in OUT: a RuntimeError fails the test outright.)
    if len(finals) < 18:
        raise RuntimeError(f"only {len(finals)} of MuJoCo's 27 runs are stable")
    ours, error = envelope.scm_final(path, seconds)
    kind = OUT.get(name, ("inside", ""))[0]
    if error is not None and kind == "outside":
        raise RuntimeError(f"SCM stopped where it was measured to run: {error}")
    if error is not None and kind == "stopped" and "Newton iterations did not converge" not in error:
        raise RuntimeError(f"SCM stopped otherwise than measured: {error}")
    assert error is None, f"SCM stopped: {error}"
    inside, worst, where = envelope.compare(model, finals, ours)
    assert inside, f"{worst:.3g} (m or rad) outside MuJoCo's envelope at {where}"
