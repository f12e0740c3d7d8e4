//! A broken scene gets a clear error that names the file, the line and the element, and
//! never a panic.

use scm::scene::{load, load_str, SceneError};
use std::path::Path;

fn err(text: &str) -> SceneError {
    load_str(text, Path::new("broken.xml")).expect_err("the scene must be refused")
}

const GOOD: &str = r#"<mujoco model="m">
  <worldbody>
    <geom name="ground" type="plane" size="1 1 0.1"/>
    <body name="ball" pos="0 0 0.3">
      <freejoint/>
      <geom name="g" type="sphere" size="0.05" mass="1"/>
    </body>
  </worldbody>
</mujoco>"#;

#[test]
fn the_reference_scene_loads() {
    let s = load_str(GOOD, Path::new("good.xml")).unwrap();
    assert_eq!(s.model.tree.bodies.len(), 2);
    assert_eq!(s.model.pairs.len(), 1);
}

#[test]
fn each_kind_of_mistake_is_named_with_its_line() {
    // (replace this, with that, expected line, expected element, expected words)
    let cases: &[(&str, &str, usize, &str, &str)] = &[
        (
            r#"size="0.05" mass="1""#,
            r#"size="-0.05" mass="1""#,
            6,
            "geom",
            "positive",
        ),
        (
            r#"<freejoint/>"#,
            r#"<joint type="screw"/>"#,
            5,
            "joint",
            "screw",
        ),
        (r#"pos="0 0 0.3""#, r#"pos="0 0 x""#, 4, "body", "pos"),
        (r#"pos="0 0 0.3""#, r#"pos="0 0 nan""#, 4, "body", "finite"),
        (
            r#"<freejoint/>"#,
            r#"<tendon/>"#,
            5,
            "tendon",
            "unsupported",
        ),
        (
            r#"size="0.05" mass="1""#,
            r#"size="0.05" mass="1" fluidshape="box""#,
            6,
            "geom",
            "expected none or ellipsoid",
        ),
        (
            r#"<freejoint/>"#,
            r#"<freejoint/><replicate count="three"/>"#,
            5,
            "replicate",
            "whole number of copies",
        ),
        (
            r#"<freejoint/>"#,
            r#"<freejoint/><composite type="grid"/>"#,
            5,
            "composite",
            "rigid bodies",
        ),
        (
            r#"type="sphere""#,
            r#"type="capsule""#,
            6,
            "geom",
            "size needs 2",
        ),
        (r#"type="sphere""#, r#"type="blob""#, 6, "geom", "blob"),
        (
            r#"size="0.05" mass="1""#,
            r#"size="0.05" mass="1" adhesion="-1""#,
            6,
            "geom",
            "0 or more",
        ),
        (
            r#"size="0.05" mass="1""#,
            r#"size="0.05" mass="1" adhesion="1" gap="0.1 0.2""#,
            6,
            "geom",
            "expected one number",
        ),
        (
            r#"</worldbody>"#,
            "</worldbody>\n<contact><pair geom1=\"ground\" geom2=\"g\" adhesion=\"-2\"/></contact>",
            9,
            "pair",
            "must not be negative",
        ),
        (
            r#"<body name="ball" pos="0 0 0.3">"#,
            r#"<body name="ball" pos="0 0 0.3" quat="0 0 0 0">"#,
            4,
            "body",
            "zero",
        ),
    ];
    for (from, to, line, element, words) in cases {
        assert!(GOOD.contains(from), "case setup: {from}");
        let e = err(&GOOD.replacen(from, to, 1));
        let text = e.to_string();
        assert!(text.starts_with("broken.xml:"), "{text}");
        assert_eq!((e.line, e.element.as_str()), (*line, *element), "{text}");
        assert!(text.contains(words), "'{words}' not in: {text}");
    }
}

#[test]
fn malformed_xml_is_refused_with_a_line() {
    for (text, line) in [
        ("<mujoco>\n<worldbody>\n</mujoco>", 3),
        ("<mujoco>\n  <worldbody/>\n  <body", 3),
        ("", 1),
        ("<mujoco>\n</mujoco>\n<extra/>", 3),
    ] {
        let e = err(text);
        assert_eq!(e.element, "xml", "{e}");
        assert!(
            e.line >= 1 && e.line <= line,
            "line {} for {text:?}: {e}",
            e.line
        );
    }
    assert!(err("<robot/>").to_string().contains("<mujoco>"));
}

#[test]
fn bad_settings_are_refused() {
    let with = |custom: &str| {
        GOOD.replace(
            "<worldbody>",
            &format!("<custom>{custom}</custom>\n  <worldbody>"),
        )
    };
    for (custom, words) in [
        (r#"<numeric name="scm_eps1" data="-1"/>"#, "scm_eps1"),
        (
            r#"<numeric name="scm_stiffness" data="0"/>"#,
            "scm_stiffness",
        ),
        (
            r#"<numeric name="scm_stifness" data="10"/>"#,
            "unknown SCM setting",
        ),
        (
            r#"<text name="scm_integrator" data="leapfrog"/>"#,
            "leapfrog",
        ),
        (
            r#"<text name="scm_dissipation" data="viscous"/>"#,
            "viscous",
        ),
        (
            r#"<numeric name="scm_eps2" data="1 2"/>"#,
            "one finite number",
        ),
        (
            r#"<numeric name="scm_pair_threads" data="0"/>"#,
            "from 1 (serial) to 64",
        ),
        (
            r#"<numeric name="scm_pair_threads" data="1.5"/>"#,
            "whole number of threads",
        ),
        (
            r#"<numeric name="scm_pair_threads" data="65"/>"#,
            "scm_pair_threads",
        ),
        (
            r#"<numeric name="scm_prune_tolerance" data="0"/>"#,
            "from above 0 to 1e-3",
        ),
        (
            r#"<numeric name="scm_prune_tolerance" data="0.01"/>"#,
            "scm_prune_tolerance",
        ),
    ] {
        let e = err(&with(custom));
        assert!(
            ["numeric", "text"].contains(&e.element.as_str()) && e.line == 2,
            "{e}"
        );
        assert!(e.to_string().contains(words), "'{words}' not in {e}");
    }
    // The pairs' threads: as set, else the machine's default.
    let threads = |custom: &str| {
        load_str(&with(custom), Path::new("ok.xml"))
            .unwrap()
            .model
            .pair_threads
    };
    assert_eq!(
        threads(r#"<numeric name="scm_pair_threads" data="1"/>"#).threads,
        1
    );
    assert_eq!(
        threads(r#"<numeric name="scm_pair_threads" data="3"/>"#),
        scm::model::PairThreads {
            threads: 3,
            min_pairs: scm::model::PairThreads::MIN_PAIRS
        }
    );
    assert_eq!(threads(""), scm::model::PairThreads::default_for_machine());
    // The pruning tolerance: on every cloud as set, else the default.
    let tolerances = |custom: &str| -> Vec<Option<f64>> {
        let s = load_str(&with(custom), Path::new("ok.xml")).unwrap();
        s.model
            .colliders
            .iter()
            .flatten()
            .map(|c| c.tolerance())
            .collect()
    };
    assert_eq!(
        tolerances(r#"<numeric name="scm_prune_tolerance" data="1e-9"/>"#),
        [None, Some(1e-9)],
        "the floor has none, the ball's cloud the scene's"
    );
    assert_eq!(tolerances(""), [None, Some(scm::scalar::PRUNE_TOLERANCE)]);
    // Settings MuJoCo ignores and we do not own pass through.
    assert!(load_str(
        &with(r#"<numeric name="other_tool" data="1 2 3"/>"#),
        Path::new("ok.xml")
    )
    .is_ok());
}

#[test]
fn structural_mistakes_are_refused() {
    // A free joint below another body.
    let nested = GOOD.replace(
        "<freejoint/>",
        "<body name=\"inner\"><freejoint/><geom size=\"0.01\"/></body><joint type=\"slide\"/>",
    );
    assert!(
        err(&nested).to_string().contains("free joint"),
        "{}",
        err(&nested)
    );
    // Two bodies with the same name.
    let twice = GOOD.replace(
        "</body>",
        "</body>\n    <body name=\"ball\"><geom size=\"0.1\"/></body>",
    );
    assert!(err(&twice)
        .to_string()
        .contains("body name 'ball' is given twice"));
    // A moving body without mass.
    let massless = GOOD.replace(
        r#"<geom name="g" type="sphere" size="0.05" mass="1"/>"#,
        r#"<geom name="g" type="sphere" size="0.05" mass="0"/>"#,
    );
    assert!(err(&massless).to_string().contains("no mass"));
    // An actuator on a joint that does not exist.
    let act = GOOD.replace(
        "</worldbody>",
        "</worldbody>\n  <actuator><motor joint=\"nope\"/></actuator>",
    );
    let e = err(&act);
    assert_eq!((e.element.as_str(), e.line), ("motor", 9), "{e}");
    // A mesh with neither a file nor data, and one made by a plugin instance never declared.
    for (mesh, element, says) in [
        (
            r#"<mesh name="torus"><plugin instance="torus"/></mesh>"#,
            "plugin",
            "no plugin instance named 'torus' (declare it in <extension>)",
        ),
        (
            r#"<mesh name="nothing"/>"#,
            "mesh",
            r#"a mesh needs file="...""#,
        ),
    ] {
        let text = GOOD.replace(
            "<worldbody>",
            &format!(
                "<asset>{mesh}</asset>
  <worldbody>"
            ),
        );
        let e = err(&text);
        assert!(e.element == element && e.to_string().contains(says), "{e}");
    }
}

#[test]
fn a_wrapping_geom_is_refused_where_mujoco_refuses_it() {
    // A tendon wraps a sphere or a cylinder between two sites (MuJoCo's compiler refuses the
    // rest the same way).
    let scene = |path: &str| {
        format!(
            r#"<mujoco><worldbody>
  <geom name="g" size=".1" pos="0 0 1"/><geom name="b" type="box" size=".1 .1 .1" pos="0 0 2"/>
  <site name="a" pos="-1 0 1"/><site name="c" pos="1 0 1"/>
  <body><joint type="slide"/><geom size=".1"/></body>
</worldbody>
<tendon><spatial>{path}</spatial></tendon></mujoco>"#
        )
    };
    for (path, says) in [
        (
            r#"<site site="a"/><geom geom="b"/><site site="c"/>"#,
            "a tendon wraps only a sphere or a cylinder",
        ),
        (
            r#"<geom geom="g"/><site site="a"/><site site="c"/>"#,
            "must follow a site",
        ),
        (
            r#"<site site="a"/><site site="c"/><geom geom="g"/>"#,
            "must be followed by a site",
        ),
        (
            r#"<site site="a"/><geom geom="nope"/><site site="c"/>"#,
            "no geom named 'nope'",
        ),
        (
            r#"<site site="a"/><geom geom="g" sidesite="nope"/><site site="c"/>"#,
            "no site named 'nope'",
        ),
    ] {
        let e = err(&scene(path));
        assert!(
            e.element == "geom" && e.line == 6 && e.to_string().contains(says),
            "{e}"
        );
    }
    let fine = scene(r#"<site site="a"/><geom geom="g"/><site site="c"/>"#);
    let s = load_str(&fine, Path::new("wrap.xml")).unwrap();
    assert!(s.model.spatial_tendons[0].segments[0].wrap.is_some());
}

#[test]
fn a_missing_file_is_named() {
    let e = load(Path::new("/nonexistent/scene.xml")).unwrap_err();
    assert!(e.to_string().starts_with("/nonexistent/scene.xml:"), "{e}");
    assert!(e.to_string().contains("cannot read"), "{e}");
}
