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
    /// The scene file as read: it goes into the FMU's `resources/` unchanged (its meshes go
    /// under `resources/meshes/`, where the loader looks for them inside an FMU).
    pub scene_text: String,
    /// The generated `modelDescription.xml`.
    pub model_description: String,
    /// The generated `documentation/index.html`.
    pub documentation: String,
    /// Other files for `resources/`: `(name relative to resources/, bytes)` (the meshes).
    pub resources: Vec<(String, Vec<u8>)>,
}

/// Loads `scene` and generates its `modelDescription.xml` and documentation: what `scm pack`
/// writes; the golden files under `modelDescription/` are checked against the former.
pub fn describe(scene: &Path) -> Result<Described, PackError> {
    let text = crate::scene::read_text(scene)?;
    let loaded = crate::scene::load_str(&text, scene)?;
    // The meshes under `meshes/`, the included files where the includes find them again.
    let files = loaded
        .meshes
        .iter()
        .filter(|m| m.inline.is_none()) // an inline mesh travels in the scene itself
        .map(|m| {
            (
                crate::scene::packed_mesh_name(&m.file),
                "mesh",
                &m.file,
                &m.path,
            )
        })
        .chain(loaded.hfields.iter().filter_map(|h| {
            let (file, path) = h.file.as_ref()?;
            Some((crate::scene::packed_mesh_name(file), "hfield", file, path))
        }))
        .chain(loaded.includes.iter().map(|i| {
            (
                packed_include_name(scene, &i.path),
                "include",
                &i.file,
                &i.path,
            )
        }));
    let mut resources: Vec<(String, Vec<u8>)> = Vec::new();
    // Each name's file: the same file twice is packed once; two files under one name (a
    // `_parent_` folder written as such and a `..`) are refused, never one silently dropped.
    let mut packed: Vec<(String, &std::path::PathBuf)> = Vec::new();
    for (name, kind, file, path) in files {
        let name = name.map_err(|why| {
            PackError::Write(format!("{}: {kind} {file}: {why}", scene.display()))
        })?;
        if let Some((_, first)) = packed.iter().find(|(n, _)| *n == name) {
            let same = |p: &std::path::Path| p.canonicalize().ok();
            if same(first) != same(path) {
                return Err(PackError::Write(format!(
                    "{}: {kind} {file}: packs as resources/{name}, as {} does: rename one",
                    scene.display(),
                    first.display()
                )));
            }
            continue;
        }
        let bytes = std::fs::read(path)
            .map_err(|e| PackError::Write(format!("{}: {e}", path.display())))?;
        packed.push((name.clone(), path));
        resources.push((name, bytes));
    }
    let sim = Simulation::new(loaded.clone(), &text);
    let model_description = crate::fmi::model_description::model_description_xml(sim.info());
    let documentation = documentation::index_html(&loaded, sim.info());
    Ok(Described {
        scene_text: text,
        model_description,
        documentation,
        resources,
    })
}

/// Packs `scene` with the FMU `library` into `out`: the scene file, the meshes it names and
/// the files it includes go into `resources/`.
pub fn pack(scene: &Path, library: &Path, out: &Path) -> Result<(), PackError> {
    let d = describe(scene)?;
    if !library.is_file() {
        return Err(PackError::Library(library.display().to_string()));
    }
    let mut files = vec![(SCENE_FILE.to_string(), d.scene_text.into_bytes())];
    files.extend(d.resources);
    crate::fmi::pack::write_fmu(
        out,
        &d.model_description,
        library,
        &files,
        Some(&d.documentation),
    )
    .map_err(|e| PackError::Write(e.to_string()))
}

/// Where an included file goes under the FMU's `resources/`: its path relative to the scene's
/// folder (the scene itself is `resources/scene.xml`), with each `..` that leaves that folder
/// kept as a `_parent_` folder ([`crate::scene::packed_relative`]), so that the include
/// resolves there as it did beside the scene. A path that does not start with the scene's
/// folder as written (an absolute path elsewhere) cannot be packed.
fn packed_include_name(scene: &Path, included: &Path) -> Result<String, String> {
    let rel = included
        .strip_prefix(crate::scene::scene_dir(scene))
        .map_err(|_| "the file is outside the scene's folder: move it under that folder")?;
    if rel.is_absolute() {
        return Err("an absolute path cannot be packed".into());
    }
    let name = crate::scene::packed_relative(&rel.to_string_lossy())?;
    if name == crate::sim::SCENE_FILE {
        return Err(format!(
            "an included file cannot be named {}",
            crate::sim::SCENE_FILE
        ));
    }
    Ok(name)
}
