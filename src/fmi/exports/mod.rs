//! The FMI 2.0 C ABI: one generic `extern "C"` function per `fmi2*` function, and the
//! [`fmi2_exports!`](crate::fmi2_exports) macro that exports them for one model type.
//!
//! Each generic function has exactly the C signature of its `fmi2*TYPE` (checked against
//! `fmi-sys` by `tests/fmi_signatures.rs`) and:
//! - runs its body inside a panic guard (`catch_unwind`): a panic returns `fmi2Fatal` (`NULL`
//!   for `fmi2Instantiate`, nothing for `fmi2FreeInstance`) and marks the instance `Fatal`;
//! - refuses a NULL, freed or foreign component with `fmi2Error` (live instances are kept in a
//!   registry, so a double `fmi2FreeInstance` does nothing);
//! - checks every pointer (NULL, alignment, length) before use and logs which argument was bad;
//! - then calls the safe [`Instance`] method.
//!
//! # Safety
//! For every function here: non-NULL pointers must be valid for the lengths given with them
//! (`nvr`, `nx`, ...), strings NUL-terminated, as the FMI 2.0 standard requires. Everything that
//! can be checked without trusting the host is checked.

use std::collections::BTreeSet;
use std::ffi::{c_char, CStr};
use std::num::NonZeroUsize;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::{Mutex, PoisonError};

use super::contract::{FmiModel, LogCategory};
use super::ffi::*;
use super::instance::{FmuStateHandle, Instance, LogSink};
use super::state_machine::Interface;

/// Addresses of the live instances (any model type).
static LIVE: Mutex<BTreeSet<usize>> = Mutex::new(BTreeSet::new());

fn live() -> std::sync::MutexGuard<'static, BTreeSet<usize>> {
    LIVE.lock().unwrap_or_else(PoisonError::into_inner)
}

fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_owned()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic payload".to_owned()
    }
}

/// Runs `body` on the instance behind `c` inside a panic guard. NULL or unknown `c`:
/// `fmi2Error` (nothing can be logged: there is no logger). Panic: `fmi2Fatal`, instance marked
/// `Fatal`.
///
/// # Safety
/// `c` must be NULL, or a component returned by [`instantiate::<M>`] and not yet freed (a
/// foreign or freed pointer is recognised through the registry of live instances).
unsafe fn with_instance<M: FmiModel>(
    c: fmi2Component,
    function: &str,
    body: impl FnOnce(&mut Instance<M>) -> fmi2Status,
) -> fmi2Status {
    if c.is_null() || !live().contains(&c.addr()) {
        return fmi2Error;
    }
    let instance = c.cast::<Instance<M>>();
    // SAFETY: `c` is live, so it is a `Box<Instance<M>>` from `instantiate::<M>`; the host calls
    // one instance from one thread at a time (FMI 2.0), so this is the only reference.
    match catch_unwind(AssertUnwindSafe(|| body(unsafe { &mut *instance }))) {
        Ok(status) => status,
        Err(payload) => {
            let message = panic_message(&*payload);
            // SAFETY: as above; the reference made for `body` is gone.
            let _ = catch_unwind(AssertUnwindSafe(|| unsafe {
                (*instance).mark_fatal(function, &message)
            }));
            fmi2Fatal
        }
    }
}

/// Why a pointer argument cannot be used.
fn pointer_problem<T>(ptr: *const T, len: usize) -> Option<String> {
    if len == 0 {
        None
    } else if ptr.is_null() {
        Some(format!("NULL pointer for {len} elements"))
    } else if !ptr.is_aligned() {
        Some("misaligned pointer".into())
    } else if len > isize::MAX as usize / std::mem::size_of::<T>().max(1) {
        Some(format!("length {len} is too large"))
    } else {
        None
    }
}

/// `&[T]` from a C array; `len == 0` gives an empty slice whatever the pointer.
///
/// # Safety
/// A non-NULL `ptr` must be valid for reading `len` elements for `'a`.
unsafe fn slice_from<'a, T>(ptr: *const T, len: usize) -> Result<&'a [T], String> {
    match pointer_problem(ptr, len) {
        Some(problem) => Err(problem),
        None if len == 0 => Ok(&[]),
        // SAFETY: non-NULL, aligned, size checked; validity is the caller's contract.
        None => Ok(unsafe { std::slice::from_raw_parts(ptr, len) }),
    }
}

/// `&mut [T]` from a C array; `len == 0` gives an empty slice whatever the pointer.
///
/// # Safety
/// A non-NULL `ptr` must be valid for writing `len` elements for `'a`, and not aliased.
unsafe fn slice_mut_from<'a, T>(ptr: *mut T, len: usize) -> Result<&'a mut [T], String> {
    match pointer_problem(ptr, len) {
        Some(problem) => Err(problem),
        None if len == 0 => Ok(&mut []),
        // SAFETY: non-NULL, aligned, size checked; validity is the caller's contract.
        None => Ok(unsafe { std::slice::from_raw_parts_mut(ptr, len) }),
    }
}

/// `&mut T` from an output pointer.
///
/// # Safety
/// A non-NULL `ptr` must be valid for writing a `T` for `'a`, and not aliased.
unsafe fn ref_mut_from<'a, T>(ptr: *mut T) -> Result<&'a mut T, String> {
    match pointer_problem(ptr, 1) {
        Some(problem) => Err(problem),
        // SAFETY: non-NULL and aligned; validity is the caller's contract.
        None => Ok(unsafe { &mut *ptr }),
    }
}

/// `&str` from a C string.
///
/// # Safety
/// A non-NULL `ptr` must point to a NUL-terminated string valid for `'a`.
unsafe fn str_from<'a>(ptr: fmi2String) -> Result<&'a str, String> {
    if ptr.is_null() {
        return Err("NULL string".into());
    }
    // SAFETY: non-NULL; NUL-terminated by the caller's contract.
    unsafe { CStr::from_ptr(ptr) }
        .to_str()
        .map_err(|e| format!("not valid UTF-8 ({e})"))
}

/// Turns a checked-argument result into its value, or logs the problem with the argument's
/// name and returns `fmi2Error` from the enclosing closure.
macro_rules! try_arg {
    ($instance:expr, $function:expr, $name:expr, $result:expr) => {
        match $result {
            Ok(value) => value,
            Err(problem) => return $instance.bad_argument($function, $name, &problem),
        }
    };
}

/// Checked `&[T]` from `(ptr, len)` (see [`slice_from`]); used inside the `unsafe` block
/// around [`with_instance`], whose contract covers the pointers.
macro_rules! try_slice {
    ($instance:expr, $function:expr, $name:expr, $ptr:expr, $len:expr) => {
        try_arg!($instance, $function, $name, slice_from($ptr, $len))
    };
}

/// Checked `&mut [T]` from `(ptr, len)` (see [`slice_mut_from`]).
macro_rules! try_slice_mut {
    ($instance:expr, $function:expr, $name:expr, $ptr:expr, $len:expr) => {
        try_arg!($instance, $function, $name, slice_mut_from($ptr, $len))
    };
}

/// Checked `&mut T` from an output pointer (see [`ref_mut_from`]).
macro_rules! try_ref_mut {
    ($instance:expr, $function:expr, $name:expr, $ptr:expr) => {
        try_arg!($instance, $function, $name, ref_mut_from($ptr))
    };
}

fn handle_from_ptr(state: fmi2FMUstate) -> Option<FmuStateHandle> {
    NonZeroUsize::new(state.addr()).map(FmuStateHandle)
}

fn handle_to_ptr(handle: Option<FmuStateHandle>) -> fmi2FMUstate {
    // Handles are numbers, never dereferenced: a pointer without provenance is right.
    std::ptr::without_provenance_mut(handle.map_or(0, |h| h.0.get()))
}

fn to_bool(b: fmi2Boolean) -> bool {
    b != fmi2False
}

// ---- common functions ------------------------------------------------------------------------

/// `fmi2GetTypesPlatform`: `"default"`.
pub extern "C" fn get_types_platform() -> *const c_char {
    c"default".as_ptr()
}

/// `fmi2GetVersion`: `"2.0"`.
pub extern "C" fn get_version() -> *const c_char {
    c"2.0".as_ptr()
}

/// `fmi2SetDebugLogging`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn set_debug_logging<M: FmiModel>(
    c: fmi2Component,
    logging_on: fmi2Boolean,
    n_categories: usize,
    categories: *const fmi2String,
) -> fmi2Status {
    const F: &str = "fmi2SetDebugLogging";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let raw = try_slice!(inst, F, "categories", categories, n_categories);
            let mut names = Vec::with_capacity(raw.len());
            for (i, &p) in raw.iter().enumerate() {
                names.push(try_arg!(inst, F, &format!("categories[{i}]"), str_from(p)));
            }
            inst.set_debug_logging(to_bool(logging_on), &names)
        })
    }
}

/// `fmi2Instantiate`: NULL (with the reason logged, if there is a logger) on a bad argument,
/// a model that cannot be built, or a GUID that does not match.
///
/// # Safety
/// See the [module documentation](self); `functions` must stay valid while the instance lives.
pub unsafe extern "C" fn instantiate<M: FmiModel>(
    instance_name: fmi2String,
    fmu_type: fmi2Type,
    fmu_guid: fmi2String,
    fmu_resource_location: fmi2String,
    functions: *const fmi2CallbackFunctions,
    _visible: fmi2Boolean,
    logging_on: fmi2Boolean,
) -> fmi2Component {
    let result = catch_unwind(AssertUnwindSafe(|| unsafe {
        instantiate_checked::<M>(
            instance_name,
            fmu_type,
            fmu_guid,
            fmu_resource_location,
            functions,
            logging_on,
        )
    }));
    match result {
        Ok(c) => c,
        Err(payload) => {
            let message = format!(
                "fmi2Instantiate: internal error (panic: {})",
                panic_message(&*payload)
            );
            let _ = catch_unwind(AssertUnwindSafe(|| {
                // SAFETY: `functions` was checked non-NULL and aligned before anything could panic,
                // or it is NULL/misaligned and `as_ref` below is not reached.
                if pointer_problem(functions, 1).is_none() {
                    if let Some(logger) = unsafe { HostLogger::new(&*functions, "") } {
                        logger.log(fmi2Error, LogCategory::StatusError.name(), &message);
                    }
                }
            }));
            std::ptr::null_mut()
        }
    }
}

/// The body of [`instantiate`], outside the panic guard.
///
/// # Safety
/// As [`instantiate`].
unsafe fn instantiate_checked<M: FmiModel>(
    instance_name: fmi2String,
    fmu_type: fmi2Type,
    fmu_guid: fmi2String,
    fmu_resource_location: fmi2String,
    functions: *const fmi2CallbackFunctions,
    logging_on: fmi2Boolean,
) -> fmi2Component {
    if pointer_problem(functions, 1).is_some() {
        return std::ptr::null_mut();
    }
    // SAFETY: non-NULL and aligned; valid by the caller's contract.
    let functions = unsafe { &*functions };
    let name = unsafe { str_from(instance_name) };
    // SAFETY: the host keeps its logger valid while the instance lives (FMI 2.0).
    let logger = unsafe { HostLogger::new(functions, name.as_deref().unwrap_or("")) };
    let fail = |message: String| {
        if let Some(logger) = &logger {
            logger.log(
                fmi2Error,
                LogCategory::StatusError.name(),
                &format!("fmi2Instantiate: {message}"),
            );
        }
        std::ptr::null_mut()
    };
    let name = match name {
        Ok(name) => name,
        Err(problem) => return fail(format!("argument instanceName is invalid: {problem}")),
    };
    let interface = if fmu_type == fmi2CoSimulation {
        Interface::CoSimulation
    } else if fmu_type == fmi2ModelExchange {
        Interface::ModelExchange
    } else {
        return fail(format!("argument fmuType = {fmu_type} is neither fmi2ModelExchange (0) nor fmi2CoSimulation (1)"));
    };
    let guid = match unsafe { str_from(fmu_guid) } {
        Ok(guid) => guid,
        Err(problem) => return fail(format!("argument fmuGUID is invalid: {problem}")),
    };
    let location = match unsafe { str_from(fmu_resource_location) } {
        Ok(location) => location,
        Err(problem) => {
            return fail(format!(
                "argument fmuResourceLocation is invalid: {problem}"
            ))
        }
    };
    let sink = logger.map(|l| Box::new(l) as Box<dyn LogSink>);
    match Instance::<M>::instantiate(name, interface, guid, location, to_bool(logging_on), sink) {
        Ok(instance) => {
            let c = Box::into_raw(Box::new(instance));
            live().insert(c.addr());
            c.cast()
        }
        Err(_) => std::ptr::null_mut(),
    }
}

/// `fmi2FreeInstance`: drops the instance; NULL, freed or foreign components are ignored.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn free_instance<M: FmiModel>(c: fmi2Component) {
    if c.is_null() || !live().remove(&c.addr()) {
        return;
    }
    // SAFETY: `c` was live (now removed from the registry), so it is our `Box<Instance<M>>`.
    let instance = unsafe { Box::from_raw(c.cast::<Instance<M>>()) };
    let _ = catch_unwind(AssertUnwindSafe(move || drop(instance)));
}

/// `fmi2SetupExperiment`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn setup_experiment<M: FmiModel>(
    c: fmi2Component,
    tolerance_defined: fmi2Boolean,
    tolerance: fmi2Real,
    start_time: fmi2Real,
    stop_time_defined: fmi2Boolean,
    stop_time: fmi2Real,
) -> fmi2Status {
    let tolerance = to_bool(tolerance_defined).then_some(tolerance);
    let stop_time = to_bool(stop_time_defined).then_some(stop_time);
    unsafe {
        with_instance::<M>(c, "fmi2SetupExperiment", |inst| {
            inst.setup_experiment(tolerance, start_time, stop_time)
        })
    }
}

/// `fmi2EnterInitializationMode`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn enter_initialization_mode<M: FmiModel>(c: fmi2Component) -> fmi2Status {
    unsafe {
        with_instance::<M>(c, "fmi2EnterInitializationMode", |inst| {
            inst.enter_initialization_mode()
        })
    }
}

/// `fmi2ExitInitializationMode`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn exit_initialization_mode<M: FmiModel>(c: fmi2Component) -> fmi2Status {
    unsafe {
        with_instance::<M>(c, "fmi2ExitInitializationMode", |inst| {
            inst.exit_initialization_mode()
        })
    }
}

/// `fmi2Terminate`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn terminate<M: FmiModel>(c: fmi2Component) -> fmi2Status {
    unsafe { with_instance::<M>(c, "fmi2Terminate", |inst| inst.terminate()) }
}

/// `fmi2Reset`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn reset<M: FmiModel>(c: fmi2Component) -> fmi2Status {
    unsafe { with_instance::<M>(c, "fmi2Reset", |inst| inst.reset()) }
}

mod cosim;
mod me;
mod state;
mod values;

pub use cosim::*;
pub use me::*;
pub use state::*;
pub use values::*;

/// Exports every FMI 2.0 function (common, Co-Simulation and Model Exchange) as a
/// `#[no_mangle] extern "C"` symbol for the model type `$model`, each a one-line trampoline into
/// the generic function of [`crate::fmi::exports`]. Invoke once, at the crate root:
/// `crate::fmi2_exports!(crate::sim::Simulation);`
#[macro_export]
macro_rules! fmi2_exports {
    ($model:ty) => {
        $crate::__fmi2_export_functions! { $model;
            fmi2GetTypesPlatform => get_types_platform() -> *const ::std::ffi::c_char;
            fmi2GetVersion => get_version() -> *const ::std::ffi::c_char;
        }
        $crate::__fmi2_export_functions! { $model; <$model>
            fmi2SetDebugLogging => set_debug_logging(c: $crate::fmi::ffi::fmi2Component, logging_on: $crate::fmi::ffi::fmi2Boolean, n_categories: usize, categories: *const $crate::fmi::ffi::fmi2String) -> $crate::fmi::ffi::fmi2Status;
            fmi2Instantiate => instantiate(instance_name: $crate::fmi::ffi::fmi2String, fmu_type: $crate::fmi::ffi::fmi2Type, fmu_guid: $crate::fmi::ffi::fmi2String, fmu_resource_location: $crate::fmi::ffi::fmi2String, functions: *const $crate::fmi::ffi::fmi2CallbackFunctions, visible: $crate::fmi::ffi::fmi2Boolean, logging_on: $crate::fmi::ffi::fmi2Boolean) -> $crate::fmi::ffi::fmi2Component;
            fmi2FreeInstance => free_instance(c: $crate::fmi::ffi::fmi2Component) -> ();
            fmi2SetupExperiment => setup_experiment(c: $crate::fmi::ffi::fmi2Component, tolerance_defined: $crate::fmi::ffi::fmi2Boolean, tolerance: f64, start_time: f64, stop_time_defined: $crate::fmi::ffi::fmi2Boolean, stop_time: f64) -> $crate::fmi::ffi::fmi2Status;
            fmi2EnterInitializationMode => enter_initialization_mode(c: $crate::fmi::ffi::fmi2Component) -> $crate::fmi::ffi::fmi2Status;
            fmi2ExitInitializationMode => exit_initialization_mode(c: $crate::fmi::ffi::fmi2Component) -> $crate::fmi::ffi::fmi2Status;
            fmi2Terminate => terminate(c: $crate::fmi::ffi::fmi2Component) -> $crate::fmi::ffi::fmi2Status;
            fmi2Reset => reset(c: $crate::fmi::ffi::fmi2Component) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetReal => get_real(c: $crate::fmi::ffi::fmi2Component, vr: *const u32, nvr: usize, value: *mut f64) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetInteger => get_integer(c: $crate::fmi::ffi::fmi2Component, vr: *const u32, nvr: usize, value: *mut $crate::fmi::ffi::fmi2Integer) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetBoolean => get_boolean(c: $crate::fmi::ffi::fmi2Component, vr: *const u32, nvr: usize, value: *mut $crate::fmi::ffi::fmi2Boolean) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetString => get_string(c: $crate::fmi::ffi::fmi2Component, vr: *const u32, nvr: usize, value: *mut $crate::fmi::ffi::fmi2String) -> $crate::fmi::ffi::fmi2Status;
            fmi2SetReal => set_real(c: $crate::fmi::ffi::fmi2Component, vr: *const u32, nvr: usize, value: *const f64) -> $crate::fmi::ffi::fmi2Status;
            fmi2SetInteger => set_integer(c: $crate::fmi::ffi::fmi2Component, vr: *const u32, nvr: usize, value: *const $crate::fmi::ffi::fmi2Integer) -> $crate::fmi::ffi::fmi2Status;
            fmi2SetBoolean => set_boolean(c: $crate::fmi::ffi::fmi2Component, vr: *const u32, nvr: usize, value: *const $crate::fmi::ffi::fmi2Boolean) -> $crate::fmi::ffi::fmi2Status;
            fmi2SetString => set_string(c: $crate::fmi::ffi::fmi2Component, vr: *const u32, nvr: usize, value: *const $crate::fmi::ffi::fmi2String) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetFMUstate => get_fmu_state(c: $crate::fmi::ffi::fmi2Component, fmu_state: *mut $crate::fmi::ffi::fmi2FMUstate) -> $crate::fmi::ffi::fmi2Status;
            fmi2SetFMUstate => set_fmu_state(c: $crate::fmi::ffi::fmi2Component, fmu_state: $crate::fmi::ffi::fmi2FMUstate) -> $crate::fmi::ffi::fmi2Status;
            fmi2FreeFMUstate => free_fmu_state(c: $crate::fmi::ffi::fmi2Component, fmu_state: *mut $crate::fmi::ffi::fmi2FMUstate) -> $crate::fmi::ffi::fmi2Status;
            fmi2SerializedFMUstateSize => serialized_fmu_state_size(c: $crate::fmi::ffi::fmi2Component, fmu_state: $crate::fmi::ffi::fmi2FMUstate, size: *mut usize) -> $crate::fmi::ffi::fmi2Status;
            fmi2SerializeFMUstate => serialize_fmu_state(c: $crate::fmi::ffi::fmi2Component, fmu_state: $crate::fmi::ffi::fmi2FMUstate, serialized_state: *mut $crate::fmi::ffi::fmi2Byte, size: usize) -> $crate::fmi::ffi::fmi2Status;
            fmi2DeSerializeFMUstate => de_serialize_fmu_state(c: $crate::fmi::ffi::fmi2Component, serialized_state: *const $crate::fmi::ffi::fmi2Byte, size: usize, fmu_state: *mut $crate::fmi::ffi::fmi2FMUstate) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetDirectionalDerivative => get_directional_derivative(c: $crate::fmi::ffi::fmi2Component, v_unknown_ref: *const u32, n_unknown: usize, v_known_ref: *const u32, n_known: usize, dv_known: *const f64, dv_unknown: *mut f64) -> $crate::fmi::ffi::fmi2Status;
            fmi2EnterEventMode => enter_event_mode(c: $crate::fmi::ffi::fmi2Component) -> $crate::fmi::ffi::fmi2Status;
            fmi2NewDiscreteStates => new_discrete_states(c: $crate::fmi::ffi::fmi2Component, event_info: *mut $crate::fmi::ffi::fmi2EventInfo) -> $crate::fmi::ffi::fmi2Status;
            fmi2EnterContinuousTimeMode => enter_continuous_time_mode(c: $crate::fmi::ffi::fmi2Component) -> $crate::fmi::ffi::fmi2Status;
            fmi2CompletedIntegratorStep => completed_integrator_step(c: $crate::fmi::ffi::fmi2Component, no_set_fmu_state_prior: $crate::fmi::ffi::fmi2Boolean, enter_event_mode: *mut $crate::fmi::ffi::fmi2Boolean, terminate_simulation: *mut $crate::fmi::ffi::fmi2Boolean) -> $crate::fmi::ffi::fmi2Status;
            fmi2SetTime => set_time(c: $crate::fmi::ffi::fmi2Component, time: f64) -> $crate::fmi::ffi::fmi2Status;
            fmi2SetContinuousStates => set_continuous_states(c: $crate::fmi::ffi::fmi2Component, x: *const f64, nx: usize) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetDerivatives => get_derivatives(c: $crate::fmi::ffi::fmi2Component, derivatives: *mut f64, nx: usize) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetEventIndicators => get_event_indicators(c: $crate::fmi::ffi::fmi2Component, event_indicators: *mut f64, ni: usize) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetContinuousStates => get_continuous_states(c: $crate::fmi::ffi::fmi2Component, x: *mut f64, nx: usize) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetNominalsOfContinuousStates => get_nominals_of_continuous_states(c: $crate::fmi::ffi::fmi2Component, x_nominal: *mut f64, nx: usize) -> $crate::fmi::ffi::fmi2Status;
            fmi2SetRealInputDerivatives => set_real_input_derivatives(c: $crate::fmi::ffi::fmi2Component, vr: *const u32, nvr: usize, order: *const $crate::fmi::ffi::fmi2Integer, value: *const f64) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetRealOutputDerivatives => get_real_output_derivatives(c: $crate::fmi::ffi::fmi2Component, vr: *const u32, nvr: usize, order: *const $crate::fmi::ffi::fmi2Integer, value: *mut f64) -> $crate::fmi::ffi::fmi2Status;
            fmi2DoStep => do_step(c: $crate::fmi::ffi::fmi2Component, current_communication_point: f64, communication_step_size: f64, no_set_fmu_state_prior: $crate::fmi::ffi::fmi2Boolean) -> $crate::fmi::ffi::fmi2Status;
            fmi2CancelStep => cancel_step(c: $crate::fmi::ffi::fmi2Component) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetStatus => get_status(c: $crate::fmi::ffi::fmi2Component, s: $crate::fmi::ffi::fmi2StatusKind, value: *mut $crate::fmi::ffi::fmi2Status) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetRealStatus => get_real_status(c: $crate::fmi::ffi::fmi2Component, s: $crate::fmi::ffi::fmi2StatusKind, value: *mut f64) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetIntegerStatus => get_integer_status(c: $crate::fmi::ffi::fmi2Component, s: $crate::fmi::ffi::fmi2StatusKind, value: *mut $crate::fmi::ffi::fmi2Integer) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetBooleanStatus => get_boolean_status(c: $crate::fmi::ffi::fmi2Component, s: $crate::fmi::ffi::fmi2StatusKind, value: *mut $crate::fmi::ffi::fmi2Boolean) -> $crate::fmi::ffi::fmi2Status;
            fmi2GetStringStatus => get_string_status(c: $crate::fmi::ffi::fmi2Component, s: $crate::fmi::ffi::fmi2StatusKind, value: *mut $crate::fmi::ffi::fmi2String) -> $crate::fmi::ffi::fmi2Status;
        }
    };
}

/// Implementation detail of [`fmi2_exports!`](crate::fmi2_exports): one trampoline per entry.
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi2_export_functions {
    ($model:ty; $( $cname:ident => $generic:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty ; )*) => {
        $(
            #[doc = concat!("`", stringify!($cname), "` (FMI 2.0): see [`", stringify!($generic), "`](", "crate::fmi::exports::", stringify!($generic), ").")]
            #[no_mangle]
            #[allow(non_snake_case)]
            pub extern "C" fn $cname($($arg: $ty),*) -> $ret {
                $crate::fmi::exports::$generic($($arg),*)
            }
        )*
    };
    ($model:ty; <$m:ty> $( $cname:ident => $generic:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty ; )*) => {
        $(
            #[doc = concat!("`", stringify!($cname), "` (FMI 2.0): see [`", stringify!($generic), "`](", "crate::fmi::exports::", stringify!($generic), ").")]
            #[doc = ""]
            #[doc = "# Safety"]
            #[doc = "As the FMI 2.0 standard requires of the caller."]
            #[no_mangle]
            #[allow(non_snake_case)]
            pub unsafe extern "C" fn $cname($($arg: $ty),*) -> $ret {
                unsafe { $crate::fmi::exports::$generic::<$m>($($arg),*) }
            }
        )*
    };
}

#[cfg(test)]
mod tests;
