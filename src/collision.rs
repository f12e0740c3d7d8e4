//! Soft collision detection (paper, Methods A.3; docs/method.md): the separation field of two
//! colliders, the separation distribution over it and the smooth separation distance.
//!
//! Two evaluations, as for the SSDF:
//! - [`separation_field`] + [`SeparationDistribution::new`]: every point of both bodies (the
//!   reference; memory O(I1 + I2), one scalar per point);
//! - [`separation_band`]: only the points whose weight in the separation distribution can
//!   matter, found by walking each body's bounding-volume hierarchy and proving, node by node,
//!   that the other body's SSDF is large over a whole node ([`ssdf_exceeds`]).
//!
//! # The band bound
//! Let `Φ_best` be the smallest field value evaluated so far (so `Φ_min ≤ Φ_best`),
//! `N = I1 + I2` and `M2 = ln(N/τ)` with `τ` = [`PRUNE_TOLERANCE`]. A node of query points is
//! skipped only once it is proven that `Φ_f > Φ_best + M2 ε2` for each of its points, so the
//! weight of each skipped point relative to the largest is below `e^{-M2} = τ/N` (docs/method.md, numerical rules), and
//! all of them together below τ. Each skipped point also has `Φ_f - Φ_min = s ε2` with
//! `s > M2`, so its share of `D = WᵀΦ` is `W_f |Φ_f - D| ≤ e^{-s} (s ε2 + |D - Φ_min|)`, and all
//! of them change `D` by less than `τ (M2 ε2 + 2|D - Φ_min|)`. Because every skipped point lies
//! above `Φ_best + M2 ε2`, the smallest evaluated value is the true `Φ_min`, so the softmax
//! shift is the same as the reference's.

use crate::geometry::ssdf::{ssdf_over, GradientSink, NoSink, Relevant};
use crate::geometry::{ssdf, ssdf_naive, Aopc};
use crate::scalar::{c, lift3, re, Scalar, PRUNE_TOLERANCE};
use nalgebra::{Matrix3, Vector3};

/// What a body collides with: its AOPC, or (for planes) an exact half-space.
#[derive(Clone, Debug, PartialEq)]
pub enum Collider {
    /// A closed surface sampled as an oriented point cloud (body frame).
    Aopc(Aopc),
    /// The half-space below the plane through `point` with outward `normal` (body frame). Its
    /// SSDF is exact: `nᵀ(p - point)`; it contributes no points to the separation field.
    HalfSpace {
        /// A point on the plane (m).
        point: Vector3<f64>,
        /// Outward unit normal.
        normal: Vector3<f64>,
    },
}

impl Collider {
    /// Number of points the collider contributes to a separation field.
    pub fn len(&self) -> usize {
        match self {
            Collider::Aopc(s) => s.len(),
            Collider::HalfSpace { .. } => 0,
        }
    }

    /// Whether it contributes no points (a half-space, or an empty AOPC).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Signed distance (soft for an AOPC, exact for a half-space) of a point in the collider's
    /// frame (pruned SSDF, exact to the bound of [`mod@crate::geometry::ssdf`]).
    pub fn signed_distance<T: Scalar>(&self, p: &Vector3<T>, eps1: T) -> T {
        match self {
            Collider::Aopc(s) => ssdf(s, p, eps1),
            Collider::HalfSpace { point, normal } => {
                (p - point.map(c::<T>)).dot(&normal.map(c::<T>))
            }
        }
    }

    /// [`Collider::signed_distance`] summed over every point (the reference).
    pub fn signed_distance_naive<T: Scalar>(&self, p: &Vector3<T>, eps1: T) -> T {
        match self {
            Collider::Aopc(s) => ssdf_naive(s, p, eps1),
            Collider::HalfSpace { .. } => self.signed_distance(p, eps1),
        }
    }
}

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
    #[inline]
    pub fn min_lin(&self, n: &Vector3<f64>) -> f64 {
        let r = self.radius;
        let alpha = n.dot(&self.m);
        let beta = (n - self.m * alpha).norm();
        let len = (alpha * alpha + beta * beta).sqrt();
        let (lo, hi) = (self.lo.max(-r), self.hi.min(r).max(self.lo.max(-r)));
        let s = if len > 0.0 {
            (-alpha * r / len).clamp(lo, hi)
        } else {
            lo
        };
        // The slack covers the rounding of these few operations (and of |m| = 1 to rounding).
        alpha * s - beta * (r * r - s * s).max(0.0).sqrt() - 1e-12 * (len * r)
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
            aopc_exceeds(s, q, t, eps1, hint, None, &[0], &mut open)
        }
    }
}

/// See [`aopc_exceeds`]: a band walk's region gives up at an unsettled cluster smaller than
/// this times its radius (measured: callgrind, one sphere–box evaluation at sharp ε, 100k
/// points per body, 23.0 M instructions without, 16.8 M at 0.15, 15.7 M at 0.3, 15.2 M at
/// 0.4; box–box 10.5 M without, 9.8 M at 0.15, 10.0 M at 0.3, and before the covering bound
/// reached past the edges 10.7 M at 0.3 against 11.2 M at 0.4; no change at 1k points or at
/// the scenes' ε).
const GIVE_UP_RATIO: f64 = 0.3;

/// The threshold the bound `L` on relevant `v_i` must exceed (step 3 of
/// [`ssdf_exceeds_over`]): `φ̂ ≥ min(L, (1 - τ) L) - τ V > t`, with a little room for rounding.
/// It grows with `t` (for a fixed `V`), so a bound proven against a larger `t` holds for a
/// smaller one.
#[inline]
fn band_need(t: f64, vmax: f64) -> f64 {
    let tt = t + PRUNE_TOLERANCE * vmax;
    (if tt >= 0.0 {
        tt / (1.0 - PRUNE_TOLERANCE)
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
/// 0.37 M).
///
/// In a band walk, a region at least four times as wide as the softmax's reach `√(M1 ε1)`
/// gives up at the first cluster it cannot settle that is smaller than [`GIVE_UP_RATIO`]
/// times its own radius: its children then walk on from that cluster. Over such a region the
/// witness's slack `2 r |p_j - p_i|` does not shrink as the clusters do, so the points of a
/// small unsettled cluster are rarely settled either; descending to them (the 16-leaf budget
/// alone) spent most of a 100k-point sphere–box evaluation on proofs that then failed.
#[allow(clippy::too_many_arguments)]
fn aopc_exceeds(
    s: &Aopc,
    q: &QueryRegion,
    t: f64,
    eps1: f64,
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
    let m1 = bvh.log_terms * eps1;
    // A sampled sphere bounds its planes in closed form (`geometry::radial`): if that bound
    // clears the threshold at the region's point nearest the centre, every cluster is settled.
    if let (Some(v), Some(rad)) = (vmax, &bvh.radial) {
        let oc = c - rad.centre;
        let l = oc.norm();
        let s_lo = if l > 0.0 {
            l + q.min_lin(&(oc / l))
        } else {
            0.0
        };
        if rad.plane_bound(s_lo, m1) > band_need(t, v) {
            return (true, hint);
        }
    }
    // So does a sampled box, face by face (`geometry::cuboid`), over the box of the region's
    // coordinates along the box's axes.
    if let (Some(v), Some(cub)) = (vmax, &bvh.cuboid) {
        let u = &cub.axes;
        let mid = u * c;
        let lo = Vector3::from_fn(|k, _| mid[k] + q.min_lin(&u.row(k).transpose()));
        let hi = Vector3::from_fn(|k, _| mid[k] - q.min_lin(&-u.row(k).transpose()));
        if cub.settles(&lo, &hi, c.norm() + r, band_need(t, v), m1) {
            return (true, hint);
        }
    }
    let (j, dj) = if vmax.is_some() && bvh.len() > 2048 {
        bvh.near(c, hint)
    } else {
        bvh.nearest_hint(c, hint)
    };
    let (pj, nj) = (bvh.points[j], bvh.normals[j]);
    let need = band_need(t, vmax.unwrap_or(dj.sqrt() + r + bvh.diameter));
    // The witness is relevant at the centre; if its plane comes below `need` in the region,
    // the answer would be `false` anyway (a quick exit, not part of the proof).
    if nj.dot(&(c - pj)) + q.min_lin(&nj) <= need {
        open.extend_from_slice(front);
        return (false, j);
    }
    // The witness's flat patch, if any (step 1' of [`ssdf_exceeds_over`]).
    let patch = bvh.patch_of(j);
    let start = open.len();
    let mut budget = 16;
    let mut stack: Vec<u32> = Vec::with_capacity(64);
    stack.extend(front.iter().rev());
    while let Some(ni) = stack.pop() {
        let node = &bvh.nodes[ni as usize];
        let gap = node.min_sq_dist(c) - dj;
        if gap - 2.0 * r * node.max_sq_dist(&pj).sqrt() > m1
            || gap + 2.0 * (q.min_lin(&(pj - node.centre)) - r * node.radius) > m1
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
        if vmax.is_some() && node.radius < GIVE_UP_RATIO * r && r * r > 16.0 * m1 {
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
                if gap + q.min_lin(&a) > m1 {
                    continue; // irrelevant point
                }
                let v0 = ni_.dot(&(c - pi));
                if v0 + q.min_lin(ni_) > need {
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
fn cluster_covered(
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
fn covered_out(
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
fn cone_bound(node: &crate::geometry::bvh::Node, q: &QueryRegion) -> f64 {
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
fn ball_halfspace_min(
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

/// Pose and velocity of a body, world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame<T: Scalar> {
    /// Orientation: world coordinates of the body axes (columns).
    pub rotation: Matrix3<T>,
    /// Position of the body origin (m).
    pub origin: Vector3<T>,
    /// Velocity of the body origin (m/s).
    pub linvel: Vector3<T>,
    /// Angular velocity (rad/s).
    pub angvel: Vector3<T>,
}

/// Motion of a query body seen from a plane body, in the plane body's frame.
#[derive(Clone, Copy, Debug)]
pub struct Relative<T: Scalar> {
    /// Rotation from query-body to plane-body coordinates.
    pub rotation: Matrix3<T>,
    /// Query-body origin in plane-body coordinates.
    pub translation: Vector3<T>,
    /// Velocity of the query-body origin relative to the plane-body origin.
    pub linvel: Vector3<T>,
    /// Angular velocity of the query body.
    pub angvel: Vector3<T>,
    /// Angular velocity of the plane body.
    pub angvel_planes: Vector3<T>,
}

impl<T: Scalar> Relative<T> {
    /// Real parts.
    pub fn re(&self) -> Relative<f64> {
        Relative {
            rotation: self.rotation.map(|x| x.re()),
            translation: crate::scalar::re3(&self.translation),
            linvel: crate::scalar::re3(&self.linvel),
            angvel: crate::scalar::re3(&self.angvel),
            angvel_planes: crate::scalar::re3(&self.angvel_planes),
        }
    }
}

impl<T: Scalar> Frame<T> {
    /// A body at rest at the world origin (the world itself).
    pub fn identity() -> Self {
        Frame {
            rotation: Matrix3::identity(),
            origin: Vector3::zeros(),
            linvel: Vector3::zeros(),
            angvel: Vector3::zeros(),
        }
    }

    /// This body's motion in the frame of `planes`. Differences of world positions are taken
    /// once here, so bodies far from the world origin lose no precision in the pair math.
    pub fn relative_to(&self, planes: &Frame<T>) -> Relative<T> {
        let rt = planes.rotation.transpose();
        Relative {
            rotation: rt * self.rotation,
            translation: rt * (self.origin - planes.origin),
            linvel: rt * (self.linvel - planes.linvel),
            angvel: rt * self.angvel,
            angvel_planes: rt * planes.angvel,
        }
    }
}

/// The separation field `Φ` (paper eq. 14): SSDFs of the points of `a` w.r.t. `b` (`of_a`)
/// followed by those of the points of `b` w.r.t. `a` (`of_b`).
#[derive(Clone, Debug, PartialEq)]
pub struct SeparationField<T> {
    /// `φ̂_b(p_i)` for the points of `a`, in order (m).
    pub of_a: Vec<T>,
    /// `φ̂_a(p'_j)` for the points of `b`, in order (m).
    pub of_b: Vec<T>,
}

impl<T: Scalar> SeparationField<T> {
    /// All entries, `a`'s then `b`'s.
    pub fn iter(&self) -> impl Iterator<Item = &T> + Clone {
        self.of_a.iter().chain(&self.of_b)
    }
}

/// Points of `query` (with frame `fq`) in the frame of the other body `fp`, and their SSDFs
/// with respect to `planes`.
fn field_one_side<T: Scalar>(
    query: &Collider,
    fq: &Frame<T>,
    planes: &Collider,
    fp: &Frame<T>,
    eps1: T,
    naive: bool,
) -> Vec<T> {
    let Collider::Aopc(s) = query else {
        return Vec::new();
    };
    let rel = fq.relative_to(fp);
    s.points
        .iter()
        .map(|p| {
            let x = rel.rotation * p.map(c::<T>) + rel.translation;
            if naive {
                planes.signed_distance_naive(&x, eps1)
            } else {
                planes.signed_distance(&x, eps1)
            }
        })
        .collect()
}

/// Soft collision detection between two colliders: the separation field, every entry (each
/// SSDF pruned to its bound).
pub fn separation_field<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    eps1: T,
) -> SeparationField<T> {
    SeparationField {
        of_a: field_one_side(a, fa, b, fb, eps1, false),
        of_b: field_one_side(b, fb, a, fa, eps1, false),
    }
}

/// [`separation_field`] with every SSDF summed over every point (the reference).
pub fn separation_field_naive<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    eps1: T,
) -> SeparationField<T> {
    SeparationField {
        of_a: field_one_side(a, fa, b, fb, eps1, true),
        of_b: field_one_side(b, fb, a, fa, eps1, true),
    }
}

/// One evaluated entry of the separation field: a query point and its SSDF w.r.t. the other
/// body.
#[derive(Clone, Copy, Debug)]
pub struct BandEntry<T> {
    /// 0: a point of `a` against the planes of `b`; 1: a point of `b` against those of `a`.
    pub side: u8,
    /// The point's position in its AOPC's BVH leaf order (`bvh().index[k]` is its face).
    pub k: u32,
    /// `Φ_f` (m).
    pub phi: T,
    /// Smallest squared distance from the point to the other body's points (m², real part;
    /// the SSDF's softmax shift). Infinite against a half-space.
    pub dmin: f64,
    /// An upper bound of `Σ_i σ_i s⁺_ε3(-φ_i)` over the planes the SSDF summed (m, real part;
    /// [`SpringBound`](crate::geometry::ssdf::SpringBound)): times the stiffness, it bounds the
    /// springs of this point's force. Infinite when the band was built without ε3.
    pub springs: f64,
    /// Leaf-order index of the other body's point nearest to this one (`u32::MAX` against a
    /// half-space).
    pub nearest: u32,
}

/// The part of the separation field that can carry weight (module documentation): every
/// entry whose weight is not provably below τ/(I1 + I2) relative to the largest.
#[derive(Clone, Debug)]
pub struct SeparationBand<T> {
    /// Evaluated entries (a superset of the band: some may turn out negligible).
    pub entries: Vec<BandEntry<T>>,
    /// `Φ_min`: the smallest entry (real part), the same as the full field's.
    pub min: f64,
    /// Number of query points skipped without evaluation.
    pub skipped: usize,
    /// `M2 = ln((I1 + I2)/τ)`: entries with `(Φ_f - Φ_min)/ε2 > M2` weigh less than τ/(I1 + I2).
    pub margin: f64,
}

/// Soft collision detection with pruning: the entries of the separation field that matter
/// (module documentation). `eps1` in m², `eps2` in m.
pub fn separation_band<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    eps1: T,
    eps2: T,
) -> SeparationBand<T> {
    let rels = [fa.relative_to(fb), fb.relative_to(fa)];
    band_of(a, b, &rels, eps1, eps2, 0.0, &mut Relevant::default(), None)
}

/// [`separation_band`] given the motion of each body in the other's frame (`rels[0]`: `a` seen
/// from `b`, `rels[1]`: `b` seen from `a`), with scratch space for the SSDF queries. With
/// `eps3 > 0` (m), each entry bounds its springs ([`BandEntry::springs`]). With `grads`, the
/// gradient `∇Φ_f` of each entry with respect to its query point (the other body's frame,
/// real parts) is pushed, in the order of the entries.
#[allow(clippy::too_many_arguments)]
pub(crate) fn band_of<T: Scalar>(
    a: &Collider,
    b: &Collider,
    rels: &[Relative<T>; 2],
    eps1: T,
    eps2: T,
    eps3: f64,
    scratch: &mut Relevant,
    mut grads: Option<&mut Vec<Vector3<f64>>>,
) -> SeparationBand<T> {
    let margin = ((a.len() + b.len()).max(1) as f64 / PRUNE_TOLERANCE).ln();
    let mut band = SeparationBand {
        entries: Vec::new(),
        min: f64::INFINITY,
        skipped: 0,
        margin,
    };
    let (e1, e2) = (re(eps1), re(eps2));
    // Two passes. The seed pass evaluates one leaf per side, the one reached by descending
    // nearer-first to the other body's centre (where the deepest points usually are), so that
    // both sides' walks start from a small Φ_best: a walk of the first side no longer proves
    // its nodes against a Φ_best that only the second side would lower. The main pass walks
    // both hierarchies and leaves the seed leaves out (their entries are already in; a
    // skipped ancestor does not count them again). Which leaves are seeds depends on the
    // poses only, so the band is as deterministic as before.
    // `seeds[side]`: the seed leaf's node index, and whether its points were evaluated.
    let mut seeds = [(u32::MAX, false); 2];
    let (mut arena, mut front): (Vec<u32>, Vec<u32>) = (Vec::new(), Vec::new());
    for pass in 0..2 {
        for (side, query, planes, rel) in [(0u8, a, b, &rels[0]), (1u8, b, a, &rels[1])] {
            let Collider::Aopc(s) = query else { continue };
            if s.is_empty() || matches!(planes, Collider::Aopc(o) if o.is_empty()) {
                continue;
            }
            let rot = rel.rotation.map(re);
            let tr = crate::scalar::re3(&rel.translation);
            let bvh = s.bvh();
            // Children are visited nearer-first to the other body's centre, so that a small Φ is
            // found early and prunes the rest.
            let target = match planes {
                Collider::Aopc(o) => o.bvh().nodes[0].centre,
                Collider::HalfSpace { point, normal } => {
                    point - normal * 1e3 * bvh.diameter.max(1.0)
                }
            };
            // A bound on |x - p_i| for every query point of this side and every point of the
            // other body (the two root spheres), for `need` to be one threshold for the walk.
            let vmax = match planes {
                Collider::Aopc(o) => {
                    let (qr, or) = (&bvh.nodes[0], &o.bvh().nodes[0]);
                    ((rot * qr.centre + tr - or.centre).norm() + qr.radius + or.radius)
                        * (1.0 + 1e-12)
                }
                Collider::HalfSpace { .. } => f64::NAN,
            };
            // Each entry: node, the witness of its parent's bound (a start for the next search),
            // and the parent's open nodes of the other hierarchy (`arena[from..to]`; see
            // `aopc_exceeds`): a node walks only what its parent left open. The arena grows and
            // shrinks with the depth-first walk.
            arena.clear();
            arena.push(0);
            let mut stack = vec![(0u32, u32::MAX, 0u32, 1u32)];
            if pass == 0 {
                let mut ni = 0u32;
                while !bvh.nodes[ni as usize].is_leaf() {
                    let (l, r) = (bvh.nodes[ni as usize].left, bvh.nodes[ni as usize].left + 1);
                    let dl = (rot * bvh.nodes[l as usize].centre + tr - target).norm_squared();
                    let dr = (rot * bvh.nodes[r as usize].centre + tr - target).norm_squared();
                    ni = if dl <= dr { l } else { r };
                }
                seeds[side as usize] = (ni, false);
                stack[0].0 = ni;
            }
            let seed = seeds[side as usize];
            while let Some((ni, hint, from, to)) = stack.pop() {
                let node = &bvh.nodes[ni as usize];
                if pass == 1 && ni == seed.0 {
                    continue; // done in the seed pass
                }
                arena.truncate(to as usize);
                let centre = rot * node.centre + tr;
                let mut witness = u32::MAX;
                let (mut cfrom, mut cto) = (from, to);
                if band.min.is_finite() {
                    // The node's points lie in its ball cut by the slab along its normal cone's axis.
                    let region = QueryRegion {
                        centre,
                        radius: node.radius,
                        m: rot * node.axis,
                        lo: node.slab_lo,
                        hi: node.slab_hi,
                    };
                    let t = band.min + margin * e2;
                    let (exceeds, j) = match planes {
                        Collider::Aopc(o) => {
                            front.clear();
                            front.extend_from_slice(&arena[from as usize..to as usize]);
                            let r = aopc_exceeds(
                                o,
                                &region,
                                t,
                                e1,
                                hint as usize,
                                Some(vmax),
                                &front,
                                &mut arena,
                            );
                            (cfrom, cto) = (to, arena.len() as u32);
                            r
                        }
                        Collider::HalfSpace { .. } => {
                            ssdf_exceeds_over(planes, &region, t, e1, usize::MAX)
                        }
                    };
                    if exceeds {
                        let seed_node = &bvh.nodes[seed.0 as usize];
                        let holds_seed = pass == 1
                            && seed.1
                            && (node.start..node.start + node.count).contains(&seed_node.start);
                        band.skipped +=
                            (node.count - if holds_seed { seed_node.count } else { 0 }) as usize;
                        continue;
                    }
                    witness = j as u32;
                }
                if node.is_leaf() {
                    if pass == 0 {
                        seeds[side as usize].1 = true;
                    }
                    // One walk of the other body's hierarchy for the whole leaf when the leaf is
                    // small against the reach of the softmax (√(ln(I/τ) ε1)): its ball's
                    // candidates are then about the points each query needs anyway. A leaf wider
                    // than that (sharp ε1) would gather far more candidates than any one point
                    // keeps, so each point walks on its own, from its neighbour's nearest point.
                    // Both give the same relevant set ([`Relevant`]).
                    let share = match planes {
                        Collider::Aopc(o) => node.radius * node.radius <= o.bvh().log_terms * e1,
                        Collider::HalfSpace { .. } => false,
                    };
                    if let (true, Collider::Aopc(o)) = (share, planes) {
                        scratch.find_ball(
                            o,
                            &centre,
                            node.radius * (1.0 + 1e-12) + 1e-12 * centre.norm(),
                            e1,
                        );
                    }
                    for k in node.start..node.start + node.count {
                        let x =
                            rel.rotation * lift3::<T>(&bvh.points[k as usize]) + rel.translation;
                        let entry = match planes {
                            Collider::Aopc(o) => {
                                if share {
                                    scratch.find_within(o, &crate::scalar::re3(&x), e1);
                                } else {
                                    let hint = scratch.nearest;
                                    scratch.find(o, &crate::scalar::re3(&x), e1, hint);
                                }
                                let (phi, springs) = match grads.as_deref_mut() {
                                    Some(g) => {
                                        let mut sink = GradientSink::default();
                                        let (phi, w, springs) =
                                            ssdf_over(o, &x, eps1, eps3, scratch, &mut sink);
                                        g.push(sink.gradient(phi.re(), w.re(), e1));
                                        (phi, springs)
                                    }
                                    None => {
                                        let (phi, _, springs) =
                                            ssdf_over(o, &x, eps1, eps3, scratch, &mut NoSink);
                                        (phi, springs)
                                    }
                                };
                                BandEntry {
                                    side,
                                    k,
                                    phi,
                                    dmin: scratch.dmin,
                                    springs,
                                    nearest: scratch.nearest as u32,
                                }
                            }
                            Collider::HalfSpace { normal, .. } => {
                                let phi = planes.signed_distance(&x, eps1);
                                if let Some(g) = grads.as_deref_mut() {
                                    g.push(*normal);
                                }
                                let springs = if eps3 > 0.0 {
                                    crate::scalar::softplus(-phi.re(), eps3) * (1.0 + 1e-12)
                                } else {
                                    f64::INFINITY
                                };
                                BandEntry {
                                    side,
                                    k,
                                    phi,
                                    dmin: f64::INFINITY,
                                    springs,
                                    nearest: u32::MAX,
                                }
                            }
                        };
                        band.min = band.min.min(entry.phi.re());
                        band.entries.push(entry);
                    }
                } else {
                    let (l, r) = (node.left, node.left + 1);
                    let dl = (rot * bvh.nodes[l as usize].centre + tr - target).norm_squared();
                    let dr = (rot * bvh.nodes[r as usize].centre + tr - target).norm_squared();
                    if dl <= dr {
                        stack.extend([(r, witness, cfrom, cto), (l, witness, cfrom, cto)]);
                    } else {
                        stack.extend([(l, witness, cfrom, cto), (r, witness, cfrom, cto)]);
                    }
                }
            }
        }
    }
    band
}

/// The separation distribution `W = σ_ε2(-Φ)` (paper eq. 15) without storing it: its
/// normaliser, and the smooth separation distance `D = WᵀΦ`.
#[derive(Clone, Copy, Debug)]
pub struct SeparationDistribution<T: Scalar> {
    /// Smallest entry of the field (real part; the softmax shift).
    pub min: f64,
    /// Temperature ε2 (m).
    pub eps: T,
    /// `Σ exp(-(Φ_f - min)/ε2)`.
    pub normaliser: T,
    /// Smooth separation distance `D` (m).
    pub distance: T,
}

impl<T: Scalar> SeparationDistribution<T> {
    /// Builds the distribution of a field (two streamed passes over it).
    pub fn new(field: &SeparationField<T>, eps2: T) -> Self {
        Self::from_values(field.iter().copied(), eps2)
    }

    /// Builds the distribution of the entries of a [`SeparationBand`].
    pub fn from_band(band: &SeparationBand<T>, eps2: T) -> Self {
        Self::from_values(band.entries.iter().map(|e| e.phi), eps2)
    }

    /// Builds the distribution of field values (two streamed passes).
    pub fn from_values<I: Iterator<Item = T> + Clone>(values: I, eps2: T) -> Self {
        let min = values.clone().map(|p| p.re()).fold(f64::INFINITY, f64::min);
        if !min.is_finite() {
            // Empty field, or nothing to collide with: no contact.
            return SeparationDistribution {
                min,
                eps: eps2,
                normaliser: T::one(),
                distance: c(f64::INFINITY),
            };
        }
        let inv = eps2.recip();
        let (mut sum, mut acc) = (T::zero(), T::zero());
        let e2 = eps2.re();
        for phi in values {
            // Past 746 ε2 the weight underflows to exactly 0 (derivatives too): skip exp's slow
            // underflow path; the sums are bit-for-bit the same.
            if phi.re() - min > 746.0 * e2 {
                continue;
            }
            let w = (-(phi - min) * inv).exp();
            sum += w;
            acc += w * phi;
        }
        SeparationDistribution {
            min,
            eps: eps2,
            normaliser: sum,
            distance: acc / sum,
        }
    }

    /// `W_f` for entry `f` whose value is `phi`.
    #[inline]
    pub fn weight(&self, _f: usize, phi: T) -> T {
        (-(phi - self.min) / self.eps).exp() / self.normaliser
    }
}

/// Temperature of the soft top-K over vertex weights: `Γ_1 = softmax(ln z / t)`, so a vertex
/// carrying twice the weight of another is preferred by a factor `2^(1/t) = 1024`.
pub const TOPK_TEMPERATURE: f64 = 0.1;

/// Soft top-K contact points (paper eq. 16; docs/method.md): the separation distribution `W` moved
/// from faces to their vertices, `z_v = Σ_f [v ∈ f] W_f`, then `c_k = Σ_v Γ_kv y_v` with the
/// successive softmax `Γ_k = softmax(ℓ_k)`, `ℓ_1 = ln z / t` ([`TOPK_TEMPERATURE`]),
/// `ℓ_{k+1} = ℓ_k + ln(1 - Γ_k)`: closed form and smooth, no iterative solver. Points are in
/// the world frame (m). Vertices of faces whose weight is below the pruning bound carry
/// nothing (their `z` would be below τ). If fewer than `k` vertices carry weight, the last
/// point repeats. Empty when neither body has points.
pub fn contact_points<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    eps1: T,
    eps2: T,
    k: usize,
) -> Vec<Vector3<T>> {
    let band = separation_band(a, fa, b, fb, eps1, eps2);
    let dist = SeparationDistribution::from_band(&band, eps2);
    if !dist.min.is_finite() || k == 0 {
        return Vec::new();
    }
    // Vertex weights z and vertex positions relative to a's origin (world axes), so that
    // bodies far from the world origin lose no precision.
    let cutoff = dist.min + band.margin * re(eps2);
    let mut z: std::collections::HashMap<(u8, u32), T> = std::collections::HashMap::new();
    for e in band.entries.iter().filter(|e| e.phi.re() <= cutoff) {
        let Collider::Aopc(s) = (if e.side == 0 { a } else { b }) else {
            continue;
        };
        let face = s.faces[s.bvh().index[e.k as usize] as usize];
        let w = dist.weight(0, e.phi);
        for v in face {
            *z.entry((e.side, v)).or_insert(T::zero()) += w;
        }
    }
    let mut verts: Vec<((u8, u32), T)> = z.into_iter().collect();
    verts.sort_by_key(|(key, _)| *key); // a fixed order: sums do not depend on hashing
    let ys: Vec<Vector3<T>> = verts
        .iter()
        .map(|((side, v), _)| {
            let (s, f) = match (side, a, b) {
                (0, Collider::Aopc(s), _) => (s, fa),
                (_, _, Collider::Aopc(s)) => (s, fb),
                _ => unreachable!("weights come from AOPC faces"),
            };
            f.rotation * lift3::<T>(&s.vertices[*v as usize]) + (f.origin - fa.origin)
        })
        .collect();
    let inv_t = T::from(1.0 / TOPK_TEMPERATURE);
    let mut ell: Vec<T> = verts.iter().map(|(_, z)| z.ln() * inv_t).collect();
    let mut out: Vec<Vector3<T>> = Vec::with_capacity(k);
    for _ in 0..k {
        let (imax, lmax) = ell
            .iter()
            .enumerate()
            .filter(|(_, l)| l.re().is_finite())
            .fold((usize::MAX, f64::NEG_INFINITY), |m, (i, l)| {
                if l.re() > m.1 {
                    (i, l.re())
                } else {
                    m
                }
            });
        if imax == usize::MAX {
            let last = out.last().copied().unwrap_or_else(Vector3::zeros);
            out.push(last);
            continue;
        }
        let e: Vec<T> = ell
            .iter()
            .map(|l| {
                if l.re().is_finite() {
                    (*l - lmax).exp()
                } else {
                    T::zero()
                }
            })
            .collect();
        let total = e.iter().fold(T::zero(), |acc, x| acc + *x);
        let others = e
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != imax)
            .fold(T::zero(), |acc, (_, x)| acc + *x);
        let mut c = Vector3::zeros();
        for (ev, y) in e.iter().zip(&ys) {
            c += y * (*ev / total);
        }
        out.push(c);
        // ℓ_{k+1} = ℓ_k + ln(1 - Γ_k); for the largest entry 1 - Γ = (Σ others)/Σ, computed
        // without cancellation.
        for (i, l) in ell.iter_mut().enumerate() {
            if !l.re().is_finite() {
                continue;
            }
            let one_minus = if i == imax {
                others / total
            } else {
                T::one() - e[i] / total
            };
            *l = if one_minus.re() > 0.0 {
                *l + one_minus.ln()
            } else {
                T::from(f64::NEG_INFINITY)
            };
        }
    }
    out.into_iter().map(|c| c + fa.origin).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;

    /// Uniform numbers in [-1, 1) (a fixed LCG: the test is the same every run).
    fn lcg(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*state >> 11) as f64) / ((1u64 << 52) as f64) - 1.0
    }

    fn vec3(s: &mut u64) -> Vector3<f64> {
        Vector3::new(lcg(s), lcg(s), lcg(s))
    }

    /// A point of the region: a random offset in the ball, projected into the slab along `m`.
    fn sample_region(q: &QueryRegion, s: &mut u64) -> Vector3<f64> {
        loop {
            let y = vec3(s) * q.radius;
            let h = q.m.dot(&y);
            if y.norm() <= q.radius && h >= q.lo && h <= q.hi {
                return q.centre + y;
            }
            // Move it into the slab along m, keeping it in the ball when possible.
            let hc = h.clamp(q.lo, q.hi);
            let y2 = y + q.m * (hc - h);
            if y2.norm() <= q.radius {
                return q.centre + y2;
            }
        }
    }

    #[test]
    fn min_lin_is_the_minimum_over_the_ball_cut_by_the_slab() {
        let mut s = 7u64;
        for _ in 0..2000 {
            let r = 0.01 + lcg(&mut s).abs();
            let m = vec3(&mut s).normalize();
            let (a, b) = (lcg(&mut s) * r, lcg(&mut s) * r);
            let q = QueryRegion {
                centre: vec3(&mut s),
                radius: r,
                m,
                lo: a.min(b),
                hi: a.max(b),
            };
            let n = vec3(&mut s) * 2.0;
            let lower = q.min_lin(&n);
            // A lower bound at sampled points of the region...
            for _ in 0..50 {
                let x = sample_region(&q, &mut s);
                assert!(
                    n.dot(&(x - q.centre)) >= lower,
                    "{} < {lower}",
                    n.dot(&(x - q.centre))
                );
            }
            // ...attained (to rounding) at the minimiser of the proof: s* clamped, then the
            // perpendicular part of the ball's extent against n.
            let alpha = n.dot(&m);
            let perp = n - m * alpha;
            let sc = (-alpha * r / n.norm()).clamp(q.lo, q.hi);
            let u = if perp.norm() > 0.0 {
                -perp.normalize() * (r * r - sc * sc).max(0.0).sqrt()
            } else {
                Vector3::zeros()
            };
            let y = m * sc + u;
            assert!(y.norm() <= r * (1.0 + 1e-12) && (m.dot(&y) - sc).abs() <= 1e-12 * r);
            assert!(
                (n.dot(&y) - lower).abs() <= 1e-9 * n.norm() * r,
                "{} vs {lower}",
                n.dot(&y)
            );
        }
        // The whole ball: -r|n|.
        let q = QueryRegion::ball(Vector3::zeros(), 0.5);
        let n = Vector3::new(0.3, -0.4, 1.2);
        assert!((q.min_lin(&n) + 0.5 * n.norm()).abs() < 1e-12);
    }

    #[test]
    fn cone_bound_is_a_lower_bound_of_every_plane_of_a_cluster_over_the_region() {
        // Curved (sphere, cylinder) and flat (box) clusters at several levels, regions near and
        // far, thin (a slab) and full balls.
        let mut s = 11u64;
        for shape in [
            Shape::Sphere { radius: 0.05 },
            Shape::Box {
                half: Vector3::new(0.1, 0.06, 0.03),
            },
            Shape::Cylinder {
                radius: 0.04,
                half_length: 0.05,
            },
        ] {
            let cloud = shape.sample(0.004);
            let bvh = cloud.bvh();
            let (mut checked, mut behind) = (0, 0);
            for node in bvh.nodes.iter().filter(|n| n.count <= 64) {
                let r = 0.002 + 0.02 * lcg(&mut s).abs();
                let m = vec3(&mut s).normalize();
                let h = 0.3 * r * lcg(&mut s).abs();
                let q = QueryRegion {
                    centre: node.centre + vec3(&mut s) * 0.1,
                    radius: r,
                    m,
                    lo: -h,
                    hi: h,
                };
                let bound = cone_bound(node, &q);
                if !bound.is_finite() {
                    continue;
                }
                checked += 1;
                // The bound for a region behind the cluster's planes (`A < 0`), sharper than
                // Cauchy–Schwarz for a narrow cone.
                let w = q.centre - node.centre;
                let big_a = node.axis.dot(&w) + q.min_lin(&node.axis);
                let big_p = (w - node.axis * node.axis.dot(&w)).norm() + q.radius;
                if big_a < 0.0 && bound > -(big_a * big_a + big_p * big_p).sqrt() - node.support {
                    behind += 1;
                }
                for _ in 0..20 {
                    let x = sample_region(&q, &mut s);
                    for k in node.start as usize..(node.start + node.count) as usize {
                        let v = bvh.normals[k].dot(&(x - bvh.points[k]));
                        assert!(v >= bound, "{v} < {bound}");
                    }
                }
            }
            assert!(checked > 20, "{checked} clusters with a cone under 90°");
            assert!(
                behind > 10,
                "{behind} regions behind a cluster's planes with a narrow cone"
            );
        }
    }

    /// The covering argument against brute force: near a box's bottom edges, below the
    /// bottom face, every point or cluster that `covered_out` / `cluster_covered` proves out
    /// is irrelevant (`d_i - d_min > m1`) at sampled points of the ball wherever its plane is
    /// at or below `need` (about 18,000 points and 2,600 clusters proven, 6 M checks). It
    /// fails if the polygon check is loosened (the side face's points past the edge are then
    /// "proven" out where they are nearest) or if the largest instead of the smallest height
    /// over the set is taken; the covering radius has its own test below.
    #[test]
    fn the_covering_argument_proves_out_only_irrelevant_points() {
        let cloud = Shape::Box {
            half: Vector3::repeat(0.05),
        }
        .sample(0.002);
        let bvh = cloud.bvh();
        assert_eq!(bvh.patches.len(), 6);
        let m1 = bvh.log_terms * 1e-9;
        let dmin = |x: &Vector3<f64>| {
            bvh.points
                .iter()
                .map(|p| (x - p).norm_squared())
                .fold(f64::INFINITY, f64::min)
        };
        let mut s = 11u64;
        let (mut points_proven, mut clusters_proven, mut checked, mut outside) = (0, 0, 0, 0);
        for case in 0..300 {
            // A region below the bottom face (z = -0.05) by 1 to 20 mm, from 1 cm inside an
            // edge in y to 2 cm past it, 1 to 8 mm in radius (it may cross the face's plane);
            // every other one close to the edge and the face, where the side face's points
            // are nearest past the edge (there the polygon check is what refuses a proof).
            // Cases 3 and 4 reach past the face's edges, where the covering bound also charges
            // the distance to the polygon: near a corner (past both edges in part), and a
            // little past one edge, where the side face's first row is nearest and its planes
            // lie below `need` (proving it out there would be wrong).
            let (c, r) = match case % 5 {
                4 => (
                    Vector3::new(
                        0.03 * lcg(&mut s),
                        -0.052 + 0.0015 * lcg(&mut s),
                        -0.06 - 0.005 * lcg(&mut s),
                    ),
                    0.0015 + 0.0005 * lcg(&mut s),
                ),
                3 => (
                    Vector3::new(
                        -0.049 + 0.007 * lcg(&mut s),
                        -0.049 + 0.007 * lcg(&mut s),
                        -0.061 - 0.009 * lcg(&mut s),
                    ),
                    0.0045 + 0.0035 * lcg(&mut s),
                ),
                0 => (
                    Vector3::new(
                        0.03 * lcg(&mut s),
                        -0.055 + 0.015 * lcg(&mut s),
                        -0.0605 - 0.0095 * lcg(&mut s),
                    ),
                    0.0045 + 0.0035 * lcg(&mut s),
                ),
                1 => (
                    Vector3::new(
                        0.03 * lcg(&mut s),
                        -0.05 + 0.001 * lcg(&mut s),
                        -0.0512 - 0.0002 * lcg(&mut s),
                    ),
                    0.00095 + 0.00015 * lcg(&mut s),
                ),
                // Touching the face from below, at the edge: the side face's first row is
                // nearest there by less than the quads' reach `ρ`.
                _ => {
                    let r = 0.0005 + 0.0003 * lcg(&mut s);
                    (
                        Vector3::new(
                            0.03 * lcg(&mut s),
                            -0.0495 + 0.0005 * lcg(&mut s),
                            -0.05 - r * 1.0001,
                        ),
                        r,
                    )
                }
            };
            let q = QueryRegion::ball(c, r);
            let (j, _) = bvh.nearest(&c);
            let Some(patch) = bvh.patch_of(j) else {
                continue;
            };
            let need = if case % 5 == 0 || case % 5 == 3 {
                0.004 * lcg(&mut s)
            } else {
                0.002 + 0.002 * lcg(&mut s)
            };
            let samples: Vec<Vector3<f64>> = (0..150).map(|_| sample_region(&q, &mut s)).collect();
            let dmins: Vec<f64> = samples.iter().map(dmin).collect();
            let mut verify = |k: usize| {
                let (pk, nk) = (bvh.points[k], bvh.normals[k]);
                for (x, dm) in samples.iter().zip(&dmins) {
                    if nk.dot(&(x - pk)) <= need {
                        checked += 1;
                        assert!(
                            (x - pk).norm_squared() - dm > m1,
                            "point {k} relevant at {x:?} with its plane below need"
                        );
                    }
                }
            };
            for (k, p) in bvh.points.iter().enumerate() {
                if (p - c).norm() > 0.03 {
                    continue;
                }
                let v0 = bvh.normals[k].dot(&(c - p));
                let depth = patch.offset - patch.normal.dot(p) - 1e-12 * p.norm();
                if covered_out(patch, &c, r, &bvh.normals[k], need - v0, (depth, depth), m1) {
                    points_proven += 1;
                    outside += usize::from(c.x - r < -0.05 || c.y - r < -0.05);
                    verify(k);
                }
            }
            for node in &bvh.nodes {
                if node.radius < 0.012
                    && (node.centre - c).norm() < 0.03
                    && cluster_covered(patch, node, &q, need, m1)
                {
                    clusters_proven += 1;
                    (node.start as usize..(node.start + node.count) as usize).for_each(&mut verify);
                }
            }
        }
        assert!(points_proven > 200 && clusters_proven > 20 && checked > 10_000 && outside > 100, "the test proves too little: {points_proven} points ({outside} from regions reaching past an edge), {clusters_proven} clusters, {checked} checks");
    }

    /// The covering radius matters: below a corner of a quad of a box's bottom face, at a
    /// height `u`, a point at a depth `s` behind the face, with `s² + 2us` under the corner's
    /// squared in-plane distance to the nearest point, is relevant there (its squared distance
    /// within `M1 ε1` of the smallest), and `covered_out` must not prove it out (it would with
    /// `ρ = 0`).
    #[test]
    fn the_covering_bound_keeps_a_point_nearer_than_the_quads_reach() {
        let cloud = Shape::Box {
            half: Vector3::repeat(0.05),
        }
        .sample(0.002);
        let bvh = cloud.bvh();
        let m1 = bvh.log_terms * 1e-9;
        let bottom = bvh
            .patches
            .iter()
            .find(|p| p.normal.z < -0.5)
            .expect("the bottom face's patch");
        let mut tested = 0;
        for (f, face) in cloud.faces.iter().enumerate() {
            if cloud.normals[f].z > -0.5 || tested >= 40 {
                continue;
            }
            let v = cloud.vertices[face[0] as usize];
            if v.x.abs() > 0.045 || v.y.abs() > 0.045 {
                continue; // an inner corner, away from the face's edges
            }
            tested += 1;
            let reach2 = bvh
                .points
                .iter()
                .filter(|p| p.z < -0.0499)
                .map(|p| (p.xy() - v.xy()).norm_squared())
                .fold(f64::INFINITY, f64::min);
            let u = 1e-4;
            // s² + 2us = 0.8 reach²
            let s = -u + (u * u + 0.8 * reach2).sqrt();
            let x = v - Vector3::z() * u;
            let pi = v + Vector3::z() * s;
            let dmin = bvh
                .points
                .iter()
                .map(|p| (x - p).norm_squared())
                .fold(f64::INFINITY, f64::min);
            assert!(
                (x - pi).norm_squared() - dmin < m1,
                "the construction: the point is relevant at x"
            );
            assert!(
                !covered_out(bottom, &x, 1e-9, &Vector3::z(), 1.0, (s, s), m1),
                "proven out although nearest, below corner {v:?}"
            );
        }
        assert_eq!(tested, 40);
    }
}
