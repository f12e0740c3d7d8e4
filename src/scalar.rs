//! The scalar type of all the math: `f64` for values, num-dual's dual numbers for exact first
//! and second derivatives, through one trait bound.
//!
//! Branches look at real parts only ([`re`]), so a dual number follows the same path as the
//! `f64` it extends, and every function here is smooth wherever the `f64` version is.

use nalgebra::U1;
use nalgebra::{Const, RealField, SVector, Vector3};
use num_dual::{
    Derivative, Dual, Dual2, Dual2Vec, DualNum, DualSVec64, DualVec, HyperDual, HyperDualVec,
};

/// A real number that the math can be evaluated on: `f64`, `Dual64`, `DualSVec64<N>`,
/// `Dual2_64`, `Dual2SVec64<N>`, `HyperDual64`, `HyperDualSVec64<M, N>`.
pub trait Scalar: DualNum<Primitive = f64> + RealField + Copy + ChainRule {}
impl<T: DualNum<Primitive = f64> + RealField + Copy + ChainRule> Scalar for T {}

/// The forward-mode chain rule across a block whose Jacobian was computed in `f64`: for a
/// first-order dual type, `y_i = values_i` with derivative parts `Σ_k J_ik ε(x_k)`, exactly
/// what the type would have carried through the block itself. Hot kernels (the pair contact)
/// use it to compute their Jacobian once, by hand, instead of carrying every derivative
/// direction through every term.
pub trait ChainRule: Sized {
    /// Whether [`ChainRule::chain`] applies (first-order duals); `f64` and second-order types
    /// run the generic code.
    const FIRST_ORDER: bool;

    /// Whether every derivative part is zero (the number is a constant).
    fn is_constant(&self) -> bool;

    /// `out[i] = values[i] + Σ_k jac[i n + k] (inputs[k] - re(inputs[k]))` (`jac` row-major,
    /// `n = inputs.len()`); `false` (and `out` untouched) when the type is not first order.
    fn chain(values: &[f64], jac: &[f64], inputs: &[Self], out: &mut [Self]) -> bool;
}

impl ChainRule for f64 {
    const FIRST_ORDER: bool = false;
    fn is_constant(&self) -> bool {
        true
    }
    fn chain(_: &[f64], _: &[f64], _: &[Self], _: &mut [Self]) -> bool {
        false
    }
}

impl ChainRule for Dual<f64> {
    const FIRST_ORDER: bool = true;
    fn is_constant(&self) -> bool {
        self.eps == 0.0
    }
    fn chain(values: &[f64], jac: &[f64], inputs: &[Self], out: &mut [Self]) -> bool {
        let n = inputs.len();
        for (i, (o, &v)) in out.iter_mut().zip(values).enumerate() {
            let row = &jac[i * n..(i + 1) * n];
            *o = Dual::new(v, row.iter().zip(inputs).map(|(j, x)| j * x.eps).sum());
        }
        true
    }
}

impl<const N: usize> ChainRule for DualVec<f64, Const<N>> {
    const FIRST_ORDER: bool = true;
    fn is_constant(&self) -> bool {
        self.eps
            .0
            .as_ref()
            .is_none_or(|e| e.iter().all(|&x| x == 0.0))
    }
    fn chain(values: &[f64], jac: &[f64], inputs: &[Self], out: &mut [Self]) -> bool {
        let n = inputs.len();
        // Only inputs that carry a derivative contribute.
        let live: Vec<(usize, &SVector<f64, N>)> = inputs
            .iter()
            .enumerate()
            .filter_map(|(k, x)| x.eps.0.as_ref().map(|e| (k, e)))
            .collect();
        for (i, (o, &v)) in out.iter_mut().zip(values).enumerate() {
            let row = &jac[i * n..(i + 1) * n];
            let mut e = SVector::<f64, N>::zeros();
            for &(k, ek) in &live {
                if row[k] != 0.0 {
                    e += ek * row[k];
                }
            }
            *o = DualVec::new(
                v,
                if live.is_empty() {
                    Derivative::none()
                } else {
                    Derivative::some(e)
                },
            );
        }
        true
    }
}

/// Second-order types: no chain rule (it would need the block's second derivatives).
macro_rules! second_order {
    ($($t:ty),* $(,)?) => {$(
        impl ChainRule for $t {
            const FIRST_ORDER: bool = false;
            fn is_constant(&self) -> bool {
                false
            }
            fn chain(_: &[f64], _: &[f64], _: &[Self], _: &mut [Self]) -> bool {
                false
            }
        }
    )*};
}
second_order!(Dual2<f64>, HyperDual<f64>);

impl<const N: usize> ChainRule for Dual2Vec<f64, Const<N>> {
    const FIRST_ORDER: bool = false;
    fn is_constant(&self) -> bool {
        false
    }
    fn chain(_: &[f64], _: &[f64], _: &[Self], _: &mut [Self]) -> bool {
        false
    }
}

impl<const M: usize, const N: usize> ChainRule for HyperDualVec<f64, Const<M>, Const<N>> {
    const FIRST_ORDER: bool = false;
    fn is_constant(&self) -> bool {
        false
    }
    fn chain(_: &[f64], _: &[f64], _: &[Self], _: &mut [Self]) -> bool {
        false
    }
}

/// `x` as a dual number of width `N` whose derivative is the unit vector of `direction` (none,
/// or one past the width: a constant).
pub fn seeded<const N: usize>(x: f64, direction: Option<usize>) -> DualSVec64<N> {
    let mut d = DualSVec64::<N>::from_re(x);
    if let Some(i) = direction.filter(|&i| i < N) {
        d.eps = Derivative::derivative_generic(Const::<N>, U1, i);
    }
    d
}

/// The derivatives of a dual number of width `N` (zeros where it carries none).
pub fn derivatives<const N: usize>(d: &DualSVec64<N>) -> [f64; N] {
    let mut out = [0.0; N];
    if let Some(e) = &d.eps.0 {
        for (o, x) in out.iter_mut().zip(e.iter()) {
            *o = *x;
        }
    }
    out
}

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
/// so it neither overflows for large `x/ε` nor loses the tail for small ones (docs/method.md).
#[inline]
pub fn softplus<T: Scalar>(x: T, eps: T) -> T {
    let (pos, abs) = if x.re() > 0.0 {
        (x, x)
    } else {
        (T::zero(), -x)
    };
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
        SoftminSum {
            shift,
            inv_eps: eps.recip(),
            weight: T::zero(),
        }
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

/// Relative weight below which a softmax term may be skipped (docs/method.md, numerical rules).
pub const PRUNE_TOLERANCE: f64 = 1e-15;

/// The largest pruning tolerance a scene or a host may set: below 1 for the bounds to hold,
/// and far below it to mean what it says (docs/method.md, numerical rules).
pub const PRUNE_TOLERANCE_MAX: f64 = 1e-3;

/// Whether `tolerance` is a pruning tolerance a scene or a host may set: above 0, at most
/// [`PRUNE_TOLERANCE_MAX`].
pub fn prune_tolerance_ok(tolerance: f64) -> bool {
    tolerance > 0.0 && tolerance <= PRUNE_TOLERANCE_MAX
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
