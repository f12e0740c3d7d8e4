//! Newton's method for the implicit steps (implicit Euler's step equation, damped Euler's
//! velocity-implicit contact): a real Jacobian kept while it serves, backtracking on the
//! residual's norm, and a fresh Jacobian at every iteration on dual numbers so that the
//! derivatives of the solution are exact.

use crate::contact::ContactParams;
use crate::model::DynamicsError;
use crate::scalar::Scalar;
use nalgebra::DMatrix;
use std::any::TypeId;

/// Newton iterations of an implicit stage: tolerance and limits.
const NEWTON_TOL: f64 = 1e-10;
const NEWTON_MAX_ITER: usize = 40;

/// A residual function of the implicit step, on the scalar type.
type Residual<'a, T> = dyn Fn(&[T]) -> Result<Vec<T>, DynamicsError> + 'a;
/// The Jacobian of a residual at real values.
type RealJacobian<'a> = dyn Fn(&[f64]) -> Result<DMatrix<f64>, DynamicsError> + 'a;

/// Newton's method for `residual(x) = 0` from `guess`, with a real Jacobian (see
/// [`Integrator::ImplicitEuler`](crate::integrator::Integrator::ImplicitEuler)): backtracking line search; in `f64` a Jacobian is kept (also from
/// the caller's `jac`) while the iterations contract by 4 or more per step; with dual numbers a
/// fresh one every iteration.
pub(super) fn newton<T: Scalar>(
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

pub(super) fn re_vec<T: Scalar>(x: &[T]) -> Vec<f64> {
    x.iter().map(|a| a.re()).collect()
}

pub(super) fn re_params<T: Scalar>(p: &ContactParams<T>) -> ContactParams<f64> {
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
