//! Property-based fuzzing of the C ABI: random sequences of `fmi2*` calls with random (often
//! bad) arguments, in both interfaces, on real scenes (`sphere_drop`: a free body; `mocap_push`:
//! a free body pushed by a mocap input), checked against an independent model of the FMI 2.0
//! state machine and of the variable table (which variable may be set when, to what).
//!
//! For every call: no panic (`fmi2Fatal`), the status the model predicts, every `fmi2Error`
//! explained by a message to the logger, and a refused call or a discarded step leaves time
//! and state unchanged, bit for bit. Saved states are restored with their phase and time,
//! serialized states round-trip and any damage to them (a flipped byte, truncation, extra
//! bytes) is refused. A second property forges serialized states whose checksums are right but
//! whose model bytes are random edits: each is refused, or accepted and then safe to use.

use crate::common::host::{self, Capture, Resources};
use proptest::prelude::*;
use scm::fmi::ffi::*;
use scm::sim::{Param, Slot};
use scm::*;
use std::sync::OnceLock;

/// What the model of the state machine needs to know about a scene.
struct Fixture {
    res: Resources,
    /// Every variable's slot and whether it is a Real, by value reference.
    slots: Vec<(Slot, bool)>,
    /// Continuous states at the start (`[q; v]`).
    x0: Vec<f64>,
    /// Start index of every quaternion in `x`.
    quats: Vec<usize>,
    /// Mocap quaternion inputs at the start, per mocap body.
    mocap_quat0: Vec<[f64; 4]>,
}

const SCENES: [&str; 2] = ["sphere_drop", "mocap_push"];

fn fixture(k: usize) -> &'static Fixture {
    static FIXTURES: OnceLock<Vec<Fixture>> = OnceLock::new();
    &FIXTURES.get_or_init(|| {
        SCENES
            .iter()
            .map(|name| {
                let sim = scm::sim::Simulation::from_file(&crate::common::scene(name)).unwrap();
                let slots = sim
                    .rows()
                    .iter()
                    .map(|(v, s)| {
                        (
                            *s,
                            matches!(v.var_type, scm::fmi::contract::VarType::Real { .. }),
                        )
                    })
                    .collect();
                let quats = sim
                    .model
                    .tree
                    .joints
                    .iter()
                    .filter_map(|j| match j.kind {
                        scm::dynamics::JointKind::Free => Some(j.qadr + 3),
                        scm::dynamics::JointKind::Ball => Some(j.qadr),
                        _ => None,
                    })
                    .collect();
                let mocap_quat0 = sim
                    .data
                    .current
                    .mocap_target
                    .chunks(7)
                    .map(|m| [m[3], m[4], m[5], m[6]])
                    .collect();
                Fixture {
                    res: host::resources(name),
                    slots,
                    x0: sim.continuous_states(),
                    quats,
                    mocap_quat0,
                }
            })
            .collect()
    })[k]
}

/// How a serialized state is damaged before it is read back.
#[derive(Clone, Debug)]
enum Damage {
    None,
    /// XOR of one byte (index modulo the length) with a non-zero mask.
    Flip(usize, u8),
    /// Keep this many bytes (modulo the length).
    Truncate(usize),
    /// Append bytes.
    Append(usize),
}

/// How the states given to `fmi2SetContinuousStates` are spoiled.
#[derive(Clone, Debug)]
enum Bad {
    None,
    NonFinite(usize, f64),
    ZeroQuaternion,
    /// `nx` off by this much (the array is allocated to match `nx`).
    Length(isize),
}

#[derive(Clone, Debug)]
enum Op {
    Setup {
        start: f64,
        stop: Option<f64>,
    },
    EnterInit,
    ExitInit,
    SetReal {
        vr: u32,
        value: f64,
    },
    GetReal {
        vr: u32,
    },
    SetString {
        vr: u32,
        value: &'static str,
    },
    /// `fmi2Get/SetInteger`, `fmi2Get/SetBoolean` (the scenes have no such variables).
    OtherType {
        vr: u32,
        set: bool,
        boolean: bool,
    },
    /// `offset` is added to the instance's own time (0: a valid communication point).
    DoStep {
        offset: f64,
        h: f64,
    },
    Terminate,
    Reset,
    SaveState,
    RestoreState {
        slot: usize,
    },
    FreeState {
        slot: usize,
    },
    Serialize {
        slot: usize,
        damage: Damage,
    },
    Logging {
        on: bool,
    },
    EnterEventMode,
    NewDiscreteStates,
    EnterContinuousTimeMode,
    CompletedIntegratorStep,
    SetTime {
        time: f64,
    },
    SetStates {
        nudge: f64,
        bad: Bad,
    },
    GetDerivatives,
    GetStates,
}

fn real() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -1.0..1.0f64,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(0.0),
        1 => Just(-0.0),
        1 => Just(1e300),
        1 => Just(-1e300),
        1 => Just(-1e-300),
        1 => Just(f64::MIN_POSITIVE),
    ]
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        1 => (prop_oneof![3 => Just(0.0), 2 => -100.0..100.0f64, 1 => real()], proptest::option::of(prop_oneof![Just(10.0), real(), -5.0..5.0f64]))
            .prop_map(|(start, stop)| Op::Setup { start, stop }),
        3 => Just(Op::EnterInit),
        3 => Just(Op::ExitInit),
        3 => (0u32..64, real()).prop_map(|(vr, value)| Op::SetReal { vr, value }),
        2 => (0u32..64).prop_map(|vr| Op::GetReal { vr }),
        1 => (0u32..64, prop_oneof![Just("rk4"), Just("implicit_euler"), Just("semi_implicit_euler"), Just("leapfrog"), Just("")]).prop_map(|(vr, value)| Op::SetString { vr, value }),
        1 => (0u32..64, any::<bool>(), any::<bool>()).prop_map(|(vr, set, boolean)| Op::OtherType { vr, set, boolean }),
        6 => (prop_oneof![6 => Just(0.0), 1 => real(), 1 => Just(1e-12)], prop_oneof![6 => 1e-4..0.01f64, 1 => real(), 1 => Just(1e300), 1 => Just(5e-324)]).prop_map(|(offset, h)| Op::DoStep { offset, h }),
        1 => Just(Op::Terminate),
        1 => Just(Op::Reset),
        3 => Just(Op::SaveState),
        2 => (0usize..3).prop_map(|slot| Op::RestoreState { slot }),
        1 => (0usize..3).prop_map(|slot| Op::FreeState { slot }),
        2 => (0usize..3, prop_oneof![
            2 => Just(Damage::None),
            2 => (any::<usize>(), 1u8..=255).prop_map(|(i, m)| Damage::Flip(i, m)),
            1 => any::<usize>().prop_map(Damage::Truncate),
            1 => (1usize..9).prop_map(Damage::Append),
        ]).prop_map(|(slot, damage)| Op::Serialize { slot, damage }),
        1 => any::<bool>().prop_map(|on| Op::Logging { on }),
        2 => Just(Op::EnterEventMode),
        1 => Just(Op::NewDiscreteStates),
        2 => Just(Op::EnterContinuousTimeMode),
        2 => Just(Op::CompletedIntegratorStep),
        2 => prop_oneof![4 => -1.0..10.0f64, 1 => real()].prop_map(|time| Op::SetTime { time }),
        3 => (-0.01..0.01f64, prop_oneof![
            4 => Just(Bad::None),
            1 => (0usize..64, prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY)]).prop_map(|(i, x)| Bad::NonFinite(i, x)),
            1 => Just(Bad::ZeroQuaternion),
            1 => prop_oneof![Just(-1isize), Just(1), Just(-5)].prop_map(Bad::Length),
        ]).prop_map(|(nudge, bad)| Op::SetStates { nudge, bad }),
        2 => Just(Op::GetDerivatives),
        1 => Just(Op::GetStates),
    ]
}

/// The phases of the FMI 2.0 state machine the model distinguishes.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    Instantiated,
    Init,
    /// Co-Simulation `StepComplete`.
    Stepping,
    /// Co-Simulation `StepFailed` (after a discarded step).
    Failed,
    /// Model Exchange `EventMode`.
    Event,
    /// Model Exchange `ContinuousTimeMode`.
    Continuous,
    Terminated,
}

/// The model: what the FMU's state should be.
#[derive(Clone, Debug)]
struct Model {
    phase: Phase,
    time: f64,
    stop: Option<f64>,
    /// `q` as set before initialization (exact until the first step).
    q_set: Vec<f64>,
    mocap_quat: Vec<[f64; 4]>,
}

impl Model {
    fn fresh(f: &Fixture) -> Model {
        Model {
            phase: Phase::Instantiated,
            time: 0.0,
            stop: None,
            q_set: f.x0.clone(),
            mocap_quat: f.mocap_quat0.clone(),
        }
    }

    fn before_init(&self) -> bool {
        matches!(self.phase, Phase::Instantiated | Phase::Init)
    }

    /// `fmi2Get*` (variables, states, derivatives) is legal.
    fn can_get(&self) -> bool {
        use Phase::*;
        matches!(
            self.phase,
            Init | Stepping | Failed | Event | Continuous | Terminated
        )
    }

    /// `fmi2SetReal` is legal.
    fn can_set_real(&self) -> bool {
        use Phase::*;
        matches!(
            self.phase,
            Instantiated | Init | Stepping | Event | Continuous
        )
    }

    /// `fmi2SetString` (and Integer, Boolean) is legal.
    fn can_set_other(&self) -> bool {
        use Phase::*;
        matches!(self.phase, Instantiated | Init | Stepping | Event)
    }

    /// Whether `fmi2SetReal(vr) = value` must succeed, from the variable's slot alone
    /// (independent of the code under test: the rules of SPEC §5 and the FMI standard).
    fn set_real_ok(&self, slot: Option<&(Slot, bool)>, value: f64) -> bool {
        let Some(&(slot, true)) = slot else {
            return false;
        };
        if !self.can_set_real() || !value.is_finite() {
            return false;
        }
        match slot {
            // Model Exchange also takes the states by value reference after initialization
            // (as `fmi2SetContinuousStates` does; CasADi relies on it).
            Slot::Q(_) | Slot::V(_) => {
                self.before_init() || matches!(self.phase, Phase::Event | Phase::Continuous)
            }
            Slot::Ctrl(_) | Slot::Mocap(..) => true,
            Slot::Param(Param::Friction) => value >= 0.0,
            Slot::Param(_) => value > 0.0,
            Slot::SolverStep | Slot::SolverTolerance => self.before_init() && value > 0.0,
            Slot::PruneTolerance => self.before_init() && value > 0.0 && value <= 1e-3,
            _ => false,
        }
    }

    fn mocap_zero(&self) -> bool {
        self.mocap_quat.iter().any(|q| q.iter().all(|&c| c == 0.0))
    }
}

/// Time and continuous states, as bits (when they can be read).
unsafe fn snapshot(c: fmi2Component, f: &Fixture, m: &Model) -> Option<Vec<u64>> {
    if !m.can_get() {
        return None;
    }
    let vrs: Vec<u32> = f
        .slots
        .iter()
        .enumerate()
        .filter(|(_, (s, _))| {
            matches!(
                s,
                Slot::Time | Slot::Q(_) | Slot::V(_) | Slot::Param(_) | Slot::SolverStep
            )
        })
        .map(|(i, _)| i as u32)
        .collect();
    let mut values = vec![0.0; vrs.len()];
    let s = unsafe { fmi2GetReal(c, vrs.as_ptr(), vrs.len(), values.as_mut_ptr()) };
    assert_eq!(s, fmi2OK, "snapshot in {:?}", m.phase);
    Some(values.iter().map(|v| v.to_bits()).collect())
}

/// Runs one sequence and checks every status against the model.
fn run(scene: usize, me: bool, ops: &[Op]) -> Result<(), TestCaseError> {
    let f = fixture(scene);
    let capture = Box::new(Capture::default());
    let callbacks = host::callbacks(&capture);
    let n = f.x0.len();
    unsafe {
        let c = host::instantiate(
            &f.res,
            if me {
                fmi2ModelExchange
            } else {
                fmi2CoSimulation
            },
            &callbacks,
        );
        prop_assert!(!c.is_null(), "{:?}", capture.all());
        let mut m = Model::fresh(f);
        // Saved states with the model they were saved in.
        let mut states: Vec<(fmi2FMUstate, Model)> = Vec::new();
        for op in ops {
            let before = snapshot(c, f, &m);
            let logged_before = capture.len();
            // What the call must return: `Ok(true)` OK, `Ok(false)` fmi2Error; `Err(set)`: one of the set.
            let expect: Result<bool, &[fmi2Status]>;
            let status = match op {
                Op::Setup { start, stop } => {
                    let s = fmi2SetupExperiment(
                        c,
                        0,
                        0.0,
                        *start,
                        stop.is_some() as i32,
                        stop.unwrap_or(0.0),
                    );
                    let ok = m.phase == Phase::Instantiated
                        && start.is_finite()
                        && stop.is_none_or(|x| x.is_finite() && x >= *start);
                    if ok {
                        m.time = *start;
                        m.stop = *stop;
                    }
                    expect = Ok(ok);
                    s
                }
                Op::EnterInit => {
                    let s = fmi2EnterInitializationMode(c);
                    let ok = m.phase == Phase::Instantiated;
                    if ok {
                        m.phase = Phase::Init;
                    }
                    expect = Ok(ok);
                    s
                }
                Op::ExitInit => {
                    let s = fmi2ExitInitializationMode(c);
                    // A quaternion the host set to zero has no orientation: refused.
                    let zero = f
                        .quats
                        .iter()
                        .any(|&i| m.q_set[i..i + 4].iter().all(|&x| x == 0.0));
                    let ok = m.phase == Phase::Init && !zero;
                    if ok {
                        m.phase = if me { Phase::Event } else { Phase::Stepping };
                    }
                    expect = Ok(ok);
                    s
                }
                Op::SetReal { vr, value } => {
                    let old = if m.can_get() { try_get(c, *vr) } else { None };
                    let s = fmi2SetReal(c, vr, 1, value);
                    let ok = m.set_real_ok(f.slots.get(*vr as usize), *value);
                    if ok {
                        match f.slots[*vr as usize].0 {
                            Slot::Q(i) => m.q_set[i] = *value,
                            Slot::Mocap(b, k) if k >= 3 => m.mocap_quat[b][k - 3] = *value,
                            _ => {}
                        }
                    } else if let Some(old) = old {
                        prop_assert_eq!(
                            try_get(c, *vr),
                            Some(old),
                            "a refused fmi2SetReal changed the variable"
                        );
                    }
                    expect = Ok(ok);
                    s
                }
                Op::GetReal { vr } => {
                    let mut v = f64::NAN;
                    let s = fmi2GetReal(c, vr, 1, &mut v);
                    let known = f.slots.get(*vr as usize).filter(|(_, real)| *real);
                    expect = match known {
                        // Accelerations come from the forward dynamics, which may refuse a state.
                        Some((Slot::VDot(_), _)) if m.can_get() => Err(&[fmi2OK, fmi2Error]),
                        Some((slot, _)) if m.can_get() => {
                            if s == fmi2OK && matches!(slot, Slot::Time | Slot::Q(_) | Slot::V(_)) {
                                // Non-finite sets and diverging steps are refused: always finite.
                                prop_assert!(v.is_finite(), "vr {} = {}", vr, v);
                            }
                            Ok(true)
                        }
                        _ => Ok(false),
                    };
                    s
                }
                Op::SetString { vr, value } => {
                    let cs = std::ffi::CString::new(*value).unwrap();
                    let s = fmi2SetString(c, vr, 1, &cs.as_ptr());
                    let is_integrator = f
                        .slots
                        .get(*vr as usize)
                        .is_some_and(|(s, _)| *s == Slot::SolverIntegrator);
                    let known = ["rk4", "implicit_euler", "semi_implicit_euler"].contains(value);
                    expect = Ok(m.can_set_other() && m.before_init() && is_integrator && known);
                    s
                }
                Op::OtherType { vr, set, boolean } => {
                    let s = match (set, boolean) {
                        (true, true) => fmi2SetBoolean(c, vr, 1, &fmi2True),
                        (true, false) => fmi2SetInteger(c, vr, 1, &7),
                        (false, true) => fmi2GetBoolean(c, vr, 1, &mut 0),
                        (false, false) => fmi2GetInteger(c, vr, 1, &mut 0),
                    };
                    expect = Ok(false);
                    s
                }
                Op::DoStep { offset, h } => {
                    let t = m.time + offset;
                    let s = fmi2DoStep(c, t, *h, 0);
                    // The communication point may differ from the FMU's time by 1e-9 relative
                    // to the larger of the time and the step; so may the end from stopTime.
                    let tol = 1e-9 * m.time.abs().max(*h);
                    let args = h.is_finite()
                        && *h > 0.0
                        && t.is_finite()
                        && (t - m.time).abs() <= tol
                        && m.stop
                            .is_none_or(|st| m.time + h <= st + 1e-9 * st.abs().max(*h));
                    if !me
                        && matches!(m.phase, Phase::Stepping | Phase::Failed)
                        && args
                        && !m.mocap_zero()
                    {
                        expect = Err(&[fmi2OK, fmi2Discard]);
                        if s == fmi2OK {
                            m.time += h;
                            m.phase = Phase::Stepping;
                        } else if s == fmi2Discard {
                            m.phase = Phase::Failed;
                        }
                    } else {
                        expect = Ok(false);
                    }
                    s
                }
                Op::Terminate => {
                    let s = fmi2Terminate(c);
                    let ok = if me {
                        matches!(m.phase, Phase::Event | Phase::Continuous)
                    } else {
                        matches!(m.phase, Phase::Stepping | Phase::Failed)
                    };
                    if ok {
                        m.phase = Phase::Terminated;
                    }
                    expect = Ok(ok);
                    s
                }
                Op::Reset => {
                    let s = fmi2Reset(c);
                    m = Model::fresh(f);
                    expect = Ok(true);
                    s
                }
                Op::SaveState => {
                    let mut st: fmi2FMUstate = std::ptr::null_mut();
                    let s = fmi2GetFMUstate(c, &mut st);
                    if s == fmi2OK {
                        let mut saved = m.clone();
                        // A state saved after a discarded step is the state at its start.
                        if saved.phase == Phase::Failed {
                            saved.phase = Phase::Stepping;
                        }
                        states.push((st, saved));
                    }
                    expect = Ok(true);
                    s
                }
                Op::RestoreState { slot } => match states.get(*slot) {
                    Some((st, saved)) => {
                        let s = fmi2SetFMUstate(c, *st);
                        if s == fmi2OK {
                            m = saved.clone();
                            if m.can_get() {
                                prop_assert_eq!(
                                    snapshot_one(c, 0),
                                    m.time.to_bits(),
                                    "restored time"
                                );
                            }
                        }
                        expect = Ok(true);
                        s
                    }
                    None => {
                        expect = Ok(false);
                        fmi2SetFMUstate(c, std::ptr::null_mut())
                    }
                },
                Op::FreeState { slot } => {
                    let mut st = states
                        .get(*slot)
                        .map(|x| x.0)
                        .unwrap_or(std::ptr::null_mut());
                    let s = fmi2FreeFMUstate(c, &mut st);
                    prop_assert!(st.is_null(), "fmi2FreeFMUstate leaves the handle NULL");
                    if *slot < states.len() {
                        // Freeing the same handle again is refused, not a crash.
                        let mut again = states.remove(*slot).0;
                        prop_assert_eq!(
                            fmi2FreeFMUstate(c, &mut again),
                            fmi2Error,
                            "double free accepted"
                        );
                        prop_assert!(
                            capture.last().message.contains("unknown FMU state"),
                            "{:?}",
                            capture.last()
                        );
                    }
                    expect = Ok(true);
                    s
                }
                Op::Serialize { slot, damage } => match states.get(*slot).cloned() {
                    None => {
                        let mut size = 0usize;
                        expect = Ok(false);
                        fmi2SerializedFMUstateSize(c, std::ptr::null_mut(), &mut size)
                    }
                    Some((st, saved)) => {
                        let mut size = 0usize;
                        prop_assert_eq!(fmi2SerializedFMUstateSize(c, st, &mut size), fmi2OK);
                        let mut bytes = vec![0u8; size];
                        prop_assert_eq!(
                            fmi2SerializeFMUstate(c, st, bytes.as_mut_ptr().cast(), size),
                            fmi2OK
                        );
                        match damage {
                            Damage::None => {}
                            Damage::Flip(i, mask) => bytes[i % size] ^= mask,
                            Damage::Truncate(k) => bytes.truncate(k % size),
                            Damage::Append(k) => bytes.extend(std::iter::repeat_n(0u8, *k)),
                        }
                        let mut back: fmi2FMUstate = std::ptr::null_mut();
                        let s = fmi2DeSerializeFMUstate(
                            c,
                            bytes.as_ptr().cast(),
                            bytes.len(),
                            &mut back,
                        );
                        if matches!(damage, Damage::None) {
                            expect = Ok(true);
                            states.push((back, saved));
                        } else {
                            expect = Ok(false);
                            prop_assert!(back.is_null(), "a refused state got a handle");
                        }
                        s
                    }
                },
                Op::Logging { on } => {
                    expect = Ok(true);
                    fmi2SetDebugLogging(c, *on as i32, 0, std::ptr::null())
                }
                Op::EnterEventMode => {
                    let s = fmi2EnterEventMode(c);
                    let ok = me && matches!(m.phase, Phase::Event | Phase::Continuous);
                    if ok {
                        m.phase = Phase::Event;
                    }
                    expect = Ok(ok);
                    s
                }
                Op::NewDiscreteStates => {
                    let mut info = fmi2EventInfo::default();
                    expect = Ok(me && m.phase == Phase::Event);
                    fmi2NewDiscreteStates(c, &mut info)
                }
                Op::EnterContinuousTimeMode => {
                    let s = fmi2EnterContinuousTimeMode(c);
                    let ok = me && m.phase == Phase::Event;
                    if ok {
                        m.phase = Phase::Continuous;
                    }
                    expect = Ok(ok);
                    s
                }
                Op::CompletedIntegratorStep => {
                    let (mut enter, mut terminate) = (fmi2True, fmi2True);
                    let s = fmi2CompletedIntegratorStep(c, fmi2True, &mut enter, &mut terminate);
                    expect = Ok(me && m.phase == Phase::Continuous);
                    if s == fmi2OK {
                        prop_assert_eq!(terminate, fmi2False);
                    }
                    s
                }
                Op::SetTime { time } => {
                    let s = fmi2SetTime(c, *time);
                    let ok = me
                        && matches!(m.phase, Phase::Event | Phase::Continuous)
                        && time.is_finite();
                    if ok {
                        m.time = *time;
                    }
                    expect = Ok(ok);
                    s
                }
                Op::SetStates { nudge, bad } => {
                    let mut x: Vec<f64> = f.x0.iter().map(|v| v + nudge).collect();
                    let mut valid = true;
                    match bad {
                        Bad::None => {}
                        Bad::NonFinite(i, v) => {
                            x[i % n] = *v;
                            valid = false;
                        }
                        Bad::ZeroQuaternion => {
                            if let Some(&q) = f.quats.first() {
                                x[q..q + 4].fill(0.0);
                                valid = false;
                            }
                        }
                        Bad::Length(d) => {
                            x.resize((n as isize + d) as usize, 0.5);
                            valid = false;
                        }
                    }
                    expect = Ok(me && m.phase == Phase::Continuous && valid);
                    fmi2SetContinuousStates(c, x.as_ptr(), x.len())
                }
                Op::GetDerivatives => {
                    let mut dx = vec![0.0; n];
                    let s = fmi2GetDerivatives(c, dx.as_mut_ptr(), n);
                    // The forward dynamics may refuse a state (a non-finite derivative).
                    expect = if me && m.can_get() {
                        Err(&[fmi2OK, fmi2Error])
                    } else {
                        Ok(false)
                    };
                    if s == fmi2OK {
                        prop_assert!(dx.iter().all(|d| d.is_finite()), "{:?}", dx);
                    }
                    s
                }
                Op::GetStates => {
                    let mut x = vec![f64::NAN; n];
                    let s = fmi2GetContinuousStates(c, x.as_mut_ptr(), n);
                    expect = Ok(me && m.can_get());
                    if s == fmi2OK {
                        prop_assert!(x.iter().all(|v| v.is_finite()), "{:?}", x);
                    }
                    s
                }
            };
            prop_assert_ne!(
                status,
                fmi2Fatal,
                "{:?} panicked inside the FMU: {:?}",
                op,
                capture.last()
            );
            match expect {
                Ok(true) => prop_assert_eq!(
                    status,
                    fmi2OK,
                    "{:?} in {:?} at t = {}: {:?}",
                    op,
                    m.phase,
                    m.time,
                    capture.last()
                ),
                Ok(false) => prop_assert_eq!(
                    status,
                    fmi2Error,
                    "{:?} in {:?} at t = {}",
                    op,
                    m.phase,
                    m.time
                ),
                Err(allowed) => prop_assert!(
                    allowed.contains(&status),
                    "{:?} in {:?}: status {} not in {:?}: {:?}",
                    op,
                    m.phase,
                    status,
                    allowed,
                    capture.last()
                ),
            }
            if status == fmi2Error || status == fmi2Discard {
                // Explained to the host...
                let said = capture.since(logged_before);
                prop_assert!(
                    said.iter()
                        .any(|l| l.status == status && !l.message.is_empty()),
                    "{:?} returned {} without a message",
                    op,
                    status
                );
                // ... and nothing changed.
                if let (Some(a), Some(b)) = (before.as_ref(), snapshot(c, f, &m)) {
                    prop_assert!(
                        *a == b,
                        "{:?} was refused ({}) but changed the state",
                        op,
                        status
                    );
                }
            }
        }
        prop_assert!(
            capture.all().iter().all(|l| l.format == "%s"),
            "every message goes through \"%s\""
        );
        fmi2FreeInstance(c);
        // Calls after free are refused, not crashes; a second free is ignored.
        prop_assert_eq!(fmi2DoStep(c, 0.0, 0.001, 0), fmi2Error);
        prop_assert_eq!(fmi2GetReal(c, &0, 1, &mut 0.0), fmi2Error);
        fmi2FreeInstance(c);
    }
    Ok(())
}

/// A variable's value as bits, if it can be read (an acceleration cannot at a state the forward
/// dynamics refuses, e.g. with a zero quaternion set before initialization).
unsafe fn try_get(c: fmi2Component, vr: u32) -> Option<u64> {
    let mut v = 0.0;
    (unsafe { fmi2GetReal(c, &vr, 1, &mut v) } == fmi2OK).then_some(v.to_bits())
}

unsafe fn snapshot_one(c: fmi2Component, vr: u32) -> u64 {
    let mut v = 0.0;
    assert_eq!(unsafe { fmi2GetReal(c, &vr, 1, &mut v) }, fmi2OK);
    v.to_bits()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 10_000, max_shrink_iters: 4000, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn random_call_sequences_never_panic_and_follow_the_state_machine(
        scene in prop_oneof![3 => Just(0usize), 1 => Just(1usize)],
        me in any::<bool>(),
        prefix in prop_oneof![
            // Half the sequences start initialized (or in continuous-time mode), so that the
            // calls of a running simulation are exercised as often as the early ones.
            2 => Just(vec![]),
            1 => Just(vec![Op::EnterInit, Op::ExitInit]),
            1 => Just(vec![Op::Setup { start: 0.0, stop: Some(10.0) }, Op::EnterInit, Op::ExitInit]),
            1 => Just(vec![Op::EnterInit, Op::ExitInit, Op::EnterContinuousTimeMode]),
        ],
        ops in proptest::collection::vec(op(), 1..24),
    ) {
        run(scene, me, &[prefix, ops].concat())?;
    }
}

/// One edit of a forged state's model bytes.
#[derive(Clone, Debug)]
enum Edit {
    /// Sets the byte at this offset (modulo the model's length).
    Byte(usize, u8),
    /// Writes this f64 at an 8-byte slot (modulo the number of slots), where most numbers are.
    Number(usize, f64),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Edit::Byte(i, b)),
        (
            any::<usize>(),
            prop_oneof![
                Just(0.0),
                Just(-1.0),
                Just(1e300),
                Just(1e-300),
                Just(f64::NAN),
                Just(f64::INFINITY),
                Just(2.0),
                Just(-1e-9)
            ]
        )
            .prop_map(|(i, x)| Edit::Number(i, x)),
    ]
}

/// Offset and length of the model's bytes inside a serialized state (see `scm::fmi::serial`).
fn model_part(bytes: &[u8]) -> (usize, usize) {
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap()) as usize;
    let mut at = 8 + 4;
    at += 4 + u32_at(at); // GUID
    at += 4 + 8; // machine state, last successful time
    at += if bytes[at] == 1 { 9 } else { 1 }; // stop time
    let len = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
    (at + 8, len)
}

/// Forges a state of `scene` (saved after `steps` steps of 2 ms, so that the implicit method's
/// Newton Jacobian is cached in `arm_push`) with `edits` in its model bytes and a correct
/// checksum: it is refused with a message, or accepted, and then restoring it, reading every
/// variable and stepping from it never panic, and a refusal of the forged state leaves the
/// instance as it was.
fn forge(scene: &str, steps: usize, edits: &[Edit]) -> Result<(), TestCaseError> {
    let res = host::resources(scene);
    let capture = Box::new(Capture::default());
    let callbacks = host::callbacks(&capture);
    unsafe {
        let c = host::instantiate(&res, fmi2CoSimulation, &callbacks);
        prop_assert!(!c.is_null());
        prop_assert_eq!(fmi2EnterInitializationMode(c), fmi2OK);
        prop_assert_eq!(fmi2ExitInitializationMode(c), fmi2OK);
        for k in 0..steps {
            prop_assert_eq!(fmi2DoStep(c, k as f64 * 0.002, 0.002, 0), fmi2OK);
        }
        let mut st: fmi2FMUstate = std::ptr::null_mut();
        prop_assert_eq!(fmi2GetFMUstate(c, &mut st), fmi2OK);
        let mut size = 0;
        prop_assert_eq!(fmi2SerializedFMUstateSize(c, st, &mut size), fmi2OK);
        let mut bytes = vec![0u8; size];
        prop_assert_eq!(
            fmi2SerializeFMUstate(c, st, bytes.as_mut_ptr().cast(), size),
            fmi2OK
        );
        let (start, len) = model_part(&bytes);
        for e in edits {
            match *e {
                Edit::Byte(i, b) => bytes[start + i % len] = b,
                Edit::Number(i, x) => {
                    let slot = start + 8 * (i % (len / 8));
                    bytes[slot..slot + 8].copy_from_slice(&x.to_bits().to_le_bytes());
                }
            }
        }
        let body = bytes.len() - 8;
        let sum = scm::fmi::serial::fnv1a(&bytes[..body], 0);
        bytes[body..].copy_from_slice(&sum.to_le_bytes());
        let nvars = scm::sim::Simulation::from_file(&crate::common::scene(scene))
            .unwrap()
            .rows()
            .len() as u32;
        let read_all = |c: fmi2Component| -> Vec<(fmi2Status, u64)> {
            (0..nvars)
                .map(|vr| {
                    let mut v = 0.0;
                    let s = fmi2GetReal(c, &vr, 1, &mut v);
                    (s, v.to_bits())
                })
                .collect()
        };
        let before = read_all(c);
        let mut forged: fmi2FMUstate = std::ptr::null_mut();
        let s = fmi2DeSerializeFMUstate(c, bytes.as_ptr().cast(), bytes.len(), &mut forged);
        prop_assert!(s == fmi2OK || s == fmi2Error, "status {}", s);
        if s == fmi2Error {
            prop_assert!(forged.is_null());
            prop_assert!(
                capture.last().message.contains("fmi2DeSerializeFMUstate"),
                "{:?}",
                capture.last()
            );
            prop_assert!(
                read_all(c) == before,
                "a refused state changed the instance"
            );
        } else {
            prop_assert_eq!(fmi2SetFMUstate(c, forged), fmi2OK);
            let values = read_all(c);
            prop_assert!(values.iter().all(|(s, _)| *s != fmi2Fatal));
            let mut t = 0.0;
            prop_assert_eq!(fmi2GetReal(c, &0, 1, &mut t), fmi2OK);
            let s = fmi2DoStep(c, t, 0.002, 0);
            prop_assert!(
                s != fmi2Fatal,
                "stepping a forged state panicked: {:?}",
                capture.last()
            );
            prop_assert!(read_all(c).iter().all(|(s, _)| *s != fmi2Fatal));
        }
        fmi2FreeInstance(c);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 600, max_shrink_iters: 2000, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn forged_states_with_right_checksums_are_refused_or_safe(
        scene in prop_oneof![Just(("arm_push", 3usize)), Just(("mocap_push", 2)), Just(("sphere_drop", 1))],
        edits in proptest::collection::vec(edit(), 1..4),
    ) {
        forge(scene.0, scene.1, &edits)?;
    }
}

/// Found by the fuzz: in Model Exchange the states may be set by value reference at an event,
/// a component at a time, so a quaternion can be zero when the host asks for the event update.
/// The update leaves it as set (it has no direction to project onto) instead of dividing by its
/// zero norm: the states stay finite, and the forward dynamics refuses the state until the host
/// sets an orientation.
#[test]
fn a_zero_quaternion_set_at_an_event_is_left_as_set_by_the_event_update() {
    // vr 4 is ball.quat.w of sphere_drop: the start quaternion is (1, 0, 0, 0).
    assert!(matches!(fixture(0).slots[4].0, Slot::Q(3)));
    run(
        0,
        true,
        &[
            Op::EnterInit,
            Op::ExitInit,
            Op::SetReal { vr: 4, value: 0.0 },
            Op::SaveState,
            Op::NewDiscreteStates,
            Op::GetStates,
            Op::GetDerivatives,
            // An orientation set again, the event projects it and the model runs on.
            Op::SetReal { vr: 5, value: 2.0 },
            Op::NewDiscreteStates,
            Op::GetStates,
            Op::EnterContinuousTimeMode,
            Op::GetDerivatives,
        ],
    )
    .unwrap();
}

/// Found by the fuzz: a zero quaternion set before initialization, saved and serialized, must
/// deserialize (the FMU's own bytes round-trip); initialization then refuses it.
#[test]
fn a_zero_quaternion_saved_before_initialization_round_trips() {
    // vr 4 is ball.quat.w of sphere_drop (time, then pos.x|y|z): the start quaternion is (1, 0, 0, 0).
    assert!(matches!(fixture(0).slots[4].0, Slot::Q(3)));
    run(
        0,
        false,
        &[
            Op::SetReal { vr: 4, value: 0.0 },
            Op::SaveState,
            Op::Serialize {
                slot: 0,
                damage: Damage::None,
            },
            Op::RestoreState { slot: 1 },
            Op::EnterInit,
            Op::ExitInit,
        ],
    )
    .unwrap();
}

/// Found by the fuzz (mocap_push, scene 1): a mocap target set and a communication step so
/// short that the move overflows (5e-324 s) made the mocap velocity infinite, accepted by the
/// step and then refused by the FMU's own state bytes. Such a step is discarded, saying why;
/// the state kept serializes.
#[test]
fn a_mocap_move_in_a_vanishing_step_is_discarded_and_the_state_kept() {
    assert!(matches!(fixture(1).slots[14].0, Slot::Mocap(0, _)));
    run(
        1,
        false,
        &[
            Op::EnterInit,
            Op::ExitInit,
            Op::SetReal { vr: 14, value: 0.0 },
            Op::DoStep {
                offset: 0.0,
                h: 5e-324,
            },
            Op::SaveState,
            Op::Serialize {
                slot: 0,
                damage: Damage::None,
            },
        ],
    )
    .unwrap();
}

/// Found by the fuzz: a mocap target orientation with huge (1e300) or tiny (-1e-300)
/// components overflowed or vanished when normalized, giving an infinite pose after the step.
/// It is scaled first; the step lands on the unit quaternion, and the state serializes.
#[test]
fn a_mocap_target_orientation_of_any_scale_lands_as_a_unit_quaternion() {
    assert!(matches!(fixture(1).slots[17].0, Slot::Mocap(0, _)));
    for value in [1e300, -1e-300] {
        run(
            1,
            false,
            &[
                Op::EnterInit,
                Op::ExitInit,
                Op::SetReal { vr: 17, value },
                Op::SaveState,
                Op::DoStep {
                    offset: 0.0,
                    h: 1e-4,
                },
                Op::SaveState,
                Op::Serialize {
                    slot: 1,
                    damage: Damage::None,
                },
            ],
        )
        .unwrap();
    }
}
