//! Mocap bodies: loaded from `mocap="true"`, driven by the FMU inputs `B.pos.*` and `B.quat.*`,
//! moving at the input's rate over each communication step and landing exactly on the input,
//! pushing what they touch.

use crate::common::scene;
use nalgebra::{UnitQuaternion, Vector3};
use scm::dynamics::MOCAP_INPUTS;
use scm::fmi::contract::{Causality, FmiModel, Phase, StepError};
use scm::scene::load_str;
use scm::sim::Simulation;
use std::path::Path;

fn vr(sim: &Simulation, name: &str) -> u32 {
    sim.rows()
        .iter()
        .find(|(v, _)| v.name == name)
        .unwrap_or_else(|| panic!("no variable {name}"))
        .0
        .value_reference
}

fn mocap_push() -> Simulation {
    Simulation::from_file(&scene("mocap_push")).unwrap()
}

#[test]
fn mocap_bodies_are_loaded_with_their_inputs() {
    let sim = mocap_push();
    let tree = &sim.model.tree;
    assert_eq!(tree.mocap.len(), 1);
    let b = tree.mocap[0];
    assert_eq!(tree.bodies[b].name, "paddle");
    assert!(
        !tree.body_moves(b),
        "a mocap body has no degrees of freedom"
    );
    assert_eq!(sim.model.nu(), MOCAP_INPUTS);
    // Inputs: position and quaternion, with the scene pose as start values.
    for (name, start) in [
        ("paddle.pos.x", -0.11),
        ("paddle.pos.y", 0.0),
        ("paddle.pos.z", 0.05),
        ("paddle.quat.w", 1.0),
        ("paddle.quat.x", 0.0),
    ] {
        let (v, _) = &sim.rows()[vr(&sim, name) as usize];
        assert_eq!(v.causality, Causality::Input, "{name}");
        match v.var_type {
            scm::fmi::contract::VarType::Real { start: Some(s), .. } => {
                assert!((s - start).abs() < 1e-15, "{name}: {s}")
            }
            _ => panic!("{name} has no start"),
        }
    }
    // The pair box–paddle collides; paddle–world does not (neither has degrees of freedom).
    let names: Vec<(String, String)> = sim
        .model
        .pairs
        .iter()
        .map(|p| (tree.bodies[p.a].name.clone(), tree.bodies[p.b].name.clone()))
        .collect();
    assert_eq!(
        names,
        [
            ("world".to_string(), "box".to_string()),
            ("box".into(), "paddle".into())
        ]
    );
}

#[test]
fn misplaced_mocap_bodies_are_refused() {
    let base = r#"<mujoco model="m"><worldbody>
  <body name="m" mocap="true" pos="0 0 1"><geom type="sphere" size="0.1"/></body>
  <body name="b"><freejoint/><geom type="sphere" size="0.1"/></body>
</worldbody></mujoco>"#;
    assert!(load_str(base, Path::new("ok.xml")).is_ok());
    for (from, to, words) in [
        (
            r#"<geom type="sphere" size="0.1"/></body>"#,
            r#"<joint type="slide"/><geom type="sphere" size="0.1"/></body>"#,
            "cannot have joints",
        ),
        (
            r#"<geom type="sphere" size="0.1"/></body>"#,
            r#"<geom type="sphere" size="0.1"/><body name="c"><geom size="0.1"/></body></body>"#,
            "cannot have child bodies",
        ),
        (
            r#"<body name="b"><freejoint/><geom type="sphere" size="0.1"/></body>"#,
            r#"<body name="b"><freejoint/><geom type="sphere" size="0.1"/><body name="n" mocap="true"/></body>"#,
            "child of the worldbody",
        ),
        (r#"mocap="true""#, r#"mocap="yes""#, "true or false"),
    ] {
        assert!(base.contains(from), "{from}");
        let e = load_str(&base.replacen(from, to, 1), Path::new("bad.xml")).unwrap_err();
        assert!(e.to_string().contains(words), "'{words}' not in {e}");
        assert!(e.line >= 2, "{e}");
    }
}

#[test]
fn the_pose_moves_at_the_input_rate_and_lands_on_the_input() {
    let mut sim = mocap_push();
    let (px, qw, qz) = (
        vr(&sim, "paddle.pos.x"),
        vr(&sim, "paddle.quat.w"),
        vr(&sim, "paddle.quat.z"),
    );
    // Before initialization a pose is taken at once, at rest.
    sim.set_real(px, -0.2, Phase::Instantiated).unwrap();
    assert_eq!((sim.inputs()[0], sim.inputs()[7]), (-0.2, 0.0));
    // During the simulation it is the target of the next communication step.
    let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.3);
    sim.set_real(px, -0.19, Phase::Simulation).unwrap();
    sim.set_real(qw, turn.w, Phase::Simulation).unwrap();
    sim.set_real(qz, turn.k, Phase::Simulation).unwrap();
    assert_eq!(
        sim.inputs()[0],
        -0.2,
        "the pose does not jump when the input is set"
    );
    assert_eq!(
        sim.get_real(px).unwrap(),
        -0.19,
        "the input reads back as set"
    );
    sim.do_step(0.0, 0.05).unwrap();
    let u = sim.inputs();
    // Landed exactly on the input, with the step's rate as its velocity.
    assert_eq!(u[0], -0.19);
    assert!((u[3] - turn.w).abs() < 1e-15 && (u[6] - turn.k).abs() < 1e-15);
    assert!(
        (u[7] - 0.01 / 0.05).abs() < 1e-12,
        "linear velocity {}",
        u[7]
    );
    assert!(
        (u[12] - 0.3 / 0.05).abs() < 1e-12 && u[10].abs() < 1e-15,
        "angular velocity {:?}",
        &u[10..13]
    );
    // Holding the input still: the next step brings the body to rest.
    sim.do_step(0.05, 0.05).unwrap();
    assert_eq!(sim.inputs()[7..13], [0.0; 6]);
    // Inside a step the body follows the straight path: the inputs dt later.
    let u: [f64; 13] = [
        -0.2, 0.0, 0.05, 1.0, 0.0, 0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.0, 6.0,
    ];
    let half: Vec<f64> = sim.model.inputs_after(&u, 0.025);
    assert!((half[0] + 0.195).abs() < 1e-15);
    let r = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
        half[3], half[4], half[5], half[6],
    ));
    assert!((r.angle() - 0.15).abs() < 1e-14 && (r.axis().unwrap().z - 1.0).abs() < 1e-14);
    // A zero quaternion is refused when the step needs it.
    for k in 0..4 {
        sim.set_real(qw + k, 0.0, Phase::Simulation).unwrap();
    }
    let before = sim.data.current.clone();
    assert!(
        matches!(sim.do_step(0.1, 0.05), Err(StepError::Error(m)) if m.contains("paddle.quat is zero"))
    );
    assert_eq!(sim.data.current, before);
}

#[test]
fn the_paddle_pushes_the_box() {
    let mut sim = mocap_push();
    let px = vr(&sim, "paddle.pos.x");
    let (h, speed) = (0.01, 0.1);
    let fx = vr(&sim, "contact.box.paddle.force.x");
    let mut push = Vec::new();
    for k in 0..150 {
        let t = k as f64 * h;
        sim.set_real(px, -0.11 + speed * (t + h), Phase::Simulation)
            .unwrap();
        sim.do_step(t, h).unwrap();
        push.push(sim.get_real(fx).unwrap());
    }
    let q = &sim.data.current.state;
    println!(
        "box at x = {:.4}, z = {:.5}, vx = {:.4}; push force on the box over the last 0.5 s: {:?}",
        q.q[0],
        q.q[2],
        q.v[0],
        &push[100..]
    );
    // The paddle reaches the box after 0.3 s (a 3 cm gap at 0.1 m/s) and drives
    // it: after 1.5 s the box has moved about speed · (1.5 - 0.3) s = 0.12 m and slides with
    // the paddle.
    assert!((q.q[0] - 0.12).abs() < 0.01, "box at {}", q.q[0]);
    assert!(
        (q.v[0] - speed).abs() < 0.01 * speed,
        "box slides at {}",
        q.v[0]
    );
    // Sliding at 0.1 m/s the floor's friction is μ m g v/sqrt(v_s² + v²) = 2.40 N: the paddle
    // pushes with that force (on the box: +x, so the pair's first body, the box, gets it).
    let mean: f64 = push[100..].iter().sum::<f64>() / 50.0;
    let friction = 0.5 * 0.5 * 9.81 * speed / (0.02f64.powi(2) + speed * speed).sqrt();
    // Measured 2.4107 N against 2.4049 N: the paddle, 0.2 mm above the box centre, also
    // presses it down a little, which adds to the friction; 1 % covers it.
    assert!(
        (mean - friction).abs() < 0.01 * friction,
        "push {mean} vs friction {friction}"
    );
    // It stays on the floor, upright.
    assert!(
        (q.q[2] - 0.05).abs() < 1e-3 && q.q[3].abs() > 0.999,
        "z {}, quat w {}",
        q.q[2],
        q.q[3]
    );
}

#[test]
fn inputs_of_the_wrong_length_are_refused() {
    // The actuator controls alone (none here) would leave the paddle nowhere: refused, with the
    // expected length in the message.
    let sim = mocap_push();
    let m = &sim.model;
    let (q, v) = (
        sim.data.current.state.q.clone(),
        sim.data.current.state.v.clone(),
    );
    let e = m.forward(&q, &v, &[], &m.contact).unwrap_err();
    assert!(e.to_string().contains("expected 13"), "{e}");
    let e = m
        .advance(
            &sim.data.current.state,
            &[0.0; 5],
            &m.contact,
            0.0,
            0.01,
            &Default::default(),
        )
        .unwrap_err();
    assert!(e.to_string().contains("5 inputs given"), "{e}");
    // The full vector works.
    assert!(m.forward(&q, &v, &sim.inputs(), &m.contact).is_ok());
}
