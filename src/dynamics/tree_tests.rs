//! Unit tests of the tree: quaternions, the mass matrix's fixed blocks and unit columns.

use super::*;
use num_dual::Dual64;

/// A tree of every kind of joint: a free torso carrying a ball joint about its origin, a
/// ball joint beside it and a hinge about a body axis; a free body alone; a slide.
fn every_joint() -> Tree {
    let joint = |name: &str, kind, axis: [f64; 3], anchor: [f64; 3]| Joint {
        name: name.into(),
        kind,
        axis: Vector3::from(axis),
        anchor: Vector3::from(anchor),
        damping: 0.0,
        stiffness: 0.0,
        reference: 0.0,
        springref: 0.0,
        limit: None,
        frictionloss: 0.0,
        armature: 0.01,
        qadr: 0,
        dadr: 0,
        body: 0,
    };
    let joints = vec![
        joint("torso", JointKind::Free, [0.0; 3], [0.0; 3]),
        joint("neck", JointKind::Ball, [0.0; 3], [0.0; 3]),
        joint("shoulder", JointKind::Ball, [0.0; 3], [0.1, 0.0, 0.0]),
        joint("elbow", JointKind::Hinge, [0.0, 1.0, 0.0], [0.0; 3]),
        joint("float", JointKind::Free, [0.0; 3], [0.0; 3]),
        joint("rail", JointKind::Slide, [0.0, 0.0, 1.0], [0.0; 3]),
    ];
    let body = |name: &str, parent: usize, at: [f64; 3], joints: Vec<usize>, k: f64| Body {
        name: name.into(),
        parent: Some(parent),
        offset: Isometry3::translation(at[0], at[1], at[2]),
        inertia: Inertia {
            mass: 1.0 + k,
            com: Vector3::new(0.05 * k, -0.03, 0.02 * k),
            rot: Matrix3::new(
                0.3,
                0.01,
                -0.02,
                0.01,
                0.2 + k * 0.01,
                0.03,
                -0.02,
                0.03,
                0.25,
            ),
        },
        joints,
        mocap: false,
        gravcomp: 0.0,
    };
    let mut world = body("world", 0, [0.0; 3], vec![], 0.0);
    world.parent = None;
    let bodies = vec![
        world,
        body("torso", 0, [0.0, 0.0, 1.0], vec![0], 1.0),
        body("head", 1, [0.0, 0.0, 0.2], vec![1], 0.5),
        body("upper", 1, [0.0, 0.2, 0.0], vec![2], 0.3),
        body("lower", 3, [0.3, 0.0, 0.0], vec![3], 0.2),
        body("float", 0, [1.0, 0.0, 1.0], vec![4], 0.7),
        body("cart", 0, [2.0, 0.0, 0.0], vec![5], 0.4),
    ];
    Tree::new(bodies, joints, Vector3::new(0.0, 0.0, -9.81)).unwrap()
}

#[test]
fn a_free_joints_fixed_block_is_the_general_loops_and_unit_columns_are_found() {
    let tree = every_joint();
    // The free joints' rotations, the ball about its origin, the hinge about a body axis
    // through it and the slide along one; not the free translations nor the offset ball.
    // (The offset ball's first column is a unit axis too: its anchor lies on that axis.)
    let (r, n) = ([Some(0), Some(1), Some(2)], [None; 3]);
    let want: Vec<Option<usize>> = [&n[..], &r, &r, &[Some(0), None, None], &[Some(1)]]
        .into_iter()
        .chain([&n[..], &r, &[Some(5)]])
        .flatten()
        .copied()
        .collect();
    assert_eq!(tree.dof_unit, want);
    let mut state = 7;
    let mut q = vec![0.0; tree.nq];
    for x in q.iter_mut() {
        *x = crate::geometry::lcg(&mut state);
    }
    let v: Vec<f64> = (0..tree.nv)
        .map(|_| crate::geometry::lcg(&mut state))
        .collect();
    let kin = tree.kinematics(&q, &v);
    let (fixed, general) = (
        tree.composite_rigid_body(&kin, true),
        tree.composite_rigid_body(&kin, false),
    );
    assert_eq!(fixed, general);
    assert!(fixed.to_dense().iter().all(|x| x.is_finite()));
}

#[test]
fn quaternions_of_any_scale_normalize_to_the_same_rotation_and_derivative() {
    // Components whose squares overflow (1e200) or underflow (1e-200) give the rotation
    // of the same direction at scale 1, with the same derivative along a seeded component.
    let unit = [0.3, -0.5, 0.7, 0.2];
    let seed = |scale: f64| -> Vec<Dual64> {
        (0..4)
            .map(|k| Dual64::new(unit[k] * scale, if k == 1 { scale } else { 0.0 }))
            .collect()
    };
    let want = quat_from(&seed(1.0));
    for scale in [1e200, 1e-200, 1e300, 1e-300] {
        let got = quat_from(&seed(scale));
        for (a, b) in [
            (got.w, want.w),
            (got.i, want.i),
            (got.j, want.j),
            (got.k, want.k),
        ] {
            assert!((a.re - b.re).abs() < 1e-15, "{scale}: {a} vs {b}");
            assert!((a.eps - b.eps).abs() < 1e-14, "{scale}: {a} vs {b}");
        }
    }
    // In range, the direct normalization, bit for bit.
    let q = [0.3f64, -0.5, 0.7, 0.2];
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    assert_eq!(quat_from(&q).w, q[0] / n);
}

/// Kinematics written into buffers that held another state's, or another tree's, are those
/// computed afresh, bit for bit; a body of two joints has its frame from both, in order, and
/// its child and a mocap body theirs.
#[test]
fn kinematics_into_reused_buffers_are_fresh_kinematics() {
    let tree_a = every_joint();
    // An arm of two joints on one body (a hinge about z, then a slide along x), a hand on it,
    // a mocap body.
    let mut joints = tree_a.joints.clone();
    let (hinge, slide) = (joints[3].clone(), joints[5].clone());
    joints.truncate(0);
    joints.push(Joint {
        axis: Vector3::z(),
        ..hinge.clone()
    });
    joints.push(Joint {
        axis: Vector3::x(),
        ..slide
    });
    joints.push(hinge);
    let mut bodies: Vec<Body> = tree_a.bodies[..2].to_vec();
    bodies[1].joints = vec![0, 1];
    bodies[1].offset = Isometry3::translation(0.0, 0.0, 1.0);
    let mut hand = tree_a.bodies[4].clone();
    (hand.parent, hand.joints) = (Some(1), vec![2]);
    let mut mocap = tree_a.bodies[5].clone();
    (mocap.parent, mocap.joints, mocap.mocap) = (Some(0), vec![], true);
    bodies.extend([hand, mocap]);
    let tree_b = Tree::new(bodies, joints, Vector3::new(0.0, 0.0, -9.81)).unwrap();
    let mut state = 11;
    let mut draw = |n: usize| -> Vec<f64> {
        (0..n)
            .map(|_| crate::geometry::lcg(&mut state) - 0.5)
            .collect()
    };
    let mocap_in = draw(MOCAP_INPUTS);
    // `Debug` prints every number so that it reads back to the same bits (zeros' signs too).
    let same = |a: &Kinematics<f64>, b: &Kinematics<f64>| format!("{a:?}") == format!("{b:?}");
    // The mocap body at its inputs' pose and, without inputs, at its scene pose.
    for (tree, inputs) in [
        (&tree_a, vec![]),
        (&tree_b, mocap_in.clone()),
        (&tree_b, vec![]),
    ] {
        let (q1, v1, q2, v2) = (draw(tree.nq), draw(tree.nv), draw(tree.nq), draw(tree.nv));
        let fresh = tree.kinematics_with(&q2, &v2, &inputs);
        // Buffers of the same tree at another state, of the other tree, and none.
        let mut kin = tree.kinematics_with(&q1, &v1, &inputs);
        tree.kinematics_into(&q2, &v2, &inputs, &mut kin);
        assert!(same(&kin, &fresh));
        // Buffers of this tree's length with every frame written over: the world's entry is
        // set again, not assumed to be the identity still.
        let mut scribbled = tree.kinematics_with(&q1, &v1, &inputs);
        for f in &mut scribbled.frames {
            (f.origin, f.linvel) = (Vector3::new(1.0, 2.0, 3.0), Vector3::new(4.0, 5.0, 6.0));
            f.rotation *= 2.0;
        }
        tree.kinematics_into(&q2, &v2, &inputs, &mut scribbled);
        assert!(same(&scribbled, &fresh));
        let mut other = every_joint().kinematics(&draw(every_joint().nq), &draw(every_joint().nv));
        tree.kinematics_into(&q2, &v2, &inputs, &mut other);
        assert!(same(&other, &fresh));
        let mut empty = Kinematics::empty();
        tree.kinematics_into(&q2, &v2, &inputs, &mut empty);
        assert!(same(&empty, &fresh));
    }
    // The arm: the hinge's turn about z, then the slide along the turned x.
    let (q, v) = (vec![0.3, 0.2, -0.4], vec![0.0; 3]);
    let kin = tree_b.kinematics_with(&q, &v, &mocap_in);
    let (s, c) = 0.3f64.sin_cos();
    let arm = &kin.frames[1];
    assert!((arm.origin - Vector3::new(0.2 * c, 0.2 * s, 1.0)).norm() < 1e-15);
    assert!((arm.rotation - Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)).norm() < 1e-15);
    // The hand hangs from the arm's frame; the mocap body is where its inputs put it.
    let hand = &kin.frames[2];
    let at = arm.origin + arm.rotation * Vector3::new(0.3, 0.0, 0.0);
    assert!((hand.origin - at).norm() < 1e-15);
    let mocap = &kin.frames[3];
    assert_eq!(
        mocap.origin,
        Vector3::new(mocap_in[0], mocap_in[1], mocap_in[2])
    );
    assert_eq!(kin.frames[0].origin, Vector3::zeros());
}
