//! `scm pack`: a scene into an FMU holding only what the scene needs.

use crate::fmi::contract::FmiModel;
use crate::sim::{Simulation, SCENE_FILE};
use std::path::Path;

/// Why packing failed.
#[derive(Debug, thiserror::Error)]
pub enum PackError {
    /// The scene does not load.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// The library is missing.
    #[error("{0}: the FMU library (libscm.so) is not there: build it with `cargo build --release` or pass --lib")]
    Library(String),
    /// Writing the archive failed.
    #[error("{0}")]
    Write(String),
}

/// Packs `scene` with the FMU `library` into `out`.
pub fn pack(scene: &Path, library: &Path, out: &Path) -> Result<(), PackError> {
    let text = std::fs::read_to_string(scene).map_err(|e| crate::scene::SceneError { file: scene.display().to_string(), line: 0, element: "mujoco".into(), message: format!("cannot read the scene: {e}") })?;
    let sim = Simulation::new(crate::scene::load_str(&text, scene)?, &text);
    if !library.is_file() {
        return Err(PackError::Library(library.display().to_string()));
    }
    let xml = crate::fmi::model_description::model_description_xml(sim.info());
    crate::fmi::pack::write_fmu(out, &xml, library, &[(SCENE_FILE.to_string(), text.into_bytes())], None).map_err(|e| PackError::Write(e.to_string()))
}
