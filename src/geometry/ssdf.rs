//! Soft signed distance function (paper eq. 8, SPEC §2):
//! `φ̂_S(p) = Σ_i σ_ε1(-d)_i · n_iᵀ(p - p_i)`, with `d_i = |p - p_i|²` (so ε1 is in m²).
//!
//! Evaluated as a streamed softmax: one pass finds the smallest `d_i` (its real part), a
//! second accumulates weights and weighted values. Memory is constant, never an array of
//! weights. Terms whose relative weight is provably below
//! [`PRUNE_TOLERANCE`](crate::scalar::PRUNE_TOLERANCE) are skipped.

use crate::scalar::{c, prune_margin, Scalar, SoftminSum};
use nalgebra::Vector3;

use super::Aopc;

/// Smallest squared distance (real part) from `p` to the points of `s`.
pub(crate) fn min_sq_distance<T: Scalar>(s: &Aopc, p: &Vector3<T>) -> f64 {
    let pr = Vector3::new(p.x.re(), p.y.re(), p.z.re());
    s.points.iter().map(|q| (pr - q).norm_squared()).fold(f64::INFINITY, f64::min)
}

/// The SSDF of point `p` (AOPC frame) with respect to `s`, with temperature `eps1` (m²).
///
/// For an empty AOPC the SSDF is `+∞` (nothing to collide with).
pub fn ssdf<T: Scalar>(s: &Aopc, p: &Vector3<T>, eps1: T) -> T {
    ssdf_weights_sum(s, p, eps1).0
}

/// The SSDF together with the softmax normaliser `Σ_i exp(-(d_i - d_min)/ε1) ≥ 1`.
pub fn ssdf_weights_sum<T: Scalar>(s: &Aopc, p: &Vector3<T>, eps1: T) -> (T, T) {
    if s.is_empty() {
        return (c(f64::INFINITY), T::one());
    }
    let dmin = min_sq_distance(s, p);
    let cutoff = dmin + prune_margin() * eps1.re();
    let mut sum = SoftminSum::new(c(dmin), eps1);
    let mut acc = T::zero();
    for (q, n) in s.points.iter().zip(&s.normals) {
        let r = p - q.map(c::<T>);
        let d = r.dot(&r);
        if d.re() > cutoff {
            continue; // relative weight < PRUNE_TOLERANCE
        }
        let w = sum.add(d);
        acc += w * (r.x * n.x + r.y * n.y + r.z * n.z);
    }
    (acc / sum.weight, sum.weight)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;
    use num_dual::Dual64;

    #[test]
    fn ssdf_of_a_single_plane_is_the_plane_distance() {
        let s = Aopc { points: vec![Vector3::new(0.0, 0.0, 1.0)], normals: vec![Vector3::z()], ..Default::default() };
        assert_eq!(ssdf(&s, &Vector3::new(3.0, -2.0, 0.25), 1e-3), -0.75);
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
