//! A communication step covered by internal steps that land exactly on its end, and the guard
//! that refuses a step that diverges (non-finite state, energy growth no input explains).

use super::cache::{reuse_all, SolverCache, StepCarry};
use super::guard::{contact_energy, EnergyMonitor};
use super::step::StepFrom;
use crate::contact::ContactParams;
use crate::dynamics::MOCAP_INPUTS;
use crate::integrator::{Integrator, State};
use crate::model::{DynamicsError, Model};
use std::borrow::Cow;

/// The size past which a position or velocity coordinate has diverged (MuJoCo's `mjMAXVAL`).
/// An energy balance cannot catch every blow-up: an explicit step that makes a stiff actuator's
/// damping unstable credits the energy it creates to the actuator's work.
pub const DIVERGED: f64 = 1e10;

impl Model {
    /// The first coordinate of a state that diverged, if any ("the velocity of joint J"): not
    /// finite, or past [`DIVERGED`], where MuJoCo declares a run unstable and resets it.
    pub fn first_non_finite(&self, s: &State<f64>) -> Option<String> {
        let bad = |x: &f64| !x.is_finite() || x.abs() > DIVERGED;
        for j in &self.tree.joints {
            if s.q[j.qadr..j.qadr + j.kind.nq()].iter().any(bad) {
                return Some(format!("the position of joint {}", j.name));
            }
            if s.v[j.dadr..j.dadr + j.kind.nv()].iter().any(bad) {
                return Some(format!("the velocity of joint {}", j.name));
            }
        }
        let activated = self.actuators.iter().filter(|a| a.activation.is_some());
        (activated.zip(&s.act))
            .find(|(_, a)| !a.is_finite())
            .map(|(a, _)| format!("the activation of actuator {}", a.name))
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
    /// method's Newton Jacobian, the guard's ledger, the kept out-of-reach proofs): a caller
    /// that advances the state it got from the previous call saves a Jacobian per call and the
    /// proofs of pairs that stay out of reach. The Jacobian only changes where Newton's
    /// iterations start, not what they converge to (to their tolerance), and is used only for
    /// the state and step it was left for; a kept proof can switch a pair off where a fresh
    /// proof would not, which changes its forces by less than the bound of
    /// [`out_of_reach`](crate::collision::out_of_reach). So a run is reproducible bit for bit
    /// from a state and its cache (an FMU state carries both), and to that bound from the
    /// state alone. A call that fails leaves the state to the caller; the cache may have
    /// changed (a Jacobian dropped, proofs kept), which is still valid for any state.
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
            .and(self.check_activations(&state.act))
            .map_err(|error| StepFailure::Dynamics {
                time: t0,
                step: 0,
                h: 0.0,
                error,
            })?;
        let ctrl = &u[..self.actuators.len()];
        let mocap_moves = (0..self.tree.mocap.len()).any(|m| {
            u[self.actuators.len() + MOCAP_INPUTS * m + 7..][..6]
                .iter()
                .any(|&x| x != 0.0)
        });
        let guard = opts.energy_guard && !mocap_moves;
        // The first stage of the explicit methods is the forward dynamics at the start: computed
        // once here, it also gives the contact state for the energy guard (implicit Euler's guard
        // takes the contacts alone, where its ledger holds none). Damped Euler's first step
        // (damped RK4's first stage) records every pair's contact at the start itself (its frozen
        // contact): the guard takes it from there, and its balance starts once that step is taken.
        let damped = self.integrator.is_damped();
        // Implicit Euler's contact energy at the start, where the last call left it with the
        // ledger it carries on (`EnergyLedger::stored`): no listing, no kinematics read.
        let stored_carried = (self.integrator == Integrator::ImplicitEuler && guard)
            && (cache.ledger.as_ref()).is_some_and(|l| l.stored_at(state, prm).is_some());
        let needs_start = match self.integrator {
            Integrator::ImplicitEuler => guard && !stored_carried,
            Integrator::DampedEuler | Integrator::DampedRk4 => false,
            _ => true,
        };
        // The fixed-step methods' internal step (refused below where it is not sensible), whose
        // first stage's inputs are driven by the activations as that step takes them.
        let steps = ((duration / self.timestep) * (1.0 - 1e-12)).ceil().max(1.0);
        let first_h = (!self.integrator.is_adaptive()).then_some(duration / steps);
        // `spare`: kinematics the forward dynamics are done with, whose buffers the guard's
        // next check reuses.
        let (start_contacts, a0, mut spare) = if needs_start {
            let known = cache.kinematics.take(state);
            let driven = self.driven_inputs(u, &state.act, &state.q, first_h);
            let reuse = reuse_all(&mut cache.pairs, known);
            match self.integrator {
                Integrator::ImplicitEuler => self
                    .contacts_only_at(&state.q, &state.v, &driven, prm, reuse)
                    .map(|(c, kin)| (Some(c), None, Some(kin))),
                _ => self
                    .forward_with(&state.q, &state.v, &driven, prm, reuse)
                    .map(|f| {
                        (
                            Some(f.contacts),
                            Some(f.vdot.data.into()),
                            Some(f.kinematics),
                        )
                    }),
            }
            .map_err(|error| StepFailure::Dynamics {
                time: t0,
                step: 1,
                h: 0.0,
                error,
            })?
        } else {
            if stored_carried {
                cache.kinematics.set_aside();
            }
            (None, None, None)
        };
        let mut monitor = (guard && !damped)
            .then(|| {
                self.energy_monitor(
                    state,
                    ctrl,
                    prm,
                    start_contacts.as_deref(),
                    t0,
                    cache.ledger.as_ref(),
                )
            })
            .flatten();
        let mut report = Advanced {
            // Written where the call ends.
            state: State::empty(),
            steps: 0,
            rejected: 0,
            subdivided: 0,
            min_step: f64::INFINITY,
            max_step: 0.0,
        };
        if !self.integrator.is_adaptive() {
            let n = steps;
            // Refused before any work (the cast below would saturate, and internal steps would
            // grow past `step`; a state that stays finite would run for ages).
            if n.is_nan() || n > opts.max_steps as f64 {
                return Err(StepFailure::TooLong {
                    time: t0,
                    duration,
                    step: self.timestep,
                    steps: opts.max_steps,
                });
            }
            let n = n as usize;
            let dt = duration / n as f64;
            // The state reached: the start's until the first step is taken (not copied).
            let mut s = Cow::Borrowed(state);
            let mut first = a0;
            // The kinematics of `s` as the guard computed them, for the next forward dynamics.
            let mut known = None;
            // The Newton Jacobian of implicit Euler, or of damped Euler in contact, carried
            // from step to step while it serves.
            // With it, implicit Euler's last velocity change V - v, its next start guess.
            // (The internal step as computed, `duration / n`, can differ by a rounding from the
            // one the cache was left for, e.g. 0.01 s in calls of 0.01 s or of 0.1 s: a warm
            // start serves either.)
            // Implicit Euler's contact energy at the end (`StepCarry::contact_energy`).
            let mut stored_end = None;
            let (mut jac, mut dv) = match cache.left {
                Some((ref s_left, h_left))
                    if (h_left - dt).abs() <= 1e-12 * dt.abs() && s_left == state =>
                {
                    (cache.jacobian.take(), cache.velocity_change.take())
                }
                _ => (None, None),
            };
            for k in 0..n {
                let t = t0 + (k + 1) as f64 * dt;
                let uk = self.inputs_after(u, k as f64 * dt);
                let dyn_err = |error| StepFailure::Dynamics {
                    time: t0 + k as f64 * dt,
                    step: k + 1,
                    h: dt,
                    error,
                };
                let from = StepFrom {
                    state: &s,
                    u: &uk,
                    prm,
                    h: dt,
                };
                s = Cow::Owned(match self.integrator {
                    Integrator::ImplicitEuler => {
                        // The memo lends Newton's evaluations the buffers of kinematics done
                        // with, and takes theirs back.
                        let carry = StepCarry {
                            jacobian: &mut jac,
                            pairs: Some(&mut cache.pairs),
                            subdivided: &mut report.subdivided,
                            kinematics: Some(&mut cache.kinematics),
                            // Asked of the call's last step only: the estimate it leaves.
                            contact_energy: (monitor.is_some() && k + 1 == n)
                                .then_some(&mut stored_end),
                        };
                        self.implicit_step_extrapolating(from, carry, &mut dv)
                            .map_err(dyn_err)?
                    }
                    i => {
                        // Every internal step's first stage with the kept out-of-reach proofs
                        // (the first one's is the start's forward dynamics).
                        // There the guard's balance may restart, with the contacts found.
                        let a = match first.take() {
                            None if !i.is_damped() => {
                                let driven = self.driven_inputs(&uk, &s.act, &s.q, Some(dt));
                                let reuse = reuse_all(&mut cache.pairs, known.take());
                                let f = self.forward_with(&s.q, &s.v, &driven, prm, reuse);
                                let f = f.map_err(dyn_err)?;
                                if let Some(m) = monitor.as_mut() {
                                    let pulls = self.pulls(&driven);
                                    let stored =
                                        contact_energy(&self.pairs, &f.contacts, prm, &pulls)
                                            + self.limits_drift(&s.q);
                                    let at = t0 + k as f64 * dt;
                                    let kinetic = m.ledger.kinetic;
                                    m.ledger.tighten(m.energy, kinetic, stored, at, m.floor);
                                }
                                spare = Some(f.kinematics);
                                Some(f.vdot.data.into())
                            }
                            a => a,
                        };
                        if i.is_damped() {
                            let mut at_start = None;
                            let first_with_guard = k == 0 && guard;
                            // The guard's kinematics of `s` for its frozen evaluation (at the
                            // first step, those the last call left, if of `s`).
                            if let Some(kin) = known.take() {
                                cache.kinematics.keep(&s, Some(kin));
                            }
                            let carry = StepCarry {
                                jacobian: &mut jac,
                                pairs: Some(&mut cache.pairs),
                                subdivided: &mut report.subdivided,
                                kinematics: Some(&mut cache.kinematics),
                                contact_energy: None,
                            };
                            let end = self.implicit_step_subdividing(
                                i,
                                from,
                                carry,
                                0,
                                first_with_guard.then_some(&mut at_start),
                            );
                            if first_with_guard {
                                monitor = self.energy_monitor(
                                    state,
                                    ctrl,
                                    prm,
                                    at_start.as_deref(),
                                    t0,
                                    cache.ledger.as_ref(),
                                );
                            }
                            end
                        } else {
                            let carry = StepCarry {
                                jacobian: &mut jac,
                                pairs: Some(&mut cache.pairs),
                                subdivided: &mut report.subdivided,
                                kinematics: None,
                                contact_energy: None,
                            };
                            self.explicit_step(i, from, a, carry)
                        }
                        .map_err(dyn_err)?
                    }
                });
                // The guard's kinematics into the buffers of kinematics done with.
                let buffers = match monitor {
                    Some(_) => {
                        (spare.take().or_else(|| known.take())).or_else(|| cache.kinematics.spare())
                    }
                    None => None,
                };
                let checked =
                    self.guard_check(&mut monitor, &s, (t, k + 1, dt), ctrl, prm, buffers);
                known = self.kinematics_kept(checked?, &mut cache.kinematics);
                if let Some(kin) = spare.take() {
                    cache.kinematics.recycle(kin);
                }
            }
            cache.kinematics.keep(&s, known);
            if matches!(
                self.integrator,
                Integrator::ImplicitEuler | Integrator::DampedEuler | Integrator::DampedRk4
            ) {
                cache.jacobian = jac;
                // Only implicit Euler's steps write (and read) the velocity change.
                cache.velocity_change = dv.filter(|_| self.integrator == Integrator::ImplicitEuler);
                match &mut cache.left {
                    // Into the buffers of the mark the last call left.
                    Some((at, h)) => {
                        at.assign(&s);
                        *h = dt;
                    }
                    None => cache.left = Some((s.clone().into_owned(), dt)),
                }
            }
            cache.ledger = EnergyMonitor::leave(monitor, &s, prm, cache.ledger.take(), stored_end);
            report.state = s.into_owned();
            report.steps = n;
            report.min_step = dt;
            report.max_step = dt;
            return Ok(report);
        }
        // Adaptive Dormand–Prince.
        let tol = self.tolerance;
        let mut s = state.clone();
        let mut elapsed = 0.0;
        let mut h = self.timestep.min(duration);
        let mut first = a0.map(|a| (self.tree.qdot(&state.q, &state.v), a));
        let mut rejected_last = false;
        // The guard's kinematics of the last accepted step's state.
        let mut known = None;
        loop {
            let remaining = duration - elapsed;
            let last = h >= remaining * (1.0 - 1e-9);
            if last {
                h = remaining;
            }
            let t = t0 + elapsed;
            let uk = self.inputs_after(u, elapsed);
            let trial = self.dopri5_step(&s, &uk, prm, h, first.clone());
            let cause;
            let (err, out) = match trial {
                Ok(out) => {
                    cause = self
                        .first_non_finite(&out.state)
                        .map(|q| format!("made {q} diverge"));
                    let x0 = s.q.iter().chain(&s.v).chain(&s.act);
                    let x1 = (out.state.q.iter())
                        .chain(&out.state.v)
                        .chain(&out.state.act);
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
                    let buffers = match monitor {
                        Some(_) => spare.take().or_else(|| known.take()),
                        None => None,
                    };
                    let at = (t0 + elapsed, report.steps, h);
                    let checked =
                        self.guard_check(&mut monitor, &out.state, at, ctrl, prm, buffers);
                    known = self.kinematics_kept(checked?, &mut cache.kinematics);
                    s = out.state;
                    first = Some(out.last);
                    if last {
                        cache.kinematics.keep(&s, known);
                        let old = cache.ledger.take();
                        cache.ledger = EnergyMonitor::leave(monitor, &s, prm, old, None);
                        report.state = s;
                        return Ok(report);
                    }
                    let grow = if err > 0.0 {
                        (0.9 * err.powf(-0.2)).clamp(0.2, 5.0)
                    } else {
                        5.0
                    };
                    h = (h * if rejected_last { grow.min(1.0) } else { grow }).min(self.timestep);
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
    /// ([`EnergyLedger`](super::guard::EnergyLedger), carried in the [`SolverCache`]), also
    /// when the energy grows by a little in every communication step. The test, after every
    /// internal step, is
    /// `E > E₀ + U₀ + W + ½ (S + Σ|ΔW|) + E_floor`, with `E₀ + U₀` the energy where the ledger
    /// started (`U` estimated by [`contact_energy`](super::contact_energy), with the drift the
    /// limits' energy count can still give back, [`Model::limits_drift`]), `S` the largest energy in motion seen
    /// since (`T` after each internal step; `T + U` at the start of each call, `U` there only up
    /// to the headroom `A - E` the state had under the allowance `A` it passed, all of it where
    /// the ledger starts), `Σ|ΔW|` the actuators' work counted without sign and `E_floor` the
    /// energy of raising every moving body by 1 mm and moving it at 1 cm/s. The half margin
    /// covers the integrators' legitimate energy errors (the work's estimate, `O(hᵖ)` drift, the
    /// estimate of `U`); a blow-up creates energy in motion from nothing and exceeds it once
    /// that is about twice what the run had before. The cap on `U` keeps a blow-up from raising
    /// its own allowance through the contact forces it drives (the estimate reads damping as
    /// stored energy): without actuators, no accepted state has more kinetic energy than
    /// `2 (E₀ + U₀ + E_floor - V_min)`, `V_min` the least potential energy of the run. The
    /// balance moves its start to a later state where `E + U` is not above `E₀ + U₀ + W`
    /// (the run lost energy since; [`EnergyLedger::tighten`](super::EnergyLedger)): checked at the start of every
    /// call and, for the explicit fixed-step methods, of every internal step (where the forward
    /// dynamics give the contacts; implicit Euler's `U` at the start is the ledger's estimate
    /// where it carries one, [`EnergyLedger::stored`](super::EnergyLedger#structfield.stored)). So a blow-up is judged from the least energy the run fell
    /// to, not from a start that held more (energy in limit springs that damping spends). The ledger restarts whenever a call starts from another state than the last one
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
    /// Implicit and damped Euler steps redone as two halves because Newton's iterations failed.
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
    /// A coordinate of the state became NaN, infinite or larger than [`DIVERGED`].
    #[error("the state diverged: {quantity} became non-finite or larger than 1e10 (where MuJoCo warns that the simulation is unstable) at t = {time} s (internal step {step}, h = {h} s)")]
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
        /// joint J diverge", "failed: …").
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
