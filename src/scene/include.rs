//! `<include file="..."/>`: the included file's `<mujoco>` children take the element's place.
//!
//! A relative path is resolved as MuJoCo resolves it: against the main file's folder first,
//! then against the folder of the file that holds the `<include>`. Every element keeps the
//! file it was read from, so errors name the included file and its line.

use super::xml::{self, Element};
use super::SceneError;
use std::path::{Path, PathBuf};

/// Deepest chain of includes accepted (a cycle is reported before that).
const MAX_DEPTH: usize = 32;

/// A file read through an `<include>`: as written and resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct IncludedFile {
    /// The `file` attribute as written.
    pub file: String,
    /// The path it resolved to.
    pub path: PathBuf,
}

/// Replaces every `<include>` under `root` (read from `path`) by the included children,
/// recursively. Returns the files read, in order.
pub fn expand(root: &mut Element, path: &Path) -> Result<Vec<IncludedFile>, SceneError> {
    let mut read = Vec::new();
    let mut chain = vec![path.to_path_buf()];
    let main = super::scene_dir(path);
    expand_in(root, &main, path, &mut chain, &mut read)?;
    Ok(read)
}

/// Where `scm pack` put `wanted` (a path under the unpacked FMU's `resources/` folder `main`,
/// lexically) if the scene is an FMU's and the file is there.
fn in_fmu(main: &Path, wanted: &Path) -> Option<PathBuf> {
    if !super::paths::is_unpacked_fmu(main) {
        return None;
    }
    let rel = wanted.strip_prefix(main).ok()?;
    let packed = main.join(super::paths::packed_relative(&rel.to_string_lossy()).ok()?);
    packed.exists().then_some(packed)
}

/// Where a file named `file` by an element of the file `holder` is, for a scene whose main file
/// is in `main`: MuJoCo's order (the main file's folder, then the holder's), then, inside an
/// FMU, where `scm pack` put a file reached through `..` (`super::paths::packed_relative`).
/// A file found nowhere resolves against `main`, so that the error names that path.
pub(super) fn resolve(main: &Path, holder: &Path, file: &str) -> PathBuf {
    let here = super::scene_dir(holder).join(file);
    let first = main.join(file);
    if first.exists() {
        first
    } else if here.exists() {
        here
    } else {
        in_fmu(main, &first)
            .or_else(|| in_fmu(main, &here))
            .unwrap_or(first)
    }
}

fn expand_in(
    el: &mut Element,
    main: &Path,
    path: &Path,
    chain: &mut Vec<PathBuf>,
    read: &mut Vec<IncludedFile>,
) -> Result<(), SceneError> {
    let mut out = Vec::with_capacity(el.children.len());
    for mut child in std::mem::take(&mut el.children) {
        if child.name != "include" {
            expand_in(&mut child, main, path, chain, read)?;
            out.push(child);
            continue;
        }
        let err = |message: String| SceneError {
            file: child.file.to_string(),
            line: child.line,
            element: "include".into(),
            message,
        };
        if let Some((k, _)) = child.attrs.iter().find(|(k, _)| k != "file") {
            return Err(err(format!("attribute '{k}' is not an include attribute")));
        }
        let file = child
            .attr("file")
            .ok_or_else(|| err("file=\"...\" is required".into()))?
            .to_string();
        if !child.children.is_empty() {
            return Err(err("an include cannot have child elements".into()));
        }
        let target = resolve(main, path, &file);
        if chain.iter().any(|p| p == &target) || chain.len() > MAX_DEPTH {
            return Err(err(format!(
                "'{file}' includes itself (through {})",
                chain
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(" -> ")
            )));
        }
        let text = std::fs::read_to_string(&target)
            .map_err(|e| err(format!("cannot read '{}': {e}", target.display())))?;
        let shown = target.display().to_string();
        let mut root = xml::parse(&text, &shown).map_err(|e| SceneError {
            file: shown.clone(),
            line: e.line,
            element: "xml".into(),
            message: e.message,
        })?;
        // `<mujocoinclude>` is the root older files give an included file; MuJoCo takes both.
        if root.name != "mujoco" && root.name != "mujocoinclude" {
            return Err(SceneError {
                file: shown,
                line: root.line,
                element: root.name.clone(),
                message: "an included file's root element must be <mujoco> (or <mujocoinclude>)"
                    .into(),
            });
        }
        read.push(IncludedFile {
            file,
            path: target.clone(),
        });
        chain.push(target.clone());
        expand_in(&mut root, main, &target, chain, read)?;
        chain.pop();
        out.extend(root.children);
    }
    el.children = out;
    Ok(())
}
