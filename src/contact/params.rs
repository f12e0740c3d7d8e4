//! The contact parameters (the FMU's tunable `scm.*`) and the dissipation factor's variants.

use super::*;

/// The dissipation factor `d(s)` of the point–plane force, `s = v_n / v_d`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Dissipation {
    /// The paper's (and IDTO's) piecewise `d`: `1 - s` for `s ≤ 0`, `(s - 2)²/4` on `(0, 2]`,
    /// `0` after. Only C¹: its second derivative jumps at `s = 0` and `s = 2`.
    #[default]
    Paper,
    /// C² variant: the same values and slopes at both ends, joined by
    /// `1 - s + s³/4 - s⁴/16` on `[0, 2]`, whose second derivative vanishes at both ends.
    Smooth,
}

impl Dissipation {
    /// Name used in scenes (`scm_dissipation`) and the FMU.
    pub fn name(self) -> &'static str {
        match self {
            Dissipation::Paper => "paper",
            Dissipation::Smooth => "smooth",
        }
    }

    /// Parses a scene's `scm_dissipation` value.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "paper" => Some(Dissipation::Paper),
            "smooth" => Some(Dissipation::Smooth),
            _ => None,
        }
    }

    /// `d(s)`.
    #[inline]
    pub fn factor<T: Scalar>(self, s: T) -> T {
        let x = s.re();
        if x <= 0.0 {
            T::one() - s
        } else if x <= 2.0 {
            match self {
                Dissipation::Paper => (s - 2.0) * (s - 2.0) * 0.25,
                Dissipation::Smooth => {
                    let s2 = s * s;
                    T::one() - s + s2 * s * 0.25 - s2 * s2 * (1.0 / 16.0)
                }
            }
        } else {
            T::zero()
        }
    }

    /// `d(s)` and `d'(s)` in `f64`.
    pub fn factor_slope(self, s: f64) -> (f64, f64) {
        if s <= 0.0 {
            (1.0 - s, -1.0)
        } else if s <= 2.0 {
            match self {
                Dissipation::Paper => ((s - 2.0) * (s - 2.0) * 0.25, (s - 2.0) * 0.5),
                Dissipation::Smooth => {
                    let s2 = s * s;
                    (
                        1.0 - s + s2 * s * 0.25 - s2 * s2 * (1.0 / 16.0),
                        -1.0 + 0.75 * s2 - 0.25 * s2 * s,
                    )
                }
            }
        } else {
            (0.0, 0.0)
        }
    }
}

/// The spacing (m) the default ε1 (1e-5 m², `√ε1` about a third of it) was chosen for, the
/// paper's: a cloud sampled finer is read with ε1 scaled by the square of its spacing over
/// this ([`eps1_scale`]).
pub const EPS1_SPACING: f64 = 0.01;

/// The factor on ε1 of a cloud whose longest quad is `longest` (m): `(longest /
/// EPS1_SPACING)²` below [`EPS1_SPACING`], 1 at it and above. The softmax's weights
/// `e^{-(d_i - d_min)/ε1}` then fall over the same number of neighbouring planes at every
/// spacing: a cloud scaled by λ with ε1 scaled by λ² reads the same SSDF times λ
/// (docs/method.md, "ε1 follows the spacing").
pub fn eps1_scale(longest: f64) -> f64 {
    if longest > 0.0 && longest < EPS1_SPACING {
        let r = longest / EPS1_SPACING;
        r * r
    } else {
        1.0
    }
}

/// The ε1 (m²) each side of a pair reads the other body's planes with, given the parameter
/// `eps1` and the factors of the pair's two clouds (`a`'s, then `b`'s; [`eps1_scale`]): side 0
/// (`a`'s points) reads `b`'s planes, side 1 (`b`'s points) `a`'s.
#[inline]
pub fn eps1_sides<T: Scalar>(eps1: T, scale: [f64; 2]) -> [T; 2] {
    let of = |s: f64| if s == 1.0 { eps1 } else { eps1 * c::<T>(s) };
    [of(scale[1]), of(scale[0])]
}

/// Parameters of the contact model. Every field but `dissipation` is a scalar so that
/// derivatives with respect to it come out of the same code.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactParams<T> {
    /// SSDF softmax temperature ε1 (m²): the contact parameter, which each cloud's planes
    /// read times their factor in `eps1_scale` ([`ContactParams::eps1_sides`]).
    pub eps1: T,
    /// The factors on ε1 with which the planes of the pair's two bodies are read, `a`'s then
    /// `b`'s: `(L / EPS1_SPACING)²` for a cloud whose longest quad `L` is finer than
    /// [`EPS1_SPACING`] ([`eps1_scale`]), 1 for the others and where the scene sets
    /// `scm_eps1` (docs/method.md, "ε1 follows the spacing"). A pair's own values
    /// ([`crate::model::Pair`]), not FMU parameters.
    pub eps1_scale: [f64; 2],
    /// Separation-distribution softmax temperature ε2 (m).
    pub eps2: T,
    /// Softplus smoothing of the penetration ε3 (m).
    pub eps3: T,
    /// Contact stiffness k (N/m).
    pub stiffness: T,
    /// Dissipation velocity v_d (m/s): the approach speed at which damping cancels the spring.
    pub dissipation_velocity: T,
    /// Stiction velocity v_s (m/s): the sliding speed below which friction fades to zero.
    pub stiction_velocity: T,
    /// Friction coefficient μ (1).
    pub friction: T,
    /// Dissipation force F_d (N): the spring force `c` at which the dissipation velocity has
    /// doubled at rest. The factor reads `s = v_n / V`, `V = v_d (1 + (c/F_d) g(v_n/v_d))`,
    /// `g(x) = 1 - tanh(x/2)` ([`ContactParams::dissipation_velocity_at`]): at rest (`g` = 1)
    /// a point's damping coefficient `c / (v_d (1 + c/F_d))` stops growing with its depth past
    /// about `F_d`, approaching (`g` up to 2) its damping force stays below `F_d |v_n| / v_d`,
    /// and separating (`g` to 0) its speed is held to a few `v_d` at any depth, so a deep
    /// overlap is released, not thrown (docs/method.md, departure 4). Infinite: the paper's
    /// law, `v_d` at every depth and speed. A pair's own value ([`crate::model::Pair`]), not an
    /// FMU parameter.
    pub dissipation_force: T,
    /// Contact margin m (m): the distance from the surface at which the spring rests. The
    /// spring reads `φ - m`, so a pair pushes from `m` outside the surface on, as MuJoCo's
    /// contact acts from its `includemargin` (the sum of the two geoms' `margin`, or a
    /// `<pair margin>`; docs/mjcf.md). 0: the paper's law. A pair's own value
    /// ([`crate::model::Pair`]), not an FMU parameter.
    pub margin: T,
    /// Adhesion δ (N; MuJoCo's geom `adhesion`): the contact can pull with up to δ, within the
    /// gap past its margin (docs/method.md, departure 7). 0: none, the paper's law. A pair's
    /// own value, not an FMU parameter.
    pub adhesion: f64,
    /// Gap g (m; MuJoCo's geom `gap`): how far past the margin an adhesive contact still pulls.
    /// Read only where the pair can pull ([`ContactParams::adhesive`]). A pair's own value.
    pub gap: f64,
    /// The pull of the adhesion actuators on the pair's bodies (N; MuJoCo's `<adhesion>`, a
    /// body transmission): within the gap past the margin, as the adhesion's pull, but with
    /// the plain spring (docs/method.md, departure 9). `None`: no such actuator drives either
    /// body; `Some(0)`: one does and is off (the same force as `None`, with the derivative
    /// with respect to its control). Set per evaluation from the controls, not an FMU
    /// parameter.
    pub pull: Option<T>,
    /// The moving surfaces of the pair's two bodies, `a`'s then `b`'s, each in its body's
    /// frame (MuJoCo's geom `surfacevel`; docs/method.md, departure 8): the friction reads the
    /// sliding of material on material. `None`: neither surface moves, the paper's law. A
    /// pair's own value, not an FMU parameter.
    pub surface: Option<[crate::collision::Twist<f64>; 2]>,
    /// Which dissipation factor `d(s)` to use.
    pub dissipation: Dissipation,
    /// Whether a finite dissipation force reads the normal speed with its share
    /// ([`ContactParams::dissipation_velocity_at`]), which holds a separation to a few `v_d` at
    /// any depth: where the integrator takes the contact's damping implicitly (the pair's law,
    /// chosen at load from the file's integrator as the dissipation force is). Without it
    /// `V = v_d (1 + c/F_d)` at every speed, whose damping an explicit integrator carries
    /// (docs/method.md, departure 4).
    pub hold_separation: bool,
}

impl Default for ContactParams<f64> {
    fn default() -> Self {
        ContactParams {
            eps1: 1e-5,
            eps1_scale: [1.0; 2],
            eps2: 1e-3,
            eps3: 1e-4,
            stiffness: 1e4,
            dissipation_velocity: 0.1,
            stiction_velocity: 1e-2,
            friction: 0.5,
            dissipation_force: f64::INFINITY,
            hold_separation: false,
            margin: 0.0,
            adhesion: 0.0,
            gap: 0.0,
            pull: None,
            surface: None,
            dissipation: Dissipation::Paper,
        }
    }
}

impl<T: Scalar> ContactParams<T> {
    /// The dissipation velocity `V` a point whose spring pushes with `spring` (N) at the normal
    /// speed `vn` (m/s, positive apart) reads that speed against: `v_d (1 + c/F_d)`, or with
    /// [`ContactParams::hold_separation`] `v_d (1 + (c/F_d) g(v_n/v_d))`, `g(x) = 1 - tanh(x/2)`
    /// (from 2 approaching fast through 1 at rest to 0 separating fast); `v_d` where `F_d` is
    /// infinite ([`ContactParams::dissipation_force`]).
    #[inline]
    pub fn dissipation_velocity_at(&self, spring: T, vn: T) -> T {
        let vd = self.dissipation_velocity;
        if self.holds_separation() {
            vd * (T::one() + spring / self.dissipation_force * separation_share(vn / vd))
        } else if self.dissipation_force.re().is_finite() {
            vd * (T::one() + spring / self.dissipation_force)
        } else {
            vd
        }
    }

    /// Whether the dissipation velocity takes the normal speed's share: a finite dissipation
    /// force held in separation ([`ContactParams::hold_separation`]) and a finite `v_d`.
    #[inline]
    pub fn holds_separation(&self) -> bool {
        self.hold_separation
            && self.dissipation_force.re().is_finite()
            && self.dissipation_velocity.re().is_finite()
    }

    /// The ε1 (m²) each side of the pair reads the other body's planes with ([`eps1_sides`]).
    #[inline]
    pub fn eps1_sides(&self) -> [T; 2] {
        eps1_sides(self.eps1, self.eps1_scale)
    }

    /// What a proof that a pair is out of reach reads of them, real parts
    /// ([`crate::collision::out_of_reach`]): those of [`ContactParams::re`]'s, without the
    /// whole set copied (a pair's proof at every evaluation).
    pub fn reach(&self) -> crate::collision::ReachParams {
        crate::collision::ReachParams {
            eps1: eps1_sides(self.eps1.re(), self.eps1_scale),
            eps3: self.eps3.re(),
            margin: self.bound_margin(),
            dissipation_velocity: self.dissipation_velocity.re(),
            friction: self.friction.re(),
        }
    }

    /// Real parts.
    pub fn re(&self) -> ContactParams<f64> {
        ContactParams {
            eps1: self.eps1.re(),
            eps1_scale: self.eps1_scale,
            eps2: self.eps2.re(),
            eps3: self.eps3.re(),
            stiffness: self.stiffness.re(),
            dissipation_velocity: self.dissipation_velocity.re(),
            stiction_velocity: self.stiction_velocity.re(),
            friction: self.friction.re(),
            dissipation_force: self.dissipation_force.re(),
            hold_separation: self.hold_separation,
            margin: self.margin.re(),
            adhesion: self.adhesion,
            gap: self.gap,
            pull: self.pull.map(|p| p.re()),
            surface: self.surface,
            dissipation: self.dissipation,
        }
    }

    /// Whether the pair can pull: it has adhesion, or an adhesion actuator drives one of its
    /// bodies (departures 7 and 9).
    pub fn adhesive(&self) -> bool {
        self.adhesion > 0.0 || self.pull.is_some()
    }

    /// The adhesion and the size of the actuators' pull together (N, real part): the most the
    /// window's term can add to a point force (a `<general body>` with a negative force
    /// pushes within the gap as much).
    pub fn pull_bound(&self) -> f64 {
        self.adhesion + self.pull.map_or(0.0, |p| p.re().abs())
    }

    /// Where the bounds of the pair's forces count from (m): the margin, or where the pair
    /// can pull ([`ContactParams::adhesive`]) `m + max(δ/k, g)`. With `k* = `[`ContactParams::bound_stiffness`] every point–plane
    /// force is at most `k* s⁺_ε3(m* - φ) (1 + V/v_d) √(1 + μ²)`, the paper's bound with
    /// `(k*, m*)` for `(k, m)` (docs/method.md, departure 7), so the pruning and the proofs of
    /// being out of reach read these two and nothing else of the adhesion.
    pub fn bound_margin(&self) -> f64 {
        if self.adhesive() {
            self.margin.re() + self.gap.max(self.adhesion / self.stiffness.re().abs())
        } else {
            self.margin.re()
        }
    }

    /// The stiffness the force bounds read (N/m): `k`, or where the pair can pull
    /// `k + (δ + a)/ε3`, `a` the actuators' pull ([`ContactParams::bound_margin`]).
    pub fn bound_stiffness(&self) -> f64 {
        if self.adhesive() {
            self.stiffness.re().abs() + self.pull_bound() / self.eps3.re()
        } else {
            self.stiffness.re().abs()
        }
    }
}

impl ContactParams<f64> {
    /// The same parameters in another scalar type (constants: zero derivative).
    pub fn lift<T: Scalar>(&self) -> ContactParams<T> {
        ContactParams {
            eps1: c(self.eps1),
            eps1_scale: self.eps1_scale,
            eps2: c(self.eps2),
            eps3: c(self.eps3),
            stiffness: c(self.stiffness),
            dissipation_velocity: c(self.dissipation_velocity),
            stiction_velocity: c(self.stiction_velocity),
            friction: c(self.friction),
            dissipation_force: c(self.dissipation_force),
            hold_separation: self.hold_separation,
            margin: c(self.margin),
            adhesion: self.adhesion,
            gap: self.gap,
            pull: self.pull.map(c),
            surface: self.surface,
            dissipation: self.dissipation,
        }
    }
}

/// A tunable contact parameter (`scm.<name>`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Param {
    /// ε1 (m²).
    Eps1,
    /// ε2 (m).
    Eps2,
    /// ε3 (m).
    Eps3,
    /// k (N/m).
    Stiffness,
    /// v_d (m/s).
    DissipationVelocity,
    /// v_s (m/s).
    StictionVelocity,
    /// μ (1).
    Friction,
}

impl Param {
    /// Every parameter, in table order.
    pub const ALL: [Param; 7] = [
        Param::Eps1,
        Param::Eps2,
        Param::Eps3,
        Param::Stiffness,
        Param::DissipationVelocity,
        Param::StictionVelocity,
        Param::Friction,
    ];

    /// `(name, unit, description)`.
    pub fn describe(self) -> (&'static str, &'static str, &'static str) {
        match self {
            Param::Eps1 => ("eps1", "m2", "SSDF softmax temperature over squared distances (smaller: sharper surfaces)"),
            Param::Eps2 => ("eps2", "m", "separation-distribution softmax temperature (smaller: force concentrates on the deepest points)"),
            Param::Eps3 => ("eps3", "m", "softplus smoothing of the penetration (force at zero penetration is k*eps3*ln 2)"),
            Param::Stiffness => ("stiffness", "N/m", "contact stiffness k"),
            Param::DissipationVelocity => ("dissipation_velocity", "m/s", "approach speed at which damping cancels the spring (v_d)"),
            Param::StictionVelocity => ("stiction_velocity", "m/s", "sliding speed below which friction fades (v_s); also smooths joint frictionloss"),
            Param::Friction => ("friction", "1", "friction coefficient mu"),
        }
    }

    /// The parameter's slot.
    pub fn get<T: Copy>(self, p: &ContactParams<T>) -> T {
        match self {
            Param::Eps1 => p.eps1,
            Param::Eps2 => p.eps2,
            Param::Eps3 => p.eps3,
            Param::Stiffness => p.stiffness,
            Param::DissipationVelocity => p.dissipation_velocity,
            Param::StictionVelocity => p.stiction_velocity,
            Param::Friction => p.friction,
        }
    }

    /// The parameter's slot, for writing.
    pub fn slot<T>(self, p: &mut ContactParams<T>) -> &mut T {
        match self {
            Param::Eps1 => &mut p.eps1,
            Param::Eps2 => &mut p.eps2,
            Param::Eps3 => &mut p.eps3,
            Param::Stiffness => &mut p.stiffness,
            Param::DissipationVelocity => &mut p.dissipation_velocity,
            Param::StictionVelocity => &mut p.stiction_velocity,
            Param::Friction => &mut p.friction,
        }
    }

    /// Whether `value` is allowed (finite; positive, or non-negative for friction).
    pub fn accepts(self, value: f64) -> bool {
        value.is_finite()
            && if self == Param::Friction {
                value >= 0.0
            } else {
                value > 0.0
            }
    }
}

/// `g(x) = 1 - tanh(x/2)` of [`ContactParams::dissipation_velocity_at`]: 1 at rest, towards 2
/// approaching and towards 0 separating, smooth, with `g'(0) = -1/2` and `g' = -g (1 - g/2)`.
/// Evaluated as `2/(1 + e^x)`, the same function, through the logistic (one `exp` of a
/// non-positive argument, never overflowing) in place of `tanh`, which every point–plane force
/// and every replay of Newton's iterations took (gymnasium's hopper spent 16 % of its run in
/// `tanh` and its `expm1`, docs/performance.md); and no cancellation where bodies part fast
/// (`1 - tanh` lost the share's relative precision there, and is 0 past `x` = 38).
#[inline]
pub fn separation_share<T: Scalar>(x: T) -> T {
    super::point::logistic(-x) * c::<T>(2.0)
}

#[cfg(test)]
mod share_tests {
    use super::separation_share;
    use num_dual::Dual64;

    /// The share is `1 - tanh(x/2)`: within a few ulps of 1 of it (the reference's own error
    /// is absolute, `1 - tanh` rounding near 1), its derivative `-g (1 - g/2)` by dual numbers
    /// and by central differences, and, where bodies part fast, the relative precision that
    /// `1 - tanh` loses.
    #[test]
    fn the_separation_share_is_one_less_tanh_of_half_its_argument() {
        for i in -400..=400 {
            let x = i as f64 * 0.05;
            let g = separation_share(x);
            let reference = 1.0 - (0.5 * x).tanh();
            assert!(
                (g - reference).abs() <= 4.0 * f64::EPSILON,
                "{x}: {g} vs {reference}"
            );
            let slope = separation_share(Dual64::new(x, 1.0)).eps;
            assert!(
                (slope + g * (1.0 - 0.5 * g)).abs() <= 1e-15,
                "{x}: g' {slope}"
            );
            let h = 1e-6;
            let fd = (separation_share(x + h) - separation_share(x - h)) / (2.0 * h);
            assert!((slope - fd).abs() <= 1e-9, "{x}: g' {slope} vs fd {fd}");
        }
        // Parting fast, the share keeps its relative precision: `2 e^-x / (1 + e^-x)`, where
        // `1 - tanh` has a few digits left at x = 30 and none from x = 38 on.
        for x in [10.0, 20.0, 30.0, 40.0, 100.0, 700.0] {
            let e = f64::exp(-x);
            let exact = 2.0 * e / (1.0 + e);
            let g = separation_share(x);
            assert!((g / exact - 1.0).abs() < 1e-15, "{x}: {g} vs {exact}");
            let slope = separation_share(Dual64::new(x, 1.0)).eps;
            assert!(
                (slope / -(g * (1.0 - 0.5 * g)) - 1.0).abs() < 1e-14,
                "{x}: g' {slope}"
            );
        }
        // Fast approach, fast separation, and past `exp`'s range: finite, and the limits.
        assert_eq!(separation_share(-800.0), 2.0);
        assert_eq!(separation_share(800.0), 0.0);
        assert_eq!(separation_share(0.0), 1.0);
        let far = separation_share(Dual64::new(800.0, 1.0));
        assert!(far.re == 0.0 && far.eps == 0.0, "{far:?}");
    }
}
