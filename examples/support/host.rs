//! An in-process FMI 2.0 host over the crate's own `fmi2*` exports (the C ABI a host calls in
//! the FMU's shared library), for the examples and tests that drive an FMU without a Python
//! interpreter in between: the FMU's `resources/` folder written as `scm pack` writes it, and
//! an instance with checked calls, variables by name and the instance freed on drop.
//!
//! Included with `#[path]` (Cargo builds `examples/*.rs` as examples and leaves this folder
//! alone).
#![allow(dead_code)]

use scm::fmi::ffi::*;
use std::ffi::CString;
use std::path::{Path, PathBuf};

/// Writes an FMU's `resources/` folder at `dir`: the scene text as the FMU's scene file and
/// the files it reads (meshes: name inside `resources/` and bytes).
pub fn write_resources(
    dir: &Path,
    scene_text: &str,
    files: &[(String, Vec<u8>)],
) -> Result<(), String> {
    let io = |p: &Path, e: std::io::Error| format!("{}: {e}", p.display());
    for (file, bytes) in files {
        let path = dir.join(file);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(|e| io(parent, e))?;
        }
        std::fs::write(&path, bytes).map_err(|e| io(&path, e))?;
    }
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    let scene = dir.join(scm::sim::SCENE_FILE);
    std::fs::write(&scene, scene_text).map_err(|e| io(&scene, e))
}

/// The `resources/` folder of a scene file as `scm pack` lays it out, written under the
/// system's temporary folder in `scm-host-<process>/<tag>/resources`.
pub fn unpack_scene(scene: &Path, tag: &str) -> Result<PathBuf, String> {
    let described = scm::pack::describe(scene).map_err(|e| e.to_string())?;
    let dir = std::env::temp_dir()
        .join(format!("scm-host-{}", std::process::id()))
        .join(tag)
        .join("resources");
    write_resources(&dir, &described.scene_text, &described.resources)?;
    Ok(dir)
}

/// Callbacks without a logger.
pub fn quiet() -> fmi2CallbackFunctions {
    fmi2CallbackFunctions {
        logger: None,
        allocateMemory: None,
        freeMemory: None,
        stepFinished: None,
        componentEnvironment: std::ptr::null_mut(),
    }
}

/// `Ok` for `fmi2OK` and `fmi2Warning`, else what returned which status.
pub fn check(status: fmi2Status, what: &str) -> Result<(), String> {
    if status <= fmi2Warning {
        Ok(())
    } else {
        Err(format!("{what} returned {status}"))
    }
}

/// A live instance of an unpacked FMU, freed when dropped.
pub struct Instance {
    c: fmi2Component,
    names: Vec<String>,
    /// What the instance was given: kept alive as long as it is.
    _callbacks: Box<fmi2CallbackFunctions>,
}

impl Instance {
    /// `fmi2Instantiate` of the FMU whose `resources/` folder is `dir`, with `callbacks` (and
    /// whatever their environment points to, which must outlive the instance).
    pub fn new(
        dir: &Path,
        kind: fmi2Type,
        callbacks: fmi2CallbackFunctions,
    ) -> Result<Instance, String> {
        let scene = dir.join(scm::sim::SCENE_FILE);
        let text =
            std::fs::read_to_string(&scene).map_err(|e| format!("{}: {e}", scene.display()))?;
        // The variable table is the FMU's (same code): names to value references.
        let names = scm::sim::Simulation::from_file(&scene)
            .map_err(|e| e.to_string())?
            .rows()
            .iter()
            .map(|(v, _)| v.name.clone())
            .collect();
        let uri = CString::new(format!("file://{}", dir.display())).map_err(|e| e.to_string())?;
        let guid = CString::new(scm::sim::guid(&text)).map_err(|e| e.to_string())?;
        let callbacks = Box::new(callbacks);
        // SAFETY: the strings are NUL-terminated and live through the call (the FMU copies
        // what it keeps); the callbacks live in a box as long as the instance.
        let c = unsafe {
            scm::fmi2Instantiate(
                c"host".as_ptr(),
                kind,
                guid.as_ptr(),
                uri.as_ptr(),
                &*callbacks,
                fmi2False,
                fmi2False,
            )
        };
        if c.is_null() {
            return Err("fmi2Instantiate failed".into());
        }
        Ok(Instance {
            c,
            names,
            _callbacks: callbacks,
        })
    }

    /// The instance, for calls this host does not wrap (timing loops, FMU states).
    pub fn raw(&self) -> fmi2Component {
        self.c
    }

    /// Value reference of a variable.
    pub fn vr(&self, name: &str) -> Result<u32, String> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| i as u32)
            .ok_or_else(|| format!("the FMU has no variable {name}"))
    }

    /// Every variable's name, by value reference.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// `fmi2SetupExperiment` from t = 0, with a stop time if given.
    pub fn setup(&self, stop: Option<f64>) -> Result<(), String> {
        let (defined, stop) = stop.map_or((fmi2False, 0.0), |t| (fmi2True, t));
        // SAFETY: a live instance.
        let s = unsafe { scm::fmi2SetupExperiment(self.c, fmi2False, 0.0, 0.0, defined, stop) };
        check(s, "fmi2SetupExperiment")
    }

    /// `fmi2EnterInitializationMode` then `fmi2ExitInitializationMode`.
    pub fn initialize(&self) -> Result<(), String> {
        // SAFETY: a live instance.
        unsafe {
            check(
                scm::fmi2EnterInitializationMode(self.c),
                "fmi2EnterInitializationMode",
            )?;
            check(
                scm::fmi2ExitInitializationMode(self.c),
                "fmi2ExitInitializationMode",
            )
        }
    }

    /// `fmi2SetReal` of several variables.
    pub fn set_real(&self, vrs: &[u32], values: &[f64]) -> Result<(), String> {
        assert_eq!(vrs.len(), values.len());
        // SAFETY: both buffers hold `vrs.len()` elements.
        let s = unsafe { scm::fmi2SetReal(self.c, vrs.as_ptr(), vrs.len(), values.as_ptr()) };
        check(s, "fmi2SetReal")
    }

    /// `fmi2SetString` of one variable.
    pub fn set_string(&self, vr: u32, value: &str) -> Result<(), String> {
        let text = CString::new(value).map_err(|e| e.to_string())?;
        let p = text.as_ptr();
        // SAFETY: one reference and one NUL-terminated string, alive through the call.
        let s = unsafe { scm::fmi2SetString(self.c, &vr, 1, &p) };
        check(s, "fmi2SetString")
    }

    /// `fmi2GetReal` of several variables into `out`.
    pub fn get_real_into(&self, vrs: &[u32], out: &mut [f64]) -> Result<(), String> {
        assert_eq!(vrs.len(), out.len());
        // SAFETY: both buffers hold `vrs.len()` elements.
        let s = unsafe { scm::fmi2GetReal(self.c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr()) };
        check(s, "fmi2GetReal")
    }

    /// `fmi2GetReal` of several variables.
    pub fn get_real(&self, vrs: &[u32]) -> Result<Vec<f64>, String> {
        let mut out = vec![f64::NAN; vrs.len()];
        self.get_real_into(vrs, &mut out)?;
        Ok(out)
    }

    /// `fmi2DoStep` from `t` by `h`: its status, so the caller tells a discard from an error.
    pub fn do_step(&self, t: f64, h: f64) -> fmi2Status {
        // SAFETY: a live instance.
        unsafe { scm::fmi2DoStep(self.c, t, h, fmi2True) }
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        // SAFETY: the instance is live and not used after this.
        unsafe { scm::fmi2FreeInstance(self.c) };
    }
}
