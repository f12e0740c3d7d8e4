//! What [`Model::advance_cached`] carries from one call to the next ([`SolverCache`]): the
//! Newton Jacobian, where the cache was left, the energy guard's ledger, implicit Euler's last
//! velocity change, the pairs' kept proofs and candidate planes, and the last kinematics.
//!
//! [`Model::advance_cached`]: crate::model::Model::advance_cached

use super::guard::EnergyLedger;
use super::newton::WarmJacobian;
use crate::collision::{PairCarry, ReachProof};
use crate::dynamics::Kinematics;
use crate::integrator::State;
use crate::model::{ForwardOptions, Reuse};
use crate::scalar::Scalar;
use nalgebra::DMatrix;
use std::any::Any;

/// What [`Model::advance_cached`](crate::model::Model::advance_cached) carries from one call to the next.
///
/// It changes the result in the last bits (Newton starts from another Jacobian) and which steps
/// the energy guard refuses (its [`EnergyLedger`]), so an FMU state that must reproduce a rollout
/// bit for bit, refusals included, carries it ([`SolverCache::parts`],
/// [`SolverCache::from_parts`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SolverCache {
    /// The last Newton Jacobian of implicit Euler, or of damped Euler in contact.
    pub(super) jacobian: Option<WarmJacobian>,
    /// Implicit Euler's last velocity change `V - v`: the next step's Newton iterations start
    /// from `v + (V - v)` (the acceleration held), an `O(h²)` guess instead of `v`'s `O(h)`.
    pub(super) velocity_change: Option<Vec<f64>>,
    /// The state and internal step the cache was left for.
    pub(super) left: Option<CacheMark>,
    /// The energy guard's balance over the run so far.
    pub(super) ledger: Option<EnergyLedger>,
    /// Per pair, the out-of-reach proof kept from an earlier step ([`ReachProof`]: which pairs
    /// a step switches off depends on it) and the band's candidate planes (a cost only).
    pub(super) pairs: PairCarry,
    /// The kinematics of the state the last call ended at, as its energy guard computed them,
    /// and the buffers of kinematics done with ([`KinematicsMemo`]).
    pub(super) kinematics: KinematicsMemo,
}

/// What one internal step borrows from the [`SolverCache`] (or from its caller) and leaves
/// there: the Newton Jacobian, the pairs' kept proofs and candidate planes, the count of
/// halved steps, the kinematics memo and where implicit Euler leaves its contact energy. The
/// Jacobian can change a result in its last bits (where Newton starts), a carried
/// [`ReachProof`](crate::collision::ReachProof) which pairs are switched off (below its bound),
/// the contact energy which steps the guard's next call refuses; the candidate memos, the
/// kinematics and the count change nothing.
pub(super) struct StepCarry<'c> {
    /// The last Newton Jacobian of implicit Euler, or of damped Euler in contact: tried first,
    /// replaced when the iterations contract slowly.
    pub(super) jacobian: &'c mut Option<WarmJacobian>,
    /// The pairs' kept out-of-reach proofs and candidate planes (`None`: everything fresh).
    pub(super) pairs: Option<&'c mut PairCarry>,
    /// How many steps were halved so far because Newton's iterations failed.
    pub(super) subdivided: &'c mut usize,
    /// The kinematics the energy guard computed of the state it checked last, for damped
    /// Euler's frozen evaluation at that very state (bit for bit), and buffers of kinematics
    /// done with, lent to damped RK4's stages and implicit Euler's iterates and taken back
    /// (`None`: none kept, none lent).
    pub(super) kinematics: Option<&'c mut KinematicsMemo>,
    /// Where implicit Euler's steps write the estimate of the energy stored in contact (J,
    /// [`contact_energy`](super::guard::contact_energy)) at their Newton iterations' last
    /// evaluated iterate, one Newton step from the state the step ends at, for the energy
    /// guard's next call ([`EnergyLedger::stored`]); `None` written where none was found (a
    /// model with mocap bodies or adhesion actuators, whose contacts read inputs the next call
    /// may change). `None`: not asked. It changes which steps the guard refuses (its estimate
    /// of the start's energy), never a state.
    pub(super) contact_energy: Option<&'c mut Option<f64>>,
}

impl StepCarry<'_> {
    /// The same carry, lent to one call.
    pub(super) fn reborrow(&mut self) -> StepCarry<'_> {
        StepCarry {
            jacobian: &mut *self.jacobian,
            pairs: self.pairs.as_deref_mut(),
            subdivided: &mut *self.subdivided,
            kinematics: self.kinematics.as_deref_mut(),
            contact_energy: self.contact_energy.as_deref_mut(),
        }
    }
}

/// The kinematics of one state (every mocap body at its scene pose), kept for the forward
/// dynamics of the next call from that state: the energy guard computes them at the end of a
/// call, the next call's first stage at its start. Only when the model has no mocap body (the
/// forward dynamics then reads no other input), and handed out only for the very same state,
/// bit for bit: a memo of a pure function, so it changes no result, and two caches that differ
/// only in it are equal. Like the rest of the cache it belongs to one model: a tree changed
/// between calls (its public joints or bodies) needs a new cache.
///
/// It also keeps the buffers of kinematics done with (its spare ones: a forward dynamics', a
/// frozen evaluation's, a missed memo's), which the next kinematics made are written into
/// ([`crate::dynamics::Tree::kinematics_into`]): the guard's, a damped RK4 stage's, an implicit
/// Euler iterate's. A clone (an FMU state) leaves them out.
#[derive(Debug)]
pub(super) struct KinematicsMemo {
    /// The state of `kin`; its buffers are kept when `kin` is taken, for the next one.
    at: State<f64>,
    /// The kept kinematics, if any.
    kin: Option<Kinematics<f64>>,
    /// Kinematics of no state in particular, done with: buffers for the next kinematics made
    /// (the guard's, `Tree::kinematics_into`).
    spare: Option<Kinematics<f64>>,
}

impl Default for KinematicsMemo {
    fn default() -> Self {
        KinematicsMemo {
            at: State::empty(),
            kin: None,
            spare: None,
        }
    }
}

impl Clone for KinematicsMemo {
    fn clone(&self) -> Self {
        KinematicsMemo {
            at: self.at.clone(),
            kin: self.kin.clone(),
            spare: None,
        }
    }
}

impl PartialEq for KinematicsMemo {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl KinematicsMemo {
    /// Keeps `kin`, the kinematics of `s` (or forgets, with `None`).
    pub(super) fn keep(&mut self, s: &State<f64>, kin: Option<Kinematics<f64>>) {
        if kin.is_some() {
            self.at.assign(s);
        }
        self.kin = kin;
    }

    /// The kept kinematics if they are those of `s`, bit for bit; either way none is kept
    /// after (kept ones of another state become spare ones).
    pub(super) fn take(&mut self, s: &State<f64>) -> Option<Kinematics<f64>> {
        self.take_at(&s.q, &s.v)
    }

    /// [`KinematicsMemo::take`] at positions `q` and velocities `v`.
    pub(super) fn take_at(&mut self, q: &[f64], v: &[f64]) -> Option<Kinematics<f64>> {
        let hit = self.at(q, v);
        let kin = self.kin.take();
        if hit {
            return kin;
        }
        self.spare = kin.or(self.spare.take());
        None
    }

    /// Sets the kept kinematics aside as spare ones, whatever their state (their buffers for
    /// the next kinematics made).
    pub(super) fn set_aside(&mut self) {
        if let Some(kin) = self.kin.take() {
            self.spare = Some(kin);
        }
    }

    /// Keeps kinematics that are done with, for their buffers ([`KinematicsMemo::spare`]).
    pub(super) fn recycle(&mut self, kin: Kinematics<f64>) {
        self.spare = Some(kin);
    }

    /// Spare kinematics lent as kinematics of `T`, to be written over: only in `f64`, the
    /// memo's own numbers (none otherwise, the spare ones staying).
    pub(super) fn lend<T: Scalar>(&mut self) -> Option<Kinematics<T>> {
        let mut spare = self.spare.take();
        let lent = (&mut spare as &mut dyn Any)
            .downcast_mut::<Option<Kinematics<T>>>()
            .and_then(Option::take);
        self.spare = spare;
        lent
    }

    /// Takes back kinematics lent ([`KinematicsMemo::lend`]) for their buffers.
    pub(super) fn take_back<T: Scalar>(&mut self, kin: Option<Kinematics<T>>) {
        let mut kin = kin;
        let back = (&mut kin as &mut dyn Any)
            .downcast_mut::<Option<Kinematics<f64>>>()
            .and_then(Option::take);
        if back.is_some() {
            self.spare = back;
        }
    }

    /// Kinematics done with ([`KinematicsMemo::recycle`], or kept and missed), to be written
    /// over.
    pub(super) fn spare(&mut self) -> Option<Kinematics<f64>> {
        self.spare.take()
    }

    /// Whether the kept kinematics are those of `s`, bit for bit.
    pub(super) fn of(&self, s: &State<f64>) -> bool {
        self.at(&s.q, &s.v)
    }

    /// Whether the kept kinematics are those of `(q, v)`, bit for bit.
    fn at(&self, q: &[f64], v: &[f64]) -> bool {
        let same = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
        };
        self.kin.is_some() && same(&self.at.q, q) && same(&self.at.v, v)
    }
}

/// Where a [`SolverCache`] was left: the state and the internal step (s).
pub type CacheMark = (State<f64>, f64);

/// What of a [`SolverCache`] is part of an FMU state, by name ([`SolverCache::parts`],
/// [`SolverCache::from_parts`]): each part can change the next step's result, so a state that
/// must replay a run bit for bit, refusals included, carries all of them (the layout of their
/// bytes: `crate::sim`'s state bytes). What the cache keeps besides (candidate planes, the last
/// kinematics) changes no result and is not part of a state.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CacheParts {
    /// The last Newton Jacobian (implicit Euler's, or damped Euler's in contact): where the next
    /// step's Newton iterations start.
    pub jacobian: Option<DMatrix<f64>>,
    /// The state and internal step the cache was left for.
    pub left: Option<CacheMark>,
    /// The energy guard's balance over the run so far: which steps it refuses.
    pub ledger: Option<EnergyLedger>,
    /// Implicit Euler's last velocity change `V - v`, the next Newton start.
    pub velocity_change: Option<Vec<f64>>,
    /// Per pair, the out-of-reach proof kept from an earlier step (none, or one entry per
    /// pair): which pairs a step switches off.
    pub reach: Vec<Option<ReachProof>>,
}

impl SolverCache {
    /// The parts of this cache that an FMU state carries (copies).
    pub fn parts(&self) -> CacheParts {
        CacheParts {
            jacobian: self.jacobian.as_ref().map(|j| j.matrix().clone()),
            left: self.left.clone(),
            ledger: self.ledger.clone(),
            velocity_change: self.velocity_change.clone(),
            reach: self.pairs.reach.clone(),
        }
    }

    /// How often the pairs' kept candidate planes served a query, and how often a query walked
    /// ([`CandidateMemo`](crate::collision::CandidateMemo)), summed over the pairs since
    /// they were made; not part of [`parts`](SolverCache::parts), since they change no result.
    pub fn candidate_counts(&self) -> crate::collision::MemoCounts {
        let mut all = crate::collision::MemoCounts::default();
        for c in &self.pairs.candidates {
            all += c.counts();
        }
        all
    }

    /// Whether the pairs keep candidate planes from one evaluation to the next (they do by
    /// default). Off, every query walks the hierarchy: the same results to the bit, at the
    /// cost before they were kept (for measurements and tests). Either way drops those kept.
    pub fn keep_candidates(&mut self, on: bool) {
        self.pairs.walk_always = !on;
        self.pairs.candidates.clear();
    }

    /// Whether the cache holds the kinematics of `s`, which the next call from `s` then starts
    /// from instead of computing them (kept by the energy guard at the end of a call, for a
    /// model without mocap bodies). They change no result, so they are not part of
    /// [`parts`](SolverCache::parts).
    pub fn holds_kinematics_of(&self, s: &State<f64>) -> bool {
        self.kinematics.of(s)
    }

    /// A cache from its [`parts`](SolverCache::parts), keeping nothing else.
    pub fn from_parts(parts: CacheParts) -> SolverCache {
        SolverCache {
            jacobian: parts.jacobian.map(WarmJacobian::new),
            velocity_change: parts.velocity_change,
            left: parts.left,
            ledger: parts.ledger,
            pairs: PairCarry::with_reach(parts.reach),
            kinematics: KinematicsMemo::default(),
        }
    }
}

/// The options of a step's first stage: the pairs' kept proofs and candidate planes, and the
/// kinematics of the state if they are known already.
pub(super) fn reuse_all(
    kept: &mut PairCarry,
    kinematics: Option<Kinematics<f64>>,
) -> ForwardOptions<'_, f64> {
    ForwardOptions {
        reuse: Reuse::All(kept),
        kinematics,
        ..ForwardOptions::default()
    }
}
