//! A minimal FMI host for the tests that call the C ABI (`fmi2*` symbols of the crate):
//! `resources/` folders laid out as `scm pack` lays them out, and a logger that records what the
//! FMU logs.
//!
//! The recording logger is the crate's [`scm::fmi::host_log`] (x86_64 and AArch64 Linux only:
//! modules that use it are limited to those targets).
#![allow(dead_code)]

use scm::fmi::ffi::*;
use std::collections::HashSet;
use std::ffi::CString;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

pub use scm::fmi::host_log::LogCapture as Capture;

// The same file is also a module of the long-run example, which a test includes.
#[allow(clippy::duplicate_mod)]
#[path = "../../examples/support/host.rs"]
mod shared;
pub use shared::{quiet, unpack_scene, write_resources, Instance};

/// Callbacks whose logger records into `capture`.
pub fn callbacks(capture: &Capture) -> fmi2CallbackFunctions {
    capture.callbacks()
}

/// An unpacked FMU's `resources/` folder.
#[derive(Clone, Debug)]
pub struct Resources {
    /// The folder.
    pub dir: PathBuf,
    /// Its `file://` URI (the `fmuResourceLocation`).
    pub uri: CString,
    /// The FMU's GUID.
    pub guid: CString,
}

fn made() -> &'static Mutex<HashSet<PathBuf>> {
    static MADE: OnceLock<Mutex<HashSet<PathBuf>>> = OnceLock::new();
    MADE.get_or_init(Default::default)
}

/// The `resources/` folder of a scene text (and the meshes, read from `meshes`: name inside
/// `resources/` and bytes), under a folder named `tag`, made once per process and tag.
pub fn resources_of(tag: &str, scene_text: &str, meshes: &[(String, Vec<u8>)]) -> Resources {
    let dir = std::env::temp_dir()
        .join(format!("scm-host-{}", std::process::id()))
        .join(tag)
        .join("resources");
    let mut made = made().lock().unwrap();
    if !made.contains(&dir) {
        write_resources(&dir, scene_text, meshes).unwrap();
        made.insert(dir.clone());
    }
    Resources {
        uri: CString::new(format!("file://{}", dir.display())).unwrap(),
        guid: CString::new(scm::sim::guid(scene_text)).unwrap(),
        dir,
    }
}

/// The `resources/` folder of a bundled scene, as `scm pack` lays it out.
pub fn resources(name: &str) -> Resources {
    let described = scm::pack::describe(&super::scene(name)).unwrap();
    resources_of(name, &described.scene_text, &described.resources)
}

/// Every bundled scene's name, sorted.
pub fn scene_names() -> Vec<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("resources/scenes");
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// `fmi2Instantiate` of `res` with `callbacks`.
///
/// # Safety
/// `callbacks` (and the capture it points to) must outlive the instance.
pub unsafe fn instantiate(
    res: &Resources,
    fmu_type: fmi2Type,
    callbacks: &fmi2CallbackFunctions,
) -> fmi2Component {
    unsafe {
        scm::fmi2Instantiate(
            c"test".as_ptr(),
            fmu_type,
            res.guid.as_ptr(),
            res.uri.as_ptr(),
            callbacks,
            fmi2False,
            fmi2False,
        )
    }
}

/// The instance's current state, got with `fmi2GetFMUstate` and serialized (the state is left
/// allocated in the instance, as a host that keeps it would).
///
/// # Safety
/// `c` must be a live instance in a state where `fmi2GetFMUstate` is allowed.
pub unsafe fn serialize_current(c: fmi2Component) -> Vec<u8> {
    unsafe {
        let mut st = std::ptr::null_mut();
        assert_eq!(scm::fmi2GetFMUstate(c, &mut st), fmi2OK);
        let mut size = 0;
        assert_eq!(scm::fmi2SerializedFMUstateSize(c, st, &mut size), fmi2OK);
        let mut bytes = vec![0u8; size];
        assert_eq!(
            scm::fmi2SerializeFMUstate(c, st, bytes.as_mut_ptr().cast(), size),
            fmi2OK
        );
        bytes
    }
}
