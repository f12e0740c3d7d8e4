"""Shared fixtures: the FMUs of the bundled scenes, packed once per test session."""
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENES = ROOT / "resources" / "scenes"
SCM = ROOT / "target" / "release" / "scm"

#: Every bundled scene, by name (a scene added under resources/scenes/ is picked up by every
#: test parametrized over this list).
ALL_SCENES = sorted(p.stem for p in SCENES.glob("*.xml"))


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory):
    """Folder holding <scene>.fmu for every bundled scene."""
    if not SCM.exists():
        subprocess.run(["cargo", "build", "--release", "-q"], cwd=ROOT, check=True)
    out = tmp_path_factory.mktemp("fmus")
    for scene in sorted(SCENES.glob("*.xml")):
        subprocess.run([str(SCM), "pack", str(scene), "-o", str(out / f"{scene.stem}.fmu")], check=True)
    return out


@pytest.fixture(scope="session")
def fmu(fmu_dir):
    """Path of the FMU of a bundled scene, by name."""
    def path(name):
        p = fmu_dir / f"{name}.fmu"
        assert p.exists(), f"no FMU for scene {name}"
        return str(p)
    return path
