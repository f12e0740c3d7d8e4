//! Compile-time check that the FMI 2.0 functions have exactly the C signatures of the standard
//! headers, as `fmi-sys` (bindgen on `fmi2FunctionTypes.h`) spells them.
//!
//! Two sets are checked: the generic functions of `scm::fmi::exports`, instantiated with a small
//! model defined here, and the `#[no_mangle]` symbols that `scm::fmi2_exports!` generates in the
//! crate itself (the FMU binary's exports). A mismatch fails to compile.
//!
//! Where fmi-sys has its own struct types (`fmi2CallbackFunctions`, `fmi2EventInfo`), the size,
//! alignment and field offsets are compared with ours, and the function pointer is then
//! transmuted between the two pointer types, which is sound because the layouts are identical.

use std::mem::{align_of, offset_of, size_of};
use std::path::Path;

use fmi_sys::fmi2 as sys;
use scm::fmi::contract::*;
use scm::fmi::exports as ex;
use scm::fmi::ffi;

/// The smallest model: one output, time advances.
pub struct Tiny {
    info: ModelInfo,
    t: f64,
}

impl FmiModel for Tiny {
    type State = f64;
    fn instantiate(_resources: &Path) -> ModelResult<Self> {
        Ok(Tiny {
            info: ModelInfo {
                model_name: "tiny".into(),
                guid: "{tiny}".into(),
                description: String::new(),
                generation_tool: String::new(),
                variables: vec![Variable {
                    name: "time".into(),
                    value_reference: 0,
                    causality: Causality::Independent,
                    variability: Variability::Continuous,
                    initial: None,
                    var_type: VarType::Real {
                        start: None,
                        unit: Some("s"),
                        derivative: None,
                    },
                    description: String::new(),
                }],
                structure: ModelStructure::default(),
                number_of_event_indicators: 0,
                model_exchange: false,
                capabilities: Default::default(),
                default_experiment: DefaultExperiment::default(),
            },
            t: 0.0,
        })
    }
    fn info(&self) -> &ModelInfo {
        &self.info
    }
    fn setup_experiment(
        &mut self,
        start: f64,
        _stop: Option<f64>,
        _tol: Option<f64>,
    ) -> ModelResult<()> {
        self.t = start;
        Ok(())
    }
    fn enter_initialization(&mut self) -> ModelResult<()> {
        Ok(())
    }
    fn exit_initialization(&mut self) -> ModelResult<()> {
        Ok(())
    }
    fn reset(&mut self) -> ModelResult<()> {
        self.t = 0.0;
        Ok(())
    }
    fn time(&self) -> f64 {
        self.t
    }
    fn get_real(&mut self, _vr: u32) -> ModelResult<f64> {
        Ok(self.t)
    }
    fn set_real(&mut self, vr: u32, _value: f64, _phase: Phase) -> ModelResult<()> {
        Err(format!("variable {vr} cannot be set"))
    }
    fn do_step(&mut self, current_time: f64, step: f64) -> Result<(), StepError> {
        self.t = current_time + step;
        Ok(())
    }
}

// The crate's own exports (generated for `scm::sim::Simulation`).
use scm::*;

/// Same layout for the callback struct and the event-info struct.
#[test]
fn struct_layouts_match() {
    assert_eq!(
        size_of::<ffi::fmi2CallbackFunctions>(),
        size_of::<sys::fmi2CallbackFunctions>()
    );
    assert_eq!(
        align_of::<ffi::fmi2CallbackFunctions>(),
        align_of::<sys::fmi2CallbackFunctions>()
    );
    assert_eq!(
        offset_of!(ffi::fmi2CallbackFunctions, logger),
        offset_of!(sys::fmi2CallbackFunctions, logger)
    );
    assert_eq!(
        offset_of!(ffi::fmi2CallbackFunctions, allocateMemory),
        offset_of!(sys::fmi2CallbackFunctions, allocateMemory)
    );
    assert_eq!(
        offset_of!(ffi::fmi2CallbackFunctions, freeMemory),
        offset_of!(sys::fmi2CallbackFunctions, freeMemory)
    );
    assert_eq!(
        offset_of!(ffi::fmi2CallbackFunctions, stepFinished),
        offset_of!(sys::fmi2CallbackFunctions, stepFinished)
    );
    assert_eq!(
        offset_of!(ffi::fmi2CallbackFunctions, componentEnvironment),
        offset_of!(sys::fmi2CallbackFunctions, componentEnvironment)
    );
    // the field types themselves are the same types
    let cb: sys::fmi2CallbackFunctions = unsafe { std::mem::zeroed() };
    let _: ffi::fmi2CallbackLogger = cb.logger;
    let _: ffi::fmi2CallbackAllocateMemory = cb.allocateMemory;
    let _: ffi::fmi2CallbackFreeMemory = cb.freeMemory;
    let _: ffi::fmi2StepFinished = cb.stepFinished;
    let _: ffi::fmi2ComponentEnvironment = cb.componentEnvironment;

    assert_eq!(
        size_of::<ffi::fmi2EventInfo>(),
        size_of::<sys::fmi2EventInfo>()
    );
    assert_eq!(
        align_of::<ffi::fmi2EventInfo>(),
        align_of::<sys::fmi2EventInfo>()
    );
    assert_eq!(
        offset_of!(ffi::fmi2EventInfo, newDiscreteStatesNeeded),
        offset_of!(sys::fmi2EventInfo, newDiscreteStatesNeeded)
    );
    assert_eq!(
        offset_of!(ffi::fmi2EventInfo, terminateSimulation),
        offset_of!(sys::fmi2EventInfo, terminateSimulation)
    );
    assert_eq!(
        offset_of!(ffi::fmi2EventInfo, nominalsOfContinuousStatesChanged),
        offset_of!(sys::fmi2EventInfo, nominalsOfContinuousStatesChanged)
    );
    assert_eq!(
        offset_of!(ffi::fmi2EventInfo, valuesOfContinuousStatesChanged),
        offset_of!(sys::fmi2EventInfo, valuesOfContinuousStatesChanged)
    );
    assert_eq!(
        offset_of!(ffi::fmi2EventInfo, nextEventTimeDefined),
        offset_of!(sys::fmi2EventInfo, nextEventTimeDefined)
    );
    assert_eq!(
        offset_of!(ffi::fmi2EventInfo, nextEventTime),
        offset_of!(sys::fmi2EventInfo, nextEventTime)
    );
    let info = sys::fmi2EventInfo::default();
    let _: ffi::fmi2Boolean = info.newDiscreteStatesNeeded;
    let _: ffi::fmi2Real = info.nextEventTime;
}

/// Scalar types and enum constants are the same.
#[test]
fn types_and_constants_match() {
    let _: sys::fmi2Component = std::ptr::null_mut::<std::ffi::c_void>() as ffi::fmi2Component;
    let _: sys::fmi2FMUstate = std::ptr::null_mut::<std::ffi::c_void>() as ffi::fmi2FMUstate;
    let _: sys::fmi2ValueReference = 0 as ffi::fmi2ValueReference;
    let _: sys::fmi2Real = 0.0 as ffi::fmi2Real;
    let _: sys::fmi2Integer = 0 as ffi::fmi2Integer;
    let _: sys::fmi2Boolean = 0 as ffi::fmi2Boolean;
    let _: sys::fmi2Char = 0 as ffi::fmi2Char;
    let _: sys::fmi2String = std::ptr::null::<ffi::fmi2Char>() as ffi::fmi2String;
    let _: sys::fmi2Byte = 0 as ffi::fmi2Byte;
    let _: sys::fmi2Status = ffi::fmi2OK;
    let _: sys::fmi2Type = ffi::fmi2CoSimulation;
    let _: sys::fmi2StatusKind = ffi::fmi2LastSuccessfulTime;
    assert_eq!(ffi::fmi2OK, sys::fmi2Status_fmi2OK);
    assert_eq!(ffi::fmi2Warning, sys::fmi2Status_fmi2Warning);
    assert_eq!(ffi::fmi2Discard, sys::fmi2Status_fmi2Discard);
    assert_eq!(ffi::fmi2Error, sys::fmi2Status_fmi2Error);
    assert_eq!(ffi::fmi2Fatal, sys::fmi2Status_fmi2Fatal);
    assert_eq!(ffi::fmi2Pending, sys::fmi2Status_fmi2Pending);
    assert_eq!(ffi::fmi2ModelExchange, sys::fmi2Type_fmi2ModelExchange);
    assert_eq!(ffi::fmi2CoSimulation, sys::fmi2Type_fmi2CoSimulation);
    assert_eq!(ffi::fmi2DoStepStatus, sys::fmi2StatusKind_fmi2DoStepStatus);
    assert_eq!(
        ffi::fmi2PendingStatus,
        sys::fmi2StatusKind_fmi2PendingStatus
    );
    assert_eq!(
        ffi::fmi2LastSuccessfulTime,
        sys::fmi2StatusKind_fmi2LastSuccessfulTime
    );
    assert_eq!(ffi::fmi2Terminated, sys::fmi2StatusKind_fmi2Terminated);
}

/// `let _: sys::fmi2XTYPE = Some(f);` for every function whose parameter types fmi-sys shares.
macro_rules! same_signature {
    ($($ty:ident: $generic:expr, $exported:expr;)*) => {
        $(
            let _: sys::$ty = Some($generic);
            let _: sys::$ty = Some($exported);
        )*
    };
}

type OursInstantiate = unsafe extern "C" fn(
    ffi::fmi2String,
    ffi::fmi2Type,
    ffi::fmi2String,
    ffi::fmi2String,
    *const ffi::fmi2CallbackFunctions,
    ffi::fmi2Boolean,
    ffi::fmi2Boolean,
) -> ffi::fmi2Component;
type OursNewDiscreteStates =
    unsafe extern "C" fn(ffi::fmi2Component, *mut ffi::fmi2EventInfo) -> ffi::fmi2Status;

#[test]
fn signatures_match_fmi_sys() {
    same_signature! {
        fmi2GetTypesPlatformTYPE: ex::get_types_platform, fmi2GetTypesPlatform;
        fmi2GetVersionTYPE: ex::get_version, fmi2GetVersion;
        fmi2SetDebugLoggingTYPE: ex::set_debug_logging::<Tiny>, fmi2SetDebugLogging;
        fmi2FreeInstanceTYPE: ex::free_instance::<Tiny>, fmi2FreeInstance;
        fmi2SetupExperimentTYPE: ex::setup_experiment::<Tiny>, fmi2SetupExperiment;
        fmi2EnterInitializationModeTYPE: ex::enter_initialization_mode::<Tiny>, fmi2EnterInitializationMode;
        fmi2ExitInitializationModeTYPE: ex::exit_initialization_mode::<Tiny>, fmi2ExitInitializationMode;
        fmi2TerminateTYPE: ex::terminate::<Tiny>, fmi2Terminate;
        fmi2ResetTYPE: ex::reset::<Tiny>, fmi2Reset;
        fmi2GetRealTYPE: ex::get_real::<Tiny>, fmi2GetReal;
        fmi2GetIntegerTYPE: ex::get_integer::<Tiny>, fmi2GetInteger;
        fmi2GetBooleanTYPE: ex::get_boolean::<Tiny>, fmi2GetBoolean;
        fmi2GetStringTYPE: ex::get_string::<Tiny>, fmi2GetString;
        fmi2SetRealTYPE: ex::set_real::<Tiny>, fmi2SetReal;
        fmi2SetIntegerTYPE: ex::set_integer::<Tiny>, fmi2SetInteger;
        fmi2SetBooleanTYPE: ex::set_boolean::<Tiny>, fmi2SetBoolean;
        fmi2SetStringTYPE: ex::set_string::<Tiny>, fmi2SetString;
        fmi2GetFMUstateTYPE: ex::get_fmu_state::<Tiny>, fmi2GetFMUstate;
        fmi2SetFMUstateTYPE: ex::set_fmu_state::<Tiny>, fmi2SetFMUstate;
        fmi2FreeFMUstateTYPE: ex::free_fmu_state::<Tiny>, fmi2FreeFMUstate;
        fmi2SerializedFMUstateSizeTYPE: ex::serialized_fmu_state_size::<Tiny>, fmi2SerializedFMUstateSize;
        fmi2SerializeFMUstateTYPE: ex::serialize_fmu_state::<Tiny>, fmi2SerializeFMUstate;
        fmi2DeSerializeFMUstateTYPE: ex::de_serialize_fmu_state::<Tiny>, fmi2DeSerializeFMUstate;
        fmi2GetDirectionalDerivativeTYPE: ex::get_directional_derivative::<Tiny>, fmi2GetDirectionalDerivative;
        fmi2EnterEventModeTYPE: ex::enter_event_mode::<Tiny>, fmi2EnterEventMode;
        fmi2EnterContinuousTimeModeTYPE: ex::enter_continuous_time_mode::<Tiny>, fmi2EnterContinuousTimeMode;
        fmi2CompletedIntegratorStepTYPE: ex::completed_integrator_step::<Tiny>, fmi2CompletedIntegratorStep;
        fmi2SetTimeTYPE: ex::set_time::<Tiny>, fmi2SetTime;
        fmi2SetContinuousStatesTYPE: ex::set_continuous_states::<Tiny>, fmi2SetContinuousStates;
        fmi2GetDerivativesTYPE: ex::get_derivatives::<Tiny>, fmi2GetDerivatives;
        fmi2GetEventIndicatorsTYPE: ex::get_event_indicators::<Tiny>, fmi2GetEventIndicators;
        fmi2GetContinuousStatesTYPE: ex::get_continuous_states::<Tiny>, fmi2GetContinuousStates;
        fmi2GetNominalsOfContinuousStatesTYPE: ex::get_nominals_of_continuous_states::<Tiny>, fmi2GetNominalsOfContinuousStates;
        fmi2SetRealInputDerivativesTYPE: ex::set_real_input_derivatives::<Tiny>, fmi2SetRealInputDerivatives;
        fmi2GetRealOutputDerivativesTYPE: ex::get_real_output_derivatives::<Tiny>, fmi2GetRealOutputDerivatives;
        fmi2DoStepTYPE: ex::do_step::<Tiny>, fmi2DoStep;
        fmi2CancelStepTYPE: ex::cancel_step::<Tiny>, fmi2CancelStep;
        fmi2GetStatusTYPE: ex::get_status::<Tiny>, fmi2GetStatus;
        fmi2GetRealStatusTYPE: ex::get_real_status::<Tiny>, fmi2GetRealStatus;
        fmi2GetIntegerStatusTYPE: ex::get_integer_status::<Tiny>, fmi2GetIntegerStatus;
        fmi2GetBooleanStatusTYPE: ex::get_boolean_status::<Tiny>, fmi2GetBooleanStatus;
        fmi2GetStringStatusTYPE: ex::get_string_status::<Tiny>, fmi2GetStringStatus;
    }

    // fmi2Instantiate and fmi2NewDiscreteStates take our struct types: same signature up to the
    // pointee struct, whose layout `struct_layouts_match` checks.
    for f in [
        ex::instantiate::<Tiny> as OursInstantiate,
        fmi2Instantiate as OursInstantiate,
    ] {
        // SAFETY: identical argument/return types except the pointee of one pointer, which has
        // the same layout; function pointers of the same ABI and arity have the same size.
        let _: sys::fmi2InstantiateTYPE = unsafe {
            std::mem::transmute::<Option<OursInstantiate>, sys::fmi2InstantiateTYPE>(Some(f))
        };
    }
    for f in [
        ex::new_discrete_states::<Tiny> as OursNewDiscreteStates,
        fmi2NewDiscreteStates as OursNewDiscreteStates,
    ] {
        // SAFETY: as above.
        let _: sys::fmi2NewDiscreteStatesTYPE = unsafe {
            std::mem::transmute::<Option<OursNewDiscreteStates>, sys::fmi2NewDiscreteStatesTYPE>(
                Some(f),
            )
        };
    }
}

/// The crate's exports are callable: version strings, NULL and bad arguments refused.
#[test]
fn crate_exports_are_callable() {
    unsafe {
        assert_eq!(std::ffi::CStr::from_ptr(fmi2GetVersion()), c"2.0");
        assert_eq!(std::ffi::CStr::from_ptr(fmi2GetTypesPlatform()), c"default");
        assert_eq!(
            fmi2DoStep(std::ptr::null_mut(), 0.0, 1.0, 0),
            ffi::fmi2Error
        );
        assert_eq!(fmi2CancelStep(std::ptr::null_mut()), ffi::fmi2Error);
        fmi2FreeInstance(std::ptr::null_mut());
        let callbacks = ffi::fmi2CallbackFunctions {
            logger: None,
            allocateMemory: None,
            freeMemory: None,
            stepFinished: None,
            componentEnvironment: std::ptr::null_mut(),
        };
        // No scene in /nonexistent: instantiation fails cleanly with NULL.
        let c = fmi2Instantiate(
            c"t".as_ptr(),
            ffi::fmi2CoSimulation,
            c"{guid}".as_ptr(),
            c"file:///nonexistent".as_ptr(),
            &callbacks,
            0,
            0,
        );
        assert!(c.is_null());
        let c = fmi2Instantiate(
            c"t".as_ptr(),
            ffi::fmi2CoSimulation,
            c"{guid}".as_ptr(),
            c"http://example/resources".as_ptr(),
            &callbacks,
            0,
            0,
        );
        assert!(c.is_null());
        let mut info = ffi::fmi2EventInfo::default();
        assert_eq!(
            fmi2NewDiscreteStates(std::ptr::null_mut(), &mut info),
            ffi::fmi2Error
        );
    }
}
