//! The tape's velocity Jacobian (`PairTape::replay_seeded`): point forces on width-3 duals
//! chained by hand, against the replay on width-12 duals throughout.

use super::tests::wide_overlap;
use super::*;
use crate::collision::Twist;
use crate::scalar::{derivatives, seeded};

#[test]
fn a_tapes_seeded_replay_gives_the_width_12_replays_derivatives() {
    // The velocity Jacobian summed point by point on width 3 and chained
    // (`PairTape::replay_seeded`) against the replay on width-12 duals throughout: a pair of
    // clouds (terms recorded, and all of them past a budget of 0), a cloud on a half-space, and
    // both with moving surfaces; every derivative to rounding.
    let seed = |f: &Frame<f64>, first: usize| Frame::<Seeds> {
        rotation: f.rotation.map(Seeds::from_re),
        origin: f.origin.map(Seeds::from_re),
        linvel: Vector3::from_fn(|k, _| seeded(f.linvel[k], Some(first + k))),
        angvel: Vector3::from_fn(|k, _| seeded(f.angvel[k], Some(first + 3 + k))),
    };
    let matrix = |w: &[Wrench<Seeds>; 2]| {
        let rows: Vec<[f64; 12]> = w
            .iter()
            .flat_map(|x| x.force.iter().chain(x.torque.iter()))
            .map(derivatives)
            .collect();
        nalgebra::DMatrix::from_fn(12, 12, |i, j| rows[i][j])
    };
    let (a, b, fa, fb, prm) = wide_overlap();
    let floor = Collider::HalfSpace {
        point: Vector3::new(0.0, 0.0, 0.015),
        normal: Vector3::new(0.1, 0.0, 1.0).normalize(),
    };
    let moving = ContactParams {
        surface: Some([
            Twist {
                lin: Vector3::new(0.05, -0.02, 0.0),
                ang: Vector3::new(0.0, 0.3, 0.1),
            },
            Twist {
                lin: Vector3::zeros(),
                ang: Vector3::new(-0.2, 0.0, 0.0),
            },
        ]),
        ..prm
    };
    let mut cases = 0;
    for (b, prm) in [(&b, &prm), (&floor, &prm), (&b, &moving), (&floor, &moving)] {
        for budget in [usize::MAX, 0] {
            let (tape, w) = PairTape::record_within(
                &a,
                &fa,
                b,
                &fb,
                prm,
                (None, &mut Scratch::default()),
                budget,
            );
            assert!(w.on_a.force.norm() > 1e-3, "in contact: {w:?}");
            let (sa, sb) = (seed(&fa, 0), seed(&fb, 6));
            let ours = matrix(&tape.replay_seeded(&a, &sa, b, &sb, prm));
            let wide = matrix(&tape.replay(&a, &sa, b, &sb, &prm.lift()));
            let gap = (&ours - &wide).amax();
            assert!(wide.amax() > 1.0, "the velocities act: {}", wide.amax());
            assert!(
                gap <= 1e-13 * wide.amax(),
                "budget {budget}: {gap:e} of {:e}",
                wide.amax()
            );
            cases += 1;
        }
    }
    assert_eq!(cases, 8);
}
