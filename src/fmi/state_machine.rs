//! The FMI 2.0 call-sequence state machine, as data.
//!
//! Each `fmi2*` function declares the set of states it may be called in, separately for
//! Co-Simulation (FMI 2.0.4, section 4.2.4) and Model Exchange (section 3.2.3); one function,
//! [`check`], tells whether a call is legal. States are bits of a `u32` so a set is a mask.
//!
//! Deviations from the standard, all more permissive and documented here:
//! - `fmi2FreeInstance` is legal in every state (a host must always be able to free).
//! - `fmi2DoStep` is also legal in `StepFailed`: a discarded step was rolled back to its start,
//!   so the host may retry with a smaller step.
//! - `fmi2GetDerivatives` is also legal in `InitializationMode`.

use std::fmt;

/// A state of the FMI 2.0 state machine (Co-Simulation and Model Exchange states together).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum ModelState {
    /// After `fmi2Instantiate` (and after `fmi2Reset`).
    Instantiated = 1 << 0,
    /// Between `fmi2EnterInitializationMode` and `fmi2ExitInitializationMode`.
    InitializationMode = 1 << 1,
    /// (CS) Ready for the next `fmi2DoStep`.
    StepComplete = 1 << 2,
    /// (CS) Asynchronous step running (never entered here: steps are synchronous).
    StepInProgress = 1 << 3,
    /// (CS) The last `fmi2DoStep` returned `fmi2Discard`.
    StepFailed = 1 << 4,
    /// (CS) `fmi2CancelStep` was called (never entered here).
    StepCanceled = 1 << 5,
    /// (ME) Event mode.
    EventMode = 1 << 6,
    /// (ME) Continuous-time mode.
    ContinuousTimeMode = 1 << 7,
    /// After `fmi2Terminate`.
    Terminated = 1 << 8,
    /// A call failed in a way that left the model in an unknown state (e.g. a failed reset).
    Error = 1 << 9,
    /// A panic happened inside the instance: only `fmi2FreeInstance` is allowed.
    Fatal = 1 << 10,
}

impl ModelState {
    /// Every state.
    pub const ALL: [ModelState; 11] = [
        ModelState::Instantiated,
        ModelState::InitializationMode,
        ModelState::StepComplete,
        ModelState::StepInProgress,
        ModelState::StepFailed,
        ModelState::StepCanceled,
        ModelState::EventMode,
        ModelState::ContinuousTimeMode,
        ModelState::Terminated,
        ModelState::Error,
        ModelState::Fatal,
    ];

    /// The state's bit.
    pub const fn bit(self) -> u32 {
        self as u32
    }

    /// Name used in messages (the standard's name).
    pub fn name(self) -> &'static str {
        match self {
            ModelState::Instantiated => "Instantiated",
            ModelState::InitializationMode => "InitializationMode",
            ModelState::StepComplete => "StepComplete",
            ModelState::StepInProgress => "StepInProgress",
            ModelState::StepFailed => "StepFailed",
            ModelState::StepCanceled => "StepCanceled",
            ModelState::EventMode => "EventMode",
            ModelState::ContinuousTimeMode => "ContinuousTimeMode",
            ModelState::Terminated => "Terminated",
            ModelState::Error => "Error",
            ModelState::Fatal => "Fatal",
        }
    }
}

impl fmt::Display for ModelState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The interface an instance was created for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interface {
    /// Co-Simulation (`fmi2CoSimulation`).
    CoSimulation,
    /// Model Exchange (`fmi2ModelExchange`).
    ModelExchange,
}

/// Every `fmi2*` function that depends on the instance's state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[allow(missing_docs)]
pub enum Function {
    SetDebugLogging,
    FreeInstance,
    SetupExperiment,
    EnterInitializationMode,
    ExitInitializationMode,
    Terminate,
    Reset,
    GetReal,
    GetInteger,
    GetBoolean,
    GetString,
    SetReal,
    SetInteger,
    SetBoolean,
    SetString,
    GetFMUstate,
    SetFMUstate,
    FreeFMUstate,
    SerializedFMUstateSize,
    SerializeFMUstate,
    DeSerializeFMUstate,
    GetDirectionalDerivative,
    // Co-Simulation
    SetRealInputDerivatives,
    GetRealOutputDerivatives,
    DoStep,
    CancelStep,
    GetStatus,
    GetRealStatus,
    GetIntegerStatus,
    GetBooleanStatus,
    GetStringStatus,
    // Model Exchange
    EnterEventMode,
    NewDiscreteStates,
    EnterContinuousTimeMode,
    CompletedIntegratorStep,
    SetTime,
    SetContinuousStates,
    GetDerivatives,
    GetEventIndicators,
    GetContinuousStates,
    GetNominalsOfContinuousStates,
}

use ModelState as S;

const INST: u32 = S::Instantiated.bit();
const INIT: u32 = S::InitializationMode.bit();
const STEP_COMPLETE: u32 = S::StepComplete.bit();
const STEP_IN_PROGRESS: u32 = S::StepInProgress.bit();
const STEP_FAILED: u32 = S::StepFailed.bit();
const STEP_CANCELED: u32 = S::StepCanceled.bit();
const EVENT: u32 = S::EventMode.bit();
const CONT: u32 = S::ContinuousTimeMode.bit();
const TERMINATED: u32 = S::Terminated.bit();
const ERROR: u32 = S::Error.bit();
const FATAL: u32 = S::Fatal.bit();
const NONE: u32 = 0;
const ANY: u32 = INST
    | INIT
    | STEP_COMPLETE
    | STEP_IN_PROGRESS
    | STEP_FAILED
    | STEP_CANCELED
    | EVENT
    | CONT
    | TERMINATED
    | ERROR
    | FATAL;

impl Function {
    /// The C name, e.g. `fmi2DoStep`.
    pub fn c_name(self) -> &'static str {
        use Function::*;
        match self {
            SetDebugLogging => "fmi2SetDebugLogging",
            FreeInstance => "fmi2FreeInstance",
            SetupExperiment => "fmi2SetupExperiment",
            EnterInitializationMode => "fmi2EnterInitializationMode",
            ExitInitializationMode => "fmi2ExitInitializationMode",
            Terminate => "fmi2Terminate",
            Reset => "fmi2Reset",
            GetReal => "fmi2GetReal",
            GetInteger => "fmi2GetInteger",
            GetBoolean => "fmi2GetBoolean",
            GetString => "fmi2GetString",
            SetReal => "fmi2SetReal",
            SetInteger => "fmi2SetInteger",
            SetBoolean => "fmi2SetBoolean",
            SetString => "fmi2SetString",
            GetFMUstate => "fmi2GetFMUstate",
            SetFMUstate => "fmi2SetFMUstate",
            FreeFMUstate => "fmi2FreeFMUstate",
            SerializedFMUstateSize => "fmi2SerializedFMUstateSize",
            SerializeFMUstate => "fmi2SerializeFMUstate",
            DeSerializeFMUstate => "fmi2DeSerializeFMUstate",
            GetDirectionalDerivative => "fmi2GetDirectionalDerivative",
            SetRealInputDerivatives => "fmi2SetRealInputDerivatives",
            GetRealOutputDerivatives => "fmi2GetRealOutputDerivatives",
            DoStep => "fmi2DoStep",
            CancelStep => "fmi2CancelStep",
            GetStatus => "fmi2GetStatus",
            GetRealStatus => "fmi2GetRealStatus",
            GetIntegerStatus => "fmi2GetIntegerStatus",
            GetBooleanStatus => "fmi2GetBooleanStatus",
            GetStringStatus => "fmi2GetStringStatus",
            EnterEventMode => "fmi2EnterEventMode",
            NewDiscreteStates => "fmi2NewDiscreteStates",
            EnterContinuousTimeMode => "fmi2EnterContinuousTimeMode",
            CompletedIntegratorStep => "fmi2CompletedIntegratorStep",
            SetTime => "fmi2SetTime",
            SetContinuousStates => "fmi2SetContinuousStates",
            GetDerivatives => "fmi2GetDerivatives",
            GetEventIndicators => "fmi2GetEventIndicators",
            GetContinuousStates => "fmi2GetContinuousStates",
            GetNominalsOfContinuousStates => "fmi2GetNominalsOfContinuousStates",
        }
    }

    /// Mask of the states this function is legal in, for Co-Simulation.
    pub fn co_simulation_mask(self) -> u32 {
        use Function::*;
        let all_but_start =
            INST | INIT | STEP_COMPLETE | STEP_FAILED | STEP_CANCELED | TERMINATED | ERROR;
        match self {
            SetDebugLogging => all_but_start | STEP_IN_PROGRESS,
            FreeInstance => ANY,
            SetupExperiment | EnterInitializationMode => INST,
            ExitInitializationMode => INIT,
            Terminate => STEP_COMPLETE | STEP_FAILED,
            Reset => all_but_start,
            GetReal | GetInteger | GetBoolean | GetString => {
                INIT | STEP_COMPLETE | STEP_FAILED | STEP_CANCELED | TERMINATED | ERROR
            }
            SetReal | SetInteger | SetBoolean | SetString => INST | INIT | STEP_COMPLETE,
            GetFMUstate
            | SetFMUstate
            | FreeFMUstate
            | SerializedFMUstateSize
            | SerializeFMUstate
            | DeSerializeFMUstate => all_but_start,
            GetDirectionalDerivative => {
                INIT | STEP_COMPLETE | STEP_FAILED | STEP_CANCELED | TERMINATED | ERROR
            }
            SetRealInputDerivatives => INST | INIT | STEP_COMPLETE,
            GetRealOutputDerivatives => {
                STEP_COMPLETE | STEP_FAILED | STEP_CANCELED | TERMINATED | ERROR
            }
            DoStep => STEP_COMPLETE | STEP_FAILED,
            CancelStep => STEP_IN_PROGRESS,
            GetStatus | GetRealStatus | GetIntegerStatus | GetBooleanStatus | GetStringStatus => {
                STEP_COMPLETE | STEP_IN_PROGRESS | STEP_FAILED | TERMINATED
            }
            EnterEventMode
            | NewDiscreteStates
            | EnterContinuousTimeMode
            | CompletedIntegratorStep
            | SetTime
            | SetContinuousStates
            | GetDerivatives
            | GetEventIndicators
            | GetContinuousStates
            | GetNominalsOfContinuousStates => NONE,
        }
    }

    /// Mask of the states this function is legal in, for Model Exchange.
    pub fn model_exchange_mask(self) -> u32 {
        use Function::*;
        let all_but_start = INST | INIT | EVENT | CONT | TERMINATED | ERROR;
        match self {
            SetDebugLogging => all_but_start,
            FreeInstance => ANY,
            SetupExperiment | EnterInitializationMode => INST,
            ExitInitializationMode => INIT,
            Terminate => EVENT | CONT,
            Reset => all_but_start,
            GetReal | GetInteger | GetBoolean | GetString => {
                INIT | EVENT | CONT | TERMINATED | ERROR
            }
            SetReal => INST | INIT | EVENT | CONT,
            SetInteger | SetBoolean | SetString => INST | INIT | EVENT,
            GetFMUstate
            | SetFMUstate
            | FreeFMUstate
            | SerializedFMUstateSize
            | SerializeFMUstate
            | DeSerializeFMUstate => all_but_start,
            GetDirectionalDerivative => INIT | EVENT | CONT | TERMINATED | ERROR,
            EnterEventMode => EVENT | CONT,
            NewDiscreteStates | EnterContinuousTimeMode => EVENT,
            CompletedIntegratorStep | SetContinuousStates => CONT,
            SetTime => EVENT | CONT,
            GetDerivatives | GetEventIndicators | GetContinuousStates => {
                INIT | EVENT | CONT | TERMINATED | ERROR
            }
            GetNominalsOfContinuousStates => INST | EVENT | CONT | TERMINATED | ERROR,
            SetRealInputDerivatives
            | GetRealOutputDerivatives
            | DoStep
            | CancelStep
            | GetStatus
            | GetRealStatus
            | GetIntegerStatus
            | GetBooleanStatus
            | GetStringStatus => NONE,
        }
    }

    /// Mask of the legal states for `interface`.
    pub fn mask(self, interface: Interface) -> u32 {
        match interface {
            Interface::CoSimulation => self.co_simulation_mask(),
            Interface::ModelExchange => self.model_exchange_mask(),
        }
    }
}

/// Whether `function` may be called in `state` for `interface`; the error is the message to log.
pub fn check(function: Function, interface: Interface, state: ModelState) -> Result<(), String> {
    let mask = function.mask(interface);
    if mask & state.bit() != 0 {
        Ok(())
    } else if mask == NONE {
        let which = match interface {
            Interface::CoSimulation => "Co-Simulation",
            Interface::ModelExchange => "Model Exchange",
        };
        Err(format!(
            "Illegal call sequence: {} is not allowed in state {} ({} is not part of {})",
            function.c_name(),
            state,
            function.c_name(),
            which
        ))
    } else {
        Err(format!(
            "Illegal call sequence: {} is not allowed in state {}",
            function.c_name(),
            state
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn do_step_only_after_initialization() {
        let cs = Interface::CoSimulation;
        assert!(check(Function::DoStep, cs, ModelState::StepComplete).is_ok());
        assert!(check(Function::DoStep, cs, ModelState::StepFailed).is_ok());
        let err = check(Function::DoStep, cs, ModelState::Instantiated).unwrap_err();
        assert_eq!(
            err,
            "Illegal call sequence: fmi2DoStep is not allowed in state Instantiated"
        );
        assert!(check(Function::DoStep, cs, ModelState::Terminated).is_err());
    }

    #[test]
    fn model_exchange_functions_are_not_co_simulation() {
        let err = check(
            Function::SetTime,
            Interface::CoSimulation,
            ModelState::StepComplete,
        )
        .unwrap_err();
        assert!(
            err.starts_with(
                "Illegal call sequence: fmi2SetTime is not allowed in state StepComplete"
            ),
            "{err}"
        );
        assert!(check(
            Function::DoStep,
            Interface::ModelExchange,
            ModelState::ContinuousTimeMode
        )
        .is_err());
        assert!(check(
            Function::SetTime,
            Interface::ModelExchange,
            ModelState::ContinuousTimeMode
        )
        .is_ok());
    }

    #[test]
    fn fatal_allows_only_free_instance() {
        for interface in [Interface::CoSimulation, Interface::ModelExchange] {
            for f in [
                Function::GetReal,
                Function::Reset,
                Function::SetDebugLogging,
                Function::GetFMUstate,
                Function::Terminate,
            ] {
                assert!(check(f, interface, ModelState::Fatal).is_err());
            }
            assert!(check(Function::FreeInstance, interface, ModelState::Fatal).is_ok());
        }
    }

    #[test]
    fn setup_and_initialization_order() {
        for interface in [Interface::CoSimulation, Interface::ModelExchange] {
            assert!(check(
                Function::SetupExperiment,
                interface,
                ModelState::Instantiated
            )
            .is_ok());
            assert!(check(
                Function::SetupExperiment,
                interface,
                ModelState::InitializationMode
            )
            .is_err());
            assert!(check(
                Function::ExitInitializationMode,
                interface,
                ModelState::Instantiated
            )
            .is_err());
            assert!(check(Function::GetReal, interface, ModelState::Instantiated).is_err());
            assert!(check(Function::SetReal, interface, ModelState::Instantiated).is_ok());
        }
    }

    #[test]
    fn every_state_has_a_distinct_bit() {
        let mut seen = 0;
        for s in ModelState::ALL {
            assert_eq!(s.bit().count_ones(), 1);
            assert_eq!(seen & s.bit(), 0);
            seen |= s.bit();
        }
        assert_eq!(seen, ANY);
    }
}
