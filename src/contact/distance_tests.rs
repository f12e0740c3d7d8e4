//! The distance alone (`pair_distance`) against the full evaluation's (`pair_contact`).

use super::tests::wide_overlap;
use super::*;
use num_dual::Dual64;

#[test]
fn a_pairs_distance_alone_is_its_evaluations_distance_to_the_bit() {
    // Clouds overlapping, touching and 5 cm and 30 cm apart, and a cloud over a half-space
    // (in it and above it), at the default ε and at sharp ε1: the same bits as the distance
    // of the full evaluation (forces, spring bounds and kept terms left out), and on dual
    // numbers the same derivative to rounding, which central differences confirm.
    let (a, b, fa, fb, prm) = wide_overlap();
    let floor = Collider::HalfSpace {
        point: Vector3::new(0.0, 0.0, 0.015),
        normal: Vector3::new(0.1, 0.0, 1.0).normalize(),
    };
    let sharp = ContactParams { eps1: 1e-7, ..prm };
    let lifted = |f: &Frame<f64>| Frame::<Dual64> {
        rotation: f.rotation.map(Dual64::from),
        origin: f.origin.map(Dual64::from),
        linvel: f.linvel.map(Dual64::from),
        angvel: f.angvel.map(Dual64::from),
    };
    let mut scratch = Scratch::default();
    let mut cases = 0;
    for planes in [&b, &floor] {
        for prm in [&prm, &sharp] {
            for lift in [0.0, 0.01, 0.05, 0.3] {
                let at = |dz: f64| Frame {
                    origin: fb.origin + Vector3::new(0.0, 0.0, lift + dz),
                    ..fb
                };
                let distance =
                    |dz: f64| pair_distance(&a, &fa, planes, &at(dz), prm, &mut Scratch::default());
                let alone = distance(0.0);
                let full = pair_contact(&a, &fa, planes, &at(0.0), prm).distance;
                assert!(alone.is_finite(), "a distance: {alone}");
                assert_eq!(
                    alone.to_bits(),
                    full.to_bits(),
                    "lift {lift}: {alone} against {full}"
                );
                // The derivative along the lift, on dual numbers, both ways.
                let mut fd = lifted(&at(0.0));
                fd.origin.z = Dual64::new(fd.origin.z.re, 1.0);
                let pd = prm.lift::<Dual64>();
                let dual = pair_distance(&a, &lifted(&fa), planes, &fd, &pd, &mut scratch);
                let dual_full = pair_contact(&a, &lifted(&fa), planes, &fd, &pd).distance;
                // (The duals' value rounds on its own path: within an ulp or two.)
                assert!((dual.re - alone).abs() <= 1e-15 * alone.abs().max(1e-3));
                // The two sum the same terms in another order (the full evaluation chains by
                // hand): the softmin's derivative weighs each term by (Φ_f - D)/ε2, up to
                // ln(N/τ) ≈ 45, over hundreds of terms, so 1e-10 of it is rounding.
                let scale = dual_full.eps.abs().max(1e-3);
                assert!(
                    (dual.eps - dual_full.eps).abs() <= 1e-10 * scale,
                    "lift {lift}: d/dz {} against {}",
                    dual.eps,
                    dual_full.eps
                );
                let h = 1e-6;
                let central = (distance(h) - distance(-h)) / (2.0 * h);
                assert!(
                    (dual.eps - central).abs() <= 1e-5 * scale,
                    "lift {lift}: d/dz {} against central differences {central}",
                    dual.eps
                );
                cases += 1;
            }
        }
    }
    assert_eq!(cases, 16);
}
