//! Joint limits as smooth one-sided springs and dampers, in the spirit of SCM's contact: a
//! force that is exactly zero inside the range, grows smoothly past a limit, and is twice
//! continuously differentiable in the position, so the dynamics keep exact, continuous
//! Jacobians.
//!
//! For a slide or hinge joint with range `[lo, hi]` and violation `d` (`lo - q` below the range,
//! `q - hi` above), the generalized force is `∓ (k s(d) + b σ(d) ḋ)`, pushing back into the
//! range, with the smooth ramp `s` and step `σ = s'` over a width `w`:
//!
//! - `s(d) = 0` for `d ≤ 0`, `w (t³ - t⁴/2)` for `0 < d < w` (`t = d / w`), `d - w/2` beyond;
//! - `σ(d) = 0`, `3t² - 2t³`, `1` on the same pieces (`C¹`, so `s` is `C²`).
//!
//! The spring stores the energy `k P(d)`, `P(d) = w² (t⁴/4 - t⁵/10)` on the blend and
//! `d²/2 - w d/2 + 3w²/20` beyond; the damper only dissipates (`b σ ḋ² ≥ 0`).
//!
//! Stiffness and damping come from MuJoCo's `solreflimit` (time constant `τ`, damping ratio
//! `ζ`; default 0.02 s and 1) and the joint's effective inertia `I` (`1 / (M⁻¹)ᵢᵢ`, armature
//! included, at the reference configuration: MuJoCo's `1 / dof_invweight0`): `k = I / (τ ζ)²`, `b = 2 I / τ`,
//! the constants of MuJoCo's reference acceleration for a unit impedance. A negative `solref`
//! gives them directly as `k = -solref[0] I`, `b = -solref[1] I`.

use crate::scalar::{c, Scalar};

/// A joint's limits and their spring and damper.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointLimit {
    /// Lower limit (m or rad).
    pub lo: f64,
    /// Upper limit (m or rad).
    pub hi: f64,
    /// Spring stiffness past a limit (N/m or N·m/rad).
    pub stiffness: f64,
    /// Damping past a limit (N·s/m or N·m·s/rad).
    pub damping: f64,
    /// Width of the smooth onset (m or rad).
    pub width: f64,
}

/// Width of the onset of every limit (m or rad): the force reaches its linear law 1 mm (or
/// 1 mrad) past the limit.
pub const LIMIT_WIDTH: f64 = 1e-3;

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

/// The stiffness and damping `(k, b)` of a spring and damper that give a coordinate of
/// effective inertia `inertia` MuJoCo's reference acceleration for `solref`: with a time
/// constant and damping ratio `(τ, ζ)`, `k = I / (τ ζ)²`, `b = 2 I / τ`; with negative values
/// `(-k', -b')`, `k = k' I`, `b = b' I`.
pub fn solref_gains(solref: [f64; 2], inertia: f64) -> (f64, f64) {
    if solref[0] > 0.0 {
        let (tau, zeta) = (solref[0], solref[1].max(1e-12));
        (inertia / (tau * zeta).powi(2), 2.0 * inertia / tau)
    } else {
        (-solref[0] * inertia, -solref[1] * inertia)
    }
}

impl JointLimit {
    /// The limit's generalized force at position `q` and velocity `v`.
    pub fn force<T: Scalar>(&self, q: T, v: T) -> T {
        let (below, step_below) = ramp(c::<T>(self.lo) - q, self.width);
        let (above, step_above) = ramp(q - c::<T>(self.hi), self.width);
        (below - above) * self.stiffness - v * (step_below + step_above) * self.damping
    }

    /// The energy stored in the limit's spring at position `q`.
    pub fn energy<T: Scalar>(&self, q: T) -> T {
        (ramp_energy(c::<T>(self.lo) - q, self.width)
            + ramp_energy(q - c::<T>(self.hi), self.width))
            * self.stiffness
    }

    /// Stiffness and damping from MuJoCo's `solref` and the joint's effective inertia.
    pub fn from_solref(lo: f64, hi: f64, solref: [f64; 2], inertia: f64) -> JointLimit {
        let (stiffness, damping) = solref_gains(solref, inertia);
        JointLimit {
            lo,
            hi,
            stiffness,
            damping,
            width: LIMIT_WIDTH,
        }
    }
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
    fn a_limit_pushes_back_into_its_range_and_is_zero_inside() {
        let l = JointLimit::from_solref(-0.5, 0.5, [0.02, 1.0], 0.1);
        assert_eq!(l.stiffness, 0.1 / 0.02f64.powi(2));
        assert_eq!(l.damping, 2.0 * 0.1 / 0.02);
        assert_eq!(l.force(0.3, 1.0), 0.0);
        assert_eq!(l.energy(0.49), 0.0);
        assert!(l.force(0.6, 0.0) < 0.0 && l.force(-0.6, 0.0) > 0.0);
        // Past the blend: a linear spring about the limit shifted by w/2, and a damper.
        let f = l.force(0.6, 0.0);
        assert!((f + l.stiffness * (0.1 - 0.5e-3)).abs() < 1e-9, "{f}");
        assert!((l.force(0.6, 2.0) - f + 2.0 * l.damping).abs() < 1e-9);
        // The damper never pushes along the motion.
        for &(q, v) in &[
            (0.6, 1.0),
            (0.6, -1.0),
            (-0.6, 1.0),
            (-0.6, -1.0),
            (0.5005, 0.3),
        ] {
            let damping_part = l.force(q, v) - l.force(q, 0.0);
            assert!(damping_part * v <= 0.0, "({q}, {v})");
        }
        // Direct stiffness and damping from a negative solref.
        let d = JointLimit::from_solref(0.0, 1.0, [-100.0, -10.0], 2.0);
        assert_eq!((d.stiffness, d.damping), (200.0, 20.0));
    }
}
