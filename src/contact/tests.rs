//! Tests of the contact forces.

use super::*;
use num_dual::Dual64;

#[test]
fn dissipation_variants_agree_at_the_ends() {
    for kind in [Dissipation::Paper, Dissipation::Smooth] {
        assert_eq!(kind.factor(0.0), 1.0);
        assert!(kind.factor(2.0f64).abs() < 1e-15);
        assert_eq!(kind.factor(2.5), 0.0);
        assert_eq!(kind.factor(-1.0), 2.0);
        let slope = |s: f64| kind.factor(Dual64::new(s, 1.0)).eps;
        assert!((slope(-1e-12) + 1.0).abs() < 1e-9 && (slope(1e-12) + 1.0).abs() < 1e-9);
        assert!(slope(2.0 - 1e-12).abs() < 1e-9);
    }
}

#[test]
fn smooth_dissipation_is_c2() {
    use num_dual::second_derivative;
    let d2 = |s: f64| second_derivative(|x| Dissipation::Smooth.factor(x), s).2;
    for s in [0.0, 2.0] {
        assert!((d2(s - 1e-9) - d2(s + 1e-9)).abs() < 1e-6, "jump at {s}");
    }
    let p2 = |s: f64| second_derivative(|x| Dissipation::Paper.factor(x), s).2;
    assert!(
        (p2(-1e-9) - p2(1e-9)).abs() > 0.4,
        "the paper's d is only C1 at 0"
    );
}

#[test]
fn point_plane_force_jacobian_matches_duals_and_central_differences() {
    // The hand-derived ∂λ/∂φ and ∂λ/∂v of `point_plane_force_jacobian` against Dual64
    // through `point_plane_force` (round-off: 1e-12 of the largest entry) and against
    // central differences (h = 1e-7 of the scale: 1e-6 relative), on both sides of the
    // dissipation's kinks (s < 0, 0 < s < 2, s > 2), pressed and separated, sliding and
    // nearly at rest, for both dissipation laws.
    let n = Vector3::new(0.2, -0.3, 0.9).normalize();
    for dissipation in [Dissipation::Paper, Dissipation::Smooth] {
        let prm = ContactParams {
            eps3: 1e-4,
            stiffness: 1e4,
            dissipation_velocity: 0.1,
            stiction_velocity: 0.01,
            friction: 0.5,
            dissipation,
            ..ContactParams::default()
        };
        for (depth, vn, vt) in [
            (1e-3, -0.05, 0.03),
            (2e-4, 0.05, -0.2),
            (-3e-4, 0.15, 1e-3),
            (5e-4, 0.25, 0.1),
            (1e-3, 0.0, 0.0),
        ] {
            let t = n.cross(&Vector3::x()).normalize();
            let (r, v) = (
                n * -depth + t * 0.01,
                n * vn + t * vt + n.cross(&t) * 0.2 * vt,
            );
            let (lambda, dphi, dv) = point_plane_force_jacobian(&r, &n, &v, &prm);
            assert!((lambda - point_plane_force(&r, &n, &v, &prm)).norm() <= 1e-15 * lambda.norm());
            let scale = dphi.amax().max(dv.amax()).max(1e-300);
            // ∂λ/∂φ along r = r0 + s n (φ changes by s).
            let along = |s: f64| point_plane_force(&(r + n * s), &n, &v, &prm);
            let dual: Vector3<f64> = point_plane_force(
                &(r.map(Dual64::from) + n.map(Dual64::from) * Dual64::new(0.0, 1.0)),
                &n.map(Dual64::from),
                &v.map(Dual64::from),
                &prm.lift(),
            )
            .map(|x| x.eps);
            let fd = (along(1e-9) - along(-1e-9)) / 2e-9;
            assert!(
                (dphi - dual).amax() <= 1e-12 * scale,
                "{dissipation:?} {depth} {vn}: dphi {dphi:?} vs dual {dual:?}"
            );
            assert!(
                (dphi - fd).amax() <= 1e-6 * scale,
                "{dissipation:?} {depth} {vn}: dphi {dphi:?} vs fd {fd:?}"
            );
            for k in 0..3 {
                let mut e = Vector3::zeros();
                e[k] = 1.0;
                let dual: Vector3<f64> = point_plane_force(
                    &r.map(Dual64::from),
                    &n.map(Dual64::from),
                    &(v.map(Dual64::from) + e.map(|x| Dual64::new(0.0, x))),
                    &prm.lift(),
                )
                .map(|x| x.eps);
                let h = 1e-7 * v.norm().max(0.01);
                let fd = (point_plane_force(&r, &n, &(v + e * h), &prm)
                    - point_plane_force(&r, &n, &(v - e * h), &prm))
                    / (2.0 * h);
                assert!(
                    (dv.column(k) - dual).amax() <= 1e-12 * scale,
                    "{dissipation:?} {depth} {vn}: dv[{k}] {:?} vs dual {dual:?}",
                    dv.column(k)
                );
                assert!(
                    (dv.column(k) - fd).amax() <= 1e-6 * scale,
                    "{dissipation:?} {depth} {vn}: dv[{k}] {:?} vs fd {fd:?}",
                    dv.column(k)
                );
            }
        }
    }
}

#[test]
fn point_plane_force_pushes_out_and_opposes_sliding() {
    let prm = ContactParams::default();
    let n = Vector3::z();
    let r = Vector3::new(0.0, 0.0, -1e-3);
    let f = point_plane_force(&r, &n, &Vector3::new(0.1, 0.0, 0.0), &prm);
    assert!(f.z > 0.0 && f.x < 0.0 && f.y == 0.0);
    // Friction bounded by μ λ_n.
    assert!(f.x.abs() <= prm.friction * f.z);
    // Separating fast (s > 2): no force.
    let f = point_plane_force(&r, &n, &Vector3::new(0.0, 0.0, 1.0), &prm);
    assert_eq!(f, Vector3::zeros());
}

#[test]
fn a_nan_temperature_gives_a_nan_contact_not_a_panic() {
    // ε2 = NaN makes the band's cutoff NaN: no entry is above it, so every entry is kept with
    // its terms (the band's test is the force's, "not above") and evaluated; the contact comes
    // out NaN for the guard to refuse, on the plain and on the chained (dual) path.
    use crate::geometry::Shape;
    use num_dual::Dual64;
    let a = Collider::Aopc(Shape::Sphere { radius: 0.05 }.sample(0.01));
    let b = Collider::Aopc(
        Shape::Box {
            half: Vector3::repeat(0.1),
        }
        .sample(0.01),
    );
    let fa = Frame {
        origin: Vector3::new(0.0, 0.0, 0.149),
        ..Frame::identity()
    };
    let prm = ContactParams {
        eps2: f64::NAN,
        ..ContactParams::default()
    };
    let pc = pair_contact(&a, &fa, &b, &Frame::identity(), &prm);
    assert!(pc.distance.is_nan() || pc.on_a.force.iter().any(|x| x.is_nan()));
    let lift = |f: &Frame<f64>| Frame {
        rotation: f.rotation.map(Dual64::from),
        origin: f.origin.map(Dual64::from),
        linvel: f.linvel.map(Dual64::from),
        angvel: f.angvel.map(Dual64::from),
    };
    let prm_d = ContactParams {
        eps1: Dual64::from(prm.eps1),
        eps2: Dual64::from(prm.eps2),
        eps3: Dual64::from(prm.eps3),
        stiffness: Dual64::from(prm.stiffness),
        dissipation_velocity: Dual64::from(prm.dissipation_velocity),
        stiction_velocity: Dual64::from(prm.stiction_velocity),
        friction: Dual64::from(prm.friction),
        dissipation: prm.dissipation,
    };
    let pd = pair_contact(&a, &lift(&fa), &b, &Frame::identity(), &prm_d);
    assert!(pd.distance.re.is_nan() || pd.on_a.force.iter().any(|x| x.re.is_nan()));
}
