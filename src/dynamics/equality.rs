//! MuJoCo's scalar equality constraints, `<equality><joint>` and `<equality><tendon>`, as smooth
//! springs and dampers in the spirit of SCM's contact and limits.
//!
//! Each couples two linear coordinates `x₁ = Σ cᵢ qᵢ` and `x₂` (a joint's coordinate, or a
//! fixed tendon's length) through MuJoCo's quartic: the error is
//! `e = x₁ - r₁ - p₀ - Σₖ pₖ dᵏ` (`k = 1..4`, `d = x₂ - r₂`), with `r` the coordinate at
//! `qpos0` (a joint's reference, a tendon's length there) and `p` the `polycoef`; without a
//! second coordinate `e = x₁ - r₁ - p₀`. MuJoCo solves `e = 0` as a soft constraint; SCM applies
//! the force `F = -(k e + b ė)` along the constraint's gradient, `∂e/∂q`, with `k` and `b` from
//! `solref` and the constraint's effective inertia `1 / (w₁ + w₂)` (each `w` MuJoCo's
//! `dof_invweight0` or `tendon_invweight0`), as the joint limits take theirs
//! ([`crate::dynamics::limit`]). The spring stores `½ k e²`; the damper only dissipates.

/// A linear combination of coordinates: `(position index, velocity index, coefficient)`.
pub type Linear = Vec<(usize, usize, f64)>;

pub use super::connect::{Connect, Orientation};
use super::limit::LimitLaw;
use super::tendon::{linear_rate as rate, linear_value as value};

/// An equality's spring and damper gains as the file defines them (docs/mjcf.md, "Equality
/// constraints"): the reference gains `(k, b)` (MuJoCo's reference acceleration for its
/// `solref` on the effective inertia `I`) and the factor `statics` by which MuJoCo's impedance
/// (`solimp`) raises them at rest. An equality acts as [`LimitLaw`] says
/// (`Model::set_integrator`): with the raised gains where the step takes its damping
/// implicitly across the coordinates it couples (implicit Euler), and elsewhere with the raised
/// gains and the inertia `(statics - 1) I` MuJoCo's impedance adds along its rows, which gives
/// it MuJoCo's statics and MuJoCo's pace.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gains {
    /// `(k, b)` of the reference.
    pub reference: (f64, f64),
    /// The factor MuJoCo's statics ask (1: none).
    pub statics: f64,
    /// The effective inertia `I` the reference gains were sized on (kg or kg·m², per row).
    pub inertia: f64,
}

impl Gains {
    /// The reference gains `(k, b)`, not raised, on the effective inertia `inertia`.
    pub fn reference(k: f64, b: f64, inertia: f64) -> Gains {
        Gains {
            reference: (k, b),
            statics: 1.0,
            inertia,
        }
    }

    /// The gains `(k, b)` an equality acts with under `law`: raised by `statics`
    /// ([`LimitLaw::Statics`], [`LimitLaw::Impedance`]) or the reference.
    pub fn acting(&self, law: LimitLaw) -> (f64, f64) {
        let g = match law {
            LimitLaw::Reference => 1.0,
            LimitLaw::Statics | LimitLaw::Impedance => self.statics,
        };
        (self.reference.0 * g, self.reference.1 * g)
    }

    /// The inertia MuJoCo's impedance adds along each of the equality's rows under `law`:
    /// `(statics - 1) I` with [`LimitLaw::Impedance`], otherwise zero.
    pub fn added_inertia(&self, law: LimitLaw) -> f64 {
        match law {
            LimitLaw::Impedance => (self.statics - 1.0).max(0.0) * self.inertia,
            _ => 0.0,
        }
    }
}

/// A joint or tendon equality.
#[derive(Clone, Debug, PartialEq)]
pub struct ScalarEquality {
    /// Name (from the scene, or MuJoCo's `equalityN`).
    pub name: String,
    /// The constrained coordinate and its value at `qpos0`.
    pub first: (Linear, f64),
    /// The coordinate it follows, and its value at `qpos0`.
    pub second: Option<(Linear, f64)>,
    /// MuJoCo's `polycoef`.
    pub poly: [f64; 5],
    /// Spring stiffness `k`, as it acts.
    pub stiffness: f64,
    /// Damping `b`, as it acts.
    pub damping: f64,
    /// The gains the file defines, from which `stiffness` and `damping` act.
    pub gains: Gains,
    /// The inertia added along each of its rows as it acts ([`Gains::added_inertia`]).
    pub impedance: f64,
}

impl ScalarEquality {
    /// The error `e` and the slope `∂e/∂x₂` (zero without a second coordinate).
    fn error<T: crate::scalar::Scalar>(&self, q: &[T]) -> (T, T) {
        let p = &self.poly;
        let x1 = value(&self.first.0, q) - self.first.1 - p[0];
        match &self.second {
            None => (x1, T::zero()),
            Some((x, r)) => {
                let d = value(x, q) - *r;
                let f = (((d * p[4] + p[3]) * d + p[2]) * d + p[1]) * d;
                let slope = ((d * (4.0 * p[4]) + 3.0 * p[3]) * d + 2.0 * p[2]) * d + p[1];
                (x1 - f, -slope)
            }
        }
    }

    /// Adds the generalized force `-(k e + b ė) ∂e/∂q` to `tau`.
    pub fn add_force<T: crate::scalar::Scalar>(&self, q: &[T], v: &[T], tau: &mut [T]) {
        let (e, slope) = self.error(q);
        let mut edot = rate(&self.first.0, v);
        if let Some((x, _)) = &self.second {
            edot += slope * rate(x, v);
        }
        let f = -(e * self.stiffness + edot * self.damping);
        for &(_, vi, c) in &self.first.0 {
            tau[vi] += f * c;
        }
        if let Some((x, _)) = &self.second {
            for &(_, vi, c) in x {
                tau[vi] += f * slope * c;
            }
        }
    }

    /// The spring's energy `½ k e²`.
    pub fn energy<T: crate::scalar::Scalar>(&self, q: &[T]) -> T {
        let (e, _) = self.error(q);
        e * e * (0.5 * self.stiffness)
    }

    /// The constraint's row `∂e/∂q`, one entry per velocity coordinate of `nv`: the first
    /// coordinate's coefficients, and the second's times `∂e/∂x₂`.
    pub fn row<T: crate::scalar::Scalar>(&self, q: &[T], nv: usize) -> nalgebra::DVector<T> {
        let (_, slope) = self.error(q);
        let mut row = nalgebra::DVector::zeros(nv);
        for &(_, vi, c) in &self.first.0 {
            row[vi] += crate::scalar::c::<T>(c);
        }
        if let Some((x, _)) = &self.second {
            for &(_, vi, c) in x {
                row[vi] += slope * c;
            }
        }
        row
    }

    /// The row's turning `J̇ v`: `-p''(x₂) ẋ₂²` (each coordinate is linear in `q`, so only the
    /// polynomial's curvature turns the row), zero without a second coordinate.
    pub fn turning<T: crate::scalar::Scalar>(&self, q: &[T], v: &[T]) -> T {
        let Some((x, r)) = &self.second else {
            return T::zero();
        };
        let p = &self.poly;
        let d = value(x, q) - *r;
        let curvature = (d * (12.0 * p[4]) + 6.0 * p[3]) * d + 2.0 * p[2];
        let xdot = rate(x, v);
        -(curvature * xdot * xdot)
    }

    /// The velocity indices the constraint acts on.
    pub fn dofs(&self) -> impl Iterator<Item = usize> + '_ {
        self.first
            .0
            .iter()
            .chain(self.second.iter().flat_map(|(x, _)| x.iter()))
            .map(|&(_, vi, _)| vi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::{first_derivative, Dual64};

    fn coupling() -> ScalarEquality {
        ScalarEquality {
            name: "e".into(),
            first: (vec![(0, 0, 1.0)], 0.1),
            second: Some((vec![(1, 1, 2.0), (2, 2, -0.5)], 0.05)),
            poly: [0.02, 0.7, -0.3, 0.2, 0.1],
            stiffness: 40.0,
            damping: 0.0,
            gains: Gains::reference(40.0, 0.0, 1.0),
            impedance: 0.0,
        }
    }

    #[test]
    fn the_spring_is_the_gradient_of_its_energy() {
        // -dE/dq_k with dual numbers, and by central differences, per coordinate.
        let eq = coupling();
        let q = [0.4, -0.2, 0.3];
        let mut tau = [0.0; 3];
        eq.add_force(&q, &[0.0; 3], &mut tau);
        for k in 0..3 {
            let at = |x: Dual64| {
                let mut z = q.map(Dual64::from);
                z[k] = x;
                eq.energy(&z)
            };
            let (_, de) = first_derivative(at, q[k]);
            let h = 1e-6;
            let (mut up, mut down) = (q, q);
            up[k] += h;
            down[k] -= h;
            let fd = (eq.energy(&up) - eq.energy(&down)) / (2.0 * h);
            assert!(
                (tau[k] + de).abs() < 1e-12 * (1.0 + de.abs()),
                "{k}: {tau:?} vs {de}"
            );
            assert!(
                (de - fd).abs() < 1e-7 * (1.0 + de.abs()),
                "{k}: {de} vs {fd}"
            );
        }
    }

    #[test]
    fn the_row_is_the_errors_gradient() {
        let eq = coupling();
        let q = [0.4, -0.2, 0.3];
        let row = eq.row(&q, 3);
        for k in 0..3 {
            let seeded: Vec<Dual64> = (0..3)
                .map(|i| Dual64::new(q[i], if i == k { 1.0 } else { 0.0 }))
                .collect();
            let (e, _) = eq.error(&seeded);
            assert!(
                (e.eps - row[k]).abs() < 1e-12,
                "{k}: {} vs {}",
                e.eps,
                row[k]
            );
        }
    }

    #[test]
    fn the_damper_only_dissipates() {
        let eq = ScalarEquality {
            stiffness: 0.0,
            damping: 3.0,
            ..coupling()
        };
        let (q, v) = ([0.4, -0.2, 0.3], [0.5, -0.1, 0.7]);
        let mut tau = [0.0; 3];
        eq.add_force(&q, &v, &mut tau);
        let power: f64 = tau.iter().zip(&v).map(|(t, v)| t * v).sum();
        assert!(power < 0.0, "{power}");
    }
}
