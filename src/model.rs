//! The whole model: the mechanical tree, each body's collider, the colliding pairs, actuators
//! and contact parameters; and the dynamics of the paper's eq. 27–28 on it:
//! `M(q) v̇ + c(q, v) = τ_actuators + τ_passive + Σ_pairs Λ_ab(q, v)`.
//!
//! The model does not change while it is stepped: what changes from step to step lives in the
//! caller's state and solver cache (MuJoCo's `mjModel`/`mjData` split). Between steps a host may
//! change its solver settings (`integrator` through [`Model::set_integrator`], which also sets
//! the limit laws that integrator takes, `step`, `tolerance`), as MuJoCo's `mjModel.opt` can.

use crate::collision::Collider;
use crate::contact::{ContactParams, PairContact, Wrench};
use crate::dynamics::fluid::Fluid;
use crate::dynamics::limit::LimitLaw;
use crate::dynamics::{quat_exp, quat_from, quat_log, JointKind, Kinematics, Tree, MOCAP_INPUTS};
use crate::integrator::Integrator;
use crate::scalar::{c, Scalar};
use nalgebra::{DVector, Vector3};

mod activation;
mod actuator;
mod coupled;
mod energy;
mod forward;
mod frozen;
mod pairs;
pub use activation::{Activation, ActivationLaw};
pub use actuator::{Actuator, ActuatorKind, SiteTransmission, SliderCrank, Transmission};
pub use energy::Energy;
pub use forward::{EvalPoint, ForwardOptions};
pub use frozen::FrozenForward;
pub(crate) use frozen::FrozenStart;
pub use pairs::{Pair, PairThreads, Reuse};

/// The complete model of a scene (see the module doc for what may change between steps).
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
    /// Internal time step (s; MuJoCo's `timestep`, the FMU's `solver.step`).
    pub timestep: f64,
    /// Local error tolerance of the adaptive integrator.
    pub tolerance: f64,
    /// Number of soft top-K contact points output per pair (`scm_contact_points`; 0: none).
    pub contact_points: usize,
    /// Initial positions: the reference configuration ([`Tree::q0`]), or a `<keyframe>`'s
    /// `qpos` chosen by `scm_keyframe`.
    pub q0: Vec<f64>,
    /// Initial velocities (zero, or the chosen keyframe's `qvel`).
    pub v0: Vec<f64>,
    /// Initial controls (zero, or the chosen keyframe's `ctrl`).
    pub ctrl0: Vec<f64>,
    /// Initial activations ([`Model::na`]; zero, or the chosen keyframe's `act`).
    pub act0: Vec<f64>,
    /// Fluid forces (MuJoCo's inertia-box model), if the scene's medium has a density or a
    /// viscosity.
    pub fluid: Option<Fluid>,
    /// Fixed tendons (`<tendon><fixed>`), each with its spring, damper, dry friction and
    /// limits (all zero for a tendon that only measures a length).
    pub tendons: Vec<crate::dynamics::tendon::FixedTendon>,
    /// Joint and tendon equality constraints, as springs and dampers.
    pub equalities: Vec<crate::dynamics::equality::ScalarEquality>,
    /// Connect equality constraints, as springs and dampers between two points.
    pub connects: Vec<crate::dynamics::equality::Connect>,
    /// Spatial tendons (`<tendon><spatial>` through sites and pulleys), each with its spring,
    /// damper, dry friction and limits; their forces act on the bodies at the sites.
    pub spatial_tendons: Vec<crate::dynamics::tendon::SpatialTendon>,
    /// The site transmissions of actuators that drive sites ([`Transmission::Site`]).
    pub site_transmissions: Vec<crate::model::SiteTransmission>,
    /// The slider-crank transmissions ([`Transmission::SliderCrank`]).
    pub slider_cranks: Vec<crate::model::SliderCrank>,
    /// Degrees of freedom whose total actuator force is clamped (MuJoCo's joint
    /// `actuatorfrcrange`): the velocity index and the range (N or N·m).
    pub actuator_ranges: Vec<(usize, f64, f64)>,
    /// How many threads evaluate the pairs in reach (the results are the same bits whatever
    /// it is; [`PairThreads::default_for_machine`] for a loaded scene).
    pub pair_threads: PairThreads,
}

/// Result of forward dynamics.
#[derive(Clone, Debug)]
pub struct Forward<T: Scalar> {
    /// Accelerations `v̇`.
    pub vdot: DVector<T>,
    /// Contact per pair, in the order of `Model::pairs` (see [`Model::contact_forces`]):
    /// `None` for a pair out of reach, whose wrenches are zero and whose smooth distance was
    /// not evaluated. Empty where the options did not ask for it
    /// ([`ForwardOptions::list_contacts`]).
    pub contacts: Vec<Option<PairContact<T>>>,
    /// The share each limit held ([`crate::dynamics::limit::JointLimit::hold`]), one per joint,
    /// fixed tendon and spatial tendon, where a limit with MuJoCo's impedance let go in part or
    /// in all; `None` where
    /// every limit held in all (or the options gave the shares, [`ForwardOptions::holds`]).
    pub holds: Option<Vec<T>>,
    /// The kinematics of the evaluation's `(q, v, mocap)` ([`ForwardOptions::kinematics`] or
    /// computed), handed back so that a caller computing kinematics again reuses their buffers
    /// ([`crate::dynamics::Tree::kinematics_into`]).
    pub(crate) kinematics: Kinematics<T>,
}

/// Why the dynamics could not be evaluated.
#[derive(Debug, Clone, thiserror::Error, PartialEq)]
pub enum DynamicsError {
    /// The mass matrix is not positive definite (should not happen for a valid model; a
    /// non-finite configuration gets here).
    #[error("the mass matrix is not positive definite (is the configuration finite?)")]
    Singular,
    /// An input vector of the wrong length.
    #[error("{got} inputs given: expected {expected} ({actuators} actuator controls, then {per} per mocap body: Simulation::inputs() gives them)", per = MOCAP_INPUTS)]
    Inputs {
        /// Full length `nu`.
        expected: usize,
        /// Number of actuators.
        actuators: usize,
        /// Length given.
        got: usize,
    },
    /// A state with another number of activations than the model's actuators have.
    #[error("a state with {got} activations: this model's actuators have {expected} (Model::act0 gives the initial ones)")]
    Activations {
        /// The model's `na`.
        expected: usize,
        /// The state's.
        got: usize,
    },
    /// The state given to the dynamics is not finite (typically a stage of a diverging step).
    #[error("the dynamics were asked at a non-finite state: {0} is not finite")]
    NonFinite(String),
    /// The Newton iterations of the implicit stage equations did not converge.
    #[error("the implicit integrator's Newton iterations did not converge (residual {residual:.3e} m/s after {iterations} iterations): reduce the step")]
    NewtonFailed {
        /// Iterations done.
        iterations: usize,
        /// Max-norm of the last residual (m/s).
        residual: f64,
    },
}

impl Model {
    /// Number of inputs `u`: the actuator controls, then [`MOCAP_INPUTS`] per mocap body
    /// (position, quaternion, linear and angular velocity; see [`MOCAP_INPUTS`]).
    pub fn nu(&self) -> usize {
        self.actuators.len() + MOCAP_INPUTS * self.tree.mocap.len()
    }

    /// The inputs at the scene's start: zero controls, mocap bodies at their scene pose at rest.
    pub fn u0(&self) -> Vec<f64> {
        let mut u = vec![0.0; self.actuators.len()];
        u.extend(self.tree.mocap0());
        u
    }

    /// Splits an input vector (length [`Model::nu`]) into actuator controls and mocap inputs.
    /// A vector of another length is an error: in particular, for a scene with mocap bodies, the
    /// actuator controls alone are refused rather than leaving the mocap bodies somewhere.
    pub fn split_inputs<'a, T>(&self, u: &'a [T]) -> Result<(&'a [T], &'a [T]), DynamicsError> {
        let na = self.actuators.len();
        if u.len() == self.nu() {
            Ok((&u[..na], &u[na..]))
        } else {
            Err(DynamicsError::Inputs {
                expected: self.nu(),
                actuators: na,
                got: u.len(),
            })
        }
    }

    /// The inputs `dt` later, with every mocap body moved by its velocity (constant linear and
    /// body-frame angular velocity: `p + dt·v`, `q ⊗ exp(dt·ω/2)`); controls unchanged.
    pub fn inputs_after<T: Scalar>(&self, u: &[T], dt: T) -> Vec<T> {
        let mut out = u.to_vec();
        let na = self.actuators.len();
        if u.len() != self.nu() {
            return out;
        }
        for m in 0..self.tree.mocap.len() {
            let o = na + MOCAP_INPUTS * m;
            for k in 0..3 {
                out[o + k] = u[o + k] + u[o + 7 + k] * dt;
            }
            let w = Vector3::new(u[o + 10], u[o + 11], u[o + 12]) * dt;
            let r = quat_from(&u[o + 3..o + 7]) * quat_exp(&w);
            out[o + 3..o + 7].copy_from_slice(&[r.w, r.i, r.j, r.k]);
        }
        out
    }

    /// Adds the passive forces that act on bodies to the wrenches `w` (world frame, about the
    /// body origin): the fluid's ([`Fluid`]) and each body's gravity compensation (`-gravcomp ·
    /// m g` at its centre of mass, see [`Body::gravcomp`](crate::dynamics::Body::gravcomp)), as
    /// MuJoCo applies it: a passive force on the body, not a change of gravity, so its
    /// generalized force is `Jᵀ f` through the tree.
    fn add_body_forces<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        stiction_velocity: T,
        w: &mut [Wrench<T>],
    ) {
        if let Some(fluid) = &self.fluid {
            fluid.add_wrenches(&kin.frames, w);
        }
        for c in &self.connects {
            c.add_wrenches(&kin.frames, w);
        }
        for t in self.spatial_tendons.iter().filter(|t| t.law.acts()) {
            t.add_wrenches(&kin.frames, stiction_velocity, w);
        }
        for (b, body) in self.tree.bodies.iter().enumerate().skip(1) {
            if body.gravcomp == 0.0 {
                continue;
            }
            let f = &kin.frames[b];
            let force = (self.tree.gravity * (-body.gravcomp * body.inertia.mass)).map(c::<T>);
            let arm = f.rotation * body.inertia.com.map(c::<T>);
            w[b].torque += arm.cross(&force);
            w[b].force += force;
        }
    }

    /// The pruning tolerance `τ` its point clouds carry (docs/method.md, "Numerical rules"):
    /// the scene's `scm_prune_tolerance`, or the FMU's `scm.prune_tolerance`; `None` for a model
    /// without a point cloud, where nothing reads it.
    pub fn prune_tolerance(&self) -> Option<f64> {
        self.colliders
            .iter()
            .flatten()
            .find_map(Collider::tolerance)
    }

    /// Gives every point cloud the pruning tolerance `tolerance` (each pair reads its two
    /// clouds'); a cloud whose tolerance changes builds its hierarchy again on its next use,
    /// as the scene loader's does.
    pub fn set_prune_tolerance(&mut self, tolerance: f64) {
        for c in self.colliders.iter_mut().flatten() {
            if let Collider::Aopc(s) = c {
                s.set_tolerance(tolerance);
            }
        }
    }

    /// Makes `integrator` the model's, its joint and tendon limits and its equality
    /// constraints acting as that integrator takes them ([`LimitLaw::under`]: MuJoCo's
    /// statics, with its impedance as an added inertia where the step does not take their
    /// damping implicitly; docs/mjcf.md, "Joint limits" and "Equality constraints").
    pub fn set_integrator(&mut self, integrator: Integrator) {
        self.integrator = integrator;
        use crate::dynamics::limit::Held;
        let (joints, tendons, coupled) = (
            LimitLaw::under(integrator, Held::Joint),
            LimitLaw::under(integrator, Held::Tendon),
            LimitLaw::under(integrator, Held::Equality),
        );
        for j in &mut self.tree.joints {
            j.limit = j.limit.map(|l| l.acting(joints));
        }
        for t in &mut self.tendons {
            t.limit = t.limit.map(|l| l.acting(tendons));
        }
        for t in &mut self.spatial_tendons {
            t.law.limit = t.law.limit.map(|l| l.acting(tendons));
        }
        for e in &mut self.equalities {
            (e.stiffness, e.damping) = e.gains.acting(coupled);
            e.impedance = e.gains.added_inertia(coupled);
        }
        for c in &mut self.connects {
            (c.stiffness, c.damping) = c.gains.acting(coupled);
            c.impedance = c.gains.added_inertia(coupled);
            if let Some(o) = &mut c.orientation {
                (o.stiffness, o.damping) = o.gains.acting(coupled);
                o.impedance = o.gains.added_inertia(coupled);
            }
        }
    }

    /// Generalized passive forces (docs/method.md): viscous damping `-b v`, joint limits (smooth
    /// one-sided springs and dampers, [`crate::dynamics::limit`]), springs towards the rest
    /// position (`-k (q - springref)` for slide and hinge joints, `-k θ` for ball joints, `θ` the rotation
    /// vector of the joint's quaternion: the exact gradient of `½ k |θ|²`), and smooth dry
    /// friction `-F v / sqrt(v_s² + v²)` per degree of freedom, with `v_s` the stiction velocity.
    pub fn passive_forces<T: Scalar>(&self, q: &[T], v: &[T], stiction_velocity: T) -> DVector<T> {
        let mut tau = DVector::zeros(self.tree.nv);
        for j in &self.tree.joints {
            let theta = (j.kind == JointKind::Ball && j.stiffness != 0.0)
                .then(|| quat_log(&quat_from(&q[j.qadr..j.qadr + 4])));
            for k in 0..j.kind.nv() {
                let vi = v[j.dadr + k];
                let mut t = -vi * j.damping;
                if j.frictionloss > 0.0 {
                    t -= vi * j.frictionloss
                        / (stiction_velocity * stiction_velocity + vi * vi).sqrt();
                }
                if j.stiffness != 0.0 {
                    match (j.kind, &theta) {
                        (JointKind::Slide | JointKind::Hinge, _) => {
                            t -= (q[j.qadr] - c::<T>(j.springref)) * j.stiffness
                        }
                        (JointKind::Ball, Some(th)) => t -= th[k] * j.stiffness,
                        _ => {}
                    }
                }
                tau[j.dadr + k] += t;
            }
            if let Some(l) = &j.limit {
                tau[j.dadr] += l.force(q[j.qadr], v[j.dadr]);
            }
        }
        for t in self.tendons.iter().filter(|t| t.acts()) {
            let f = t.force(q, v, stiction_velocity);
            for &(_, vi, coef) in &t.joints {
                tau[vi] += f * coef;
            }
        }
        for e in &self.equalities {
            e.add_force(q, v, tau.as_mut_slice());
        }
        tau
    }

    /// Inverse dynamics (paper eq. 27): the generalized actuation `τ = ID(q, v, v̇) = M v̇ + c -
    /// Σ Λ - τ_passive` that produces accelerations `vdot`, contact included, so that
    /// `ID(q, v, FD(q, v, τ)) = τ`. `mocap`: [`MOCAP_INPUTS`] per mocap body, or empty;
    /// `pulls`: the adhesion actuators' ([`Model::pulls`] of the controls, or empty: none), whose
    /// force acts through the contacts, not in `τ`.
    pub fn inverse<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        vdot: &[T],
        mocap: &[T],
        prm: &ContactParams<T>,
        pulls: &[Option<T>],
    ) -> DVector<T> {
        let kin = self.tree.kinematics_with(q, v, mocap);
        let (mut wrenches, _) = self.contact_forces(&kin, prm, pulls);
        self.add_body_forces(&kin, prm.stiction_velocity, &mut wrenches);
        let mut tau = self.tree.rnea(&kin, vdot, &wrenches)
            - self.passive_forces(q, v, prm.stiction_velocity);
        // Armature is part of M but not of the bodies' inertia, and so is the inertia MuJoCo's
        // impedance adds (`Model::add_impedance_forces`).
        for j in &self.tree.joints {
            for k in 0..j.kind.nv() {
                tau[j.dadr + k] += vdot[j.dadr + k] * j.armature;
            }
        }
        self.add_impedance_forces(&kin, q, v, vdot, &mut tau);
        tau
    }

    /// Total mass of the bodies that move (kg).
    pub fn moving_mass(&self) -> f64 {
        (1..self.tree.bodies.len())
            .filter(|&b| self.tree.body_moves(b))
            .map(|b| self.tree.bodies[b].inertia.mass)
            .sum()
    }
}
