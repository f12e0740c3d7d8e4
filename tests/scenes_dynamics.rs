//! The dynamics scenes: a box stack that settles and stays at rest, a two-link arm that pushes a
//! box, and the paper's planar pushing (a finger pushing a T-block).

use crate::common::scene;
use nalgebra::Vector3;
use scm::fmi::contract::{FmiModel, Phase};
use scm::integrate::Integrator;
use scm::sim::Simulation;

fn vr(sim: &Simulation, name: &str) -> u32 {
    sim.rows()
        .iter()
        .find(|(v, _)| v.name == name)
        .unwrap_or_else(|| panic!("no variable {name}"))
        .0
        .value_reference
}

/// Runs the box stack for 10 s in communication steps of 0.1 s and checks that it settles, then
/// neither drifts nor jitters.
fn box_stack_rests(integrator: Integrator, step: f64) {
    let mut sim = Simulation::from_file(&scene("box_stack")).unwrap();
    sim.model.integrator = integrator;
    sim.model.timestep = step;
    let h = 0.1;
    let mut settled = None;
    let mut kinetic = Vec::new();
    let mut max_drift: f64 = 0.0;
    for k in 0..100 {
        sim.do_step(k as f64 * h, h).unwrap();
        let s = &sim.data.current.state;
        kinetic.push(sim.model.energy(&s.q, &s.v).kinetic);
        if k == 9 {
            settled = Some(s.q.clone()); // t = 1 s
        }
        if let Some(q1) = &settled {
            // Positions of the three boxes (x, y, z of each free joint) and their orientation.
            for b in 0..3 {
                let o = 7 * b;
                max_drift = max_drift.max(
                    (Vector3::new(s.q[o], s.q[o + 1], s.q[o + 2])
                        - Vector3::new(q1[o], q1[o + 1], q1[o + 2]))
                    .norm(),
                );
                let dq: f64 = (0..4)
                    .map(|i| (s.q[o + 3 + i] - q1[o + 3 + i]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                max_drift = max_drift.max(dq * 0.05); // a rotation, as a displacement at 5 cm
            }
        }
    }
    let name = integrator.name();
    let late = kinetic[90..].iter().cloned().fold(0.0, f64::max);
    let early = kinetic[10..20].iter().cloned().fold(0.0, f64::max);
    println!("{name} (h = {step}): drift after 1 s {max_drift:e} m, kinetic energy max over 1–2 s {early:e} J, over 9–10 s {late:e} J");
    // At rest: every box has stopped (1 µJ is a speed of 1 mm/s of the lightest box).
    assert!(late < 1e-6, "{name}: kinetic energy {late} J after 9 s");
    // No drift: from 1 s to 10 s no box moves or turns by more than 1 µm.
    assert!(max_drift < 1e-6, "{name}: drift {max_drift} m");
    // No jitter growth: the last second is no livelier than the second after settling.
    assert!(
        late <= early.max(1e-12),
        "{name}: kinetic energy grew from {early} to {late}"
    );
    // The floor carries the whole stack, the bottom box carries the two above it.
    let weight = |m: f64| m * 9.81;
    let f = sim.contacts().to_vec();
    let pairs: Vec<(String, String)> = sim
        .model
        .pairs
        .iter()
        .map(|p| {
            (
                sim.model.tree.bodies[p.a].name.clone(),
                sim.model.tree.bodies[p.b].name.clone(),
            )
        })
        .collect();
    let force = |a: &str, b: &str| {
        f[pairs.iter().position(|(x, y)| x == a && y == b).unwrap()]
            .on_a
            .force
    };
    let (m_bottom, m_middle, m_top) = (1.728, 1.0, 0.512);
    assert!(
        (force("world", "bottom").z + weight(m_bottom + m_middle + m_top)).abs() < 1e-6,
        "{name}: floor carries {:?}",
        force("world", "bottom")
    );
    assert!(
        (force("bottom", "middle").z + weight(m_middle + m_top)).abs() < 1e-6,
        "{name}: bottom carries {:?}",
        force("bottom", "middle")
    );
    assert!(
        (force("middle", "top").z + weight(m_top)).abs() < 1e-6,
        "{name}: middle carries {:?}",
        force("middle", "top")
    );
}

#[test]
fn box_stack_settles_and_stays_at_rest_with_the_scene_integrator() {
    // Semi-implicit Euler at 1 ms: the stiffest modes (the top box on k = 1e5 N/m, and the
    // stiction of friction, μ λ_n / v_s per unit mass) are resolved. Measured: 1.4 s wall time.
    box_stack_rests(Integrator::SemiImplicitEuler, 0.001);
}

#[test]
fn box_stack_settles_and_stays_at_rest_with_implicit_euler_at_10_ms() {
    // Ten times the explicit step: the implicit method is stable where semi-implicit Euler is
    // not (h ω ≈ 4.5 on the top box), and lands on the same rest state.
    box_stack_rests(Integrator::ImplicitEuler, 0.01);
}

#[test]
fn the_arm_pushes_the_box() {
    // A controller outside the FMU (as a co-simulation host would run it) drives the motors
    // every 10 ms: PD on the shoulder towards an angle that grows at 0.6 rad/s up to 1.9 rad,
    // and on the elbow towards 0.
    let mut sim = Simulation::from_file(&scene("arm_push")).unwrap();
    let (sh, el) = (
        vr(&sim, "shoulder_motor.ctrl"),
        vr(&sim, "elbow_motor.ctrl"),
    );
    let fx = vr(&sim, "contact.tip.box.force.x");
    let dist = vr(&sim, "contact.tip.box.distance");
    let h = 0.01;
    let mut contact_at = None;
    let mut approached = false;
    let mut push = Vec::new();
    for k in 0..400 {
        let t = k as f64 * h;
        let s = sim.data.current.state.clone();
        let target = (0.6 * t).min(1.9);
        sim.set_real(
            sh,
            20.0 * (target - s.q[0]) - 4.0 * s.v[0],
            Phase::Simulation,
        )
        .unwrap();
        sim.set_real(el, -20.0 * s.q[1] - 2.0 * s.v[1], Phase::Simulation)
            .unwrap();
        sim.do_step(t, h).unwrap();
        let f = sim.get_real(fx).unwrap();
        if !approached && sim.get_real(dist).unwrap() < 0.005 {
            approached = true;
            // Until the tip came within 5 mm, the box had not moved.
            let b = &sim.data.current.state.q[2..];
            assert!(
                b.iter().all(|x| x.abs() < 1e-9),
                "box moved before contact: {b:?}"
            );
        }
        if contact_at.is_none() && f.abs() > 0.1 {
            contact_at = Some((t + h, sim.data.current.state.q[0]));
        }
        if (3.0..3.4).contains(&t) {
            push.push(f);
        }
        // The motors never give more than their control range allows.
        let tau = sim
            .model
            .actuator_forces(&s.q, &s.v, &sim.data.current.ctrl);
        assert!(tau.iter().all(|x| x.abs() <= 2.0 + 1e-12), "{tau:?}");
    }
    let (t_contact, angle) = contact_at.expect("the tip never touched the box");
    let s = &sim.data.current.state;
    println!(
        "contact at t = {t_contact} s, shoulder {angle}; box at ({}, {}, yaw {}); push {:?}",
        s.q[2], s.q[3], s.q[4], push
    );
    // The tip (2 cm) meets the box's face 5 cm from its centre on the 55 cm circle: cos θ =
    // 0.07/0.55, θ = 1.443 rad.
    assert!(
        (angle - 1.443).abs() < 0.02,
        "contact at shoulder angle {angle}"
    );
    // The tip, pushing along -x, moved the box by about its own travel after contact
    // (0.55 (sin 1.443 ... ) along the arc: 0.22 m), with little sideways motion or turning.
    assert!((-0.25..-0.18).contains(&s.q[2]), "box x {}", s.q[2]);
    assert!(
        s.q[3].abs() < 0.005 && s.q[4].abs() < 0.1,
        "box y {}, yaw {}",
        s.q[3],
        s.q[4]
    );
    // While it slides the tip pushes against the table's friction (frictionloss 2 N along x,
    // smoothed: a little less below the stiction velocity).
    let mean = push.iter().sum::<f64>() / push.len() as f64;
    assert!(
        (1.5..2.5).contains(&-mean) || (1.5..2.5).contains(&mean),
        "push {mean}"
    );
}

#[test]
fn the_finger_pushes_the_t_block() {
    let mut sim = Simulation::from_file(&scene("t_push")).unwrap();
    let (ax, ay) = (vr(&sim, "act_x.ctrl"), vr(&sim, "act_y.ctrl"));
    let h = 0.01;
    let mut touched = None;
    let mut last_yaw_rate: Option<f64> = None;
    for k in 0..300 {
        let t = k as f64 * h;
        // The finger stays 1 cm right of the stem's centre line and advances 10 cm/s for 2 s.
        sim.set_real(ax, 0.01, Phase::Simulation).unwrap();
        sim.set_real(ay, (0.1 * t).min(0.2), Phase::Simulation)
            .unwrap();
        sim.do_step(t, h).unwrap();
        let s = &sim.data.current.state;
        if k > 250 {
            // No jitter: the T's yaw rate never flips sign from one step to the next at more
            // than 1 mrad/s (the symptom of an unstable friction damper).
            if let Some(prev) = last_yaw_rate {
                assert!(
                    !(prev * s.v[2] < 0.0 && s.v[2].abs() > 1e-3),
                    "yaw rate flips: {prev} -> {}",
                    s.v[2]
                );
            }
            last_yaw_rate = Some(s.v[2]);
        }
        if touched.is_none() && s.q[1] > 1e-4 {
            touched = Some(s.q[4]);
        }
    }
    let s = &sim.data.current.state;
    let finger_at_contact = touched.expect("the T never moved");
    println!("T at ({}, {}, yaw {}), finger at ({}, {}), first moved with the finger at y = {finger_at_contact}", s.q[0], s.q[1], s.q[2], s.q[3], s.q[4]);
    // The finger (r = 1.5 cm, starting 25 cm below the T's centre) reaches the stem's end
    // (12.75 cm below) at a displacement of 9.75 cm; the position actuator then tracks its
    // target to within the force it needs against the friction.
    assert!(
        (finger_at_contact - 0.0975).abs() < 0.003,
        "{finger_at_contact}"
    );
    assert!(
        (s.q[3] - 0.01).abs() < 0.002 && (s.q[4] - 0.2).abs() < 0.01,
        "finger at ({}, {})",
        s.q[3],
        s.q[4]
    );
    // The T moved ahead of the finger by the finger's travel after contact, and the push 1 cm
    // right of its centre of mass turned it counterclockwise.
    assert!(
        (s.q[1] - (s.q[4] - finger_at_contact)).abs() < 0.01,
        "T y {} for finger travel {}",
        s.q[1],
        s.q[4] - finger_at_contact
    );
    assert!(s.q[2] > 0.002, "yaw {}", s.q[2]);
    // Once the finger stops, the table's friction stops the T (below the 1 cm/s stiction
    // velocity the smooth friction lets it creep).
    assert!(
        s.v[1].abs() < 0.01 && s.v[0].abs() < 0.01,
        "T still moving at {:?}",
        &s.v[..3]
    );
}
