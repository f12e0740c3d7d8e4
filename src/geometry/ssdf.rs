//! Soft signed distance function (paper eq. 8, docs/method.md):
//! `φ̂_S(p) = Σ_i σ_ε1(-d)_i · n_iᵀ(p - p_i)`, with `d_i = |p - p_i|²` (so ε1 is in m²).
//!
//! Two evaluations of the same sum:
//! - [`ssdf_naive`]: every term, the reference;
//! - [`ssdf`]: the terms that can matter, found with the AOPC's bounding-volume hierarchy
//!   ([`Relevant`]), with a proven bound on what is skipped.
//!
//! Both stream the softmax (shift by the smallest `d_i`, then one pass accumulating weights and
//! weighted values): memory is constant, never an array of weights.
//!
//! # The pruning bound
//! Let `d_min = min_i d_i`, `I` the number of points, `τ` = [`PRUNE_TOLERANCE`](crate::scalar::PRUNE_TOLERANCE) and
//! `ℓ = √d_min + √ε1`. A term is skipped only if
//! `(d_i - d_min)/ε1 > ln(I/τ) + ln(1 + √d_i/ℓ)`, so its weight relative to the largest
//! (which is 1, at `d_min`) is `w_i < (τ/I)/(1 + √d_i/ℓ)`: every skipped term is below the
//! relative weight τ/I ≤ τ (docs/method.md, numerical rules). Summed over at most `I` skipped terms:
//! `Σ_skip w_i < τ` and `Σ_skip w_i |v_i| < τ ℓ`, because `|v_i| = |n_iᵀ(p - p_i)| ≤ √d_i`.
//! With `A = Σ w_i v_i`, `Z = Σ w_i ≥ 1` and the skipped parts `A_s`, `Z_s`, the pruned value
//! differs from the full one by `|(Z_s φ̂ - A_s)/(Z - Z_s)| < τ (|φ̂| + ℓ)/(1 - τ)`: relative to
//! the natural length of the query (its distance to the cloud, or √ε1), the error is τ.
//! A whole node is skipped when the bound holds for its box: `d_i ≥ d_lo` (smallest squared
//! distance from `p` to the box) on the left, and inside the logarithm `d_i` is at most the
//! largest squared distance to the root box; the logarithm is rounded up to a multiple of
//! `ln 2` ([`ln_upper`]), which only keeps a few more terms.
//! The same visit weighs point–plane forces (contact), whose size grows at most linearly with
//! `√d_i` too, so the same argument bounds them.

use crate::scalar::{c, lift3, re3, Scalar, SoftminSum};
use nalgebra::Vector3;

use super::Aopc;

pub use super::relevant::{gather_ball, ln_upper, visit_relevant, Relevant};

/// Receives the real parts of every term of an SSDF sum (for derivatives computed alongside
/// the value; see [`GradientSink`]).
pub trait SsdfSink {
    /// Whether the sink does anything (when `false`, the calls compile away).
    const ON: bool;
    /// One term: weight `w = exp(-(d - d_min)/ε1)`, offset `r = p - p_i`, normal and
    /// `φ_i = n_iᵀ r`.
    fn term(&mut self, w: f64, r: &Vector3<f64>, n: &Vector3<f64>, phi: f64);
}

/// A sink that does nothing.
pub struct NoSink;

impl SsdfSink for NoSink {
    const ON: bool = false;
    #[inline(always)]
    fn term(&mut self, _: f64, _: &Vector3<f64>, _: &Vector3<f64>, _: f64) {}
}

/// Accumulates the gradient of the SSDF with respect to the query point:
/// `∇φ̂ = (Σ w_i n_i - (2/ε1) Σ w_i r_i (φ_i - φ̂)) / Σ w_i` (the derivative of the weights is
/// `∂w_i/∂p = -(2/ε1) w_i r_i`).
#[derive(Clone, Copy, Debug, Default)]
pub struct GradientSink {
    sn: Vector3<f64>,
    srphi: Vector3<f64>,
    sr: Vector3<f64>,
}

impl SsdfSink for GradientSink {
    const ON: bool = true;
    #[inline(always)]
    fn term(&mut self, w: f64, r: &Vector3<f64>, n: &Vector3<f64>, phi: f64) {
        self.sn += n * w;
        self.srphi += r * (w * phi);
        self.sr += r * w;
    }
}

impl GradientSink {
    /// `∇φ̂` given the value `phi`, the weight sum and ε1 (m²).
    pub fn gradient(&self, phi: f64, weight: f64, eps1: f64) -> Vector3<f64> {
        (self.sn - (self.srphi - self.sr * phi) * (2.0 / eps1)) / weight
    }
}

/// The SSDF of `p` (AOPC frame) over the points `rel` found relevant at its real part:
/// `(φ̂, Σ_i w_i)` with `w_i = exp(-(d_i - d_min)/ε1)`.
///
/// With `spring.eps3 > 0` it also bounds, from real parts, the point–plane springs these
/// planes would exert on `p` (see [`SpringBound`]); with [`SpringShape::NONE`] that bound is
/// left infinite. With
/// `terms`, each term's leaf-order index and weight `w_i` are pushed in summation order (the
/// point–SSDF force at `p` sums the same terms with the same weights; `contact`). `floor`: a
/// lower bound of every distance the springs read at `p` (the polytope's floor,
/// [`super::polytope::Floor::lower`]; `-∞` for none), which the spring bound may use, each
/// plane's raised to its own ([`super::polytope::Polytope::lift_of`]).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn ssdf_over<T: Scalar, S: SsdfSink>(
    s: &Aopc,
    p: &Vector3<T>,
    eps1: T,
    spring: SpringShape,
    floor: f64,
    rel: &Relevant,
    sink: &mut S,
    mut terms: Option<&mut Vec<(u32, T)>>,
) -> (T, T, f64) {
    let bvh = s.bvh();
    let mut sum = SoftminSum::new(c(rel.dmin), eps1);
    let mut acc = T::zero();
    let mut springs = SpringBound::new(rel.dmin, eps1.re(), spring.eps3);
    let lifts = bvh.polytope.as_ref().filter(|_| floor > f64::NEG_INFINITY);
    for &(k, d) in &rel.items {
        let (q, n) = (&bvh.points[k as usize], &bvh.normals[k as usize]);
        let r = p - lift3::<T>(q);
        let w = sum.add(r.dot(&r));
        let phi = r.x * n.x + r.y * n.y + r.z * n.z;
        acc += w * phi;
        if spring.eps3 > 0.0 {
            let floor = lifts.map_or(floor, |l| floor + l.lift_of(k as usize));
            springs.add(d, w.re(), phi.re().max(floor) - spring.margin);
        }
        if S::ON {
            sink.term(w.re(), &re3(&r), n, phi.re());
        }
        if let Some(t) = terms.as_deref_mut() {
            t.push((k, w));
        }
    }
    let weight = sum.weight;
    (
        acc / weight,
        weight,
        springs.bound(rel.items.len(), weight.re()),
    )
}

/// What the spring bounds need of the point–plane spring `k s⁺_ε3(m - φ)`: its softplus
/// temperature and the margin `m` at which it rests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringShape {
    /// ε3 (m); not positive: no bound is kept.
    pub eps3: f64,
    /// The margin (m; 0: the paper's spring, resting on the surface).
    pub margin: f64,
}

impl SpringShape {
    /// No spring to bound (the SSDF alone).
    pub const NONE: SpringShape = SpringShape {
        eps3: 0.0,
        margin: 0.0,
    };
}

/// An upper bound of `Σ_i σ_i s⁺_ε3(-φ_i)` (m) over the terms of an SSDF sum, `σ_i` its
/// softmax weights and `φ_i = n_iᵀ(p - p_i)`: with the stiffness, it bounds every point–plane
/// spring of the point–SSDF force at `p` (the contact's force pruning; with a margin `m`, each
/// `φ_i` is given less `m`). From real parts, with
/// `s⁺_ε(-φ) ≤ ε exp(-φ/ε)` for `φ ≥ 0` (kept as the exponent `-(d_i - d_min)/ε1 - φ_i/ε3`
/// of `w_i exp(-φ_i/ε3)`, so no `exp` per term) and `≤ -φ + ε ln 2` for `φ < 0`; the sum is at
/// most the number of terms times the largest.
#[derive(Clone, Copy, Debug)]
pub struct SpringBound {
    dmin: f64,
    inv_eps1: f64,
    eps3: f64,
    inv_eps3: f64,
    /// Largest `-(d_i - d_min)/ε1 - φ_i/ε3` over terms with `φ_i ≥ 0`.
    exponent: f64,
    /// Largest `w_i (-φ_i + ε3 ln 2)` over terms with `φ_i < 0`.
    deep: f64,
}

impl SpringBound {
    /// A bound for an SSDF sum with shift `dmin` (m²) and temperatures `eps1` (m²), `eps3` (m).
    #[inline]
    pub fn new(dmin: f64, eps1: f64, eps3: f64) -> Self {
        SpringBound {
            dmin,
            inv_eps1: 1.0 / eps1,
            eps3,
            inv_eps3: 1.0 / eps3,
            exponent: f64::NEG_INFINITY,
            deep: 0.0,
        }
    }

    /// One term: squared distance `d` (m²), weight `w` and plane distance `phi` (m).
    #[inline]
    pub fn add(&mut self, d: f64, w: f64, phi: f64) {
        if phi >= 0.0 {
            self.exponent = self
                .exponent
                .max(-(d - self.dmin) * self.inv_eps1 - phi * self.inv_eps3);
        } else {
            self.deep = self
                .deep
                .max(w * (-phi + self.eps3 * std::f64::consts::LN_2));
        }
    }

    /// The bound for `terms` terms with weight sum `weight` (≥ 1), rounded up.
    #[inline]
    pub fn bound(&self, terms: usize, weight: f64) -> f64 {
        if self.eps3.is_nan() || self.eps3 <= 0.0 {
            return f64::INFINITY;
        }
        let shallow = if self.exponent > -745.0 {
            self.eps3 * self.exponent.exp()
        } else {
            0.0
        };
        terms as f64 * shallow.max(self.deep) / weight * (1.0 + 1e-12)
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
    let mut rel = Relevant::default();
    rel.find(s, &re3(p), eps1.re(), usize::MAX);
    let (phi, w, _) = ssdf_over(
        s,
        p,
        eps1,
        SpringShape::NONE,
        f64::NEG_INFINITY,
        &rel,
        &mut NoSink,
        None,
    );
    (phi, w)
}

/// The SSDF summed over every point (no pruning): the reference for [`ssdf`].
pub fn ssdf_naive<T: Scalar>(s: &Aopc, p: &Vector3<T>, eps1: T) -> T {
    if s.is_empty() {
        return c(f64::INFINITY);
    }
    let pr = crate::scalar::re3(p);
    let dmin = s
        .points
        .iter()
        .map(|q| (pr - q).norm_squared())
        .fold(f64::INFINITY, f64::min);
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
        let s = Aopc::new(
            vec![Vector3::new(0.0, 0.0, 1.0)],
            vec![Vector3::z()],
            vec![1.0],
            vec![],
            vec![],
        );
        assert_eq!(ssdf(&s, &Vector3::new(3.0, -2.0, 0.25), 1e-3), -0.75);
    }

    #[test]
    fn pruned_matches_naive_and_prunes() {
        let s = Shape::Box {
            half: Vector3::new(0.1, 0.05, 0.03),
        }
        .sample(0.005);
        for (p, eps1) in [
            (Vector3::new(0.03, 0.052, -0.01), 1e-5),
            (Vector3::new(0.5, -0.2, 0.1), 1e-6),
            (Vector3::zeros(), 1e-4),
            (Vector3::new(0.1, 0.05, 0.03), 1e-9),
        ] {
            let (a, b): (f64, f64) = (ssdf(&s, &p, eps1), ssdf_naive(&s, &p, eps1));
            assert!(
                (a - b).abs() <= 1e-13 * (a.abs() + 0.1),
                "{p:?}: {a} vs {b}"
            );
            let mut n = 0;
            visit_relevant(&s, &p, eps1, |_, _| n += 1);
            // At the centre with a wide ε1 most points matter; elsewhere few do.
            if p != Vector3::zeros() {
                assert!(n < s.len() / 20, "{n} of {} visited", s.len());
            }
        }
    }

    #[test]
    fn gradient_matches_central_differences() {
        let s = Shape::Box {
            half: Vector3::new(0.1, 0.05, 0.03),
        }
        .sample(0.01);
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
            assert!(
                (g - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                "axis {k}: {g} vs {fd}"
            );
        }
    }
}
