//! `<attach>` (MuJoCo's composition of models): what travels into an FMU, and what is refused
//! with its file and line. The compiled model's agreement with MuJoCo's is the Python
//! compiler test's (`test_attached_models_compile_as_mujoco_attaches_them`).

use scm::scene::{load, Scene, SceneError};
use std::path::{Path, PathBuf};

/// A folder of its own under the system's temporary folder.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("scm-attach-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A closed cube mesh of half-size `h`, as OBJ text.
fn cube_obj(h: f64) -> String {
    let mut s = String::new();
    for x in [-h, h] {
        for y in [-h, h] {
            for z in [-h, h] {
                s += &format!("v {x} {y} {z}\n");
            }
        }
    }
    for [a, b, c, d] in [
        [1, 2, 4, 3],
        [5, 7, 8, 6],
        [1, 5, 6, 2],
        [3, 4, 8, 7],
        [1, 3, 7, 5],
        [2, 6, 8, 4],
    ] {
        s += &format!("f {a} {b} {c}\nf {a} {c} {d}\n");
    }
    s
}

const CHILD: &str = r#"<mujoco model="gripper">
  <compiler meshdir="parts"/>
  <default><geom size="0.02"/></default>
  <asset><mesh name="palm" file="palm.obj"/></asset>
  <worldbody>
    <body name="palm" pos="0 0 0.1">
      <geom type="mesh" mesh="palm"/>
      <body name="finger" pos="0 0 0.05"><joint name="slide" type="slide" axis="1 0 0"/><geom/></body>
    </body>
  </worldbody>
  <actuator><motor name="squeeze" joint="slide"/></actuator>
</mujoco>
"#;

const PARENT: &str = r#"<mujoco>
  <asset><model name="gripper" file="models/gripper.xml"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="arm" pos="0 0 0.5"><freejoint/><geom size="0.05"/>
      <attach model="gripper" body="palm" prefix="left_"/>
    </body>
  </worldbody>
</mujoco>
"#;

/// A scene attaching a model whose mesh lies under the model's own `meshdir`.
fn write_scene(dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir.join("models/parts")).unwrap();
    std::fs::write(dir.join("models/gripper.xml"), CHILD).unwrap();
    std::fs::write(dir.join("models/parts/palm.obj"), cube_obj(0.03)).unwrap();
    let main = dir.join("scene.xml");
    std::fs::write(&main, PARENT).unwrap();
    main
}

/// Each geom's name, body, shape and pose (a mesh by its vertices and triangles, not by the
/// path it was read from).
fn shape(s: &Scene) -> Vec<(String, usize, String)> {
    s.geoms
        .iter()
        .map(|g| {
            let mut shown = format!("{:?} {:?}", g.shape, g.pose);
            if let Some(at) = shown.find("file: \"") {
                let end = at + 7 + shown[at + 7..].find('"').unwrap();
                shown.replace_range(at..=end, "");
            }
            (g.name.clone(), g.body, shown)
        })
        .collect()
}

#[test]
fn an_attached_model_and_its_mesh_travel_in_the_fmu() {
    let dir = scratch("pack");
    let main = write_scene(&dir);
    let s = load(&main).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = s.geoms.iter().map(|g| g.name.as_str()).collect();
    assert!(names.contains(&"floor"), "{names:?}");
    assert!(
        s.model.tree.joints.iter().any(|j| j.name == "left_slide"),
        "the attached joint is prefixed"
    );
    assert!(s.model.actuators.iter().any(|a| a.name == "left_squeeze"));
    // The model's file travels as an include does; its mesh under meshes/, by the path from
    // this scene's folder.
    let d = scm::pack::describe(&main).unwrap_or_else(|e| panic!("{e}"));
    let packed: Vec<&str> = d.resources.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        packed,
        ["meshes/models/parts/palm.obj", "models/gripper.xml"]
    );
    let fmu = dir.join("unpacked/resources");
    std::fs::create_dir_all(&fmu).unwrap();
    std::fs::write(fmu.join("scene.xml"), &d.scene_text).unwrap();
    for (name, bytes) in &d.resources {
        let to = fmu.join(name);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::write(to, bytes).unwrap();
    }
    // Loaded from the FMU alone (the originals gone), the same geoms in the same places.
    std::fs::remove_dir_all(dir.join("models")).unwrap();
    let again = load(&fmu.join("scene.xml")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(shape(&again), shape(&s));
    std::fs::remove_dir_all(&dir).ok();
}

/// The refusal of `parent` (with the child model of [`CHILD`], changed by `child`).
fn refused(name: &str, parent: &str, child: impl Fn(&str) -> String) -> SceneError {
    let dir = scratch(name);
    let main = write_scene(&dir);
    std::fs::write(dir.join("models/gripper.xml"), child(CHILD)).unwrap();
    std::fs::write(&main, parent).unwrap();
    let e = load(&main).expect_err("must be refused");
    std::fs::remove_dir_all(&dir).ok();
    e
}

#[test]
fn attach_mistakes_are_refused_with_their_line_and_what_to_do() {
    let same = |c: &str| c.to_string();
    let with =
        |attach: &str| PARENT.replace(r#"model="gripper" body="palm" prefix="left_""#, attach);
    for (attach, wanted) in [
        (
            r#"model="gripper" body="palm""#,
            "prefix=\"...\" is required",
        ),
        (
            r#"model="hand" body="palm" prefix="l_""#,
            "no <asset><model> named 'hand' (models: gripper)",
        ),
        (
            r#"model="gripper" body="thumb" prefix="l_""#,
            "has no body named 'thumb'",
        ),
        (
            r#"model="gripper" frame="f" prefix="l_""#,
            "attach the body it holds",
        ),
        // Without a model: a part of this same file, which has no body 'palm'.
        (
            r#"body="palm" prefix="l_""#,
            "this model has no body named 'palm'",
        ),
        (
            r#"prefix="l_""#,
            "needs one of body=\"...\" or frame=\"...\"",
        ),
        (
            r#"model="gripper" body="palm" prefix="l_" scale="2""#,
            "attribute 'scale'",
        ),
    ] {
        let e = refused("mistake", &with(attach), same);
        assert_eq!((e.line, e.element.as_str()), (6, "attach"), "{attach}: {e}");
        assert!(e.message.contains(wanted), "{attach}: {e}");
    }
    // The child compiled under other settings than the scene.
    let e = refused("settings", PARENT, |c| {
        c.replace(
            r#"<compiler meshdir="parts"/>"#,
            r#"<compiler meshdir="parts" autolimits="false"/>"#,
        )
    });
    assert!(
        e.message.contains("autolimits: false there, true here"),
        "{e}"
    );
    // A mistake inside the child names the child's file and line.
    let e = refused("inside", PARENT, |c| {
        c.replace("<geom/>", r#"<geom type="blob"/>"#)
    });
    assert!(e.file.ends_with("models/gripper.xml") && e.line == 8, "{e}");
    // A model attaching itself is refused, not followed for ever.
    let e = refused("cycle", PARENT, |c| {
        c.replace(
            "<asset>",
            r#"<asset><model name="again" file="gripper.xml"/>"#,
        )
        .replace(
            r#"<geom/></body>"#,
            r#"<geom/><attach model="again" body="palm" prefix="x_"/></body>"#,
        )
    });
    assert!(e.message.contains("attaches itself"), "{e}");
    // A missing model file is named.
    let e = refused(
        "missing",
        &PARENT.replace("models/gripper.xml", "models/none.xml"),
        same,
    );
    assert!(e.message.contains("none.xml") && e.line == 2, "{e}");
}
