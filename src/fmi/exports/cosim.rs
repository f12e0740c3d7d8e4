//! The C entry points of Co-Simulation.
//!
//! # Safety
//! As [the module's](crate::fmi::exports): every pointer is checked before use.

use super::*;

/// `fmi2SetRealInputDerivatives`: not supported.
///
/// # Safety
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
pub unsafe extern "C" fn cancel_step<M: FmiModel>(c: fmi2Component) -> fmi2Status {
    unsafe { with_instance::<M>(c, "fmi2CancelStep", |inst| inst.cancel_step()) }
}

/// `fmi2GetStatus`: not available.
///
/// # Safety
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
pub unsafe extern "C" fn get_string_status<M: FmiModel>(
    c: fmi2Component,
    s: fmi2StatusKind,
    _value: *mut fmi2String,
) -> fmi2Status {
    unsafe { with_instance::<M>(c, "fmi2GetStringStatus", |inst| inst.get_string_status(s)) }
}
