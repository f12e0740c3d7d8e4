//! The contract between the FMI 2.0 plumbing and a model.
//!
//! The plumbing (`fmi2*` entry points, call-order state machine, logging, resource URIs,
//! `modelDescription.xml`) is the same for every model; a model only implements [`FmiModel`].
//! Everything here is safe Rust: no pointers, no C types.

use std::path::Path;

/// Causality of a variable (FMI 2.0, section 2.2.7).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Causality {
    /// Independent parameter, set before initialization (or between steps if tunable).
    Parameter,
    /// Calculated parameter (depends on parameters only).
    CalculatedParameter,
    /// Input of the model.
    Input,
    /// Output of the model.
    Output,
    /// Local variable (e.g. continuous state derivatives that are not outputs).
    Local,
    /// The independent variable (time).
    Independent,
}

/// Variability of a variable (FMI 2.0, section 2.2.7).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variability {
    /// Never changes.
    Constant,
    /// Fixed after initialization.
    Fixed,
    /// Changes only when set by the environment (between steps).
    Tunable,
    /// Changes only at events.
    Discrete,
    /// Changes continuously in time.
    Continuous,
}

/// `initial` attribute of a variable (FMI 2.0, section 2.2.7).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Initial {
    /// The start value is the initial value.
    Exact,
    /// The start value is a guess for an algebraic loop.
    Approx,
    /// Computed from other variables during initialization.
    Calculated,
}

/// Type and start value of a variable.
#[derive(Clone, Debug, PartialEq)]
pub enum VarType {
    /// `<Real>`; `derivative` is the value reference of the state this variable is the
    /// derivative of (Model Exchange), if any.
    Real {
        /// Start value.
        start: Option<f64>,
        /// Unit (one of the units `modelDescription.xml` declares).
        unit: Option<&'static str>,
        /// Value reference of the state this is the derivative of.
        derivative: Option<u32>,
    },
    /// `<Integer>`.
    Integer {
        /// Start value.
        start: Option<i32>,
    },
    /// `<Boolean>`.
    Boolean {
        /// Start value.
        start: Option<bool>,
    },
    /// `<String>`.
    String {
        /// Start value.
        start: Option<String>,
    },
}

/// One scalar variable: one row of the model's variable table.
#[derive(Clone, Debug, PartialEq)]
pub struct Variable {
    /// Structured name, e.g. `ball.pos.z` or `scm.eps1`.
    pub name: String,
    /// Value reference: unique within its type.
    pub value_reference: u32,
    /// Causality.
    pub causality: Causality,
    /// Variability.
    pub variability: Variability,
    /// `initial` attribute (`None`: the default for the causality and variability).
    pub initial: Option<Initial>,
    /// Type and start value.
    pub var_type: VarType,
    /// Human-readable description.
    pub description: String,
}

/// `<ModelStructure>`: dependencies given as value references (the writer turns them into the
/// 1-based indices of `<ModelVariables>`). `None` means "depends on everything" (attribute
/// omitted); `Some(vec![])` means "depends on nothing" (`dependencies=""`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ModelStructure {
    /// `<Outputs>`: each output and what it depends on.
    pub outputs: Vec<(u32, Option<Vec<u32>>)>,
    /// `<Derivatives>`: each state derivative and what it depends on.
    pub derivatives: Vec<(u32, Option<Vec<u32>>)>,
    /// `<InitialUnknowns>`.
    pub initial_unknowns: Vec<(u32, Option<Vec<u32>>)>,
}

/// A log category declared in `modelDescription.xml`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LogCategory {
    /// Errors (`fmi2Error`, `fmi2Fatal`).
    StatusError,
    /// Warnings (`fmi2Warning`).
    StatusWarning,
    /// Instantiation, initialization, reset, termination, state changes.
    Events,
    /// Per-step contact diagnostics (smooth distances, forces).
    Contact,
}

impl LogCategory {
    /// Every category, in the order declared in `modelDescription.xml`.
    pub const ALL: [LogCategory; 4] = [
        LogCategory::StatusError,
        LogCategory::StatusWarning,
        LogCategory::Events,
        LogCategory::Contact,
    ];

    /// Name as declared in `<LogCategories>`.
    pub fn name(self) -> &'static str {
        match self {
            LogCategory::StatusError => "logStatusError",
            LogCategory::StatusWarning => "logStatusWarning",
            LogCategory::Events => "logEvents",
            LogCategory::Contact => "logContact",
        }
    }

    /// Description as declared in `<LogCategories>`.
    pub fn description(self) -> &'static str {
        match self {
            LogCategory::StatusError => "Errors: calls that return fmi2Error or fmi2Fatal",
            LogCategory::StatusWarning => "Warnings: calls that return fmi2Warning",
            LogCategory::Events => {
                "Instantiation, initialization, reset, termination and FMU state"
            }
            LogCategory::Contact => {
                "Contact diagnostics: smooth separation distance and force per pair"
            }
        }
    }
}

/// A message from the model to the host's logger.
#[derive(Clone, Debug, PartialEq)]
pub struct LogMessage {
    /// Category (the host sees it only if the category is switched on).
    pub category: LogCategory,
    /// Text.
    pub text: String,
}

/// Everything `modelDescription.xml` says about a model.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelInfo {
    /// `modelName`.
    pub model_name: String,
    /// `guid`: must equal the `fmuGUID` passed to `fmi2Instantiate`.
    pub guid: String,
    /// `description`.
    pub description: String,
    /// `generationTool`.
    pub generation_tool: String,
    /// The variable table; its order is the order of `<ModelVariables>`.
    pub variables: Vec<Variable>,
    /// `<ModelStructure>`.
    pub structure: ModelStructure,
    /// `numberOfEventIndicators` (this model has no events: 0).
    pub number_of_event_indicators: usize,
    /// Whether `<ModelExchange>` is offered besides `<CoSimulation>`.
    pub model_exchange: bool,
    /// Optional capabilities, declared in both interfaces' elements. A flag must be true only
    /// if the model implements the matching [`FmiModel`] methods (their defaults refuse); the
    /// plumbing refuses the calls of an undeclared capability.
    pub capabilities: Capabilities,
    /// `<DefaultExperiment>`: start, stop, tolerance, step size.
    pub default_experiment: DefaultExperiment,
}

/// The optional capabilities of `<ModelExchange>`/`<CoSimulation>` (FMI 2.0, section 2.2.1 and
/// 3.3.1/4.3.1). `Default` declares none of them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Capabilities {
    /// `canGetAndSetFMUstate`: [`FmiModel::get_state`] and [`FmiModel::set_state`] work.
    pub can_get_and_set_fmu_state: bool,
    /// `canSerializeFMUstate`: [`FmiModel::serialize_state`] and
    /// [`FmiModel::deserialize_state`] work.
    pub can_serialize_fmu_state: bool,
    /// `providesDirectionalDerivative`: [`FmiModel::directional_derivative`] answers for every
    /// pair of unknown and known that `<ModelStructure>` declares.
    pub provides_directional_derivative: bool,
}

/// `<DefaultExperiment>` attributes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DefaultExperiment {
    /// `startTime` (s).
    pub start_time: Option<f64>,
    /// `stopTime` (s).
    pub stop_time: Option<f64>,
    /// `tolerance`.
    pub tolerance: Option<f64>,
    /// `stepSize` (s).
    pub step_size: Option<f64>,
}

/// Why a step failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StepError {
    /// The step was refused (bad arguments); the state is unchanged (`fmi2Error`).
    #[error("step refused: {0}")]
    Error(String),
    /// The step diverged; the state was rolled back to the start of the step (`fmi2Discard`),
    /// so the host may retry with a smaller step.
    #[error("step discarded, the state is as before it: {0}")]
    Discard(String),
}

/// Error of a model call: the message names the variable/value/reason (goes to the logger).
pub type ModelResult<T> = Result<T, String>;

/// The phase of the FMI state machine a set call is made in, so the model can decide which
/// variables may be set (e.g. `fixed` parameters only before initialization).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// After `fmi2Instantiate`, before `fmi2EnterInitializationMode`.
    Instantiated,
    /// Between `fmi2EnterInitializationMode` and `fmi2ExitInitializationMode`.
    Initialization,
    /// After initialization (stepping / continuous-time mode / event mode).
    Simulation,
}

/// What a model implements to be exported through the FMI 2.0 plumbing.
///
/// Methods with default bodies are optional capabilities; their defaults refuse with a reason.
pub trait FmiModel: Sized + Send {
    /// The FMU state saved by `fmi2GetFMUstate`: a plain value (no pointers into the instance).
    type State: Clone + Send;

    /// Builds the model from the FMU's unzipped `resources/` folder.
    fn instantiate(resources: &Path) -> ModelResult<Self>;

    /// The model's description (variables, structure, guid). Cheap: a reference.
    fn info(&self) -> &ModelInfo;

    /// `fmi2SetupExperiment`.
    fn setup_experiment(
        &mut self,
        start_time: f64,
        stop_time: Option<f64>,
        tolerance: Option<f64>,
    ) -> ModelResult<()>;
    /// `fmi2EnterInitializationMode`.
    fn enter_initialization(&mut self) -> ModelResult<()>;
    /// `fmi2ExitInitializationMode`.
    fn exit_initialization(&mut self) -> ModelResult<()>;
    /// `fmi2Reset`: back to the state right after instantiation (start values restored).
    fn reset(&mut self) -> ModelResult<()>;
    /// `fmi2Terminate`.
    fn terminate(&mut self) -> ModelResult<()> {
        Ok(())
    }

    /// Current simulation time.
    fn time(&self) -> f64;

    /// `fmi2GetReal` of one variable.
    fn get_real(&mut self, vr: u32) -> ModelResult<f64>;
    /// `fmi2SetReal` of one variable; refuses non-finite or out-of-range values with a message naming them.
    fn set_real(&mut self, vr: u32, value: f64, phase: Phase) -> ModelResult<()>;
    /// `fmi2GetInteger` of one variable.
    fn get_integer(&mut self, vr: u32) -> ModelResult<i32> {
        Err(format!("no Integer variable with value reference {vr}"))
    }
    /// `fmi2SetInteger` of one variable.
    fn set_integer(&mut self, vr: u32, _value: i32, _phase: Phase) -> ModelResult<()> {
        Err(format!("no Integer variable with value reference {vr}"))
    }
    /// `fmi2GetBoolean` of one variable.
    fn get_boolean(&mut self, vr: u32) -> ModelResult<bool> {
        Err(format!("no Boolean variable with value reference {vr}"))
    }
    /// `fmi2SetBoolean` of one variable.
    fn set_boolean(&mut self, vr: u32, _value: bool, _phase: Phase) -> ModelResult<()> {
        Err(format!("no Boolean variable with value reference {vr}"))
    }
    /// `fmi2GetString` of one variable.
    fn get_string(&mut self, vr: u32) -> ModelResult<String> {
        Err(format!("no String variable with value reference {vr}"))
    }
    /// `fmi2SetString` of one variable.
    fn set_string(&mut self, vr: u32, _value: &str, _phase: Phase) -> ModelResult<()> {
        Err(format!("no String variable with value reference {vr}"))
    }

    /// `fmi2DoStep` (Co-Simulation): advance from `current_time` by `step`. The plumbing has
    /// already refused a step that is not finite and positive, a `current_time` that is not the
    /// model's time (to rounding) and a step past `stopTime` (which it owns and saves with the
    /// FMU state); on failure the model keeps its state from before the call.
    fn do_step(&mut self, current_time: f64, step: f64) -> Result<(), StepError>;

    /// Messages produced since the last call (warnings, events, contact diagnostics).
    fn take_messages(&mut self) -> Vec<LogMessage> {
        Vec::new()
    }

    /// `fmi2GetFMUstate`.
    fn get_state(&self) -> ModelResult<Self::State> {
        Err("this model cannot save its state".into())
    }
    /// `fmi2SetFMUstate`.
    fn set_state(&mut self, _state: &Self::State) -> ModelResult<()> {
        Err("this model cannot restore a state".into())
    }
    /// `fmi2SerializeFMUstate`: a self-contained byte string (no pointers).
    fn serialize_state(&self, _state: &Self::State) -> ModelResult<Vec<u8>> {
        Err("this model cannot serialize its state".into())
    }
    /// `fmi2DeSerializeFMUstate`: refuses bytes from another scene, version, or corrupt ones.
    fn deserialize_state(&self, _bytes: &[u8]) -> ModelResult<Self::State> {
        Err("this model cannot deserialize a state".into())
    }

    /// `fmi2GetDirectionalDerivative`: `dv_unknown = J[unknowns, knowns] · dv_known`.
    fn directional_derivative(
        &mut self,
        _unknowns: &[u32],
        _knowns: &[u32],
        _dv_known: &[f64],
    ) -> ModelResult<Vec<f64>> {
        Err("this model does not provide directional derivatives".into())
    }

    // ---- Model Exchange -------------------------------------------------------------------
    /// Number of continuous states (`fmi2GetContinuousStates` length).
    fn number_of_states(&self) -> usize {
        0
    }
    /// `fmi2SetTime`.
    fn set_time(&mut self, _time: f64) -> ModelResult<()> {
        Err("this model does not support Model Exchange".into())
    }
    /// `fmi2GetContinuousStates`.
    fn get_continuous_states(&mut self) -> ModelResult<Vec<f64>> {
        Err("this model does not support Model Exchange".into())
    }
    /// `fmi2SetContinuousStates`.
    fn set_continuous_states(&mut self, _x: &[f64]) -> ModelResult<()> {
        Err("this model does not support Model Exchange".into())
    }
    /// `fmi2GetDerivatives`.
    fn get_derivatives(&mut self) -> ModelResult<Vec<f64>> {
        Err("this model does not support Model Exchange".into())
    }
    /// `fmi2GetNominalsOfContinuousStates`.
    fn get_nominals(&mut self) -> ModelResult<Vec<f64>> {
        Ok(vec![1.0; self.number_of_states()])
    }
    /// `fmi2CompletedIntegratorStep`: returns whether the host must call `fmi2EnterEventMode`
    /// (e.g. because the state drifted off a constraint the model projects back onto in
    /// [`FmiModel::event_update`]).
    fn completed_integrator_step(&mut self) -> ModelResult<bool> {
        Ok(false)
    }
    /// `fmi2NewDiscreteStates` (event mode): the model's event update. Returns whether it
    /// changed the continuous states (`valuesOfContinuousStatesChanged`), e.g. by projecting
    /// them back onto a constraint.
    fn event_update(&mut self) -> ModelResult<bool> {
        Ok(false)
    }

    /// Told whenever a log category is switched on or off (`loggingOn` of `fmi2Instantiate`,
    /// `fmi2SetDebugLogging`), so the model produces costly diagnostics only when the host
    /// will see them.
    fn logging_changed(&mut self, _category: LogCategory, _on: bool) {}

    /// Told once, right after instantiation, which interface the host instantiated
    /// (`fmi2ModelExchange` or `fmi2CoSimulation`), for models whose inputs mean different
    /// things in the two (e.g. an input that is a target reached at the end of a communication
    /// step in Co-Simulation, and the value at the current time in Model Exchange).
    fn interface_chosen(&mut self, _model_exchange: bool) {}
}
