//! The small facade a Rust caller and the command line use (`Simulation::set`, `set_param`,
//! `advance`, `outputs`): it is the FMU's own code path, so a run through it equals, bit for bit,
//! the same run through the C ABI, and it refuses what a host would be refused.

use crate::common::host::{self, Instance};
use crate::common::scene;
use scm::contact::Param;
use scm::fmi::ffi::*;
use scm::sim::{Simulation, Value};

/// t_push with its finger driven along a path, a tuned contact parameter and a start value,
/// run through the facade and through `fmi2*`: every output at every communication point
/// agrees to the bit.
#[test]
fn the_facade_runs_as_the_fmu_does_to_the_bit() {
    let path = scene("t_push");
    let h = 0.01;
    let steps = 40;
    let input = |k: usize| [0.005 + 0.002 * k as f64, 0.25f64.min(0.01 * k as f64)];

    let mut sim = Simulation::from_file(&path).unwrap();
    let names: Vec<String> = sim.output_names().iter().map(|n| n.to_string()).collect();
    assert!(names.iter().any(|n| n.ends_with(".force.y")), "{names:?}");
    sim.set("t_yaw.q", Value::Real(0.1)).unwrap();
    sim.set("solver.integrator", Value::Text("rk4")).unwrap();
    sim.set_param(Param::Friction, 0.4).unwrap();
    sim.initialize().unwrap();
    let mut via_facade = vec![sim.outputs().unwrap()];
    for k in 0..steps {
        let [x, y] = input(k);
        sim.set("act_x.ctrl", Value::Real(x)).unwrap();
        sim.set("act_y.ctrl", Value::Real(y)).unwrap();
        sim.advance(h).unwrap();
        via_facade.push(sim.outputs().unwrap());
    }

    let dir = host::unpack_scene(&path, "facade").unwrap();
    let fmu = Instance::new(&dir, fmi2CoSimulation, host::quiet()).unwrap();
    let vr = |n: &str| fmu.vr(n).unwrap();
    let outs: Vec<u32> = names.iter().map(|n| vr(n)).collect();
    fmu.setup(None).unwrap();
    fmu.set_real(&[vr("t_yaw.q"), vr("scm.friction")], &[0.1, 0.4])
        .unwrap();
    fmu.set_string(vr("solver.integrator"), "rk4").unwrap();
    fmu.initialize().unwrap();
    let mut via_fmu = vec![fmu.get_real(&outs).unwrap()];
    for k in 0..steps {
        fmu.set_real(&[vr("act_x.ctrl"), vr("act_y.ctrl")], &input(k))
            .unwrap();
        assert_eq!(fmu.do_step(k as f64 * h, h), fmi2OK);
        via_fmu.push(fmu.get_real(&outs).unwrap());
    }
    for (k, (a, b)) in via_facade.iter().zip(&via_fmu).enumerate() {
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            assert_eq!(
                x.to_bits(),
                y.to_bits(),
                "t = {} s, {}",
                k as f64 * h,
                names[i]
            );
        }
    }
    // The finger reached the T: the run is not trivially at rest.
    let force = names.iter().position(|n| n.ends_with(".force.y")).unwrap();
    assert!(via_fmu.iter().any(|r| r[force].abs() > 0.1));
}

/// Every refusal names the variable and the reason, and leaves the simulation as it was.
#[test]
fn the_facade_refuses_with_the_reason_and_changes_nothing() {
    let mut sim = Simulation::from_file(&scene("sphere_drop")).unwrap();
    let before = sim.data.current.clone();
    let cases: [(&str, Value, &str); 6] = [
        (
            "ball.pos.q",
            Value::Real(1.0),
            "variables of that name: ball.pos.x",
        ),
        ("nothing", Value::Real(1.0), "no variable 'nothing'"),
        ("ball.pos.z", Value::Real(f64::NAN), "must be finite"),
        ("scm.eps1", Value::Real(-1.0), "must be positive"),
        (
            "solver.integrator",
            Value::Text("euler2"),
            "known integrators are",
        ),
        ("ball.linacc.z", Value::Real(1.0), "cannot be set"),
    ];
    for (name, value, words) in cases {
        let err = sim.set(name, value.clone()).unwrap_err();
        assert!(
            err.contains(words),
            "{name} = {value:?}: '{words}' not in {err}"
        );
        assert_eq!(
            sim.data.current, before,
            "{name}: a refused value changed the state"
        );
    }
    assert!(sim.set_param(Param::Friction, -0.1).is_err());
    assert_eq!(sim.data.current, before);

    // Once started, the states belong to the simulation (as in Co-Simulation); a tunable
    // parameter still takes effect.
    sim.set("ball.pos.z", Value::Real(0.3)).unwrap();
    sim.advance(0.01).unwrap();
    let err = sim.set("ball.pos.z", Value::Real(0.5)).unwrap_err();
    assert!(err.contains("after initialization"), "{err}");
    sim.set("scm.stiffness", Value::Real(2e4)).unwrap();
    assert_eq!(sim.get("scm.stiffness").unwrap(), 2e4);
    assert!(sim.get("ball.pos.z").unwrap() < 0.3, "the ball falls");
}

/// A host's pruning tolerance (`scm.prune_tolerance`, a fixed parameter) acts as the scene's
/// `scm_prune_tolerance` does, to the bit, through the facade and through `fmi2*`; it is refused
/// out of range and after initialization, and `fmi2Reset` gives the clouds the scene's again.
#[test]
fn a_hosts_pruning_tolerance_acts_as_the_scenes_to_the_bit() {
    let path = scene("box_stack");
    let (h, steps, loose) = (0.01, 10, 1e-9);
    let text = std::fs::read_to_string(&path).unwrap();
    let setting = format!(
        "<custom><numeric name=\"scm_prune_tolerance\" data=\"{loose:e}\"/></custom>\n  <worldbody>"
    );
    let in_scene = text.replacen("<worldbody>", &setting, 1);
    assert_ne!(in_scene, text);
    let dir = std::env::temp_dir().join(format!("scm-prune-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let in_scene_path = dir.join("box_stack_loose.xml");
    std::fs::write(&in_scene_path, &in_scene).unwrap();

    // Every output after each of `steps` steps, through the facade, with `set` before start.
    let run = |path: &std::path::Path, set: Option<f64>| {
        let mut sim = Simulation::from_file(path).unwrap();
        if let Some(t) = set {
            sim.set("scm.prune_tolerance", Value::Real(t)).unwrap();
        }
        let scenes = if path == in_scene_path { loose } else { 1e-15 };
        assert_eq!(
            sim.get("scm.prune_tolerance").unwrap(),
            set.unwrap_or(scenes)
        );
        sim.initialize().unwrap();
        let mut rows = vec![sim.outputs().unwrap()];
        for _ in 0..steps {
            sim.advance(h).unwrap();
            rows.push(sim.outputs().unwrap());
        }
        (sim, rows)
    };
    let (mut sim, by_host) = run(&path, Some(loose));
    let (_, by_scene) = run(&in_scene_path, None);
    let (_, by_default) = run(&path, None);
    let bits = |rows: &[Vec<f64>]| -> Vec<Vec<u64>> {
        rows.iter()
            .map(|r| r.iter().map(|x| x.to_bits()).collect())
            .collect()
    };
    assert!(
        bits(&by_host) == bits(&by_scene),
        "the host's tolerance is not the scene's"
    );
    // It acts: the boxes' contact forces move in their last bits (by far less than its
    // bound, a thousand times the tolerance relative: tests/geometry_pruning.rs).
    assert!(
        bits(&by_host) != bits(&by_default),
        "the tolerance changed nothing"
    );
    let largest = |rows: &[Vec<f64>]| rows.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    let apart = by_host
        .iter()
        .flatten()
        .zip(by_default.iter().flatten())
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(
        apart <= 1e3 * loose * largest(&by_default),
        "apart by {apart:e}"
    );

    // After initialization a fixed parameter is refused, and nothing changes.
    let err = sim
        .set("scm.prune_tolerance", Value::Real(1e-6))
        .unwrap_err();
    assert!(err.to_string().contains("after initialization"), "{err}");
    assert_eq!(sim.get("scm.prune_tolerance").unwrap(), loose);
    // Out of range before initialization: refused with the range.
    let mut fresh = Simulation::from_file(&path).unwrap();
    for bad in [0.0, -1e-9, 2e-3, 1.0] {
        let err = fresh
            .set("scm.prune_tolerance", Value::Real(bad))
            .unwrap_err();
        assert!(err.to_string().contains("at most 1e-3"), "{bad}: {err}");
    }
    assert_eq!(fresh.get("scm.prune_tolerance").unwrap(), 1e-15);

    // Through the C ABI: the same bits; after `fmi2Reset` the scene's tolerance again.
    let unpacked = host::unpack_scene(&path, "prune").unwrap();
    let fmu = Instance::new(&unpacked, fmi2CoSimulation, host::quiet()).unwrap();
    let names: Vec<String> = sim.output_names().iter().map(|n| n.to_string()).collect();
    let outs: Vec<u32> = names.iter().map(|n| fmu.vr(n).unwrap()).collect();
    let tol = fmu.vr("scm.prune_tolerance").unwrap();
    let fmu_run = |set: Option<f64>| {
        fmu.setup(None).unwrap();
        if let Some(t) = set {
            fmu.set_real(&[tol], &[t]).unwrap();
        }
        fmu.initialize().unwrap();
        let at_start = fmu.get_real(&[tol]).unwrap()[0];
        let mut rows = vec![fmu.get_real(&outs).unwrap()];
        for k in 0..steps {
            assert_eq!(fmu.do_step(k as f64 * h, h), fmi2OK);
            rows.push(fmu.get_real(&outs).unwrap());
        }
        (at_start, rows)
    };
    let (at_start, rows) = fmu_run(Some(loose));
    assert!(
        at_start == loose && bits(&rows) == bits(&by_host),
        "C ABI: {at_start:e}, or its rows"
    );
    assert_eq!(
        unsafe { scm::fmi2SetReal(fmu.raw(), &tol, 1, &1e-6) },
        fmi2Error
    );
    assert_eq!(unsafe { scm::fmi2Reset(fmu.raw()) }, fmi2OK);
    let (at_start, rows) = fmu_run(None);
    assert!(
        at_start == 1e-15 && bits(&rows) == bits(&by_default),
        "after reset: {at_start:e}, or its rows"
    );
    std::fs::remove_dir_all(&dir).ok();
}
