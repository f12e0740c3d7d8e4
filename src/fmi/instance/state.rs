//! FMU states: `fmi2GetFMUstate`/`SetFMUstate`/`FreeFMUstate`, their serialization, and
//! directional derivatives.

use super::*;

impl<M: FmiModel> Instance<M> {
    fn restorable(&self, machine: ModelState) -> bool {
        use ModelState::*;
        match self.interface {
            Interface::CoSimulation => matches!(
                machine,
                Instantiated | InitializationMode | StepComplete | Terminated | Error
            ),
            Interface::ModelExchange => {
                matches!(
                    machine,
                    Instantiated
                        | InitializationMode
                        | EventMode
                        | ContinuousTimeMode
                        | Terminated
                        | Error
                )
            }
        }
    }

    fn unknown_handle(handle: FmuStateHandle) -> Failure {
        Failure::Error(format!(
            "unknown FMU state {:#x} (already freed, or not created by this instance); nothing was done",
            handle.0
        ))
    }

    /// `fmi2GetFMUstate`: saves the current state into `*slot` (a new handle if `None`, else
    /// overwriting that known state).
    pub fn get_fmu_state(&mut self, slot: &mut Option<FmuStateHandle>) -> fmi2Status {
        self.run(Function::GetFMUstate, |this| {
            this.require(
                this.model.info().capabilities.can_get_and_set_fmu_state,
                "canGetAndSetFMUstate",
            )?;
            if let Some(h) = *slot {
                if !this.saved.contains_key(&h) {
                    return Err(Self::unknown_handle(h));
                }
            }
            let model = this.model.get_state()?;
            let machine = if this.state == ModelState::StepFailed {
                ModelState::StepComplete
            } else {
                this.state
            };
            let saved = Saved {
                model,
                machine,
                last_successful_time: this.last_successful_time,
                stop_time: this.stop_time,
                serialized: None,
            };
            let handle = slot.unwrap_or_else(new_handle);
            this.saved.insert(handle, saved);
            *slot = Some(handle);
            this.log_event(|| {
                format!(
                    "fmi2GetFMUstate: saved state {:#x} at t = {:?}",
                    handle.0,
                    this.model.time()
                )
            });
            Ok(fmi2OK)
        })
    }

    /// `fmi2SetFMUstate`: restores a saved state (model and state machine).
    pub fn set_fmu_state(&mut self, handle: Option<FmuStateHandle>) -> fmi2Status {
        self.run(Function::SetFMUstate, |this| {
            this.require(
                this.model.info().capabilities.can_get_and_set_fmu_state,
                "canGetAndSetFMUstate",
            )?;
            let h = handle.ok_or_else(|| "FMUstate is NULL".to_string())?;
            let saved = this.saved.get(&h).ok_or_else(|| Self::unknown_handle(h))?;
            this.model.set_state(&saved.model)?;
            this.state = saved.machine;
            this.last_successful_time = saved.last_successful_time;
            this.stop_time = saved.stop_time;
            this.log_event(|| {
                format!(
                    "fmi2SetFMUstate: restored state {:#x}, t = {:?}",
                    h.0,
                    this.model.time()
                )
            });
            Ok(fmi2OK)
        })
    }

    /// `fmi2FreeFMUstate`: frees `*slot` and sets it to `None`; `None` is ignored. A handle that
    /// is unknown (double free, foreign pointer) is refused.
    pub fn free_fmu_state(&mut self, slot: &mut Option<FmuStateHandle>) -> fmi2Status {
        self.run(Function::FreeFMUstate, |this| {
            if let Some(h) = *slot {
                this.saved
                    .remove(&h)
                    .ok_or_else(|| Self::unknown_handle(h))?;
                *slot = None;
            }
            Ok(fmi2OK)
        })
    }

    fn serialized(&mut self, handle: FmuStateHandle) -> Result<&[u8], Failure> {
        let saved = self
            .saved
            .get_mut(&handle)
            .ok_or_else(|| Self::unknown_handle(handle))?;
        if saved.serialized.is_none() {
            let model_bytes = self.model.serialize_state(&saved.model)?;
            saved.serialized = Some(serial::encode(
                &self.model.info().guid,
                saved.machine.bit(),
                saved.last_successful_time,
                saved.stop_time,
                &model_bytes,
            ));
        }
        Ok(saved.serialized.as_deref().unwrap_or_default())
    }

    /// Refuses a call of an optional capability that `modelDescription.xml` does not declare.
    fn require(&self, declared: bool, flag: &str) -> Result<(), Failure> {
        if declared {
            Ok(())
        } else {
            Err(format!("not supported: this FMU declares {flag}=\"false\"").into())
        }
    }

    /// `fmi2SerializedFMUstateSize`.
    pub fn serialized_fmu_state_size(
        &mut self,
        handle: Option<FmuStateHandle>,
        size: &mut usize,
    ) -> fmi2Status {
        self.run(Function::SerializedFMUstateSize, |this| {
            this.require(
                this.model.info().capabilities.can_serialize_fmu_state,
                "canSerializeFMUstate",
            )?;
            let h = handle.ok_or_else(|| "FMUstate is NULL".to_string())?;
            *size = this.serialized(h)?.len();
            Ok(fmi2OK)
        })
    }

    /// `fmi2SerializeFMUstate`: `out` must hold at least `fmi2SerializedFMUstateSize` bytes.
    pub fn serialize_fmu_state(
        &mut self,
        handle: Option<FmuStateHandle>,
        out: &mut [u8],
    ) -> fmi2Status {
        self.run(Function::SerializeFMUstate, |this| {
            this.require(
                this.model.info().capabilities.can_serialize_fmu_state,
                "canSerializeFMUstate",
            )?;
            let h = handle.ok_or_else(|| "FMUstate is NULL".to_string())?;
            let bytes = this.serialized(h)?;
            if out.len() < bytes.len() {
                return Err(format!(
                    "buffer of {} bytes is too small: the state needs {}",
                    out.len(),
                    bytes.len()
                )
                .into());
            }
            out[..bytes.len()].copy_from_slice(bytes);
            Ok(fmi2OK)
        })
    }

    /// `fmi2DeSerializeFMUstate`: into `*slot` (new handle if `None`, else that known state).
    /// Corrupt or foreign bytes are refused.
    pub fn deserialize_fmu_state(
        &mut self,
        bytes: &[u8],
        slot: &mut Option<FmuStateHandle>,
    ) -> fmi2Status {
        self.run(Function::DeSerializeFMUstate, |this| {
            this.require(this.model.info().capabilities.can_serialize_fmu_state, "canSerializeFMUstate")?;
            if let Some(h) = *slot {
                if !this.saved.contains_key(&h) {
                    return Err(Self::unknown_handle(h));
                }
            }
            let decoded = serial::decode(bytes, &this.model.info().guid)?;
            let machine = ModelState::ALL.into_iter().find(|s| s.bit() == decoded.machine).filter(|s| this.restorable(*s));
            let machine = machine.ok_or_else(|| format!("serialized state was saved in a state-machine state ({:#x}) this {:?} instance cannot restore", decoded.machine, this.interface))?;
            let (last_successful_time, stop_time) = (decoded.last_successful_time, decoded.stop_time);
            if !last_successful_time.is_finite() || stop_time.is_some_and(|s| !s.is_finite()) {
                return Err(format!("serialized state is corrupt: last successful time {last_successful_time:?}, stop time {stop_time:?}").into());
            }
            let model_bytes = decoded.model;
            let model = this.model.deserialize_state(model_bytes)?;
            let handle = slot.unwrap_or_else(new_handle);
            this.saved.insert(handle, Saved { model, machine, last_successful_time, stop_time, serialized: Some(bytes.to_vec()) });
            *slot = Some(handle);
            Ok(fmi2OK)
        })
    }

    /// `fmi2GetDirectionalDerivative`: `dv_unknown = J[unknowns, knowns] · dv_known`.
    pub fn get_directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        dv_known: &[f64],
        dv_unknown: &mut [f64],
    ) -> fmi2Status {
        self.run(Function::GetDirectionalDerivative, |this| {
            this.require(
                this.model
                    .info()
                    .capabilities
                    .provides_directional_derivative,
                "providesDirectionalDerivative",
            )?;
            Self::same_length("dvKnown", knowns.len(), dv_known.len())?;
            Self::same_length("dvUnknown", unknowns.len(), dv_unknown.len())?;
            this.check_known(Kind::Real, unknowns)?;
            this.check_known(Kind::Real, knowns)?;
            let dv = this
                .model
                .directional_derivative(unknowns, knowns, dv_known)?;
            Self::same_length(
                "the model's directional derivative",
                unknowns.len(),
                dv.len(),
            )?;
            dv_unknown.copy_from_slice(&dv);
            Ok(fmi2OK)
        })
    }
}
