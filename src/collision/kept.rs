//! Candidate planes kept from one evaluation of a pair to the next (temporal coherence): the
//! band's query points barely move between internal steps, so the other body's points that can
//! be relevant around where a query point was still hold everything relevant where it is now.
//!
//! For a query point at `x₀` (the other body's frame), [`gather_ball`] collects every plane
//! that can be relevant at some point of the ball `|x - x₀| ≤ δ` (its proof is the shared
//! ball's, `geometry::ssdf`). While the point stays in that ball, its relevant set is narrowed
//! from those few candidates ([`Relevant::find_among`]) instead of walking the hierarchy again.
//! The relevant set, its order (increasing index) and so every sum over it are the same to the
//! last bit as a fresh walk's: what is kept changes the cost, never a result, which is why it
//! is not part of a saved FMU state.
//!
//! `δ` is an eighth of the ball's own reach at `x₀` (`√(d_min + ln(I/τ) ε1)`: the candidates
//! grow by about a quarter in radius) and at least a quarter of the nearest plane's spacing
//! (`√area`), so that a point resting against a fine cloud at sharp `ε1` is not re-gathered at
//! every micrometre.

use super::KeptReach;
use crate::geometry::ssdf::{gather_ball, Relevant};
use crate::geometry::Aopc;
use nalgebra::Vector3;

/// The candidates kept for one pair (both sides). Empty by default; filled by the band walk
/// of the pair's evaluations that are given it ([`pair_contact_kept`](crate::contact::pair_contact_kept)).
#[derive(Clone, Debug, Default)]
pub struct KeptCandidates {
    /// The `ε1` (m²) the candidates were gathered for (bits): another one drops them all.
    eps1: u64,
    /// Per side: 0 the points of `a` against the planes of `b`, 1 the reverse.
    sides: [SideCandidates; 2],
    /// Queries answered so far, from a kept ball or not.
    counts: KeptCounts,
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
    /// Scratch of one gathering.
    gathered: Vec<u32>,
}

#[derive(Clone, Copy, Debug)]
struct Ball {
    centre: Vector3<f64>,
    /// `δ²` (m²).
    radius_sq: f64,
    start: u32,
    len: u32,
}

/// Query points whose kept ball held them, and those that gathered a new one
/// ([`KeptCandidates::counts`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KeptCounts {
    /// Queries answered from a kept ball.
    pub hits: usize,
    /// Queries that walked the hierarchy and kept a new ball.
    pub misses: usize,
}

impl KeptCandidates {
    /// How many queries were answered from a kept ball, and how many walked, since the
    /// candidates were made (or dropped for another `ε1`).
    pub fn counts(&self) -> KeptCounts {
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
                    + 4 * (s.cands.capacity() + s.gathered.capacity())
                    + 8 * s.xyz.iter().map(Vec::capacity).sum::<usize>()
            })
            .sum()
    }

    /// Drops everything kept if `eps1` (m²) is not the one it was kept for.
    pub(crate) fn begin(&mut self, eps1: f64) {
        if self.eps1 != eps1.to_bits() {
            *self = KeptCandidates {
                eps1: eps1.to_bits(),
                ..Default::default()
            };
        }
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
        let n = query.len();
        if s.slot.len() != n {
            *s = SideCandidates {
                slot: vec![u32::MAX; n],
                ..Default::default()
            };
        }
        let slot = s.slot[k as usize];
        if let Some(b) = s.balls.get(slot as usize) {
            if (x - b.centre).norm_squared() <= b.radius_sq {
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
        let spacing = planes.areas[bvh.index[scratch.nearest] as usize].sqrt();
        let delta = (reach / 8.0).max(spacing / 4.0);
        let mut gathered = std::mem::take(&mut s.gathered);
        gather_ball(planes, x, delta, eps1, scratch.nearest, &mut gathered);
        let (start, len) = (s.cands.len(), gathered.len());
        s.cands.extend_from_slice(&gathered);
        for (d, coord) in s.xyz.iter_mut().enumerate() {
            coord.extend(gathered.iter().map(|&k| bvh.points[k as usize][d]));
        }
        s.gathered = gathered;
        let ball = Ball {
            centre: *x,
            radius_sq: delta * delta,
            start: start as u32,
            len: len as u32,
        };
        match s.balls.get_mut(slot as usize) {
            Some(old) => {
                s.live -= old.len as usize;
                *old = ball;
            }
            None => {
                s.slot[k as usize] = s.balls.len() as u32;
                s.balls.push(ball);
            }
        }
        s.live += len;
        if s.cands.len() > 2 * s.live + 4096 {
            s.compact();
        }
        false
    }
}

impl SideCandidates {
    /// Drops the candidates of replaced balls.
    fn compact(&mut self) {
        let mut cands = Vec::with_capacity(2 * self.live);
        let mut xyz: [Vec<f64>; 3] = Default::default();
        for b in &mut self.balls {
            let (from, to) = (b.start as usize, (b.start + b.len) as usize);
            b.start = cands.len() as u32;
            cands.extend_from_slice(&self.cands[from..to]);
            for (d, coord) in xyz.iter_mut().enumerate() {
                coord.extend_from_slice(&self.xyz[d][from..to]);
            }
        }
        self.cands = cands;
        self.xyz = xyz;
    }
}

/// What a model's pairs keep from one evaluation to the next, one entry per pair: the
/// out-of-reach proofs ([`KeptReach`]; which pairs a step switches off depends on them, so a
/// saved FMU state carries them) and the candidate planes ([`KeptCandidates`]; a cost, never a
/// result, so two `PairsKept` with the same proofs are equal).
#[derive(Clone, Debug, Default)]
pub struct PairsKept {
    /// Per pair, the out-of-reach proof kept from an earlier step, if any.
    pub reach: Vec<Option<KeptReach>>,
    /// Per pair, the candidate planes of its band's query points.
    pub candidates: Vec<KeptCandidates>,
}

impl PartialEq for PairsKept {
    fn eq(&self, o: &Self) -> bool {
        self.reach == o.reach
    }
}

impl PairsKept {
    /// Kept proofs for a model (no candidates yet).
    pub fn with_reach(reach: Vec<Option<KeptReach>>) -> Self {
        PairsKept {
            reach,
            candidates: Vec::new(),
        }
    }

    /// One entry per pair of a model with `pairs` pairs (new ones empty).
    pub fn fit(&mut self, pairs: usize) {
        self.reach.resize(pairs, None);
        self.candidates.resize_with(pairs, KeptCandidates::default);
    }

    /// Pair `k`'s kept proof and candidates ([`PairsKept::fit`] first).
    pub fn pair(&mut self, k: usize) -> (&mut Option<KeptReach>, &mut KeptCandidates) {
        (&mut self.reach[k], &mut self.candidates[k])
    }
}
