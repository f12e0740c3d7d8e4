//! SSDF–SSDF contact between two spheres and between a box and a plane: direction, action and
//! reaction, derivatives, degenerate configurations.

use crate::common::{central_difference, pair_outputs, Lcg};
use nalgebra::{Matrix3, Rotation3, Vector3};
use num_dual::Dual64;
use scm::collision::{Collider, Frame, Scratch};
use scm::contact::{pair_contact, pair_pressing, ContactParams, Dissipation, PairContact};
use scm::geometry::Shape;
use scm::scalar::Scalar;

fn big() -> Collider {
    Collider::Aopc(Shape::Sphere { radius: 0.1 }.sample(0.02))
}
fn small() -> Collider {
    Collider::Aopc(Shape::Sphere { radius: 0.05 }.sample(0.01))
}

fn frame<T: Scalar>(origin: Vector3<T>, linvel: Vector3<T>) -> Frame<T> {
    Frame {
        rotation: Matrix3::identity(),
        origin,
        linvel,
        angvel: Vector3::zeros(),
    }
}

fn params() -> ContactParams<f64> {
    ContactParams {
        eps1: 1e-5,
        eps1_scale: [1.0; 2],
        eps2: 1e-3,
        eps3: 1e-4,
        stiffness: 1e4,
        dissipation_velocity: 0.1,
        stiction_velocity: 0.05,
        friction: 0.5,
        dissipation_force: f64::INFINITY,
        hold_separation: false,
        margin: 0.0,
        adhesion: 0.0,
        gap: 0.0,
        pull: None,
        surface: None,
        dissipation: Dissipation::Paper,
    }
}

/// Contact between the big sphere at the origin and the small one at `x` moving with `v`.
fn spheres<T: Scalar>(x: [T; 3], v: [T; 3], prm: &ContactParams<T>) -> PairContact<T> {
    let o = frame(Vector3::zeros(), Vector3::zeros());
    pair_contact(
        &big(),
        &o,
        &small(),
        &frame(Vector3::from(x), Vector3::from(v)),
        prm,
    )
}

#[test]
fn overlapping_spheres_repel_along_the_line_of_centres() {
    let mut rng = Lcg(5);
    for _ in 0..20 {
        let dir = rng.direction();
        let depth = rng.range(0.001, 0.02);
        let x = dir * (0.15 - depth);
        let c = spheres([x.x, x.y, x.z], [0.0; 3], &params());
        let on_small = c.on_b.force;
        assert!(
            on_small.dot(&dir) > 0.0,
            "not repelling: {on_small:?} for {dir:?}"
        );
        // Along the line of centres, up to the facets of the sampled spheres.
        let angle = on_small.angle(&dir);
        assert!(
            angle < 0.15,
            "force {on_small:?} is {angle} rad off the line of centres {dir:?}"
        );
        assert!(
            c.distance < 0.0,
            "smooth distance {} for depth {depth}",
            c.distance
        );
    }
}

#[test]
fn action_equals_reaction() {
    let mut rng = Lcg(9);
    for _ in 0..20 {
        let x = rng.direction() * rng.range(0.0, 0.2);
        let v = rng.direction() * rng.range(0.0, 0.5);
        let c = spheres([x.x, x.y, x.z], [v.x, v.y, v.z], &params());
        let scale = c.on_a.force.norm().max(1e-300);
        assert!(
            (c.on_a.force + c.on_b.force).norm() <= 1e-12 * scale,
            "{:?} vs {:?}",
            c.on_a.force,
            c.on_b.force
        );
    }
}

#[test]
fn concentric_and_coincident_bodies_give_finite_values() {
    // Concentric spheres: the paper's unstable equilibrium, where the force vanishes by symmetry.
    let c = spheres([0.0; 3], [0.0; 3], &params());
    assert!(
        c.on_a
            .force
            .iter()
            .chain(c.on_a.torque.iter())
            .all(|x| x.is_finite())
            && c.distance.is_finite()
    );
    assert!(
        c.on_b.force.norm() < 1e-6 * params().stiffness * 0.05,
        "{:?}",
        c.on_b.force
    );
    // Two identical bodies at the same place: every point coincides with a plane point.
    let s = small();
    let f = frame(Vector3::new(1e5, -2e5, 3e5), Vector3::zeros());
    let c = pair_contact(&s, &f, &s, &f, &params());
    assert!(
        c.on_a
            .force
            .iter()
            .chain(c.on_b.torque.iter())
            .all(|x| x.is_finite())
            && c.distance.is_finite(),
        "{c:?}"
    );
}

#[test]
fn far_from_the_origin_nothing_changes() {
    // Distances are taken in a body's frame: moving the pair 1e5 m away changes nothing
    // beyond the rounding of the positions themselves (1e5 m has an ulp of 1.5e-11 m).
    let x = [0.02, 0.13, -0.01];
    let near = spheres(x, [0.0; 3], &params());
    let shift = Vector3::new(1e5, 1e5, -1e5);
    let far = pair_contact(
        &big(),
        &frame(shift, Vector3::zeros()),
        &small(),
        &frame(shift + Vector3::from(x), Vector3::zeros()),
        &params(),
    );
    assert!(
        (near.on_b.force - far.on_b.force).norm() < 1e-6 * near.on_b.force.norm(),
        "{:?} vs {:?}",
        near.on_b.force,
        far.on_b.force
    );
}

#[test]
fn box_on_a_plane_is_pushed_up_and_rotation_changes_nothing_at_rest() {
    let plane = Collider::HalfSpace {
        point: Vector3::zeros(),
        normal: Vector3::z(),
    };
    let boxc = Collider::Aopc(
        Shape::Box {
            half: Vector3::new(0.05, 0.05, 0.05),
        }
        .sample(0.01),
    );
    let f = Frame {
        rotation: Matrix3::identity(),
        origin: Vector3::new(0.0, 0.0, 0.049),
        linvel: Vector3::zeros(),
        angvel: Vector3::zeros(),
    };
    let c = pair_contact(&boxc, &f, &plane, &Frame::identity(), &params());
    assert!(
        c.on_a.force.z > 0.0
            && c.on_a.force.x.abs() < 1e-9 * c.on_a.force.z
            && c.on_a.force.y.abs() < 1e-9 * c.on_a.force.z
    );
    // A quarter turn about z maps the box onto itself.
    let r =
        Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2).into_inner();
    let c2 = pair_contact(
        &boxc,
        &Frame { rotation: r, ..f },
        &plane,
        &Frame::identity(),
        &params(),
    );
    assert!((c.on_a.force - c2.on_a.force).norm() < 1e-9 * c.on_a.force.norm());
    assert!(
        (c.distance - (-0.001)).abs() < 1e-4,
        "distance {}",
        c.distance
    );
}

#[test]
fn pair_derivatives_match_central_differences() {
    // Inputs: the small sphere's position (3) and velocity (3), then the seven parameters.
    let mut rng = Lcg(21);
    let prm = params();
    let names = [
        "x",
        "y",
        "z",
        "vx",
        "vy",
        "vz",
        "eps1",
        "eps2",
        "eps3",
        "stiffness",
        "dissipation_velocity",
        "stiction_velocity",
        "friction",
    ];
    for state in 0..6 {
        // Every other state with the dissipation force holding a separation (departure 4).
        let hold = state % 2 == 1;
        let x = rng.direction() * rng.range(0.13, 0.16);
        let v = rng.direction() * rng.range(0.0, 0.2);
        let base = [
            x.x,
            x.y,
            x.z,
            v.x,
            v.y,
            v.z,
            prm.eps1,
            prm.eps2,
            prm.eps3,
            prm.stiffness,
            prm.dissipation_velocity,
            prm.stiction_velocity,
            prm.friction,
        ];
        let eval = |inp: &[f64]| -> Vec<f64> {
            let p = ContactParams {
                eps1: inp[6],
                eps1_scale: [1.0; 2],
                eps2: inp[7],
                eps3: inp[8],
                stiffness: inp[9],
                dissipation_velocity: inp[10],
                stiction_velocity: inp[11],
                friction: inp[12],
                dissipation_force: 4.0,
                hold_separation: hold,
                margin: 0.004,
                adhesion: 0.0,
                gap: 0.0,
                pull: None,
                surface: None,
                dissipation: Dissipation::Paper,
            };
            pair_outputs(&spheres(
                [inp[0], inp[1], inp[2]],
                [inp[3], inp[4], inp[5]],
                &p,
            ))
        };
        for k in 0..base.len() {
            let mut d: Vec<Dual64> = base.iter().map(|&b| Dual64::from(b)).collect();
            d[k].eps = 1.0;
            let p = ContactParams {
                eps1: d[6],
                eps1_scale: [1.0; 2],
                eps2: d[7],
                eps3: d[8],
                stiffness: d[9],
                dissipation_velocity: d[10],
                stiction_velocity: d[11],
                friction: d[12],
                dissipation_force: Dual64::from(4.0),
                hold_separation: hold,
                margin: Dual64::from(0.004),
                adhesion: 0.0,
                gap: 0.0,
                pull: None,
                surface: None,
                dissipation: Dissipation::Paper,
            };
            let exact: Vec<f64> =
                pair_outputs(&spheres([d[0], d[1], d[2]], [d[3], d[4], d[5]], &p))
                    .iter()
                    .map(|o| o.eps)
                    .collect();
            let h = 1e-6 * base[k].abs().max(1e-3);
            let values = eval(&base);
            for (i, e) in exact.iter().enumerate() {
                let fd = central_difference(|inp| eval(inp)[i], &base, k, h);
                // Relative to the output's own scale times the input's, so tiny entries of a
                // large vector are not held to more digits than differences can give.
                let scale =
                    values.iter().map(|x| x.abs()).fold(0.0, f64::max) / base[k].abs().max(1e-3);
                assert!(
                    (e - fd).abs() <= 1e-5 * (fd.abs() + scale) + 1e-9,
                    "d output {i} / d {} (hold {hold}): dual {e} vs fd {fd}",
                    names[k]
                );
            }
        }
    }
}

/// The pair's outputs for the 18 motion inputs `z` (generic over the scalar): body b's
/// origin, linear velocity, angular velocity and rotation vector (applied after a fixed tilt),
/// then body a's origin and angular velocity (a keeps a fixed tilt and linear velocity).
fn moving_pair<T: Scalar>(
    a: &Collider,
    b: &Collider,
    z: &[T],
    prm: &ContactParams<T>,
    generic: bool,
) -> PairContact<T> {
    let v3 = |i: usize| Vector3::new(z[i], z[i + 1], z[i + 2]);
    let tilt_b = Rotation3::from_euler_angles(0.3, -0.2, 0.5)
        .into_inner()
        .map(scm::scalar::c::<T>);
    let tilt_a = Rotation3::from_euler_angles(-0.1, 0.05, 0.2)
        .into_inner()
        .map(scm::scalar::c::<T>);
    let fb = Frame {
        rotation: tilt_b * Rotation3::from_scaled_axis(v3(9)).into_inner(),
        origin: v3(0),
        linvel: v3(3),
        angvel: v3(6),
    };
    let fa = Frame {
        rotation: tilt_a,
        origin: v3(12),
        linvel: Vector3::new(0.01, -0.02, 0.0).map(scm::scalar::c::<T>),
        angvel: v3(15),
    };
    if generic {
        scm::contact::pair_contact_generic(a, &fa, b, &fb, prm)
    } else {
        pair_contact(a, &fa, b, &fb, prm)
    }
}

/// The box of [`hand_jacobian_matches_the_generic_duals_and_central_differences`]'s first
/// case (20 × 12 × 6 cm) with only its top and bottom faces: beside the top face's edge its
/// planes read a point in their plane as touching, however far out it is, the SSDF's far
/// field at its worst (robot meshes show it at the edges of their flat faces).
fn open_box() -> Collider {
    let Collider::Aopc(full) = closed_box() else {
        unreachable!()
    };
    Collider::Aopc(full.retain(|p| p.z.abs() > 0.029))
}

fn closed_box() -> Collider {
    Collider::Aopc(
        Shape::Box {
            half: Vector3::new(0.1, 0.06, 0.03),
        }
        .sample(0.01),
    )
}

/// The points, normals and areas of `cloud` alone: no faces, so no polytope bounds its planes.
fn without_polytope(cloud: &scm::geometry::Aopc) -> Collider {
    Collider::Aopc(scm::geometry::Aopc::new(
        cloud.points.clone(),
        cloud.normals.clone(),
        cloud.areas.clone(),
        Vec::new(),
        Vec::new(),
    ))
}

#[test]
fn a_plane_reads_no_closer_than_the_polytope_proves() {
    // A ball 4 cm beside the open box's top edge, in the face's plane: the top face's planes
    // read its nearest point as touching (the raw SSDF there is within 1 mm of zero) and,
    // unbounded, push it with newtons. The polytope proves 4 cm less its margin; with its
    // floor the pair does not push, and its distance is centimetres.
    let open = open_box();
    let Collider::Aopc(cloud) = &open else {
        unreachable!()
    };
    let ball = small();
    let prm = params();
    let at = |x: f64| frame(Vector3::new(x, 0.0, 0.0295), Vector3::zeros());
    let (fa, fb) = (Frame::identity(), at(0.19));
    let nearest = Vector3::new(0.14, 0.0, 0.0295);
    let raw = scm::geometry::ssdf(cloud, &nearest, prm.eps1);
    assert!(
        raw.abs() < 1e-3,
        "the top face's plane passes beside: {raw}"
    );
    // The same planes without a polytope (no faces to bound them by) push.
    let bare = without_polytope(cloud);
    let unbounded = pair_contact(&bare, &fa, &ball, &fb, &prm);
    assert!(
        unbounded.on_b.force.norm() > 0.1,
        "the far field pushes without the floor: {:?}",
        unbounded.on_b.force
    );
    let pc = pair_contact(&open, &fa, &ball, &fb, &prm);
    assert!(
        pc.on_b.force.norm() < 1e-9 && pc.on_a.torque.norm() < 1e-9,
        "no push 4 cm away: {:?}",
        pc.on_b.force
    );
    assert!(pc.distance > 0.02, "distance {}", pc.distance);
    // Where the planes are right (the ball resting 1 mm into the top face), the floor changes
    // nothing: the same bits as without it.
    let on_top = frame(
        Vector3::new(0.02, 0.01, 0.079),
        Vector3::new(0.01, 0.0, -0.02),
    );
    let bits = |p: &PairContact<f64>| {
        [p.on_a.force, p.on_a.torque, p.on_b.force, p.on_b.torque]
            .iter()
            .flat_map(|v| v.iter().map(|x| x.to_bits()))
            .chain([p.distance.to_bits()])
            .collect::<Vec<_>>()
    };
    let (with, without) = (
        pair_contact(&open, &fa, &ball, &on_top, &prm),
        pair_contact(&bare, &fa, &ball, &on_top, &prm),
    );
    assert!(with.on_b.force.z > 1.0, "resting: {:?}", with.on_b.force);
    assert_eq!(bits(&with), bits(&without));
    // Resting against the closed box's side face, the planes that push read the truth and the
    // floor leaves them; it raises only the ball's far points, whose separation weights are
    // about e^-20 of the deepest's (they read the top face's plane 2 cm away where the box is
    // 5 cm away): the wrenches change by less than 1e-8 of their size.
    let Collider::Aopc(closed) = closed_box() else {
        unreachable!()
    };
    let closed_bare = without_polytope(&closed);
    let at_side = frame(Vector3::new(0.1495, 0.0, 0.0), Vector3::zeros());
    let side = pair_contact(&Collider::Aopc(closed), &fa, &ball, &at_side, &prm);
    assert!(
        side.on_b.force.x > 0.1,
        "the side face pushes: {:?}",
        side.on_b.force
    );
    let side_bare = pair_contact(&closed_bare, &fa, &ball, &at_side, &prm);
    let change = (side.on_b.force - side_bare.on_b.force).norm()
        + (side.on_a.torque - side_bare.on_a.torque).norm();
    println!("resting on the side: the floor changes the wrenches by {change:.1e}");
    assert!(
        change <= 1e-8 * side.on_b.force.norm(),
        "{change:e} of {:?}",
        side.on_b.force
    );
    assert!((side.distance - side_bare.distance).abs() <= 1e-12);
}

/// A finger-like slab (6 × 1.2 × 1.2 cm) sampled at 3 mm, with its two end caps either in
/// 3 mm faces like the rest (`big_caps` false) or each one face of 12 mm (as a mesh in patches
/// of unequal size is: flat sides in large patches, small ones elsewhere).
fn slab(big_caps: bool) -> Collider {
    let half = Vector3::new(0.03, 0.006, 0.006);
    let sampled = Shape::Box { half }.sample(0.003);
    if !big_caps {
        return Collider::Aopc(sampled);
    }
    let mut cloud = sampled.retain(|p| p.x.abs() < half.x - 1e-6);
    for s in [1.0, -1.0] {
        let (y, z) = (half.y, half.z);
        let c = |a: f64, b: f64| Vector3::new(s * half.x, a, b);
        // Counter-clockwise seen from outside (+x for the cap at +x).
        let mut quad = [c(-y, -z), c(y, -z), c(y, z), c(-y, z)];
        if s < 0.0 {
            quad.reverse();
        }
        cloud.push_quad(quad);
    }
    Collider::Aopc(cloud)
}

#[test]
fn a_plane_reads_no_closer_than_its_own_face_proves() {
    // A ball of 5 mm radius 4 mm beside the slab's side face, level with its top edge: the top
    // face's planes near that edge read the ball's points 1 to 3 mm inside them, with softmax
    // weights of e^-1 to e^-3 against the side face's. Each plane's reading is held to the
    // polytope's proof less one and a half of its own face's cover radius (2.1 mm for the 3 mm
    // faces): 4 mm less 3.2 mm, so the ball is not pushed. Two 12 mm end caps 3 cm away, with
    // no weight at the ball, must not change that: with the cloud's largest cover radius
    // (8.5 mm) as every plane's margin (and its temperature, r/80), their readings stood and
    // the slab pushed the ball with 0.42 N, as without a floor (measured). Now both slabs push
    // it with 1.9e-6 N: 9e-7 of the ball's force pressed 0.5 mm in, below.
    let prm = params();
    let ball = Collider::Aopc(Shape::Sphere { radius: 0.005 }.sample(0.0025));
    let at = frame(Vector3::new(0.0, 0.015, 0.004), Vector3::zeros());
    let fa = Frame::identity();
    let (even, caps) = (slab(false), slab(true));
    let Collider::Aopc(cloud) = &caps else {
        unreachable!()
    };
    let r = cloud.bvh().polytope.as_ref().expect("faces").cover();
    assert!(r > 0.008, "the end caps' cover radius: {r}");
    // The far field is there to hold: without a polytope the same planes push.
    let bare = pair_contact(&without_polytope(cloud), &fa, &ball, &at, &prm);
    println!("no floor: force {:.2e} N", bare.on_b.force.norm());
    assert!(
        bare.on_b.force.norm() > 0.1,
        "the top face's planes push without a floor: {:?}",
        bare.on_b.force
    );
    for (name, slab) in [("3 mm faces", &even), ("12 mm end caps", &caps)] {
        let pc = pair_contact(slab, &fa, &ball, &at, &prm);
        println!("{name}: force {:.2e} N", pc.on_b.force.norm());
        assert!(
            pc.on_b.force.norm() < 1e-5 && pc.on_a.torque.norm() < 1e-6,
            "{name}: the ball 4 mm away is pushed: {:?}",
            pc.on_b.force
        );
    }
    // In contact, the end caps change next to nothing: the ball pressed 0.5 mm into the side
    // face, whose top and bottom planes are raised to their own floors in both slabs (measured
    // 5.8e-12 of the force apart: sums over two hierarchies of other shapes, in other orders,
    // each pruned within its bound).
    let pressed = frame(Vector3::new(0.0, 0.0105, 0.0), Vector3::zeros());
    let (e, c) = (
        pair_contact(&even, &fa, &ball, &pressed, &prm),
        pair_contact(&caps, &fa, &ball, &pressed, &prm),
    );
    assert!(e.on_b.force.y > 1.0, "pressed: {:?}", e.on_b.force);
    assert!(
        (e.on_b.force - c.on_b.force).norm() <= 1e-10 * e.on_b.force.norm(),
        "{:?} against {:?}",
        e.on_b.force,
        c.on_b.force
    );
}

#[test]
fn hand_jacobian_matches_the_generic_duals_and_central_differences() {
    // `pair_contact` with first-order duals and constant parameters runs the pair in f64 and
    // chains the hand-derived Jacobian (`pair_jacobian`); `pair_contact_generic` carries the
    // duals through every term. Same terms, same pruning: they must agree to round-off
    // (1e-12 of the largest derivative of each output; measured 1.0e-13), for every motion
    // input at once (rotation, both angular velocities included), on Aopc–Aopc pairs with
    // both softmaxes and on an Aopc against a half-space, for both dissipation laws with and
    // without a dissipation force (3 N; the smooth one's with a 6 mm margin), while
    // sliding and spinning. Central differences check the values' slopes independently.
    use num_dual::DualSVec64;
    const N: usize = 18;
    let box_a = Collider::Aopc(
        Shape::Box {
            half: Vector3::new(0.1, 0.06, 0.03),
        }
        .sample(0.01),
    );
    let box_b = Collider::Aopc(
        Shape::Box {
            half: Vector3::new(0.05, 0.05, 0.05),
        }
        .sample(0.01),
    );
    let ball = Collider::Aopc(Shape::Sphere { radius: 0.05 }.sample(0.01));
    let floor = Collider::HalfSpace {
        point: Vector3::new(0.0, 0.0, 0.02),
        normal: Vector3::z(),
    };
    // A box open at its sides (its top and bottom faces only, its polytope the whole box's),
    // with the ball beside its top face's edge, in that face's plane: the top face's planes read
    // the ball's nearest points as touching, and the polytope's floor raises them (softly,
    // here: the case where both parts of each reading's derivative count).
    let open = open_box();
    let beside = Rotation3::from_euler_angles(-0.1, 0.05, 0.2) * Vector3::new(0.157, 0.0, 0.0285);
    // (a, b, b's origin): b rests ~1–2 mm into a.
    // (The new case last, so that the others draw the random inputs they always drew.)
    let cases: [(&str, &Collider, &Collider, [f64; 3]); 5] = [
        ("box on box", &box_a, &box_b, [0.02, -0.01, 0.095]),
        ("ball on box", &box_a, &ball, [0.01, 0.02, 0.0765]),
        ("box on floor", &floor, &box_b, [0.0, 0.0, 0.088]),
        ("floor under box", &box_b, &floor, [0.0, 0.0, -0.06]),
        ("ball beside an open box", &open, &ball, beside.into()),
    ];
    let mut rng = Lcg(77);
    let (mut checked, mut worst) = (0, 0.0f64);
    for (name, a, b, origin) in cases {
        // The last laws adhesive (departure 7: 2 N within 3 mm past a 2 mm margin) and pulled
        // by an adhesion actuator (departure 9: 1.5 N within the same gap), so that the points
        // pressed, those in the gap and those past it all count; then the dissipation force
        // holding a separation (departure 4: its share of the speed).
        let laws = [Dissipation::Paper, Dissipation::Smooth]
            .into_iter()
            .flat_map(|d| [f64::INFINITY, 3.0].map(|f| (d, f, false, None, false)))
            .chain([
                (Dissipation::Paper, 3.0, true, None, false),
                (Dissipation::Smooth, f64::INFINITY, false, Some(1.5), false),
                (Dissipation::Paper, 3.0, false, None, true),
            ]);
        for (dissipation, dissipation_force, adhesive, pull, hold_separation) in laws {
            // A margin (6 mm, where the springs rest) with the smooth law's dissipation force.
            let margin = match (dissipation, dissipation_force.is_finite(), adhesive) {
                _ if pull.is_some() => 0.002,
                (_, _, true) => 0.002,
                (Dissipation::Smooth, true, _) => 0.006,
                _ => 0.0,
            };
            let (adhesion, gap) = match (adhesive, pull) {
                (true, _) => (2.0, 0.003),
                (false, Some(_)) => (0.0, 0.003),
                (false, None) => (0.0, 0.0),
            };
            // Each cloud's planes read with its own ε1 on the two pairs of clouds (docs/method.md,
            // "ε1 follows the spacing"): the softmax's weight derivative `2/ε1` per side.
            let eps1_scale = match name {
                "box on box" => [0.5, 1.0],
                "ball on box" => [1.0, 0.3],
                _ => [1.0; 2],
            };
            let prm = ContactParams {
                dissipation,
                dissipation_force,
                hold_separation,
                margin,
                adhesion,
                gap,
                pull,
                eps1_scale,
                ..params()
            };
            let mut base = [0.0; N];
            base[..3].copy_from_slice(&origin);
            for (i, b) in base.iter_mut().enumerate().skip(3) {
                *b = match i {
                    3..=5 => rng.range(-0.05, 0.05), // b's velocity (m/s): sliding, s across 0 and 2
                    6..=8 => rng.range(-0.5, 0.5),   // b's spin (rad/s)
                    9..=11 => rng.range(-0.02, 0.02), // b's extra rotation (rad)
                    12..=14 => rng.range(-1e-3, 1e-3), // a's origin (m)
                    _ => rng.range(-0.3, 0.3),       // a's spin (rad/s)
                };
            }
            let z: Vec<DualSVec64<N>> = (0..N)
                .map(|i| {
                    DualSVec64::new(
                        base[i],
                        num_dual::Derivative::derivative_generic(
                            nalgebra::Const::<N>,
                            nalgebra::Const::<1>,
                            i,
                        ),
                    )
                })
                .collect();
            let chained = pair_outputs(&moving_pair(a, b, &z, &prm.lift(), false));
            let generic = pair_outputs(&moving_pair(a, b, &z, &prm.lift(), true));
            let value = |x: &[f64]| pair_outputs(&moving_pair(a, b, x, &prm, false));
            let v0 = value(&base);
            assert!(
                v0.iter().skip(1).any(|f| f.abs() > 0.1),
                "{name}: not in contact: {v0:?}"
            );
            for (o, (c, g)) in chained.iter().zip(&generic).enumerate() {
                // The chained values are the f64 path's to round-off: the frames are built
                // here once from duals and once from f64 (the rotation of a scaled axis can round
                // differently), and the stiffness amplifies an ulp of a pose (measured: equal in
                // most cases, 1.5e-13 of the largest output at worst, on the open box's planes
                // without their polytope). The generic duals' differ by round-off too (dual
                // arithmetic orders some operations differently).
                let largest = v0.iter().map(|x| x.abs()).fold(0.0, f64::max);
                assert!(
                    (c.re - v0[o]).abs() <= 1e-12 * largest,
                    "{name}: value {o}: {} vs {}",
                    c.re,
                    v0[o]
                );
                assert!(
                    (c.re - g.re).abs() <= 1e-13 * v0.iter().map(|x| x.abs()).fold(0.0, f64::max),
                    "{name}: value {o}: {} vs {}",
                    c.re,
                    g.re
                );
                let (dc, dg) = (
                    c.eps
                        .unwrap_generic(nalgebra::Const::<N>, nalgebra::Const::<1>),
                    g.eps
                        .unwrap_generic(nalgebra::Const::<N>, nalgebra::Const::<1>),
                );
                let scale = dg.amax().max(1e-300);
                for k in 0..N {
                    worst = worst.max((dc[k] - dg[k]).abs() / scale);
                    assert!((dc[k] - dg[k]).abs() <= 1e-12 * scale, "{name} {dissipation:?} {dissipation_force} {hold_separation} {adhesion}: d{o}/dz{k}: hand {} vs generic duals {} (scale {scale})", dc[k], dg[k]);
                    let h = 1e-7;
                    let fd = central_difference(|x| value(x)[o], &base, k, h);
                    // Differences of a value of size |v| carry ~1e-16 |v| / h of round-off.
                    assert!(
                        (dc[k] - fd).abs() <= 1e-5 * scale + 1e-8 * v0[o].abs().max(1.0),
                        "{name} {dissipation:?} {dissipation_force} {hold_separation} {adhesion}: d{o}/dz{k}: hand {} vs fd {fd}",
                        dc[k]
                    );
                    checked += 1;
                }
            }
        }
    }
    println!("largest hand − generic difference: {worst:.1e} of the output's largest derivative");
    assert_eq!(checked, 5 * 7 * 13 * N);
}

/// A pair's contact recorded at one configuration ([`PairTape`]) equals `pair_contact` bit for
/// bit where it was recorded, and replays it at other velocities of the same positions: a box
/// tilted into a plane, two boxes and two spheres overlapping, each at random velocities.
#[test]
fn a_recorded_pair_replays_its_contact_at_other_velocities() {
    use scm::contact::PairTape;
    let plane = Collider::HalfSpace {
        point: Vector3::zeros(),
        normal: Vector3::z(),
    };
    let boxc = || {
        Collider::Aopc(
            Shape::Box {
                half: Vector3::new(0.05, 0.04, 0.03),
            }
            .sample(0.01),
        )
    };
    let tilt = Rotation3::from_euler_angles(0.2, -0.1, 0.4).into_inner();
    let cases: [(Collider, Collider, Vector3<f64>); 3] = [
        (boxc(), plane, Vector3::new(0.01, -0.02, 0.024)),
        (boxc(), boxc(), Vector3::new(0.02, 0.01, 0.062)),
        (big(), small(), Vector3::new(0.05, 0.08, 0.06)),
    ];
    let mut rng = Lcg(11);
    let mut motion = |scale: f64| -> [Vector3<f64>; 2] {
        [rng.direction() * scale, rng.direction() * (3.0 * scale)]
    };
    // a's planes read at half the ε1 of b's (each cloud its own, docs/method.md).
    let prm = ContactParams {
        stiffness: 2e4,
        dissipation_force: 5.0,
        hold_separation: false,
        margin: 0.003,
        eps1_scale: [0.5, 1.0],
        ..params()
    };
    for (a, b, at) in &cases {
        let frames = |m: [Vector3<f64>; 2], n: [Vector3<f64>; 2]| {
            (
                Frame {
                    rotation: tilt,
                    origin: Vector3::new(0.0, 0.0, 0.0),
                    linvel: m[0],
                    angvel: m[1],
                },
                Frame {
                    rotation: Matrix3::identity(),
                    origin: *at,
                    linvel: n[0],
                    angvel: n[1],
                },
            )
        };
        let (fb, fa) = frames(motion(0.1), motion(0.1));
        let (tape, recorded) =
            PairTape::record(a, &fa, b, &fb, &prm, None, &mut Scratch::default());
        let full = pair_contact(a, &fa, b, &fb, &prm);
        assert!(full.on_a.force.norm() > 1.0, "the bodies touch: {full:?}");
        assert_eq!(recorded.distance.to_bits(), full.distance.to_bits());
        for (w, f) in [recorded.on_a, recorded.on_b]
            .iter()
            .chain(&tape.replay(a, &fa, b, &fb, &prm))
            .zip([&full.on_a, &full.on_b, &full.on_a, &full.on_b])
        {
            assert_eq!(
                (w.force, w.torque),
                (f.force, f.torque),
                "bit for bit where recorded"
            );
        }
        for scale in [0.01, 0.3, 2.0] {
            let (gb, ga) = frames(motion(scale), motion(scale));
            let (ga, gb) = (
                Frame {
                    rotation: fa.rotation,
                    origin: fa.origin,
                    ..ga
                },
                Frame {
                    rotation: fb.rotation,
                    origin: fb.origin,
                    ..gb
                },
            );
            let full = pair_contact(a, &ga, b, &gb, &prm);
            let replayed = tape.replay(a, &ga, b, &gb, &prm);
            let size = full.on_a.force.norm() + full.on_a.torque.norm();
            for (w, f) in replayed.iter().zip([&full.on_a, &full.on_b]) {
                let diff = (w.force - f.force).norm() + (w.torque - f.torque).norm();
                assert!(
                    diff <= 1e-13 * size,
                    "at speed scale {scale}: {diff} of {size}"
                );
            }
        }
    }
}

/// `pair_pressing` adds up the sizes of the point forces: the net force's size where every
/// point force is parallel (a box resting flat on a plane, nothing moving), more where they push
/// in many directions. Two cylinders stacked 0.2 mm apart, axis on axis (docs/mjcf.md, "Contact
/// on, against MuJoCo's spread"): the lower one's cap points under the upper one's edge weigh
/// the upper one's side planes in their SSDF (within `√ε1` of them), which read them
/// millimetres inside and push them outwards, all round the edge; the net force keeps only
/// what the caps push across the gap. With a sharper `ε1` the side planes weigh nothing there,
/// and with a smaller `ε3` the caps push next to nothing across the gap.
#[test]
fn pressing_adds_the_sizes_of_the_point_forces() {
    let plane = Collider::HalfSpace {
        point: Vector3::zeros(),
        normal: Vector3::z(),
    };
    let half = Vector3::new(0.05, 0.04, 0.03);
    let boxc = Collider::Aopc(Shape::Box { half }.sample(0.01));
    let f = frame(Vector3::new(0.0, 0.0, 0.029), Vector3::zeros());
    let (prm, o) = (params(), Frame::identity());
    let net = pair_contact(&boxc, &f, &plane, &o, &prm).on_a.force.norm();
    let pressing = pair_pressing(&boxc, &f, &plane, &o, &prm);
    println!("box: net {net:e} pressing {pressing:e}");
    assert!(
        net > 1.0 && (pressing - net).abs() <= 1e-12 * net,
        "{pressing} {net}"
    );
    let cylinder = |radius| {
        Collider::Aopc(
            Shape::Cylinder {
                radius,
                half_length: 0.05,
            }
            .sample(0.01),
        )
    };
    let low = frame(Vector3::zeros(), Vector3::zeros());
    let high = frame(Vector3::new(0.0, 0.0, 0.1002), Vector3::zeros());
    let stacked = |upper: f64, eps1: f64, eps3: f64| {
        let prm = ContactParams {
            eps1,
            eps3,
            ..params()
        };
        let (a, b) = (cylinder(0.045), cylinder(upper));
        let net = pair_contact(&a, &low, &b, &high, &prm).on_a.force.norm();
        (net, pair_pressing(&a, &low, &b, &high, &prm))
    };
    // Measured: 0.188 N against 0.126 at the defaults, 0.087 N against 9.0e-6 N at ε3 = 2e-5,
    // 0.192 N against 0.126 under a 3.5 cm upper cylinder (its edge, not a rim on a rim).
    for (upper, eps3, ratio) in [(0.045, 1e-4, 1.4), (0.045, 2e-5, 1e3), (0.035, 1e-4, 1.4)] {
        let (net, pressing) = stacked(upper, 1e-5, eps3);
        assert!(pressing > ratio * net, "{upper} {eps3}: {pressing} {net}");
    }
    // ε1 = 3e-6: the same to 4e-9 (measured 3.6e-9); a tolerance of 1e-6 fails by far where the
    // side planes push (0.48 of the net force at ε1 = 1e-5).
    let (net, pressing) = stacked(0.045, 3e-6, 1e-4);
    assert!(
        net > 0.1 && pressing - net <= 1e-6 * net,
        "{pressing} {net}"
    );
}
