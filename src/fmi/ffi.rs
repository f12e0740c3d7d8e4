//! The FMI 2.0 C types (`fmi2TypesPlatform.h`, `fmi2FunctionTypes.h`), defined here so that
//! building the FMU needs no bindgen/libclang.
//!
//! The C enums (`fmi2Status`, `fmi2Type`, `fmi2StatusKind`) are plain integers with constants:
//! GCC and Clang give an enum without negative enumerators the type `unsigned int`, which is also
//! what bindgen (and so `fmi-sys`) uses; `tests/fmi_signatures.rs` checks that the exported
//! functions have exactly the C signatures.
//!
//! This module also holds [`HostLogger`], the only place where the host's (variadic) logger is
//! called.
#![allow(non_camel_case_types, non_upper_case_globals, non_snake_case)]

use std::ffi::{c_char, c_int, c_uint, c_void, CString};

use super::instance::LogSink;

/// `fmi2Component`: the instance handle given to the host.
pub type fmi2Component = *mut c_void;
/// `fmi2ComponentEnvironment`: the host's pointer, passed back to its callbacks.
pub type fmi2ComponentEnvironment = *mut c_void;
/// `fmi2FMUstate`: an opaque handle to a saved FMU state.
pub type fmi2FMUstate = *mut c_void;
/// `fmi2ValueReference`.
pub type fmi2ValueReference = c_uint;
/// `fmi2Real`.
pub type fmi2Real = f64;
/// `fmi2Integer`.
pub type fmi2Integer = c_int;
/// `fmi2Boolean` (`fmi2True` = 1, `fmi2False` = 0).
pub type fmi2Boolean = c_int;
/// `fmi2Char`.
pub type fmi2Char = c_char;
/// `fmi2String`: a NUL-terminated string.
pub type fmi2String = *const fmi2Char;
/// `fmi2Byte` (serialized FMU state).
pub type fmi2Byte = c_char;

/// `fmi2True`.
pub const fmi2True: fmi2Boolean = 1;
/// `fmi2False`.
pub const fmi2False: fmi2Boolean = 0;

/// `fmi2Status` (a C enum).
pub type fmi2Status = c_uint;
/// All is well.
pub const fmi2OK: fmi2Status = 0;
/// Something is not right, but the computation can continue.
pub const fmi2Warning: fmi2Status = 1;
/// (Co-Simulation) The step was not done; the state is that at the start of the step.
pub const fmi2Discard: fmi2Status = 2;
/// The call failed; the instance keeps its last good state.
pub const fmi2Error: fmi2Status = 3;
/// The instance is corrupt and must be freed.
pub const fmi2Fatal: fmi2Status = 4;
/// (Co-Simulation) Asynchronous step in progress (never returned here).
pub const fmi2Pending: fmi2Status = 5;

/// `fmi2Type` (a C enum): the interface an instance is created for.
pub type fmi2Type = c_uint;
/// Model Exchange.
pub const fmi2ModelExchange: fmi2Type = 0;
/// Co-Simulation.
pub const fmi2CoSimulation: fmi2Type = 1;

/// `fmi2StatusKind` (a C enum): what `fmi2Get*Status` asks for.
pub type fmi2StatusKind = c_uint;
/// Status of an asynchronous `fmi2DoStep`.
pub const fmi2DoStepStatus: fmi2StatusKind = 0;
/// Description of the pending asynchronous step.
pub const fmi2PendingStatus: fmi2StatusKind = 1;
/// Time of the end of the last successful step.
pub const fmi2LastSuccessfulTime: fmi2StatusKind = 2;
/// Whether the slave wants to end the simulation.
pub const fmi2Terminated: fmi2StatusKind = 3;

/// `fmi2CallbackLogger`: printf-like (`message` is the format, the variadic part its arguments).
pub type fmi2CallbackLogger = Option<
    unsafe extern "C" fn(
        componentEnvironment: fmi2ComponentEnvironment,
        instanceName: fmi2String,
        status: fmi2Status,
        category: fmi2String,
        message: fmi2String,
        ...
    ),
>;
/// `fmi2CallbackAllocateMemory` (like `calloc`).
pub type fmi2CallbackAllocateMemory =
    Option<unsafe extern "C" fn(nobj: usize, size: usize) -> *mut c_void>;
/// `fmi2CallbackFreeMemory` (like `free`).
pub type fmi2CallbackFreeMemory = Option<unsafe extern "C" fn(obj: *mut c_void)>;
/// `fmi2StepFinished` (asynchronous Co-Simulation; never called here).
pub type fmi2StepFinished = Option<
    unsafe extern "C" fn(componentEnvironment: fmi2ComponentEnvironment, status: fmi2Status),
>;

/// `fmi2CallbackFunctions`: the host's callbacks given to `fmi2Instantiate`.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct fmi2CallbackFunctions {
    /// Logger; may be NULL (then nothing is logged).
    pub logger: fmi2CallbackLogger,
    /// Memory allocation (not used: `canNotUseMemoryManagementFunctions="true"`).
    pub allocateMemory: fmi2CallbackAllocateMemory,
    /// Memory release (not used).
    pub freeMemory: fmi2CallbackFreeMemory,
    /// Asynchronous step callback (not used).
    pub stepFinished: fmi2StepFinished,
    /// Passed back as the first argument of the callbacks.
    pub componentEnvironment: fmi2ComponentEnvironment,
}

/// `fmi2EventInfo`: filled by `fmi2NewDiscreteStates` (Model Exchange).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct fmi2EventInfo {
    /// Another event iteration is needed.
    pub newDiscreteStatesNeeded: fmi2Boolean,
    /// The model wants to end the simulation.
    pub terminateSimulation: fmi2Boolean,
    /// The nominals of the continuous states changed.
    pub nominalsOfContinuousStatesChanged: fmi2Boolean,
    /// The values of the continuous states changed.
    pub valuesOfContinuousStatesChanged: fmi2Boolean,
    /// `nextEventTime` is defined.
    pub nextEventTimeDefined: fmi2Boolean,
    /// Time of the next time event.
    pub nextEventTime: fmi2Real,
}

/// Turns text into a C string, writing interior NULs as `\0` so nothing is cut off.
pub fn c_string_lossless(text: &str) -> CString {
    match CString::new(text) {
        Ok(s) => s,
        Err(_) => CString::new(text.replace('\0', "\\0")).unwrap_or_default(),
    }
}

/// The host's logger with its environment and the instance name: the one place where the
/// variadic C logger is called. Always passes `"%s"` as the format and the text as its argument.
pub struct HostLogger {
    logger: unsafe extern "C" fn(
        fmi2ComponentEnvironment,
        fmi2String,
        fmi2Status,
        fmi2String,
        fmi2String,
        ...
    ),
    environment: fmi2ComponentEnvironment,
    instance_name: CString,
}

impl HostLogger {
    /// Wraps the host's callbacks; `None` if the host gave no logger.
    ///
    /// # Safety
    /// `callbacks.logger` must be a valid logger callback, callable with
    /// `callbacks.componentEnvironment` for as long as the returned value lives (the FMI 2.0
    /// standard requires this for the lifetime of the instance).
    pub unsafe fn new(
        callbacks: &fmi2CallbackFunctions,
        instance_name: &str,
    ) -> Option<HostLogger> {
        callbacks.logger.map(|logger| HostLogger {
            logger,
            environment: callbacks.componentEnvironment,
            instance_name: c_string_lossless(instance_name),
        })
    }
}

impl LogSink for HostLogger {
    fn log(&self, status: fmi2Status, category: &str, message: &str) {
        let category = c_string_lossless(category);
        let message = c_string_lossless(message);
        // SAFETY: the logger is valid for the life of `self` (contract of `HostLogger::new`);
        // the format "%s" consumes exactly one `char*` argument, which we pass; every string
        // outlives the call.
        unsafe {
            (self.logger)(
                self.environment,
                self.instance_name.as_ptr(),
                status,
                category.as_ptr(),
                c"%s".as_ptr(),
                message.as_ptr(),
            )
        }
    }
}
