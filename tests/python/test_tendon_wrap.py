"""Spatial tendons wrapping spheres and cylinders, against MuJoCo (docs/mjcf.md, "Spatial
tendons"): the lengths of random wraps as MuJoCo computes them, and the wrapping fixture's
motion (a rope over a sphere, a belt round a cylinder on a sprung carriage, a sling held by a
side site inside a sphere) as MuJoCo's."""
import csv
import io
import json
import pathlib
import subprocess

import mujoco
import numpy as np

from conftest import SCM

FIXTURE = pathlib.Path(__file__).resolve().parents[1] / "fixtures" / "tendon_wrap.xml"


def random_wraps(rng, kind, side, n=100):
    """A scene of n tendons, each from one site round its own geom (a sphere or a cylinder at a
    random pose, radius 5 to 30 cm) to another, the sites 1.2 to 4 radii from the geom's centre;
    `side`: no side site ("none") or one inside the geom ("inside", 0.3 radii from its centre)."""
    geoms, sites, tendons = [], [], []
    for i in range(n):
        c = rng.uniform(-1, 1, 3)
        r = rng.uniform(0.05, 0.3)
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        size = f"{r}" if kind == "sphere" else f"{r} 0.5"
        geoms.append(f'<geom name="g{i}" type="{kind}" size="{size}" pos="{c[0]} {c[1]} {c[2]}" '
                     f'quat="{q[0]} {q[1]} {q[2]} {q[3]}" contype="0" conaffinity="0"/>')
        for k in "ab":
            d = rng.normal(size=3)
            p = c + d / np.linalg.norm(d) * r * rng.uniform(1.2, 4)
            sites.append(f'<site name="{k}{i}" pos="{p[0]} {p[1]} {p[2]}"/>')
        attr = ""
        if side == "inside":
            d = rng.normal(size=3)
            p = c + d / np.linalg.norm(d) * r * 0.3
            sites.append(f'<site name="s{i}" pos="{p[0]} {p[1]} {p[2]}"/>')
            attr = f' sidesite="s{i}"'
        tendons.append(f'<spatial name="t{i}"><site site="a{i}"/><geom geom="g{i}"{attr}/>'
                       f'<site site="b{i}"/></spatial>')
    return (f'<mujoco><worldbody>{"".join(geoms)}{"".join(sites)}'
            f'<body><joint type="slide"/><geom size=".1"/></body></worldbody>'
            f'<tendon>{"".join(tendons)}</tendon></mujoco>')


def test_wrapped_lengths_are_mujocos(tmp_path):
    # 100 random tendons per shape, with no side site (the path goes round the side of the
    # shorter chord) and with one inside the geom (the path touches the geom at one point and
    # reflects there, up to grazing): the lengths at the reference pose (`scm compile`'s
    # length0) against MuJoCo's ten_length. A side site outside the geom is left out: there
    # MuJoCo 4.0 departs in some poses from its published algorithm, which SCM follows
    # (docs/mjcf.md, "Spatial tendons", with the measurements; `scm check` warns).
    rng = np.random.default_rng(3)
    for kind in ("sphere", "cylinder"):
        for side in ("none", "inside"):
            path = tmp_path / f"{kind}_{side}.xml"
            path.write_text(random_wraps(rng, kind, side))
            m = mujoco.MjModel.from_xml_path(str(path))
            d = mujoco.MjData(m)
            mujoco.mj_forward(m, d)
            out = subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True)
            assert out.returncode == 0, out.stderr
            compiled = json.loads(out.stdout)["spatial_tendons"]
            assert all(t["wraps"][0]["shape"] == kind for t in compiled)
            ours = np.array([t["length0"] for t in compiled])
            wrapped = (d.ten_wrapnum == 4).sum()
            err = np.abs(ours - d.ten_length).max()
            print(f"{kind}, side site {side}: {wrapped} of {len(ours)} wrapped, largest difference {err:.1e} m")
            assert wrapped >= 20, (kind, side, wrapped)
            assert err < 1e-12, (kind, side, err)


def test_a_wrapped_tendon_moves_as_in_mujoco():
    # The fixture as written (Euler, 2 ms) for 1 s from rest: the arm swings on the rope and the
    # belt, the carriage and the bob move, the belt wraps and unwraps its cylinder and the
    # sling holds the bob, the tendons pulling the geoms' bodies at the tangent points; SCM's
    # motion is MuJoCo's to rounding.
    names = ["hinge.q", "wx.q", "wz.q", "bx.q", "bz.q"]
    run = subprocess.run([str(SCM), "simulate", str(FIXTURE), "--duration", "1", "--output-interval",
                          "0.01", "--outputs", ",".join(names)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    rows = list(csv.reader(io.StringIO(run.stdout)))
    assert rows[0] == ["time"] + names
    ours = np.array([[float(x) for x in r[1:]] for r in rows[1:]])
    m = mujoco.MjModel.from_xml_path(str(FIXTURE))
    d = mujoco.MjData(m)
    theirs, wraps = [d.qpos.copy()], []
    while d.time < 1.0 - 1e-9:
        mujoco.mj_step(m, d)
        if abs(d.time / 0.01 - round(d.time / 0.01)) < 1e-6:
            theirs.append(d.qpos.copy())
            wraps.append(d.ten_wrapnum.copy())
    theirs, wraps = np.array(theirs), np.array(wraps)
    assert np.ptp(theirs[:, 0]) > 1.0, "the arm swings"
    assert (wraps[:, 0] == 4).all() and (wraps[:, 2] == 4).all(), "the rope and the sling wrap"
    assert (wraps[:, 1] == 4).any() and (wraps[:, 1] == 2).any(), "the belt wraps and unwraps"
    diff = np.abs(ours - theirs).max()
    print(f"largest coordinate difference from MuJoCo over 1 s: {diff:.1e}")
    assert diff < 1e-8, diff
