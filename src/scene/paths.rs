//! Where a scene's files are: mesh files as MuJoCo resolves them (`meshdir`, absolute or
//! relative paths), their names inside a packed FMU, and the scene's folder.

use super::SCENE_FILE;
use std::path::{Path, PathBuf};

/// Where a mesh file is: absolute as given, else relative to the scene file's folder joined
/// with `meshdir` (itself relative to the scene's folder unless absolute), as MuJoCo does.
///
/// Inside an unpacked FMU (the scene is `resources/scene.xml`), a mesh that is not found there
/// is looked up where `scm pack` puts it: `resources/` + [`packed_mesh_name`].
pub fn mesh_path(scene: &Path, meshdir: Option<&str>, file: &str) -> PathBuf {
    let f = Path::new(file);
    if f.is_absolute() {
        return f.to_path_buf();
    }
    let mut dir = scene_dir(scene);
    if let Some(d) = meshdir {
        dir = dir.join(d);
    }
    let path = dir.join(f);
    let in_fmu = scene.file_name().is_some_and(|n| n == SCENE_FILE)
        && scene_dir(scene)
            .file_name()
            .is_some_and(|n| n == "resources");
    if !path.exists() && in_fmu {
        if let Ok(packed) = packed_mesh_name(file) {
            let p = scene_dir(scene).join(packed);
            if p.exists() {
                return p;
            }
        }
    }
    path
}

/// The name under an FMU's `resources/` of a mesh whose `file` attribute is `file`:
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
                parts
                    .pop()
                    .ok_or("the path leaves the mesh folder: give the file relative to meshdir")?;
            }
            c => parts.push(c),
        }
    }
    if parts.is_empty() {
        return Err("empty file name".into());
    }
    Ok(format!("meshes/{}", parts.join("/")))
}

/// The folder a scene's relative paths start from.
pub fn scene_dir(path: &Path) -> PathBuf {
    path.parent().map(Path::to_path_buf).unwrap_or_default()
}
