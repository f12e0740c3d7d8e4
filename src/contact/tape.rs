//! A pair's contact with its positions frozen: what damped Euler's step equation evaluates at
//! many velocities of one configuration (see `Model::damped_euler_velocity`).
//!
//! At fixed positions everything the contact model finds (the separation band and
//! distribution, each query point's relevant planes and their softmin weights, the offsets and
//! normals) is the same at every velocity; only the point–plane forces change, through the
//! relative velocity of each query point against each plane. A [`PairTape`] records those
//! terms in one evaluation and replays the forces at other velocities: the same operations in
//! the same order as [`pair_contact`](super::pair_contact) on `f64`, so at the velocity it was
//! recorded at the replay equals the evaluation bit for bit. At another velocity it keeps the
//! recorded choice of which point forces can matter (their bound grows with the speed: a
//! skipped one stays below the pruning tolerance times the largest unless the speeds grow
//! many orders of magnitude).

use super::*;

/// One term of a point–SSDF force: softmin weight, offset `r = x - p`, normal, plane point.
#[derive(Clone, Debug)]
struct Term {
    w: f64,
    r: Vector3<f64>,
    n: Vector3<f64>,
    p: Vector3<f64>,
}

/// The terms of one point–SSDF force, in the order they were summed.
struct TermSink(Vec<Term>);

impl ForceSink for TermSink {
    const ON: bool = true;

    fn term(
        &mut self,
        w: f64,
        r: &Vector3<f64>,
        n: &Vector3<f64>,
        p: &Vector3<f64>,
        _v: &Vector3<f64>,
    ) {
        self.0.push(Term {
            w,
            r: *r,
            n: *n,
            p: *p,
        });
    }
}

/// One evaluated point force: its side, arm, separation weight and terms.
#[derive(Clone, Debug)]
struct Entry {
    side: usize,
    arm: Vector3<f64>,
    weight: f64,
    terms: std::ops::Range<usize>,
    /// Against a half-space: one term, not normalized by its weight.
    half_space: bool,
}

/// A pair's contact recorded at one configuration, replayed at other velocities.
#[derive(Clone, Debug)]
pub struct PairTape {
    entries: Vec<Entry>,
    terms: Vec<Term>,
}

impl PairTape {
    /// Records the contact of collider `a` on frame `fa` and `b` on `fb`, and returns it with
    /// the wrenches on `a` and `b` at these frames' velocities; `kept`: the pair's candidate
    /// planes kept across calls, if any ([`KeptCandidates`]).
    pub fn record(
        a: &Collider,
        fa: &Frame<f64>,
        b: &Collider,
        fb: &Frame<f64>,
        prm: &ContactParams<f64>,
        kept: Option<&mut KeptCandidates>,
    ) -> (PairTape, [Wrench<f64>; 2]) {
        let rels = [fa.relative_to(fb), fb.relative_to(fa)];
        let mut order: Vec<(usize, f64, Vec<Term>)> = Vec::new();
        let parts = pair_sides(
            a,
            b,
            &rels,
            prm,
            &mut Relevant::default(),
            None,
            kept,
            || TermSink(Vec::new()),
            |i, w, _, sink| order.push((i, w, sink.0)),
        );
        let mut tape = PairTape {
            entries: Vec::with_capacity(order.len()),
            terms: Vec::new(),
        };
        for (i, weight, terms) in order {
            let e = &parts.band.entries[i];
            let side = e.side as usize;
            let (query, planes) = if side == 0 { (a, b) } else { (b, a) };
            let Collider::Aopc(s) = query else {
                continue;
            };
            let start = tape.terms.len();
            tape.terms.extend(terms);
            tape.entries.push(Entry {
                side,
                arm: rels[side].rotation * s.bvh().points[e.k as usize],
                weight,
                terms: start..tape.terms.len(),
                half_space: matches!(planes, Collider::HalfSpace { .. }),
            });
        }
        let (mut on_a, mut on_b) = (Wrench::zero(), Wrench::zero());
        let [s0, s1] = parts.sums;
        s0.finish(fb, true, &mut on_a, &mut on_b);
        s1.finish(fa, false, &mut on_a, &mut on_b);
        (tape, [on_a, on_b])
    }

    /// The wrenches on `a` and `b` with the bodies moving as `fa` and `fb` say, at the
    /// positions the tape was recorded at (`fa`, `fb` must have those poses).
    pub fn replay(
        &self,
        fa: &Frame<f64>,
        fb: &Frame<f64>,
        prm: &ContactParams<f64>,
    ) -> [Wrench<f64>; 2] {
        let rels = [fa.relative_to(fb), fb.relative_to(fa)];
        let mut sums = [SideSums::zero(), SideSums::zero()];
        for e in &self.entries {
            let rel = &rels[e.side];
            let v_point = rel.linvel + rel.angvel.cross(&e.arm);
            let (mut force, mut moment) = (Vector3::zeros(), Vector3::zeros());
            let mut total = 0.0;
            for t in &self.terms[e.terms.clone()] {
                let v = v_point - rel.angvel_planes.cross(&t.p);
                let lambda = if e.half_space {
                    point_plane_force(&t.r, &t.n, &v, prm)
                } else {
                    point_plane_force(&t.r, &t.n, &v, prm) * t.w
                };
                force += lambda;
                moment += t.p.cross(&lambda);
                total += t.w;
            }
            let pf = if e.half_space {
                PointForce { force, moment }
            } else {
                let inv = total.recip();
                PointForce {
                    force: force * inv,
                    moment: moment * inv,
                }
            };
            sums[e.side].add(&e.arm, &pf, e.weight);
        }
        let (mut on_a, mut on_b) = (Wrench::zero(), Wrench::zero());
        let [s0, s1] = sums;
        s0.finish(fb, true, &mut on_a, &mut on_b);
        s1.finish(fa, false, &mut on_a, &mut on_b);
        [on_a, on_b]
    }
}
