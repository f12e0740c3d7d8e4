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

use super::tendon::{linear_rate as rate, linear_value as value};

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
    /// Spring stiffness `k`.
    pub stiffness: f64,
    /// Damping `b`.
    pub damping: f64,
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

/// MuJoCo's `<equality><connect>`: a point of one body held at a point of another (or of the
/// world), as a spring and damper between the two points.
///
/// The points are `p₁ = x₁ + R₁ a₁` and `p₂ = x₂ + R₂ a₂`, with `a₂` the place of `p₁` in
/// body 2's frame at `qpos0` (as MuJoCo's compiler sets it), so the error `e = p₁ - p₂` is
/// zero there. The force `F = -(k e + b ė)` acts at `p₁` on body 1 and `-F` at `p₂` on body 2;
/// `k` and `b` come from `solref` and the inertia `1 / (w₁ + w₂)`, with `w` MuJoCo's
/// translational `body_invweight0`. The spring stores `½ k |e|²`.
#[derive(Clone, Debug, PartialEq)]
pub struct Connect {
    /// Name (from the scene, or MuJoCo's `equalityN`).
    pub name: String,
    /// Body 1 and the anchor in its frame.
    pub first: (usize, nalgebra::Vector3<f64>),
    /// Body 2 (0: the world) and the anchor in its frame.
    pub second: (usize, nalgebra::Vector3<f64>),
    /// Spring stiffness `k` (N/m).
    pub stiffness: f64,
    /// Damping `b` (N·s/m).
    pub damping: f64,
}

impl Connect {
    /// The two points and their velocities, world frame.
    #[allow(clippy::type_complexity)]
    fn points<T: crate::scalar::Scalar>(
        &self,
        frames: &[crate::collision::Frame<T>],
    ) -> [(
        nalgebra::Vector3<T>,
        nalgebra::Vector3<T>,
        nalgebra::Vector3<T>,
    ); 2] {
        [self.first, self.second].map(|(b, a)| {
            let f = &frames[b];
            let arm = f.rotation * a.map(crate::scalar::c::<T>);
            (f.origin + arm, f.linvel + f.angvel.cross(&arm), arm)
        })
    }

    /// Adds the two point forces to the bodies' wrenches (force, and torque about the body
    /// origin, world axes).
    pub fn add_wrenches<T: crate::scalar::Scalar>(
        &self,
        frames: &[crate::collision::Frame<T>],
        w: &mut [crate::contact::Wrench<T>],
    ) {
        let [(p1, v1, arm1), (p2, v2, arm2)] = self.points(frames);
        let (k, b) = (
            crate::scalar::c::<T>(self.stiffness),
            crate::scalar::c::<T>(self.damping),
        );
        let force = -((p1 - p2) * k + (v1 - v2) * b);
        w[self.first.0].force += force;
        w[self.first.0].torque += arm1.cross(&force);
        w[self.second.0].force -= force;
        w[self.second.0].torque -= arm2.cross(&force);
    }

    /// The spring's energy `½ k |e|²`.
    pub fn energy<T: crate::scalar::Scalar>(&self, frames: &[crate::collision::Frame<T>]) -> T {
        let [(p1, _, _), (p2, _, _), ..] = self.points(frames);
        let e = p1 - p2;
        e.dot(&e) * (0.5 * self.stiffness)
    }
}
