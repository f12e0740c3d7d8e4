//! Rigid-body dynamics on kinematic trees (Featherstone): joints, forward kinematics, the mass
//! matrix by the composite-rigid-body algorithm and the bias forces by recursive Newton–Euler,
//! all in body coordinates and generic over the scalar.
//!
//! A body may carry several joints (MJCF allows it: the T-block of planar pushing has slide x,
//! slide y and hinge z). Internally each joint is a node of the tree, applied in order in the
//! frame left by the previous ones; the body's inertia sits on its last node. A body without
//! joints is one fixed node (welded to its parent).
//!
//! A *mocap* body (MJCF `mocap="true"`) is a top-level body without joints whose pose and
//! velocity are inputs: it moves kinematically, pushes what it touches and is pushed by nothing.
//! Its pose and velocity enter [`Tree::kinematics_with`] as [`MOCAP_INPUTS`] numbers per mocap
//! body (see [`Tree::mocap`]).

mod connect;
mod coupled;
pub mod equality;
mod factor;
pub mod fluid;
mod kinematics;
mod law;
mod lie;
pub mod limit;
mod ramp;
mod rnea;

pub use coupled::{CoupledFactor, Row};
pub use factor::{MassFactor, TreeMatrix};
pub use kinematics::{BodyColumn, Kinematics};
pub use lie::{quat_exp, quat_from, quat_log, quat_matrix};
pub mod spatial;
pub mod tendon;
pub mod wrap;

use crate::scalar::{c, Scalar};
use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Vector3, Vector6};
use spatial::{cross_force, cross_motion, skew, BodyInertia, Inertia, Transform};

/// Kind of a joint and its number of position/velocity coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    /// 6 DOF, top-level bodies only. `q = [x y z qw qx qy qz]`, `v = [linvel (world), angvel
    /// (body frame)]` as in MuJoCo.
    Free,
    /// 3 rotational DOF about `anchor`. `q = [qw qx qy qz]`, `v` = angular velocity (body frame).
    Ball,
    /// Translation along `axis`: `q` in m.
    Slide,
    /// Rotation about `axis` through `anchor`: `q` in rad.
    Hinge,
}

impl JointKind {
    /// Number of position coordinates.
    pub fn nq(self) -> usize {
        match self {
            JointKind::Free => 7,
            JointKind::Ball => 4,
            _ => 1,
        }
    }

    /// Number of velocity coordinates (degrees of freedom).
    pub fn nv(self) -> usize {
        match self {
            JointKind::Free => 6,
            JointKind::Ball => 3,
            _ => 1,
        }
    }
}

/// A joint and its passive properties.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    /// Name (from the scene; FMU variables are named after it).
    pub name: String,
    /// Kind.
    pub kind: JointKind,
    /// Unit axis (body frame) for slide and hinge.
    pub axis: Vector3<f64>,
    /// Point the rotation is about (body frame) for hinge and ball.
    pub anchor: Vector3<f64>,
    /// Viscous damping (N·s/m or N·m·s/rad).
    pub damping: f64,
    /// Spring stiffness towards `q = springref` (N/m or N·m/rad), slide and hinge; towards
    /// the identity for ball joints.
    pub stiffness: f64,
    /// Reference position of a slide or hinge joint (m or rad): the value of `q` at which the
    /// body sits at its `offset` (MuJoCo's `ref`), and the initial `q`.
    pub reference: f64,
    /// Spring rest position of a slide or hinge joint (m or rad, MuJoCo's `springref`).
    pub springref: f64,
    /// Limits of a slide or hinge joint, as smooth springs and dampers ([`limit`]).
    pub limit: Option<limit::JointLimit>,
    /// Dry friction force or torque (N or N·m), smoothed by the stiction velocity.
    pub frictionloss: f64,
    /// Armature: inertia added to the joint's DOFs (kg or kg·m²).
    pub armature: f64,
    /// Index of the first position coordinate.
    pub qadr: usize,
    /// Index of the first velocity coordinate.
    pub dadr: usize,
    /// Body the joint moves.
    pub body: usize,
}

/// A body of the tree. Body 0 is the world.
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    /// Name (from the scene; `world` for body 0).
    pub name: String,
    /// Parent body (`None` for the world).
    pub parent: Option<usize>,
    /// Pose of the body frame in its parent's frame, before its joints move it.
    pub offset: Isometry3<f64>,
    /// Inertia about the body frame origin, in body coordinates.
    pub inertia: Inertia,
    /// Joints, in the order they are applied.
    pub joints: Vec<usize>,
    /// Whether the body is a mocap body: top-level, no joints, pose and velocity from inputs.
    pub mocap: bool,
    /// Gravity compensation: the body also receives the force `-gravcomp · m g` at its centre
    /// of mass (MuJoCo's `gravcomp`: 1 cancels its weight, 0 leaves it).
    pub gravcomp: f64,
}

/// Numbers per mocap body in an input vector: position (3, m, world frame), orientation
/// quaternion `w x y z` (4, normalized on use), linear velocity of the body origin (3, m/s,
/// world frame), angular velocity (3, rad/s, body frame, as for free joints).
pub const MOCAP_INPUTS: usize = 13;

#[derive(Clone, Debug, PartialEq)]
struct Node {
    body: usize,
    joint: Option<usize>,
    parent: Option<usize>,
    /// Fixed transform before the joint (the body's offset for its first node), as the
    /// rotation matrix and translation the kinematics compose (made once here, not at every
    /// evaluation: the same numbers).
    offset: Transform<f64>,
    /// Whether the body's inertia sits on this node (its last node).
    carries_inertia: bool,
    /// The inertia this node carries, about its origin (the body's where
    /// `carries_inertia`, none elsewhere), made once here rather than at every evaluation
    /// (the same numbers: [`Inertia::about_origin`] computes in `f64`).
    inertia: BodyInertia<f64>,
}

impl Node {
    fn new(
        body: usize,
        joint: Option<usize>,
        parent: Option<usize>,
        offset: &Isometry3<f64>,
        carries: Option<&Inertia>,
    ) -> Node {
        Node {
            body,
            joint,
            parent,
            offset: Transform {
                rotation: offset.rotation.to_rotation_matrix().into_inner(),
                translation: offset.translation.vector,
            },
            carries_inertia: carries.is_some(),
            inertia: carries.map_or_else(BodyInertia::zero, Inertia::about_origin),
        }
    }
}

/// The mechanical model: bodies, joints, gravity. Immutable once built: its nodes keep each
/// body's offset and inertia as built, and each DOF's unit axis (`dof_unit`), so a body's
/// `offset` or `inertia`, or a joint's kind, axis or anchor, changed afterwards would not be
/// seen (a joint's passive properties and limits are read where they are).
#[derive(Clone, Debug, PartialEq)]
pub struct Tree {
    /// Bodies; index 0 is the world. Parents come before children.
    pub bodies: Vec<Body>,
    /// Joints, in coordinate order.
    pub joints: Vec<Joint>,
    /// Gravity (m/s², world frame).
    pub gravity: Vector3<f64>,
    /// Number of position coordinates.
    pub nq: usize,
    /// Number of velocity coordinates.
    pub nv: usize,
    /// Mocap bodies, in scene order (their inputs come in this order).
    pub mocap: Vec<usize>,
    nodes: Vec<Node>,
    /// Node whose frame is the body frame, per body (`None` for the world).
    body_node: Vec<Option<usize>>,
    /// Where the entries of a [`TreeMatrix`] of this tree are ([`Tree::factor`]).
    dof_shape: std::sync::Arc<factor::Sparsity>,
    /// Per DOF, `Some(i)` where its motion subspace column is the same unit axis at every
    /// configuration (entry `i` is 1, the others 0: a free joint's rotations, a ball joint's
    /// about its body origin, a hinge about a body axis through it, a slide along one), so
    /// that the mass matrix applies an inertia to it by reading the inertia's entries
    /// ([`BodyInertia::apply_unit`]; the same numbers for finite entries, but for the sign
    /// of a zero).
    dof_unit: Vec<Option<usize>>,
}

/// Why a tree cannot be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TreeError {
    /// A free joint on a body whose parent is not the world, or not alone on its body.
    #[error("free joint '{0}' must be the only joint of a body attached to the world")]
    FreeJointPlacement(String),
    /// A moving body without mass or without rotational inertia.
    #[error("body '{0}' moves but has no mass or no rotational inertia: give it geoms with mass or an <inertial>")]
    Massless(String),
    /// A body listed before its parent.
    #[error("body '{0}' comes before its parent")]
    Order(String),
    /// A mocap body that is not a joint-less child of the world, or that has child bodies.
    #[error(
        "mocap body '{0}' must be a child of the world without joints and without child bodies"
    )]
    MocapPlacement(String),
}

impl Tree {
    /// Builds the tree, checking the structure. Joint `qadr`/`dadr` are assigned here.
    pub fn new(
        bodies: Vec<Body>,
        mut joints: Vec<Joint>,
        gravity: Vector3<f64>,
    ) -> Result<Tree, TreeError> {
        let mut nodes = Vec::new();
        let mut body_node = vec![None; bodies.len()];
        let (mut nq, mut nv) = (0, 0);
        let mut mocap = Vec::new();
        for (b, body) in bodies.iter().enumerate().skip(1) {
            let parent = body.parent.unwrap_or(0);
            if parent >= b {
                return Err(TreeError::Order(body.name.clone()));
            }
            if body.mocap {
                if parent != 0
                    || !body.joints.is_empty()
                    || bodies.iter().any(|o| o.parent == Some(b))
                {
                    return Err(TreeError::MocapPlacement(body.name.clone()));
                }
                mocap.push(b);
            }
            let parent_node = body_node[parent];
            if body.joints.is_empty() {
                nodes.push(Node::new(
                    b,
                    None,
                    parent_node,
                    &body.offset,
                    Some(&body.inertia),
                ));
            } else {
                for (k, &j) in body.joints.iter().enumerate() {
                    let joint = &mut joints[j];
                    if joint.kind == JointKind::Free && (parent != 0 || body.joints.len() != 1) {
                        return Err(TreeError::FreeJointPlacement(joint.name.clone()));
                    }
                    joint.qadr = nq;
                    joint.dadr = nv;
                    joint.body = b;
                    nq += joint.kind.nq();
                    nv += joint.kind.nv();
                    let parent = if k == 0 {
                        parent_node
                    } else {
                        Some(nodes.len() - 1)
                    };
                    let offset = if k == 0 {
                        body.offset
                    } else {
                        Isometry3::identity()
                    };
                    let carries = (k + 1 == body.joints.len()).then_some(&body.inertia);
                    nodes.push(Node::new(b, Some(j), parent, &offset, carries));
                }
            }
            body_node[b] = Some(nodes.len() - 1);
        }
        let mut tree = Tree {
            bodies,
            joints,
            gravity,
            nq,
            nv,
            mocap,
            nodes,
            body_node,
            dof_shape: std::sync::Arc::new(factor::Sparsity::new(&[])),
            dof_unit: vec![None; nv],
        };
        tree.dof_shape = std::sync::Arc::new(factor::Sparsity::new(&tree.dof_parents()));
        tree.dof_unit = tree.unit_columns();
        // MuJoCo's rule: every body with joints, together with the jointless bodies welded to
        // it (they move as one), has a mass and a rotational inertia; a welded body alone may
        // have none (a body that only holds a site, or a massless frame around the geoms).
        for (b, body) in tree.bodies.iter().enumerate().skip(1) {
            if body.joints.is_empty() {
                continue;
            }
            let i = tree.welded_inertia(b);
            if i.mass <= 0.0 || i.rot.symmetric_eigenvalues().min() <= 0.0 {
                return Err(TreeError::Massless(body.name.clone()));
            }
        }
        Ok(tree)
    }

    /// Which DOFs' motion columns are a fixed unit axis ([`Tree::dof_unit`]): read off the
    /// kinematics at a neutral configuration, leaving out a free joint's translations (their
    /// columns turn with the body).
    fn unit_columns(&self) -> Vec<Option<usize>> {
        let mut q = vec![0.0; self.nq];
        for j in &self.joints {
            match j.kind {
                JointKind::Free => q[j.qadr + 3] = 1.0,
                JointKind::Ball => q[j.qadr] = 1.0,
                _ => {}
            }
        }
        let kin = self.kinematics(&q, &vec![0.0; self.nv]);
        let mut unit = vec![None; self.nv];
        for j in &self.joints {
            let first = if j.kind == JointKind::Free { 3 } else { 0 };
            let dofs = j.dadr + first..j.dadr + j.kind.nv();
            for (u, s) in unit[dofs.clone()].iter_mut().zip(&kin.s[dofs]) {
                let one = s.iter().position(|&x| x == 1.0);
                *u = one.filter(|&i| s.iter().enumerate().all(|(e, &x)| e == i || x == 0.0));
            }
        }
        unit
    }

    /// The inertia of body `b` with every jointless body welded below it, in `b`'s frame.
    fn welded_inertia(&self, b: usize) -> Inertia {
        let mut total = self.bodies[b].inertia;
        // (body, its pose in b's frame), walking jointless children.
        let mut stack = vec![(b, Isometry3::identity())];
        while let Some((p, pose)) = stack.pop() {
            for (k, child) in self.bodies.iter().enumerate() {
                if child.parent != Some(p) || !child.joints.is_empty() || k == p {
                    continue;
                }
                let at = pose * child.offset;
                let r = at.rotation.to_rotation_matrix().into_inner();
                let i = &child.inertia;
                total = total.add(&Inertia {
                    mass: i.mass,
                    com: (at * nalgebra::Point3::from(i.com)).coords,
                    rot: r * i.rot * r.transpose(),
                });
                stack.push((k, at));
            }
        }
        total
    }

    /// Whether a body has a joint on its path to the world.
    pub fn body_moves(&self, mut b: usize) -> bool {
        while b != 0 {
            if !self.bodies[b].joints.is_empty() {
                return true;
            }
            b = self.bodies[b].parent.unwrap_or(0);
        }
        false
    }

    /// The inputs of every mocap body at its scene pose, at rest ([`MOCAP_INPUTS`] per body).
    pub fn mocap0(&self) -> Vec<f64> {
        let mut out = Vec::with_capacity(MOCAP_INPUTS * self.mocap.len());
        for &b in &self.mocap {
            let o = &self.bodies[b].offset;
            let (t, r) = (o.translation.vector, o.rotation.quaternion());
            out.extend_from_slice(&[t.x, t.y, t.z, r.w, r.i, r.j, r.k]);
            out.extend_from_slice(&[0.0; 6]);
        }
        out
    }

    /// Initial configuration: free joints at their body's offset, quaternions identity, slide
    /// and hinge joints at their reference position.
    pub fn q0(&self) -> Vec<f64> {
        let mut q = vec![0.0; self.nq];
        for j in &self.joints {
            match j.kind {
                JointKind::Free => {
                    let o = &self.bodies[j.body].offset;
                    let t = o.translation.vector;
                    let r = o.rotation.quaternion();
                    q[j.qadr..j.qadr + 7].copy_from_slice(&[t.x, t.y, t.z, r.w, r.i, r.j, r.k]);
                }
                JointKind::Ball => q[j.qadr] = 1.0,
                JointKind::Slide | JointKind::Hinge => q[j.qadr] = j.reference,
            }
        }
        q
    }
}

impl Tree {
    /// The velocity coordinates of node `i`'s joint (none for a jointless node).
    fn node_dofs(&self, i: usize) -> std::ops::Range<usize> {
        self.node_dofs_of(&self.nodes[i])
    }

    fn node_dofs_of(&self, node: &Node) -> std::ops::Range<usize> {
        node.joint.map_or(0..0, |j| {
            let joint = &self.joints[j];
            joint.dadr..joint.dadr + joint.kind.nv()
        })
    }

    fn node_inertia<T: Scalar>(&self, i: usize) -> BodyInertia<T> {
        self.nodes[i].inertia.lift()
    }

    /// Joint-space inertia matrix `M(q)` by the composite-rigid-body algorithm, armature
    /// included, dense.
    pub fn mass_matrix<T: Scalar>(&self, kin: &Kinematics<T>) -> DMatrix<T> {
        self.mass_matrix_sparse(kin).to_dense()
    }

    /// Joint-space inertia matrix `M(q)` by the composite-rigid-body algorithm, armature
    /// included, at its tree sparsity (what [`Tree::factor`] takes): each entry is between a
    /// DOF and one of its ancestors (or itself), computed once.
    pub fn mass_matrix_sparse<T: Scalar>(&self, kin: &Kinematics<T>) -> TreeMatrix<T> {
        self.composite_rigid_body(kin, true)
    }

    /// [`Tree::mass_matrix_sparse`], with a free joint's block by its fixed loops where
    /// `fixed_blocks` (the same entries as the general loop's: tested).
    // Nodes are visited by index: each step reads several per-node arrays and walks parents.
    #[allow(clippy::needless_range_loop)]
    fn composite_rigid_body<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        fixed_blocks: bool,
    ) -> TreeMatrix<T> {
        let n = self.nodes.len();
        let mut ic: Vec<BodyInertia<T>> = (0..n).map(|i| self.node_inertia(i)).collect();
        for i in (0..n).rev() {
            if let Some(p) = self.nodes[i].parent {
                let add = ic[i].to_parent(&kin.x[i]);
                ic[p] += add;
            }
        }
        let mut m = self.tree_matrix();
        for i in 0..n {
            let dofs = self.node_dofs(i);
            let free = self.nodes[i]
                .joint
                .is_some_and(|j| self.joints[j].kind == JointKind::Free);
            if free && fixed_blocks {
                // A free joint (at the top of its tree: no ancestors), its 21 entries written
                // by loops of fixed length, which unroll: on `floating3` (three free bodies)
                // the general loop's bookkeeping over rows of 1 to 6 entries was most of the
                // mass matrix's cost.
                let block = m.rows_mut(dofs.clone());
                let s = &kin.s[dofs.clone()];
                // (A plain loop: `std::array::from_fn` here was a twentieth of the step's
                // wall time, its machinery not inlined.)
                let mut f = [Vector6::zeros(); 6];
                for (a, fa) in f.iter_mut().enumerate() {
                    *fa = match self.dof_unit[dofs.start + a] {
                        Some(u) => ic[i].apply_unit(u),
                        None => ic[i].apply(&s[a]),
                    };
                }
                let mut at = 0;
                for a in 0..6 {
                    for b in (0..a + 1).rev() {
                        block[at] = f[a].dot(&s[b]);
                        at += 1;
                    }
                }
                continue;
            }
            for a in dofs.clone() {
                // Row a as stored: a, then its ancestors from the nearest up (`TreeMatrix`),
                // written in that order, each against its DOF's column (slices of the
                // columns: no index checked per entry).
                let row = m.row_mut(a);
                let mut f = match self.dof_unit[a] {
                    Some(u) => ic[i].apply_unit(u),
                    None => ic[i].apply(&kin.s[a]),
                };
                // The node's own block: the earlier DOFs of a joint are ancestors of the later.
                let (own, above) = row.split_at_mut(a + 1 - dofs.start);
                for (e, s) in own.iter_mut().zip(kin.s[dofs.start..a + 1].iter().rev()) {
                    *e = f.dot(s);
                }
                let mut rest = above;
                let mut j = i;
                while let Some(p) = self.nodes[j].parent {
                    f = kin.x[j].force_to_parent(&f);
                    j = p;
                    let up = self.node_dofs(j);
                    let (here, next) = rest.split_at_mut(up.len());
                    for (e, s) in here.iter_mut().zip(kin.s[up].iter().rev()) {
                        *e = f.dot(s);
                    }
                    rest = next;
                }
            }
        }
        for jt in &self.joints {
            for k in 0..jt.kind.nv() {
                *m.entry_mut(jt.dadr + k, jt.dadr + k) += c::<T>(jt.armature);
            }
        }
        m
    }

    /// The joints on the path from body `b` to the world.
    pub fn path_joints(&self, mut b: usize) -> Vec<usize> {
        let mut out = Vec::new();
        while b != 0 {
            out.extend(&self.bodies[b].joints);
            b = self.bodies[b].parent.unwrap_or(0);
        }
        out
    }
}

#[cfg(test)]
#[path = "tree_tests.rs"]
mod tests;
