//! Pairs out of reach: a proof, over whole nodes of one body's points, that the other body's
//! SSDF stays above a distance at which no point of the pair can push, so that the pair's
//! forces are known to be negligible without walking its separation band.
//!
//! The proof is the band walk's node test ([`ssdf_exceeds_over`]) against a fixed threshold
//! instead of the band's moving one, walking down the query body's hierarchy only where a
//! node cannot be settled whole, and at a leaf point by point, within [`reach_budget`]
//! tests. A pair it cannot settle is evaluated in full, so giving up costs time, never
//! accuracy.
//!
//! Every distance the model reads at a query point is raised to the floor of the plane body's
//! bounding polytope (docs/method.md, "Departure 3"), so a node whose ball lies above `t` by
//! that floor alone is settled by 26 plane values before any SSDF plane is looked at. Far
//! from a part, the SSDF's own planes can pass close to a query (beside a flat face's edge),
//! and without the floor such pairs failed their proofs and were evaluated in full: robosuite's
//! Franka arm, at rest, had 7 of its 22 link pairs in reach, 5 of them 6 cm to 44 cm apart, and
//! one 2 ms step took 123 ms; with the floor only the 2 pairs that touch are in reach, and the
//! step takes 43 ms (`examples/pair_stats`, one run each).
//!
//! How sharp it is (tests/contact_reach.rs, ε1 = 1e-5 m², ε3 = 0.1 mm, reach distance 3.5 mm
//! at rest, 1 cm spacing): a sphere beside a box face is settled from a gap of 6 mm, two boxes
//! side by side from 1.45 cm (one and a half cover radii, the floor's margin, is 1.06 cm), and
//! 117 of 117 random pairs of shapes more than two reach distances + 5 mm apart. Without the
//! floor the boxes needed 3.6 cm: the edge points of one box lie behind the planes of the
//! other's top and bottom faces, which still weigh `e^{-g s/ε1}` there (`g` the gap, `s` the
//! spacing). Bounding each point's springs weighted by their softmax weights settled no more
//! of those boxes; it settles curved parts seen past their nearest point, where the planes
//! around it read within `t` but weigh too little to matter (`springs_settle`, tried at a
//! leaf's points that the planes leave unsettled): gymnasium's humanoid's hands beside its
//! thighs, 7 mm apart, went from a failed proof and a full evaluation at every RK4 stage to a
//! proof, and its run of 1 s from 3.3 s to 2.6 s.

use super::bounds::{aopc_exceeds, widened_margin};
use super::proof::{ln_above, reach_distance_by};
use super::settle::{point_springs_settle, seed_within};
use super::*;

/// Node and point tests one side of a pair may spend on its proof at least, before it gives
/// up (the pair is then evaluated in full); a side of more than four times as many points may
/// spend a quarter of its point count ([`reach_budget`]). Far pairs settle at the root or a few
/// levels below it; pairs in contact fail at the first point of the first leaf they reach, so
/// the budget bounds what the proof adds to a pair that is near without touching.
pub const REACH_BUDGET: usize = 256;

/// The tests one side may spend on its proof: [`REACH_BUDGET`], or a quarter of the query
/// cloud's points where that is more. Two concave links of an arm 1 to 2 cm apart (xArm7 at
/// rest, 2,500 to 3,700 points a side) settle in 300 to 600 tests, where the pair evaluated in
/// full walks every point of its band (4 to 7 ms against 0.1 to 0.5 ms for the proof, measured
/// with `examples/pair_stats`); a fixed budget of 256 gave them up and left them in reach. A
/// test costs about what a point of the band walk costs or less, so a proof that still fails
/// adds at most about a quarter of a full evaluation.
pub fn reach_budget(points: usize) -> usize {
    REACH_BUDGET.max(points / 4)
}

/// Scratch space of [`cloud_beyond`]'s walk, part of a [`Scratch`]. A step proves several
/// pairs out of reach, each proof a short walk: with the scratch carried from one to the next,
/// the walk allocates nothing once its vectors have grown (with bodies out of reach,
/// allocating them was a tenth of the step).
#[derive(Default)]
pub(super) struct ReachWalk {
    /// Open nodes of the other hierarchy, per entry of the stack (see the walk).
    arena: Vec<u32>,
    front: Vec<u32>,
    unsettled: Vec<u32>,
    stack: Vec<(u32, usize, u32, u32)>,
}

/// What a proof asks of a cloud of query points ([`cloud_beyond`]): whether every distance
/// the model reads at each of them, posed in the frame of `planes` by `x = rot p + tr`, exceeds
/// `t` (m), with the SSDF's `eps1` (m²) and, where a point's springs are summed, `spring`.
#[derive(Clone, Copy)]
pub struct ReachQuestion<'a> {
    /// The body whose planes the query points are measured against.
    pub planes: &'a Collider,
    /// The query cloud's rotation into the frame of `planes`.
    pub rot: &'a Matrix3<f64>,
    /// The query cloud's translation into the frame of `planes` (m).
    pub tr: &'a Vector3<f64>,
    /// The threshold (m).
    pub t: f64,
    /// The SSDF's smoothing `ε1` (m²). Infinite: every plane counts as relevant, which no
    /// point of a closed surface's outside passes, so only the floor of the plane body's
    /// polytope settles a point (a proof by the floor alone, `ProofSide::floor_room`).
    pub eps1: f64,
    /// The springs' shape, for the points whose springs are summed.
    pub spring: SpringShape,
    /// The motion (m) the proof must survive (a kept proof's room, 0 for a proof at this pose
    /// only): at each query point the relevance margin `M1 ε1` is widened by
    /// `4δ (√(D + M1 ε1) + δ)`, at most `4δR`, `D` the squared distance to the nearest plane
    /// point and `R` the plane cloud's root radius (`bounds::widened_margin`,
    /// docs/performance.md).
    pub room: f64,
}

/// Whether every distance the model reads at every point of `query` exceeds the threshold of
/// `q` ([`ReachQuestion`]): the SSDF of its planes (the bound of [`ssdf_exceeds_over`], which
/// also bounds every relevant plane: `n_iᵀ(x - p_i) > t`), or else the floor of its polytope,
/// to which every reading is raised; proven, or `false`. The tests it makes are taken from
/// `budget`; its walk works in `scratch`.
pub fn cloud_beyond(
    q: &ReachQuestion,
    query: &Aopc,
    (budget, scratch): (&mut usize, &mut Scratch),
) -> Beyond {
    cloud_beyond_with(q, query, (budget, scratch), Seed::AfterRoot)
}

/// When [`cloud_beyond`]'s walk looks at its one point nearest the other body (`seed_within`),
/// which ends a proof that cannot succeed. Never the answer, only its cost: the look is sound
/// (tested), so wherever it ends a walk, every walk ends unproven.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Seed {
    /// Not at all (for the test that it changes no answer).
    Off,
    /// After the root node's test, when that test has not settled the cloud: the order for a
    /// pair that may be out of reach, which the root test usually settles at once.
    AfterRoot,
    /// Before the root node's test: the order for a pair whose plain proof failed at its
    /// last forward (in contact, as a resting stack's boxes are), where the root test, a walk
    /// of the other cloud's hierarchy, would fail anyway.
    First,
}

/// How [`cloud_beyond`] settled a cloud.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Beyond {
    /// Not proven (a point within, or the budget spent).
    Not,
    /// Every relevant plane at every point is farther than the threshold (or the floor is):
    /// the proof holds with room where its margins give room ([`super::ProofSide`]).
    Planes,
    /// As `Planes`, except at points whose springs were summed and found below the threshold's
    /// spring (`springs_settle`, src/collision/settle.rs): a proof at this pose only.
    Springs,
}

impl Beyond {
    /// Whether the cloud is proven beyond the threshold.
    pub fn proven(self) -> bool {
        self != Beyond::Not
    }
}

/// [`cloud_beyond`], with its look at one point where `seed` says ([`Seed`]).
pub(super) fn cloud_beyond_with(
    q: &ReachQuestion,
    query: &Aopc,
    (budget, scratch): (&mut usize, &mut Scratch),
    seed: Seed,
) -> Beyond {
    let ReachQuestion {
        planes, rot, tr, t, ..
    } = *q;
    let bvh = query.bvh();
    if bvh.is_empty() {
        return Beyond::Planes;
    }
    // One bound on |x - p_i| for every query point and every plane point (the two root
    // spheres), so that the threshold the walk proves is the same at every node.
    let vmax = match planes {
        Collider::Aopc(o) if o.is_empty() => return Beyond::Planes,
        Collider::Aopc(o) => {
            let (qr, or) = (&bvh.nodes[0], &o.bvh().nodes[0]);
            ((rot * qr.centre + tr - or.centre).norm() + qr.radius + or.radius) * (1.0 + 1e-12)
        }
        Collider::HalfSpace { .. } => f64::NAN,
    };
    if matches!(planes, Collider::Aopc(_)) && !vmax.is_finite() || !t.is_finite() {
        return Beyond::Not;
    }
    // Both clouds' shapes first: one test for the whole side where they settle it.
    if let Collider::Aopc(o) = planes {
        let base = o.bvh().log_terms * q.eps1;
        // No witness here: a room's widening at its cap, `4δR`.
        let m1 = widened_margin(base, q.room, o.bvh().nodes[0].radius, f64::INFINITY, 0.0);
        let need = super::bounds::band_need(t, vmax, o.bvh().tolerance);
        if m1.is_finite() && super::shapes::shapes_settle(o, query, rot, tr, m1, need) {
            *budget = budget.saturating_sub(1);
            return Beyond::Planes;
        }
    }
    let (beyond, tests) = walk(q, bvh, (vmax, *budget), seed, scratch);
    *budget = budget.saturating_sub(tests);
    beyond
}

/// The walk of [`cloud_beyond`] over the hierarchy of the query cloud.
fn walk(
    q: &ReachQuestion,
    bvh: &crate::geometry::bvh::Bvh,
    (vmax, budget): (f64, usize),
    seed: Seed,
    scratch: &mut Scratch,
) -> (Beyond, usize) {
    let ReachQuestion {
        planes,
        rot,
        tr,
        t,
        eps1,
        spring,
        room,
    } = *q;
    // Depth first, as the band walk: each entry is a node, the witness of its parent's test
    // and the parent's open nodes of the other hierarchy (`arena[from..to]`).
    // `relevant`: the relevant set of `seed_within`'s point, and of the points whose springs
    // are summed.
    let Scratch {
        reach:
            ReachWalk {
                arena,
                front,
                unsettled,
                stack,
            },
        relevant,
        ..
    } = scratch;
    arena.clear();
    arena.push(0);
    stack.clear();
    stack.push((0u32, usize::MAX, 0u32, 1u32));
    // A proof by the floor alone (`eps1` infinite) tries no plane: with every plane relevant
    // the planes facing away fail it at the first node (a sound answer, found slowly).
    let floors_only = eps1 == f64::INFINITY;
    if seed == Seed::First && !floors_only && seed_within(q, bvh, vmax, relevant) {
        return (Beyond::Not, 1); // in contact again: the root test would fail
    }
    let mut tests = 0;
    let mut springs_used = false;
    while let Some((ni, hint, from, to)) = stack.pop() {
        tests += 1;
        if tests > budget {
            return (Beyond::Not, tests);
        }
        arena.truncate(to as usize);
        let node = &bvh.nodes[ni as usize];
        let region = QueryRegion {
            centre: rot * node.centre + tr,
            radius: node.radius,
            m: rot * node.axis,
            lo: node.slab_lo,
            hi: node.slab_hi,
        };
        if !(region.centre.iter().all(|x| x.is_finite()) && region.radius.is_finite()) {
            // Poses beyond f64's range (forged states): no proof; the full evaluation deals
            // with them.
            return (Beyond::Not, tests);
        }
        let (settled, witness, (cfrom, cto)) = match planes {
            // Every distance the model reads at a point of the node is at least the plane
            // body's floor there (docs/method.md, "Departure 3"), and the floor over the
            // node's ball is above `t`: settled by 26 plane values, whatever the SSDF's own
            // planes read (beside a flat face's edge they pass near far-away points).
            Collider::Aopc(o) if floor_above(o, &region.centre, region.radius, t) => continue,
            Collider::Aopc(_) if floors_only => (false, hint, (from, to)),
            Collider::Aopc(o) => {
                front.clear();
                front.extend_from_slice(&arena[from as usize..to as usize]);
                let (ok, j) =
                    aopc_exceeds(o, &region, t, (eps1, room), hint, Some(vmax), front, arena);
                (ok, j, (to, arena.len() as u32))
            }
            Collider::HalfSpace { .. } => {
                let (ok, j) = ssdf_exceeds_over(planes, &region, t, eps1, usize::MAX);
                (ok, j, (from, to))
            }
        };
        if settled {
            continue;
        }
        if seed == Seed::AfterRoot
            && !floors_only
            && tests == 1
            && seed_within(q, bvh, vmax, relevant)
        {
            return (Beyond::Not, tests); // in contact: the walk could only fail further down
        }
        if node.is_leaf() {
            // Point by point: a region of one point has no slack in its relevance and plane
            // bounds, which a leaf's ball has (`2 r |p_j - p_i|`).
            for k in node.start..node.start + node.count {
                tests += 1;
                if tests > budget {
                    return (Beyond::Not, tests);
                }
                let x = rot * bvh.points[k as usize] + tr;
                let mut by_springs = false;
                let one = QueryRegion::ball(x, 1e-12 * (x.norm() + 1.0));
                let ok = match planes {
                    Collider::Aopc(o) if floor_above(o, &one.centre, one.radius, t) => true,
                    Collider::Aopc(_) if floors_only => false,
                    Collider::Aopc(o) => {
                        unsettled.clear();
                        let front = &arena[cfrom as usize..cto as usize];
                        aopc_exceeds(
                            o,
                            &one,
                            t,
                            (eps1, room),
                            witness,
                            Some(vmax),
                            front,
                            unsettled,
                        )
                        .0 || {
                            // Its springs summed: a second test's worth.
                            tests += 1;
                            by_springs = tests <= budget
                                && point_springs_settle(o, &x, eps1, spring, t, relevant);
                            by_springs
                        }
                    }
                    Collider::HalfSpace { .. } => {
                        ssdf_exceeds_over(planes, &one, t, eps1, usize::MAX).0
                    }
                };
                if !ok {
                    return (Beyond::Not, tests);
                }
                springs_used |= by_springs;
            }
            continue;
        }
        stack.push((node.left + 1, witness, cfrom, cto));
        stack.push((node.left, witness, cfrom, cto));
    }
    let beyond = if springs_used {
        Beyond::Springs
    } else {
        Beyond::Planes
    };
    (beyond, tests)
}

/// Whether the floor of `o`'s bounding polytope is above `t` (m) over the ball of radius `rho`
/// (m) around `c` (`o`'s frame): then every distance the model reads there, each plane's and
/// the separation field's, is above `t`, as it is raised to the floor. `false` for a cloud
/// without a polytope.
fn floor_above(o: &Aopc, c: &Vector3<f64>, rho: f64, t: f64) -> bool {
    o.bvh()
        .polytope
        .as_ref()
        .is_some_and(|p| p.floor_over_ball(c, rho) > t)
}

/// What a pair's proof of being out of reach reads of its contact parameters (real parts):
/// the SSDF's ε1 (m²) on each side, the spring's ε3 (m), the margin where its springs rest (m), the
/// dissipation velocity (m/s) and the friction coefficient.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReachParams {
    /// The SSDF's smoothing ε1 (m²) each side reads the other body's planes with (0: `a`'s
    /// points against `b`'s planes, 1: the reverse; [`crate::contact::eps1_sides`]).
    pub eps1: [f64; 2],
    /// The spring's smoothing ε3 (m).
    pub eps3: f64,
    /// Where the pair's springs rest (m): they read the distance less it.
    pub margin: f64,
    /// The dissipation velocity (m/s).
    pub dissipation_velocity: f64,
    /// The friction coefficient.
    pub friction: f64,
}

impl ReachParams {
    /// The pair's spring, whose sums the proofs may bound at a point ([`cloud_beyond`]).
    pub fn spring(&self) -> SpringShape {
        SpringShape {
            eps3: self.eps3,
            margin: self.margin,
        }
    }
}

/// Whether the pair `a`–`b` is out of reach: for each body with points, the other body's
/// SSDF is proven above `margin` plus [`reach_distance`] at all of them ([`cloud_beyond`]),
/// with the speed bound taken from the bodies' motion (`rels[0]`: `a` seen from `b`,
/// `rels[1]`: `b` seen from `a`, real parts). `margin` (m): where the pair's springs rest
/// (they read the distance less it).
///
/// Then every force of the pair is below
/// `τ k (ε3 + (max(0, ℓ + m) + ε3 ln 2) (1 + V/v_d) √(1 + μ²))`,
/// `ℓ` the largest distance between a point of one body and a point of the other: the
/// relevant planes of each point force contribute less than `τ k ε3`, and planes the pruned
/// SSDF may keep although they are irrelevant weigh less than τ in all, each with a spring of
/// at most `ℓ + ε3 ln 2` (the pruning every pair already has). Torques are below that times
/// the bodies' reach from their origins. A pair with no points on either side is not out of
/// reach (there is nothing to save). At a point whose springs were summed (`springs_settle`, src/collision/settle.rs)
/// the relevant planes' springs together are below `τ ε3` over the speed and friction factor,
/// which gives the same bound. The proof's walks work in `scratch`.
pub fn out_of_reach(
    a: &Collider,
    b: &Collider,
    rels: &[Relative<f64>; 2],
    prm: &ReachParams,
    scratch: &mut Scratch,
) -> bool {
    out_of_reach_by(a, b, rels, prm, Seed::AfterRoot, scratch).proven()
}

/// [`out_of_reach`], saying how: [`Beyond::Springs`] where a point of either side needed its
/// springs summed, [`Beyond::Planes`] where the planes settled every point. `seed` orders each
/// side's walk ([`Seed`]: the same answer, at another cost).
pub fn out_of_reach_by(
    a: &Collider,
    b: &Collider,
    rels: &[Relative<f64>; 2],
    prm: &ReachParams,
    seed: Seed,
    scratch: &mut Scratch,
) -> Beyond {
    let Some(sides) = sides(a, b, rels, prm, false) else {
        return Beyond::Not;
    };
    let spring = prm.spring();
    let mut budget = sides.budget();
    let mut how = if sides.is_empty() {
        Beyond::Not
    } else {
        Beyond::Planes
    };
    for (_, s) in sides.iter() {
        if how == Beyond::Not {
            break;
        }
        let (rot, tr) = (&s.rotation, &s.translation);
        let q = ReachQuestion {
            planes: s.planes,
            rot,
            tr,
            t: s.t,
            eps1: s.eps1,
            spring,
            room: 0.0,
        };
        match cloud_beyond_with(&q, s.query, (&mut budget, &mut *scratch), seed) {
            Beyond::Planes => {}
            other => how = other,
        }
    }
    how
}

/// One side of a pair's proof: the query body's cloud, posed in the plane body's frame, and
/// the reach distance `t` (m) at its speed.
pub(super) struct Side<'a> {
    pub(super) query: &'a Aopc,
    pub(super) planes: &'a Collider,
    pub(super) rotation: Matrix3<f64>,
    pub(super) translation: Vector3<f64>,
    pub(super) t: f64,
    /// The bound on the query points' speed relative to the planes (m/s).
    pub(super) speed: f64,
    /// The ε1 (m²) the query points read the planes with.
    pub(super) eps1: f64,
}

impl Side<'_> {
    /// The query root sphere's centre in the plane body's frame, and its radius.
    pub(super) fn root(&self) -> (Vector3<f64>, f64) {
        let n = &self.query.bvh().nodes[0];
        (self.rotation * n.centre + self.translation, n.radius)
    }

    /// For a cloud of planes: `M1` (the relevance margin per unit ε1, m1 = M1 ε1), the bound
    /// `R` on half the distance between two plane points, `|p_i - p_j| ≤ 2R` (the plane
    /// cloud's root sphere), and the gap between the root spheres less `t`. For a half-space:
    /// `M1 = 0`, `R = 0`, and the root sphere's height above the plane less `t`.
    pub(super) fn margins(&self) -> (f64, f64, f64) {
        let (m1_per_eps1, spread) = self.relevance();
        let (c, r) = self.root();
        let gap = match self.planes {
            // No planes: nothing to be near; no room to choose (`with_room` gives none).
            Collider::Aopc(o) if o.is_empty() => f64::INFINITY,
            Collider::Aopc(o) => {
                let (oc, or) = (&o.bvh().nodes[0].centre, o.bvh().nodes[0].radius);
                (c - oc).norm() - r - or - self.t
            }
            Collider::HalfSpace { point, normal } => normal.dot(&(c - point)) - r - self.t,
        };
        (m1_per_eps1, spread, gap)
    }

    /// The first two of [`Side::margins`], `M1` and `R`, without the root spheres' gap (a kept
    /// proof's check reads only these, at every forward of every pair it settles).
    pub(super) fn relevance(&self) -> (f64, f64) {
        match self.planes {
            Collider::Aopc(o) if !o.is_empty() => {
                (o.bvh().log_terms, o.bvh().nodes[0].radius * (1.0 + 1e-12))
            }
            _ => (0.0, 0.0),
        }
    }
}

/// A pair's sides with points, by index (no allocation: every pair of every step has them).
pub(super) struct Sides<'a>([Option<(usize, Side<'a>)>; 2]);

impl<'a> Sides<'a> {
    pub(super) fn iter(&self) -> impl Iterator<Item = &(usize, Side<'a>)> {
        self.0.iter().flatten()
    }

    pub(super) fn is_empty(&self) -> bool {
        self.iter().next().is_none()
    }

    /// The tests the pair's proof may spend, both sides together: the sum of the sides'
    /// [`reach_budget`]s, so that a side may use what the other leaves (a proof that succeeds
    /// within each side's own budget still does). Beside a thigh, the humanoid's lower arm
    /// sampled at 1 cm (1,107 points, 276 tests of its own) settles in about 330 tests, the thigh's side in
    /// about 280 of its 490.
    pub(super) fn budget(&self) -> usize {
        self.iter().map(|(_, s)| reach_budget(s.query.len())).sum()
    }
}

/// The sides of a pair with points at `rels`, as in [`out_of_reach`] (0: `a`'s points against
/// `b`'s planes, 1: the reverse), each with its reach distance `t`; `None` when a side has no
/// reach distance or ε1 is not positive (nothing can be proven). Where `above`, `t` is bounded
/// from above without a square root or a logarithm (the speed's norms by their sums of
/// magnitudes, `ln` by `ln_above`), for a kept proof's quick check; `None` also where a
/// speed's square overflows (the exact speed is then infinite, and so is its distance).
// Always inlined: a kept proof's check (every step, every pair) is mostly this; left to the
// compiler it stopped being inlined when unrelated code moved, and the copy of its result
// cost `floating3`'s semi-implicit step 0.6 k of its 40 k instructions (callgrind).
#[inline(always)]
pub(super) fn sides<'a>(
    a: &'a Collider,
    b: &'a Collider,
    rels: &[Relative<f64>; 2],
    prm: &ReachParams,
    above: bool,
) -> Option<Sides<'a>> {
    let ReachParams {
        eps1,
        eps3,
        margin,
        dissipation_velocity,
        friction,
    } = *prm;
    if eps1.iter().any(|e| e.is_nan() || *e <= 0.0) {
        return None;
    }
    let tolerance = super::pair_tolerance(a, b);
    let mut out = Sides([None, None]);
    for (k, (query, planes, rel)) in [(a, b, &rels[0]), (b, a, &rels[1])].into_iter().enumerate() {
        let Collider::Aopc(s) = query else { continue };
        if s.is_empty() {
            continue;
        }
        // A query point `x = arm + t` moves against the plane body's material point at it
        // (the sliding velocity every plane reads there, docs/method.md, departure 6) with
        // `(linvel - ω_p × t) + (ω_q - ω_p) × arm`: bounded over the cloud by its largest arm.
        let (lin, ang) = (
            rel.linvel - rel.angvel_planes.cross(&rel.translation),
            rel.angvel - rel.angvel_planes,
        );
        let max_norm = s.bvh().max_norm;
        let (speed, ln): (f64, fn(f64) -> f64) = if above {
            if !(lin.norm_squared().is_finite() && ang.norm_squared().is_finite()) {
                return None;
            }
            // |x| ≤ Σ|x_i|; the factor covers the norm's last bit of rounding, the term its
            // loss where the squares are below the normal range.
            let l1 = |x: Vector3<f64>| x.x.abs() + x.y.abs() + x.z.abs();
            (
                (l1(lin) + l1(ang) * max_norm) * (1.0 + 1e-12) + 1e-140,
                ln_above,
            )
        } else {
            (lin.norm() + ang.norm() * max_norm, f64::ln)
        };
        // The springs rest at the margin: the reach distance counts from there.
        let t =
            margin + reach_distance_by(eps3, speed, dissipation_velocity, friction, tolerance, ln)?;
        if !t.is_finite() {
            return None;
        }
        out.0[k] = Some((
            k,
            Side {
                query: s,
                planes,
                rotation: rel.rotation,
                translation: rel.translation,
                t,
                speed,
                eps1: eps1[k],
            },
        ));
    }
    Some(out)
}
