//! Time stepping: one enumeration of integrators (SPEC §2), the same names in code, scenes,
//! command line and FMU.

use crate::contact::ContactParams;
use crate::model::{DynamicsError, Model};
use crate::scalar::{c, Scalar};

/// Integration method of the internal steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Integrator {
    /// Explicit Euler, as in the paper: `q' = q ⊕ h v`, `v' = v + h v̇`.
    Euler,
    /// Semi-implicit (symplectic) Euler: `v' = v + h v̇`, `q' = q ⊕ h v'`.
    #[default]
    SemiImplicitEuler,
    /// Classic fourth-order Runge–Kutta on `(q, v)`, quaternions renormalized after the step.
    Rk4,
}

impl Integrator {
    /// Every integrator.
    pub const ALL: [Integrator; 3] = [Integrator::Euler, Integrator::SemiImplicitEuler, Integrator::Rk4];

    /// Name used in scenes (`scm_integrator`), the command line and the FMU.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Euler => "euler",
            Integrator::SemiImplicitEuler => "semi_implicit_euler",
            Integrator::Rk4 => "rk4",
        }
    }

    /// Parses a name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|i| i.name() == name)
    }
}

/// Positions and velocities.
#[derive(Clone, Debug, PartialEq)]
pub struct State<T> {
    /// Generalized positions `q`.
    pub q: Vec<T>,
    /// Generalized velocities `v`.
    pub v: Vec<T>,
}

fn axpy<T: Scalar>(x: &[T], a: T, y: &[T]) -> Vec<T> {
    x.iter().zip(y).map(|(&xi, &yi)| xi + a * yi).collect()
}

impl Model {
    /// One internal step of length `h` from `state` with controls `ctrl`.
    pub fn step<T: Scalar>(&self, state: &State<T>, ctrl: &[T], prm: &ContactParams<T>, h: T) -> Result<State<T>, DynamicsError> {
        let tree = &self.tree;
        let accel = |q: &[T], v: &[T]| -> Result<Vec<T>, DynamicsError> { Ok(self.forward(q, v, ctrl, prm)?.vdot.iter().copied().collect()) };
        match self.integrator {
            Integrator::Euler => {
                let a = accel(&state.q, &state.v)?;
                Ok(State { q: tree.integrate_q(&state.q, &state.v, h), v: axpy(&state.v, h, &a) })
            }
            Integrator::SemiImplicitEuler => {
                let a = accel(&state.q, &state.v)?;
                let v = axpy(&state.v, h, &a);
                Ok(State { q: tree.integrate_q(&state.q, &v, h), v })
            }
            Integrator::Rk4 => {
                let half = h * 0.5;
                let (q1, v1) = (&state.q, &state.v);
                let (dq1, dv1) = (tree.qdot(q1, v1), accel(q1, v1)?);
                let (q2, v2) = (axpy(q1, half, &dq1), axpy(v1, half, &dv1));
                let (dq2, dv2) = (tree.qdot(&q2, &v2), accel(&q2, &v2)?);
                let (q3, v3) = (axpy(q1, half, &dq2), axpy(v1, half, &dv2));
                let (dq3, dv3) = (tree.qdot(&q3, &v3), accel(&q3, &v3)?);
                let (q4, v4) = (axpy(q1, h, &dq3), axpy(v1, h, &dv3));
                let (dq4, dv4) = (tree.qdot(&q4, &v4), accel(&q4, &v4)?);
                let sixth = h / c::<T>(6.0);
                let comb = |x: &[T], k1: &[T], k2: &[T], k3: &[T], k4: &[T]| -> Vec<T> {
                    (0..x.len()).map(|i| x[i] + sixth * (k1[i] + (k2[i] + k3[i]) * 2.0 + k4[i])).collect()
                };
                let mut q = comb(q1, &dq1, &dq2, &dq3, &dq4);
                tree.normalize_q(&mut q);
                Ok(State { q, v: comb(v1, &dv1, &dv2, &dv3, &dv4) })
            }
        }
    }
}
