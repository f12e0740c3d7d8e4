//! The `fmi` crate (0.8) as an FMI host: it unpacks the FMU of t_push, reads its
//! `modelDescription.xml`, loads `scm.so` through `libloading`, and runs it: instantiate, step,
//! read outputs, get/set and serialize/deserialize the FMU state (a rerun from a restored
//! state is bit-identical), and a directional derivative.
//!
//! Quirk handled: `fmi` 0.8 asserts in `get_directional_derivative` that the number of knowns
//! equals the number of unknowns (it compares the known list with the output buffer), so every
//! call here asks for as many unknowns as it gives knowns.

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common};
use fmi::traits::{FmiImport, FmiInstance, FmiStatus};
use std::path::PathBuf;

/// The FMU binary cargo built next to this test (the crate's `cdylib`).
fn library() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let lib = exe.parent().unwrap().join("libscm.so");
    assert!(lib.is_file(), "{} not built", lib.display());
    lib
}

#[test]
fn the_fmi_crate_instantiates_steps_reads_outputs_and_restores_states() {
    let dir = std::env::temp_dir().join(format!("scm-fmi-crate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let fmu = dir.join("t_push.fmu");
    scm::pack::pack(&crate::common::scene("t_push"), &library(), &fmu).unwrap();

    let import: Fmi2Import = fmi::import::from_path(&fmu).expect("the fmi crate reads the FMU");
    let md = import.model_description();
    assert_eq!(md.model_name, "t_push");
    let vr = |name: &str| {
        md.model_variable_by_name(name)
            .unwrap_or_else(|_| panic!("{name}"))
            .value_reference
    };
    let (ctrl_x, ctrl_y) = (vr("act_x.ctrl"), vr("act_y.ctrl"));
    let outputs: Vec<u32> = [
        "t_x.q",
        "t_y.q",
        "t_yaw.q",
        "finger_y.q",
        "contact.tblock.finger.force.y",
        "contact.tblock.finger.distance",
    ]
    .iter()
    .map(|n| vr(n))
    .collect();

    let mut inst = import
        .instantiate_cs("fmi-crate", false, false)
        .expect("instantiate");
    FmiInstance::enter_initialization_mode(&mut inst, None, 0.0, None).unwrap();
    inst.set_real(&[ctrl_x, ctrl_y], &[0.01, 0.16]).unwrap();
    FmiInstance::exit_initialization_mode(&mut inst).unwrap();

    let h = 0.01;
    let read = |inst: &mut fmi::fmi2::instance::InstanceCS| -> Vec<f64> {
        let mut y = vec![0.0; outputs.len()];
        inst.get_real(&outputs, &mut y).unwrap();
        y
    };
    for k in 0..50 {
        inst.do_step(k as f64 * h, h, true).unwrap();
    }
    let state = inst.get_fmu_state().expect("fmi2GetFMUstate");
    let bytes = inst
        .serialize_fmu_state(&state)
        .expect("fmi2SerializeFMUstate");
    let mut reference = Vec::new();
    for k in 50..100 {
        inst.do_step(k as f64 * h, h, true).unwrap();
        reference.push(read(&mut inst));
    }
    let y = reference.last().unwrap();
    assert!(
        y[1] > 0.02,
        "the finger pushed the T-block forward: t_y.q = {}",
        y[1]
    );
    assert!(
        y[4] > 0.0,
        "the T-block is pushed (+y) by the finger: force on it {}",
        y[4]
    );

    // Restored from the saved state, and from the deserialized bytes: the same, bit for bit.
    for restored in [
        state,
        inst.deserialize_fmu_state(&bytes)
            .expect("fmi2DeSerializeFMUstate"),
    ] {
        let status = inst.set_fmu_state(&restored);
        assert!(status.ok().is_ok(), "fmi2SetFMUstate");
        let rerun: Vec<Vec<f64>> = (50..100)
            .map(|k| {
                inst.do_step(k as f64 * h, h, true).unwrap();
                read(&mut inst)
            })
            .collect();
        assert!(rerun
            .iter()
            .flatten()
            .map(|x| x.to_bits())
            .eq(reference.iter().flatten().map(|x| x.to_bits())));
    }

    // ∂(der(finger_y.v), der(finger_x.v)) / ∂(act_y.ctrl, act_x.ctrl) · (1, 0): the position
    // actuator's kp / m = 500 on its own joint, 0 on the other. Two unknowns, two knowns.
    let unknowns = [vr("der(finger_y.v)"), vr("der(finger_x.v)")];
    let mut dv = [0.0; 2];
    inst.get_directional_derivative(&unknowns, &[ctrl_y, ctrl_x], &[1.0, 0.0], &mut dv)
        .unwrap();
    assert_eq!(dv, [500.0, 0.0]);
    FmiInstance::terminate(&mut inst).unwrap();
    drop(inst);
    let _ = std::fs::remove_dir_all(&dir);
}
