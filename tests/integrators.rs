//! Integrators: the implicit method on stiff contact (k = 1e6 N/m at h = 16 ms, k = 1e9 N/m at
//! 50 ms) settles at the analytic penetration while the explicit ones are refused as unstable,
//! a non-finite step is refused with the state kept, communication steps land exactly on their
//! end, and each method converges at its order (the adaptive one to its tolerance).

use crate::common::{bisect, static_lift};
use crate::dynamics_tree::model_of;
use scm::collision::Collider;
use scm::fmi::contract::{FmiModel, StepError};
use scm::integrate::{AdvanceOptions, Integrator, State, StepFailure};
use scm::model::{EvalPoint, ForwardOptions, Model, Reuse};
use scm::scalar::softplus;
use scm::sim::Simulation;

/// A 1 kg sphere (r = 5 cm) on a free joint above a plane, with stiffness `k`, `ε3 = 1e-6` m,
/// starting at rest with its lowest point 1 cm above the plane.
fn stiff_sphere(k: f64, step: f64, integrator: &str) -> String {
    format!(
        r#"<mujoco model="stiff_sphere">
  <option timestep="{step}" gravity="0 0 -9.81"/>
  <custom>
    <numeric name="scm_stiffness" data="{k}"/>
    <numeric name="scm_eps1" data="1e-5"/>
    <numeric name="scm_eps2" data="2e-4"/>
    <numeric name="scm_eps3" data="1e-6"/>
    <numeric name="scm_dissipation_velocity" data="0.1"/>
    <numeric name="scm_stiction_velocity" data="0.05"/>
    <numeric name="scm_friction" data="0.5"/>
    <numeric name="scm_spacing" data="0.01"/>
    <text name="scm_integrator" data="{integrator}"/>
  </custom>
  <worldbody>
    <geom name="ground" type="plane" size="1 1 0.1"/>
    <body name="ball" pos="0 0 0.06">
      <freejoint/>
      <geom name="ball" type="sphere" size="0.05" mass="1"/>
    </body>
  </worldbody>
</mujoco>"#
    )
}

/// Resting height of the sphere's centre from the static balance over its own AOPC, and the
/// analytic point-contact penetration `m g = k s⁺_ε3(-φ)`.
fn equilibrium(model: &Model) -> (f64, f64) {
    let prm = model.contact;
    let Some(Collider::Aopc(aopc)) = &model.colliders[1] else {
        panic!("the ball has an AOPC")
    };
    let lift = |z: f64| static_lift(aopc, &prm, z);
    let z = bisect(|z| 9.81 - lift(z), 0.0, 0.1);
    let phi = bisect(
        |phi| 9.81 - prm.stiffness * softplus(-phi, prm.eps3),
        -0.05,
        0.05,
    );
    (z, phi)
}

/// Runs `duration` in communication steps of `h`, returning the first refusal.
fn run(
    sim: &mut Simulation,
    h: f64,
    duration: f64,
    mut each: impl FnMut(&Simulation),
) -> Result<(), (f64, String)> {
    let n = (duration / h).round() as usize;
    for k in 0..n {
        let t = k as f64 * h;
        match sim.do_step(t, h) {
            Ok(()) => each(sim),
            Err(StepError::Discard(m)) | Err(StepError::Error(m)) => return Err((t, m)),
        }
    }
    Ok(())
}

#[test]
fn stiff_contact_implicit_settles_and_explicit_are_refused() {
    let h = 0.016;
    // k = 1e6 N/m on 1 kg: ω = 1000 rad/s, h ω = 16, far beyond every explicit method's
    // stability limit (2 for semi-implicit Euler, 2.8 for RK4, 0 for Euler).
    let text = stiff_sphere(1e6, h, "implicit_euler");
    let mut sim = Simulation::new(
        scm::scene::load_str(&text, std::path::Path::new("stiff.xml")).unwrap(),
        &text,
    );
    let (z_rest, phi) = equilibrium(&sim.model);
    let (mut zmin, mut zmax) = (f64::INFINITY, f64::NEG_INFINITY);
    run(&mut sim, h, 1.0, |s| {
        zmin = zmin.min(s.data.current.state.q[2]);
        zmax = zmax.max(s.data.current.state.q[2]);
    })
    .unwrap_or_else(|(t, m)| panic!("implicit_euler refused a step at {t}: {m}"));
    let (z, vz) = (sim.data.current.state.q[2], sim.data.current.state.v[2]);
    println!(
        "implicit_euler: z in [{zmin}, {zmax}], rests at {z} (static balance {z_rest}), vz {vz:e}"
    );
    // Bounded: never above the start, never deeper than 1 mm below the rest height (an
    // explicit blow-up would launch it metres high).
    assert!(
        zmax <= 0.06 + 1e-12 && zmin > z_rest - 1e-3,
        "z in [{zmin}, {zmax}]"
    );
    // Settled: the static balance over this AOPC to 1e-9 m, at rest.
    assert!(
        vz.abs() < 1e-8 && (z - z_rest).abs() < 1e-9,
        "z = {z} vs {z_rest}, vz = {vz}"
    );
    // The analytic point contact: four points around the pole share the load (the next ring,
    // 1.9 mm ≈ 9.5 ε2 higher, carries < 0.1 %), so the lowest points sit at φ within 1 %.
    let Some(Collider::Aopc(aopc)) = &sim.model.colliders[1] else {
        unreachable!()
    };
    let lowest = z + aopc
        .points
        .iter()
        .map(|p| p.z)
        .fold(f64::INFINITY, f64::min);
    assert!(
        lowest < 0.0 && (lowest - phi).abs() < 0.01 * phi.abs(),
        "penetration {lowest} vs analytic {phi}"
    );

    for integrator in [
        Integrator::Euler,
        Integrator::SemiImplicitEuler,
        Integrator::Rk4,
    ] {
        let mut sim = Simulation::new(
            scm::scene::load_str(&text, std::path::Path::new("stiff.xml")).unwrap(),
            &text,
        );
        sim.model.integrator = integrator;
        let mut last_good = sim.data.current.clone();
        let refused = run(&mut sim, h, 1.0, |s| last_good = s.data.current.clone());
        let (t, message) = refused.expect_err(&format!("{} was not refused", integrator.name()));
        println!("{}: refused at t = {t}: {message}", integrator.name());
        // The message says what diverged and when; the state is the last good one, finite.
        assert!(
            message.contains("unstable") || message.contains("non-finite"),
            "{message}"
        );
        assert!(message.contains("t = "), "{message}");
        assert_eq!(sim.data.current.state, last_good.state);
        assert!(sim
            .data
            .current
            .state
            .q
            .iter()
            .chain(&sim.data.current.state.v)
            .all(|x| x.is_finite()));
        assert!(t < 0.5, "{}: refused only at {t}", integrator.name());
    }

    // The adaptive method stays stable by taking steps below the stability limit (2.8/ω ≈
    // 3 ms), and settles too.
    let mut sim = Simulation::new(
        scm::scene::load_str(&text, std::path::Path::new("stiff.xml")).unwrap(),
        &text,
    );
    sim.model.integrator = Integrator::Dopri5;
    run(&mut sim, h, 1.0, |_| {})
        .unwrap_or_else(|(t, m)| panic!("dopri5 refused a step at {t}: {m}"));
    assert!(
        (sim.data.current.state.q[2] - z_rest).abs() < 1e-6,
        "dopri5 rests at {}",
        sim.data.current.state.q[2]
    );
}

#[test]
fn implicit_method_holds_k_1e9_at_50_ms() {
    // ω = 31623 rad/s, h ω = 1581.
    let text = stiff_sphere(1e9, 0.05, "implicit_euler");
    let mut sim = Simulation::new(
        scm::scene::load_str(&text, std::path::Path::new("stiff.xml")).unwrap(),
        &text,
    );
    let (z_rest, _) = equilibrium(&sim.model);
    run(&mut sim, 0.05, 1.0, |s| {
        println!(
            "t {} z {:.9e} vz {:.3e}",
            s.data.current.time, s.data.current.state.q[2], s.data.current.state.v[2]
        )
    })
    .unwrap_or_else(|(t, m)| panic!("refused at {t}: {m}"));
    let (z, vz) = (sim.data.current.state.q[2], sim.data.current.state.v[2]);
    assert!(
        vz.abs() < 1e-8 && (z - z_rest).abs() < 1e-9,
        "z = {z} vs {z_rest}, vz = {vz}"
    );
}

#[test]
fn a_non_finite_step_is_refused_and_the_state_kept() {
    // A body spinning at 1e160 rad/s: the gyroscopic term ω × Iω overflows in the first step.
    let text = r#"<mujoco model="spin"><option gravity="0 0 0" timestep="0.001"/>
  <worldbody><body name="top" pos="0 0 1"><freejoint name="top"/><geom type="box" size="0.1 0.05 0.02" mass="1"/></body></worldbody></mujoco>"#;
    for integrator in Integrator::ALL {
        let mut sim = Simulation::new(
            scm::scene::load_str(text, std::path::Path::new("spin.xml")).unwrap(),
            text,
        );
        sim.model.integrator = integrator;
        sim.data.current.state.v[3..6].copy_from_slice(&[1e160, 2e160, -1e160]);
        sim.data.current.time = 0.25;
        let before = sim.data.current.clone();
        let err = sim.do_step(0.25, 0.01).unwrap_err();
        let StepError::Discard(message) = err else {
            panic!("{}: {err:?}", integrator.name())
        };
        println!("{}: {message}", integrator.name());
        assert!(
            message.contains("of joint top") && message.contains("non-finite"),
            "{message}"
        );
        assert!(message.contains("t = 0.25"), "{message}");
        assert_eq!(
            sim.data.current,
            before,
            "{}: the state changed",
            integrator.name()
        );
    }
    // The same through Model::advance: the failure names the quantity and the time.
    let model = model_of(text);
    let mut state = State::new(model.tree.q0(), vec![0.0; 6]);
    state.v[3..6].copy_from_slice(&[1e160, 2e160, -1e160]);
    let opts = AdvanceOptions {
        energy_guard: false,
        ..Default::default()
    };
    match model.advance(&state, &[], &model.contact, 2.0, 0.003, &opts) {
        Err(StepFailure::NonFinite {
            time,
            step,
            quantity,
            ..
        }) => {
            assert_eq!(step, 1);
            assert!(quantity.contains("of joint top"), "{quantity}");
            assert!((time - 2.001).abs() < 1e-12, "{time}");
        }
        other => panic!("{other:?}"),
    }
}

/// A pendulum (hinge, no contact) for convergence studies.
const PENDULUM: &str = r#"<mujoco model="pendulum"><option gravity="0 0 -9.81"/>
  <worldbody><body name="p"><joint name="j" type="hinge" axis="0 1 0"/>
    <inertial pos="0 0 -0.5" mass="1" diaginertia="0.001 0.001 0.001"/></body></worldbody></mujoco>"#;

fn pendulum_after(
    integrator: Integrator,
    step: f64,
    tolerance: f64,
    duration: f64,
) -> (State<f64>, usize) {
    let mut model = model_of(PENDULUM);
    model.integrator = integrator;
    model.timestep = step;
    model.tolerance = tolerance;
    let state = State::new(vec![1.0], vec![0.0]);
    let done = model
        .advance(
            &state,
            &[],
            &model.contact,
            0.0,
            duration,
            &AdvanceOptions::default(),
        )
        .unwrap();
    (done.state, done.steps)
}

#[test]
fn each_method_converges_at_its_order() {
    let (reference, _) = pendulum_after(Integrator::Rk4, 1e-4, 0.0, 2.0);
    let err =
        |s: &State<f64>| (s.q[0] - reference.q[0]).abs() + 0.3 * (s.v[0] - reference.v[0]).abs();
    for (integrator, order) in [
        (Integrator::SemiImplicitEuler, 1.0),
        (Integrator::Euler, 1.0),
        (Integrator::Rk4, 4.0),
        (Integrator::ImplicitEuler, 1.0),
    ] {
        let e: Vec<f64> = [0.004, 0.002, 0.001]
            .iter()
            .map(|&h| err(&pendulum_after(integrator, h, 0.0, 2.0).0))
            .collect();
        let rates: Vec<f64> = e.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
        println!(
            "{}: errors {e:?}, observed orders {rates:?}",
            integrator.name()
        );
        for r in rates {
            assert!(
                (r - order).abs() < 0.25,
                "{}: observed order {r}, expected {order}",
                integrator.name()
            );
        }
    }
    // The adaptive method meets its tolerance: the global error follows it down.
    let mut last = f64::INFINITY;
    for tol in [1e-4, 1e-6, 1e-8] {
        let (s, steps) = pendulum_after(Integrator::Dopri5, 0.1, tol, 2.0);
        let e = err(&s);
        println!("dopri5 tolerance {tol:e}: error {e:e} in {steps} steps");
        assert!(e < 50.0 * tol && e < last, "tolerance {tol}: error {e}");
        last = e;
    }
}

#[test]
fn implicit_euler_damps_resolved_motion_as_its_stability_function_says() {
    // A small swing (0.05 rad) of the pendulum is a linear oscillator with ω² = m g l / I
    // (I = m l² + I_c about the hinge). Implicit Euler multiplies its energy by 1/(1 + (hω)²)
    // per step, and never increases it.
    let model = model_of(PENDULUM);
    let omega = (9.81 * 0.5 / (0.25 + 0.001f64)).sqrt();
    let h = 0.01;
    let mut m = model.clone();
    m.integrator = Integrator::ImplicitEuler;
    m.timestep = h;
    let bottom = model.energy(&[0.0], &[0.0]).total();
    let mut s = State::new(vec![0.05], vec![0.0]);
    let e0 = model.energy(&s.q, &s.v).total() - bottom;
    let mut last = e0;
    for k in 0..500 {
        s = m
            .advance(
                &s,
                &[],
                &m.contact,
                k as f64 * h,
                h,
                &AdvanceOptions::default(),
            )
            .unwrap()
            .state;
        let e = model.energy(&s.q, &s.v).total() - bottom;
        assert!(
            e <= last * (1.0 + 1e-12),
            "energy grew at step {k}: {last} -> {e}"
        );
        last = e;
    }
    let predicted = (1.0 + (h * omega).powi(2)).powi(-500);
    println!(
        "implicit Euler, 500 steps at hω = {}: energy ratio {} (predicted {predicted})",
        h * omega,
        last / e0
    );
    // 2 %: the swing is not exactly linear (sin θ ≈ θ to 4e-4 at 0.05 rad) and the energy
    // oscillates slightly within a period around its decay.
    assert!(
        (last / e0 / predicted - 1.0).abs() < 0.02,
        "{} vs {predicted}",
        last / e0
    );
}

#[test]
fn communication_steps_land_exactly_on_their_end() {
    // Free fall: Runge–Kutta methods of order ≥ 2 integrate the quadratic exactly, and the
    // Euler methods have a closed-form discrete solution, so the end state shows whether the
    // internal steps covered exactly the communication step.
    let text = r#"<mujoco model="fall"><option gravity="0 0 -9.81" timestep="0.003"/>
  <worldbody><body name="b" pos="0 0 10"><freejoint/><geom type="sphere" size="0.1" mass="1"/></body></worldbody></mujoco>"#;
    let steps = [0.01, 0.0137, 0.001, 0.05, 0.0251];
    let g = 9.81;
    for integrator in Integrator::ALL {
        let mut sim = Simulation::new(
            scm::scene::load_str(text, std::path::Path::new("fall.xml")).unwrap(),
            text,
        );
        sim.model.integrator = integrator;
        let (mut t, mut z, mut vz) = (0.0, 10.0, 0.0);
        for &h in &steps {
            sim.do_step(t, h).unwrap();
            t += h;
            // The discrete solution with n = ⌈h / 3 ms⌉ equal internal steps.
            let n = (h / 0.003 * (1.0 - 1e-12)).ceil() as usize;
            let dt = h / n as f64;
            for _ in 0..n {
                match integrator {
                    Integrator::Euler => {
                        z += dt * vz;
                        vz -= g * dt;
                    }
                    Integrator::SemiImplicitEuler
                    | Integrator::DampedEuler
                    | Integrator::ImplicitEuler => {
                        vz -= g * dt;
                        z += dt * vz;
                    }
                    _ => {
                        z += dt * vz - 0.5 * g * dt * dt;
                        vz -= g * dt;
                    }
                }
            }
        }
        let (zs, vs) = (sim.data.current.state.q[2], sim.data.current.state.v[2]);
        assert!(
            (zs - z).abs() < 1e-12 && (vs - vz).abs() < 1e-12,
            "{}: z {zs} vs {z}, vz {vs} vs {vz} at {t}",
            integrator.name()
        );
        assert!((sim.time() - t).abs() < 1e-15);
    }
}

/// Explicit Euler on the pendulum swinging 0.5 rad at `hω = 0.1`: a linear swing gains a
/// factor `1 + (hω)² = 1.01` of its energy per step, too little for any one communication
/// step to look unstable, but it adds up.
fn slowly_growing_pendulum() -> (Model, f64, State<f64>) {
    let mut model = model_of(PENDULUM);
    let omega = (9.81 * 0.5 / (0.25 + 0.001f64)).sqrt();
    model.integrator = Integrator::Euler;
    model.timestep = 0.1 / omega;
    let h = model.timestep;
    (model, h, State::new(vec![0.5], vec![0.0]))
}

#[test]
fn the_energy_guard_adds_up_a_slow_growth_over_communication_steps() {
    let (model, h, s0) = slowly_growing_pendulum();
    let bottom = model.energy(&[0.0], &[0.0]).total();
    let swing = |s: &State<f64>| model.energy(&s.q, &s.v).total() - bottom;
    let e0 = swing(&s0);
    // The guard's floor for 1 kg: raised by 1 mm, moving at 1 cm/s.
    let floor = 9.81e-3 + 0.5e-4;
    let opts = AdvanceOptions::default();
    // One communication step per internal step, the cache (and its ledger) carried along as
    // an FMU does. Every accepted state has `E - E₀ ≤ ½ S + E_floor` with `S`, the largest
    // kinetic energy seen, at most the largest swing energy: so the swing never exceeds
    // 2 (e0 + floor), and at 1 % per step it gets there in about ln(2)/0.01 ≈ 70 steps.
    let mut cache = scm::integrate::SolverCache::default();
    let mut s = s0.clone();
    let mut refused = None;
    for k in 0..200 {
        match model.advance_cached(&s, &[], &model.contact, k as f64 * h, h, &opts, &mut cache) {
            Ok(a) => {
                s = a.state;
                assert!(
                    swing(&s) <= 2.0 * (e0 + floor) * (1.0 + 1e-9),
                    "step {k}: swing energy {} accepted (started at {e0})",
                    swing(&s)
                );
            }
            Err(e @ StepFailure::EnergyGrowth { .. }) => {
                println!(
                    "refused at step {k}, swing energy {e0} -> {}: {e}",
                    swing(&s)
                );
                refused = Some(k);
                break;
            }
            Err(e) => panic!("step {k}: {e}"),
        }
    }
    let k = refused.expect("the slow growth was never refused");
    assert!(
        k > 10 && swing(&s) > 1.5 * e0,
        "refused too early: step {k}, swing {} from {e0}",
        swing(&s)
    );
    // Without the ledger (a fresh cache in every call, as if the host set the state each
    // time) each call judges only itself: a step is refused only once its own growth, 1 % of
    // the swing, exceeds the floor and half the kinetic energy at its start, which happens
    // near a turning point when the swing has grown about five-fold (measured: step 163,
    // 0.60 → 2.6 J, against step 62, 1.08 J, with the ledger).
    let mut s = s0;
    let mut alone = 200;
    for j in 0..200 {
        match model.advance_cached(
            &s,
            &[],
            &model.contact,
            j as f64 * h,
            h,
            &opts,
            &mut Default::default(),
        ) {
            Ok(a) => s = a.state,
            Err(_) => {
                alone = j;
                break;
            }
        }
    }
    println!(
        "without the ledger: refused at step {alone}, swing energy {e0} -> {}",
        swing(&s)
    );
    assert!(
        alone > 2 * k && swing(&s) > 2.0 * (e0 + floor),
        "step {alone}: swing {} from {e0}",
        swing(&s)
    );
}

/// The slowly growing pendulum of [`slowly_growing_pendulum`] beside a damped flywheel (its own
/// body, turning about its centre of mass, so gravity does no work on it) spinning with 100 J
/// at the start: the flywheel's damping spends that in a few steps, then only the pendulum's
/// swing, about 1 J, is left to grow.
#[test]
fn the_energy_guard_judges_a_growth_from_the_least_energy_the_run_fell_to() {
    let (_, h, _) = slowly_growing_pendulum();
    // Damping `b` on a unit inertia: explicit Euler keeps `1 - h b = 1/2` of the spin per step.
    let b = 0.5 / h;
    let text = format!(
        r#"<mujoco model="pendulum_and_flywheel"><option timestep="{h:e}" gravity="0 0 -9.81"/>
  <custom><text name="scm_integrator" data="euler"/></custom>
  <worldbody>
    <body name="p"><joint name="j" type="hinge" axis="0 1 0"/>
      <inertial pos="0 0 -0.5" mass="1" diaginertia="0.001 0.001 0.001"/></body>
    <body name="w" pos="3 0 0"><joint name="spin" type="hinge" axis="0 1 0" damping="{b:e}"/>
      <inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body>
  </worldbody></mujoco>"#
    );
    let model = model_of(&text);
    assert_eq!(model.timestep, h);
    let s0 = State {
        q: vec![0.5, 0.0],
        v: vec![0.0, (200.0f64).sqrt()],
        act: Vec::new(),
    };
    let total = |s: &State<f64>| model.energy(&s.q, &s.v).total();
    let bottom = total(&State {
        q: vec![0.0, 0.0],
        v: vec![0.0, 0.0],
        act: Vec::new(),
    });
    let (e0, swing0) = (total(&s0) - bottom, 9.81 * 0.5 * (1.0 - 0.5f64.cos()));
    assert!((e0 - 100.0 - swing0).abs() < 1e-9, "{e0}");
    let floor = 2.0 * (9.81e-3 + 0.5e-4);
    let opts = AdvanceOptions::default();
    let mut cache = scm::integrate::SolverCache::default();
    let mut s = s0;
    for k in 0..400 {
        match model.advance_cached(&s, &[], &model.contact, k as f64 * h, h, &opts, &mut cache) {
            Ok(a) => s = a.state,
            Err(StepFailure::EnergyGrowth {
                since, from, to, ..
            }) => {
                let spin = 0.5 * s.v[1] * s.v[1];
                let swing = total(&s) - bottom - spin;
                println!(
                    "refused at step {k}: balance restarted at t = {since} s from {} J above \
                     the rest, reached {} J; the swing grew from {swing0} J to {swing} J, the \
                     flywheel keeps {spin} J",
                    from - bottom,
                    to - bottom
                );
                // Restarted once the flywheel's 100 J were spent, not at the start ...
                assert!(
                    since > 0.0 && from - bottom < 2.0 * swing0,
                    "{since} {from}"
                );
                // ... and judged from there: the energy at refusal is a few percent of the
                // first allowance, which would have let it grow about a hundredfold.
                assert!(to - bottom < 0.1 * e0, "{}", to - bottom);
                // The swing's own margin is still the one a growth from the start has
                // (`the_energy_guard_adds_up_a_slow_growth_over_communication_steps`).
                assert!(
                    swing > 1.5 * swing0 && swing <= 2.0 * (from - bottom + floor),
                    "swing {swing} from {swing0}"
                );
                return;
            }
            Err(e) => panic!("step {k}: {e}"),
        }
    }
    panic!(
        "the pendulum's growth from 1 J was never refused: {} J",
        total(&s) - bottom
    );
}

#[test]
fn the_energy_ledger_restarts_when_the_state_or_the_contact_parameters_are_set() {
    let (model, h, s0) = slowly_growing_pendulum();
    let opts = AdvanceOptions::default();
    let mut cache = scm::integrate::SolverCache::default();
    let mut s = s0;
    for k in 0..20 {
        s = model
            .advance_cached(&s, &[], &model.contact, k as f64 * h, h, &opts, &mut cache)
            .unwrap()
            .state;
    }
    let since = |c: &scm::integrate::SolverCache| c.parts().ledger.map(|l| l.since);
    assert_eq!(since(&cache), Some(0.0), "the ledger runs from the start");
    // The state carried on: the ledger goes on.
    let t = 20.0 * h;
    s = model
        .advance_cached(&s, &[], &model.contact, t, h, &opts, &mut cache)
        .unwrap()
        .state;
    assert_eq!(since(&cache), Some(0.0));
    // A host that sets the velocity puts in energy (here 50 J, far above what the ledger
    // allows): the ledger restarts there instead of refusing the step.
    let mut fast = s.clone();
    fast.v[0] = 10.0;
    let t = 21.0 * h;
    s = model
        .advance_cached(&fast, &[], &model.contact, t, h, &opts, &mut cache)
        .unwrap_or_else(|e| panic!("{e}"))
        .state;
    assert_eq!(since(&cache), Some(t));
    // Other contact parameters change the energy stored in contact: a new ledger too.
    let mut prm = model.contact;
    prm.stiffness *= 2.0;
    let t = 22.0 * h;
    model
        .advance_cached(&s, &[], &prm, t, h, &opts, &mut cache)
        .unwrap();
    assert_eq!(since(&cache), Some(t));
    // With the guard off nothing is carried.
    model
        .advance_cached(
            &s,
            &[],
            &prm,
            t,
            h,
            &AdvanceOptions {
                energy_guard: false,
                ..opts
            },
            &mut cache,
        )
        .unwrap();
    assert_eq!(since(&cache), None);
}

/// The guard's estimate of the energy stored in contact at `s` (J), with the model's own
/// contact parameters and no adhesion pull.
fn stored_in_contact(model: &Model, s: &State<f64>) -> f64 {
    let prm = model.contact;
    let kin = model.tree.kinematics(&s.q, &s.v);
    let contacts = model.contact_forces(&kin, &prm, &[]).1;
    scm::integrate::contact_energy(&model.pairs, &contacts, &prm, &[])
}

#[test]
fn implicit_euler_leaves_the_contact_energy_at_its_end_for_the_next_call() {
    // Implicit Euler's guard reads the energy stored in contact at a call's start. Its steps'
    // Newton iterations stop on a step they do not evaluate, so the call leaves the estimate at
    // its last evaluated iterate in the ledger (`EnergyLedger::stored`), one Newton step from
    // the end state, and the next call takes it instead of listing every contact again. The 1 kg
    // sphere of `stiff_sphere` at k = 3e4 N/m dropped from 1 cm and settling, one internal step
    // per call: the estimate left must be the one the contacts at the end state give.
    let model = model_of(&stiff_sphere(3e4, 2e-3, "implicit_euler"));
    assert_eq!(model.integrator, Integrator::ImplicitEuler);
    let (h, prm) = (model.timestep, model.contact);
    let stored = |s: &State<f64>| stored_in_contact(&model, s);
    let mut s = State {
        q: vec![0.0, 0.0, 0.06, 1.0, 0.0, 0.0, 0.0],
        v: vec![0.0; 6],
        act: Vec::new(),
    };
    let mut cache = scm::integrate::SolverCache::default();
    let opts = AdvanceOptions::default();
    let (mut in_contact, mut worst) = (0, 0.0f64);
    for k in 0..150 {
        s = model
            .advance_cached(&s, &[], &prm, k as f64 * h, h, &opts, &mut cache)
            .unwrap_or_else(|e| panic!("step {k}: {e}"))
            .state;
        let ledger = cache.parts().ledger.expect("the ledger is kept");
        let left = ledger
            .stored
            .expect("implicit Euler leaves its contact energy");
        let exact = stored(&s);
        // The last iterate is one Newton step from the end state: a step within the tolerance
        // (1e-10 of the velocities), or, where the iterations contract fast, up to
        // (1 - θ)/θ times it (the stopping rule bounds the distance to the solution, not the
        // step). That moves the pair's damping force by F Δv / v_d (v_d = 0.1 m/s) and the
        // estimate `ε3 F + F²/2k` by twice that relatively: measured 2e-7 at most on this run,
        // so the bound is a measured one with a margin of 5, not derived.
        let error = (left - exact).abs() / exact.max(1e-12);
        assert!(
            error <= 1e-6,
            "step {k}: {left} J left, {exact} J at the end state"
        );
        if exact > 1e-9 {
            in_contact += 1;
            worst = worst.max(error);
        }
    }
    println!("{in_contact} calls in contact, largest relative difference {worst:.2e}");
    assert!(
        in_contact > 100,
        "the sphere rests: {in_contact} calls in contact"
    );
    // Calls of three internal steps, the sphere pushed down into the floor at 0.2 m/s (the
    // energy stored in contact changes by tens of percent within a call): the estimate left is
    // the last step's.
    s.v[2] = -0.2;
    for k in 0..10 {
        let t = (150 + 3 * k) as f64 * h;
        s = model
            .advance_cached(&s, &[], &prm, t, 3.0 * h, &opts, &mut cache)
            .unwrap()
            .state;
        let left = cache.parts().ledger.and_then(|l| l.stored).unwrap();
        let exact = stored(&s);
        assert!(
            (left - exact).abs() <= 1e-6 * exact,
            "call {k} of 3 steps: {left} J left, {exact} J at its end"
        );
    }
    let t_end = 180.0 * h;

    // A ledger left at another state restarts at this one: its start then lists the contacts
    // here, and its reference counts their energy (`E₀ + U₀`).
    let mut elsewhere = cache.parts();
    elsewhere.ledger.as_mut().unwrap().at.q[2] = 0.3;
    let mut restarted = scm::integrate::SolverCache::from_parts(elsewhere);
    model
        .advance_cached(&s, &[], &prm, t_end, h, &opts, &mut restarted)
        .unwrap();
    let ledger = restarted.parts().ledger.unwrap();
    let (e0, u0) = (model.energy(&s.q, &s.v).total(), stored(&s));
    assert!(u0 > 1e-4, "in contact: {u0} J stored");
    assert_eq!(ledger.since, t_end, "a new ledger");
    assert!(
        (ledger.reference - (e0 + u0)).abs() <= 1e-12 * (e0.abs() + u0),
        "reference {} J against E {e0} J + U {u0} J",
        ledger.reference
    );

    // The next call reads it: a ledger that says far more is stored at its state raises the
    // energy in motion the guard allows for (`S`, up to the headroom the state has), where
    // the honest one leaves it as the run made it.
    let scale_after = |stored: f64| {
        let mut parts = cache.parts();
        let ledger = parts.ledger.as_mut().unwrap();
        ledger.stored = Some(stored);
        let mut forged = scm::integrate::SolverCache::from_parts(parts);
        model
            .advance_cached(&s, &[], &prm, t_end, h, &opts, &mut forged)
            .unwrap();
        forged.parts().ledger.unwrap().scale
    };
    let honest = scale_after(stored(&s));
    let inflated = scale_after(1e3);
    assert!(
        inflated > 2.0 * honest,
        "scale {inflated} J with 1 kJ carried, {honest} J with the honest estimate"
    );
}

#[test]
fn implicit_euler_leaves_no_contact_energy_where_the_contacts_read_inputs() {
    // A mocap body's pose is an input, and so is an adhesion actuator's control: the next call
    // may change them, and with them the contacts at the same state. Implicit Euler then leaves
    // no estimate, and the next call lists the contacts at its start; the same sphere resting
    // on the floor without either leaves one.
    let scene = |extra_body: &str, actuator: &str| {
        format!(
            r#"<mujoco><option timestep="0.002"/>
  <custom><text name="scm_integrator" data="implicit_euler"/></custom>
  <worldbody><geom type="plane" size="1 1 0.1"/>{extra_body}
    <body name="b" pos="0 0 0.049"><freejoint/><geom type="sphere" size="0.05" mass="1"/></body>
  </worldbody>{actuator}</mujoco>"#
        )
    };
    let mocap =
        r#"<body name="m" mocap="true" pos="0.3 0 0.1"><geom type="sphere" size="0.02"/></body>"#;
    let adhesion = r#"<actuator><adhesion body="b" ctrlrange="0 1" gain="5"/></actuator>"#;
    for (what, text, leaves) in [
        ("a mocap body", scene(mocap, ""), false),
        ("an adhesion actuator", scene("", adhesion), false),
        ("neither", scene("", ""), true),
    ] {
        let model = model_of(&text);
        assert_eq!(model.integrator, Integrator::ImplicitEuler);
        let s = State {
            q: vec![0.0, 0.0, 0.049, 1.0, 0.0, 0.0, 0.0],
            v: vec![0.0; 6],
            act: Vec::new(),
        };
        let u = model.u0();
        let mut cache = scm::integrate::SolverCache::default();
        let opts = AdvanceOptions::default();
        let prm = model.contact;
        let end = model
            .advance_cached(&s, &u, &prm, 0.0, 0.002, &opts, &mut cache)
            .unwrap()
            .state;
        let ledger = cache.parts().ledger.expect("the ledger is kept");
        assert_eq!(ledger.at, end);
        assert_eq!(ledger.stored.is_some(), leaves, "{what}");
    }
}

#[test]
fn a_restored_fmu_state_carries_the_energy_ledger_and_refuses_at_the_same_step() {
    let (model, h, _) = slowly_growing_pendulum();
    let text = format!(
        r#"<mujoco model="pendulum"><option timestep="{h:e}" gravity="0 0 -9.81"/>
  <custom><text name="scm_integrator" data="euler"/></custom>
  <worldbody><body name="p"><joint name="j" type="hinge" axis="0 1 0" ref="0"/>
    <inertial pos="0 0 -0.5" mass="1" diaginertia="0.001 0.001 0.001"/></body></worldbody></mujoco>"#
    );
    assert_eq!(model.timestep, h);
    let scene = scm::scene::load_str(&text, std::path::Path::new("pendulum.xml")).unwrap();
    let mut sim = Simulation::new(scene, &text);
    sim.data.current.state.q[0] = 0.5;
    let run = |sim: &mut Simulation, from: usize| -> usize {
        for k in from..400 {
            match sim.do_step(k as f64 * h, h) {
                Ok(()) => {}
                Err(StepError::Discard(m)) => {
                    assert!(m.contains("unstable"), "{m}");
                    return k;
                }
                Err(StepError::Error(m)) => panic!("{m}"),
            }
        }
        panic!("never refused");
    };
    for k in 0..30 {
        sim.do_step(k as f64 * h, h).unwrap();
    }
    let saved = sim.get_state().unwrap();
    let bytes = sim.serialize_state(&saved).unwrap();
    let restored = sim.deserialize_state(&bytes).unwrap();
    assert_eq!(
        restored, saved,
        "the state with its ledger round-trips through bytes"
    );
    assert!(
        saved.solver_cache.parts().ledger.is_some(),
        "the ledger is part of the state"
    );
    let first = run(&mut sim, 30);
    let end = sim.data.current.clone();
    sim.set_state(&restored).unwrap();
    assert_eq!(
        run(&mut sim, 30),
        first,
        "the restored run is refused at the same step"
    );
    assert_eq!(sim.data.current, end);
    println!("refused at communication step {first}, after a restore at step 30 too");
}

#[test]
fn the_contact_energy_estimate_is_the_work_of_the_contact_force_within_a_small_factor() {
    // The sphere of `stiff_sphere` (ε3 = 1e-6 m, here k = 1e5 N/m and ε3 = 1e-4 m as in the
    // bundled scenes) at rest at heights around its resting one: the energy stored in contact
    // is the work the contact force does as the sphere is lifted slowly (no damping at v = 0)
    // out of reach, `∫_z^∞ F_z dz`. The guard's estimate must stay within a small factor of it
    // (the doc of `contact_energy`: 1.00 to 1.25 for one spring). Measured: 1.00 at 0.5 mm
    // above rest, 1.17 at rest, 1.33, 1.80, 1.94 at 0.2, 0.5, 1 mm below: deeper, more springs
    // of the sphere's patch push, the force grows faster than one spring's and `|F|²/2k`
    // reads high (on the side of allowing more, never less).
    let mut model = model_of(&stiff_sphere(1e5, 1e-3, "implicit_euler"));
    model.contact.eps3 = 1e-4;
    let prm = model.contact;
    let at = |z: f64| {
        let q = [0.0, 0.0, z, 1.0, 0.0, 0.0, 0.0];
        let kin = model.tree.kinematics_with(&q, &[0.0; 6], &[]);
        model.contacts(&kin, &prm, &[]).1
    };
    let force = |z: f64| at(z)[0].on_b.force.z.abs().max(at(z)[0].on_a.force.z.abs());
    // Resting height: the lift equals m g.
    let rest = bisect(|z| 9.81 - force(z), 0.045, 0.06);
    assert!(
        (force(rest) - 9.81).abs() < 1e-6,
        "resting height {rest}: lift {}",
        force(rest)
    );
    for depth in [-5e-4, 0.0, 2e-4, 5e-4, 1e-3] {
        let z = rest - depth;
        // Trapezoid on 4,000 steps of 1 µm up to 4 mm above the resting height (the force
        // there is e^-40 of the resting one).
        let n = 4000;
        let top = rest + 4e-3;
        let dz = (top - z) / n as f64;
        let work: f64 = (0..n)
            .map(|i| 0.5 * (force(z + i as f64 * dz) + force(z + (i + 1) as f64 * dz)) * dz)
            .sum();
        let in_reach: Vec<_> = at(z).into_iter().map(Some).collect();
        let estimate = scm::integrate::contact_energy(&model.pairs, &in_reach, &prm, &[]);
        println!(
            "{:.1} mm below rest: work {work:.4e} J, estimate {estimate:.4e} J, ratio {:.3}",
            depth * 1e3,
            estimate / work
        );
        assert!(
            estimate >= 0.9 * work && estimate <= 2.5 * work,
            "depth {depth}: estimate {estimate} J against the work {work} J"
        );
    }
}

#[test]
fn the_contact_energy_estimate_cannot_raise_the_guards_allowance() {
    // The 1 kg sphere of `stiff_sphere` at k = 3e4 N/m dropped from 30 cm (2.2 m/s at impact)
    // and bouncing under semi-implicit Euler at 2 ms, one communication step per internal step
    // as a benchmark's host runs it: a damped bounce (the energy falls from 2.9 J to 0.5 J),
    // which the guard must let run. At impact the estimate of the energy stored in contact,
    // `ε3 |F| + |F|²/2k`, reads the damping force too (1 + 22 at 2.2 m/s against v_d = 0.1 m/s)
    // and finds 41 J in a 2.9 J run. Counted in full as energy in motion it raised the
    // allowance to 25 J for the rest of the run (and in gymnasium's ant, where a blow-up drives
    // a leg into the floor, to 8.9e4 J: the blow-up was refused at 9.4e4 J instead of 25 J).
    // Counted only up to the headroom the state had, the guard keeps its bound: with no
    // actuator, `S` and every accepted kinetic energy stay below `2 (E₀ + U₀ + E_floor - V_min)`.
    let model = model_of(&stiff_sphere(3e4, 2e-3, "semi_implicit_euler"));
    assert_eq!(model.integrator, Integrator::SemiImplicitEuler);
    let (h, prm) = (model.timestep, model.contact);
    let stored = |s: &State<f64>| stored_in_contact(&model, s);
    let potential = |s: &State<f64>| {
        let e = model.energy(&s.q, &s.v);
        e.gravity + e.springs
    };
    let mut s = State {
        q: vec![0.0, 0.0, 0.3, 1.0, 0.0, 0.0, 0.0],
        v: vec![0.0; 6],
        act: Vec::new(),
    };
    let reference = model.energy(&s.q, &s.v).total() + stored(&s);
    let floor = model.moving_mass() * (9.81e-3 + 0.5e-4);
    let mut v_min = potential(&s);
    let (mut most_stored, mut most_scale) = (0.0f64, 0.0f64);
    let mut cache = scm::integrate::SolverCache::default();
    let opts = AdvanceOptions::default();
    // 0.6 s: the first impact at 0.23 s, the second at 0.41 s.
    for k in 0..300 {
        most_stored = most_stored.max(stored(&s));
        s = model
            .advance_cached(&s, &[], &prm, k as f64 * h, h, &opts, &mut cache)
            .unwrap_or_else(|e| panic!("step {k}: a damped bounce refused: {e}"))
            .state;
        v_min = v_min.min(potential(&s));
        let bound = 2.0 * (reference + floor - v_min);
        let scale = cache.parts().ledger.expect("the ledger is kept").scale;
        let kinetic = model.energy(&s.q, &s.v).kinetic;
        most_scale = most_scale.max(scale);
        assert!(
            scale <= bound * (1.0 + 1e-12) && kinetic <= bound * (1.0 + 1e-12),
            "step {k}: energy in motion {scale} J, kinetic {kinetic} J, above the bound {bound} J"
        );
    }
    let end = model.energy(&s.q, &s.v).total();
    let bound = 2.0 * (reference + floor - v_min);
    println!(
        "run energy {reference:.3} -> {end:.3} J; largest contact estimate {most_stored:.3e} J; \
         largest S {most_scale:.3} J against the bound {bound:.3} J"
    );
    // The run exercises the cap: the estimate at impact is far above the bound (were it
    // counted, `S` would exceed it), and the bounce lost energy.
    assert!(most_stored > 4.0 * bound, "estimate {most_stored} J");
    assert!(end < 0.5 * reference, "{reference} -> {end} J");
}

#[test]
fn damped_euler_takes_stiff_frictionloss_at_mujocos_step() {
    // A 1 kg slider thrown at 1 m/s against 5 N of frictionloss, with a stiction velocity of
    // 1 mm/s: near rest the smooth friction is a damper of F / v_s = 5000 N s/m, h F / (v_s m)
    // = 10 at MuJoCo's 2 ms step, past semi-implicit Euler's limit of 2. MuJoCo (frictionloss
    // as a constraint) stops it after v0² m / (2F) = 10 cm. damped_euler, with the friction's
    // slope implicit, stops it there too without the velocity changing sign; semi-implicit
    // Euler rings about zero velocity instead.
    let scene = |integrator: &str| {
        model_of(&format!(
            r#"<mujoco>
  <option timestep="0.002" gravity="0 0 0"/>
  <custom>
    <numeric name="scm_stiction_velocity" data="0.001"/>
    <text name="scm_integrator" data="{integrator}"/>
  </custom>
  <worldbody>
    <body name="b"><joint name="s" type="slide" axis="1 0 0" frictionloss="5"/>
      <geom type="box" size="0.05 0.05 0.05" mass="1"/></body>
  </worldbody>
</mujoco>"#
        ))
    };
    let run = |model: &Model| {
        let mut s = State::new(vec![0.0], vec![1.0]);
        let mut sign_changes = 0;
        for k in 0..300 {
            let a = model
                .advance(
                    &s,
                    &[],
                    &model.contact,
                    k as f64 * 0.002,
                    0.002,
                    &AdvanceOptions {
                        energy_guard: false,
                        ..Default::default()
                    },
                )
                .unwrap();
            if a.state.v[0] * s.v[0] < 0.0 {
                sign_changes += 1;
            }
            s = a.state;
        }
        (s, sign_changes)
    };
    let (s, flips) = run(&scene("damped_euler"));
    assert_eq!(flips, 0, "the velocity must not change sign");
    assert!(s.v[0].abs() < 1e-3, "at rest: v = {}", s.v[0]);
    assert!((s.q[0] - 0.1).abs() < 2e-3, "stops after {} m", s.q[0]);
    let (_, flips) = run(&scene("semi_implicit_euler"));
    assert!(
        flips > 10,
        "semi-implicit Euler should ring ({flips} sign changes)"
    );
}

#[test]
fn damped_euler_takes_stiff_contact_friction_at_mujocos_step() {
    // A flat 0.1 kg box (10 x 10 x 2 cm, so it does not tip) sliding at 1 m/s on a floor with
    // friction 1 and a stiction velocity of 1 mm/s: near rest SCM's friction is a damper of
    // mu m g / v_s, h mu g / v_s = 19.6 at MuJoCo's 2 ms step, ten times past semi-implicit
    // Euler's limit. Coulomb stops the box after v0² / (2 mu g) = 5.1 cm. damped_euler, with
    // the contact velocity-implicit, stops it there (to 2 %: the smooth friction) and it
    // settles (its rocking on the contact, a 26 ms period, dies out); semi-implicit Euler
    // rings about rest for ever, the velocity changing sign at every step.
    let scene = sliding_box;
    // The state after 0.3 s and the largest sliding speed over its last 0.1 s.
    let run = |model: &Model| {
        let mut s = State {
            q: model.tree.q0(),
            v: vec![1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            act: Vec::new(),
        };
        let mut late = 0.0_f64;
        for k in 0..150 {
            s = model
                .advance(
                    &s,
                    &[],
                    &model.contact,
                    k as f64 * 0.002,
                    0.002,
                    &AdvanceOptions::default(),
                )
                .unwrap()
                .state;
            if k >= 100 {
                late = late.max(s.v[0].abs());
            }
        }
        (s, late)
    };
    let (s, late) = run(&scene("damped_euler"));
    assert!(late < 1e-3, "settled: |v| up to {late} m/s after 0.2 s");
    let coulomb = 1.0 / (2.0 * 9.81);
    assert!(
        (s.q[0] - coulomb).abs() < 0.03 * coulomb,
        "stops after {} m (Coulomb: {coulomb} m)",
        s.q[0]
    );
    let (_, late) = run(&scene("semi_implicit_euler"));
    assert!(late > 3e-3, "semi-implicit Euler should ring ({late} m/s)");
}

/// A flat 0.1 kg box sliding at 1 m/s on a floor with friction 1 and a stiction velocity of
/// 1 mm/s (see the test above), under `integrator`.
fn sliding_box(integrator: &str) -> Model {
    model_of(&format!(
        r#"<mujoco>
  <option timestep="0.002"/>
  <custom>
    <numeric name="scm_stiction_velocity" data="0.001"/>
    <numeric name="scm_friction" data="1"/>
    <text name="scm_integrator" data="{integrator}"/>
  </custom>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="b" pos="0 0 0.01"><freejoint/>
      <geom type="box" size="0.05 0.05 0.01" mass="0.1"/></body>
  </worldbody>
</mujoco>"#
    ))
}

/// The sliding box with an integrator, started at 1 m/s along x.
struct SlidingRun {
    model: Model,
}

impl SlidingRun {
    fn new(integrator: &str) -> Self {
        SlidingRun {
            model: sliding_box(integrator),
        }
    }

    /// The box at rest on the floor, sliding at 1 m/s.
    fn start(&self) -> State<f64> {
        State {
            q: self.model.tree.q0(),
            v: vec![1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            act: Vec::new(),
        }
    }

    /// One call from `s` at time `t` for `d` seconds, with `cache` carried.
    fn call(
        &self,
        s: &State<f64>,
        t: f64,
        d: f64,
        cache: &mut scm::integrate::SolverCache,
    ) -> State<f64> {
        let m = &self.model;
        m.advance_cached(s, &[], &m.contact, t, d, &AdvanceOptions::default(), cache)
            .unwrap()
            .state
    }
}

/// 150 steps of 2 ms of the sliding box with `integrator`, from 1 m/s, once carrying the solver
/// cache from step to step and once with a fresh one each step: the carried and fresh runs
/// agree to the Newton tolerance, and the cache saved at step 50 and restored replays the rest
/// of the carried run bit for bit. `each(k, before, after, cache)` sees every carried step.
fn carried_against_fresh(
    integrator: &str,
    mut each: impl FnMut(usize, &State<f64>, &State<f64>, &scm::integrate::SolverCache),
) {
    let run = SlidingRun::new(integrator);
    let h = 0.002;
    let start = run.start();
    let step = |s: &State<f64>, k: usize, cache: &mut scm::integrate::SolverCache| {
        run.call(s, k as f64 * h, h, cache)
    };
    let mut cache = scm::integrate::SolverCache::default();
    let (mut carried, mut fresh) = (start.clone(), start);
    let mut saved = None;
    let mut largest = 0.0f64;
    for k in 0..150 {
        if k == 50 {
            saved = Some((carried.clone(), cache.clone()));
        }
        let before = carried.clone();
        carried = step(&carried, k, &mut cache);
        fresh = step(&fresh, k, &mut Default::default());
        assert!(
            cache.parts().jacobian.is_some(),
            "step {k}: no Jacobian carried"
        );
        each(k, &before, &carried, &cache);
        for (a, b) in carried.q.iter().zip(&fresh.q) {
            largest = largest.max((a - b).abs());
        }
    }
    assert!(
        largest < 1e-9,
        "{integrator}: carried and fresh runs differ by {largest} m"
    );
    let (mut again, mut restored) = saved.unwrap();
    for k in 50..150 {
        again = step(&again, k, &mut restored);
    }
    assert_eq!(again, carried, "the restored cache replays bit for bit");
}

/// A host that computes each communication step as the difference of its communication points
/// (`t_{k+1} - t_k`, as `scm simulate` did) passes durations that differ from the internal step
/// by a rounding. Implicit Euler's warm start (its Jacobian and last velocity change) serves
/// such a step as well as the exact one: the run matches the run with exact steps to the
/// rounding, where a cache dropped at every such call (its step compared exactly) restarted
/// Newton and left the runs apart by its tolerance. (Gymnasium's ant, in calls of 0.1 s computed
/// so, ended 1.4e-3 rad from its run in one call; now 2e-16.)
#[test]
fn implicit_euler_keeps_its_warm_start_over_calls_whose_step_differs_by_a_rounding() {
    let run = SlidingRun::new("implicit_euler");
    let h = 0.002;
    let start = run.start();
    let step = |s: &State<f64>, t: f64, d: f64, cache: &mut scm::integrate::SolverCache| {
        run.call(s, t, d, cache)
    };
    let (mut exact, mut exact_cache) = (start.clone(), Default::default());
    let (mut rounded, mut rounded_cache) = (start, Default::default());
    let (mut differing, mut largest) = (0, 0.0f64);
    for k in 0..150 {
        let (t, t_next) = (k as f64 * h, (k + 1) as f64 * h);
        differing += usize::from(t_next - t != h);
        exact = step(&exact, t, h, &mut exact_cache);
        rounded = step(&rounded, t, t_next - t, &mut rounded_cache);
        for (a, b) in exact
            .q
            .iter()
            .chain(&exact.v)
            .zip(rounded.q.iter().chain(&rounded.v))
        {
            largest = largest.max((a - b).abs());
        }
    }
    assert!(differing > 30, "only {differing} durations differ from h");
    assert!(
        largest < 1e-13,
        "exact and rounded communication steps differ by {largest}"
    );
}

#[test]
fn damped_euler_carries_its_newton_jacobian_and_a_restored_cache_replays_to_the_bit() {
    // In contact, damped Euler solves its step equation by Newton's iterations; the real
    // Jacobian is kept from step to step in the solver cache while the iterations contract.
    // Carried or fresh, the steps agree to the Newton tolerance; a cache saved and restored
    // (as an FMU state carries it) replays the rest of the run bit for bit. It carries no
    // velocity change (implicit Euler's).
    carried_against_fresh("damped_euler", |k, _, _, cache| {
        assert!(
            cache.parts().velocity_change.is_none(),
            "step {k}: a velocity change"
        );
    });
}

#[test]
fn implicit_euler_starts_from_the_last_velocity_change_and_its_state_carries_it() {
    // Implicit Euler keeps its Newton Jacobian and its last velocity change V - v from step to
    // step; Newton starts from v + (V - v). Carried or fresh (from v, a new Jacobian), the
    // steps agree to the Newton tolerance; the carried change is the last step's; a cache
    // saved and restored replays the rest of the run bit for bit, also through the FMU
    // state's bytes.
    carried_against_fresh("implicit_euler", |k, before, after, cache| {
        let change = cache
            .parts()
            .velocity_change
            .expect("a velocity change carried");
        for (i, &dv) in change.iter().enumerate() {
            assert_eq!(dv, after.v[i] - before.v[i], "step {k}, velocity {i}");
        }
    });

    // Through the FMU state's bytes: the change is in them, and the run replays.
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/resources/scenes/sphere_drop.xml"
    ))
    .unwrap();
    let scene = scm::scene::load_str(&text, std::path::Path::new("sphere_drop.xml")).unwrap();
    let mut sim = Simulation::new(scene, &text);
    sim.model.integrator = Integrator::ImplicitEuler;
    sim.initialize().unwrap();
    let dt = sim.model.timestep;
    for k in 0..20 {
        sim.do_step(k as f64 * dt, dt).unwrap();
    }
    let saved = sim.get_state().unwrap();
    assert!(
        saved.solver_cache.parts().velocity_change.is_some(),
        "the velocity change is part of the state"
    );
    let restored = sim
        .deserialize_state(&sim.serialize_state(&saved).unwrap())
        .unwrap();
    assert_eq!(restored, saved, "the state round-trips through bytes");
    for k in 20..60 {
        sim.do_step(k as f64 * dt, dt).unwrap();
    }
    let end = sim.data.current.clone();
    sim.set_state(&restored).unwrap();
    for k in 20..60 {
        sim.do_step(k as f64 * dt, dt).unwrap();
    }
    assert_eq!(
        sim.data.current, end,
        "the restored run replays bit for bit"
    );

    // Layout version 3 (before the velocity change) still loads where it has none, e.g. a
    // damped Euler state (its cache entry has flag 1); a flag 2 under version 3 is refused.
    // Versions 3 to 5 end without the kept out-of-reach proofs (version 6 ends with their
    // number, 0 here), 3 and 4 also without the ledger's kinetic energy (the 8 bytes before,
    // the ledger being last), which decoding computes again: the same state, bit for bit.
    assert!(
        saved.solver_cache.parts().ledger.is_some(),
        "a ledger is kept"
    );
    // Version 10 keeps implicit Euler's contact energy at the ledger's state (ledger flag 2):
    // an older layout has no place for it, and a version 9 state that says it has is refused.
    let parts = saved.solver_cache.parts();
    assert!(parts.ledger.as_ref().is_some_and(|l| l.stored.is_some()));
    let with_energy = sim.serialize_state(&saved).unwrap();
    assert_eq!(with_energy[..4], 10u32.to_le_bytes());
    let as_9 = [&9u32.to_le_bytes()[..], &with_energy[4..]].concat();
    let refused = sim.deserialize_state(&as_9).unwrap_err();
    assert!(refused.to_string().contains("ledger flag 2"), "{refused}");
    // A negative contact energy is corrupt.
    let mut forged = saved.clone();
    forged.solver_cache = scm::integrate::SolverCache::from_parts(scm::integrate::CacheParts {
        ledger: (parts.ledger.clone()).map(|l| scm::integrate::EnergyLedger {
            stored: Some(-1.0),
            ..l
        }),
        ..parts.clone()
    });
    let refused = sim
        .deserialize_state(&sim.serialize_state(&forged).unwrap())
        .unwrap_err();
    assert!(
        refused.to_string().contains("negative contact energy"),
        "{refused}"
    );
    // The same state without the kept proofs, and without that energy (the next call lists
    // the contacts at its start instead).
    let without_proofs = |state: &scm::sim::FmuState| {
        let mut s = state.clone();
        let parts = state.solver_cache.parts();
        s.solver_cache = scm::integrate::SolverCache::from_parts(scm::integrate::CacheParts {
            reach: vec![],
            ledger: (parts.ledger.clone())
                .map(|l| scm::integrate::EnergyLedger { stored: None, ..l }),
            ..parts
        });
        s
    };
    let saved = without_proofs(&saved);
    // Version 7 adds the activations, none here: its bytes are version 6's; version 8 a
    // kept proof's side flag 2, version 9 its room and version 10 the ledger's flag 2, no
    // proofs and no contact energy here: their bytes are version 7's.
    let as_version = |version: u32, bytes: &[u8]| {
        let cut = match version {
            6.. => 0,
            5 => 4,
            _ => 12,
        };
        [&version.to_le_bytes()[..], &bytes[4..bytes.len() - cut]].concat()
    };
    let version_10 = sim.serialize_state(&saved).unwrap();
    assert_eq!(version_10[..4], 10u32.to_le_bytes());
    assert_eq!(version_10[version_10.len() - 4..], 0u32.to_le_bytes());
    let version_6 = version_10;
    for old in [4, 5, 6, 7, 8, 9] {
        assert_eq!(
            sim.deserialize_state(&as_version(old, &version_6)).unwrap(),
            saved
        );
    }
    let version_5 = as_version(5, &version_6);
    // A kinetic energy below zero or above the ledger's scale is corrupt.
    for bad in [-1.0f64, 1e6] {
        let n = version_5.len();
        let forged = [&version_5[..n - 8], &bad.to_bits().to_le_bytes()[..]].concat();
        let err = sim.deserialize_state(&forged).unwrap_err();
        assert!(err.to_string().contains("kinetic energy"), "{err}");
    }
    let refused = sim
        .deserialize_state(&as_version(3, &version_6))
        .unwrap_err();
    assert!(refused.to_string().contains("corrupt"), "{refused}");
    let scene = scm::scene::load_str(&text, std::path::Path::new("sphere_drop.xml")).unwrap();
    let mut damped = Simulation::new(scene, &text);
    damped.model.integrator = Integrator::DampedEuler;
    damped.initialize().unwrap();
    for k in 0..20 {
        damped.do_step(k as f64 * dt, dt).unwrap();
    }
    let state = damped.get_state().unwrap();
    assert!(
        state.solver_cache.parts().left.is_some()
            && state.solver_cache.parts().velocity_change.is_none()
    );
    let state = without_proofs(&state);
    let old = as_version(3, &damped.serialize_state(&state).unwrap());
    assert_eq!(damped.deserialize_state(&old).unwrap(), state);
}

/// A box resting tilted on a floor, damped Euler at 2 ms, with the bodies `$rest` adds: the
/// frozen contact's scenes.
macro_rules! tilted_box_and {
    ($rest:literal) => {
        concat!(
            r#"<mujoco>
  <option timestep="0.002"/>
  <custom><text name="scm_integrator" data="damped_euler"/></custom>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="b" pos="0 0 0.0195" euler="0.02 -0.01 0.3"><freejoint/>
      <geom type="box" size="0.05 0.04 0.02" mass="0.2"/></body>
"#,
            $rest,
            "\n  </worldbody>\n</mujoco>"
        )
    };
}

/// The tilted box pressed by a sphere.
const TILTED_BOX_PRESSED: &str = tilted_box_and!(
    r#"    <body name="s" pos="0.01 0 0.068"><freejoint/>
      <geom type="sphere" size="0.03" mass="0.1"/></body>"#
);

/// A forearm of a two-joint arm (a ball at the shoulder, a hinge at the elbow) pressing the
/// tilted box: a pair whose columns are several bodies' coordinates.
const ARM_PRESSING_BOX: &str = tilted_box_and!(
    r#"    <body name="upper" pos="-0.2 0 0.2"><joint type="ball"/>
      <geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.015" mass="0.1"/>
      <body name="fore" pos="0.1 0 0"><joint type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.12 0 -0.146" size="0.015" mass="0.1"/></body></body>"#
);

#[test]
fn damped_euler_without_a_pair_in_reach_is_the_forward_dynamics_step_to_the_bit() {
    // A step with no pair in reach and no limit takes the frozen evaluation's free start (no
    // evaluation kept for Newton): its velocity must be `v + h v̇` of the damped forward
    // dynamics (`forward_at` with the joints' damping implicit) to the bit, as the frozen
    // evaluation made in full gives it. A box falling far above a floor and a pendulum with
    // viscous damping and frictionloss, whose implicit terms the damped mass matrix holds.
    let model = model_of(
        r#"<mujoco><option timestep="0.002"/>
  <custom><text name="scm_integrator" data="damped_euler"/></custom>
  <worldbody><geom type="plane" size="1 1 0.1"/>
    <body name="box" pos="0 0 0.5" euler="10 20 30"><freejoint/>
      <geom type="box" size="0.05 0.04 0.03" mass="0.7"/></body>
    <body name="arm" pos="1 0 1"><joint name="j" type="hinge" axis="0 1 0" damping="0.3"
      frictionloss="0.05"/><geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="0.4"/></body>
  </worldbody></mujoco>"#,
    );
    assert_eq!(model.integrator, Integrator::DampedEuler);
    let q = model.tree.q0();
    let v = vec![0.1, -0.2, 0.3, 1.0, -2.0, 0.5, 0.7];
    let (h, prm) = (model.timestep, model.contact);
    let tau = vec![0.0; v.len()];
    let at = EvalPoint {
        q: &q,
        v: &v,
        tau: &tau,
        mocap: &[],
        pulls: &[],
    };
    let damped = ForwardOptions {
        implicit_damping: Some(h),
        ..ForwardOptions::default()
    };
    let a = model.forward_at(at, &prm, damped).unwrap().vdot;
    let (frozen, a0) = model.frozen_forward(at, &prm, h, Reuse::Nothing).unwrap();
    assert!(frozen.contact_free(), "nothing in reach");
    let bits = |x: &[f64]| x.iter().map(|a| a.to_bits()).collect::<Vec<u64>>();
    assert_eq!(bits(&a0), bits(a.as_slice()), "the full frozen evaluation");
    let s = State {
        q: q.clone(),
        v: v.clone(),
        act: Vec::new(),
    };
    let end = model
        .step_with(Integrator::DampedEuler, &s, &[], &prm, h)
        .unwrap();
    let v1: Vec<f64> = (0..v.len()).map(|k| v[k] + h * a[k]).collect();
    assert_eq!(bits(&end.v), bits(&v1), "the step's velocity");
    assert_eq!(bits(&end.q), bits(&model.tree.integrate_q(&q, &v1, h)));
    // The damping is implicit: the explicit step would differ.
    let plain = model
        .forward_at(at, &prm, ForwardOptions::default())
        .unwrap();
    assert_ne!(plain.vdot[6], a[6], "the hinge's damping taken implicitly");
}

#[test]
fn damped_euler_frozen_contact_equals_the_full_evaluation() {
    // Damped Euler's Newton iterations evaluate the contact at many end velocities of one
    // configuration through `FrozenForward` (each pair's contact terms recorded once). Against
    // the full evaluation (`forward_at` with a contact velocity) on a box resting tilted on a floor and pressed
    // by a sphere, at end velocities up to 1 m/s from the start: equal where recorded, and to
    // 1e-12 of the accelerations' size elsewhere.
    let model = model_of(TILTED_BOX_PRESSED);
    let (q, v) = (
        model.tree.q0(),
        vec![
            0.05, -0.02, -0.1, 0.3, 0.1, -0.2, 0.0, 0.1, -0.3, 0.0, 0.5, 0.1,
        ],
    );
    let (h, tau, prm) = (0.002, vec![0.0; 12], model.contact);
    let mut rng = crate::common::Lcg(3);
    let at = EvalPoint {
        q: &q,
        v: &v,
        tau: &tau,
        mocap: &[],
        pulls: &[],
    };
    fn damped(h: f64, contact_velocity: Option<&[f64]>) -> ForwardOptions<'_, f64> {
        ForwardOptions {
            contact_velocity,
            implicit_damping: Some(h),
            ..ForwardOptions::default()
        }
    }
    let (frozen, at_v) = model.frozen_forward(at, &prm, h, Reuse::Nothing).unwrap();
    let full = |x: &[f64]| model.forward_at(at, &prm, damped(h, Some(x))).unwrap().vdot;
    let here = full(&v);
    assert!(here.norm() > 1.0, "the bodies touch: {here}");
    assert_eq!(at_v.as_slice(), here.as_slice(), "equal where recorded");
    assert_eq!(frozen.vdot(&v).as_slice(), here.as_slice());
    // Each pair's contact where it was recorded, the same bits as the forward dynamics' there
    // (what damped Euler's energy guard reads instead of a forward dynamics of its own).
    let forward = model.forward_at(at, &prm, damped(h, None)).unwrap();
    assert_eq!(frozen.contacts().len(), forward.contacts.len());
    assert!(frozen.contacts().iter().filter(|c| c.is_some()).count() >= 2);
    for (a, b) in frozen.contacts().iter().zip(&forward.contacts) {
        let bits = |c: &Option<scm::contact::PairContact<f64>>| {
            c.as_ref().map(|c| {
                (c.on_a.force.iter().chain(c.on_a.torque.iter()))
                    .chain(c.on_b.force.iter().chain(c.on_b.torque.iter()))
                    .chain([&c.distance])
                    .map(|x| x.to_bits())
                    .collect::<Vec<u64>>()
            })
        };
        assert_eq!(bits(a), bits(b));
    }
    for scale in [1e-3, 0.1, 1.0] {
        for _ in 0..5 {
            let x: Vec<f64> = v.iter().map(|a| a + scale * rng.range(-1.0, 1.0)).collect();
            let (a, b) = (frozen.vdot(&x), full(&x));
            let diff = a
                .iter()
                .zip(b.iter())
                .fold(0.0f64, |m, (p, r)| m.max((p - r).abs()));
            assert!(
                diff <= 1e-12 * b.norm(),
                "at +-{scale} m/s: {diff} of {}",
                b.norm()
            );
        }
    }
}

#[test]
fn damped_euler_frozen_jacobian_equals_central_differences_and_the_full_one() {
    // Newton's Jacobian of damped Euler's step equation in f64 comes from the frozen contact:
    // `I - h (M + h D)⁻¹ ∂τ_c/∂V`, `∂τ_c/∂V` from the tapes replayed on dual numbers, pair by
    // pair against the two bodies' velocities (the same as with every velocity seeded, to
    // rounding: measured 4e-17 to 4e-16 apart, relative). Against
    // central differences of the frozen residual `r(V) = V - v - h v̇(V)` (steps of 1e-6 m/s:
    // rounding of about 1e-16 / 1e-6 and truncation of order 1e-12 per entry; measured 3.5e-9
    // at most on entries up to 33) and against the Jacobian of the full evaluation on dual
    // numbers (the same function up to the pruning of far terms; measured 1.4e-14 apart), at
    // the start velocity and at end velocities up to 0.1 m/s from it.
    let pressed = vec![
        0.05, -0.02, -0.1, 0.3, 0.1, -0.2, 0.0, 0.1, -0.3, 0.0, 0.5, 0.1,
    ];
    // An arm of a ball and a hinge (its forearm pressing the box: coordinates of several
    // bodies in one pair's columns) and the box on the floor.
    let arm = vec![0.05, -0.02, -0.1, 0.3, 0.1, -0.2, 0.4, -0.3, 0.2, 0.5];
    for (scene, v) in [(TILTED_BOX_PRESSED, pressed), (ARM_PRESSING_BOX, arm)] {
        let model = model_of(scene);
        frozen_jacobian_against_central_differences_and_the_full_one(&model, &v);
    }
}

fn frozen_jacobian_against_central_differences_and_the_full_one(model: &Model, v: &[f64]) {
    use scm::autodiff::{jacobian, VectorFunction};
    use scm::model::{DynamicsError, FrozenForward};
    use scm::scalar::{c, Scalar};
    struct Force<'f, 'm>(&'f FrozenForward<'m>);
    impl VectorFunction for Force<'_, '_> {
        fn eval<T: Scalar>(&self, x: &[T]) -> Result<Vec<T>, DynamicsError> {
            Ok(self.0.contact_force(x))
        }
    }
    struct Full<'a>(&'a Model, Vec<f64>, Vec<f64>, f64);
    impl VectorFunction for Full<'_> {
        fn eval<T: Scalar>(&self, x: &[T]) -> Result<Vec<T>, DynamicsError> {
            let Full(model, q, v, h) = self;
            let lift = |a: &[f64]| a.iter().map(|&y| c::<T>(y)).collect::<Vec<T>>();
            let (q, v, tau) = (lift(q), lift(v), vec![T::zero(); v.len()]);
            let at = EvalPoint {
                q: &q,
                v: &v,
                tau: &tau,
                mocap: &[],
                pulls: &[],
            };
            let opts = ForwardOptions {
                contact_velocity: Some(x),
                implicit_damping: Some(c(*h)),
                ..ForwardOptions::default()
            };
            let a = model.forward_at(at, &model.contact.lift(), opts)?.vdot;
            Ok((0..x.len())
                .map(|k| x[k] - v[k] - a[k] * c::<T>(*h))
                .collect())
        }
    }
    let n = model.tree.nv;
    let (q, v) = (model.tree.q0(), v.to_vec());
    let (h, tau, prm) = (0.002, vec![0.0; n], model.contact);
    let at = EvalPoint {
        q: &q,
        v: &v,
        tau: &tau,
        mocap: &[],
        pulls: &[],
    };
    let (frozen, _) = model.frozen_forward(at, &prm, h, Reuse::Nothing).unwrap();
    let residual = |x: &[f64]| -> Vec<f64> {
        let a = frozen.vdot(x);
        (0..x.len()).map(|k| x[k] - v[k] - h * a[k]).collect()
    };
    let mut rng = crate::common::Lcg(5);
    for scale in [0.0, 1e-3, 0.1] {
        let x: Vec<f64> = v.iter().map(|a| a + scale * rng.range(-1.0, 1.0)).collect();
        // Pair by pair (what Newton uses), against every velocity seeded at once.
        let force = frozen.contact_force_jacobian(&x);
        let (_, seeded) = jacobian(&Force(&frozen), &x).unwrap();
        let gap = (&force - &seeded).amax();
        assert!(gap <= 1e-13 * seeded.amax(), "{gap} of {}", seeded.amax());
        // Every coordinate moves a body of a pair in reach (the arm's four move the forearm).
        for k in 0..n {
            assert!(
                force.column(k).amax() > 0.0,
                "coordinate {k} reads no contact"
            );
        }
        let ours = frozen.step_jacobian(&force, h);
        // The contact matters: the Jacobian is not the identity.
        let off = (&ours - nalgebra::DMatrix::identity(n, n)).amax();
        assert!(off > 1e-3, "no contact in the Jacobian: {off}");
        let d = 1e-6;
        for k in 0..x.len() {
            let (mut up, mut down) = (x.clone(), x.clone());
            up[k] += d;
            down[k] -= d;
            let (ru, rd) = (residual(&up), residual(&down));
            for i in 0..x.len() {
                let fd = (ru[i] - rd[i]) / (2.0 * d);
                assert!(
                    (ours[(i, k)] - fd).abs() <= 1e-8 * (1.0 + fd.abs()),
                    "at +-{scale} m/s, entry ({i}, {k}): {} against {fd}",
                    ours[(i, k)]
                );
            }
        }
        let (_, full) = jacobian(&Full(model, q.clone(), v.clone(), h), &x).unwrap();
        let gap = (&ours - &full).amax();
        assert!(
            gap <= 1e-12 * full.amax(),
            "at +-{scale} m/s: {gap} of {}",
            full.amax()
        );
    }
}

#[test]
fn kept_candidate_planes_change_no_bit_of_any_integrators_run() {
    // A 6 cm box sliding at 0.3 m/s and spinning on a fixed 40 cm slab (both point clouds: the
    // pair's band walks the slab's hierarchy), 80 steps of 2 ms with each fixed-step method:
    // carrying the solver cache with the pairs' kept candidate planes, and carrying it with no
    // candidates kept (every query walks, at every stage and Newton residual; the proofs and
    // Newton's Jacobian kept as usual). Kept candidates served most queries, and the two runs
    // are the same to the bit.
    for integrator in [
        "semi_implicit_euler",
        "damped_euler",
        "implicit_euler",
        "rk4",
    ] {
        let model = model_of(&format!(
            r#"<mujoco>
  <option timestep="0.002"/>
  <custom>
    <numeric name="scm_friction" data="0.1"/>
    <text name="scm_integrator" data="{integrator}"/>
  </custom>
  <worldbody>
    <geom name="slab" type="box" size="0.2 0.2 0.02" pos="0 0 -0.02"/>
    <body name="b" pos="0 0 0.0298"><freejoint/>
      <geom type="box" size="0.03 0.03 0.03" mass="0.2"/></body>
  </worldbody>
</mujoco>"#
        ));
        assert!(
            model
                .colliders
                .iter()
                .flatten()
                .all(|c| matches!(c, Collider::Aopc(_))),
            "both are point clouds"
        );
        let opts = AdvanceOptions::default();
        let h = 0.002;
        let start = State {
            q: model.tree.q0(),
            v: vec![0.3, 0.1, 0.0, 0.0, 0.0, 2.0],
            act: Vec::new(),
        };
        let run = |keep: bool| {
            let mut cache = scm::integrate::SolverCache::default();
            cache.keep_candidates(keep);
            let mut s = start.clone();
            let mut states = Vec::new();
            for k in 0..80 {
                s = model
                    .advance_cached(&s, &[], &model.contact, k as f64 * h, h, &opts, &mut cache)
                    .unwrap()
                    .state;
                states.push(s.clone());
            }
            (states, cache.candidate_counts())
        };
        let (kept, counts) = run(true);
        let (fresh, none) = run(false);
        assert!(
            counts.hits > 4 * counts.misses,
            "{integrator}: kept candidates served {counts:?}"
        );
        assert_eq!(none, Default::default(), "{integrator}: none kept");
        let moved = (kept[79].q[0] - start.q[0]).abs();
        assert!(moved > 0.01, "{integrator}: the box slid {moved} m");
        for (k, (a, b)) in kept.iter().zip(&fresh).enumerate() {
            assert_eq!(a, b, "{integrator}: step {k} differs");
        }
    }
}

/// The energy guard's kinematics of the state a call ends at are kept in the solver cache and
/// the next call from that state starts from them: a memo, which changes no bit. Free bodies
/// falling onto a floor and onto each other, with two explicit methods and implicit Euler,
/// 150 communication steps: one run carries its cache, the other rebuilds it from its parts
/// (which drop the kept kinematics) before every call. Every 20th call starts from a state a
/// host set (the velocities changed), where the kept kinematics must not be used. Damped Euler
/// and damped RK4 take them into their frozen evaluation at the step's start, and within a call
/// the guard's kinematics after each internal step serve the next one: calls of five steps
/// give the same bits as with the guard off (which computes none).
#[test]
fn the_guards_kinematics_carried_to_the_next_call_change_no_bit() {
    for integrator in [
        "semi_implicit_euler",
        "rk4",
        "implicit_euler",
        "damped_euler",
        "damped_rk4",
    ] {
        let model = model_of(&format!(
            r#"<mujoco>
  <option timestep="0.002"/>
  <custom><text name="scm_integrator" data="{integrator}"/></custom>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="a" pos="0 0 0.06"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="1"/></body>
    <body name="b" pos="0.01 0 0.2"><freejoint/><geom type="sphere" size="0.05" mass="0.5"/></body>
    <body name="c" pos="0.5 0 0.3"><joint type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.2"/></body>
  </worldbody>
</mujoco>"#
        ));
        let opts = AdvanceOptions::default();
        let h = 0.002;
        let mut carried = scm::integrate::SolverCache::default();
        let mut rebuilt = scm::integrate::SolverCache::default();
        let (mut a, mut b) = (
            State::new(model.tree.q0(), vec![0.0; model.tree.nv]),
            State::new(model.tree.q0(), vec![0.0; model.tree.nv]),
        );
        let mut kept = 0;
        for k in 0..150 {
            if k % 20 == 19 {
                // A host sets the state: the kept kinematics are of another one.
                for s in [&mut a, &mut b] {
                    s.v[0] += 0.1;
                    s.v[8] -= 0.2;
                }
                assert!(!carried.holds_kinematics_of(&a));
            }
            kept += usize::from(carried.holds_kinematics_of(&a));
            let t = k as f64 * h;
            a = (model.advance_cached(&a, &[], &model.contact, t, h, &opts, &mut carried))
                .unwrap()
                .state;
            rebuilt = scm::integrate::SolverCache::from_parts(rebuilt.parts());
            assert!(!rebuilt.holds_kinematics_of(&b));
            b = (model.advance_cached(&b, &[], &model.contact, t, h, &opts, &mut rebuilt))
                .unwrap()
                .state;
            assert_eq!(a, b, "{integrator}: step {k}");
        }
        // Every call but the first and those from a state set by the host found them.
        assert_eq!(kept, 150 - 1 - 7, "{integrator}");
        // Within a call: five internal steps per call, guard on against guard off.
        let unguarded = AdvanceOptions {
            energy_guard: false,
            ..AdvanceOptions::default()
        };
        let (mut on, mut off) = (
            scm::integrate::SolverCache::default(),
            scm::integrate::SolverCache::default(),
        );
        let mut c = State::new(model.tree.q0(), vec![0.0; model.tree.nv]);
        let mut d = c.clone();
        for k in 0..30 {
            let t = 5.0 * k as f64 * h;
            c = (model.advance_cached(&c, &[], &model.contact, t, 5.0 * h, &opts, &mut on))
                .unwrap()
                .state;
            d = (model.advance_cached(&d, &[], &model.contact, t, 5.0 * h, &unguarded, &mut off))
                .unwrap()
                .state;
            assert_eq!(c, d, "{integrator}: call {k} of five steps");
        }
        assert!(on.holds_kinematics_of(&c), "{integrator}");
        assert!(!off.holds_kinematics_of(&d), "{integrator}");
    }
}

/// Pairs in reach evaluated on several threads ([`scm::model::PairThreads`]) give the same
/// bits as serial ones: a box on a floor with a second box beside it, a sphere dropped onto it
/// and a swinging capsule (the first box in three pairs in reach at once, so that the order
/// its wrenches are summed in shows in the last bits), 100 steps of 2 ms with
/// every fixed-step method (damped Euler records its contact tapes on the threads too; the
/// adaptive one evaluates the dynamics as RK4 does, at many more steps), on 2 and 3
/// threads from two pairs in reach on, against serial.
#[test]
fn pairs_on_several_threads_change_no_bit() {
    for integrator in [
        "semi_implicit_euler",
        "rk4",
        "implicit_euler",
        "damped_euler",
    ] {
        let serial = model_of(&format!(
            r#"<mujoco>
  <option timestep="0.002"/>
  <custom><text name="scm_integrator" data="{integrator}"/></custom>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="a" pos="0 0 0.0495"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="1"/></body>
    <body name="b" pos="0.01 0 0.16"><freejoint/><geom type="sphere" size="0.05" mass="0.5"/></body>
    <body name="d" pos="0.1005 0 0.0495"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="1"/></body>
    <body name="c" pos="0.3 0 0.1"><joint type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.2"/></body>
  </worldbody>
</mujoco>"#
        ));
        let mut serial = serial;
        serial.pair_threads = scm::model::PairThreads::SERIAL;
        let threaded = |threads| {
            let mut m = serial.clone();
            m.pair_threads = scm::model::PairThreads {
                threads,
                min_pairs: 0,
            };
            m
        };
        let models = [serial.clone(), threaded(2), threaded(3)];
        let opts = AdvanceOptions::default();
        let h = 0.002;
        let start = State::new(serial.tree.q0(), vec![0.0; serial.tree.nv]);
        let mut states = vec![start.clone(); 3];
        let mut caches = vec![scm::integrate::SolverCache::default(); 3];
        let mut most_in_reach = 0;
        let clock = std::time::Instant::now();
        let bits = |s: &State<f64>| {
            s.q.iter()
                .chain(&s.v)
                .map(|x| x.to_bits())
                .collect::<Vec<_>>()
        };
        for k in 0..100 {
            let t = k as f64 * h;
            let mut refusals = Vec::new();
            for ((m, s), cache) in models.iter().zip(&mut states).zip(&mut caches) {
                match m.advance_cached(s, &[], &m.contact, t, h, &opts, cache) {
                    Ok(a) => *s = a.state,
                    Err(e) => refusals.push(e.to_string()),
                }
            }
            // The energy guard's decisions are the same on every thread count too. Semi-implicit
            // Euler is refused at step 55: the hinged capsule's tip (about 0.06 kg of effective
            // mass, its inertia about the hinge over the arm squared, against the 0.86 kg of
            // MuJoCo's body_invweight0 its law is sized on, as `scm check` shows) strikes the
            // floor and the run's kinetic energy triples (0.079 J to 0.24 J).
            if !refusals.is_empty() {
                assert_eq!(refusals.len(), 3, "{integrator}: step {k}: {refusals:?}");
                assert!(
                    refusals.iter().all(|r| *r == refusals[0]),
                    "{integrator}: step {k}: {refusals:?}"
                );
                println!(
                    "{integrator}: refused at step {k} on every thread count: {}",
                    refusals[0]
                );
                break;
            }
            for s in &states[1..] {
                assert_eq!(bits(s), bits(&states[0]), "{integrator}: step {k} differs");
            }
            if k % 10 != 9 {
                continue;
            }
            let kin = serial.tree.kinematics(&states[0].q, &states[0].v);
            let forces = |m: &Model| m.contact_forces(&kin, &m.contact, &[]).1;
            let in_reach = forces(&serial).iter().flatten().count();
            most_in_reach = most_in_reach.max(in_reach);
            // The contact outputs too, pair by pair, every tenth step.
            for m in &models[1..] {
                for (x, y) in forces(m).iter().zip(&forces(&serial)) {
                    let w = |p: &Option<scm::contact::PairContact<f64>>| {
                        p.as_ref().map(|p| {
                            (p.on_a.force.iter().chain(&p.on_b.torque))
                                .chain(std::iter::once(&p.distance))
                                .map(|x| x.to_bits())
                                .collect::<Vec<_>>()
                        })
                    };
                    assert_eq!(
                        w(x),
                        w(y),
                        "{integrator}: step {k}: a pair's contact differs"
                    );
                }
            }
        }
        println!(
            "{integrator}: up to {most_in_reach} pairs in reach, {:.1} s",
            clock.elapsed().as_secs_f64()
        );
        assert!(
            most_in_reach >= 4,
            "{integrator}: at most {most_in_reach} pairs in reach"
        );
    }
}

/// Three steel balls in a row, the last two touching, the first thrown at the second at
/// 0.5 m/s with MuJoCo's undamped contact (`solref="-k -0"`, as in MuJoCo's newton_cradle.xml:
/// an infinite dissipation velocity) and no friction, run as MuJoCo's Euler (damped Euler, 18
/// velocities: Newton's Jacobian from the tapes pair by pair). The undamped contact's Jacobian
/// was not a number (its dual velocity divided by an infinite constant) and the first step
/// failed. Now the last ball leaves at the thrower's speed: momentum kept to 1e-9 (the
/// contact's forces are equal and opposite, no other force acts) and the kinetic energy to
/// 1e-3 (no damping; measured 0.49999 m/s, the first ball back at -0.0032 m/s).
#[test]
fn an_undamped_contact_passes_the_momentum_along_a_row_of_balls() {
    let model = model_of(
        r#"<mujoco><option timestep="0.0001" gravity="0 0 0"/>
<default><geom type="sphere" size="0.02" density="8000" friction="0" solref="-1e5 -0"/></default>
<worldbody>
<body name="a" pos="-0.05 0 0"><freejoint/><geom/></body>
<body name="b" pos="0 0 0"><freejoint/><geom/></body>
<body name="c" pos="0.0401 0 0"><freejoint/><geom/></body>
</worldbody></mujoco>"#,
    );
    assert_eq!(model.integrator, Integrator::DampedEuler);
    for pair in &model.pairs {
        assert_eq!(
            pair.params(&model.contact).dissipation_velocity,
            f64::INFINITY
        );
    }
    let mut state = State::new(model.tree.q0(), vec![0.0; 18]);
    state.v[0] = 0.5;
    let done = model
        .advance(
            &state,
            &[],
            &model.contact,
            0.0,
            0.1,
            &AdvanceOptions::default(),
        )
        .unwrap();
    let vx: Vec<f64> = (0..3).map(|b| done.state.v[6 * b]).collect();
    let momentum: f64 = vx.iter().sum();
    assert!((momentum - 0.5).abs() < 1e-9, "{vx:?}");
    let energy: f64 = vx.iter().map(|v| v * v).sum();
    assert!((energy - 0.25).abs() < 0.25e-3, "{vx:?}");
    assert!(vx[2] > 0.49 && vx[0].abs() < 0.01, "{vx:?}");
}

#[test]
fn damped_rk4_is_classic_rk4_where_nothing_damps_and_differs_where_a_joint_has_frictionloss() {
    // Contact-free, off its limits, no frictionloss: each stage's damped Euler velocity is the
    // explicit one and the step is RK4's to rounding (a stage's acceleration is read back as
    // `(v + h a - v)/h`; a joint's viscous damping stays explicit, a passive force in MuJoCo's
    // RK4, so a damped pendulum is RK4's too).
    let text = |frictionloss: f64| {
        format!(
            r#"<mujoco model="p"><option timestep="0.004"/>
  <worldbody><body name="l"><joint name="j" axis="0 1 0" damping="0.4" frictionloss="{frictionloss}"/>
  <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1" contype="0" conaffinity="0"/></body>
  </worldbody></mujoco>"#
        )
    };
    let run = |frictionloss: f64, integrator: Integrator| {
        let t = text(frictionloss);
        let mut sim = Simulation::new(
            scm::scene::load_str(&t, std::path::Path::new("p.xml")).unwrap(),
            &t,
        );
        sim.model.integrator = integrator;
        sim.do_step(0.0, 0.4).unwrap();
        sim.data.current.state.clone()
    };
    let (damped, classic) = (run(0.0, Integrator::DampedRk4), run(0.0, Integrator::Rk4));
    assert!(
        (damped.q[0] - classic.q[0]).abs() < 1e-13,
        "{damped:?} {classic:?}"
    );
    assert!(
        (damped.v[0] - classic.v[0]).abs() < 1e-13,
        "{damped:?} {classic:?}"
    );
    // With frictionloss (a constraint in MuJoCo, solved at each of its RK4's stages) its slope is
    // implicit at every stage: the swing differs, and both still swing down.
    let (damped, classic) = (run(0.5, Integrator::DampedRk4), run(0.5, Integrator::Rk4));
    assert!(
        (damped.q[0] - classic.q[0]).abs() > 1e-9,
        "{damped:?} {classic:?}"
    );
    assert!(
        damped.q[0] > 0.1 && classic.q[0] > 0.1,
        "{damped:?} {classic:?}"
    );
}

#[test]
fn a_halved_implicit_euler_step_leaves_the_contact_energy_of_its_last_half() {
    // Where Newton's iterations fail, an implicit Euler step is done again as two halves
    // (`implicit_step_subdividing`), recursively; the estimate of the energy stored in contact
    // that the call leaves for the guard's next call must be the last half's, at the state the
    // call ends at, not the first half's nor the failed attempt's. A 10 × 6 × 4 cm box of 1 kg
    // thrown tumbling at the floor (3 m/s down, 20 rad/s) with 10 ms steps: its impact's steps
    // are halved two or three times, and within such a call the energy stored in contact goes
    // from none to 0.22 J and back to 1e-3 J. The estimate left agreed with the contacts at the
    // end state within 2e-7 relatively here (5.5e-6 at k = 1e7 N/m, on a step where the stored
    // energy was 1.5e-5 J), so 1e-4 holds it, and a half's or the start's estimate would miss
    // it by orders of magnitude.
    for k in [1e6, 1e7] {
        let xml = stiff_sphere(k, 0.01, "implicit_euler").replace(
            r#"type="sphere" size="0.05""#,
            r#"type="box" size="0.05 0.03 0.02""#,
        );
        let model = model_of(&xml);
        assert_eq!(model.integrator, Integrator::ImplicitEuler);
        let (h, prm) = (model.timestep, model.contact);
        let mut s = State {
            q: vec![0.0, 0.0, 0.08, 1.0, 0.0, 0.0, 0.0],
            v: vec![0.5, 0.0, -3.0, 20.0, 6.0, 0.0],
            act: Vec::new(),
        };
        let mut cache = scm::integrate::SolverCache::default();
        let opts = AdvanceOptions::default();
        let (mut halved_calls, mut most_halvings) = (0, 0);
        for step in 0..10 {
            let done = model
                .advance_cached(&s, &[], &prm, step as f64 * h, h, &opts, &mut cache)
                .unwrap_or_else(|e| panic!("k = {k}, step {step}: {e}"));
            let left = cache.parts().ledger.and_then(|l| l.stored).unwrap();
            let (start, exact) = (
                stored_in_contact(&model, &s),
                stored_in_contact(&model, &done.state),
            );
            if done.subdivided > 0 {
                halved_calls += 1;
                most_halvings = most_halvings.max(done.subdivided);
                assert!(
                    (left - exact).abs() <= 1e-4 * exact,
                    "k = {k}, step {step} (halved {} times): {left} J left, {exact} J at its end, {start} J at its start",
                    done.subdivided
                );
            }
            s = done.state;
        }
        // A half halved again: the estimate passes through the recursion, not one level.
        assert!(
            halved_calls >= 2 && most_halvings >= 2,
            "k = {k}: {halved_calls} calls halved, at most {most_halvings} times"
        );
    }
}
