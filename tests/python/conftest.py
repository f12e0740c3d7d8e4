"""Shared fixtures: the FMUs of the bundled scenes, packed once per test session."""
import functools
import pathlib
import subprocess
from types import SimpleNamespace

import lark
import pytest
from fmpy import validation as fmpy_validation

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENES = ROOT / "resources" / "scenes"
SCM = ROOT / "target" / "release" / "scm"

#: Every bundled scene, by name (a scene added under resources/scenes/ is picked up by every
#: test parametrized over this list).
ALL_SCENES = sorted(p.stem for p in SCENES.glob("*.xml"))

#: dm_control's models, a second corpus of MJCF files as users bring them (unpacked from its
#: wheel by scripts/setup.sh): the suite's, and the walkers, props, arenas, the Kinova arm and
#: the test models it ships beside them (those MuJoCo loads).
DM_CONTROL_ROOT = ROOT / ".venv" / "dm_control_assets" / "dm_control"
DM_CONTROL_DIR = DM_CONTROL_ROOT / "suite"
DM_CONTROL_SUITE = sorted(DM_CONTROL_DIR.glob("*.xml"))
DM_CONTROL_MORE = sorted(DM_CONTROL_ROOT / f for f in (
    "locomotion/walkers/assets/humanoid_CMU_V2019.xml",
    "locomotion/walkers/assets/humanoid_CMU_V2020.xml",
    "locomotion/walkers/assets/rodent.xml",
    "locomotion/walkers/assets/dog_v2/dog.xml",
    "locomotion/walkers/assets/fruitfly_v2/fruitfly.xml",
    "locomotion/walkers/assets/jumping_ball/jumping_ball_with_head.xml",
    "locomotion/soccer/assets/boxhead/boxhead.xml",
    "third_party/ant/ant.xml",
    "third_party/kinova/jaco_arm.xml",
    "third_party/kinova/jaco_hand.xml",
    "entities/props/duplo/duplo2x4.xml",
    "composer/arena.xml",
    "mujoco/testing/assets/arm.xml",
    "mujoco/testing/assets/cartpole.xml",
    "mujoco/testing/assets/cartpole_no_names.xml",
    "mujoco/testing/assets/humanoid.xml",
    "mujoco/testing/assets/model_with_ball_joints.xml",
    "mujoco/testing/assets/model_with_third_order_actuators.xml",
    "mujoco/testing/assets/sphere.xml",
))
DM_CONTROL = DM_CONTROL_SUITE + DM_CONTROL_MORE


def dm_id(path):
    """A test id for a dm_control file: the suite's by name, the others by folder and name."""
    if path.parent == DM_CONTROL_DIR:
        return path.stem
    if path.parent.name == "assets" and path.parent.parent.name == "testing":
        return f"testing_{path.stem}"
    return f"{path.parent.name}_{path.stem}" if path.parent.name in ("dog_v2", "fruitfly_v2") else path.stem


#: The dm_control files SCM refuses, and the reason its message must give (at the file and line
#: of the element). Everything else loads.
DM_CONTROL_REFUSED: dict = {}

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


# Tests of about 5 s or more each on the 2-core development machine (pytest --durations), by
# name: marked `slow` here rather than in their modules, since several are one case of a
# parametrized test. The quick tier leaves them out; CI runs them.
SLOW_BY_NAME = {
    "test_a_nut_screws_down_its_bolt_as_the_thread_demands",
    "test_gears_of_the_gear_plugin_weigh_and_mesh_as_in_mujoco",
    "test_a_robot_with_dense_meshes_runs_its_first_steps_in_bounded_memory[fourier_left_hand]",
    "test_nut_on_bolt_derivatives_are_exact_in_the_thread",
    "test_a_long_run_shows_its_progress_on_a_terminal",
    "test_no_progress_where_standard_error_is_not_a_terminal",
    "test_height_fields_with_elevation_data_collide_as_in_mujoco[png]",
    "test_height_fields_with_elevation_data_collide_as_in_mujoco[inline]",
    "test_height_fields_with_elevation_data_collide_as_in_mujoco[custom]",
    "test_sdf_plugin_shapes_weigh_as_mujoco_weighs_them",
    "test_generated_names_never_panic_and_always_validate",
    "test_co_simulation_and_model_exchange_agree[horseshoe]",
    "test_a_bounded_contact_damping_carries_the_humanoids_fall_at_its_own_step",
    "test_the_bodies_that_collide_are_those_mujoco_lets_touch[dm_control-dog]",
    "test_the_bodies_that_collide_are_those_mujoco_lets_touch[dm_control-dog_v2_dog]",
    "test_a_scheduler_and_workers_started_by_hand",
    "test_a_sweep_on_two_workers_equals_the_serial_runs",
    "test_corpus_file_packs_validates_and_runs[humanoid]",
    "test_corpus_file_packs_validates_and_runs[humanoidstandup]",
    "test_a_robot_runs_the_same_bits_every_time",
    "test_builtin_meshes_compile_as_mujoco_compiles_them",
    "test_sdf_nut_and_bolt_weigh_as_mujoco_weighs_them",
    "test_sdf_torus_dropped_on_a_floor_lands_flat_as_in_mujoco",
}


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.name in SLOW_BY_NAME:
            item.add_marker(pytest.mark.slow)


def pytest_configure(config):
    config.addinivalue_line(
        "markers",
        "slow: left out of `scripts/test.sh --quick` (the report, the contact-on envelope, the bench, the "
        "inference studies, the dm_control and gymnasium-robotics corpora, the wheel's build: each costs tens "
        "of seconds or more; and the tests of about 5 s or more named in SLOW_BY_NAME); CI runs them")


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


#: fmpy's own check of structured variable names, kept as it is for the test that compares.
FMPY_NAME_CHECK = fmpy_validation._validate_variable_names


def name_check_by_lalr(model_description):
    """fmpy's check of the structured variable names, with its own grammar, parsed LALR(1)
    first and by fmpy's Earley parser only for the names LALR refuses. Earley takes about 11 ms
    a name: 150 s of rodent's 13,358 variables (a contact's seven per pair of bodies that can
    touch), most of the corpus tests' time on the CI machine; LALR takes 4 s. A name an LALR
    parse accepts is derived by the grammar; LALR's lexer refuses some names Earley accepts
    (escapes inside quotes), which Earley then decides. The verdicts are fmpy's:
    test_mjcf_names.py compares them on good and bad names."""
    earley = lark.Lark
    lark.Lark = functools.partial(earley, parser="lalr")
    try:
        refused = FMPY_NAME_CHECK(model_description)
    finally:
        lark.Lark = earley
    if not refused:
        return []
    heads = {problem.split(" is not a legal")[0] for problem in refused}
    doubtful = [v for v in model_description.modelVariables if f'"{v.name}" (line {v.sourceline})' in heads]
    return FMPY_NAME_CHECK(SimpleNamespace(variableNamingConvention=model_description.variableNamingConvention,
                                           modelVariables=doubtful))


fmpy_validation._validate_variable_names = name_check_by_lalr
