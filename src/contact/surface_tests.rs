//! Tests of the moving surfaces' flow (MuJoCo's geom `surfacevel`; docs/method.md,
//! departure 8): at rest it is the paper's law to the bit, it drags along the flow in the
//! tangent plane only, it is the same as moving the other body the other way where the flow is
//! tangent, and its derivatives are exact.

use super::tests::wide_overlap;
use super::*;
use crate::collision::Twist;
use num_dual::Dual64;

fn twist(lin: [f64; 3], ang: [f64; 3]) -> Twist<f64> {
    Twist {
        lin: Vector3::from(lin),
        ang: Vector3::from(ang),
    }
}

fn bits(c: &PairContact<f64>) -> Vec<u64> {
    [c.on_a.force, c.on_a.torque, c.on_b.force, c.on_b.torque]
        .iter()
        .flat_map(|v| v.iter().copied())
        .chain([c.distance])
        .map(f64::to_bits)
        .collect()
}

/// A 4 cm × 6 cm × 2 cm box sunk 0.5 mm into a half-space at z = 0 (its body turning slowly
/// about z), the box at rest or moving as `linvel`, `angvel`.
fn box_on_ground(
    linvel: Vector3<f64>,
    angvel: Vector3<f64>,
) -> (Collider, Frame<f64>, Collider, Frame<f64>) {
    use crate::geometry::Shape;
    let cube = Collider::Aopc(
        Shape::Box {
            half: Vector3::new(0.02, 0.03, 0.01),
        }
        .sample(0.005),
    );
    let ground = Collider::HalfSpace {
        point: Vector3::zeros(),
        normal: Vector3::z(),
    };
    let on = Frame {
        rotation: *nalgebra::Rotation3::from_euler_angles(0.0, 0.0, 0.4).matrix(),
        origin: Vector3::new(0.3, -0.2, 0.0095),
        linvel,
        angvel,
    };
    (cube, on, ground, Frame::identity())
}

fn close(x: &PairContact<f64>, y: &PairContact<f64>, tol: f64) -> bool {
    let scale = x.on_a.force.norm().max(1e-9);
    [
        (x.on_a.force - y.on_a.force).norm(),
        (x.on_b.force - y.on_b.force).norm(),
        (x.on_a.torque - y.on_a.torque).norm(),
        (x.on_b.torque - y.on_b.torque).norm(),
    ]
    .iter()
    .all(|d| *d <= tol * scale)
}

#[test]
fn a_surface_at_rest_is_the_paper_law_to_the_bit() {
    // Two still flows: the friction reads `v + 0`, projected, which is `v`'s own projection in
    // every bit; pruned, naive and replayed alike.
    let (a, b, fa, fb, prm) = wide_overlap();
    let still = ContactParams {
        surface: Some([twist([0.0; 3], [0.0; 3]); 2]),
        ..prm
    };
    assert_eq!(
        bits(&pair_contact(&a, &fa, &b, &fb, &prm)),
        bits(&pair_contact(&a, &fa, &b, &fb, &still))
    );
    assert_eq!(
        bits(&pair_contact_naive(&a, &fa, &b, &fb, &prm)),
        bits(&pair_contact_naive(&a, &fa, &b, &fb, &still))
    );
    let mut scratch = Scratch::default();
    let (tape, _) = PairTape::record(&a, &fa, &b, &fb, &prm, None, &mut scratch);
    let (still_tape, _) = PairTape::record(&a, &fa, &b, &fb, &still, None, &mut scratch);
    let other = Frame {
        linvel: Vector3::new(0.1, 0.2, -0.3),
        ..fa
    };
    let w = tape.replay(&a, &other, &b, &fb, &prm);
    let w_still = still_tape.replay(&a, &other, &b, &fb, &still);
    for (x, y) in w.iter().zip(&w_still) {
        assert_eq!(x.force.map(f64::to_bits), y.force.map(f64::to_bits));
        assert_eq!(x.torque.map(f64::to_bits), y.torque.map(f64::to_bits));
    }
}

#[test]
fn a_belt_drags_along_its_flow_in_the_tangent_plane_as_if_the_box_slid_back() {
    // A still box on a half-space whose surface flows at 0.5 m/s along x: the friction drags
    // the box along x with about μ times the normal force (0.5 m/s is 50 stiction velocities),
    // the normal force is the one without a flow (the flow's normal part, 0.3 m/s here, is not
    // read), and the contact is the one of the box sliding back at 0.5 m/s on a still surface.
    let prm = ContactParams::default();
    let (cube, on, ground, world) = box_on_ground(Vector3::zeros(), Vector3::zeros());
    let belt = ContactParams {
        surface: Some([twist([0.0; 3], [0.0; 3]), twist([0.5, 0.0, 0.3], [0.0; 3])]),
        ..prm
    };
    let still = pair_contact(&cube, &on, &ground, &world, &prm);
    let moved = pair_contact(&cube, &on, &ground, &world, &belt);
    let normal = still.on_a.force.z;
    assert!(normal > 1.0, "the box is pressed ({normal} N)");
    assert!((moved.on_a.force.z - normal).abs() <= 1e-12 * normal);
    let drag = moved.on_a.force.x / (prm.friction * normal);
    assert!(drag > 0.999 && drag <= 1.0, "μ N along the flow: {drag}");
    assert!(moved.on_a.force.y.abs() <= 1e-12 * normal);
    let (_, back, _, _) = box_on_ground(Vector3::new(-0.5, 0.0, 0.0), Vector3::zeros());
    let sliding = pair_contact(&cube, &back, &ground, &world, &prm);
    assert!(close(&moved, &sliding, 1e-12));
    // The naive evaluation agrees with the pruned one (its skipped terms: 1e-9).
    assert!(close(
        &moved,
        &pair_contact_naive(&cube, &on, &ground, &world, &belt),
        1e-9
    ));
}

#[test]
fn a_turntable_carries_a_box_round_as_if_the_box_turned_the_other_way() {
    // A half-space whose surface turns at 2 rad/s about z through its origin (a turntable)
    // under a still box 0.36 m off its axis: the same contact as the box turning at -2 rad/s
    // about that axis on a still surface (its origin moving at -ω × o), the flow being tangent
    // to the plane everywhere. And a flow on the box's own surface, expressed in the box's
    // frame, acts as the opposite flow on the ground: the field is carried between frames.
    let prm = ContactParams::default();
    let (cube, on, ground, world) = box_on_ground(Vector3::zeros(), Vector3::zeros());
    let w = Vector3::new(0.0, 0.0, 2.0);
    let table = ContactParams {
        surface: Some([twist([0.0; 3], [0.0; 3]), twist([0.0; 3], w.into())]),
        ..prm
    };
    let carried = pair_contact(&cube, &on, &ground, &world, &table);
    let (_, turning, _, _) = box_on_ground(-w.cross(&on.origin), -w);
    let turned = pair_contact(&cube, &turning, &ground, &world, &prm);
    assert!(carried.on_a.force.norm() > 1.0);
    assert!(close(&carried, &turned, 1e-12));
    // The ground's flow written instead as the box's own, opposite, in the box's frame: its
    // value at a box point `y` is `Rᵀ(-ω × (R y + o))`.
    let r = on.rotation;
    let own = twist(
        (r.transpose() * -w.cross(&on.origin)).into(),
        (r.transpose() * -w).into(),
    );
    let on_box = ContactParams {
        surface: Some([own, twist([0.0; 3], [0.0; 3])]),
        ..prm
    };
    assert!(close(
        &carried,
        &pair_contact(&cube, &on, &ground, &world, &on_box),
        1e-12
    ));
}

#[test]
fn a_moving_surfaces_pair_derivatives_equal_central_differences() {
    // Both bodies' surfaces flowing (belt and turning parts): the pair's wrenches on dual
    // numbers (the generic path: the hand-derived Jacobian is the paper's law's) against
    // central differences, along a position, an orientation and a velocity of each body.
    // Step 1e-7; bound 1e-6 of the largest derivative entry (the differences' truncation) and
    // 1e-7 of the largest wrench entry (their rounding and the pruning's noise, about 1e-14 of
    // the wrenches over the step). Measured: 1.6e-6 to 3.7e-6 off, wrenches of 156 N.
    let (a, b, fa, fb, prm) = wide_overlap();
    let prm = ContactParams {
        surface: Some([
            twist([0.05, -0.02, 0.01], [0.0, 0.0, 3.0]),
            twist([-0.1, 0.0, 0.02], [1.0, -0.5, 0.0]),
        ]),
        ..prm
    };
    let rot = |f: &Frame<f64>, t: f64| {
        f.rotation * *nalgebra::Rotation3::from_euler_angles(t, 0.5 * t, -t).matrix()
    };
    type Move = fn(&mut Frame<f64>, f64);
    let moves: [(&str, Move); 4] = [
        ("a's origin x", |f, t| f.origin.x += t),
        ("a's origin z", |f, t| f.origin.z += t),
        ("a's linvel y", |f, t| f.linvel.y += t),
        ("a's angvel z", |f, t| f.angvel.z += t),
    ];
    let flat = |c: &PairContact<f64>| -> Vec<f64> {
        [c.on_a.force, c.on_a.torque, c.on_b.force, c.on_b.torque]
            .iter()
            .flat_map(|v| v.iter().copied())
            .collect()
    };
    let lift = |f: &Frame<f64>| Frame::<Dual64> {
        rotation: f.rotation.map(Dual64::from),
        origin: f.origin.map(Dual64::from),
        linvel: f.linvel.map(Dual64::from),
        angvel: f.angvel.map(Dual64::from),
    };
    let live = pair_contact(&a, &fa, &b, &fb, &prm);
    // Damped Euler's tape replays the flows too: at the recorded motion, the same bits.
    let (tape, recorded) = PairTape::record(&a, &fa, &b, &fb, &prm, None, &mut Scratch::default());
    assert_eq!(bits(&recorded), bits(&live));
    let replayed = tape.replay(&a, &fa, &b, &fb, &prm);
    assert_eq!(
        replayed[0].force.map(f64::to_bits),
        live.on_a.force.map(f64::to_bits)
    );
    assert_eq!(
        replayed[1].torque.map(f64::to_bits),
        live.on_b.torque.map(f64::to_bits)
    );
    let value = flat(&live);
    let scale = value.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let h = 1e-7;
    let check = |name: &str, dual: Vec<f64>, plus: Vec<f64>, minus: Vec<f64>| {
        let cd: Vec<f64> = plus
            .iter()
            .zip(&minus)
            .map(|(p, m)| (p - m) / (2.0 * h))
            .collect();
        let size = cd.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(
            size > 1e-3 * scale,
            "{name}: the wrenches move ({size} against {scale})"
        );
        for (d, c) in dual.iter().zip(&cd) {
            let bound = 1e-6 * size + 1e-7 * scale;
            assert!((d - c).abs() <= bound, "{name}: dual {d} against {c}");
        }
    };
    for (name, step) in moves {
        let at = |t: f64| {
            let mut g = fa;
            step(&mut g, t);
            flat(&pair_contact(&a, &g, &b, &fb, &prm))
        };
        let mut da = lift(&fa);
        let seed = |x: &mut Dual64| *x = Dual64::new(x.re, 1.0);
        match name {
            "a's origin x" => seed(&mut da.origin.x),
            "a's origin z" => seed(&mut da.origin.z),
            "a's linvel y" => seed(&mut da.linvel.y),
            _ => seed(&mut da.angvel.z),
        }
        let dual = pair_contact(&a, &da, &b, &lift(&fb), &prm.lift());
        let d: Vec<f64> = [
            dual.on_a.force,
            dual.on_a.torque,
            dual.on_b.force,
            dual.on_b.torque,
        ]
        .iter()
        .flat_map(|v| v.iter().map(|x| x.eps))
        .collect();
        check(name, d, at(h), at(-h));
    }
    // b's orientation: R(t) = R Rx(t) Ry(t/2) Rz(-t) on duals through the same formula.
    let mut db = lift(&fb);
    let t = Dual64::new(0.0, 1.0);
    let turn = nalgebra::Rotation3::from_euler_angles(t, t * 0.5, -t);
    db.rotation *= turn.matrix();
    let at = |s: f64| {
        let g = Frame {
            rotation: rot(&fb, s),
            ..fb
        };
        flat(&pair_contact(&a, &fa, &b, &g, &prm))
    };
    let dual = pair_contact(&a, &lift(&fa), &b, &db, &prm.lift());
    let d: Vec<f64> = [
        dual.on_a.force,
        dual.on_a.torque,
        dual.on_b.force,
        dual.on_b.torque,
    ]
    .iter()
    .flat_map(|v| v.iter().map(|x| x.eps))
    .collect();
    check("b's orientation", d, at(h), at(-h));
}
