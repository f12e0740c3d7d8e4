//! Names as MuJoCo's compiler checks them: within one kind of object (bodies, joints, geoms,
//! sites, actuators, tendons, …) a name given twice is an error, wherever the two elements are
//! (included files too); objects of different kinds may share a name, and an unnamed object
//! has none. SCM names its unnamed objects for its FMU variables and messages (`body3`,
//! `arm_geom0`, `actuator1`, …); such a name never takes one the file gives to another object
//! of the same kind, so a file MuJoCo accepts is not refused for a name it never wrote.

use super::xml::Element;
use super::{element_error, SceneError};
use std::collections::{HashMap, HashSet};

/// The names a scene gives, per kind of object, and those SCM made up for unnamed ones.
#[derive(Debug, Default)]
pub(super) struct Names {
    given: HashMap<&'static str, HashSet<String>>,
    made: HashMap<&'static str, HashSet<String>>,
}

/// The kind of object `el` declares as a direct child of `section` (a child of the root, or
/// a body or frame under `worldbody`), as MuJoCo's namespaces go; `None` for an element that
/// declares no named object there (a reference such as a tendon's `<joint joint="…">` is a
/// grandchild and never reaches here).
fn kind(section: &str, el: &str) -> Option<&'static str> {
    Some(match (section, el) {
        ("worldbody", "body") => "body",
        ("worldbody", "joint" | "freejoint") => "joint",
        ("worldbody", "geom") => "geom",
        ("worldbody", "site") => "site",
        ("worldbody", "camera") => "camera",
        ("worldbody", "light") => "light",
        ("worldbody", "frame") => "frame",
        ("asset", "mesh") => "mesh",
        ("asset", "texture") => "texture",
        ("asset", "material") => "material",
        ("asset", "hfield") => "hfield",
        ("asset", "skin") => "skin",
        ("tendon", _) => "tendon",
        ("actuator", _) => "actuator",
        ("equality", _) => "equality",
        ("sensor", _) => "sensor",
        ("keyframe", "key") => "key",
        ("contact", "pair") => "pair",
        ("contact", "exclude") => "exclude",
        ("custom", "numeric") => "numeric",
        ("custom", "text") => "text",
        ("custom", "tuple") => "tuple",
        _ => return None,
    })
}

impl Names {
    /// Reads every name `root` gives (after its `<include>`s are expanded, before its frames
    /// are folded into their bodies) and refuses a name given twice within a kind, naming the
    /// second element and where the first is. The world body is named `world`, as in MuJoCo.
    pub(super) fn read(root: &Element) -> Result<Self, SceneError> {
        let mut names = Names::default();
        let mut first: HashMap<(&'static str, String), String> = HashMap::new();
        first.insert(("body", "world".into()), "the world body".into());
        names
            .given
            .entry("body")
            .or_default()
            .insert("world".into());
        let mut visit = |section: &str, el: &Element| -> Result<(), SceneError> {
            let (Some(kind), Some(name)) = (kind(section, &el.name), el.attr("name")) else {
                return Ok(());
            };
            if name.is_empty() {
                return Ok(());
            }
            let here = format!("<{}> at {}:{}", el.name, el.file, el.line);
            if let Some(before) = first.insert((kind, name.to_string()), here) {
                return Err(element_error(
                    el,
                    format!("{kind} name '{name}' is given twice (first: {before}); MuJoCo refuses a repeated name within one kind of object: rename one"),
                ));
            }
            names
                .given
                .entry(kind)
                .or_default()
                .insert(name.to_string());
            Ok(())
        };
        for section in &root.children {
            if section.name == "worldbody" {
                let mut stack: Vec<&Element> = section.children.iter().rev().collect();
                while let Some(el) = stack.pop() {
                    visit("worldbody", el)?;
                    if matches!(el.name.as_str(), "body" | "frame") {
                        stack.extend(el.children.iter().rev());
                    }
                }
            } else {
                for el in &section.children {
                    visit(&section.name, el)?;
                }
            }
        }
        Ok(names)
    }

    /// A name for an unnamed object of `kind`: `base` unless the scene gives that name to
    /// another object of the kind (or SCM made it up already), else `base_2`, `base_3`, …
    pub(super) fn make(&mut self, kind: &'static str, base: String) -> String {
        let taken = |n: &str, s: &Self| {
            s.given.get(kind).is_some_and(|g| g.contains(n))
                || s.made.get(kind).is_some_and(|m| m.contains(n))
        };
        let mut name = base.clone();
        let mut k = 2;
        while taken(&name, self) {
            name = format!("{base}_{k}");
            k += 1;
        }
        self.made.entry(kind).or_default().insert(name.clone());
        name
    }
}
