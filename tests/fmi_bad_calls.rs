//! Bad calls through the C ABI of the real FMU (`mocap_push`: a free box, a mocap paddle, one
//! contact pair): every `fmi2*` function in every reachable state of the FMI 2.0 state
//! machine, with NULL pointers, unknown value references and arrays of the wrong length; double
//! frees; calls after `fmi2Terminate` and after `fmi2FreeInstance`.
//!
//! The legal states of each function are written here from the tables of the FMI 2.0.4
//! standard (Co-Simulation section 4.2.4, Model Exchange section 3.2.3), independently of
//! `scm::fmi::state_machine`, with the FMU's documented, more permissive deviations
//! (`fmi2DoStep` after a discarded step, `fmi2GetDerivatives` in initialization mode). A legal
//! call with valid arguments returns `fmi2OK`; an illegal one returns `fmi2Error`, says so
//! through the logger (naming the function and the state), and changes nothing.

use crate::common::host::{self, Capture, Resources};
use scm::fmi::ffi::*;
use scm::*;
use std::ptr::{null, null_mut};
use std::sync::OnceLock;

/// The reachable states.
#[derive(Clone, Copy, Debug, PartialEq)]
enum St {
    Instantiated,
    Init,
    StepComplete,
    StepFailed,
    Event,
    Continuous,
    Terminated,
}

use St::*;

const CS_STATES: [St; 5] = [Instantiated, Init, StepComplete, StepFailed, Terminated];
const ME_STATES: [St; 5] = [Instantiated, Init, Event, Continuous, Terminated];

/// Every function that depends on the state, with the states the standard allows it in, per
/// interface (`None`: not part of that interface).
#[derive(Clone, Copy, Debug, PartialEq)]
enum F {
    SetDebugLogging,
    SetupExperiment,
    EnterInit,
    ExitInit,
    Terminate,
    Reset,
    GetReal,
    GetInteger,
    GetBoolean,
    GetString,
    SetReal,
    SetInteger,
    SetBoolean,
    SetString,
    GetFMUstate,
    SetFMUstate,
    FreeFMUstate,
    SerializedSize,
    Serialize,
    DeSerialize,
    DirectionalDerivative,
    DoStep,
    GetRealStatus,
    GetBooleanStatus,
    EnterEventMode,
    NewDiscreteStates,
    EnterContinuousTimeMode,
    CompletedIntegratorStep,
    SetTime,
    SetContinuousStates,
    GetDerivatives,
    GetEventIndicators,
    GetContinuousStates,
    GetNominals,
}

const ALL: [F; 34] = [
    F::SetDebugLogging,
    F::SetupExperiment,
    F::EnterInit,
    F::ExitInit,
    F::Terminate,
    F::Reset,
    F::GetReal,
    F::GetInteger,
    F::GetBoolean,
    F::GetString,
    F::SetReal,
    F::SetInteger,
    F::SetBoolean,
    F::SetString,
    F::GetFMUstate,
    F::SetFMUstate,
    F::FreeFMUstate,
    F::SerializedSize,
    F::Serialize,
    F::DeSerialize,
    F::DirectionalDerivative,
    F::DoStep,
    F::GetRealStatus,
    F::GetBooleanStatus,
    F::EnterEventMode,
    F::NewDiscreteStates,
    F::EnterContinuousTimeMode,
    F::CompletedIntegratorStep,
    F::SetTime,
    F::SetContinuousStates,
    F::GetDerivatives,
    F::GetEventIndicators,
    F::GetContinuousStates,
    F::GetNominals,
];

/// The standard's table (with the FMU's two documented extensions).
fn legal(f: F, me: bool, s: St) -> bool {
    let any_but_start = true; // every reachable state is past instantiation
    match f {
        F::SetDebugLogging | F::Reset => any_but_start,
        F::GetFMUstate
        | F::SetFMUstate
        | F::FreeFMUstate
        | F::SerializedSize
        | F::Serialize
        | F::DeSerialize => any_but_start,
        F::SetupExperiment | F::EnterInit => s == Instantiated,
        F::ExitInit => s == Init,
        F::Terminate => {
            if me {
                matches!(s, Event | Continuous)
            } else {
                matches!(s, StepComplete | StepFailed)
            }
        }
        F::GetReal | F::GetInteger | F::GetBoolean | F::GetString | F::DirectionalDerivative => {
            !matches!(s, Instantiated)
        }
        // A continuous input: also in continuous-time mode (ME).
        F::SetReal => matches!(s, Instantiated | Init | StepComplete | Event | Continuous),
        F::SetInteger | F::SetBoolean | F::SetString => {
            matches!(s, Instantiated | Init | StepComplete | Event)
        }
        // Extension: a retry after a discarded step.
        F::DoStep => !me && matches!(s, StepComplete | StepFailed),
        F::GetRealStatus | F::GetBooleanStatus => {
            !me && matches!(s, StepComplete | StepFailed | Terminated)
        }
        F::EnterEventMode | F::SetTime => me && matches!(s, Event | Continuous),
        F::NewDiscreteStates | F::EnterContinuousTimeMode => me && s == Event,
        F::CompletedIntegratorStep | F::SetContinuousStates => me && s == Continuous,
        // Extension: derivatives also in initialization mode.
        F::GetDerivatives | F::GetEventIndicators | F::GetContinuousStates => {
            me && matches!(s, Init | Event | Continuous | Terminated)
        }
        F::GetNominals => me && matches!(s, Instantiated | Event | Continuous | Terminated),
    }
}

struct Fixture {
    res: Resources,
    /// Number of variables, continuous states.
    nvars: u32,
    nx: usize,
    /// The start states.
    x0: Vec<f64>,
    /// `paddle.pos.x` (an input) and `contact.box.paddle.force.x` or whichever contact force
    /// output comes first.
    input: u32,
    output: u32,
    /// A serialized Co-Simulation state, and a Model Exchange one (after initialization).
    bytes_cs: Vec<u8>,
    bytes_me: Vec<u8>,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let sim = scm::sim::Simulation::from_file(&crate::common::scene("mocap_push")).unwrap();
        let find = |pred: &dyn Fn(&str) -> bool| {
            sim.rows().iter().position(|(v, _)| pred(&v.name)).unwrap() as u32
        };
        let input = find(&|n| n == "paddle.pos.x");
        let output = find(&|n| n.starts_with("contact.") && n.ends_with(".force.x"));
        let res = host::resources("mocap_push");
        let serialized = |me: bool| unsafe {
            let cb = host::quiet();
            let c = host::instantiate(
                &res,
                if me {
                    fmi2ModelExchange
                } else {
                    fmi2CoSimulation
                },
                &cb,
            );
            assert_eq!(fmi2EnterInitializationMode(c), fmi2OK);
            assert_eq!(fmi2ExitInitializationMode(c), fmi2OK);
            let bytes = host::serialize_current(c);
            fmi2FreeInstance(c);
            bytes
        };
        let (bytes_cs, bytes_me) = (serialized(false), serialized(true));
        Fixture {
            nvars: sim.rows().len() as u32,
            nx: sim.continuous_states().len(),
            x0: sim.continuous_states(),
            input,
            output,
            res,
            bytes_cs,
            bytes_me,
        }
    })
}

/// A new instance driven to state `s`.
unsafe fn reach(
    f: &Fixture,
    me: bool,
    s: St,
    cb: &fmi2CallbackFunctions,
    capture: &Capture,
) -> fmi2Component {
    unsafe {
        let c = host::instantiate(
            &f.res,
            if me {
                fmi2ModelExchange
            } else {
                fmi2CoSimulation
            },
            cb,
        );
        assert!(!c.is_null());
        if s == Instantiated {
            return c;
        }
        assert_eq!(fmi2EnterInitializationMode(c), fmi2OK);
        if s == Init {
            return c;
        }
        assert_eq!(fmi2ExitInitializationMode(c), fmi2OK);
        match s {
            StepComplete => assert_eq!(fmi2DoStep(c, 0.0, 0.002, fmi2True), fmi2OK),
            StepFailed => {
                // A step that would need ~1e303 internal steps is refused before any work.
                assert_eq!(fmi2DoStep(c, 0.0, 1e300, fmi2True), fmi2Discard);
                assert!(
                    capture.last().message.contains("internal steps"),
                    "{:?}",
                    capture.last()
                );
            }
            Continuous => assert_eq!(fmi2EnterContinuousTimeMode(c), fmi2OK),
            Terminated => assert_eq!(fmi2Terminate(c), fmi2OK),
            _ => {}
        }
        c
    }
}

/// Calls `f` on `c` with valid arguments.
unsafe fn call(fx: &Fixture, c: fmi2Component, me: bool, f: F) -> fmi2Status {
    unsafe {
        let mut time = 0.0;
        // Time is value reference 0; unreadable before initialization (then it is 0).
        if fmi2GetReal(c, &0, 1, &mut time) != fmi2OK {
            time = 0.0;
        }
        let nx = fx.nx;
        match f {
            F::SetDebugLogging => fmi2SetDebugLogging(c, fmi2True, 0, null()),
            F::SetupExperiment => fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0),
            F::EnterInit => fmi2EnterInitializationMode(c),
            F::ExitInit => fmi2ExitInitializationMode(c),
            F::Terminate => fmi2Terminate(c),
            F::Reset => fmi2Reset(c),
            F::GetReal => fmi2GetReal(c, &fx.output, 1, &mut 0.0),
            // No Integer or Boolean variables, and the String one is fixed: nvr = 0 is a valid call.
            F::GetInteger => fmi2GetInteger(c, null(), 0, null_mut()),
            F::GetBoolean => fmi2GetBoolean(c, null(), 0, null_mut()),
            F::GetString => fmi2GetString(c, null(), 0, null_mut()),
            F::SetReal => fmi2SetReal(c, &fx.input, 1, &0.01),
            F::SetInteger => fmi2SetInteger(c, null(), 0, null()),
            F::SetBoolean => fmi2SetBoolean(c, null(), 0, null()),
            F::SetString => fmi2SetString(c, null(), 0, null()),
            F::GetFMUstate => {
                let mut st = null_mut();
                fmi2GetFMUstate(c, &mut st)
            }
            F::SetFMUstate | F::FreeFMUstate | F::SerializedSize | F::Serialize => {
                // The state comes from a call that is legal wherever these are.
                let mut st = null_mut();
                let bytes = if me { &fx.bytes_me } else { &fx.bytes_cs };
                let s = fmi2DeSerializeFMUstate(c, bytes.as_ptr().cast(), bytes.len(), &mut st);
                if s != fmi2OK {
                    return s;
                }
                match f {
                    F::SetFMUstate => fmi2SetFMUstate(c, st),
                    F::FreeFMUstate => fmi2FreeFMUstate(c, &mut st),
                    F::SerializedSize => fmi2SerializedFMUstateSize(c, st, &mut 0),
                    _ => {
                        let mut out = vec![0u8; bytes.len()];
                        fmi2SerializeFMUstate(c, st, out.as_mut_ptr().cast(), out.len())
                    }
                }
            }
            F::DeSerialize => {
                let mut st = null_mut();
                let bytes = if me { &fx.bytes_me } else { &fx.bytes_cs };
                fmi2DeSerializeFMUstate(c, bytes.as_ptr().cast(), bytes.len(), &mut st)
            }
            F::DirectionalDerivative => {
                fmi2GetDirectionalDerivative(c, &fx.output, 1, &fx.input, 1, &1.0, &mut 0.0)
            }
            F::DoStep => fmi2DoStep(c, time, 0.002, fmi2True),
            F::GetRealStatus => fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &mut 0.0),
            F::GetBooleanStatus => fmi2GetBooleanStatus(c, fmi2Terminated, &mut 0),
            F::EnterEventMode => fmi2EnterEventMode(c),
            F::NewDiscreteStates => fmi2NewDiscreteStates(c, &mut fmi2EventInfo::default()),
            F::EnterContinuousTimeMode => fmi2EnterContinuousTimeMode(c),
            F::CompletedIntegratorStep => fmi2CompletedIntegratorStep(c, fmi2True, &mut 0, &mut 0),
            F::SetTime => fmi2SetTime(c, time),
            F::SetContinuousStates => {
                // The start states (readable or not in this state).
                let mut x = fx.x0.clone();
                let _ = fmi2GetContinuousStates(c, x.as_mut_ptr(), nx);
                fmi2SetContinuousStates(c, x.as_ptr(), nx)
            }
            F::GetDerivatives => fmi2GetDerivatives(c, vec![0.0; nx].as_mut_ptr(), nx),
            F::GetEventIndicators => fmi2GetEventIndicators(c, null_mut(), 0),
            F::GetContinuousStates => fmi2GetContinuousStates(c, vec![0.0; nx].as_mut_ptr(), nx),
            F::GetNominals => fmi2GetNominalsOfContinuousStates(c, vec![0.0; nx].as_mut_ptr(), nx),
        }
    }
}

/// Every Real variable as bits where readable.
unsafe fn snapshot(c: fmi2Component, n: u32) -> Vec<Option<u64>> {
    (0..n)
        .map(|vr| {
            let mut v = 0.0;
            (unsafe { fmi2GetReal(c, &vr, 1, &mut v) } == fmi2OK).then_some(v.to_bits())
        })
        .collect()
}

#[test]
fn every_function_in_every_state_follows_the_standard() {
    let fx = fixture();
    let mut checked = 0;
    for me in [false, true] {
        for s in if me { ME_STATES } else { CS_STATES } {
            for f in ALL {
                let capture = Capture::default();
                let cb = host::callbacks(&capture);
                unsafe {
                    let c = reach(fx, me, s, &cb, &capture);
                    let before = snapshot(c, fx.nvars);
                    let logged = capture.len();
                    let status = call(fx, c, me, f);
                    if legal(f, me, s) {
                        assert_eq!(
                            status,
                            fmi2OK,
                            "{f:?} in {s:?} (me = {me}): {:?}",
                            capture.since(logged)
                        );
                    } else {
                        assert_eq!(status, fmi2Error, "{f:?} in {s:?} (me = {me}) was accepted");
                        let said = capture.since(logged);
                        let named = said.iter().any(|l| {
                            l.status == fmi2Error
                                && l.message.contains("fmi2")
                                && (l.message.contains(&format!("state {}", state_name(s)))
                                    || l.message.contains("is not part of"))
                        });
                        assert!(named, "{f:?} in {s:?} (me = {me}): {said:?}");
                        assert_eq!(
                            snapshot(c, fx.nvars),
                            before,
                            "{f:?} in {s:?} (me = {me}) was refused but changed the instance"
                        );
                    }
                    fmi2FreeInstance(c);
                }
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 2 * 5 * ALL.len());
}

fn state_name(s: St) -> &'static str {
    match s {
        Instantiated => "Instantiated",
        Init => "InitializationMode",
        StepComplete => "StepComplete",
        StepFailed => "StepFailed",
        Event => "EventMode",
        Continuous => "ContinuousTimeMode",
        Terminated => "Terminated",
    }
}

/// Co-Simulation functions are refused in Model Exchange and the other way round, whatever
/// the state; unsupported functions are refused with a reason.
#[test]
fn other_interface_and_unsupported_functions_are_refused() {
    let fx = fixture();
    let capture = Capture::default();
    let cb = host::callbacks(&capture);
    unsafe {
        for me in [false, true] {
            let c = reach(fx, me, if me { Event } else { StepComplete }, &cb, &capture);
            let s = [
                fmi2CancelStep(c),
                fmi2SetRealInputDerivatives(c, &fx.input, 1, &1, &0.0),
                fmi2GetRealOutputDerivatives(c, &fx.output, 1, &1, &mut 0.0),
                fmi2GetStatus(c, fmi2DoStepStatus, &mut 0),
                fmi2GetIntegerStatus(c, fmi2PendingStatus, &mut 0),
                fmi2GetStringStatus(c, fmi2PendingStatus, &mut null()),
            ];
            assert!(s.iter().all(|&s| s == fmi2Error), "me = {me}: {s:?}");
            if me {
                assert_eq!(fmi2DoStep(c, 0.0, 0.002, fmi2True), fmi2Error);
                assert!(
                    capture
                        .last()
                        .message
                        .contains("not part of Model Exchange"),
                    "{:?}",
                    capture.last()
                );
            } else {
                assert_eq!(fmi2SetTime(c, 0.0), fmi2Error);
                assert!(
                    capture.last().message.contains("not part of Co-Simulation"),
                    "{:?}",
                    capture.last()
                );
            }
            fmi2FreeInstance(c);
        }
    }
}

/// Every pointer argument of every function, NULL (with a count that says it is used): refused
/// with a message naming the argument; the instance works afterwards. A NULL instance is refused
/// by every function.
#[test]
fn null_pointers_are_refused_by_every_function() {
    let fx = fixture();
    let capture = Capture::default();
    let cb = host::callbacks(&capture);
    unsafe {
        // A NULL component.
        let z: fmi2Component = null_mut();
        let mut st: fmi2FMUstate = null_mut();
        let statuses = [
            fmi2SetDebugLogging(z, 1, 0, null()),
            fmi2SetupExperiment(z, 0, 0.0, 0.0, 0, 0.0),
            fmi2EnterInitializationMode(z),
            fmi2ExitInitializationMode(z),
            fmi2Terminate(z),
            fmi2Reset(z),
            fmi2GetReal(z, &0, 1, &mut 0.0),
            fmi2SetReal(z, &0, 1, &0.0),
            fmi2GetInteger(z, null(), 0, null_mut()),
            fmi2SetString(z, null(), 0, null()),
            fmi2GetFMUstate(z, &mut st),
            fmi2SetFMUstate(z, st),
            fmi2FreeFMUstate(z, &mut st),
            fmi2SerializedFMUstateSize(z, st, &mut 0),
            fmi2DeSerializeFMUstate(z, fx.bytes_cs.as_ptr().cast(), fx.bytes_cs.len(), &mut st),
            fmi2GetDirectionalDerivative(z, &0, 1, &0, 1, &1.0, &mut 0.0),
            fmi2DoStep(z, 0.0, 0.002, 1),
            fmi2GetRealStatus(z, fmi2LastSuccessfulTime, &mut 0.0),
            fmi2EnterEventMode(z),
            fmi2SetTime(z, 0.0),
            fmi2GetDerivatives(z, [0.0; 13].as_mut_ptr(), 13),
            fmi2CompletedIntegratorStep(z, 1, &mut 0, &mut 0),
        ];
        assert!(statuses.iter().all(|&s| s == fmi2Error), "{statuses:?}");
        fmi2FreeInstance(z);
        assert!(scm::fmi2Instantiate(
            null(),
            fmi2CoSimulation,
            fx.res.guid.as_ptr(),
            fx.res.uri.as_ptr(),
            &cb,
            0,
            0
        )
        .is_null());
        assert!(scm::fmi2Instantiate(
            c"x".as_ptr(),
            fmi2CoSimulation,
            null(),
            fx.res.uri.as_ptr(),
            &cb,
            0,
            0
        )
        .is_null());
        assert!(scm::fmi2Instantiate(
            c"x".as_ptr(),
            fmi2CoSimulation,
            fx.res.guid.as_ptr(),
            null(),
            &cb,
            0,
            0
        )
        .is_null());
        assert!(scm::fmi2Instantiate(
            c"x".as_ptr(),
            fmi2CoSimulation,
            fx.res.guid.as_ptr(),
            fx.res.uri.as_ptr(),
            null(),
            0,
            0
        )
        .is_null());

        for me in [false, true] {
            let c = reach(
                fx,
                me,
                if me { Continuous } else { StepComplete },
                &cb,
                &capture,
            );
            let before = snapshot(c, fx.nvars);
            let nx = fx.nx;
            let mut x = vec![0.0; nx];
            let mut st = null_mut();
            assert_eq!(fmi2GetFMUstate(c, &mut st), fmi2OK);
            let mut cases: Vec<(&str, fmi2Status)> = vec![
                ("categories", fmi2SetDebugLogging(c, 1, 1, null())),
                ("vr", fmi2GetReal(c, null(), 1, &mut 0.0)),
                ("value", fmi2GetReal(c, &fx.output, 1, null_mut())),
                ("vr", fmi2SetReal(c, null(), 1, &0.0)),
                ("value", fmi2SetReal(c, &fx.input, 1, null())),
                ("vr", fmi2GetInteger(c, null(), 1, &mut 0)),
                ("value", fmi2GetBoolean(c, &0, 1, null_mut())),
                ("value", fmi2GetString(c, &0, 1, null_mut())),
                ("value", fmi2SetString(c, &0, 1, null())),
                ("value[0]", fmi2SetString(c, &0, 1, [null()].as_ptr())),
                ("FMUstate", fmi2GetFMUstate(c, null_mut())),
                ("FMUstate", fmi2SetFMUstate(c, null_mut())),
                ("size", fmi2SerializedFMUstateSize(c, st, null_mut())),
                (
                    "serializedState",
                    fmi2SerializeFMUstate(c, st, null_mut(), fx.bytes_cs.len()),
                ),
                (
                    "serializedState",
                    fmi2DeSerializeFMUstate(c, null(), fx.bytes_cs.len(), &mut null_mut()),
                ),
                (
                    "FMUstate",
                    fmi2DeSerializeFMUstate(
                        c,
                        fx.bytes_cs.as_ptr().cast(),
                        fx.bytes_cs.len(),
                        null_mut(),
                    ),
                ),
                (
                    "vUnknown_ref",
                    fmi2GetDirectionalDerivative(c, null(), 1, &fx.input, 1, &1.0, &mut 0.0),
                ),
                (
                    "vKnown_ref",
                    fmi2GetDirectionalDerivative(c, &fx.output, 1, null(), 1, &1.0, &mut 0.0),
                ),
                (
                    "dvKnown",
                    fmi2GetDirectionalDerivative(c, &fx.output, 1, &fx.input, 1, null(), &mut 0.0),
                ),
                (
                    "dvUnknown",
                    fmi2GetDirectionalDerivative(c, &fx.output, 1, &fx.input, 1, &1.0, null_mut()),
                ),
            ];
            if me {
                cases.extend([
                    ("x", fmi2SetContinuousStates(c, null(), nx)),
                    ("x", fmi2GetContinuousStates(c, null_mut(), nx)),
                    ("derivatives", fmi2GetDerivatives(c, null_mut(), nx)),
                    (
                        "x_nominal",
                        fmi2GetNominalsOfContinuousStates(c, null_mut(), nx),
                    ),
                    (
                        "enterEventMode",
                        fmi2CompletedIntegratorStep(c, 1, null_mut(), &mut 0),
                    ),
                    (
                        "terminateSimulation",
                        fmi2CompletedIntegratorStep(c, 1, &mut 0, null_mut()),
                    ),
                ]);
            } else {
                cases.extend([
                    (
                        "value",
                        fmi2GetRealStatus(c, fmi2LastSuccessfulTime, null_mut()),
                    ),
                    ("value", fmi2GetBooleanStatus(c, fmi2Terminated, null_mut())),
                ]);
            }
            for (i, (arg, s)) in cases.iter().enumerate() {
                assert_eq!(
                    *s, fmi2Error,
                    "case {i} ({arg}, me = {me}) accepted a NULL pointer"
                );
            }
            // Every refusal is explained, and names the argument.
            let errors: Vec<_> = capture
                .all()
                .into_iter()
                .filter(|l| l.status == fmi2Error)
                .collect();
            for (arg, _) in &cases {
                assert!(
                    errors
                        .iter()
                        .any(|l| l.message.contains(&format!("argument {arg}"))
                            || l.message.contains(&format!("{arg} is NULL"))),
                    "no message names {arg}: {errors:?}"
                );
            }
            assert_eq!(
                snapshot(c, fx.nvars),
                before,
                "a refused call changed the instance"
            );
            // Still usable.
            if me {
                assert_eq!(fmi2GetContinuousStates(c, x.as_mut_ptr(), nx), fmi2OK);
                assert_eq!(fmi2SetContinuousStates(c, x.as_ptr(), nx), fmi2OK);
            } else {
                assert_eq!(
                    fmi2DoStep(c, 0.002, 0.002, 1),
                    fmi2OK,
                    "{:?}",
                    capture.last()
                );
            }
            fmi2FreeInstance(c);
        }
    }
}

/// Unknown value references in every accessor, arrays whose length is not the model's, and
/// serialized buffers of the wrong size.
#[test]
fn unknown_references_and_wrong_lengths_are_refused() {
    let fx = fixture();
    let capture = Capture::default();
    let cb = host::callbacks(&capture);
    unsafe {
        for me in [false, true] {
            let c = reach(
                fx,
                me,
                if me { Continuous } else { StepComplete },
                &cb,
                &capture,
            );
            let before = snapshot(c, fx.nvars);
            let bad = [fx.nvars, fx.nvars + 1, u32::MAX];
            for vr in bad {
                let vrs = [fx.input, vr];
                let s = [
                    fmi2GetReal(c, vrs.as_ptr(), 2, [0.0; 2].as_mut_ptr()),
                    fmi2SetReal(c, vrs.as_ptr(), 2, [0.01, 0.01].as_ptr()),
                    fmi2GetInteger(c, &vr, 1, &mut 0),
                    fmi2SetBoolean(c, &vr, 1, &1),
                    fmi2GetString(c, &vr, 1, &mut null()),
                    fmi2GetDirectionalDerivative(c, &vr, 1, &fx.input, 1, &1.0, &mut 0.0),
                    fmi2GetDirectionalDerivative(c, &fx.output, 1, &vr, 1, &1.0, &mut 0.0),
                ];
                assert!(
                    s.iter().all(|&s| s == fmi2Error),
                    "vr {vr} (me = {me}): {s:?}"
                );
                assert!(
                    capture.last().message.contains(&format!("{vr}")),
                    "{:?}",
                    capture.last()
                );
            }
            // An input is not an unknown, an output not a known.
            assert_eq!(
                fmi2GetDirectionalDerivative(c, &fx.input, 1, &fx.input, 1, &1.0, &mut 0.0),
                fmi2Error
            );
            assert_eq!(
                fmi2GetDirectionalDerivative(c, &fx.output, 1, &fx.output, 1, &1.0, &mut 0.0),
                fmi2Error
            );
            // A Real read as a String and the other way round.
            assert_eq!(fmi2GetString(c, &fx.input, 1, &mut null()), fmi2Error);
            assert_eq!(snapshot(c, fx.nvars), before);
            if me {
                let nx = fx.nx;
                for n in [0, nx - 1, nx + 1, 1000] {
                    let mut x = vec![0.5; n.max(1)];
                    let s = [
                        fmi2SetContinuousStates(c, x.as_ptr(), n),
                        fmi2GetContinuousStates(c, x.as_mut_ptr(), n),
                        fmi2GetDerivatives(c, x.as_mut_ptr(), n),
                        fmi2GetNominalsOfContinuousStates(c, x.as_mut_ptr(), n),
                    ];
                    assert!(s.iter().all(|&s| s == fmi2Error), "nx = {n}: {s:?}");
                    assert!(
                        capture.last().message.contains(&format!("{n}")),
                        "{:?}",
                        capture.last()
                    );
                }
                // No event indicators.
                assert_eq!(fmi2GetEventIndicators(c, [0.0].as_mut_ptr(), 1), fmi2Error);
            }
            // Serialized buffers: too small, too large, truncated or extended bytes.
            let mut st = null_mut();
            assert_eq!(fmi2GetFMUstate(c, &mut st), fmi2OK);
            let mut size = 0;
            assert_eq!(fmi2SerializedFMUstateSize(c, st, &mut size), fmi2OK);
            let mut buf = vec![0u8; size + 1];
            assert_eq!(
                fmi2SerializeFMUstate(c, st, buf.as_mut_ptr().cast(), size - 1),
                fmi2Error
            );
            // A larger buffer is fine (the state fills its first `size` bytes).
            assert_eq!(
                fmi2SerializeFMUstate(c, st, buf.as_mut_ptr().cast(), size),
                fmi2OK
            );
            let mut back = null_mut();
            assert_eq!(
                fmi2DeSerializeFMUstate(c, buf.as_ptr().cast(), size - 1, &mut back),
                fmi2Error
            );
            assert_eq!(
                fmi2DeSerializeFMUstate(c, buf.as_ptr().cast(), size + 1, &mut back),
                fmi2Error
            );
            assert_eq!(
                fmi2DeSerializeFMUstate(c, buf.as_ptr().cast(), 0, &mut back),
                fmi2Error
            );
            assert!(back.is_null());
            // A state of the other interface is not restorable here.
            let other = if me { &fx.bytes_cs } else { &fx.bytes_me };
            let s = fmi2DeSerializeFMUstate(c, other.as_ptr().cast(), other.len(), &mut back);
            if s == fmi2OK {
                // Both are "after initialization" states: restorable only if the state-machine
                // state exists in this interface (it does not: StepComplete vs EventMode).
                panic!(
                    "a {} state was accepted by a {} instance",
                    if me { "CS" } else { "ME" },
                    if me { "ME" } else { "CS" }
                );
            }
            assert_eq!(snapshot(c, fx.nvars), before);
            fmi2FreeInstance(c);
        }
    }
}

/// Double frees of states and instances, and every call after `fmi2Terminate` and after
/// `fmi2FreeInstance`.
#[test]
fn double_free_and_calls_after_terminate_and_free() {
    let fx = fixture();
    let capture = Capture::default();
    let cb = host::callbacks(&capture);
    unsafe {
        let c = reach(fx, false, StepComplete, &cb, &capture);
        let mut st = null_mut();
        assert_eq!(fmi2GetFMUstate(c, &mut st), fmi2OK);
        let copy = st;
        assert_eq!(fmi2FreeFMUstate(c, &mut st), fmi2OK);
        assert!(st.is_null());
        let mut again = copy;
        assert_eq!(fmi2FreeFMUstate(c, &mut again), fmi2Error);
        assert!(
            capture.last().message.contains("unknown FMU state"),
            "{:?}",
            capture.last()
        );
        assert_eq!(
            fmi2SetFMUstate(c, copy),
            fmi2Error,
            "a freed state was restored"
        );
        assert_eq!(fmi2SerializedFMUstateSize(c, copy, &mut 0), fmi2Error);
        // A state handle of another instance is unknown here.
        let d = reach(fx, false, StepComplete, &cb, &capture);
        let mut foreign = null_mut();
        assert_eq!(fmi2GetFMUstate(d, &mut foreign), fmi2OK);
        assert_eq!(fmi2SetFMUstate(c, foreign), fmi2Error);
        fmi2FreeInstance(d);

        assert_eq!(fmi2Terminate(c), fmi2OK);
        let before = snapshot(c, fx.nvars);
        assert!(
            before.iter().any(|v| v.is_some()),
            "variables stay readable after fmi2Terminate"
        );
        let after_terminate = [
            fmi2DoStep(c, 0.002, 0.002, 1),
            fmi2SetReal(c, &fx.input, 1, &0.5),
            fmi2Terminate(c),
            fmi2EnterInitializationMode(c),
            fmi2ExitInitializationMode(c),
            fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0),
        ];
        assert!(
            after_terminate.iter().all(|&s| s == fmi2Error),
            "{after_terminate:?}"
        );
        assert_eq!(snapshot(c, fx.nvars), before);
        // fmi2Reset after fmi2Terminate starts over.
        assert_eq!(fmi2Reset(c), fmi2OK);
        assert_eq!(fmi2EnterInitializationMode(c), fmi2OK);
        assert_eq!(fmi2ExitInitializationMode(c), fmi2OK);
        assert_eq!(fmi2DoStep(c, 0.0, 0.002, 1), fmi2OK);
        fmi2FreeInstance(c);
        // After free: refused, never a crash; a second free is ignored.
        assert_eq!(fmi2DoStep(c, 0.002, 0.002, 1), fmi2Error);
        assert_eq!(fmi2GetReal(c, &0, 1, &mut 0.0), fmi2Error);
        assert_eq!(fmi2GetFMUstate(c, &mut null_mut()), fmi2Error);
        assert_eq!(fmi2Reset(c), fmi2Error);
        fmi2FreeInstance(c);
        fmi2FreeInstance(c);
    }
}
