//! Tests of the C ABI through the generic functions, with the logger of [`crate::fmi::host_log`]
//! (x86_64 and AArch64 Linux only, as that module).
#![cfg(all(
    any(target_arch = "x86_64", target_arch = "aarch64"),
    target_os = "linux"
))]

use std::ffi::{CStr, CString};
use std::ptr::{null, null_mut};

use super::*;
use crate::fmi::host_log::{LogCapture, Logged};
use crate::fmi::toy_model::{Toy, GUID};

/// The log of a test: the crate's host-side capture.
type Env = LogCapture;

fn callbacks(env: &Env) -> fmi2CallbackFunctions {
    env.callbacks()
}

fn records(env: &Env) -> Vec<Logged> {
    env.all()
}

fn last(env: &Env) -> Logged {
    records(env).last().cloned().expect("something was logged")
}

const RES: &CStr = c"file:///tmp/scm-toy-resources";

unsafe fn new_instance(
    _env: &Env,
    cb: &fmi2CallbackFunctions,
    fmu_type: fmi2Type,
) -> fmi2Component {
    let guid = CString::new(GUID).unwrap();
    unsafe {
        instantiate::<Toy>(
            c"toy".as_ptr(),
            fmu_type,
            guid.as_ptr(),
            RES.as_ptr(),
            cb,
            fmi2False,
            fmi2False,
        )
    }
}

unsafe fn initialized(env: &Env, cb: &fmi2CallbackFunctions) -> fmi2Component {
    unsafe {
        let c = new_instance(env, cb, fmi2CoSimulation);
        assert!(!c.is_null(), "{:?}", records(env));
        assert_eq!(
            setup_experiment::<Toy>(c, fmi2False, 0.0, 0.0, fmi2False, 0.0),
            fmi2OK
        );
        assert_eq!(enter_initialization_mode::<Toy>(c), fmi2OK);
        assert_eq!(exit_initialization_mode::<Toy>(c), fmi2OK);
        c
    }
}

#[test]
fn version_and_platform() {
    assert_eq!(unsafe { CStr::from_ptr(get_types_platform()) }, c"default");
    assert_eq!(unsafe { CStr::from_ptr(get_version()) }, c"2.0");
}

#[test]
fn instantiate_failures_return_null_and_log_with_percent_s() {
    let env = Env::default();
    let cb = callbacks(&env);
    unsafe {
        let c = instantiate::<Toy>(
            c"toy".as_ptr(),
            fmi2CoSimulation,
            c"{not-the-guid}".as_ptr(),
            RES.as_ptr(),
            &cb,
            0,
            1,
        );
        assert!(c.is_null());
        let r = last(&env);
        assert_eq!(r.format, "%s");
        assert_eq!(r.status, fmi2Error);
        assert_eq!(r.category, "logStatusError");
        assert_eq!(r.instance, "toy");
        assert!(r.message.contains("{not-the-guid}"), "{r:?}");

        let guid = CString::new(GUID).unwrap();
        assert!(instantiate::<Toy>(
            null(),
            fmi2CoSimulation,
            guid.as_ptr(),
            RES.as_ptr(),
            &cb,
            0,
            1
        )
        .is_null());
        assert!(last(&env).message.contains("instanceName"));
        assert!(
            instantiate::<Toy>(c"toy".as_ptr(), 7, guid.as_ptr(), RES.as_ptr(), &cb, 0, 1)
                .is_null()
        );
        assert!(last(&env).message.contains("fmuType = 7"));
        assert!(instantiate::<Toy>(
            c"toy".as_ptr(),
            fmi2CoSimulation,
            null(),
            RES.as_ptr(),
            &cb,
            0,
            1
        )
        .is_null());
        assert!(instantiate::<Toy>(
            c"toy".as_ptr(),
            fmi2CoSimulation,
            guid.as_ptr(),
            null(),
            &cb,
            0,
            1
        )
        .is_null());
        assert!(last(&env).message.contains("fmuResourceLocation"));
        assert!(instantiate::<Toy>(
            c"toy".as_ptr(),
            fmi2CoSimulation,
            guid.as_ptr(),
            c"http://x".as_ptr(),
            &cb,
            0,
            1
        )
        .is_null());
        assert!(instantiate::<Toy>(
            c"toy".as_ptr(),
            fmi2CoSimulation,
            guid.as_ptr(),
            RES.as_ptr(),
            null(),
            0,
            1
        )
        .is_null());
        // a message holding printf directives is passed as an argument, never as the format
        let c = instantiate::<Toy>(
            c"toy".as_ptr(),
            fmi2CoSimulation,
            c"%s%n%s".as_ptr(),
            RES.as_ptr(),
            &cb,
            0,
            1,
        );
        assert!(c.is_null());
        assert!(last(&env).message.contains("\"%s%n%s\""));
        assert!(records(&env).iter().all(|r| r.format == "%s"));
        // no logger at all: still NULL, no crash
        let quiet = fmi2CallbackFunctions { logger: None, ..cb };
        assert!(instantiate::<Toy>(
            c"toy".as_ptr(),
            fmi2CoSimulation,
            c"x".as_ptr(),
            RES.as_ptr(),
            &quiet,
            0,
            1
        )
        .is_null());
    }
}

#[test]
fn co_simulation_through_the_c_abi() {
    let env = Env::default();
    let cb = callbacks(&env);
    unsafe {
        let c = initialized(&env, &cb);
        let vr = [0u32, 1];
        let mut v = [0.0; 2];
        assert_eq!(get_real::<Toy>(c, vr.as_ptr(), 2, v.as_mut_ptr()), fmi2OK);
        assert_eq!(v, [1.0, 0.0]);
        assert_eq!(do_step::<Toy>(c, 0.0, 0.1, fmi2True), fmi2OK);
        assert_eq!(
            do_step::<Toy>(c, 0.0, 0.1, fmi2True),
            fmi2Error,
            "wrong communication point"
        );
        assert!(last(&env).message.contains("currentCommunicationPoint"));
        let mut t = 0.0;
        assert_eq!(
            get_real_status::<Toy>(c, fmi2LastSuccessfulTime, &mut t),
            fmi2OK
        );
        assert_eq!(t, 0.1);
        // strings
        let mut s: fmi2String = null();
        assert_eq!(get_string::<Toy>(c, [0u32].as_ptr(), 1, &mut s), fmi2OK);
        assert_eq!(CStr::from_ptr(s).to_str().unwrap(), "toy");
        // debug logging through C strings
        let cats = [c"logContact".as_ptr()];
        assert_eq!(
            set_debug_logging::<Toy>(c, fmi2True, 1, cats.as_ptr()),
            fmi2OK
        );
        assert_eq!(do_step::<Toy>(c, 0.1, 0.1, fmi2True), fmi2OK);
        assert_eq!(last(&env).category, "logContact");
        let bad = [c"logNope".as_ptr()];
        assert_eq!(
            set_debug_logging::<Toy>(c, fmi2True, 1, bad.as_ptr()),
            fmi2Error
        );
        assert!(last(&env).message.contains("logNope"));
        assert_eq!(cancel_step::<Toy>(c), fmi2Error);
        assert_eq!(terminate::<Toy>(c), fmi2OK);
        free_instance::<Toy>(c);
        assert!(records(&env).iter().all(|r| r.format == "%s"));
    }
}

#[test]
fn null_pointers_are_refused() {
    let env = Env::default();
    let cb = callbacks(&env);
    unsafe {
        assert_eq!(do_step::<Toy>(null_mut(), 0.0, 0.1, 0), fmi2Error);
        assert_eq!(
            get_real::<Toy>(null_mut(), null(), 0, null_mut()),
            fmi2Error
        );
        free_instance::<Toy>(null_mut());
        let c = initialized(&env, &cb);
        let mut v = [0.0];
        assert_eq!(get_real::<Toy>(c, null(), 1, v.as_mut_ptr()), fmi2Error);
        let r = last(&env);
        assert_eq!(
            r.message,
            "fmi2GetReal: argument vr is invalid: NULL pointer for 1 elements"
        );
        assert_eq!(
            get_real::<Toy>(c, [0u32].as_ptr(), 1, null_mut()),
            fmi2Error
        );
        assert!(last(&env).message.contains("argument value"));
        assert_eq!(
            get_real::<Toy>(c, null(), 0, null_mut()),
            fmi2OK,
            "nvr = 0: pointers unused"
        );
        assert_eq!(set_real::<Toy>(c, [2u32].as_ptr(), 1, null()), fmi2Error);
        let strings = [null()];
        assert_eq!(
            set_string::<Toy>(c, [0u32].as_ptr(), 1, strings.as_ptr()),
            fmi2Error
        );
        assert!(last(&env).message.contains("value[0]"));
        assert_eq!(get_fmu_state::<Toy>(c, null_mut()), fmi2Error);
        assert_eq!(
            free_fmu_state::<Toy>(c, null_mut()),
            fmi2OK,
            "ignored by the standard"
        );
        assert_eq!(
            serialized_fmu_state_size::<Toy>(c, null_mut(), null_mut()),
            fmi2Error
        );
        assert_eq!(
            get_real_status::<Toy>(c, fmi2LastSuccessfulTime, null_mut()),
            fmi2Error
        );
        assert_eq!(new_discrete_states::<Toy>(c, null_mut()), fmi2Error);
        let misaligned = (v.as_mut_ptr() as *mut u8).wrapping_add(1) as *mut f64;
        assert_eq!(
            get_real::<Toy>(c, [0u32].as_ptr(), 1, misaligned),
            fmi2Error
        );
        assert!(last(&env).message.contains("misaligned"));
        free_instance::<Toy>(c);
    }
}

#[test]
fn freed_and_foreign_components_are_refused() {
    let env = Env::default();
    let cb = callbacks(&env);
    unsafe {
        let c = initialized(&env, &cb);
        free_instance::<Toy>(c);
        assert_eq!(do_step::<Toy>(c, 0.0, 0.1, 0), fmi2Error, "use after free");
        free_instance::<Toy>(c); // double free: ignored
        let mut not_an_instance = [0u64; 64];
        let foreign = not_an_instance.as_mut_ptr() as fmi2Component;
        assert_eq!(reset::<Toy>(foreign), fmi2Error);
        free_instance::<Toy>(foreign);
    }
}

#[test]
fn fmu_state_handles_through_the_c_abi() {
    let env = Env::default();
    let cb = callbacks(&env);
    unsafe {
        let c = initialized(&env, &cb);
        let mut state: fmi2FMUstate = null_mut();
        assert_eq!(get_fmu_state::<Toy>(c, &mut state), fmi2OK);
        assert!(!state.is_null());
        assert_eq!(do_step::<Toy>(c, 0.0, 0.5, 0), fmi2OK);
        let mut size = 0usize;
        assert_eq!(
            serialized_fmu_state_size::<Toy>(c, state, &mut size),
            fmi2OK
        );
        let mut bytes = vec![0 as fmi2Byte; size];
        assert_eq!(
            serialize_fmu_state::<Toy>(c, state, bytes.as_mut_ptr(), size),
            fmi2OK
        );
        assert_eq!(set_fmu_state::<Toy>(c, state), fmi2OK);
        let mut x = 0.0;
        assert_eq!(get_real::<Toy>(c, [0u32].as_ptr(), 1, &mut x), fmi2OK);
        assert_eq!(x, 1.0);
        let mut copy: fmi2FMUstate = null_mut();
        assert_eq!(
            de_serialize_fmu_state::<Toy>(c, bytes.as_ptr(), size, &mut copy),
            fmi2OK
        );
        assert!(!copy.is_null() && copy != state);
        let stale = state;
        assert_eq!(free_fmu_state::<Toy>(c, &mut state), fmi2OK);
        assert!(state.is_null());
        let mut again = stale;
        assert_eq!(
            free_fmu_state::<Toy>(c, &mut again),
            fmi2Error,
            "double free"
        );
        assert!(last(&env).message.contains("unknown FMU state"));
        let mut foreign = &mut x as *mut f64 as fmi2FMUstate;
        assert_eq!(
            free_fmu_state::<Toy>(c, &mut foreign),
            fmi2Error,
            "foreign pointer"
        );
        assert_eq!(set_fmu_state::<Toy>(c, foreign), fmi2Error);
        assert_eq!(free_fmu_state::<Toy>(c, &mut copy), fmi2OK);
        let garbage = [7 as fmi2Byte; 40];
        let mut slot: fmi2FMUstate = null_mut();
        assert_eq!(
            de_serialize_fmu_state::<Toy>(c, garbage.as_ptr(), garbage.len(), &mut slot),
            fmi2Error
        );
        assert!(slot.is_null());
        free_instance::<Toy>(c);
    }
}

#[test]
fn a_panic_becomes_fatal() {
    let env = Env::default();
    let cb = callbacks(&env);
    unsafe {
        let c = initialized(&env, &cb);
        assert_eq!(
            set_real::<Toy>(c, [2u32].as_ptr(), 1, [-666.0].as_ptr()),
            fmi2Fatal
        );
        let r = last(&env);
        assert_eq!(r.status, fmi2Fatal);
        assert!(r.message.contains("toy panic on request"), "{r:?}");
        assert_eq!(do_step::<Toy>(c, 0.0, 0.1, 0), fmi2Error);
        assert!(last(&env).message.contains("state Fatal"));
        free_instance::<Toy>(c);
    }
}

#[test]
fn model_exchange_through_the_c_abi() {
    let env = Env::default();
    let cb = callbacks(&env);
    unsafe {
        let c = new_instance(&env, &cb, fmi2ModelExchange);
        assert!(!c.is_null());
        assert_eq!(enter_initialization_mode::<Toy>(c), fmi2OK);
        assert_eq!(exit_initialization_mode::<Toy>(c), fmi2OK);
        let mut info = fmi2EventInfo::default();
        assert_eq!(new_discrete_states::<Toy>(c, &mut info), fmi2OK);
        assert_eq!(enter_continuous_time_mode::<Toy>(c), fmi2OK);
        assert_eq!(set_time::<Toy>(c, 0.01), fmi2OK);
        let x = [0.5, 1.0];
        assert_eq!(set_continuous_states::<Toy>(c, x.as_ptr(), 2), fmi2OK);
        let mut dx = [0.0; 2];
        assert_eq!(get_derivatives::<Toy>(c, dx.as_mut_ptr(), 2), fmi2OK);
        assert_eq!(dx, [1.0, -2.0]);
        assert_eq!(get_event_indicators::<Toy>(c, null_mut(), 0), fmi2OK);
        let (mut enter, mut stop) = (fmi2True, fmi2True);
        assert_eq!(
            completed_integrator_step::<Toy>(c, fmi2True, &mut enter, &mut stop),
            fmi2OK
        );
        assert_eq!((enter, stop), (fmi2False, fmi2False));
        let mut dv = [0.0];
        assert_eq!(
            get_directional_derivative::<Toy>(
                c,
                [5u32].as_ptr(),
                1,
                [0u32].as_ptr(),
                1,
                [1.0].as_ptr(),
                dv.as_mut_ptr()
            ),
            fmi2OK
        );
        assert_eq!(dv, [-4.0]);
        assert_eq!(do_step::<Toy>(c, 0.0, 0.1, 0), fmi2Error);
        free_instance::<Toy>(c);
    }
}
