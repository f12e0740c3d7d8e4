//! Fixed tendons, as MuJoCo defines them: a length `L = Σ cᵢ qᵢ` over slide and hinge joints
//! (`cᵢ` the joint's coefficient), its velocity `L̇ = Σ cᵢ vᵢ`, and a force `F` along the tendon
//! that acts on each joint as `cᵢ F` (the tendon's Jacobian is the coefficient vector, constant).
//!
//! `F` sums, as MuJoCo's passive forces do: a spring `-k x` with `x = L - l_hi` above the spring
//! length's range `[l_lo, l_hi]`, `L - l_lo` below it and zero inside (MuJoCo's deadband; one
//! spring length when `l_lo = l_hi`); a damper `-b L̇`; SCM's smooth dry friction
//! `-F_f L̇ / sqrt(v_s² + L̇²)` (MuJoCo solves a tendon's frictionloss as a constraint, as it
//! does a joint's); and a smooth limit (see [`crate::dynamics::limit`]) on `L`, stiffened by
//! the tendon's effective inertia `1 / (c M⁻¹ cᵀ)` at the reference configuration (MuJoCo's
//! `1 / tendon_invweight0`).

use super::limit::JointLimit;
use crate::scalar::{c, Scalar};

/// A fixed tendon.
#[derive(Clone, Debug, PartialEq)]
pub struct FixedTendon {
    /// Name (from the scene, or MuJoCo's `tendonN`).
    pub name: String,
    /// `(position index, velocity index, coefficient)` of each joint.
    pub joints: Vec<(usize, usize, f64)>,
    /// Spring stiffness `k` (N/m or N·m/rad per unit of length).
    pub stiffness: f64,
    /// The spring length's range `[l_lo, l_hi]`: no spring force inside.
    pub spring_length: (f64, f64),
    /// Damping `b`.
    pub damping: f64,
    /// Dry friction `F_f` (smooth, with the contact's stiction velocity).
    pub frictionloss: f64,
    /// Limits on the length, as a joint's are on its coordinate.
    pub limit: Option<JointLimit>,
}

impl FixedTendon {
    /// `L = Σ cᵢ qᵢ`.
    pub fn length<T: Scalar>(&self, q: &[T]) -> T {
        linear_value(&self.joints, q)
    }

    /// `L̇ = Σ cᵢ vᵢ`.
    pub fn velocity<T: Scalar>(&self, v: &[T]) -> T {
        linear_rate(&self.joints, v)
    }

    /// Whether the tendon exerts any force.
    pub fn acts(&self) -> bool {
        self.stiffness != 0.0
            || self.damping != 0.0
            || self.frictionloss != 0.0
            || self.limit.is_some()
    }

    /// The stretch `x` of the spring: past the spring length's range, zero inside.
    fn stretch<T: Scalar>(&self, l: T) -> T {
        let (lo, hi) = self.spring_length;
        if l.re() > hi {
            l - c::<T>(hi)
        } else if l.re() < lo {
            l - c::<T>(lo)
        } else {
            T::zero()
        }
    }

    /// The force along the tendon at `q`, `v`, with the stiction velocity `v_s`.
    pub fn force<T: Scalar>(&self, q: &[T], v: &[T], stiction_velocity: T) -> T {
        let (l, ldot) = (self.length(q), self.velocity(v));
        let mut f = -self.stretch(l) * self.stiffness - ldot * self.damping;
        if self.frictionloss > 0.0 {
            f -= ldot * self.frictionloss
                / (stiction_velocity * stiction_velocity + ldot * ldot).sqrt();
        }
        if let Some(limit) = &self.limit {
            f += limit.force(l, ldot);
        }
        f
    }

    /// The energy stored in the spring and the limit at `q`.
    pub fn energy<T: Scalar>(&self, q: &[T]) -> T {
        let l = self.length(q);
        let x = self.stretch(l);
        let limit = self.limit.map_or(T::zero(), |lim| lim.energy(l));
        x * x * (0.5 * self.stiffness) + limit
    }
}

/// `Σ cᵢ qᵢ` of a linear coordinate given as `(position index, velocity index, cᵢ)`: a fixed
/// tendon's length, or a joint or tendon equality's coordinate.
pub fn linear_value<T: Scalar>(x: &[(usize, usize, f64)], q: &[T]) -> T {
    x.iter().fold(T::zero(), |s, &(qi, _, c)| s + q[qi] * c)
}

/// `Σ cᵢ vᵢ`: the rate of [`linear_value`].
pub fn linear_rate<T: Scalar>(x: &[(usize, usize, f64)], v: &[T]) -> T {
    x.iter().fold(T::zero(), |s, &(_, vi, c)| s + v[vi] * c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::{first_derivative, Dual64};

    fn tendon() -> FixedTendon {
        FixedTendon {
            name: "t".into(),
            joints: vec![(0, 0, 1.5), (2, 1, -0.5)],
            stiffness: 20.0,
            spring_length: (0.1, 0.3),
            damping: 0.7,
            frictionloss: 0.4,
            limit: Some(JointLimit::from_solref(-0.5, 0.6, [0.02, 1.0], 0.3)),
        }
    }

    #[test]
    fn the_spring_is_the_gradient_of_its_energy() {
        // With zero velocity the force is the spring's and the limit's: -dE/dL along the
        // tendon, checked through q0 (coefficient 1.5) at lengths below, inside and above the
        // deadband and past the upper limit.
        let t = tendon();
        for q0 in [-0.2, 0.1, 0.3, 0.45] {
            let e = |x: Dual64| t.energy(&[x, Dual64::from(0.0), Dual64::from(0.1)]);
            let (_, de) = first_derivative(e, q0);
            let f = t.force(&[q0, 0.0, 0.1], &[0.0, 0.0], 0.01);
            assert!(
                (f * 1.5 + de).abs() < 1e-9 * (1.0 + de.abs()),
                "q0 = {q0}: {f} vs {de}"
            );
        }
    }

    #[test]
    fn the_damper_and_friction_only_dissipate() {
        let t = FixedTendon {
            stiffness: 0.0,
            limit: None,
            ..tendon()
        };
        for (v0, v1) in [(0.3, -0.2), (-1.0, 0.5), (0.01, 0.0)] {
            let ldot = 1.5 * v0 - 0.5 * v1;
            let f = t.force(&[0.0, 0.0, 0.0], &[v0, v1], 0.01);
            assert!(f * ldot < 0.0, "power {}", f * ldot);
        }
    }
}
