//! The side settled by the two clouds' shapes alone (`shapes.rs`): sound against every
//! relevant plane read point by point, and sharp enough to settle limbs side by side.

use super::super::shapes::shapes_settle;
use super::*;
use crate::geometry::union::sample_union;
use nalgebra::{Isometry3, Rotation3, Translation3, Unit, UnitQuaternion};

pub(super) fn capsule(a: Vector3<f64>, b: Vector3<f64>, radius: f64) -> (Shape, Isometry3<f64>) {
    let axis = b - a;
    (
        Shape::Capsule {
            radius,
            half_length: axis.norm() / 2.0,
        },
        Isometry3::from_parts(
            Translation3::from((a + b) / 2.0),
            UnitQuaternion::rotation_between(&Vector3::z(), &axis).unwrap(),
        ),
    )
}

pub(super) fn sphere(c: Vector3<f64>, radius: f64) -> (Shape, Isometry3<f64>) {
    (
        Shape::Sphere { radius },
        Isometry3::translation(c.x, c.y, c.z),
    )
}

/// The squared distances from `x` to every point of `o`, and the least of them.
pub(super) fn distances(o: &Aopc, x: &Vector3<f64>) -> (Vec<f64>, f64) {
    let d: Vec<f64> = o.points.iter().map(|p| (x - p).norm_squared()).collect();
    let least = d.iter().cloned().fold(f64::INFINITY, f64::min);
    (d, least)
}

/// The least plane over the planes that carry weight at `x` (within `m1` of the nearest
/// point's squared distance), read point by point.
pub(super) fn least_relevant_plane(o: &Aopc, x: &Vector3<f64>, m1: f64) -> f64 {
    let (d, dmin) = distances(o, x);
    o.points
        .iter()
        .zip(&o.normals)
        .zip(&d)
        .filter(|(_, di)| **di - dmin <= m1)
        .map(|((p, n), _)| n.dot(&(x - p)))
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn a_side_settled_by_shapes_has_every_relevant_plane_above_the_threshold() {
    let v = Vector3::new;
    // A sphere, a capsule and a union of both (the humanoid's lower arm), at 1 cm.
    let clouds = [
        sample_union(&[sphere(v(0.0, 0.0, 0.0), 0.05)], 0.01),
        sample_union(&[capsule(v(0.0, 0.0, 0.0), v(0.0, 0.01, -0.3), 0.06)], 0.01),
        sample_union(
            &[
                capsule(v(0.01, 0.01, 0.01), v(0.17, 0.17, 0.17), 0.031),
                sphere(v(0.18, 0.18, 0.18), 0.04),
            ],
            0.01,
        ),
    ];
    for c in &clouds {
        assert!(
            crate::geometry::holders::holders(c.bvh()).next().is_some(),
            "each cloud has a certificate"
        );
    }
    let mut s = 5u64;
    let (mut settled, mut tried) = (0, 0);
    for case in 0..240 {
        let (planes, query) = (&clouds[case % 3], &clouds[(case / 3) % 3]);
        let axis = Unit::new_normalize(vec3(&mut s));
        let rot = Rotation3::from_axis_angle(&axis, 3.0 * lcg(&mut s)).into_inner();
        // Centres from 5 cm to 45 cm apart: overlapping root spheres to well clear.
        let tr = vec3(&mut s).normalize() * (0.25 + 0.2 * lcg(&mut s));
        let m1 = planes.bvh().log_terms * [1e-5, 1e-6][case % 2];
        let need = 0.005;
        tried += 1;
        if !shapes_settle(planes, query, &rot, &tr, m1, need) {
            continue;
        }
        settled += 1;
        for p in &query.points {
            let x = rot * p + tr;
            let least = least_relevant_plane(planes, &x, m1);
            assert!(
                least > need,
                "case {case}: settled, yet a relevant plane reads {least} at {x:?}"
            );
        }
    }
    println!("settled by shapes: {settled} of {tried}");
    assert!(
        settled * 3 >= tried && settled < tried,
        "both outcomes occur: {settled} of {tried} settled"
    );
}

#[test]
fn capsules_side_by_side_are_settled_from_about_a_centimetre() {
    let v = Vector3::new;
    let thigh = sample_union(
        &[capsule(v(0.0, 0.0, 0.0), v(0.0, 0.001, -0.34), 0.06)],
        0.01,
    );
    let arm = sample_union(
        &[capsule(v(0.0, 0.0, 0.0), v(0.0, 0.001, -0.3), 0.04)],
        0.01,
    );
    let m1 = thigh.bvh().log_terms * 1e-5;
    let at = |gap: f64| {
        let tr = v(0.06 + 0.04 + gap, 0.0, -0.02);
        shapes_settle(&thigh, &arm, &Matrix3::identity(), &tr, m1, 0.006)
    };
    // Parallel, their root spheres overlapping by about 25 cm.
    assert!(at(0.03) && at(0.015), "settled at 3 and 1.5 cm");
    assert!(
        !at(0.004),
        "not at 4 mm, within the threshold and the bound's margins"
    );
    // A cloud without a certificate (a box) settles nothing.
    let cube = Shape::Box {
        half: v(0.05, 0.05, 0.05),
    }
    .sample(0.01);
    let tr = v(0.5, 0.0, 0.0);
    let settles = |planes: &Aopc, query: &Aopc| {
        shapes_settle(planes, query, &Matrix3::identity(), &tr, m1, 0.006)
    };
    assert!(!settles(&cube, &arm));
    assert!(!settles(&thigh, &cube));
}
