//! The whole model: the mechanical tree, each body's collider, the colliding pairs, actuators
//! and contact parameters; and the dynamics of the paper's eq. 27–28 on it:
//! `M(q) v̇ + c(q, v) = τ_actuators + τ_passive + Σ_pairs Λ_ab(q, v)`.
//!
//! The model is immutable; all that changes lives in the caller's state (MuJoCo's
//! `mjModel`/`mjData` split).

use crate::collision::Collider;
use crate::contact::{pair_contact, ContactParams, PairContact, Wrench};
use crate::dynamics::{Kinematics, Tree};
use crate::integrate::Integrator;
use crate::scalar::{c, Scalar};
use nalgebra::DVector;

/// A pair of bodies whose colliders interact.
#[derive(Clone, Debug, PartialEq)]
pub struct Pair {
    /// First body (scene order): the FMU's `contact.A.B.*` forces act on it.
    pub a: usize,
    /// Second body.
    pub b: usize,
}

/// How an actuator turns its control into a joint force.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ActuatorKind {
    /// `force = u`.
    Motor,
    /// `force = kp (u - gear·q) - kv gear·v`.
    Position {
        /// Position gain (N/m or N·m/rad).
        kp: f64,
        /// Velocity gain (N·s/m or N·m·s/rad).
        kv: f64,
    },
    /// `force = kv (u - gear·v)`.
    Velocity {
        /// Velocity gain.
        kv: f64,
    },
}

/// An actuator on a 1-DOF joint. The generalized force is `gear · force`.
#[derive(Clone, Debug, PartialEq)]
pub struct Actuator {
    /// Name (the FMU input is `<name>.ctrl`).
    pub name: String,
    /// Kind and gains.
    pub kind: ActuatorKind,
    /// Joint index.
    pub joint: usize,
    /// Gear ratio.
    pub gear: f64,
    /// Control range, if limited (controls are clamped to it).
    pub ctrlrange: Option<(f64, f64)>,
}

/// The complete, immutable model of a scene.
#[derive(Clone, Debug)]
pub struct Model {
    /// Name of the scene (`<mujoco model="...">`).
    pub name: String,
    /// Bodies and joints.
    pub tree: Tree,
    /// Collider of each body (`None`: it collides with nothing), indexed like `tree.bodies`.
    pub colliders: Vec<Option<Collider>>,
    /// Colliding body pairs.
    pub pairs: Vec<Pair>,
    /// Actuators.
    pub actuators: Vec<Actuator>,
    /// Default contact parameters (the FMU's `scm.*` start values).
    pub contact: ContactParams<f64>,
    /// Integrator.
    pub integrator: Integrator,
    /// Internal time step (s).
    pub step: f64,
    /// Local error tolerance of the adaptive integrator.
    pub tolerance: f64,
    /// Number of soft top-K contact points output per pair (`scm_contact_points`; 0: none).
    pub contact_points: usize,
}

/// Result of forward dynamics.
#[derive(Clone, Debug)]
pub struct Forward<T: Scalar> {
    /// Accelerations `v̇`.
    pub vdot: DVector<T>,
    /// Contact per pair, in the order of `Model::pairs`.
    pub contacts: Vec<PairContact<T>>,
}

/// Why the dynamics could not be evaluated.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DynamicsError {
    /// The mass matrix is not positive definite (should not happen for a valid model).
    #[error("the mass matrix is not positive definite")]
    Singular,
}

impl Model {
    /// Contact of every pair and the wrench each body receives (world frame, about its origin).
    pub fn contacts<T: Scalar>(&self, kin: &Kinematics<T>, prm: &ContactParams<T>) -> (Vec<Wrench<T>>, Vec<PairContact<T>>) {
        let mut wrenches = vec![Wrench::zero(); self.tree.bodies.len()];
        let mut out = Vec::with_capacity(self.pairs.len());
        for pair in &self.pairs {
            let (Some(ca), Some(cb)) = (&self.colliders[pair.a], &self.colliders[pair.b]) else {
                out.push(PairContact { on_a: Wrench::zero(), on_b: Wrench::zero(), distance: c(f64::INFINITY) });
                continue;
            };
            let pc = pair_contact(ca, &kin.frames[pair.a], cb, &kin.frames[pair.b], prm);
            for (b, w) in [(pair.a, &pc.on_a), (pair.b, &pc.on_b)] {
                wrenches[b].force += w.force;
                wrenches[b].torque += w.torque;
            }
            out.push(pc);
        }
        (wrenches, out)
    }

    /// Generalized passive forces: joint springs, dampers and smooth dry friction
    /// `-F v / sqrt(v_s² + v²)` (SPEC §2), with `v_s` the stiction velocity.
    pub fn passive_forces<T: Scalar>(&self, q: &[T], v: &[T], stiction_velocity: T) -> DVector<T> {
        let mut tau = DVector::zeros(self.tree.nv);
        for j in &self.tree.joints {
            for k in 0..j.kind.nv() {
                let vi = v[j.dadr + k];
                let mut t = -vi * j.damping;
                if j.frictionloss > 0.0 {
                    t -= vi * j.frictionloss / (stiction_velocity * stiction_velocity + vi * vi).sqrt();
                }
                if j.kind.nv() == 1 && j.stiffness != 0.0 {
                    t -= q[j.qadr] * j.stiffness;
                }
                tau[j.dadr + k] += t;
            }
        }
        tau
    }

    /// Generalized actuator forces for controls `ctrl` (clamped to their ranges).
    pub fn actuator_forces<T: Scalar>(&self, q: &[T], v: &[T], ctrl: &[T]) -> DVector<T> {
        let mut tau = DVector::zeros(self.tree.nv);
        for (a, &u) in self.actuators.iter().zip(ctrl) {
            let u = match a.ctrlrange {
                Some((lo, _)) if u.re() < lo => c(lo),
                Some((_, hi)) if u.re() > hi => c(hi),
                _ => u,
            };
            let j = &self.tree.joints[a.joint];
            let (qj, vj) = (q[j.qadr], v[j.dadr]);
            let force = match a.kind {
                ActuatorKind::Motor => u,
                ActuatorKind::Position { kp, kv } => (u - qj * a.gear) * kp - vj * (kv * a.gear),
                ActuatorKind::Velocity { kv } => (u - vj * a.gear) * kv,
            };
            tau[j.dadr] += force * a.gear;
        }
        tau
    }

    /// Forward dynamics `v̇ = M⁻¹ (τ_act + τ_passive - c + Σ Λ)` (paper eq. 28).
    pub fn forward<T: Scalar>(&self, q: &[T], v: &[T], ctrl: &[T], prm: &ContactParams<T>) -> Result<Forward<T>, DynamicsError> {
        let kin = self.tree.kinematics(q, v);
        let (wrenches, contacts) = self.contacts(&kin, prm);
        let zero = vec![T::zero(); self.tree.nv];
        let bias = self.tree.rnea(&kin, &zero, &wrenches);
        let rhs = self.actuator_forces(q, v, ctrl) + self.passive_forces(q, v, prm.stiction_velocity) - bias;
        let m = self.tree.mass_matrix(&kin);
        let vdot = m.cholesky().ok_or(DynamicsError::Singular)?.solve(&rhs);
        Ok(Forward { vdot, contacts })
    }

    /// Inverse dynamics (paper eq. 27): the actuation `τ = M v̇ + c - Σ Λ - τ_passive` that
    /// produces accelerations `vdot`.
    pub fn inverse<T: Scalar>(&self, q: &[T], v: &[T], vdot: &[T], prm: &ContactParams<T>) -> DVector<T> {
        let kin = self.tree.kinematics(q, v);
        let (wrenches, _) = self.contacts(&kin, prm);
        let mut tau = self.tree.rnea(&kin, vdot, &wrenches) - self.passive_forces(q, v, prm.stiction_velocity);
        // Armature is part of M but not of the bodies' inertia.
        for j in &self.tree.joints {
            for k in 0..j.kind.nv() {
                tau[j.dadr + k] += vdot[j.dadr + k] * j.armature;
            }
        }
        tau
    }
}
