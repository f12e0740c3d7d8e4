//! The floor under a cloud's planes (docs/method.md, departure 3): a mesh in patches bounded by
//! its own surface, not by its patches' square faces, and the tight floor, which no plane reads
//! below: a mesh's cloud's by default, every cloud's where a scene's `scm_floor` asks.

use crate::common::Lcg;
use nalgebra::{Matrix3, Vector3};
use scm::collision::{Collider, Frame};
use scm::contact::{pair_contact, pair_pressing, ContactParams};
use scm::geometry::polytope::FloorKind;
use scm::geometry::{Aopc, Shape, TriMesh};
use std::path::Path;

/// A 48-sided prism 9 cm across and 10 cm tall, its base at z = 0, sampled in 1 cm patches.
fn prism() -> (TriMesh, Aopc) {
    let (n, r) = (48u32, 0.045);
    let mut vertices = Vec::new();
    for z in [0.0, 0.1] {
        for i in 0..n {
            let a = std::f64::consts::TAU * f64::from(i) / f64::from(n);
            vertices.push(Vector3::new(r * a.cos(), r * a.sin(), z));
        }
    }
    vertices.extend([Vector3::zeros(), Vector3::new(0.0, 0.0, 0.1)]);
    let mut triangles = Vec::new();
    for i in 0..n {
        let j = (i + 1) % n;
        triangles.extend([
            [i, j, n + j],
            [i, n + j, n + i],
            [2 * n, j, i],
            [2 * n + 1, n + i, n + j],
        ]);
    }
    let (mesh, _) = TriMesh::new("prism", vertices, triangles).expect("a closed prism");
    let cloud = mesh.sample_patches(0.01);
    (mesh, cloud)
}

fn params(eps3: f64) -> ContactParams<f64> {
    ContactParams {
        eps3,
        stiffness: 5e4,
        friction: 1.0,
        ..Default::default()
    }
}

fn at(z: f64) -> Frame<f64> {
    Frame {
        rotation: Matrix3::identity(),
        origin: Vector3::new(0.0, 0.0, z),
        linvel: Vector3::zeros(),
        angvel: Vector3::zeros(),
    }
}

/// The patches' square faces reach up to 6 mm past the prism's edges (the squares' corners at
/// a patch's reach, in its plane); the polytope is the surface's (its points and the mesh's
/// vertices), so just below the base the floor sits one margin below the 0.2 mm the base plane
/// proves, and under the tight floor at it, less the smoothing's `T ln 26`. Either floor stays
/// below the prism's exact signed distance everywhere around it.
#[test]
fn a_mesh_in_patches_is_floored_by_its_own_surface() {
    let (mesh, cloud) = prism();
    let below_the_rim = Vector3::new(0.0412, 0.0, -2e-4);
    for kind in [FloorKind::Margin, FloorKind::Tight] {
        let mut c = cloud.clone();
        c.set_floor(kind);
        let p = c.bvh().polytope.as_ref().expect("a quad mesh");
        let (r, margin) = (p.cover(), if kind == FloorKind::Tight { 0.0 } else { 1.5 });
        let lower = p.floor(&below_the_rim).lower();
        let proven = 2e-4 - margin * r - r / 80.0 * 26f64.ln();
        // With the squares' corners in the polytope it stood 4.9 mm lower (measured: -5.16 mm at
        // no margin).
        assert!(lower >= proven - 1e-11, "{kind:?}: {lower} below {proven}");
        let mut rng = Lcg(5);
        for _ in 0..2000 {
            let x = Vector3::new(
                rng.range(-0.07, 0.07),
                rng.range(-0.07, 0.07),
                rng.range(-0.03, 0.13),
            );
            let (b, _) = p.floor(&x).value();
            assert!(
                b <= mesh.sdf(&x) + 1e-12,
                "{kind:?} at {x:?}: {b} above {}",
                mesh.sdf(&x)
            );
        }
    }
}

/// A cloud joined to a mesh in patches keeps its own faces' corners where the joined cloud's
/// polytope takes its surface from, its `reach`, whichever is joined to which, and in a body of
/// a mesh and a box: a box reaching 1.5 cm past the prism's side would otherwise be cut off at
/// its face centres, and the tight floor would stand above the box near its corners.
#[test]
fn a_cloud_joined_to_a_mesh_in_patches_keeps_its_corners_in_the_reach() {
    let (_, prism) = prism();
    let half = Vector3::new(0.06, 0.02, 0.01);
    let boxed = Shape::Box { half }.sample(0.01);
    let (mut box_first, mut prism_first) = (boxed.clone(), prism.clone());
    box_first.extend(&prism);
    prism_first.extend(&boxed);
    for mut joined in [box_first, prism_first] {
        assert!(boxed.vertices.iter().all(|v| joined.reach.contains(v)));
        joined.set_floor(FloorKind::Tight);
        let p = joined.bvh().polytope.as_ref().expect("quads");
        for corner in boxed.vertices.iter().filter(|v| v.abs() == half) {
            let (b, _) = p.floor(corner).value();
            assert!(b <= 1e-12, "{corner:?}: {b}");
        }
    }
    // A body of the U-shaped mesh of the fixtures (in patches) and a box beside it: by default
    // the body's one cloud has the mesh's tight floor, its box's part included.
    let xml = r#"<mujoco><asset><mesh name="u" file="u_block.obj"/></asset><worldbody>
      <geom type="plane" size="1 1 0.1"/>
      <body name="b" pos="0 0 0.1"><freejoint/><geom type="mesh" mesh="u"/><geom type="box" pos="0.2 0 0" size="0.03 0.02 0.01"/></body>
      </worldbody></mujoco>"#;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures");
    let model = scm::scene::load_str(xml, &dir.join("joined.xml"))
        .unwrap()
        .model;
    let Some(Collider::Aopc(cloud)) = &model.colliders[1] else {
        panic!("a cloud")
    };
    assert!(!cloud.reach.is_empty() && cloud.floor() == FloorKind::Tight);
    let p = cloud.bvh().polytope.as_ref().expect("quads");
    for corner in [
        Vector3::new(0.23, 0.02, 0.01),
        Vector3::new(0.23, -0.02, -0.01),
    ] {
        let (b, _) = p.floor(&corner).value();
        assert!(b <= 1e-12, "{corner:?}: {b}");
    }
}

/// Under the tight floor a plane's floor is the sampled surface's: where a curved shape sits
/// off the polytope's 26 directions, the surface bulges past its samples by up to a sagitta,
/// `r²/(2R)` for cover radius `r` and radius of curvature `R`, and a plane's floor near it may
/// stand that much above the exact distance. Measured on a sphere, a capsule and a cylinder
/// turned 0.5 rad: at most 61, 38 and 98 µm at 1 cm spacing (bounds 570, 670, 540 µm), 7 µm at
/// 5 mm; the cloud's floor (its temperature four times the planes') stays below the surface.
#[test]
fn under_the_tight_floor_a_turned_curved_shape_reads_at_most_a_sagitta_above_its_surface() {
    use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion};
    let turn = UnitQuaternion::from_scaled_axis(Vector3::new(0.35, 0.35, 0.1));
    let pose = Isometry3::from_parts(Translation3::identity(), turn);
    let shapes = [
        (Shape::Sphere { radius: 0.05 }, 0.05),
        (
            Shape::Capsule {
                radius: 0.03,
                half_length: 0.06,
            },
            0.03,
        ),
        (
            Shape::Cylinder {
                radius: 0.045,
                half_length: 0.05,
            },
            0.045,
        ),
    ];
    for ((shape, curvature), spacing) in shapes.iter().flat_map(|s| [(s, 0.01), (s, 0.005)]) {
        let mut c = shape.sample(spacing).transformed(&pose);
        c.set_floor(FloorKind::Tight);
        let p = c.bvh().polytope.as_ref().expect("quads");
        let sagitta = p.cover() * p.cover() / (2.0 * curvature);
        let mut rng = Lcg(3);
        let mut worst = f64::NEG_INFINITY;
        for _ in 0..20000 {
            let x = Vector3::new(
                rng.range(-0.12, 0.12),
                rng.range(-0.12, 0.12),
                rng.range(-0.12, 0.12),
            );
            let sdf = shape.sdf(&(pose.inverse() * Point3::from(x)).coords);
            if sdf.abs() < 0.01 {
                let mut f = p.floor(&x);
                let (raised, _, _) = f.raise_plane(-1.0, 0);
                worst = worst.max(raised - sdf);
                let (cloud, _) = f.value();
                assert!(
                    cloud <= sdf,
                    "{shape:?} at {spacing}, {x:?}: the cloud's floor {cloud} above {sdf}"
                );
            }
        }
        assert!(
            worst <= sagitta,
            "{shape:?} at {spacing}: {worst} above, sagitta {sagitta}"
        );
    }
}

/// Two prisms stacked 0.2 mm apart, axis on axis (docs/mjcf.md, "What pushes, in a small
/// scene"): under the default floor their point forces add up to newtons, the planes round each
/// edge reading the other's points millimetres inside; under the tight floor, at a small
/// `ε3`, they push next to nothing: measured 12.1 N against 9.6e-5 N (k = 5e4 N/m).
#[test]
fn stacked_prisms_push_nothing_across_their_gap_under_the_tight_floor() {
    let (_, cloud) = prism();
    let pressing = |kind| {
        let mut c = cloud.clone();
        c.set_floor(kind);
        let c = Collider::Aopc(c);
        let prm = params(2e-5);
        let net = pair_contact(&c, &at(0.0), &c, &at(0.1002), &prm)
            .on_a
            .force
            .norm();
        (net, pair_pressing(&c, &at(0.0), &c, &at(0.1002), &prm))
    };
    let ((net_m, margin), (net_t, tight)) =
        (pressing(FloorKind::Margin), pressing(FloorKind::Tight));
    println!(
        "margin: net {net_m:e}, pressing {margin:e}; tight: net {net_t:e}, pressing {tight:e}"
    );
    assert!(
        margin > 1.0 && tight < 1e-3 && net_t <= tight,
        "{margin} {tight}"
    );
}

/// Unset, the floor is tight on a mesh's cloud in patches and the margin on a primitive's;
/// `scm_floor` sets `margin` or `tight` for every cloud; any other word is refused with the line
/// and both names.
#[test]
fn the_floor_is_tight_on_a_meshs_cloud_unless_the_scene_chooses_and_a_wrong_word_is_named() {
    let scene = |floor: Option<&str>| {
        let custom = floor.map_or(String::new(), |f| {
            format!("<custom><text name=\"scm_floor\" data=\"{f}\"/></custom>")
        });
        format!(
            "<mujoco><asset><mesh name=\"u\" file=\"u_block.obj\"/></asset>\n{custom}\n<worldbody>\n<body><freejoint/><geom type=\"box\" size=\"0.1 0.1 0.1\"/></body>\n<body pos=\"0.5 0 0.1\"><freejoint/><geom type=\"mesh\" mesh=\"u\"/></body>\n<geom type=\"plane\" size=\"1 1 0.1\"/>\n</worldbody></mujoco>"
        )
    };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/floor.xml");
    let e = scm::scene::load_str(&scene(Some("tighter")), &path).unwrap_err();
    assert_eq!(e.line, 2, "{e}");
    assert!(
        e.message.contains("'tighter'")
            && e.message.contains("'margin'")
            && e.message.contains("'tight'"),
        "{e}"
    );
    let (m, t) = (FloorKind::Margin, FloorKind::Tight);
    for (word, kinds) in [
        (None, [m, t]),
        (Some("margin"), [m, m]),
        (Some("tight"), [t, t]),
    ] {
        let model = scm::scene::load_str(&scene(word), &path).unwrap().model;
        // The box's cloud, then the mesh's (the plane is a half-space).
        let clouds: Vec<_> = (model.colliders.iter().flatten())
            .filter_map(|c| match c {
                Collider::Aopc(s) => Some((s.reach.is_empty(), s.floor())),
                _ => None,
            })
            .collect();
        assert_eq!(clouds, [(true, kinds[0]), (false, kinds[1])], "{word:?}");
    }
}
