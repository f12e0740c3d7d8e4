//! MJCF as MuJoCo compiles it: default classes, includes, frames, orientations, compiler
//! settings, joint reference positions, option flags, and what is refused or noted as unused.
//! (tests/python/test_mjcf_compiler.py checks the same against MuJoCo itself.)

use nalgebra::{UnitQuaternion, Vector3};
use scm::model::Transmission;
use scm::scene::{compile, load_str, Scene, SceneError};
use std::path::{Path, PathBuf};

fn load(text: &str) -> Scene {
    load_str(text, Path::new("m.xml")).unwrap_or_else(|e| panic!("{e}"))
}

fn refuse(text: &str) -> SceneError {
    load_str(text, Path::new("m.xml")).expect_err("must be refused")
}

fn joint<'a>(s: &'a Scene, name: &str) -> &'a scm::dynamics::Joint {
    s.model
        .tree
        .joints
        .iter()
        .find(|j| j.name == name)
        .unwrap_or_else(|| panic!("no joint {name}"))
}

fn body<'a>(s: &'a Scene, name: &str) -> &'a scm::dynamics::Body {
    s.model
        .tree
        .bodies
        .iter()
        .find(|b| b.name == name)
        .unwrap_or_else(|| panic!("no body {name}"))
}

/// Writes what `scm pack` would put in an FMU's `resources/` under `fmu/resources/`, as a
/// host unpacks it; returns the scene's path there.
fn unpack(d: &scm::pack::Described, fmu: &Path) -> PathBuf {
    let resources = fmu.join("resources");
    std::fs::create_dir_all(&resources).unwrap();
    std::fs::write(resources.join("scene.xml"), &d.scene_text).unwrap();
    for (name, bytes) in &d.resources {
        let to = resources.join(name);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::write(to, bytes).unwrap();
    }
    resources.join("scene.xml")
}

/// A folder of its own under the system's temporary folder.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("scm-mjcf-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn nested_default_classes_and_childclass_apply_as_in_mujoco() {
    let s = load(
        r#"<mujoco>
  <default>
    <joint damping="1" armature="0.1"/>
    <geom density="500"/>
    <default class="leg">
      <joint damping="2"/>
      <default class="foot">
        <joint stiffness="3"/>
      </default>
    </default>
  </default>
  <worldbody>
    <body name="a" childclass="leg">
      <joint name="inherits_leg" axis="0 1 0"/>
      <joint name="own_class" class="foot" axis="0 1 0"/>
      <joint name="own_value" damping="7" axis="0 1 0"/>
      <geom type="sphere" size="0.1"/>
      <body name="b">
        <joint name="childclass_reaches_down" axis="1 0 0"/>
        <geom type="sphere" size="0.1" class="main"/>
      </body>
    </body>
    <body name="c" pos="1 0 0">
      <joint name="main_only" axis="0 1 0"/>
      <geom type="sphere" size="0.1"/>
    </body>
  </worldbody>
</mujoco>"#,
    );
    let j = |n| {
        let j = joint(&s, n);
        (j.damping, j.armature, j.stiffness)
    };
    assert_eq!(j("inherits_leg"), (2.0, 0.1, 0.0));
    assert_eq!(j("own_class"), (2.0, 0.1, 3.0));
    assert_eq!(j("own_value"), (7.0, 0.1, 0.0));
    assert_eq!(j("childclass_reaches_down"), (2.0, 0.1, 0.0));
    assert_eq!(j("main_only"), (1.0, 0.1, 0.0));
    // density 500 from main: a 10 cm sphere weighs 500 * 4/3 pi 0.001.
    let m = 500.0 * 4.0 / 3.0 * std::f64::consts::PI * 1e-3;
    assert!((body(&s, "c").inertia.mass - m).abs() < 1e-12);
}

/// Files a scene names through `..` out of its folder (an include `../parts/arm.xml`, a mesh
/// `../meshes/box.obj` from a `meshdir` beside the scene, as the Franka kitchen's files do)
/// travel in the FMU under `_parent_` folders, and the same names find them there again; two
/// different files that would share a packed name are refused.
#[test]
fn files_named_out_of_their_folder_travel_in_the_fmu() {
    let dir = scratch("parent");
    for sub in ["scenes", "parts", "meshes", "assets"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
    }
    let cube = "v 0 0 0\nv 0.1 0 0\nv 0.1 0.1 0\nv 0 0.1 0\nv 0 0 0.1\nv 0.1 0 0.1\nv 0.1 0.1 0.1\nv 0 0.1 0.1\nf 1 4 3\nf 1 3 2\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
    std::fs::write(dir.join("meshes/box.obj"), cube).unwrap();
    std::fs::write(
        dir.join("parts/arm.xml"),
        "<mujoco>\n  <body name=\"arm\" pos=\"0 0 1\">\n    <joint name=\"hinge\" axis=\"0 1 0\"/>\n    <include file=\"hand.xml\"/>\n  </body>\n</mujoco>\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("parts/hand.xml"),
        "<mujoco>\n  <geom name=\"hand\" type=\"mesh\" mesh=\"box\"/>\n</mujoco>\n",
    )
    .unwrap();
    let main = dir.join("scenes/main.xml");
    let scene = |mesh: &str| {
        format!("<mujoco>\n  <compiler meshdir=\"../assets\"/>\n  <asset>{mesh}</asset>\n  <worldbody>\n    <include file=\"../parts/arm.xml\"/>\n  </worldbody>\n</mujoco>\n")
    };
    std::fs::write(
        &main,
        scene(r#"<mesh name="box" file="../meshes/box.obj"/>"#),
    )
    .unwrap();
    let s = scm::scene::load(&main).unwrap();
    let d = scm::pack::describe(&main).unwrap();
    let mut names: Vec<&str> = d.resources.iter().map(|(n, _)| n.as_str()).collect();
    names.sort();
    assert_eq!(
        names,
        [
            "_parent_/parts/arm.xml",
            "_parent_/parts/hand.xml",
            "meshes/_parent_/meshes/box.obj"
        ]
    );
    let again = scm::scene::load(&unpack(&d, &dir.join("unpacked"))).unwrap();
    // The same geoms, the mesh read from its packed copy.
    let shape = |s: &Scene| -> Vec<_> {
        s.geoms
            .iter()
            .map(|g| match &g.shape {
                Some(scm::geometry::Shape::Mesh(m)) => (
                    g.name.clone(),
                    g.body,
                    m.vertices.clone(),
                    m.triangles.clone(),
                ),
                other => panic!("{other:?}"),
            })
            .collect()
    };
    assert_eq!(shape(&again), shape(&s));
    // `_parent_/box.obj` written as such and `../box.obj` would be one packed file.
    std::fs::create_dir_all(dir.join("assets/_parent_")).unwrap();
    std::fs::write(dir.join("assets/_parent_/box.obj"), cube).unwrap();
    std::fs::write(dir.join("box.obj"), cube).unwrap();
    std::fs::write(
        &main,
        scene(
            r#"<mesh name="box" file="_parent_/box.obj"/><mesh name="other" file="../box.obj"/>"#,
        ),
    )
    .unwrap();
    let e = match scm::pack::describe(&main) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("two files under one packed name must be refused"),
    };
    assert!(
        e.contains("meshes/_parent_/box.obj") && e.contains("rename"),
        "{e}"
    );
    // Inside the FMU a mesh is found by its packed name first: `meshes/a.obj` written (packed
    // as `meshes/meshes/a.obj`) is not `a.obj` packed as `meshes/a.obj`.
    std::fs::write(dir.join("assets/a.obj"), cube).unwrap();
    std::fs::create_dir_all(dir.join("assets/meshes")).unwrap();
    std::fs::write(dir.join("assets/meshes/a.obj"), cube.replace("0.1", "0.2")).unwrap();
    std::fs::write(
        &main,
        scene(r#"<mesh name="box" file="a.obj"/><mesh name="big" file="meshes/a.obj"/>"#).replace(
            "<worldbody>",
            "<worldbody>\n    <body name=\"big\"><geom type=\"mesh\" mesh=\"big\"/></body>",
        ),
    )
    .unwrap();
    let s = scm::scene::load(&main).unwrap();
    let d = scm::pack::describe(&main).unwrap();
    let again = scm::scene::load(&unpack(&d, &dir.join("unpacked2"))).unwrap();
    assert_eq!(shape(&again), shape(&s));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_unknown_class_is_refused_with_its_line() {
    let e = refuse(
        "<mujoco>\n<worldbody>\n<body>\n<joint class=\"nope\"/>\n<geom size=\"0.1\"/>\n</body>\n</worldbody>\n</mujoco>",
    );
    assert_eq!((e.line, e.element.as_str()), (4, "joint"), "{e}");
    assert!(e.message.contains("nope"), "{e}");
}

#[test]
fn includes_resolve_as_in_mujoco_travel_in_the_fmu_and_errors_name_them() {
    let dir = scratch("include");
    std::fs::create_dir_all(dir.join("parts")).unwrap();
    std::fs::write(
        dir.join("parts/arm.xml"),
        "<mujoco>\n  <body name=\"arm\" pos=\"0 0 1\">\n    <joint name=\"hinge\" axis=\"0 1 0\"/>\n    <include file=\"hand.xml\"/>\n  </body>\n</mujoco>\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("parts/hand.xml"),
        "<mujoco>\n  <geom name=\"hand\" type=\"sphere\" size=\"0.05\"/>\n</mujoco>\n",
    )
    .unwrap();
    let main = dir.join("scene.xml");
    std::fs::write(
        &main,
        "<mujoco>\n  <worldbody>\n    <include file=\"parts/arm.xml\"/>\n  </worldbody>\n</mujoco>\n",
    )
    .unwrap();
    let s = scm::scene::load(&main).unwrap();
    assert!(s.geoms.iter().any(|g| g.name == "hand"));
    assert_eq!(joint(&s, "hinge").body, 1);
    assert_eq!(s.includes.len(), 2);

    // The FMU carries every included file where the include finds it again.
    let d = scm::pack::describe(&main).unwrap();
    let names: Vec<&str> = d.resources.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["parts/arm.xml", "parts/hand.xml"]);
    let again = scm::scene::load(&unpack(&d, &dir.join("unpacked"))).unwrap();
    let shape = |s: &Scene| -> Vec<_> {
        s.geoms
            .iter()
            .map(|g| (g.name.clone(), g.body, g.shape.clone(), g.pose))
            .collect()
    };
    assert_eq!(shape(&again), shape(&s));
    assert!(again.geoms[0]
        .file
        .ends_with("unpacked/resources/parts/hand.xml"));

    // As in MuJoCo, a file beside the main scene wins over one beside the including file.
    std::fs::write(
        dir.join("hand.xml"),
        "<mujoco>\n  <geom name=\"hand_main\" type=\"sphere\" size=\"0.05\"/>\n</mujoco>\n",
    )
    .unwrap();
    let s = scm::scene::load(&main).unwrap();
    assert!(s.geoms.iter().any(|g| g.name == "hand_main"));
    std::fs::remove_file(dir.join("hand.xml")).unwrap();

    // A mistake inside an included file names that file and its line.
    std::fs::write(
        dir.join("parts/hand.xml"),
        "<mujoco>\n\n  <geom name=\"hand\" type=\"blob\" size=\"0.05\"/>\n</mujoco>\n",
    )
    .unwrap();
    let e = scm::scene::load(&main).unwrap_err();
    assert!(e.file.ends_with("hand.xml"), "{e}");
    assert_eq!(e.line, 3, "{e}");

    // A cycle is refused, not followed for ever.
    std::fs::write(
        dir.join("parts/hand.xml"),
        "<mujoco>\n  <include file=\"arm.xml\"/>\n</mujoco>\n",
    )
    .unwrap();
    let e = scm::scene::load(&main).unwrap_err();
    assert!(e.message.contains("includes itself"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn frames_compose_onto_what_they_hold() {
    let s = load(
        r#"<mujoco>
  <compiler angle="degree"/>
  <worldbody>
    <frame pos="1 0 0" euler="0 0 90">
      <body name="b" pos="1 0 0">
        <freejoint/>
        <geom name="g" type="sphere" size="0.1"/>
      </body>
      <geom name="fixed" type="box" size="0.1 0.1 0.1" pos="0 0 1"/>
    </frame>
  </worldbody>
</mujoco>"#,
    );
    let b = body(&s, "b");
    assert!((b.offset.translation.vector - Vector3::new(1.0, 1.0, 0.0)).norm() < 1e-12);
    let quarter = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2);
    assert!(b.offset.rotation.angle_to(&quarter) < 1e-12);
    let g = s.geoms.iter().find(|g| g.name == "fixed").unwrap();
    assert!((g.pose.translation.vector - Vector3::new(1.0, 0.0, 1.0)).norm() < 1e-12);
}

#[test]
fn a_joint_reference_position_is_where_the_body_sits_as_written() {
    // A hinge with ref 30 degrees: at q = ref the body is at its offset; springref sets the
    // spring's rest angle.
    let s = load(
        r#"<mujoco>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="h" axis="0 1 0" ref="30" springref="45" stiffness="2"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.02"/>
    </body>
  </worldbody>
</mujoco>"#,
    );
    let j = joint(&s, "h");
    assert!((j.reference - 30f64.to_radians()).abs() < 1e-15);
    assert!((j.springref - 45f64.to_radians()).abs() < 1e-15);
    let q0 = s.model.tree.q0();
    assert_eq!(q0, vec![30f64.to_radians()]);
    let kin = s.model.tree.kinematics(&q0, &[0.0]);
    let f = &kin.frames[1];
    assert!((f.origin - Vector3::new(0.0, 0.0, 1.0)).norm() < 1e-15);
    assert!((f.rotation - nalgebra::Matrix3::identity()).norm() < 1e-15);
    // The spring pulls towards springref, not towards ref.
    let at = |q: f64| s.model.passive_forces(&[q], &[0.0], 1e-3)[0];
    assert!(at(45f64.to_radians()).abs() < 1e-15);
    assert!((at(30f64.to_radians()) - 2.0 * 15f64.to_radians()).abs() < 1e-12);
}

#[test]
fn compiler_mass_settings_apply() {
    let scene = |compiler: &str| {
        load(&format!(
            r#"<mujoco>
  <compiler {compiler}/>
  <worldbody>
    <body name="a"><freejoint/><geom type="box" size="0.1 0.1 0.1" density="1000"/>
      <inertial pos="0 0 0" mass="3" diaginertia="1 1 1"/></body>
    <body name="b" pos="1 0 0"><freejoint/><geom type="sphere" size="0.01" mass="0.001"/></body>
  </worldbody>
</mujoco>"#
        ))
    };
    let mass = |s: &Scene, n| body(s, n).inertia.mass;
    let auto = scene("");
    assert_eq!(mass(&auto, "a"), 3.0);
    let from_geoms = scene(r#"inertiafromgeom="true""#);
    assert!((mass(&from_geoms, "a") - 8.0).abs() < 1e-12);
    let bounded = scene(r#"boundmass="0.5" boundinertia="0.01""#);
    assert_eq!(mass(&bounded, "b"), 0.5);
    let e = body(&bounded, "b").inertia.rot.symmetric_eigenvalues();
    assert!(e.iter().all(|&x| x >= 0.01 - 1e-15), "{e}");
    let total = scene(r#"settotalmass="6.002""#);
    assert!((mass(&total, "a") + mass(&total, "b") - 6.002).abs() < 1e-12);
    assert!((mass(&total, "a") / mass(&total, "b") - 3000.0).abs() < 1e-6);
}

const LIMITED: &str = r#"<mujoco>
  <compiler autolimits="AUTO"/>
  <option>FLAGS</option>
  <worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <body name="arm" pos="0 0 1">
      <joint name="h" axis="0 1 0" range="-30 30"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.02"/>
    </body>
  </worldbody>
</mujoco>"#;

#[test]
fn a_range_limits_a_joint_by_autolimits_unless_limits_are_switched_off() {
    let with = |auto: &str, flags: &str| LIMITED.replace("AUTO", auto).replace("FLAGS", flags);
    let l = joint(&load(&with("true", "")), "h")
        .limit
        .expect("limited by autolimits");
    assert!((l.lo + 30f64.to_radians()).abs() < 1e-15 && (l.hi - 30f64.to_radians()).abs() < 1e-15);
    assert!(l.stiffness > 0.0 && l.damping > 0.0);
    // autolimits off: a range alone does not limit.
    assert_eq!(joint(&load(&with("false", "")), "h").limit, None);
    // limits switched off.
    assert_eq!(
        joint(&load(&with("true", r#"<flag limit="disable"/>"#)), "h").limit,
        None
    );
}

#[test]
fn option_flags_switch_forces_off() {
    let s = load(
        &LIMITED
            .replace("AUTO", "true")
            .replace(
                "FLAGS",
                r#"<flag gravity="disable" contact="disable" limit="disable" warmstart="disable"/>"#,
            )
            .replace("range=\"-30 30\"", "range=\"-30 30\" damping=\"3\" frictionloss=\"1\""),
    );
    assert_eq!(s.model.tree.gravity, Vector3::zeros());
    assert!(s.model.pairs.is_empty());
    assert!(s.model.colliders.iter().all(Option::is_none));
    assert!(
        s.unused.iter().any(|u| u.contains("warmstart")),
        "{:?}",
        s.unused
    );
    let s = load(
        &LIMITED
            .replace("AUTO", "false")
            .replace(
                "FLAGS",
                r#"<flag damper="disable" frictionloss="disable"/>"#,
            )
            .replace("range=\"-30 30\"", "damping=\"3\" frictionloss=\"1\""),
    );
    assert_eq!(
        (joint(&s, "h").damping, joint(&s, "h").frictionloss),
        (0.0, 0.0)
    );
    // Gravity compensation goes with the passive forces: off only when springs and dampers
    // both are (MuJoCo 4.0's rule).
    let arm = |flags: &str| {
        load(&format!(
            r#"<mujoco><option>{flags}</option><worldbody><body name="b" gravcomp="0.7"><freejoint/><geom size="0.1"/></body></worldbody></mujoco>"#
        ))
    };
    assert_eq!(body(&arm(""), "b").gravcomp, 0.7);
    assert_eq!(body(&arm(r#"<flag spring="disable"/>"#), "b").gravcomp, 0.7);
    let off = arm(r#"<flag spring="disable" damper="disable"/>"#);
    assert_eq!(body(&off, "b").gravcomp, 0.0);
}

#[test]
fn solver_and_renderer_settings_are_accepted_and_listed_as_unused() {
    let s = load(
        r#"<mujoco>
  <option iterations="50" solver="PGS" cone="elliptic" impratio="10"/>
  <visual><map znear="0.02"/></visual>
  <size nkey="5"/>
  <worldbody>
    <light pos="0 0 3"/>
    <body name="b" pos="0 0 1">
      <freejoint/>
      <geom type="sphere" size="0.1" solref="0.02 1" solimp="0.9 0.95 0.001" margin="0.01" gap="0.01" rgba="1 0 0 1"/>
    </body>
  </worldbody>
</mujoco>"#,
    );
    let all = s.unused.join("\n");
    for word in ["iterations", "solver", "gap", "visual", "size"] {
        assert!(all.contains(word), "'{word}' not listed as unused:\n{all}");
    }
    assert!(all.contains("m.xml:2:"), "{all}");
    // A geom's solref, solimp and margin size its contact, and so do the friction cone and
    // impratio (docs/mjcf.md): used, not listed.
    for word in ["solref", "solimp", "margin", "cone", "impratio"] {
        assert!(!all.contains(word), "'{word}' listed as unused:\n{all}");
    }
}

/// A friction cone MuJoCo does not have, or a `<pair>` condim it does not take, is refused
/// with the line; a pair's own condim sizes its law (docs/mjcf.md, "The friction cone").
#[test]
fn a_cone_or_pair_condim_mujoco_does_not_know_is_refused_with_the_line() {
    let e = refuse("<mujoco>\n<option cone=\"cubic\"/>\n<worldbody/></mujoco>");
    assert_eq!(e.line, 2, "{e}");
    assert!(
        e.to_string().contains("expected pyramidal or elliptic"),
        "{e}"
    );
    let pair = |condim: &str| {
        format!(
            r#"<mujoco><worldbody><geom name="floor" type="plane" size="1 1 .1"/>
<body pos="0 0 0.1"><freejoint/><geom name="ball" type="sphere" size="0.1" friction="1.9"/></body>
</worldbody><contact><pair geom1="floor" geom2="ball" friction="1.9" condim="{condim}"/></contact></mujoco>"#
        )
    };
    let e = refuse(&pair("2"));
    assert_eq!(e.line, 3, "{e}");
    assert!(e.to_string().contains("expected 1, 3, 4 or 6"), "{e}");
    // The pair's condim 4 holds the normal on six edges instead of four: 3/2 the share.
    let law = |condim: &str| load(&pair(condim)).pair_laws[0].expect("a law");
    let (three, four) = (law("3"), law("4"));
    assert!(
        (four.cone / three.cone - 1.5).abs() < 1e-12,
        "{} {}",
        three.cone,
        four.cone
    );
    assert!(four.stiffness > three.stiffness && law("1").cone == 1.0);
}

#[test]
fn physics_that_scm_does_not_model_is_refused_with_what_to_do() {
    let cases = [
        (r#"<option density="1.2" wind="1 0 0"/>"#, "option", "wind"),
        (r#"<compiler coordinate="global"/>"#, "compiler", "local"),
        (
            r#"<equality><flex flex="f"/></equality>"#,
            "flex",
            "equality",
        ),
        (
            r#"<option><flag passive="disable"/></option>"#,
            "flag",
            "spring=\"disable\" damper=\"disable\"",
        ),
        (
            r#"<option integrator="discrete"/>"#,
            "option",
            "implicitfast",
        ),
    ];
    for (extra, element, words) in cases {
        let text = format!(
            "<mujoco>\n{extra}\n<worldbody>\n<body name=\"b\"><freejoint/><geom size=\"0.1\"/></body>\n</worldbody>\n</mujoco>"
        );
        let e = refuse(&text);
        assert_eq!(e.element, element, "{e}");
        assert!(e.line >= 2, "{e}");
        assert!(e.message.contains(words), "'{words}' not in {e}");
    }
}

#[test]
fn compile_reports_every_refusal_without_stopping() {
    let dir = scratch("compile");
    let path = dir.join("two_refusals.xml");
    std::fs::write(
        &path,
        r#"<mujoco>
  <option density="1.2" wind="0 0 1"/>
  <worldbody>
    <body name="b" pos="0 0 1">
      <joint name="ball" type="ball" range="0 30"/>
      <geom type="sphere" size="0.1"/>
    </body>
  </worldbody>
</mujoco>"#,
    )
    .unwrap();
    let c = compile(&path).unwrap();
    let lines: Vec<usize> = c.refused.iter().map(|e| e.line).collect();
    assert_eq!(lines, [2, 5], "{:?}", c.refused);
    assert_eq!(c.limits.iter().flatten().count(), 1);
    let json = c.to_json();
    assert_eq!(json["joints"][0]["limited"], true);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn limits_take_mujocos_statics_under_the_integrator_a_run_uses() {
    // A hinge limit and a fixed tendon's limit, `solimplimit` dmax 0.9: the joint's gains 10
    // times the reference under every integrator, with MuJoCo's impedance as an added inertia
    // (9 times the joint's) where the step does not take the limit's damping implicitly (all but
    // damped and implicit Euler); the tendon's 10 times with its added inertia (9 times the
    // tendon's) under every integrator, its row added to the tree's factor; the law follows
    // `Model::set_integrator` both ways.
    use scm::integrate::Integrator;
    let xml = r#"<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="h" axis="0 1 0" range="-0.5 0.5" solimplimit="0.8 0.9 0.001"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.02" mass="1"/>
      <body name="fore" pos="0.5 0 0">
        <joint name="e" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.02" mass="1"/>
      </body>
    </body>
  </worldbody>
  <tendon>
    <fixed name="t" range="-0.3 0.3" solimplimit="0.8 0.9 0.001">
      <joint joint="h" coef="1"/><joint joint="e" coef="1"/>
    </fixed>
  </tendon>
</mujoco>"#;
    let mut model = load_str(xml, Path::new("limits.xml")).unwrap().model;
    let gains = |m: &scm::model::Model| {
        let j = m.tree.joints[0].limit.unwrap();
        let t = m.tendons[0].limit.unwrap();
        [
            (j.stiffness / j.reference.0, j.damping / j.reference.1),
            (t.stiffness / t.reference.0, t.damping / t.reference.1),
        ]
    };
    let close = |a: [(f64, f64); 2], b: [f64; 2]| {
        a.iter()
            .zip(b)
            .all(|(&(k, d), g)| (k - g).abs() < 1e-12 * g && (d - g).abs() < 1e-12 * g)
    };
    // The joint's added inertia ([`LimitLaw::Impedance`]): `(statics - 1) I`, zero elsewhere.
    let added = |m: &scm::model::Model| {
        let j = m.tree.joints[0].limit.unwrap();
        let t = m.tendons[0].limit.unwrap();
        (j.impedance / j.inertia, t.impedance / t.inertia)
    };
    assert_eq!(model.integrator, Integrator::DampedEuler);
    assert!(close(gains(&model), [10.0, 10.0]), "{:?}", gains(&model));
    assert_eq!(added(&model).0, 0.0);
    for (integrator, expected, inertia) in [
        (Integrator::Rk4, [10.0, 10.0], 9.0),
        (Integrator::DampedRk4, [10.0, 10.0], 9.0),
        (Integrator::ImplicitEuler, [10.0, 10.0], 0.0),
        (Integrator::Euler, [10.0, 10.0], 9.0),
        (Integrator::Dopri5, [10.0, 10.0], 9.0),
        (Integrator::DampedEuler, [10.0, 10.0], 0.0),
    ] {
        model.set_integrator(integrator);
        assert!(
            close(gains(&model), expected),
            "{integrator:?}: {:?}",
            gains(&model)
        );
        let (a, t) = added(&model);
        assert!(
            (a - inertia).abs() < 1e-12 && (t - 9.0).abs() < 1e-12,
            "{integrator:?}: {a} {t}"
        );
    }
}

#[test]
fn a_limited_pendulum_rests_against_its_limit() {
    // A hinge pendulum released horizontally, limited to 30 degrees below horizontal: it comes
    // to rest against the limit, past it by the static deflection of the limit's spring
    // (k = I / (0.02² (1 - 0.95)) from MuJoCo's default solreflimit and solimplimit: its Euler
    // gives the limit MuJoCo's statics).
    let text = r#"<mujoco>
  <option timestep="0.001"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="h" axis="0 1 0" range="-5 30" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.02" mass="1"/>
    </body>
  </worldbody>
</mujoco>"#;
    let s = load(text);
    let l = joint(&s, "h").limit.expect("the joint is limited");
    assert!((l.hi - 30f64.to_radians()).abs() < 1e-15 && (l.lo + 5f64.to_radians()).abs() < 1e-15);
    use scm::fmi::contract::FmiModel;
    let mut sim = scm::sim::Simulation::new(s, text);
    sim.do_step(0.0, 3.0).unwrap();
    let (q, v) = (sim.data.current.state.q[0], sim.data.current.state.v[0]);
    // Static balance: gravity's torque about the hinge equals the limit spring's.
    let gravity_torque = 1.0 * 9.81 * 0.25 * q.cos();
    let deflection = gravity_torque / l.stiffness + 0.5 * l.width;
    assert!(v.abs() < 1e-6, "at rest: v = {v}");
    assert!(
        (q - l.hi - deflection).abs() < 1e-6,
        "q - hi = {} vs the static deflection {deflection} (k = {})",
        q - l.hi,
        l.stiffness
    );
    // The limit's force is an FMU output: at rest it holds gravity's torque.
    let var = |name: &str| {
        let v = sim.info().variables.iter().find(|v| v.name == name);
        v.unwrap_or_else(|| panic!("no variable {name}"))
            .value_reference
    };
    let (f, hq, hv) = (var("h.limit.force"), var("h.q"), var("h.v"));
    let force = sim.get_real(f).unwrap();
    assert!(
        (force + gravity_torque).abs() < 1e-6 * gravity_torque,
        "{force} vs -{gravity_torque}"
    );
    // Its ModelStructure dependencies are the joint's angle and velocity.
    let deps = &sim.info().structure.outputs;
    let (_, d) = deps.iter().find(|(o, _)| *o == f).unwrap();
    assert_eq!(d.as_deref(), Some(&[hq, hv][..]));
    // Its directional derivatives match central differences of the output, past the onset
    // (moving) and inside the onset, where the force is C² but curved, going deeper and coming
    // back at the speed where the push `k s + b σ ḋ` is half-way down the blend that lets go.
    let d = 0.3 * l.width;
    let (s, sigma) = scm::dynamics::limit::ramp(d, l.width);
    let letting_go = (-0.25 * l.stiffness * l.width - l.stiffness * s) / (l.damping * sigma);
    // (Central differences over 1e-7 are within about 4e-7 of the exact slope here, whatever
    // the inertia: the tolerance below is 2.5 times that.)
    assert!(letting_go < 0.0);
    for (q, v) in [(l.hi + 0.01, 0.2), (l.hi + d, 0.1), (l.hi + d, letting_go)] {
        let at = |sim: &mut scm::sim::Simulation, q: f64, v: f64| {
            sim.data.current.state.q[0] = q;
            sim.data.current.state.v[0] = v;
            sim.get_real(f).unwrap()
        };
        for (known, dq, dv) in [(hq, 1e-7, 0.0), (hv, 0.0, 1e-7)] {
            at(&mut sim, q, v);
            let exact = sim.directional_derivative(&[f], &[known], &[1.0]).unwrap()[0];
            let fd = (at(&mut sim, q + dq, v + dv) - at(&mut sim, q - dq, v - dv)) / 2e-7;
            assert!(
                exact != 0.0 && (exact - fd).abs() < 1e-6 * exact.abs(),
                "{exact} vs {fd}"
            );
        }
    }
}

#[test]
fn a_keyframe_chosen_by_scm_keyframe_is_the_initial_state() {
    let scene = |choice: &str| {
        format!(
            r#"<mujoco>
  <custom><text name="scm_keyframe" data="{choice}"/></custom>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="h" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.02" mass="1"/>
    </body>
  </worldbody>
  <actuator><motor name="m" joint="h"/></actuator>
  <keyframe>
    <key name="rest" qpos="0"/>
    <key name="home" qpos="0.3" qvel="-1.5" ctrl="0.25"/>
  </keyframe>
</mujoco>"#
        )
    };
    for choice in ["home", "1"] {
        let s = load(&scene(choice));
        assert_eq!(
            (
                s.model.q0.clone(),
                s.model.v0.clone(),
                s.model.ctrl0.clone()
            ),
            (vec![0.3], vec![-1.5], vec![0.25])
        );
        assert!(
            s.unused.iter().any(|u| u.contains("keyframe not chosen")),
            "{:?}",
            s.unused
        );
        let sim = scm::sim::Simulation::new(s, &scene(choice));
        assert_eq!(
            (
                sim.data.current.state.q[0],
                sim.data.current.state.v[0],
                sim.data.current.ctrl[0]
            ),
            (0.3, -1.5, 0.25)
        );
    }
    let e = refuse(&scene("away"));
    assert_eq!((e.line, e.element.as_str()), (2, "text"), "{e}");
    assert!(e.message.contains("away"), "{e}");
    let bad = scene("home").replace("qvel=\"-1.5\"", "qvel=\"-1.5 2\"");
    let e = refuse(&bad);
    assert_eq!((e.line, e.element.as_str()), (12, "key"), "{e}");
}

#[test]
fn an_inertia_no_rigid_body_has_is_refused_as_mujoco_refuses_it() {
    let e = refuse(
        r#"<mujoco><worldbody><body name="b"><freejoint/>
<inertial pos="0 0 0" mass="1" diaginertia="0.05 0.02 0.01"/>
</body></worldbody></mujoco>"#,
    );
    assert_eq!((e.element.as_str(), e.line), ("inertial", 2), "{e}");
    assert!(e.message.contains("A + B >= C"), "{e}");
}

/// A name repeated across an `<include>` and an SCM setting inside an included file are
/// reported at the included file's line, and an unnamed object never takes a name the file
/// gives (MuJoCo accepts such a file: names only clash between given names).
#[test]
fn names_and_settings_in_included_files_name_those_files() {
    let dir = scratch("include-names");
    let main = dir.join("scene.xml");
    let write_main = |extra: &str| {
        std::fs::write(
            &main,
            format!("<mujoco>\n  <include file=\"parts.xml\"/>\n  <worldbody>\n    <body name=\"ball\" pos=\"0 0 1\"><freejoint/><geom name=\"g\" size=\"0.1\"/></body>\n{extra}  </worldbody>\n</mujoco>\n"),
        )
        .unwrap();
    };
    let parts = dir.join("parts.xml");
    // A setting out of range, three lines into the included file.
    std::fs::write(
        &parts,
        "<mujoco>\n  <custom>\n    <numeric name=\"scm_eps1\" data=\"-1\"/>\n  </custom>\n</mujoco>\n",
    )
    .unwrap();
    write_main("");
    let e = scm::scene::load(&main).unwrap_err();
    assert!(e.file.ends_with("parts.xml") && e.line == 3, "{e}");
    assert!(e.message.contains("scm_eps1"), "{e}");
    // A per-geom spacing for a geom that collides with nothing: the warning names parts.xml.
    std::fs::write(
        &parts,
        "<mujoco>\n  <custom>\n    <numeric name=\"scm_spacing:g\" data=\"0.02\"/>\n  </custom>\n</mujoco>\n",
    )
    .unwrap();
    let s = scm::scene::load(&main).unwrap();
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("parts.xml:3") && w.contains("scm_spacing:g")),
        "{:?}",
        s.warnings
    );
    // A geom name given in the included file and again in the main file.
    std::fs::write(
        &parts,
        "<mujoco>\n  <worldbody>\n\n    <geom name=\"g\" type=\"plane\" size=\"1 1 0.1\"/>\n  </worldbody>\n</mujoco>\n",
    )
    .unwrap();
    let e = scm::scene::load(&main).unwrap_err();
    assert!(e.file.ends_with("scene.xml") && e.line == 4, "{e}");
    assert!(
        e.message.contains("geom name 'g' is given twice") && e.message.contains("parts.xml:4"),
        "{e}"
    );
    // Unnamed objects next to given names they would otherwise be called by.
    std::fs::write(&parts, "<mujoco/>\n").unwrap();
    write_main("    <body pos=\"1 0 1\"><joint axis=\"0 1 0\"/><geom size=\"0.1\"/></body>\n    <body name=\"body2\" pos=\"2 0 1\"><joint name=\"body2_2_joint0\" axis=\"0 1 0\"/><geom name=\"body2_geom0\" size=\"0.1\"/></body>\n");
    let s = scm::scene::load(&main).unwrap();
    let bodies: Vec<&str> = s
        .model
        .tree
        .bodies
        .iter()
        .map(|b| b.name.as_str())
        .collect();
    assert_eq!(bodies, ["world", "ball", "body2_2", "body2"]);
    let joints: Vec<&str> = s
        .model
        .tree
        .joints
        .iter()
        .map(|j| j.name.as_str())
        .collect();
    assert_eq!(joints, ["ball", "body2_2_joint0_2", "body2_2_joint0"]);
    std::fs::remove_dir_all(&dir).ok();
}

/// A typing slip MuJoCo reads past (dm_control's stacker.xml has `</visual>>`) loads, and the
/// stray text is listed as unused with its file and line.
#[test]
fn stray_text_between_elements_is_listed_not_refused() {
    let s = load("<mujoco>\n  <visual/>>\n  <worldbody>\n    <geom type=\"plane\" size=\"1 1 0.1\"/>\n  </worldbody>\n</mujoco>\n");
    assert!(
        s.unused
            .iter()
            .any(|u| u.starts_with("m.xml:2: text '>' inside <mujoco>")),
        "{:?}",
        s.unused
    );
}

/// Stray text inside a `<replicate>` (or inside what it copies) is listed once, at its line,
/// not once per copy.
#[test]
fn stray_text_in_a_replicate_is_listed_once() {
    let s = load("<mujoco>\n  <worldbody>\n    <replicate count=\"3\" offset=\"0.1 0 0\">x\n      <body>y\n        <geom size=\"0.01\"/>\n      </body>\n    </replicate>\n  </worldbody>\n</mujoco>\n");
    let texts: Vec<&String> = s.unused.iter().filter(|u| u.contains("text '")).collect();
    assert_eq!(texts.len(), 2, "{:?}", s.unused);
    assert!(
        texts[0].starts_with("m.xml:3: text 'x' inside <replicate>"),
        "{texts:?}"
    );
    assert!(
        texts[1].starts_with("m.xml:4: text 'y' inside <body>"),
        "{texts:?}"
    );
}

/// `<custom>` as MuJoCo reads it: a tuple holds `<element>`s and no data, a numeric may give
/// a size instead of data; entries other than SCM's settings are the user's data, listed as
/// unused. An SCM setting still needs its data.
#[test]
fn custom_data_for_the_user_is_read_past_and_listed() {
    let s = load("<mujoco>\n  <custom>\n    <numeric name=\"gains\" size=\"3\"/>\n    <text name=\"note\" data=\"abc\"/>\n    <tuple name=\"t\">\n      <element objtype=\"body\" objname=\"world\" prm=\"1\"/>\n    </tuple>\n  </custom>\n  <worldbody/>\n</mujoco>\n");
    for line in ["m.xml:3: <numeric>", "m.xml:4: <text>", "m.xml:5: <tuple>"] {
        assert!(
            s.unused.iter().any(|u| u.starts_with(line)),
            "{line}: {:?}",
            s.unused
        );
    }
    let e = refuse("<mujoco>\n  <custom>\n    <numeric name=\"scm_eps1\" size=\"1\"/>\n  </custom>\n  <worldbody/>\n</mujoco>\n");
    assert!(e.line == 3 && e.message.contains("missing data"), "{e}");
}

/// A position actuator's `dampratio` gives critical damping at ζ = 1 for the inertia it
/// drives: on a lone slider of mass m (with armature a) `kv = 2 ζ √(kp (m + a))`; refused
/// where MuJoCo refuses it. (tests/python/test_mjcf_compiler.py compares chains and tendons
/// with MuJoCo's compiled kv.)
#[test]
fn position_dampratio_sets_kv_from_the_driven_inertia() {
    let scene = |act: &str| {
        format!("<mujoco>\n  <worldbody>\n    <body pos=\"0 0 1\">\n      <joint name=\"s\" type=\"slide\" axis=\"1 0 0\" armature=\"0.5\"/>\n      <geom type=\"box\" size=\"0.1 0.1 0.1\" mass=\"2\"/>\n    </body>\n  </worldbody>\n  <actuator>\n    {act}\n  </actuator>\n</mujoco>\n")
    };
    let s = load(&scene(
        r#"<position joint="s" kp="10" dampratio="0.5" gear="2"/>"#,
    ));
    let scm::model::ActuatorKind::Position { kp, kv } = s.model.actuators[0].kind else {
        panic!("a position actuator")
    };
    // Moment 2 through the inertia 2.5: m = 2.5 / 4.
    let want = 2.0 * 0.5 * (kp * 2.5 / 4.0_f64).sqrt();
    assert!((kv - want).abs() < 1e-12 * want, "{kv} vs {want}");
    for (act, says) in [
        (
            r#"<position joint="s" kv="1" dampratio="1"/>"#,
            "cannot both",
        ),
        (
            r#"<position joint="s" dampratio="-1"/>"#,
            "must not be negative",
        ),
    ] {
        let e = refuse(&scene(act));
        assert!(e.line == 9 && e.message.contains(says), "{act}: {e}");
    }
    // MuJoCo's schema has dampratio on a position only.
    let e = refuse(&scene(r#"<motor joint="s" dampratio="1"/>"#));
    assert!(
        e.line == 9 && e.message.contains("not an attribute of <motor>"),
        "{e}"
    );
    // A <general> whose bias is a position servo's reads a positive biasprm[2] as a damping
    // ratio, as MuJoCo's compiler does.
    let s = load(&scene(
        r#"<general joint="s" gainprm="10" biastype="affine" biasprm="0 -10 0.5" gear="2"/>"#,
    ));
    let scm::model::ActuatorKind::General { bias, .. } = s.model.actuators[0].kind else {
        panic!("a general actuator")
    };
    assert!((bias[2] + want).abs() < 1e-12 * want, "{bias:?} vs {want}");
}

/// Actuator defaults as MuJoCo 4 resolves them: a shortcut's parameters come from a default of
/// its own kind, or from a `<general>` default whose gain it reads, never from a default of
/// another shortcut (whose shared attributes, gear and ranges, still reach it).
/// (test_mjcf_compiler.py checks many more combinations against MuJoCo itself.)
#[test]
fn actuator_defaults_give_parameters_by_kind() {
    let gains = |defaults: &str, act: &str| {
        let s = load(&format!("<mujoco>\n  <default>{defaults}</default>\n  <worldbody>\n    <body>\n      <joint name=\"s\" type=\"slide\"/>\n      <geom size=\"0.1\" mass=\"2\"/>\n    </body>\n  </worldbody>\n  <actuator>{act}</actuator>\n</mujoco>\n"));
        let a = &s.model.actuators[0];
        (a.kind, a.gear)
    };
    use scm::model::ActuatorKind::*;
    let velocity = r#"<velocity kv="10" gear="3"/>"#;
    let (kind, gear) = gains(velocity, r#"<position joint="s"/>"#);
    assert!(
        matches!(kind, Position { kp: 1.0, kv: 0.0 }) && gear == 3.0,
        "{kind:?}"
    );
    let (kind, _) = gains(velocity, r#"<damper joint="s" ctrlrange="0 1"/>"#);
    assert!(
        matches!(kind, General { gain: [0.0, 0.0, g], .. } if g == 0.0),
        "{kind:?}"
    );
    let (kind, _) = gains(velocity, r#"<velocity joint="s"/>"#);
    assert!(matches!(kind, Velocity { kv: 10.0 }), "{kind:?}");
    // A <general> element takes the parameters the default left.
    let (kind, _) = gains(velocity, r#"<general joint="s"/>"#);
    assert!(
        matches!(
            kind,
            General {
                gain: [10.0, 0.0, 0.0],
                bias: [0.0, 0.0, -10.0]
            }
        ),
        "{kind:?}"
    );
    // A position reads kp from a <general> default's fixed gain and keeps its biasprm[2].
    let general = r#"<general gainprm="5" biastype="affine" biasprm="0 0 -2"/>"#;
    let (kind, _) = gains(general, r#"<position joint="s"/>"#);
    assert!(matches!(kind, Position { kp: 5.0, kv: 2.0 }), "{kind:?}");
    // A nested class's default of another kind leaves the parent's position default visible.
    let nested = r#"<position kp="7" kv="1"/><default class="c"><velocity kv="3"/></default>"#;
    let (kind, _) = gains(nested, r#"<position joint="s" class="c"/>"#);
    assert!(matches!(kind, Position { kp: 7.0, kv: 1.0 }), "{kind:?}");
    // MuJoCo's schema: one default of a kind per class, and a kind's own attributes only.
    let e = refuse(
        "<mujoco>\n  <default>\n    <motor/>\n    <motor gear=\"2\"/>\n  </default>\n</mujoco>\n",
    );
    assert!(e.line == 4 && e.message.contains("once"), "{e}");
    let e = refuse("<mujoco>\n  <default>\n    <velocity kp=\"2\"/>\n  </default>\n</mujoco>\n");
    assert!(
        e.line == 3 && e.message.contains("not an attribute of <velocity>"),
        "{e}"
    );
}

/// `springdamper` on a lone slider body of mass m: `k = m/(τζ)²`, `b = 2m/τ` replace the
/// joint's stiffness and damping (MuJoCo's `dof_invweight0` of such a "simple" body leaves
/// the armature out: MuJoCo gives 600 and 30 here); non-positive values refused.
#[test]
fn joint_springdamper_sets_stiffness_and_damping_from_the_inertia() {
    let scene = |attrs: &str| {
        format!("<mujoco>\n  <worldbody>\n    <body pos=\"0 0 1\">\n      <geom type=\"box\" size=\"0.1 0.1 0.1\" mass=\"2\"/>\n      <body>\n        <joint name=\"s\" type=\"slide\" axis=\"1 0 0\" armature=\"0.5\" stiffness=\"7\" {attrs}/>\n        <geom type=\"sphere\" size=\"0.05\" mass=\"1.5\"/>\n      </body>\n    </body>\n  </worldbody>\n</mujoco>\n")
    };
    let s = load(&scene(r#"springdamper="0.1 0.5""#));
    let j = joint(&s, "s");
    assert!(
        (j.stiffness - 1.5 / (0.1f64 * 0.5).powi(2)).abs() < 1e-9,
        "{}",
        j.stiffness
    );
    assert!((j.damping - 2.0 * 1.5 / 0.1).abs() < 1e-12, "{}", j.damping);
    let e = refuse(&scene(r#"springdamper="0 1""#));
    assert!(e.line == 6 && e.message.contains("must be positive"), "{e}");
}

/// A damper without a control range, or with a negative one, is refused as MuJoCo refuses it.
#[test]
fn a_damper_needs_a_non_negative_control_range() {
    let scene = |act: &str| {
        format!("<mujoco>\n  <worldbody>\n    <body pos=\"0 0 1\">\n      <joint name=\"h\" axis=\"0 1 0\"/>\n      <geom type=\"capsule\" fromto=\"0 0 0 0.3 0 0\" size=\"0.02\"/>\n    </body>\n  </worldbody>\n  <actuator>\n    {act}\n  </actuator>\n</mujoco>\n")
    };
    let s = load(&scene(r#"<damper joint="h" kv="2" ctrlrange="0 1"/>"#));
    assert!(matches!(
        s.model.actuators[0].kind,
        scm::model::ActuatorKind::General { gain: [0.0, 0.0, g], bias: [0.0, 0.0, 0.0] } if g == -2.0
    ));
    for (act, says) in [
        (r#"<damper joint="h" kv="2"/>"#, "needs a ctrlrange"),
        (
            r#"<damper joint="h" kv="2" ctrlrange="-1 1"/>"#,
            "cannot be negative",
        ),
    ] {
        let e = refuse(&scene(act));
        assert!(e.line == 9 && e.message.contains(says), "{act}: {e}");
    }
}

/// Files as gymnasium-robotics writes them: an included file rooted at `<mujocoinclude>`, a
/// tendon declared (in an include) before the joints it names, and an open mesh: left out
/// (listed as unused) on a geom that neither collides nor carries mass; on a colliding geom
/// sampled by its convex hull, as MuJoCo collides it (a warning says so); on a geom that gives
/// its body mass weighed as MuJoCo weighs it: by default its legacy rule (pyramids from the
/// faces there are), the hull's mass under `inertia="convex"`, and refused under
/// `inertia="exact"` (the solid a closed surface encloses), naming both the mesh and the geom.
#[test]
fn robotics_files_include_roots_late_joints_and_open_meshes() {
    let dir = scratch("robotics");
    // A tetrahedron with one face missing: open; its hull is the whole tetrahedron.
    std::fs::write(
        dir.join("open.obj"),
        "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\n",
    )
    .unwrap();
    let shared = |inertia: &str| {
        format!("<mujocoinclude>\n  <tendon>\n    <fixed name=\"t\"><joint joint=\"h\" coef=\"1\"/></fixed>\n  </tendon>\n  <asset><mesh name=\"shell\" file=\"open.obj\" {inertia}/></asset>\n</mujocoinclude>\n")
    };
    std::fs::write(dir.join("shared.xml"), shared("")).unwrap();
    let main = dir.join("robot.xml");
    let scene = |visual: &str| {
        format!("<mujoco>\n  <include file=\"shared.xml\"/>\n  <worldbody>\n    <body name=\"arm\" pos=\"0 0 1\">\n      <joint name=\"h\" axis=\"0 1 0\"/>\n      <geom type=\"capsule\" fromto=\"0 0 0 0.3 0 0\" size=\"0.02\"/>\n      <geom type=\"mesh\" mesh=\"shell\" {visual}/>\n    </body>\n  </worldbody>\n</mujoco>\n")
    };
    std::fs::write(&main, scene(r#"contype="0" conaffinity="0" mass="0""#)).unwrap();
    let s = scm::scene::load(&main).unwrap();
    assert_eq!(s.model.tendons.len(), 1);
    assert_eq!(s.geoms.len(), 1, "the visual mesh geom is left out");
    assert!(
        s.unused
            .iter()
            .any(|u| u.contains("robot.xml:7: <geom> geom left out") && u.contains("open")),
        "{:?}",
        s.unused
    );
    // Colliding without mass: the convex hull, a closed tetrahedron of volume 0.1³/6.
    std::fs::write(&main, scene(r#"mass="0""#)).unwrap();
    let s = scm::scene::load(&main).unwrap();
    let hull = match &s.geoms[1].shape {
        Some(scm::geometry::Shape::Mesh(m)) => m.mass_properties(),
        other => panic!("{other:?}"),
    };
    // (OBJ coordinates are read as f32.)
    assert!((hull.volume - 1e-3 / 6.0).abs() < 1e-10, "{}", hull.volume);
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("robot.xml:7") && w.contains("convex hull") && w.contains("open")),
        "{:?}",
        s.warnings
    );
    // Carrying mass by MuJoCo's default rule: three pyramids from the faces' centroid
    // (0.1/45)·(2, 2, 2), each of height 0.1·2/9 on a face of 0.005 m²: 0.1³/9 in all.
    let capsule = std::f64::consts::PI * 0.02f64.powi(2) * (0.3 + 4.0 / 3.0 * 0.02);
    for visual in ["", r#"contype="0" conaffinity="0""#] {
        std::fs::write(&main, scene(visual)).unwrap();
        let s = scm::scene::load(&main).unwrap();
        let mass = body(&s, "arm").inertia.mass;
        assert!(
            (mass - 1000.0 * (capsule + 1e-3 / 9.0)).abs() < 1e-7,
            "{visual}: {mass}"
        );
    }
    // The solid the surface encloses (inertia="exact") needs a closed surface: refused where
    // the mesh is declared, naming the geom.
    std::fs::write(dir.join("shared.xml"), shared(r#"inertia="exact""#)).unwrap();
    let e = scm::scene::load(&main).unwrap_err();
    assert!(e.file.ends_with("shared.xml") && e.line == 5, "{e}");
    assert!(
        e.message.contains("the mesh is open")
            && e.message.contains("robot.xml:7")
            && e.message.contains("inertia=\"exact\""),
        "{e}"
    );
    // ... unless the mesh asks for its hull's mass, as MuJoCo then takes it.
    std::fs::write(dir.join("shared.xml"), shared(r#"inertia="convex""#)).unwrap();
    let s = scm::scene::load(&main).unwrap();
    let mass = body(&s, "arm").inertia.mass;
    assert!(
        (mass - 1000.0 * (capsule + 1e-3 / 6.0)).abs() < 1e-7,
        "{mass}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// MuJoCo's edges of `actuatorfrcrange` and a damper's control range: an empty range (lo =
/// hi) limits nothing under autolimits, a reversed one written limited is refused, and a
/// damper's control is limited by its ctrlrange even with autolimits off.
#[test]
fn actuator_force_and_damper_ranges_at_their_edges() {
    let scene = |compiler: &str, joint: &str, act: &str| {
        format!("<mujoco>\n  <compiler {compiler}/>\n  <worldbody>\n    <body pos=\"0 0 1\">\n      <joint name=\"h\" axis=\"0 1 0\" {joint}/>\n      <geom type=\"capsule\" fromto=\"0 0 0 0.3 0 0\" size=\"0.02\"/>\n    </body>\n  </worldbody>\n  <actuator>\n    {act}\n  </actuator>\n</mujoco>\n")
    };
    let s = load(&scene(
        r#"autolimits="true""#,
        r#"actuatorfrcrange="1 1""#,
        r#"<motor joint="h"/>"#,
    ));
    assert!(
        s.model.actuator_ranges.is_empty(),
        "an empty range limits nothing"
    );
    let e = refuse(&scene(
        r#"autolimits="true""#,
        r#"actuatorfrcrange="1 -1" actuatorfrclimited="true""#,
        r#"<motor joint="h"/>"#,
    ));
    assert!(e.line == 5 && e.message.contains("reversed"), "{e}");
    let s = load(&scene(
        r#"autolimits="false""#,
        "",
        r#"<damper joint="h" kv="2" ctrlrange="0 1"/>"#,
    ));
    assert_eq!(s.model.actuators[0].ctrlrange, Some((0.0, 1.0)));
}

/// `<inertial mass="0">` is MuJoCo's massless frame (a camera mount in a robot file): taken on
/// a body welded to one that moves with mass; a moving body with nothing else is refused, as
/// MuJoCo refuses it, and so is a negative mass.
#[test]
fn a_zero_inertial_is_a_massless_frame() {
    let scene = |joint: &str, inertial: &str| {
        format!("<mujoco>\n  <worldbody>\n    <body name=\"arm\" pos=\"0 0 1\">\n      <joint axis=\"0 1 0\"/>\n      <geom type=\"capsule\" fromto=\"0 0 0 0.3 0 0\" size=\"0.02\"/>\n      <body name=\"frame\" pos=\"0.3 0 0\">\n        {joint}\n        <inertial pos=\"0 0 0\" {inertial}/>\n      </body>\n    </body>\n  </worldbody>\n</mujoco>\n")
    };
    let zero = r#"mass="0" diaginertia="0 0 0""#;
    let s = load(&scene("", zero));
    assert_eq!(body(&s, "frame").inertia.mass, 0.0);
    let e = refuse(&scene(r#"<joint axis="0 1 0"/>"#, zero));
    assert!(e.line == 6 && e.message.contains("frame"), "{e}");
    let e = refuse(&scene("", r#"mass="-1" diaginertia="1 1 1""#));
    assert!(
        e.line == 8 && e.message.contains("must not be negative"),
        "{e}"
    );
}

/// A position's `inheritrange` r: its control range is the middle of its target's range ± r
/// times the half-width (a hinge's range in degrees read in radians; a fixed tendon's length
/// range), as MuJoCo compiles it; refused on a target without a range, as MuJoCo refuses it.
#[test]
fn inheritrange_takes_the_control_range_from_the_target() {
    let scene = |joint: &str, act: &str| {
        format!("<mujoco>\n  <worldbody>\n    <body pos=\"0 0 1\">\n      <joint name=\"h\" axis=\"0 1 0\" {joint}/>\n      <geom type=\"capsule\" fromto=\"0 0 0 0.3 0 0\" size=\"0.02\"/>\n    </body>\n  </worldbody>\n  <tendon><fixed name=\"t\" range=\"0 4\"><joint joint=\"h\" coef=\"2\"/></fixed></tendon>\n  <actuator>\n    {act}\n  </actuator>\n</mujoco>\n")
    };
    let s = load(&scene(
        r#"range="-30 90""#,
        r#"<position joint="h" inheritrange="0.5"/><position tendon="t" inheritrange="1"/>"#,
    ));
    let (lo, hi) = s.model.actuators[0].ctrlrange.expect("limited");
    let (mid, half) = (30f64.to_radians(), 60f64.to_radians());
    assert!((lo - (mid - 0.5 * half)).abs() < 1e-12 && (hi - (mid + 0.5 * half)).abs() < 1e-12);
    assert_eq!(s.model.actuators[1].ctrlrange, Some((0.0, 4.0)));
    let e = refuse(&scene("", r#"<position joint="h" inheritrange="1"/>"#));
    assert!(
        e.line == 10 && e.message.contains("inheritrange needs"),
        "{e}"
    );
}

/// Welds as MuJoCo reads them: body semantics hold the pose at `qpos0` (a zero `relpose`
/// quaternion is MuJoCo's "not given"), `relpose` gives body 1's point and the held rotation,
/// sites give both points and frames, `torquescale="0"` frees the rotation; what would hold
/// nothing or cannot be placed is refused at its line.
#[test]
fn welds_are_read_as_mujoco_reads_them() {
    let scene = |equality: &str| {
        format!(
            r#"<mujoco>
  <worldbody>
    <body name="a" pos="0 0 1" euler="0 30 0">
      <freejoint/>
      <geom type="box" size="0.1 0.05 0.05"/>
      <site name="s" pos="0.1 0 0" quat="0 1 0 0"/>
    </body>
    <body name="b" pos="0.5 0 1">
      <freejoint/>
      <geom type="sphere" size="0.05"/>
      <site name="fromto" type="capsule" size="0.01" fromto="0 0 0 0 0 0.1"/><site name="t" pos="0 0.05 0"/>
    </body>
  </worldbody>
  <equality>{equality}</equality>
</mujoco>"#
        )
    };
    let held = load(&scene(
        r#"<weld body1="a" body2="b" relpose="0 0 0 0 0 0 0"/>"#,
    ));
    let c = &held.model.connects[0];
    let o = c
        .orientation
        .as_ref()
        .expect("a weld holds the orientation");
    // Body 1's point is body 2's origin (the anchor's default) as seen from body 1 at qpos0,
    // and the held rotation is body 2's relative to body 1's there: the 30° about y undone.
    let turn = UnitQuaternion::from_euler_angles(0.0, 30f64.to_radians(), 0.0);
    let expected = turn.inverse() * Vector3::new(0.5, 0.0, 0.0);
    assert!((c.first.1 - expected).norm() < 1e-12, "{}", c.first.1);
    assert!(c.second.1.norm() < 1e-12);
    assert!((o.relative - turn.inverse().to_rotation_matrix().matrix()).amax() < 1e-12);
    let given = load(&scene(
        r#"<weld body1="a" body2="b" relpose="0.1 0.2 0.3 0 0 0 2" anchor="0 0 0.05"/>"#,
    ));
    let c = &given.model.connects[0];
    let half = UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::PI);
    assert_eq!(c.first.1, Vector3::new(0.1, 0.2, 0.3));
    assert_eq!(c.second.1, Vector3::new(0.0, 0.0, 0.05));
    let o = c.orientation.as_ref().unwrap();
    assert!((o.relative - half.to_rotation_matrix().matrix()).amax() < 1e-12);
    let free = load(&scene(r#"<weld body1="a" body2="b" torquescale="0"/>"#));
    assert!(free.model.connects[0].orientation.is_none());
    assert!(free.warnings.is_empty(), "{:?}", free.warnings);
    let scaled = load(&scene(r#"<weld body1="a" torquescale="3"/>"#));
    assert_eq!(
        scaled.model.connects[0].second.0, 0,
        "body 2 defaults to the world"
    );
    assert!(
        scaled
            .warnings
            .iter()
            .any(|w| w.contains("m.xml:14") && w.contains("torquescale=\"3\"")),
        "{:?}",
        scaled.warnings
    );
    // A negative torquescale is its magnitude (MuJoCo flips residual and Jacobian together);
    // two sites of one body hold nothing, in MuJoCo too: left out, and said so.
    let flipped = load(&scene(r#"<weld body1="a" torquescale="-1"/>"#));
    assert!(flipped.model.connects[0].orientation.is_some() && flipped.warnings.is_empty());
    let nothing = load(&scene(
        r#"<weld site1="s" site2="s"/><connect site1="t" site2="t"/>"#,
    ));
    assert!(nothing.model.connects.is_empty());
    assert_eq!(
        nothing
            .unused
            .iter()
            .filter(|u| u.contains("holds nothing"))
            .count(),
        2
    );
    // Sites: the points are the sites, the held rotation site 1's frame on site 2's.
    let sites = load(&scene(r#"<weld site1="s" site2="t"/>"#));
    let c = &sites.model.connects[0];
    assert_eq!((c.first.0, c.second.0), (1, 2));
    assert_eq!(
        (c.first.1, c.second.1),
        (Vector3::new(0.1, 0.0, 0.0), Vector3::new(0.0, 0.05, 0.0))
    );
    let flip = UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0);
    assert!(
        (c.orientation.as_ref().unwrap().relative - flip.to_rotation_matrix().matrix()).amax()
            < 1e-12
    );
    for (equality, why) in [
        (r#"<weld body1="a" body2="a"/>"#, "the same body"),
        (
            r#"<weld body1="a" body2="a" active="false"/>"#,
            "the same body",
        ),
        (r#"<connect body1="a" active="false"/>"#, "needs an anchor"),
        (r#"<weld site1="s" site2="fromto"/>"#, "placed by fromto"),
        (r#"<weld site1="s"/>"#, "site2 is required"),
        (
            r#"<weld site1="s" site2="nowhere"/>"#,
            "no site named 'nowhere'",
        ),
        (r#"<weld body2="b"/>"#, "body2 without body1"),
        (r#"<connect body1="a" body2="b"/>"#, "needs an anchor"),
        (r#"<weld body1="a" relpose="0 0 0 1 0 0"/>"#, "relpose"),
        (r#"<flex flex="f"/>"#, "unsupported equality"),
    ] {
        let e = refuse(&scene(equality)).to_string();
        assert!(e.contains("m.xml:14") && e.contains(why), "{equality}: {e}");
    }
}

/// A body whose joints move it the same way twice (a hinge beside a ball joint) has a singular
/// mass matrix, which MuJoCo regularizes with a warning and SCM's forward dynamics cannot
/// solve: refused at load, at the body's line, naming the joint, instead of failing at t = 0
/// (and giving the equalities' springs no stiffness on the way).
#[test]
fn a_body_turned_twice_the_same_way_is_refused_at_its_line() {
    let e = refuse(
        r#"<mujoco>
  <worldbody>
    <body name="b"><joint type="hinge" axis="1 0 0"/><joint name="twice" type="ball"/><geom size=".1" pos=".2 0 0"/></body>
    <body name="a" pos="2 0 0"><freejoint/><geom size=".1"/></body>
  </worldbody>
</mujoco>"#,
    );
    assert_eq!((e.line, e.element.as_str()), (3, "body"), "{e}");
    assert!(
        e.message.contains("singular") && e.message.contains("'twice'"),
        "{e}"
    );
}

/// What SCM does not model among equalities switched off (`<flag equality="disable">`), or
/// inactive, does not stop the file: a flex equality and a connect to a site placed by
/// `fromto` load with the flag, listed unused; an inactive connect to such a site loads too.
/// A mesh weighed by its hull (`inertia="convex"`) with MuJoCo's reduced hull (`maxhullvert`)
/// is refused only where a geom's mass uses it.
#[test]
fn what_a_file_switches_off_or_does_not_weigh_does_not_stop_it() {
    let scene = |option: &str, equality: &str| {
        format!(
            r#"<mujoco>
  {option}
  <worldbody>
    <body name="a" pos="0 0 1">
      <freejoint/>
      <geom type="box" size="0.1 0.05 0.05"/>
      <site name="s" pos="0.1 0 0"/><site name="f" type="capsule" size="0.01" fromto="0 0 0 0 0 0.1"/>
    </body>
  </worldbody>
  <equality>{equality}</equality>
</mujoco>"#
        )
    };
    let off = r#"<option><flag equality="disable"/></option>"#;
    for equality in [r#"<flex flex="x"/>"#, r#"<connect site1="s" site2="f"/>"#] {
        let s = load(&scene(off, equality));
        assert!(s.model.connects.is_empty(), "{equality}");
        assert!(
            s.unused.iter().any(|u| u.contains("switched off")),
            "{:?}",
            s.unused
        );
        refuse(&scene("", equality));
    }
    let s = load(&scene(
        "",
        r#"<connect site1="s" site2="f" active="false"/>"#,
    ));
    assert!(s.model.connects.is_empty());

    let dir = scratch("convex_maxhullvert");
    std::fs::write(
        dir.join("cube.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\n\
         f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n",
    )
    .unwrap();
    let file = |geom: &str| {
        format!("<mujoco>\n  <asset><mesh name=\"c\" file=\"cube.obj\" scale=\"0.1 0.1 0.1\" inertia=\"convex\" maxhullvert=\"8\"/></asset>\n  <worldbody>\n    <body name=\"b\" pos=\"0 0 1\">\n      <freejoint/>\n      <geom type=\"sphere\" size=\"0.05\"/>\n      <geom type=\"mesh\" mesh=\"c\" {geom}/>\n    </body>\n  </worldbody>\n</mujoco>\n")
    };
    let path = dir.join("m.xml");
    std::fs::write(&path, file(r#"mass="0""#)).unwrap();
    let s = scm::scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        s.unused.iter().any(|u| u.contains("maxhullvert")),
        "{:?}",
        s.unused
    );
    std::fs::write(&path, file("")).unwrap();
    let e = scm::scene::load(&path).unwrap_err();
    assert!(e.line == 7 && e.message.contains("maxhullvert"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A spatial tendon is read as MuJoCo reads it: straight segments between consecutive sites,
/// each scaled by `1 / divisor` of the pulley before it, a segment within one body kept (it
/// adds length, exerts nothing), unnamed tendons numbered with the fixed ones, the spring
/// length at the springs' rest pose by default; what MuJoCo's compiler refuses is refused at
/// the element's line, and so is what SCM does not model yet (wrapping around a geom, an
/// equality on a spatial tendon). An actuator drives a spatial tendon.
#[test]
fn spatial_tendons_read_as_mujoco_reads_them_and_refuse_what_it_refuses() {
    let scene = |tendon: &str, after: &str| {
        format!(
            "<mujoco>
  <worldbody>
    <site name=\"hook\" pos=\"0 0 2\"/>
    <site name=\"hook2\" pos=\"1 0 2\"/>
    <site name=\"drawn\" fromto=\"0 0 2 0 0 2.1\"/>
    <geom name=\"drum\" type=\"cylinder\" size=\"0.1 0.1\" pos=\"0.5 0 2\"/>
    <body name=\"arm\" pos=\"0 0 1\">
      <joint name=\"h\" axis=\"0 1 0\" springref=\"0.5\"/>
      <geom type=\"capsule\" fromto=\"0 0 0 0.4 0 0\" size=\"0.02\"/>
      <site name=\"tip\" pos=\"0.4 0 0\"/>
      <site name=\"mid\" pos=\"0.2 0 0\"/>
    </body>
  </worldbody>
  <tendon>
    <fixed><joint joint=\"h\" coef=\"1\"/></fixed>
    {tendon}
  </tendon>
  {after}
</mujoco>
"
        )
    };
    let s = load(&scene(
        r#"<spatial range="0 3"><site site="hook"/><site site="tip"/><pulley divisor="4"/><site site="hook2"/><site site="tip"/><site site="mid"/></spatial>"#,
        "",
    ));
    let t = &s.model.spatial_tendons[0];
    assert_eq!(t.name, "tendon1", "numbered after the fixed tendon0");
    let scales: Vec<f64> = t.segments.iter().map(|g| g.scale).collect();
    assert_eq!(scales, [1.0, 0.25, 0.25]);
    let arm = s
        .model
        .tree
        .bodies
        .iter()
        .position(|b| b.name == "arm")
        .unwrap();
    assert_eq!((t.segments[2].from.0, t.segments[2].to.0), (arm, arm));
    assert!(t.law.limit.is_some());
    // The spring length: at springref 0.5° (MuJoCo's value, 1.4225672 m, is compared in
    // tests/python/test_mjcf_compiler.py) the tip is at (0.4 cos a, 0, 1 - 0.4 sin a).
    let a = 0.5f64.to_radians();
    let tip = Vector3::new(0.4 * a.cos(), 0.0, 1.0 - 0.4 * a.sin());
    let mid = Vector3::new(0.2 * a.cos(), 0.0, 1.0 - 0.2 * a.sin());
    let rest = (tip - Vector3::new(0.0, 0.0, 2.0)).norm()
        + 0.25 * ((tip - Vector3::new(1.0, 0.0, 2.0)).norm() + (tip - mid).norm());
    let (lo, hi) = t.law.spring_length;
    assert!((lo - rest).abs() < 1e-12 && lo == hi, "{lo} vs {rest}");
    let s = load(&scene(
        r#"<spatial name="s"><site site="hook"/><site site="tip"/></spatial>"#,
        r#"<actuator><motor tendon="s"/></actuator>"#,
    ));
    assert_eq!(
        s.model.actuators[0].target,
        scm::model::Transmission::Spatial(0)
    );

    // A geom between two sites wraps the segment (tests/python/test_tendon_wrap.py compares
    // it with MuJoCo).
    let s = load(&scene(
        r#"<spatial><site site="hook"/><geom geom="drum"/><site site="tip"/></spatial>"#,
        "",
    ));
    let w = s.model.spatial_tendons[0].segments[0]
        .wrap
        .expect("the segment wraps");
    assert_eq!((w.body, w.radius), (0, 0.1));

    for (tendon, after, element, says) in [
        (
            r#"<spatial><site site="hook"/><site site="tip"/><pulley divisor="2"/></spatial>"#,
            "",
            "pulley",
            "end with a pulley",
        ),
        (
            r#"<spatial><site site="hook"/><site site="tip"/><pulley divisor="2"/><pulley divisor="2"/><site site="hook2"/><site site="tip"/></spatial>"#,
            "",
            "pulley",
            "consecutive pulleys",
        ),
        (
            r#"<spatial><site site="hook"/><site site="tip"/><pulley/><site site="hook2"/><site site="tip"/></spatial>"#,
            "",
            "pulley",
            "divisor is required",
        ),
        (
            r#"<spatial><site site="hook"/><site site="tip"/><pulley divisor="0"/><site site="hook2"/><site site="tip"/></spatial>"#,
            "",
            "pulley",
            "positive divisor",
        ),
        (
            r#"<spatial><site site="hook"/><pulley divisor="2"/><site site="tip"/><pulley divisor="2"/><site site="hook2"/></spatial>"#,
            "",
            "site",
            "needs a neighbour",
        ),
        (
            r#"<spatial><site site="tip"/><site site="tip"/></spatial>"#,
            "",
            "site",
            "repeated",
        ),
        (
            r#"<spatial><site site="tip"/></spatial>"#,
            "",
            "spatial",
            "at least two",
        ),
        (
            r#"<spatial><site site="drawn"/><site site="tip"/></spatial>"#,
            "",
            "site",
            "fromto",
        ),
        (
            r#"<spatial><site site="nowhere"/><site site="tip"/></spatial>"#,
            "",
            "site",
            "no site named 'nowhere'",
        ),
        (
            r#"<spatial width="0"><site site="hook"/><site site="tip"/></spatial>"#,
            "",
            "spatial",
            "width",
        ),
        (
            r#"<spatial range="0.3 0.3"><site site="hook"/><site site="tip"/></spatial>"#,
            "",
            "spatial",
            "increasing",
        ),
        (
            r#"<spatial name="s"><site site="hook"/><site site="tip"/></spatial>"#,
            r#"<equality><tendon tendon1="s"/></equality>"#,
            "tendon",
            "an equality of a spatial tendon is not supported",
        ),
    ] {
        let e = refuse(&scene(tendon, after));
        assert!(
            e.element == element && e.line >= 16 && e.message.contains(says),
            "{tendon} {after}: {e}"
        );
    }
}

/// An actuator on a site reads MuJoCo's 6-vector gear (missing entries zero, default along
/// the site's x axis) and keeps a scalar gear of 1; an adhesion drives its body (its gain, its
/// class's, no gear read); what SCM does not model (a `refsite`) and what MuJoCo refuses (an
/// adhesion's negative or missing control range) is refused at the actuator's line.
#[test]
fn site_transmissions_read_their_gear_and_refuse_what_they_cannot_drive() {
    let scene = |act: &str| {
        format!("<mujoco>\n  <worldbody>\n    <site name=\"drawn\" fromto=\"0 0 0 0 0 0.1\"/>\n    <body name=\"b\" pos=\"0 0 1\">\n      <freejoint/>\n      <geom type=\"box\" size=\"0.1 0.1 0.1\"/>\n      <site name=\"s\" pos=\"0.1 0 0\"/>\n      <site name=\"t\"/>\n    </body>\n  </worldbody>\n  <actuator>\n    {act}\n  </actuator>\n</mujoco>\n")
    };
    let s = load(&scene(r#"<motor site="s" gear="0 0 2"/><motor site="t"/>"#));
    let gears: Vec<[f64; 6]> = s.model.site_transmissions.iter().map(|t| t.gear).collect();
    assert_eq!(
        gears,
        [
            [0.0, 0.0, 2.0, 0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        ]
    );
    assert!(s.model.actuators.iter().all(|a| a.gear == 1.0));
    // MuJoCo's adhesion: a fixed gain (its own, else its class's), no bias, on its body.
    let s = load(
        &scene(r#"<adhesion body="b" ctrlrange="0 1" gain="4"/>"#).replace(
            "<mujoco>",
            r#"<mujoco><default><adhesion gain="7"/></default>"#,
        ),
    );
    let a = &s.model.actuators[0];
    assert_eq!(a.target, Transmission::Body(1));
    assert_eq!(a.kind.gain_bias(), ([4.0, 0.0, 0.0], [0.0; 3]));
    let s = load(&scene(r#"<adhesion body="b" ctrlrange="0 1"/>"#).replace(
        "<mujoco>",
        r#"<mujoco><default><adhesion gain="7"/></default>"#,
    ));
    assert_eq!(s.model.actuators[0].kind.gain_bias().0, [7.0, 0.0, 0.0]);
    assert_eq!(s.model.actuators[0].ctrlrange, Some((0.0, 1.0)));
    for (act, says) in [
        (r#"<motor site="s" refsite="t"/>"#, "refsite"),
        (
            r#"<adhesion body="b" ctrlrange="-1 1"/>"#,
            "ctrlrange cannot be negative",
        ),
        (r#"<adhesion body="b"/>"#, "needs a ctrlrange"),
        (
            r#"<adhesion body="b" ctrlrange="0 1" gain="-2"/>"#,
            "must not be negative",
        ),
        (
            r#"<adhesion body="c" ctrlrange="0 1"/>"#,
            "no body named 'c'",
        ),
        (r#"<adhesion body="world" ctrlrange="0 1"/>"#, "world body"),
        (
            r#"<adhesion body="b" ctrlrange="0 1" gear="2"/>"#,
            "not an attribute of <adhesion>",
        ),
        (
            r#"<general body="b" site="s" ctrlrange="0 1"/>"#,
            "one thing",
        ),
        (r#"<motor site="nowhere"/>"#, "no site named 'nowhere'"),
        (r#"<motor site="drawn"/>"#, "fromto"),
        (
            r#"<motor site="s" gear="1 2 3 4 5 6 7"/>"#,
            "1 to 6 numbers",
        ),
        (r#"<motor site="s" joint="x"/>"#, "one site"),
    ] {
        let e = refuse(&scene(act));
        assert!(e.line == 12 && e.message.contains(says), "{act}: {e}");
    }
}

/// Found by a random differential review against MuJoCo: where a tendon's length does not
/// change with any joint at qpos0 (a string straight along a hanging arm, through its hinge's
/// axis), MuJoCo's effective inertia there is zero: a servo's dampratio then gives kv = 0, as
/// in MuJoCo (warned), and a limit, which MuJoCo holds as a hard constraint and SCM would size
/// by that inertia, is refused at the tendon's line instead of being left out silently.
#[test]
fn tendons_without_inertia_at_qpos0_give_no_damping_and_refuse_their_limit() {
    let scene = |range: &str, act: &str| {
        format!("<mujoco>\n  <worldbody>\n    <site name=\"anchor\" pos=\"0 0 -1\"/>\n    <body name=\"arm\">\n      <joint name=\"h\" axis=\"0 1 0\"/>\n      <geom type=\"capsule\" fromto=\"0 0 0 0 0 -0.5\" size=\"0.02\"/>\n      <site name=\"tip\" pos=\"0 0 -0.5\"/>\n    </body>\n  </worldbody>\n  <tendon>\n    <spatial name=\"leash\" {range}><site site=\"tip\"/><site site=\"anchor\"/></spatial>\n  </tendon>\n  <actuator>{act}</actuator>\n</mujoco>\n")
    };
    let s = load(&scene(
        "",
        r#"<position tendon="leash" kp="10" dampratio="1"/>"#,
    ));
    let scm::model::ActuatorKind::Position { kv, .. } = s.model.actuators[0].kind else {
        panic!("a position actuator")
    };
    assert_eq!(kv, 0.0);
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("dampratio gives kv = 0")),
        "{:?}",
        s.warnings
    );
    let e = refuse(&scene(r#"range="0 0.55""#, ""));
    assert!(
        e.line == 11 && e.element == "tendon" && e.message.contains("does not change"),
        "{e}"
    );
    // Written off that line (the arm turned 20°), the same tendon has an inertia and its limit
    // loads.
    let s = load(&scene(r#"range="0 0.55""#, "").replace(
        r#"<body name="arm">"#,
        r#"<body name="arm" euler="0 20 0">"#,
    ));
    assert!(s.model.spatial_tendons[0].law.limit.is_some());
}

/// `content_type` (MuJoCo's name of a mesh file's format, as three of MuJoCo Menagerie's robots
/// write it) is read where it agrees with the file's extension, by which SCM reads a mesh;
/// a disagreeing or unknown one is refused at the mesh's line.
#[test]
fn a_mesh_content_type_must_agree_with_its_extension() {
    let dir = scratch("content_type");
    let cube = "v 0 0 0\nv 0.1 0 0\nv 0.1 0.1 0\nv 0 0.1 0\nv 0 0 0.1\nv 0.1 0 0.1\nv 0.1 0.1 0.1\nv 0 0.1 0.1\nf 1 4 3\nf 1 3 2\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
    std::fs::write(dir.join("box.obj"), cube).unwrap();
    let main = dir.join("main.xml");
    let load_with = |ct: &str| {
        std::fs::write(&main, format!("<mujoco>\n  <asset>\n    <mesh name=\"box\" file=\"box.obj\" content_type=\"{ct}\"/>\n  </asset>\n  <worldbody>\n    <body pos=\"0 0 1\"><freejoint/><geom type=\"mesh\" mesh=\"box\"/></body>\n  </worldbody>\n</mujoco>\n")).unwrap();
        scm::scene::load(&main)
    };
    assert!(load_with("model/obj").is_ok());
    for (ct, says) in [
        ("model/stl", "extension is '.obj'"),
        ("text/plain", "SCM reads model/obj"),
    ] {
        let e = load_with(ct).expect_err("refused");
        assert!(e.line == 3 && e.message.contains(says), "{ct}: {e}");
    }
}

/// Every key must have MuJoCo's sizes, not only the one `scm_keyframe` picks: MuJoCo refuses a
/// file with any key of the wrong size (MuJoCo Menagerie's shadow hand `keyframes.xml`, a file
/// meant to be included, compiled alone in SCM and not in MuJoCo).
#[test]
fn every_key_has_mujocos_sizes() {
    let scene = |key: &str| {
        format!("<mujoco>\n  <worldbody>\n    <body pos=\"0 0 1\">\n      <joint name=\"h\" axis=\"0 1 0\"/>\n      <geom type=\"sphere\" size=\"0.1\"/>\n    </body>\n  </worldbody>\n  <keyframe>\n    <key name=\"good\" qpos=\"0.1\"/>\n    {key}\n  </keyframe>\n</mujoco>\n")
    };
    assert!(load_str(
        &scene(r#"<key name="also" qpos="0.2" qvel="1"/>"#),
        Path::new("m.xml")
    )
    .is_ok());
    // A short ctrl is padded with zeros, as MuJoCo pads it (a longer one is refused).
    let padded = scene(r#"<key name="short" ctrl="0.5"/>"#).replace(
        "</worldbody>",
        "</worldbody>\n  <actuator><motor joint=\"h\"/><motor joint=\"h\"/></actuator>\n  <custom><text name=\"scm_keyframe\" data=\"short\"/></custom>",
    );
    assert_eq!(load(&padded).model.ctrl0, [0.5, 0.0]);
    for (key, says) in [
        (
            r#"<key name="long" qpos="0 0"/>"#,
            "qpos: expected 1 numbers, got 2",
        ),
        (
            r#"<key name="moving" qvel="1 2"/>"#,
            "qvel: expected 1 numbers, got 2",
        ),
        (
            r#"<key name="pushed" ctrl="1"/>"#,
            "ctrl: expected 0 numbers, got 1",
        ),
        (
            r#"<key name="held" mpos="0 0 1"/>"#,
            "mpos: expected 0 numbers, got 3",
        ),
    ] {
        let e = refuse(&scene(key));
        assert!(e.line == 10 && e.message.contains(says), "{key}: {e}");
        let path = scratch("keys").join("m.xml");
        std::fs::write(&path, scene(key)).unwrap();
        let e = compile(&path).expect_err("compile refuses it too");
        assert!(e.message.contains(says), "{key}: {e}");
    }
}

/// A primitive geom with a mesh is fitted to the mesh, as MuJoCo's compiler fits it (its size
/// from the mesh, whatever size says). On a box mesh of half-extents 0.2 x 0.1 x 0.05 centred
/// at (1, 0, 0), worked out by hand: its equivalent inertia box is the box itself, its
/// principal moments largest first are about z, y, x, so a fitted box has half-sizes 0.05, 0.1,
/// 0.2 along z, y, x; a sphere the mean 0.35/3; a cylinder radius 0.075 (the mean of the first
/// two) and half-length 0.2 along x; a capsule the same radius and 0.2 - 0.075/2. Under
/// fitaabb the bounding box: a sphere 0.2, a capsule radius 0.1 and half-length 0.2 - 0.1.
/// fitscale scales all. Each sits at the mesh's centre, weighs as its own shape, and a written
/// size is listed as unused. (tests/python/test_mjcf_compiler.py compares with MuJoCo.)
#[test]
fn a_primitive_with_a_mesh_is_fitted_to_it_as_in_mujoco() {
    let dir = scratch("fit");
    let mut obj = String::new();
    for z in [-0.05, 0.05] {
        for y in [-0.1, 0.1] {
            for x in [0.8, 1.2] {
                obj += &format!("v {x} {y} {z}\n");
            }
        }
    }
    obj += "f 1 3 4\nf 1 4 2\nf 5 6 8\nf 5 8 7\nf 1 2 6\nf 1 6 5\nf 3 7 8\nf 3 8 4\nf 1 5 7\nf 1 7 3\nf 2 4 8\nf 2 8 6\n";
    std::fs::write(dir.join("slab.obj"), obj).unwrap();
    let scene = |compiler: &str, geom: &str| {
        format!("<mujoco>\n  {compiler}\n  <asset><mesh name=\"m\" file=\"slab.obj\"/></asset>\n  <worldbody>\n    <body name=\"b\">\n      <freejoint/>\n      {geom}\n    </body>\n  </worldbody>\n</mujoco>\n")
    };
    let fit = |compiler: &str, geom: &str| {
        let s = load_str(&scene(compiler, geom), &dir.join("m.xml"))
            .unwrap_or_else(|e| panic!("{geom}: {e}"));
        assert_eq!(s.geoms[0].fitted_to.as_deref(), Some("m"), "{geom}");
        assert!(
            s.geoms[0].mesh.is_none(),
            "{geom}: the fitted geom is a primitive"
        );
        s
    };
    let near = |a: f64, b: f64| (a - b).abs() < 1e-7; // the OBJ's coordinates are single precision
    let x = Vector3::x();
    // Along which of the mesh's axes the geom's z axis lies (either way).
    let along = |s: &Scene, axis: &Vector3<f64>| {
        (s.geoms[0].pose.rotation * Vector3::z()).dot(axis).abs() > 1.0 - 1e-9
    };
    use scm::geometry::Shape;
    let s = fit("", r#"<geom type="box" size="0.01 0.01 0.01" mesh="m"/>"#);
    match &s.geoms[0].shape {
        Some(Shape::Box { half }) => assert!(
            near(half.x, 0.05) && near(half.y, 0.1) && near(half.z, 0.2),
            "{half}"
        ),
        other => panic!("{other:?}"),
    }
    assert!(along(&s, &x));
    assert!((s.geoms[0].pose.translation.vector - Vector3::new(1.0, 0.0, 0.0)).norm() < 1e-7);
    assert!(
        (body(&s, "b").inertia.mass - 8.0).abs() < 1e-6 * 8.0,
        "the box weighs as a box: {}",
        body(&s, "b").inertia.mass
    );
    assert!(
        s.unused
            .iter()
            .any(|u| u.contains("size (MuJoCo sizes a geom fitted to a mesh")),
        "{:?}",
        s.unused
    );
    let s = fit("", r#"<geom mesh="m"/>"#); // MuJoCo's default type, a sphere
    assert!(matches!(s.geoms[0].shape, Some(Shape::Sphere { radius }) if near(radius, 0.35 / 3.0)));
    let s = fit("", r#"<geom type="cylinder" mesh="m"/>"#);
    assert!(
        matches!(s.geoms[0].shape, Some(Shape::Cylinder { radius, half_length }) if near(radius, 0.075) && near(half_length, 0.2))
    );
    assert!(along(&s, &x));
    let s = fit("", r#"<geom type="capsule" mesh="m" fitscale="2"/>"#);
    assert!(
        matches!(s.geoms[0].shape, Some(Shape::Capsule { radius, half_length }) if near(radius, 0.15) && near(half_length, 2.0 * (0.2 - 0.0375)))
    );
    let aabb = r#"<compiler fitaabb="true"/>"#;
    let s = fit(aabb, r#"<geom type="sphere" mesh="m"/>"#);
    assert!(matches!(s.geoms[0].shape, Some(Shape::Sphere { radius }) if near(radius, 0.2)));
    let s = fit(aabb, r#"<geom type="capsule" mesh="m"/>"#);
    assert!(
        matches!(s.geoms[0].shape, Some(Shape::Capsule { radius, half_length }) if near(radius, 0.1) && near(half_length, 0.1))
    );
    assert!(along(&s, &x));
    // What MuJoCo refuses, or what SCM cannot take, at the geom's line.
    for (compiler, geom, says) in [
        (
            "",
            r#"<geom type="capsule" fromto="0 0 0 0 0 1" mesh="m"/>"#,
            "fromto with mesh",
        ),
        (
            "",
            r#"<geom type="plane" mesh="m"/>"#,
            "MuJoCo fits only spheres",
        ),
        (
            "",
            r#"<geom type="box" mesh="nothing"/>"#,
            "no mesh asset named 'nothing'",
        ),
    ] {
        let e = load_str(&scene(compiler, geom), &dir.join("m.xml")).expect_err(geom);
        assert!(e.line == 7 && e.message.contains(says), "{geom}: {e}");
    }
    // A cube fitted as a capsule under fitaabb: radius 0.1, half-length 0.
    let cube = "v -0.1 -0.1 -0.1\nv 0.1 -0.1 -0.1\nv -0.1 0.1 -0.1\nv 0.1 0.1 -0.1\nv -0.1 -0.1 0.1\nv 0.1 -0.1 0.1\nv -0.1 0.1 0.1\nv 0.1 0.1 0.1\nf 1 3 4\nf 1 4 2\nf 5 6 8\nf 5 8 7\nf 1 2 6\nf 1 6 5\nf 3 7 8\nf 3 8 4\nf 1 5 7\nf 1 7 3\nf 2 4 8\nf 2 8 6\n";
    std::fs::write(dir.join("slab.obj"), cube).unwrap();
    let e = load_str(
        &scene(aabb, r#"<geom type="capsule" mesh="m"/>"#),
        &dir.join("m.xml"),
    )
    .expect_err("zero half-length");
    assert!(e.line == 7 && e.message.contains("not all positive"), "{e}");
}

/// A box fitted to a mesh whose inertia has two equal principal moments, with its axes off
/// the mesh's own (a square prism tilted in its file): the inertia frame is free to turn in
/// that plane, and so is the box, so SCM warns that MuJoCo's choice may differ; a cylinder
/// along the third axis is the same either way and is not warned about, nor is a sphere of
/// the inertia box; a sphere of the bounding box (fitaabb) is.
#[test]
fn a_box_fitted_to_a_mesh_of_two_equal_moments_is_warned_about() {
    let dir = scratch("fit-equal");
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let mut obj = String::new();
    for z in [-0.3, 0.3] {
        for y in [-0.1, 0.1] {
            for x in [-0.1, 0.1] {
                obj += &format!("v {x} {} {}\n", c * y - s * z, s * y + c * z);
            }
        }
    }
    obj += "f 1 3 4\nf 1 4 2\nf 5 6 8\nf 5 8 7\nf 1 2 6\nf 1 6 5\nf 3 7 8\nf 3 8 4\nf 1 5 7\nf 1 7 3\nf 2 4 8\nf 2 8 6\n";
    std::fs::write(dir.join("prism.obj"), obj).unwrap();
    for (kind, aabb, warned) in [
        ("box", false, true),
        ("cylinder", false, false),
        // Under fitaabb even a sphere's size (the largest half-extent) depends on the frame.
        ("sphere", true, true),
        ("sphere", false, false),
    ] {
        let compiler = if aabb {
            r#"<compiler fitaabb="true"/>"#
        } else {
            ""
        };
        let text = format!("<mujoco>\n  {compiler}<asset><mesh name=\"m\" file=\"prism.obj\"/></asset>\n  <worldbody>\n    <body>\n      <freejoint/>\n      <geom type=\"{kind}\" mesh=\"m\"/>\n    </body>\n  </worldbody>\n</mujoco>\n");
        let s = load_str(&text, &dir.join("m.xml")).unwrap();
        let w = s
            .warnings
            .iter()
            .any(|w| w.contains("two equal principal moments"));
        assert_eq!(w, warned, "{kind} {aabb}: {:?}", s.warnings);
    }
}

/// An `<equality><joint>` reads the class's `<equality>` defaults, not its `<joint>` ones
/// (armature there was refused as an attribute of the equality), and an `<inertial>` with a
/// mass and no inertia is MuJoCo's point mass (refused with the tree on a body that moves, as
/// MuJoCo refuses it).
#[test]
fn equality_joints_read_equality_defaults_and_an_inertial_may_be_a_point_mass() {
    let scene = |tip: &str| {
        format!(
            r#"<mujoco>
  <default>
    <joint armature="0.1" damping="1"/>
    <equality solref="0.01 1"/>
  </default>
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="a" axis="0 1 0"/>
      <geom type="capsule" size="0.02" fromto="0 0 0 0.2 0 0"/>
      <body name="tip" pos="0.2 0 0">
        {tip}
        <inertial pos="0.01 0 0" mass="0.5"/>
      </body>
    </body>
    <body name="b" pos="0 0 2">
      <joint name="b" axis="0 1 0"/>
      <geom type="capsule" size="0.02" fromto="0 0 0 0.2 0 0"/>
    </body>
  </worldbody>
  <equality>
    <joint joint1="a" joint2="b" polycoef="0 1 0 0 0"/>
  </equality>
</mujoco>
"#
        )
    };
    let s = load(&scene(""));
    assert!((joint(&s, "a").armature - 0.1).abs() < 1e-15);
    let tip = body(&s, "tip");
    assert_eq!(tip.inertia.mass, 0.5);
    assert_eq!(tip.inertia.rot, nalgebra::Matrix3::zeros());
    let e = refuse(&scene(r#"<joint name="spin" axis="1 0 0"/>"#));
    assert!(
        e.message.contains("no mass or no rotational inertia"),
        "{e}"
    );
}

/// An actuator computed by an engine plugin SCM does not build (anything but `mujoco.pid`, whose
/// PD law is a `<general>`: the Python dynamics test) is refused at its line naming the plugin;
/// the `<extension>` declaring it is listed as unused.
#[test]
fn a_plugin_actuator_is_refused_naming_the_plugin() {
    let text = r#"<mujoco>
  <extension><plugin plugin="acme.thruster"><instance name="jet"/></plugin></extension>
  <worldbody>
    <body><joint name="j"/><geom size="0.1"/></body>
  </worldbody>
  <actuator>
    <plugin name="a" plugin="acme.thruster" instance="jet" joint="j" actdim="2"/>
  </actuator>
</mujoco>
"#;
    let e = refuse(text);
    assert!(
        e.line == 7 && e.message.contains("engine plugin acme.thruster"),
        "{e}"
    );
    let s = load(&text.replace(
        r#"<plugin name="a" plugin="acme.thruster" instance="jet" joint="j" actdim="2"/>"#,
        r#"<motor joint="j"/>"#,
    ));
    assert!(
        s.unused
            .iter()
            .any(|u| u.contains("engine plugins, declared")),
        "{:?}",
        s.unused
    );
}

/// A height field without elevation data is flat when compiled (MuJoCo's zeros; dm_control's
/// quadruped fills its terrain at run time): SCM takes it as the plane of its surface, with
/// a warning naming its extent. A ball dropped on the raised, tilted field moves exactly as on
/// a plane geom in the same place, and rests on it (its centre a radius above it, less the
/// soft contact's sink, within 2 mm). A field whose elevation data does not fill its grid,
/// or without its size, is refused at its line.
#[test]
fn a_flat_height_field_is_the_plane_of_its_surface() {
    let dir = scratch("hfield");
    let text = r#"<mujoco>
  <option timestep="0.002"/>
  <asset>
    <hfield name="terrain" nrow="11" ncol="11" size="3 2 1 0.1"/>
  </asset>
  <worldbody>
    <geom type="hfield" hfield="terrain" pos="0 0 0.05" euler="5 0 0"/>
    <body name="ball" pos="0 0 0.3">
      <freejoint/>
      <geom type="sphere" size="0.05" friction="1"/>
    </body>
  </worldbody>
</mujoco>
"#;
    let path = dir.join("field.xml");
    std::fs::write(&path, text).unwrap();
    let mut sim = scm::sim::Simulation::from_file(&path).unwrap();
    let warnings = load(text).warnings;
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("height field 'terrain' is flat") && w.contains("6 x 4 m")),
        "{warnings:?}"
    );
    let plane = dir.join("plane.xml");
    std::fs::write(
        &plane,
        text.replace(
            r#"type="hfield" hfield="terrain""#,
            r#"type="plane" size="3 2 0.1""#,
        ),
    )
    .unwrap();
    let mut on_plane = scm::sim::Simulation::from_file(&plane).unwrap();
    for _ in 0..750 {
        sim.advance(0.002).unwrap();
        on_plane.advance(0.002).unwrap();
    }
    let q = &sim.data.current.state.q;
    assert_eq!(
        q, &on_plane.data.current.state.q,
        "the same motion as on the plane"
    );
    let centre = Vector3::new(q[0], q[1], q[2]);
    let normal = UnitQuaternion::from_euler_angles(5f64.to_radians(), 0.0, 0.0) * Vector3::z();
    let height = (centre - Vector3::new(0.0, 0.0, 0.05)).dot(&normal);
    assert!((height - 0.05).abs() < 2e-3, "{height}");
    for (hfield, says) in [
        (
            r#"<hfield name="terrain" nrow="11" ncol="11" size="3 2 1 0.1" elevation="1 2"/>"#,
            "elevation has 2 numbers where nrow × ncol is 121",
        ),
        (
            r#"<hfield name="terrain" nrow="11" ncol="11"/>"#,
            "four positive numbers",
        ),
    ] {
        let t = text.replace(
            r#"<hfield name="terrain" nrow="11" ncol="11" size="3 2 1 0.1"/>"#,
            hfield,
        );
        let e = refuse(&t);
        assert!(e.line == 4 && e.message.contains(says), "{hfield}: {e}");
    }
}

/// A mesh whose triangles face inward as written is refused under `inertia="exact"`, as
/// MuJoCo 4.0.0 refuses it ("mesh volume is negative"; measured with this tetrahedron both
/// ways round and mirrored by a negative scale, which MuJoCo does not count as inward); by the
/// default rule it loads, turned outward with a warning.
#[test]
fn an_inward_mesh_weighed_exactly_is_refused_as_in_mujoco() {
    let dir = scratch("inward");
    let v = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n";
    std::fs::write(
        dir.join("out.obj"),
        format!("{v}f 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n"),
    )
    .unwrap();
    std::fs::write(
        dir.join("in.obj"),
        format!("{v}f 1 2 3\nf 1 4 2\nf 2 4 3\nf 3 4 1\n"),
    )
    .unwrap();
    for (file, scale, inertia, refused) in [
        ("out.obj", "1 1 1", "exact", false),
        ("out.obj", "-1 1 1", "exact", false),
        ("in.obj", "1 1 1", "exact", true),
        ("in.obj", "-1 1 1", "exact", true),
        ("in.obj", "1 1 1", "legacy", false),
    ] {
        let text = format!("<mujoco>\n  <asset><mesh name=\"m\" file=\"{file}\" scale=\"{scale}\" inertia=\"{inertia}\"/></asset>\n  <worldbody><body><freejoint/><geom type=\"mesh\" mesh=\"m\"/></body></worldbody>\n</mujoco>\n");
        let r = load_str(&text, &dir.join("m.xml"));
        match (r, refused) {
            (Err(e), true) => assert!(e.line == 2 && e.message.contains("faces inward"), "{e}"),
            (Ok(s), false) => {
                let mass = s.model.tree.bodies[1].inertia.mass;
                assert!(
                    (mass - 1000.0 / 6.0).abs() < 1e-9,
                    "{file} {scale} {inertia}: {mass}"
                );
            }
            (Err(e), false) => panic!("{file} {scale} {inertia}: {e}"),
            (Ok(_), true) => panic!("{file} {scale} {inertia}: must be refused"),
        }
    }
}

/// An explicit `<pair>` joins its two geoms to their bodies' colliders, and no other: a visual
/// geom of the same body (`contype` and `conaffinity` 0) stays out, as MuJoCo collides only the
/// pair's geoms (Adroit's finger capsules are paired so, beside their visual meshes).
#[test]
fn an_explicit_pair_brings_its_own_geoms_into_the_colliders_and_no_visual_one() {
    let s = load(
        r#"<mujoco>
  <worldbody>
    <body name="a" pos="0 0 1"><freejoint/>
      <geom name="Ca" type="capsule" size="0.01 0.02" contype="1" conaffinity="0"/>
      <geom name="Va" type="box" size="0.1 0.1 0.1" contype="0" conaffinity="0" mass="0"/>
    </body>
    <body name="b" pos="0 0 1.5"><freejoint/>
      <geom name="Cb" type="capsule" size="0.01 0.02" contype="1" conaffinity="0"/>
    </body>
  </worldbody>
  <contact><pair geom1="Ca" geom2="Cb"/></contact>
</mujoco>"#,
    );
    assert_eq!(s.model.pairs.len(), 1);
    let a = s
        .model
        .tree
        .bodies
        .iter()
        .position(|b| b.name == "a")
        .unwrap();
    let Some(scm::collision::Collider::Aopc(cloud)) = &s.model.colliders[a] else {
        panic!("body a has no point cloud");
    };
    // Every point on the capsule (radius 1 cm, half-length 2 cm), none on the 20 cm box.
    for p in &cloud.points {
        let radial = (p.x * p.x + p.y * p.y).sqrt();
        assert!(radial <= 0.01 + 1e-9 && p.z.abs() <= 0.03 + 1e-9, "{p:?}");
    }
}

#[test]
fn a_pair_whose_inverse_weights_vanish_is_sized_for_the_mass_that_moves() {
    // A 0.2 kg paddle on a hinge through its own centre of mass: MuJoCo's translational
    // inverse weight of its centre is zero (robosuite's Jaco thumb: 9.9e-31 1/kg, an effective
    // mass of 3e32 kg and a stiffness of 8.6e36 N/m). Below MuJoCo's mjMINVAL the pair's law is
    // sized for the mass that moves with the paddle, 0.2 kg, as a free 0.2 kg body's would be.
    let paddle = |joint: &str| {
        format!(
            r#"<mujoco><worldbody>
              <geom name="floor" type="box" size="0.2 0.2 0.01"/>
              <body name="paddle" pos="0 0 0.05">{joint}
                <geom type="box" size="0.04 0.01 0.04" mass="0.2"/>
              </body>
            </worldbody></mujoco>"#
        )
    };
    let hinged = load(&paddle(r#"<joint type="hinge" axis="0 1 0"/>"#));
    let free = load(&paddle("<freejoint/>"));
    let k = |s: &Scene| {
        assert_eq!(s.model.pairs.len(), 1);
        s.model.pairs[0].stiffness.expect("a law from solref")
    };
    let (kh, kf) = (k(&hinged), k(&free));
    assert!(kh.is_finite() && kh > 0.0);
    assert!(
        (kh - kf).abs() <= 1e-12 * kf,
        "hinged {kh} N/m, free {kf} N/m"
    );
    // The law is MuJoCo's resting depth for 0.2 kg: k s⁺_ε3(r) = m g.
    let soft = scm::scene::contact::Softness::default();
    let r = soft.resting_depth(9.81, Some(free.model.timestep));
    let eps3 = free.model.contact.eps3;
    let held = kf * scm::scalar::softplus(r, eps3);
    assert!((held - 0.2 * 9.81).abs() < 1e-9, "holds {held} N");
}
