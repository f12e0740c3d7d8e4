//! The implicit steps: implicit Euler's (its step equation in the end velocity, solved by
//! Newton's method, with a Jacobian carried between steps, a guess extrapolated from the last
//! step, and halving where Newton fails) and damped Euler's velocity with the contact taken at
//! the end velocity ([`Integrator::DampedEuler`]).

use super::cache::{KinematicsMemo, StepCarry};
use super::guard::contact_energy;
use super::newton::{inf_norm, newton, newton_from, re_vec};
use super::step::axpy;
use super::step::StepFrom;
use crate::autodiff::{jacobian, passes, VectorFunction};
use crate::collision::PairCarry;
use crate::contact::{ContactParams, PairContact};
use crate::dynamics::Kinematics;
use crate::integrator::{Integrator, State};
use crate::model::{DynamicsError, EvalPoint, ForwardOptions, FrozenStart, Model, Reuse};
use crate::scalar::{c, Scalar};
use nalgebra::DMatrix;
use std::any::Any;
use std::cell::{Cell, RefCell};

/// Each pair's contact at a step's start, in pair order (`None` out of reach).
pub(super) type StartContacts = Vec<Option<PairContact<f64>>>;

/// The residual of the implicit Euler step equation `r(V) = V - v0 - h v̇(q0 ⊕ h V, V)` as a
/// function of the new velocity `V`, on real numbers (for its Jacobian).
struct StepResidual<'a> {
    model: &'a Model,
    q0: Vec<f64>,
    v0: Vec<f64>,
    h: f64,
    u: Vec<f64>,
    prm: ContactParams<f64>,
    /// What the pairs keep from one pass of dual numbers of the Jacobian to the next, all at the
    /// same real point: each pair's proof and hand-derived Jacobian, found in the first pass
    /// (a fresh carry per Jacobian: the same decisions and numbers as without one). On MuJoCo's
    /// cards (318 velocities, 40 passes) every pass took every pair's Jacobian again: 88 % of
    /// a run.
    pairs: RefCell<PairCarry>,
}

impl VectorFunction for StepResidual<'_> {
    fn eval<T: Scalar>(&self, x: &[T]) -> Result<Vec<T>, DynamicsError> {
        let lift = |v: &[f64]| v.iter().map(|&a| c::<T>(a)).collect::<Vec<T>>();
        // `u` is already driven by the activations (which the residual does not move).
        let start = State::new(lift(&self.q0), lift(&self.v0));
        let (u, prm) = (lift(&self.u), self.prm.lift());
        let from = StepFrom {
            state: &start,
            u: &u,
            prm: &prm,
            h: c(self.h),
        };
        let mut pairs = self.pairs.borrow_mut();
        let kept = RefCell::new(&mut *pairs);
        let at = IterateAt {
            kept: Some(&kept),
            buffers: None,
            energy: None,
        };
        step_residual(self.model, from, x, at)
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
    pulls: Vec<Option<f64>>,
    prm: ContactParams<f64>,
    h: f64,
    /// The share each limit holds, decided at the step's start ([`crate::model::Forward::holds`]).
    holds: Option<Vec<f64>>,
}

impl VectorFunction for ContactImplicitResidual<'_> {
    fn eval<T: Scalar>(&self, x: &[T]) -> Result<Vec<T>, DynamicsError> {
        let lift = |v: &[f64]| v.iter().map(|&a| c::<T>(a)).collect::<Vec<T>>();
        let (q, v) = (lift(&self.q), lift(&self.v));
        let (tau, mocap) = (lift(&self.tau), lift(&self.mocap));
        let pulls: Vec<Option<T>> = self.pulls.iter().map(|p| p.map(c)).collect();
        let holds = self.holds.as_deref().map(lift);
        let at = EvalPoint {
            q: &q,
            v: &v,
            tau: &tau,
            mocap: &mocap,
            pulls: &pulls,
        };
        let opts = ForwardOptions {
            contact_velocity: Some(x),
            implicit_damping: Some(c(self.h)),
            list_contacts: false,
            holds: holds.as_deref(),
            ..ForwardOptions::default()
        };
        let a = self.model.forward_at(at, &self.prm.lift(), opts)?.vdot;
        Ok((0..x.len()).map(|k| x[k] - v[k] - a[k] * self.h).collect())
    }
}

/// What an iterate of implicit Euler's step equation borrows ([`step_residual`]).
#[derive(Clone, Copy)]
struct IterateAt<'a, 'c, T: Scalar> {
    /// The pairs' kept out-of-reach proofs and candidate planes.
    kept: Option<&'a RefCell<&'c mut PairCarry>>,
    /// Kinematics buffers, handed from one iterate to the next.
    buffers: Option<&'a RefCell<Option<Kinematics<T>>>>,
    /// Where the contact energy at the iterate is written (only in `f64`).
    energy: Option<&'a Cell<Option<f64>>>,
}

/// The implicit Euler step equation's residual `r(V) = V - v0 - h v̇(q0 ⊕ h V, V)` at `vs`,
/// `from.u` the inputs at the end of the step; with `at.kept`, the pairs' kept out-of-reach
/// proofs and candidate planes serve each iterate (a proof with room holds wherever it covers,
/// so an iterate may be switched off by it as the step's start is; docs/performance.md); with
/// `at.energy`, the estimate of the energy stored in the iterate's contacts is written there
/// ([`contact_energy`], pulled by no adhesion actuator: the caller's to check).
fn step_residual<T: Scalar>(
    model: &Model,
    from: StepFrom<'_, T>,
    vs: &[T],
    at: IterateAt<'_, '_, T>,
) -> Result<Vec<T>, DynamicsError> {
    let IterateAt {
        kept,
        buffers,
        energy,
    } = at;
    let StepFrom { state, u, prm, h } = from;
    let (q0, v0) = (&state.q, &state.v);
    let q = model.tree.integrate_q(q0, vs, h);
    let mut carried = kept.map(RefCell::borrow_mut);
    // The iterate's kinematics into the buffers lent, if any (the same bits as computed by the
    // forward dynamics itself), whose own are lent on.
    let kinematics = match buffers.and_then(|b| b.borrow_mut().take()) {
        Some(mut kin) => {
            let (_, mocap) = model.split_inputs(u)?;
            model.tree.kinematics_into(&q, vs, mocap, &mut kin);
            Some(kin)
        }
        None => None,
    };
    let opts = ForwardOptions {
        reuse: (carried.as_deref_mut()).map_or(Reuse::Nothing, |c| Reuse::All(c)),
        list_contacts: energy.is_some(),
        kinematics,
        ..ForwardOptions::default()
    };
    let f = model.forward_with(&q, vs, u, prm, opts)?;
    if let Some(cell) = energy {
        let real = (&f.contacts as &dyn Any).downcast_ref::<Vec<Option<PairContact<f64>>>>();
        let prm = (prm as &dyn Any).downcast_ref::<ContactParams<f64>>();
        cell.set(
            real.zip(prm)
                .map(|(c, p)| contact_energy(&model.pairs, c, p, &[])),
        );
    }
    if let Some(b) = buffers {
        *b.borrow_mut() = Some(f.kinematics);
    }
    let a = f.vdot;
    Ok((0..vs.len()).map(|k| vs[k] - v0[k] - h * a[k]).collect())
}

/// Damped Euler's forward dynamics over a step `h`: the joints' damping implicit, the contact
/// taken at `contact_velocity` if given.
fn damped<T: Scalar>(h: T, contact_velocity: Option<&[T]>) -> ForwardOptions<'_, T> {
    ForwardOptions {
        contact_velocity,
        implicit_damping: Some(h),
        ..ForwardOptions::default()
    }
}

impl Model {
    /// Damped Euler's velocity at the end of a step `h` ([`Integrator::DampedEuler`]): `V`
    /// solves `(M + h D)(V - v) = h (τ + τ_passive - c + Σ Λ(q, V))`, every term at the start
    /// `(q, v)` but the contact forces `Λ`, taken at `V`. The joints' damping is implicit as in
    /// MuJoCo's `Euler`; the contact's velocity dependence (its damping, and friction, which is
    /// a damper `μ F / v_s` near rest) is implicit as MuJoCo's constraint solver makes it: a
    /// stiff position actuator pressing a light finger on a block (`μ F / (v_s m)` in the
    /// thousands per second at 2 ms steps) rings and blows up with the contact explicit.
    ///
    /// Without a pair in reach at the start, the step is explicit (contact-free and off every
    /// limit, it is MuJoCo's `Euler` exactly). Otherwise Newton's iterations from the start
    /// velocity `V = v`, on the real Jacobian from dual numbers, as
    /// [`Integrator::ImplicitEuler`]'s (with dual numbers a fresh one at every iteration, so the
    /// derivatives of the step are exact; in `f64` past one pass of duals, the frozen
    /// contact's own, [`crate::model::FrozenForward::step_jacobian`], and so in every damped
    /// RK4 stage, `rk4_stage`). Newton starts from `v`, not from the
    /// explicit step: where friction is a stiff damper (`h μ F / (v_s m) ≫ 1`) the explicit step
    /// reverses the sliding velocity many times over, far outside the basin; from `v` the first
    /// iteration is the linearly implicit step. On dm_control's dog (5 ms, 18 to 22 pairs in
    /// reach) that took 7.4 Jacobians and 28 residuals a step down to 1.3 and 6.3 (and the line
    /// search's halvings from 945 to 4 in 60 steps); on robosuite's Jaco, 7.9 and 20 to 2.5 and
    /// 6.2. In
    /// `f64`, `jac` carries the last real Jacobian from step to step while it serves (Newton
    /// takes a fresh one when the iterations stop contracting), as for implicit Euler; the
    /// pairs' kept out-of-reach proofs and candidate planes serve the frozen contact (both
    /// from `carry`); `at_start`, if given, receives in `f64` each pair's contact at the start
    /// of the step, as the forward dynamics there would give it (what the energy guard reads).
    pub(super) fn damped_euler_velocity<T: Scalar>(
        &self,
        from: StepFrom<'_, T>,
        carry: StepCarry<'_>,
        at_start: Option<&mut Option<StartContacts>>,
        rk4_stage: bool,
        guess: Option<&[f64]>,
    ) -> Result<Vec<T>, DynamicsError> {
        let StepFrom { state, u, prm, h } = from;
        let (q, v) = (&state.q[..], &state.v[..]);
        let StepCarry {
            jacobian: jac,
            pairs: kept,
            kinematics: known,
            ..
        } = carry;
        let (ctrl, mocap) = self.split_inputs(u)?;
        let forces = self.actuator_forces_at(q, v, ctrl, mocap);
        let tau = forces.as_slice();
        let pulls = self.pulls(ctrl);
        // The step's values in `f64`, for the Jacobian by dual numbers.
        let real = || ContactImplicitResidual {
            model: self,
            q: re_vec(q),
            v: re_vec(v),
            tau: re_vec(tau),
            mocap: re_vec(mocap),
            pulls: pulls.iter().map(|p| p.map(|p| p.re())).collect(),
            prm: prm.re(),
            h: h.re(),
            holds: None,
        };
        if let (Some(s64), Some(tau64), Some(pulls64), Some(prm64)) = (
            (state as &dyn Any).downcast_ref::<State<f64>>(),
            (&forces as &dyn Any).downcast_ref::<nalgebra::DVector<f64>>(),
            (&pulls as &dyn Any).downcast_ref::<Vec<Option<f64>>>(),
            (prm as &dyn Any).downcast_ref::<ContactParams<f64>>(),
        ) {
            let (q64, v64, tau64) = (&s64.q[..], &s64.v[..], tau64.as_slice());
            // Values only: everything but the contact's velocities is frozen at the start of the
            // step, each pair's contact terms recorded there and replayed at each trial end
            // velocity (`FrozenForward`); the same arithmetic as `forward_at`'s. (Read where
            // they are, not copied: a step out of reach has no other use for a copy.)
            let mocap64 = re_vec(mocap);
            let at = EvalPoint {
                q: q64,
                v: v64,
                tau: tau64,
                mocap: &mocap64,
                pulls: pulls64,
            };
            let reuse = kept.map_or(Reuse::Nothing, Reuse::All);
            // The guard's kinematics of this very state, if it kept them (the memo is of a
            // model without mocap bodies, so they are those of `at`); else computed into the
            // buffers of kinematics done with (a damped RK4 stage's before).
            let mut memo = known;
            let known = memo.as_deref_mut().and_then(|m| {
                m.take_at(q64, v64).or_else(|| {
                    let mut kin = m.spare()?;
                    (self.tree).kinematics_into(q64, v64, &mocap64, &mut kin);
                    Some(kin)
                })
            });
            let start = self.frozen_start(at, prm64, h.re(), reuse, known, true)?;
            // `v + h v̇` into the accelerations' own vector: `T` is `f64` in this branch (its
            // state is a `State<f64>`), so the same sums and no vector of their own.
            let h64 = h.re();
            let explicit = |mut a: Vec<f64>| -> Vec<T> {
                debug_assert_eq!(a.len(), v64.len());
                for (ak, vk) in a.iter_mut().zip(v64) {
                    *ak = vk + h64 * *ak;
                }
                let mut out = Some(a);
                let out = (&mut out as &mut dyn Any).downcast_mut::<Option<Vec<T>>>();
                out.and_then(Option::take).expect("the scalar is f64")
            };
            let (mut frozen, a0) = match start {
                FrozenStart::Free {
                    vdot,
                    kin,
                    contacts,
                } => {
                    if let Some(slot) = at_start {
                        *slot = Some(contacts);
                    }
                    // Its kinematics' buffers for the next ones (the guard's, a stage's).
                    if let Some(m) = memo {
                        m.recycle(kin);
                    }
                    return Ok(explicit(vdot));
                }
                FrozenStart::Recorded(frozen, a0) => (frozen, a0),
            };
            if let Some(slot) = at_start {
                *slot = Some(frozen.take_contacts());
            }
            if frozen.contact_free() {
                // A limit could let go: the frozen evaluation was made (its accelerations are
                // those of the limits let go); its kinematics' buffers for the next ones.
                if let Some(m) = memo {
                    m.recycle(frozen.into_kinematics());
                }
                return Ok(explicit(a0));
            }
            let residual = |x: &[T]| -> Result<Vec<T>, DynamicsError> {
                let a = frozen.vdot(&re_vec(x));
                Ok((0..x.len())
                    .map(|k| x[k] - v[k] - h * c::<T>(a[k]))
                    .collect())
            };
            // The residual at the start velocity, from the frozen evaluation's own
            // accelerations there (the tapes replayed at `v` give the same bits, and `v - v` is
            // zero): one replay fewer per step or damped RK4 stage, of the hopper's 4.0 (cpu
            // 0.88 on its 1 s, walker2d 0.98, the ant 0.97, Jaco's 10 steps 0.99; same bits).
            let r0: Vec<T> = (0..v.len())
                .map(|k| T::zero() - h * c::<T>(a0[k]))
                .collect();
            // Past one pass of dual numbers, its Jacobian from the same tapes: only the contact
            // forces differentiated, each pair's tape once against its two bodies' velocities
            // (`FrozenForward::contact_force_jacobian`), where each pass of the full evaluation
            // finds every pair's contact again and builds the mass matrix on duals (dm_control's
            // dog, 85 velocities, 0.1 s: 4.22 s -> 3.55 s with the tapes replayed per pass of
            // 8 velocities). In one pass the full evaluation's hand-derived pair Jacobians cost
            // less than the tapes replayed on duals of width 16 (robosuite's Fourier hand, 10
            // steps: 0.53 s against 0.98 s; Jaco 0.50 / 0.58), but not in damped RK4's stages
            // (`rk4_stage`), where the tapes' took 0.53 of the cpu on gymnasium's walker2d,
            // 0.67 on walker2d_v5, 0.81 on the ant and 1.01 on the hopper (1 s each, farm-bench;
            // the same runs under damped Euler: Fourier hand 1.11, Jaco 1.23, Franka 1.02).
            // A guess (a damped RK4 stage's, from the stage before) replaces the start velocity
            // where its residual is smaller.
            let (x0, r0) = match guess.filter(|g| g.len() == v.len()) {
                Some(g) => {
                    let x: Vec<T> = g.iter().map(|&a| c::<T>(a)).collect();
                    let r = residual(&x)?;
                    if inf_norm(&re_vec(&r)) < inf_norm(&re_vec(&r0)) {
                        (x, r)
                    } else {
                        (v.to_vec(), r0)
                    }
                }
                None => (v.to_vec(), r0),
            };
            let end = if passes(v.len()) > 1 || rk4_stage {
                let frozen_jacobian = |x: &[f64]| -> Result<DMatrix<f64>, DynamicsError> {
                    Ok(frozen.step_jacobian(&frozen.contact_force_jacobian(x), h.re()))
                };
                newton_from(&residual, &frozen_jacobian, x0, r0, jac)
            } else {
                // The full evaluation on dual numbers, from the step's values in `f64`; the
                // limits that let go at the start are let go at every iterate, as the frozen
                // evaluation lets them go.
                let mut real = real();
                real.holds = self.limits_can_let_go().then(|| match frozen.holds() {
                    Some(h) => h.to_vec(),
                    None => vec![1.0; self.limit_slots()],
                });
                let real = &real;
                let real_jacobian =
                    |x: &[f64]| -> Result<DMatrix<f64>, DynamicsError> { Ok(jacobian(real, x)?.1) };
                newton_from(&residual, &real_jacobian, x0, r0, jac)
            };
            if let Some(m) = memo {
                m.recycle(frozen.into_kinematics());
            }
            return end;
        }
        let at = EvalPoint {
            q,
            v,
            tau,
            mocap,
            pulls: &pulls,
        };
        let start = self.forward_at(at, prm, damped(h, None))?;
        let explicit = axpy(v, h, start.vdot.as_slice());
        if start.contacts.iter().all(Option::is_none) {
            return Ok(explicit);
        }
        // The limits that let go at the start are let go at every iterate, as in `f64`.
        let holds = (self.limits_can_let_go())
            .then(|| (start.holds).unwrap_or_else(|| vec![T::one(); self.limit_slots()]));
        let mut real = real();
        real.holds = holds.as_deref().map(re_vec);
        let residual = |x: &[T]| -> Result<Vec<T>, DynamicsError> {
            let opts = ForwardOptions {
                holds: holds.as_deref(),
                ..damped(h, Some(x))
            };
            let a = self.forward_at(at, prm, opts)?.vdot;
            Ok((0..x.len()).map(|k| x[k] - v[k] - h * a[k]).collect())
        };
        let real = &real;
        let real_jacobian =
            |x: &[f64]| -> Result<DMatrix<f64>, DynamicsError> { Ok(jacobian(real, x)?.1) };
        newton(&residual, &real_jacobian, v.to_vec(), jac)
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
    /// `carry.jacobian`: a Jacobian of the step equation from an earlier step of the same `h`,
    /// tried first and replaced when the iterations contract slowly; updated here. `guess`: the
    /// velocity change `V - v` Newton starts from (none: `V = v`).
    pub(super) fn implicit_euler_step<T: Scalar>(
        &self,
        from: StepFrom<'_, T>,
        carry: StepCarry<'_>,
        guess: Option<&[f64]>,
    ) -> Result<State<T>, DynamicsError> {
        let StepFrom { state, prm, h, .. } = from;
        let (driven, act) = self.euler_activations(&from);
        let u1 = self.inputs_after(&driven, h);
        let at_end = StepFrom { u: &u1, ..from };
        let StepCarry {
            jacobian: jac,
            pairs: kept,
            kinematics: mut memo,
            contact_energy: mut energy_slot,
            ..
        } = carry;
        let kept = kept.map(RefCell::new);
        // Buffers for the iterates' kinematics: the memo's spare ones, handed from one
        // evaluation to the next and back to the memo at the end.
        let buffers = RefCell::new(memo.as_deref_mut().and_then(KinematicsMemo::lend::<T>));
        // The contact energy at each real iterate, where asked and where the contacts read no
        // input the next call may change (mocap poses, adhesion actuators' controls).
        let energy = Cell::new(None);
        if let Some(slot) = energy_slot.as_deref_mut() {
            *slot = None;
        }
        let watch = energy_slot.is_some() && self.tree.mocap.is_empty() && !self.has_adhesion();
        let residual = |x: &[T]| {
            let at = IterateAt {
                kept: kept.as_ref(),
                buffers: Some(&buffers),
                energy: watch.then_some(&energy),
            };
            step_residual(self, at_end, x, at)
        };
        let real_jacobian = |x: &[f64]| -> Result<DMatrix<f64>, DynamicsError> {
            let f = StepResidual {
                model: self,
                q0: re_vec(&state.q),
                v0: re_vec(&state.v),
                h: h.re(),
                u: re_vec(&u1),
                prm: prm.re(),
                pairs: RefCell::default(),
            };
            Ok(jacobian(&f, x)?.1)
        };
        let start = match guess {
            Some(dv) if dv.len() == state.v.len() => {
                (0..dv.len()).map(|k| state.v[k] + c::<T>(dv[k])).collect()
            }
            _ => state.v.clone(),
        };
        let v = newton(&residual, &real_jacobian, start, jac);
        if let Some(m) = memo {
            m.take_back(buffers.into_inner());
        }
        let v = v?;
        // Newton's last residual was at its last evaluated iterate (the Jacobians' passes are
        // on dual numbers and write nothing), one Newton step from `v`.
        if let Some(slot) = energy_slot {
            *slot = energy.get();
        }
        Ok(State {
            q: self.tree.integrate_q(&state.q, &v, h),
            v,
            act,
        })
    }

    /// An implicit step of `h` from the carried Newton Jacobian and, in `dv`, the last
    /// step's velocity change `V - v`: Newton starts from `v + dv` (the acceleration held over
    /// the step: the start is `O(h²)` from the solution where motion is smooth, where `v` is
    /// `O(h)`). Where Newton fails from there (after an impact the last change says little),
    /// the step is tried again from `v`, then subdivided as without a guess. `dv` is left with
    /// this step's change, or none when the step was subdivided (its halves' changes say
    /// nothing of the next full step).
    pub(super) fn implicit_step_extrapolating(
        &self,
        from: StepFrom<'_, f64>,
        mut carry: StepCarry<'_>,
        dv: &mut Option<Vec<f64>>,
    ) -> Result<State<f64>, DynamicsError> {
        let guessed = match dv.take() {
            Some(guess) => match self.implicit_euler_step(from, carry.reborrow(), Some(&guess)) {
                Err(DynamicsError::NewtonFailed { .. }) => None,
                other => Some(other?),
            },
            None => None,
        };
        let before = *carry.subdivided;
        let next = match guessed {
            Some(next) => next,
            None => self.implicit_step_subdividing(
                Integrator::ImplicitEuler,
                from,
                carry.reborrow(),
                0,
                None,
            )?,
        };
        let s = from.state;
        *dv = (*carry.subdivided == before)
            .then(|| next.v.iter().zip(&s.v).map(|(a, b)| a - b).collect());
        Ok(next)
    }

    /// An implicit step of `h` of `integrator` ([`Integrator::ImplicitEuler`], or
    /// [`Integrator::DampedEuler`] or [`Integrator::DampedRk4`], implicit in the contact's
    /// velocities); when Newton's
    /// iterations fail (typically when contact starts within a step much longer than the
    /// contact's period), the step is done as two halves of the same method, recursively, down
    /// to `h / 2⁸`; the halves start from a fresh Jacobian and share it. `depth`: the halvings
    /// so far;
    /// `at_start`: as [`Model::damped_euler_velocity`]'s, for damped Euler and damped RK4.
    pub(super) fn implicit_step_subdividing(
        &self,
        integrator: Integrator,
        from: StepFrom<'_, f64>,
        mut carry: StepCarry<'_>,
        depth: usize,
        at_start: Option<&mut Option<StartContacts>>,
    ) -> Result<State<f64>, DynamicsError> {
        let StepFrom { state: s, u, h, .. } = from;
        let step = match integrator {
            Integrator::DampedEuler => {
                let (driven, act) = self.euler_activations(&from);
                let at = StepFrom { u: &driven, ..from };
                (self.damped_euler_velocity(at, carry.reborrow(), at_start, false, None)).map(|v| {
                    State {
                        q: self.tree.integrate_q(&s.q, &v, h),
                        v,
                        act,
                    }
                })
            }
            Integrator::DampedRk4 => self.damped_rk4_step(from, carry.reborrow(), at_start),
            _ => self.implicit_euler_step(from, carry.reborrow(), None),
        };
        match step {
            Err(DynamicsError::NewtonFailed { .. }) if depth < 8 => {
                *carry.subdivided += 1;
                let half = 0.5 * h;
                let mut sub = None;
                let mut halves = StepCarry {
                    jacobian: &mut sub,
                    ..carry
                };
                let first = StepFrom { h: half, ..from };
                let mid = self.implicit_step_subdividing(
                    integrator,
                    first,
                    halves.reborrow(),
                    depth + 1,
                    None,
                )?;
                let u_mid = self.inputs_after(u, half);
                let second = StepFrom {
                    state: &mid,
                    u: &u_mid,
                    ..first
                };
                self.implicit_step_subdividing(integrator, second, halves, depth + 1, None)
            }
            other => other,
        }
    }
}
