//! A proof with room (`ProofSide`, docs/performance.md, "A proof that is kept"): its relevance
//! margin widened point by point (`bounds::widened_margin`) holds every plane that becomes
//! relevant after a move within the room, and near the other body it is far narrower than the
//! uniform `4δR`, which is what lets limbs a centimetre or two apart keep a proof.

use super::shapes::{capsule, distances, least_relevant_plane, sphere};
use super::*;
use crate::geometry::union::sample_union;
use nalgebra::{Rotation3, Unit};

/// At points near a capsule, moved by `δ` toward each plane point `p_j` from the nearest one
/// (the move that brings `p_j` nearest to relevance), every plane relevant after the move was
/// within the widened margin before it; and the margin is not loose: somewhere a plane needs
/// more than half of the widening (half the widening would not do).
#[test]
fn the_widened_margin_holds_every_plane_relevant_after_a_move() {
    let v = Vector3::new;
    let o = sample_union(
        &[capsule(v(0.0, 0.0, 0.0), v(0.0, 0.001, -0.3), 0.05)],
        0.01,
    );
    let big_r = o.bvh().nodes[0].radius;
    let mut s = 11u64;
    let (mut worst, mut checked) = (0.0f64, 0);
    for case in 0..300 {
        let m1 = o.bvh().log_terms * [1e-5, 1e-6, 1e-4][case % 3];
        let delta = [0.0005, 0.002, 0.008][(case / 3) % 3];
        // A point 2 mm to 6 cm off the surface, anywhere along the capsule.
        let dir = Vector3::new(lcg(&mut s), lcg(&mut s), 0.0).normalize();
        let x0 = dir * (0.052 + 0.058 * (0.5 + 0.5 * lcg(&mut s)))
            + v(0.0, 0.0, -0.15 + 0.2 * lcg(&mut s));
        let (d0, dmin0) = distances(&o, &x0);
        let i = d0.iter().position(|&d| d == dmin0).unwrap();
        let margin = super::super::bounds::widened_margin(m1, delta, big_r, dmin0, 0.0);
        for (j, pj) in o.points.iter().enumerate() {
            if j == i {
                continue;
            }
            let u = (pj - o.points[i]).normalize() * delta;
            let (d1, dmin1) = distances(&o, &(x0 + u));
            if d1[j] - dmin1 > m1 {
                continue;
            }
            checked += 1;
            let before = d0[j] - dmin0;
            assert!(
                before <= margin,
                "case {case}: plane {j} relevant after a move of {delta} m was {before:e} m² \
                 off the nearest before, beyond the margin {margin:e}"
            );
            worst = worst.max((before - m1) / (margin - m1));
        }
    }
    println!("planes checked: {checked}, the most of the widening used: {worst:.3}");
    assert!(checked > 10_000, "{checked} planes checked");
    assert!(worst > 0.5, "half the widening would have held: {worst}");
}

/// A side proven with room `δ` (at `t + δ`, margin widened for `δ`) has every relevant plane
/// farther than `t` at every query point after any move of at most `δ` (a translation and a
/// rotation, half of it each), read point by point against every plane; capsules, a union of
/// a capsule and a sphere (the humanoid's lower arm) and spheres, 5 to 45 cm between centres.
#[test]
fn a_proof_with_room_holds_after_any_move_within_it() {
    let v = Vector3::new;
    let clouds = [
        sample_union(&[capsule(v(0.0, 0.0, 0.0), v(0.0, 0.01, -0.3), 0.06)], 0.01),
        sample_union(
            &[
                capsule(v(0.01, 0.01, 0.01), v(0.17, 0.17, 0.17), 0.031),
                sphere(v(0.18, 0.18, 0.18), 0.04),
            ],
            0.01,
        ),
        sample_union(&[sphere(v(0.0, 0.0, 0.0), 0.05)], 0.01),
    ];
    let mut s = 7u64;
    let (t, eps1) = (0.006, 1e-5);
    let (mut proven, mut tried) = (0, 0);
    for case in 0..90 {
        let (o, query) = (&clouds[case % 3], &clouds[(case / 3) % 3]);
        let planes = Collider::Aopc(o.clone());
        let axis = Unit::new_normalize(vec3(&mut s));
        let rot = Rotation3::from_axis_angle(&axis, 3.0 * lcg(&mut s)).into_inner();
        let tr = vec3(&mut s).normalize() * (0.25 + 0.2 * lcg(&mut s));
        let m1 = o.bvh().log_terms * eps1;
        let delta = 3.0 * m1 / (4.0 * o.bvh().nodes[0].radius) * [1.0, 3.0][case % 2];
        let q = ReachQuestion {
            planes: &planes,
            rot: &rot,
            tr: &tr,
            t: t + delta,
            eps1,
            spring: SpringShape::NONE,
            room: delta,
        };
        tried += 1;
        let budget = &mut usize::MAX.clone();
        if cloud_beyond(&q, query, (budget, &mut Scratch::default())) != Beyond::Planes {
            continue;
        }
        proven += 1;
        let scale = query.bvh().max_norm;
        for _ in 0..4 {
            let turn = Unit::new_normalize(vec3(&mut s));
            // ‖ΔR‖_F = 2√2 sin(θ/2) ≤ √2 θ for a rotation by θ.
            let theta = 0.5 * delta / (2f64.sqrt() * scale);
            let moved_rot = Rotation3::from_axis_angle(&turn, theta).into_inner() * rot;
            let moved_tr = tr + vec3(&mut s).normalize() * (0.5 * delta);
            let moved = (moved_rot - rot).norm() * scale + (moved_tr - tr).norm();
            assert!(moved <= delta * (1.0 + 1e-9), "the move is within the room");
            for p in &query.points {
                let x = moved_rot * p + moved_tr;
                let least = least_relevant_plane(o, &x, m1);
                assert!(
                    least > t,
                    "case {case}: proven with room {delta} m, yet after a move of {moved} m \
                     a relevant plane reads {least} m at {x:?}"
                );
            }
        }
    }
    println!("proven with room: {proven} of {tried}");
    assert!(proven * 4 >= tried && proven < tried, "{proven} of {tried}");
}

/// Near the other body the widening is `4δ(√(D + m₁) + δ)`, not `4δR`: a lower arm 1.5 cm
/// beside a thigh (their root spheres overlapping by 25 cm) is proven with the room
/// `3 m₁ / 4R` point by point, where the same room widened uniformly fails.
#[test]
fn limbs_side_by_side_keep_a_room_the_uniform_widening_could_not_give() {
    let v = Vector3::new;
    let thigh = Collider::Aopc(sample_union(
        &[capsule(v(0.0, 0.0, 0.0), v(0.0, 0.001, -0.34), 0.06)],
        0.01,
    ));
    let arm = sample_union(
        &[
            capsule(v(0.0, 0.0, 0.0), v(0.0, 0.001, -0.25), 0.031),
            sphere(v(0.0, 0.001, -0.28), 0.04),
        ],
        0.01,
    );
    let Collider::Aopc(o) = &thigh else {
        unreachable!()
    };
    let (t, eps1) = (0.006, 1e-5);
    let m1 = o.bvh().log_terms * eps1;
    let big_r = o.bvh().nodes[0].radius;
    let delta = 3.0 * m1 / (4.0 * big_r);
    let tr = v(0.06 + 0.04 + 0.015, 0.0, -0.02);
    let rot = Matrix3::identity();
    let proven = |eps1: f64, room: f64| {
        let q = ReachQuestion {
            planes: &thigh,
            rot: &rot,
            tr: &tr,
            t: t + delta,
            eps1,
            spring: SpringShape::NONE,
            room,
        };
        let budget = &mut usize::MAX.clone();
        cloud_beyond(&q, &arm, (budget, &mut Scratch::default()))
    };
    assert_eq!(proven(eps1, delta), Beyond::Planes, "point by point");
    let uniform = (m1 + 4.0 * delta * big_r) / o.bvh().log_terms;
    assert_eq!(proven(uniform, 0.0), Beyond::Not, "uniformly");
}

#[test]
fn the_logarithm_bounded_from_above_lies_within_2e_3_above_it() {
    // Across magnitudes (the reach distances' ratios run from about 1 to 1e12), at every
    // eighth's edge and middle of the mantissa (where the tangent is worst and exact), at
    // random points, and at values that are not normal numbers.
    let mut ys = vec![f64::MIN_POSITIVE, f64::MAX, 1.0, 2.0, 0.5, 1e-300, 1e300];
    for e in -60..60 {
        for j in 0..=16 {
            ys.push(2f64.powi(e) * (1.0 + j as f64 / 16.0));
        }
    }
    let mut state = 11;
    for _ in 0..100_000 {
        let x = crate::geometry::lcg(&mut state);
        ys.push(10f64.powf(14.0 * x));
    }
    for y in ys {
        let (bound, ln) = (super::proof::ln_above(y), y.ln());
        assert!(
            bound >= ln && bound - ln < 2e-3,
            "{y}: {bound} against {ln}"
        );
    }
    for y in [0.0, -1.0, f64::INFINITY, 1e-310] {
        let (bound, ln) = (super::proof::ln_above(y), y.ln());
        assert!(bound == ln || (bound.is_nan() && ln.is_nan()), "{y}");
    }
}

#[test]
fn a_body_seen_from_the_world_is_its_own_frame() {
    // `relative_to_world` is `relative_to` the world's identity frame, entry for entry.
    let mut state = 5;
    let mut r = || crate::geometry::lcg(&mut state);
    for _ in 0..50 {
        let axis = Unit::new_normalize(Vector3::new(r(), r(), r() + 2.0));
        let frame = Frame {
            rotation: *Rotation3::from_axis_angle(&axis, 3.0 * r()).matrix(),
            origin: Vector3::new(r(), r(), r()) * 10.0,
            linvel: Vector3::new(r(), r(), r()),
            angvel: Vector3::new(r(), r(), r()),
        };
        let (a, b) = (
            frame.relative_to_world(),
            frame.relative_to(&Frame::identity()),
        );
        assert_eq!(a.rotation, b.rotation);
        assert_eq!(a.translation, b.translation);
        assert_eq!(a.linvel, b.linvel);
        assert_eq!(a.angvel, b.angvel);
        assert_eq!(a.angvel_planes, b.angvel_planes);
        assert!(a.surface.is_none() && b.surface.is_none());
    }
}

#[test]
fn the_quick_check_of_a_kept_proof_never_covers_what_the_exact_one_does_not() {
    // A kept proof's side against moves of every size around its room and its margin, with
    // the reach distance a little larger in the quick check (as `sides(.., true)` bounds it):
    // wherever `covers_above` holds, `covers` holds; and it holds often.
    use super::proof::ProofSide;
    use super::reach::Side;
    let v = Vector3::new;
    let query = sample_union(&[sphere(v(0.0, 0.0, 0.0), 0.05)], 0.01);
    let planes = [
        Collider::Aopc(sample_union(
            &[capsule(v(0.0, 0.0, 0.0), v(0.0, 0.0, 0.3), 0.03)],
            0.01,
        )),
        Collider::HalfSpace {
            point: Vector3::zeros(),
            normal: Vector3::z(),
        },
    ];
    let mut s = 9u64;
    let (mut quick, mut exact) = (0, 0);
    for case in 0..4000 {
        let axis = Unit::new_normalize(vec3(&mut s));
        let rotation = Rotation3::from_axis_angle(&axis, 3.0 * lcg(&mut s)).into_inner();
        let translation = vec3(&mut s) * 0.5;
        let room = 0.002 * (1.0 + lcg(&mut s));
        let kept = ProofSide {
            rotation,
            translation,
            t: 0.01 + 0.005 * lcg(&mut s),
            m1: if case % 5 == 0 {
                f64::INFINITY
            } else {
                1e-4 * (1.5 + lcg(&mut s))
            },
            room,
        };
        let size = room * 2f64.powf(3.0 * lcg(&mut s));
        let turn = Unit::new_normalize(vec3(&mut s));
        // A turn whose points at the cloud's radius move about `size`, and a shift of `size`.
        let moved_rot =
            Rotation3::from_axis_angle(&turn, size * lcg(&mut s) / 0.05).into_inner() * rotation;
        let moved_tr = translation + vec3(&mut s).normalize() * size;
        let side = |t: f64| Side {
            query: &query,
            planes: &planes[case % 2],
            rotation: moved_rot,
            translation: moved_tr,
            t,
            speed: 0.0,
            eps1: 1e-5,
        };
        let t = 0.008 * (1.0 + 0.5 * lcg(&mut s));
        let (exact_side, bounded) = (side(t), side(t * (1.0 + 1e-3 * (1.0 + lcg(&mut s)))));
        let (a, b) = (kept.covers_above(&bounded), kept.covers(&exact_side));
        assert!(
            !a || b,
            "case {case}: the quick check covers, the exact one does not"
        );
        quick += a as usize;
        exact += b as usize;
    }
    // Where a square overflows, neither covers (the exact norms are infinite).
    let kept = ProofSide {
        rotation: Matrix3::identity(),
        translation: Vector3::zeros(),
        t: 1e300,
        m1: f64::INFINITY,
        room: 0.0,
    };
    let far = Side {
        query: &query,
        planes: &planes[1],
        rotation: Matrix3::identity(),
        translation: v(1e160, 0.0, 0.0),
        t: 0.01,
        speed: 0.0,
        eps1: 1e-5,
    };
    assert!(!kept.covers(&far) && !kept.covers_above(&far));
    println!("covered: quick {quick}, exact {exact} of 4000");
    assert!(
        quick * 3 >= exact && quick < exact,
        "quick {quick}, exact {exact}"
    );
}
