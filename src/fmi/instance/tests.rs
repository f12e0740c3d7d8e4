use std::cell::RefCell;
use std::rc::Rc;

use super::*;
use crate::fmi::toy_model::{Toy, GUID};

type Log = Rc<RefCell<Vec<(fmi2Status, String, String)>>>;

struct Capture(Log);

impl LogSink for Capture {
    fn log(&self, status: fmi2Status, category: &str, message: &str) {
        self.0
            .borrow_mut()
            .push((status, category.to_owned(), message.to_owned()));
    }
}

fn new(interface: Interface, logging_on: bool) -> (Instance<Toy>, Log) {
    let log: Log = Rc::default();
    let inst = Instance::<Toy>::instantiate(
        "toy1",
        interface,
        GUID,
        "file:///tmp/res",
        logging_on,
        Some(Box::new(Capture(log.clone()))),
    )
    .unwrap();
    (inst, log)
}

fn initialized_cs() -> (Instance<Toy>, Log) {
    let (mut inst, log) = new(Interface::CoSimulation, false);
    assert_eq!(inst.setup_experiment(None, 0.0, Some(10.0)), fmi2OK);
    assert_eq!(inst.enter_initialization_mode(), fmi2OK);
    assert_eq!(inst.exit_initialization_mode(), fmi2OK);
    (inst, log)
}

fn last(log: &Log) -> (fmi2Status, String, String) {
    log.borrow().last().cloned().expect("something was logged")
}

fn real(inst: &mut Instance<Toy>, vr: u32) -> f64 {
    let mut v = [0.0];
    assert_eq!(inst.get_real(&[vr], &mut v), fmi2OK);
    v[0]
}

#[test]
fn instantiate_refuses_bad_guid_uri_and_interface() {
    let log: Log = Rc::default();
    let sink = || Some(Box::new(Capture(log.clone())) as Box<dyn LogSink>);
    let err = Instance::<Toy>::instantiate(
        "a",
        Interface::CoSimulation,
        "{wrong}",
        "file:///tmp",
        true,
        sink(),
    )
    .err()
    .unwrap();
    assert!(err.contains("{wrong}"), "{err}");
    let (status, category, message) = last(&log);
    assert_eq!((status, category.as_str()), (fmi2Error, "logStatusError"));
    assert!(message.starts_with("fmi2Instantiate: fmuGUID"), "{message}");
    assert!(Instance::<Toy>::instantiate(
        "a",
        Interface::CoSimulation,
        GUID,
        "http://x/res",
        true,
        sink()
    )
    .is_err());
    assert!(last(&log).2.contains("not a file: URI"));
    assert!(Instance::<Toy>::instantiate(
        "",
        Interface::CoSimulation,
        GUID,
        "file:///tmp",
        true,
        sink()
    )
    .is_err());
    assert!(Instance::<Toy>::instantiate(
        "a",
        Interface::CoSimulation,
        GUID,
        "file:///tmp/missing",
        true,
        sink()
    )
    .is_err());
    assert!(
        last(&log).2.contains("no scene in /tmp/missing"),
        "{:?}",
        last(&log)
    );
    assert!(Instance::<Toy>::instantiate(
        "a",
        Interface::ModelExchange,
        GUID,
        "file:///tmp",
        false,
        None
    )
    .is_ok());
}

#[test]
fn illegal_call_order_is_refused_and_logged() {
    let (mut inst, log) = new(Interface::CoSimulation, false);
    assert_eq!(inst.do_step(0.0, 0.1, false), fmi2Error);
    let (status, category, message) = last(&log);
    assert_eq!(status, fmi2Error);
    assert_eq!(category, "logStatusError");
    assert_eq!(
        message,
        "Illegal call sequence: fmi2DoStep is not allowed in state Instantiated"
    );
    assert_eq!(inst.state(), ModelState::Instantiated);
    assert_eq!(inst.exit_initialization_mode(), fmi2Error);
    assert_eq!(inst.get_real(&[0], &mut [0.0]), fmi2Error);
    assert_eq!(
        inst.set_time(1.0),
        fmi2Error,
        "ME function on a CS instance"
    );
    assert!(last(&log).2.contains("fmi2SetTime is not allowed"));
    assert_eq!(inst.enter_initialization_mode(), fmi2OK);
    assert_eq!(inst.setup_experiment(None, 0.0, None), fmi2Error);
    assert_eq!(inst.exit_initialization_mode(), fmi2OK);
    assert_eq!(inst.state(), ModelState::StepComplete);
    assert_eq!(inst.do_step(0.0, 0.1, false), fmi2OK);
    assert_eq!(inst.terminate(), fmi2OK);
    assert_eq!(inst.do_step(0.1, 0.1, false), fmi2Error);
    assert_eq!(inst.reset(), fmi2OK);
    assert_eq!(inst.state(), ModelState::Instantiated);
    assert_eq!(
        inst.set_real(&[0], &[2.0]),
        fmi2OK,
        "start values settable again after reset"
    );
}

#[test]
fn do_step_checks_the_communication_point_and_step() {
    let (mut inst, log) = initialized_cs();
    assert_eq!(inst.do_step(0.0, 0.25, false), fmi2OK);
    let x = real(&mut inst, 0);
    assert_eq!(inst.do_step(0.3, 0.25, false), fmi2Error);
    assert!(
        last(&log)
            .2
            .contains("currentCommunicationPoint = 0.3 does not match the FMU's time 0.25"),
        "{:?}",
        last(&log)
    );
    assert_eq!(real(&mut inst, 0), x, "state kept");
    assert_eq!(inst.state(), ModelState::StepComplete);
    for h in [0.0, -0.1, f64::NAN, f64::INFINITY] {
        assert_eq!(inst.do_step(0.25, h, false), fmi2Error, "{h}");
    }
    assert_eq!(inst.do_step(f64::NAN, 0.1, false), fmi2Error);
    // a host that adds steps repeatedly drifts a little: accepted within the tolerance
    assert_eq!(inst.do_step(0.25 + 1e-14, 0.25, false), fmi2OK);
    let mut t = 0.0;
    assert_eq!(inst.get_real_status(fmi2LastSuccessfulTime, &mut t), fmi2OK);
    assert_eq!(t, 0.5);
    // stopTime = 10
    assert_eq!(inst.do_step(0.5, 20.0, false), fmi2Error);
}

#[test]
fn discard_lets_the_host_retry() {
    let (mut inst, log) = initialized_cs();
    let x0 = real(&mut inst, 0);
    assert_eq!(inst.do_step(0.0, 2.0, false), fmi2Discard); // max_step = 1
    let (status, category, message) = last(&log);
    assert_eq!(
        (status, category.as_str()),
        (fmi2Discard, "logStatusWarning")
    );
    assert!(
        message.starts_with("fmi2DoStep: step from t = 0.0 by 2.0 discarded"),
        "{message}"
    );
    assert_eq!(inst.state(), ModelState::StepFailed);
    // The FMU asks a master that cannot shrink its step to end the run (fmpy would retry the
    // same step forever otherwise) ...
    let mut terminated = fmi2False;
    assert_eq!(
        inst.get_boolean_status(fmi2Terminated, &mut terminated),
        fmi2OK
    );
    assert_eq!(terminated, fmi2True);
    assert_eq!(real(&mut inst, 0), x0);
    // ... and one that can may retry with a smaller step; success clears the flag.
    assert_eq!(
        inst.do_step(0.0, 0.5, false),
        fmi2OK,
        "retry with a smaller step"
    );
    assert_eq!(inst.state(), ModelState::StepComplete);
    assert_eq!(
        inst.get_boolean_status(fmi2Terminated, &mut terminated),
        fmi2OK
    );
    assert_eq!(terminated, fmi2False);
}

#[test]
fn unknown_value_references_and_rejected_values() {
    let (mut inst, log) = initialized_cs();
    assert_eq!(inst.get_real(&[0, 42], &mut [0.0, 0.0]), fmi2Error);
    assert_eq!(
        last(&log).2,
        "fmi2GetReal: unknown value reference 42: no Real variable has it"
    );
    assert_eq!(
        inst.get_integer(&[0], &mut [0]),
        fmi2Error,
        "vr 0 is not an Integer"
    );
    assert!(last(&log).2.contains("unknown value reference 0"));
    // NaN: refused by the model, message forwarded, nothing changed (all or nothing)
    assert_eq!(inst.set_real(&[2, 3], &[5.0, f64::NAN]), fmi2Error);
    let message = last(&log).2;
    assert!(
        message.contains("k (value reference 3)") && message.contains("not finite"),
        "{message}"
    );
    assert_eq!(real(&mut inst, 2), 0.0, "u restored");
    assert_eq!(inst.set_real(&[2, 3], &[5.0, 9.0]), fmi2OK);
    assert_eq!((real(&mut inst, 2), real(&mut inst, 3)), (5.0, 9.0));
    // phase: x is settable only before initialization
    assert_eq!(inst.set_real(&[0], &[3.0]), fmi2Error);
}

#[test]
fn integer_boolean_string() {
    let (mut inst, _log) = new(Interface::CoSimulation, false);
    assert_eq!(inst.set_boolean(&[0], &[fmi2True]), fmi2OK);
    assert_eq!(inst.set_string(&[0], &["spring"]), fmi2OK);
    assert_eq!(inst.enter_initialization_mode(), fmi2OK);
    assert_eq!(inst.exit_initialization_mode(), fmi2OK);
    assert_eq!(inst.set_boolean(&[0], &[fmi2False]), fmi2Error, "fixed");
    let mut b = [0];
    assert_eq!(inst.get_boolean(&[0], &mut b), fmi2OK);
    assert_eq!(b, [fmi2True]);
    assert_eq!(inst.do_step(0.0, 0.1, false), fmi2OK);
    let mut n = [0];
    assert_eq!(inst.get_integer(&[10], &mut n), fmi2OK);
    assert_eq!(n, [1]);
    let mut p = [std::ptr::null(); 1];
    assert_eq!(inst.get_string(&[0], &mut p), fmi2OK);
    assert!(!p[0].is_null());
    assert_eq!(inst.strings[0].to_str().unwrap(), "spring");
}

#[test]
fn fmu_state_registry_refuses_double_free_and_unknown_handles() {
    let (mut inst, log) = initialized_cs();
    let mut saved = None;
    assert_eq!(inst.get_fmu_state(&mut saved), fmi2OK);
    let handle = saved.unwrap();
    assert_eq!(inst.do_step(0.0, 0.5, false), fmi2OK);
    let x_after = real(&mut inst, 0);
    assert_eq!(inst.set_fmu_state(saved), fmi2OK);
    assert_eq!(real(&mut inst, 0), 1.0);
    assert_eq!(inst.model().time(), 0.0);
    assert_eq!(inst.do_step(0.0, 0.5, false), fmi2OK);
    assert_eq!(real(&mut inst, 0), x_after, "replay is identical");

    // overwrite in place keeps the handle
    let mut slot = saved;
    assert_eq!(inst.get_fmu_state(&mut slot), fmi2OK);
    assert_eq!(slot, saved);
    assert_eq!(inst.saved_state_count(), 1);

    let mut slot = saved;
    assert_eq!(inst.free_fmu_state(&mut slot), fmi2OK);
    assert_eq!(slot, None);
    let mut again = Some(handle);
    assert_eq!(inst.free_fmu_state(&mut again), fmi2Error, "double free");
    assert!(
        last(&log).2.contains("unknown FMU state"),
        "{:?}",
        last(&log)
    );
    assert_eq!(
        inst.set_fmu_state(Some(handle)),
        fmi2Error,
        "use after free"
    );
    let foreign = Some(FmuStateHandle(NonZeroUsize::new(0xdead_beef).unwrap()));
    assert_eq!(inst.set_fmu_state(foreign), fmi2Error);
    let mut foreign_slot = foreign;
    assert_eq!(inst.get_fmu_state(&mut foreign_slot), fmi2Error);
    assert_eq!(inst.set_fmu_state(None), fmi2Error);
    let mut none = None;
    assert_eq!(inst.free_fmu_state(&mut none), fmi2OK, "NULL is ignored");

    // a handle of another instance is unknown here
    let (mut other, _) = initialized_cs();
    let mut theirs = None;
    assert_eq!(other.get_fmu_state(&mut theirs), fmi2OK);
    assert_eq!(inst.set_fmu_state(theirs), fmi2Error);
}

#[test]
fn undeclared_capabilities_are_refused() {
    let (mut inst, log) = initialized_cs();
    inst.model_mut().info.capabilities = crate::fmi::contract::Capabilities::default();
    let mut slot = None;
    assert_eq!(inst.get_fmu_state(&mut slot), fmi2Error);
    assert!(
        last(&log).2.contains("canGetAndSetFMUstate=\"false\""),
        "{:?}",
        last(&log)
    );
    assert_eq!(inst.deserialize_fmu_state(b"x", &mut slot), fmi2Error);
    assert!(last(&log).2.contains("canSerializeFMUstate"));
    let mut out = [0.0];
    assert_eq!(
        inst.get_directional_derivative(&[0], &[0], &[1.0], &mut out),
        fmi2Error
    );
    assert!(last(&log).2.contains("providesDirectionalDerivative"));
}

#[test]
fn serialize_round_trip_and_corrupt_bytes() {
    let (mut inst, _log) = initialized_cs();
    assert_eq!(inst.do_step(0.0, 0.5, false), fmi2OK);
    let mut saved = None;
    assert_eq!(inst.get_fmu_state(&mut saved), fmi2OK);
    let mut size = 0;
    assert_eq!(inst.serialized_fmu_state_size(saved, &mut size), fmi2OK);
    let mut bytes = vec![0u8; size];
    assert_eq!(
        inst.serialize_fmu_state(saved, &mut bytes[..size - 1]),
        fmi2Error,
        "buffer too small"
    );
    assert_eq!(inst.serialize_fmu_state(saved, &mut bytes), fmi2OK);
    let x = real(&mut inst, 0);

    let (mut fresh, _) = initialized_cs();
    let mut restored = None;
    assert_eq!(fresh.deserialize_fmu_state(&bytes, &mut restored), fmi2OK);
    assert_eq!(fresh.set_fmu_state(restored), fmi2OK);
    assert_eq!(real(&mut fresh, 0), x);
    assert_eq!(fresh.model().time(), 0.5);
    assert_eq!(fresh.do_step(0.5, 0.5, false), fmi2OK);

    let mut slot = None;
    assert_eq!(
        fresh.deserialize_fmu_state(&bytes[..10], &mut slot),
        fmi2Error
    );
    let mut corrupt = bytes.clone();
    corrupt[0] ^= 1;
    assert_eq!(fresh.deserialize_fmu_state(&corrupt, &mut slot), fmi2Error);
    let mut truncated = bytes.clone();
    truncated.truncate(bytes.len() - 3);
    assert_eq!(
        fresh.deserialize_fmu_state(&truncated, &mut slot),
        fmi2Error
    );
    // a Co-Simulation state cannot be restored into a Model Exchange instance
    let (mut me, _) = new(Interface::ModelExchange, false);
    assert_eq!(me.deserialize_fmu_state(&bytes, &mut slot), fmi2Error);
    assert_eq!(slot, None);
}

#[test]
fn set_debug_logging_filters_categories() {
    let (mut inst, log) = new(Interface::CoSimulation, false);
    assert_eq!(inst.enter_initialization_mode(), fmi2OK);
    assert!(
        log.borrow().is_empty(),
        "logging off: model messages are dropped: {:?}",
        log.borrow()
    );
    assert_eq!(inst.exit_initialization_mode(), fmi2OK);
    assert_eq!(inst.set_debug_logging(true, &["logContact"]), fmi2OK);
    assert!(inst.is_logging(LogCategory::Contact) && !inst.is_logging(LogCategory::Events));
    assert_eq!(inst.do_step(0.0, 0.1, false), fmi2OK);
    assert_eq!(
        last(&log),
        (fmi2OK, "logContact".into(), "toy: step to t = 0.1".into())
    );
    assert_eq!(
        inst.set_debug_logging(true, &["logEvents", "logNoSuch"]),
        fmi2Error
    );
    assert!(last(&log).2.contains("unknown log category \"logNoSuch\""));
    assert!(!inst.is_logging(LogCategory::Events), "nothing changed");
    assert_eq!(inst.set_debug_logging(false, &[]), fmi2OK);
    let before = log.borrow().len();
    assert_eq!(inst.do_step(0.1, 0.1, false), fmi2OK);
    assert_eq!(log.borrow().len(), before);
    // errors are logged whatever the categories
    assert_eq!(inst.do_step(5.0, 0.1, false), fmi2Error);
    assert_eq!(log.borrow().len(), before + 1);
    assert_eq!(inst.set_debug_logging(true, &[]), fmi2OK);
    assert!(LogCategory::ALL.iter().all(|c| inst.is_logging(*c)));
}

#[test]
fn logging_on_at_instantiation_forwards_model_messages() {
    let (mut inst, log) = new(Interface::CoSimulation, true);
    assert_eq!(inst.enter_initialization_mode(), fmi2OK);
    assert!(
        log.borrow()
            .iter()
            .any(|(s, c, m)| *s == fmi2OK && c == "logEvents" && m == "toy: initializing"),
        "{:?}",
        log.borrow()
    );
}

#[test]
fn unsupported_co_simulation_functions() {
    let (mut inst, log) = initialized_cs();
    assert_eq!(inst.cancel_step(), fmi2Error);
    assert!(last(&log).2.contains("not supported"));
    assert_eq!(
        inst.set_real_input_derivatives(&[2], &[1], &[0.0]),
        fmi2Error
    );
    assert!(last(&log).2.contains("canInterpolateInputs"));
    assert_eq!(
        inst.get_real_output_derivatives(&[0], &[1], &mut [0.0]),
        fmi2Error
    );
    let mut s = fmi2OK;
    assert_eq!(
        inst.get_status(super::super::ffi::fmi2DoStepStatus, &mut s),
        fmi2Error
    );
    assert_eq!(inst.get_integer_status(fmi2Terminated, &mut 0), fmi2Error);
    assert_eq!(inst.get_string_status(fmi2Terminated), fmi2Error);
    assert_eq!(inst.get_real_status(fmi2Terminated, &mut 0.0), fmi2Error);
}

#[test]
fn directional_derivative() {
    let (mut inst, log) = initialized_cs();
    let mut dv = [0.0; 2];
    assert_eq!(
        inst.get_directional_derivative(&[4, 5], &[0, 1, 2], &[1.0, 0.0, 2.0], &mut dv),
        fmi2OK
    );
    assert_eq!(dv, [0.0, -4.0 + 2.0]);
    assert_eq!(
        inst.get_directional_derivative(&[5], &[77], &[1.0], &mut [0.0]),
        fmi2Error
    );
    assert!(last(&log).2.contains("77"));
    assert_eq!(
        inst.get_directional_derivative(&[5, 4], &[0], &[1.0], &mut [0.0]),
        fmi2Error,
        "length mismatch"
    );
}

#[test]
fn model_exchange_sequence() {
    let (mut inst, log) = new(Interface::ModelExchange, false);
    let mut nominal = [0.0; 2];
    assert_eq!(inst.get_nominals_of_continuous_states(&mut nominal), fmi2OK);
    assert_eq!(nominal, [1.0, 1.0]);
    assert_eq!(inst.enter_initialization_mode(), fmi2OK);
    assert_eq!(inst.exit_initialization_mode(), fmi2OK);
    assert_eq!(inst.state(), ModelState::EventMode);
    let mut info = fmi2EventInfo {
        newDiscreteStatesNeeded: fmi2True,
        nextEventTimeDefined: fmi2True,
        ..Default::default()
    };
    assert_eq!(inst.new_discrete_states(&mut info), fmi2OK);
    assert_eq!(info, fmi2EventInfo::default());
    assert_eq!(
        inst.do_step(0.0, 0.1, false),
        fmi2Error,
        "CS function on an ME instance"
    );
    assert_eq!(
        inst.set_continuous_states(&[0.5, 0.0]),
        fmi2Error,
        "only in continuous-time mode"
    );
    assert_eq!(inst.enter_continuous_time_mode(), fmi2OK);
    assert_eq!(inst.set_time(0.1), fmi2OK);
    assert_eq!(inst.set_continuous_states(&[0.5, 0.25]), fmi2OK);
    assert_eq!(inst.set_continuous_states(&[0.5]), fmi2Error);
    assert_eq!(inst.set_continuous_states(&[f64::NAN, 0.0]), fmi2Error);
    let mut x = [0.0; 2];
    assert_eq!(inst.get_continuous_states(&mut x), fmi2OK);
    assert_eq!(x, [0.5, 0.25]);
    let mut dx = [0.0; 2];
    assert_eq!(inst.get_derivatives(&mut dx), fmi2OK);
    assert_eq!(dx, [0.25, -2.0]);
    assert_eq!(inst.get_derivatives(&mut [0.0; 3]), fmi2Error);
    assert_eq!(inst.get_event_indicators(&mut []), fmi2OK);
    assert_eq!(inst.get_event_indicators(&mut [0.0]), fmi2Error);
    let (mut enter, mut stop) = (true, true);
    assert_eq!(
        inst.completed_integrator_step(true, &mut enter, &mut stop),
        fmi2OK
    );
    assert!(!enter && !stop);
    assert_eq!(inst.enter_event_mode(), fmi2OK);
    assert_eq!(inst.terminate(), fmi2OK);
    assert_eq!(inst.set_time(1.0), fmi2Error);
    assert!(last(&log)
        .2
        .contains("Illegal call sequence: fmi2SetTime is not allowed in state Terminated"));
}

#[test]
fn fatal_instance_accepts_nothing() {
    let (mut inst, log) = initialized_cs();
    inst.mark_fatal("fmi2DoStep", "boom");
    assert_eq!(last(&log).0, super::super::ffi::fmi2Fatal);
    assert!(last(&log).2.contains("boom"));
    assert_eq!(inst.get_real(&[0], &mut [0.0]), fmi2Error);
    assert_eq!(inst.reset(), fmi2Error);
}
