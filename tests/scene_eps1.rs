//! Each pair's ε1 from its clouds' spacing (docs/method.md, "ε1 follows the spacing").

use nalgebra::Vector3;
use scm::scene::Scene;
use std::path::Path;

/// Two boxes of half-size `h` (m), the second 0.4 `h` above the first's top, sampled at
/// `spacing` (m), with `extra` settings.
fn boxes(h: f64, spacing: f64, extra: &str) -> Scene {
    let xml = format!(
        r#"<mujoco model="boxes">
  <custom><numeric name="scm_spacing" data="{spacing}"/>{extra}</custom>
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="low"><freejoint/><geom name="lo" type="box" size="{h} {h} {h}" mass="1"/></body>
    <body name="high" pos="0.3 0.1 {z}"><freejoint/><geom name="hi" type="box" size="{h} {h} {h}" mass="1"/></body>
  </worldbody>
</mujoco>"#,
        z = 2.4 * h,
    );
    scm::scene::load_str(&xml, Path::new("boxes.xml")).unwrap()
}

/// The ε1 the pair's first side (the low box's points) reads the high box's planes with, as
/// its forces read it.
fn pair_eps1(scene: &Scene) -> f64 {
    let m = &scene.model;
    m.pairs[0].params(&m.contact).eps1_sides()[0]
}

#[test]
fn a_pair_finer_than_a_centimetre_reads_eps1_scaled_by_its_spacing_squared() {
    let default = scm::contact::ContactParams::default().eps1;
    for (spacing, scale) in [(0.01, 1.0), (0.02, 1.0), (0.005, 0.25), (0.0025, 0.0625)] {
        let s = boxes(0.04, spacing, "");
        assert_eq!(s.model.pairs[0].eps1_scale, [scale; 2], "spacing {spacing}");
        assert!((pair_eps1(&s) - default * scale).abs() <= 1e-18);
    }
    // A scene that sets scm_eps1 chose it: every pair reads it as it is.
    let own = boxes(0.04, 0.005, r#"<numeric name="scm_eps1" data="2e-5"/>"#);
    assert_eq!(own.model.pairs[0].eps1_scale, [1.0; 2]);
    assert_eq!(pair_eps1(&own), 2e-5);
    // A host's scm.eps1 scales the pair with it.
    let s = boxes(0.04, 0.005, "");
    let mut prm = s.model.contact;
    prm.eps1 = 4e-5;
    assert_eq!(s.model.pairs[0].params(&prm).eps1_sides(), [1e-5; 2]);
}

#[test]
fn each_cloud_is_read_with_its_own_eps1_whatever_it_meets() {
    // The high box sampled at 5 mm, the low one at 1 cm: the low box's points read the high
    // box's planes with a quarter of ε1, as a pair of two 5 mm boxes does, and the high box's
    // points read the low box's planes with ε1 as it is, as a pair of two 1 cm boxes does. A
    // cloud's SSDF is its own, not its partner's.
    let mixed = boxes(
        0.04,
        0.01,
        r#"<numeric name="scm_spacing:hi" data="0.005"/>"#,
    );
    let (fine, coarse) = (boxes(0.04, 0.005, ""), boxes(0.04, 0.01, ""));
    let sides = |s: &Scene| s.model.pairs[0].params(&s.model.contact).eps1_sides();
    assert_eq!(mixed.model.pairs[0].eps1_scale, [1.0, 0.25]);
    assert_eq!(sides(&mixed), [sides(&fine)[0], sides(&coarse)[1]]);
    assert_eq!(sides(&mixed), [2.5e-6, 1e-5]);
}

#[test]
fn a_scene_and_its_half_scale_copy_read_the_same_ssdf_halved() {
    // The paper's ratio held at every spacing: a cloud scaled by λ with ε1 scaled by λ² reads
    // the same soft distance times λ, at the same points scaled. At 1 cm the copy at half
    // scale (5 mm) used to read ε1 = 1e-5 m² on a cloud twice as fine: a blurrier box.
    let (big, small) = (boxes(0.04, 0.01, ""), boxes(0.02, 0.005, ""));
    let cloud = |s: &Scene| s.model.colliders[s.model.pairs[0].b].clone().unwrap();
    let (cb, cs) = (cloud(&big), cloud(&small));
    let (eb, es) = (pair_eps1(&big), pair_eps1(&small));
    assert_eq!(es, eb / 4.0);
    let mut worst: f64 = 0.0;
    for p in [
        Vector3::new(0.0, 0.0, 0.05),
        Vector3::new(0.045, 0.0, 0.0),
        Vector3::new(0.043, 0.043, 0.043),
        Vector3::new(0.05, 0.01, -0.03),
        Vector3::new(0.0, 0.0, 0.0),
        Vector3::new(0.039, 0.041, 0.0),
        Vector3::new(0.046, 0.037, 0.01),
    ] {
        let (db, ds) = (
            cb.signed_distance(&p, eb),
            cs.signed_distance(&(p * 0.5), es),
        );
        worst = worst.max((ds - 0.5 * db).abs());
    }
    assert!(worst <= 1e-12, "half-scale SSDF off by {worst:e} m");
    // With ε1 fixed instead, the copy is a blurrier box: beside an edge, where the two faces'
    // planes read differently, it reads the blend of both.
    let x = Vector3::new(0.046, 0.037, 0.01);
    let fixed = (cb.signed_distance(&x, eb) - 2.0 * cs.signed_distance(&(x * 0.5), eb)).abs();
    // (Measured 0.83 mm: the property is not a rounding accident.)
    assert!(fixed > 1e-4, "fixed ε1 reads {fixed:e} m apart");
}

/// The high box (its own spacing 5 mm) 1 mm above the low one's top (the scene's 1 cm),
/// offset so that the edges of both read in the band, with `extra` settings.
fn stacked(extra: &str) -> String {
    format!(
        r#"<mujoco model="stacked">
  <custom><numeric name="scm_spacing" data="0.01"/><numeric name="scm_spacing:hi" data="0.005"/>{extra}</custom>
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="low"><freejoint/><geom name="lo" type="box" size="0.04 0.04 0.04" mass="1"/></body>
    <body name="high" pos="0.012 0.005 0.081"><freejoint/><geom name="hi" type="box" size="0.04 0.04 0.04" mass="1"/></body>
  </worldbody>
</mujoco>"#
    )
}

#[test]
fn the_contact_points_and_the_distance_hessian_read_each_clouds_own_eps1() {
    use scm::collision::{contact_points, separation_field, SeparationDistribution};
    let xml = stacked(r#"<numeric name="scm_contact_points" data="2"/>"#);
    let scene = scm::scene::load_str(&xml, Path::new("stacked.xml")).unwrap();
    let m = scene.model.clone();
    let pair = &m.pairs[0];
    assert_eq!(pair.eps1_scale, [1.0, 0.25]);
    let (e1, e2) = (m.contact.eps1, m.contact.eps2);
    let kin = m.tree.kinematics(&m.q0, &m.v0);
    let (ca, cb) = (
        m.colliders[pair.a].as_ref().unwrap(),
        m.colliders[pair.b].as_ref().unwrap(),
    );
    let (fa, fb) = (&kin.frames[pair.a], &kin.frames[pair.b]);
    // The soft contact points of the simulation's outputs: each side's own ε1, not the
    // parameter read for both (which gives other points: the test tells the two apart).
    let points = |eps1: [f64; 2]| contact_points(ca, fa, cb, fb, eps1, e2, 2);
    let own = points(pair.eps1_sides(e1));
    assert_ne!(own, points([e1; 2]));
    let mut sim = scm::sim::Simulation::new(scene, &xml);
    assert_eq!(sim.contact_points()[0], own);
    // The distance's value and its derivative with respect to ε1 (the gradient's entry after
    // q), against the field read with each side's ε1 and central differences of it.
    let d = |eps1: f64| {
        let field = separation_field(ca, fa, cb, fb, pair.eps1_sides(eps1));
        SeparationDistribution::new(&field, e2).distance
    };
    let point = scm::derivatives::Point::start(&m);
    let (value, grad, _) =
        scm::derivatives::distance_hessian(&m, 0, &point, scm::derivatives::Coordinates::Embedded)
            .unwrap();
    assert!((value - d(e1)).abs() <= 1e-15, "{value} against {}", d(e1));
    let field = separation_field(ca, fa, cb, fb, [e1; 2]);
    let both = SeparationDistribution::new(&field, e2).distance;
    assert!((value - both).abs() > 1e-9, "{value} against {both}");
    let h = 1e-3 * e1;
    let fd = (d(e1 + h) - d(e1 - h)) / (2.0 * h);
    let exact = grad[m.tree.nq];
    assert!(
        (exact - fd).abs() <= 1e-6 * fd.abs(),
        "∂D/∂ε1 {exact} against {fd}"
    );
}

#[test]
fn the_smoothing_warning_reads_each_bodys_own_eps1() {
    // Boxes 8 cm wide (13.9 cm across) sampled at 5 mm: their planes are read with a quarter
    // of scm.eps1. At 0.03 m² the parameter's square root (17 cm) is larger than the boxes,
    // but what they read (8.7 cm) is not: no warning. At 0.1 m² they read 15.8 cm: a warning
    // that says so.
    use scm::contact::Param;
    use scm::fmi::contract::FmiModel;
    let xml = "boxes.xml";
    let mut sim = scm::sim::Simulation::new(boxes(0.04, 0.005, ""), xml);
    let warned = |sim: &mut scm::sim::Simulation, eps1: f64| {
        sim.take_messages();
        sim.set_param(Param::Eps1, eps1).unwrap();
        sim.take_messages()
            .into_iter()
            .map(|m| m.text)
            .find(|t| t.contains("no longer contact"))
    };
    assert_eq!(warned(&mut sim, 0.03), None);
    let text = warned(&mut sim, 0.1).expect("a warning at 0.1 m²");
    assert!(text.contains("read times 0.2500"), "{text}");
}
