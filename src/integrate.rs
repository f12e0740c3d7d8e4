//! Time stepping: one enumeration of integrators (SPEC §2), the same names in code, scenes
//! (`scm_integrator`), the command line (`scm simulate --integrator`) and the FMU
//! (`solver.integrator`); one step of any of them ([`Model::step_with`], generic over the scalar,
//! so its exact derivatives come from the same code), and [`Model::advance`], which covers a
//! communication step with internal steps that land exactly on its end, refusing a step that
//! diverges.
//!
//! Positions live on a manifold (quaternions for free and ball joints). The one-step methods
//! move them with [`Tree::integrate_q`](crate::dynamics::Tree::integrate_q) (the exponential map)
//! or, for the Runge–Kutta methods, combine `q̇ = ½ q ⊗ (0, ω)` stages additively and normalize
//! the quaternions at the end of the step.
//!
//! Mocap bodies move with the constant velocity their inputs carry (see
//! [`Model::inputs_after`]): every stage sees them where they are at its time.

use crate::contact::ContactParams;
use crate::derivatives::{jacobian, VectorFunction};
use crate::dynamics::MOCAP_INPUTS;
use crate::model::{DynamicsError, Model};
use crate::scalar::{c, Scalar};
use nalgebra::DMatrix;
use std::any::TypeId;

/// Integration method of the internal steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Integrator {
    /// Explicit Euler, as in the paper: `q' = q ⊕ h v`, `v' = v + h v̇(q, v)`. First order;
    /// grows the energy of every oscillation.
    Euler,
    /// Semi-implicit (symplectic) Euler: `v' = v + h v̇(q, v)`, `q' = q ⊕ h v'`. First order,
    /// no energy drift on conservative systems; stable for `h ω < 2` (ω: the stiffest
    /// frequency, `sqrt(k/m)` in contact). MuJoCo's `Euler`.
    #[default]
    SemiImplicitEuler,
    /// Classic fourth-order Runge–Kutta. Stable for `h ω ≲ 2.8`; energy error `O(h⁴)`.
    /// MuJoCo's `RK4`.
    Rk4,
    /// MuJoCo's `Euler`: semi-implicit Euler with the joints' viscous damping taken implicitly,
    /// `(M + h D) v̇ = f(q, v)`, `v' = v + h v̇`, `q' = q ⊕ h v'`, where `D` holds each degree of
    /// freedom's joint damping and `f` every force (the damping's `-D v` included). A damped
    /// joint stays stable at any step; without damping it is `semi_implicit_euler`. MJCF's
    /// `integrator="Euler"` maps to it (to `semi_implicit_euler` with
    /// `<flag eulerdamp="disable">`).
    DampedEuler,
    /// Implicit (backward) Euler: `v' = v + h v̇(q', v')`, `q' = q ⊕ h v'`, its step equation in
    /// `v'` solved by Newton iterations on the exact Jacobian from dual numbers. MuJoCo's
    /// `implicit` and `implicitfast` (implicit in velocity) map to it.
    ///
    /// Why this method: contact is stiff (`k` up to 1e9 N/m, so `ω = sqrt(k/m)` reaches 3e4
    /// rad/s for 1 kg) and steps go up to 50 ms, so `h ω` reaches 1e3.
    /// - Explicit methods are unstable there. Implicit midpoint and the trapezoidal rule are
    ///   A-stable, but their amplification tends to -1 for stiff modes, which then ring for ever
    ///   instead of settling. Implicit Euler is **L-stable** (`R(∞) = 0`): unresolved contact
    ///   vibrations die within a step and the state lands on the quasi-static equilibrium, which
    ///   is the physical answer at that step size.
    /// - It takes **impacts without creating energy or penetrating**. Contact starting within a
    ///   step is where higher-order implicit methods fail. Measured over 40 drops of a 1 kg
    ///   sphere (k = 1e6 and 1e9 N/m, h = 8 to 50 ms, drops of 1 to 30 mm while sliding at
    ///   0.1 m/s; energy after each step against the energy before the impact, and the deepest
    ///   end-of-step position below the resting one): implicit Euler ≤ 0.99 of the energy, 38 µm;
    ///   2-stage Radau IIA (order 3, B-stable) ≤ 1.0 but ends impact steps up to 10.7 mm deep,
    ///   because its last stage's force does not move its last position (`(A²)_22 = 0`); the
    ///   L-stable SDIRK of order 2 (γ = 1 - 1/√2) gains 29 % and 2.4 mm, with γ = 1 + 1/√2 5.7 %;
    ///   TR-BDF2 20-fold; Lobatto IIIC found a spurious stage solution with a 1e12-fold gain.
    /// - Energy of resolved motion: first order, it damps an oscillation at `hω = y` by
    ///   `1/(1 + y²)` in energy per step (a pendulum at `hω = 0.01` loses 1e-4 of its energy per
    ///   step). That is the price of the above; `rk4` or `dopri5` keep the energy of resolved
    ///   motion, and a smaller step shrinks the damping quadratically.
    /// - One Newton system of size `nv`; its Jacobian is kept from step to step while the
    ///   iterations contract fast (at rest one Jacobian serves many steps). When contact starts
    ///   within a step far longer than the contact's period, Newton's iterations may fail from
    ///   the contact-free guess: [`Model::advance`] then does that step as two halves,
    ///   recursively.
    ImplicitEuler,
    /// Adaptive explicit Dormand–Prince 5(4) with local error control: a step is accepted when
    /// the embedded error estimate is below `solver.tolerance` (absolute plus relative, RMS over
    /// the state), the next step size follows the usual `0.9 err^(-1/5)` controller;
    /// `solver.step` is the first and largest internal step. Stiff contact makes it take small
    /// steps rather than diverge.
    Dopri5,
}

impl Integrator {
    /// Every integrator.
    pub const ALL: [Integrator; 6] = [
        Integrator::Euler,
        Integrator::SemiImplicitEuler,
        Integrator::DampedEuler,
        Integrator::Rk4,
        Integrator::ImplicitEuler,
        Integrator::Dopri5,
    ];

    /// Name used in scenes (`scm_integrator`), the command line and the FMU.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Euler => "euler",
            Integrator::SemiImplicitEuler => "semi_implicit_euler",
            Integrator::DampedEuler => "damped_euler",
            Integrator::Rk4 => "rk4",
            Integrator::ImplicitEuler => "implicit_euler",
            Integrator::Dopri5 => "dopri5",
        }
    }

    /// Parses a name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|i| i.name() == name)
    }

    /// Whether the method is explicit (its stability is limited by the stiffest frequency).
    pub fn is_explicit(self) -> bool {
        self != Integrator::ImplicitEuler
    }

    /// Whether the method chooses its internal steps by error control.
    pub fn is_adaptive(self) -> bool {
        self == Integrator::Dopri5
    }

    /// Order of accuracy.
    pub fn order(self) -> usize {
        match self {
            Integrator::Euler
            | Integrator::SemiImplicitEuler
            | Integrator::DampedEuler
            | Integrator::ImplicitEuler => 1,
            Integrator::Rk4 => 4,
            Integrator::Dopri5 => 5,
        }
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

/// `x + h Σ_j b_j k_j` for the non-zero `b_j`.
fn combine<T: Scalar>(x: &[T], h: T, terms: &[(f64, &[T])]) -> Vec<T> {
    let mut out = x.to_vec();
    for (b, k) in terms {
        if *b != 0.0 {
            let hb = h * *b;
            for (o, ki) in out.iter_mut().zip(k.iter()) {
                *o += hb * *ki;
            }
        }
    }
    out
}

/// Dormand–Prince 5(4) tableau: nodes, stage coefficients, 5th-order weights and error weights
/// (5th minus 4th order).
mod dp {
    pub const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
    pub const A: [&[f64]; 7] = [
        &[],
        &[1.0 / 5.0],
        &[3.0 / 40.0, 9.0 / 40.0],
        &[44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0],
        &[
            19372.0 / 6561.0,
            -25360.0 / 2187.0,
            64448.0 / 6561.0,
            -212.0 / 729.0,
        ],
        &[
            9017.0 / 3168.0,
            -355.0 / 33.0,
            46732.0 / 5247.0,
            49.0 / 176.0,
            -5103.0 / 18656.0,
        ],
        &[
            35.0 / 384.0,
            0.0,
            500.0 / 1113.0,
            125.0 / 192.0,
            -2187.0 / 6784.0,
            11.0 / 84.0,
        ],
    ];
    pub const B: [f64; 7] = [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
        0.0,
    ];
    pub const E: [f64; 7] = [
        71.0 / 57600.0,
        0.0,
        -71.0 / 16695.0,
        71.0 / 1920.0,
        -17253.0 / 339200.0,
        22.0 / 525.0,
        -1.0 / 40.0,
    ];
}

/// A Dormand–Prince step: the 5th-order solution, the error estimate (`nq + nv`), and the
/// acceleration at the solution (the first stage of the next step).
pub struct Dopri5Step<T> {
    /// 5th-order solution, quaternions normalized.
    pub state: State<T>,
    /// Embedded error estimate `h Σ (b_j - b*_j) k_j`, positions then velocities.
    pub error: Vec<T>,
    /// `q̇` and `v̇` at the solution (inputs at the end of the step).
    pub last: (Vec<T>, Vec<T>),
}

/// Newton iterations of an implicit stage: tolerance and limits.
const NEWTON_TOL: f64 = 1e-10;
const NEWTON_MAX_ITER: usize = 40;

/// The residual of the implicit Euler step equation `r(V) = V - v0 - h v̇(q0 ⊕ h V, V)` as a
/// function of the new velocity `V`, on real numbers (for its Jacobian).
struct StepResidual<'a> {
    model: &'a Model,
    q0: Vec<f64>,
    v0: Vec<f64>,
    h: f64,
    u: Vec<f64>,
    prm: ContactParams<f64>,
}

impl VectorFunction for StepResidual<'_> {
    fn eval<T: Scalar>(&self, x: &[T]) -> Result<Vec<T>, DynamicsError> {
        let lift = |v: &[f64]| v.iter().map(|&a| c::<T>(a)).collect::<Vec<T>>();
        step_residual(
            self.model,
            &lift(&self.q0),
            &lift(&self.v0),
            c(self.h),
            &lift(&self.u),
            &self.prm.lift(),
            x,
        )
    }
}

fn step_residual<T: Scalar>(
    model: &Model,
    q0: &[T],
    v0: &[T],
    h: T,
    u: &[T],
    prm: &ContactParams<T>,
    vs: &[T],
) -> Result<Vec<T>, DynamicsError> {
    let q = model.tree.integrate_q(q0, vs, h);
    let a = model.forward(&q, vs, u, prm)?.vdot;
    Ok((0..vs.len()).map(|k| vs[k] - v0[k] - h * a[k]).collect())
}

/// A residual function of the implicit step, on the scalar type.
type Residual<'a, T> = dyn Fn(&[T]) -> Result<Vec<T>, DynamicsError> + 'a;
/// The Jacobian of a residual at real values.
type RealJacobian<'a> = dyn Fn(&[f64]) -> Result<DMatrix<f64>, DynamicsError> + 'a;

/// Newton's method for `residual(x) = 0` from `guess`, with a real Jacobian (see
/// [`Integrator::ImplicitEuler`]): backtracking line search; in `f64` a Jacobian is kept (also from
/// the caller's `jac`) while the iterations contract by 4 or more per step; with dual numbers a
/// fresh one every iteration.
fn newton<T: Scalar>(
    residual: &Residual<T>,
    real_jacobian: &RealJacobian,
    guess: Vec<T>,
    jac: &mut Option<DMatrix<f64>>,
) -> Result<Vec<T>, DynamicsError> {
    let n = guess.len();
    if n == 0 {
        return Ok(guess);
    }
    let exact_each_iteration = TypeId::of::<T>() != TypeId::of::<f64>();
    let fail = |iterations: usize, r: &[T]| DynamicsError::NewtonFailed {
        iterations,
        residual: inf_norm(&re_vec(r)),
    };
    let mut x = guess;
    let mut r = residual(&x)?;
    if jac.as_ref().is_some_and(|j| j.nrows() != n) {
        *jac = None;
    }
    // `inverse`: the inverse of the Jacobian in use; `refresh`: take a new Jacobian at the
    // current iterate before the next update.
    let mut inverse: Option<DMatrix<f64>> = None;
    let mut refresh = jac.is_none();
    let mut last_dx = f64::INFINITY;
    let mut crawling = 0;
    for it in 1..=NEWTON_MAX_ITER {
        let fresh = refresh || exact_each_iteration;
        if fresh {
            *jac = Some(real_jacobian(&re_vec(&x))?);
            inverse = None;
            refresh = false;
        }
        if inverse.is_none() {
            let j = jac.as_ref().expect("a Jacobian was computed");
            inverse = Some(j.clone().lu().try_inverse().ok_or_else(|| fail(it, &r))?);
        }
        let jinv = inverse.as_ref().expect("inverted above");
        // dx = J⁻¹ r, in the scalar type (J is real).
        let dx: Vec<T> = (0..n)
            .map(|i| (0..n).fold(T::zero(), |s, k| s + r[k] * jinv[(i, k)]))
            .collect();
        let dx_re = inf_norm(&re_vec(&dx));
        // Backtracking (Armijo on the merit ½|r|², for which the Newton direction descends):
        // halve the step while the merit does not decrease enough.
        let merit = sq_norm(&re_vec(&r));
        let mut alpha = 1.0;
        let (mut x_new, mut r_new);
        loop {
            x_new = (0..n).map(|i| x[i] - dx[i] * alpha).collect::<Vec<T>>();
            r_new = residual(&x_new);
            let ok = match &r_new {
                Ok(rn) => {
                    let m = sq_norm(&re_vec(rn));
                    m.is_finite()
                        && (m <= (1.0 - 1e-4 * alpha) * merit || m <= 1e-24 * (1.0 + merit))
                }
                Err(_) => false,
            };
            if ok || alpha < 1e-3 {
                break;
            }
            alpha *= 0.5;
        }
        let r_next = r_new?;
        let scale = 1.0 + inf_norm(&re_vec(&x_new));
        let step = dx_re * alpha;
        x = x_new;
        r = r_next;
        if !inf_norm(&re_vec(&r)).is_finite() {
            return Err(fail(it, &r));
        }
        // Converged: a tiny full Newton step, or (with a Jacobian taken at this iterate) a small
        // one that no longer contracts: the rounding floor of a stiff residual.
        let contraction = step / last_dx;
        if alpha == 1.0
            && (step <= NEWTON_TOL * scale || (fresh && step <= 1e-7 * scale && contraction > 0.5))
        {
            return Ok(x);
        }
        // Slow contraction or a damped step: a fresh Jacobian next time.
        if alpha < 1.0 || contraction > 0.25 {
            refresh = true;
        }
        // Heavily damped steps one after another: the iterate is far from the solution's basin
        // (contact onset within the step); give up early, the caller subdivides the step.
        crawling = if alpha < 1.0 / 64.0 { crawling + 1 } else { 0 };
        if crawling >= 4 {
            return Err(fail(it, &r));
        }
        last_dx = step;
    }
    Err(fail(NEWTON_MAX_ITER, &r))
}

fn re_vec<T: Scalar>(x: &[T]) -> Vec<f64> {
    x.iter().map(|a| a.re()).collect()
}

fn re_params<T: Scalar>(p: &ContactParams<T>) -> ContactParams<f64> {
    ContactParams {
        eps1: p.eps1.re(),
        eps2: p.eps2.re(),
        eps3: p.eps3.re(),
        stiffness: p.stiffness.re(),
        dissipation_velocity: p.dissipation_velocity.re(),
        stiction_velocity: p.stiction_velocity.re(),
        friction: p.friction.re(),
        dissipation: p.dissipation,
    }
}

fn sq_norm(x: &[f64]) -> f64 {
    x.iter().map(|a| a * a).sum()
}

fn inf_norm(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |m, a| m.max(a.abs()))
}

impl Model {
    /// One internal step of length `h` (s) with the model's integrator.
    pub fn step<T: Scalar>(
        &self,
        state: &State<T>,
        u: &[T],
        prm: &ContactParams<T>,
        h: T,
    ) -> Result<State<T>, DynamicsError> {
        self.step_with(self.integrator, state, u, prm, h)
    }

    fn accel<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        u: &[T],
        prm: &ContactParams<T>,
    ) -> Result<Vec<T>, DynamicsError> {
        Ok(self.forward(q, v, u, prm)?.vdot.iter().copied().collect())
    }

    /// Accelerations with the joints' damping implicit over a step `h` (MuJoCo's `Euler`).
    fn damped_accel<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        u: &[T],
        prm: &ContactParams<T>,
        h: T,
    ) -> Result<Vec<T>, DynamicsError> {
        let (ctrl, mocap) = self.split_inputs(u)?;
        let tau = self.actuator_forces(q, v, ctrl);
        let f = self.forward_damped(q, v, tau.as_slice(), mocap, prm, Some(h))?;
        Ok(f.vdot.iter().copied().collect())
    }

    /// One step of length `h` (s) of `integrator` from `state` with inputs `u` at the start of
    /// the step ([`Model::nu`]; mocap bodies move on with their velocity during the step). For
    /// `dopri5`, the 5th-order solution of one step of exactly this length (no error control:
    /// that is [`Model::advance`]).
    pub fn step_with<T: Scalar>(
        &self,
        integrator: Integrator,
        state: &State<T>,
        u: &[T],
        prm: &ContactParams<T>,
        h: T,
    ) -> Result<State<T>, DynamicsError> {
        match integrator {
            Integrator::ImplicitEuler => self.implicit_euler_step(state, u, prm, h, &mut None),
            Integrator::Dopri5 => Ok(self.dopri5_step(state, u, prm, h, None)?.state),
            _ => self.explicit_step(integrator, state, u, prm, h, None),
        }
    }

    /// Euler, semi-implicit Euler or RK4; `a0`: the acceleration at the start, if known.
    fn explicit_step<T: Scalar>(
        &self,
        integrator: Integrator,
        state: &State<T>,
        u: &[T],
        prm: &ContactParams<T>,
        h: T,
        a0: Option<Vec<T>>,
    ) -> Result<State<T>, DynamicsError> {
        let tree = &self.tree;
        let (q1, v1) = (&state.q, &state.v);
        let dv1 = match a0 {
            _ if integrator == Integrator::DampedEuler => self.damped_accel(q1, v1, u, prm, h)?,
            Some(a) => a,
            None => self.accel(q1, v1, u, prm)?,
        };
        match integrator {
            Integrator::Euler => Ok(State {
                q: tree.integrate_q(q1, v1, h),
                v: axpy(v1, h, &dv1),
            }),
            Integrator::SemiImplicitEuler | Integrator::DampedEuler => {
                let v = axpy(v1, h, &dv1);
                Ok(State {
                    q: tree.integrate_q(q1, &v, h),
                    v,
                })
            }
            _ => {
                let half = h * 0.5;
                let (u_half, u_end) = (self.inputs_after(u, half), self.inputs_after(u, h));
                let dq1 = tree.qdot(q1, v1);
                let (q2, v2) = (axpy(q1, half, &dq1), axpy(v1, half, &dv1));
                let (dq2, dv2) = (tree.qdot(&q2, &v2), self.accel(&q2, &v2, &u_half, prm)?);
                let (q3, v3) = (axpy(q1, half, &dq2), axpy(v1, half, &dv2));
                let (dq3, dv3) = (tree.qdot(&q3, &v3), self.accel(&q3, &v3, &u_half, prm)?);
                let (q4, v4) = (axpy(q1, h, &dq3), axpy(v1, h, &dv3));
                let (dq4, dv4) = (tree.qdot(&q4, &v4), self.accel(&q4, &v4, &u_end, prm)?);
                let w = [1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0];
                let mut q = combine(
                    q1,
                    h,
                    &[(w[0], &dq1), (w[1], &dq2), (w[2], &dq3), (w[3], &dq4)],
                );
                tree.normalize_q(&mut q);
                Ok(State {
                    q,
                    v: combine(
                        v1,
                        h,
                        &[(w[0], &dv1), (w[1], &dv2), (w[2], &dv3), (w[3], &dv4)],
                    ),
                })
            }
        }
    }

    /// One Dormand–Prince 5(4) step of length `h`; `first`: `(q̇, v̇)` at the start if known
    /// (the last stage of the previous step).
    pub fn dopri5_step<T: Scalar>(
        &self,
        state: &State<T>,
        u: &[T],
        prm: &ContactParams<T>,
        h: T,
        first: Option<(Vec<T>, Vec<T>)>,
    ) -> Result<Dopri5Step<T>, DynamicsError> {
        let tree = &self.tree;
        let (nq, nv) = (tree.nq, tree.nv);
        let mut kq: Vec<Vec<T>> = Vec::with_capacity(7);
        let mut kv: Vec<Vec<T>> = Vec::with_capacity(7);
        let (dq0, dv0) = match first {
            Some(f) => f,
            None => (
                tree.qdot(&state.q, &state.v),
                self.accel(&state.q, &state.v, u, prm)?,
            ),
        };
        kq.push(dq0);
        kv.push(dv0);
        for s in 1..6 {
            let a = dp::A[s];
            let tq: Vec<(f64, &[T])> = a.iter().zip(&kq).map(|(&x, k)| (x, k.as_slice())).collect();
            let tv: Vec<(f64, &[T])> = a.iter().zip(&kv).map(|(&x, k)| (x, k.as_slice())).collect();
            let q = combine(&state.q, h, &tq);
            let v = combine(&state.v, h, &tv);
            let us = self.inputs_after(u, h * dp::C[s]);
            kq.push(tree.qdot(&q, &v));
            kv.push(self.accel(&q, &v, &us, prm)?);
        }
        let tq: Vec<(f64, &[T])> = dp::B
            .iter()
            .zip(&kq)
            .map(|(&x, k)| (x, k.as_slice()))
            .collect();
        let tv: Vec<(f64, &[T])> = dp::B
            .iter()
            .zip(&kv)
            .map(|(&x, k)| (x, k.as_slice()))
            .collect();
        let mut q = combine(&state.q, h, &tq);
        tree.normalize_q(&mut q);
        let v = combine(&state.v, h, &tv);
        let u_end = self.inputs_after(u, h);
        let last = (tree.qdot(&q, &v), self.accel(&q, &v, &u_end, prm)?);
        kq.push(last.0.clone());
        kv.push(last.1.clone());
        let zq = vec![T::zero(); nq];
        let zv = vec![T::zero(); nv];
        let eq: Vec<(f64, &[T])> = dp::E
            .iter()
            .zip(&kq)
            .map(|(&x, k)| (x, k.as_slice()))
            .collect();
        let ev: Vec<(f64, &[T])> = dp::E
            .iter()
            .zip(&kv)
            .map(|(&x, k)| (x, k.as_slice()))
            .collect();
        let mut error = combine(&zq, h, &eq);
        error.extend(combine(&zv, h, &ev));
        Ok(Dopri5Step {
            state: State { q, v },
            error,
            last,
        })
    }

    /// One implicit Euler step ([`Integrator::ImplicitEuler`]): `V` solves
    /// `V = v0 + h v̇(q0 ⊕ h V, V)` with the inputs at the end of the step; the result is
    /// `(q0 ⊕ h V, V)`.
    ///
    /// Newton's method uses the exact Jacobian `∂r/∂V` from dual numbers (evaluated on real
    /// parts), a backtracking line search, and, in `f64`, keeps a Jacobian while the iterations
    /// contract fast. With a dual-number scalar every iteration takes a fresh Jacobian, so the
    /// dual parts of the converged solution are the implicit-function derivative of the step.
    ///
    /// `jac`: a Jacobian of the step equation from an earlier step of the same `h`, tried first
    /// and replaced when the iterations contract slowly; updated here.
    fn implicit_euler_step<T: Scalar>(
        &self,
        state: &State<T>,
        u: &[T],
        prm: &ContactParams<T>,
        h: T,
        jac: &mut Option<DMatrix<f64>>,
    ) -> Result<State<T>, DynamicsError> {
        let u1 = self.inputs_after(u, h);
        let residual = |x: &[T]| step_residual(self, &state.q, &state.v, h, &u1, prm, x);
        let real_jacobian = |x: &[f64]| -> Result<DMatrix<f64>, DynamicsError> {
            let f = StepResidual {
                model: self,
                q0: re_vec(&state.q),
                v0: re_vec(&state.v),
                h: h.re(),
                u: re_vec(&u1),
                prm: re_params(prm),
            };
            Ok(jacobian(&f, x)?.1)
        };
        let v = newton(&residual, &real_jacobian, state.v.clone(), jac)?;
        Ok(State {
            q: self.tree.integrate_q(&state.q, &v, h),
            v,
        })
    }

    /// An implicit step of `h`; when Newton's iterations fail (typically when contact starts
    /// within a step much longer than the contact's period), the step is done as two halves,
    /// recursively, down to `h / 2⁸`.
    #[allow(clippy::too_many_arguments)]
    fn implicit_step_subdividing(
        &self,
        s: &State<f64>,
        u: &[f64],
        prm: &ContactParams<f64>,
        h: f64,
        jac: &mut Option<DMatrix<f64>>,
        depth: usize,
        subdivided: &mut usize,
    ) -> Result<State<f64>, DynamicsError> {
        match self.implicit_euler_step(s, u, prm, h, jac) {
            Err(DynamicsError::NewtonFailed { .. }) if depth < 8 => {
                *subdivided += 1;
                let half = 0.5 * h;
                let mut sub = None;
                let mid = self.implicit_step_subdividing(
                    s,
                    u,
                    prm,
                    half,
                    &mut sub,
                    depth + 1,
                    subdivided,
                )?;
                self.implicit_step_subdividing(
                    &mid,
                    &self.inputs_after(u, half),
                    prm,
                    half,
                    &mut sub,
                    depth + 1,
                    subdivided,
                )
            }
            other => other,
        }
    }

    /// Name of the first non-finite coordinate of a state, if any ("the position of joint J" or
    /// "the velocity of joint J").
    pub fn first_non_finite(&self, s: &State<f64>) -> Option<String> {
        for j in &self.tree.joints {
            if (j.qadr..j.qadr + j.kind.nq()).any(|i| !s.q[i].is_finite()) {
                return Some(format!("the position of joint {}", j.name));
            }
            if (j.dadr..j.dadr + j.kind.nv()).any(|i| !s.v[i].is_finite()) {
                return Some(format!("the velocity of joint {}", j.name));
            }
        }
        None
    }

    /// Power of the actuators `τ_act · v` (W).
    fn actuator_power(&self, s: &State<f64>, ctrl: &[f64]) -> f64 {
        self.actuator_forces(&s.q, &s.v, ctrl)
            .iter()
            .zip(&s.v)
            .map(|(t, v)| t * v)
            .sum()
    }

    /// The guard's state at the start of a call from `state` at time `t0` (s), with the contacts
    /// there (`None`: none evaluated), continuing `ledger` if it was left at this state and
    /// these parameters. `None` when the energy is not finite (it cannot be judged).
    fn energy_monitor(
        &self,
        state: &State<f64>,
        ctrl: &[f64],
        prm: &ContactParams<f64>,
        contacts: Option<&[crate::contact::PairContact<f64>]>,
        t0: f64,
        ledger: Option<&EnergyLedger>,
    ) -> Option<EnergyMonitor> {
        let e = self.energy(&state.q, &state.v);
        let stored = contacts.map_or(0.0, |c| contact_energy(c, prm));
        let moving = e.kinetic + stored;
        let ledger = match ledger {
            Some(l) if l.at == *state && l.params == *prm => EnergyLedger {
                scale: l.scale.max(moving),
                ..l.clone()
            },
            _ => EnergyLedger {
                at: state.clone(),
                params: *prm,
                since: t0,
                reference: e.total() + stored,
                work: 0.0,
                gross_work: 0.0,
                scale: moving,
            },
        };
        (ledger.reference.is_finite() && ledger.scale.is_finite()).then(|| EnergyMonitor {
            ledger,
            power: self.actuator_power(state, ctrl),
            floor: self.moving_mass() * (self.tree.gravity.norm() * 1e-3 + 0.5 * 1e-4),
        })
    }

    /// Advances `state` by `duration` (s) from time `t0` (s, for messages) with inputs `u` at the
    /// start ([`Model::nu`]; mocap bodies move with their velocities): fixed-step methods in
    /// `n = ⌈duration / step⌉` equal internal steps, `dopri5` in adaptive steps with the last one
    /// clipped, so that the end lands exactly on `t0 + duration`.
    ///
    /// A step that produces a non-finite state, a dynamics error or (with
    /// [`AdvanceOptions::energy_guard`]) an energy growth no input explains fails the whole
    /// call: the caller keeps its state from before.
    pub fn advance(
        &self,
        state: &State<f64>,
        u: &[f64],
        prm: &ContactParams<f64>,
        t0: f64,
        duration: f64,
        opts: &AdvanceOptions,
    ) -> Result<Advanced, StepFailure> {
        self.advance_cached(
            state,
            u,
            prm,
            t0,
            duration,
            opts,
            &mut SolverCache::default(),
        )
    }

    /// [`Model::advance`] with a cache carried from one call to the next (the implicit
    /// method's Newton Jacobian): a caller that advances the state it got from the previous
    /// call saves a Jacobian per call. The cache only changes where Newton's iterations start,
    /// not what they converge to (to their tolerance); it is used only for the state and step
    /// it was left for, so a run is reproducible from any state.
    #[allow(clippy::too_many_arguments)]
    pub fn advance_cached(
        &self,
        state: &State<f64>,
        u: &[f64],
        prm: &ContactParams<f64>,
        t0: f64,
        duration: f64,
        opts: &AdvanceOptions,
        cache: &mut SolverCache,
    ) -> Result<Advanced, StepFailure> {
        self.split_inputs(u)
            .map_err(|error| StepFailure::Dynamics {
                time: t0,
                step: 0,
                h: 0.0,
                error,
            })?;
        let u = u.to_vec();
        let ctrl = &u[..self.actuators.len()];
        let mocap_moves = (0..self.tree.mocap.len()).any(|m| {
            u[self.actuators.len() + MOCAP_INPUTS * m + 7..][..6]
                .iter()
                .any(|&x| x != 0.0)
        });
        let guard = opts.energy_guard && !mocap_moves;
        // The first stage of the explicit methods is the forward dynamics at the start: computed
        // once here, it also gives the contact state for the energy guard.
        let needs_start = self.integrator != Integrator::ImplicitEuler || guard;
        let start = if needs_start {
            Some(self.forward(&state.q, &state.v, &u, prm).map_err(|error| {
                StepFailure::Dynamics {
                    time: t0,
                    step: 1,
                    h: 0.0,
                    error,
                }
            })?)
        } else {
            None
        };
        let mut monitor = guard
            .then(|| {
                self.energy_monitor(
                    state,
                    ctrl,
                    prm,
                    start.as_ref().map(|f| f.contacts.as_slice()),
                    t0,
                    cache.ledger.as_ref(),
                )
            })
            .flatten();
        let a0 = start.map(|f| f.vdot.iter().copied().collect::<Vec<f64>>());
        let mut report = Advanced {
            state: state.clone(),
            steps: 0,
            rejected: 0,
            subdivided: 0,
            min_step: f64::INFINITY,
            max_step: 0.0,
        };
        let check = |monitor: &mut Option<EnergyMonitor>,
                     s: &State<f64>,
                     t: f64,
                     step: usize,
                     h: f64|
         -> Result<(), StepFailure> {
            if let Some(quantity) = self.first_non_finite(s) {
                return Err(StepFailure::NonFinite {
                    time: t,
                    step,
                    h,
                    quantity,
                });
            }
            if let Some(m) = monitor.as_mut() {
                let e = self.energy(&s.q, &s.v);
                let p = self.actuator_power(s, ctrl);
                let dw = 0.5 * (m.power + p) * h;
                m.ledger.work += dw;
                m.ledger.gross_work += dw.abs();
                m.power = p;
                m.ledger.scale = m.ledger.scale.max(e.kinetic);
                let total = e.total();
                if !total.is_finite() || total > m.ledger.allowed(m.floor) {
                    let l = &m.ledger;
                    return Err(StepFailure::EnergyGrowth {
                        time: t,
                        step,
                        h,
                        since: l.since,
                        from: l.reference,
                        to: total,
                        input: l.work,
                        allowed: l.allowed(m.floor),
                    });
                }
            }
            Ok(())
        };
        // What the guard leaves for the next call: the balance so far, at the end state.
        let leave = |monitor: Option<EnergyMonitor>, end: &State<f64>| {
            monitor.map(|m| EnergyLedger {
                at: end.clone(),
                params: *prm,
                ..m.ledger
            })
        };
        if !self.integrator.is_adaptive() {
            let n = ((duration / self.step) * (1.0 - 1e-12)).ceil().max(1.0);
            // Refused before any work (the cast below would saturate, and internal steps would
            // grow past `step`; a state that stays finite would run for ages).
            if n.is_nan() || n > opts.max_steps as f64 {
                return Err(StepFailure::TooLong {
                    time: t0,
                    duration,
                    step: self.step,
                    steps: opts.max_steps,
                });
            }
            let n = n as usize;
            let dt = duration / n as f64;
            let mut s = state.clone();
            let mut first = a0;
            // The implicit method's Newton Jacobian, carried from step to step while it serves.
            let mut jac = match cache.left {
                Some((ref s_left, h_left)) if h_left == dt && s_left == state => {
                    cache.jacobian.take()
                }
                _ => None,
            };
            for k in 0..n {
                let t = t0 + (k + 1) as f64 * dt;
                let uk = self.inputs_after(&u, k as f64 * dt);
                let dyn_err = |error| StepFailure::Dynamics {
                    time: t0 + k as f64 * dt,
                    step: k + 1,
                    h: dt,
                    error,
                };
                s = match self.integrator {
                    Integrator::ImplicitEuler => self
                        .implicit_step_subdividing(
                            &s,
                            &uk,
                            prm,
                            dt,
                            &mut jac,
                            0,
                            &mut report.subdivided,
                        )
                        .map_err(dyn_err)?,
                    i => self
                        .explicit_step(i, &s, &uk, prm, dt, first.take())
                        .map_err(dyn_err)?,
                };
                check(&mut monitor, &s, t, k + 1, dt)?;
            }
            if self.integrator == Integrator::ImplicitEuler {
                cache.jacobian = jac;
                cache.left = Some((s.clone(), dt));
            }
            cache.ledger = leave(monitor, &s);
            report.state = s;
            report.steps = n;
            report.min_step = dt;
            report.max_step = dt;
            return Ok(report);
        }
        // Adaptive Dormand–Prince.
        let tol = self.tolerance;
        let mut s = state.clone();
        let mut elapsed = 0.0;
        let mut h = self.step.min(duration);
        let mut first = a0.map(|a| (self.tree.qdot(&state.q, &state.v), a));
        let mut rejected_last = false;
        loop {
            let remaining = duration - elapsed;
            let last = h >= remaining * (1.0 - 1e-9);
            if last {
                h = remaining;
            }
            let t = t0 + elapsed;
            let uk = self.inputs_after(&u, elapsed);
            let trial = self.dopri5_step(&s, &uk, prm, h, first.clone());
            let cause;
            let (err, out) = match trial {
                Ok(out) => {
                    cause = self
                        .first_non_finite(&out.state)
                        .map(|q| format!("made {q} non-finite"));
                    let x0 = s.q.iter().chain(&s.v);
                    let x1 = out.state.q.iter().chain(&out.state.v);
                    let sum: f64 = out
                        .error
                        .iter()
                        .zip(x0.zip(x1))
                        .map(|(e, (a, b))| (e / (tol * (1.0 + a.abs().max(b.abs())))).powi(2))
                        .sum();
                    let err = (sum / out.error.len().max(1) as f64).sqrt();
                    (if err.is_finite() { err } else { f64::INFINITY }, Some(out))
                }
                // A stage that cannot be evaluated (e.g. a non-finite stage state): reject.
                Err(e) => {
                    cause = Some(format!("failed: {e}"));
                    (f64::INFINITY, None)
                }
            };
            if report.steps + report.rejected >= opts.max_steps {
                return Err(StepFailure::TooManySteps {
                    time: t,
                    steps: opts.max_steps,
                });
            }
            match out {
                Some(out) if err <= 1.0 => {
                    report.steps += 1;
                    report.min_step = report.min_step.min(h);
                    report.max_step = report.max_step.max(h);
                    elapsed = if last { duration } else { elapsed + h };
                    check(&mut monitor, &out.state, t0 + elapsed, report.steps, h)?;
                    s = out.state;
                    first = Some(out.last);
                    if last {
                        cache.ledger = leave(monitor, &s);
                        report.state = s;
                        return Ok(report);
                    }
                    let grow = if err > 0.0 {
                        (0.9 * err.powf(-0.2)).clamp(0.2, 5.0)
                    } else {
                        5.0
                    };
                    h = (h * if rejected_last { grow.min(1.0) } else { grow }).min(self.step);
                    rejected_last = false;
                }
                _ => {
                    report.rejected += 1;
                    rejected_last = true;
                    h *= if err.is_finite() {
                        (0.9 * err.powf(-0.2)).clamp(0.1, 0.9)
                    } else {
                        0.1
                    };
                    if h < 1e-14 * (1.0 + t.abs()) || h < 1e-12 * duration {
                        return Err(StepFailure::StepTooSmall {
                            time: t,
                            h,
                            tolerance: tol,
                            cause,
                        });
                    }
                }
            }
        }
    }
}

/// What [`Model::advance_cached`] carries from one call to the next.
///
/// It changes the result in the last bits (Newton starts from another Jacobian) and which steps
/// the energy guard refuses (its [`EnergyLedger`]), so an FMU state that must reproduce a rollout
/// bit for bit, refusals included, carries it ([`SolverCache::parts`],
/// [`SolverCache::from_parts`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SolverCache {
    /// The implicit method's last Newton Jacobian.
    jacobian: Option<DMatrix<f64>>,
    /// The state and internal step the cache was left for.
    left: Option<CacheMark>,
    /// The energy guard's balance over the run so far.
    ledger: Option<EnergyLedger>,
}

/// Where a [`SolverCache`] was left: the state and the internal step (s).
pub type CacheMark = (State<f64>, f64);

impl SolverCache {
    /// The cached Newton Jacobian, the state and internal step (s) it was left for, and the
    /// energy guard's ledger.
    pub fn parts(
        &self,
    ) -> (
        Option<&DMatrix<f64>>,
        Option<&CacheMark>,
        Option<&EnergyLedger>,
    ) {
        (
            self.jacobian.as_ref(),
            self.left.as_ref(),
            self.ledger.as_ref(),
        )
    }

    /// A cache from its [`parts`](SolverCache::parts).
    pub fn from_parts(
        jacobian: Option<DMatrix<f64>>,
        left: Option<CacheMark>,
        ledger: Option<EnergyLedger>,
    ) -> SolverCache {
        SolverCache {
            jacobian,
            left,
            ledger,
        }
    }
}

/// The energy balance the guard keeps over a run (see [`AdvanceOptions::energy_guard`]):
/// carried from one [`Model::advance_cached`] call to the next in the [`SolverCache`], so that
/// an energy that grows a little in every communication step is seen as it adds up.
#[derive(Clone, Debug, PartialEq)]
pub struct EnergyLedger {
    /// The state the ledger was left at; a call from any other state starts a new ledger.
    pub at: State<f64>,
    /// The contact parameters it was kept with; other parameters start a new ledger (they
    /// change the energy stored in contact).
    pub params: ContactParams<f64>,
    /// Time the ledger started (s, for messages).
    pub since: f64,
    /// Energy at the start, `E + U` (J): mechanical energy and the estimate of the energy
    /// stored in contact ([`contact_energy`]).
    pub reference: f64,
    /// Work of the actuators since the start (J, trapezoidal rule on the internal steps).
    pub work: f64,
    /// Sum of the magnitudes of that work's increments (J): what its rounding scales with.
    pub gross_work: f64,
    /// Largest energy in motion seen: `T + U` at the start of each call, `T` after every
    /// internal step (J).
    pub scale: f64,
}

impl EnergyLedger {
    /// The most mechanical energy a state may have (J), given the energy floor `floor` (J):
    /// `E₀ + U₀ + W + ½ (S + Σ|ΔW|) + E_floor` ([`AdvanceOptions::energy_guard`]).
    fn allowed(&self, floor: f64) -> f64 {
        self.reference + self.work + 0.5 * (self.scale + self.gross_work) + floor
    }
}

/// The guard's working state during one [`Model::advance`] call.
struct EnergyMonitor {
    /// The balance since the ledger started.
    ledger: EnergyLedger,
    /// Actuator power at the last internal step (W).
    power: f64,
    /// Energy below which growth is not judged (J).
    floor: f64,
}

/// An estimate of the elastic energy stored in the contacts `contacts` (J), per pair the
/// larger of `ε3 |F| + |F|²/(2k)` (`F`: the force between the two bodies) and `k D²` (`D < 0`:
/// the smooth penetration).
///
/// A point–plane spring `k s`, `s = s⁺_ε3(-φ)`, stores `k ε3² P(φ/ε3)`, with
/// `P(y) = ∫_y^∞ ln(1 + e^{-t}) dt = -Li₂(-e^{-y})` (the work its force does as the point
/// leaves to infinity); `k (ε3 s + ½ s²)` has the same tails (`k ε3² e^{-y}` far out, `½ k φ²`
/// deep in) and lies between 1.00 and 1.25 times it for every `φ` (checked numerically on
/// `y ∈ [-20, 20]`). A pair's force is such springs averaged by the softmax weights, times the
/// dissipation factor, so with `s = |F|/k` this is an estimate, not a bound: it reads high
/// while the bodies approach (damping adds to `|F|`) and low where forces of one pair cancel
/// (one body inside another: the `k D²` term covers that). The old per-step bound `k (D² + ε3²)`
/// allowed `k ε3²` for every pair in reach however far apart (10 J at `k = 1e9`, `ε3 = 1e-4`)
/// where a 1 kg sphere resting on a plane stores about `ε3 m g ≈ 1 mJ`.
pub fn contact_energy(
    contacts: &[crate::contact::PairContact<f64>],
    prm: &ContactParams<f64>,
) -> f64 {
    let k = prm.stiffness;
    contacts
        .iter()
        .filter(|pc| pc.distance.is_finite())
        .map(|pc| {
            let f = pc.on_a.force.norm();
            let deep = (-pc.distance).max(0.0);
            (prm.eps3 * f + f * f / (2.0 * k)).max(k * deep * deep)
        })
        .sum()
}

/// Options of [`Model::advance`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdvanceOptions {
    /// Refuse a communication step whose mechanical energy grows beyond what was put in.
    ///
    /// Without mocap motion, the energy `H = T + V_gravity + V_springs + U` (`U`: the elastic
    /// energy stored in contact) can only grow by the actuators' work `W = ∫ τ_act·v dt`
    /// (contact damping, friction, joint damping and frictionloss dissipate). An explicit
    /// integrator on stiff contact adds energy at every bounce; this guard refuses the step
    /// long before the state overflows, and, since it keeps its balance over the whole run
    /// ([`EnergyLedger`], carried in the [`SolverCache`]), also when the energy grows by a
    /// little in every communication step. The test, after every internal step, is
    /// `E > E₀ + U₀ + W + ½ (S + Σ|ΔW|) + E_floor`, with `E₀ + U₀` the energy where the ledger
    /// started (`U` estimated by [`contact_energy`]), `S` the largest energy in motion seen
    /// since (`T + U` at the start of each call, `T` after each internal step), `Σ|ΔW|` the
    /// actuators' work counted without sign and `E_floor` the energy of raising every moving
    /// body by 1 mm and moving it at 1 cm/s. The half margin covers the integrators' legitimate
    /// energy errors (trapezoidal work, `O(hᵖ)` drift, the estimate of `U`); a blow-up creates
    /// energy in motion from nothing and exceeds it once that is about twice what the run had
    /// before. The ledger restarts whenever a call starts from another state than the last one
    /// ended at, or with other contact parameters (the host set them: energy the guard cannot
    /// account for). Mocap bodies put in energy the guard cannot bound: it is off while one
    /// moves.
    pub energy_guard: bool,
    /// Most internal steps (accepted and rejected) an adaptive advance may take, and most
    /// internal steps a fixed-step advance may be split into.
    pub max_steps: usize,
}

impl Default for AdvanceOptions {
    fn default() -> Self {
        AdvanceOptions {
            energy_guard: true,
            max_steps: 1_000_000,
        }
    }
}

/// Result of [`Model::advance`].
#[derive(Clone, Debug, PartialEq)]
pub struct Advanced {
    /// State at the end.
    pub state: State<f64>,
    /// Accepted internal steps.
    pub steps: usize,
    /// Rejected internal steps (adaptive only).
    pub rejected: usize,
    /// Implicit steps redone as two halves because Newton's iterations failed.
    pub subdivided: usize,
    /// Smallest accepted internal step (s).
    pub min_step: f64,
    /// Largest accepted internal step (s).
    pub max_step: f64,
}

/// Why [`Model::advance`] refused to go on; times are absolute (s).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StepFailure {
    /// The dynamics could not be evaluated.
    #[error("internal step {step} (h = {h} s) from t = {time} s failed: {error}")]
    Dynamics {
        /// Start of the internal step (s).
        time: f64,
        /// Internal step (1-based).
        step: usize,
        /// Internal step size (s).
        h: f64,
        /// The error.
        error: DynamicsError,
    },
    /// A coordinate of the state became NaN or infinite.
    #[error("the state diverged: {quantity} became non-finite at t = {time} s (internal step {step}, h = {h} s)")]
    NonFinite {
        /// End of the internal step (s).
        time: f64,
        /// Internal step (1-based).
        step: usize,
        /// Internal step size (s).
        h: f64,
        /// Which coordinate ("the velocity of joint J").
        quantity: String,
    },
    /// The mechanical energy grew beyond what inputs and stored contact energy explain.
    #[error("the integration is unstable: the energy was {from:.6e} J at t = {since} s (stored contact energy included); by t = {time} s (internal step {step}, h = {h} s) it reached {to:.6e} J, above the {allowed:.6e} J that the actuators' work ({input:.3e} J) and the guard's margin allow")]
    EnergyGrowth {
        /// End of the internal step (s).
        time: f64,
        /// Internal step (1-based).
        step: usize,
        /// Internal step size (s).
        h: f64,
        /// Time the energy balance started (s).
        since: f64,
        /// Energy where the balance started, stored contact energy included (J).
        from: f64,
        /// Energy reached (J).
        to: f64,
        /// Actuators' work since then (J).
        input: f64,
        /// Most energy allowed (J).
        allowed: f64,
    },
    /// The adaptive step fell to a size that can no longer advance.
    #[error("the adaptive step fell to {h:e} s at t = {time} s without meeting the tolerance {tolerance:e}{}", cause.as_ref().map(|c| format!(": the last trial step {c}")).unwrap_or_else(|| " (stiff contact? try implicit_euler)".into()))]
    StepTooSmall {
        /// Time reached (s).
        time: f64,
        /// Last step tried (s).
        h: f64,
        /// `solver.tolerance`.
        tolerance: f64,
        /// What went wrong in the last trial, if more than the tolerance ("made the velocity of
        /// joint J non-finite", "failed: …").
        cause: Option<String>,
    },
    /// A fixed-step advance would need more than [`AdvanceOptions::max_steps`] internal steps;
    /// refused before any step is taken.
    #[error("a step of {duration:e} s from t = {time} s would need more than {steps} internal steps of {step:e} s: split it into shorter communication steps")]
    TooLong {
        /// Start of the refused advance (s).
        time: f64,
        /// The requested duration (s).
        duration: f64,
        /// The internal step (s).
        step: f64,
        /// The limit.
        steps: usize,
    },
    /// The adaptive method needed too many steps.
    #[error(
        "more than {steps} internal steps by t = {time} s (stiff contact? try implicit_euler)"
    )]
    TooManySteps {
        /// Time reached (s).
        time: f64,
        /// The limit.
        steps: usize,
    },
}
