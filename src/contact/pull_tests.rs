//! The adhesion actuators' pull on a contact (docs/method.md, departure 9): the plain spring,
//! less the pull within the gap past the margin, its friction unchanged, inside the bounds
//! the pruning and the proofs read.

use super::*;
use num_dual::Dual64;

#[test]
fn an_actuated_pull_acts_within_the_gap_and_leaves_the_spring_and_its_friction_alone() {
    // Sharp ε3 (10 µm) so the plateaus are flat to e^-10; the tolerances are those tails.
    let n = Vector3::z();
    let (k, eps3, pull, gap, margin) = (1e4, 1e-5, 2.0, 5e-4, 2e-3);
    let plain = ContactParams {
        stiffness: k,
        eps3,
        dissipation_velocity: 0.1,
        stiction_velocity: 0.01,
        friction: 0.5,
        margin,
        gap,
        ..ContactParams::default()
    };
    let pulled = ContactParams {
        pull: Some(pull),
        ..plain
    };
    let off = ContactParams {
        pull: Some(0.0),
        ..plain
    };
    let at = |y: f64, v: Vector3<f64>, p: &ContactParams<f64>| {
        point_plane_force_at(margin + y, &n, &v, p)
    };
    let sliding = Vector3::new(0.3, 0.0, -0.01);
    // Switched off, the plain law to the bit, pressed, in the gap and past it.
    for y in [-1e-3, -1e-5, 0.0, 2e-4, 6e-4, 0.01] {
        assert_eq!(at(y, sliding, &off), at(y, sliding, &plain), "{y}");
    }
    // Pressed 1 mm: the plain spring less the pull, the friction the plain one (no budget
    // added: MuJoCo's actuator pulls, its contacts are not adhesive).
    let (a, b) = (at(-1e-3, sliding, &pulled), at(-1e-3, sliding, &plain));
    assert!((a.z - (b.z - pull)).abs() <= 1e-9 * b.z, "{a:?} vs {b:?}");
    assert_eq!(a.x, b.x);
    // In the gap: the pull along -n, no friction.
    for y in [10.0 * eps3, 3e-4, gap - 10.0 * eps3] {
        let f = at(y, sliding, &pulled);
        assert!((f.z + pull).abs() <= 1e-4 * pull, "{y}: {f:?}");
        assert!(f.x.abs() <= 1e-4 * pull, "{y}: {f:?}");
    }
    // Past the gap nothing: e^-40 of the pull 40 ε3 out, exactly 0 past the reach.
    assert!(at(gap + 40.0 * eps3, sliding, &pulled).norm() <= 1e-17 * pull);
    let reach = pulled.bound_margin() - margin + 746.0 * eps3;
    assert_eq!(at(reach * 1.001, sliding, &pulled), Vector3::zeros());
    // The bound the pruning and the proofs read, and the damping passive, as for adhesion.
    let speeds = [(-0.3, 0.1), (0.02, 0.5), (0.4, 0.0)];
    super::tests::assert_bounded_and_passive(|y, v| at(y, v, &pulled), &pulled, 300, &speeds);
    // The derivative with respect to the pull (the actuator's control, through its gain): -W
    // along n, 1 pressed and in the gap, 0 past it.
    let seeded = ContactParams {
        pull: Some(Dual64::new(pull, 1.0)),
        ..plain.lift()
    };
    let lift = |x: Vector3<f64>| x.map(Dual64::from);
    for (y, w) in [(-1e-3, 1.0), (3e-4, 1.0), (gap + 40.0 * eps3, 0.0)] {
        let f = point_plane_force_at(Dual64::from(margin + y), &lift(n), &lift(sliding), &seeded);
        assert!((f.z.eps + w).abs() <= 1e-8, "{y}: {}", f.z.eps); // W to e^-20
        assert_eq!(f.x.eps, 0.0, "{y}");
    }
}
