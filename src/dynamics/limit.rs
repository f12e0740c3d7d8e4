//! Joint limits as smooth one-sided springs and dampers, in the spirit of SCM's contact: a
//! force that is exactly zero inside the range, grows smoothly past a limit and only pushes
//! back into the range. The spring is twice continuously differentiable in the position, the
//! damper's onset once (`σ` is `C¹`), and the clamp `C` twice in its argument, so the dynamics
//! keep exact, continuous Jacobians.
//!
//! For a slide or hinge joint with range `[lo, hi]` and violation `d` (`lo - q` below the range,
//! `q - hi` above), the limit pushes back into the range with `C(k s(d) + b σ(d) ḋ)`, with the
//! smooth ramp `s` and step `σ = s'` over a width `w`:
//!
//! - `s(d) = 0` for `d ≤ 0`, `w (t³ - t⁴/2)` for `0 < d < w` (`t = d / w`), `d - w/2` beyond;
//! - `σ(d) = 0`, `3t² - 2t³`, `1` on the same pieces (`C¹`, so `s` is `C²`).
//!
//! `C` is a smooth `max(0, x)` ([`one_sided`]): MuJoCo's limit is a unilateral constraint whose
//! force is never negative, so a joint moving back into its range fast is let go, not braked by
//! the damper until it rests on the limit. (gymnasium's ant starts with its ankles 0.52 rad
//! outside their range: MuJoCo's limits throw them back in at 9.6 rad/s, to swing on through
//! the range; a two-sided damper stopped SCM's on the limit.) `C(x) = x` for `x ≥ 0`, so the
//! law is unchanged while the limit pushes; below zero it falls to `0` over a width `W` (`k w/2`,
//! the spring's force where its onset ends), through a pull of at most `16 W / 81`.
//!
//! The spring stores the energy `k P(d)`, `P(d) = w² (t⁴/4 - t⁵/10)` on the blend and
//! `d²/2 - w d/2 + 3w²/20` beyond. The rest only dissipates: the force is `k s` at `ḋ = 0`, at
//! least `k s` while the joint goes deeper and at most `k s` while it comes back (`C(x) = x` for
//! `x ≥ 0` and `C ≤ 0` below).
//!
//! Stiffness and damping come from MuJoCo's `solreflimit` (time constant `τ`, damping ratio
//! `ζ`; default 0.02 s and 1) and the joint's effective inertia `I` (`1 / (M⁻¹)ᵢᵢ`, armature
//! included, at the reference configuration: MuJoCo's `1 / dof_invweight0`): `k = I / (τ ζ)²`, `b = 2 I / τ`,
//! the constants of MuJoCo's reference acceleration for a unit impedance. A negative `solref`
//! gives them directly as `k = -solref[0] I`, `b = -solref[1] I`. A joint's limit acts with
//! both `1 / (1 - dmax)` times that, MuJoCo's statics, and, where the step does not take its
//! damping implicitly, with MuJoCo's impedance as an added inertia, which gives it MuJoCo's
//! dynamics as well ([`JointLimit::statics`], [`LimitLaw`]; docs/mjcf.md, "Joint limits").

pub use super::law::{Held, LimitLaw};
pub use super::ramp::{one_sided, one_sided_slope, ramp, ramp_energy};
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
    /// The spring and damper of MuJoCo's reference acceleration, `(k, b)` (see the module).
    pub reference: (f64, f64),
    /// The factor MuJoCo's statics ask of them, `1 / (1 - dmax)`, applied as [`LimitLaw`] says
    /// ([`JointLimit::acting`]).
    pub statics: f64,
    /// The coordinate's effective inertia the gains were sized on (kg or kg·m²).
    pub inertia: f64,
    /// The inertia MuJoCo's impedance adds to the coordinate where the limit pushes,
    /// `(statics - 1) I` under [`LimitLaw::Impedance`], otherwise zero
    /// ([`JointLimit::added_inertia`]).
    pub impedance: f64,
}

/// Width of the onset of every limit (m or rad): the force reaches its linear law 1 mm (or
/// 1 mrad) past the limit.
pub const LIMIT_WIDTH: f64 = 1e-3;

/// The width over which a limit with an added inertia lets go ([`JointLimit::hold`]), as a
/// share of the spring's force where its onset ends (`k w / 2`): narrow, since a load a limit
/// does not hold must take the coordinate off it at once, as MuJoCo's solver lets it go.
pub const HOLD_WIDTH: f64 = 0.01;

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
    /// Each side's push into the range before it is let go, `x = k s(d) + b σ(d) ḋ`, with the
    /// side's step `σ(d)`: `[(x₋, σ(d₋)), (x₊, σ(d₊))]`, the lower side's push upwards and the
    /// upper side's downwards, and the width of the blend [`one_sided`] lets them go over.
    fn pushes<T: Scalar>(&self, q: T, v: T) -> ([(T, T); 2], f64) {
        let (below, step_below) = ramp(c::<T>(self.lo) - q, self.width);
        let (above, step_above) = ramp(q - c::<T>(self.hi), self.width);
        let up = below * self.stiffness - v * step_below * self.damping;
        let down = above * self.stiffness + v * step_above * self.damping;
        (
            [(up, step_below), (down, step_above)],
            0.5 * self.stiffness * self.width,
        )
    }

    /// The limit's generalized force at position `q` and velocity `v`: each side's push, let go
    /// where it would pull.
    pub fn force<T: Scalar>(&self, q: T, v: T) -> T {
        let ([(up, _), (down, _)], blend) = self.pushes(q, v);
        one_sided(up, blend) - one_sided(down, blend)
    }

    /// The damping the limit adds where it pushes: `b (σ(d₋) C'(x₋)² + σ(d₊) C'(x₊)²)`,
    /// `-∂F/∂v` itself wherever the limit pushes (`C' = 1`). Damped Euler takes it implicitly
    /// with the joints' own damping (`(M + h D) v̇ = f`, docs/dynamics.md), as MuJoCo's
    /// constraint solver takes a limit's. On the narrow band below zero where the limit lets
    /// go, `C'` dips below zero; its square keeps `D` positive, so `M + h D` stays positive
    /// definite at any step, and smooth (`C'` is `C¹`), so the step's derivatives stay
    /// continuous.
    pub fn damping_slope<T: Scalar>(&self, q: T, v: T) -> T {
        self.pushing(q, v) * self.damping
    }

    /// How much the limit pushes, `σ(d₋) C'(x₋)² + σ(d₊) C'(x₊)²`: the weight of its damping
    /// slope and of its added inertia.
    fn pushing<T: Scalar>(&self, q: T, v: T) -> T {
        let (sides, blend) = self.pushes(q, v);
        let [below, above] = sides.map(|(x, step)| {
            let slope = one_sided_slope(x, blend);
            step * slope * slope
        });
        below + above
    }

    /// The inertia the limit adds to its coordinate at position `q` and velocity `v`: its
    /// [`JointLimit::impedance`] weighed as each side pushes, `σ(d) C'(x)²` (`1` past the onset
    /// while the limit pushes, falling to `0` inside the range and where the limit lets go),
    /// so that the mass matrix stays smooth and positive definite.
    pub fn added_inertia<T: Scalar>(&self, q: T, v: T) -> T {
        if self.impedance == 0.0 {
            return T::zero();
        }
        self.pushing(q, v) * self.impedance
    }

    /// How much of the limit holds, given the coordinate's acceleration `vdot` with it fully
    /// held: `1` while the limit pushes in all, falling smoothly (`C¹`) to `0` where it would
    /// pull. With an added inertia `I_a` ([`JointLimit::added_inertia`]) the limit's whole force
    /// into the range is its spring-damper's push plus `I_a r̈`, `r̈` the acceleration further
    /// past the limit, and that is MuJoCo's constraint force: an outside force taking the
    /// coordinate back into its range faster than the reference motion would makes it
    /// negative, and MuJoCo's solver lets a limit go rather than pull. Without this, a joint
    /// resting on its limit that a load (gravity on a bending knee) takes off it would be
    /// `statics` times heavier until it left the onset. The fall is over [`HOLD_WIDTH`] of the
    /// width of [`one_sided`]'s blend; without an added inertia the limit always holds (its own
    /// clamp lets go).
    pub fn hold<T: Scalar>(&self, q: T, v: T, vdot: T) -> T {
        let added = self.added_inertia(q, v);
        if added.re() == 0.0 {
            return T::one();
        }
        let ([(up, below), (down, above)], blend) = self.pushes(q, v);
        // One side engages at a time (a range is far wider than the onset).
        let push = if above.re() >= below.re() {
            one_sided(down, blend) + added * vdot
        } else {
            one_sided(up, blend) - added * vdot
        };
        let width = blend * HOLD_WIDTH;
        if push.re() >= 0.0 {
            return T::one();
        }
        if push.re() <= -width {
            return T::zero();
        }
        let u = push / width + 1.0;
        u * u * (-(u * 2.0) + 3.0)
    }

    /// The same limit whose statics ask `gain` times its reference gains, acting with them.
    pub fn stiffened(self, gain: f64) -> JointLimit {
        JointLimit {
            statics: gain,
            ..self
        }
        .acting(LimitLaw::Statics)
    }

    /// The same limit acting by `law`: the statics' gains ([`LimitLaw::Statics`]), those with
    /// MuJoCo's impedance as an added inertia ([`LimitLaw::Impedance`]), or the reference gains
    /// ([`LimitLaw::under`]).
    pub fn acting(self, law: LimitLaw) -> JointLimit {
        let gain = match law {
            LimitLaw::Reference => 1.0,
            LimitLaw::Statics | LimitLaw::Impedance => self.statics,
        };
        let impedance = match law {
            LimitLaw::Impedance => (self.statics - 1.0).max(0.0) * self.inertia,
            _ => 0.0,
        };
        JointLimit {
            stiffness: self.reference.0 * gain,
            damping: self.reference.1 * gain,
            impedance,
            ..self
        }
    }

    /// The energy stored in the limit's spring at position `q`. With an added inertia
    /// ([`LimitLaw::Impedance`]) the spring's energy is counted at the reference stiffness,
    /// `1 / statics` of the spring's: that is what the motion conserves without a load on the
    /// coordinate, the coordinate being `statics` times heavier while the limit pushes (a
    /// coordinate swinging onto the limit with kinetic energy `E` stores `statics E` in the
    /// stiff spring and gives `E` back). Under a load `G` the count drifts by
    /// `(1 - 1/statics) G Δr` over a depth `Δr` past the limit, down going in and back coming
    /// out: about `G² / k` at rest, small against the guard's margin.
    pub fn energy<T: Scalar>(&self, q: T) -> T {
        let stiffness = if self.impedance > 0.0 {
            self.stiffness / self.statics
        } else {
            self.stiffness
        };
        (ramp_energy(c::<T>(self.lo) - q, self.width)
            + ramp_energy(q - c::<T>(self.hi), self.width))
            * stiffness
    }

    /// How far [`JointLimit::energy`]'s count can still drift at position `q` (J): the
    /// `(1 - 1/statics) G Δr` of a load `G` over the depth `Δr` past the limit, with the load
    /// read as the spring's push `k s(d)` (what it carries at rest) and the depth as `s(d)`:
    /// `(1 - 1/statics) k s(d)²`. Zero without an added inertia (the count is then exact).
    ///
    /// The energy guard counts it as stored energy, as it counts a contact's: a limit that
    /// swings in deep and settles back out to rest under its load gives the count back that
    /// drift (a pendulum settling on its limit under semi-implicit Euler: 1.7 mJ of 3.85 J,
    /// measured), which without it the guard took for created energy. At a depth `Δr` deeper
    /// than the rest's `r₀ = G/k`, this term falls by `(1 - 1/statics) k (Δr² - r₀²)`, at least
    /// the `(1 - 1/statics) G (Δr - r₀)` the count rises by on the way back to rest.
    pub fn load_drift(&self, q: f64) -> f64 {
        if self.impedance == 0.0 {
            return 0.0;
        }
        let below = ramp(self.lo - q, self.width).0;
        let above = ramp(q - self.hi, self.width).0;
        (1.0 - 1.0 / self.statics) * self.stiffness * (below * below + above * above)
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
            reference: (stiffness, damping),
            statics: 1.0,
            inertia,
            impedance: 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::{first_derivative, Dual64};

    #[test]
    fn the_impedance_adds_inertia_where_the_limit_pushes_and_lets_go_where_it_would_pull() {
        let l = JointLimit::from_solref(-0.5, 0.5, [0.02, 1.0], 0.3)
            .stiffened(20.0)
            .acting(LimitLaw::Impedance);
        assert_eq!(l.impedance, 19.0 * 0.3);
        // Inside the range nothing; past the onset, pushing, all of it.
        assert_eq!(l.added_inertia(0.2, 0.0), 0.0);
        assert!((l.added_inertia(0.51, 0.0) - 5.7).abs() < 1e-12);
        // Leaving fast, the damper's push turns over and the clamp lets go of the inertia too.
        assert_eq!(l.added_inertia(0.51, -100.0), 0.0);
        // The whole force into the range is the push plus the added inertia times the
        // acceleration further past: it holds while that is positive, not once it pulls.
        let push = l.force(0.51, 0.0).abs();
        assert_eq!(l.hold(0.51, 0.0, 0.0), 1.0);
        assert_eq!(l.hold(0.51, 0.0, -0.5 * push / 5.7), 1.0);
        assert_eq!(l.hold(0.51, 0.0, -2.0 * push / 5.7), 0.0);
        assert_eq!(l.hold(-0.51, 0.0, 2.0 * push / 5.7), 0.0);
        assert_eq!(l.hold(-0.51, 0.0, -2.0 * push / 5.7), 1.0);
        // Between, it falls smoothly over HOLD_WIDTH of the onset's force: its derivatives (in
        // the acceleration, the velocity and the position) are the central differences'.
        let width = 0.5 * l.stiffness * l.width * HOLD_WIDTH;
        let a = -(push + 0.4 * width) / 5.7;
        let g = l.hold(0.51, 0.0, a);
        assert!(0.1 < g && g < 0.9, "{g}");
        let e = 1e-7 * width / 5.7;
        let fd = (l.hold(0.51, 0.0, a + e) - l.hold(0.51, 0.0, a - e)) / (2.0 * e);
        let (_, dual) = first_derivative(
            |x: Dual64| l.hold(Dual64::from(0.51), Dual64::from(0.0), x),
            a,
        );
        assert!((dual - fd).abs() < 1e-6 * dual.abs(), "{dual} vs {fd}");
        for (which, x0) in [(0, 0.51), (1, 0.0)] {
            let at = |x: f64| {
                if which == 0 {
                    l.hold(x, 0.0, a)
                } else {
                    l.hold(0.51, x, a)
                }
            };
            let e = 1e-9;
            let fd = (at(x0 + e) - at(x0 - e)) / (2.0 * e);
            let (_, dual) = first_derivative(
                |x: Dual64| {
                    let (q, v) = if which == 0 {
                        (x, Dual64::from(0.0))
                    } else {
                        (Dual64::from(0.51), x)
                    };
                    l.hold(q, v, Dual64::from(a))
                },
                x0,
            );
            assert!(
                (dual - fd).abs() < 1e-5 * dual.abs().max(1.0),
                "{which}: {dual} vs {fd}"
            );
        }
        // The spring's energy is counted at the reference stiffness (what the motion conserves).
        let reference = JointLimit::from_solref(-0.5, 0.5, [0.02, 1.0], 0.3);
        assert!((l.energy(0.52) - reference.energy(0.52)).abs() < 1e-12);
        // Without the impedance a limit always holds.
        assert_eq!(l.acting(LimitLaw::Statics).hold(0.51, 0.0, -1e9), 1.0);
    }

    #[test]
    fn the_load_drift_covers_what_the_count_gives_back_as_a_loaded_limit_settles() {
        // A coordinate of inertia 0.3 under a constant load G falls onto its limit at 2 m/s
        // (rad/s), swings in deep and settles to rest; its motion is integrated finely
        // (semi-implicit Euler at 1 µs). The count `½ I v² + energy(q) - G q` is lowest near
        // the deepest swing and rises as the coordinate settles back out; the drift term there
        // covers that rise.
        let (inertia, load) = (0.3, 40.0);
        let l = JointLimit::from_solref(-0.5, 0.5, [0.02, 1.0], inertia)
            .stiffened(20.0)
            .acting(LimitLaw::Impedance);
        assert_eq!(l.acting(LimitLaw::Statics).load_drift(0.6), 0.0);
        let s = 0.6 - 0.5 - 0.5 * l.width;
        let expected = (1.0 - 1.0 / 20.0) * l.stiffness * s * s;
        assert!((l.load_drift(0.6) - expected).abs() < 1e-12 * expected);
        assert!((l.load_drift(-0.6) - expected).abs() < 1e-12 * expected);
        let count = |q: f64, v: f64| 0.5 * inertia * v * v + l.energy(q) - load * q;
        let (mut q, mut v, h) = (0.5, 2.0, 1e-6);
        let (mut deepest, mut at_deepest) = (q, (count(q, v), l.load_drift(q)));
        for _ in 0..400_000 {
            let a = (load + l.force(q, v)) / (inertia + l.added_inertia(q, v));
            v += h * a;
            q += h * v;
            if q > deepest {
                deepest = q;
                at_deepest = (count(q, v), l.load_drift(q));
            }
        }
        let rest = 0.5 + 0.5 * l.width + load / l.stiffness;
        assert!(
            v.abs() < 1e-6 && (q - rest).abs() < 1e-6,
            "{q} {v} vs {rest}"
        );
        let rise = count(q, v) - at_deepest.0;
        // From the deepest swing to rest the count rose, by the drift
        // (1 - 1/statics) G (Δr - r₀) (`Δr - r₀` the swing's overshoot) less what the damper
        // spent, and the drift term at the deepest swing covers it.
        let overshoot = deepest - q;
        let drift = (1.0 - 1.0 / 20.0) * load * overshoot;
        assert!(rise > 0.5 * drift && rise < drift, "{rise} vs {drift}");
        assert!(at_deepest.1 > rise, "{rise} vs {}", at_deepest.1);
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
        // Coming back into the range fast, the limit lets go: no pull beyond the blend's
        // 16/81 of `k w / 2`, and none once the damper's pull passes that width. Past the
        // onset (s = 0.1 - w/2, σ = 1), the speed that makes the push -W/3 on either side
        // gives the deepest pull, 16/81 W, away from the range.
        let blend = 0.5 * l.stiffness * l.width;
        let v = (-blend / 3.0 - l.stiffness * (0.1 - 0.5 * l.width)) / l.damping;
        assert!((l.force(0.6, v) - 16.0 / 81.0 * blend).abs() < 1e-9 * blend);
        assert!((l.force(-0.6, -v) + 16.0 / 81.0 * blend).abs() < 1e-9 * blend);
        for &(q, v) in &[(0.6, -1.0), (0.5005, -0.3), (-0.6, 1.0), (-0.5002, 5.0)] {
            let f = l.force(q, v);
            assert!(
                f * q.signum() <= 16.0 / 81.0 * blend + 1e-12,
                "({q}, {v}): {f}"
            );
        }
        assert_eq!(l.force(0.6, -100.0), 0.0);
        assert_eq!(l.force(-0.6, 100.0), 0.0);
        // Direct stiffness and damping from a negative solref.
        let d = JointLimit::from_solref(0.0, 1.0, [-100.0, -10.0], 2.0);
        assert_eq!((d.stiffness, d.damping), (200.0, 20.0));
    }

    #[test]
    fn the_damping_slope_is_minus_the_forces_velocity_derivative_where_the_limit_pushes_and_never_negative(
    ) {
        let l = JointLimit::from_solref(-0.5, 0.5, [0.02, 1.0], 0.3).stiffened(20.0);
        let blend = 0.5 * l.stiffness * l.width;
        // The blend's slope against central differences of the blend, and at its ends.
        for &x in &[-1.2, -0.9, -0.6, -0.3, -0.01, 0.0, 0.4] {
            let x = x * blend;
            let h = 1e-6 * blend;
            let fd = (one_sided::<f64>(x + h, blend) - one_sided::<f64>(x - h, blend)) / (2.0 * h);
            let slope = one_sided_slope::<f64>(x, blend);
            assert!((fd - slope).abs() < 1e-6, "C'({x}) = {slope} vs {fd}");
        }
        let (mut pushing, mut letting_go) = (0, 0);
        // Inside the range, in the onset, past it; going deeper, resting, coming back (-0.018
        // at 0.8 w past the upper limit: on the blend, where C' < 0).
        for &q in &[0.0, 0.4999, 0.5003, 0.5008, 0.52, -0.5004, -0.6] {
            for &v in &[-3.0, -0.2, -0.018, -0.01, 0.0, 0.01, 0.2, 3.0] {
                let slope = l.damping_slope(q, v);
                assert!(slope >= 0.0, "({q}, {v}): {slope}");
                let (_, dfdv) = first_derivative(|x: Dual64| l.force(Dual64::from(q), x), v);
                let (d_minus, d_plus) = (l.lo - q, q - l.hi);
                let x = if d_plus > 0.0 {
                    ramp(d_plus, l.width).0 * l.stiffness + v * ramp(d_plus, l.width).1 * l.damping
                } else {
                    ramp(d_minus, l.width).0 * l.stiffness
                        - v * ramp(d_minus, l.width).1 * l.damping
                };
                let cp = one_sided_slope::<f64>(x, blend);
                if cp == 1.0 || cp == 0.0 {
                    // Where the limit pushes, or is idle: the force's own slope.
                    assert!(
                        (slope + dfdv).abs() <= 1e-9 * l.damping,
                        "({q}, {v}): {slope} vs {dfdv}"
                    );
                    pushing += usize::from(slope > 0.0);
                } else {
                    // Letting go on the blend: `-∂F/∂v = b σ C'` and the slope is `b σ C'²`.
                    assert!(
                        (slope + dfdv * cp).abs() <= 1e-9 * l.damping,
                        "({q}, {v}): {slope} vs {dfdv} at C' = {cp}"
                    );
                    letting_go += usize::from(cp < 0.0);
                }
            }
        }
        assert!(pushing > 10, "{pushing} cases where the limit damps");
        assert!(
            letting_go > 0,
            "the band where the limit lets go is visited"
        );
        // Stiffened: spring and damper alike.
        let base = JointLimit::from_solref(-0.5, 0.5, [0.02, 1.0], 0.3);
        assert_eq!(
            (l.stiffness, l.damping),
            (20.0 * base.stiffness, 20.0 * base.damping)
        );
    }
}
