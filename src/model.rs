//! The whole model: the mechanical tree, each body's collider, the colliding pairs, actuators
//! and contact parameters; and the dynamics of the paper's eq. 27–28 on it:
//! `M(q) v̇ + c(q, v) = τ_actuators + τ_passive + Σ_pairs Λ_ab(q, v)`.
//!
//! The model is immutable; all that changes lives in the caller's state (MuJoCo's
//! `mjModel`/`mjData` split).

use crate::collision::{
    out_of_reach, out_of_reach_kept, Collider, KeptCandidates, KeptReach, PairsKept,
};
use crate::contact::{pair_contact_kept, ContactParams, PairContact, Wrench};
use crate::dynamics::fluid::Fluid;
use crate::dynamics::{quat_exp, quat_from, quat_log, JointKind, Kinematics, Tree, MOCAP_INPUTS};
use crate::integrator::Integrator;
use crate::scalar::{c, Scalar};
use nalgebra::{DVector, Vector3};

mod actuator;
mod frozen;
pub use actuator::{Actuator, ActuatorKind, SiteTransmission, Transmission};
pub use frozen::FrozenForward;

/// A pair of bodies whose colliders interact.
#[derive(Clone, Debug, PartialEq)]
pub struct Pair {
    /// First body (scene order): the FMU's `contact.A.B.*` forces act on it.
    pub a: usize,
    /// Second body.
    pub b: usize,
    /// The pair's own friction coefficient (MuJoCo's combination of its geoms' `friction`, or
    /// a `<pair friction>`), which the contact parameter `friction` does not change; `None`:
    /// the pair uses the contact parameter.
    pub friction: Option<f64>,
    /// The pair's own contact stiffness (N/m; from MuJoCo's `solref` and `solimp` and the
    /// pair's effective mass, docs/mjcf.md), which the contact parameter `stiffness` does not
    /// change; `None`: the pair uses the contact parameter.
    pub stiffness: Option<f64>,
    /// The pair's own dissipation velocity (m/s), as `stiffness`.
    pub dissipation_velocity: Option<f64>,
    /// The pair's own dissipation force (N; [`ContactParams::dissipation_force`]): where its
    /// law comes from the file, `f` times its resting force `m̂ g`, `f` being 4 under an
    /// integrator that takes the damping explicitly (RK4) or the scene's
    /// `scm_dissipation_force`; `None`: the pair uses the contact parameter (infinite by
    /// default, the paper's law).
    pub dissipation_force: Option<f64>,
}

impl Pair {
    /// The contact parameters of this pair: `prm` with the pair's own friction, stiffness,
    /// dissipation velocity and dissipation force where it has them.
    pub fn params<T: Scalar>(&self, prm: &ContactParams<T>) -> ContactParams<T> {
        let own = |x: Option<f64>, p: T| x.map_or(p, c);
        ContactParams {
            friction: own(self.friction, prm.friction),
            stiffness: own(self.stiffness, prm.stiffness),
            dissipation_velocity: own(self.dissipation_velocity, prm.dissipation_velocity),
            dissipation_force: own(self.dissipation_force, prm.dissipation_force),
            ..*prm
        }
    }

    /// Whether the pair has its own value of `p`, which the contact parameter does not change.
    pub fn owns(&self, p: crate::contact::Param) -> bool {
        use crate::contact::Param;
        match p {
            Param::Friction => self.friction.is_some(),
            Param::Stiffness => self.stiffness.is_some(),
            Param::DissipationVelocity => self.dissipation_velocity.is_some(),
            _ => false,
        }
    }
}

/// What an evaluation of the pairs may use of what they keep across calls ([`PairsKept`]).
pub(crate) enum Keep<'a> {
    /// Nothing: every pair proven and walked afresh.
    Nothing,
    /// The out-of-reach proofs and the candidate planes.
    All(&'a mut PairsKept),
    /// The candidate planes only (they change no result), where proofs must be fresh.
    Candidates(&'a mut PairsKept),
}

/// One pair's kept out-of-reach proof and candidate planes, as [`Model::contacts_with`] hands
/// them out (either may be absent).
type PairKept<'a> = (
    Option<&'a mut Option<KeptReach>>,
    Option<&'a mut KeptCandidates>,
);

/// A pair in reach, waiting for its evaluation: its index, colliders, bodies, parameters (its
/// own friction applied) and kept candidate planes.
pub(crate) struct PendingPair<'a, T: Scalar> {
    pub(crate) k: usize,
    pub(crate) sides: [&'a Collider; 2],
    pub(crate) bodies: [usize; 2],
    pub(crate) prm: ContactParams<T>,
    pub(crate) candidates: Option<&'a mut KeptCandidates>,
}

impl<T: Scalar> PendingPair<'_, T> {
    /// The number of points the pair's colliders carry (a half-space has none): a rough
    /// measure of its evaluation's cost, known before it runs, by which the pairs are shared
    /// out over threads.
    fn points(&self) -> usize {
        self.sides
            .iter()
            .map(|c| match c {
                Collider::Aopc(a) => a.points.len(),
                Collider::HalfSpace { .. } => 0,
            })
            .sum()
    }

    /// The pair's contact at `kin`.
    fn evaluate(self, kin: &Kinematics<T>) -> PairContact<T> {
        let [a, b] = self.bodies;
        let [ca, cb] = self.sides;
        pair_contact_kept(
            ca,
            &kin.frames[a],
            cb,
            &kin.frames[b],
            &self.prm,
            self.candidates,
        )
    }
}

/// How many threads evaluate the pairs in reach ([`Model::pair_threads`]). A pair's evaluation
/// reads only the kinematics and writes only its own kept candidates, so pairs run on scoped
/// threads (`std::thread::scope`, joined before the evaluation returns: no thread outlives a
/// call, so an FMU's library can be unloaded safely, which a global pool such as rayon's
/// prevents) and their results are the same bits as serial ones.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairThreads {
    /// Most threads (1: serial).
    pub threads: usize,
    /// Fewest pairs in reach for which more than one thread is used: starting a thread costs
    /// about what evaluating a small pair does ([`PairThreads::MIN_PAIRS`]).
    pub min_pairs: usize,
}

impl PairThreads {
    /// Serial evaluation.
    pub const SERIAL: PairThreads = PairThreads {
        threads: 1,
        min_pairs: usize::MAX,
    };

    /// Two threads where at least [`PairThreads::MIN_PAIRS`] pairs are in reach, if the
    /// machine has two cores to run them; serial otherwise.
    pub fn default_for_machine() -> PairThreads {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        PairThreads {
            threads: cores.min(2),
            min_pairs: Self::MIN_PAIRS,
        }
    }

    /// The default [`PairThreads::min_pairs`]. Measured on 2 cores (`docs/performance.md`),
    /// with a scoped thread started per evaluation: 8 and 32 boxes resting on a floor (8 and
    /// 32 pairs in reach) step 1.2–1.4× faster on two threads, while gymnasium's ant (4 legs on
    /// the floor) gains nothing, `box_stack` (3 pairs) and the half cheetah (2) lose 35–40 %.
    pub const MIN_PAIRS: usize = 8;

    /// `f` of every pair of `pending`, with the pair's index, in pair order: on one thread, or
    /// split over up to [`PairThreads::threads`] by their points.
    pub(crate) fn map<'a, T: Scalar, R: Send>(
        &self,
        pending: Vec<PendingPair<'a, T>>,
        f: impl Fn(PendingPair<'a, T>) -> R + Sync,
    ) -> Vec<(usize, R)> {
        let f = &f;
        let run = move |group: Vec<PendingPair<'a, T>>| -> Vec<(usize, R)> {
            group.into_iter().map(|p| (p.k, f(p))).collect()
        };
        if self.threads < 2 || pending.len() < self.min_pairs.max(2) {
            return run(pending);
        }
        // Largest first, each to the group with the fewest points so far.
        let mut pending = pending;
        pending.sort_by_key(|p| std::cmp::Reverse(p.points()));
        let groups = self.threads.min(pending.len());
        let mut split: Vec<(usize, Vec<PendingPair<'a, T>>)> =
            (0..groups).map(|_| (0, Vec::new())).collect();
        for p in pending {
            let g = (0..groups).min_by_key(|&g| split[g].0).unwrap_or(0);
            split[g].0 += p.points();
            split[g].1.push(p);
        }
        let mut groups = split.into_iter().map(|(_, g)| g);
        let own = groups.next().unwrap_or_default();
        let mut all = std::thread::scope(|s| {
            let others: Vec<_> = groups.map(|g| s.spawn(move || run(g))).collect();
            let mut all = run(own);
            for h in others {
                // A panic in a worker is the same panic here.
                all.extend(h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)));
            }
            all
        });
        all.sort_by_key(|(k, _)| *k);
        all
    }
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
    /// Initial positions: the reference configuration ([`Tree::q0`]), or a `<keyframe>`'s
    /// `qpos` chosen by `scm_keyframe`.
    pub q0: Vec<f64>,
    /// Initial velocities (zero, or the chosen keyframe's `qvel`).
    pub v0: Vec<f64>,
    /// Initial controls (zero, or the chosen keyframe's `ctrl`).
    pub ctrl0: Vec<f64>,
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
    /// not evaluated.
    pub contacts: Vec<Option<PairContact<T>>>,
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

/// Mechanical energy of a state (J).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Energy<T> {
    /// Kinetic energy of the bodies with joints, armature included (J).
    pub kinetic: T,
    /// Potential energy of gravity, zero at the world origin (J).
    pub gravity: T,
    /// Energy stored in joint springs (J).
    pub springs: T,
}

impl<T: Scalar> Energy<T> {
    /// `kinetic + gravity + springs` (J).
    pub fn total(&self) -> T {
        self.kinetic + self.gravity + self.springs
    }
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

    /// Contact of every pair and the wrench each body receives (world frame, about its origin),
    /// every pair evaluated in full, its smooth distance included: what the outputs read.
    pub fn contacts<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        prm: &ContactParams<T>,
    ) -> (Vec<Wrench<T>>, Vec<PairContact<T>>) {
        let (wrenches, pairs) = self.contacts_with(kin, prm, false, Keep::Nothing);
        let pairs = pairs
            .into_iter()
            .map(|pc| pc.unwrap_or_else(PairContact::none))
            .collect();
        (wrenches, pairs)
    }

    /// The contact wrenches for the dynamics: as [`Model::contacts`], except that a pair proven
    /// out of reach ([`out_of_reach`]: every force of the pair below τ times the force scale
    /// `k ε3`, see there) costs only that proof and is `None`: zero wrenches, its smooth
    /// distance not evaluated (the outputs ask [`Model::contacts`] for it).
    pub fn contact_forces<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        prm: &ContactParams<T>,
    ) -> (Vec<Wrench<T>>, Vec<Option<PairContact<T>>>) {
        self.contacts_with(kin, prm, true, Keep::Nothing)
    }

    /// Every pair's contact, with the pair's own friction if it has one (`None`: proven out of
    /// reach, when `prune`), and the wrenches they add up to. The proofs come first, in pair
    /// order; the pairs left are evaluated on [`Model::pair_threads`] threads when they are
    /// many enough ([`PairThreads`]), each with only its own kept candidates, and the wrenches
    /// are summed in pair order whatever the threads: the same bits either way.
    fn contacts_with<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        prm: &ContactParams<T>,
        prune: bool,
        keep: Keep,
    ) -> (Vec<Wrench<T>>, Vec<Option<PairContact<T>>>) {
        let n = self.pairs.len();
        let kept: Vec<PairKept<'_>> = match keep {
            Keep::Nothing => (0..n).map(|_| (None, None)).collect(),
            Keep::All(all) => all.pairs().map(|(r, c)| (Some(r), c)).take(n).collect(),
            Keep::Candidates(all) => all.pairs().map(|(_, c)| (None, c)).take(n).collect(),
        };
        let mut out: Vec<Option<PairContact<T>>> = Vec::with_capacity(n);
        let mut pending = Vec::new();
        for (k, (pair, (reach, candidates))) in self.pairs.iter().zip(kept).enumerate() {
            let (Some(ca), Some(cb)) = (&self.colliders[pair.a], &self.colliders[pair.b]) else {
                out.push(Some(PairContact::none()));
                continue;
            };
            let prm = pair.params(prm);
            if prune && self.out_of_reach_with(pair, kin, &prm, reach) {
                out.push(None);
                continue;
            }
            out.push(None);
            pending.push(PendingPair {
                k,
                sides: [ca, cb],
                bodies: [pair.a, pair.b],
                prm,
                candidates,
            });
        }
        for (k, pc) in self.pair_threads.map(pending, |p| p.evaluate(kin)) {
            out[k] = Some(pc);
        }
        let mut wrenches = vec![Wrench::zero(); self.tree.bodies.len()];
        for (pair, pc) in self.pairs.iter().zip(&out) {
            if let Some(pc) = pc {
                for (b, x) in [(pair.a, &pc.on_a), (pair.b, &pc.on_b)] {
                    wrenches[b].force += x.force;
                    wrenches[b].torque += x.torque;
                }
            }
        }
        (wrenches, out)
    }

    /// Whether a pair is proven out of reach ([`out_of_reach`]) at `kin` with its parameters,
    /// with the pair's kept proof if given ([`out_of_reach_kept`]).
    pub(crate) fn out_of_reach_with<T: Scalar>(
        &self,
        pair: &Pair,
        kin: &Kinematics<T>,
        prm: &ContactParams<T>,
        kept: Option<&mut Option<KeptReach>>,
    ) -> bool {
        let (Some(ca), Some(cb)) = (&self.colliders[pair.a], &self.colliders[pair.b]) else {
            return true;
        };
        let (ra, rb) = (kin.frames[pair.a].re(), kin.frames[pair.b].re());
        let p = prm.re();
        let rels = [ra.relative_to(&rb), rb.relative_to(&ra)];
        match kept {
            Some(kept) => out_of_reach_kept(
                ca,
                cb,
                &rels,
                p.eps1,
                p.eps3,
                p.dissipation_velocity,
                p.friction,
                kept,
                // A kept proof is worth making if it serves two internal steps.
                2.0 * self.step,
            ),
            None => out_of_reach(
                ca,
                cb,
                &rels,
                p.eps1,
                p.eps3,
                p.dissipation_velocity,
                p.friction,
            ),
        }
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

    /// Forward dynamics (paper eq. 28) for inputs `u` (actuator controls, then the mocap
    /// bodies' inputs, see [`Model::nu`]; [`Simulation::inputs`](crate::sim::Simulation::inputs)
    /// gives them for a running simulation): `v̇ = M⁻¹ (τ_act(u) + τ_passive - c + Σ Λ)`.
    ///
    /// # Example
    ///
    /// A free box far above a floor falls at `g`, and exact derivatives come from the same call
    /// with dual numbers: `∂v̇/∂v = 0` for the free fall.
    ///
    /// ```
    /// use num_dual::Dual64;
    /// use std::path::Path;
    ///
    /// let xml = r#"<mujoco>
    ///   <worldbody>
    ///     <geom type="plane" size="1 1 0.1"/>
    ///     <body pos="0 0 1"><freejoint/><geom type="box" size="0.1 0.1 0.1" mass="2"/></body>
    ///   </worldbody>
    /// </mujoco>"#;
    /// let model = scm::scene::load_str(xml, Path::new("box.xml"))?.model;
    /// let f = model.forward(&model.q0, &model.v0, &model.u0(), &model.contact)?;
    /// assert!((f.vdot[2] + 9.81).abs() < 1e-9); // gravity, nothing else
    ///
    /// // The same dynamics on dual numbers: seed the box's vertical velocity.
    /// let q: Vec<Dual64> = model.q0.iter().map(|&x| Dual64::from(x)).collect();
    /// let mut v: Vec<Dual64> = model.v0.iter().map(|&x| Dual64::from(x)).collect();
    /// v[2] = Dual64::new(0.0, 1.0);
    /// let prm = model.contact.lift::<Dual64>();
    /// let fd = model.forward(&q, &v, &[], &prm)?;
    /// assert_eq!(fd.vdot[2].eps, 0.0);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn forward<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        u: &[T],
        prm: &ContactParams<T>,
    ) -> Result<Forward<T>, DynamicsError> {
        let (ctrl, mocap) = self.split_inputs(u)?;
        self.forward_tau(
            q,
            v,
            self.actuator_forces_at(q, v, ctrl, mocap).as_slice(),
            mocap,
            prm,
        )
    }

    /// Forward dynamics for a generalized applied force: `v̇ = FD(q, v, τ) = M⁻¹ (τ + τ_passive
    /// - c + Σ Λ)`, contact included. `mocap`: [`MOCAP_INPUTS`] per mocap body, or empty.
    pub fn forward_tau<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        tau: &[T],
        mocap: &[T],
        prm: &ContactParams<T>,
    ) -> Result<Forward<T>, DynamicsError> {
        self.forward_damped(q, v, tau, mocap, prm, None)
    }

    /// [`Model::forward_tau`], optionally with the joints' viscous damping taken implicitly
    /// over a step `h`: `v̇ = (M + h D)⁻¹ (τ + τ_passive - c + Σ Λ)`, `D` the diagonal of the
    /// joints' damping per degree of freedom plus the slope of their smooth frictionloss at `v`
    /// (MuJoCo's `Euler`, see
    /// [`Integrator::DampedEuler`]).
    pub fn forward_damped<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        tau: &[T],
        mocap: &[T],
        prm: &ContactParams<T>,
        implicit_damping: Option<T>,
    ) -> Result<Forward<T>, DynamicsError> {
        self.forward_contact_at(q, v, None, tau, mocap, prm, implicit_damping)
    }

    /// [`Model::forward_damped`] with the contact forces taken at the velocity `v_contact`
    /// (`None`: at `v`) and everything else at `v`: the acceleration whose root in `v_contact`
    /// is damped Euler's velocity-implicit contact ([`Integrator::DampedEuler`]).
    #[allow(clippy::too_many_arguments)]
    pub fn forward_contact_at<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        v_contact: Option<&[T]>,
        tau: &[T],
        mocap: &[T],
        prm: &ContactParams<T>,
        implicit_damping: Option<T>,
    ) -> Result<Forward<T>, DynamicsError> {
        self.forward_kept_at(
            q,
            v,
            v_contact,
            tau,
            mocap,
            prm,
            implicit_damping,
            Keep::Nothing,
            None,
        )
    }

    /// [`Model::forward`], keeping out-of-reach proofs and candidate planes across calls in
    /// `kept` (one entry per pair; resized to the pairs if it is not: [`out_of_reach_kept`],
    /// [`KeptCandidates`]). The result can differ
    /// from [`Model::forward`]'s only where a pair's forces are below the bound of
    /// [`out_of_reach`] (a kept proof switches off a pair that a fresh proof might not).
    pub fn forward_kept(
        &self,
        q: &[f64],
        v: &[f64],
        u: &[f64],
        prm: &ContactParams<f64>,
        kept: &mut PairsKept,
    ) -> Result<Forward<f64>, DynamicsError> {
        self.forward_kept_from(q, v, u, prm, kept, None)
    }

    /// [`Model::forward_kept`] with the kinematics of `(q, v)` and the mocap inputs of `u`
    /// already computed (`None`: computed here).
    pub(crate) fn forward_kept_from(
        &self,
        q: &[f64],
        v: &[f64],
        u: &[f64],
        prm: &ContactParams<f64>,
        kept: &mut PairsKept,
        kin: Option<Kinematics<f64>>,
    ) -> Result<Forward<f64>, DynamicsError> {
        self.forward_keeping(q, v, u, prm, Keep::All(kept), kin)
    }

    /// [`Model::forward`] with the pairs' candidate planes kept across calls in `kept` (not its
    /// out-of-reach proofs: every pair is proven afresh), so the same result to the last bit.
    pub(crate) fn forward_candidates<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        u: &[T],
        prm: &ContactParams<T>,
        kept: &mut PairsKept,
    ) -> Result<Forward<T>, DynamicsError> {
        self.forward_keeping(q, v, u, prm, Keep::Candidates(kept), None)
    }

    /// [`Model::forward`] with what `keep` lets the pairs keep (fitted to the pairs first).
    fn forward_keeping<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        u: &[T],
        prm: &ContactParams<T>,
        mut keep: Keep,
        kin: Option<Kinematics<T>>,
    ) -> Result<Forward<T>, DynamicsError> {
        let (ctrl, mocap) = self.split_inputs(u)?;
        if let Keep::All(kept) | Keep::Candidates(kept) = &mut keep {
            kept.fit(self.pairs.len());
        }
        let tau = self.actuator_forces_at(q, v, ctrl, mocap);
        self.forward_kept_at(q, v, None, tau.as_slice(), mocap, prm, None, keep, kin)
    }

    #[allow(clippy::too_many_arguments)]
    fn forward_kept_at<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        v_contact: Option<&[T]>,
        tau: &[T],
        mocap: &[T],
        prm: &ContactParams<T>,
        implicit_damping: Option<T>,
        keep: Keep,
        kin: Option<Kinematics<T>>,
    ) -> Result<Forward<T>, DynamicsError> {
        self.check_finite(q, v)?;
        let kin = kin.unwrap_or_else(|| self.tree.kinematics_with(q, v, mocap));
        let contact_kin = v_contact.map(|vc| self.tree.kinematics_with(q, vc, mocap));
        // With `v_contact`, the same positions, so the wrenches are in the same frames.
        let (mut wrenches, contacts) =
            self.contacts_with(contact_kin.as_ref().unwrap_or(&kin), prm, true, keep);
        self.add_body_forces(&kin, prm.stiction_velocity, &mut wrenches);
        let zero = vec![T::zero(); self.tree.nv];
        let bias = self.tree.rnea(&kin, &zero, &wrenches);
        let rhs = DVector::from_column_slice(tau)
            + self.passive_forces(q, v, prm.stiction_velocity)
            - bias;
        let m = self.damped_mass_matrix(&kin, v, prm, implicit_damping);
        let vdot = self
            .tree
            .factor(m)
            .ok_or(DynamicsError::Singular)?
            .solve(&rhs);
        Ok(Forward { vdot, contacts })
    }

    /// An error naming the first joint whose position or velocity is not finite.
    pub(crate) fn check_finite<T: Scalar>(&self, q: &[T], v: &[T]) -> Result<(), DynamicsError> {
        for j in &self.tree.joints {
            let bad = |x: &[T]| x.iter().any(|x| !x.re().is_finite());
            if bad(&q[j.qadr..j.qadr + j.kind.nq()]) {
                return Err(DynamicsError::NonFinite(format!(
                    "the position of joint {}",
                    j.name
                )));
            }
            if bad(&v[j.dadr..j.dadr + j.kind.nv()]) {
                return Err(DynamicsError::NonFinite(format!(
                    "the velocity of joint {}",
                    j.name
                )));
            }
        }
        Ok(())
    }

    /// The mass matrix at `kin`, with `h D` added when `implicit_damping` is `Some(h)`: `D` the
    /// joints' viscous damping plus the slope of their smooth frictionloss at `v`.
    pub(crate) fn damped_mass_matrix<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        v: &[T],
        prm: &ContactParams<T>,
        implicit_damping: Option<T>,
    ) -> nalgebra::DMatrix<T> {
        let mut m = self.tree.mass_matrix(kin);
        if let Some(h) = implicit_damping {
            let vs2 = prm.stiction_velocity * prm.stiction_velocity;
            for j in &self.tree.joints {
                for k in 0..j.kind.nv() {
                    let mut d = c::<T>(j.damping);
                    if j.frictionloss > 0.0 {
                        // The smooth frictionloss -F v / sqrt(v_s² + v²) is a damper of slope
                        // F v_s² / (v_s² + v²)^{3/2} near rest: stiff (F/v_s) when v_s is small,
                        // where MuJoCo's frictionloss is a constraint, solved implicitly.
                        let vi = v[j.dadr + k];
                        let r = vs2 + vi * vi;
                        d += vs2 * j.frictionloss / (r * r.sqrt());
                    }
                    m[(j.dadr + k, j.dadr + k)] += h * d;
                }
            }
        }
        m
    }

    /// Inverse dynamics (paper eq. 27): the generalized actuation `τ = ID(q, v, v̇) = M v̇ + c -
    /// Σ Λ - τ_passive` that produces accelerations `vdot`, contact included, so that
    /// `ID(q, v, FD(q, v, τ)) = τ`. `mocap`: [`MOCAP_INPUTS`] per mocap body, or empty.
    pub fn inverse<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        vdot: &[T],
        mocap: &[T],
        prm: &ContactParams<T>,
    ) -> DVector<T> {
        let kin = self.tree.kinematics_with(q, v, mocap);
        let (mut wrenches, _) = self.contact_forces(&kin, prm);
        self.add_body_forces(&kin, prm.stiction_velocity, &mut wrenches);
        let mut tau = self.tree.rnea(&kin, vdot, &wrenches)
            - self.passive_forces(q, v, prm.stiction_velocity);
        // Armature is part of M but not of the bodies' inertia.
        for j in &self.tree.joints {
            for k in 0..j.kind.nv() {
                tau[j.dadr + k] += vdot[j.dadr + k] * j.armature;
            }
        }
        tau
    }

    /// Mechanical energy of a state, computed from the bodies' motion (not from `M`): kinetic
    /// energy `Σ ½ m |v_com|² + ½ ωᵀ I_c ω + Σ ½ armature v²`, gravity `-Σ (1 - gravcomp) m gᵀ
    /// x_com`, springs
    /// `½ k q²` (slide, hinge) and `½ k |θ|²` (ball). Mocap bodies are not counted.
    pub fn energy<T: Scalar>(&self, q: &[T], v: &[T]) -> Energy<T> {
        self.energy_at(&self.tree.kinematics(q, v), q, v)
    }

    /// [`Model::energy`] with the kinematics of `(q, v)` already computed
    /// ([`Tree::kinematics`](crate::dynamics::Tree::kinematics): every mocap body at its scene
    /// pose).
    pub fn energy_at<T: Scalar>(&self, kin: &Kinematics<T>, q: &[T], v: &[T]) -> Energy<T> {
        let g = self.tree.gravity.map(c::<T>);
        let (mut kinetic, mut gravity, mut springs) = (T::zero(), T::zero(), T::zero());
        for (b, body) in self.tree.bodies.iter().enumerate().skip(1) {
            if body.mocap || body.inertia.mass <= 0.0 {
                continue;
            }
            let f = &kin.frames[b];
            let arm = f.rotation * body.inertia.com.map(c::<T>);
            let vcom = f.linvel + f.angvel.cross(&arm);
            let wb = f.rotation.transpose() * f.angvel;
            let m = c::<T>(body.inertia.mass);
            kinetic +=
                m * vcom.dot(&vcom) * 0.5 + wb.dot(&(body.inertia.rot.map(c::<T>) * wb)) * 0.5;
            // Gravity compensation is a conservative force too: it scales the weight.
            gravity -= m * g.dot(&(f.origin + arm)) * (1.0 - body.gravcomp);
        }
        for j in &self.tree.joints {
            for k in 0..j.kind.nv() {
                kinetic += v[j.dadr + k] * v[j.dadr + k] * (0.5 * j.armature);
            }
            match j.kind {
                JointKind::Slide | JointKind::Hinge => {
                    let stretch = q[j.qadr] - c::<T>(j.springref);
                    springs += stretch * stretch * (0.5 * j.stiffness);
                    if let Some(l) = &j.limit {
                        springs += l.energy(q[j.qadr]);
                    }
                }
                JointKind::Ball if j.stiffness != 0.0 => {
                    let th = quat_log(&quat_from(&q[j.qadr..j.qadr + 4]));
                    springs += th.dot(&th) * (0.5 * j.stiffness);
                }
                _ => {}
            }
        }
        for t in self.tendons.iter().filter(|t| t.acts()) {
            springs += t.energy(q);
        }
        for e in &self.equalities {
            springs += e.energy(q);
        }
        for c in &self.connects {
            springs += c.energy(&kin.frames);
        }
        for t in self.spatial_tendons.iter().filter(|t| t.law.acts()) {
            springs += t.energy(&kin.frames);
        }
        Energy {
            kinetic,
            gravity,
            springs,
        }
    }

    /// Total mass of the bodies that move (kg).
    pub fn moving_mass(&self) -> f64 {
        (1..self.tree.bodies.len())
            .filter(|&b| self.tree.body_moves(b))
            .map(|b| self.tree.bodies[b].inertia.mass)
            .sum()
    }
}
