//! Bad values through the C ABI, table-driven over every settable variable of every bundled
//! scene: NaN and ±Inf everywhere, zero and negative values where a quantity must be positive
//! (ε1, ε2, ε3, k, v_d, v_s, `solver.step`, `solver.tolerance`; a negative friction; a pruning
//! tolerance out of its range), unknown integrator names, and bad communication steps
//! (negative, zero, non-finite, not at the FMU's time, past `stopTime`).
//!
//! Each is refused with `fmi2Error` and a message to the host's logger that names the variable
//! (or argument) and the value; the variable keeps its value, a valid call right after works,
//! and a run with every bad call interleaved ends bit-identical to the same run without them:
//! nothing of the last good state is lost.

use crate::common::host::{self, Capture, Resources};
use scm::fmi::contract::{Causality, VarType};
use scm::fmi::ffi::*;
use scm::sim::{Param, Slot};
use scm::*;
use std::ffi::CString;

/// A settable Real variable: value reference, name, slot.
struct Settable {
    vr: u32,
    name: String,
    slot: Slot,
}

/// The variable table of a bundled scene: settable Reals, the String `solver.integrator`, and
/// the number of variables.
fn table(name: &str) -> (Vec<Settable>, Option<u32>, u32) {
    let sim = scm::sim::Simulation::from_file(&crate::common::scene(name)).unwrap();
    let mut settable = Vec::new();
    let mut integrator = None;
    for (i, (var, slot)) in sim.rows().iter().enumerate() {
        let vr = i as u32;
        match slot {
            Slot::Q(_)
            | Slot::V(_)
            | Slot::Ctrl(_)
            | Slot::Mocap(..)
            | Slot::Param(_)
            | Slot::SolverStep
            | Slot::SolverTolerance
            | Slot::PruneTolerance => {
                assert!(matches!(var.var_type, VarType::Real { .. }), "{}", var.name);
                settable.push(Settable {
                    vr,
                    name: var.name.clone(),
                    slot: *slot,
                });
            }
            Slot::SolverIntegrator => integrator = Some(vr),
            _ => assert!(
                !matches!(var.causality, Causality::Input | Causality::Parameter),
                "{} is settable but not covered by the table",
                var.name
            ),
        }
    }
    (settable, integrator, sim.rows().len() as u32)
}

/// The bad values of a variable (refused in every phase where it may be set).
fn bad_values(slot: Slot) -> Vec<f64> {
    let mut bad = vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY];
    match slot {
        Slot::Param(Param::Friction) => bad.extend([-1.0, -1e-300]),
        Slot::Param(_) | Slot::SolverStep | Slot::SolverTolerance => {
            bad.extend([0.0, -0.0, -1.0, -1e-300])
        }
        // A relative weight: above 0, at most 1e-3.
        Slot::PruneTolerance => bad.extend([0.0, -0.0, -1e-300, 2e-3, 1.0]),
        _ => {}
    }
    bad
}

/// Whether the variable may be set during the simulation (after initialization).
fn tunable(slot: Slot) -> bool {
    matches!(slot, Slot::Ctrl(_) | Slot::Mocap(..) | Slot::Param(_))
}

unsafe fn get(c: fmi2Component, vr: u32) -> Option<u64> {
    let mut v = 0.0;
    (unsafe { fmi2GetReal(c, &vr, 1, &mut v) } == fmi2OK).then_some(v.to_bits())
}

/// Every Real variable as bits (a non-Real or unreadable one as a marker).
unsafe fn all(c: fmi2Component, n: u32) -> Vec<Option<u64>> {
    (0..n).map(|vr| unsafe { get(c, vr) }).collect()
}

/// Sets `vr` to `value`, expects `fmi2Error` with a message naming `name` and `value`, checks
/// the variable did not change (when it can be read), and sets it again to its value (a valid
/// call, which must work).
unsafe fn refuse(
    c: fmi2Component,
    capture: &Capture,
    vr: u32,
    name: &str,
    value: f64,
    readable: bool,
) {
    unsafe {
        let before = if readable { get(c, vr) } else { None };
        let s = fmi2SetReal(c, &vr, 1, &value);
        assert_eq!(s, fmi2Error, "{name} = {value} was accepted");
        let msg = capture.last();
        assert_eq!(msg.status, fmi2Error);
        assert!(
            msg.message.contains(name) && msg.message.contains(&format!("{value:?}")),
            "{name} = {value}: message {:?}",
            msg.message
        );
        if readable {
            let after = get(c, vr);
            assert_eq!(after, before, "{name} changed after a refused set");
            let good = f64::from_bits(after.unwrap());
            assert_eq!(
                fmi2SetReal(c, &vr, 1, &good),
                fmi2OK,
                "{name}: a valid set after a refused one: {:?}",
                capture.last()
            );
        }
    }
}

#[allow(clippy::too_many_arguments)]
/// A scene's run: setup with `stopTime`, initialization, `steps` communication steps of `h`
/// with a hook after each, then every variable.
unsafe fn run(
    res: &Resources,
    capture: &Capture,
    n: u32,
    stop: f64,
    steps: usize,
    h: f64,
    mut before_init: impl FnMut(fmi2Component, bool),
    mut hook: impl FnMut(fmi2Component, usize),
) -> Vec<Option<u64>> {
    unsafe {
        let callbacks = host::callbacks(capture);
        let c = host::instantiate(res, fmi2CoSimulation, &callbacks);
        assert!(!c.is_null(), "{:?}", capture.all());
        before_init(c, false);
        assert_eq!(
            fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2True, stop),
            fmi2OK
        );
        assert_eq!(fmi2EnterInitializationMode(c), fmi2OK);
        before_init(c, true);
        assert_eq!(
            fmi2ExitInitializationMode(c),
            fmi2OK,
            "{:?}",
            capture.last()
        );
        for k in 0..steps {
            let s = fmi2DoStep(c, k as f64 * h, h, fmi2True);
            assert_eq!(s, fmi2OK, "step {k}: {:?}", capture.last());
            hook(c, k);
        }
        let out = all(c, n);
        fmi2FreeInstance(c);
        out
    }
}

#[test]
fn every_bad_value_of_every_settable_variable_is_refused_and_nothing_is_lost() {
    let (h, steps) = (0.002, 4);
    let stop = steps as f64 * h;
    let mut refused = 0usize;
    for name in host::scene_names() {
        let res = host::resources(&name);
        let (settable, integrator, n) = table(&name);
        let quiet = Capture::default();
        let reference = unsafe { run(&res, &quiet, n, stop, steps, h, |_, _| {}, |_, _| {}) };
        let capture = Capture::default();
        let count = std::cell::Cell::new(0usize);
        let hardened = unsafe {
            run(
                &res,
                &capture,
                n,
                stop,
                steps,
                h,
                |c, readable| {
                    // Before initialization (Instantiated: not readable; initialization mode: readable).
                    for v in &settable {
                        for value in bad_values(v.slot) {
                            refuse(c, &capture, v.vr, &v.name, value, readable);
                            count.set(count.get() + 1);
                        }
                    }
                    if let Some(vr) = integrator {
                        let bad = CString::new("leapfrog").unwrap();
                        assert_eq!(fmi2SetString(c, &vr, 1, &bad.as_ptr()), fmi2Error);
                        assert!(
                            capture.last().message.contains("solver.integrator")
                                && capture.last().message.contains("leapfrog"),
                            "{:?}",
                            capture.last()
                        );
                        count.set(count.get() + 1);
                    }
                },
                |c, k| {
                    if k != 1 {
                        return;
                    }
                    // During the simulation: the tunable variables' bad values, and setting a
                    // fixed one at all.
                    for v in &settable {
                        if tunable(v.slot) {
                            for value in bad_values(v.slot) {
                                refuse(c, &capture, v.vr, &v.name, value, true);
                                count.set(count.get() + 1);
                            }
                        } else {
                            let value = f64::from_bits(get(c, v.vr).unwrap());
                            assert_eq!(
                                fmi2SetReal(c, &v.vr, 1, &value),
                                fmi2Error,
                                "{} set after initialization",
                                v.name
                            );
                            assert!(
                                capture.last().message.contains(&v.name)
                                    && capture.last().message.contains("after initialization"),
                                "{:?}",
                                capture.last()
                            );
                            count.set(count.get() + 1);
                        }
                    }
                    // All or nothing: a good value followed by a bad one sets neither.
                    if let Some(v) = settable.iter().find(|v| tunable(v.slot)) {
                        let before = get(c, v.vr).unwrap();
                        let vrs = [v.vr, v.vr];
                        assert_eq!(
                            fmi2SetReal(c, vrs.as_ptr(), 2, [0.5, f64::NAN].as_ptr()),
                            fmi2Error
                        );
                        assert_eq!(
                            get(c, v.vr).unwrap(),
                            before,
                            "{}: half of a refused fmi2SetReal was applied",
                            v.name
                        );
                        count.set(count.get() + 1);
                    }
                    // Bad communication steps: each names the argument and the value.
                    let t = (k + 1) as f64 * h;
                    let cases: [(f64, f64, &str, String); 9] = [
                        (t, -h, "communicationStepSize", format!("{:?}", -h)),
                        (t, 0.0, "communicationStepSize", "0.0".into()),
                        (t, -0.0, "communicationStepSize", "-0.0".into()),
                        (t, f64::NAN, "communicationStepSize", "NaN".into()),
                        (t, f64::INFINITY, "communicationStepSize", "inf".into()),
                        (
                            t + h,
                            h,
                            "currentCommunicationPoint",
                            format!("{:?}", t + h),
                        ),
                        (
                            t - h,
                            h,
                            "currentCommunicationPoint",
                            format!("{:?}", t - h),
                        ),
                        (f64::NAN, h, "currentCommunicationPoint", "NaN".into()),
                        (t, 1.0, "stopTime", format!("{stop:?}")),
                    ];
                    for (point, step, what, value) in cases {
                        assert_eq!(
                            fmi2DoStep(c, point, step, fmi2True),
                            fmi2Error,
                            "fmi2DoStep({point}, {step}) accepted"
                        );
                        let msg = capture.last().message;
                        assert!(
                            msg.contains(what) && msg.contains(&value),
                            "fmi2DoStep({point}, {step}): {msg:?} should name {what} = {value}"
                        );
                        count.set(count.get() + 1);
                    }
                    // The time did not move.
                    assert_eq!(get(c, 0).unwrap(), t.to_bits());
                },
            )
        };
        assert!(
            hardened == reference,
            "{name}: the run with refused calls differs from the run without them"
        );
        assert!(capture.all().iter().all(|l| l.format == "%s"));
        refused += count.get();
    }
    // 8 scenes; every settable variable has at least 3 bad values.
    assert!(refused > 500, "only {refused} refusals checked");
}

/// Model Exchange: non-finite time and states are refused with the index and value, and the
/// states keep their values.
#[test]
fn model_exchange_refuses_non_finite_time_and_states() {
    let res = host::resources("sphere_drop");
    let capture = Capture::default();
    let callbacks = host::callbacks(&capture);
    unsafe {
        let c = host::instantiate(&res, fmi2ModelExchange, &callbacks);
        assert!(!c.is_null());
        assert_eq!(fmi2EnterInitializationMode(c), fmi2OK);
        assert_eq!(fmi2ExitInitializationMode(c), fmi2OK);
        assert_eq!(fmi2EnterContinuousTimeMode(c), fmi2OK);
        let mut x = [0.0; 13];
        assert_eq!(fmi2GetContinuousStates(c, x.as_mut_ptr(), 13), fmi2OK);
        for time in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert_eq!(fmi2SetTime(c, time), fmi2Error);
            assert!(
                capture.last().message.contains("time")
                    && capture.last().message.contains(&format!("{time:?}")),
                "{:?}",
                capture.last()
            );
        }
        for i in 0..13 {
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut y = x;
                y[i] = bad;
                assert_eq!(fmi2SetContinuousStates(c, y.as_ptr(), 13), fmi2Error);
                assert!(
                    capture
                        .last()
                        .message
                        .contains(&format!("x[{i}] = {bad:?}")),
                    "{:?}",
                    capture.last()
                );
                let mut back = [0.0; 13];
                assert_eq!(fmi2GetContinuousStates(c, back.as_mut_ptr(), 13), fmi2OK);
                assert_eq!(back.map(f64::to_bits), x.map(f64::to_bits));
            }
        }
        // A zero quaternion (x[3..7]) has no orientation.
        let mut y = x;
        y[3..7].fill(0.0);
        assert_eq!(fmi2SetContinuousStates(c, y.as_ptr(), 13), fmi2Error);
        assert!(
            capture.last().message.contains("quaternion"),
            "{:?}",
            capture.last()
        );
        // A valid call works from there.
        assert_eq!(fmi2SetTime(c, 0.001), fmi2OK);
        let mut dx = [0.0; 13];
        assert_eq!(fmi2GetDerivatives(c, dx.as_mut_ptr(), 13), fmi2OK);
        assert!(
            (dx[9] + 9.81).abs() < 1e-9,
            "free fall: vz' = -g, got {}",
            dx[9]
        );
        fmi2FreeInstance(c);
    }
}

/// Divergence: an explicit integrator on contact far too stiff for its internal step (k = 1e9
/// N/m on 1 kg: ω = 3.2e4 rad/s, h ω = 32 at the scene's 1 ms step) makes the energy explode;
/// `fmi2DoStep` returns `fmi2Discard`, names the quantity and the time, keeps the state at the
/// start of the step bit for bit (`fmi2LastSuccessfulTime` says where), answers
/// `fmi2Terminated = true`, and a retry with communication steps short enough for the
/// stiffness (10 µs: h ω = 0.32) succeeds from there and clears the flag.
#[test]
fn a_diverging_step_is_discarded_and_a_smaller_retry_continues() {
    let res = host::resources("sphere_drop");
    let sim = scm::sim::Simulation::from_file(&crate::common::scene("sphere_drop")).unwrap();
    let vr = |name: &str| sim.rows().iter().position(|(v, _)| v.name == name).unwrap() as u32;
    let (z, vz, k) = (vr("ball.pos.z"), vr("ball.linvel.z"), vr("scm.stiffness"));
    let n = sim.rows().len() as u32;
    let capture = Capture::default();
    let callbacks = host::callbacks(&capture);
    unsafe {
        let c = host::instantiate(&res, fmi2CoSimulation, &callbacks);
        // Resting on the plane (r = 5 cm), moving down at 1 m/s.
        assert_eq!(fmi2SetReal(c, &z, 1, &0.0505), fmi2OK);
        assert_eq!(fmi2SetReal(c, &vz, 1, &-1.0), fmi2OK);
        assert_eq!(fmi2EnterInitializationMode(c), fmi2OK);
        assert_eq!(fmi2ExitInitializationMode(c), fmi2OK);
        assert_eq!(fmi2DoStep(c, 0.0, 1e-4, 1), fmi2OK);
        assert_eq!(fmi2SetReal(c, &k, 1, &1e9), fmi2OK);
        let before = all(c, n);
        let t0 = 1e-4;
        assert_eq!(
            fmi2DoStep(c, t0, 0.01, 1),
            fmi2Discard,
            "{:?}",
            capture.last()
        );
        let msg = capture.last();
        assert_eq!(msg.status, fmi2Discard);
        assert!(
            msg.message.contains("energy") || msg.message.contains("non-finite"),
            "{msg:?}"
        );
        assert!(msg.message.contains(&format!("t = {t0}")), "{msg:?}");
        assert_eq!(all(c, n), before, "a discarded step changed the state");
        let (mut last, mut terminated) = (0.0, fmi2False);
        assert_eq!(
            fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &mut last),
            fmi2OK
        );
        assert_eq!(last, t0);
        assert_eq!(
            fmi2GetBooleanStatus(c, fmi2Terminated, &mut terminated),
            fmi2OK
        );
        assert_eq!(terminated, fmi2True);
        // Retry with short steps: the sphere is stopped by the stiff contact without blowing up.
        let h = 1e-5;
        let mut zmin = f64::INFINITY;
        for i in 0..300 {
            let s = fmi2DoStep(c, t0 + i as f64 * h, h, 1);
            assert_eq!(s, fmi2OK, "retry step {i}: {:?}", capture.last());
            let mut x = 0.0;
            assert_eq!(fmi2GetReal(c, &z, 1, &mut x), fmi2OK);
            zmin = zmin.min(x);
            assert!(x.is_finite() && x < 0.06, "z = {x}");
        }
        assert_eq!(
            fmi2GetBooleanStatus(c, fmi2Terminated, &mut terminated),
            fmi2OK
        );
        assert_eq!(terminated, fmi2False);
        // k = 1e9 N/m stops 1 m/s on 1 kg within about v/ω = 32 µm (plus the softplus offset).
        assert!(zmin > 0.0505 - 0.002, "penetrated to z = {zmin}");
        fmi2FreeInstance(c);
    }
}
