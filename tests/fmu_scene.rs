//! The FMU of each bundled scene through the safe instance API (the same code the C ABI calls):
//! capabilities declared only when provided, exact directional derivatives against central
//! differences, structural dependencies complete, FMU state saved, serialized and restored bit
//! for bit, foreign and corrupt states refused, Model Exchange (states, derivatives, quaternion
//! projection), tunable parameters and reset, the contact log category.

use scm::fmi::contract::{Causality, FmiModel, LogCategory, ModelInfo};
use scm::fmi::ffi::*;
use scm::fmi::instance::{FmuStateHandle, Instance, LogSink};
use scm::fmi::state_machine::Interface;
use scm::sim::{Simulation, Slot};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

type Log = Arc<Mutex<Vec<(fmi2Status, String, String)>>>;

struct Capture(Log);

impl LogSink for Capture {
    fn log(&self, status: fmi2Status, category: &str, message: &str) {
        self.0
            .lock()
            .unwrap()
            .push((status, category.to_owned(), message.to_owned()));
    }
}

/// A `resources/` folder holding `name`'s scene and the meshes it uses, as `scm pack` lays it
/// out, made once per scene and process.
fn resources(name: &str) -> (String, String) {
    let dir = std::env::temp_dir()
        .join(format!("scm-fmu-scene-{}-{name}", std::process::id()))
        .join("resources");
    let described = scm::pack::describe(&crate::common::scene(name)).unwrap();
    for (file, bytes) in &described.resources {
        let path = dir.join(file);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, bytes).unwrap();
    }
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join(scm::sim::SCENE_FILE), &described.scene_text).unwrap();
    (
        format!("file://{}", dir.display()),
        scm::sim::guid(&described.scene_text),
    )
}

fn instance(name: &str, interface: Interface) -> (Instance<Simulation>, Log) {
    let (uri, guid) = resources(name);
    let log: Log = Arc::default();
    let inst = Instance::<Simulation>::instantiate(
        name,
        interface,
        &guid,
        &uri,
        false,
        Some(Box::new(Capture(log.clone()))),
    )
    .unwrap();
    (inst, log)
}

fn initialized(name: &str, interface: Interface) -> (Instance<Simulation>, Log) {
    let (mut inst, log) = instance(name, interface);
    assert_eq!(inst.setup_experiment(None, 0.0, None), fmi2OK);
    assert_eq!(inst.enter_initialization_mode(), fmi2OK);
    assert_eq!(inst.exit_initialization_mode(), fmi2OK);
    (inst, log)
}

/// The names of the variables an unknown of `<ModelStructure>` (an output or a state
/// derivative) depends on.
fn dep_names(info: &ModelInfo, unknown: &str) -> Vec<String> {
    let u = vr(info, unknown);
    let d = (info.structure.outputs.iter())
        .chain(&info.structure.derivatives)
        .find(|(x, _)| *x == u)
        .and_then(|(_, d)| d.clone())
        .unwrap();
    let name = |r: &u32| {
        let v = info.variables.iter().find(|v| v.value_reference == *r);
        v.unwrap().name.clone()
    };
    d.iter().map(name).collect()
}

fn vr(info: &ModelInfo, name: &str) -> u32 {
    info.variables
        .iter()
        .find(|v| v.name == name)
        .unwrap_or_else(|| panic!("no variable {name}"))
        .value_reference
}

fn real(inst: &mut Instance<Simulation>, vr: u32) -> f64 {
    let mut v = [0.0];
    assert_eq!(inst.get_real(&[vr], &mut v), fmi2OK);
    v[0]
}

/// Every Real output, as bits.
fn outputs(inst: &mut Instance<Simulation>) -> Vec<u64> {
    let vrs: Vec<u32> = inst
        .model()
        .info()
        .variables
        .iter()
        .filter(|v| v.causality == Causality::Output)
        .map(|v| v.value_reference)
        .collect();
    let mut values = vec![0.0; vrs.len()];
    assert_eq!(inst.get_real(&vrs, &mut values), fmi2OK);
    values.iter().map(|v| v.to_bits()).collect()
}

fn scenes() -> Vec<String> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("resources/scenes");
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A state of each scene where its contacts are active: sphere_drop and mesh_drop resting on
/// the plane (after 0.6 s), sphere_pair at its start (1 cm deep), t_push after the finger has been pushed
/// into the T for 0.35 s with a controlled target 3 cm in, plus some sideways velocity on
/// every coordinate so that no partial derivative vanishes by symmetry.
fn in_contact(name: &str) -> Simulation {
    let mut sim = Simulation::from_file(&crate::common::scene(name)).unwrap();
    match name {
        "sphere_drop" | "mesh_drop" => {
            sim.do_step(0.0, 0.6).unwrap();
        }
        "t_push" => {
            let ctrl_y = vr(sim.info(), "act_y.ctrl");
            sim.set_real(
                ctrl_y,
                0.25 - 0.1 - 0.015 + 0.03,
                scm::fmi::contract::Phase::Simulation,
            )
            .unwrap();
            let ctrl_x = vr(sim.info(), "act_x.ctrl");
            sim.set_real(ctrl_x, 0.01, scm::fmi::contract::Phase::Simulation)
                .unwrap();
            sim.do_step(0.0, 0.35).unwrap();
        }
        // The box hanging from the pad, the pull's control inside its range (at its end, 0,
        // a central difference halves the one-sided slope).
        "adhesion_pick" => {
            for (input, value) in [("grip.ctrl", 0.6), ("lift.ctrl", 0.01)] {
                let vr = vr(sim.info(), input);
                sim.set_real(vr, value, scm::fmi::contract::Phase::Simulation)
                    .unwrap();
            }
            sim.do_step(0.0, 0.3).unwrap();
        }
        _ => {}
    }
    let mut rng = crate::common::Lcg(7);
    for v in sim.data.current.state.v.iter_mut() {
        *v += rng.range(-0.02, 0.02);
    }
    sim.exit_initialization().unwrap();
    sim
}

/// A known's current value and a central-difference step for it.
fn known_step(slot: Slot, x: f64) -> f64 {
    match slot {
        // Contact varies on the scale of ε3 = 1e-4 m and v_s = 1e-2 m/s: steps far below.
        Slot::Q(_) | Slot::V(_) => 1e-8,
        Slot::Ctrl(_) | Slot::Act(_) => 1e-7,
        // Parameters: relative steps; their outputs vary on the parameter's own scale.
        _ => 1e-4 * x.abs(),
    }
}

fn set_known(sim: &mut Simulation, slot: Slot, vr: u32, x: f64) {
    match slot {
        Slot::Q(i) => sim.data.current.state.q[i] = x,
        Slot::V(i) => sim.data.current.state.v[i] = x,
        Slot::Act(k) => sim.data.current.state.act[k] = x,
        _ => sim
            .set_real(vr, x, scm::fmi::contract::Phase::Simulation)
            .unwrap(),
    }
    // Drop cached outputs: set the state through the Model Exchange entry point.
    let x = sim.continuous_states();
    sim.set_continuous_states(&x).unwrap();
}

#[test]
fn capability_flags_are_declared_and_provided() {
    for name in scenes() {
        let (mut inst, _) = initialized(&name, Interface::CoSimulation);
        let caps = inst.model().info().capabilities;
        assert!(
            caps.can_get_and_set_fmu_state
                && caps.can_serialize_fmu_state
                && caps.provides_directional_derivative,
            "{name}"
        );
        assert!(inst.model().info().model_exchange);
        let xml = scm::pack::describe(&crate::common::scene(&name))
            .unwrap()
            .model_description;
        for flag in [
            "canGetAndSetFMUstate=\"true\"",
            "canSerializeFMUstate=\"true\"",
            "providesDirectionalDerivative=\"true\"",
        ] {
            assert_eq!(
                xml.matches(flag).count(),
                2,
                "{name}: {flag} in both ModelExchange and CoSimulation"
            );
        }
        // Each declared capability answers.
        let mut slot = None;
        assert_eq!(inst.get_fmu_state(&mut slot), fmi2OK);
        let mut size = 0;
        assert_eq!(inst.serialized_fmu_state_size(slot, &mut size), fmi2OK);
        assert!(size > 0);
        let structure = inst.model().info().structure.clone();
        let (unknown, deps) = &structure
            .outputs
            .iter()
            .find(|(_, d)| d.as_ref().is_some_and(|d| !d.is_empty()))
            .unwrap()
            .clone();
        let deps = deps.clone().unwrap();
        let mut dv = [0.0];
        assert_eq!(
            inst.get_directional_derivative(&[*unknown], &deps[..1], &[1.0], &mut dv),
            fmi2OK,
            "{name}"
        );
    }
}

/// Every declared (unknown, known) pair of `<ModelStructure>` against central differences of
/// the same model, at a state in contact; and every pair that is not declared is exactly zero.
#[test]
fn directional_derivatives_match_central_differences_and_dependencies_are_complete() {
    for name in scenes() {
        check_dependencies(&name, &mut in_contact(&name));
    }
}

/// Fixed tendons tie subtrees together: an arm's accelerations depend on the coordinates of
/// the other arm its tendon holds (spring, damper, dry friction, limit and a servo on the
/// tendon) and on the servo's control, a joint equality ties a fourth arm to them and a
/// connect a fifth, and nothing else; the declared dependencies say so, exactly.
#[test]
fn dependencies_follow_tendons_across_subtrees() {
    let xml = r#"<mujoco>
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="ja" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" contype="0" conaffinity="0"/>
    </body>
    <body name="b" pos="0.5 0 1">
      <joint name="jb" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.02" contype="0" conaffinity="0"/>
    </body>
    <body name="c" pos="1 0 1">
      <joint name="jc" type="slide" axis="1 0 0"/>
      <geom type="sphere" size="0.03" contype="0" conaffinity="0"/>
    </body>
    <body name="d" pos="1.5 0 1">
      <joint name="jd" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" contype="0" conaffinity="0"/>
    </body>
    <body name="e" pos="1.7 0 1">
      <joint name="je" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <equality>
    <joint joint1="jd" joint2="jb" polycoef="0.1 0.5 0.3 0 0"/>
    <connect body1="e" body2="d" anchor="0 0 -0.2"/>
  </equality>
  <tendon>
    <fixed name="tie" stiffness="5" damping="0.3" frictionloss="0.1" range="-0.2 0.05">
      <joint joint="ja" coef="1"/>
      <joint joint="jb" coef="-0.5"/>
    </fixed>
  </tendon>
  <actuator>
    <position name="servo" tendon="tie" kp="2" kv="0.1"/>
  </actuator>
</mujoco>"#;
    let dir = std::env::temp_dir().join(format!("scm_tendon_deps_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("tendons.xml");
    std::fs::write(&path, xml).unwrap();
    let mut sim = Simulation::from_file(&path).unwrap();
    // Past the limit, moving: every term of the tendon's force acts.
    sim.data.current.state.q = vec![0.2, -0.1, 0.0, 0.4, -0.2];
    sim.data.current.state.v = vec![0.3, -0.2, 0.1, -0.3, 0.5];
    let x = sim.continuous_states();
    sim.set_continuous_states(&x).unwrap();
    // The tendon's limit force is an output, depending on its joints' coordinates and
    // velocities alone, and acting here (the tendon is past its upper limit).
    let force = vr(sim.info(), "tendon.tie.limit.force");
    assert!(sim.get_real(force).unwrap() < -1e-3);
    // The names an unknown of `<ModelStructure>` (an output or a state derivative) depends on.
    let deps = |unknown: &str| dep_names(sim.info(), unknown);
    assert_eq!(
        deps("tendon.tie.limit.force"),
        ["ja.q", "ja.v", "jb.q", "jb.v"]
    );
    let a = deps("der(ja.v)");
    assert!(
        a.contains(&"jb.q".to_string()) && a.contains(&"jb.v".to_string()),
        "{a:?}"
    );
    assert!(!a.iter().any(|n| n.starts_with("jc.")), "{a:?}");
    let b = deps("der(jb.v)");
    assert!(b.contains(&"servo.ctrl".to_string()), "{b:?}");
    assert!(!deps("der(jc.v)").contains(&"servo.ctrl".to_string()));
    // The joint equality ties the fourth arm to the second (and through the tendon, the first).
    let d = deps("der(jd.v)");
    assert!(
        d.contains(&"jb.q".to_string()) && d.contains(&"ja.q".to_string()),
        "{d:?}"
    );
    assert!(deps("der(jb.v)").contains(&"jd.q".to_string()));
    // The connect ties a fifth arm to the fourth.
    assert!(deps("der(je.v)").contains(&"jd.q".to_string()));
    assert!(deps("der(jd.v)").contains(&"je.v".to_string()));
    // The equalities and the tendon's limit act at MuJoCo's statics with its impedance (the
    // file's Euler): steps 100 times longer, and rounding of 1e-12 of the unknowns.
    check_dependencies_stepped("tendons", &mut sim, 100.0, 1e-12);
    std::fs::remove_dir_all(&dir).ok();
}

/// Spatial tendons tie the bodies of their sites: an arm pulled over a pulley by a string from
/// another arm depends on that arm's coordinates (spring with a deadband, damper, dry friction
/// and limit all acting), a segment within one body exerts nothing, and a string from a mocap
/// body makes the arm it pulls depend on the mocap inputs; nothing else is tied. The declared
/// dependencies say so, and every partial (the limit force's and the accelerations') matches
/// central differences.
#[test]
fn dependencies_follow_spatial_tendons() {
    let xml = r#"<mujoco>
  <worldbody>
    <site name="w1" pos="0.3 0 1.5"/>
    <site name="w2" pos="1.0 0 1.5"/>
    <body name="a" pos="0 0 1">
      <joint name="ja" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" contype="0" conaffinity="0"/>
      <site name="a_tip" pos="0.3 0 0"/>
    </body>
    <body name="b" pos="0.8 0 1">
      <joint name="jb" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.02" contype="0" conaffinity="0"/>
      <site name="b_mid" pos="0.1 0 0"/>
      <site name="b_tip" pos="0.25 0 0"/>
    </body>
    <body name="c" pos="2 0 1">
      <joint name="jc" type="slide" axis="1 0 0"/>
      <geom type="sphere" size="0.03" contype="0" conaffinity="0"/>
      <site name="c_site" pos="0 0 0.03"/>
    </body>
    <body name="d" pos="3 0 1">
      <joint name="jd" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" contype="0" conaffinity="0"/>
      <site name="d_tip" pos="0.2 0 0"/>
    </body>
    <body name="hand" mocap="true" pos="2.2 0 1.4">
      <site name="hand_site"/>
    </body>
  </worldbody>
  <tendon>
    <spatial name="string" stiffness="20" damping="0.5" frictionloss="0.1" springlength="0.4 0.5" range="0 0.6">
      <site site="a_tip"/>
      <site site="w1"/>
      <pulley divisor="2"/>
      <site site="w2"/>
      <site site="b_tip"/>
      <site site="b_mid"/>
    </spatial>
    <spatial name="leash" stiffness="50" range="0 0.3">
      <site site="hand_site"/>
      <site site="c_site"/>
    </spatial>
    <spatial name="cord">
      <site site="w2"/>
      <site site="d_tip"/>
    </spatial>
  </tendon>
  <actuator>
    <motor name="pull" tendon="string" gear="2"/>
    <position name="servo" tendon="cord" kp="30" kv="2"/>
  </actuator>
</mujoco>"#;
    let dir = std::env::temp_dir().join(format!("scm_spatial_deps_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("strings.xml");
    std::fs::write(&path, xml).unwrap();
    let mut sim = Simulation::from_file(&path).unwrap();
    assert_eq!(sim.model.spatial_tendons.len(), 3);
    // Both arms moving, the string past its deadband and its limit.
    sim.data.current.state.q = vec![0.2, -0.3, 0.05, 0.1];
    sim.data.current.state.v = vec![0.4, -0.6, 0.2, 0.3];
    let x = sim.continuous_states();
    sim.set_continuous_states(&x).unwrap();
    let force = vr(sim.info(), "tendon.string.limit.force");
    assert!(
        sim.get_real(force).unwrap() < -1e-3,
        "the string's limit acts"
    );
    let deps = |unknown: &str| dep_names(sim.info(), unknown);
    assert_eq!(
        deps("tendon.string.limit.force"),
        ["ja.q", "ja.v", "jb.q", "jb.v"]
    );
    let a = deps("der(ja.v)");
    assert!(
        a.contains(&"jb.q".into()) && a.contains(&"jb.v".into()),
        "{a:?}"
    );
    assert!(
        !a.iter()
            .any(|n| n.starts_with("jc.") || n.starts_with("jd.")),
        "{a:?}"
    );
    let c = deps("der(jc.v)");
    assert!(c.contains(&"hand.pos.z".into()), "{c:?}");
    assert!(!c.iter().any(|n| n.starts_with("ja.")), "{c:?}");
    // An actuator on a spatial tendon moves the joints of its sites' bodies; the servo on the
    // cord (no force of its own) ties the fourth arm to its controls alone.
    assert!(a.contains(&"pull.ctrl".into()), "{a:?}");
    assert!(deps("der(jb.v)").contains(&"pull.ctrl".into()));
    assert_eq!(deps("der(jd.v)"), ["jd.q", "jd.v", "servo.ctrl"]);
    assert!(!c.iter().any(|n| n.ends_with(".ctrl")), "{c:?}");
    for (name, u) in [("pull.ctrl", 0.7), ("servo.ctrl", 0.3)] {
        let r = vr(sim.info(), name);
        set_known(&mut sim, Slot::Ctrl(0), r, u);
    }
    check_dependencies("spatial tendons", &mut sim);
    std::fs::remove_dir_all(&dir).ok();
}

/// Actuators on sites act on the bodies of their sites only: the drone's accelerations depend
/// on its four motors' controls and not on the arm's, the arm's on its servos' and not on the
/// drone's; every partial (through the site's moment, its velocity in the servo's damping and
/// the gear's torque) matches central differences.
#[test]
fn site_actuators_depend_on_their_bodies_and_match_central_differences() {
    let xml = include_str!("fixtures/site_actuators.xml");
    let dir = std::env::temp_dir().join(format!("scm_site_deps_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("drone.xml");
    std::fs::write(&path, xml).unwrap();
    let mut sim = Simulation::from_file(&path).unwrap();
    sim.data.current.state.v = (0..sim.model.tree.nv)
        .map(|k| 0.2 - 0.05 * k as f64)
        .collect();
    for (k, name) in ["m1", "m2", "m3", "m4", "push", "drag", "aff"]
        .iter()
        .enumerate()
    {
        let r = vr(sim.info(), &format!("{name}.ctrl"));
        set_known(&mut sim, Slot::Ctrl(k), r, 0.05 + 0.01 * k as f64);
    }
    let info = sim.info().clone();
    let deps = |unknown: &str| dep_names(&info, unknown);
    let drone = deps("der(drone.linvel.z)");
    assert!(drone.contains(&"m3.ctrl".into()), "{drone:?}");
    assert!(!drone.contains(&"push.ctrl".into()), "{drone:?}");
    let arm = deps("der(hinge.v)");
    assert!(
        arm.contains(&"push.ctrl".into()) && arm.contains(&"drag.ctrl".into()),
        "{arm:?}"
    );
    assert!(!arm.contains(&"m1.ctrl".into()), "{arm:?}");
    check_dependencies("site actuators", &mut sim);
    std::fs::remove_dir_all(&dir).ok();
}

/// Every declared (unknown, known) pair of `sim`'s `<ModelStructure>` against central
/// differences; every pair that is not declared exactly zero.
fn check_dependencies(name: &str, sim: &mut Simulation) {
    check_dependencies_stepped(name, sim, 1.0, 64.0 * f64::EPSILON);
}

/// [`check_dependencies`] with the steps of the states and inputs `longer` times
/// [`known_step`]'s and the unknowns' rounding taken as `rounding` of their size: for scenes
/// whose values round further than 64 ε (equalities and tendon limits at MuJoCo's statics,
/// gains 10 to 20 times their reference, most of whose force the inertia MuJoCo's impedance
/// adds cancels: 1e-11 absolute on accelerations of 50 rad/s², measured), and whose own scale
/// is far above the steps.
fn check_dependencies_stepped(name: &str, sim: &mut Simulation, longer: f64, rounding: f64) {
    {
        let info = sim.info().clone();
        let rows: Vec<_> = sim.rows().to_vec();
        let unknowns: Vec<(u32, Slot, String)> = rows
            .iter()
            .filter(|(_, s)| scm::sim::structure::knowns_of(&sim.model, *s).is_some())
            .map(|(v, s)| (v.value_reference, *s, v.name.clone()))
            .collect();
        let knowns: Vec<(u32, Slot, String)> = rows
            .iter()
            .filter(|(_, s)| {
                matches!(
                    s,
                    Slot::Q(_) | Slot::V(_) | Slot::Act(_) | Slot::Ctrl(_) | Slot::Param(_)
                )
            })
            .map(|(v, s)| (v.value_reference, *s, v.name.clone()))
            .collect();
        // Declared dependencies: InitialUnknowns lists parameters too; Outputs and Derivatives
        // the states and inputs.
        let declared = |u: u32, k: u32| -> bool {
            let s = &info.structure;
            s.outputs
                .iter()
                .chain(&s.derivatives)
                .chain(&s.initial_unknowns)
                .any(|(x, d)| *x == u && d.as_ref().is_some_and(|d| d.contains(&k)))
        };
        let base = sim.data.current.clone();
        let (mut checked, mut zero) = (0, 0);
        for (kvr, kslot, kname) in &knowns {
            // The column of the Jacobian for this known, exactly.
            let uvrs: Vec<u32> = unknowns.iter().map(|u| u.0).collect();
            let exact = sim.directional_derivative(&uvrs, &[*kvr], &[1.0]).unwrap();
            let x0 = sim.get_real(*kvr).unwrap();
            let h = match kslot {
                Slot::Param(_) => known_step(*kslot, x0),
                _ => known_step(*kslot, x0) * longer,
            };
            let mut eval = |x: f64| -> Vec<f64> {
                set_known(sim, *kslot, *kvr, x);
                let out = uvrs.iter().map(|&u| sim.get_real(u).unwrap()).collect();
                sim.data.current = base.clone();
                set_known(sim, *kslot, *kvr, x0);
                out
            };
            let (plus, minus) = (eval(x0 + h), eval(x0 - h));
            for (i, (uvr, _, uname)) in unknowns.iter().enumerate() {
                let fd = (plus[i] - minus[i]) / (2.0 * h);
                let value = sim.get_real(*uvr).unwrap();
                // Central differences: truncation O((h/scale)²) ≤ 1e-8 relative; round-off is
                // about ε·|y|/h times the cancellation inside the model (forces of ~10 N summed
                // into accelerations), e.g. 64 · 2e-16 · 10 / 1e-8 m = 1e-5 against partials of
                // 1e2..1e4.
                let tol = 1e-5 * exact[i].abs().max(fd.abs()) + rounding * value.abs().max(1.0) / h;
                assert!((exact[i] - fd).abs() <= tol, "{name}: d {uname} / d {kname}: exact {} vs central difference {fd} (tol {tol})", exact[i]);
                if declared(*uvr, *kvr) {
                    checked += 1;
                } else {
                    assert_eq!(
                        exact[i], 0.0,
                        "{name}: d {uname} / d {kname} = {} but ModelStructure does not declare it",
                        exact[i]
                    );
                    zero += 1;
                }
            }
        }
        eprintln!("{name}: {checked} declared partials checked against central differences, {zero} undeclared ones exactly zero");
        assert!(checked > 0 && zero > 0);
    }
}

#[test]
fn dependencies_follow_slider_cranks_and_activations() {
    // A slider-crank whose crank is on one subtree and whose slider site rides on another ties
    // their accelerations; a filtered actuator's acceleration depends on its activation, not
    // its control, and its activation's rate on both; a third subtree stays apart.
    let xml = r#"<mujoco>
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="ja" axis="0 0 1" damping="0.1"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.01" contype="0" conaffinity="0"/>
      <site name="crank" pos="0.1 0 0"/>
    </body>
    <body name="b" pos="0 -0.1 1">
      <joint name="jb" axis="0 0 1"/>
      <geom type="capsule" fromto="0 0 0 0 -0.1 0" size="0.01" contype="0" conaffinity="0"/>
      <site name="slider" pos="0 -0.05 0" zaxis="1 0.5 0"/>
    </body>
    <body name="c" pos="2 0 1">
      <joint name="jc" type="slide" axis="1 0 0"/>
      <geom type="sphere" size="0.03" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <actuator>
    <position name="crank" cranksite="crank" slidersite="slider" cranklength="0.12" kp="20" kv="0.5"/>
    <general name="filtered" joint="jc" dyntype="filter" dynprm="0.05" gainprm="3" biastype="affine" biasprm="0 -2 -0.3"/>
  </actuator>
</mujoco>"#;
    let dir = std::env::temp_dir().join(format!("scm_crank_deps_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("crank.xml");
    std::fs::write(&path, xml).unwrap();
    let mut sim = Simulation::from_file(&path).unwrap();
    sim.data.current.state.q = vec![0.3, -0.2, 0.05];
    sim.data.current.state.v = vec![0.4, -0.6, 0.2];
    sim.data.current.state.act = vec![0.7];
    sim.data.current.ctrl = vec![0.02, -0.4];
    let x = sim.continuous_states();
    sim.set_continuous_states(&x).unwrap();
    check_dependencies("crank", &mut sim);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn declared_dependencies_are_not_everything() {
    // t_push: the T-block's accelerations do not depend on the finger's controls (only through
    // contact, after integration), the finger's positions' derivatives only on its velocities.
    let sim = Simulation::from_file(&crate::common::scene("t_push")).unwrap();
    let info = sim.info();
    fn deps_in(info: &ModelInfo, name: &str) -> Vec<u32> {
        let u = vr(info, name);
        info.structure
            .derivatives
            .iter()
            .chain(&info.structure.outputs)
            .find(|(x, _)| *x == u)
            .unwrap()
            .1
            .clone()
            .unwrap()
    }
    let deps = |name: &str| deps_in(info, name);
    assert!(!deps("der(t_x.v)").contains(&vr(info, "act_x.ctrl")));
    assert!(deps("der(finger_x.v)").contains(&vr(info, "act_x.ctrl")));
    assert_eq!(deps("der(finger_x.q)"), vec![vr(info, "finger_x.v")]);
    assert!(
        !deps("contact.tblock.finger.distance").contains(&vr(info, "t_x.v")),
        "a distance depends on positions only"
    );
    // sphere_drop: der(quat.w) depends on the other three components and ω only.
    let sim = Simulation::from_file(&crate::common::scene("sphere_drop")).unwrap();
    let info = sim.info();
    let d = deps_in(info, "der(ball.quat.w)");
    let expect: Vec<u32> = [
        "ball.quat.x",
        "ball.quat.y",
        "ball.quat.z",
        "ball.angvel.x",
        "ball.angvel.y",
        "ball.angvel.z",
    ]
    .iter()
    .map(|n| vr(info, n))
    .collect();
    assert_eq!(d, expect);
}

#[test]
fn directional_derivative_refuses_what_is_not_a_known_or_unknown() {
    let (mut inst, log) = initialized("t_push", Interface::CoSimulation);
    let info = inst.model().info().clone();
    let force = vr(&info, "contact.tblock.finger.force.y");
    let mut out = [0.0];
    assert_eq!(
        inst.get_directional_derivative(&[force], &[vr(&info, "solver.step")], &[1.0], &mut out),
        fmi2Error
    );
    assert!(
        log.lock()
            .unwrap()
            .last()
            .unwrap()
            .2
            .contains("solver.step (value reference"),
        "{:?}",
        log.lock().unwrap().last()
    );
    assert_eq!(
        inst.get_directional_derivative(&[vr(&info, "act_x.ctrl")], &[force], &[1.0], &mut out),
        fmi2Error
    );
    assert_eq!(
        inst.get_directional_derivative(&[force], &[vr(&info, "t_x.q")], &[f64::NAN], &mut out),
        fmi2Error
    );
    assert_eq!(
        inst.get_directional_derivative(&[force], &[9999], &[1.0], &mut out),
        fmi2Error
    );
}

/// Saves a state after `before` steps, runs `after` more; restores (directly, and after a
/// serialize/deserialize round trip, also into a fresh instance) and reruns: bit for bit.
#[test]
fn a_rollout_resumed_from_a_saved_or_serialized_state_is_bit_identical() {
    for name in scenes() {
        let (mut inst, _) = initialized(&name, Interface::CoSimulation);
        let h = 0.01;
        let (before, after) = (30, 20);
        let ctrl: Vec<u32> = inst
            .model()
            .info()
            .variables
            .iter()
            .filter(|v| v.causality == Causality::Input)
            .map(|v| v.value_reference)
            .collect();
        let run = |inst: &mut Instance<Simulation>, from: usize, n: usize| -> Vec<Vec<u64>> {
            (from..from + n)
                .map(|k| {
                    // A control signal that changes every step, so the inputs are part of what
                    // must be reproduced.
                    for (i, &c) in ctrl.iter().enumerate() {
                        assert_eq!(
                            inst.set_real(&[c], &[0.05 * ((k + i) as f64 * 0.3).sin()]),
                            fmi2OK
                        );
                    }
                    assert_eq!(inst.do_step(k as f64 * h, h, false), fmi2OK);
                    outputs(inst)
                })
                .collect()
        };
        run(&mut inst, 0, before);
        let mut saved = None;
        assert_eq!(inst.get_fmu_state(&mut saved), fmi2OK);
        let reference = run(&mut inst, before, after);

        assert_eq!(inst.set_fmu_state(saved), fmi2OK);
        assert_eq!(
            run(&mut inst, before, after),
            reference,
            "{name}: resumed from a saved state"
        );

        let mut size = 0;
        assert_eq!(inst.serialized_fmu_state_size(saved, &mut size), fmi2OK);
        let mut bytes = vec![0u8; size];
        assert_eq!(inst.serialize_fmu_state(saved, &mut bytes), fmi2OK);
        let mut restored = None;
        assert_eq!(inst.deserialize_fmu_state(&bytes, &mut restored), fmi2OK);
        assert_eq!(inst.set_fmu_state(restored), fmi2OK);
        assert_eq!(
            run(&mut inst, before, after),
            reference,
            "{name}: resumed from a deserialized state"
        );

        // Another instance (as another process would) continues from the bytes.
        let (mut fresh, _) = initialized(&name, Interface::CoSimulation);
        let mut slot = None;
        assert_eq!(fresh.deserialize_fmu_state(&bytes, &mut slot), fmi2OK);
        assert_eq!(fresh.set_fmu_state(slot), fmi2OK);
        assert_eq!(
            run(&mut fresh, before, after),
            reference,
            "{name}: resumed in a fresh instance"
        );
        let mut s = saved;
        assert_eq!(inst.free_fmu_state(&mut s), fmi2OK);
    }
}

#[test]
fn foreign_old_corrupt_and_truncated_states_are_refused_and_change_nothing() {
    let (mut pair, _) = initialized("sphere_pair", Interface::CoSimulation);
    let mut saved = None;
    assert_eq!(pair.do_step(0.0, 0.01, false), fmi2OK);
    assert_eq!(pair.get_fmu_state(&mut saved), fmi2OK);
    let mut size = 0;
    assert_eq!(pair.serialized_fmu_state_size(saved, &mut size), fmi2OK);
    let mut bytes = vec![0u8; size];
    assert_eq!(pair.serialize_fmu_state(saved, &mut bytes), fmi2OK);

    let (mut drop, log) = initialized("sphere_drop", Interface::CoSimulation);
    assert_eq!(drop.do_step(0.0, 0.02, false), fmi2OK);
    let before = outputs(&mut drop);
    let last = || {
        log.lock()
            .unwrap()
            .last()
            .map(|l| l.2.clone())
            .unwrap_or_default()
    };
    let mut slot = None;
    assert_eq!(drop.deserialize_fmu_state(&bytes, &mut slot), fmi2Error);
    assert!(last().contains("belongs to another FMU"), "{}", last());
    let mut old = bytes.clone();
    old[8] = 1;
    assert_eq!(pair.deserialize_fmu_state(&old, &mut slot), fmi2Error);
    assert_eq!(
        pair.deserialize_fmu_state(&bytes[..bytes.len() / 2], &mut slot),
        fmi2Error
    );
    let mut corrupt = bytes.clone();
    let mid = corrupt.len() / 2;
    corrupt[mid] ^= 1;
    assert_eq!(pair.deserialize_fmu_state(&corrupt, &mut slot), fmi2Error);
    assert_eq!(slot, None::<FmuStateHandle>, "no state was created");
    assert_eq!(outputs(&mut drop), before, "the instance kept its state");
    assert_eq!(drop.do_step(0.02, 0.01, false), fmi2OK);
}

#[test]
fn model_exchange_states_derivatives_and_quaternion_projection() {
    let (mut me, _) = initialized("sphere_drop", Interface::ModelExchange);
    let n = me.model().number_of_states();
    assert_eq!(n, 7 + 6);
    let info = me.model().info().clone();
    assert_eq!(info.structure.derivatives.len(), n);
    let mut x = vec![0.0; n];
    assert_eq!(me.get_continuous_states(&mut x), fmi2OK);
    assert_eq!(x[2], 0.3);
    let mut info_ev = fmi2EventInfo::default();
    assert_eq!(me.new_discrete_states(&mut info_ev), fmi2OK);
    assert_eq!(info_ev.valuesOfContinuousStatesChanged, fmi2False);
    assert_eq!(me.enter_continuous_time_mode(), fmi2OK);
    let mut dx = vec![0.0; n];
    assert_eq!(me.get_derivatives(&mut dx), fmi2OK);
    // Free fall, out of contact: v̇_z = -g, the position moves with the velocity (zero).
    assert!((dx[7 + 2] + 9.81).abs() < 1e-12, "{dx:?}");
    assert_eq!(real(&mut me, vr(&info, "der(ball.linvel.z)")), dx[7 + 2]);
    // Spin about x: q̇ = ½ q ⊗ (0, ω) = (0, ω/2, 0, 0) at the identity.
    x[7 + 3] = 2.0;
    assert_eq!(me.set_continuous_states(&x), fmi2OK);
    assert_eq!(me.get_derivatives(&mut dx), fmi2OK);
    assert_eq!(&dx[3..7], &[0.0, 1.0, 0.0, 0.0]);
    // A solver step that leaves the unit sphere: the FMU asks for an event and projects.
    x[3..7].copy_from_slice(&[1.01, 0.0, 0.0, 0.0]);
    assert_eq!(me.set_continuous_states(&x), fmi2OK);
    let (mut enter, mut terminate) = (false, false);
    assert_eq!(
        me.completed_integrator_step(true, &mut enter, &mut terminate),
        fmi2OK
    );
    assert!(enter && !terminate);
    assert_eq!(me.enter_event_mode(), fmi2OK);
    assert_eq!(me.new_discrete_states(&mut info_ev), fmi2OK);
    assert_eq!(info_ev.valuesOfContinuousStatesChanged, fmi2True);
    assert_eq!(me.enter_continuous_time_mode(), fmi2OK);
    assert_eq!(me.get_continuous_states(&mut x), fmi2OK);
    assert_eq!(&x[3..7], &[1.0, 0.0, 0.0, 0.0]);
    assert_eq!(
        me.completed_integrator_step(true, &mut enter, &mut terminate),
        fmi2OK
    );
    assert!(!enter);
    // A zero quaternion is refused and changes nothing.
    let mut bad = x.clone();
    bad[3..7].copy_from_slice(&[0.0; 4]);
    assert_eq!(me.set_continuous_states(&bad), fmi2Error);
    let mut now = vec![0.0; n];
    assert_eq!(me.get_continuous_states(&mut now), fmi2OK);
    assert_eq!(now, x);
}

/// At an event a Model Exchange host may set the states by value reference, a component at a
/// time, so a quaternion can be zero when it asks for the event update: the update leaves it as
/// set (there is no direction to project onto) and warns, the forward dynamics refuses it, and
/// once an orientation is set the next update projects it and the model runs on.
#[test]
fn a_zero_quaternion_at_an_event_is_left_as_set_and_warned_about() {
    let (mut me, log) = initialized("sphere_drop", Interface::ModelExchange);
    let info = me.model().info().clone();
    let n = me.model().number_of_states();
    let (w, y) = (vr(&info, "ball.quat.w"), vr(&info, "ball.quat.y"));
    assert_eq!(me.set_debug_logging(true, &["logStatusWarning"]), fmi2OK);
    let mut ev = fmi2EventInfo::default();
    assert_eq!(me.set_real(&[w], &[0.0]), fmi2OK);
    assert_eq!(me.new_discrete_states(&mut ev), fmi2OK);
    assert_eq!(ev.valuesOfContinuousStatesChanged, fmi2False);
    let warned = log
        .lock()
        .unwrap()
        .iter()
        .any(|l| l.0 == fmi2Warning && l.2.contains("ball.quat is zero"));
    assert!(warned, "{:?}", log.lock().unwrap().last());
    let mut x = vec![f64::NAN; n];
    assert_eq!(me.get_continuous_states(&mut x), fmi2OK);
    assert_eq!(&x[3..7], &[0.0; 4]);
    assert!(x.iter().all(|v| v.is_finite()), "{x:?}");
    assert_eq!(me.enter_continuous_time_mode(), fmi2OK);
    let mut dx = vec![0.0; n];
    assert_eq!(me.get_derivatives(&mut dx), fmi2Error);
    // An orientation set again: projected at the next event, and the derivatives are back.
    assert_eq!(me.enter_event_mode(), fmi2OK);
    assert_eq!(me.set_real(&[y], &[-3.0]), fmi2OK);
    assert_eq!(me.new_discrete_states(&mut ev), fmi2OK);
    assert_eq!(ev.valuesOfContinuousStatesChanged, fmi2True);
    assert_eq!(me.get_continuous_states(&mut x), fmi2OK);
    assert_eq!(&x[3..7], &[0.0, 0.0, -1.0, 0.0]);
    assert_eq!(me.enter_continuous_time_mode(), fmi2OK);
    assert_eq!(me.get_derivatives(&mut dx), fmi2OK);
    assert!((dx[7 + 2] + 9.81).abs() < 1e-12, "{dx:?}");
}

/// A spinning, tumbling body integrated by a host's explicit solver (Euler on the FMU's
/// derivatives, projected at the events the FMU asks for) keeps unit quaternions.
#[test]
fn model_exchange_keeps_quaternions_unit_under_a_hosts_solver() {
    let (mut me, _) = initialized("sphere_drop", Interface::ModelExchange);
    let n = me.model().number_of_states();
    let mut ev = fmi2EventInfo::default();
    assert_eq!(me.new_discrete_states(&mut ev), fmi2OK);
    assert_eq!(me.enter_continuous_time_mode(), fmi2OK);
    let (mut x, mut dx) = (vec![0.0; n], vec![0.0; n]);
    assert_eq!(me.get_continuous_states(&mut x), fmi2OK);
    x[10..13].copy_from_slice(&[3.0, -2.0, 5.0]);
    assert_eq!(me.set_continuous_states(&x), fmi2OK);
    let h = 1e-3;
    let mut events = 0;
    for k in 1..=200 {
        assert_eq!(me.get_derivatives(&mut dx), fmi2OK);
        for i in 0..n {
            x[i] += h * dx[i];
        }
        assert_eq!(me.set_time(k as f64 * h), fmi2OK);
        assert_eq!(me.set_continuous_states(&x), fmi2OK);
        let (mut enter, mut term) = (false, false);
        assert_eq!(
            me.completed_integrator_step(true, &mut enter, &mut term),
            fmi2OK
        );
        if enter {
            events += 1;
            assert_eq!(me.enter_event_mode(), fmi2OK);
            assert_eq!(me.new_discrete_states(&mut ev), fmi2OK);
            assert_eq!(ev.valuesOfContinuousStatesChanged, fmi2True);
            assert_eq!(me.enter_continuous_time_mode(), fmi2OK);
            assert_eq!(me.get_continuous_states(&mut x), fmi2OK);
        }
        let norm = x[3..7].iter().map(|c| c * c).sum::<f64>().sqrt();
        // Explicit Euler grows the norm by ½ h² |ω|² / 4 ≈ 5e-6 per step: one step past the
        // tolerance at most.
        assert!(
            (norm - 1.0).abs() < scm::sim::QUATERNION_DRIFT_TOLERANCE + 1e-5,
            "step {k}: |q| = {norm}"
        );
    }
    assert!(events > 0, "the drift never triggered a projection");
}

#[test]
fn tunable_parameters_take_effect_between_steps_and_reset_restores_start_values() {
    let (mut inst, _) = initialized("sphere_drop", Interface::CoSimulation);
    let info = inst.model().info().clone();
    let (eps2, z, fz, step) = (
        vr(&info, "scm.eps2"),
        vr(&info, "ball.pos.z"),
        vr(&info, "contact.world.ball.force.z"),
        vr(&info, "solver.step"),
    );
    let eps2_start = real(&mut inst, eps2);
    for k in 0..60 {
        assert_eq!(inst.do_step(k as f64 * 0.01, 0.01, false), fmi2OK);
    }
    let mut saved = None;
    assert_eq!(inst.get_fmu_state(&mut saved), fmi2OK);
    assert_eq!(inst.do_step(0.6, 0.01, false), fmi2OK);
    let f_same = real(&mut inst, fz);
    assert_eq!(inst.set_fmu_state(saved), fmi2OK);
    // Anneal: a 10x wider separation distribution spreads the load over more points.
    assert_eq!(inst.set_real(&[eps2], &[10.0 * eps2_start]), fmi2OK);
    assert_eq!(inst.do_step(0.6, 0.01, false), fmi2OK);
    let f_wider = real(&mut inst, fz);
    assert!(
        (f_same - f_wider).abs() > 1e-3 * f_same.abs(),
        "eps2 had no effect: {f_same} vs {f_wider}"
    );
    // Out of range: refused, unchanged.
    assert_eq!(inst.set_real(&[eps2], &[-1.0]), fmi2Error);
    assert_eq!(real(&mut inst, eps2), 10.0 * eps2_start);

    // Start values set before initialization do not survive a reset either.
    assert_eq!(inst.reset(), fmi2OK);
    assert_eq!(inst.set_real(&[z, step], &[0.5, 0.0005]), fmi2OK);
    assert_eq!(inst.reset(), fmi2OK);
    assert_eq!(inst.setup_experiment(None, 0.0, None), fmi2OK);
    assert_eq!(inst.enter_initialization_mode(), fmi2OK);
    assert_eq!(real(&mut inst, eps2), eps2_start);
    assert_eq!(real(&mut inst, z), 0.3);
    assert_eq!(real(&mut inst, step), 0.001);
}

#[test]
fn contact_diagnostics_follow_the_log_category() {
    let (mut inst, log) = initialized("sphere_pair", Interface::CoSimulation);
    let contact = |log: &Log| {
        log.lock()
            .unwrap()
            .iter()
            .filter(|l| l.1 == "logContact")
            .count()
    };
    assert_eq!(inst.do_step(0.0, 0.01, false), fmi2OK);
    assert_eq!(contact(&log), 0, "off by default (loggingOn = false)");
    assert_eq!(inst.set_debug_logging(true, &["logContact"]), fmi2OK);
    assert_eq!(inst.do_step(0.01, 0.01, false), fmi2OK);
    assert_eq!(inst.do_step(0.02, 0.01, false), fmi2OK);
    assert_eq!(contact(&log), 2, "one message per pair and step");
    let last = log.lock().unwrap().last().unwrap().clone();
    assert_eq!(last.0, fmi2OK);
    assert!(
        last.2
            .starts_with("t = 0.03 s: contact big-small: distance D = ")
            && last.2.contains("force on big"),
        "{}",
        last.2
    );
    assert!(inst.is_logging(LogCategory::Contact) && !inst.is_logging(LogCategory::Events));
    assert_eq!(inst.set_debug_logging(false, &["logContact"]), fmi2OK);
    assert_eq!(inst.do_step(0.03, 0.01, false), fmi2OK);
    assert_eq!(contact(&log), 2);
    assert_eq!(inst.set_debug_logging(true, &["logNoSuchThing"]), fmi2Error);
}

/// Model Exchange: a mocap input is its body's pose at the current time (it acts at once, with
/// exact directional derivatives), and its velocity is the input's rate over the host's last
/// completed integrator step. In Co-Simulation the same input is a target reached at the end of
/// the next step, so nothing changes at once and its partials are zero.
#[test]
fn model_exchange_mocap_inputs_act_at_once_and_their_rate_is_the_velocity() {
    let name = "mocap_push";
    let (mut me, log) = initialized(name, Interface::ModelExchange);
    let info = me.model().info().clone();
    let (px, fx) = (
        vr(&info, "paddle.pos.x"),
        vr(&info, "contact.box.paddle.force.x"),
    );
    let mut event = fmi2EventInfo::default();
    assert_eq!(me.new_discrete_states(&mut event), fmi2OK);
    assert_eq!(me.enter_continuous_time_mode(), fmi2OK);
    // The paddle (r = 3 cm) starts 3 cm behind the box's face at x = -0.05: no force.
    assert!(real(&mut me, fx).abs() < 1e-9);
    // Moved 1 mm into the box: the box is pushed at once (+x), and the output depends on the
    // input as ModelStructure says.
    let x_in = -0.08 + 1e-3;
    assert_eq!(me.set_real(&[px], &[x_in]), fmi2OK);
    let f = real(&mut me, fx);
    assert!(f > 1.0, "force on the box {f} N");
    let deps = info
        .structure
        .outputs
        .iter()
        .find(|(u, _)| *u == fx)
        .unwrap()
        .1
        .clone()
        .unwrap();
    assert!(
        deps.contains(&px),
        "ModelStructure: {fx} does not list paddle.pos.x"
    );
    let mut exact = [0.0];
    assert_eq!(
        me.get_directional_derivative(&[fx], &[px], &[1.0], &mut exact),
        fmi2OK,
        "{:?}",
        log.lock().unwrap().last()
    );
    let h = 1e-8;
    let mut at = |x: f64| {
        assert_eq!(me.set_real(&[px], &[x]), fmi2OK);
        real(&mut me, fx)
    };
    let fd = (at(x_in + h) - at(x_in - h)) / (2.0 * h);
    at(x_in);
    // Central differences at h = 1e-8 m on a force of ~10 N with slope ~1e4 N/m: truncation
    // (h/ε3)² = 1e-8 relative, round-off ~1e-16 · 10 N / 1e-8 m = 1e-7 N/m.
    assert!(
        (exact[0] - fd).abs() <= 1e-6 * fd.abs(),
        "exact {} vs central difference {fd}",
        exact[0]
    );
    // The velocity: the input moves 1 mm over a completed step of 10 ms: 0.1 m/s along x.
    let (mut enter, mut terminate) = (false, false);
    assert_eq!(
        me.completed_integrator_step(true, &mut enter, &mut terminate),
        fmi2OK
    );
    assert_eq!(me.set_time(0.01), fmi2OK);
    assert_eq!(me.set_real(&[px], &[x_in + 1e-3]), fmi2OK);
    assert_eq!(
        me.completed_integrator_step(true, &mut enter, &mut terminate),
        fmi2OK
    );
    let mocap = &me.model().data.current.mocap;
    assert!(
        (mocap[7] - 0.1).abs() < 1e-9 && mocap[8] == 0.0 && mocap[9] == 0.0,
        "paddle velocity {:?}",
        &mocap[7..13]
    );

    // Co-Simulation: the same input is a target, nothing acts at once, its partial is zero.
    let (mut cs, _) = initialized(name, Interface::CoSimulation);
    assert_eq!(cs.set_real(&[px], &[x_in]), fmi2OK);
    assert!(real(&mut cs, fx).abs() < 1e-9);
    assert_eq!(
        cs.get_directional_derivative(&[fx], &[px], &[1.0], &mut exact),
        fmi2OK
    );
    assert_eq!(exact[0], 0.0);
    // ... and it is reached at the end of the next step.
    assert_eq!(cs.do_step(0.0, 0.01, false), fmi2OK);
    assert!(real(&mut cs, fx) > 1.0);
}
