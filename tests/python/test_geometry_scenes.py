"""The geometry scenes through fmpy: the FMUs carry their meshes, validate and simulate.

horseshoe: a ring (torus mesh) dropped on a bar comes to rest on it, the contact carrying its
weight with no sideways force, and its soft top-K contact points lie on the bar's top face.
mesh_drop: an L-shaped STL bracket dropped on a plane comes to rest on it.
"""
import zipfile

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu


@pytest.mark.parametrize("name,mesh", [("horseshoe", "ring.obj"), ("mesh_drop", "bracket.stl")])
def test_fmu_validates_and_carries_its_mesh(fmu, name, mesh):
    path = fmu(name)
    assert validate_fmu(path) == []
    with zipfile.ZipFile(path) as z:
        names = z.namelist()
        assert f"resources/meshes/{mesh}" in names, names


def test_horseshoe_comes_to_rest_on_the_bar(fmu):
    res = simulate_fmu(fmu("horseshoe"), stop_time=0.6, output_interval=0.02,
                       output=["ring.pos.x", "ring.pos.y", "ring.pos.z", "ring.linvel.z",
                               "contact.bar.ring.force.x", "contact.bar.ring.force.y",
                               "contact.bar.ring.force.z", "contact.bar.ring.distance",
                               "contact.bar.ring.point1.z", "contact.bar.ring.point2.z"])
    z, fz = res["ring.pos.z"], res["contact.bar.ring.force.z"]
    assert z[0] == pytest.approx(0.05)
    # At rest on the bar top (z = 0.02): the ring's lowest facet is r cos 18° = 14.27 mm below
    # its centre, less a penetration below 1 mm.
    assert 0.0332 < z[-1] < 0.0343, z[-1]
    assert abs(res["ring.linvel.z"][-1]) < 1e-4
    # The bar (the pair's first body) carries the ring's weight, 0.3 kg x 9.81: force on it -m g.
    assert fz[-1] == pytest.approx(-0.3 * 9.81, rel=1e-3)
    # Symmetric contact at two places: no sideways force, no sideways motion.
    assert np.max(np.abs(res["contact.bar.ring.force.x"])) < 1e-6
    assert np.max(np.abs(res["ring.pos.x"])) < 1e-9 and np.max(np.abs(res["ring.pos.y"])) < 1e-9
    assert res["contact.bar.ring.distance"][-1] < 0
    # Contact points on the bar's top face (z = 0.02), within the penetration.
    for k in (1, 2):
        assert abs(res[f"contact.bar.ring.point{k}.z"][-1] - 0.02) < 2e-3


def test_mesh_drop_comes_to_rest_on_the_plane(fmu):
    res = simulate_fmu(fmu("mesh_drop"), stop_time=1.5, output_interval=0.05,
                       output=["bracket.pos.z", "bracket.linvel.x", "bracket.linvel.y", "bracket.linvel.z",
                               "contact.world.bracket.force.z"])
    assert res["bracket.pos.z"][0] == pytest.approx(0.1)
    v = np.sqrt(res["bracket.linvel.x"] ** 2 + res["bracket.linvel.y"] ** 2 + res["bracket.linvel.z"] ** 2)
    assert v[-1] < 1e-3, "the bracket is not at rest"
    # Resting on a face: its centre of mass between 1.5 and 4 cm above the plane (the bracket is
    # 8 x 4 x 6 cm), and the plane (first body) carries its weight, 0.2 kg x 9.81.
    assert 0.015 < res["bracket.pos.z"][-1] < 0.04
    assert res["contact.world.bracket.force.z"][-1] == pytest.approx(-0.2 * 9.81, rel=1e-2)
