//! Candidate planes kept from one evaluation of a pair to the next (temporal coherence): the
//! band's query points barely move between internal steps, so the other body's points that can
//! be relevant around where a query point was still hold everything relevant where it is now.
//!
//! For a query point at `x₀` (the other body's frame), [`gather_ball`] collects every plane
//! that can be relevant at some point of the ball `|x - x₀| ≤ δ` (its proof is the shared
//! ball's, `geometry::ssdf`). While the point stays in that ball, its relevant set is narrowed
//! from those few candidates ([`Relevant::find_among_xyz`]) instead of walking the hierarchy again.
//! The relevant set, its order (increasing index) and so every sum over it are the same to the
//! last bit as a fresh walk's: what is kept changes the cost, never a result, which is why it
//! is not in a saved FMU state's bytes (a state saved in memory carries a copy).
//!
//! `δ` is the smaller of an eighth of the ball's own reach at `x₀` (`ρ = √(d_min + ln(I/τ) ε1)`)
//! and a quarter of the relevant set's shell thickness `ρ - √d_min`, and at least a quarter of
//! the nearest plane's spacing (`√area`), so that a point resting against a fine cloud at sharp
//! `ε1` is not re-gathered at every micrometre. The candidates fill a shell about `2δ` thicker
//! than the relevant set's, so a ball holds a small multiple of the planes its point needs. (With
//! `δ = ρ/8` alone, a point a few centimetres from the other body had a `δ` of several
//! millimetres, a shell several times the relevant set's, and the balls of Franka's link1 (38,928
//! points at 0.9 mm) held 1 GB per pair.)
//!
//! What is kept is bounded: a side keeps at most [`CANDIDATES_PER_POINT`] `(I1 + I2)`
//! candidates, and a query whose new ball would pass that walks and keeps nothing. Where `ε1` is
//! wide against the clouds every plane is relevant everywhere, the balls are the other body,
//! and only a few fit: those points walk at every step, which costs time, not memory. What was
//! kept is for one pair of point clouds: another cloud on either side (another model's cache)
//! drops that side's balls, and balls no query has read for [`UNUSED_WALKS`] band walks are
//! dropped, so what is kept follows the band.
//!
//! Two more things are kept per side, both costs only, since the band is the points within
//! its cutoff whatever else a walk evaluated (`collision` module documentation):
//! - each ball's floor, the smallest `n_iᵀ(x₀ - p_i)` of its candidates, from which a lower
//!   bound of the SSDF anywhere in the ball follows (`CandidateMemo::above`): a point it
//!   proves beyond the band's running cutoff is not evaluated (a resting box's side faces,
//!   one row above the contact);
//! - per node of the query hierarchy, whether its proof failed lately: a node holding the
//!   band's points fails at every step, so after a failure its next [`PROOF_RETRY`] visits
//!   do not try it (`CandidateMemo::try_proof`).

use super::{ReachProof, Scratch};
use crate::geometry::ssdf::{gather_ball, Relevant};
use crate::geometry::Aopc;
use nalgebra::Vector3;

/// Candidates a side keeps per point of the pair's two clouds, at most (28 bytes each, and as
/// many in the spare buffers): a query whose new ball would pass that is answered by its walk
/// and keeps nothing ([`MemoCounts::unkept`]), so what is kept stays `O(I1 + I2)` however wide
/// the relevant sets are against the clouds.
pub const CANDIDATES_PER_POINT: usize = 16;

/// Band walks after which a ball that no query read is dropped.
pub const UNUSED_WALKS: u32 = 64;

/// Times the band walk reaches a node whose proof failed before it tries to prove it again.
pub const PROOF_RETRY: u8 = 8;

/// The candidates kept for one pair (both sides). Empty by default; filled by the band walk
/// of the pair's evaluations that are given it ([`pair_contact_memo`](crate::contact::pair_contact_memo)).
#[derive(Clone, Debug, Default)]
pub struct CandidateMemo {
    /// The `ε1` (m²) of each side's planes the candidates were gathered for (bits): another
    /// one drops them all.
    eps1: [u64; 2],
    /// Per side: 0 the points of `a` against the planes of `b`, 1 the reverse.
    sides: [SideCandidates; 2],
    /// Queries answered so far, from a kept ball or not.
    counts: MemoCounts,
    /// The pair's last hand-derived Jacobian, with the real inputs it was taken at.
    pub linearized: Option<Box<Linearized>>,
    /// The most entries and kept terms the pair's last band held (`band_of`'s start sizes
    /// for its next: a cost, never a result).
    pub(crate) band_sizes: (usize, usize),
    /// Whether the pair's out-of-reach proof failed at its last forward: its next proof looks
    /// at its nearest point first (`collision::Seed::First`; a cost, never a result).
    pub(crate) proof_failed: bool,
}

/// A function's value and Jacobian at one input (a pair's hand-derived Jacobian, which the chain
/// rule's path takes at the real parts of the pair's inputs: `crate::contact::pair_jacobian`).
/// The passes of dual numbers of one Jacobian ([`crate::autodiff::jacobian`]) evaluate every
/// pair at the same real inputs, so the first pass takes it and the others find it here. Read
/// only where `key` equals the new inputs in every bit: a cost, never a result.
#[derive(Clone, Debug, Default)]
pub struct Linearized {
    /// The inputs, with the parameters they were taken with, as the caller lists them.
    pub key: Vec<f64>,
    /// The value.
    pub values: Vec<f64>,
    /// The Jacobian, as the caller lays it out.
    pub jacobian: Vec<f64>,
}

impl Linearized {
    /// Whether it was taken at `key`, every bit equal.
    pub fn taken_at(&self, key: &[f64]) -> bool {
        self.key.len() == key.len()
            && self
                .key
                .iter()
                .zip(key)
                .all(|(a, b)| a.to_bits() == b.to_bits())
    }
}

/// One side's kept balls.
#[derive(Clone, Debug, Default)]
struct SideCandidates {
    /// Per query point (leaf order), its ball in `balls`, or `u32::MAX`.
    slot: Vec<u32>,
    /// The balls, each with its candidates `cands[start..start + len]`.
    balls: Vec<Ball>,
    /// Candidates (the other body's leaf-order indices), increasing within each ball.
    cands: Vec<u32>,
    /// Their coordinates, one array per axis (contiguous, for the distances' plain loop).
    xyz: [Vec<f64>; 3],
    /// How many entries of `cands` belong to a ball (the rest were replaced).
    live: usize,
    /// The clouds the balls are for: the query points' and the planes' hierarchies
    /// (addresses, with their lengths), `(0, 0, 0, 0)` before the first walk.
    clouds: (usize, usize, usize, usize),
    /// Band walks so far (for dropping balls nobody reads).
    walks: u32,
    /// Scratch of one gathering.
    gathered: Vec<u32>,
    /// Per node of the query hierarchy, how many more times the walk reaches it before trying
    /// its proof again (0: try).
    retry: Vec<u8>,
    /// The other buffers of `cands` and `xyz`, which compaction fills and swaps in: memory
    /// is reused, so once the largest band has been kept nothing more is allocated.
    spare: (Vec<u32>, [Vec<f64>; 3]),
}

#[derive(Clone, Copy, Debug)]
struct Ball {
    /// The query point's leaf-order index.
    k: u32,
    /// The band walk that last read it.
    used: u32,
    centre: Vector3<f64>,
    /// `δ²` (m²).
    radius_sq: f64,
    /// `min_i v_i(x₀)` over the candidates, less a rounding allowance (m;
    /// `CandidateMemo::above`); `-∞` if any `v_i(x₀)` is not a number.
    floor: f64,
    /// The largest `|n_i|` of the candidates (1 to rounding for the crate's clouds): how fast
    /// any `v_i` can change with `x`.
    slope: f64,
    start: u32,
    len: u32,
}

/// Query points whose kept ball held them, and those that gathered a new one
/// ([`CandidateMemo::counts`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoCounts {
    /// Queries answered from a kept ball.
    pub hits: usize,
    /// Queries that walked the hierarchy and kept a new ball.
    pub misses: usize,
    /// Balls replaced by a new one (their point had left them).
    pub replaced: usize,
    /// Balls dropped because no query read them for [`UNUSED_WALKS`] band walks.
    pub dropped: usize,
    /// Times the candidates of replaced and dropped balls were cleared out.
    pub compactions: usize,
    /// Queries not evaluated: their kept ball proved the point above the band's cutoff.
    pub above: usize,
    /// Node proofs not tried, the node's proof having failed at one of its last visits.
    pub untried: usize,
    /// Queries that walked and kept no ball: it would have passed the side's budget
    /// ([`CANDIDATES_PER_POINT`]).
    pub unkept: usize,
}

impl std::ops::AddAssign for MemoCounts {
    fn add_assign(&mut self, o: MemoCounts) {
        self.hits += o.hits;
        self.misses += o.misses;
        self.replaced += o.replaced;
        self.dropped += o.dropped;
        self.compactions += o.compactions;
        self.above += o.above;
        self.untried += o.untried;
        self.unkept += o.unkept;
    }
}

impl CandidateMemo {
    /// How many queries were answered from a kept ball, and how many walked, since the
    /// candidates were made (or dropped for another `ε1`).
    pub fn counts(&self) -> MemoCounts {
        self.counts
    }

    /// The heap memory held (bytes): what a copy of it costs (an FMU state saved in memory
    /// carries one).
    pub fn heap_bytes(&self) -> usize {
        self.sides
            .iter()
            .map(|s| {
                4 * s.slot.capacity()
                    + std::mem::size_of::<Ball>() * s.balls.capacity()
                    + 4 * (s.cands.capacity() + s.gathered.capacity() + s.spare.0.capacity())
                    + s.retry.capacity()
                    + 8 * s.xyz.iter().map(Vec::capacity).sum::<usize>()
                    + 8 * s.spare.1.iter().map(Vec::capacity).sum::<usize>()
            })
            .sum::<usize>()
            + self.linearized.as_ref().map_or(0, |l| {
                std::mem::size_of::<Linearized>()
                    + 8 * (l.key.capacity() + l.values.capacity() + l.jacobian.capacity())
            })
    }

    /// Starts a band walk of the pair `(a, b)` whose sides read their planes with `eps1` (m²,
    /// per side): drops everything kept if `eps1` is not what it was kept for, a side's balls
    /// if they were kept for other point clouds, and the balls no query read for
    /// [`UNUSED_WALKS`] walks.
    pub(crate) fn begin(&mut self, eps1: [f64; 2], a: &super::Collider, b: &super::Collider) {
        let bits = eps1.map(f64::to_bits);
        if self.eps1 != bits {
            let counts = self.counts;
            *self = CandidateMemo {
                eps1: bits,
                counts,
                ..Default::default()
            };
        }
        let id = |c: &super::Collider| match c {
            super::Collider::Aopc(s) => (s.bvh() as *const _ as usize, s.len()),
            super::Collider::HalfSpace { .. } => (0, 0),
        };
        let nodes = |c: &super::Collider| match c {
            super::Collider::Aopc(s) => s.bvh().nodes.len(),
            super::Collider::HalfSpace { .. } => 0,
        };
        let ((ia, na), (ib, nb)) = (id(a), id(b));
        for ((s, clouds), query) in self
            .sides
            .iter_mut()
            .zip([(ia, na, ib, nb), (ib, nb, ia, na)])
            .zip([a, b])
        {
            if s.clouds != clouds {
                *s = SideCandidates {
                    slot: vec![u32::MAX; clouds.1],
                    retry: vec![0; nodes(query)],
                    clouds,
                    ..Default::default()
                };
            }
            s.walks = s.walks.wrapping_add(1);
            if s.walks % UNUSED_WALKS == 0 {
                let before = s.balls.len();
                s.drop_unused();
                self.counts.dropped += before - s.balls.len();
                self.counts.compactions += 1;
            }
        }
    }

    /// Whether the band walk should try to prove node `ni` of `side`'s query hierarchy beyond
    /// the cutoff: not while the node's proof failed at one of its last [`PROOF_RETRY`]
    /// visits (a node holding the band's points fails at every step). Not trying is always
    /// sound: the node's points are then evaluated, or proven by their balls
    /// ([`CandidateMemo::above`]), and those beyond the cutoff leave the band all the same.
    pub(crate) fn try_proof(&mut self, side: usize, ni: u32) -> bool {
        match self.sides[side].retry.get_mut(ni as usize) {
            Some(r) if *r > 0 => {
                *r -= 1;
                self.counts.untried += 1;
                false
            }
            _ => true,
        }
    }

    /// Records that the proof of node `ni` of `side`'s query hierarchy failed.
    pub(crate) fn proof_failed(&mut self, side: usize, ni: u32) {
        if let Some(r) = self.sides[side].retry.get_mut(ni as usize) {
            *r = PROOF_RETRY;
        }
    }

    /// Whether the kept ball of query point `k` (leaf order) holds `x` (m, the planes' frame)
    /// and proves the SSDF above `t` (m) there. The SSDF at `x` is a weighted mean of
    /// `v_i(x) = n_iᵀ(x - p_i)` over its relevant set, which lies among the ball's candidates,
    /// and each `v_i` moves by at most `|n_i| |x - x₀|` from the ball's centre: so it is at
    /// least `min_i v_i(x₀) - max_i |n_i| |x - x₀|` over the candidates, less a rounding
    /// allowance. A candidate whose `v_i(x₀)` is not a number proves nothing (the point is
    /// evaluated, and a NaN SSDF stays in the band). The ball counts as read.
    pub(crate) fn above(&mut self, side: usize, k: u32, x: &Vector3<f64>, t: f64) -> bool {
        let s = &mut self.sides[side];
        let walks = s.walks;
        let Some(b) = s
            .slot
            .get(k as usize)
            .and_then(|&i| s.balls.get_mut(i as usize))
        else {
            return false;
        };
        let moved = (x - b.centre).norm_squared();
        if !(moved <= b.radius_sq && b.floor - moved.sqrt() * b.slope * (1.0 + 1e-12) > t) {
            return false;
        }
        b.used = walks;
        self.counts.above += 1;
        true
    }

    /// The relevant set of `planes` at the query point `k` (leaf order) of `query`, at `x` (m,
    /// `planes`' frame), into `scratch`: from the point's kept ball if `x` is still in it,
    /// otherwise by a walk, keeping a new ball around `x`. Returns whether the kept ball held.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn relevant(
        &mut self,
        side: usize,
        k: u32,
        query: &Aopc,
        planes: &Aopc,
        x: &Vector3<f64>,
        eps1: f64,
        scratch: &mut Relevant,
    ) -> bool {
        let s = &mut self.sides[side];
        debug_assert_eq!(s.slot.len(), query.len(), "begin() was given this pair");
        let slot = s.slot[k as usize];
        let walks = s.walks;
        if let Some(b) = s.balls.get_mut(slot as usize) {
            if (x - b.centre).norm_squared() <= b.radius_sq {
                b.used = walks;
                let b = *b;
                let (from, to) = (b.start as usize, (b.start + b.len) as usize);
                let [xs, ys, zs] = &s.xyz;
                let xyz = [&xs[from..to], &ys[from..to], &zs[from..to]];
                scratch.find_among_xyz(planes, x, eps1, &s.cands[from..to], xyz);
                self.counts.hits += 1;
                return true;
            }
        }
        self.counts.misses += 1;
        let hint = scratch.nearest;
        scratch.find(planes, x, eps1, hint);
        let bvh = planes.bvh();
        if scratch.nearest >= bvh.len() {
            return false;
        }
        let reach = (scratch.dmin + bvh.log_terms * eps1).sqrt();
        // The relevant set's shell, `√d_min ≤ |x - p_i| ≤ reach`, is `reach - √d_min` thick:
        // the ball's candidates fill a shell about `2δ` thicker, so `δ` no larger than that
        // thickness keeps them within a few times the relevant set (module documentation).
        let shell = bvh.log_terms * eps1 / (reach + scratch.dmin.sqrt());
        let spacing = planes.areas[bvh.index[scratch.nearest] as usize].sqrt();
        let delta = (reach / 8.0).min(shell / 4.0).max(spacing / 4.0);
        let mut gathered = std::mem::take(&mut s.gathered);
        gather_ball(planes, x, delta, eps1, scratch.nearest, &mut gathered);
        let budget = CANDIDATES_PER_POINT * (query.len() + planes.len());
        let freed = s.balls.get(slot as usize).map_or(0, |b| b.len as usize);
        if s.live - freed + gathered.len() > budget {
            s.gathered = gathered;
            self.counts.unkept += 1;
            return false;
        }
        let (start, len) = (s.cands.len(), gathered.len());
        s.cands.extend_from_slice(&gathered);
        for (d, coord) in s.xyz.iter_mut().enumerate() {
            coord.extend(gathered.iter().map(|&k| bvh.points[k as usize][d]));
        }
        // The floor of [`CandidateMemo::above`]; the allowance covers the rounding of the
        // distances and of the SSDF's mean (a few ulps of lengths near |x| + reach).
        let (mut low, mut slope, mut nan) = (f64::INFINITY, 0.0f64, false);
        for &j in &gathered {
            let n = &bvh.normals[j as usize];
            let v = n.dot(&(x - bvh.points[j as usize]));
            // (`f64::min` and `max` pass over a NaN, which must prove nothing here.)
            nan |= v.is_nan() || n.norm().is_nan();
            low = low.min(v);
            slope = slope.max(n.norm());
        }
        let floor = match nan || gathered.is_empty() || !slope.is_finite() {
            true => f64::NEG_INFINITY,
            false => low - 1e-12 * (1.0 + x.norm() + reach),
        };
        s.gathered = gathered;
        let ball = Ball {
            k,
            used: walks,
            centre: *x,
            radius_sq: delta * delta,
            floor,
            slope,
            start: start as u32,
            len: len as u32,
        };
        match s.balls.get_mut(slot as usize) {
            Some(old) => {
                s.live -= old.len as usize;
                *old = ball;
                self.counts.replaced += 1;
            }
            None => {
                s.slot[k as usize] = s.balls.len() as u32;
                s.balls.push(ball);
            }
        }
        s.live += len;
        if s.cands.len() > 2 * s.live + 4096 {
            s.compact();
            self.counts.compactions += 1;
        }
        false
    }
}

impl SideCandidates {
    /// Drops the balls no query read in the last [`UNUSED_WALKS`] walks, and the candidates
    /// of every dropped or replaced ball.
    fn drop_unused(&mut self) {
        let walks = self.walks;
        self.balls
            .retain(|b| walks.wrapping_sub(b.used) < UNUSED_WALKS);
        self.slot.fill(u32::MAX);
        for (i, b) in self.balls.iter().enumerate() {
            self.slot[b.k as usize] = i as u32;
        }
        self.live = self.balls.iter().map(|b| b.len as usize).sum();
        self.compact();
    }

    /// Drops the candidates of replaced balls (into the spare buffers, then swapped).
    fn compact(&mut self) {
        let (mut cands, mut xyz) = std::mem::take(&mut self.spare);
        cands.clear();
        for coord in &mut xyz {
            coord.clear();
        }
        for b in &mut self.balls {
            let (from, to) = (b.start as usize, (b.start + b.len) as usize);
            b.start = cands.len() as u32;
            cands.extend_from_slice(&self.cands[from..to]);
            for (d, coord) in xyz.iter_mut().enumerate() {
                coord.extend_from_slice(&self.xyz[d][from..to]);
            }
        }
        let old = (
            std::mem::replace(&mut self.cands, cands),
            std::mem::replace(&mut self.xyz, xyz),
        );
        self.spare = old;
    }
}

/// One pair's kept proof and candidate planes ([`PairCarry::pairs`]; no candidates when
/// [`PairCarry::walk_always`]).
pub type CarriedPair<'a> = (&'a mut Option<ReachProof>, Option<&'a mut CandidateMemo>);

/// What a model's pairs keep from one evaluation to the next, one entry per pair: the
/// out-of-reach proofs ([`ReachProof`]; which pairs a step switches off depends on them, so a
/// saved FMU state carries them) and the candidate planes ([`CandidateMemo`]; a cost, never a
/// result, so two `PairCarry` with the same proofs are equal); and, one per pair thread, the
/// hierarchy walks' scratch ([`Scratch`]; never a result either).
#[derive(Clone, Debug, Default)]
pub struct PairCarry {
    /// Per pair, the out-of-reach proof kept from an earlier step, if any.
    pub reach: Vec<Option<ReachProof>>,
    /// Per pair, the candidate planes of its band's query points.
    pub candidates: Vec<CandidateMemo>,
    /// No candidates are kept (every query walks): for measurements and tests.
    pub walk_always: bool,
    /// The hierarchy walks' scratch, one per thread that evaluates pairs (grown on demand by
    /// [`PairCarry::pairs_and_scratch`]). Changes a result: no. FMU state: no (a copy starts empty).
    scratch: Vec<Scratch>,
}

impl PartialEq for PairCarry {
    fn eq(&self, o: &Self) -> bool {
        self.reach == o.reach
    }
}

impl PairCarry {
    /// Kept proofs for a model (no candidates yet).
    pub fn with_reach(reach: Vec<Option<ReachProof>>) -> Self {
        PairCarry {
            reach,
            candidates: Vec::new(),
            walk_always: false,
            scratch: Vec::new(),
        }
    }

    /// One entry per pair of a model with `pairs` pairs (new ones empty; no candidates when
    /// [`PairCarry::walk_always`]).
    pub fn fit(&mut self, pairs: usize) {
        self.reach.resize(pairs, None);
        let n = if self.walk_always { 0 } else { pairs };
        self.candidates.resize_with(n, CandidateMemo::default);
    }

    /// Pair `k`'s kept proof and candidates (none when [`PairCarry::walk_always`];
    /// [`PairCarry::fit`] first).
    pub fn pair(&mut self, k: usize) -> (&mut Option<ReachProof>, Option<&mut CandidateMemo>) {
        (&mut self.reach[k], self.candidates.get_mut(k))
    }

    /// [`PairCarry::pair`] of every pair at once, in pair order (disjoint borrows, so that pairs
    /// can be evaluated on several threads).
    pub fn pairs(&mut self) -> impl Iterator<Item = CarriedPair<'_>> {
        self.pairs_and_scratch(1).0
    }

    /// [`PairCarry::pairs`], and the walks' scratch for `threads` threads (at least one).
    pub fn pairs_and_scratch(
        &mut self,
        threads: usize,
    ) -> (impl Iterator<Item = CarriedPair<'_>>, &mut [Scratch]) {
        let threads = threads.max(1);
        if self.scratch.len() < threads {
            self.scratch.resize_with(threads, Scratch::default);
        }
        let mut candidates = self.candidates.iter_mut();
        let pairs = self.reach.iter_mut().map(move |r| (r, candidates.next()));
        (pairs, &mut self.scratch[..threads])
    }
}
