//! One internal step of each integrator, generic over the scalar so that exact derivatives of a
//! step come from the same code.

use super::newton::{newton, re_vec, KeptJacobian};
use crate::autodiff::{jacobian, VectorFunction};
use crate::collision::PairsKept;
use crate::contact::ContactParams;
use crate::integrator::{Integrator, State};
use crate::model::{DynamicsError, Model};
use crate::scalar::{c, Scalar};
use nalgebra::DMatrix;
use std::any::TypeId;
use std::cell::RefCell;

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
            None,
        )
    }
}

/// Damped Euler's step equation in the end velocity, on real values (for its Jacobian): see
/// [`Model::damped_euler_velocity`].
struct ContactImplicitResidual<'a> {
    model: &'a Model,
    q: Vec<f64>,
    v: Vec<f64>,
    tau: Vec<f64>,
    mocap: Vec<f64>,
    prm: ContactParams<f64>,
    h: f64,
}

impl VectorFunction for ContactImplicitResidual<'_> {
    fn eval<T: Scalar>(&self, x: &[T]) -> Result<Vec<T>, DynamicsError> {
        let lift = |v: &[f64]| v.iter().map(|&a| c::<T>(a)).collect::<Vec<T>>();
        let (q, v) = (lift(&self.q), lift(&self.v));
        let a = self
            .model
            .forward_contact_at(
                &q,
                &v,
                Some(x),
                &lift(&self.tau),
                &lift(&self.mocap),
                &self.prm.lift(),
                Some(c(self.h)),
            )?
            .vdot;
        Ok((0..x.len()).map(|k| x[k] - v[k] - a[k] * self.h).collect())
    }
}

#[allow(clippy::too_many_arguments)]
fn step_residual<T: Scalar>(
    model: &Model,
    q0: &[T],
    v0: &[T],
    h: T,
    u: &[T],
    prm: &ContactParams<T>,
    vs: &[T],
    kept: Option<&RefCell<&mut PairsKept>>,
) -> Result<Vec<T>, DynamicsError> {
    let q = model.tree.integrate_q(q0, vs, h);
    let a = match kept {
        Some(kept) => {
            model
                .forward_candidates(&q, vs, u, prm, &mut kept.borrow_mut())?
                .vdot
        }
        None => model.forward(&q, vs, u, prm)?.vdot,
    };
    Ok((0..vs.len()).map(|k| vs[k] - v0[k] - h * a[k]).collect())
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

    /// Damped Euler's velocity at the end of a step `h` ([`Integrator::DampedEuler`]): `V`
    /// solves `(M + h D)(V - v) = h (τ + τ_passive - c + Σ Λ(q, V))`, every term at the start
    /// `(q, v)` but the contact forces `Λ`, taken at `V`. The joints' damping is implicit as in
    /// MuJoCo's `Euler`; the contact's velocity dependence (its damping, and friction, which is
    /// a damper `μ F / v_s` near rest) is implicit as MuJoCo's constraint solver makes it: a
    /// stiff position actuator pressing a light finger on a block (`μ F / (v_s m)` in the
    /// thousands per second at 2 ms steps) rings and blows up with the contact explicit.
    ///
    /// Without a pair in reach at the start, the step is explicit (contact-free, it is
    /// MuJoCo's `Euler` exactly). Otherwise Newton's iterations from the explicit step, on
    /// the real Jacobian from dual numbers, as [`Integrator::ImplicitEuler`]'s (with dual
    /// numbers a fresh one at every iteration, so the derivatives of the step are exact). In
    /// `f64`, `jac` carries the last real Jacobian from step to step while it serves (Newton
    /// takes a fresh one when the iterations stop contracting), as for implicit Euler; `kept`,
    /// the pairs' kept out-of-reach proofs and candidate planes, serves the frozen contact.
    #[allow(clippy::too_many_arguments)]
    fn damped_euler_velocity<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        u: &[T],
        prm: &ContactParams<T>,
        h: T,
        jac: &mut Option<KeptJacobian>,
        kept: Option<&mut PairsKept>,
    ) -> Result<Vec<T>, DynamicsError> {
        let (ctrl, mocap) = self.split_inputs(u)?;
        let tau = self
            .actuator_forces_at(q, v, ctrl, mocap)
            .as_slice()
            .to_vec();
        let real = ContactImplicitResidual {
            model: self,
            q: re_vec(q),
            v: re_vec(v),
            tau: re_vec(&tau),
            mocap: re_vec(mocap),
            prm: prm.re(),
            h: h.re(),
        };
        let real_jacobian =
            |x: &[f64]| -> Result<DMatrix<f64>, DynamicsError> { Ok(jacobian(&real, x)?.1) };
        if TypeId::of::<T>() == TypeId::of::<f64>() {
            // Values only: everything but the contact's velocities is frozen at the start of the
            // step, each pair's contact terms recorded there and replayed at each trial end
            // velocity (`FrozenForward`); the same arithmetic as `forward_contact_at`.
            let mut kept = kept;
            if let Some(all) = kept.as_deref_mut() {
                all.fit(self.pairs.len());
            }
            let (frozen, a0) = self.frozen_forward_kept(
                &real.q,
                &real.v,
                &real.tau,
                &real.mocap,
                &real.prm,
                real.h,
                kept,
            )?;
            let explicit: Vec<T> = (0..v.len()).map(|k| v[k] + h * c::<T>(a0[k])).collect();
            if frozen.contact_free() {
                return Ok(explicit);
            }
            let residual = |x: &[T]| -> Result<Vec<T>, DynamicsError> {
                let a = frozen.vdot(&re_vec(x));
                Ok((0..x.len())
                    .map(|k| x[k] - v[k] - h * c::<T>(a[k]))
                    .collect())
            };
            return newton(&residual, &real_jacobian, explicit, jac);
        }
        let start = self.forward_damped(q, v, &tau, mocap, prm, Some(h))?;
        let explicit = axpy(v, h, start.vdot.as_slice());
        if start.contacts.iter().all(Option::is_none) {
            return Ok(explicit);
        }
        let residual = |x: &[T]| -> Result<Vec<T>, DynamicsError> {
            let a = self
                .forward_contact_at(q, v, Some(x), &tau, mocap, prm, Some(h))?
                .vdot;
            Ok((0..x.len()).map(|k| x[k] - v[k] - h * a[k]).collect())
        };
        newton(&residual, &real_jacobian, explicit, jac)
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
            Integrator::ImplicitEuler => {
                self.implicit_euler_step(state, u, prm, h, &mut None, None, None)
            }
            Integrator::Dopri5 => Ok(self.dopri5_step(state, u, prm, h, None)?.state),
            _ => self.explicit_step(integrator, state, u, prm, h, None, &mut None, None),
        }
    }

    /// Euler, semi-implicit Euler, damped Euler or RK4; `a0`: the acceleration at the start, if
    /// known; `jac`: damped Euler's Newton Jacobian, carried between steps; `kept`: the pairs'
    /// kept out-of-reach proofs and candidate planes, used by damped Euler's frozen contact
    /// (values only), and their candidate planes by RK4's later stages.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn explicit_step<T: Scalar>(
        &self,
        integrator: Integrator,
        state: &State<T>,
        u: &[T],
        prm: &ContactParams<T>,
        h: T,
        a0: Option<Vec<T>>,
        jac: &mut Option<KeptJacobian>,
        kept: Option<&mut PairsKept>,
    ) -> Result<State<T>, DynamicsError> {
        let tree = &self.tree;
        let (q1, v1) = (&state.q, &state.v);
        if integrator == Integrator::DampedEuler {
            let v = self.damped_euler_velocity(q1, v1, u, prm, h, jac, kept)?;
            return Ok(State {
                q: tree.integrate_q(q1, &v, h),
                v,
            });
        }
        // The later stages (RK4's) with the pairs' kept candidate planes: the same results,
        // at less cost (their proofs fresh, as everywhere but at a step's start).
        let mut kept = kept;
        let mut accel = |q: &[T], v: &[T], u: &[T]| match kept.as_deref_mut() {
            Some(kept) => Ok(self
                .forward_candidates(q, v, u, prm, kept)?
                .vdot
                .iter()
                .copied()
                .collect()),
            None => self.accel(q, v, u, prm),
        };
        let dv1 = match a0 {
            Some(a) => a,
            None => accel(q1, v1, u)?,
        };
        match integrator {
            Integrator::Euler => Ok(State {
                q: tree.integrate_q(q1, v1, h),
                v: axpy(v1, h, &dv1),
            }),
            Integrator::SemiImplicitEuler => {
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
                let (dq2, dv2) = (tree.qdot(&q2, &v2), accel(&q2, &v2, &u_half)?);
                let (q3, v3) = (axpy(q1, half, &dq2), axpy(v1, half, &dv2));
                let (dq3, dv3) = (tree.qdot(&q3, &v3), accel(&q3, &v3, &u_half)?);
                let (q4, v4) = (axpy(q1, h, &dq3), axpy(v1, h, &dv3));
                let (dq4, dv4) = (tree.qdot(&q4, &v4), accel(&q4, &v4, &u_end)?);
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
    /// and replaced when the iterations contract slowly; updated here. `guess`: the velocity
    /// change `V - v` Newton starts from (none: `V = v`).
    #[allow(clippy::too_many_arguments)]
    fn implicit_euler_step<T: Scalar>(
        &self,
        state: &State<T>,
        u: &[T],
        prm: &ContactParams<T>,
        h: T,
        jac: &mut Option<KeptJacobian>,
        guess: Option<&[f64]>,
        kept: Option<&mut PairsKept>,
    ) -> Result<State<T>, DynamicsError> {
        let u1 = self.inputs_after(u, h);
        let kept = kept.map(RefCell::new);
        let residual =
            |x: &[T]| step_residual(self, &state.q, &state.v, h, &u1, prm, x, kept.as_ref());
        let real_jacobian = |x: &[f64]| -> Result<DMatrix<f64>, DynamicsError> {
            let f = StepResidual {
                model: self,
                q0: re_vec(&state.q),
                v0: re_vec(&state.v),
                h: h.re(),
                u: re_vec(&u1),
                prm: prm.re(),
            };
            Ok(jacobian(&f, x)?.1)
        };
        let start = match guess {
            Some(dv) if dv.len() == state.v.len() => {
                (0..dv.len()).map(|k| state.v[k] + c::<T>(dv[k])).collect()
            }
            _ => state.v.clone(),
        };
        let v = newton(&residual, &real_jacobian, start, jac)?;
        Ok(State {
            q: self.tree.integrate_q(&state.q, &v, h),
            v,
        })
    }

    /// An implicit step of `h` from the carried Newton Jacobian `jac` and, in `dv`, the last
    /// step's velocity change `V - v`: Newton starts from `v + dv` (the acceleration held over
    /// the step: the start is `O(h²)` from the solution where motion is smooth, where `v` is
    /// `O(h)`). Where Newton fails from there (after an impact the last change says little),
    /// the step is tried again from `v`, then subdivided as without a guess. `dv` is left with
    /// this step's change, or none when the step was subdivided (its halves' changes say
    /// nothing of the next full step).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn implicit_step_extrapolating(
        &self,
        s: &State<f64>,
        u: &[f64],
        prm: &ContactParams<f64>,
        h: f64,
        jac: &mut Option<KeptJacobian>,
        dv: &mut Option<Vec<f64>>,
        subdivided: &mut usize,
        mut kept: Option<&mut PairsKept>,
    ) -> Result<State<f64>, DynamicsError> {
        let guessed = match dv.take() {
            Some(guess) => {
                match self.implicit_euler_step(s, u, prm, h, jac, Some(&guess), kept.as_deref_mut())
                {
                    Err(DynamicsError::NewtonFailed { .. }) => None,
                    other => Some(other?),
                }
            }
            None => None,
        };
        let before = *subdivided;
        let next = match guessed {
            Some(next) => next,
            None => self.implicit_step_subdividing(
                Integrator::ImplicitEuler,
                s,
                u,
                prm,
                h,
                jac,
                0,
                subdivided,
                kept,
            )?,
        };
        *dv =
            (*subdivided == before).then(|| next.v.iter().zip(&s.v).map(|(a, b)| a - b).collect());
        Ok(next)
    }

    /// An implicit step of `h` of `integrator` ([`Integrator::ImplicitEuler`], or
    /// [`Integrator::DampedEuler`], implicit in the contact's velocities); when Newton's
    /// iterations fail (typically when contact starts within a step much longer than the
    /// contact's period), the step is done as two halves of the same method, recursively, down
    /// to `h / 2⁸`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn implicit_step_subdividing(
        &self,
        integrator: Integrator,
        s: &State<f64>,
        u: &[f64],
        prm: &ContactParams<f64>,
        h: f64,
        jac: &mut Option<KeptJacobian>,
        depth: usize,
        subdivided: &mut usize,
        mut kept: Option<&mut PairsKept>,
    ) -> Result<State<f64>, DynamicsError> {
        let step = match integrator {
            Integrator::DampedEuler => {
                self.explicit_step(integrator, s, u, prm, h, None, jac, kept.as_deref_mut())
            }
            _ => self.implicit_euler_step(s, u, prm, h, jac, None, kept.as_deref_mut()),
        };
        match step {
            Err(DynamicsError::NewtonFailed { .. }) if depth < 8 => {
                *subdivided += 1;
                let half = 0.5 * h;
                let mut sub = None;
                let mid = self.implicit_step_subdividing(
                    integrator,
                    s,
                    u,
                    prm,
                    half,
                    &mut sub,
                    depth + 1,
                    subdivided,
                    kept.as_deref_mut(),
                )?;
                self.implicit_step_subdividing(
                    integrator,
                    &mid,
                    &self.inputs_after(u, half),
                    prm,
                    half,
                    &mut sub,
                    depth + 1,
                    subdivided,
                    kept,
                )
            }
            other => other,
        }
    }
}
