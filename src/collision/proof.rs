//! Out-of-reach proofs kept from step to step (docs/performance.md, "A proof that is kept"):
//! a pair proven out of reach with room to move stays switched off, at the cost of one
//! comparison, while neither body has moved farther than that room; and a kept proof read from
//! outside (a restored FMU state) is proven again before it is trusted.

use super::reach::{cloud_beyond, out_of_reach_by, reach_budget, sides, Beyond, Seed, Side};
use super::*;

/// The distance (m) beyond which a point cannot push: every relevant plane at least this far
/// makes a point–SSDF force smaller than `τ k ε3`, `τ` the pair's pruning `tolerance`
/// ([`PRUNE_TOLERANCE`] unless the scene sets another, [`super::pair_tolerance`]). With `V` a bound on
/// the speed of a query point relative to the plane body's material point, a point–plane
/// force is at most `k s⁺_ε3(-φ) (1 + V/v_d) √(1 + μ²)` (the force bound of
/// [`pair_contact`](crate::contact::pair_contact)), and `s⁺_ε3(-φ) ≤ ε3 e^{-φ/ε3}` for
/// `φ ≥ 0`, so `φ ≥ ε3 ln((1 + V/v_d) √(1 + μ²) / τ)` is enough. `None` when the parameters
/// leave no such distance (ε3 not positive, not finite values).
pub fn reach_distance(
    eps3: f64,
    speed: f64,
    dissipation_velocity: f64,
    friction: f64,
    tolerance: f64,
) -> Option<f64> {
    reach_distance_by(
        eps3,
        speed,
        dissipation_velocity,
        friction,
        tolerance,
        f64::ln,
    )
}

/// [`reach_distance`] with `ln` for the logarithm: the natural one, or an upper bound of it
/// (`ln_above`), which bounds the distance from above.
pub(super) fn reach_distance_by(
    eps3: f64,
    speed: f64,
    dissipation_velocity: f64,
    friction: f64,
    tolerance: f64,
    ln: fn(f64) -> f64,
) -> Option<f64> {
    let factor = (1.0 + speed / dissipation_velocity.abs()) * (1.0 + friction * friction).sqrt();
    let t = eps3 * ln(factor / tolerance);
    (eps3 > 0.0 && t.is_finite()).then_some(t * (1.0 + 1e-12))
}

/// Per eighth `j` of the mantissa's range `[1, 2)`: `1 / c`, `ln c` and `c`, `c = 1 + (j + ½) / 8`,
/// the point whose tangent bounds `ln` over that eighth ([`ln_above`]).
const LN_TANGENTS: [(f64, f64, f64); 8] = [
    (0.9411764705882353, 0.06062462181643484, 1.0625),
    (0.8421052631578947, 0.17185025692665923, 1.1875),
    (0.7619047619047619, 0.27193371548364176, 1.3125),
    (0.6956521739130435, 0.3629054936893685, 1.4375),
    (0.64, 0.44628710262841953, 1.5625),
    (0.5925925925925926, 0.5232481437645479, 1.6875),
    (0.5517241379310345, 0.5947071077466928, 1.8125),
    (0.5161290322580645, 0.661398482245365, 1.9375),
];

/// An upper bound of `ln y`, less than `2e-3` above it, for `y > 0`: `y = m 2^e` with `m` in
/// `[1, 2)`, `ln y = e ln 2 + ln m`, and `ln m` at most the tangent of the concave `ln` at the
/// middle `c` of `m`'s eighth of `[1, 2)` (at most `(1/16)² / 2c²` above it there), plus `1e-9`
/// for the rounding of this sum and of `f64::ln` (both below `1e-12` for `|ln y| < 800`). Other
/// `y` (not normal, not positive) take `f64::ln`.
pub(super) fn ln_above(y: f64) -> f64 {
    if !(y.is_normal() && y > 0.0) {
        return y.ln();
    }
    let bits = y.to_bits();
    let e = ((bits >> 52) & 0x7ff) as f64 - 1023.0;
    let m = f64::from_bits((bits & ((1u64 << 52) - 1)) | (1023u64 << 52));
    let (inv_c, ln_c, c) = LN_TANGENTS[((bits >> 49) & 7) as usize];
    e * std::f64::consts::LN_2 + ln_c + (m - c) * inv_c + 1e-9
}

/// How many lives a proof by the floor alone is given room for (`ProofSide::floor_room`): its
/// room is that many times the motion the bodies' speed bound allows in the life asked.
pub const FLOOR_ROOM_LIVES: f64 = 4.0;

/// An out-of-reach proof kept for the steps after it (docs/performance.md, "A proof that is
/// kept"): per side of the pair (as [`out_of_reach`]; `None` for a side without points), the
/// query body's pose in the plane body's frame when it was proven, and what was proven there.
#[derive(Clone, Debug, PartialEq)]
pub struct ReachProof {
    /// The two sides.
    pub sides: [Option<ProofSide>; 2],
}

/// One side of a [`ReachProof`]: at the pose `x = rotation p + translation`, at every query
/// point either every plane whose squared distance is within `m1 + W` (m²) of the nearest
/// one's lies farther than `t` (m), or the polytope's floor does (for a half-space, its plane;
/// `m1` is then unused and 0). `W` widens the margin for a motion of `room` (m): at a point
/// whose squared distance to the nearest plane point is `D`,
/// `W = min(4δR, 4δ(√(D + m1) + δ))` with `δ = room` (`bounds::widened_margin`;
/// 0 without room). Both hold `δ` less after a move of at most `δ` (the floor is
/// 1-Lipschitz), which is what `ProofSide::covers` uses. `m1` infinite: a proof by the floor
/// alone (`ProofSide::floor_room`), whose room no relevance margin limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProofSide {
    /// Rotation from query-body to plane-body coordinates at the proof.
    pub rotation: Matrix3<f64>,
    /// Query-body origin in plane-body coordinates at the proof (m).
    pub translation: Vector3<f64>,
    /// The distance proven (m).
    pub t: f64,
    /// The relevance margin it was proven over (m²), before the widening for `room`.
    pub m1: f64,
    /// The motion the relevance margin was widened for, point by point (m).
    pub room: f64,
}

impl ProofSide {
    /// A sufficient test for [`ProofSide::covers`] without a square root, for `side` with its
    /// distance bounded from above (`sides(.., true)`): `δ`'s two terms `a + b` are at most
    /// `√(2(a² + b²))`, so each `δ ≤ L` that `covers` asks holds where
    /// `2(a² + b²)(1 + 1e-8) ≤ (L - ε)²`, `ε` twice `covers`' rounding allowance of `1e-15` of
    /// the poses' size (bounded by sums of magnitudes) plus `1e-15` of the distances (the
    /// rounding of `t + δ`), and `1e-8` covering `covers`' own `1e-9` and this sum's
    /// rounding; where a square overflows (`covers`' norms infinite), `false`. Where this
    /// holds, `covers` does (tested on random moves).
    pub(super) fn covers_above(&self, side: &Side) -> bool {
        let scale = side.query.bvh().max_norm;
        let (dt, dr) = (
            side.translation - self.translation,
            side.rotation - self.rotation,
        );
        let r2 = 2.0 * (dt.norm_squared() + dr.norm_squared() * (scale * scale)) * (1.0 + 1e-8);
        let tr = &side.translation;
        let tr1 = tr.x.abs() + tr.y.abs() + tr.z.abs();
        // Where a square may overflow, `covers`' norms may be infinite and it refuse: so does
        // this.
        if !(r2.is_finite() && tr1 < 1e150) {
            return false;
        }
        // (With the distances' own size: `t` and `δ` are added before `covers` compares.)
        let small = 2e-15 * (tr1 + scale) + 1e-15 * (self.t.abs() + side.t.abs());
        let within = |l: f64| {
            let l = l - small;
            l >= 0.0 && r2 <= l * l
        };
        let relevant = match side.planes {
            Collider::Aopc(_) => {
                let (m1_per_eps1, spread) = side.relevance();
                let m1 = m1_per_eps1 * side.eps1;
                within((self.m1 - m1) / (4.0 * spread)) || (m1 <= self.m1 && within(self.room))
            }
            Collider::HalfSpace { .. } => true,
        };
        within(self.t - side.t) && relevant
    }

    /// Whether the proof still covers `side` now: every query point has moved at most `δ`
    /// (`|Δtranslation| + ‖Δrotation‖_F max|p|`), and lies farther than `t - δ` from every
    /// plane the proof read; a plane relevant now (within `m₁ = M1 ε1`) was within
    /// `m₁ + 2δ|p_j - p_i|` at the proof (relevance compares `d_j - d_i`, affine in the query
    /// point with gradient `2(p_i - p_j)`, `i` the nearest point at the proof), and
    /// `|p_j - p_i|` is at most `2R` (`R` the plane cloud's root radius) and at most
    /// `2√(D + m₁) + 2δ` (`D` the squared distance to the nearest point at the proof:
    /// docs/performance.md). So the proof covers where `m₁ + 4δR` is within its margin, or
    /// where `m₁` is and `δ` is within its room. A proof by the floor alone (`m1` infinite)
    /// needs only the distance. Rounding allowances: 1e-9 relative, and 1e-15 of the poses'
    /// size.
    pub(super) fn covers(&self, side: &Side) -> bool {
        let scale = side.query.bvh().max_norm;
        let delta = ((side.translation - self.translation).norm()
            + (side.rotation - self.rotation).norm() * scale)
            * (1.0 + 1e-9)
            + 1e-15 * (side.translation.norm() + scale);
        let relevant = match side.planes {
            Collider::Aopc(_) => {
                let (m1_per_eps1, spread) = side.relevance();
                let m1 = m1_per_eps1 * side.eps1;
                m1 + 4.0 * delta * spread <= self.m1 || (m1 <= self.m1 && delta <= self.room)
            }
            Collider::HalfSpace { .. } => true,
        };
        delta.is_finite() && side.t + delta <= self.t && relevant
    }

    /// The proof to attempt for `side` with room to move: `δ_b` a quarter of the root spheres'
    /// gap (half of a half-space's), for a cloud of planes also at most `3 m₁ / 4R`, what
    /// would widen the relevance margin fourfold if it were widened by `4δR` everywhere (it is
    /// widened by less near the plane body: [`ProofSide`]); the proof must still exclude the
    /// planes facing away (with the uniform widening, at sixteenfold a box 0.5 m from a sphere
    /// was no longer settled, at eightfold it was; rooms of 1.5 and 2 times `3 m₁ / 4R` with
    /// the local widening cost gymnasium's humanoid 1.00 and 1.02 times the instructions).
    /// `None` without a gap, or when the bodies' relative speed would use `δ_b` up in less
    /// than `life` (s): the proof would not be reused.
    fn with_room(side: &Side, life: f64) -> Option<ProofSide> {
        Self::planes_room(side)
            .filter(|&(delta, _)| delta >= side.speed * life)
            .map(|(delta, m1)| ProofSide {
                rotation: side.rotation,
                translation: side.translation,
                t: side.t + delta,
                m1,
                room: if m1 > 0.0 { delta } else { 0.0 },
            })
    }

    /// The room `δ_b` of [`ProofSide::with_room`] and the margin `m₁ = M1 ε1` its proof is
    /// made over (0 over a half-space), before the speed is looked at; `None` without a gap or
    /// room.
    fn planes_room(side: &Side) -> Option<(f64, f64)> {
        let (m1_per_eps1, spread, gap) = side.margins();
        let overlapping = matches!(side.planes, Collider::Aopc(_)) && gap <= 0.0;
        if gap.is_nan() || (gap <= 0.0 && !overlapping) {
            return None;
        }
        let (delta, m1) = match side.planes {
            Collider::Aopc(_) => {
                let m1 = m1_per_eps1 * side.eps1;
                // Root spheres that overlap (two links of one arm) leave the relevance margin
                // alone to choose the room by.
                let quarter = if overlapping {
                    f64::INFINITY
                } else {
                    0.25 * gap
                };
                (quarter.min(3.0 * m1 / (4.0 * spread)), m1)
            }
            Collider::HalfSpace { .. } => (0.5 * gap, 0.0),
        };
        (delta > 0.0 && delta.is_finite()).then_some((delta, m1))
    }

    /// The proof by the polytope's floor alone to attempt for `side` when the planes give no
    /// room that lasts `life` (s) ([`ProofSide::with_room`]): room `δ` = [`FLOOR_ROOM_LIVES`]
    /// times what the bodies' speed bound uses up in `life`. The floor is 1-Lipschitz and
    /// reads no relevance, so its room is not capped by the relevance margin as a proof by
    /// planes is: limbs of gymnasium's humanoid falling at 1 to 3 m/s, 4 to 12 cm apart, got
    /// rooms of 0.1 to 0.3 mm by their planes widened uniformly (none lasting half an RK4
    /// step) and several millimetres by the floor. `None` for a half-space (its planes' room
    /// has no such cap), a cloud without a polytope, bodies whose speed bound is 0, or where
    /// the planes' room lasts.
    pub(super) fn floor_room(side: &Side, life: f64) -> Option<ProofSide> {
        let Collider::Aopc(o) = side.planes else {
            return None;
        };
        o.bvh().polytope.as_ref()?;
        let used = side.speed * life;
        if Self::planes_room(side).is_some_and(|(delta, _)| delta >= used) {
            return None;
        }
        let delta = FLOOR_ROOM_LIVES * used;
        (delta > 0.0 && delta.is_finite()).then_some(ProofSide {
            rotation: side.rotation,
            translation: side.translation,
            t: side.t + delta,
            m1: f64::INFINITY,
            room: 0.0,
        })
    }

    /// The proof by the polytope's floor over the query cloud's root ball alone, with half the
    /// room that floor leaves above `t`: what a pair far apart gets. One floor reading (26
    /// plane values) decides; [`ProofSide::prove`] then settles it at the root node. Where the
    /// planes' room lasts, the floor's is not otherwise tried, and that room is capped by the
    /// relevance margin (`3 m₁ / 4R`): gymnasium's humanoid's limbs 0.2 to 1 m apart got 1.3 to
    /// 4 mm by their planes, used up in about ten forwards, and now get centimetres to
    /// decimetres. `None` for a half-space (its planes' room is already half the gap), a cloud
    /// without a polytope, or a room no larger than the planes' ([`ProofSide::with_room`]) or
    /// than what [`ProofSide::floor_room`] asks ([`FLOOR_ROOM_LIVES`] lives).
    fn far_floor(side: &Side, life: f64) -> Option<ProofSide> {
        let Collider::Aopc(o) = side.planes else {
            return None;
        };
        let polytope = o.bvh().polytope.as_ref()?;
        let (centre, radius) = side.root();
        let delta = 0.5 * (polytope.floor_over_ball(&centre, radius) - side.t);
        let planes = Self::planes_room(side).map_or(0.0, |(room, _)| room);
        let least = planes.max(FLOOR_ROOM_LIVES * side.speed * life);
        (delta > least && delta.is_finite()).then_some(ProofSide {
            rotation: side.rotation,
            translation: side.translation,
            t: side.t + delta,
            m1: f64::INFINITY,
            room: 0.0,
        })
    }

    /// Proves this side at its own pose, distance and margin for `planes` and `query`.
    fn prove(&self, planes: &Collider, query: &Aopc, scratch: &mut Scratch) -> bool {
        // The margin with a rounding allowance: `M1 (m1 / M1)` may come out below `m1`.
        let eps1 = match planes {
            Collider::Aopc(o) => self.m1 * (1.0 + 1e-12) / o.bvh().log_terms,
            // A half-space's SSDF is its plane: ε1 does not enter; any positive value.
            Collider::HalfSpace { .. } => 1.0,
        };
        eps1 > 0.0
            // Planes only: a point settled by its springs gives no room.
            && cloud_beyond(
                &ReachQuestion {
                    planes,
                    rot: &self.rotation,
                    tr: &self.translation,
                    t: self.t,
                    eps1,
                    spring: SpringShape::NONE,
                    room: self.room,
                },
                query,
                (&mut reach_budget(query.len()), scratch),
            ) == Beyond::Planes
    }
}

/// [`out_of_reach`], keeping proofs across calls in `kept`: a pair still covered by its kept
/// proof (`ProofSide::covers`) costs no walk. Otherwise, where the planes' room would not last
/// `life` (s; two internal steps, say), each side is first proven by its polytope's floor
/// alone with room for [`FLOOR_ROOM_LIVES`] lives (`ProofSide::floor_room`): where both sides
/// pass, that proof is kept and the pair is out of reach. Else the pair is proven as
/// [`out_of_reach`] does, and where that succeeds, each side the floor did not prove is proven
/// again with room to move by planes (made only where the speed bound lets it last `life`: one
/// that would not be reused costs a second proof), and the two sides kept together. What it
/// returns is `true` only where every force of the pair is below the bound of
/// [`out_of_reach`]; it can be `true` where a fresh proof would not be (the kept one holds
/// with room), so the decisions depend on `kept`, which is part of the simulation's state.
/// `seed` orders the plain proof's walks ([`Seed`]: a cost, never the answer). The walks work
/// in `scratch`.
#[allow(clippy::too_many_arguments)]
pub fn out_of_reach_proven(
    a: &Collider,
    b: &Collider,
    rels: &[Relative<f64>; 2],
    prm: &ReachParams,
    kept: &mut Option<ReachProof>,
    life: f64,
    seed: Seed,
    scratch: &mut Scratch,
) -> bool {
    // A kept proof is checked first with its reach distances and motion bounded from above
    // without a square root or a logarithm (`sides(.., true)`, `ProofSide::covers_above`):
    // where it covers those it covers the exact ones (larger distances and motions only make
    // the test harder), so the answer is the same; where it does not, the exact check below
    // decides. (On three free bodies out of reach, those roots and logarithms and their wait
    // were about a tenth of the step's wall time.)
    if let Some(k) = kept.as_ref() {
        let covered = sides(a, b, rels, prm, true).is_some_and(|quick| {
            !quick.is_empty()
                && quick
                    .iter()
                    .all(|(i, s)| k.sides[*i].is_some_and(|ks| ks.covers_above(s)))
        });
        if covered {
            return true;
        }
    }
    let Some(sides) = sides(a, b, rels, prm, false) else {
        *kept = None;
        return false;
    };
    if sides.is_empty() {
        *kept = None;
        return false;
    }
    if let Some(k) = kept {
        if sides
            .iter()
            .all(|(i, s)| k.sides[*i].is_some_and(|ks| ks.covers(s)))
        {
            return true;
        }
    }
    // A pair whose last proof was by planes with room, now used up, is usually proven with
    // room again (gymnasium's humanoid: limbs a few centimetres apart, proven afresh every
    // other RK4 stage): for it the proof with room comes first, and where it holds it also
    // proves the pair out of reach now (it covers the pose it is made at), so the plain proof
    // is not made.
    let room_first = kept
        .take()
        .is_some_and(|k| k.sides.iter().flatten().any(|ks| ks.m1.is_finite()));
    // The floor alone first, with room to move: it reads no plane (a walk of 26 plane values
    // per node), and where every side passes, the pair is out of reach with that room, no
    // proof by planes needed. A side it proves is kept for the room stage below.
    let mut floor = [None, None];
    for (i, s) in sides.iter() {
        floor[*i] = ProofSide::far_floor(s, life)
            .filter(|ks| ks.prove(s.planes, s.query, scratch))
            .or_else(|| {
                ProofSide::floor_room(s, life).filter(|ks| ks.prove(s.planes, s.query, scratch))
            });
    }
    if sides.iter().all(|(i, _)| floor[*i].is_some()) {
        *kept = Some(ReachProof { sides: floor });
        return true;
    }
    // Each side the floor did not prove, proven with room to move by planes, and the two sides
    // kept together; whether every side was (the same poses give the same answer, so it is
    // asked at most once).
    let with_room = |floor: &mut [Option<ProofSide>; 2],
                     kept: &mut Option<ReachProof>,
                     scratch: &mut Scratch| {
        let roomy = sides.iter().all(|(i, s)| {
            floor[*i]
                .or_else(|| {
                    ProofSide::with_room(s, life).filter(|ks| ks.prove(s.planes, s.query, scratch))
                })
                .map(|ks| floor[*i] = Some(ks))
                .is_some()
        });
        if roomy {
            *kept = Some(ReachProof { sides: *floor });
        }
        roomy
    };
    if room_first && with_room(&mut floor, kept, scratch) {
        return true;
    }
    let how = out_of_reach_by(a, b, rels, prm, seed, scratch);
    // Out of reach now: prove it again with room to move by planes where the floor gave none,
    // and keep that for the next steps. (Only here: a pair near enough to fail the plain proof
    // would fail this one too, and a failing proof can cost a whole budget of node tests. Nor
    // where a point needed its springs summed: the proof with room is by planes alone, and
    // that point would fail it.)
    if how == Beyond::Planes && !room_first {
        with_room(&mut floor, kept, scratch);
    }
    how.proven()
}

/// Whether `kept` is a proof that holds for the pair `a`–`b`: each side present where the
/// pair has points, and its proof made again at its own pose succeeds. For a kept proof
/// read from outside (a restored state's bytes): a forged one must not switch a contact off.
pub fn reach_proof_holds(a: &Collider, b: &Collider, kept: &ReachProof) -> bool {
    let mut scratch = Scratch::default();
    [(a, b), (b, a)]
        .into_iter()
        .zip(&kept.sides)
        .all(|((query, planes), side)| match (query, side) {
            (Collider::Aopc(s), Some(ks)) if !s.is_empty() => ks.prove(planes, s, &mut scratch),
            (Collider::Aopc(s), None) => s.is_empty(),
            (Collider::HalfSpace { .. }, None) => true,
            _ => false,
        })
}
