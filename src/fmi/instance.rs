//! One FMU instance in safe Rust: the model, the state machine, logging, saved FMU states.
//!
//! Every `fmi2*` function is a method returning an `fmi2Status`; arrays are slices, handles are
//! plain numbers. The C boundary (pointers, NULL checks, panics) is in [`super::exports`].
//!
//! Logging: plumbing messages with a status of `fmi2Discard` or worse (refused calls, illegal
//! call sequences, discarded steps) are always logged, with category `logStatusError` (or
//! `logStatusWarning` for a discarded step); the model's own messages
//! ([`FmiModel::take_messages`]) and the plumbing's event messages are logged only when their
//! category is enabled (`loggingOn` of `fmi2Instantiate`, then `fmi2SetDebugLogging`).

use std::collections::HashMap;
use std::ffi::{c_char, CString};
use std::num::NonZeroUsize;
use std::sync::atomic::{AtomicUsize, Ordering};

use super::contract::{FmiModel, LogCategory, Phase, StepError, VarType};
use super::ffi::{
    c_string_lossless, fmi2Boolean, fmi2Discard, fmi2Error, fmi2EventInfo, fmi2False,
    fmi2LastSuccessfulTime, fmi2OK, fmi2Status, fmi2StatusKind, fmi2Terminated, fmi2True,
    fmi2Warning,
};
use super::serial;
use super::state_machine::{check, Function, Interface, ModelState};
use super::uri::resource_uri_to_path;

/// Where an instance's log messages go (the host's logger, or a test's collector).
pub trait LogSink {
    /// Logs `message` (plain text, never a format) with `status` under `category`.
    fn log(&self, status: fmi2Status, category: &str, message: &str);
}

/// `currentCommunicationPoint` of `fmi2DoStep` may differ from the instance's time by at most
/// this much, relative to the larger of the time and the step size (docs/fmu.md).
pub const COMMUNICATION_POINT_RELATIVE_TOLERANCE: f64 = 1e-9;

/// Whether a communication step of `step` (s) ending at `end` (s) passes `stop` (s), the
/// `stopTime` of `fmi2SetupExperiment`, by more than rounding: the same relative tolerance as
/// the communication point ([`COMMUNICATION_POINT_RELATIVE_TOLERANCE`], relative to the larger
/// of `|stop|` and the step), so that a host's time grid that lands on `stop` up to its last bits
/// is accepted, whatever the sign of `stop`. One function, used by the plumbing and by models,
/// so the two can never disagree on a step.
pub fn passes_stop_time(end: f64, stop: f64, step: f64) -> bool {
    end > stop + COMMUNICATION_POINT_RELATIVE_TOLERANCE * stop.abs().max(step)
}

/// Opaque handle of a saved FMU state (never 0, unique in the process, never reused).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FmuStateHandle(pub NonZeroUsize);

/// Source of handles: process-wide so that a handle of one instance is unknown to another.
static NEXT_HANDLE: AtomicUsize = AtomicUsize::new(1);

fn new_handle() -> FmuStateHandle {
    // Multiples of 16 (like heap pointers), starting at 16: never 0.
    let n = NEXT_HANDLE.fetch_add(1, Ordering::Relaxed);
    FmuStateHandle(NonZeroUsize::new(n.wrapping_mul(16)).unwrap_or(NonZeroUsize::MIN))
}

/// A saved FMU state: the model's part and the plumbing's part.
struct Saved<S> {
    model: S,
    machine: ModelState,
    last_successful_time: f64,
    /// `stopTime` of `fmi2SetupExperiment` when the state was saved (part of the state: a
    /// state restored after `fmi2Reset`, or into another instance, keeps its experiment).
    stop_time: Option<f64>,
    serialized: Option<Vec<u8>>,
}

/// Kinds of variables, for value-reference lookups.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Kind {
    Real,
    Integer,
    Boolean,
    String,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Real => "Real",
            Kind::Integer => "Integer",
            Kind::Boolean => "Boolean",
            Kind::String => "String",
        }
    }
}

/// Why a call failed.
enum Failure {
    /// `fmi2Error`, with the reason.
    Error(String),
    /// `fmi2Discard`, with the reason.
    Discard(String),
}

impl From<String> for Failure {
    fn from(message: String) -> Failure {
        Failure::Error(message)
    }
}

type Outcome = Result<fmi2Status, Failure>;

/// One FMU instance.
pub struct Instance<M: FmiModel> {
    model: M,
    name: String,
    interface: Interface,
    state: ModelState,
    log_enabled: [bool; LogCategory::ALL.len()],
    sink: Option<Box<dyn LogSink>>,
    saved: HashMap<FmuStateHandle, Saved<M::State>>,
    variables: HashMap<(Kind, u32), String>,
    stop_time: Option<f64>,
    last_successful_time: f64,
    strings: Vec<CString>,
}

fn category_index(category: LogCategory) -> usize {
    LogCategory::ALL
        .iter()
        .position(|&c| c == category)
        .unwrap_or(0)
}

fn fmi_bool(b: bool) -> fmi2Boolean {
    if b {
        fmi2True
    } else {
        fmi2False
    }
}

impl<M: FmiModel> Instance<M> {
    /// `fmi2Instantiate`: checks the arguments, builds the model from its resources and checks
    /// the GUID. On failure the reason is logged to `sink` (if any) and returned.
    pub fn instantiate(
        instance_name: &str,
        interface: Interface,
        guid: &str,
        resource_uri: &str,
        logging_on: bool,
        sink: Option<Box<dyn LogSink>>,
    ) -> Result<Instance<M>, String> {
        let fail = |message: String| {
            if let Some(sink) = &sink {
                sink.log(
                    fmi2Error,
                    LogCategory::StatusError.name(),
                    &format!("fmi2Instantiate: {message}"),
                );
            }
            Err(message)
        };
        if instance_name.is_empty() {
            return fail("instanceName is empty".into());
        }
        let resources = match resource_uri_to_path(resource_uri) {
            Ok(path) => path,
            Err(e) => return fail(e.to_string()),
        };
        let model = match M::instantiate(&resources) {
            Ok(model) => model,
            Err(e) => {
                return fail(format!(
                    "cannot build the model from {}: {e}",
                    resources.display()
                ))
            }
        };
        let info = model.info();
        if info.guid != guid {
            return fail(format!("fmuGUID {guid:?} does not match the FMU's guid {:?} (modelDescription.xml and binary differ)", info.guid));
        }
        if interface == Interface::ModelExchange && !info.model_exchange {
            return fail("this FMU does not offer Model Exchange".into());
        }
        let mut variables = HashMap::new();
        for v in &info.variables {
            let kind = match v.var_type {
                VarType::Real { .. } => Kind::Real,
                VarType::Integer { .. } => Kind::Integer,
                VarType::Boolean { .. } => Kind::Boolean,
                VarType::String { .. } => Kind::String,
            };
            variables.insert((kind, v.value_reference), v.name.clone());
        }
        let start_time = info.default_experiment.start_time.unwrap_or(0.0);
        let mut instance = Instance {
            model,
            name: instance_name.to_owned(),
            interface,
            state: ModelState::Instantiated,
            log_enabled: [logging_on; LogCategory::ALL.len()],
            sink,
            saved: HashMap::new(),
            variables,
            stop_time: None,
            last_successful_time: start_time,
            strings: Vec::new(),
        };
        instance
            .model
            .interface_chosen(interface == Interface::ModelExchange);
        for category in LogCategory::ALL {
            instance.model.logging_changed(category, logging_on);
        }
        instance.log_event(&format!(
            "fmi2Instantiate: instance {instance_name:?} created ({interface:?}) from {}",
            resources.display()
        ));
        instance.forward_messages();
        Ok(instance)
    }

    /// The model.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// The model, mutably (tests change its description).
    #[cfg(test)]
    pub(crate) fn model_mut(&mut self) -> &mut M {
        &mut self.model
    }

    /// The instance name given to `fmi2Instantiate`.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The interface the instance was created for.
    pub fn interface(&self) -> Interface {
        self.interface
    }

    /// The current state of the FMI state machine.
    pub fn state(&self) -> ModelState {
        self.state
    }

    /// Whether messages of `category` are currently logged.
    pub fn is_logging(&self, category: LogCategory) -> bool {
        self.log_enabled[category_index(category)]
    }

    /// Number of saved FMU states alive in this instance.
    pub fn saved_state_count(&self) -> usize {
        self.saved.len()
    }

    // ---- logging ------------------------------------------------------------------------------

    fn log(&self, status: fmi2Status, category: LogCategory, message: &str) {
        if let Some(sink) = &self.sink {
            sink.log(status, category.name(), message);
        }
    }

    /// Logs an error (always, whatever the enabled categories).
    pub fn log_error(&self, message: &str) {
        self.log(fmi2Error, LogCategory::StatusError, message);
    }

    fn log_event(&self, message: &str) {
        if self.is_logging(LogCategory::Events) {
            self.log(fmi2OK, LogCategory::Events, message);
        }
    }

    /// Passes the model's pending messages to the logger, honouring the enabled categories.
    fn forward_messages(&mut self) {
        for m in self.model.take_messages() {
            if self.is_logging(m.category) {
                let status = match m.category {
                    LogCategory::StatusError => fmi2Error,
                    LogCategory::StatusWarning => fmi2Warning,
                    _ => fmi2OK,
                };
                self.log(status, m.category, &m.text);
            }
        }
    }

    /// Marks the instance as corrupt after a panic in `function`: from now on only
    /// `fmi2FreeInstance` is accepted.
    pub fn mark_fatal(&mut self, function: &str, panic_message: &str) {
        self.state = ModelState::Fatal;
        self.log(
            super::ffi::fmi2Fatal,
            LogCategory::StatusError,
            &format!(
                "{function}: internal error (panic: {panic_message}); the instance must be freed"
            ),
        );
    }

    /// Logs that a NULL pointer was passed for `argument` of `function`; returns `fmi2Error`.
    pub fn null_argument(&self, function: &str, argument: &str) -> fmi2Status {
        self.log_error(&format!("{function}: argument {argument} is NULL"));
        fmi2Error
    }

    /// Logs that `argument` of `function` is invalid (e.g. not UTF-8); returns `fmi2Error`.
    pub fn bad_argument(&self, function: &str, argument: &str, reason: &str) -> fmi2Status {
        self.log_error(&format!(
            "{function}: argument {argument} is invalid: {reason}"
        ));
        fmi2Error
    }

    /// Runs `body` if `function` is legal now, then forwards model messages and logs a failure.
    fn run(&mut self, function: Function, body: impl FnOnce(&mut Self) -> Outcome) -> fmi2Status {
        let outcome = match check(function, self.interface, self.state) {
            Ok(()) => body(self).map_err(|f| match f {
                Failure::Error(m) => Failure::Error(format!("{}: {m}", function.c_name())),
                Failure::Discard(m) => Failure::Discard(format!("{}: {m}", function.c_name())),
            }),
            Err(message) => Err(Failure::Error(message)),
        };
        self.forward_messages();
        match outcome {
            Ok(status) => status,
            Err(Failure::Error(message)) => {
                self.log_error(&message);
                fmi2Error
            }
            Err(Failure::Discard(message)) => {
                self.log(fmi2Discard, LogCategory::StatusWarning, &message);
                fmi2Discard
            }
        }
    }

    fn phase(&self) -> Phase {
        match self.state {
            ModelState::Instantiated => Phase::Instantiated,
            ModelState::InitializationMode => Phase::Initialization,
            _ => Phase::Simulation,
        }
    }

    fn check_known(&self, kind: Kind, vrs: &[u32]) -> Result<(), Failure> {
        match vrs
            .iter()
            .find(|vr| !self.variables.contains_key(&(kind, **vr)))
        {
            Some(vr) => Err(Failure::Error(format!(
                "unknown value reference {vr}: no {} variable has it",
                kind.name()
            ))),
            None => Ok(()),
        }
    }

    fn var_name(&self, kind: Kind, vr: u32) -> &str {
        self.variables
            .get(&(kind, vr))
            .map(String::as_str)
            .unwrap_or("?")
    }

    fn same_length(what: &str, expected: usize, got: usize) -> Result<(), Failure> {
        if expected == got {
            Ok(())
        } else {
            Err(Failure::Error(format!(
                "{what} has {got} elements, expected {expected}"
            )))
        }
    }

    // ---- common functions ---------------------------------------------------------------------

    /// `fmi2SetDebugLogging`: with no categories, switches every category; otherwise the named
    /// ones. An unknown name is an error and changes nothing.
    pub fn set_debug_logging(&mut self, logging_on: bool, categories: &[&str]) -> fmi2Status {
        self.run(Function::SetDebugLogging, |this| {
            let mut indices = Vec::with_capacity(categories.len());
            for name in categories {
                match LogCategory::ALL.iter().position(|c| c.name() == *name) {
                    Some(i) => indices.push(i),
                    None => {
                        let known: Vec<&str> = LogCategory::ALL.iter().map(|c| c.name()).collect();
                        return Err(format!(
                            "unknown log category {name:?} (known: {})",
                            known.join(", ")
                        )
                        .into());
                    }
                }
            }
            if indices.is_empty() {
                indices = (0..LogCategory::ALL.len()).collect();
            }
            for i in indices {
                this.log_enabled[i] = logging_on;
                this.model.logging_changed(LogCategory::ALL[i], logging_on);
            }
            Ok(fmi2OK)
        })
    }

    /// `fmi2SetupExperiment`.
    pub fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> fmi2Status {
        self.run(Function::SetupExperiment, |this| {
            if !start_time.is_finite() {
                return Err(format!("startTime must be finite, got {start_time:?}").into());
            }
            if let Some(tol) = tolerance {
                if !(tol.is_finite() && tol > 0.0) {
                    return Err(format!("tolerance must be finite and > 0, got {tol:?}").into());
                }
            }
            if let Some(stop) = stop_time {
                if !(stop.is_finite() && stop >= start_time) {
                    return Err(format!(
                        "stopTime must be finite and >= startTime = {start_time:?}, got {stop:?}"
                    )
                    .into());
                }
            }
            this.model
                .setup_experiment(start_time, stop_time, tolerance)?;
            this.stop_time = stop_time;
            this.last_successful_time = start_time;
            Ok(fmi2OK)
        })
    }

    /// `fmi2EnterInitializationMode`.
    pub fn enter_initialization_mode(&mut self) -> fmi2Status {
        self.run(Function::EnterInitializationMode, |this| {
            this.model.enter_initialization()?;
            this.state = ModelState::InitializationMode;
            this.log_event("fmi2EnterInitializationMode: entered initialization mode");
            Ok(fmi2OK)
        })
    }

    /// `fmi2ExitInitializationMode`: to `StepComplete` (CS) or `EventMode` (ME).
    pub fn exit_initialization_mode(&mut self) -> fmi2Status {
        self.run(Function::ExitInitializationMode, |this| {
            this.model.exit_initialization()?;
            this.state = match this.interface {
                Interface::CoSimulation => ModelState::StepComplete,
                Interface::ModelExchange => ModelState::EventMode,
            };
            this.last_successful_time = this.model.time();
            this.log_event(&format!(
                "fmi2ExitInitializationMode: initialized at t = {:?}",
                this.last_successful_time
            ));
            Ok(fmi2OK)
        })
    }

    /// `fmi2Terminate`.
    pub fn terminate(&mut self) -> fmi2Status {
        self.run(Function::Terminate, |this| {
            this.model.terminate()?;
            this.state = ModelState::Terminated;
            this.log_event("fmi2Terminate: terminated");
            Ok(fmi2OK)
        })
    }

    /// `fmi2Reset`: back to `Instantiated` with start values. A failed reset leaves the
    /// instance in state `Error`.
    pub fn reset(&mut self) -> fmi2Status {
        self.run(Function::Reset, |this| match this.model.reset() {
            Ok(()) => {
                this.state = ModelState::Instantiated;
                this.stop_time = None;
                this.last_successful_time = this
                    .model
                    .info()
                    .default_experiment
                    .start_time
                    .unwrap_or(0.0);
                this.log_event("fmi2Reset: reset to the instantiated state");
                Ok(fmi2OK)
            }
            Err(e) => {
                this.state = ModelState::Error;
                Err(format!("{e}; the instance is now in state Error").into())
            }
        })
    }

    // ---- get / set --------------------------------------------------------------------------------

    fn get_all<T>(
        &mut self,
        kind: Kind,
        vrs: &[u32],
        values: &mut [T],
        get: impl Fn(&mut M, u32) -> Result<T, String>,
    ) -> Outcome {
        Self::same_length("value", vrs.len(), values.len())?;
        self.check_known(kind, vrs)?;
        for (vr, value) in vrs.iter().zip(values.iter_mut()) {
            *value = get(&mut self.model, *vr)
                .map_err(|e| format!("{} (value reference {vr}): {e}", self.var_name(kind, *vr)))?;
        }
        Ok(fmi2OK)
    }

    /// Sets every value or none: if one is refused, the ones already set are restored.
    fn set_all<T: std::fmt::Debug>(
        &mut self,
        kind: Kind,
        vrs: &[u32],
        values: &[T],
        get: impl Fn(&mut M, u32) -> Result<T, String>,
        set: impl Fn(&mut M, u32, &T, Phase) -> Result<(), String>,
    ) -> Outcome {
        Self::same_length("value", vrs.len(), values.len())?;
        self.check_known(kind, vrs)?;
        let phase = self.phase();
        let mut done: Vec<(u32, Option<T>)> = Vec::with_capacity(vrs.len());
        for (&vr, value) in vrs.iter().zip(values) {
            let old = get(&mut self.model, vr).ok();
            if let Err(e) = set(&mut self.model, vr, value, phase) {
                for (vr, old) in done.into_iter().rev() {
                    if let Some(old) = old {
                        let _ = set(&mut self.model, vr, &old, phase);
                    }
                }
                let name = self.var_name(kind, vr);
                return Err(format!("cannot set {name} (value reference {vr}) to {value:?}: {e}; no value was changed").into());
            }
            done.push((vr, old));
        }
        Ok(fmi2OK)
    }

    /// `fmi2GetReal`.
    pub fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> fmi2Status {
        self.run(Function::GetReal, |this| {
            this.get_all(Kind::Real, vrs, values, |m, vr| m.get_real(vr))
        })
    }

    /// `fmi2GetInteger`.
    pub fn get_integer(&mut self, vrs: &[u32], values: &mut [i32]) -> fmi2Status {
        self.run(Function::GetInteger, |this| {
            this.get_all(Kind::Integer, vrs, values, |m, vr| m.get_integer(vr))
        })
    }

    /// `fmi2GetBoolean`.
    pub fn get_boolean(&mut self, vrs: &[u32], values: &mut [fmi2Boolean]) -> fmi2Status {
        self.run(Function::GetBoolean, |this| {
            this.get_all(Kind::Boolean, vrs, values, |m, vr| {
                m.get_boolean(vr).map(fmi_bool)
            })
        })
    }

    /// `fmi2GetString`: writes pointers to NUL-terminated strings owned by the instance, valid
    /// until the next `get_string` call or until the instance is freed.
    pub fn get_string(&mut self, vrs: &[u32], values: &mut [*const c_char]) -> fmi2Status {
        self.run(Function::GetString, |this| {
            let mut strings = vec![String::new(); vrs.len()];
            this.get_all(Kind::String, vrs, &mut strings, |m, vr| m.get_string(vr))?;
            this.strings = strings.iter().map(|s| c_string_lossless(s)).collect();
            for (out, s) in values.iter_mut().zip(&this.strings) {
                *out = s.as_ptr();
            }
            Ok(fmi2OK)
        })
    }

    /// `fmi2SetReal`: all or nothing (NaN/Inf are for the model to refuse).
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> fmi2Status {
        self.run(Function::SetReal, |this| {
            this.set_all(
                Kind::Real,
                vrs,
                values,
                |m, vr| m.get_real(vr),
                |m, vr, v, p| m.set_real(vr, *v, p),
            )
        })
    }

    /// `fmi2SetInteger`: all or nothing.
    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> fmi2Status {
        self.run(Function::SetInteger, |this| {
            this.set_all(
                Kind::Integer,
                vrs,
                values,
                |m, vr| m.get_integer(vr),
                |m, vr, v, p| m.set_integer(vr, *v, p),
            )
        })
    }

    /// `fmi2SetBoolean`: all or nothing; any non-zero value is true.
    pub fn set_boolean(&mut self, vrs: &[u32], values: &[fmi2Boolean]) -> fmi2Status {
        let values: Vec<bool> = values.iter().map(|&b| b != fmi2False).collect();
        self.run(Function::SetBoolean, |this| {
            this.set_all(
                Kind::Boolean,
                vrs,
                &values,
                |m, vr| m.get_boolean(vr),
                |m, vr, v, p| m.set_boolean(vr, *v, p),
            )
        })
    }

    /// `fmi2SetString`: all or nothing.
    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> fmi2Status {
        let values: Vec<String> = values.iter().map(|s| (*s).to_owned()).collect();
        self.run(Function::SetString, |this| {
            this.set_all(
                Kind::String,
                vrs,
                &values,
                |m, vr| m.get_string(vr),
                |m, vr, v, p| m.set_string(vr, v, p),
            )
        })
    }

    // ---- FMU state ------------------------------------------------------------------------------

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
            this.log_event(&format!(
                "fmi2GetFMUstate: saved state {:#x} at t = {:?}",
                handle.0,
                this.model.time()
            ));
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
            this.log_event(&format!(
                "fmi2SetFMUstate: restored state {:#x}, t = {:?}",
                h.0,
                this.model.time()
            ));
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

    // ---- Co-Simulation ------------------------------------------------------------------------

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
            (super::ffi::fmi2DoStepStatus, "fmi2DoStepStatus"),
            (super::ffi::fmi2PendingStatus, "fmi2PendingStatus"),
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

    // ---- Model Exchange -----------------------------------------------------------------------

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
                this.log_event(&format!(
                    "fmi2NewDiscreteStates: the model changed its continuous states at t = {:?}",
                    this.model.time()
                ));
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

#[cfg(test)]
#[path = "instance_tests.rs"]
mod tests;
