//! A bounding-volume hierarchy over the points of an AOPC, for exact pruning (docs/method.md, numerical rules).
//!
//! Every node stores an axis-aligned box of its points, a bounding sphere (for query nodes, whose
//! boxes rotate with their body), a box of its normals (for bounding `nᵢᵀ(x - pᵢ)` over a
//! cluster), and a normal cone with the slab of its points along the cone's axis: a patch of
//! a smooth surface is thin along its mean normal (a flat face has zero thickness, a patch of
//! radius `r` on a sphere of radius `R` about `r²/2R`) and its normals stay in a narrow cone, so
//! bounds over "the points of the node" need not cover the whole ball (`Node::axis`). Points and normals are copied in leaf order, so a leaf is a contiguous slice;
//! `index` maps back to the AOPC's own order (faces, for the soft top-K). The cloud's flat
//! patches ([`super::patch`]) are attached by [`Bvh::set_surface`], per point in leaf order, with
//! the certificates of a sampled sphere ([`super::radial`]) and of a sampled box
//! ([`super::cuboid`]).
//!
//! All bounds here work on real parts (`f64`): they decide which terms of a softmax are summed,
//! never the value of a term, so dual numbers follow the same path as the `f64` they extend.

use crate::scalar::PRUNE_TOLERANCE;
use nalgebra::Vector3;

/// Points per leaf (at most).
pub const LEAF_SIZE: usize = 16;

/// Nodes whose normal cone is wider than this (cosine of the half-angle) are split by normals
/// (a cone of 30°: box edges and corners, cylinder rims, mesh feature edges).
pub const NORMAL_SPLIT_COS: f64 = 0.866;

/// Clouds with fewer points keep purely spatial splits: at the bundled scenes' ε their ball
/// queries (`geometry::ssdf::Relevant`) visit more nodes among face-split leaves than the cone
/// bound saves (t_push, 760 + 96 points: about 200 µs per step with normal splits against 173
/// µs without, measured together); at 1k points and above the normal splits pay (box–box at
/// sharp ε: 2.1 M instructions per pair evaluation against 3.2 M at 1k points, 23 M against
/// 49 M at 100k).
pub const NORMAL_SPLIT_MIN_POINTS: usize = 1000;

/// One node: a contiguous range of points in leaf order.
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    /// Lower corner of the points' box (m).
    pub lo: Vector3<f64>,
    /// Upper corner of the points' box (m).
    pub hi: Vector3<f64>,
    /// Centre of the bounding sphere (the box centre, m).
    pub centre: Vector3<f64>,
    /// Radius of the bounding sphere: the largest distance from `centre` to a point (m).
    pub radius: f64,
    /// Lower corner of the normals' box.
    pub nlo: Vector3<f64>,
    /// Upper corner of the normals' box.
    pub nhi: Vector3<f64>,
    /// Axis `a` of the normal cone: the normalised mean normal (`z` when the mean vanishes).
    /// Every point lies in the slab `slab_lo ≤ aᵀ(p - centre) ≤ slab_hi`, every normal in the
    /// cone `aᵀn ≥ cos_cone`, and `nᵀ(p - centre) ≤ support` for each point and its normal.
    /// All four are rounded outwards, so they hold exactly for the stored points.
    pub axis: Vector3<f64>,
    /// Lower end of the points' slab along `axis` (m).
    pub slab_lo: f64,
    /// Upper end of the points' slab along `axis` (m).
    pub slab_hi: f64,
    /// Cosine of the normal cone's half-angle (at most the smallest `aᵀn`; may be negative).
    pub cos_cone: f64,
    /// Sine of the normal cone's half-angle (at least `√(1 - cos_cone²)`; 1 when the half-angle
    /// exceeds 90°).
    pub sin_cone: f64,
    /// Largest `nᵢᵀ(pᵢ - centre)` over the node's points (m): 0 for a flat face, the sagitta for
    /// a convex patch.
    pub support: f64,
    /// First point (leaf order).
    pub start: u32,
    /// Number of points.
    pub count: u32,
    /// Index of the first child (the second is `left + 1`); 0 for a leaf.
    pub left: u32,
}

impl Node {
    /// Whether the node has no children.
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.left == 0
    }

    /// Smallest squared distance from `p` to the node's box (m²).
    #[inline]
    pub fn min_sq_dist(&self, p: &Vector3<f64>) -> f64 {
        let mut s = 0.0;
        for k in 0..3 {
            let d = (self.lo[k] - p[k]).max(p[k] - self.hi[k]).max(0.0);
            s += d * d;
        }
        s
    }

    /// Largest squared distance from `p` to the node's box (m²).
    #[inline]
    pub fn max_sq_dist(&self, p: &Vector3<f64>) -> f64 {
        let mut s = 0.0;
        for k in 0..3 {
            let d = (p[k] - self.lo[k]).abs().max((self.hi[k] - p[k]).abs());
            s += d * d;
        }
        s
    }
}

/// The hierarchy. Memory is O(I): about 2I/[`LEAF_SIZE`] nodes and one copy of the points.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Bvh {
    /// Nodes; `nodes[0]` is the root (absent for an empty cloud).
    pub nodes: Vec<Node>,
    /// Points in leaf order (m).
    pub points: Vec<Vector3<f64>>,
    /// Normals in leaf order.
    pub normals: Vec<Vector3<f64>>,
    /// Original index of each point in leaf order.
    pub index: Vec<u32>,
    /// Largest distance between two points (an upper bound: the root box's diagonal, m).
    pub diameter: f64,
    /// Largest distance of a point from the AOPC's origin (m; rounded up).
    pub max_norm: f64,
    /// `ln(I/τ)`, `I` the number of points and `τ` its pruning tolerance ([`Bvh::tolerance`]):
    /// the margin (in units of the temperature) beyond which a softmax term over these points
    /// is negligible.
    pub log_terms: f64,
    /// The pruning tolerance `τ` of softmax sums over these points and of the contacts they
    /// make ([`PRUNE_TOLERANCE`] unless the scene sets another, [`Bvh::set_tolerance`]).
    pub tolerance: f64,
    /// Flat patch of each point in leaf order (an index into `patches`, `u32::MAX` for none);
    /// empty until [`Bvh::set_surface`].
    pub patch: Vec<u32>,
    /// The cloud's flat patches ([`super::patch`]).
    pub patches: Vec<super::patch::Patch>,
    /// The cloud's radial certificate, if it is a sampled sphere ([`super::radial`]); `None`
    /// until [`Bvh::set_surface`].
    pub radial: Option<super::radial::Radial>,
    /// The cloud's cuboid certificate, if it is a sampled box ([`super::cuboid`]); `None`
    /// until [`Bvh::set_surface`].
    pub cuboid: Option<super::cuboid::Cuboid>,
    /// The cloud's spine certificate, if it is a sampled capsule ([`super::spine`]); `None`
    /// until [`Bvh::set_surface`].
    pub spine: Option<super::spine::Spine>,
    /// The certificate of a union of spheres and capsules ([`super::rounded`]), if the cloud
    /// is one.
    pub rounded: Option<std::sync::Arc<super::rounded::Rounded>>,
    /// The cloud's bounding polytope and cover radius ([`super::polytope`]); `None` until
    /// [`Bvh::set_surface`], and for a cloud without faces.
    pub polytope: Option<super::polytope::Polytope>,
}

impl Bvh {
    /// Attaches what the quad mesh whose face centres the points are proves about the surface:
    /// its flat patches and, for a sampled sphere or box, its radial or cuboid certificate
    /// (`points`, `normals`, `vertices`, `faces` in the cloud's own order, `reach`, as in
    /// [`super::Aopc`]), and its bounding polytope with the floor `floor`.
    pub fn set_surface(
        &mut self,
        points: &[Vector3<f64>],
        normals: &[Vector3<f64>],
        vertices: &[Vector3<f64>],
        faces: &[[u32; 4]],
        reach: &[Vector3<f64>],
        floor: super::polytope::FloorKind,
    ) {
        let (of, patches) = super::patch::find_patches(points, normals, vertices, faces);
        self.cuboid = super::cuboid::find_cuboid(points, normals, vertices, faces, &of, &patches);
        self.patch = self
            .index
            .iter()
            .map(|&i| of.get(i as usize).copied().unwrap_or(u32::MAX))
            .collect();
        self.patches = patches;
        self.radial = super::radial::find_radial(points, normals, vertices, faces);
        self.spine = super::spine::find_spine(points, normals, vertices, faces);
        self.polytope = super::polytope::Polytope::of(points, vertices, faces, reach, floor);
        if let Some(p) = &mut self.polytope {
            p.reorder(&self.index);
        }
    }

    /// The flat patch of the point `k` (leaf order), if any.
    #[inline]
    pub fn patch_of(&self, k: usize) -> Option<&super::patch::Patch> {
        self.patch
            .get(k)
            .and_then(|&p| self.patches.get(p as usize))
    }

    /// Builds the hierarchy by median splits along the longest box axis.
    pub fn build(points: &[Vector3<f64>], normals: &[Vector3<f64>]) -> Bvh {
        let n = points.len();
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut bvh = Bvh {
            tolerance: PRUNE_TOLERANCE,
            ..Bvh::default()
        };
        if n == 0 {
            return bvh;
        }
        bvh.nodes.reserve(2 * n / LEAF_SIZE + 1);
        bvh.nodes
            .push(Self::make_node(points, normals, &order, 0, n));
        let mut stack = vec![0usize];
        while let Some(ni) = stack.pop() {
            let (start, count) = (bvh.nodes[ni].start as usize, bvh.nodes[ni].count as usize);
            if count <= LEAF_SIZE {
                continue;
            }
            // A node whose normals spread wider than NORMAL_SPLIT_COS (a box edge or corner, a
            // mesh's feature edge), in a cloud of NORMAL_SPLIT_MIN_POINTS or more, is split by
            // its normals first, at the middle of the normals'
            // box along its widest axis: the children are then patches of single faces, whose
            // normal cones and slabs are narrow (the cone bound of `collision::ssdf_exceeds_over`).
            // Otherwise (or if that split leaves one side empty) the median along the longest
            // box axis.
            let node = &bvh.nodes[ni];
            let mut mid = 0;
            if node.cos_cone < NORMAL_SPLIT_COS && n >= NORMAL_SPLIT_MIN_POINTS {
                let next = node.nhi - node.nlo;
                let k = if next.x >= next.y && next.x >= next.z {
                    0
                } else if next.y >= next.z {
                    1
                } else {
                    2
                };
                let cut = 0.5 * (node.nlo[k] + node.nhi[k]);
                let slice = &mut order[start..start + count];
                // Stable partition (deterministic): normals below the cut first.
                let (below, above): (Vec<u32>, Vec<u32>) =
                    slice.iter().partition(|&&i| normals[i as usize][k] < cut);
                if !below.is_empty() && !above.is_empty() {
                    mid = below.len();
                    slice[..mid].copy_from_slice(&below);
                    slice[mid..].copy_from_slice(&above);
                }
            }
            if mid == 0 {
                let ext = bvh.nodes[ni].hi - bvh.nodes[ni].lo;
                let axis = if ext.x >= ext.y && ext.x >= ext.z {
                    0
                } else if ext.y >= ext.z {
                    1
                } else {
                    2
                };
                mid = count / 2;
                order[start..start + count].select_nth_unstable_by(mid, |&a, &b| {
                    points[a as usize][axis].total_cmp(&points[b as usize][axis])
                });
            }
            let left = bvh.nodes.len();
            bvh.nodes
                .push(Self::make_node(points, normals, &order, start, mid));
            bvh.nodes.push(Self::make_node(
                points,
                normals,
                &order,
                start + mid,
                count - mid,
            ));
            bvh.nodes[ni].left = left as u32;
            stack.push(left);
            stack.push(left + 1);
        }
        bvh.points = order.iter().map(|&i| points[i as usize]).collect();
        bvh.normals = order.iter().map(|&i| normals[i as usize]).collect();
        bvh.index = order;
        bvh.diameter = (bvh.nodes[0].hi - bvh.nodes[0].lo).norm();
        bvh.max_norm =
            bvh.points.iter().map(|p| p.norm()).fold(0.0, f64::max) * (1.0 + 4.0 * f64::EPSILON);
        bvh.set_tolerance(PRUNE_TOLERANCE);
        bvh
    }

    /// Sets the pruning tolerance `τ` (and `log_terms` with it): a skipped softmax term or
    /// point force weighs less than `τ` relative to the largest (docs/method.md, numerical
    /// rules).
    pub fn set_tolerance(&mut self, tolerance: f64) {
        self.tolerance = tolerance;
        self.log_terms = (self.points.len() as f64 / tolerance).ln();
    }

    fn make_node(
        points: &[Vector3<f64>],
        normals: &[Vector3<f64>],
        order: &[u32],
        start: usize,
        count: usize,
    ) -> Node {
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        let mut nlo = Vector3::repeat(f64::INFINITY);
        let mut nhi = Vector3::repeat(f64::NEG_INFINITY);
        for &i in &order[start..start + count] {
            lo = lo.inf(&points[i as usize]);
            hi = hi.sup(&points[i as usize]);
            nlo = nlo.inf(&normals[i as usize]);
            nhi = nhi.sup(&normals[i as usize]);
        }
        let centre = (lo + hi) * 0.5;
        let radius = order[start..start + count]
            .iter()
            .map(|&i| (points[i as usize] - centre).norm())
            .fold(0.0, f64::max);
        // Rounding of the norm: the sphere must contain every point.
        let radius = radius * (1.0 + 4.0 * f64::EPSILON);
        let mean: Vector3<f64> = order[start..start + count]
            .iter()
            .map(|&i| normals[i as usize])
            .sum();
        let axis = if mean.norm() > 1e-6 * count as f64 {
            mean.normalize()
        } else {
            Vector3::z()
        };
        let (mut slab_lo, mut slab_hi, mut cos_cone, mut support) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for &i in &order[start..start + count] {
            let (y, n) = (points[i as usize] - centre, normals[i as usize]);
            let h = axis.dot(&y);
            slab_lo = slab_lo.min(h);
            slab_hi = slab_hi.max(h);
            // The cone must hold for the unit vector n/|n| too (stored normals are unit to
            // rounding): the cosine is taken of the normalised normal.
            cos_cone = cos_cone.min(axis.dot(&n) / n.norm());
            support = support.max(n.dot(&y));
        }
        // Outward rounding: a few ulps of the quantities involved (each is a 3-term dot
        // product of numbers at most `radius` or 1 in size), then a relative 1e-12 margin.
        let pad = 1e-12 * radius;
        let (slab_lo, slab_hi, support) = (
            (slab_lo - pad).max(-radius),
            (slab_hi + pad).min(radius),
            support + pad,
        );
        let cos_cone = (cos_cone - 1e-12).max(-1.0);
        let sin_cone = if cos_cone <= 0.0 {
            1.0
        } else {
            ((1.0 - cos_cone * cos_cone).max(0.0).sqrt() + 1e-12).min(1.0)
        };
        Node {
            lo,
            hi,
            centre,
            radius,
            nlo,
            nhi,
            axis,
            slab_lo,
            slab_hi,
            cos_cone,
            sin_cone,
            support,
            start: start as u32,
            count: count as u32,
            left: 0,
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The nearest point to `p`: its leaf-order position and squared distance (m²). The
    /// distance is computed as `(p - q).norm_squared()`, exactly as a full scan would.
    pub fn nearest(&self, p: &Vector3<f64>) -> (usize, f64) {
        self.nearest_except(p, usize::MAX)
    }

    /// [`Bvh::nearest`] ignoring the point at leaf-order position `skip`.
    pub fn nearest_except(&self, p: &Vector3<f64>, skip: usize) -> (usize, f64) {
        self.nearest_search(p, skip, usize::MAX)
    }

    /// [`Bvh::nearest`] starting from the point at leaf-order position `hint` (a guess, e.g.
    /// the nearest point of a neighbouring query): the same answer, found sooner when the guess
    /// is good.
    pub fn nearest_hint(&self, p: &Vector3<f64>, hint: usize) -> (usize, f64) {
        self.nearest_search(p, usize::MAX, hint)
    }

    /// A point near `p`, not always the nearest: the better of `hint` (a leaf-order index, or
    /// `usize::MAX`) and the nearest point of the leaf reached by descending into the child
    /// whose box is nearer (depth steps, no backtracking). Its leaf-order position and squared
    /// distance (m²).
    pub fn near(&self, p: &Vector3<f64>, hint: usize) -> (usize, f64) {
        let mut best = (usize::MAX, f64::INFINITY);
        if self.nodes.is_empty() {
            return best;
        }
        if hint < self.len() {
            best = (hint, (p - self.points[hint]).norm_squared());
        }
        let mut node = &self.nodes[0];
        while !node.is_leaf() {
            let (a, b) = (
                &self.nodes[node.left as usize],
                &self.nodes[node.left as usize + 1],
            );
            node = if a.min_sq_dist(p) <= b.min_sq_dist(p) {
                a
            } else {
                b
            };
        }
        for k in node.start as usize..(node.start + node.count) as usize {
            let d = (p - self.points[k]).norm_squared();
            if d < best.1 {
                best = (k, d);
            }
        }
        best
    }

    fn nearest_search(&self, p: &Vector3<f64>, skip: usize, hint: usize) -> (usize, f64) {
        let mut best = (usize::MAX, f64::INFINITY);
        if self.nodes.is_empty() {
            return best;
        }
        if hint < self.len() && hint != skip {
            best = (hint, (p - self.points[hint]).norm_squared());
        }
        self.nearest_from(p, skip, best, 0)
    }

    fn nearest_from(
        &self,
        p: &Vector3<f64>,
        skip: usize,
        mut best: (usize, f64),
        root: u32,
    ) -> (usize, f64) {
        let mut stack: [u32; 64] = [root; 64];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if node.min_sq_dist(p) >= best.1 {
                continue;
            }
            if node.is_leaf() {
                for k in node.start as usize..(node.start + node.count) as usize {
                    let d = (p - self.points[k]).norm_squared();
                    if d < best.1 && k != skip {
                        best = (k, d);
                    }
                }
            } else {
                // Nearer child last, so it is popped first.
                let (a, b) = (node.left, node.left + 1);
                let (da, db) = (
                    self.nodes[a as usize].min_sq_dist(p),
                    self.nodes[b as usize].min_sq_dist(p),
                );
                let (first, second) = if da <= db { (a, b) } else { (b, a) };
                stack[top] = second;
                stack[top + 1] = first;
                top += 2;
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cloud(n: usize) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
        let mut s = 12345u64;
        let mut r = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
        };
        let pts: Vec<_> = (0..n).map(|_| Vector3::new(r(), r(), r())).collect();
        let nrm: Vec<_> = (0..n)
            .map(|_| Vector3::new(r(), r(), r()).normalize())
            .collect();
        (pts, nrm)
    }

    #[test]
    fn nodes_contain_their_points_and_nearest_matches_a_scan() {
        let (pts, nrm) = cloud(1000);
        let bvh = Bvh::build(&pts, &nrm);
        let mut seen = vec![false; pts.len()];
        for &i in &bvh.index {
            seen[i as usize] = true;
        }
        assert!(seen.iter().all(|&s| s), "the leaf order is a permutation");
        for node in &bvh.nodes {
            for k in node.start as usize..(node.start + node.count) as usize {
                let (p, n) = (bvh.points[k], bvh.normals[k]);
                assert!((0..3).all(|a| p[a] >= node.lo[a]
                    && p[a] <= node.hi[a]
                    && n[a] >= node.nlo[a]
                    && n[a] <= node.nhi[a]));
                assert!((p - node.centre).norm() <= node.radius);
                let h = node.axis.dot(&(p - node.centre));
                assert!(h >= node.slab_lo && h <= node.slab_hi, "slab");
                assert!(
                    node.axis.dot(&n) / n.norm() >= node.cos_cone
                        && node.cos_cone * node.cos_cone + node.sin_cone * node.sin_cone >= 1.0,
                    "cone"
                );
                assert!(n.dot(&(p - node.centre)) <= node.support, "support");
            }
            if !node.is_leaf() {
                let (l, r) = (
                    &bvh.nodes[node.left as usize],
                    &bvh.nodes[node.left as usize + 1],
                );
                assert_eq!((l.start, l.count + r.count), (node.start, node.count));
            }
        }
        let (queries, _) = cloud(50);
        for q in queries.iter().map(|q| q * 3.0) {
            let scan = pts
                .iter()
                .map(|p| (q - p).norm_squared())
                .fold(f64::INFINITY, f64::min);
            let (k, d) = bvh.nearest(&q);
            assert_eq!(d, scan);
            assert_eq!((q - bvh.points[k]).norm_squared(), d);
        }
    }
}
