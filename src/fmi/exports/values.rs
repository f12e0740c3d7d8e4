//! The C entry points of `fmi2Get*`/`fmi2Set*`.
//!
//! # Safety
//! As [the module's](crate::fmi::exports): every pointer is checked before use.

use super::*;

/// `fmi2GetReal`.
///
/// # Safety
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
