//! Co-Simulation: `fmi2DoStep`, `fmi2CancelStep`, the status queries and input/output
//! derivatives.

use super::*;

impl<M: FmiModel> Instance<M> {
    /// `fmi2SetRealInputDerivatives`: not supported (`canInterpolateInputs="false"`).
    pub fn set_real_input_derivatives(
        &mut self,
        _vrs: &[u32],
        _orders: &[i32],
        _values: &[f64],
    ) -> fmi2Status {
        self.run(Function::SetRealInputDerivatives, |_| {
            Err("not supported: this FMU does not interpolate inputs (canInterpolateInputs=\"false\")".to_string().into())
        })
    }

    /// `fmi2GetRealOutputDerivatives`: not supported (`maxOutputDerivativeOrder="0"`).
    pub fn get_real_output_derivatives(
        &mut self,
        _vrs: &[u32],
        _orders: &[i32],
        _values: &mut [f64],
    ) -> fmi2Status {
        self.run(Function::GetRealOutputDerivatives, |_| {
            Err("not supported: this FMU provides no output derivatives (maxOutputDerivativeOrder=\"0\")".to_string().into())
        })
    }

    /// `fmi2DoStep`: advances the model from its own time (which `current_communication_point`
    /// must match within [`COMMUNICATION_POINT_RELATIVE_TOLERANCE`]) by `step`.
    /// A step the model discards returns `fmi2Discard` with the state at the start of the step;
    /// the host may retry (also from `StepFailed`).
    pub fn do_step(
        &mut self,
        current_communication_point: f64,
        step: f64,
        _no_set_fmu_state_prior: bool,
    ) -> fmi2Status {
        self.run(Function::DoStep, |this| {
            if !(step.is_finite() && step > 0.0) {
                return Err(format!("communicationStepSize must be finite and > 0, got {step:?}; the state is unchanged").into());
            }
            let now = this.model.time();
            let tol = COMMUNICATION_POINT_RELATIVE_TOLERANCE * now.abs().max(step);
            if !current_communication_point.is_finite() || (current_communication_point - now).abs() > tol {
                return Err(format!(
                    "currentCommunicationPoint = {current_communication_point:?} does not match the FMU's time {now:?} \
                     (tolerance {tol:e}); the state is unchanged"
                )
                .into());
            }
            if let Some(stop) = this.stop_time {
                let end = now + step;
                if passes_stop_time(end, stop, step) {
                    return Err(format!("the step to t = {end:?} would pass stopTime = {stop:?}; the state is unchanged").into());
                }
            }
            match this.model.do_step(now, step) {
                Ok(()) => {
                    this.state = ModelState::StepComplete;
                    this.last_successful_time = this.model.time();
                    Ok(fmi2OK)
                }
                Err(StepError::Discard(m)) => {
                    this.state = ModelState::StepFailed;
                    Err(Failure::Discard(format!("step from t = {now:?} by {step:?} discarded: {m}; the state is that at t = {:?}", this.model.time())))
                }
                Err(StepError::Error(m)) => Err(format!("step from t = {now:?} by {step:?} refused: {m}").into()),
            }
        })
    }

    /// `fmi2CancelStep`: not supported (steps are synchronous).
    pub fn cancel_step(&mut self) -> fmi2Status {
        self.log_error("fmi2CancelStep: not supported: asynchronous stepping is not offered (fmi2DoStep never returns fmi2Pending)");
        fmi2Error
    }

    fn status_kind_name(kind: fmi2StatusKind) -> String {
        let names = [
            (crate::fmi::ffi::fmi2DoStepStatus, "fmi2DoStepStatus"),
            (crate::fmi::ffi::fmi2PendingStatus, "fmi2PendingStatus"),
            (fmi2LastSuccessfulTime, "fmi2LastSuccessfulTime"),
            (fmi2Terminated, "fmi2Terminated"),
        ];
        match names.iter().find(|(k, _)| *k == kind) {
            Some((_, name)) => (*name).to_owned(),
            None => format!("unknown status kind {kind}"),
        }
    }

    fn unsupported_status(kind: fmi2StatusKind) -> Outcome {
        Err(format!(
            "{} is not available from this function (steps are synchronous, never pending)",
            Self::status_kind_name(kind)
        )
        .into())
    }

    /// `fmi2GetStatus`: not available (no asynchronous steps).
    pub fn get_status(&mut self, kind: fmi2StatusKind, _value: &mut fmi2Status) -> fmi2Status {
        self.run(Function::GetStatus, |_| Self::unsupported_status(kind))
    }

    /// `fmi2GetRealStatus`: `fmi2LastSuccessfulTime` only.
    pub fn get_real_status(&mut self, kind: fmi2StatusKind, value: &mut f64) -> fmi2Status {
        self.run(Function::GetRealStatus, |this| {
            if kind == fmi2LastSuccessfulTime {
                *value = this.last_successful_time;
                Ok(fmi2OK)
            } else {
                Self::unsupported_status(kind)
            }
        })
    }

    /// `fmi2GetIntegerStatus`: nothing available.
    pub fn get_integer_status(&mut self, kind: fmi2StatusKind, _value: &mut i32) -> fmi2Status {
        self.run(Function::GetIntegerStatus, |_| {
            Self::unsupported_status(kind)
        })
    }

    /// `fmi2GetBooleanStatus`: `fmi2Terminated` only, the standard's question after a discarded
    /// step: true while the last `fmi2DoStep` was discarded (`StepFailed`), false otherwise.
    ///
    /// After a discard the FMU keeps the state at the start of the refused step and would accept
    /// a retry with a smaller step; but a master that cannot shrink its step (fmpy's
    /// `simulate_fmu` retries the same step for as long as `fmi2Terminated` is false, recording a
    /// sample each time) would loop forever. So the FMU asks to end the simulation there, and a
    /// master that can retry still may: `fmi2DoStep` stays legal in `StepFailed`.
    pub fn get_boolean_status(
        &mut self,
        kind: fmi2StatusKind,
        value: &mut fmi2Boolean,
    ) -> fmi2Status {
        self.run(Function::GetBooleanStatus, |this| {
            if kind == fmi2Terminated {
                *value = fmi_bool(this.state == ModelState::StepFailed);
                Ok(fmi2OK)
            } else {
                Self::unsupported_status(kind)
            }
        })
    }

    /// `fmi2GetStringStatus`: nothing available.
    pub fn get_string_status(&mut self, kind: fmi2StatusKind) -> fmi2Status {
        self.run(Function::GetStringStatus, |_| {
            Self::unsupported_status(kind)
        })
    }
}
