//! Proven lower bounds of a collider's SSDF over a region of query points (a ball, or the
//! points of a BVH node): what lets the band walk skip whole nodes exactly.

use super::*;

/// Whether the collider's SSDF exceeds `t` (m) at every point within `r` (m) of `centre`
/// (collider frame), proven; `false` when it cannot be shown cheaply. `eps1` in m².
/// [`QueryRegion`] and [`ssdf_exceeds_over`] take a thinner region than a ball (the points of
/// a BVH node), with the bound documented there.
pub fn ssdf_exceeds(planes: &Collider, centre: &Vector3<f64>, r: f64, t: f64, eps1: f64) -> bool {
    ssdf_exceeds_over(planes, &QueryRegion::ball(*centre, r), t, eps1, usize::MAX).0
}

/// A region of query points, in the frame of the collider whose SSDF is bounded over it: the
/// ball `|x - centre| ≤ radius` cut by the slab `lo ≤ mᵀ(x - centre) ≤ hi` (`m` a unit vector).
/// For a BVH node of query points, the node's bounding sphere and the slab of its points along
/// its normal cone's axis ([`Node::axis`](crate::geometry::bvh::Node::axis)): every point of
/// the node lies in the region, and a patch of a smooth surface makes it thin.
#[derive(Clone, Copy, Debug)]
pub struct QueryRegion {
    /// Centre of the ball (m).
    pub centre: Vector3<f64>,
    /// Radius of the ball (m).
    pub radius: f64,
    /// Unit normal of the slab.
    pub m: Vector3<f64>,
    /// Lower end of the slab, relative to the centre (m; at least `-radius`).
    pub lo: f64,
    /// Upper end of the slab, relative to the centre (m; at most `radius`).
    pub hi: f64,
}

/// Below this radius (m) a [`QueryRegion`] is a point given a rounding allowance (the reach
/// walk's points): [`QueryRegion::min_lin`] then bounds by `|n|₁`, which needs no square root.
pub const POINT_RADIUS: f64 = 1e-9;

impl QueryRegion {
    /// The whole ball (the slab is the ball's extent along any axis).
    pub fn ball(centre: Vector3<f64>, radius: f64) -> Self {
        QueryRegion {
            centre,
            radius,
            m: Vector3::z(),
            lo: -radius,
            hi: radius,
        }
    }

    /// A lower bound of `nᵀy` over the offsets `y = x - centre` of the region's points:
    /// `min { nᵀy : |y| ≤ r, lo ≤ mᵀy ≤ hi }`, in closed form, less a rounding allowance.
    ///
    /// Proof: write `y = s m + u` with `u ⊥ m`, `|u|² ≤ r² - s²`, and `n = α m + β t` with
    /// `α = nᵀm`, `β = |n - α m| ≥ 0`, `t ⊥ m` a unit vector. Then `nᵀy = α s + β tᵀu ≥
    /// g(s) := α s - β √(r² - s²)`, with equality at `u = -√(r² - s²) t`. `g` is convex on
    /// `[-r, r]` (`g'' = β r²/(r² - s²)^{3/2} ≥ 0`) with its minimum at `s* = -α r/|n|`
    /// (`g'(s*) = 0`; the ball's own minimiser `-r n/|n|`), so over `s ∈ [lo, hi]` the minimum
    /// is at `s*` clamped to the interval. For the whole ball this is `-r|n|`.
    #[inline(always)]
    pub fn min_lin(&self, n: &Vector3<f64>) -> f64 {
        let r = self.radius;
        if r <= POINT_RADIUS {
            // A point's region (a rounding allowance wide): `|n|₁ ≥ |n|` bounds the ball's
            // minimum without a square root, at most `0.73 r|n|` looser.
            return -r * (n.x.abs() + n.y.abs() + n.z.abs()) * (1.0 + 1e-12);
        }
        let alpha = n.dot(&self.m);
        let len = n.norm();
        let (lo, hi) = (self.lo.max(-r), self.hi.min(r).max(self.lo.max(-r)));
        let slack = 1e-12 * (len * r);
        // `s* ∈ [lo, hi]`, multiplied through by `|n| > 0` (no division). Rounding may decide
        // either way at an end of the slab; both answers are lower bounds there (the ball's
        // minimum bounds any part of it, and `g` is flat at `s*`).
        let turn = -alpha * r;
        if len > 0.0 && lo * len <= turn && turn <= hi * len {
            // The slab does not bind: `g(s*) = -r|n|`, the ball's own minimum (one square root
            // in all: this is most calls, and the bound walks' hot spot).
            return -r * len - slack;
        }
        let free = if len > 0.0 { turn / len } else { lo };
        // `s*` clamped to an end of the slab: `g(s) = α s - √(β² (r² - s²))`, with `β²` from
        // the components of `n - α m` (not `|n|² - α²`, which cancels when `n` is nearly
        // along `m`).
        let s = free.clamp(lo, hi);
        let beta2 = (n - self.m * alpha).norm_squared();
        // The slack covers the rounding of these few operations (and of |m| = 1 to rounding).
        alpha * s - (beta2 * (r * r - s * s).max(0.0)).sqrt() - slack
    }

    /// Whether `base + min_lin(n) > bound`, proven: the ball's own bound `-r|n|` first,
    /// compared in squares (no square root; with an allowance for the slack and rounding; not
    /// for radii whose square would underflow), then [`QueryRegion::min_lin`] where the slab
    /// may help.
    #[inline(always)]
    pub fn lin_exceeds(&self, base: f64, n: &Vector3<f64>, bound: f64) -> bool {
        let e = base - bound;
        let r = self.radius;
        (e > 0.0 && r > 1e-100 && e * e > r * r * n.norm_squared() * (1.0 + 1e-10))
            || base + self.min_lin(n) > bound
    }

    /// A lower bound of the distance from the region's points to a convex set, given `a`, the
    /// set's point nearest the centre: with `w` the unit vector from `a` to the centre, every
    /// point `x` of the region is at least `wᵀ(x - a)` from the set (`wᵀ(y - a) ≤ 0` for every
    /// `y` of the set, `a` being its nearest point to the centre), and the least of that over
    /// the region is `|centre - a| + min_lin(w)`. Zero when the centre is in the set.
    #[inline]
    pub fn lower_distance_to(&self, a: &Vector3<f64>) -> f64 {
        let ac = self.centre - a;
        let l = ac.norm();
        if l > 0.0 {
            l + self.min_lin(&(ac / l))
        } else {
            0.0
        }
    }
}

/// [`ssdf_exceeds`] over a [`QueryRegion`], with `hint` a leaf-order index of a point of the
/// collider probably near the centre (e.g. the witness of an enclosing region, or
/// `usize::MAX`): it only shortens the search for the nearest point. Returns the answer and the
/// witness (the nearest point to the centre; `usize::MAX` for a half-space or no points). In a
/// band walk over a cloud of more than 2048 points the witness is only a point near the centre
/// (`Bvh::near`, the better of the hint and one descent; the exact search costs more there
/// than the sharper tests save): any point `j` gives `d_min(x) ≤ d_j(x)`, a nearer one only
/// sharper tests.
///
/// For a half-space, `nᵀ(x - p) ≥ nᵀ(centre - p) + min nᵀ(x - centre)` is exact. For an AOPC,
/// with `X` the region:
/// 1. Witness: `j`, a point near the centre (here the nearest). A point `i` can carry a softmax weight
///    above `e^{-M1}` (`M1 = ln(I/τ)`) somewhere in `X` only where
///    `d_i(x) - d_j(x) ≤ M1 ε1`, since `d_min(x) ≤ d_j(x)`. That difference is affine in `x`:
///    `d_i(c + y) - d_j(c + y) = d_i(c) - d_j(c) + 2yᵀ(p_j - p_i)`, so over `X` its minimum is
///    at least `d_i(c) - d_j(c) + min_X 2yᵀ(p_j - p_i)` ([`QueryRegion::min_lin`]), and over a
///    cluster of points in a box at least `mindist²(c, box) - d_j(c) - 2r maxdist(p_j, box)`,
///    and at least `mindist²(c, box) - d_j(c) + 2 min_X yᵀ(p_j - b) - 2r ρ` (`b`, `ρ` the
///    cluster's centre and radius: `2yᵀ(p_j - p_i) = 2yᵀ(p_j - b) + 2yᵀ(b - p_i)`).
///    Points that fail it are *irrelevant*: all of them together weigh less than τ.
///
///    1'. In a band walk, when the witness lies on a flat patch of the collider
///    ([`crate::geometry::patch`]: a box face, a cylinder's cap), a point or cluster behind
///    the patch's plane is also irrelevant wherever its plane could be at or below the
///    threshold, if the patch's covering bound on `d_min` over that part of `X` (sharpest
///    where it projects into the patch) proves it (`covered_out`, `cluster_covered`). This
///    settles the other faces' points near an edge over a region far wider than a spacing,
///    which the single witness cannot (a paraboloid bounds `d_min` well only near its apex).
/// 2. For a relevant point, `v_i(x) = n_iᵀ(x - p_i)` is bounded below over the part of `X`
///    where it can matter by the larger of: its minimum over the ball cut by the half-space
///    `d_i - d_j ≤ M1 ε1` (a linear minimum over a ball cut by a plane, in closed form), and
///    its minimum over `X` ([`QueryRegion::min_lin`]). A cluster of the collider's points is
///    first bounded as a whole, by the larger of
///    - interval arithmetic over the box of `x - p_i` and the box of normals, and
///    - its normal cone (axis `a`, half-angle `θ`, `cos θ ≥ 0`) and support `σ ≥ n_iᵀ(p_i - b)`
///      (`b` the cluster's centre): `v_i(x) = n_iᵀ(x - b) - n_iᵀ(p_i - b)`, and with `z = x - b`,
///      `n_i = cos φ a + sin φ t` (`φ ≤ θ`, `t ⊥ a` unit), `n_iᵀz ≥ cos φ A - sin φ P` where
///      `A ≤ aᵀz` and `P ≥ |z - (aᵀz) a|` over `X`. For `A ≥ 0` that is decreasing in `φ`
///      (derivative `-A sin φ - P cos φ ≤ 0`), so at least `A cos θ - P sin θ`; for `A < 0`
///      at least `A - P sin θ` (`cos φ A ≥ A`, `sin φ ≤ sin θ`) and at least `-√(A² + P²)`
///      (Cauchy–Schwarz; sharper only for a wide cone). So `v_i ≥ that - σ`. (`A < 0` is the
///      usual case where the bodies overlap: the query points lie behind the cluster's planes.
///      The Cauchy–Schwarz bound alone is about `-P`, the region's reach; with `A - P sin θ`, a
///      100k-point sphere–box evaluation at sharp ε took 12.1 M instructions instead of 15.7 M.)
/// 3. `φ̂(x)` is a convex combination of the `v_i(x)`: with `L` the smallest bound over relevant
///    points, `s < τ` the irrelevant weight and `|v_i(x)| ≤ V = √d_j(c) + r + diameter`,
///    `φ̂(x) ≥ min(L, (1 - τ) L) - τ V`. The answer is `true` when that exceeds `t`.
///
/// The walk gives up (returns `false`) after 16 leaves, so a large region costs little: the
/// caller then splits it.
pub fn ssdf_exceeds_over(
    planes: &Collider,
    q: &QueryRegion,
    t: f64,
    eps1: f64,
    hint: usize,
) -> (bool, usize) {
    match planes {
        Collider::HalfSpace { point, normal } => (
            normal.dot(&(q.centre - point)) + q.min_lin(normal) > t,
            usize::MAX,
        ),
        Collider::Aopc(s) => {
            let mut open = Vec::new();
            aopc_exceeds(s, q, t, (eps1, 0.0), hint, None, &[0], &mut open)
        }
    }
}

/// See [`aopc_exceeds`]: a band walk's region gives up at an unsettled cluster smaller than
/// this times its radius. Why 0.3 (callgrind, one evaluation at sharp ε, 100k points per
/// body): sphere–box 23.0 M instructions without giving up, 16.8 M at 0.15, 15.7 M at 0.3,
/// 15.2 M at 0.4; box–box 10.5 M without, 9.8 M at 0.15, 10.0 M at 0.3; no change at 1k
/// points or at the scenes' ε.
pub(super) const GIVE_UP_RATIO: f64 = 0.3;

/// The threshold the bound `L` on relevant `v_i` must exceed (step 3 of
/// [`ssdf_exceeds_over`]): `φ̂ ≥ min(L, (1 - τ) L) - τ V > t`, with a little room for rounding,
/// `τ` the cloud's pruning tolerance ([`crate::geometry::bvh::Bvh::tolerance`]).
/// It grows with `t` (for a fixed `V`), so a bound proven against a larger `t` holds for a
/// smaller one.
#[inline]
pub(super) fn band_need(t: f64, vmax: f64, tolerance: f64) -> f64 {
    let tt = t + tolerance * vmax;
    (if tt >= 0.0 {
        tt / (1.0 - tolerance)
    } else {
        tt
    }) + 1e-12 * (tt.abs() + vmax)
}

/// The walk of [`ssdf_exceeds_over`] for an AOPC, starting from the nodes `front` of its
/// hierarchy instead of the root. Every node of `front` that it cannot settle (prove
/// irrelevant or bounded above `t` over the region) is left in `open`: a leaf with a point it
/// could not settle, or a node it did not reach within its budget. The answer is `true` when
/// nothing is left open.
///
/// The nodes settled for a region stay settled for any region of the same points: each proof
/// holds pointwise at every point of the region (a point irrelevant or a plane above `need`
/// at `x`), so a query node's children, whose points are among its points, need only walk its
/// `open` nodes, provided `need` is the same or smaller (`t` only decreases during a band walk,
/// and `vmax` is then one bound for the whole walk: `|x - p_i| ≤ vmax` for every query point
/// `x` and every point `p_i`). `vmax = None` takes `√d_j(c) + r + diameter`, valid in the
/// region only.
///
/// In a band walk over a sampled sphere ([`crate::geometry::radial`]), the closed-form bound
/// of its planes at the region's point nearest the sphere's centre is tried first: when it
/// clears `need`, every cluster is settled at once (a 100k-point sphere–box evaluation at sharp
/// ε: 12.1 M instructions without, 1.1 M with; 1k points: 3.0 M and 0.63 M). Over a
/// sampled box ([`crate::geometry::cuboid`]) its face-by-face bound is tried the same way
/// (box–box at sharp ε, 100k points: 9.8 M without, 0.94 M with; 1k points: 1.90 M and
/// 0.37 M). A sampled capsule ([`crate::geometry::spine`]) has the sphere's bound in the
/// distance to its segment.
///
/// In a band walk, a region at least four times as wide as the softmax's reach `√(M1 ε1)`
/// gives up at the first cluster it cannot settle that is smaller than [`GIVE_UP_RATIO`]
/// times its own radius: its children then walk on from that cluster. Over such a region the
/// witness's slack `2 r |p_j - p_i|` does not shrink as the clusters do, so the points of a
/// small unsettled cluster are rarely settled either; descending to them (the 16-leaf budget
/// alone) spent most of a 100k-point sphere–box evaluation on proofs that then failed.
#[allow(clippy::too_many_arguments)]
pub(super) fn aopc_exceeds(
    s: &Aopc,
    q: &QueryRegion,
    t: f64,
    (eps1, room): (f64, f64),
    hint: usize,
    vmax: Option<f64>,
    front: &[u32],
    open: &mut Vec<u32>,
) -> (bool, usize) {
    let bvh = s.bvh();
    if bvh.is_empty() || front.is_empty() {
        return (true, usize::MAX);
    }
    let (c, r) = (&q.centre, q.radius);
    let base = bvh.log_terms * eps1;
    // Without room the closed forms come first (they need no witness); with room their margin
    // is the region's, which the witness gives.
    if room == 0.0 && super::shapes::closed_forms_settle(s, q, t, vmax, base) {
        return (true, hint);
    }
    let approximate = vmax.is_some() && bvh.len() > 2048;
    let (mut j, mut dj) = if approximate {
        bvh.near(c, hint)
    } else {
        bvh.nearest_hint(c, hint)
    };
    let m1 = widened_margin(base, room, bvh.nodes[0].radius, dj, r);
    if room > 0.0 && super::shapes::closed_forms_settle(s, q, t, vmax, m1) {
        return (true, j);
    }
    let need = band_need(
        t,
        vmax.unwrap_or(dj.sqrt() + r + bvh.diameter),
        bvh.tolerance,
    );
    // The witness is relevant at the centre; if its plane comes below `need` in the region,
    // the answer would be `false` anyway (a quick exit, not part of the proof). A witness
    // found without backtracking ([`Bvh::near`]) can lie on the far side of a thin part (the
    // outer face of a wall 2 cm thick, 2 cm farther than the inner face, whose plane the query
    // lies behind): before giving up on it, the exact nearest point is taken and tried.
    let below = |j: usize| {
        let (pj, nj) = (bvh.points[j], bvh.normals[j]);
        !q.lin_exceeds(nj.dot(&(c - pj)), &nj, need)
    };
    if below(j) && approximate {
        (j, dj) = bvh.nearest_hint(c, j);
    }
    if below(j) {
        open.extend_from_slice(front);
        return (false, j);
    }
    // A nearer witness found above gives a smaller widening; the one computed with the
    // farther point is still sound (it bounds `d_min` from above), only wider.
    let m1 = m1.min(widened_margin(base, room, bvh.nodes[0].radius, dj, r));
    walk_clusters(s, q, (need, m1, vmax.is_some()), (j, dj), front, open)
}

/// The relevance margin (m²) over a region of radius `r` (m) whose centre is `dj` (m²) from a
/// point of the cloud, for a proof that must hold after every query point moves by up to
/// `room` (m) (docs/performance.md, "A proof that is kept"): `base` plus
/// `4δ (√(D + base) + δ)`, `D = (√dj + r)²` bounding the squared distance to the nearest point
/// anywhere in the region, and at most `4δR` (`R` the cloud's root radius, `|p_i - p_j| ≤ 2R`),
/// with a rounding allowance; `base` itself without room.
#[inline]
pub(super) fn widened_margin(base: f64, room: f64, root_radius: f64, dj: f64, r: f64) -> f64 {
    if room == 0.0 {
        return base;
    }
    let d = dj.sqrt() + r;
    let local = 4.0 * room * ((d * d + base).sqrt() + room);
    base + local.min(4.0 * room * root_radius) * (1.0 + 1e-9)
}

/// The cluster walk of [`aopc_exceeds`] from the nodes `front`, with the threshold `need`, the
/// relevance margin `m1` (m²) and the witness `j` at `dj` (m²) from the region's centre;
/// `give_up`: whether a wide region gives up at a small unsettled cluster ([`GIVE_UP_RATIO`]).
fn walk_clusters(
    s: &Aopc,
    q: &QueryRegion,
    (need, m1, give_up): (f64, f64, bool),
    (j, dj): (usize, f64),
    front: &[u32],
    open: &mut Vec<u32>,
) -> (bool, usize) {
    let bvh = s.bvh();
    let (c, r) = (&q.centre, q.radius);
    let pj = bvh.points[j];
    // The witness's flat patch, if any (step 1' of [`ssdf_exceeds_over`]).
    let patch = bvh.patch_of(j);
    let start = open.len();
    let mut budget = 16;
    let mut stack: Vec<u32> = Vec::with_capacity(64);
    stack.extend(front.iter().rev());
    while let Some(ni) = stack.pop() {
        let node = &bvh.nodes[ni as usize];
        let gap = node.min_sq_dist(c) - dj;
        // `gap - 2r max|p_j - p| > m1`, in squares.
        let e = gap - m1;
        if (e > 0.0 && r > 1e-100 && e * e > 4.0 * r * r * node.max_sq_dist(&pj) * (1.0 + 1e-10))
            || q.lin_exceeds(gap - 2.0 * r * node.radius, &((pj - node.centre) * 2.0), m1)
        {
            continue; // irrelevant cluster
        }
        // Interval bound of nᵀ(x - p) over the ball's box, the cluster's box and normals' box.
        let mut lb = 0.0;
        for k in 0..3 {
            let (ylo, yhi) = (c[k] - r - node.hi[k], c[k] + r - node.lo[k]);
            let (a, b) = (node.nlo[k], node.nhi[k]);
            lb += (a * ylo).min(a * yhi).min(b * ylo).min(b * yhi);
        }
        if lb > need || cone_bound(node, q) > need {
            continue;
        }
        if let Some(p) = patch {
            if cluster_covered(p, node, q, need, m1) {
                continue; // irrelevant wherever its planes could be below `need`
            }
        }
        if give_up && node.radius < GIVE_UP_RATIO * r && r * r > 16.0 * m1 {
            open.push(ni);
            open.extend(stack.iter().rev());
            return (false, j);
        }
        if budget == 0 {
            open.push(ni);
            continue;
        }
        if node.is_leaf() {
            budget -= 1;
            for k in node.start as usize..(node.start + node.count) as usize {
                let (pi, ni_) = (&bvh.points[k], &bvh.normals[k]);
                let gap = (c - pi).norm_squared() - dj;
                let a = (pj - pi) * 2.0;
                if q.lin_exceeds(gap, &a, m1) {
                    continue; // irrelevant point
                }
                let v0 = ni_.dot(&(c - pi));
                if q.lin_exceeds(v0, ni_, need) {
                    continue;
                }
                if ball_halfspace_min(v0, ni_, r, &a, a.norm(), m1 - gap) <= need
                    && !patch.is_some_and(|p| {
                        let depth = p.offset - p.normal.dot(pi) - 1e-12 * pi.norm();
                        covered_out(p, c, r, ni_, need - v0, (depth, depth), m1)
                    })
                {
                    // The answer is `false`: stop here, leaving this leaf and every node not
                    // yet examined open.
                    open.push(ni);
                    open.extend(stack.iter().rev());
                    return (false, j);
                }
            }
        } else {
            stack.push(node.left + 1);
            stack.push(node.left);
        }
    }
    (open.len() == start, j)
}

/// Step 1' of [`ssdf_exceeds_over`] for a cluster of the collider's points: whether they
/// are irrelevant wherever in the region's ball their planes could be at or below `need`,
/// by [`covered_out`] against the witness's flat patch `p`. With `b` the cluster's centre,
/// `a` its normal cone's axis, `σ` its support and `w = √(2 - 2 cos θ) ≥ |n_i - a|`:
/// `v_i(x) = n_iᵀ(x - b) - n_iᵀ(p_i - b) ≥ aᵀ(x - b) - w |x - b| - σ`, so a point of the
/// cluster can be at or below `need` only where `aᵀ(x - b) ≤ need + σ + w (|c - b| + r)`; the
/// depths `o - nᵀp_i` behind the patch's plane are bounded by the cluster's box.
pub(super) fn cluster_covered(
    p: &crate::geometry::patch::Patch,
    node: &crate::geometry::bvh::Node,
    q: &QueryRegion,
    need: f64,
    m1: f64,
) -> bool {
    if node.cos_cone < 0.0 {
        return false;
    }
    let n = &p.normal;
    let (mut lo, mut hi) = (0.0, 0.0);
    for k in 0..3 {
        let (x, y) = (n[k] * node.lo[k], n[k] * node.hi[k]);
        lo += x.min(y);
        hi += x.max(y);
    }
    let slack = 1e-12 * (node.lo.norm() + node.hi.norm() + p.offset.abs());
    let depth = (p.offset - hi - slack, p.offset - lo + slack);
    if depth.0 <= 0.0 {
        return false; // some of the cluster may lie on the patch's plane or in front of it
    }
    let w = (2.0 - 2.0 * node.cos_cone).max(0.0).sqrt() + 1e-12;
    let cb = q.centre - node.centre;
    let beta = need + node.support + w * (cb.norm() + q.radius) - node.axis.dot(&cb);
    covered_out(
        p,
        &q.centre,
        q.radius,
        &node.axis,
        beta + 1e-12 * (beta.abs() + cb.norm() + q.radius),
        depth,
        m1,
    )
}

/// The covering argument ([`crate::geometry::patch`]): points `i` that lie at depths
/// `s_i = o - nᵀp_i ∈ [s.0, s.1]`, `s.0 > 0`, behind the plane of the flat patch `p` are
/// irrelevant (`d_i - d_min > m1`) at every point `x = c + y` of `S = {|y| ≤ r, aᵀy ≤ beta}`,
/// proven, or `false`. `|a|` need not be 1.
///
/// Proof: with `u = nᵀx - o`, `d_min(x) ≤ (|u| + t)² + (w + ρ)²` where `w` bounds the
/// in-plane distance from `x`'s projection to the polygon: the quads tile the polygon, so
/// the polygon's point nearest to the projection lies in a quad whose centre is within `ρ` of
/// it in the plane and `t` across. `w = 0` if every `x` of `S` projects into the polygon (each
/// edge: the largest `mᵀx - c_e` over `S`, [`ball_halfspace_min`], is at most 0); otherwise,
/// with `w_e` those largest excesses, `w = √(k Σ w_e⁺²)` (`k` = [`Patch::outside`](
/// crate::geometry::patch::Patch::outside): the nearest point is on one edge, at distance at
/// most its excess, or a corner, at distance at most `√k` times the two edges' excesses
/// when the corner's interior angle is 90° or more). And `d_i(x) ≥ (nᵀ(x - p_i))² = (u +
/// s_i)²`, so `d_i - d_min ≥ s_i² + 2u s_i - (2|u| t + t² + (w + ρ)²)`. Over `u ∈ [u_lo,
/// u_hi]` (the range of `nᵀx - o` over `S`) and `s_i ∈ [s.0, s.1]` the first part is smallest at `u_lo` (as
/// `s_i > 0`) and at `s_i = -u_lo` clamped to the interval (it is convex in `s_i`).
///
/// Why: outside a box near an edge, where the bottom face is nearest, the side face's planes
/// are below the field; one witness `j` at the region's centre (a paraboloid `d_j`) cannot
/// prove those points out over a region a few spacings wide, but the bottom face's patch
/// bounds `d_min` at every `x` below it, and a side point a depth `s` behind the bottom's
/// plane is out by about `2 s u`, the depth times the distance.
pub(super) fn covered_out(
    p: &crate::geometry::patch::Patch,
    c: &Vector3<f64>,
    r: f64,
    a: &Vector3<f64>,
    beta: f64,
    s: (f64, f64),
    m1: f64,
) -> bool {
    if s.0 <= 0.0 {
        return false;
    }
    let alen = a.norm();
    let lowest = |g: &Vector3<f64>| ball_halfspace_min(0.0, g, r, a, alen, beta);
    let n = &p.normal;
    let un = lowest(n);
    if un == f64::INFINITY {
        return true; // S is empty
    }
    let u0 = n.dot(c) - p.offset;
    let (ulo, uhi) = (u0 + un, u0 - lowest(&-n));
    let umax = ulo.abs().max(uhi.abs());
    let (t, rho) = (p.thickness, p.rho);
    let si = (-ulo).clamp(s.0, s.1);
    let inside = si * si + 2.0 * ulo * si - (2.0 * umax * t + t * t);
    if inside - rho * rho <= m1 {
        return false; // not even where S projects into the polygon
    }
    let mut w2 = 0.0;
    for (m, cm) in &p.edges {
        let v = m.dot(c) - lowest(&-m) - cm;
        if v > 0.0 {
            if p.outside == f64::INFINITY {
                return false; // part of S projects outside a polygon with an acute corner
            }
            w2 += v * v;
        }
    }
    let w = (p.outside * w2).sqrt();
    let gap = inside - (w + rho) * (w + rho);
    gap - 1e-12 * (umax + s.1 + rho + w).powi(2) > m1
}

/// The cone bound of a cluster (step 2 of [`ssdf_exceeds_over`]): a lower bound of
/// `n_iᵀ(x - p_i)` over the cluster's points `i` and the region's points `x`; `-∞` when the
/// cone is wider than 90°.
#[inline]
pub(super) fn cone_bound(node: &crate::geometry::bvh::Node, q: &QueryRegion) -> f64 {
    if node.cos_cone < 0.0 {
        return f64::NEG_INFINITY;
    }
    let a = &node.axis;
    let w = q.centre - node.centre;
    let aw = a.dot(&w);
    let big_a = aw + q.min_lin(a);
    let big_p = (w - a * aw).norm() + q.radius;
    let f = if big_a >= 0.0 {
        big_a * node.cos_cone - big_p * node.sin_cone
    } else {
        (big_a - big_p * node.sin_cone).max(-(big_a * big_a + big_p * big_p).sqrt())
    };
    f - node.support - 1e-12 * (w.norm() + q.radius)
}

/// `min { v0 + nᵀy : |y| ≤ r, aᵀy ≤ β }` (closed form; `+∞` if the set is empty), with
/// `alen = |a|`, less a relative rounding allowance.
pub(super) fn ball_halfspace_min(
    v0: f64,
    n: &Vector3<f64>,
    r: f64,
    a: &Vector3<f64>,
    alen: f64,
    beta: f64,
) -> f64 {
    let slack = 1e-12 * (v0.abs() + r);
    // The ball's own minimiser y* = -r n, if it satisfies the constraint.
    if -r * a.dot(n) <= beta {
        return v0 - r - slack;
    }
    if alen == 0.0 {
        return f64::INFINITY; // 0 ≤ β fails: empty
    }
    let dist = beta / alen; // signed distance of the cutting plane from the centre, along a
    if dist < -r {
        return f64::INFINITY;
    }
    // Otherwise the minimum lies on the disk where the plane cuts the ball.
    let ah = a / alen;
    let y0 = ah * dist;
    let rho = (r * r - dist * dist).max(0.0).sqrt();
    let nperp = n - ah * n.dot(&ah);
    v0 + n.dot(&y0) - rho * nperp.norm() - slack
}
