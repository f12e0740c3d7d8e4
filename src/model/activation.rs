//! Actuator activation dynamics (MuJoCo's `dyntype`): an actuator with an activation state
//! `a` drives its force law with `a` in place of its control, and `a` follows its control
//! through its own first-order law (docs/dynamics.md, "Activation dynamics").
//!
//! The laws of `dyntype` read only the control and the activation; the integral of MuJoCo's PID
//! plugin ([`ActivationLaw::PidIntegral`]) reads the actuator's length too. Every integrator
//! advances the activations beside `(q, v)` the way MuJoCo does: the Euler family takes the
//! force at the step's start activation (or at its end one, `actearly`) and then moves the
//! activation by [`Model::next_activations`]; RK4 and Dormand–Prince carry it through their
//! stages as a state of the ODE, each stage's rate at that stage's configuration.

use super::{DynamicsError, Model};
use crate::scalar::{c, Scalar};

/// MuJoCo's smallest time constant (`mjMINVAL`): a filter's `τ` is at least this.
const MIN_TIME_CONSTANT: f64 = 1e-15;

/// How an activation follows its control `u` (clamped to the actuator's control range).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ActivationLaw {
    /// `ȧ = u` (MuJoCo's `integrator`).
    Integrator,
    /// `ȧ = (u - a) / τ`, stepped as the integrator steps every state (MuJoCo's `filter`).
    Filter {
        /// Time constant `τ` (s; `dynprm[0]`).
        tau: f64,
    },
    /// `ȧ = (u - a) / τ`, stepped exactly over an Euler-family step:
    /// `a' = a + ȧ τ (1 - e^{-h/τ})` (MuJoCo's `filterexact`, a `<position>`'s `timeconst`).
    FilterExact {
        /// Time constant `τ` (s).
        tau: f64,
    },
    /// The error integral `I` of MuJoCo's `mujoco.pid` actuator plugin with its `ki`: with the
    /// error `e = u - L` (`u` the clamped control, `L` the actuator's length) and the file's step
    /// `h`, the next integral is `I⁺ = clamp(I + e h, ±imax/ki)` and
    /// `İ = (I⁺ - I) / h` (so `İ = e` within the clamp). The actuator's force law reads
    /// `kp u + ki I⁺` where the others read their activation ([`Model::driven_inputs`]); the
    /// actuator is the `<general>` with `gainprm="1 0 0"` and `biasprm="0 -kp -kd"`, so its force
    /// is the plugin's `kp e - kd L̇ + ki I⁺` (docs/mjcf.md, "Actuators").
    PidIntegral {
        /// Proportional gain `kp`.
        kp: f64,
        /// Integral gain `ki` (nonzero).
        ki: f64,
        /// The clamp of the integral, `imax / ki` (the plugin's `imax` is a force), if any.
        bound: Option<f64>,
        /// The file's step `h` (s; MuJoCo's `opt.timestep`), which the plugin's law reads.
        step: f64,
    },
}

/// An actuator's activation state and how it moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Activation {
    /// Its law.
    pub law: ActivationLaw,
    /// `actrange` where `actlimited`: the activation is clamped to it after every step (as
    /// MuJoCo clamps it; within the stages of RK4 and Dormand–Prince it is not).
    pub range: Option<(f64, f64)>,
    /// MuJoCo's `actearly`: under the Euler-family integrators the force reads the activation
    /// at the end of the step, so the control acts without a step's delay.
    pub early: bool,
}

impl ActivationLaw {
    fn tau(self) -> Option<f64> {
        match self {
            ActivationLaw::Integrator | ActivationLaw::PidIntegral { .. } => None,
            ActivationLaw::Filter { tau } | ActivationLaw::FilterExact { tau } => {
                Some(tau.max(MIN_TIME_CONSTANT))
            }
        }
    }
}

impl Model {
    /// Number of activation states (MuJoCo's `na`): one per actuator with an activation.
    pub fn na(&self) -> usize {
        self.actuators
            .iter()
            .filter(|a| a.activation.is_some())
            .count()
    }

    /// Refuses a state's activations `act` of another number than [`Model::na`].
    pub fn check_activations<T>(&self, act: &[T]) -> Result<(), DynamicsError> {
        match self.na() {
            n if n == act.len() => Ok(()),
            expected => Err(DynamicsError::Activations {
                expected,
                got: act.len(),
            }),
        }
    }

    /// The actuators with an activation, each with its index among the actuators, in the
    /// order of the activation states.
    fn activated(&self) -> impl Iterator<Item = (usize, &Activation)> {
        (self.actuators.iter().enumerate())
            .filter_map(|(i, a)| a.activation.as_ref().map(|d| (i, d)))
    }

    /// `ȧ` of every activation `act` under the controls `ctrl` (each clamped to its range;
    /// the derivative with respect to a clamped control is zero) at the configuration `q` (read
    /// by a PID's integral only).
    pub fn activation_rates<T: Scalar>(&self, act: &[T], ctrl: &[T], q: &[T]) -> Vec<T> {
        self.activated()
            .zip(act)
            .map(|((i, d), &a)| {
                let u = self.actuators[i].clamped_control(ctrl[i]);
                match d.law {
                    ActivationLaw::PidIntegral { step, bound, .. } => {
                        (self.pid_next_integral(i, a, u, q, step, bound) - a) / step
                    }
                    law => match law.tau() {
                        None => u,
                        Some(tau) => (u - a) / tau,
                    },
                }
            })
            .collect()
    }

    /// A PID's next error integral `clamp(I + (u - L) h, ±bound)` (MuJoCo's plugin), `L` the
    /// length of actuator `i` at `q`: `gear · q` on a joint, `gear · L(q)` on a fixed tendon
    /// (the scene refuses a PID's integral on other transmissions).
    fn pid_next_integral<T: Scalar>(
        &self,
        i: usize,
        integral: T,
        u: T,
        q: &[T],
        step: f64,
        bound: Option<f64>,
    ) -> T {
        let a = &self.actuators[i];
        let length = match a.target {
            super::Transmission::Joint(j) => q[self.tree.joints[j].qadr],
            super::Transmission::Tendon(t) => self.tendons[t].length(q),
            _ => unreachable!("a PID's integral on a joint or a fixed tendon (scene)"),
        } * a.gear;
        let next = integral + (u - length) * step;
        match bound {
            Some(b) if next.re() > b => c(b),
            Some(b) if next.re() < -b => c(-b),
            _ => next,
        }
    }

    /// The activations after an Euler-family step `h` from `act` at the rates `rates`: the
    /// filters of [`ActivationLaw::FilterExact`] exactly, the others by Euler's rule, each
    /// clamped to its range (MuJoCo's `mj_nextActivation`).
    pub fn next_activations<T: Scalar>(&self, act: &[T], rates: &[T], h: T) -> Vec<T> {
        self.activated()
            .zip(act.iter().zip(rates))
            .map(|((_, d), (&a, &r))| {
                let next = match d.law {
                    ActivationLaw::FilterExact { .. } => {
                        let tau = d.law.tau().unwrap_or(MIN_TIME_CONSTANT);
                        a + r * (-(-h / tau).exp_m1()) * tau
                    }
                    _ => a + r * h,
                };
                clamp_to(next, d.range)
            })
            .collect()
    }

    /// The inputs the force laws read at the configuration `q`: `u` with each activated
    /// actuator's control replaced by its activation from `act` (or, with `early`, by the
    /// activation after an Euler step `h` at the rate its control sets), a PID's with its
    /// integral by `kp u + ki I⁺` ([`ActivationLaw::PidIntegral`]). A model without activations
    /// reads `u` as it is.
    pub fn driven_inputs<T: Scalar>(&self, u: &[T], act: &[T], q: &[T], h: Option<T>) -> Vec<T> {
        let mut out = u.to_vec();
        if act.is_empty() {
            return out;
        }
        let next = h.map(|h| {
            let rates = self.activation_rates(act, u, q);
            self.next_activations(act, &rates, h)
        });
        for (k, (i, d)) in self.activated().enumerate() {
            out[i] = match (d.law, &next, d.early) {
                (
                    ActivationLaw::PidIntegral {
                        kp,
                        ki,
                        bound,
                        step,
                    },
                    ..,
                ) => {
                    let u = self.actuators[i].clamped_control(u[i]);
                    u * kp + self.pid_next_integral(i, act[k], u, q, step, bound) * ki
                }
                (_, Some(next), true) => next[k],
                _ => act[k],
            };
        }
        out
    }

    /// Activations clamped to their ranges (after a stage-wise integrator's step).
    pub fn clamp_activations<T: Scalar>(&self, act: &mut [T]) {
        for ((_, d), a) in self.activated().zip(act.iter_mut()) {
            *a = clamp_to(*a, d.range);
        }
    }
}

fn clamp_to<T: Scalar>(x: T, range: Option<(f64, f64)>) -> T {
    match range {
        Some((lo, _)) if x.re() < lo => c(lo),
        Some((_, hi)) if x.re() > hi => c(hi),
        _ => x,
    }
}
