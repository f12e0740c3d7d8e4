//! The effective inertias MuJoCo's compiler takes at the reference configuration `qpos0`: a
//! joint's (`1 / dof_invweight0`) and a body's inverse weights (`body_invweight0`), which size
//! the springs of limits, equalities and contact pairs.

use super::*;

/// The inertia of slide or hinge joint `j` at `qpos0` as MuJoCo's compiler takes it (its
/// `1 / dof_invweight0`; see [`Builder::set_limits`]), given the mass matrix there and its
/// inverse.
pub(super) fn joint_inertia(
    tree: &Tree,
    j: usize,
    m: &nalgebra::DMatrix<f64>,
    m_inv: &Option<nalgebra::DMatrix<f64>>,
) -> f64 {
    let d = tree.joints[j].dadr;
    match (slider_body_mass(tree, j), m_inv) {
        (Some(mass), _) => mass,
        (None, Some(inv)) if inv[(d, d)] > 0.0 => 1.0 / inv[(d, d)],
        // A singular mass matrix (a massless chain): the locked-joint inertia.
        _ => m[(d, d)],
    }
}

/// The mass MuJoCo takes as the inertia of joint `j` when its body is what MuJoCo's compiler
/// calls a simple body with sliders only (`body_simple = 2`): every joint of the body a slide
/// at the body origin along a coordinate axis, no child body, the parent the world or a
/// jointless child of it, and the inertia's frame the body frame (centre of mass at the
/// origin, diagonal inertia). For such a body MuJoCo's `dof_invweight0` is `1 / mass`: the
/// joints' armature is left out (for other joints it is in). `None` for every other joint.
fn slider_body_mass(tree: &Tree, j: usize) -> Option<f64> {
    let b = tree.joints[j].body;
    let body = &tree.bodies[b];
    let at_origin_on_an_axis = |k: &usize| {
        let joint = &tree.joints[*k];
        joint.kind == JointKind::Slide
            && joint.anchor.norm() == 0.0
            && joint.axis.iter().filter(|a| a.abs() > 1e-14).count() == 1
    };
    let parent_fixed = match body.parent {
        Some(0) => true,
        Some(p) => tree.bodies[p].parent == Some(0) && tree.bodies[p].joints.is_empty(),
        None => false,
    };
    let i = &body.inertia;
    let same_frame =
        i.com.norm() == 0.0 && (0..3).all(|r| (0..3).all(|c| r == c || i.rot[(r, c)] == 0.0));
    let leaf = tree.bodies.iter().all(|o| o.parent != Some(b));
    (body.joints.iter().all(at_origin_on_an_axis) && parent_fixed && same_frame && leaf)
        .then_some(i.mass)
}

/// MuJoCo's `body_invweight0` of every body: `(translational, rotational)`, zero for a body
/// that cannot move, `(1 / mass, 0)` for a top-level body of sliders, else the means of the
/// diagonals of `J M⁻¹ Jᵀ` at `qpos0` for the linear and angular Jacobians `J` of its centre
/// of mass.
pub(super) fn body_weights(tree: &Tree) -> Vec<(f64, f64)> {
    let q0 = tree.q0();
    let inv = mass_at_q0(tree).1;
    // Columns of each body's centre-of-mass Jacobian: its velocity for a unit velocity of
    // each degree of freedom.
    let columns = unit_velocity_kinematics(tree, &q0);
    let weight = |b: usize| -> (f64, f64) {
        if b == 0 || !tree.body_moves(b) {
            return (0.0, 0.0);
        }
        if let Some(mass) = tree.bodies[b]
            .joints
            .first()
            .and_then(|&j| slider_body_mass(tree, j))
        {
            return (1.0 / mass, 0.0);
        }
        let Some(inv) = &inv else { return (0.0, 0.0) };
        let com = tree.bodies[b].inertia.com;
        let (linear, angular): (Vec<Vector3<f64>>, Vec<Vector3<f64>>) = columns
            .iter()
            .map(|k| {
                let f = &k.frames[b];
                (f.linvel + f.angvel.cross(&(f.rotation * com)), f.angvel)
            })
            .unzip();
        // Over the velocities that move the body (a zero column adds exact zeros): 6 of a
        // free leaf's 1,800 in MuJoCo's leaves scene.
        let mean = |jac: &[Vector3<f64>]| {
            let moving: Vec<usize> = (0..jac.len())
                .filter(|&a| jac[a] != Vector3::zeros())
                .collect();
            let mut trace = 0.0;
            for &a in &moving {
                for &c in &moving {
                    trace += jac[a].dot(&jac[c]) * inv[(a, c)];
                }
            }
            trace / 3.0
        };
        (mean(&linear), mean(&angular))
    };
    (0..tree.bodies.len()).map(weight).collect()
}

/// The mass that moves with each body: the total mass of the moving bodies in the tree under
/// its top-level ancestor (a child of the world), 0 for a body that cannot move. It sizes a
/// pair whose inverse weights are a rounding error (a centre of mass on its only joint's axis:
/// robosuite's Jaco thumb, 9.9e-31 1/kg).
pub(super) fn moving_masses(tree: &Tree) -> Vec<f64> {
    let top = |mut b: usize| {
        while let Some(p) = tree.bodies[b].parent.filter(|&p| p != 0) {
            b = p;
        }
        b
    };
    let tops: Vec<usize> = (0..tree.bodies.len()).map(top).collect();
    let mut per_top = vec![0.0; tree.bodies.len()];
    for (b, body) in tree.bodies.iter().enumerate().skip(1) {
        if tree.body_moves(b) {
            per_top[tops[b]] += body.inertia.mass;
        }
    }
    (0..tree.bodies.len())
        .map(|b| {
            if b == 0 || !tree.body_moves(b) {
                0.0
            } else {
                per_top[tops[b]]
            }
        })
        .collect()
}

/// The kinematics at `q` for a unit velocity of each degree of freedom in turn: the columns of
/// every body's (and point's) velocity Jacobian there.
pub(super) fn unit_velocity_kinematics(
    tree: &Tree,
    q: &[f64],
) -> Vec<crate::dynamics::Kinematics<f64>> {
    (0..tree.nv)
        .map(|k| {
            let mut v = vec![0.0; tree.nv];
            v[k] = 1.0;
            tree.kinematics(q, &v)
        })
        .collect()
}

/// The mass matrix at the reference configuration `qpos0` and its inverse (`None` when it is
/// singular: a massless chain), for the effective inertias MuJoCo's compiler takes there.
pub(super) fn mass_at_q0(tree: &Tree) -> (nalgebra::DMatrix<f64>, Option<nalgebra::DMatrix<f64>>) {
    let q0 = tree.q0();
    let kin = tree.kinematics(&q0, &vec![0.0; tree.nv]);
    let m = tree.mass_matrix(&kin);
    // Block-diagonal over the free-moving trees: inverted per tree (`crate::linalg`).
    let inv = crate::linalg::block_inverse(&m, |b| b.cholesky().map(|c| c.inverse()));
    (m, inv)
}
