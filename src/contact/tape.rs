//! A pair's contact with its positions frozen: what damped Euler's step equation evaluates at
//! many velocities of one configuration (see `Model::damped_euler_velocity`).
//!
//! At fixed positions everything the contact model finds (the separation band and
//! distribution, each query point's relevant planes and their softmin weights, the offsets and
//! normals) is the same at every velocity; only the point–plane forces change, through the
//! relative velocity of each query point against each plane. A [`PairTape`] records those
//! terms in one evaluation and replays the forces at other velocities. Recording goes through
//! the live evaluation's own loop ([`pair_sides`]); the replay sums each point force with the
//! live evaluation's own arithmetic (`SoftAverage`, `half_space_force`, and `point_force` on the
//! terms found again past the budget, `terms_again`) and the pair's wrenches with its own
//! `SideSums`, so at the velocity it was recorded at the replay equals
//! [`pair_contact`](super::pair_contact) on `f64` bit for bit by construction, not by a copy
//! kept in step by hand. At another velocity it keeps the
//! recorded choice of which point forces can matter (their bound grows with the speed: a
//! skipped one stays below the pruning tolerance times the largest unless the speeds grow
//! many orders of magnitude).

use super::*;
use crate::scalar::{derivatives, seeded};
use nalgebra::{Matrix3, SMatrix};
use num_dual::{Derivative, DualSVec64};

/// The dual numbers a tape's velocity Jacobian is seeded with ([`PairTape::replay_seeded`]):
/// the two bodies' linear and angular velocities, 12 directions.
pub type Seeds = DualSVec64<12>;

/// One term of a point–SSDF force: softmin weight, normal, and its spring
/// ([`spring_at`](super::point::spring_at): it does not depend on the velocity, so a replay
/// does not compute it again).
#[derive(Clone, Debug)]
struct Term {
    w: f64,
    n: Vector3<f64>,
    spring: Option<super::point::Spring<f64>>,
}

/// The terms of one point–SSDF force, in the order they were summed.
struct TermSink(Vec<Term>);

impl ForceSink for TermSink {
    const ON: bool = true;

    fn term(&mut self, t: &PlaneTerm) {
        self.0.push(Term {
            w: t.w,
            n: *t.n,
            spring: t.spring,
        });
    }
}

/// One evaluated point force: its side, query point, arm, separation weight and terms.
#[derive(Clone, Debug)]
struct Entry {
    side: usize,
    /// The query point in the plane body's frame, less the translation: `R p`.
    arm: Vector3<f64>,
    weight: f64,
    /// The recorded terms; `None` past the tape's budget.
    terms: Option<std::ops::Range<usize>>,
    /// Against a half-space: one term, not normalized by its weight.
    half_space: bool,
}

/// Terms a tape records per point of the pair's two clouds, at most (48 bytes each): past that
/// budget an entry keeps its query point only, and a replay sums its terms again (the same
/// relevant set and weights, so the same bits), which keeps a tape's memory `O(I1 + I2)`.
pub const TAPE_TERMS_PER_POINT: usize = 8;

/// A pair's contact recorded at one configuration, replayed at other velocities.
#[derive(Clone, Debug)]
pub struct PairTape {
    entries: Vec<Entry>,
    terms: Vec<Term>,
}

impl PairTape {
    /// Records the contact of collider `a` on frame `fa` and `b` on `fb`, and returns it with
    /// the contact at these frames' velocities (the wrenches on `a` and `b` and the smooth
    /// distance, the same bits as [`pair_contact_memo`]); `kept`: the pair's candidate planes
    /// kept across calls, if any ([`CandidateMemo`]).
    pub fn record(
        a: &Collider,
        fa: &Frame<f64>,
        b: &Collider,
        fb: &Frame<f64>,
        prm: &ContactParams<f64>,
        kept: Option<&mut CandidateMemo>,
        scratch: &mut Scratch,
    ) -> (PairTape, PairContact<f64>) {
        let budget = TAPE_TERMS_PER_POINT * (a.len() + b.len()).max(1);
        Self::record_within(a, fa, b, fb, prm, (kept, scratch), budget)
    }

    /// [`PairTape::record`] recording at most `budget` terms.
    pub(crate) fn record_within(
        a: &Collider,
        fa: &Frame<f64>,
        b: &Collider,
        fb: &Frame<f64>,
        prm: &ContactParams<f64>,
        (kept, scratch): (Option<&mut CandidateMemo>, &mut Scratch),
        budget: usize,
    ) -> (PairTape, PairContact<f64>) {
        let rels = crate::collision::pair_relatives(fa, fb, prm.surface.as_ref());
        // Each force's terms go to the tape as it is evaluated, while they fit the budget (a
        // force against a half-space has one term and always fits).
        let mut terms = Vec::new();
        let mut order: Vec<(usize, f64, Option<std::ops::Range<usize>>)> = Vec::new();
        // One force's terms at a time, in one vector handed from force to force (a new one for
        // each force grew term by term: 0.6 % of gymnasium's humanoid's instructions in its
        // reallocations alone).
        let spare = std::cell::Cell::new(Vec::new());
        let parts = pair_sides(
            a,
            b,
            &rels,
            prm,
            BandWork {
                keep_terms: terms_budget(a, b),
                scratch,
                grads: None,
                memo: kept,
            },
            || TermSink(spare.take()),
            |i, w, _, TermSink(mut sunk)| {
                let start = terms.len();
                let fits = start + sunk.len() <= budget || sunk.len() <= 1;
                if fits {
                    terms.append(&mut sunk);
                }
                sunk.clear();
                spare.set(sunk);
                order.push((i, w, fits.then_some(start..terms.len())));
            },
        );
        let mut tape = PairTape {
            entries: Vec::with_capacity(order.len()),
            terms,
        };
        for (i, weight, range) in order {
            let e = &parts.band.entries[i];
            let side = e.side as usize;
            let (query, planes) = if side == 0 { (a, b) } else { (b, a) };
            let Collider::Aopc(s) = query else {
                continue;
            };
            tape.entries.push(Entry {
                side,
                arm: rels[side].rotation * s.bvh().points[e.k as usize],
                weight,
                terms: range,
                half_space: matches!(planes, Collider::HalfSpace { .. }),
            });
        }
        let [on_a, on_b] = SideSums::wrenches(parts.sums, fa, fb);
        let contact = PairContact {
            on_a,
            on_b,
            distance: parts.dist.distance,
        };
        (tape, contact)
    }

    /// How many terms the tape recorded (its memory is about 48 bytes each).
    pub fn recorded_terms(&self) -> usize {
        self.terms.len()
    }

    /// The wrenches on `a` and `b` (the colliders it was recorded for) with the bodies moving
    /// as `fa` and `fb` say, at the positions the tape was recorded at (`fa`, `fb` must have
    /// those poses). On dual numbers whose positions carry no derivative, the replay's
    /// derivatives with respect to the bodies' velocities: what damped Euler's Newton
    /// Jacobian is made of (`FrozenForward::step_jacobian`); on `f64`, the same arithmetic.
    pub fn replay<T: Scalar>(
        &self,
        a: &Collider,
        fa: &Frame<T>,
        b: &Collider,
        fb: &Frame<T>,
        prm: &ContactParams<T>,
    ) -> [Wrench<T>; 2] {
        let rels = crate::collision::pair_relatives(fa, fb, prm.surface.as_ref());
        let mut sums = [SideSums::zero(), SideSums::zero()];
        // Terms summed again for the entries past the budget.
        let mut work = (Relevant::default(), Vec::new());
        for e in &self.entries {
            let rel = &rels[e.side];
            let arm = lift3(&e.arm);
            let v_point = rel.linvel + rel.angvel.cross(&arm);
            // As `pair_sides` evaluated it: x = R p + t (the arm plus the translation).
            let x = arm + rel.translation;
            let planes = if e.side == 0 { b } else { a };
            let pf = self.entry_force(e, planes, &x, &v_point, rel, prm, &mut work);
            sums[e.side].add(&arm, &pf, c(e.weight));
        }
        SideSums::wrenches(sums, fa, fb)
    }

    /// [`PairTape::replay`] on frames whose velocities are seeded as the 12 directions of
    /// `Seeds` (positions carrying none): the wrenches' derivatives with respect to the two
    /// bodies' linear and angular velocities, the same as that replay gives on these frames
    /// to rounding. Each point force reads the velocities only through the sliding velocity
    /// `v = u + ω × arm - ω_p × x` of its query point (3 numbers: `SoftAverage`,
    /// `half_space_force`), so it is summed on dual numbers of width 3 seeded on `v`, giving
    /// `G = ∂f/∂v`; and the sums are linear in each force with the point's arm and position
    /// as coefficients, so each side gathers `Σ w G`, `Σ w G [arm]×`, `Σ w G [x]×` and the
    /// same with `[arm]×` in front (3 × 3 each), chained once at the end with the 3 × 12
    /// derivatives of the side's `u`, `ω` and `ω_p`. A point costs a width-3 sum and a few
    /// 3 × 3 products instead of its terms and sums on width 12 (gymnasium's humanoid as
    /// written, RK4: these Jacobians were a fifth of its run).
    pub fn replay_seeded(
        &self,
        a: &Collider,
        fa: &Frame<Seeds>,
        b: &Collider,
        fb: &Frame<Seeds>,
        prm: &ContactParams<f64>,
    ) -> [Wrench<Seeds>; 2] {
        type D3 = DualSVec64<3>;
        type Rows = SMatrix<f64, 3, 12>;
        let rels = crate::collision::pair_relatives(fa, fb, prm.surface.as_ref());
        let prm3: ContactParams<D3> = prm.lift();
        let rows = |u: &Vector3<Seeds>| Rows::from_fn(|i, j| derivatives(&u[i])[j]);
        // Per side: its motion's real parts, the derivatives of `u`, `ω`, `ω_p`, and the
        // motion a point force reads when `v` is all of it (the plane body still: `v - 0 × x`
        // is `v`).
        let sides = rels.each_ref().map(|rel| {
            let real3 = |u: &Vector3<Seeds>| u.map(|c| D3::from_re(c.re));
            let still = Relative::<D3> {
                rotation: rel.rotation.map(|c| D3::from_re(c.re)),
                translation: real3(&rel.translation),
                linvel: Vector3::zeros(),
                angvel: Vector3::zeros(),
                angvel_planes: Vector3::zeros(),
                surface: rel.surface.as_ref().map(|t| crate::collision::Twist {
                    lin: real3(&t.lin),
                    ang: real3(&t.ang),
                }),
            };
            let real = |u: &Vector3<Seeds>| u.map(|c| c.re);
            (
                [
                    real(&rel.linvel),
                    real(&rel.angvel),
                    real(&rel.angvel_planes),
                ],
                real(&rel.translation),
                [
                    rows(&rel.linvel),
                    rows(&rel.angvel),
                    rows(&rel.angvel_planes),
                ],
                still,
            )
        });
        let mut values = [SideSums::<f64>::zero(), SideSums::zero()];
        let mut gathered = [[Matrix3::<f64>::zeros(); 6]; 2];
        let mut work = (Relevant::default(), Vec::new());
        for e in &self.entries {
            let ([u, om, om_p], tr, _, still) = &sides[e.side];
            let arm = e.arm;
            // As the replay on `Seeds` computes the real parts.
            let v_point = u + om.cross(&arm);
            let x = arm + tr;
            let v = sliding_velocity(&x, &v_point, om_p);
            let v3 = Vector3::from_fn(|k, _| seeded::<3>(v[k], Some(k)));
            let planes = if e.side == 0 { b } else { a };
            let x3 = x.map(D3::from_re);
            let pf3 = self.entry_force(e, planes, &x3, &v3, still, &prm3, &mut work);
            let force = pf3.force.map(|c| c.re);
            let g = Matrix3::from_fn(|i, k| derivatives(&pf3.force[i])[k]);
            let pf = PointForce {
                moment: x.cross(&force),
                force,
            };
            values[e.side].add(&arm, &pf, e.weight);
            let (wg, ax, xx) = (g * e.weight, arm.cross_matrix(), x.cross_matrix());
            let awg = ax * wg;
            let m = &mut gathered[e.side];
            m[0] += wg;
            m[1] += wg * ax;
            m[2] += wg * xx;
            m[3] += awg;
            m[4] += awg * ax;
            m[5] += awg * xx;
        }
        let sums = [0, 1].map(|side| {
            let (_, tr, [du, dom, dom_p], _) = &sides[side];
            let m = &gathered[side];
            // dv = du - [arm]× dω + [x]× dω_p, summed with the gathered coefficients.
            let df_q = m[0] * du - m[1] * dom + m[2] * dom_p;
            let dt_q = m[3] * du - m[4] * dom + m[5] * dom_p;
            // f_p = -f_q; t_p = -Σ w x × f, with x = arm + t: -(t_q + t × f_q).
            let df_p = -df_q;
            let dt_p = -(dt_q + tr.cross_matrix() * df_q);
            let dual = |value: &Vector3<f64>, d: &Rows| {
                Vector3::from_fn(|i, _| {
                    Seeds::new(value[i], Derivative::some(d.row(i).transpose()))
                })
            };
            let v = &values[side];
            SideSums {
                f_q: dual(&v.f_q, &df_q),
                t_q: dual(&v.t_q, &dt_q),
                f_p: dual(&v.f_p, &df_p),
                t_p: dual(&v.t_p, &dt_p),
            }
        });
        SideSums::wrenches(sums, fa, fb)
    }

    /// The point force of entry `e` of this tape at the query point `x` moving with `v_point`
    /// against the planes of `planes` (the bodies' motion `rel`), by the arithmetic the live
    /// evaluation uses (`point_force`): from the recorded terms or, past the budget, from the
    /// terms found again (`work`: the walk's scratch and those terms).
    #[allow(clippy::too_many_arguments)]
    fn entry_force<T: Scalar>(
        &self,
        e: &Entry,
        planes: &Collider,
        x: &Vector3<T>,
        v_point: &Vector3<T>,
        rel: &Relative<T>,
        prm: &ContactParams<T>,
        (scratch, again): &mut (Relevant, Vec<(u32, T)>),
    ) -> PointForce<T> {
        match &e.terms {
            Some(range) if e.half_space => {
                let t = &self.terms[range.start];
                let spring = t.spring.as_ref().map(super::point::Spring::lift);
                half_space_force(x, &lift3(&t.n), spring, v_point, rel, prm).0
            }
            Some(range) => {
                let mut average = SoftAverage::new(*x, v_point, rel, prm);
                for t in &self.terms[range.clone()] {
                    let spring = t.spring.as_ref().map(super::point::Spring::lift);
                    average.add_spring(c(t.w), &lift3(&t.n), spring);
                }
                average.finish()
            }
            None => {
                let Collider::Aopc(o) = planes else {
                    unreachable!("a term past the budget is a point against an AOPC")
                };
                // Its relevant set and weights, as `pair_sides` found them.
                let terms = terms_again(o, x, prm.eps1_sides()[e.side], scratch, again);
                point_force(planes, x, v_point, rel, prm, terms, &mut NoForceSink)
            }
        }
    }
}
