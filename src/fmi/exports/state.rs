//! The C entry points of FMU states, their serialization and directional derivatives.
//!
//! # Safety
//! As [the module's](crate::fmi::exports): every pointer is checked before use.

use super::*;

/// `fmi2GetFMUstate`.
///
/// # Safety
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
