//! Model Exchange: time, continuous states, derivatives, events.

use super::*;

impl<M: FmiModel> Instance<M> {
    /// `fmi2EnterEventMode`.
    pub fn enter_event_mode(&mut self) -> fmi2Status {
        self.run(Function::EnterEventMode, |this| {
            this.state = ModelState::EventMode;
            Ok(fmi2OK)
        })
    }

    /// `fmi2NewDiscreteStates`: the model has no discrete states, event indicators or time
    /// events; its event update ([`FmiModel::event_update`]) may change the continuous states.
    pub fn new_discrete_states(&mut self, info: &mut fmi2EventInfo) -> fmi2Status {
        self.run(Function::NewDiscreteStates, |this| {
            let changed = this.model.event_update()?;
            *info = fmi2EventInfo {
                valuesOfContinuousStatesChanged: fmi_bool(changed),
                ..fmi2EventInfo::default()
            };
            if changed {
                this.log_event(|| {
                    format!(
                    "fmi2NewDiscreteStates: the model changed its continuous states at t = {:?}",
                    this.model.time()
                )
                });
            }
            Ok(fmi2OK)
        })
    }

    /// `fmi2EnterContinuousTimeMode`.
    pub fn enter_continuous_time_mode(&mut self) -> fmi2Status {
        self.run(Function::EnterContinuousTimeMode, |this| {
            this.state = ModelState::ContinuousTimeMode;
            Ok(fmi2OK)
        })
    }

    /// `fmi2CompletedIntegratorStep`: returns through `enter_event_mode` whether the host must
    /// enter event mode; `terminate_simulation` is always false.
    pub fn completed_integrator_step(
        &mut self,
        _no_set_fmu_state_prior: bool,
        enter_event_mode: &mut bool,
        terminate_simulation: &mut bool,
    ) -> fmi2Status {
        self.run(Function::CompletedIntegratorStep, |this| {
            *enter_event_mode = this.model.completed_integrator_step()?;
            *terminate_simulation = false;
            Ok(fmi2OK)
        })
    }

    /// `fmi2SetTime`.
    pub fn set_time(&mut self, time: f64) -> fmi2Status {
        self.run(Function::SetTime, |this| {
            if !time.is_finite() {
                return Err(format!("time must be finite, got {time:?}").into());
            }
            this.model.set_time(time)?;
            Ok(fmi2OK)
        })
    }

    /// `fmi2SetContinuousStates`: length must be the number of states; values must be finite.
    pub fn set_continuous_states(&mut self, x: &[f64]) -> fmi2Status {
        self.run(Function::SetContinuousStates, |this| {
            Self::same_length("x", this.model.number_of_states(), x.len())?;
            if let Some(i) = x.iter().position(|v| !v.is_finite()) {
                return Err(format!(
                    "x[{i}] = {:?} is not finite; the states are unchanged",
                    x[i]
                )
                .into());
            }
            this.model.set_continuous_states(x)?;
            Ok(fmi2OK)
        })
    }

    fn copy_states(
        &mut self,
        what: &str,
        out: &mut [f64],
        get: impl FnOnce(&mut M) -> Result<Vec<f64>, String>,
    ) -> Outcome {
        Self::same_length(what, self.model.number_of_states(), out.len())?;
        let v = get(&mut self.model)?;
        Self::same_length("the model's result", out.len(), v.len())?;
        out.copy_from_slice(&v);
        Ok(fmi2OK)
    }

    /// `fmi2GetDerivatives`.
    pub fn get_derivatives(&mut self, out: &mut [f64]) -> fmi2Status {
        self.run(Function::GetDerivatives, |this| {
            this.copy_states("derivatives", out, |m| m.get_derivatives())
        })
    }

    /// `fmi2GetContinuousStates`.
    pub fn get_continuous_states(&mut self, out: &mut [f64]) -> fmi2Status {
        self.run(Function::GetContinuousStates, |this| {
            this.copy_states("x", out, |m| m.get_continuous_states())
        })
    }

    /// `fmi2GetNominalsOfContinuousStates`.
    pub fn get_nominals_of_continuous_states(&mut self, out: &mut [f64]) -> fmi2Status {
        self.run(Function::GetNominalsOfContinuousStates, |this| {
            this.copy_states("x_nominal", out, |m| m.get_nominals())
        })
    }

    /// `fmi2GetEventIndicators`: the FMU has no event indicators (`ni` must be 0).
    pub fn get_event_indicators(&mut self, out: &mut [f64]) -> fmi2Status {
        self.run(Function::GetEventIndicators, |_| {
            Self::same_length(
                "eventIndicators (numberOfEventIndicators=\"0\")",
                0,
                out.len(),
            )?;
            Ok(fmi2OK)
        })
    }
}
