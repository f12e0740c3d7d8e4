//! The smooth pieces a limit is made of (re-exported by [`crate::dynamics::limit`]): the ramp
//! `s(d)` past a limit with its step `σ = s'` and its energy `P = ∫ s`, and the smooth
//! `max(0, x)` that lets a limit go where it would pull, with its slope. Their formulas and
//! smoothness are given in [`crate::dynamics::limit`]'s module doc.

use crate::scalar::{c, Scalar};

/// The smooth ramp `s(d)` and step `σ(d) = s'(d)` of the module doc.
pub fn ramp<T: Scalar>(d: T, w: f64) -> (T, T) {
    if d.re() <= 0.0 {
        return (T::zero(), T::zero());
    }
    if d.re() >= w {
        return (d - c::<T>(0.5 * w), T::one());
    }
    let t = d / w;
    let t2 = t * t;
    ((t2 * t - t2 * t2 * 0.5) * w, t2 * 3.0 - t2 * t * 2.0)
}

/// The limit's smooth `max(0, x)`, `C(x)`, over the width `width` (`W`) below zero: `x` from
/// zero on, `0` up to `-W`, and between them `W q(u)`, `u = 1 + x / W`, with
/// `q(u) = -4u³ + 7u⁴ - 3u⁵ = -u³ (1 - u) (4 - 3u)`, the quintic whose value and first two
/// derivatives meet both neighbours (`C²`). `q ≤ 0` on `[0, 1]` (its least value is `-16/81`, at
/// `u = 2/3`), so `C(x) ≤ max(0, x)` and `C(x) ≥ x`: the blend never adds to a push and never
/// pulls more than `16 W / 81`. Where `width` is zero, `max(0, x)`.
///
/// `C` cannot be monotone as well (zero at `-W`, never positive below zero, slope 1 at zero):
/// its slope dips to about `-0.51` at `x = -0.6 W`, so on that band the damper's slope in the
/// velocity turns over, to at most half of `b`. An implicit Euler step's Newton matrix for one
/// limited coordinate there, `I (1 + C' g (2h/τ + h²/τ²))` at `ζ = 1` with `g` the statics
/// gain ([`JointLimit::statics`](crate::dynamics::limit::JointLimit::statics), 20 at the default `solimplimit`), stays regular for steps
/// below `0.72 τ` at `g = 1` but only below about `0.05 τ` at `g = 20`: at MuJoCo's steps a
/// joint leaving its limit fast can meet a singular matrix on that band, where Newton's
/// iterations fail and the implicit step is done as two halves, recursively
/// (docs/dynamics.md).
pub fn one_sided<T: Scalar>(x: T, width: f64) -> T {
    if x.re() >= 0.0 {
        return x;
    }
    if x.re() <= -width {
        return T::zero();
    }
    let u = x / width + 1.0;
    let u3 = u * u * u;
    -(u3 * (-u + 1.0) * (-(u * 3.0) + 4.0)) * width
}

/// The slope `C'(x)` of [`one_sided`]: `1` from zero on, `0` up to `-W`, `q'(u)` between
/// (`q'(u) = -12u² + 28u³ - 15u⁴`, from `0` at `u = 0` to `1` at `u = 1`, dipping to about
/// `-0.51` on the way).
pub fn one_sided_slope<T: Scalar>(x: T, width: f64) -> T {
    if x.re() >= 0.0 {
        return T::one();
    }
    if x.re() <= -width {
        return T::zero();
    }
    let u = x / width + 1.0;
    let u2 = u * u;
    u2 * (u * 28.0 - u2 * 15.0 - 12.0)
}

/// The energy `P(d) = ∫ s` of the ramp.
pub fn ramp_energy<T: Scalar>(d: T, w: f64) -> T {
    if d.re() <= 0.0 {
        return T::zero();
    }
    if d.re() >= w {
        return d * d * 0.5 - d * (0.5 * w) + c::<T>(0.15 * w * w);
    }
    let t = d / w;
    let t4 = t * t * t * t;
    (t4 * 0.25 - t4 * t * 0.1) * (w * w)
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::{first_derivative, Dual64};

    #[test]
    fn the_ramp_is_twice_continuously_differentiable_and_its_energy_integrates_it() {
        let w = 1e-3;
        // Central differences of the energy give the ramp; of the ramp, the step.
        for &d in &[
            -1e-3_f64, -1e-9, 1e-9, 1e-4, 5e-4, 9.99e-4, 1e-3, 1.0001e-3, 2e-3, 0.5,
        ] {
            // Steps well inside one piece of the blend; larger far from it, against round-off.
            let h = if d.abs() < 1e-2 { 1e-9 } else { 1e-6 };
            let (s, sigma) = ramp::<f64>(d, w);
            let ds = (ramp_energy::<f64>(d + h, w) - ramp_energy::<f64>(d - h, w)) / (2.0 * h);
            assert!((ds - s).abs() < 1e-9, "P' = {ds} vs s = {s} at {d}");
            let dsig = (ramp::<f64>(d + h, w).0 - ramp::<f64>(d - h, w).0) / (2.0 * h);
            assert!(
                (dsig - sigma).abs() < 1e-6,
                "s' = {dsig} vs σ = {sigma} at {d}"
            );
            // The dual-number derivative is the step.
            let (_, dual) = first_derivative(|x: Dual64| ramp(x, w).0, d);
            assert!((dual - sigma).abs() < 1e-12, "{dual} vs {sigma} at {d}");
        }
        // Continuity of s, σ and σ' at both ends of the blend.
        for &end in &[0.0, w] {
            let e = 1e-12;
            let (a, b) = (ramp::<f64>(end - e, w), ramp::<f64>(end + e, w));
            assert!((a.0 - b.0).abs() < 1e-11 && (a.1 - b.1).abs() < 1e-8);
        }
    }

    #[test]
    fn the_one_sided_blend_is_twice_continuously_differentiable_and_never_pulls_much() {
        let w = 2.5;
        let c = |x: f64| one_sided::<f64>(x, w);
        // Value and first two derivatives (central differences) meet at both ends.
        let d1 = |x: f64, h: f64| (c(x + h) - c(x - h)) / (2.0 * h);
        let d2 = |x: f64, h: f64| (c(x + h) - 2.0 * c(x) + c(x - h)) / (h * h);
        for &end in &[-w, 0.0] {
            let e = 1e-9;
            assert!((c(end - e) - c(end + e)).abs() < 1e-8, "C at {end}");
            let h = 1e-4;
            assert!(
                (d1(end - 2.0 * h, h) - d1(end + 2.0 * h, h)).abs() < 1e-3,
                "C' at {end}"
            );
            assert!(
                (d2(end - 4.0 * h, h) - d2(end + 4.0 * h, h)).abs() < 1e-2,
                "C'' at {end}"
            );
        }
        for k in 0..=400 {
            let x = -1.5 * w + 2.0 * w * f64::from(k) / 400.0;
            let y = c(x);
            // Between x and max(0, x), and no deeper than 16/81 of the width.
            assert!(y <= x.max(0.0) + 1e-15 && y >= x - 1e-15, "{x}: {y}");
            assert!(y >= -16.0 / 81.0 * w - 1e-12, "{x}: {y}");
            // The dual-number derivative against a central difference.
            let (_, dual) = first_derivative(|x: Dual64| one_sided(x, w), x);
            assert!((dual - d1(x, 1e-6)).abs() < 1e-6, "{x}: {dual}");
        }
        assert!((c(-w / 3.0) + 16.0 / 81.0 * w).abs() < 1e-12);
        assert_eq!(one_sided::<f64>(-1e-9, 0.0), 0.0);
    }
}
