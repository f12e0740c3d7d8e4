//! Kinematics of a tree at one configuration and velocity: every node's transform, motion
//! subspace, velocity and bias acceleration, and every body's frame (pose and velocity).

use super::*;

/// Rotation by `angle` about the unit `axis`.
fn axis_angle<T: Scalar>(axis: &Vector3<f64>, angle: T) -> Matrix3<T> {
    let (s, co) = (angle.sin(), angle.cos());
    let k = skew(&axis.map(c::<T>));
    Matrix3::identity() + k * s + k * k * (T::one() - co)
}

/// Everything the dynamics needs from one configuration and velocity.
#[derive(Clone, Debug)]
pub struct Kinematics<T: Scalar> {
    /// Per node: transform from its parent node's frame (or the world) to its frame.
    pub(super) x: Vec<Transform<T>>,
    /// Per DOF (velocity index): its motion subspace column, in the frame of its joint's node.
    pub(super) s: Vec<Vector6<T>>,
    /// Per node: spatial velocity (node frame).
    pub(super) vel: Vec<Vector6<T>>,
    /// Per node: velocity-product acceleration `c_J + v × v_J` (node frame).
    pub(super) bias_acc: Vec<Vector6<T>>,
    /// Per body: world pose and velocity of the body frame.
    pub frames: Vec<crate::collision::Frame<T>>,
}

impl Tree {
    /// Forward kinematics with every mocap body at its scene pose, at rest.
    pub fn kinematics<T: Scalar>(&self, q: &[T], v: &[T]) -> Kinematics<T> {
        self.kinematics_with(q, v, &[])
    }

    /// Forward kinematics: frames, spatial velocities and motion subspaces. `mocap` holds
    /// [`MOCAP_INPUTS`] numbers per mocap body (in [`Tree::mocap`] order), or is empty for the
    /// scene poses at rest.
    ///
    /// # Panics
    /// If `mocap` is neither empty nor of length `MOCAP_INPUTS · mocap bodies`.
    pub fn kinematics_with<T: Scalar>(&self, q: &[T], v: &[T], mocap: &[T]) -> Kinematics<T> {
        let mut kin = Kinematics::empty();
        self.kinematics_into(q, v, mocap, &mut kin);
        kin
    }

    /// [`Tree::kinematics_with`] written into `kin`, whose buffers are reused (the same bits,
    /// whatever `kin` held before): a caller that computes kinematics at every step keeps one
    /// [`Kinematics`] instead of allocating five vectors each time.
    ///
    /// # Panics
    /// As [`Tree::kinematics_with`].
    pub fn kinematics_into<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        mocap: &[T],
        kin: &mut Kinematics<T>,
    ) {
        assert!(
            mocap.is_empty() || mocap.len() == MOCAP_INPUTS * self.mocap.len(),
            "{} mocap inputs for {} mocap bodies",
            mocap.len(),
            self.mocap.len()
        );
        let Kinematics {
            x,
            s,
            vel,
            bias_acc,
            frames,
        } = kin;
        x.clear();
        vel.clear();
        bias_acc.clear();
        // Every DOF's column, at its velocity index (a node's columns are its joint's DOFs).
        s.clear();
        s.resize(self.nv, Vector6::zeros());
        // Every body's frame, written at each of its nodes in turn (a body's nodes come one
        // after the other, its last one its frame): until a body's last node is done, its
        // entry holds the world pose of the node done last, which is what that body's next
        // node and only it reads as its parent's. The world and any body without a node
        // stay at the identity. (Reused buffers of this length: only those are set, the
        // others being written before they are read; a fill of every entry was a fiftieth of
        // a step of free bodies out of reach.)
        let identity = crate::collision::Frame::identity();
        debug_assert_eq!(self.body_node.len(), self.bodies.len());
        if frames.len() == self.bodies.len() {
            for (f, node) in frames.iter_mut().zip(&self.body_node) {
                if node.is_none() {
                    *f = identity;
                }
            }
        } else {
            frames.clear();
            frames.resize(self.bodies.len(), identity);
        }
        let world = |frame: &crate::collision::Frame<T>| Transform {
            rotation: frame.rotation,
            translation: frame.origin,
        };
        for node in &self.nodes {
            let (xj, cj): (Transform<T>, Vector6<T>) = match node.joint.map(|j| &self.joints[j]) {
                None if self.bodies[node.body].mocap && !mocap.is_empty() => {
                    // A mocap body: its world pose and velocity are inputs (it is top-level).
                    let m = &mocap[MOCAP_INPUTS
                        * self.mocap.iter().position(|&b| b == node.body).unwrap_or(0)..];
                    let r = quat_matrix(&quat_from(&m[3..7]));
                    let xi = Transform {
                        rotation: r,
                        translation: Vector3::new(m[0], m[1], m[2]),
                    };
                    let linvel = Vector3::new(m[7], m[8], m[9]);
                    let angvel = Vector3::new(m[10], m[11], m[12]);
                    x.push(xi);
                    vel.push(spatial::spatial(&angvel, &(r.transpose() * linvel)));
                    bias_acc.push(Vector6::zeros());
                    frames[node.body] = body_frame(&xi, &vel[vel.len() - 1]);
                    continue;
                }
                None => (Transform::identity(), Vector6::zeros()),
                Some(j) => {
                    let qa = j.qadr;
                    let da = j.dadr;
                    match j.kind {
                        JointKind::Slide => {
                            let a = j.axis.map(c::<T>);
                            s[da] = spatial::spatial(&Vector3::zeros(), &a);
                            let xj = Transform {
                                rotation: Matrix3::identity(),
                                translation: a * (q[qa] - c::<T>(j.reference)),
                            };
                            (xj, Vector6::zeros())
                        }
                        JointKind::Hinge => {
                            let a = j.axis.map(c::<T>);
                            let p = j.anchor.map(c::<T>);
                            let r = axis_angle(&j.axis, q[qa] - c::<T>(j.reference));
                            s[da] = spatial::spatial(&a, &p.cross(&a));
                            let xj = Transform {
                                rotation: r,
                                translation: p - r * p,
                            };
                            (xj, Vector6::zeros())
                        }
                        JointKind::Ball => {
                            let p = j.anchor.map(c::<T>);
                            let r = quat_matrix(&quat_from(&q[qa..qa + 4]));
                            let px = skew(&p);
                            for k in 0..3 {
                                s[da + k] = spatial::spatial(
                                    &Vector3::ith(k, T::one()),
                                    &px.column(k).into_owned(),
                                );
                            }
                            let xj = Transform {
                                rotation: r,
                                translation: p - r * p,
                            };
                            (xj, Vector6::zeros())
                        }
                        JointKind::Free => {
                            let r = quat_matrix(&quat_from(&q[qa + 3..qa + 7]));
                            let rt = r.transpose();
                            for k in 0..3 {
                                s[da + k] =
                                    spatial::spatial(&Vector3::zeros(), &rt.column(k).into_owned());
                                s[da + 3 + k] =
                                    spatial::spatial(&Vector3::ith(k, T::one()), &Vector3::zeros());
                            }
                            let vw = Vector3::new(v[da], v[da + 1], v[da + 2]);
                            let wb = Vector3::new(v[da + 3], v[da + 4], v[da + 5]);
                            let cj = spatial::spatial(&Vector3::zeros(), &(-wb.cross(&(rt * vw))));
                            // A free joint's frame is absolute: it ignores the body offset.
                            let xj = Transform {
                                rotation: r,
                                translation: Vector3::new(q[qa], q[qa + 1], q[qa + 2]),
                            };
                            x.push(xj);
                            vel.push(self.joint_velocity(s, v, da..da + 6));
                            bias_acc.push(cj);
                            frames[node.body] = body_frame(&xj, &vel[vel.len() - 1]);
                            continue;
                        }
                    }
                }
            };
            let xi = node.offset.lift::<T>().then(&xj);
            let parent_world = node
                .parent
                .map(|p| world(&frames[self.nodes[p].body]))
                .unwrap_or_else(Transform::identity);
            let vparent = node
                .parent
                .map(|p| xi.motion(&vel[p]))
                .unwrap_or_else(Vector6::zeros);
            let vj = self.joint_velocity(s, v, self.node_dofs_of(node));
            let vi = vparent + vj;
            bias_acc.push(cj + cross_motion(&vi, &vj));
            vel.push(vi);
            x.push(xi);
            frames[node.body] = body_frame(&parent_world.then(&xi), &vi);
        }
    }
}

/// A body's frame from its node's world pose `w` and spatial velocity `vel` (node frame).
fn body_frame<T: Scalar>(w: &Transform<T>, vel: &Vector6<T>) -> crate::collision::Frame<T> {
    crate::collision::Frame {
        rotation: w.rotation,
        origin: w.translation,
        linvel: w.rotation * spatial::lin(vel),
        angvel: w.rotation * spatial::ang(vel),
    }
}

impl<T: Scalar> Kinematics<T> {
    /// Kinematics of nothing, holding no memory: to be filled by [`Tree::kinematics_into`].
    pub fn empty() -> Kinematics<T> {
        Kinematics {
            x: Vec::new(),
            s: Vec::new(),
            vel: Vec::new(),
            bias_acc: Vec::new(),
            frames: Vec::new(),
        }
    }
}

impl Tree {
    /// The bodies' frames of `kin`'s positions at the velocities `v` ([`Kinematics::frames`]
    /// of [`Tree::kinematics_with`]`(q, v, mocap)`, `q` and `mocap` those of `kin`): the same
    /// bits without the positions' rotations and transforms made again, only the velocities
    /// carried down the tree. What damped Euler's Newton iterations read at each trial end
    /// velocity (`FrozenForward`): on gymnasium's humanoid the full kinematics there were a
    /// tenth of its run.
    ///
    /// # Panics
    /// If `v` has not one entry per velocity coordinate.
    pub fn frames_at_velocity<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        v: &[T],
        mocap: &[T],
    ) -> Vec<crate::collision::Frame<T>> {
        assert_eq!(v.len(), self.nv, "one velocity per coordinate");
        let mut vel: Vec<Vector6<T>> = Vec::with_capacity(self.nodes.len());
        for (i, node) in self.nodes.iter().enumerate() {
            let free = node
                .joint
                .is_some_and(|j| self.joints[j].kind == JointKind::Free);
            let mocap_node =
                node.joint.is_none() && self.bodies[node.body].mocap && !mocap.is_empty();
            vel.push(if mocap_node {
                // Its velocity is an input, not a coordinate.
                kin.vel[i]
            } else if free {
                self.joint_velocity(&kin.s, v, self.node_dofs_of(node))
            } else {
                // As `kinematics_with`: the parent's velocity carried by the node's transform,
                // plus the joint's.
                let vparent = node
                    .parent
                    .map(|p| kin.x[i].motion(&vel[p]))
                    .unwrap_or_else(Vector6::zeros);
                vparent + self.joint_velocity(&kin.s, v, self.node_dofs_of(node))
            });
        }
        (self.body_node.iter().zip(&kin.frames))
            .map(|(bn, frame)| match bn {
                None => *frame,
                Some(i) => crate::collision::Frame {
                    rotation: frame.rotation,
                    origin: frame.origin,
                    linvel: frame.rotation * spatial::lin(&vel[*i]),
                    angvel: frame.rotation * spatial::ang(&vel[*i]),
                },
            })
            .collect()
    }

    /// The velocity `Σ_k s_k v_k` of the columns `dofs` of `s`.
    pub(super) fn joint_velocity<T: Scalar>(
        &self,
        s: &[Vector6<T>],
        v: &[T],
        dofs: std::ops::Range<usize>,
    ) -> Vector6<T> {
        dofs.fold(Vector6::zeros(), |acc, k| acc + s[k] * v[k])
    }
}

/// One velocity coordinate's share of a body's frame velocity (a column of the body's
/// Jacobian): `(dof, linear, angular)`, the velocity of the body origin and the angular
/// velocity (world frame) that a unit velocity of `dof` gives the body.
pub type BodyColumn<T> = (usize, Vector3<T>, Vector3<T>);

impl Tree {
    /// The columns of body `b`'s Jacobian at the configuration of `kin`: for every velocity
    /// coordinate that moves it, the frame velocity ([`crate::collision::Frame`]'s `linvel`
    /// and `angvel`) a unit velocity of that coordinate gives it, so that
    /// `Σ (linear, angular) v[dof]` is the body's frame velocity and `Σ (linear·f + angular·τ)`
    /// over the columns gives the generalized force of a wrench `(f, τ)` on the body (world
    /// frame, torque about its origin), as [`Tree::wrench_forces`]. Empty for the world, a
    /// mocap body and a body welded to either. Costs the depth of the body's node: each
    /// ancestor's motion subspace is carried down to the body's node by the composed joint
    /// transforms.
    pub fn body_jacobian<T: Scalar>(&self, kin: &Kinematics<T>, b: usize) -> Vec<BodyColumn<T>> {
        let mut out = Vec::new();
        let Some(i) = self.body_node[b] else {
            return out;
        };
        let rotation = kin.frames[b].rotation;
        // From node j's frame to node i's, starting at j = i.
        let mut down = Transform::identity();
        let mut j = i;
        loop {
            for d in self.node_dofs(j) {
                let m = down.motion(&kin.s[d]);
                out.push((d, rotation * spatial::lin(&m), rotation * spatial::ang(&m)));
            }
            match self.nodes[j].parent {
                Some(p) => {
                    down = kin.x[j].then(&down);
                    j = p;
                }
                None => return out,
            }
        }
    }
}
