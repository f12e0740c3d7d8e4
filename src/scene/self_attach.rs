//! `<attach body="B">` or `frame="F"` without `model`: MuJoCo's self-attachment, a copy of a
//! body or frame of this same file (see [`super::attach`]).

use super::attach::{bring_referring, holds_attach, Graft};
use super::replicate::{collect_names, rename, Named};
use super::xml::Element;
use super::{element_error, Builder, SceneError};

/// Whether an `<attach>` without `model` (a self-attachment) is anywhere under `el`.
pub(super) fn attaches_itself(el: &Element) -> bool {
    el.children
        .iter()
        .any(|c| (c.name == "attach" && c.attr("model").is_none()) || attaches_itself(c))
}

/// What a self-attachment brings (`<attach body="B">` or `frame="F"` without `model`, MuJoCo's
/// attachment within the same model): a copy of the body or frame as this file writes it,
/// `own` the file before any attach is expanded, every name in it renamed by `prefixed`, and
/// the other sections' elements that name only what is copied. The copy keeps the default
/// class it had where it was written (the innermost `childclass` above it). It may not itself
/// hold an `<attach>`.
pub(super) fn graft_self(
    att: &Element,
    b: &mut Builder,
    own: &Element,
    prefixed: &dyn Fn(&str) -> String,
) -> Result<Graft, SceneError> {
    let (kind, name) = match (att.attr("body"), att.attr("frame")) {
        (Some(n), None) => ("body", n),
        (None, Some(n)) => ("frame", n),
        _ => return Err(element_error(att, "attaching a part of this same model (no model=\"...\") needs one of body=\"...\" or frame=\"...\", as MuJoCo does")),
    };
    let found = own
        .children
        .iter()
        .filter(|s| s.name == "worldbody")
        .find_map(|w| find_in(w, kind, name, None))
        .ok_or_else(|| element_error(att, format!("this model has no {kind} named '{name}'")))?;
    let (found, class) = found;
    if holds_attach(found) {
        return Err(element_error(att, format!("the {kind} '{name}' holds an <attach> itself: SCM attaches a part of this model only where it attaches nothing")));
    }
    let mut copy = found.clone();
    if let Some(class) = class.filter(|_| copy.attr("childclass").is_none()) {
        copy.attrs
            .push(("childclass".to_string(), class.to_string()));
    }
    let mut named = Named::new();
    collect_names(&copy, "worldbody", &mut named);
    rename(&mut copy, &named, prefixed);
    let other = bring_referring(att, b, own, "this model", &mut named, prefixed, false);
    Ok((vec![copy], other))
}

/// The `kind` element (`body` or `frame`) named `name` at or below `el`, with the innermost
/// `childclass` above it (`class` the one in effect at `el`).
fn find_in<'a>(
    el: &'a Element,
    kind: &str,
    name: &str,
    class: Option<&'a str>,
) -> Option<(&'a Element, Option<&'a str>)> {
    el.children
        .iter()
        .filter(|c| matches!(c.name.as_str(), "body" | "frame"))
        .find_map(|c| {
            if c.name == kind && c.attr("name") == Some(name) {
                return Some((c, class));
            }
            find_in(c, kind, name, c.attr("childclass").or(class))
        })
}
