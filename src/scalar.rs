//! The scalar type of all the math: `f64` for values, num-dual's dual numbers for exact first
//! and second derivatives, through one trait bound.
//!
//! Branches look at real parts only ([`re`]), so a dual number follows the same path as the
//! `f64` it extends, and every function here is smooth wherever the `f64` version is.

use nalgebra::{RealField, Vector3};
use num_dual::DualNum;

/// A real number that the math can be evaluated on: `f64`, `Dual64`, `DualSVec64<N>`,
/// `Dual2SVec64<N>`, `HyperDual64`.
pub trait Scalar: DualNum<Primitive = f64> + RealField + Copy {}
impl<T: DualNum<Primitive = f64> + RealField + Copy> Scalar for T {}

/// Real part of a scalar (the value without its derivative parts).
#[inline]
pub fn re<T: Scalar>(x: T) -> f64 {
    x.re()
}

/// Lifts an `f64` constant into the scalar type (zero derivative).
#[inline]
pub fn c<T: Scalar>(x: f64) -> T {
    T::from(x)
}

/// Lifts an `f64` vector into the scalar type.
#[inline]
pub fn lift3<T: Scalar>(v: &Vector3<f64>) -> Vector3<T> {
    Vector3::new(c(v.x), c(v.y), c(v.z))
}

/// Real parts of a vector.
#[inline]
pub fn re3<T: Scalar>(v: &Vector3<T>) -> Vector3<f64> {
    Vector3::new(v.x.re(), v.y.re(), v.z.re())
}

/// Softplus `s⁺_ε(x) = ε·log(1 + exp(x/ε))`, evaluated as `max(x,0) + ε·log1p(exp(-|x|/ε))`
/// so it neither overflows for large `x/ε` nor loses the tail for small ones (SPEC §2).
#[inline]
pub fn softplus<T: Scalar>(x: T, eps: T) -> T {
    let (pos, abs) = if x.re() > 0.0 { (x, x) } else { (T::zero(), -x) };
    // Past |x|/ε = 746, exp underflows to exactly 0 (and so do its derivatives): skip the
    // slow underflow path of exp. Past 40, exp(-|x|/ε) < 5e-18 and log1p(y) = y(1 - y/2 + ...)
    // equals y to within a relative 3e-18, below f64 rounding: skip the log1p.
    let a = abs.re();
    if a > 746.0 * eps.re() {
        return pos;
    }
    if a > 40.0 * eps.re() {
        return pos + eps * (-abs / eps).exp();
    }
    pos + eps * (-abs / eps).exp().ln_1p()
}

/// `sqrt(a² + |v|²)`, a smooth norm that stays differentiable at `v = 0` for `a > 0`.
#[inline]
pub fn smooth_norm<T: Scalar>(v: &Vector3<T>, a: T) -> T {
    (a * a + v.dot(v)).sqrt()
}

/// Streaming softmin-weighted average: accumulates `Σ_i w_i x_i / Σ_i w_i` with
/// `w_i = exp(-(k_i - k_min)/ε)`, given the minimum key `k_min` up front (its real part
/// decides nothing but overflow safety: the result does not depend on the shift).
///
/// Memory is constant: this is how every softmax sum of the method is evaluated, never as an
/// array of weights.
#[derive(Clone, Copy, Debug)]
pub struct SoftminSum<T> {
    shift: T,
    inv_eps: T,
    /// `Σ w_i`.
    pub weight: T,
}

impl<T: Scalar> SoftminSum<T> {
    /// Starts a sum with weights `exp(-(key - shift)/eps)`.
    #[inline]
    pub fn new(shift: T, eps: T) -> Self {
        SoftminSum { shift, inv_eps: eps.recip(), weight: T::zero() }
    }

    /// Weight of a key, added to the running total and returned (so the caller can weigh its
    /// own accumulators with it).
    #[inline]
    pub fn add(&mut self, key: T) -> T {
        let w = (-(key - self.shift) * self.inv_eps).exp();
        self.weight += w;
        w
    }
}

/// Relative weight below which a softmax term may be skipped (SPEC §3).
pub const PRUNE_TOLERANCE: f64 = 1e-15;

/// `-ln(PRUNE_TOLERANCE)`: a term whose key exceeds the minimum by more than `ε` times this has a
/// relative weight below [`PRUNE_TOLERANCE`].
pub fn prune_margin() -> f64 {
    -PRUNE_TOLERANCE.ln()
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::Dual64;

    #[test]
    fn softplus_matches_definition_and_stays_finite() {
        for &(x, e) in &[(0.3, 0.1), (-0.3, 0.1), (0.0, 1e-3), (5.0, 1.0)] {
            let direct = e * (1.0f64 + (x / e).exp()).ln();
            assert!((softplus(x, e) - direct).abs() < 1e-14 * (1.0 + direct.abs()));
        }
        assert_eq!(softplus(1e3, 1e-9), 1e3);
        assert!(softplus(-1e3, 1e-9) >= 0.0 && softplus(-1e3, 1e-9) < 1e-300);
    }

    #[test]
    fn softplus_derivative_is_a_sigmoid() {
        for &x in &[-0.02, -1e-4, 0.0, 1e-4, 0.02] {
            let eps = 1e-3;
            let d = softplus(Dual64::new(x, 1.0), Dual64::from(eps)).eps;
            let sig = 1.0 / (1.0 + (-x / eps).exp());
            assert!((d - sig).abs() < 1e-12, "{x}: {d} vs {sig}");
        }
    }
}
