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
        instance.log_event(|| {
            format!(
                "fmi2Instantiate: instance {instance_name:?} created ({interface:?}) from {}",
                resources.display()
            )
        });
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

    /// Logs an event; the message is formatted only when the host listens to events (a host
    /// that saves and restores states every step pays nothing for the text otherwise).
    fn log_event(&self, message: impl FnOnce() -> String) {
        if self.is_logging(LogCategory::Events) {
            self.log(fmi2OK, LogCategory::Events, &message());
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
            this.log_event(|| "fmi2EnterInitializationMode: entered initialization mode".into());
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
            this.log_event(|| {
                format!(
                    "fmi2ExitInitializationMode: initialized at t = {:?}",
                    this.last_successful_time
                )
            });
            Ok(fmi2OK)
        })
    }

    /// `fmi2Terminate`.
    pub fn terminate(&mut self) -> fmi2Status {
        self.run(Function::Terminate, |this| {
            this.model.terminate()?;
            this.state = ModelState::Terminated;
            this.log_event(|| "fmi2Terminate: terminated".into());
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
                this.log_event(|| "fmi2Reset: reset to the instantiated state".into());
                Ok(fmi2OK)
            }
            Err(e) => {
                this.state = ModelState::Error;
                Err(format!("{e}; the instance is now in state Error").into())
            }
        })
    }
}

mod cosim;
mod me;
mod state;
mod values;

#[cfg(test)]
mod tests;
