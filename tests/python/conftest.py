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

#: dm_control's suite models, a second corpus of MJCF files as users bring them (unpacked from
#: its wheel by scripts/setup.sh).
DM_CONTROL_DIR = ROOT / ".venv" / "dm_control_suite" / "dm_control" / "suite"
DM_CONTROL = sorted(DM_CONTROL_DIR.glob("*.xml"))
#: The suite files SCM refuses, and the reason its message must give (at the file and line of
#: the element). Everything else in the suite loads.
DM_CONTROL_REFUSED = {
    "ball_in_cup": ("ball_in_cup.xml:47: <spatial>", "spatial tendons are not supported"),
    "dog": ("dog.xml:945: <general>", "no activation state"),
    "quadruped": ("quadruped.xml:13: <hfield>", "height fields are not supported"),
}

#: gymnasium-robotics' models, a third corpus (unpacked from its wheel by scripts/setup.sh): the
#: files its environments load (the others are included by these).
ROBOTICS_DIR = ROOT / ".venv" / "gymnasium_robotics_assets" / "gymnasium_robotics" / "envs" / "assets"
ROBOTICS = sorted(
    p for pattern in ("adroit_hand/adroit_*.xml", "fetch/*.xml", "hand/*.xml", "point/point.xml",
                      "kitchen_franka/kitchen_assets/kitchen_env_model.xml")
    for p in ROBOTICS_DIR.glob(pattern)
    if p.stem not in ("adroit_assets", "adroit_model", "robot", "shared", "shared_asset",
                      "robot_touch_sensors_92", "shared_touch_sensors_92")
)
#: The robotics files SCM refuses, and the reason its message must give: none since welds
#: (Fetch's mocap gripper) are supported.
ROBOTICS_REFUSED: dict = {}


def robotics_id(path):
    """A test id for a robotics file: its name, with the folder where names repeat."""
    return f"{path.stem}_fetch" if path.parent.name == "fetch" and path.stem == "reach" else path.stem


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
