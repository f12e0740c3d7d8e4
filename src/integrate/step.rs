//! One internal step of each integrator, generic over the scalar so that exact derivatives of a
//! step come from the same code: the explicit ones and `dopri5` here, the implicit ones (and
//! damped Euler's velocity) in `implicit.rs`.

use super::cache::StepCarry;
use super::implicit::StartContacts;
use crate::contact::ContactParams;
use crate::integrator::{Integrator, State};
use crate::model::{DynamicsError, ForwardOptions, Model, Reuse};
use crate::scalar::Scalar;

/// One internal step's problem: from `state` over `h`, with the inputs `u` ([`Model::nu`]; at
/// the step's start, but in implicit Euler's residual, which reads them at its end) and the
/// contact parameters `prm`.
pub(super) struct StepFrom<'a, T: Scalar> {
    pub(super) state: &'a State<T>,
    pub(super) u: &'a [T],
    pub(super) prm: &'a ContactParams<T>,
    pub(super) h: T,
}

// By hand: a derive would ask `ContactParams<T>: Copy` of the reference's target.
impl<T: Scalar> Clone for StepFrom<'_, T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T: Scalar> Copy for StepFrom<'_, T> {}

pub(super) fn axpy<T: Scalar>(x: &[T], a: T, y: &[T]) -> Vec<T> {
    x.iter().zip(y).map(|(&xi, &yi)| xi + a * yi).collect()
}

/// A Runge–Kutta stage's acceleration at `(q, v)` with the stage's inputs.
type StageAccel<'a, T> = dyn FnMut(&[T], &[T], &[T]) -> Result<Vec<T>, DynamicsError> + 'a;

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
    /// Embedded error estimate `h Σ (b_j - b*_j) k_j`, positions, velocities, then activations.
    pub error: Vec<T>,
    /// `q̇` and `v̇` at the solution (inputs at the end of the step).
    pub last: (Vec<T>, Vec<T>),
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
        self.check_activations(&state.act)?;
        self.split_inputs(u)?;
        let from = StepFrom { state, u, prm, h };
        let (mut jacobian, mut subdivided) = (None, 0);
        let carry = StepCarry {
            jacobian: &mut jacobian,
            pairs: None,
            subdivided: &mut subdivided,
            kinematics: None,
            contact_energy: None,
        };
        match integrator {
            Integrator::ImplicitEuler => self.implicit_euler_step(from, carry, None),
            Integrator::Dopri5 => Ok(self.dopri5_step(state, u, prm, h, None)?.state),
            _ => self.explicit_step(integrator, from, None, carry),
        }
    }

    /// Euler, semi-implicit Euler, damped Euler, RK4 or damped RK4; `a0`: the acceleration at
    /// the start, if known (never damped RK4's: its stages are damped Euler's); from `carry`:
    /// damped Euler's Newton Jacobian, carried between steps, and the pairs' kept out-of-reach
    /// proofs and candidate planes, used by damped Euler's frozen contact (values only), and
    /// their candidate planes by RK4's later stages.
    pub(super) fn explicit_step<T: Scalar>(
        &self,
        integrator: Integrator,
        from: StepFrom<'_, T>,
        a0: Option<Vec<T>>,
        carry: StepCarry<'_>,
    ) -> Result<State<T>, DynamicsError> {
        let StepFrom { state, prm, h, .. } = from;
        let tree = &self.tree;
        let (q1, v1) = (&state.q, &state.v);
        if integrator == Integrator::DampedRk4 {
            return self.damped_rk4_step(from, carry, None);
        }
        // The activations drive the force laws: the Euler family's at the step's start (or
        // end, `actearly`) for the whole step, RK4's at each stage.
        let (u, act) = self.euler_activations(&from);
        let u = u.as_slice();
        if integrator == Integrator::DampedEuler {
            let v = self.damped_euler_velocity(StepFrom { u, ..from }, carry, None, false, None)?;
            return Ok(State {
                q: tree.integrate_q(q1, &v, h),
                v,
                act,
            });
        }
        // The later stages (RK4's) with the pairs' kept proofs and candidate planes, as the
        // first stage.
        let mut kept = carry.pairs;
        let mut accel = |q: &[T], v: &[T], u: &[T]| -> Result<Vec<T>, DynamicsError> {
            let opts = ForwardOptions {
                reuse: kept.as_deref_mut().map_or(Reuse::Nothing, Reuse::All),
                ..ForwardOptions::default()
            };
            let f = self.forward_with(q, v, u, prm, opts)?;
            Ok(f.vdot.data.into())
        };
        let dv1 = match a0 {
            Some(a) => a,
            None => accel(q1, v1, u)?,
        };
        match integrator {
            Integrator::Euler => Ok(State {
                q: tree.integrate_q(q1, v1, h),
                v: axpy(v1, h, &dv1),
                act,
            }),
            Integrator::SemiImplicitEuler => {
                // `v + h v̇`, as `axpy` computes it, into the acceleration's vector.
                let mut v = dv1;
                for (a, &x) in v.iter_mut().zip(v1) {
                    *a = x + h * *a;
                }
                Ok(State {
                    q: tree.integrate_q(q1, &v, h),
                    v,
                    act,
                })
            }
            _ => self.rk4_stages(from, dv1, &mut accel),
        }
    }

    /// One damped RK4 step ([`Integrator::DampedRk4`]): classic RK4 whose stage accelerations
    /// are damped Euler's over the whole step from the stage's state, `(V - v)/h`
    /// ([`Model::damped_euler_velocity`]: the contact's damping and friction and the joints'
    /// frictionloss implicit in velocity; the joints' viscous damping and the limits, which
    /// have MuJoCo's impedance, explicit, as MuJoCo's RK4 takes them). The stages share
    /// the carried Newton Jacobian and the pairs' kept proofs and candidate planes; `at_start`
    /// receives the contacts at the first stage, as damped Euler's. A stage whose Newton
    /// iterations fail fails the step ([`Model::implicit_step_subdividing`] then halves it).
    pub(super) fn damped_rk4_step<T: Scalar>(
        &self,
        from: StepFrom<'_, T>,
        carry: StepCarry<'_>,
        at_start: Option<&mut Option<StartContacts>>,
    ) -> Result<State<T>, DynamicsError> {
        let StepFrom { state, prm, h, .. } = from;
        let (u, _) = self.euler_activations(&from);
        let StepCarry {
            jacobian,
            pairs: mut kept,
            subdivided,
            mut kinematics,
            ..
        } = carry;
        let mut at_start = at_start;
        // The stage before's acceleration: its end velocity from this stage's start is the
        // guess Newton's iterations start from, where it is nearer than the start velocity.
        let mut before: Option<Vec<f64>> = None;
        let mut accel = |q: &[T], v: &[T], u: &[T]| -> Result<Vec<T>, DynamicsError> {
            let stage = State {
                q: q.to_vec(),
                v: v.to_vec(),
                act: Vec::new(),
            };
            let carry = StepCarry {
                jacobian: &mut *jacobian,
                pairs: kept.as_deref_mut(),
                subdivided: &mut *subdivided,
                kinematics: kinematics.as_deref_mut(),
                contact_energy: None,
            };
            let from = StepFrom {
                state: &stage,
                u,
                prm,
                h,
            };
            let guess: Option<Vec<f64>> = (before.as_deref())
                .map(|a| v.iter().zip(a).map(|(v, a)| v.re() + h.re() * a).collect());
            let end =
                self.damped_euler_velocity(from, carry, at_start.take(), true, guess.as_deref())?;
            let dv: Vec<T> = end.iter().zip(v).map(|(&e, &v)| (e - v) / h).collect();
            before = Some(dv.iter().map(|a| a.re()).collect());
            Ok(dv)
        };
        let dv1 = accel(&state.q, &state.v, &u)?;
        self.rk4_stages(from, dv1, &mut accel)
    }

    /// The stages of one RK4 step from `from` after the first (its acceleration `dv1`, at the
    /// step's start with the activations driving the inputs as the Euler family's first
    /// stage), each stage's acceleration from `accel(q, v, inputs)`.
    fn rk4_stages<T: Scalar>(
        &self,
        from: StepFrom<'_, T>,
        dv1: Vec<T>,
        accel: &mut StageAccel<'_, T>,
    ) -> Result<State<T>, DynamicsError> {
        let StepFrom { state, h, .. } = from;
        let tree = &self.tree;
        let (q1, v1) = (&state.q, &state.v);
        let half = h * 0.5;
        let raw = from.u;
        let (u_half, u_end) = (self.inputs_after(raw, half), self.inputs_after(raw, h));
        // The activations through the stages as MuJoCo's RK4 takes them (unclamped
        // within the step), each stage's inputs driven by its own and its rates read at
        // its own configuration (a PID's integral reads the actuator's length).
        let a1 = &state.act;
        let ctrl = &raw[..self.actuators.len()];
        let stage = |u: &[T], a: &[T], q: &[T]| self.driven_inputs(u, a, q, Some(h));
        let r1 = self.activation_rates(a1, ctrl, q1);
        let dq1 = tree.qdot(q1, v1);
        let (q2, v2) = (axpy(q1, half, &dq1), axpy(v1, half, &dv1));
        let a2 = axpy(a1, half, &r1);
        let r2 = self.activation_rates(&a2, ctrl, &q2);
        let dq2 = tree.qdot(&q2, &v2);
        let dv2 = accel(&q2, &v2, &stage(&u_half, &a2, &q2))?;
        let (q3, v3) = (axpy(q1, half, &dq2), axpy(v1, half, &dv2));
        let a3 = axpy(a1, half, &r2);
        let r3 = self.activation_rates(&a3, ctrl, &q3);
        let dq3 = tree.qdot(&q3, &v3);
        let dv3 = accel(&q3, &v3, &stage(&u_half, &a3, &q3))?;
        let (q4, v4) = (axpy(q1, h, &dq3), axpy(v1, h, &dv3));
        let a4 = axpy(a1, h, &r3);
        let r4 = self.activation_rates(&a4, ctrl, &q4);
        let dq4 = tree.qdot(&q4, &v4);
        let dv4 = accel(&q4, &v4, &stage(&u_end, &a4, &q4))?;
        let w = [1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0];
        let rate = combine(
            &vec![T::zero(); a1.len()],
            T::one(),
            &[(w[0], &r1), (w[1], &r2), (w[2], &r3), (w[3], &r4)],
        );
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
            act: self.next_activations(a1, &rate, h),
        })
    }

    /// An Euler-family step's inputs with each activation driving its actuator (at the step's
    /// start, or at its end with `actearly`), and the activations at the step's end.
    pub(super) fn euler_activations<T: Scalar>(&self, from: &StepFrom<'_, T>) -> (Vec<T>, Vec<T>) {
        let act = &from.state.act;
        if act.is_empty() {
            return (from.u.to_vec(), Vec::new());
        }
        let q = &from.state.q;
        let rates = self.activation_rates(act, &from.u[..self.actuators.len()], q);
        let end = self.next_activations(act, &rates, from.h);
        (self.driven_inputs(from.u, act, q, Some(from.h)), end)
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
        self.check_activations(&state.act)?;
        self.split_inputs(u)?;
        let tree = &self.tree;
        let (nq, nv) = (tree.nq, tree.nv);
        // The activations are states of the ODE here: each stage's inputs are driven by its
        // own (`actearly`, a device of the fixed-step Euler family, does not apply).
        let ctrl = &u[..self.actuators.len().min(u.len())];
        let mut ka: Vec<Vec<T>> = Vec::with_capacity(7);
        let mut kq: Vec<Vec<T>> = Vec::with_capacity(7);
        let mut kv: Vec<Vec<T>> = Vec::with_capacity(7);
        let (dq0, dv0) = match first {
            Some(f) => f,
            None => (
                tree.qdot(&state.q, &state.v),
                self.accel(
                    &state.q,
                    &state.v,
                    &self.driven_inputs(u, &state.act, &state.q, None),
                    prm,
                )?,
            ),
        };
        ka.push(self.activation_rates(&state.act, ctrl, &state.q));
        kq.push(dq0);
        kv.push(dv0);
        let terms = |w: &[f64], k: &[Vec<T>]| -> Vec<(f64, Vec<T>)> {
            w.iter().zip(k).map(|(&x, k)| (x, k.clone())).collect()
        };
        let at = |x: &[T], w: &[f64], k: &[Vec<T>]| -> Vec<T> {
            let t = terms(w, k);
            let t: Vec<(f64, &[T])> = t.iter().map(|(x, k)| (*x, k.as_slice())).collect();
            combine(x, h, &t)
        };
        for s in 1..6 {
            let a = dp::A[s];
            let q = at(&state.q, a, &kq);
            let v = at(&state.v, a, &kv);
            let act = at(&state.act, a, &ka);
            let us = self.driven_inputs(&self.inputs_after(u, h * dp::C[s]), &act, &q, None);
            kq.push(tree.qdot(&q, &v));
            kv.push(self.accel(&q, &v, &us, prm)?);
            ka.push(self.activation_rates(&act, ctrl, &q));
        }
        let mut q = at(&state.q, &dp::B, &kq);
        tree.normalize_q(&mut q);
        let v = at(&state.v, &dp::B, &kv);
        let mut act = at(&state.act, &dp::B, &ka);
        // Clamped before the last stage, which the next step takes as its first: that step
        // starts from the clamped activations.
        self.clamp_activations(&mut act);
        let u_end = self.driven_inputs(&self.inputs_after(u, h), &act, &q, None);
        let last = (tree.qdot(&q, &v), self.accel(&q, &v, &u_end, prm)?);
        kq.push(last.0.clone());
        kv.push(last.1.clone());
        ka.push(self.activation_rates(&act, ctrl, &q));
        let zq = vec![T::zero(); nq];
        let zv = vec![T::zero(); nv];
        let za = vec![T::zero(); act.len()];
        let mut error = at(&zq, &dp::E, &kq);
        error.extend(at(&zv, &dp::E, &kv));
        error.extend(at(&za, &dp::E, &ka));
        Ok(Dopri5Step {
            state: State { q, v, act },
            error,
            last,
        })
    }
}
