//! Cost of one step, of the same step through the C ABI, and of the full Jacobian of a step,
//! for the report (`scripts/report/`), measured in one run and printed as JSON.
//!
//! ```text
//! step_cost FMU_DIR --h S [--integrators a,b|all] [--set NAME=VALUE]... [--warmup S]
//!           [--budget S] [--steps-only [--error T]] [--profile step|jacobian|ffi --iterations N]
//! ```
//! `FMU_DIR` is an unpacked FMU. The state at which everything is measured is reached by
//! simulating `--warmup` seconds from the start with the `--set` values (e.g. a constant finger
//! target that presses the finger into the T), so contact is active. Per integrator:
//! - `model_step_s`: `Model::step::<f64>`, one internal step of `h` (the bare method);
//! - `engine_step_s`: `Simulation::advance(h)` with `solver.step = h` (one internal step, with
//!   the non-finite check and state bookkeeping the FMU does), from the same state as the FFI
//!   step (its whole state, solver cache included, restored before each timed step);
//! - `ffi_step_s`: `fmi2DoStep(h)` through the crate's exported `extern "C"` function (the
//!   same code path a host calling `scm.so` runs), `solver.step = h`, each timed step restored
//!   to the instance's state a few steps after the warm-up (so what a running simulation
//!   carries from step to step, the implicit methods' Newton Jacobian, is there);
//! - `jacobian_*_s`: the full Jacobian of one step `x' = step(x, u)`, `x = (q, v)`, `u` the
//!   controls, with forward-mode dual numbers through the generic `Model::step`: `dual64`
//!   (n = nq + nv + nu passes of `Dual64`), `dualvec4` (`DualSVec64<4>`, ⌈n/4⌉ passes),
//!   `dualvec16` (`DualSVec64<16>`, one pass for n ≤ 16);
//! - `jacobian_crate_s`: the same Jacobian through the crate's API,
//!   `derivatives::step_jacobian_state` (one dual pass of width 16 for up to 16 inputs), and
//!   `crate_vs_dual64_rel`, its agreement with the `Dual64` columns;
//! - `fd_s`: central finite differences of the same map, 2n + 1 steps;
//! - accuracy: `jacobian_vs_fd_rel` = max |J_dual − J_fd| / max |J_dual| at the relative FD step
//!   of 1e-4 … 1e-8 that agrees best (`fd_rel_step`; `fd_s` is timed at 1e-6),
//!   and `dualvec_vs_dual64` (should be rounding only).
//!
//! With `--steps-only`, only `model_step_s` and `ffi_step_s` are measured (the benchmark
//! against MuJoCo, `scripts/bench.sh`), and with `--error T` the accuracy of the run:
//! `error_pos_m` and `error_rot_rad`, the largest error of a body's position and orientation
//! after `T` s from the warmed-up state at `--h`, against `rk4` at `h / 16` from the same state
//! (`reference_divisions`), and `reference_check_*`, the same difference between `rk4` at
//! `h / 8` and at `h / 16` (the reference's own error is about a fifteenth of it). A run that the
//! integrator refuses (its energy guard catching a blow-up) has `error_refused`, the refusal's
//! message, in place of the two errors; its timings stand. `model_step_s`
//! is timed at the warmed-up state without a solver cache (no carried Newton Jacobian), the
//! FFI step a few steps later with one.
//!
//! Times are medians over 9 interleaved rounds (one batch of every quantity per round, about
//! `--budget` seconds per quantity in all), so a change of load hits all quantities alike. `--profile` runs one
//! quantity `--iterations` times and prints nothing else, for callgrind: `step` the bare method
//! from the warmed-up state, `jacobian` its `Dual64` Jacobian, `ffi` consecutive `fmi2DoStep`
//! calls of the instance (a running simulation).
//!

use nalgebra::{Const, U1};
use num_dual::{Derivative, Dual64, DualSVec64};
use scm::contact::ContactParams;
use scm::derivatives::{step_jacobian_state, Coordinates, Point};
use scm::fmi::contract::FmiModel;
use scm::fmi::ffi::*;
use scm::integrate::{Integrator, State};
use scm::model::Model;
use scm::scalar::Scalar;
use scm::sim::{SimState, Simulation, Slot, Value};
use scm::*;
use std::hint::black_box;
use std::path::PathBuf;

#[path = "support/host.rs"]
mod host;
#[path = "support/json.rs"]
mod json;
use json::json_str;
#[path = "support/timing.rs"]
mod timing;
use timing::time_interleaved;

struct Args {
    dir: PathBuf,
    h: f64,
    integrators: Vec<Integrator>,
    sets: Vec<(String, f64)>,
    warmup: f64,
    budget: f64,
    profile: Option<(String, usize)>,
    /// Time the steps only (no Jacobians, no finite differences): `--steps-only`.
    steps_only: bool,
    /// `--error T`: also the pose error after `T` s against a converged reference.
    error: Option<f64>,
}

fn parse() -> Result<Args, String> {
    let raw: Vec<String> = std::env::args().skip(1).collect();
    let dir = PathBuf::from(raw.first().ok_or("usage: step_cost FMU_DIR --h S [--integrators a,b|all] [--set N=V]... [--warmup S] [--budget S] [--profile step|jacobian --iterations N]")?);
    let mut a = Args {
        dir,
        h: 0.002,
        integrators: Integrator::ALL.to_vec(),
        sets: vec![],
        warmup: 0.0,
        budget: 0.3,
        profile: None,
        steps_only: false,
        error: None,
    };
    let mut iterations = 100;
    let mut profile = None;
    let mut it = raw[1..].iter();
    let num = |s: &str| s.parse::<f64>().map_err(|_| format!("not a number: {s}"));
    while let Some(flag) = it.next() {
        if flag == "--steps-only" {
            a.steps_only = true;
            continue;
        }
        let v = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--h" => a.h = num(v)?,
            "--warmup" => a.warmup = num(v)?,
            "--budget" => a.budget = num(v)?,
            "--error" => a.error = Some(num(v)?),
            "--iterations" => iterations = num(v)? as usize,
            "--profile" => profile = Some(v.clone()),
            "--set" => {
                let (n, x) = v
                    .split_once('=')
                    .ok_or_else(|| format!("expected NAME=VALUE, got {v}"))?;
                a.sets.push((n.to_string(), num(x)?));
            }
            "--integrators" if v == "all" => {}
            "--integrators" => {
                a.integrators = v
                    .split(',')
                    .map(|n| {
                        Integrator::from_name(n).ok_or_else(|| format!("unknown integrator {n}"))
                    })
                    .collect::<Result<_, _>>()?
            }
            other => return Err(format!("unknown option {other}")),
        }
    }
    if a.error.is_some() && !a.steps_only {
        return Err("--error is measured with --steps-only only".into());
    }
    a.profile = profile.map(|p| (p, iterations));
    Ok(a)
}

/// The state reached by simulating the warm-up from the start with the `--set` values (with the
/// scene's own integrator at 1 ms internal steps, so every integrator is measured at the same
/// state). Done once per run: on a large model (gymnasium's humanoid) it is most of the run.
fn warm_state(a: &Args, scene: &std::path::Path) -> Result<SimState, String> {
    let mut sim = started(a, scene)?;
    sim.model.timestep = 1e-3;
    let n = (a.warmup / 0.01).round() as usize;
    for _ in 0..n {
        sim.advance(0.01).map_err(|e| format!("warm-up: {e}"))?;
    }
    Ok(sim.data.current)
}

/// The scene's simulation with the `--set` values applied, initialized.
fn started(a: &Args, scene: &std::path::Path) -> Result<Simulation, String> {
    let mut sim = Simulation::from_file(scene).map_err(|e| e.to_string())?;
    for (name, value) in &a.sets {
        sim.set(name, Value::Real(*value))?;
    }
    sim.initialize()?;
    Ok(sim)
}

/// The scene's simulation at the warmed-up state `warm`, switched to `integrator` with internal
/// step `h` (s).
fn simulation_at(
    a: &Args,
    scene: &std::path::Path,
    warm: &SimState,
    integrator: Integrator,
    h: f64,
) -> Result<Simulation, String> {
    let mut sim = started(a, scene)?;
    sim.data.current = warm.clone();
    sim.model.integrator = integrator;
    sim.model.timestep = h;
    Ok(sim)
}

/// How the library words the refusal of a blow-up (`integrate::StepFailure`: the energy
/// guard's, and a state gone non-finite): the failures of an `--error` run that are reported
/// as refused rather than stopping the measurement.
const BLOW_UPS: [&str; 2] = ["the integration is unstable", "the state diverged"];

/// The reference of `--error`: classic Runge–Kutta at `h / REFERENCE_DIVISIONS`. Converged
/// there: on `t_push` while pushing, `rk4` at 2 ms and at 1/8 ms end 0.2 s apart by 2e-12 m,
/// and a fourth-order method's error shrinks 65536-fold from there.
const REFERENCE_DIVISIONS: f64 = 16.0;

/// The poses of every body (world frames) after `t` s from the warmed-up state with
/// `integrator` at internal step `h`, in communication steps of `--h` (so the inputs, constant
/// controls and mocap paths, are the same for every run).
fn poses_after(
    a: &Args,
    scene: &std::path::Path,
    warm: &SimState,
    integrator: Integrator,
    h: f64,
    t: f64,
) -> Result<Vec<scm::collision::Frame<f64>>, String> {
    let mut sim = simulation_at(a, scene, warm, integrator, h)?;
    for _ in 0..(t / a.h).round() as usize {
        sim.advance(a.h)
            .map_err(|e| format!("--error run ({}, h = {h} s): {e}", integrator.name()))?;
    }
    Ok(sim
        .model
        .tree
        .kinematics(&sim.data.current.state.q, &sim.data.current.state.v)
        .frames)
}

/// The largest difference of a body's pose between two sets of poses: (position of the body's
/// origin (m), rotation angle (rad)).
fn pose_error(
    ours: &[scm::collision::Frame<f64>],
    reference: &[scm::collision::Frame<f64>],
) -> (f64, f64) {
    ours.iter()
        .zip(reference)
        .fold((0.0f64, 0.0f64), |(p, r), (x, y)| {
            // The angle of the relative rotation D from its sine and cosine (|axial(D - Dᵀ)| =
            // 2 sin θ, tr D - 1 = 2 cos θ): exact down to small angles, where acos loses them.
            let d = x.rotation.transpose() * y.rotation;
            let axial = nalgebra::Vector3::new(
                d[(2, 1)] - d[(1, 2)],
                d[(0, 2)] - d[(2, 0)],
                d[(1, 0)] - d[(0, 1)],
            );
            let angle = axial.norm().atan2(d.trace() - 1.0);
            (p.max((x.origin - y.origin).norm()), r.max(angle))
        })
}

/// The step map `x' = step(x, u)` on a flat vector `[q, v, u]` → `[q', v']`.
fn step_map<T: Scalar>(
    model: &Model,
    prm: &ContactParams<f64>,
    h: f64,
    nq: usize,
    nv: usize,
    x: &[T],
) -> Vec<T> {
    let state = State::new(x[..nq].to_vec(), x[nq..nq + nv].to_vec());
    let next = model
        .step(&state, &x[nq + nv..], &prm.lift::<T>(), T::from(h))
        .expect("step");
    next.q.into_iter().chain(next.v).collect()
}

/// Jacobian (rows: outputs, columns: inputs) with `Dual64`, one column per pass.
// `j` is a column index: it indexes the inner vectors, which clippy does not see.
#[allow(clippy::needless_range_loop)]
fn jacobian_dual64(
    model: &Model,
    prm: &ContactParams<f64>,
    h: f64,
    nq: usize,
    nv: usize,
    x: &[f64],
) -> Vec<Vec<f64>> {
    let n = x.len();
    let mut jac = vec![vec![0.0; n]; nq + nv];
    for j in 0..n {
        let xd: Vec<Dual64> = x
            .iter()
            .enumerate()
            .map(|(i, &xi)| Dual64::new(xi, if i == j { 1.0 } else { 0.0 }))
            .collect();
        for (r, y) in step_map(model, prm, h, nq, nv, &xd).iter().enumerate() {
            jac[r][j] = y.eps;
        }
    }
    jac
}

/// Jacobian with `DualSVec64<N>`: N columns per pass.
fn jacobian_vec<const N: usize>(
    model: &Model,
    prm: &ContactParams<f64>,
    h: f64,
    nq: usize,
    nv: usize,
    x: &[f64],
) -> Vec<Vec<f64>> {
    let n = x.len();
    let mut jac = vec![vec![0.0; n]; nq + nv];
    for first in (0..n).step_by(N) {
        let xd: Vec<DualSVec64<N>> = x
            .iter()
            .enumerate()
            .map(|(i, &xi)| {
                if i >= first && i < first + N {
                    let mut e = nalgebra::SVector::<f64, N>::zeros();
                    e[i - first] = 1.0;
                    DualSVec64::new(xi, Derivative::some(e))
                } else {
                    DualSVec64::from_re(xi)
                }
            })
            .collect();
        for (r, y) in step_map(model, prm, h, nq, nv, &xd).into_iter().enumerate() {
            let d = y.eps.unwrap_generic(Const::<N>, U1);
            for k in 0..N.min(n - first) {
                jac[r][first + k] = d[k];
            }
        }
    }
    jac
}

/// Central finite differences with relative step `rel`: 2n + 1 steps.
fn jacobian_fd(
    model: &Model,
    prm: &ContactParams<f64>,
    h: f64,
    nq: usize,
    nv: usize,
    x: &[f64],
    rel: f64,
) -> Vec<Vec<f64>> {
    let n = x.len();
    let _nominal = step_map::<f64>(model, prm, h, nq, nv, x);
    let mut jac = vec![vec![0.0; n]; nq + nv];
    let mut xp = x.to_vec();
    for j in 0..n {
        let d = rel * x[j].abs().max(1.0);
        xp[j] = x[j] + d;
        let yp = step_map::<f64>(model, prm, h, nq, nv, &xp);
        xp[j] = x[j] - d;
        let ym = step_map::<f64>(model, prm, h, nq, nv, &xp);
        xp[j] = x[j];
        for r in 0..nq + nv {
            jac[r][j] = (yp[r] - ym[r]) / (2.0 * d);
        }
    }
    jac
}

/// Steps an instance takes from the warmed-up state before the state the FFI timing restores is
/// saved.
const FMU_WARM_STEPS: usize = 3;

/// Relative steps of the central differences the accuracy is checked with.
const FD_STEPS: [f64; 5] = [1e-4, 1e-5, 1e-6, 1e-7, 1e-8];

fn max_abs(j: &[Vec<f64>]) -> f64 {
    j.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn max_diff(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// The part a profiler looks at (`valgrind --tool=callgrind --toggle-collect='*profiled_section*'`):
/// `iterations` steps or Jacobians from the warmed-up state, nothing else.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn profiled_section(
    what: &str,
    iterations: usize,
    model: &Model,
    state: &State<f64>,
    ctrl: &[f64],
    prm: &ContactParams<f64>,
    h: f64,
    nq: usize,
    nv: usize,
    x: &[f64],
) -> Result<(), String> {
    for _ in 0..iterations {
        match what {
            "step" => {
                black_box(model.step(state, ctrl, prm, h).map_err(|e| e.to_string())?);
            }
            "jacobian" => {
                black_box(jacobian_dual64(model, prm, h, nq, nv, x));
            }
            other => return Err(format!("unknown --profile {other} (step, jacobian or ffi)")),
        }
    }
    Ok(())
}

/// What a profiler looks at for `--profile ffi`: `iterations` consecutive `fmi2DoStep` calls
/// of the instance from the warmed-up state (a running simulation, with what it keeps from
/// step to step).
#[inline(never)]
fn profiled_section_ffi(
    fmu: &host::Instance,
    t0: f64,
    h: f64,
    iterations: usize,
) -> Result<(), String> {
    let mut t = t0;
    for _ in 0..iterations {
        host::check(fmu.do_step(t, h), "fmi2DoStep")?;
        t += h;
    }
    Ok(())
}

fn main() {
    match run() {
        Ok(json) => println!("{json}"),
        Err(e) => {
            eprintln!("step_cost: {e}");
            std::process::exit(2);
        }
    }
}

fn run() -> Result<String, String> {
    let a = parse()?;
    let scene = a.dir.join("resources").join(scm::sim::SCENE_FILE);
    let mut items = Vec::new();
    let warm = warm_state(&a, &scene)?;
    // The `--error` reference, computed once for all integrators, and how far the same
    // reference at twice its step is from it (its own error is about a fifteenth of that).
    let (reference, reference_check) = match a.error {
        Some(t) => {
            let at = |divisions: f64| {
                poses_after(&a, &scene, &warm, Integrator::Rk4, a.h / divisions, t)
            };
            let reference = at(REFERENCE_DIVISIONS)?;
            let check = pose_error(&at(REFERENCE_DIVISIONS / 2.0)?, &reference);
            (Some(reference), check)
        }
        None => (None, (0.0, 0.0)),
    };
    for &integrator in &a.integrators {
        let sim0 = simulation_at(&a, &scene, &warm, integrator, a.h)?;
        let model = sim0.model.clone();
        let prm = sim0.data.current.params;
        let (nq, nv) = (model.tree.nq, model.tree.nv);
        let x: Vec<f64> = sim0
            .data
            .current
            .state
            .q
            .iter()
            .chain(&sim0.data.current.state.v)
            .chain(&sim0.data.current.ctrl)
            .copied()
            .collect();
        let state = sim0.data.current.state.clone();
        let ctrl = sim0.data.current.ctrl.clone();
        let h = a.h;

        // Through the C ABI: a fresh instance whose start values are the warmed-up state and
        // controls, with solver.step = h, so one fmi2DoStep(h) is one internal step of h.
        let fmu = host::Instance::new(&a.dir.join("resources"), fmi2CoSimulation, host::quiet())?;
        let (mut vrs, mut starts) = (Vec::new(), Vec::new());
        let (mut vr_step, mut vr_int) = (None, None);
        for (var, slot) in sim0.rows() {
            let start = match *slot {
                Slot::Q(i) => state.q[i],
                Slot::V(i) => state.v[i],
                Slot::Ctrl(i) => ctrl[i],
                Slot::Param(p) => p.get(&prm),
                Slot::SolverStep => {
                    vr_step = Some(var.value_reference);
                    continue;
                }
                Slot::SolverIntegrator => {
                    vr_int = Some(var.value_reference);
                    continue;
                }
                _ => continue,
            };
            vrs.push(var.value_reference);
            starts.push(start);
        }
        fmu.setup(None)?;
        fmu.set_real(&vrs, &starts)?;
        fmu.set_string(vr_int.ok_or("no solver.integrator")?, integrator.name())?;
        fmu.set_real(&[vr_step.ok_or("no solver.step")?], &[h])?;
        fmu.initialize()?;
        // A few steps before the state is saved, so the instance carries what a running
        // simulation carries from step to step (the implicit methods' Newton Jacobian, in the
        // saved FMU state too): each timed fmi2DoStep is a step in a running simulation.
        // An explicit method that blows up from the warm-up state (gymnasium's ant landing,
        // semi-implicit Euler at 2 ms) is refused by the energy guard within these steps: the
        // timed step is then the last accepted one, from the state before it (its FMU state
        // saved), and the engine takes as many steps.
        let c = fmu.raw();
        let mut t_saved = 0.0;
        let mut warm_steps = FMU_WARM_STEPS;
        let mut before: Vec<fmi2FMUstate> = Vec::new();
        for k in 0..FMU_WARM_STEPS {
            let mut s: fmi2FMUstate = std::ptr::null_mut();
            // SAFETY: `c` is a live instance; `s` receives a state the FMU allocates.
            if unsafe { fmi2GetFMUstate(c, &mut s) } != fmi2OK {
                return Err("fmi2GetFMUstate (warm-up) failed".into());
            }
            before.push(s);
            let status = fmu.do_step(t_saved, h);
            if status == fmi2Discard && k > 0 {
                // SAFETY: a state this instance saved, before the last accepted step.
                if unsafe { fmi2SetFMUstate(c, before[k - 1]) } != fmi2OK {
                    return Err("fmi2SetFMUstate (warm-up) failed".into());
                }
                t_saved -= h;
                warm_steps = k - 1;
                break;
            }
            host::check(status, "fmi2DoStep (warm-up)")?;
            t_saved += h;
        }
        for mut s in before {
            // SAFETY: states this instance saved, freed once.
            unsafe { fmi2FreeFMUstate(c, &mut s) };
        }

        if let Some(("ffi", iterations)) = a.profile.as_ref().map(|(w, n)| (w.as_str(), *n)) {
            profiled_section_ffi(&fmu, t_saved, h, iterations)?;
            return Ok(format!(
                "{{\"profiled\": \"ffi\", \"iterations\": {iterations}}}"
            ));
        }
        if let Some((what, iterations)) = &a.profile {
            profiled_section(
                what,
                *iterations,
                &model,
                &state,
                &ctrl,
                &prm,
                h,
                nq,
                nv,
                &x,
            )?;
            return Ok(format!(
                "{{\"profiled\": \"{what}\", \"iterations\": {iterations}}}"
            ));
        }

        // The engine's simulation, a few steps on like the instance, its whole state (the
        // solver cache with it) saved to be restored before each timed step.
        let mut sim = simulation_at(&a, &scene, &warm, integrator, a.h)?;
        for _ in 0..warm_steps {
            sim.advance(h)
                .map_err(|e| format!("engine warm-up step: {e}"))?;
        }
        let saved = sim.get_state().map_err(|e| e.to_string())?;
        // Two timed closures use it (the restore alone, and the restore with a step).
        let sim = std::cell::RefCell::new(sim);
        // FFI: fmi2DoStep advances the instance; to time the same step each time, restore its
        // state with fmi2SetFMUstate (itself timed and subtracted).
        let mut fmu_state: fmi2FMUstate = std::ptr::null_mut();
        unsafe {
            if fmi2GetFMUstate(c, &mut fmu_state) != fmi2OK {
                return Err("fmi2GetFMUstate failed".into());
            }
        }
        if a.steps_only {
            let times = time_interleaved(
                a.budget * 3.0,
                &mut [
                    &mut || {
                        black_box(model.step(black_box(&state), &ctrl, &prm, h).expect("step"));
                    },
                    &mut || unsafe {
                        assert_eq!(fmi2SetFMUstate(c, fmu_state), fmi2OK);
                    },
                    &mut || unsafe {
                        assert_eq!(fmi2SetFMUstate(c, fmu_state), fmi2OK);
                        let s = fmi2DoStep(c, t_saved, h, fmi2True);
                        assert_eq!(s, fmi2OK, "fmi2DoStep");
                    },
                ],
            );
            let [model_step, restore, ffi_with_restore] = times[..] else {
                unreachable!()
            };
            let error = match (a.error, &reference) {
                (Some(t), Some(reference)) => {
                    let (check_pos, check_rot) = reference_check;
                    let common = format!(
                        ", \"error_t_s\": {t:e}, \"reference_divisions\": {REFERENCE_DIVISIONS}, \
                         \"reference_check_pos_m\": {check_pos:e}, \"reference_check_rot_rad\": {check_rot:e}"
                    );
                    // A run the integrator refuses as a blow-up (its energy guard, or a state
                    // gone non-finite) has no error: the refusal is reported in its place, and
                    // the timings stand. Any other failure stops the measurement.
                    match poses_after(&a, &scene, &warm, integrator, a.h, t) {
                        Ok(ours) => {
                            let (pos, rot) = pose_error(&ours, reference);
                            format!(
                                "{common}, \"error_pos_m\": {pos:e}, \"error_rot_rad\": {rot:e}"
                            )
                        }
                        Err(e) if BLOW_UPS.iter().any(|b| e.contains(b)) => {
                            format!("{common}, \"error_refused\": {}", json_str(&e))
                        }
                        Err(e) => return Err(e),
                    }
                }
                _ => String::new(),
            };
            unsafe {
                fmi2FreeFMUstate(c, &mut fmu_state);
            }
            items.push(format!(
                "{{\"integrator\": \"{}\", \"h\": {h:e}, \"model_step_s\": {model_step:e}, \"ffi_step_s\": {:e}, \"ffi_restore_s\": {restore:e}{error}}}",
                integrator.name(),
                (ffi_with_restore - restore).max(0.0)
            ));
            continue;
        }
        let j64 = jacobian_dual64(&model, &prm, h, nq, nv, &x);
        let j4 = jacobian_vec::<4>(&model, &prm, h, nq, nv, &x);
        let j16 = jacobian_vec::<16>(&model, &prm, h, nq, nv, &x);
        // The crate's own API (what a user calls): `derivatives::step_jacobian_state`, the same
        // map in embedded coordinates, its columns [q, v, u].
        let point = Point {
            q: state.q.clone(),
            v: state.v.clone(),
            u: ctrl.clone(),
            params: prm,
            act: Vec::new(),
        };
        let crate_jacobian = || {
            step_jacobian_state(&model, integrator, &point, h, Coordinates::Embedded)
                .map_err(|e| format!("step_jacobian_state: {e}"))
        };
        let jc = crate_jacobian()?.1.full;
        let jc: Vec<Vec<f64>> = (0..jc.nrows())
            .map(|r| jc.row(r).iter().copied().collect())
            .collect();
        // Accuracy against central differences at the FD step that agrees best: a map with a
        // fast smooth transition (frictionloss below the stiction velocity, the dissipation
        // factor) has a truncation error that only a small step makes small, and rounding takes
        // over below it. The FD column is timed at 1e-6.
        let (fd_err, fd_rel) = FD_STEPS
            .iter()
            .map(|&rel| {
                (
                    max_diff(&j64, &jacobian_fd(&model, &prm, h, nq, nv, &x, rel)),
                    rel,
                )
            })
            .fold(
                (f64::INFINITY, 0.0),
                |best, e| if e.0 < best.0 { e } else { best },
            );
        // Every quantity is timed in interleaved rounds (one batch of each per round), so a
        // change of machine load affects all of them alike and their ratios stay meaningful.
        let times = time_interleaved(
            a.budget * 8.0,
            &mut [
                &mut || {
                    black_box(model.step(black_box(&state), &ctrl, &prm, h).expect("step"));
                },
                &mut || {
                    sim.borrow_mut().set_state(&saved).expect("restore");
                },
                &mut || {
                    // Restart from the same state each time, so every call times the same step.
                    let mut sim = sim.borrow_mut();
                    sim.set_state(&saved).expect("restore");
                    sim.advance(h).expect("step");
                },
                &mut || unsafe {
                    assert_eq!(fmi2SetFMUstate(c, fmu_state), fmi2OK);
                },
                &mut || unsafe {
                    assert_eq!(fmi2SetFMUstate(c, fmu_state), fmi2OK);
                    let s = fmi2DoStep(c, t_saved, h, fmi2True);
                    assert_eq!(s, fmi2OK, "fmi2DoStep");
                },
                &mut || {
                    black_box(jacobian_dual64(&model, &prm, h, nq, nv, black_box(&x)));
                },
                &mut || {
                    black_box(jacobian_vec::<4>(&model, &prm, h, nq, nv, black_box(&x)));
                },
                &mut || {
                    black_box(jacobian_vec::<16>(&model, &prm, h, nq, nv, black_box(&x)));
                },
                &mut || {
                    black_box(jacobian_fd(&model, &prm, h, nq, nv, black_box(&x), 1e-6));
                },
                &mut || {
                    black_box(crate_jacobian().expect("step_jacobian_state"));
                },
            ],
        );
        let [model_step, engine_restore, engine_with_restore, restore, ffi_with_restore, t_j64, t_j4, t_j16, t_fd, t_crate] =
            times[..]
        else {
            unreachable!()
        };
        let engine_step = (engine_with_restore - engine_restore).max(0.0);
        let ffi_step = (ffi_with_restore - restore).max(0.0);
        unsafe {
            fmi2FreeFMUstate(c, &mut fmu_state);
        }
        let scale = max_abs(&j64).max(1e-300);
        let vec_err = max_diff(&j64, &j4).max(max_diff(&j64, &j16)) / scale;
        let crate_err = max_diff(&j64, &jc) / scale;
        let distances: Vec<String> = {
            let kin = model.tree.kinematics(&state.q, &state.v);
            model
                .contacts(&kin, &prm, &[])
                .1
                .iter()
                .map(|p| format!("{:e}", p.distance))
                .collect()
        };
        items.push(format!(
            "{{\"integrator\": \"{}\", \"h\": {h:e}, \"n_inputs\": {}, \"n_outputs\": {}, \"pair_distances\": [{}], \
             \"model_step_s\": {model_step:e}, \"engine_step_s\": {engine_step:e}, \"ffi_step_s\": {ffi_step:e}, \"ffi_restore_s\": {restore:e}, \
             \"jacobian_dual64_s\": {t_j64:e}, \"jacobian_dualvec4_s\": {t_j4:e}, \"jacobian_dualvec16_s\": {t_j16:e}, \"fd_s\": {t_fd:e}, \"jacobian_crate_s\": {t_crate:e}, \"crate_vs_dual64_rel\": {crate_err:e}, \
             \"jacobian_vs_fd_rel\": {:e}, \"fd_rel_step\": {fd_rel:e}, \"dualvec_vs_dual64_rel\": {vec_err:e}, \"jacobian_max_abs\": {scale:e}}}",
            integrator.name(),
            x.len(),
            nq + nv,
            distances.join(", "),
            fd_err / scale,
        ));
    }
    Ok(format!(
        "{{\"scene\": \"{}\", \"results\": [{}]}}",
        scene.display(),
        items.join(", ")
    ))
}
