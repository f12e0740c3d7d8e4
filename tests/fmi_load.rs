//! Load: two instances of every bundled scene (as bundled, and with other contact parameters
//! and controls) stepped concurrently, one thread each, give results
//! bit-identical to running them one after another (no shared mutable state between instances).

use scm::fmi::ffi::*;
use scm::*;
use std::ffi::CString;
use std::path::{Path, PathBuf};

/// Packs a scene into an FMU and unzips it; returns (resources URI, GUID, number of variables).
fn unpacked(scene: &Path, root: &Path) -> (CString, CString, Vec<(String, f64)>) {
    let name = scene.file_stem().unwrap().to_string_lossy().into_owned();
    let dir = root.join(&name);
    let fmu = root.join(format!("{name}.fmu"));
    // The library itself is not loaded here (the test calls the exports linked into it).
    let lib = root.join("placeholder.so");
    std::fs::write(&lib, b"not loaded").unwrap();
    scm::pack::pack(scene, &lib, &fmu).unwrap();
    let mut archive = zip::ZipArchive::new(std::fs::File::open(&fmu).unwrap()).unwrap();
    archive.extract(&dir).unwrap();
    let sim = scm::sim::Simulation::from_file(scene).unwrap();
    let text = std::fs::read_to_string(scene).unwrap();
    (
        CString::new(format!("file://{}", dir.join("resources").display())).unwrap(),
        CString::new(scm::sim::guid(&text)).unwrap(),
        sim.rows()
            .iter()
            .map(|(v, _)| {
                (
                    v.name.clone(),
                    match v.var_type {
                        scm::fmi::contract::VarType::Real { start, .. } => {
                            start.unwrap_or(f64::NAN)
                        }
                        _ => f64::NAN,
                    },
                )
            })
            .collect(),
    )
}

/// Runs one instance for `steps` communication steps and returns every Real variable after
/// each step, as bits. The variant doubles the stiffness, sets the friction to 0.3, ε2 to 1.5
/// times its value and every control to 0.05 before initialization.
fn rollout(
    uri: &CString,
    guid: &CString,
    names: &[(String, f64)],
    seed: usize,
    variant: bool,
    steps: usize,
) -> Vec<u64> {
    let nvars = names.len() as u32;
    let callbacks = fmi2CallbackFunctions {
        logger: None,
        allocateMemory: None,
        freeMemory: None,
        stepFinished: None,
        componentEnvironment: std::ptr::null_mut(),
    };
    let mut out = Vec::new();
    unsafe {
        let name = CString::new(format!("load{seed}")).unwrap();
        let c = fmi2Instantiate(
            name.as_ptr(),
            fmi2CoSimulation,
            guid.as_ptr(),
            uri.as_ptr(),
            &callbacks,
            0,
            0,
        );
        assert!(!c.is_null());
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), fmi2OK);
        if variant {
            for (i, (name, start)) in names.iter().enumerate() {
                let vr = i as u32;
                let value = match name.as_str() {
                    "scm.stiffness" => 2.0 * start,
                    "scm.eps2" => 1.5 * start,
                    "scm.friction" => 0.3,
                    n if n.ends_with(".ctrl") => 0.05,
                    _ => continue,
                };
                assert_eq!(fmi2SetReal(c, &vr, 1, &value), fmi2OK);
            }
        }
        assert_eq!(fmi2EnterInitializationMode(c), fmi2OK);
        let vrs: Vec<u32> = (0..nvars).collect();
        let mut values = vec![0.0; nvars as usize];
        assert_eq!(fmi2ExitInitializationMode(c), fmi2OK);
        let h = 0.002;
        for k in 0..steps {
            assert_eq!(fmi2DoStep(c, k as f64 * h, h, 1), fmi2OK);
            // Every variable: Reals where they are Real (the String row is refused as a whole
            // call, so read Reals one by one).
            for (i, vr) in vrs.iter().enumerate() {
                let mut v = 0.0;
                if fmi2GetReal(c, vr, 1, &mut v) == fmi2OK {
                    values[i] = v;
                }
            }
            out.extend(values.iter().map(|v| v.to_bits()));
        }
        fmi2FreeInstance(c);
    }
    out
}

#[test]
fn two_concurrent_instances_of_every_scene_match_sequential_runs_bit_for_bit() {
    let root = std::env::temp_dir().join(format!("scm-load-{}", std::process::id()));
    std::fs::create_dir_all(&root).unwrap();
    let mut scenes: Vec<PathBuf> =
        std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("resources/scenes"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "xml"))
            .collect();
    scenes.sort();
    let fmus: Vec<_> = scenes.iter().map(|s| unpacked(s, &root)).collect();
    let steps = 25;
    let n = fmus.len();
    assert!(n >= 8, "the bundled scenes");
    let jobs: Vec<usize> = (0..2 * n).collect();
    let sequential: Vec<Vec<u64>> = jobs
        .iter()
        .map(|&i| {
            let (uri, guid, names) = &fmus[i % n];
            rollout(uri, guid, names, i, i >= n, steps)
        })
        .collect();
    let concurrent: Vec<Vec<u64>> = std::thread::scope(|scope| {
        let handles: Vec<_> = jobs
            .iter()
            .map(|&i| {
                let (uri, guid, names) = &fmus[i % n];
                scope.spawn(move || rollout(uri, guid, names, i, i >= n, steps))
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for i in 0..n {
        assert!(
            sequential[i] != sequential[i + n],
            "{}: the variant ran like the original",
            scenes[i].display()
        );
    }
    for (i, (s, c)) in sequential.iter().zip(&concurrent).enumerate() {
        assert!(
            s == c,
            "instance {i} ({}) differs between sequential and concurrent runs",
            scenes[i % scenes.len()].display()
        );
    }
    let _ = std::fs::remove_dir_all(&root);
}
