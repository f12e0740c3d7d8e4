//! Tests of a pair's own law: its stiction velocity held at its floor, its ε1 scaled.

use super::*;
use crate::contact::eps1_scale;
use num_dual::Dual64;

fn pair(friction: Option<f64>, stiction_floor: f64) -> Pair {
    Pair {
        a: 0,
        b: 1,
        friction,
        stiffness: None,
        rest: None,
        dissipation_velocity: None,
        dissipation_force: None,
        hold_separation: false,
        margin: 0.004,
        adhesion: 0.0,
        gap: 0.0,
        stiction_floor,
        surface: None,
        eps1_scale: [1.0; 2],
    }
}

#[test]
fn a_pairs_stiction_velocity_is_held_at_its_floor_and_the_parameter_acts_above() {
    // Floor 0.02 m/s per unit of friction: 0.012 m/s at the pair's own 0.6.
    let prm = ContactParams::default(); // v_s 0.01 m/s, friction 0.5
    let own = pair(Some(0.6), 0.02).params(&prm);
    assert_eq!(own.stiction_velocity, 0.02 * 0.6);
    assert_eq!(own.margin, 0.004);
    let above = ContactParams {
        stiction_velocity: 0.05,
        ..prm
    };
    assert_eq!(pair(Some(0.6), 0.02).params(&above).stiction_velocity, 0.05);
    assert_eq!(pair(Some(0.6), 0.0).params(&prm).stiction_velocity, 0.01);
    // Without its own friction the floor follows the parameter friction, with its
    // derivative: d v_s / d mu = floor where the floor holds, and none from v_s.
    let dual = ContactParams {
        friction: Dual64::new(0.5, 1.0),
        stiction_velocity: Dual64::new(0.01, 0.0),
        ..prm.lift()
    };
    let held = pair(None, 0.04).params(&dual).stiction_velocity;
    assert_eq!((held.re, held.eps), (0.04 * 0.5, 0.04));
    let dual = ContactParams {
        stiction_velocity: Dual64::new(0.05, 1.0),
        ..prm.lift()
    };
    let free = pair(None, 0.04).params(&dual).stiction_velocity;
    assert_eq!((free.re, free.eps), (0.05, 1.0));
}

#[test]
fn each_cloud_reads_eps1_times_its_own_scale_with_its_derivative() {
    // docs/method.md, "ε1 follows the spacing": a cloud at 5 mm is read with a quarter of the
    // parameter, and the derivative with respect to the parameter is that quarter; the other
    // cloud, at 1 cm, with the parameter as it is. Side 0 (a's points) reads b's planes.
    let prm = ContactParams::default();
    let mut fine = pair(None, 0.0);
    fine.eps1_scale = [1.0, eps1_scale(0.005)];
    assert_eq!(fine.eps1_scale, [1.0, 0.25]);
    let dual = ContactParams {
        eps1: Dual64::new(1e-5, 1.0),
        ..prm.lift()
    };
    let [of_b, of_a] = fine.params(&dual).eps1_sides();
    assert_eq!((of_b.re, of_b.eps), (2.5e-6, 0.25));
    assert_eq!((of_a.re, of_a.eps), (1e-5, 1.0));
    assert_eq!(fine.eps1_sides(dual.eps1), [of_b, of_a]);
    // At 1 cm and coarser, and for a non-positive or non-finite length, the parameter as it is.
    for l in [0.01, 0.05, 0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert_eq!(eps1_scale(l), 1.0, "{l}");
    }
    let e = pair(None, 0.0).params(&dual).eps1_sides();
    assert_eq!(e.map(|e| (e.re, e.eps)), [(1e-5, 1.0); 2]);
}

/// A pair's stiffness from the file is sized on its rest, `k = m̂ g / s⁺_ε3(r_g)`, at the
/// contact parameter ε3: to the bit as sized at load at the scene's ε3 (the dual's value
/// included), the law's at another ε3, and its derivative along ε3 against central
/// differences. Where `r_g` is below ε3, `k` is about `m̂ g / (ε3 ln 2)`: it moves with ε3.
#[test]
fn a_pairs_stiffness_is_sized_on_its_rest_at_the_contact_parameter_eps3() {
    let softplus = crate::scalar::softplus::<f64>;
    let (weight, depth, eps3) = (9.81 * 463.0, 2e-7, 1e-4);
    let mut p = pair(None, 0.0);
    p.stiffness = Some(weight / softplus(depth, eps3));
    p.rest = Some([weight, depth]);
    assert_eq!(p.stiffness_at(eps3), p.stiffness);
    assert_eq!(p.stiffness_at(2e-5), Some(weight / softplus(depth, 2e-5)));
    assert!(p.stiffness_at(2e-5).unwrap() > 4.5 * p.stiffness.unwrap());
    let dual = p.stiffness_at(Dual64::new(eps3, 1.0)).unwrap();
    assert_eq!(dual.re, p.stiffness.unwrap());
    for h in [1e-8, 1e-9] {
        let fd =
            (p.stiffness_at(eps3 + h).unwrap() - p.stiffness_at(eps3 - h).unwrap()) / (2.0 * h);
        assert!(
            (dual.eps - fd).abs() <= 1e-6 * fd.abs(),
            "{h}: {} against {fd}",
            dual.eps
        );
    }
    // Without a rest, the stiffness as it is, whatever ε3.
    p.rest = None;
    assert_eq!(p.stiffness_at(2e-5), p.stiffness);
    let params = p.params(&ContactParams {
        eps3: 2e-5,
        ..Default::default()
    });
    assert_eq!(Some(params.stiffness), p.stiffness);
}
