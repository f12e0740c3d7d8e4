//! A mesh collides by its convex hull, as MuJoCo collides a mesh, unless the scene asks for its
//! surface (`scm_mesh_collision`; docs/mjcf.md, "Meshes"). Its mass stays the mesh's own.

use scm::collision::Collider;
use scm::scene::Scene;
use std::path::Path;

/// A ball of radius 5 mm held (gravity off) in the notch of `tests/fixtures/u_block.obj`: a U,
/// 6 × 4 × 3 cm, its notch 2 cm wide from z = 1 cm up to its top at 3 cm. The ball's centre
/// is at z = 1.8 cm: 3 mm above the notch's floor, 5 mm from its walls, inside the block's
/// convex hull (a 6 × 4 × 3 cm box) by 7 mm below its top. The block weighs as the solid
/// its surface encloses (`inertia="exact"`). `custom` goes in `<custom>`, `mesh_attrs` on the
/// `<mesh>`.
fn u_and_ball(custom: &str, mesh_attrs: &str) -> Result<Scene, scm::scene::SceneError> {
    let xml = format!(
        r#"<mujoco model="u_and_ball">
  <option gravity="0 0 0"/>
  <custom>{custom}</custom>
  <asset><mesh name="u" file="u_block.obj" inertia="exact" {mesh_attrs}/></asset>
  <worldbody>
    <body name="u"><freejoint/><geom name="u" type="mesh" mesh="u"/></body>
    <body name="ball" pos="0 0 0.018"><freejoint/><geom name="ball" type="sphere" size="0.005" mass="0.1"/></body>
  </worldbody>
</mujoco>"#
    );
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures");
    scm::scene::load_str(&xml, &dir.join("u_and_ball.xml"))
}

const SURFACE: &str = r#"<text name="scm_mesh_collision" data="surface"/>"#;

/// The pair's smooth distance (m) and the vertical force on the ball (N) at the scene's
/// initial pose.
fn distance_and_lift(s: &Scene) -> (f64, f64) {
    let m = &s.model;
    let kin = m.tree.kinematics(&m.tree.q0(), &vec![0.0; m.tree.nv]);
    let p = &m.pairs[0];
    let (ca, cb) = (
        m.colliders[p.a].as_ref().unwrap(),
        m.colliders[p.b].as_ref().unwrap(),
    );
    let c = scm::contact::pair_contact(
        ca,
        &kin.frames[p.a],
        cb,
        &kin.frames[p.b],
        &p.params(&m.contact),
    );
    let ball = m.tree.bodies.iter().position(|b| b.name == "ball").unwrap();
    let lift = if p.b == ball {
        c.on_b.force.z
    } else {
        c.on_a.force.z
    };
    (c.distance, lift)
}

/// The enclosed volume of body `name`'s cloud (m³).
fn cloud_volume(s: &Scene, name: &str) -> f64 {
    let b = s.model.tree.bodies.iter().position(|x| x.name == name);
    match s.model.colliders[b.unwrap()].as_ref().unwrap() {
        Collider::Aopc(c) => c.enclosed_volume(),
        _ => unreachable!("a mesh body has a point cloud"),
    }
}

#[test]
fn a_concave_mesh_collides_by_its_convex_hull_and_weighs_as_its_mesh() {
    let (hull, surface) = (
        u_and_ball("", "").unwrap(),
        u_and_ball(SURFACE, "").unwrap(),
    );
    let u = |s: &Scene| s.geoms.iter().find(|g| g.name == "u").unwrap().clone();
    assert!(u(&hull).by_hull && !u(&surface).by_hull);
    // The cloud encloses the hull, a 6 × 4 × 3 cm box (72 cm³), or the U (56 cm³): exact
    // for a polyhedron's quads.
    assert!((cloud_volume(&hull, "u") - 72e-6).abs() < 1e-9);
    assert!((cloud_volume(&surface, "u") - 56e-6).abs() < 1e-9);
    // Its mass is the mesh's own either way: 56 cm³ of water (MuJoCo: 0.0559999962 kg), not
    // the hull's 72 cm³, and the same inertia.
    let body = |s: &Scene| {
        let b = s.model.tree.bodies.iter().find(|b| b.name == "u");
        b.unwrap().inertia
    };
    // (Its vertices in single precision, as MuJoCo keeps them.)
    assert!(
        (body(&hull).mass - 0.056).abs() < 1e-8,
        "{}",
        body(&hull).mass
    );
    assert_eq!(body(&hull), body(&surface));
    // The ball in the notch is 7 mm inside the hull's top, and pushed up out of it with more
    // than its weight (0.98 N); by the surface it is 3 mm clear of the notch's floor, reads
    // 4.0 mm and feels 1.3 mN (measured; the soft far field of the notch's walls and floor),
    // under a hundredth of its weight.
    let (d, lift) = distance_and_lift(&hull);
    assert!(
        d < -0.005 && lift > 1.0,
        "by the hull: distance {d} m, lift {lift} N"
    );
    let (d, lift) = distance_and_lift(&surface);
    assert!(
        d > 0.002 && lift.abs() < 0.0098,
        "by the surface: distance {d} m, lift {lift} N"
    );
}

#[test]
fn how_a_mesh_collides_is_the_scenes_choice_and_a_wrong_one_is_named() {
    let e = u_and_ball(r#"<text name="scm_mesh_collision" data="hulls"/>"#, "").unwrap_err();
    assert_eq!(e.line, 3, "{e}");
    assert!(
        e.message.contains("'hulls'")
            && e.message.contains("'hull'")
            && e.message.contains("'surface'"),
        "{e}"
    );
    // `hull` is the default, said or not.
    let said = u_and_ball(r#"<text name="scm_mesh_collision" data="hull"/>"#, "").unwrap();
    assert_eq!(
        cloud_volume(&said, "u"),
        cloud_volume(&u_and_ball("", "").unwrap(), "u")
    );
}

#[test]
fn a_hull_mujoco_reduces_is_taken_whole_and_listed() {
    // MuJoCo reduces its hull to maxhullvert vertices; SCM collides by the full hull (which
    // holds MuJoCo's) and lists the attribute. The U's hull has 8 corners either way.
    let s = u_and_ball("", r#"maxhullvert="8""#).unwrap();
    assert!(
        s.unused
            .iter()
            .any(|u| u.contains("maxhullvert") && u.contains("full hull")),
        "{:?}",
        s.unused
    );
    assert!((cloud_volume(&s, "u") - 72e-6).abs() < 1e-9);
}

#[test]
fn a_geom_written_sdf_collides_by_its_meshs_surface_and_a_mesh_geom_by_the_hull() {
    // MuJoCo's sdflib gives a mesh file a distance field, which only a `type="sdf"` geom
    // collides by; a `type="mesh"` geom on the same mesh collides by the hull.
    let xml = r#"<mujoco model="sdflib">
  <option gravity="0 0 0"/>
  <extension><plugin plugin="mujoco.sdf.sdflib"><instance name="field"/></plugin></extension>
  <asset><mesh name="u" file="u_block.obj" inertia="exact"><plugin instance="field"/></mesh></asset>
  <worldbody>
    <body name="by_field"><freejoint/><geom name="f" type="sdf" mesh="u"><plugin instance="field"/></geom></body>
    <body name="by_mesh" pos="0.2 0 0"><freejoint/><geom name="m" type="mesh" mesh="u"/></body>
  </worldbody>
</mujoco>"#;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures");
    let s = scm::scene::load_str(xml, &dir.join("sdflib.xml")).unwrap_or_else(|e| panic!("{e}"));
    let by_hull = |name: &str| s.geoms.iter().find(|g| g.name == name).unwrap().by_hull;
    assert!(!by_hull("f") && by_hull("m"));
    assert!((cloud_volume(&s, "by_field") - 56e-6).abs() < 1e-9);
    assert!((cloud_volume(&s, "by_mesh") - 72e-6).abs() < 1e-9);
}
