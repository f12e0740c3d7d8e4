//! Spacing per geom (docs/geometry.md, "Spacing per geom"): with `scm_resolution` a large geom
//! is sampled coarsely away from its edges, a geom can have its own spacing, and a body resting
//! on a coarsely sampled one still comes to rest where it was put.

use nalgebra::Vector3;
use scm::collision::Collider;
use scm::integrator::{Integrator, State};
use scm::scene::{load_str, Scene};
use std::path::Path;

/// A 3 m × 2 m × 4 cm table top above a floor, a 5 cm cube just above it at (x, y), and
/// `settings` (`<custom>` entries, from line 4 on). The contact law is the scene's own, k =
/// 1e4 N/m (on the spacing's line, so that the settings' lines stay as the tests name them), as
/// the test was measured with: at the file's (MuJoCo's default `solref`, 2.6e3 N/m for the 0.1 kg
/// cube) the cube on the graded table still creeps 6e-5 m in the last 0.2 s of 1.6 s.
fn table(x: f64, y: f64, settings: &str) -> String {
    format!(
        r#"<mujoco model="table">
  <custom>
    <numeric name="scm_spacing" data="0.01"/><numeric name="scm_stiffness" data="1e4"/>
    {settings}
  </custom>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="table" pos="0 0 0.5">
      <geom name="top" type="box" size="1.5 1.0 0.02"/>
    </body>
    <body name="cube" pos="{x} {y} 0.5452">
      <freejoint/>
      <geom name="cube" type="box" size="0.025 0.025 0.025" mass="0.1"/>
    </body>
  </worldbody>
</mujoco>"#
    )
}

const GRADED: &str = r#"<numeric name="scm_resolution" data="16"/>"#;

fn load(xml: &str) -> Scene {
    load_str(xml, Path::new("table.xml")).unwrap_or_else(|e| panic!("{e}"))
}

fn cloud<'a>(scene: &'a Scene, body: &str) -> &'a scm::geometry::Aopc {
    let b = scene
        .model
        .tree
        .bodies
        .iter()
        .position(|x| x.name == body)
        .unwrap();
    match &scene.model.colliders[b] {
        Some(Collider::Aopc(s)) => s,
        _ => panic!("{body} has no AOPC"),
    }
}

/// The first free body's position after `t` s of semi-implicit Euler at 1 ms, and how far it
/// moved in the last 0.2 s.
fn run(scene: &Scene, t: f64) -> (Vector3<f64>, f64) {
    let m = &scene.model;
    let mut s = State::new(m.q0.clone(), m.v0.clone());
    let at = |s: &State<f64>| Vector3::new(s.q[0], s.q[1], s.q[2]);
    let steps = (t / 1e-3).round() as usize;
    let mut before = at(&s);
    for k in 0..steps {
        if k + 200 == steps {
            before = at(&s);
        }
        s = m
            .step_with(Integrator::SemiImplicitEuler, &s, &m.u0(), &m.contact, 1e-3)
            .unwrap();
    }
    (at(&s), (at(&s) - before).norm())
}

#[test]
fn a_large_table_is_graded_and_a_cube_comes_to_rest_on_it() {
    // At the table's middle, 1 cm from its long edge, and at its corner (the cube's side 1 cm
    // from both edges): the graded rows are fine there.
    for (x, y) in [(0.3, 0.2), (1.5 - 0.035, 0.2), (1.5 - 0.035, 1.0 - 0.035)] {
        let graded = load(&table(x, y, GRADED));
        let even = load(&table(x, y, ""));
        let (ng, ne) = (cloud(&graded, "table").len(), cloud(&even, "table").len());
        assert!(ng < 4_000 && ne == 124_000, "{ng} {ne} points");
        assert_eq!(
            cloud(&graded, "cube"),
            cloud(&even, "cube"),
            "a small geom is unchanged"
        );
        let ((a, va), (b, vb)) = (run(&graded, 1.6), run(&even, 1.6));
        let start = Vector3::new(x, y, 0.5452);
        println!(
            "cube at ({x}, {y}), {ng} graded / {ne} even points: moved {:.3e} / {:.3e} m \
             sideways, rests at {:.7} / {:.7} m, moved {va:.1e} / {vb:.1e} m in its last 0.2 s",
            (a - start).xy().norm(),
            (b - start).xy().norm(),
            a.z,
            b.z
        );
        // At rest on the top (centre 0.545 m up, less the contact's sink, 84 µm on the even
        // table), not sunk into it nor lifted off; where it was put, within 2 mm: the SCM
        // force averages over both bodies' deepest points, and the few graded points under
        // the cube are not symmetric about it, which the even table's 25 are (docs/geometry.md).
        assert!(va < 5e-5 && vb < 5e-6, "{va} {vb}");
        assert!(
            a.z < 0.545 && a.z > 0.545 - 2.0 * (0.545 - b.z),
            "{} {}",
            a.z,
            b.z
        );
        assert!((a - start).xy().norm() < 2e-3, "{a:?}");
        assert!((b - start).xy().norm() < 1e-5, "{b:?}");
    }
}

#[test]
fn a_geoms_own_spacing_overrides_the_scenes() {
    // Graded scene, the table at 1 cm by its own setting: the same cloud and the same motion
    // as with every geom at scm_spacing.
    let own = load(&table(
        0.3,
        0.2,
        &format!(r#"{GRADED}<numeric name="scm_spacing:top" data="0.01"/>"#),
    ));
    let even = load(&table(0.3, 0.2, ""));
    assert_eq!(cloud(&own, "table"), cloud(&even, "table"));
    assert_eq!(run(&own, 0.05), run(&even, 0.05));
    // A coarser spacing of its own: 5 cm everywhere.
    let coarse = load(&table(
        0.3,
        0.2,
        r#"<numeric name="scm_spacing:top" data="0.05"/>"#,
    ));
    assert_eq!(cloud(&coarse, "table").len(), 2 * (60 * 40 + 60 + 40));
    let top = coarse.geoms.iter().find(|g| g.name == "top").unwrap();
    assert_eq!(top.spacing, Some(scm::geometry::Spacing::uniform(0.05)));
}

#[test]
fn a_ground_box_too_large_for_scm_spacing_loads_graded() {
    // A 10 m × 10 m ground box (a common MJCF floor) at an even 1 cm would be 2·10⁶ points:
    // refused, with what to do; graded (scm_resolution 16, or a scene that sets no spacing) it
    // is a few thousand, and a ball rests on it as on a plane.
    let ball = |ground: &str, settings: &str| {
        format!(
            r#"<mujoco><custom>{settings}</custom><worldbody>{ground}
            <body name="ball" pos="0.3 0.2 0.0501"><freejoint/>
              <geom name="ball" type="sphere" size="0.05" mass="1"/></body>
            </worldbody></mujoco>"#
        )
    };
    let boxed = r#"<geom name="ground" type="box" pos="0 0 -0.1" size="5 5 0.1"/>"#;
    let err = load_str(&ball(boxed, SPACING), Path::new("ground.xml")).unwrap_err();
    assert!(
        err.message.contains("scm_resolution") && err.message.contains("'ground'"),
        "{err}"
    );
    // Graded by scm_resolution, and by the scene's defaults when it says nothing of the
    // ground; the ball on a plane sampled as on the box (the same settings), at 1 cm in both
    // (its own setting: sampled to its curvature by the defaults, 1.41 cm, it creeps 2.3 µm
    // on the plane, on the box 0.06 µm, and rests at the same height to 1e-11 m).
    let ball_at_1cm = r#"<numeric name="scm_spacing:ball" data="0.01"/>"#;
    for (settings, most) in [(GRADED, 10_000), (ball_at_1cm, 10_000)] {
        let graded = load(&ball(boxed, settings));
        let plane = load(&ball(r#"<geom type="plane" size="5 5 0.1"/>"#, settings));
        let n = cloud(&graded, "world").len();
        assert!(n < most, "{settings}: {n} points");
        let ((a, va), (b, vb)) = (run(&graded, 1.0), run(&plane, 1.0));
        println!("{settings}: ball on the graded box ({n} points) at {a:?} (moved {va:.1e} m in 0.2 s), on a plane at {b:?} ({vb:.1e} m)");
        // The box's top is the plane z = 0 (every top quad's plane), and its quad centres are
        // centimetres from the ball: the forces of a half-space but for the box's own points'
        // few terms, the same rest to a micrometre (the ball itself creeps 5 µm on either).
        assert!(va < 1e-5 && (a - b).norm() < 1e-6, "{a:?} vs {b:?}");
    }
}

#[test]
fn per_geom_spacings_that_name_nothing_useful_are_refused_or_reported() {
    let with = |entry: &str| load_str(&table(0.3, 0.2, entry), Path::new("table.xml"));
    for (entry, says) in [
        (
            r#"<numeric name="scm_spacing:desk" data="0.02"/>"#,
            "no geom is named 'desk'",
        ),
        (
            r#"<numeric name="scm_spacing:floor" data="0.02"/>"#,
            "is a plane",
        ),
        (
            r#"<numeric name="scm_spacing:top" data="0"/>"#,
            "must be positive",
        ),
        (
            r#"<numeric name="scm_spacing:top" data="-1"/>"#,
            "must be positive",
        ),
        (r#"<numeric name="scm_resolution" data="0"/>"#, "positive"),
        (
            r#"<numeric name="scm_spacing:top" data="0.02"/><numeric name="scm_spacing:top" data="0.03"/>"#,
            "numeric name 'scm_spacing:top' is given twice (first: <numeric> at table.xml:4)",
        ),
    ] {
        let err = with(entry).unwrap_err();
        println!("{err}");
        assert!(err.message.contains(says), "{entry}: {err}");
        assert_eq!(err.element, "numeric");
        assert_eq!(err.line, 4, "{entry}: the setting's line");
    }
    // A geom that collides with nothing: its spacing is unused, and said so.
    let xml = table(0.3, 0.2, r#"<numeric name="scm_spacing:top" data="0.02"/>"#).replace(
        r#"size="1.5 1.0 0.02"/>"#,
        r#"size="1.5 1.0 0.02" contype="0" conaffinity="0"/>"#,
    );
    let scene = load(&xml);
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("scm_spacing:top") && w.contains("unused")),
        "{:?}",
        scene.warnings
    );
}

/// The copies of one body (here a replicate's) are sampled once and get the same cloud; a copy
/// whose geom has a spacing of its own is sampled apart, at that spacing.
#[test]
fn copies_of_one_body_share_their_cloud_and_a_changed_copy_does_not() {
    let s = load_str(
        r#"<mujoco>
  <custom><numeric name="scm_spacing:bead-1" data="0.004"/></custom>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <replicate count="3" offset="0.2 0 0" sep="-">
      <body name="bead" pos="0 0 0.1" euler="0 0 30"><freejoint/><geom name="bead" type="capsule" size="0.02 0.03"/></body>
    </replicate>
  </worldbody>
</mujoco>"#,
        Path::new("beads.xml"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let cloud = |name: &str| {
        let b = s
            .model
            .tree
            .bodies
            .iter()
            .position(|b| b.name == name)
            .unwrap();
        match &s.model.colliders[b] {
            Some(Collider::Aopc(a)) => (a.points.clone(), a.normals.clone(), a.areas.clone()),
            _ => panic!("{name} has no cloud"),
        }
    };
    assert_eq!(cloud("bead-0"), cloud("bead-2"));
    let (fine, coarse) = (cloud("bead-1").0.len(), cloud("bead-0").0.len());
    assert!(
        fine > 4 * coarse,
        "{fine} points at 4 mm against {coarse} at 1 cm"
    );
}

/// The table scene's spacing setting, removed to leave the spacing to the scene's defaults.
const SPACING: &str = r#"<numeric name="scm_spacing" data="0.01"/>"#;

/// With neither scm_spacing nor scm_resolution, the table is graded at its size / 16 (3,664
/// points instead of 124,000). A cube put down anywhere but on the even grid's symmetric places
/// creeps sideways until the table's points under it are symmetric about it (SCM's force
/// averages over both bodies' deepest points; docs/geometry.md): measured over these eight
/// places, 1.4 to 4.4 mm on the even table, 1.5 µm to 2.0 mm on the graded one, whose few
/// points mostly miss the cube. The test holds the graded table to the even one's largest
/// creep and rest height.
#[test]
fn a_scene_that_says_nothing_samples_a_large_geom_graded() {
    let places = [
        (0.3033, 0.2047),
        (0.3071, 0.2011),
        (0.2113, -0.1252),
        (-0.4261, 0.3318),
        (0.0149, 0.0078),
        (0.6624, -0.5463),
        (-0.9037, 0.1981),
        (0.1234, 0.5678),
    ];
    let (mut worst_auto, mut worst_even) = (0.0f64, 0.0f64);
    for (x, y) in places {
        let auto = load(&table(x, y, "").replace(SPACING, ""));
        let even = load(&table(x, y, ""));
        let top = auto.geoms.iter().find(|g| g.name == "top").unwrap();
        assert_eq!(
            top.spacing.map(|h| (h.fine, h.coarse)),
            Some((0.01, Vector3::new(1.5 / 16.0, 1.0 / 16.0, 0.01)))
        );
        assert!(
            top.spacing_reason.starts_with("graded"),
            "{}",
            top.spacing_reason
        );
        let cube = auto.geoms.iter().find(|g| g.name == "cube").unwrap();
        assert_eq!(cube.spacing, Some(scm::geometry::Spacing::uniform(0.01)));
        assert_eq!(cloud(&auto, "cube"), cloud(&even, "cube"));
        let (na, ne) = (cloud(&auto, "table").len(), cloud(&even, "table").len());
        assert!(na < 4_000 && ne == 124_000, "{na} {ne} points");
        let ((a, _), (b, _)) = (run(&auto, 1.6), run(&even, 1.6));
        let start = Vector3::new(x, y, 0.5452);
        let (da, de) = ((a - start).xy().norm(), (b - start).xy().norm());
        println!(
            "cube at ({x}, {y}): crept {da:.3e} (graded) / {de:.3e} m (even), rests at {:.7} / {:.7} m",
            a.z, b.z
        );
        // Resting on the top, sunk no more than twice as deep as on the even table.
        assert!(
            a.z < 0.545 && a.z > 0.545 - 2.0 * (0.545 - b.z),
            "{} {}",
            a.z,
            b.z
        );
        worst_auto = worst_auto.max(da);
        worst_even = worst_even.max(de);
    }
    assert!(worst_auto <= worst_even, "{worst_auto} > {worst_even}");
}

/// `scm check` prints how many of a body's points each geom gives (issue 41, "the points per
/// geom and why"): the counts are of the union's points, the faces inside the body's other
/// geoms dropped, so they add up to the body's cloud, and a body's copies have the same.
#[test]
fn each_geom_knows_its_points_in_its_bodys_cloud() {
    let xml = r#"<mujoco><worldbody>
  <body name="t" pos="0 0 0.1"><freejoint/>
    <geom name="bar" type="box" size="0.1 0.025 0.02"/>
    <geom name="stem" type="box" size="0.025 0.08 0.02" pos="0 -0.1 0"/>
  </body>
  <body name="u" pos="1 0 0.1"><freejoint/>
    <geom name="bar2" type="box" size="0.1 0.025 0.02"/>
    <geom name="stem2" type="box" size="0.025 0.08 0.02" pos="0 -0.1 0"/>
  </body>
  <geom name="floor" type="plane" size="5 5 0.1"/>
</worldbody></mujoco>"#;
    let scene = load(xml);
    let points = |name: &str| {
        scene
            .geoms
            .iter()
            .find(|g| g.name == name)
            .unwrap()
            .points
            .unwrap()
    };
    let (bar, stem) = (points("bar"), points("stem"));
    assert_eq!(bar + stem, cloud(&scene, "t").len());
    assert_eq!(
        (points("bar2"), points("stem2")),
        (bar, stem),
        "a copy's counts"
    );
    // The stem's end inside the bar is dropped: fewer than the stem sampled alone.
    let alone = load(&xml.replace(r#"<geom name="bar" type="box" size="0.1 0.025 0.02"/>"#, ""));
    assert!(stem < cloud(&alone, "t").len(), "{stem}");
    let floor = scene.geoms.iter().find(|g| g.name == "floor").unwrap();
    assert_eq!(floor.points, None, "a plane is not sampled");
}

/// The largest `|SSDF - exact distance|` (m) of `shape`'s cloud `cloud` over 2,000 points of
/// its surface pushed out by `offset` (m) along the normal (a Fibonacci lattice of directions
/// from the shape's axis), at the scenes' default ε1 = 1e-5 m².
fn ssdf_error(shape: &scm::geometry::Shape, cloud: &scm::geometry::Aopc, offset: f64) -> f64 {
    use scm::geometry::Shape;
    let n = 2000;
    let (radius, half) = match shape {
        Shape::Sphere { radius } => (*radius, 0.0),
        Shape::Capsule {
            radius,
            half_length,
        } => (*radius, *half_length),
        _ => unreachable!("a smooth shape"),
    };
    (0..n)
        .map(|k| {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let phi = k as f64 * 2.399_963_229_728_653;
            let r = (1.0 - z * z).sqrt();
            let dir = Vector3::new(r * phi.cos(), r * phi.sin(), z);
            let p = Vector3::new(0.0, 0.0, z * half) + dir * (radius + offset);
            (scm::geometry::ssdf(cloud, &p, 1e-5) - shape.sdf(&p)).abs()
        })
        .fold(0.0, f64::max)
}

/// A file that says nothing samples a smooth geom (sphere, capsule, ellipsoid) at the spacing
/// whose sagitta on its radius is 0.5 mm (docs/geometry.md, "Spacing per geom"): larger than
/// 1 cm above a 2.5 cm radius, where that spacing's error is no larger than what 1 cm already
/// gives on a 2.5 cm radius, and a body resting on it moves by no more than that error. A box
/// and a cylinder (edges), and a small sphere, keep 1 cm.
#[test]
fn a_smooth_geom_is_sampled_to_its_curvature_when_the_file_says_nothing() {
    use scm::geometry::Shape;
    let scene = |settings: &str| {
        load(&format!(
            r#"<mujoco><custom>{settings}</custom><worldbody>
  <geom name="floor" type="plane" size="5 5 0.1"/>
  <body name="ball" pos="0 0 0.0895"><freejoint/><geom name="ball" type="sphere" size="0.09" mass="1"/></body>
  <body name="rod" pos="1 0 0.0595" euler="90 0 0"><freejoint/><geom name="rod" type="capsule" size="0.06 0.15" mass="1"/></body>
  <body name="bead" pos="2 0 0.0195"><freejoint/><geom name="bead" type="sphere" size="0.02" mass="0.1"/></body>
  <body name="brick" pos="3 0 0.1"><freejoint/><geom name="brick" type="box" size="0.1 0.1 0.1"/></body>
  <body name="drum" pos="4 0 0.1"><freejoint/><geom name="drum" type="cylinder" size="0.1 0.1"/></body>
</worldbody></mujoco>"#
        ))
    };
    let (auto, even) = (
        &scene(""),
        &scene(r#"<numeric name="scm_spacing" data="0.01"/>"#),
    );
    fn geom<'a>(s: &'a Scene, name: &str) -> &'a scm::scene::Geom {
        s.geoms.iter().find(|g| g.name == name).unwrap()
    }
    // √(8 ρ × 0.5 mm), floored to 0.1 mm: 1.89 cm on the 9 cm ball, 1.54 cm on the 6 cm rod.
    for (name, spacing) in [("ball", 0.0189), ("rod", 0.0154)] {
        let g = geom(auto, name);
        assert_eq!(g.spacing.map(|h| h.coarse.min()), Some(spacing), "{name}");
        assert!(
            g.spacing_reason.contains("0.5 mm sagitta"),
            "{}",
            g.spacing_reason
        );
    }
    for name in ["bead", "brick", "drum"] {
        assert_eq!(
            geom(auto, name).spacing,
            geom(even, name).spacing,
            "{name} keeps the scene's default"
        );
        assert_eq!(cloud(auto, name), cloud(even, name), "{name}");
    }
    // What 1 cm gives on a 2.5 cm radius: the error the default already accepts.
    let small = Shape::Sphere { radius: 0.025 };
    let accepted = ssdf_error(&small, &small.sample(0.01), 0.0);
    let mut fewer = Vec::new();
    for name in ["ball", "rod"] {
        let shape = geom(auto, name).shape.clone().unwrap();
        let (ca, ce) = (cloud(auto, name), cloud(even, name));
        let (ea, ee) = (ssdf_error(&shape, ca, 0.0), ssdf_error(&shape, ce, 0.0));
        let far = ssdf_error(&shape, ca, 3e-3);
        println!(
            "{name}: {} points (1 cm: {}), |SSDF - distance| at most {:.3} mm on the surface, {:.3} mm 3 mm off (1 cm: {:.3} mm; 1 cm on a 2.5 cm radius: {:.3} mm)",
            ca.len(),
            ce.len(),
            ea * 1e3,
            far * 1e3,
            ee * 1e3,
            accepted * 1e3
        );
        assert!(ea <= accepted && far <= accepted && ee < ea, "{name}");
        fewer.push(ca.len() as f64 / ce.len() as f64);
    }
    assert!(fewer.iter().all(|&r| r < 0.6), "{fewer:?}");
    // Resting on the floor (MuJoCo's default contact), 1 s of semi-implicit Euler at 1 ms:
    // each body's rest height moves by less than the sampling error that moved it.
    let rest = |s: &Scene| {
        let m = &s.model;
        let mut st = State::new(m.q0.clone(), m.v0.clone());
        for _ in 0..1000 {
            st = m
                .step_with(
                    Integrator::SemiImplicitEuler,
                    &st,
                    &m.u0(),
                    &m.contact,
                    1e-3,
                )
                .unwrap();
        }
        [st.q[2], st.q[9]]
    };
    let (ra, re) = (rest(auto), rest(even));
    for (k, name) in ["ball", "rod"].iter().enumerate() {
        println!(
            "{name} rests at {:.4} mm (1 cm: {:.4} mm) above its centre's touching height",
            (ra[k] - [0.09, 0.06][k]) * 1e3,
            (re[k] - [0.09, 0.06][k]) * 1e3
        );
        assert!((ra[k] - re[k]).abs() <= accepted, "{name}");
    }
}
