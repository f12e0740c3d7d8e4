//! The colliding pairs: each pair's own law ([`Pair`]), how an evaluation may reuse what the
//! pairs keep across calls ([`Reuse`]), the threads that evaluate the pairs in reach
//! ([`PairThreads`]), and the loop over them that gives every pair's contact and the wrench
//! each body receives ([`Model::contacts`], [`Model::contact_forces`]).

use super::Model;
use crate::collision::{
    out_of_reach, out_of_reach_proven, CandidateMemo, Collider, Frame, PairCarry, ReachProof,
    Relative, Scratch, Seed,
};
use crate::contact::{pair_contact_memo, pair_distance, ContactParams, PairContact, Wrench};
use crate::dynamics::Kinematics;
use crate::scalar::{c, Scalar};

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
    /// The pair's own contact stiffness (N/m; from `solref`, `solimp` and the pair's effective
    /// mass at the scene's ε3), which the contact parameter `stiffness` does not change.
    pub stiffness: Option<f64>,
    /// `[m̂ g (N), r_g (m)]` where its law is the file's: `k = m̂ g / s⁺_ε3(r_g)` (docs/mjcf.md).
    pub rest: Option<[f64; 2]>,
    /// The pair's own dissipation velocity (m/s), as `stiffness`.
    pub dissipation_velocity: Option<f64>,
    /// The pair's own dissipation force (N; [`ContactParams::dissipation_force`]): from the file
    /// `f m̂ g`, `f` the scene's `scm_dissipation_force` or its integrator's (4 explicit, 8 implicit),
    /// infinite at 0 (the paper's law); `None` where the scene's own `scm_*` law sets every pair's.
    pub dissipation_force: Option<f64>,
    /// Whether its own force holds a separation ([`ContactParams::hold_separation`]).
    pub hold_separation: bool,
    /// The pair's contact margin (m; [`ContactParams::margin`]): MuJoCo's `includemargin`,
    /// the sum of its geoms' `margin` or a `<pair>`'s own (docs/mjcf.md). 0: none.
    pub margin: f64,
    /// The pair's adhesion (N; [`ContactParams::adhesion`]): MuJoCo's sum of its geoms'
    /// `adhesion`, the higher `priority`'s, or a `<pair>`'s own. 0: none.
    pub adhesion: f64,
    /// The pair's gap (m; [`ContactParams::gap`]): the sum of its geoms' `gap` or a `<pair>`'s
    /// own; read only with adhesion.
    pub gap: f64,
    /// The pair's stiction floor per unit of friction coefficient (s·m/s² = m/s; 0: none):
    /// its stiction velocity is at least this times its friction coefficient, whatever the
    /// contact parameter says (above it the parameter acts). `κ h g` under an integrator that
    /// takes the friction explicitly (`h` the file's step, `g` the gravity, κ the scene's
    /// `scm_stiction_floor` or 2), so that the friction's slope at zero slip, `μ N / v_s`,
    /// stays within what the integrator carries at that step (docs/mjcf.md, "Stiction floor").
    pub stiction_floor: f64,
    /// The flows of the two bodies' moving surfaces (`a`'s, `b`'s, each in its body's frame;
    /// MuJoCo's geom `surfacevel`, [`ContactParams::surface`]); `None` where neither moves.
    pub surface: Option<[crate::collision::Twist<f64>; 2]>,
    /// The factors on the contact parameter ε1 with which the planes of `a`'s and of `b`'s
    /// cloud are read (1: the parameter as it is): `(L / EPS1_SPACING)²` for a cloud sampled
    /// finer than [`crate::contact::EPS1_SPACING`], `L` its longest quad, so that each cloud's
    /// softmax blends over the same number of neighbouring planes at every spacing
    /// (docs/method.md, "ε1 follows the spacing"); 1 where the scene sets `scm_eps1`
    /// ([`ContactParams::eps1_scale`]).
    pub eps1_scale: [f64; 2],
}

impl Pair {
    /// The ε1 (m²) each side reads the other body's planes with, given the contact parameter
    /// `eps1` ([`ContactParams::eps1_sides`]).
    pub fn eps1_sides<T: Scalar>(&self, eps1: T) -> [T; 2] {
        crate::contact::eps1_sides(eps1, self.eps1_scale)
    }

    /// The pair's own stiffness at the contact parameter `eps3` (m), from its `rest` or else
    /// its `stiffness`; `None`: the contact parameter's.
    pub fn stiffness_at<T: Scalar>(&self, eps3: T) -> Option<T> {
        match self.rest {
            Some([weight, depth]) => {
                let k = c::<T>(weight) / crate::scalar::softplus(c(depth), eps3);
                // The f64 division's value to the bit (a dual divides by a reciprocal); `exact - k`
                // is exact (Sterbenz), and a constant added keeps every derivative.
                let exact = weight / crate::scalar::softplus(depth, eps3.re());
                Some(k + c::<T>(exact - k.re()))
            }
            None => self.stiffness.map(c),
        }
    }

    /// The contact parameters of this pair: `prm` with the pair's own friction, stiffness,
    /// dissipation velocity, force and hold where it has them, margin, clouds' ε1 factors
    /// ([`Pair::eps1_scale`]), and stiction velocity raised to its floor (`stiction_floor μ`).
    pub fn params<T: Scalar>(&self, prm: &ContactParams<T>) -> ContactParams<T> {
        let own = |x: Option<f64>, p: T| x.map_or(p, c);
        let hold = self.dissipation_force.is_none() && prm.hold_separation;
        let friction = own(self.friction, prm.friction);
        let floor = friction * self.stiction_floor;
        let stiction_velocity = if prm.stiction_velocity.re() < floor.re() {
            floor
        } else {
            prm.stiction_velocity
        };
        ContactParams {
            friction,
            stiction_velocity,
            stiffness: self.stiffness_at(prm.eps3).unwrap_or(prm.stiffness),
            dissipation_velocity: own(self.dissipation_velocity, prm.dissipation_velocity),
            dissipation_force: own(self.dissipation_force, prm.dissipation_force),
            hold_separation: self.hold_separation || hold,
            margin: c(self.margin),
            adhesion: self.adhesion,
            gap: self.gap,
            surface: self.surface,
            eps1_scale: self.eps1_scale,
            ..*prm
        }
    }

    /// The adhesion actuators' pull on the pair from `pulls` ([`Model::pulls`], per body; empty:
    /// none): the sum of its two bodies', `None` where neither has one.
    pub fn pull<T: Scalar>(&self, pulls: &[Option<T>]) -> Option<T> {
        let (Some(&a), Some(&b)) = (pulls.get(self.a), pulls.get(self.b)) else {
            return None;
        };
        match (a, b) {
            (Some(a), Some(b)) => Some(a + b),
            (a, b) => a.or(b),
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

/// What an evaluation of the pairs may use of what they keep across calls ([`PairCarry`],
/// fitted to the model's pairs first).
pub enum Reuse<'a> {
    /// Nothing: every pair proven and walked afresh.
    Nothing,
    /// The out-of-reach proofs and the candidate planes.
    All(&'a mut PairCarry),
}

/// Which pairs an evaluation of the pairs evaluates ([`Model::visit_pairs`]).
#[derive(Clone, Copy)]
pub(super) enum Pick<'a> {
    /// Every pair with two colliders, none proven out of reach (what the outputs' smooth
    /// distances need).
    Every,
    /// The pairs not proven out of reach: the others' forces are below τ k ε3 and left out
    /// (what the dynamics apply).
    InReach,
    /// The pairs marked `true` here (indexed as [`Model::pairs`]), without proofs.
    Marked(&'a [bool]),
}

/// What [`Model::visit_pairs`] did with one pair.
pub(super) enum PairVisit<R> {
    /// One of its bodies has no collider: nothing to evaluate.
    NoCollider,
    /// Proven out of reach: not evaluated.
    OutOfReach,
    /// Evaluated, with this result.
    Evaluated(R),
}

/// Adds a pair's wrenches on its bodies `a` and `b` to `wrenches`.
pub(super) fn add_pair_wrenches<T: Scalar>(
    wrenches: &mut [Wrench<T>],
    a: usize,
    b: usize,
    on: [&Wrench<T>; 2],
) {
    for (body, x) in [(a, on[0]), (b, on[1])] {
        wrenches[body].force += x.force;
        wrenches[body].torque += x.torque;
    }
}

impl Reuse<'_> {
    /// Fits the carried data, if any, to `pairs` pairs ([`PairCarry::fit`]; a no-op when it
    /// fits already).
    pub fn fit(&mut self, pairs: usize) {
        if let Reuse::All(carry) = self {
            carry.fit(pairs);
        }
    }
}

/// A pair in reach, waiting for its evaluation: its index, colliders, bodies, parameters (its
/// own friction applied) and kept candidate planes.
pub(crate) struct PendingPair<'a, T: Scalar> {
    pub(crate) k: usize,
    pub(crate) sides: [&'a Collider; 2],
    pub(crate) bodies: [usize; 2],
    pub(crate) prm: ContactParams<T>,
    pub(crate) candidates: Option<&'a mut CandidateMemo>,
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

    /// The pair's contact at `kin`, the walks working in `scratch`.
    fn evaluate(self, kin: &Kinematics<T>, scratch: &mut Scratch) -> PairContact<T> {
        let [a, b] = self.bodies;
        let [ca, cb] = self.sides;
        pair_contact_memo(
            ca,
            &kin.frames[a],
            cb,
            &kin.frames[b],
            &self.prm,
            self.candidates,
            scratch,
        )
    }

    /// The pair's smooth distance at `kin` alone ([`pair_distance`]: the same bits as its
    /// evaluation's), the walks working in `scratch`.
    fn distance(self, kin: &Kinematics<T>, scratch: &mut Scratch) -> T {
        let [a, b] = self.bodies;
        let [ca, cb] = self.sides;
        pair_distance(ca, &kin.frames[a], cb, &kin.frames[b], &self.prm, scratch)
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

    /// The default [`PairThreads::min_pairs`]. Measured on 2 cores,
    /// with a scoped thread started per evaluation: 8 and 32 boxes resting on a floor (8 and
    /// 32 pairs in reach) step 1.2–1.4× faster on two threads, while gymnasium's ant (4 legs on
    /// the floor) gains nothing, `box_stack` (3 pairs) and the half cheetah (2) lose 35–40 %.
    pub const MIN_PAIRS: usize = 8;

    /// `f` of every pair of `pending`, with the pair's index, in pair order: on one thread, or
    /// split over up to [`PairThreads::threads`] by their points, each thread with its own of
    /// `scratch` (which has one per thread).
    pub(crate) fn map<'a, T: Scalar, R: Send>(
        &self,
        pending: Vec<PendingPair<'a, T>>,
        scratch: &mut [Scratch],
        f: impl Fn(PendingPair<'a, T>, &mut Scratch) -> R + Sync,
    ) -> Vec<(usize, R)> {
        let f = &f;
        let run = move |group: Vec<PendingPair<'a, T>>, s: &mut Scratch| -> Vec<(usize, R)> {
            group.into_iter().map(|p| (p.k, f(p, s))).collect()
        };
        let (first, more) = scratch
            .split_first_mut()
            .expect("the pair loop has scratch for one thread at least");
        if self.threads < 2 || pending.len() < self.min_pairs.max(2) {
            return run(pending, first);
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
        // Every group has scratch of its own: none may be left out unevaluated.
        assert!(
            more.len() + 1 >= groups,
            "the pair loop has scratch for each thread"
        );
        let mut groups = split.into_iter().map(|(_, g)| g);
        let own = groups.next().unwrap_or_default();
        let mut all = std::thread::scope(|s| {
            let others: Vec<_> = groups
                .zip(more.iter_mut())
                .map(|(g, scratch)| s.spawn(move || run(g, scratch)))
                .collect();
            let mut all = run(own, first);
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

impl Model {
    /// Contact of every pair and the wrench each body receives (world frame, about its origin),
    /// every pair evaluated in full, its smooth distance included (the reference the outputs'
    /// [`Model::complete_contacts`] is tested against).
    /// `pulls`: the adhesion actuators' ([`Model::pulls`], or empty).
    pub fn contacts<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        prm: &ContactParams<T>,
        pulls: &[Option<T>],
    ) -> (Vec<Wrench<T>>, Vec<PairContact<T>>) {
        let (wrenches, pairs) = self.contacts_with(kin, prm, pulls, Pick::Every, Reuse::Nothing);
        let pairs = pairs
            .into_iter()
            .map(|pc| pc.unwrap_or_else(PairContact::none))
            .collect();
        (wrenches, pairs)
    }

    /// The contact wrenches for the dynamics: as [`Model::contacts`], except that a pair proven
    /// out of reach ([`out_of_reach`]: every force of the pair below τ times the force scale
    /// `k ε3`, see there) costs only that proof and is `None`: zero wrenches, its smooth
    /// distance not evaluated (the outputs complete it with [`Model::complete_contacts`]).
    pub fn contact_forces<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        prm: &ContactParams<T>,
        pulls: &[Option<T>],
    ) -> (Vec<Wrench<T>>, Vec<Option<PairContact<T>>>) {
        self.contacts_with(kin, prm, pulls, Pick::InReach, Reuse::Nothing)
    }

    /// The contacts the outputs read, from `applied` ([`Model::contact_forces`] at `kin`): a
    /// pair it left out (proven out of reach) has zero wrenches, as the dynamics apply it, and
    /// the smooth distance `D` of its full evaluation, as [`Model::contacts`] evaluates it (all
    /// such pairs at once, on the pair threads).
    pub fn complete_contacts<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        prm: &ContactParams<T>,
        pulls: &[Option<T>],
        applied: &[Option<PairContact<T>>],
    ) -> Vec<PairContact<T>> {
        let missing: Vec<bool> = applied.iter().map(Option::is_none).collect();
        let pick = Pick::Marked(&missing);
        let distances = self.visit_pairs(kin, prm, pulls, pick, Reuse::Nothing, |p, s| {
            p.distance(kin, s)
        });
        applied
            .iter()
            .zip(distances)
            .map(|(applied, visit)| match (applied, visit) {
                (Some(pc), _) => *pc,
                (None, PairVisit::Evaluated(distance)) => PairContact {
                    distance,
                    ..PairContact::none()
                },
                (None, _) => unreachable!("a pair left out by the proofs has two colliders"),
            })
            .collect()
    }

    /// Every pair's contact, with the pair's own friction if it has one (`None`: proven out of
    /// reach or not picked), and the wrenches they add up to ([`Model::visit_pairs`]).
    pub(super) fn contacts_with<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        prm: &ContactParams<T>,
        pulls: &[Option<T>],
        pick: Pick,
        reuse: Reuse,
    ) -> (Vec<Wrench<T>>, Vec<Option<PairContact<T>>>) {
        let out: Vec<Option<PairContact<T>>> = self
            .visit_pairs(kin, prm, pulls, pick, reuse, |p, s| p.evaluate(kin, s))
            .into_iter()
            .map(|visit| match visit {
                PairVisit::NoCollider => Some(PairContact::none()),
                PairVisit::OutOfReach => None,
                PairVisit::Evaluated(pc) => Some(pc),
            })
            .collect();
        (self.pair_wrenches(&out), out)
    }

    /// The wrenches of [`Model::contacts_with`] alone, without its list of every pair's contact
    /// (the same bits): what a residual that reads only the accelerations needs. The list is a
    /// full `PairContact` per pair, in reach or not: for MuJoCo's leaves (44,850 pairs) 47 MB
    /// of dual numbers of width 8 per pass of an implicit step's Jacobian, a third of the step in
    /// page faults.
    pub(super) fn wrenches_with<T: Scalar>(
        &self,
        kin: &Kinematics<T>,
        prm: &ContactParams<T>,
        pulls: &[Option<T>],
        pick: Pick,
        reuse: Reuse,
    ) -> Vec<Wrench<T>> {
        let visits = self.visit_pairs(kin, prm, pulls, pick, reuse, |p, s| {
            Box::new(p.evaluate(kin, s))
        });
        let mut wrenches = vec![Wrench::zero(); self.tree.bodies.len()];
        // Made only for a pair without colliders (a large value to build at every evaluation).
        let mut none = None;
        for (pair, visit) in self.pairs.iter().zip(&visits) {
            let pc = match visit {
                PairVisit::NoCollider => &*none.get_or_insert_with(PairContact::none),
                PairVisit::OutOfReach => continue,
                PairVisit::Evaluated(pc) => pc.as_ref(),
            };
            add_pair_wrenches(&mut wrenches, pair.a, pair.b, [&pc.on_a, &pc.on_b]);
        }
        wrenches
    }

    /// The one loop over the pairs: `eval` of every pair `pick` picks, in pair order (the others
    /// are [`PairVisit::OutOfReach`]). The proofs come first, in pair order (only for
    /// [`Pick::InReach`]; with the pairs' kept proofs when `reuse` is [`Reuse::All`]); the pairs
    /// left are evaluated on [`Model::pair_threads`] threads when they are many enough
    /// ([`PairThreads`]), each with only its own kept candidates, so the results are the same
    /// bits whatever the threads. The walks work in the carried scratch ([`PairCarry`]: one
    /// per thread), or in scratch of this call's own when nothing is carried. A pair one of
    /// whose bodies an adhesion actuator drives is pulled with `pulls` ([`Model::pulls`]; empty:
    /// none) of its two bodies.
    pub(super) fn visit_pairs<'a, T: Scalar, R: Send>(
        &'a self,
        kin: &Kinematics<T>,
        prm: &ContactParams<T>,
        pulls: &[Option<T>],
        pick: Pick,
        reuse: Reuse<'a>,
        eval: impl Fn(PendingPair<'a, T>, &mut Scratch) -> R + Sync,
    ) -> Vec<PairVisit<R>> {
        let n = self.pairs.len();
        let threads = self.pair_threads.threads.max(1);
        let mut own = Vec::new();
        // Fitted by the callers that carry data (`forward_at`, `frozen_forward`), before any
        // check that can fail, so a failing call leaves a fitted carry.
        // What each pair carries, read in pair order (no vector of it at every evaluation).
        let (mut carried, scratch) = match reuse {
            Reuse::Nothing => {
                own.resize_with(threads, Scratch::default);
                (None, &mut own[..])
            }
            Reuse::All(all) => {
                let (pairs, scratch) = all.pairs_and_scratch(threads);
                (Some(pairs), scratch)
            }
        };
        let mut out: Vec<PairVisit<R>> = Vec::with_capacity(n);
        let mut pending = Vec::new();
        for (k, pair) in self.pairs.iter().enumerate() {
            let (reach, mut candidates) = match carried.as_mut().map(|pairs| pairs.next()) {
                None => (None, None),
                Some(Some((r, c))) => (Some(r), c),
                Some(None) => unreachable!("the carried pair data is fitted to the pairs"),
            };
            let (Some(ca), Some(cb)) = (&self.colliders[pair.a], &self.colliders[pair.b]) else {
                out.push(PairVisit::NoCollider);
                continue;
            };
            let mut prm = pair.params(prm);
            prm.pull = pair.pull(pulls);
            out.push(PairVisit::OutOfReach);
            let left_out = match pick {
                Pick::Every => false,
                Pick::InReach => {
                    // A pair whose plain proof failed at its last forward (in contact) looks at
                    // its nearest point first: a cost, never a result (`Seed`).
                    let seed = match candidates.as_deref() {
                        Some(c) if c.proof_failed => Seed::First,
                        _ => Seed::AfterRoot,
                    };
                    let out =
                        self.out_of_reach_with(pair, kin, &prm, (reach, seed), &mut scratch[0]);
                    if let Some(c) = candidates.as_deref_mut() {
                        c.proof_failed = !out;
                    }
                    out
                }
                Pick::Marked(marked) => !marked[k],
            };
            if left_out {
                continue;
            }
            pending.push(PendingPair {
                k,
                sides: [ca, cb],
                bodies: [pair.a, pair.b],
                prm,
                candidates,
            });
        }
        for (k, r) in self.pair_threads.map(pending, scratch, eval) {
            out[k] = PairVisit::Evaluated(r);
        }
        out
    }

    /// The wrench each body receives from the pairs' contacts (`None`: none), summed in pair
    /// order.
    pub(super) fn pair_wrenches<T: Scalar>(
        &self,
        contacts: &[Option<PairContact<T>>],
    ) -> Vec<Wrench<T>> {
        let mut wrenches = vec![Wrench::zero(); self.tree.bodies.len()];
        for (pair, pc) in self.pairs.iter().zip(contacts) {
            if let Some(pc) = pc {
                add_pair_wrenches(&mut wrenches, pair.a, pair.b, [&pc.on_a, &pc.on_b]);
            }
        }
        wrenches
    }

    /// Whether a pair is proven out of reach ([`out_of_reach`]) at `kin` with its parameters,
    /// with the pair's kept proof if given ([`out_of_reach_proven`], its plain proof's walks in
    /// the order `seed` says: [`Seed`]), the walks working in `scratch`.
    pub(crate) fn out_of_reach_with<T: Scalar>(
        &self,
        pair: &Pair,
        kin: &Kinematics<T>,
        prm: &ContactParams<T>,
        (kept, seed): (Option<&mut Option<ReachProof>>, Seed),
        scratch: &mut Scratch,
    ) -> bool {
        let (Some(ca), Some(cb)) = (&self.colliders[pair.a], &self.colliders[pair.b]) else {
            return true;
        };
        let (ra, rb) = (kin.frames[pair.a].real(), kin.frames[pair.b].real());
        // A body's motion seen from the other, for each body with points to query: a
        // half-space has none, and its side's frame is never read (half the frames of a pair
        // with the floor, a tenth of the proofs' time on free bodies).
        // (Seen from the world, body 0, a body's motion is its own frame's.)
        let seen = |query: &Collider, q: &Frame<f64>, planes: &Frame<f64>, world: bool| match query
        {
            Collider::Aopc(_) if world => q.relative_to_world(),
            Collider::Aopc(_) => q.relative_to(planes),
            Collider::HalfSpace { .. } => Relative::unread(),
        };
        let rels = [
            seen(ca, &ra, &rb, pair.b == 0),
            seen(cb, &rb, &ra, pair.a == 0),
        ];
        match kept {
            Some(kept) => out_of_reach_proven(
                ca,
                cb,
                &rels,
                &prm.reach(),
                kept,
                // A kept proof is worth making if it serves the next two forwards: two internal
                // steps of a one-stage method, half a step of RK4 (its second and third stages).
                // (With two steps asked of RK4, gymnasium's humanoid's limbs, moving at about
                // 0.5 m/s, never had room enough: pelvis–arm pairs proven afresh at every stage.)
                2.0 * self.timestep / self.integrator.forwards_per_step(),
                seed,
                scratch,
            ),
            None => out_of_reach(ca, cb, &rels, &prm.reach(), scratch),
        }
    }
}

#[cfg(test)]
#[path = "pairs_tests.rs"]
mod tests;
