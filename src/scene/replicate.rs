//! `<replicate count="n" offset="x y z" euler="a b c" sep="s">`: its children, `n` times, as
//! MuJoCo's compiler expands them (docs/mjcf.md, the feature table).
//!
//! Copy `i` (from 0) is placed by one frame: its rotation is the replicate's `euler` angles
//! times `i` (the angles scaled, not the rotation composed: the two differ where the rotation is
//! not about one axis), and its position `p_i = Σ_{k<i} E(k euler) offset`, each offset turned
//! by the rotation of the copy before it (`E(a)` the rotation of the angles `a`). So an offset
//! along the axis of a rotation builds a helix and one across it a circle. Angles are in the
//! compiler's unit and sequence. Every name in copy `i` gets the suffix `sep` and `i` written
//! with as many digits as `count` has (`b00` to `b11` for 12 copies; nested replicates add their
//! suffixes innermost first: `c_03-1`). Measured against MuJoCo's compiler
//! (tests/python/test_mjcf_compiler.py).
//!
//! An element of another section that names an element inside a replicate (an actuator on a
//! replicated joint, a tendon through replicated sites, an actuator on such a tendon) is
//! copied with each replica, as MuJoCo's compiler copies it: its names suffixed, its references
//! to replicated elements suffixed, the others left as they are. Sections of one kind are one
//! list, as in MuJoCo: the elements that name nothing replicated keep their places, and the
//! copies go at the end of the kind's last section, replica by replica, each in the file's
//! order. Kinds are taken tendons first, then equalities, contact pairs, actuators and sensors,
//! so an element that names a copied one is copied in turn. A reference is matched by name and
//! kind (`joint="x"` names the joint `x`, not a body `x`; `objname` names any kind, as its kind
//! is given apart). `childclass` on a replicate applies to every copy, as on a frame.

use super::canonical::{error, numbers, pose, Angles};
use super::xml::Element;
use super::SceneError;
use nalgebra::Vector3;
use std::collections::BTreeSet;

/// The sections whose elements can name bodies, joints, geoms, sites or tendons, in the order
/// their references are resolved (an actuator can name a tendon, a tendon no actuator).
pub(super) const REFERRING: [&str; 5] = ["tendon", "equality", "contact", "actuator", "sensor"];

/// The kind of element an attribute names (MuJoCo's references, in every section above), or
/// `Some("")` for one that can name any kind (its kind is given by another attribute); `None`
/// for an attribute that names nothing.
pub(super) fn kind_of_reference(attr: &str) -> Option<&'static str> {
    Some(match attr {
        "joint" | "joint1" | "joint2" | "jointinparent" => "joint",
        "tendon" | "tendon1" | "tendon2" => "tendon",
        "site" | "site1" | "site2" | "sidesite" | "cranksite" | "slidersite" | "refsite" => "site",
        "geom" | "geom1" | "geom2" => "geom",
        "body" | "body1" | "body2" => "body",
        "actuator" => "actuator",
        "objname" | "refname" | "target" => "",
        _ => return None,
    })
}

/// The kind an element's `name` belongs to, in the world's tree or in section `section`.
fn kind_of_element<'a>(element: &'a str, section: &'a str) -> &'a str {
    match (section, element) {
        (_, "freejoint") => "joint",
        ("tendon", _) => "tendon",
        ("worldbody", e) => e,
        (s, _) => s,
    }
}

/// Replicated names by kind.
pub(super) type Named = BTreeSet<(String, String)>;

/// Whether `named` holds `value` for the attribute `attr` (by its kind).
pub(super) fn names(named: &Named, attr: &str, value: &str) -> bool {
    match kind_of_reference(attr) {
        None => false,
        Some("") => named.iter().any(|(_, n)| n == value),
        Some(kind) => named.contains(&(kind.to_string(), value.to_string())),
    }
}

/// Replaces every `<replicate>` under `<worldbody>` by its copies, innermost first, and copies
/// the elements of the other sections that name what it replicates (see the module).
pub fn expand(root: &mut Element, angles: &Angles) -> Result<(), SceneError> {
    // A file (with its includes) can have several `<worldbody>` sections, as MuJoCo allows.
    let worlds: Vec<usize> = (0..root.children.len())
        .filter(|&w| root.children[w].name == "worldbody")
        .collect();
    for w in worlds {
        // The world's tree apart, so that each replicate can reach the other sections.
        let mut world = std::mem::take(&mut root.children[w].children);
        let mut kinds: Vec<Vec<&mut Element>> = REFERRING.iter().map(|_| Vec::new()).collect();
        for s in root.children.iter_mut() {
            if let Some(k) = REFERRING.iter().position(|r| *r == s.name) {
                kinds[k].push(s);
            }
        }
        let result = expand_all(&mut world, angles, &mut kinds);
        root.children[w].children = world;
        result?;
    }
    Ok(())
}

/// Expands the replicates among `children` and below, innermost first.
fn expand_all(
    children: &mut Vec<Element>,
    angles: &Angles,
    kinds: &mut [Vec<&mut Element>],
) -> Result<(), SceneError> {
    let mut out = Vec::with_capacity(children.len());
    for mut child in std::mem::take(children) {
        expand_all(&mut child.children, angles, kinds)?;
        if child.name == "replicate" {
            out.extend(copies(child, angles, kinds)?);
        } else {
            out.push(child);
        }
    }
    *children = out;
    Ok(())
}

/// The copies of one replicate whose own replicates are already expanded.
fn copies(
    rep: Element,
    angles: &Angles,
    kinds: &mut [Vec<&mut Element>],
) -> Result<Vec<Element>, SceneError> {
    if let Some((k, _)) = rep.attrs.iter().find(|(k, _)| {
        !matches!(
            k.as_str(),
            "count" | "offset" | "euler" | "sep" | "childclass"
        )
    }) {
        return Err(error(
            &rep,
            format!("attribute '{k}' is not a replicate attribute (count, offset, euler, sep, childclass)"),
        ));
    }
    let count: usize = match rep.attr("count").map(|c| c.trim().parse()) {
        Some(Ok(n)) => n,
        Some(Err(_)) => {
            return Err(error(
                &rep,
                format!(
                    "count=\"{}\": expected a whole number of copies (0 or more)",
                    rep.attr("count").unwrap_or_default()
                ),
            ))
        }
        None => return Err(error(&rep, "count is required: how many copies")),
    };
    let sep = rep.attr("sep").unwrap_or_default().to_string();
    let digits = count.to_string().len();
    let mut named = Named::new();
    for c in &rep.children {
        collect_names(c, "worldbody", &mut named);
    }
    let suffixes: Vec<String> = (0..count).map(|i| format!("{sep}{i:0digits$}")).collect();
    for sections in kinds.iter_mut() {
        copy_referring(sections, &mut named, &suffixes);
    }
    let offset = three(&rep, "offset")?;
    let euler = three(&rep, "euler")?;
    // The frame of copy `i`: its angles `i euler`, read as any frame's are.
    // (With the replicate's childclass. Stray text was listed before the expansion.)
    let frame = |i: usize, pos: &Vector3<f64>| Element {
        name: "frame".into(),
        attrs: [
            ("pos".to_string(), format!("{} {} {}", pos.x, pos.y, pos.z)),
            (
                "euler".to_string(),
                format!(
                    "{} {} {}",
                    euler.x * i as f64,
                    euler.y * i as f64,
                    euler.z * i as f64
                ),
            ),
        ]
        .into_iter()
        .chain(
            rep.attr("childclass")
                .map(|c| ("childclass".to_string(), c.to_string())),
        )
        .collect(),
        children: Vec::new(),
        line: rep.line,
        file: rep.file.clone(),
        text: Vec::new(),
    };
    let mut out = Vec::new();
    let mut pos = Vector3::zeros();
    for (i, suffix) in suffixes.iter().enumerate() {
        let mut copy = frame(i, &pos);
        copy.children = rep.children.clone();
        for k in &mut copy.children {
            add_suffix(k, suffix, &Named::new());
        }
        // The next copy's position: this copy's offset, turned by this copy's rotation.
        pos += pose(&copy, angles)?.rotation * offset;
        out.push(copy);
    }
    Ok(out)
}

/// Three numbers of attribute `key` of a replicate (zeros when absent).
fn three(rep: &Element, key: &str) -> Result<Vector3<f64>, SceneError> {
    Ok(numbers(rep, key, 3)?.map_or_else(Vector3::zeros, |v| Vector3::new(v[0], v[1], v[2])))
}

/// Every `name` in `el`'s subtree (`el` read in `section`), by kind, as written.
pub(super) fn collect_names(el: &Element, section: &str, out: &mut Named) {
    if let Some(n) = el.attr("name") {
        out.insert((
            kind_of_element(&el.name, section).to_string(),
            n.to_string(),
        ));
    }
    for c in &el.children {
        collect_names(c, section, out);
    }
}

/// Appends `suffix` to every `name` in `el`'s subtree, and to every reference to one of
/// `named`.
fn add_suffix(el: &mut Element, suffix: &str, named: &Named) {
    rename(el, named, &|v| format!("{v}{suffix}"));
    suffix_attaches(el, suffix);
}

/// Appends `suffix` to the suffix each `<attach>` in `el`'s subtree gives the names it brings
/// ([`super::attach::SUFFIX`]; attaches are expanded after replicates, copy by copy).
fn suffix_attaches(el: &mut Element, suffix: &str) {
    if el.name == "attach" {
        match el
            .attrs
            .iter_mut()
            .find(|(k, _)| k == super::attach::SUFFIX)
        {
            Some(slot) => slot.1.push_str(suffix),
            None => el
                .attrs
                .push((super::attach::SUFFIX.to_string(), suffix.to_string())),
        }
    }
    for c in el.children.iter_mut() {
        suffix_attaches(c, suffix);
    }
}

/// Renames by `new` every `name` in `el`'s subtree (an empty name stays empty: the object
/// stays unnamed, as in MuJoCo), and every reference to one of `named`.
pub(super) fn rename(el: &mut Element, named: &Named, new: &dyn Fn(&str) -> String) {
    for (k, v) in el.attrs.iter_mut() {
        if (k == "name" && !v.is_empty()) || names(named, k, v) {
            *v = new(v);
        }
    }
    for c in el.children.iter_mut() {
        rename(c, named, new);
    }
}

/// Whether `el` or an element inside it (a tendon's path) names one of `named`.
pub(super) fn refers(el: &Element, named: &Named) -> bool {
    el.attrs.iter().any(|(k, v)| names(named, k, v)) || el.children.iter().any(|c| refers(c, named))
}

/// Copies each element of the sections of one kind (one list, in file order) that names one
/// of `named` once per suffix: the others keep their places, the copies go at the end of the
/// last section, replica by replica; the copied elements' names join `named`, so that the
/// kinds after this one copy what names them.
fn copy_referring(sections: &mut [&mut Element], named: &mut Named, suffixes: &[String]) {
    let mut referring = Vec::new();
    for section in sections.iter_mut() {
        let (moved, kept): (Vec<Element>, Vec<Element>) = std::mem::take(&mut section.children)
            .into_iter()
            .partition(|el| refers(el, named));
        section.children = kept;
        referring.extend(moved.into_iter().map(|el| (section.name.clone(), el)));
    }
    let Some(last) = sections.last_mut() else {
        return;
    };
    for (section, el) in &referring {
        collect_names(el, section, named);
    }
    for suffix in suffixes {
        for (_, el) in &referring {
            let mut copy = el.clone();
            add_suffix(&mut copy, suffix, named);
            last.children.push(copy);
        }
    }
}
