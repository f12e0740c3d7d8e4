//! The points of an AOPC that can carry weight in the SSDF's softmax at a query point: one
//! walk of the AOPC's bounding-volume hierarchy that skips every node the pruning bound of
//! [`mod@super::ssdf`]'s documentation proves negligible, for one query point or for a ball of
//! them shared by a band of queries.

use nalgebra::Vector3;

use super::Aopc;

/// An upper bound of `ln x` for `x ≥ 1` from the exponent bits alone (`x < 2^(e+1)`, so
/// `ln x < (e + 1) ln 2`): at most `ln 2` above the logarithm, and no call to `log`.
#[inline]
pub fn ln_upper(x: f64) -> f64 {
    let e = ((x.to_bits() >> 52) & 0x7ff) as i64 - 1023;
    (e + 1) as f64 * std::f64::consts::LN_2
}

/// The points of an AOPC that can carry weight in the SSDF's softmax at one query point (real
/// part, AOPC frame): every point not provably negligible by the bound of the module
/// documentation, found in one walk of the hierarchy, with the smallest squared distance.
///
/// It is scratch space: one `Relevant` serves query after query without allocating.
#[derive(Clone, Debug, Default)]
pub struct Relevant {
    /// `(leaf-order index, squared distance (m²))` of every relevant point, by increasing
    /// index: the same order whichever way the set was found (one point's walk, a shared ball,
    /// a kept list), so that every sum over it is the same to the last bit.
    pub items: Vec<(u32, f64)>,
    /// Smallest squared distance from the query to the points (m²); `+∞` for no points.
    pub dmin: f64,
    /// Leaf-order index of the nearest point (`usize::MAX` for no points).
    pub nearest: usize,
    /// Candidates of the last ball query (leaf-order indices).
    ball: Vec<u32>,
    /// Candidates of the last [`Relevant::find`] (scratch; the ball's are kept apart).
    walk: Vec<u32>,
    /// The ball's candidate points, coordinate by coordinate: contiguous, so that the squared
    /// distances of [`Relevant::find_within`] (every point of a leaf against the shared
    /// ball's candidates) are a plain loop rather than a gather through the indices.
    ball_xyz: [Vec<f64>; 3],
    /// Squared distances to the ball's candidates (scratch of `find_within`).
    dist: Vec<f64>,
}

impl Relevant {
    /// Finds the relevant points of `s` at `pr` (AOPC frame) for temperature `eps1` (m²).
    /// `hint`: a leaf-order index whose point is probably near (e.g. the nearest point of the
    /// previous query), or `usize::MAX`; it only makes the walk shorter.
    ///
    /// The walk keeps every point within `d_best + k_max ε1` of the best squared distance so
    /// far, with `k_max` the largest threshold the bound can ask for (`ℓ ≥ √ε1`), then keeps
    /// those within the exact query's threshold `d_min + k ε1`: one walk finds both `d_min`
    /// and the relevant set.
    pub fn find(&mut self, s: &Aopc, pr: &Vector3<f64>, eps1: f64, hint: usize) {
        let bvh = s.bvh();
        self.items.clear();
        let mut cands = std::mem::take(&mut self.walk);
        gather(bvh, pr, 0.0, eps1, hint, &mut cands);
        self.filter(s, pr, eps1, &cands);
        self.walk = cands;
    }

    /// Finds the points of `s` that can be relevant at some point of the ball of radius `r`
    /// (m) around `c` (AOPC frame): a superset of what [`Relevant::find`] gives at every point
    /// of the ball, to be narrowed per point with [`Relevant::find_within`]. Several nearby
    /// queries (the points of one BVH leaf) then share one walk of the hierarchy.
    pub fn find_ball(&mut self, s: &Aopc, c: &Vector3<f64>, r: f64, eps1: f64) {
        let bvh = s.bvh();
        let mut cands = std::mem::take(&mut self.ball);
        gather(bvh, c, r, eps1, usize::MAX, &mut cands);
        for (d, coord) in self.ball_xyz.iter_mut().enumerate() {
            coord.clear();
            coord.extend(cands.iter().map(|&k| bvh.points[k as usize][d]));
        }
        self.ball = cands;
    }

    /// [`Relevant::find`] for a point `pr` of the ball last given to [`Relevant::find_ball`]:
    /// the same relevant set and `d_min`, from the ball's candidates.
    pub fn find_within(&mut self, s: &Aopc, pr: &Vector3<f64>, eps1: f64) {
        let (ball, xyz) = (
            std::mem::take(&mut self.ball),
            std::mem::take(&mut self.ball_xyz),
        );
        let [xs, ys, zs] = &xyz;
        self.find_among_xyz(s, pr, eps1, &ball, [xs, ys, zs]);
        (self.ball, self.ball_xyz) = (ball, xyz);
    }

    /// [`Relevant::find_among`] with the candidates' coordinates given contiguously (`xyz[d][i]`
    /// the coordinate `d` of point `cands[i]`), so that their distances are a plain loop.
    pub fn find_among_xyz(
        &mut self,
        s: &Aopc,
        pr: &Vector3<f64>,
        eps1: f64,
        cands: &[u32],
        xyz: [&[f64]; 3],
    ) {
        let bvh = s.bvh();
        self.items.clear();
        if bvh.is_empty() {
            self.dmin = f64::INFINITY;
            self.nearest = usize::MAX;
            return;
        }
        (self.dmin, self.nearest) =
            narrow(bvh, pr, eps1, cands, xyz, &mut self.dist, &mut self.items);
    }

    /// [`Relevant::find`] from candidates known to hold the relevant set at `pr`, by
    /// increasing index: those of [`gather_ball`] for a ball around `pr`, kept from an earlier
    /// query ([`CandidateMemo`](crate::collision::CandidateMemo)).
    pub fn find_among(&mut self, s: &Aopc, pr: &Vector3<f64>, eps1: f64, cands: &[u32]) {
        self.filter(s, pr, eps1, cands);
    }

    /// The relevant set at `pr` among `cands` (which must contain it, by increasing index).
    fn filter(&mut self, s: &Aopc, pr: &Vector3<f64>, eps1: f64, cands: &[u32]) {
        self.items.clear();
        let bvh = s.bvh();
        if bvh.is_empty() {
            self.dmin = f64::INFINITY;
            self.nearest = usize::MAX;
            return;
        }
        self.items.extend(
            cands
                .iter()
                .map(|&k| (k, (pr - bvh.points[k as usize]).norm_squared())),
        );
        (self.dmin, self.nearest) = nearest_of(self.items.iter().copied());
        let cutoff = cutoff(bvh, pr, eps1, self.dmin);
        self.items.retain(|&(_, d)| d <= cutoff);
    }
}

/// The relevant set at `pr` among candidates `cands` given with their coordinates
/// contiguously (`xyz[d][i]`), pushed to `items` in the candidates' order; returns `d_min` and
/// the nearest index. `dist` is scratch.
fn narrow(
    bvh: &super::bvh::Bvh,
    pr: &Vector3<f64>,
    eps1: f64,
    cands: &[u32],
    xyz: [&[f64]; 3],
    dist: &mut Vec<f64>,
    items: &mut Vec<(u32, f64)>,
) -> (f64, usize) {
    // The same squared distances as `filter` (`(pr - p).norm_squared()`, x² + y² + z² in
    // that order), so both give the same set bit for bit.
    // Indexed over equal lengths so that the loop vectorizes.
    let n = cands.len();
    let (xs, ys, zs) = (&xyz[0][..n], &xyz[1][..n], &xyz[2][..n]);
    dist.resize(n, 0.0);
    let dist = &mut dist[..n];
    for i in 0..n {
        let (dx, dy, dz) = (pr.x - xs[i], pr.y - ys[i], pr.z - zs[i]);
        dist[i] = dx * dx + dy * dy + dz * dz;
    }
    let (dmin, nearest) = nearest_of(cands.iter().copied().zip(dist.iter().copied()));
    let cutoff = cutoff(bvh, pr, eps1, dmin);
    items.extend(
        cands
            .iter()
            .zip(dist.iter())
            .filter(|(_, &d)| d <= cutoff)
            .map(|(&k, &d)| (k, d)),
    );
    (dmin, nearest)
}

/// The smallest squared distance of `(index, squared distance)` pairs and its index (the
/// smallest of equals, whatever their order; `(+∞, usize::MAX)` for none).
fn nearest_of(pairs: impl Iterator<Item = (u32, f64)>) -> (f64, usize) {
    let (mut best, mut nearest) = (f64::INFINITY, usize::MAX);
    for (k, d) in pairs {
        if d < best || (d == best && (k as usize) < nearest) {
            best = d;
            nearest = k as usize;
        }
    }
    (best, nearest)
}

/// The relevance threshold on squared distances at `pr`, given the smallest one, `best`
/// (module documentation: `d_min + k ε1` with `ℓ ≥ √d_min + √ε1`).
fn cutoff(bvh: &super::bvh::Bvh, pr: &Vector3<f64>, eps1: f64, best: f64) -> f64 {
    let dmax = bvh.nodes[0].max_sq_dist(pr).sqrt();
    let ell = best.sqrt() + eps1.sqrt();
    best + (bvh.log_terms + ln_upper(1.0 + dmax / ell)) * eps1
}

/// The points of `s` that can be relevant (module documentation) at some point of the ball
/// `|x - c| ≤ r` (m, AOPC frame) for temperature `eps1` (m²), by increasing leaf-order index,
/// in `out`: for [`Relevant::find_among`] at any point of the ball. `hint` as for
/// [`Relevant::find`].
pub fn gather_ball(s: &Aopc, c: &Vector3<f64>, r: f64, eps1: f64, hint: usize, out: &mut Vec<u32>) {
    gather(s.bvh(), c, r, eps1, hint, out);
}

/// The points of `bvh` that can be relevant (module documentation) at some point `x` of the
/// ball `|x - c| ≤ r`, as leaf-order indices in `out`. With `j` the point nearest to `c` and
/// `K` the largest threshold over the ball (`K = ln(I/τ) + ln↑(1 + (√d_max(c) + r)/√ε1)`, as
/// `ℓ ≥ √ε1` and `√d_max(x) ≤ √d_max(c) + r`): `d_min(x) ≤ (√d_j(c) + r)²` and
/// `d_i(x) ≥ (|c - p_i| - r)²`, so a relevant `i` has
/// `|c - p_i| ≤ r + √((√d_j(c) + r)² + K ε1)`. The walk applies that test with the best `d_j`
/// so far (which only shrinks), then once more with the final one.
fn gather(
    bvh: &super::bvh::Bvh,
    c: &Vector3<f64>,
    r: f64,
    eps1: f64,
    hint: usize,
    out: &mut Vec<u32>,
) {
    out.clear();
    if bvh.is_empty() {
        return;
    }
    let dmax = bvh.nodes[0].max_sq_dist(c).sqrt() + r;
    let slack = (bvh.log_terms + ln_upper(1.0 + dmax / eps1.sqrt())) * eps1;
    let reach = |best: f64| {
        let x = r + ((best.sqrt() + r).powi(2) + slack).sqrt();
        x * x * (1.0 + 1e-12)
    };
    // A first bound on the nearest distance, from the hint or from the leaf a greedy descent
    // reaches, so that the walk below can go in leaf order (left child first) and still prune
    // early: its output is then by increasing index without a sort.
    let start = if hint < bvh.len() {
        hint
    } else {
        let mut ni = 0usize;
        while !bvh.nodes[ni].is_leaf() {
            let a = bvh.nodes[ni].left as usize;
            ni = if bvh.nodes[a].min_sq_dist(c) <= bvh.nodes[a + 1].min_sq_dist(c) {
                a
            } else {
                a + 1
            };
        }
        bvh.nodes[ni].start as usize
    };
    let mut best = (c - bvh.points[start]).norm_squared();
    let mut limit = reach(best);
    let mut stack: [u32; 64] = [0; 64];
    let mut top = 1usize;
    while top > 0 {
        top -= 1;
        let node = &bvh.nodes[stack[top] as usize];
        if node.min_sq_dist(c) > limit {
            continue;
        }
        if node.is_leaf() {
            for k in node.start..node.start + node.count {
                let d = (c - bvh.points[k as usize]).norm_squared();
                if d <= limit {
                    out.push(k);
                    if d < best {
                        best = d;
                        limit = reach(best);
                    }
                }
            }
        } else {
            // The right child below the left, so that the left (lower indices) is walked first.
            stack[top] = node.left + 1;
            stack[top + 1] = node.left;
            top += 2;
        }
    }
    // Every point within the final limit was kept: the nearest point always passes, so the
    // final `best` is the true one whatever the order of the walk.
    debug_assert!(out.is_sorted());
    out.retain(|&k| (c - bvh.points[k as usize]).norm_squared() <= limit);
}

/// Calls `f(p_i, n_i)` for every point of `s` whose softmax weight at the query `pr` (real
/// part, AOPC frame) is not provably negligible (see the module documentation). A convenience
/// over [`Relevant`] (which the hot paths use, to reuse its buffer).
pub fn visit_relevant(
    s: &Aopc,
    pr: &Vector3<f64>,
    eps1: f64,
    mut f: impl FnMut(&Vector3<f64>, &Vector3<f64>),
) {
    let mut rel = Relevant::default();
    rel.find(s, pr, eps1, usize::MAX);
    let bvh = s.bvh();
    for &(k, _) in &rel.items {
        f(&bvh.points[k as usize], &bvh.normals[k as usize]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;

    /// A shared ball query and its per-point narrowing, a ball's candidates kept for later
    /// queries in it, and each point's own walk from any hint give the same relevant set in
    /// the same order, `d_min` and nearest point, bit for bit (the band walk relies on it for
    /// results that do not depend on which path a query takes, nor on what was kept).
    #[test]
    fn the_shared_ball_gives_each_point_its_own_relevant_set() {
        let cloud = Shape::Box {
            half: Vector3::new(0.05, 0.03, 0.02),
        }
        .sample(0.004);
        let mut state = 5u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64) / ((1u64 << 52) as f64) - 1.0
        };
        for eps1 in [1e-5, 1e-7, 1e-9] {
            for _ in 0..40 {
                let c = Vector3::new(0.08 * next(), 0.06 * next(), 0.05 * next());
                let r = 0.01 * next().abs();
                let (mut shared, mut own) = (Relevant::default(), Relevant::default());
                let (mut kept, mut among, mut hinted) =
                    (Vec::new(), Relevant::default(), Relevant::default());
                shared.find_ball(&cloud, &c, r, eps1);
                gather_ball(&cloud, &c, r, eps1, usize::MAX, &mut kept);
                assert!(kept.windows(2).all(|w| w[0] < w[1]), "increasing indices");
                let xyz: Vec<Vec<f64>> = (0..3)
                    .map(|d| {
                        kept.iter()
                            .map(|&k| cloud.bvh().points[k as usize][d])
                            .collect()
                    })
                    .collect();
                let mut contiguous = Relevant::default();
                for j in 0..8 {
                    // Inside the ball, and every other query on its sphere (as far as a kept
                    // ball is trusted: `|x - c|² ≤ r²` as computed).
                    let d = Vector3::new(next(), next(), next());
                    let scale = if j % 2 == 0 {
                        1.0 / d.norm()
                    } else {
                        0.999 / d.norm().max(1.0)
                    };
                    let x = c + d * (r * scale);
                    if (x - c).norm_squared() > r * r {
                        continue;
                    }
                    shared.find_within(&cloud, &x, eps1);
                    own.find(&cloud, &x, eps1, usize::MAX);
                    among.find_among(&cloud, &x, eps1, &kept);
                    contiguous.find_among_xyz(&cloud, &x, eps1, &kept, [&xyz[0], &xyz[1], &xyz[2]]);
                    let hint = (next().abs() * cloud.points.len() as f64) as usize;
                    hinted.find(&cloud, &x, eps1, hint);
                    assert!(!own.items.is_empty());
                    assert!(own.items.windows(2).all(|w| w[0].0 < w[1].0));
                    let bits = |r: &Relevant| {
                        let items: Vec<_> =
                            r.items.iter().map(|&(k, d)| (k, d.to_bits())).collect();
                        (items, r.dmin.to_bits(), r.nearest)
                    };
                    assert_eq!(bits(&shared), bits(&own));
                    assert_eq!(bits(&among), bits(&own));
                    assert_eq!(bits(&contiguous), bits(&own));
                    assert_eq!(bits(&hinted), bits(&own));
                }
            }
        }
    }
}
