//! `scm pack`: a scene into an FMU holding only what the scene needs.

use crate::fmi::contract::FmiModel;
use crate::sim::{Simulation, SCENE_FILE};
use std::path::Path;

pub mod documentation;

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

/// A scene's text and the `modelDescription.xml` its FMU carries.
pub struct Described {
    /// The scene file, as read (it goes into the FMU's `resources/`).
    pub scene_text: String,
    /// The generated `modelDescription.xml`.
    pub model_description: String,
    /// The generated `documentation/index.html`.
    pub documentation: String,
}

/// Loads `scene` and generates its `modelDescription.xml` and documentation: what `scm pack`
/// writes; the golden files under `modelDescription/` are checked against the former.
pub fn describe(scene: &Path) -> Result<Described, PackError> {
    let text = std::fs::read_to_string(scene).map_err(|e| crate::scene::SceneError { file: scene.display().to_string(), line: 0, element: "mujoco".into(), message: format!("cannot read the scene: {e}") })?;
    let loaded = crate::scene::load_str(&text, scene)?;
    let sim = Simulation::new(loaded.clone(), &text);
    let model_description = crate::fmi::model_description::model_description_xml(sim.info());
    let documentation = documentation::index_html(&loaded, sim.info());
    Ok(Described { scene_text: text, model_description, documentation })
}

/// Packs `scene` with the FMU `library` into `out`.
pub fn pack(scene: &Path, library: &Path, out: &Path) -> Result<(), PackError> {
    let d = describe(scene)?;
    if !library.is_file() {
        return Err(PackError::Library(library.display().to_string()));
    }
    crate::fmi::pack::write_fmu(out, &d.model_description, library, &[(SCENE_FILE.to_string(), d.scene_text.into_bytes())], Some(&d.documentation)).map_err(|e| PackError::Write(e.to_string()))
}
