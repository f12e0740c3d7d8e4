//! Recursive Newton–Euler (Featherstone, *Rigid Body Dynamics Algorithms*, ch. 5): the bias
//! forces `c(q, v) - Σ Jᵀ f_ext` and inverse dynamics, its forward pass split from the
//! external wrenches so that many wrenches at one state share one pass; the generalized force
//! of body wrenches alone (its backward pass) and the bodies' velocity-product accelerations.

use super::*;
use crate::contact::Wrench;

impl Tree {
    /// Recursive Newton–Euler: the generalized force that produces acceleration `vdot` under
    /// gravity and external body wrenches `f_ext` (per body, world frame, torque about the body
    /// origin). With `vdot = 0` this is the bias `c(q, v) - Σ Jᵀ f_ext`; an empty `vdot` is
    /// taken as zero (the bias, without a vector of zeros to allocate at every evaluation).
    ///
    /// # Panics
    /// If `vdot` is neither empty nor one entry per velocity coordinate.
    pub fn rnea<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        vdot: &[T],
        f_ext: &[Wrench<T>],
    ) -> DVector<T> {
        self.rnea_with(kin, self.rnea_forces(kin, vdot), f_ext)
    }

    /// RNEA's forward pass ([`Tree::rnea`]): each node's spatial force (body coordinates)
    /// that gives it the acceleration of `vdot` (empty: zero) under gravity, before any
    /// external wrench. It reads no wrench, so a caller that evaluates many wrenches at one
    /// configuration and velocity (damped Euler's Newton iterations, `FrozenForward`) makes
    /// it once and finishes each with [`Tree::rnea_with`]: the same bits as [`Tree::rnea`].
    ///
    /// # Panics
    /// If `vdot` is neither empty nor one entry per velocity coordinate.
    pub fn rnea_forces<T: Scalar>(&self, kin: &Kinematics<T>, vdot: &[T]) -> Vec<Vector6<T>> {
        assert!(
            vdot.is_empty() || vdot.len() == self.nv,
            "{} accelerations for {} velocity coordinates",
            vdot.len(),
            self.nv
        );
        let n = self.nodes.len();
        let g = self.gravity.map(c::<T>);
        let a0 = spatial::spatial(&Vector3::zeros(), &(-g));
        let mut f: Vec<Vector6<T>> = Vec::with_capacity(n);
        let mut acc: Vec<Vector6<T>> = Vec::with_capacity(n);
        for i in 0..n {
            let node = &self.nodes[i];
            let ap = match node.parent {
                Some(p) => kin.x[i].motion(&acc[p]),
                None => kin.x[i].motion(&a0),
            };
            let ai = if vdot.is_empty() {
                ap + kin.bias_acc[i]
            } else {
                ap + self.joint_velocity(&kin.s, vdot, self.node_dofs(i)) + kin.bias_acc[i]
            };
            let inertia = self.node_inertia::<T>(i);
            acc.push(ai);
            f.push(inertia.apply(&ai) + cross_force(&kin.vel[i], &inertia.apply(&kin.vel[i])));
        }
        f
    }

    /// [`Tree::rnea`] from its forward pass's forces `f` ([`Tree::rnea_forces`]): the
    /// external wrenches `f_ext` taken from them, then the backward pass.
    pub fn rnea_with<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        mut f: Vec<Vector6<T>>,
        f_ext: &[Wrench<T>],
    ) -> DVector<T> {
        for (fi, node) in f.iter_mut().zip(&self.nodes) {
            if node.carries_inertia {
                *fi -= body_wrench(kin, node, f_ext);
            }
        }
        self.backward(kin, f)
    }

    /// RNEA's backward pass: each node's spatial force `f` (body coordinates) projected on its
    /// joint's motion subspace, then carried to its parent; the generalized forces.
    fn backward<T: Scalar>(&self, kin: &Kinematics<T>, mut f: Vec<Vector6<T>>) -> DVector<T> {
        let mut tau = DVector::zeros(self.nv);
        for i in (0..self.nodes.len()).rev() {
            for k in self.node_dofs(i) {
                tau[k] = kin.s[k].dot(&f[i]);
            }
            if let Some(p) = self.nodes[i].parent {
                let fp = kin.x[i].force_to_parent(&f[i]);
                f[p] += fp;
            }
        }
        tau
    }

    /// The generalized force `Σ Jᵀ f` of body wrenches `f_ext` (per body, world frame, torque
    /// about the body origin) at the configuration of `kin`: the backward pass of
    /// [`Tree::rnea`] alone (`rnea` at rest without gravity would give its negative plus the
    /// velocity terms).
    pub fn wrench_forces<T: Scalar>(&self, kin: &Kinematics<T>, f_ext: &[Wrench<T>]) -> DVector<T> {
        let f: Vec<Vector6<T>> = (self.nodes.iter())
            .map(|node| match node.carries_inertia {
                true => body_wrench(kin, node, f_ext),
                false => Vector6::zeros(),
            })
            .collect();
        self.backward(kin, f)
    }

    /// Each body's acceleration where every joint's acceleration is zero and without gravity,
    /// world axes: `(α, a)`, its angular acceleration and its origin's linear acceleration,
    /// the velocity products `J̇ v` of the body's motion (a point at `r` from the origin then
    /// accelerates at `a + α × r + ω × (ω × r)`). The world and mocap bodies' are zero. RNEA's
    /// forward pass at `v̇ = 0` with the spatial accelerations turned classical
    /// (`a = R (a_s + ω × v)` in body coordinates).
    pub fn bias_accelerations<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
    ) -> Vec<(Vector3<T>, Vector3<T>)> {
        let mut acc: Vec<Vector6<T>> = Vec::with_capacity(self.nodes.len());
        for (i, node) in self.nodes.iter().enumerate() {
            let from_parent = node
                .parent
                .map_or_else(Vector6::zeros, |p| kin.x[i].motion(&acc[p]));
            acc.push(from_parent + kin.bias_acc[i]);
        }
        (self.body_node.iter().enumerate())
            .map(|(b, node)| match node {
                Some(_) if self.bodies[b].mocap => (Vector3::zeros(), Vector3::zeros()),
                None => (Vector3::zeros(), Vector3::zeros()),
                Some(i) => {
                    let r = &kin.frames[b].rotation;
                    let (w, v) = (spatial::ang(&kin.vel[*i]), spatial::lin(&kin.vel[*i]));
                    let (alpha, a) = (spatial::ang(&acc[*i]), spatial::lin(&acc[*i]));
                    (r * alpha, r * (a + w.cross(&v)))
                }
            })
            .collect()
    }
}

/// The external wrench on `node`'s body (`f_ext`: per body, world frame, torque about the body
/// origin) as a spatial force in the body's coordinates.
fn body_wrench<T: Scalar>(kin: &Kinematics<T>, node: &Node, f_ext: &[Wrench<T>]) -> Vector6<T> {
    let rt = kin.frames[node.body].rotation.transpose();
    let w = &f_ext[node.body];
    spatial::spatial(&(rt * w.torque), &(rt * w.force))
}
