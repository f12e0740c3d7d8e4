//! `<attach model="M" body="B" prefix="P"/>`: MuJoCo's composition of models. `M` is an
//! `<asset><model name="M" file="..."/>` (its name, when not given, is the file's own
//! `<mujoco model="...">`); the body `B` of that model and everything below it take the
//! attach's place in this file's tree, or, without `body`, everything in that model's world.
//!
//! As in MuJoCo's compiler, the attached elements keep their own model's meaning: its default
//! classes and its angle unit and Euler sequence (the child is read to its canonical form on
//! its own, then grafted; [`super::canonical::ATTACHED`] keeps this file's defaults away);
//! every name it gives is prefixed with `P` (an unnamed element stays unnamed), and so is every
//! reference to a prefixed name. The elements of the child's other sections (tendons,
//! equalities, contact pairs and exclusions, actuators, sensors) that name what is attached
//! are copied too, prefixed, after this file's own; an element that names both something
//! attached and something left behind is dropped, as MuJoCo drops it, and listed as unused
//! (attach a body holding both to keep it). Meshes and
//! height fields the attached geoms use come along, prefixed, their files found where the
//! child's `meshdir` puts them. The child's `<option>`, `<size>`, `<custom>` and renderer
//! settings are not used (this file's hold, as in MuJoCo), nor are its keyframes (MuJoCo keeps
//! them through one attachment only): both are listed as unused.
//!
//! A `<replicate>` holding an `<attach>` copies the attach, which then brings its model copy by
//! copy, in the tree's order, the replicate's suffix after the name ([`SUFFIX`]): `_torso-00`,
//! as MuJoCo names it and orders what it brings.
//!
//! Without `model`, an `<attach body="B">` or `frame="F"` copies a body or frame of this same
//! file (MuJoCo's self-attachment, as its luggage carousel builds three conveyors from one):
//! the copy as the file writes it, before any attach is expanded, in this file's defaults (its
//! class where it was written), prefixed, with the other sections' elements that name only
//! what it copies.

use super::canonical::{convert_angles, ATTACHED};
use super::include::{resolve, IncludedFile};
use super::replicate::{collect_names, kind_of_reference, names, refers, rename, Named, REFERRING};
use super::self_attach::{attaches_itself, graft_self};
use super::xml::Element;
use super::{element_error, scene_dir, Builder, SceneError};
use std::path::{Component, Path, PathBuf};

/// The suffix a `<replicate>` gives the names an `<attach>` inside it brings (an attribute
/// the replicate writes on its copies of the attach; XML cannot write it: it holds a space).
pub(super) const SUFFIX: &str = "scm suffix";

/// Deepest chain of models attaching models accepted (a cycle is reported before that).
const MAX_DEPTH: usize = 16;

/// A model an `<asset><model>` declares, read to its canonical tree.
struct Child {
    /// The name `<attach model>` uses.
    name: String,
    /// The declaring element (for errors and the unused list).
    declared: Element,
    /// The child's file.
    path: PathBuf,
    /// Its builder: compiler settings, angle unit, mesh folder.
    b: Builder,
    /// Its canonical tree.
    root: Element,
    /// Whether an `<attach>` used it.
    used: bool,
}

/// What one `<attach>` brings: the elements taking its place, and those of other sections
/// (by section name, in order).
pub(super) type Graft = (Vec<Element>, Vec<(String, Element)>);

/// Replaces every `<attach>` under `root`'s `<worldbody>` (read from `path`, attached from the
/// files in `chain`) by what it attaches, and the `<asset><model>`s by nothing. Returns the
/// files read (the models' files and what they include or attach), for `scm pack`.
pub(super) fn expand(
    root: &mut Element,
    b: &mut Builder,
    path: &Path,
    chain: &mut Vec<PathBuf>,
) -> Result<Vec<IncludedFile>, SceneError> {
    let mut declared = Vec::new();
    for section in root.children.iter_mut().filter(|s| s.name == "asset") {
        let (models, rest): (Vec<Element>, Vec<Element>) = std::mem::take(&mut section.children)
            .into_iter()
            .partition(|a| a.name == "model");
        section.children = rest;
        declared.extend(models);
    }
    let attaches = root
        .children
        .iter()
        .filter(|s| s.name == "worldbody")
        .any(holds_attach);
    if declared.is_empty() && !attaches {
        return Ok(Vec::new());
    }
    let mut files = Vec::new();
    let mut children = Vec::new();
    for el in declared {
        b.check_attrs(&el, &["name", "file", "content_type"])?;
        let file = el
            .attr("file")
            .ok_or_else(|| element_error(&el, "a <model> asset needs file=\"...\""))?
            .to_string();
        if !attaches {
            b.unused(&el, "a model that no <attach> uses");
            continue;
        }
        // A model's file is found from the folder of the file declaring it (MuJoCo's rule).
        let target = resolve(&scene_dir(path), path, &file);
        let real = target.canonicalize().ok();
        let same = |p: &PathBuf| p == &target || (real.is_some() && p.canonicalize().ok() == real);
        if chain.iter().any(same) || chain.len() > MAX_DEPTH {
            let through: Vec<String> = chain.iter().map(|p| p.display().to_string()).collect();
            return Err(element_error(
                &el,
                format!(
                    "'{file}' attaches itself (through {})",
                    through.join(" -> ")
                ),
            ));
        }
        let text = std::fs::read_to_string(&target)
            .map_err(|e| element_error(&el, format!("cannot read '{}': {e}", target.display())))?;
        chain.push(target.clone());
        let prepared = super::prepare(&text, &target, chain);
        chain.pop();
        let (cb, croot, cfiles) = prepared?;
        files.push(IncludedFile {
            file: file.clone(),
            path: target.clone(),
        });
        files.extend(cfiles);
        let name = match (el.attr("name"), croot.attr("model")) {
            (Some(n), _) | (None, Some(n)) => n.to_string(),
            (None, None) => {
                return Err(element_error(
                    &el,
                    format!("the model '{file}' has no name: give the asset name=\"...\" (its <mujoco> gives no model=\"...\")"),
                ))
            }
        };
        if children.iter().any(|c: &Child| c.name == name) {
            return Err(element_error(
                &el,
                format!("model name '{name}' is given twice"),
            ));
        }
        children.push(Child {
            name,
            declared: el,
            path: target,
            b: cb,
            root: croot,
            used: false,
        });
    }
    let mut extra: Vec<(String, Element)> = Vec::new();
    // A self-attachment copies from this file as written (before any attach is expanded).
    let own = root
        .children
        .iter()
        .filter(|s| s.name == "worldbody")
        .any(attaches_itself)
        .then(|| root.clone());
    let mut models = Models {
        children: &mut children,
        own: own.as_ref(),
    };
    for w in root.children.iter_mut().filter(|s| s.name == "worldbody") {
        graft_in(&mut w.children, b, &mut models, &mut extra)?;
    }
    // The other sections' elements after this file's own, in a section of their kind.
    for (section, el) in extra {
        // An asset a replicate's copies of one attach all bring is brought once.
        let same = |a: &Element| a == &el;
        if section == "asset"
            && (root.children.iter())
                .filter(|s| s.name == "asset")
                .any(|s| s.children.iter().any(same))
        {
            continue;
        }
        match root.children.iter_mut().rev().find(|s| s.name == section) {
            Some(s) => s.children.push(el),
            None => root.children.push(Element {
                name: section,
                attrs: Vec::new(),
                children: vec![el],
                line: root.line,
                file: root.file.clone(),
                text: Vec::new(),
            }),
        }
    }
    for c in children {
        if !c.used {
            b.unused(&c.declared, "a model that no <attach> uses");
        }
        b.unused.extend(c.b.unused);
        b.warnings.extend(c.b.warnings);
    }
    Ok(files)
}

/// Whether an `<attach>` is anywhere under `el`.
pub(super) fn holds_attach(el: &Element) -> bool {
    el.children
        .iter()
        .any(|c| c.name == "attach" || holds_attach(c))
}

/// Where `<attach>`es take from: the declared models, and this file as written (for a
/// self-attachment; `None` when the file has none).
struct Models<'a> {
    children: &'a mut [Child],
    own: Option<&'a Element>,
}

/// Replaces the `<attach>`s among `children` (and in their bodies and frames).
fn graft_in(
    children: &mut Vec<Element>,
    b: &mut Builder,
    models: &mut Models,
    extra: &mut Vec<(String, Element)>,
) -> Result<(), SceneError> {
    let mut out = Vec::with_capacity(children.len());
    for mut el in std::mem::take(children) {
        if el.name == "attach" {
            let (here, other) = graft(&el, b, models)?;
            out.extend(here);
            extra.extend(other);
            continue;
        }
        if matches!(el.name.as_str(), "body" | "frame") {
            graft_in(&mut el.children, b, models, extra)?;
        }
        out.push(el);
    }
    *children = out;
    Ok(())
}

/// What one `<attach>` brings (see the module).
fn graft(att: &Element, b: &mut Builder, models: &mut Models) -> Result<Graft, SceneError> {
    b.check_attrs(att, &["model", "body", "frame", "prefix", SUFFIX])?;
    let suffix = att.attr(SUFFIX).unwrap_or("");
    if !att.children.is_empty() {
        return Err(element_error(att, "an <attach> has no child elements"));
    }
    let prefix = att.attr("prefix").ok_or_else(|| {
        element_error(att, "prefix=\"...\" is required (MuJoCo requires it too): it keeps the attached names apart from this file's")
    })?;
    let Some(model) = att.attr("model") else {
        let own = models
            .own
            .expect("a self-attachment keeps the file as written");
        return graft_self(att, b, own, &|v: &str| format!("{prefix}{v}{suffix}"));
    };
    if att.attr("frame").is_some() {
        return Err(element_error(att, "attaching a <frame> (frame=\"...\") of another model is not supported by SCM: attach the body it holds (body=\"...\"), or the whole model (neither); a frame of this same model attaches (no model=\"...\")"));
    }
    let Some(child) = models.children.iter_mut().find(|c| c.name == model) else {
        let known: Vec<&str> = models.children.iter().map(|c| c.name.as_str()).collect();
        return Err(element_error(
            att,
            format!(
                "no <asset><model> named '{model}' (models: {})",
                if known.is_empty() {
                    "none".to_string()
                } else {
                    known.join(", ")
                }
            ),
        ));
    };
    child.used = true;
    let differ = compiler_differences(b, &child.b);
    if !differ.is_empty() {
        return Err(element_error(
            att,
            format!(
                "the model '{model}' is compiled with other settings than this file ({}): SCM compiles a scene under one <compiler>, give both files the same",
                differ.join("; ")
            ),
        ));
    }
    let worlds = || {
        child
            .root
            .children
            .iter()
            .filter(|s| s.name == "worldbody")
            .flat_map(|w| w.children.iter())
    };
    let mut here: Vec<Element> = match att.attr("body") {
        Some(name) => {
            let found = worlds().find_map(|el| find_body(el, name)).ok_or_else(|| {
                element_error(
                    att,
                    format!("the model '{model}' has no body named '{name}'"),
                )
            })?;
            vec![found.clone()]
        }
        None => worlds().cloned().collect(),
    };
    let mut named = Named::new();
    for el in &here {
        collect_names(el, "worldbody", &mut named);
    }
    if child.b.angles.degrees != b.angles.degrees {
        for el in here.iter_mut() {
            convert_angles(el, child.b.angles.degrees)?;
        }
    }
    let prefixed = |v: &str| format!("{prefix}{v}{suffix}");
    let mut other: Vec<(String, Element)> = Vec::new();
    // The assets the attached geoms use, prefixed, their files where the child finds them.
    let mut assets = Vec::new();
    for el in here.iter_mut() {
        take_assets(el, child, b, prefix, &mut assets)?;
    }
    other.extend(assets.into_iter().map(|a| ("asset".to_string(), a)));
    for el in here.iter_mut() {
        rename(el, &named, &prefixed);
        el.attrs.push((ATTACHED.to_string(), String::new()));
    }
    // The other sections: a kind's elements that name what is attached (and what the kinds
    // before it brought: an actuator on an attached tendon), in the child's order.
    let from = format!("model '{model}'");
    other.extend(bring_referring(
        att,
        b,
        &child.root,
        &from,
        &mut named,
        &prefixed,
        true,
    ));
    for s in &child.root.children {
        let why = match s.name.as_str() {
            "keyframe" => "keyframes of an attached model (MuJoCo keeps them through one attachment only): give the pose in a key of the attaching file",
            "option" | "size" | "custom" | "extension" => "settings of an attached model (the attaching file's hold, as in MuJoCo)",
            "visual" | "statistic" => "renderer settings of an attached model",
            _ => continue,
        };
        b.unused(s, why);
    }
    Ok((here, other))
}

/// The elements of `root`'s other sections (tendons, equalities, contact, actuators, sensors)
/// that name what is attached (`named`, which grows with what each kind brings: an actuator on
/// an attached tendon), renamed by `prefixed`, in `root`'s order; those that also name
/// something left behind in `from` are dropped and listed as unused, as MuJoCo drops them.
/// `attached`: the elements come from another model, already canonical
/// ([`ATTACHED`](super::canonical::ATTACHED)).
pub(super) fn bring_referring(
    att: &Element,
    b: &mut Builder,
    root: &Element,
    from: &str,
    named: &mut Named,
    prefixed: &dyn Fn(&str) -> String,
    attached: bool,
) -> Vec<(String, Element)> {
    let mut other = Vec::new();
    for kind in REFERRING {
        let mut brought = Vec::new();
        for s in root.children.iter().filter(|s| s.name == kind) {
            for el in s.children.iter().filter(|el| refers(el, named)) {
                if let Some((k, v)) = foreign(el, named) {
                    b.unused(
                        el,
                        format!("it names '{v}' ({k}), which the <attach> at {}:{} leaves behind in {from}: not attached (MuJoCo drops it too)", att.file, att.line),
                    );
                    continue;
                }
                brought.push(el.clone());
            }
        }
        for el in &brought {
            collect_names(el, kind, named);
        }
        for mut el in brought {
            rename(&mut el, named, prefixed);
            if attached && kind != "sensor" {
                el.attrs.push((ATTACHED.to_string(), String::new()));
            }
            other.push((kind.to_string(), el));
        }
    }
    other
}

/// The body named `name` at or below `el` (a canonical tree: bodies hold bodies).
fn find_body<'a>(el: &'a Element, name: &str) -> Option<&'a Element> {
    if el.name != "body" {
        return None;
    }
    if el.attr("name") == Some(name) {
        return Some(el);
    }
    el.children.iter().find_map(|c| find_body(c, name))
}

/// A reference of `el` (or of an element inside it) to something not in `named`: the
/// attribute and the name. The world body belongs to every model.
fn foreign(el: &Element, named: &Named) -> Option<(String, String)> {
    for (k, v) in &el.attrs {
        let Some(kind) = kind_of_reference(k) else {
            continue;
        };
        if names(named, k, v) || (kind == "body" && v == "world") {
            continue;
        }
        // `target` is a camera's or light's, `objname` and `refname` a sensor's: for those
        // the kind comes from elsewhere; a name found nowhere among the attached is foreign.
        return Some((k.clone(), v.clone()));
    }
    el.children.iter().find_map(|c| foreign(c, named))
}

/// The compiler settings under which two files differ, for a refusal.
fn compiler_differences(parent: &Builder, child: &Builder) -> Vec<String> {
    let (p, c) = (&parent.settings, &child.settings);
    let mut out = Vec::new();
    let mut cmp = |what: &str, a: String, b: String| {
        if a != b {
            out.push(format!("{what}: {b} there, {a} here"));
        }
    };
    cmp(
        "autolimits",
        p.autolimits.to_string(),
        c.autolimits.to_string(),
    );
    cmp(
        "inertiafromgeom",
        format!("{:?}", p.inertia_from_geom),
        format!("{:?}", c.inertia_from_geom),
    );
    cmp(
        "inertiagrouprange",
        format!("{:?}", p.inertia_groups),
        format!("{:?}", c.inertia_groups),
    );
    cmp(
        "settotalmass",
        p.total_mass.to_string(),
        c.total_mass.to_string(),
    );
    cmp(
        "boundmass",
        p.bound_mass.to_string(),
        c.bound_mass.to_string(),
    );
    cmp(
        "boundinertia",
        p.bound_inertia.to_string(),
        c.bound_inertia.to_string(),
    );
    cmp("fitaabb", p.fit_aabb.to_string(), c.fit_aabb.to_string());
    out
}

/// Copies into `out` (once each) the child's meshes and height fields that the geoms under
/// `el` use, prefixed, with their files written relative to the attaching file's mesh folder;
/// the geoms' references follow.
fn take_assets(
    el: &mut Element,
    child: &Child,
    b: &Builder,
    prefix: &str,
    out: &mut Vec<Element>,
) -> Result<(), SceneError> {
    if el.name == "geom" {
        for key in ["mesh", "hfield"] {
            let Some(used) = el.attr(key).map(str::to_string) else {
                continue;
            };
            let asset = child
                .root
                .children
                .iter()
                .filter(|s| s.name == "asset")
                .flat_map(|s| s.children.iter())
                .find(|a| a.name == key && asset_name(a).as_deref() == Some(used.as_str()))
                .ok_or_else(|| {
                    element_error(el, format!("{key} '{used}' is not an asset of its model"))
                })?;
            // (MuJoCo shares the assets among a replicate's copies: no suffix.)
            let name = format!("{prefix}{used}");
            if !out
                .iter()
                .any(|a| a.name == key && a.attr("name") == Some(name.as_str()))
            {
                out.push(moved_asset(asset, &name, child, b)?);
            }
            if let Some(slot) = el.attrs.iter_mut().find(|(k, _)| k == key) {
                slot.1 = name;
            }
        }
    }
    for c in el.children.iter_mut() {
        take_assets(c, child, b, prefix, out)?;
    }
    Ok(())
}

/// A mesh's or height field's name: given, or its file's stem (MuJoCo's rule).
fn asset_name(a: &Element) -> Option<String> {
    a.attr("name").map(str::to_string).or_else(|| {
        Path::new(a.attr("file")?)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
    })
}

/// `asset` of the child named `name`, its file relative to the attaching file's mesh folder.
fn moved_asset(
    asset: &Element,
    name: &str,
    child: &Child,
    b: &Builder,
) -> Result<Element, SceneError> {
    if asset.children.iter().any(|c| c.name == "plugin") {
        return Err(element_error(asset, "a mesh an engine plugin makes cannot be attached by SCM yet: declare it in the attaching file"));
    }
    let mut a = asset.clone();
    match a.attrs.iter_mut().find(|(k, _)| k == "name") {
        Some(slot) => slot.1 = name.to_string(),
        None => a.attrs.push(("name".into(), name.to_string())),
    }
    if let Some(file) = asset.attr("file") {
        let mut dir = scene_dir(&child.path);
        if let Some(d) = &child.b.meshdir {
            dir = dir.join(d);
        }
        let mut base = scene_dir(Path::new(&b.file));
        if let Some(d) = &b.meshdir {
            base = base.join(d);
        }
        let moved = relative_to(&dir.join(file), &base);
        if let Some(slot) = a.attrs.iter_mut().find(|(k, _)| k == "file") {
            slot.1 = moved;
        }
    }
    a.attrs.push((ATTACHED.to_string(), String::new()));
    Ok(a)
}

/// `target` written relative to the folder `base` (both taken lexically, after making them
/// absolute from the working folder), `/`-separated; an absolute path where they share no root.
fn relative_to(target: &Path, base: &Path) -> String {
    let absolute = |p: &Path| -> Vec<String> {
        let full = if p.is_absolute() {
            p.to_path_buf()
        } else {
            std::env::current_dir().unwrap_or_default().join(p)
        };
        let mut parts: Vec<String> = Vec::new();
        for c in full.components() {
            match c {
                Component::ParentDir => {
                    parts.pop();
                }
                Component::CurDir => {}
                c => parts.push(c.as_os_str().to_string_lossy().into_owned()),
            }
        }
        parts
    };
    let (t, b) = (absolute(target), absolute(base));
    let common = t.iter().zip(&b).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return target.display().to_string();
    }
    let mut out: Vec<String> = vec!["..".to_string(); b.len() - common];
    out.extend(t[common..].iter().cloned());
    out.join("/")
}
