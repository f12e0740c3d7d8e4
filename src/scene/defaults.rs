//! Default classes as MuJoCo applies them: `<default>` is the class `main`; a nested
//! `<default class="c">` inherits every attribute of its parent and overrides some. An element
//! takes the class named by its `class` attribute, else the `childclass` of its nearest body or
//! frame that has one, else `main`; attributes it does not set come from that class.
//!
//! The actuator kinds (`general`, `motor`, `position`, `velocity`, ...) share the attributes
//! of one default per class, as in MuJoCo: a `<motor ctrlrange>` default also reaches
//! `<position>` elements. Their gain, bias and dynamics parameters follow MuJoCo's own rules
//! (docs/mjcf.md, "Actuator defaults").

use super::actuator_defaults::{check_parameters, is_kept_with_parameters, ActuatorDefaults};
use super::canonical::error;
use super::xml::Element;
use super::SceneError;
use std::collections::HashMap;

/// The default slot an element kind reads from, `None` for elements without defaults.
pub fn slot(element: &str) -> Option<&'static str> {
    Some(match element {
        "joint" => "joint",
        "geom" => "geom",
        "site" => "site",
        "camera" => "camera",
        "light" => "light",
        "mesh" => "mesh",
        "material" => "material",
        "pair" => "pair",
        "fixed" | "spatial" | "tendon" => "tendon",
        "connect" | "weld" | "equality" => "equality",
        "general" | "motor" | "position" | "velocity" | "intvelocity" | "damper" | "cylinder"
        | "muscle" | "adhesion" | "dcmotor" => "actuator",
        _ => return None,
    })
}

/// Attributes of one class, per slot, with the parents' already folded in.
#[derive(Clone, Debug, Default)]
struct Class {
    slots: HashMap<&'static str, Vec<(String, String)>>,
    actuator: ActuatorDefaults,
}

/// Every default class of a model.
#[derive(Clone, Debug)]
pub struct Defaults {
    classes: HashMap<String, Class>,
}

impl Default for Defaults {
    fn default() -> Self {
        let mut classes = HashMap::new();
        classes.insert(MAIN.to_string(), Class::default());
        Defaults { classes }
    }
}

/// Name of the top-level class.
pub const MAIN: &str = "main";

impl Defaults {
    /// Reads a top-level `<default>` element (there may be several: later ones add to `main`).
    pub fn read(&mut self, el: &Element) -> Result<(), SceneError> {
        if let Some(c) = el.attr("class") {
            if c != MAIN {
                return Err(error(
                    el,
                    format!("the top-level <default> is the class 'main', not '{c}': nest <default class=\"{c}\"> inside it"),
                ));
            }
        }
        self.read_class(el, MAIN)
    }

    fn read_class(&mut self, el: &Element, name: &str) -> Result<(), SceneError> {
        for (k, _) in &el.attrs {
            if k != "class" {
                return Err(error(
                    el,
                    format!("attribute '{k}' is not a default attribute"),
                ));
            }
        }
        // As MuJoCo reads them: the class's own defaults first, then its nested classes
        // (which inherit all of them, wherever they are written).
        let (nested, own): (Vec<&Element>, Vec<&Element>) =
            el.children.iter().partition(|c| c.name == "default");
        for (i, child) in own.iter().enumerate() {
            if own[..i].iter().any(|c| c.name == child.name) {
                return Err(error(
                    child,
                    format!("a default class gives <{}> once (MuJoCo refuses a repeat too): merge the two", child.name),
                ));
            }
        }
        for child in own.into_iter().chain(nested) {
            if child.name == "default" {
                let sub = child
                    .attr("class")
                    .ok_or_else(|| error(child, "a nested <default> needs class=\"NAME\""))?
                    .to_string();
                if self.classes.contains_key(&sub) {
                    return Err(error(
                        child,
                        format!("default class '{sub}' is defined twice"),
                    ));
                }
                let parent = &self.classes[name];
                let inherited = Class {
                    slots: parent.slots.clone(),
                    actuator: parent.actuator.inherit(),
                };
                self.classes.insert(sub.clone(), inherited);
                self.read_class(child, &sub)?;
                continue;
            }
            let Some(slot) = slot(&child.name) else {
                return Err(error(
                    child,
                    format!("<{}> cannot be given defaults", child.name),
                ));
            };
            if !child.children.is_empty() {
                return Err(error(child, "a default cannot have child elements"));
            }
            let class = self.classes.get_mut(name).expect("class inserted before");
            if slot == "actuator" {
                class.actuator.read(child)?;
            }
            let attrs = class.slots.entry(slot).or_default();
            for (k, v) in &child.attrs {
                if slot == "actuator" && is_kept_with_parameters(&child.name, k) {
                    continue;
                }
                match attrs.iter_mut().find(|(key, _)| key == k) {
                    Some(entry) => entry.1 = v.clone(),
                    None => attrs.push((k.clone(), v.clone())),
                }
            }
            // MuJoCo's damper and adhesion defaults switch the control limit on for the whole
            // class (every kind), whatever was written.
            if matches!(child.name.as_str(), "damper" | "adhesion") {
                attrs.retain(|(k, _)| k != "ctrllimited");
                attrs.push(("ctrllimited".into(), "true".into()));
            }
        }
        Ok(())
    }

    /// Whether a class exists.
    pub fn has(&self, class: &str) -> bool {
        self.classes.contains_key(class)
    }

    /// Whether `class` (or an ancestor) gives actuators defaults.
    pub fn gives_actuators(&self, class: &str) -> bool {
        self.classes.get(class).is_some_and(|c| {
            c.slots.get("actuator").is_some_and(|a| !a.is_empty()) || !c.actuator.is_empty()
        })
    }

    /// Fills in the attributes `el` does not set from its class (its `class` attribute, else
    /// `inherited`), and drops `class`. Elements without defaults are left as they are.
    pub fn apply(&self, el: &mut Element, inherited: &str) -> Result<(), SceneError> {
        self.apply_from(el, inherited, slot(&el.name))
    }

    /// [`Defaults::apply`] for an element of `<equality>`: each kind there (`connect`, `weld`,
    /// `joint`, `tendon`) reads the class's `<equality>` defaults, never those of a `<joint>`
    /// or a `<tendon>` of the same name.
    pub fn apply_equality(&self, el: &mut Element) -> Result<(), SceneError> {
        self.apply_from(el, MAIN, Some("equality"))
    }

    fn apply_from(
        &self,
        el: &mut Element,
        inherited: &str,
        slot: Option<&'static str>,
    ) -> Result<(), SceneError> {
        let own = el.attr("class").map(str::to_string);
        let class = own.as_deref().unwrap_or(inherited);
        let Some(found) = self.classes.get(class) else {
            return Err(error(el, format!("no default class named '{class}'")));
        };
        el.attrs.retain(|(k, _)| k != "class");
        let Some(slot) = slot else {
            return Ok(());
        };
        let written_ctrlrange = el.attr("ctrlrange").is_some();
        if slot == "actuator" {
            check_parameters(el)?;
        }
        if let Some(attrs) = found.slots.get(slot) {
            for (k, v) in attrs {
                if el.attr(k).is_none() && !overridden_by(el, k) {
                    el.attrs.push((k.clone(), v.clone()));
                }
            }
        }
        if slot == "actuator" {
            found.actuator.resolve(el, written_ctrlrange)?;
        }
        Ok(())
    }
}

/// Whether a default attribute `key` is superseded by another way of giving the same thing
/// on the element (MuJoCo's alternative orientation and placement attributes).
fn overridden_by(el: &Element, key: &str) -> bool {
    const ORIENTATION: [&str; 5] = ["quat", "axisangle", "euler", "xyaxes", "zaxis"];
    if ORIENTATION.contains(&key) {
        return ORIENTATION.iter().any(|k| el.attr(k).is_some()) || el.attr("fromto").is_some();
    }
    if key == "pos" {
        return el.attr("fromto").is_some();
    }
    if key == "fromto" {
        return el.attr("pos").is_some() || ORIENTATION.iter().any(|k| el.attr(k).is_some());
    }
    false
}
