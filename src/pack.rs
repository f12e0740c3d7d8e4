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

/// A scene's text and the `modelDescription.xml` its FMU carries.
pub struct Described {
    /// The scene file as it goes into the FMU's `resources/`: as read, except that a scene
    /// with meshes gets `meshdir="meshes"` (its meshes are packed under `resources/meshes/`).
    pub scene_text: String,
    /// The generated `modelDescription.xml`.
    pub model_description: String,
    /// Other files for `resources/`: `(name relative to resources/, bytes)` (the meshes).
    pub resources: Vec<(String, Vec<u8>)>,
}

/// Where packed meshes go, under `resources/`, and the `meshdir` the packed scene names.
pub const MESH_FOLDER: &str = "meshes";

/// Loads `scene` and generates its `modelDescription.xml`: what `scm pack` writes, and what the
/// golden files under `modelDescription/` are checked against.
pub fn describe(scene: &Path) -> Result<Described, PackError> {
    let text = std::fs::read_to_string(scene).map_err(|e| crate::scene::SceneError { file: scene.display().to_string(), line: 0, element: "mujoco".into(), message: format!("cannot read the scene: {e}") })?;
    let loaded = crate::scene::load_str(&text, scene)?;
    let mut resources: Vec<(String, Vec<u8>)> = Vec::new();
    let scene_text = if loaded.meshes.is_empty() {
        text
    } else {
        for m in &loaded.meshes {
            let name = packed_mesh_name(&m.file).map_err(|why| PackError::Write(format!("{}: mesh {}: {why}", scene.display(), m.file)))?;
            if resources.iter().any(|(n, _)| *n == name) {
                continue;
            }
            let bytes = std::fs::read(&m.path).map_err(|e| PackError::Write(format!("{}: {e}", m.path.display())))?;
            resources.push((name, bytes));
        }
        with_meshdir(&text, MESH_FOLDER).map_err(|why| PackError::Write(format!("{}: {why}", scene.display())))?
    };
    let sim = Simulation::new(loaded, &scene_text);
    let model_description = crate::fmi::model_description::model_description_xml(sim.info());
    Ok(Described { scene_text, model_description, resources })
}

/// Packs `scene` with the FMU `library` into `out`: the scene file and the meshes it names go
/// into `resources/`.
pub fn pack(scene: &Path, library: &Path, out: &Path) -> Result<(), PackError> {
    let d = describe(scene)?;
    if !library.is_file() {
        return Err(PackError::Library(library.display().to_string()));
    }
    let mut files = vec![(SCENE_FILE.to_string(), d.scene_text.into_bytes())];
    files.extend(d.resources);
    crate::fmi::pack::write_fmu(out, &d.model_description, library, &files, None).map_err(|e| PackError::Write(e.to_string()))
}

/// The name under `resources/` of a mesh whose `file` attribute is `file`:
/// `meshes/<file>`, with `.` and `..` resolved (a path that leaves the mesh folder, or an
/// absolute one, cannot be packed).
pub fn packed_mesh_name(file: &str) -> Result<String, String> {
    if Path::new(file).is_absolute() {
        return Err("an absolute path cannot be packed: give the file relative to meshdir".into());
    }
    let mut parts: Vec<&str> = Vec::new();
    for c in file.split(['/', '\\']) {
        match c {
            "" | "." => {}
            ".." => {
                parts.pop().ok_or("the path leaves the mesh folder: give the file relative to meshdir")?;
            }
            c => parts.push(c),
        }
    }
    if parts.is_empty() {
        return Err("empty file name".into());
    }
    Ok(format!("{MESH_FOLDER}/{}", parts.join("/")))
}

/// The scene text with the `<compiler>` element's `meshdir` set to `dir` (added, with a
/// `<compiler>` element if there is none). Comments are skipped.
pub fn with_meshdir(text: &str, dir: &str) -> Result<String, String> {
    // Start positions of tags outside comments.
    let outside_comments = |pos: usize| {
        let before = &text[..pos];
        match before.rfind("<!--") {
            Some(open) => before[open..].contains("-->"),
            None => true,
        }
    };
    let find_tag = |name: &str| {
        let pat = format!("<{name}");
        let mut from = 0;
        while let Some(i) = text[from..].find(&pat).map(|i| i + from) {
            let next = text[i + pat.len()..].chars().next();
            if outside_comments(i) && matches!(next, Some(c) if c.is_whitespace() || c == '/' || c == '>') {
                return Some(i);
            }
            from = i + pat.len();
        }
        None
    };
    if let Some(start) = find_tag("compiler") {
        let end = start + text[start..].find('>').ok_or("unterminated <compiler> tag")?;
        let tag = &text[start..end];
        for q in ['"', '\''] {
            for key in [" meshdir=", "\tmeshdir=", "\nmeshdir="] {
                if let Some(k) = tag.find(&format!("{key}{q}")) {
                    let vstart = start + k + key.len() + 1;
                    let vend = vstart + text[vstart..].find(q).ok_or("unterminated meshdir value")?;
                    return Ok(format!("{}{dir}{}", &text[..vstart], &text[vend..]));
                }
            }
        }
        let at = start + "<compiler".len();
        return Ok(format!("{} meshdir=\"{dir}\"{}", &text[..at], &text[at..]));
    }
    let root = find_tag("mujoco").ok_or("no <mujoco> element")?;
    let end = root + text[root..].find('>').ok_or("unterminated <mujoco> tag")? + 1;
    Ok(format!("{}\n  <compiler meshdir=\"{dir}\"/>{}", &text[..end], &text[end..]))
}
