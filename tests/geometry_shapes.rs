//! Every geom type: AOPC quality (closed, outward, on the surface, even), SSDF against the
//! exact SDF (sign and a near-surface error that shrinks with spacing and ε1), mass properties
//! against closed forms, unions of geoms, and the soft top-K contact points.

use crate::common::Lcg;
use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};
use scm::collision::{contact_points, Collider, Frame};
use scm::geometry::union::{sample_union, union_volume};
use scm::geometry::{ssdf, Shape, TriMesh};
use std::f64::consts::PI;
use std::sync::Arc;

/// A torus mesh (major radius `big`, tube radius `r`), `nu × nv` quads split in triangles.
pub fn torus(big: f64, r: f64, nu: usize, nv: usize) -> TriMesh {
    let mut v = Vec::new();
    for i in 0..nu {
        let u = 2.0 * PI * i as f64 / nu as f64;
        for j in 0..nv {
            let w = 2.0 * PI * j as f64 / nv as f64;
            v.push(Vector3::new(
                (big + r * w.cos()) * u.cos(),
                (big + r * w.cos()) * u.sin(),
                r * w.sin(),
            ));
        }
    }
    let idx = |i: usize, j: usize| ((i % nu) * nv + (j % nv)) as u32;
    let mut t = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            t.push([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)]);
            t.push([idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]);
        }
    }
    TriMesh::new("torus", v, t).unwrap().0
}

fn shapes() -> Vec<(&'static str, Shape)> {
    vec![
        ("sphere", Shape::Sphere { radius: 0.1 }),
        (
            "box",
            Shape::Box {
                half: Vector3::new(0.1, 0.06, 0.04),
            },
        ),
        (
            "capsule",
            Shape::Capsule {
                radius: 0.05,
                half_length: 0.06,
            },
        ),
        (
            "cylinder",
            Shape::Cylinder {
                radius: 0.06,
                half_length: 0.05,
            },
        ),
        (
            "ellipsoid",
            Shape::Ellipsoid {
                radii: Vector3::new(0.1, 0.06, 0.04),
            },
        ),
        (
            "torus mesh",
            Shape::Mesh(Arc::new(torus(0.07, 0.03, 48, 24))),
        ),
    ]
}

#[test]
fn aopcs_are_closed_outward_even_and_on_the_surface() {
    for (name, shape) in shapes() {
        let s = shape.sample(0.01);
        let size = shape.size();
        // Closed: Σ n·area = 0 (exact faces; curved areas from a midpoint rule).
        assert!(
            s.closure_defect().norm() < 1e-4 * size * size,
            "{name}: |Σ n area| = {:e}",
            s.closure_defect().norm()
        );
        // The quads' volume is the shape's up to the chords of curved surfaces (< 1 %).
        let v = shape.volume();
        assert!(
            (s.enclosed_volume() - v).abs() < 0.01 * v,
            "{name}: volume {} vs {v}",
            s.enclosed_volume()
        );
        // Points on the surface (the mesh's own triangles: exactly; curved shapes: exactly at
        // their parametric centres; planar caps: chords, within h²/r).
        for (p, n) in s.points.iter().zip(&s.normals) {
            assert!(
                shape.sdf(p).abs() < 0.002,
                "{name}: point {p:?} is {} off the surface",
                shape.sdf(p)
            );
            // Outward: a step along the normal leaves the solid, one against it enters.
            assert!(
                shape.sdf(&(p + n * 0.003)) > shape.sdf(&(p - n * 0.003)),
                "{name}: normal {n:?} at {p:?} points inward"
            );
        }
        // Even: the nearest-neighbour spacing is about the target (meshes: the input's).
        let h = s.spacing();
        if !name.contains("mesh") {
            assert!(h > 0.005 && h < 0.013, "{name}: spacing {h}");
        }
        // Every quad is wound like its normal.
        for (f, n) in s.faces.iter().zip(&s.normals) {
            let c: Vec<_> = f.iter().map(|&i| s.vertices[i as usize]).collect();
            assert!(
                (c[2] - c[0]).cross(&(c[3] - c[1])).dot(n) > 0.0,
                "{name}: a quad is wound against its normal"
            );
        }
        println!(
            "{name}: {} points, spacing {h:.4}, volume error {:.2e}",
            s.len(),
            (s.enclosed_volume() - v) / v
        );
    }
}

#[test]
fn quads_follow_sharp_edges() {
    // Cylinder: no quad crosses a rim (every quad is on the side or on a cap).
    let s = Shape::Cylinder {
        radius: 0.05,
        half_length: 0.04,
    }
    .sample(0.01);
    for f in &s.faces {
        let zs: Vec<f64> = f.iter().map(|&i| s.vertices[i as usize].z).collect();
        let on_cap = zs.iter().all(|z| (z.abs() - 0.04).abs() < 1e-12);
        let rims = zs.iter().filter(|z| (z.abs() - 0.04).abs() < 1e-12).count();
        assert!(on_cap || rims <= 2, "a quad crosses a rim: {zs:?}");
    }
    // The rim is a polygon of vertices at the side's column angles, shared by side and cap.
    let rim: Vec<_> = s
        .vertices
        .iter()
        .filter(|v| (v.z - 0.04).abs() < 1e-12 && (v.xy().norm() - 0.05).abs() < 1e-12)
        .collect();
    assert_eq!(rim.len() % 4, 0);
    assert_eq!(
        s.vertices.len() + s.faces.len() - 2,
        s.faces.len() * 2,
        "V - E + F = 2: a closed, welded quad mesh"
    );
}

#[test]
fn ssdf_sign_is_right_for_every_shape() {
    let mut rng = Lcg(11);
    for (name, shape) in shapes() {
        let aopc = shape.sample(0.01);
        let mut checked = 0;
        for _ in 0..300 {
            let p = Vector3::new(
                rng.range(-0.2, 0.2),
                rng.range(-0.2, 0.2),
                rng.range(-0.15, 0.15),
            );
            let exact = shape.sdf(&p);
            // At least 5 mm from the surface: the facets (sag below 1 mm) cannot flip the sign.
            if exact.abs() < 0.005 {
                continue;
            }
            checked += 1;
            assert_eq!(
                ssdf(&aopc, &p, 1e-5).signum(),
                exact.signum(),
                "{name} at {p:?}: sdf {exact}"
            );
        }
        assert!(checked > 150, "{name}");
    }
}

/// Largest |SSDF - SDF| over points within ±2 mm of the surface, where the nearest feature is
/// a face (outside convex edges the planes extend sharply while the Euclidean SDF rounds).
fn near_surface_error(shape: &Shape, spacing: f64, eps1: f64) -> f64 {
    near_surface_error_of(shape, &shape.sample(spacing), eps1)
}

/// [`near_surface_error`] of a given sampling `aopc` of `shape`.
fn near_surface_error_of(shape: &Shape, aopc: &scm::geometry::Aopc, eps1: f64) -> f64 {
    let fine = shape.sample(0.002);
    let mut rng = Lcg(7);
    let mut worst: f64 = 0.0;
    for _ in 0..300 {
        // A point of the fine surface sampling, moved along its normal.
        let k = (rng.next() * fine.len() as f64) as usize;
        let p = fine.points[k] + fine.normals[k] * rng.range(-0.002, 0.002);
        // Skip the neighbourhood of sharp edges (their SDF is not a plane's).
        let g = shape.sdf_gradient(&p, 1e-5);
        if (g - fine.normals[k]).norm() > 0.05 {
            continue;
        }
        worst = worst.max((ssdf(aopc, &p, eps1) - shape.sdf(&p)).abs());
    }
    worst
}

#[test]
fn ssdf_error_near_the_surface_shrinks_with_spacing_and_eps1() {
    for (name, shape) in shapes() {
        if name == "torus mesh" {
            continue; // its error is bounded by the input mesh's: see the next test
        }
        // ε1 = 0.1 h² keeps the softmin as sharp relative to the spacing at every h.
        let e: Vec<f64> = [0.02, 0.01, 0.005]
            .iter()
            .map(|&h| near_surface_error(&shape, h, 0.1 * h * h))
            .collect();
        println!("{name}: spacing 2, 1, 0.5 cm: {e:?}");
        assert!(
            e[1] < 0.8 * e[0] && e[2] < 0.8 * e[1],
            "{name}: error does not shrink with spacing: {e:?}"
        );
        assert!(e[2] < 3e-4, "{name}: {e:?}");
        let e: Vec<f64> = [1e-4, 1e-5, 1e-6]
            .iter()
            .map(|&e1| near_surface_error(&shape, 0.01, e1))
            .collect();
        println!("{name}: eps1 1e-4, 1e-5, 1e-6: {e:?}");
        assert!(
            e[0] > e[1] && e[1] > e[2],
            "{name}: error does not shrink with eps1: {e:?}"
        );
    }
}

#[test]
fn ssdf_of_a_mesh_tracks_its_exact_sdf() {
    // Meshes of the same torus at two resolutions, sampled on their own triangles: the error
    // near the surface shrinks. Sampled as a scene samples them (simplified first within
    // `SIMPLIFY_TOLERANCE` × the spacing of the file's surface, then one point per patch of
    // at most `PATCH_RADIUS` × the spacing), the error is at most the own triangles' plus that
    // tolerance plus a patch's sagitta on the tube (radius 3 cm): a patch's plane departs from
    // a surface of radius R by ρ² / 2R at ρ from its point.
    let spacing = 0.01;
    let rho = scm::geometry::mesh::PATCH_RADIUS * spacing;
    let tolerance = scm::geometry::mesh::SIMPLIFY_TOLERANCE * spacing + rho * rho / (2.0 * 0.03);
    let (own, scene): (Vec<f64>, Vec<f64>) = [(24, 12), (48, 24)]
        .iter()
        .map(|&(nu, nv)| {
            let mesh = Arc::new(torus(0.07, 0.03, nu, nv));
            let shape = Shape::Mesh(mesh.clone());
            (
                near_surface_error_of(&shape, &mesh.sample_as_is(spacing), 1e-6),
                near_surface_error(&shape, spacing, 1e-6),
            )
        })
        .unzip();
    println!("torus mesh 24x12, 48x24: own triangles {own:?}, as a scene samples it {scene:?}");
    assert!(own[1] < 0.6 * own[0] && own[1] < 1e-3, "{own:?}");
    for (o, s) in own.iter().zip(&scene) {
        assert!(*s <= o + tolerance, "{s} against {o} + {tolerance}");
    }
}

#[test]
fn mass_properties_match_closed_forms() {
    // Against independent closed forms per unit density (m⁵ for inertia).
    let (r, h) = (0.05, 0.06);
    let cap = Shape::Capsule {
        radius: r,
        half_length: h,
    }
    .mass_properties();
    let v_cap = PI * r * r * 2.0 * h + 4.0 / 3.0 * PI * r.powi(3);
    assert!((cap.volume - v_cap).abs() < 1e-15);
    // Capsule I_zz: cylinder m r²/2 plus a sphere's 2/5 m r².
    let izz = PI * r * r * 2.0 * h * r * r / 2.0 + 0.4 * (4.0 / 3.0 * PI * r.powi(3)) * r * r;
    assert!((cap.inertia[(2, 2)] - izz).abs() < 1e-15 * izz.max(1.0));
    // The same solids as fine meshes (exact polyhedra): agreement to the facets' error.
    let ring = torus(0.07, 0.03, 192, 96).mass_properties();
    let (big, tube) = (0.07, 0.03);
    let v = 2.0 * PI * PI * big * tube * tube;
    assert!(
        (ring.volume - v).abs() < 1e-3 * v,
        "torus volume {} vs {v}",
        ring.volume
    );
    // Torus: I_zz = m (R² + 3/4 r²), I_xx = m (R²/2 + 5/8 r²).
    assert!(
        (ring.inertia[(2, 2)] - v * (big * big + 0.75 * tube * tube)).abs()
            < 2e-3 * ring.inertia[(2, 2)]
    );
    assert!(
        (ring.inertia[(0, 0)] - v * (big * big / 2.0 + 0.625 * tube * tube)).abs()
            < 2e-3 * ring.inertia[(0, 0)]
    );
    assert!(ring.com.norm() < 1e-12);
    // Cylinder and ellipsoid against a numerical integration on a grid (midpoint rule, 1e-3).
    for shape in [
        Shape::Cylinder {
            radius: 0.05,
            half_length: 0.03,
        },
        Shape::Ellipsoid {
            radii: Vector3::new(0.05, 0.03, 0.02),
        },
        Shape::Capsule {
            radius: 0.03,
            half_length: 0.02,
        },
    ] {
        let mp = shape.mass_properties();
        let n = 120;
        let ext = shape.size();
        let step = 2.0 * ext / n as f64;
        let (mut vol, mut inertia) = (0.0, Matrix3::zeros());
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    let p = Vector3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * step
                        - Vector3::repeat(ext);
                    if shape.contains(&p) {
                        let dv = step.powi(3);
                        vol += dv;
                        inertia +=
                            (Matrix3::identity() * p.norm_squared() - p * p.transpose()) * dv;
                    }
                }
            }
        }
        assert!(
            (mp.volume - vol).abs() < 5e-3 * vol,
            "{shape:?}: volume {} vs grid {vol}",
            mp.volume
        );
        assert!(
            (mp.inertia - inertia).norm() < 1e-2 * inertia.norm(),
            "{shape:?}: inertia {} vs grid {inertia}",
            mp.inertia
        );
    }
}

#[test]
fn overlapping_boxes_give_the_ssdf_of_their_union() {
    // Two boxes of one body whose union is one box: [-0.1, 0.06] and [-0.04, 0.1] along x.
    let a = (
        Shape::Box {
            half: Vector3::new(0.08, 0.03, 0.02),
        },
        Isometry3::translation(-0.02, 0.0, 0.0),
    );
    let b = (
        Shape::Box {
            half: Vector3::new(0.07, 0.03, 0.02),
        },
        Isometry3::translation(0.03, 0.0, 0.0),
    );
    let union = sample_union(&[a.clone(), b.clone()], 0.01);
    let one = Shape::Box {
        half: Vector3::new(0.1, 0.03, 0.02),
    }
    .sample(0.01);
    assert_eq!(union.len(), one.len(), "interior or duplicate faces remain");
    assert!((union_volume(&[a, b]).0 - 0.2 * 0.06 * 0.04).abs() < 1e-15);
    let mut rng = Lcg(4);
    for _ in 0..300 {
        // Near the shared top, bottom and side surfaces, and across the overlap.
        let p = Vector3::new(
            rng.range(-0.12, 0.12),
            rng.range(-0.05, 0.05),
            rng.range(-0.04, 0.04),
        );
        for eps1 in [1e-4, 1e-5] {
            let (u, o) = (ssdf(&union, &p, eps1), ssdf(&one, &p, eps1));
            assert!((u - o).abs() < 1e-12, "{p:?}: union {u} vs one box {o}");
        }
    }
}

#[test]
fn t_block_union_has_no_interior_points_and_the_exact_volume() {
    let bar = (
        Shape::Box {
            half: Vector3::new(0.125, 0.025, 0.02),
        },
        Isometry3::translation(0.0, 0.0375, 0.0),
    );
    let stem = (
        Shape::Box {
            half: Vector3::new(0.025, 0.085, 0.02),
        },
        Isometry3::translation(0.0, -0.0525, 0.0),
    );
    let s = sample_union(&[bar.clone(), stem.clone()], 0.01);
    assert!(
        (s.enclosed_volume() - 8.0e-4).abs() < 1e-15,
        "{}",
        s.enclosed_volume()
    );
    assert!(s.closure_defect().norm() < 1e-15);
    // No point strictly inside either box, and no two points at the same place.
    for p in &s.points {
        for (shape, pose) in [&bar, &stem] {
            assert!(
                shape.sdf(&(pose.inverse() * nalgebra::Point3::from(*p)).coords) > -1e-12,
                "interior point {p:?}"
            );
        }
    }
    let bvh = s.bvh();
    assert!(
        (0..bvh.len()).all(|k| bvh.nearest_except(&bvh.points[k], k).1 > 1e-8),
        "duplicate points"
    );
}

#[test]
fn union_with_curved_geoms_drops_inside_faces() {
    // A capsule through a sphere (a dumbbell-like body): no point inside the other geom, and
    // the volume close to the union's.
    let parts = [
        (Shape::Sphere { radius: 0.05 }, Isometry3::identity()),
        (
            Shape::Capsule {
                radius: 0.02,
                half_length: 0.06,
            },
            Isometry3::from_parts(
                Translation3::new(0.03, 0.0, 0.0),
                UnitQuaternion::from_axis_angle(&Vector3::y_axis(), PI / 2.0),
            ),
        ),
    ];
    let s = sample_union(&parts, 0.005);
    for p in &s.points {
        for (shape, pose) in &parts {
            assert!(
                shape.sdf(&(pose.inverse() * nalgebra::Point3::from(*p)).coords) > -1e-3,
                "interior point {p:?}"
            );
        }
    }
    let (v, exact) = union_volume(&parts);
    assert!(!exact);
    assert!(
        (s.enclosed_volume() - v).abs() < 0.02 * v,
        "{} vs {v}",
        s.enclosed_volume()
    );
}

/// Capsules of one radius meeting at their ends (gymnasium's pusher's gripper: a U of three
/// capsules), whose caps around each joint are the same sphere: the shared part is kept once,
/// not dropped from both (the 4×4 sub-samples of a cap's quads lay inside the other cap by the
/// chord's sagitta, and the gripper lost 14.5 % of its volume), and the surface closes.
#[test]
fn capsules_meeting_at_their_ends_keep_the_joint_once() {
    let capsule = |a, b| crate::common::capsule(a, b, 0.02);
    let v = Vector3::new;
    let parts = [
        capsule(v(0.0, -0.1, 0.0), v(0.0, 0.1, 0.0)),
        capsule(v(0.0, -0.1, 0.0), v(0.1, -0.1, 0.0)),
        capsule(v(0.0, 0.1, 0.0), v(0.1, 0.1, 0.0)),
    ];
    let s = sample_union(&parts, 0.0078);
    // Every point on the union's surface (to the chord's sagitta), none inside or astray.
    for p in &s.points {
        let d = parts
            .iter()
            .map(|(shape, pose)| shape.sdf(&(pose.inverse() * nalgebra::Point3::from(*p)).coords))
            .fold(f64::INFINITY, f64::min);
        assert!(d.abs() < 1e-3, "a point {d} m off the surface: {p:?}");
    }
    let (exact, _) = union_volume(&parts);
    let volume = s.enclosed_volume();
    assert!(
        (volume - exact).abs() < 0.01 * exact,
        "enclosed volume {volume} against the union's {exact}"
    );
    let area: f64 = s.areas.iter().sum();
    let closure = s.closure_defect().norm();
    assert!(closure < 1e-3 * area, "|Σ n·area| = {closure} of {area} m²");
    // Around each joint the outer quarter of the sphere is there, once: its outermost point.
    for corner in [v(0.0, -0.1, 0.0), v(0.0, 0.1, 0.0)] {
        let out = v(-1.0, corner.y.signum(), 0.0).normalize();
        let near = s
            .points
            .iter()
            .filter(|p| (*p - corner - out * 0.02).norm() < 0.006)
            .count();
        assert!(
            (1..=4).contains(&near),
            "{near} points at the joint's outer corner"
        );
    }
}

#[test]
fn soft_top_k_points_find_the_contacts_and_are_smooth() {
    // A box tilted about y resting on a larger box: its lower edge (at x > 0: a turn about y
    // takes +x down) is deeper than anything else, so the points are there, on the contact.
    let ground = Collider::Aopc(
        Shape::Box {
            half: Vector3::new(0.2, 0.2, 0.05),
        }
        .sample(0.01),
    );
    let block = Collider::Aopc(
        Shape::Box {
            half: Vector3::new(0.05, 0.05, 0.05),
        }
        .sample(0.01),
    );
    let rot = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.2)
        .to_rotation_matrix()
        .into_inner();
    let fb = Frame {
        rotation: rot,
        origin: Vector3::new(
            0.0,
            0.0,
            0.05 + 0.05 * (0.2f64.cos() + 0.2f64.sin()) - 0.002,
        ),
        linvel: Vector3::zeros(),
        angvel: Vector3::zeros(),
    };
    let pts = contact_points(&ground, &Frame::identity(), &block, &fb, [1e-5; 2], 1e-3, 3);
    assert_eq!(pts.len(), 3);
    for c in &pts {
        assert!(
            (c.z - 0.05).abs() < 0.005,
            "contact point {c:?} is not at the contact height"
        );
        assert!(c.x > 0.02, "contact point {c:?} is not at the deeper edge");
    }
    // Derivative of a point with respect to the block's height, against central differences.
    use num_dual::Dual64;
    let at = |z: Dual64| {
        let f = Frame {
            rotation: rot.map(Dual64::from),
            origin: Vector3::new(Dual64::from(0.0), Dual64::from(0.0), z),
            linvel: Vector3::zeros(),
            angvel: Vector3::zeros(),
        };
        contact_points(
            &ground,
            &Frame::identity(),
            &block,
            &f,
            [Dual64::from(1e-5); 2],
            Dual64::from(1e-3),
            2,
        )
    };
    let z0 = fb.origin.z;
    let d = at(Dual64::new(z0, 1.0));
    let h = 1e-7;
    let (up, down) = (at(Dual64::from(z0 + h)), at(Dual64::from(z0 - h)));
    for k in 0..2 {
        for i in 0..3 {
            let fd = (up[k][i].re - down[k][i].re) / (2.0 * h);
            assert!(
                (d[k][i].eps - fd).abs() < 1e-4 * (1.0 + fd.abs()),
                "point {k} axis {i}: dual {} vs fd {fd}",
                d[k][i].eps
            );
        }
    }
}

/// The union volume estimate of a body whose parts include meshes (`scm check`), by the
/// crossings of its grid lines with each mesh: a tilted torus mesh and a sphere apart from it
/// (so the union's volume is the sum), within the 128³ grid's resolution of the exact sum.
/// (A winding number per grid point took minutes on the Kinova arm's meshes; the crossings
/// take seconds.)
#[test]
fn a_union_with_meshes_measures_its_volume_by_grid_line_crossings() {
    let torus = Arc::new(torus(0.1, 0.03, 48, 24));
    let exact_torus = torus.mass_properties().volume;
    let parts = [
        (
            Shape::Mesh(torus),
            Isometry3::from_parts(
                Translation3::new(0.02, -0.01, 0.03),
                UnitQuaternion::from_euler_angles(0.4, -0.3, 0.2),
            ),
        ),
        (
            Shape::Sphere { radius: 0.05 },
            Isometry3::translation(0.3, 0.0, 0.0),
        ),
    ];
    let exact = exact_torus + 4.0 / 3.0 * PI * 0.05f64.powi(3);
    let (v, is_exact) = union_volume(&parts);
    assert!(!is_exact);
    assert!((v - exact).abs() < 0.01 * exact, "{v} vs {exact}");
}
