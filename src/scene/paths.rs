//! Where a scene's files are: mesh files as MuJoCo resolves them (`meshdir`, absolute or
//! relative paths), their names inside a packed FMU, and the scene's folder.

use super::SCENE_FILE;
use std::path::{Path, PathBuf};

/// Where a mesh file is: absolute as given, else relative to the scene file's folder joined
/// with `meshdir` (itself relative to the scene's folder unless absolute), as MuJoCo does.
///
/// Inside an unpacked FMU (the scene is `resources/scene.xml`), a mesh is looked up first
/// where `scm pack` puts it, `resources/` + [`packed_mesh_name`]: the path as written could
/// name another packed mesh there (`meshes/a.obj` written, `a.obj` packed as `meshes/a.obj`).
pub fn mesh_path(scene: &Path, meshdir: Option<&str>, file: &str) -> PathBuf {
    let f = Path::new(file);
    if f.is_absolute() {
        return f.to_path_buf();
    }
    if is_unpacked_fmu(&scene_dir(scene)) {
        if let Ok(packed) = packed_mesh_name(file) {
            let p = scene_dir(scene).join(packed);
            if p.exists() {
                return p;
            }
        }
    }
    let mut dir = scene_dir(scene);
    if let Some(d) = meshdir {
        dir = dir.join(d);
    }
    dir.join(f)
}

/// Whether `folder` is an unpacked FMU's `resources/`, holding the scene `scm pack` put
/// there: where packed files are looked up by their packed names first.
pub fn is_unpacked_fmu(folder: &Path) -> bool {
    folder.file_name().is_some_and(|n| n == "resources") && folder.join(SCENE_FILE).exists()
}

/// The name under an FMU's `resources/` of a mesh whose `file` attribute is `file`:
/// `meshes/<file>`, with `.` and `..` resolved ([`packed_relative`]: a `..` that leaves the
/// mesh folder, as in `../../meshes/hood.stl` relative to `meshdir`, becomes a folder named
/// `_parent_`). An absolute path cannot be packed.
pub fn packed_mesh_name(file: &str) -> Result<String, String> {
    if Path::new(file).is_absolute() {
        return Err("an absolute path cannot be packed: give the file relative to meshdir".into());
    }
    Ok(format!("meshes/{}", packed_relative(file)?))
}

/// A relative path with `.` and `..` resolved, `/`-separated, each `..` that would leave its
/// starting folder kept as a folder named `_parent_`: where `scm pack` puts a file that a
/// scene names by such a path, so that the same path finds it again inside the FMU.
pub fn packed_relative(path: &str) -> Result<String, String> {
    let mut parts: Vec<&str> = Vec::new();
    for c in path.split(['/', '\\']) {
        match c {
            "" | "." => {}
            ".." if parts.last().is_some_and(|p| *p != PARENT) => {
                parts.pop();
            }
            ".." => parts.push(PARENT),
            c => parts.push(c),
        }
    }
    if parts.is_empty() {
        return Err("empty file name".into());
    }
    Ok(parts.join("/"))
}

/// The folder that stands for a `..` leaving its starting folder in a packed file's name
/// ([`packed_relative`]); `scm pack` refuses two different files that would share a name.
pub const PARENT: &str = "_parent_";

/// The folder a scene's relative paths start from.
pub fn scene_dir(path: &Path) -> PathBuf {
    path.parent().map(Path::to_path_buf).unwrap_or_default()
}
