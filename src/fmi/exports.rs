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

// ---- get / set ---------------------------------------------------------------------------------

/// `fmi2GetReal`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_real<M: FmiModel>(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2Real,
) -> fmi2Status {
    const F: &str = "fmi2GetReal";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let vr = try_slice!(inst, F, "vr", vr, nvr);
            let value = try_slice_mut!(inst, F, "value", value, nvr);
            inst.get_real(vr, value)
        })
    }
}

/// `fmi2GetInteger`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_integer<M: FmiModel>(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2Integer,
) -> fmi2Status {
    const F: &str = "fmi2GetInteger";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let vr = try_slice!(inst, F, "vr", vr, nvr);
            let value = try_slice_mut!(inst, F, "value", value, nvr);
            inst.get_integer(vr, value)
        })
    }
}

/// `fmi2GetBoolean`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_boolean<M: FmiModel>(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2Boolean,
) -> fmi2Status {
    const F: &str = "fmi2GetBoolean";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let vr = try_slice!(inst, F, "vr", vr, nvr);
            let value = try_slice_mut!(inst, F, "value", value, nvr);
            inst.get_boolean(vr, value)
        })
    }
}

/// `fmi2GetString`: the strings stay valid until the next `fmi2GetString` on this instance.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_string<M: FmiModel>(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2String,
) -> fmi2Status {
    const F: &str = "fmi2GetString";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let vr = try_slice!(inst, F, "vr", vr, nvr);
            let value = try_slice_mut!(inst, F, "value", value, nvr);
            inst.get_string(vr, value)
        })
    }
}

/// `fmi2SetReal`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn set_real<M: FmiModel>(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2Real,
) -> fmi2Status {
    const F: &str = "fmi2SetReal";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let vr = try_slice!(inst, F, "vr", vr, nvr);
            let value = try_slice!(inst, F, "value", value, nvr);
            inst.set_real(vr, value)
        })
    }
}

/// `fmi2SetInteger`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn set_integer<M: FmiModel>(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2Integer,
) -> fmi2Status {
    const F: &str = "fmi2SetInteger";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let vr = try_slice!(inst, F, "vr", vr, nvr);
            let value = try_slice!(inst, F, "value", value, nvr);
            inst.set_integer(vr, value)
        })
    }
}

/// `fmi2SetBoolean`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn set_boolean<M: FmiModel>(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2Boolean,
) -> fmi2Status {
    const F: &str = "fmi2SetBoolean";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let vr = try_slice!(inst, F, "vr", vr, nvr);
            let value = try_slice!(inst, F, "value", value, nvr);
            inst.set_boolean(vr, value)
        })
    }
}

/// `fmi2SetString`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn set_string<M: FmiModel>(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2String,
) -> fmi2Status {
    const F: &str = "fmi2SetString";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let vr = try_slice!(inst, F, "vr", vr, nvr);
            let raw = try_slice!(inst, F, "value", value, nvr);
            let mut values = Vec::with_capacity(raw.len());
            for (i, &p) in raw.iter().enumerate() {
                values.push(try_arg!(inst, F, &format!("value[{i}]"), str_from(p)));
            }
            inst.set_string(vr, &values)
        })
    }
}

// ---- FMU state ---------------------------------------------------------------------------------

/// `fmi2GetFMUstate`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_fmu_state<M: FmiModel>(
    c: fmi2Component,
    fmu_state: *mut fmi2FMUstate,
) -> fmi2Status {
    const F: &str = "fmi2GetFMUstate";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let out = try_ref_mut!(inst, F, "FMUstate", fmu_state);
            let mut slot = handle_from_ptr(*out);
            let status = inst.get_fmu_state(&mut slot);
            *out = handle_to_ptr(slot);
            status
        })
    }
}

/// `fmi2SetFMUstate`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn set_fmu_state<M: FmiModel>(
    c: fmi2Component,
    fmu_state: fmi2FMUstate,
) -> fmi2Status {
    unsafe {
        with_instance::<M>(c, "fmi2SetFMUstate", |inst| {
            inst.set_fmu_state(handle_from_ptr(fmu_state))
        })
    }
}

/// `fmi2FreeFMUstate`: sets `*FMUstate` to NULL; an unknown handle is refused.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn free_fmu_state<M: FmiModel>(
    c: fmi2Component,
    fmu_state: *mut fmi2FMUstate,
) -> fmi2Status {
    const F: &str = "fmi2FreeFMUstate";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            if fmu_state.is_null() {
                return fmi2OK; // the standard: a NULL pointer is ignored
            }
            let out = try_ref_mut!(inst, F, "FMUstate", fmu_state);
            let mut slot = handle_from_ptr(*out);
            let status = inst.free_fmu_state(&mut slot);
            *out = handle_to_ptr(slot);
            status
        })
    }
}

/// `fmi2SerializedFMUstateSize`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn serialized_fmu_state_size<M: FmiModel>(
    c: fmi2Component,
    fmu_state: fmi2FMUstate,
    size: *mut usize,
) -> fmi2Status {
    const F: &str = "fmi2SerializedFMUstateSize";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let size = try_ref_mut!(inst, F, "size", size);
            inst.serialized_fmu_state_size(handle_from_ptr(fmu_state), size)
        })
    }
}

/// `fmi2SerializeFMUstate`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn serialize_fmu_state<M: FmiModel>(
    c: fmi2Component,
    fmu_state: fmi2FMUstate,
    serialized_state: *mut fmi2Byte,
    size: usize,
) -> fmi2Status {
    const F: &str = "fmi2SerializeFMUstate";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let out = try_slice_mut!(
                inst,
                F,
                "serializedState",
                serialized_state.cast::<u8>(),
                size
            );
            inst.serialize_fmu_state(handle_from_ptr(fmu_state), out)
        })
    }
}

/// `fmi2DeSerializeFMUstate`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn de_serialize_fmu_state<M: FmiModel>(
    c: fmi2Component,
    serialized_state: *const fmi2Byte,
    size: usize,
    fmu_state: *mut fmi2FMUstate,
) -> fmi2Status {
    const F: &str = "fmi2DeSerializeFMUstate";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let bytes = try_slice!(
                inst,
                F,
                "serializedState",
                serialized_state.cast::<u8>(),
                size
            );
            let out = try_ref_mut!(inst, F, "FMUstate", fmu_state);
            let mut slot = handle_from_ptr(*out);
            let status = inst.deserialize_fmu_state(bytes, &mut slot);
            *out = handle_to_ptr(slot);
            status
        })
    }
}

/// `fmi2GetDirectionalDerivative`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_directional_derivative<M: FmiModel>(
    c: fmi2Component,
    v_unknown_ref: *const fmi2ValueReference,
    n_unknown: usize,
    v_known_ref: *const fmi2ValueReference,
    n_known: usize,
    dv_known: *const fmi2Real,
    dv_unknown: *mut fmi2Real,
) -> fmi2Status {
    const F: &str = "fmi2GetDirectionalDerivative";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let unknowns = try_slice!(inst, F, "vUnknown_ref", v_unknown_ref, n_unknown);
            let knowns = try_slice!(inst, F, "vKnown_ref", v_known_ref, n_known);
            let dv_known = try_slice!(inst, F, "dvKnown", dv_known, n_known);
            let dv_unknown = try_slice_mut!(inst, F, "dvUnknown", dv_unknown, n_unknown);
            inst.get_directional_derivative(unknowns, knowns, dv_known, dv_unknown)
        })
    }
}

// ---- Co-Simulation -----------------------------------------------------------------------------

/// `fmi2SetRealInputDerivatives`: not supported.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn set_real_input_derivatives<M: FmiModel>(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    order: *const fmi2Integer,
    value: *const fmi2Real,
) -> fmi2Status {
    const F: &str = "fmi2SetRealInputDerivatives";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let vr = try_slice!(inst, F, "vr", vr, nvr);
            let order = try_slice!(inst, F, "order", order, nvr);
            let value = try_slice!(inst, F, "value", value, nvr);
            inst.set_real_input_derivatives(vr, order, value)
        })
    }
}

/// `fmi2GetRealOutputDerivatives`: not supported.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_real_output_derivatives<M: FmiModel>(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    order: *const fmi2Integer,
    value: *mut fmi2Real,
) -> fmi2Status {
    const F: &str = "fmi2GetRealOutputDerivatives";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let vr = try_slice!(inst, F, "vr", vr, nvr);
            let order = try_slice!(inst, F, "order", order, nvr);
            let value = try_slice_mut!(inst, F, "value", value, nvr);
            inst.get_real_output_derivatives(vr, order, value)
        })
    }
}

/// `fmi2DoStep`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn do_step<M: FmiModel>(
    c: fmi2Component,
    current_communication_point: fmi2Real,
    communication_step_size: fmi2Real,
    no_set_fmu_state_prior_to_current_point: fmi2Boolean,
) -> fmi2Status {
    unsafe {
        with_instance::<M>(c, "fmi2DoStep", |inst| {
            inst.do_step(
                current_communication_point,
                communication_step_size,
                to_bool(no_set_fmu_state_prior_to_current_point),
            )
        })
    }
}

/// `fmi2CancelStep`: not supported (steps are synchronous).
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn cancel_step<M: FmiModel>(c: fmi2Component) -> fmi2Status {
    unsafe { with_instance::<M>(c, "fmi2CancelStep", |inst| inst.cancel_step()) }
}

/// `fmi2GetStatus`: not available.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_status<M: FmiModel>(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Status,
) -> fmi2Status {
    const F: &str = "fmi2GetStatus";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let value = try_ref_mut!(inst, F, "value", value);
            inst.get_status(s, value)
        })
    }
}

/// `fmi2GetRealStatus`: `fmi2LastSuccessfulTime`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_real_status<M: FmiModel>(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Real,
) -> fmi2Status {
    const F: &str = "fmi2GetRealStatus";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let value = try_ref_mut!(inst, F, "value", value);
            inst.get_real_status(s, value)
        })
    }
}

/// `fmi2GetIntegerStatus`: not available.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_integer_status<M: FmiModel>(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Integer,
) -> fmi2Status {
    const F: &str = "fmi2GetIntegerStatus";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let value = try_ref_mut!(inst, F, "value", value);
            inst.get_integer_status(s, value)
        })
    }
}

/// `fmi2GetBooleanStatus`: `fmi2Terminated` (always false).
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_boolean_status<M: FmiModel>(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Boolean,
) -> fmi2Status {
    const F: &str = "fmi2GetBooleanStatus";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let value = try_ref_mut!(inst, F, "value", value);
            inst.get_boolean_status(s, value)
        })
    }
}

/// `fmi2GetStringStatus`: not available.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_string_status<M: FmiModel>(
    c: fmi2Component,
    s: fmi2StatusKind,
    _value: *mut fmi2String,
) -> fmi2Status {
    unsafe { with_instance::<M>(c, "fmi2GetStringStatus", |inst| inst.get_string_status(s)) }
}

// ---- Model Exchange ------------------------------------------------------------------------------

/// `fmi2EnterEventMode`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn enter_event_mode<M: FmiModel>(c: fmi2Component) -> fmi2Status {
    unsafe { with_instance::<M>(c, "fmi2EnterEventMode", |inst| inst.enter_event_mode()) }
}

/// `fmi2NewDiscreteStates`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn new_discrete_states<M: FmiModel>(
    c: fmi2Component,
    event_info: *mut fmi2EventInfo,
) -> fmi2Status {
    const F: &str = "fmi2NewDiscreteStates";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let info = try_ref_mut!(inst, F, "fmi2eventInfo", event_info);
            inst.new_discrete_states(info)
        })
    }
}

/// `fmi2EnterContinuousTimeMode`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn enter_continuous_time_mode<M: FmiModel>(c: fmi2Component) -> fmi2Status {
    unsafe {
        with_instance::<M>(c, "fmi2EnterContinuousTimeMode", |inst| {
            inst.enter_continuous_time_mode()
        })
    }
}

/// `fmi2CompletedIntegratorStep`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn completed_integrator_step<M: FmiModel>(
    c: fmi2Component,
    no_set_fmu_state_prior_to_current_point: fmi2Boolean,
    enter_event_mode: *mut fmi2Boolean,
    terminate_simulation: *mut fmi2Boolean,
) -> fmi2Status {
    const F: &str = "fmi2CompletedIntegratorStep";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let enter = try_ref_mut!(inst, F, "enterEventMode", enter_event_mode);
            let terminate = try_ref_mut!(inst, F, "terminateSimulation", terminate_simulation);
            let (mut e, mut t) = (false, false);
            let status = inst.completed_integrator_step(
                to_bool(no_set_fmu_state_prior_to_current_point),
                &mut e,
                &mut t,
            );
            *enter = if e { fmi2True } else { fmi2False };
            *terminate = if t { fmi2True } else { fmi2False };
            status
        })
    }
}

/// `fmi2SetTime`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn set_time<M: FmiModel>(c: fmi2Component, time: fmi2Real) -> fmi2Status {
    unsafe { with_instance::<M>(c, "fmi2SetTime", |inst| inst.set_time(time)) }
}

/// `fmi2SetContinuousStates`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn set_continuous_states<M: FmiModel>(
    c: fmi2Component,
    x: *const fmi2Real,
    nx: usize,
) -> fmi2Status {
    const F: &str = "fmi2SetContinuousStates";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let x = try_slice!(inst, F, "x", x, nx);
            inst.set_continuous_states(x)
        })
    }
}

/// `fmi2GetDerivatives`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_derivatives<M: FmiModel>(
    c: fmi2Component,
    derivatives: *mut fmi2Real,
    nx: usize,
) -> fmi2Status {
    const F: &str = "fmi2GetDerivatives";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let out = try_slice_mut!(inst, F, "derivatives", derivatives, nx);
            inst.get_derivatives(out)
        })
    }
}

/// `fmi2GetEventIndicators` (there are none: `ni` must be 0).
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_event_indicators<M: FmiModel>(
    c: fmi2Component,
    event_indicators: *mut fmi2Real,
    ni: usize,
) -> fmi2Status {
    const F: &str = "fmi2GetEventIndicators";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let out = try_slice_mut!(inst, F, "eventIndicators", event_indicators, ni);
            inst.get_event_indicators(out)
        })
    }
}

/// `fmi2GetContinuousStates`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_continuous_states<M: FmiModel>(
    c: fmi2Component,
    x: *mut fmi2Real,
    nx: usize,
) -> fmi2Status {
    const F: &str = "fmi2GetContinuousStates";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let out = try_slice_mut!(inst, F, "x", x, nx);
            inst.get_continuous_states(out)
        })
    }
}

/// `fmi2GetNominalsOfContinuousStates`.
///
/// # Safety
/// See the [module documentation](self).
pub unsafe extern "C" fn get_nominals_of_continuous_states<M: FmiModel>(
    c: fmi2Component,
    x_nominal: *mut fmi2Real,
    nx: usize,
) -> fmi2Status {
    const F: &str = "fmi2GetNominalsOfContinuousStates";
    unsafe {
        with_instance::<M>(c, F, |inst| {
            let out = try_slice_mut!(inst, F, "x_nominal", x_nominal, nx);
            inst.get_nominals_of_continuous_states(out)
        })
    }
}

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
#[path = "exports_tests.rs"]
mod tests;
