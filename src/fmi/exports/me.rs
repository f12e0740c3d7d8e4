//! The C entry points of Model Exchange.
//!
//! # Safety
//! As [the module's](crate::fmi::exports): every pointer is checked before use.

use super::*;

/// `fmi2EnterEventMode`.
///
/// # Safety
/// See the [module documentation](crate::fmi::exports).
pub unsafe extern "C" fn enter_event_mode<M: FmiModel>(c: fmi2Component) -> fmi2Status {
    unsafe { with_instance::<M>(c, "fmi2EnterEventMode", |inst| inst.enter_event_mode()) }
}

/// `fmi2NewDiscreteStates`.
///
/// # Safety
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
pub unsafe extern "C" fn set_time<M: FmiModel>(c: fmi2Component, time: fmi2Real) -> fmi2Status {
    unsafe { with_instance::<M>(c, "fmi2SetTime", |inst| inst.set_time(time)) }
}

/// `fmi2SetContinuousStates`.
///
/// # Safety
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
/// See the [module documentation](crate::fmi::exports).
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
