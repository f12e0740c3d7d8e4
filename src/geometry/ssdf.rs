//! Soft signed distance function (paper eq. 8, SPEC §2):
//! `φ̂_S(p) = Σ_i σ_ε1(-d)_i · n_iᵀ(p - p_i)`, with `d_i = |p - p_i|²` (so ε1 is in m²).
//!
//! Two evaluations of the same sum:
//! - [`ssdf_naive`]: every term, the reference;
//! - [`ssdf`]: the terms that can matter, found with the AOPC's bounding-volume hierarchy
//!   ([`visit_relevant`]), with a proven bound on what is skipped.
//!
//! Both stream the softmax (shift by the smallest `d_i`, then one pass accumulating weights and
//! weighted values): memory is constant, never an array of weights.
//!
//! # The pruning bound
//! Let `d_min = min_i d_i`, `I` the number of points, `τ` = [`PRUNE_TOLERANCE`] and
//! `ℓ = √d_min + √ε1`. A term is skipped only if
//! `(d_i - d_min)/ε1 > ln(I/τ) + ln(1 + √d_i/ℓ)`, so its weight relative to the largest
//! (which is 1, at `d_min`) is `w_i < (τ/I)/(1 + √d_i/ℓ)`: every skipped term is below the
//! relative weight τ/I ≤ τ (SPEC §3). Summed over at most `I` skipped terms:
//! `Σ_skip w_i < τ` and `Σ_skip w_i |v_i| < τ ℓ`, because `|v_i| = |n_iᵀ(p - p_i)| ≤ √d_i`.
//! With `A = Σ w_i v_i`, `Z = Σ w_i ≥ 1` and the skipped parts `A_s`, `Z_s`, the pruned value
//! differs from the full one by `|(Z_s φ̂ - A_s)/(Z - Z_s)| < τ (|φ̂| + ℓ)/(1 - τ)`: relative to
//! the natural length of the query (its distance to the cloud, or √ε1), the error is τ.
//! A whole node is skipped when the bound holds for its box: `d_i ≥ d_lo` (smallest squared
//! distance from `p` to the box) on the left, and inside the logarithm `d_i` is at most the
//! largest squared distance to the root box.
//! The same visit weighs point–plane forces (contact), whose size grows at most linearly with
//! `√d_i` too, so the same argument bounds them.

use crate::scalar::{c, Scalar, SoftminSum, PRUNE_TOLERANCE};
use nalgebra::Vector3;

use super::Aopc;

/// Calls `f(p_i, n_i)` for every point of `s` whose softmax weight at the query `pr` (real
/// part, AOPC frame) is not provably negligible (see the module documentation). `dmin` is the
/// smallest squared distance from `pr` to the points ([`Bvh::nearest`](super::bvh::Bvh::nearest)).
#[inline]
pub fn visit_relevant(s: &Aopc, pr: &Vector3<f64>, eps1: f64, dmin: f64, mut f: impl FnMut(&Vector3<f64>, &Vector3<f64>)) {
    let bvh = s.bvh();
    if bvh.is_empty() {
        return;
    }
    // One threshold for the whole query: `ln(1 + √d_i/ℓ)` is at most its value at the largest
    // distance to the root box, so skipping beyond `k ε1` satisfies the bound for every term
    // (a few more terms are kept than the per-term bound would keep; one logarithm per query).
    let ell = dmin.sqrt() + eps1.sqrt();
    let k = (bvh.len() as f64 / PRUNE_TOLERANCE).ln() + (bvh.nodes[0].max_sq_dist(pr).sqrt() / ell).ln_1p();
    let cutoff = dmin + k * eps1;
    let skip = |dlo: f64, _dhi: f64| dlo > cutoff;
    let mut stack: [u32; 64] = [0; 64];
    let mut top = 1usize;
    while top > 0 {
        top -= 1;
        let node = &bvh.nodes[stack[top] as usize];
        if skip(node.min_sq_dist(pr), node.max_sq_dist(pr)) {
            continue;
        }
        if node.is_leaf() {
            for k in node.start as usize..(node.start + node.count) as usize {
                let q = &bvh.points[k];
                let d = (pr - q).norm_squared();
                if !skip(d, d) {
                    f(q, &bvh.normals[k]);
                }
            }
        } else {
            stack[top] = node.left;
            stack[top + 1] = node.left + 1;
            top += 2;
        }
    }
}

/// The SSDF of point `p` (AOPC frame) with respect to `s`, with temperature `eps1` (m²),
/// pruned to a proven bound (module documentation).
///
/// For an empty AOPC the SSDF is `+∞` (nothing to collide with).
pub fn ssdf<T: Scalar>(s: &Aopc, p: &Vector3<T>, eps1: T) -> T {
    ssdf_weights_sum(s, p, eps1).0
}

/// The SSDF together with the softmax normaliser `Σ_i exp(-(d_i - d_min)/ε1) ≥ 1` (pruned).
pub fn ssdf_weights_sum<T: Scalar>(s: &Aopc, p: &Vector3<T>, eps1: T) -> (T, T) {
    if s.is_empty() {
        return (c(f64::INFINITY), T::one());
    }
    let pr = crate::scalar::re3(p);
    ssdf_at(s, p, eps1, s.bvh().nearest(&pr).1)
}

/// [`ssdf_weights_sum`] given `dmin`, the smallest squared distance from `p` (real part) to the
/// points of `s` (from [`Bvh::nearest`](super::bvh::Bvh::nearest)).
pub fn ssdf_at<T: Scalar>(s: &Aopc, p: &Vector3<T>, eps1: T, dmin: f64) -> (T, T) {
    let pr = crate::scalar::re3(p);
    let mut sum = SoftminSum::new(c(dmin), eps1);
    let mut acc = T::zero();
    visit_relevant(s, &pr, eps1.re(), dmin, |q, n| {
        let r = p - q.map(c::<T>);
        let w = sum.add(r.dot(&r));
        acc += w * (r.x * n.x + r.y * n.y + r.z * n.z);
    });
    (acc / sum.weight, sum.weight)
}

/// The SSDF summed over every point (no pruning): the reference for [`ssdf`].
pub fn ssdf_naive<T: Scalar>(s: &Aopc, p: &Vector3<T>, eps1: T) -> T {
    if s.is_empty() {
        return c(f64::INFINITY);
    }
    let pr = crate::scalar::re3(p);
    let dmin = s.points.iter().map(|q| (pr - q).norm_squared()).fold(f64::INFINITY, f64::min);
    let mut sum = SoftminSum::new(c(dmin), eps1);
    let mut acc = T::zero();
    for (q, n) in s.points.iter().zip(&s.normals) {
        let r = p - q.map(c::<T>);
        let w = sum.add(r.dot(&r));
        acc += w * (r.x * n.x + r.y * n.y + r.z * n.z);
    }
    acc / sum.weight
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;
    use num_dual::Dual64;

    #[test]
    fn ssdf_of_a_single_plane_is_the_plane_distance() {
        let s = Aopc::new(vec![Vector3::new(0.0, 0.0, 1.0)], vec![Vector3::z()], vec![1.0], vec![], vec![]);
        assert_eq!(ssdf(&s, &Vector3::new(3.0, -2.0, 0.25), 1e-3), -0.75);
    }

    #[test]
    fn pruned_matches_naive_and_prunes() {
        let s = Shape::Box { half: Vector3::new(0.1, 0.05, 0.03) }.sample(0.005);
        for (p, eps1) in [(Vector3::new(0.03, 0.052, -0.01), 1e-5), (Vector3::new(0.5, -0.2, 0.1), 1e-6), (Vector3::zeros(), 1e-4), (Vector3::new(0.1, 0.05, 0.03), 1e-9)] {
            let (a, b): (f64, f64) = (ssdf(&s, &p, eps1), ssdf_naive(&s, &p, eps1));
            assert!((a - b).abs() <= 1e-13 * (a.abs() + 0.1), "{p:?}: {a} vs {b}");
            let mut n = 0;
            visit_relevant(&s, &p, eps1, s.bvh().nearest(&p).1, |_, _| n += 1);
            // At the centre with a wide ε1 most points matter; elsewhere few do.
            if p != Vector3::zeros() {
                assert!(n < s.len() / 20, "{n} of {} visited", s.len());
            }
        }
    }

    #[test]
    fn gradient_matches_central_differences() {
        let s = Shape::Box { half: Vector3::new(0.1, 0.05, 0.03) }.sample(0.01);
        let p = Vector3::new(0.03, 0.052, -0.01);
        let eps1 = 1e-4;
        for k in 0..3 {
            let mut pd = p.map(Dual64::from);
            pd[k].eps = 1.0;
            let g = ssdf(&s, &pd, Dual64::from(eps1)).eps;
            let h = 1e-7;
            let (mut a, mut b) = (p, p);
            a[k] += h;
            b[k] -= h;
            let fd = (ssdf(&s, &a, eps1) - ssdf(&s, &b, eps1)) / (2.0 * h);
            assert!((g - fd).abs() < 1e-6 * (1.0 + fd.abs()), "axis {k}: {g} vs {fd}");
        }
    }
}
