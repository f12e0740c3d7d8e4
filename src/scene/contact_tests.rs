//! Tests of each pair's law from `solref` and `solimp` (`super`).

use super::*;

#[test]
fn impedance_follows_the_power_curve_between_its_ends() {
    let s = Softness::default();
    assert_eq!(s.impedance(0.0), 0.9);
    assert_eq!(s.impedance(0.002), 0.95);
    // Midpoint: half-way; a quarter of the width: y = 0.25² / 0.5 = 0.125.
    assert!((s.impedance(0.0005) - 0.925).abs() < 1e-15);
    assert!((s.impedance(0.00025) - (0.9 + 0.125 * 0.05)).abs() < 1e-15);
    // Past the midpoint: y = 1 - 0.25² / 0.5 = 0.875.
    assert!((s.impedance(0.00075) - (0.9 + 0.875 * 0.05)).abs() < 1e-15);
    let flat = Softness {
        solimp: [0.8, 0.8, 0.001, 0.5, 2.0],
        ..s
    };
    assert_eq!(flat.impedance(0.0007), 0.8);
}

#[test]
fn resting_depth_solves_the_static_law() {
    let s = Softness::default();
    let r = s.resting_depth(9.81, None);
    let (k, b) = s.reference(None);
    let d = s.impedance(r);
    assert!((r * d * d / (1.0 - d) - 9.81 / k).abs() < 1e-12 * 9.81 / k);
    // MuJoCo 4.0's default contact rests at 0.367 mm whatever the mass (measured: a sphere
    // on a plane), with d = 0.9135.
    assert!((r - 3.67e-4).abs() < 1e-6, "{r}");
    assert!((d - 0.9135).abs() < 1e-3, "{d}");
    assert!((k - 1.0 / (0.95f64 * 0.95 * 0.02 * 0.02)).abs() < 1e-9 * k);
    assert!((b - 2.0 / (0.95 * 0.02)).abs() < 1e-12 * b);
    assert!((s.damping_ratio(None) - 1.0).abs() < 1e-12);
}

#[test]
fn refsafe_holds_the_time_constant_at_twice_the_step() {
    let s = Softness::default();
    assert_eq!(s.reference(Some(0.005)), s.reference(None));
    let slow = Softness {
        solref: [0.04, 1.0],
        ..s
    };
    assert_eq!(s.reference(Some(0.02)), slow.reference(None));
    // Direct stiffness and damping are not held.
    let direct = Softness {
        solref: [-1e4, -100.0],
        ..s
    };
    assert_eq!(direct.reference(Some(0.02)), direct.reference(None));
    let (k, b) = direct.reference(None);
    assert!((k - 1e4 / 0.9025).abs() < 1e-9 && (b - 100.0 / 0.95).abs() < 1e-12);
    assert!((direct.damping_ratio(None) - 0.5).abs() < 1e-12);
}

#[test]
fn the_pair_law_holds_the_weight_at_the_resting_depth_with_mujocos_damping() {
    // Cone shares: an elliptic cone's (or μ = 1 in a pyramid), a pyramid at μ 0.9 and 1.9.
    for ((mass, zeta), cone) in [(0.1, 1.0), (1.0, 0.5), (40.0, 2.0)]
        .into_iter()
        .flat_map(|m| [1.0, 1.364, 0.120].map(|c| (m, c)))
    {
        let s = Softness {
            solref: [0.02, zeta],
            ..Softness::default()
        };
        let eps3 = 1e-4;
        for f in [None, Some(4.0)] {
            let law = PairLaw::new(s, mass, cone, 9.81, eps3, None, f);
            // The spring k s⁺(r) carries m̂ g at r: checked against a direct evaluation.
            let spring = |r: f64| law.stiffness * eps3 * (r / eps3).exp().ln_1p();
            assert!((spring(law.depth) - mass * 9.81).abs() < 1e-9 * mass * 9.81);
            // The damping at rest, c / V(c) with c = k s⁺(r) and V(c) = v_d (1 + c/F_d) (the
            // factor's slope is -1 at zero speed), is MuJoCo's there: m̂ d(r) B, with
            // B = 2 / (dmax τ); F_d is f times the weight, and the damping's bound F_d / v_d
            // is (1 + f) times the resting value.
            let rest = spring(law.depth);
            let c = rest / (law.dissipation_velocity * (1.0 + rest / law.dissipation_force));
            match f {
                Some(f) => {
                    let weight = mass * 9.81;
                    assert!((law.dissipation_force - f * weight).abs() < 1e-12 * f * weight);
                    let bound = law.dissipation_force / law.dissipation_velocity;
                    assert!((bound - (1.0 + f) * c).abs() < 1e-9 * bound);
                }
                None => assert_eq!(law.dissipation_force, f64::INFINITY),
            }
            // MuJoCo's normal in the cone: regularized by R / c, its impedance d' has
            // (1 - d') / d' = (1 - d) / (c d).
            let d = s.impedance(law.depth);
            let d_cone = 1.0 / (1.0 + (1.0 - d) / (cone * d));
            let mujoco = mass * d_cone * 2.0 / (0.95 * 0.02);
            assert!((c - mujoco).abs() < 1e-9 * mujoco, "{c} vs {mujoco}");
            // At rest the cone's regularized force carries the weight: c d²/(1 - d) r K = g.
            let k_ref = 1.0 / (0.95f64 * 0.95 * 0.02 * 0.02 * zeta * zeta);
            let held = cone * d * d / (1.0 - d) * law.depth * k_ref;
            assert!((held - 9.81).abs() < 1e-9 * 9.81, "{held}");
            // The depth does not depend on the mass, the stiffness is proportional to it.
            assert!((law.depth - s.resting_depth(9.81 / cone, None)).abs() < 1e-15);
        }
    }
}

/// The pyramid's share of the normal against one row (MuJoCo's `mj_makeImpedance`): the
/// normal match at μ = 1 for condim 3, `(n - 1) impratio / (μ² (1 + μ²))` otherwise, and none
/// for an elliptic cone or a frictionless contact.
#[test]
fn the_cone_share_is_mujocos_pyramid_against_one_row() {
    let pyramid = Cone::default();
    let elliptic = Cone {
        elliptic: true,
        ..Cone::default()
    };
    let share = |cone, mu, n| cone_share(cone, mu, n);
    assert_eq!(share(pyramid, 1.0, 3), 1.0);
    assert!((share(pyramid, 0.9, 3) - 2.0 / (0.81 * 1.81)).abs() < 1e-15);
    assert!((share(pyramid, 1.9, 3) - 2.0 / (3.61 * 4.61)).abs() < 1e-15);
    assert!((share(pyramid, 1.0, 4) - 1.5).abs() < 1e-15);
    assert!((share(pyramid, 1.0, 6) - 2.5).abs() < 1e-15);
    let stiffer = Cone {
        impratio: 10.0,
        ..Cone::default()
    };
    assert!((share(stiffer, 1.0, 3) - 10.0).abs() < 1e-14);
    for (cone, mu, n) in [(elliptic, 1.9, 3), (pyramid, 1.9, 1), (pyramid, 0.0, 3)] {
        assert_eq!(share(cone, mu, n), 1.0);
    }
}

#[test]
fn mixing_follows_priority_then_solmix() {
    let soft = |tau: f64, d0: f64, solmix: f64, priority: i32| GeomSoftness {
        softness: Softness {
            solref: [tau, 1.0],
            solimp: [d0, 0.95, 0.001, 0.5, 2.0],
        },
        solmix,
        priority,
    };
    let (a, b) = (soft(0.01, 0.8, 1.0, 0), soft(0.03, 0.9, 3.0, 0));
    let m = mix(&a, &b);
    assert!((m.solref[0] - (0.25 * 0.01 + 0.75 * 0.03)).abs() < 1e-15);
    assert!((m.solimp[0] - (0.25 * 0.8 + 0.75 * 0.9)).abs() < 1e-15);
    assert_eq!(mix(&a, &b), mix(&b, &a));
    // A higher priority gives its values whole.
    let high = soft(0.05, 0.5, 1.0, 1);
    assert_eq!(mix(&a, &high), high.softness);
    assert_eq!(mix(&high, &b), high.softness);
    // Both solmix zero: half and half; one zero: the other's.
    let (z1, z2) = (soft(0.01, 0.8, 0.0, 0), soft(0.03, 0.9, 0.0, 0));
    assert!((mix(&z1, &z2).solref[0] - 0.02).abs() < 1e-15);
    assert_eq!(mix(&z1, &b).solref, b.softness.solref);
    // Direct (negative) values: the smaller of each entry.
    let direct = GeomSoftness {
        softness: Softness {
            solref: [-5e3, -20.0],
            ..Softness::default()
        },
        ..GeomSoftness::default()
    };
    assert_eq!(mix(&direct, &a).solref, [-5e3, -20.0]);
    let g = GeomSoftness::default();
    assert_eq!(mix(&g, &a).solref, [0.015, 1.0]);
}
