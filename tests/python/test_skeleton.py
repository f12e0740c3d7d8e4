"""The walking skeleton through fmpy: the FMUs validate, a sphere comes to rest on a plane at
the analytic penetration, and overlapping spheres are pushed apart."""
import math

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

from conftest import ALL_SCENES


@pytest.mark.parametrize("name", ALL_SCENES)
def test_fmu_validates(fmu, name):
    problems = validate_fmu(fmu(name))
    assert problems == [], problems


def softplus(x, eps):
    return max(x, 0.0) + eps * math.log1p(math.exp(-abs(x) / eps))


def test_sphere_drop_rests_at_the_analytic_penetration(fmu):
    path = fmu("sphere_drop")
    md = read_model_description(path)
    start = {v.name: float(v.start) for v in md.modelVariables if v.name.startswith("scm.")}
    res = simulate_fmu(path, stop_time=2.0, output_interval=0.01,
                       output=["ball.pos.z", "ball.linvel.z", "contact.world.ball.force.z"])
    z, vz, fz = res["ball.pos.z"], res["ball.linvel.z"], res["contact.world.ball.force.z"]
    assert z[0] == pytest.approx(0.3)
    assert abs(vz[-1]) < 1e-6, "the sphere is not at rest after 2 s"
    # At rest the contact carries the weight: the force on the world is -m g (m = 1 kg).
    assert fz[-1] == pytest.approx(-9.81, rel=1e-6)
    # Analytic equilibrium of a point contact, m g = k s⁺_ε3(-φ), solved by bisection.
    k, eps3 = start["scm.stiffness"], start["scm.eps3"]
    lo, hi = -0.05, 0.05
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if k * softplus(-mid, eps3) > 9.81 else (lo, mid)
    phi = 0.5 * (lo + hi)
    # The sphere's AOPC (spacing 1 cm, 8x8 quads per cube face) rests on the four points
    # around its pole, r (1 - cos θ) = 0.478 mm above the sphere's lowest point, θ = 0.1384 rad.
    lowest = z[-1] - 0.05 * math.cos(math.atan(math.sqrt(2) * math.tan(math.pi / 32)))
    # Tolerance 1 %: the next ring of points (1.9 mm ≈ 9.5 ε2 higher) carries < 0.1 % of the load.
    assert lowest == pytest.approx(phi, rel=0.01), (lowest, phi)


def test_sphere_pair_pushes_overlapping_spheres_apart(fmu):
    res = simulate_fmu(fmu("sphere_pair"), stop_time=0.2, output_interval=0.001,
                       output=["x.q", "y.q", "z.q", "y.v", "contact.big.small.force.y",
                               "contact.big.small.distance"])
    # The small sphere starts 1 cm deep along +y: the force on the big one (the pair's first
    # body) points to -y, so the small one is pushed to +y.
    assert res["contact.big.small.force.y"][0] < 0
    assert res["contact.big.small.distance"][0] < 0
    assert res["y.q"][-1] > 0.01, "the small sphere did not leave the big one"
    assert res["y.v"][-1] > 0
    # Symmetry: no sideways motion.
    assert np.max(np.abs(res["x.q"])) < 1e-9 and np.max(np.abs(res["z.q"])) < 1e-9
    # No gravity and no input: the kinetic energy it gains is bounded by the elastic energy
    # it started with, ∫ k s⁺(-φ) dφ over the 1 cm overlap ≤ ½ k (1 cm)² = 0.5 J for 0.5 kg.
    assert 0.5 * 0.5 * res["y.v"][-1] ** 2 <= 0.5 + 1e-9
