//! Tests of the contact's derivative paths: an undamped contact's derivatives on dual numbers,
//! and a pair's hand-derived Jacobian kept for the passes of one Jacobian.

use super::tests::wide_overlap;
use super::*;
use num_dual::Dual64;

#[test]
fn an_undamped_contact_has_finite_derivatives() {
    // MuJoCo's `solref="-k -0"` (newton_cradle.xml) is an infinite dissipation velocity: no
    // damping. Its point force on dual numbers seeded on the velocity and the depth: finite
    // derivatives, those of a dissipation velocity of 1e200 m/s (to 1e-12), and the real force
    // of the hand-derived Jacobian's `f64` path. (Dividing a dual velocity by an infinite
    // constant gave `∞ · 0`, not a number, and Newton's Jacobian with it.)
    let still = ContactParams {
        dissipation_velocity: f64::INFINITY,
        ..ContactParams::default()
    };
    let huge = ContactParams {
        dissipation_velocity: 1e200,
        ..still
    };
    let n = Vector3::<f64>::z().map(Dual64::from);
    for seed in 0..2 {
        let (depth, vz) = if seed == 0 {
            (Dual64::new(-1e-3, 1.0), Dual64::from(-0.2))
        } else {
            (Dual64::from(-1e-3), Dual64::new(-0.2, 1.0))
        };
        let r = Vector3::new(Dual64::from(0.0), Dual64::from(0.0), depth);
        let v = Vector3::new(Dual64::from(0.05), Dual64::from(0.0), vz);
        let a = point_plane_force(&r, &n, &v, &still.lift());
        let b = point_plane_force(&r, &n, &v, &huge.lift());
        for k in 0..3 {
            assert!(a[k].eps.is_finite(), "{seed}: {a:?}");
            assert!(
                (a[k].eps - b[k].eps).abs() <= 1e-12 * (1.0 + b[k].eps.abs()),
                "{a:?} {b:?}"
            );
            assert!((a[k].re - b[k].re).abs() <= 1e-12 * (1.0 + b[k].re.abs()));
        }
        let real = point_plane_force(&r.map(|x| x.re), &Vector3::z(), &v.map(|x| x.re), &still);
        assert_eq!(real, a.map(|x| x.re));
    }
}

#[test]
fn a_pairs_kept_jacobian_serves_the_same_real_inputs_only() {
    // The chain rule's path keeps the pair's hand-derived Jacobian with the real inputs it was
    // taken at (`pair_contact_memo` given a `CandidateMemo`): a pass of dual numbers seeded on
    // other directions at the same real point reads it (tampering with it shows in the result),
    // and gives the bits of a fresh evaluation; at another real point it is taken again.
    use crate::scalar::{derivatives, seeded};
    use num_dual::DualSVec64;
    type D = DualSVec64<3>;
    let (a, b, fa, fb, prm) = wide_overlap();
    let seeded_frame = |f: &Frame<f64>, first: usize| Frame::<D> {
        rotation: f.rotation.map(D::from_re),
        origin: Vector3::from_fn(|k, _| seeded(f.origin[k], (k == 0).then_some(first + 2))),
        linvel: Vector3::from_fn(|k, _| seeded(f.linvel[k], Some(first + k))),
        angvel: f.angvel.map(D::from_re),
    };
    let flat = |c: &PairContact<D>| -> Vec<u64> {
        [c.on_a.force, c.on_a.torque, c.on_b.force, c.on_b.torque]
            .iter()
            .flat_map(|v| v.iter())
            .chain([&c.distance])
            .flat_map(|x| std::iter::once(x.re).chain(derivatives(x)))
            .map(f64::to_bits)
            .collect()
    };
    // b's frame constant (its directions past the width), a's seeded on its x and velocity.
    let (fb_d, prm_d) = (seeded_frame(&fb, 3), prm.lift::<D>());
    let mut memo = crate::collision::CandidateMemo::default();
    let mut scratch = Scratch::default();
    let mut run = |fa: &Frame<D>, memo: Option<&mut crate::collision::CandidateMemo>| {
        flat(&pair_contact_memo(
            &a,
            fa,
            &b,
            &fb_d,
            &prm_d,
            memo,
            &mut scratch,
        ))
    };
    let (first, second) = (seeded_frame(&fa, 0), seeded_frame(&fa, 1));
    assert_eq!(run(&first, Some(&mut memo)), run(&first, None));
    assert!(memo.linearized.is_some());
    assert_eq!(run(&second, Some(&mut memo)), run(&second, None));
    // Read from the memo at the same real inputs: a tampered Jacobian changes the result.
    let fresh = run(&second, None);
    let kept = memo.linearized.as_mut().unwrap();
    kept.jacobian.iter_mut().for_each(|x| *x *= 2.0);
    assert_ne!(run(&second, Some(&mut memo)), fresh);
    // At another real point (a moved 10 µm) it is taken again: a fresh evaluation's bits.
    let moved = Frame {
        origin: fa.origin + Vector3::new(1e-5, 0.0, 0.0),
        ..fa
    };
    let moved = seeded_frame(&moved, 0);
    assert_eq!(run(&moved, Some(&mut memo)), run(&moved, None));
}
