//! Property-based fuzzing of the C ABI: random sequences of `fmi2*` calls with random (often
//! bad) arguments, on a real scene, checked against a model of the FMI 2.0 state machine.
//! Zero panics (no `fmi2Fatal`), the right status for each call, and the state kept on refusal.

use proptest::prelude::*;
use scm::fmi::ffi::*;
use scm::*;
use std::ffi::CString;
use std::path::PathBuf;

/// A resources folder holding `sphere_drop` as `scene.xml`, made once per test process.
fn resources() -> &'static (PathBuf, String) {
    static DIR: std::sync::OnceLock<(PathBuf, String)> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("scm-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let text = std::fs::read_to_string(crate::common::scene("sphere_drop")).unwrap();
        std::fs::write(dir.join(scm::sim::SCENE_FILE), &text).unwrap();
        (dir, scm::sim::guid(&text))
    })
}

#[derive(Clone, Debug)]
enum Op {
    Setup { start: f64, stop: Option<f64> },
    EnterInit,
    ExitInit,
    SetReal { vr: u32, value: f64 },
    GetReal { vr: u32 },
    /// `offset` is added to the instance's own time (0: a valid communication point).
    DoStep { offset: f64, h: f64 },
    Terminate,
    Reset,
    SaveState,
    RestoreState { slot: usize },
    FreeState { slot: usize },
    Serialize { slot: usize, corrupt: Option<usize> },
    Logging { on: bool },
}

fn real() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -1.0..1.0f64,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(0.0),
        1 => Just(1e300),
        1 => Just(-1e-300),
    ]
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        1 => (real(), proptest::option::of(prop_oneof![Just(10.0), real()])).prop_map(|(start, stop)| Op::Setup { start: if start.is_finite() { 0.0 } else { start }, stop }),
        3 => Just(Op::EnterInit),
        3 => Just(Op::ExitInit),
        3 => (0u32..56, real()).prop_map(|(vr, value)| Op::SetReal { vr, value }),
        1 => (0u32..56).prop_map(|vr| Op::GetReal { vr }),
        6 => (prop_oneof![4 => Just(0.0), 1 => real()], prop_oneof![4 => 1e-4..0.01f64, 1 => real()]).prop_map(|(offset, h)| Op::DoStep { offset, h }),
        1 => Just(Op::Terminate),
        1 => Just(Op::Reset),
        2 => Just(Op::SaveState),
        2 => (0usize..3).prop_map(|slot| Op::RestoreState { slot }),
        1 => (0usize..3).prop_map(|slot| Op::FreeState { slot }),
        1 => (0usize..3, proptest::option::of(0usize..400)).prop_map(|(slot, corrupt)| Op::Serialize { slot, corrupt }),
        1 => any::<bool>().prop_map(|on| Op::Logging { on }),
    ]
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    Instantiated,
    Init,
    Stepping,
    Terminated,
}

/// Runs one sequence and checks every status against the model.
fn run(ops: &[Op]) -> Result<(), TestCaseError> {
    let (dir, guid) = resources();
    let uri = CString::new(format!("file://{}", dir.display())).unwrap();
    let guid = CString::new(guid.as_str()).unwrap();
    let callbacks = fmi2CallbackFunctions { logger: None, allocateMemory: None, freeMemory: None, stepFinished: None, componentEnvironment: std::ptr::null_mut() };
    // Value references of sphere_drop: 0 time, 1-3 position, 4-7 quaternion, 8-13 velocities,
    // then contact outputs, parameters, solver settings and state derivatives; `nvars` (40) and
    // above do not exist.
    let table = scm::sim::Simulation::from_file(&crate::common::scene("sphere_drop")).unwrap();
    let nvars = table.rows().len() as u32;
    unsafe {
        let c = fmi2Instantiate(c"fuzz".as_ptr(), fmi2CoSimulation, guid.as_ptr(), uri.as_ptr(), &callbacks, 0, 0);
        prop_assert!(!c.is_null());
        let mut phase = Phase::Instantiated;
        let mut time = 0.0f64;
        let mut stop: Option<f64> = None;
        // Saved states with the phase and time they were saved in (a state carries both).
        let mut states: Vec<(fmi2FMUstate, Phase, f64)> = Vec::new();
        let get = |vr: u32| {
            let mut v = f64::NAN;
            let s = fmi2GetReal(c, &vr, 1, &mut v);
            (s, v)
        };
        for op in ops {
            let status = match op {
                Op::Setup { start, stop: st } => {
                    let s = fmi2SetupExperiment(c, 0, 0.0, *start, st.is_some() as i32, st.unwrap_or(0.0));
                    let valid = phase == Phase::Instantiated && start.is_finite() && st.is_none_or(|x| x.is_finite() && x >= *start);
                    prop_assert_eq!(s == fmi2OK, valid, "{:?} in {:?}", op, phase);
                    if valid {
                        time = *start;
                        stop = *st;
                    }
                    s
                }
                Op::EnterInit => {
                    let s = fmi2EnterInitializationMode(c);
                    prop_assert_eq!(s == fmi2OK, phase == Phase::Instantiated, "{:?} in {:?}", op, phase);
                    if s == fmi2OK {
                        phase = Phase::Init;
                    }
                    s
                }
                Op::ExitInit => {
                    let s = fmi2ExitInitializationMode(c);
                    // A zero quaternion set by the fuzzer is refused at exit.
                    if phase != Phase::Init {
                        prop_assert_eq!(s, fmi2Error);
                    }
                    if s == fmi2OK {
                        phase = Phase::Stepping;
                    }
                    s
                }
                Op::SetReal { vr, value } => {
                    let before = get(*vr);
                    let s = fmi2SetReal(c, vr, 1, value);
                    if *vr >= nvars || !value.is_finite() {
                        prop_assert_eq!(s, fmi2Error, "{:?}", op);
                        // Refused: nothing changed.
                        let after = get(*vr);
                        prop_assert!(before.1.to_bits() == after.1.to_bits() || (before.1.is_nan() && after.1.is_nan()));
                    }
                    s
                }
                Op::GetReal { vr } => {
                    let (s, v) = get(*vr);
                    if *vr >= nvars {
                        prop_assert_eq!(s, fmi2Error);
                    } else if s == fmi2OK && *vr <= 13 {
                        // Time and state are finite whatever was tried (non-finite sets and
                        // diverging steps are refused).
                        prop_assert!(v.is_finite(), "vr {} = {}", vr, v);
                    }
                    s
                }
                Op::DoStep { offset, h } => {
                    let z_before = get(3).1;
                    let t = time + offset;
                    let s = fmi2DoStep(c, t, *h, 0);
                    // The communication point may differ from the FMU's time by 1e-9 relative.
                    let tol = 1e-9 * time.abs().max(*h);
                    let valid = phase == Phase::Stepping
                        && h.is_finite()
                        && *h > 0.0
                        && t.is_finite()
                        && (t - time).abs() <= tol
                        && stop.is_none_or(|st| time + h <= st + 1e-9 * st.abs().max(*h));
                    if !valid {
                        prop_assert_eq!(s, fmi2Error, "{:?} in {:?} at t = {}", op, phase, time);
                        prop_assert_eq!(get(3).1.to_bits(), z_before.to_bits(), "state changed by a refused step");
                    } else {
                        prop_assert!(s == fmi2OK || s == fmi2Discard, "{:?}: {}", op, s);
                        if s == fmi2OK {
                            time += h;
                        } else {
                            prop_assert_eq!(get(3).1.to_bits(), z_before.to_bits(), "state changed by a discarded step");
                        }
                    }
                    s
                }
                Op::Terminate => {
                    let s = fmi2Terminate(c);
                    if s == fmi2OK {
                        phase = Phase::Terminated;
                    }
                    s
                }
                Op::Reset => {
                    let s = fmi2Reset(c);
                    prop_assert_eq!(s, fmi2OK);
                    phase = Phase::Instantiated;
                    time = 0.0;
                    stop = None;
                    s
                }
                Op::SaveState => {
                    let mut st: fmi2FMUstate = std::ptr::null_mut();
                    let s = fmi2GetFMUstate(c, &mut st);
                    if s == fmi2OK {
                        states.push((st, phase, time));
                    }
                    s
                }
                Op::RestoreState { slot } => match states.get(*slot) {
                    Some(&(st, saved_phase, saved_time)) => {
                        let s = fmi2SetFMUstate(c, st);
                        if s == fmi2OK {
                            phase = saved_phase;
                            time = saved_time;
                            if phase != Phase::Instantiated {
                                prop_assert_eq!(get(0).1, time);
                            }
                        }
                        s
                    }
                    None => {
                        let s = fmi2SetFMUstate(c, std::ptr::null_mut());
                        prop_assert_eq!(s, fmi2Error);
                        s
                    }
                },
                Op::FreeState { slot } => {
                    // Freeing twice the same handle must be refused, not crash.
                    let mut st = states.get(*slot).map(|x| x.0).unwrap_or(std::ptr::null_mut());
                    let s = fmi2FreeFMUstate(c, &mut st);
                    if *slot < states.len() {
                        let mut again = states.remove(*slot).0;
                        let s2 = fmi2FreeFMUstate(c, &mut again);
                        prop_assert!(s2 == fmi2Error || again.is_null(), "double free accepted");
                    }
                    s
                }
                Op::Serialize { slot, corrupt } => match states.get(*slot) {
                    None => fmi2OK,
                    Some(&(st, saved_phase, saved_time)) => {
                        let mut size = 0usize;
                        let s = fmi2SerializedFMUstateSize(c, st, &mut size);
                        if s != fmi2OK {
                            s
                        } else {
                            let mut bytes = vec![0u8; size];
                            let s = fmi2SerializeFMUstate(c, st, bytes.as_mut_ptr().cast(), size);
                            if s == fmi2OK {
                                if let Some(i) = corrupt {
                                    if !bytes.is_empty() {
                                        let i = i % bytes.len();
                                        bytes[i] ^= 0x5a;
                                    }
                                }
                                let mut back: fmi2FMUstate = std::ptr::null_mut();
                                let d = fmi2DeSerializeFMUstate(c, bytes.as_ptr().cast(), bytes.len(), &mut back);
                                if corrupt.is_some() {
                                    prop_assert_eq!(d, fmi2Error, "a corrupted state was accepted");
                                } else {
                                    prop_assert_eq!(d, fmi2OK);
                                    states.push((back, saved_phase, saved_time));
                                }
                            }
                            s
                        }
                    }
                },
                Op::Logging { on } => fmi2SetDebugLogging(c, *on as i32, 0, std::ptr::null()),
            };
            prop_assert_ne!(status, fmi2Fatal, "{:?} panicked inside the FMU", op);
        }
        fmi2FreeInstance(c);
        // Calls after free are refused, not crashes.
        prop_assert_eq!(fmi2DoStep(c, 0.0, 0.001, 0), fmi2Error);
        fmi2FreeInstance(c);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 10_000, max_shrink_iters: 2000, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn random_call_sequences_never_panic_and_follow_the_state_machine(ops in proptest::collection::vec(op(), 1..14)) {
        run(&ops)?;
    }
}
