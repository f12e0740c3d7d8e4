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
//! to replicated elements suffixed, the others left as they are. In each section the elements
//! that name nothing replicated come first, then the copies replica by replica, each in the
//! file's order. Sections are taken tendons first, then equalities, contact pairs, actuators and
//! sensors, so an element that names a copied one is copied in turn. A reference is matched by
//! name alone, whatever the kind it names (MuJoCo keeps a namespace per kind): a file that names
//! a joint outside a replicate and a site inside it alike would be misread.

use super::canonical::{error, pose, Angles};
use super::xml::Element;
use super::SceneError;
use nalgebra::Vector3;
use std::collections::BTreeSet;

/// The sections whose elements can name bodies, joints, geoms, sites or tendons, in the order
/// their references are resolved (an actuator can name a tendon, a tendon no actuator).
const REFERRING: [&str; 5] = ["tendon", "equality", "contact", "actuator", "sensor"];

/// The attributes that name another element (MuJoCo's references, in every section above).
const REFERENCES: [&str; 24] = [
    "joint",
    "jointinparent",
    "tendon",
    "site",
    "geom",
    "body",
    "body1",
    "body2",
    "geom1",
    "geom2",
    "site1",
    "site2",
    "joint1",
    "joint2",
    "tendon1",
    "tendon2",
    "sidesite",
    "cranksite",
    "slidersite",
    "refsite",
    "objname",
    "refname",
    "actuator",
    "target",
];

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
        let mut sections: Vec<&mut Element> = root
            .children
            .iter_mut()
            .filter(|s| REFERRING.contains(&s.name.as_str()))
            .collect();
        sections.sort_by_key(|s| REFERRING.iter().position(|r| *r == s.name));
        let result = expand_all(&mut world, angles, &mut sections);
        root.children[w].children = world;
        result?;
    }
    Ok(())
}

/// Expands the replicates among `children` and below, innermost first.
fn expand_all(
    children: &mut Vec<Element>,
    angles: &Angles,
    sections: &mut [&mut Element],
) -> Result<(), SceneError> {
    let mut out = Vec::with_capacity(children.len());
    for mut child in std::mem::take(children) {
        expand_all(&mut child.children, angles, sections)?;
        if child.name == "replicate" {
            out.extend(copies(child, angles, sections)?);
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
    sections: &mut [&mut Element],
) -> Result<Vec<Element>, SceneError> {
    if let Some((k, _)) = rep
        .attrs
        .iter()
        .find(|(k, _)| !matches!(k.as_str(), "count" | "offset" | "euler" | "sep"))
    {
        return Err(error(
            &rep,
            format!("attribute '{k}' is not a replicate attribute (count, offset, euler, sep)"),
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
    let mut names = BTreeSet::new();
    for c in &rep.children {
        collect_names(c, &mut names);
    }
    let suffixes: Vec<String> = (0..count).map(|i| format!("{sep}{i:0digits$}")).collect();
    for section in sections.iter_mut() {
        copy_referring(section, &mut names, &suffixes);
    }
    let offset = three(&rep, "offset")?;
    let euler = three(&rep, "euler")?;
    // The frame of copy `i`: its angles `i euler`, read as any frame's are.
    let frame = |i: usize, pos: &Vector3<f64>| Element {
        name: "frame".into(),
        attrs: vec![
            ("pos".into(), format!("{} {} {}", pos.x, pos.y, pos.z)),
            (
                "euler".into(),
                format!(
                    "{} {} {}",
                    euler.x * i as f64,
                    euler.y * i as f64,
                    euler.z * i as f64
                ),
            ),
        ],
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
            add_suffix(k, suffix, &BTreeSet::new());
        }
        // The next copy's position: this copy's offset, turned by this copy's rotation.
        pos += pose(&copy, angles)?.rotation * offset;
        out.push(copy);
    }
    Ok(out)
}

/// Three numbers of attribute `key` of a replicate (zeros when absent).
fn three(rep: &Element, key: &str) -> Result<Vector3<f64>, SceneError> {
    let Some(text) = rep.attr(key) else {
        return Ok(Vector3::zeros());
    };
    let v: Vec<f64> = text
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()
        .map_err(|_| error(rep, format!("{key}=\"{text}\": expected 3 numbers")))?;
    match v[..] {
        [x, y, z] if v.iter().all(|x| x.is_finite()) => Ok(Vector3::new(x, y, z)),
        _ => Err(error(
            rep,
            format!("{key}=\"{text}\": expected 3 finite numbers"),
        )),
    }
}

/// Every `name` in `el`'s subtree, as written.
fn collect_names(el: &Element, out: &mut BTreeSet<String>) {
    if let Some(n) = el.attr("name") {
        out.insert(n.to_string());
    }
    for c in &el.children {
        collect_names(c, out);
    }
}

/// Appends `suffix` to every `name` in `el`'s subtree, and to every reference to one of
/// `replicated`.
fn add_suffix(el: &mut Element, suffix: &str, replicated: &BTreeSet<String>) {
    for (k, v) in el.attrs.iter_mut() {
        if k == "name" || REFERENCES.contains(&k.as_str()) && replicated.contains(v.as_str()) {
            v.push_str(suffix);
        }
    }
    for c in el.children.iter_mut() {
        add_suffix(c, suffix, replicated);
    }
}

/// Whether `el` or an element inside it (a tendon's path) names one of `replicated`.
fn refers(el: &Element, replicated: &BTreeSet<String>) -> bool {
    el.attrs
        .iter()
        .any(|(k, v)| REFERENCES.contains(&k.as_str()) && replicated.contains(v.as_str()))
        || el.children.iter().any(|c| refers(c, replicated))
}

/// Copies each element of `section` that names one of `replicated` once per suffix (the
/// elements that name none first, then the copies replica by replica), and adds the copied
/// elements' names to `replicated`, so that the sections after this one copy what names them.
fn copy_referring(section: &mut Element, replicated: &mut BTreeSet<String>, suffixes: &[String]) {
    let (referring, mut kept): (Vec<Element>, Vec<Element>) = std::mem::take(&mut section.children)
        .into_iter()
        .partition(|el| refers(el, replicated));
    for el in &referring {
        collect_names(el, replicated);
    }
    for suffix in suffixes {
        for el in &referring {
            let mut copy = el.clone();
            add_suffix(&mut copy, suffix, replicated);
            kept.push(copy);
        }
    }
    section.children = kept;
}
