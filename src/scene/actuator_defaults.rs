//! Actuator defaults as MuJoCo 4 resolves them (docs/mjcf.md, "Actuator defaults").
//!
//! The actuator shortcuts are not attribute bags: each one sets the actuator's gain, bias and
//! dynamics parameters from its own few attributes (`<position kp kv>` gives a fixed gain `kp`
//! and an affine bias `[0, -kp, -kv]`), and a parameter it is not given comes from the
//! parameters it starts from. So a default class keeps two things apart:
//!
//! - the attributes every actuator shares (ranges, gear, limits): inherited attribute by
//!   attribute, whichever kind of default wrote them (kept by [`super::defaults`]);
//! - the parameters, kept here: what the last actuator default a class writes leaves (a
//!   `<general>` writes on the parameters current where it stands), class by class up to
//!   `main`.
//!
//! An element (or a default) of a shortcut kind starts from the nearest class, its own first,
//! whose last actuator default is of its kind, or is a `<general>` whose gain it can read (fixed
//! for a position or a velocity, affine for a damper); with none, from MuJoCo's defaults. A
//! `<general>` element starts from the parameters current in its class. These rules were read
//! off MuJoCo 4.0's compiled models; the differential test
//! `test_actuator_defaults_compile_as_mujoco_compiles_them` holds them to it.

use super::canonical::error;
use super::read::parse_floats;
use super::xml::Element;
use super::SceneError;

/// Attributes every actuator kind shares: they are inherited one by one, whichever kind of
/// default wrote them.
const COMMON: &[&str] = &[
    "name",
    "class",
    "group",
    "ctrllimited",
    "forcelimited",
    "actlimited",
    "ctrlrange",
    "forcerange",
    "actrange",
    "lengthrange",
    "gear",
    "cranklength",
    "user",
    "joint",
    "jointinparent",
    "tendon",
    "cranksite",
    "site",
    "refsite",
    "body",
    "slidersite",
    "actdim",
    "actearly",
];

/// The parameter attributes of the kinds SCM reads; a parameter attribute written on a kind
/// that does not have it is refused, as MuJoCo's schema refuses it.
const PARAMETERS: &[(&str, &[&str])] = &[
    (
        "general",
        &[
            "gaintype",
            "gainprm",
            "biastype",
            "biasprm",
            "dyntype",
            "dynprm",
            "inheritrange",
        ],
    ),
    ("motor", &[]),
    (
        "position",
        &["kp", "kv", "dampratio", "timeconst", "inheritrange"],
    ),
    ("velocity", &["kv"]),
    ("damper", &["kv"]),
    (
        "intvelocity",
        &["kp", "kv", "dampratio", "timeconst", "inheritrange"],
    ),
    ("cylinder", &["timeconst", "bias", "area", "diameter"]),
    ("adhesion", &["gain"]),
];

/// Every parameter attribute of [`PARAMETERS`].
fn is_parameter(key: &str) -> bool {
    PARAMETERS.iter().any(|(_, keys)| keys.contains(&key))
}

/// Whether a default of kind `kind` keeps attribute `key` with its parameters (rather than
/// sharing it with every actuator of the class).
pub fn is_kept_with_parameters(kind: &str, key: &str) -> bool {
    match PARAMETERS.iter().find(|(k, _)| *k == kind) {
        Some(_) => is_parameter(key),
        // The kinds SCM does not simulate keep whatever is not shared: those attributes only
        // reach elements of their own kind, which are refused.
        None => !COMMON.contains(&key),
    }
}

/// MuJoCo's length of the gain, bias and dynamics parameter vectors.
const N: usize = 10;

/// An actuator's gain, bias and dynamics, as MuJoCo's `<general>` writes them.
#[derive(Clone, Debug, PartialEq)]
struct Parameters {
    gaintype: String,
    gainprm: [f64; N],
    biastype: String,
    biasprm: [f64; N],
    dyntype: String,
    dynprm: [f64; N],
    /// A position's control range as a fraction of its target's range (0: none).
    inheritrange: f64,
}

impl Default for Parameters {
    /// MuJoCo's defaults: a unit fixed gain, no bias, no dynamics.
    fn default() -> Self {
        let mut unit = [0.0; N];
        unit[0] = 1.0;
        Parameters {
            gaintype: "fixed".into(),
            gainprm: unit,
            biastype: "none".into(),
            biasprm: [0.0; N],
            dyntype: "none".into(),
            dynprm: unit,
            inheritrange: 0.0,
        }
    }
}

/// Parameters as a default left them: known, or set by a kind SCM does not simulate.
#[derive(Clone, Debug)]
enum State {
    Known(Box<Parameters>),
    Other(String),
}

/// The actuator parameters of one default class: for it and each of its ancestors (nearest
/// first), the kind and parameters of the last actuator default that class wrote itself.
#[derive(Clone, Debug)]
pub struct ActuatorDefaults {
    chain: Vec<Option<(String, State)>>,
}

impl ActuatorDefaults {
    /// Whether the class or an ancestor wrote an actuator default.
    pub fn is_empty(&self) -> bool {
        self.chain.iter().all(Option::is_none)
    }
}

impl Default for ActuatorDefaults {
    fn default() -> Self {
        ActuatorDefaults { chain: vec![None] }
    }
}

/// The value of a one-number attribute, if written.
fn number(el: &Element, key: &str) -> Result<Option<f64>, SceneError> {
    match el.attr(key) {
        None => Ok(None),
        Some(s) => match s.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Some(v)),
            _ => Err(error(
                el,
                format!("{key}=\"{s}\": expected one finite number"),
            )),
        },
    }
}

/// The leading entries of a parameter vector written on `el` (MuJoCo overwrites those and
/// keeps the rest of the vector it starts from).
fn vector(el: &Element, key: &str) -> Result<Option<Vec<f64>>, SceneError> {
    let Some(s) = el.attr(key) else {
        return Ok(None);
    };
    let values: Option<Vec<f64>> = s
        .split_whitespace()
        .map(|t| t.parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect();
    match values {
        Some(v) if v.len() <= N => Ok(Some(v)),
        _ => Err(error(
            el,
            format!("{key}=\"{s}\": expected at most {N} finite numbers"),
        )),
    }
}

/// Refuses a parameter attribute that `el`'s kind does not have (and a damper's
/// `ctrllimited`: MuJoCo's schema has none, a damper's control is always limited). For an
/// element, called on what it writes itself, before its class's attributes are filled in.
pub fn check_parameters(el: &Element) -> Result<(), SceneError> {
    if el.name == "damper" && el.attr("ctrllimited").is_some() {
        return Err(error(
            el,
            "'ctrllimited' is not an attribute of <damper> (MuJoCo refuses it too): a damper's control is always limited by its ctrlrange",
        ));
    }
    if el.name == "adhesion" {
        // MuJoCo's schema of an adhesion: no gear, no dynamics, its control always limited.
        const ADHESION: &[&str] = &[
            "name",
            "class",
            "group",
            "nsample",
            "interp",
            "delay",
            "ctrlrange",
            "user",
            "forcelimited",
            "forcerange",
            "body",
            "gain",
        ];
        if let Some((k, _)) = el
            .attrs
            .iter()
            .find(|(k, _)| !ADHESION.contains(&k.as_str()))
        {
            return Err(error(
                el,
                format!(
                    "'{k}' is not an attribute of <adhesion> (MuJoCo refuses it too): it has {}",
                    ADHESION.join(", ")
                ),
            ));
        }
    }
    let Some((_, own)) = PARAMETERS.iter().find(|(k, _)| *k == el.name) else {
        return Ok(());
    };
    match el
        .attrs
        .iter()
        .find(|(k, _)| is_parameter(k) && !own.contains(&k.as_str()))
    {
        Some((k, _)) => Err(error(
            el,
            format!(
                "'{k}' is not an attribute of <{}> (MuJoCo refuses it too){}",
                el.name,
                if el.name == "general" {
                    ": write gainprm and biasprm (with gaintype, biastype)"
                } else {
                    ""
                }
            ),
        )),
        None => Ok(()),
    }
}

/// `start` with what a `<general>` writes on it.
fn general(mut p: Parameters, el: &Element) -> Result<Parameters, SceneError> {
    for (key, slot) in [("gaintype", &mut p.gaintype), ("biastype", &mut p.biastype)] {
        if let Some(v) = el.attr(key) {
            *slot = v.to_string();
        }
    }
    if let Some(v) = el.attr("dyntype") {
        p.dyntype = v.to_string();
    }
    for (key, slot) in [
        ("gainprm", &mut p.gainprm),
        ("biasprm", &mut p.biasprm),
        ("dynprm", &mut p.dynprm),
    ] {
        if let Some(v) = vector(el, key)? {
            slot[..v.len()].copy_from_slice(&v);
        }
    }
    if let Some(r) = number(el, "inheritrange")? {
        p.inheritrange = r;
    }
    Ok(p)
}

/// The parameters a shortcut of kind `el.name` sets from its attributes, starting from
/// `start` (one whose gain it reads, see [`ActuatorDefaults::start`]).
fn shortcut(start: &Parameters, el: &Element) -> Result<Parameters, SceneError> {
    let mut p = Parameters::default();
    match el.name.as_str() {
        "motor" => {}
        "position" | "intvelocity" => {
            let kp = number(el, "kp")?.unwrap_or(start.gainprm[0]);
            let damping =
                match (number(el, "kv")?, number(el, "dampratio")?) {
                    (Some(_), Some(_)) => return Err(error(
                        el,
                        "kv and dampratio cannot both be given (MuJoCo refuses it too): keep one",
                    )),
                    (Some(kv), None) if kv < 0.0 => {
                        return Err(error(el, format!("kv=\"{kv}\" must not be negative")))
                    }
                    (Some(kv), None) => -kv,
                    (None, Some(z)) if z < 0.0 => {
                        return Err(error(el, format!("dampratio=\"{z}\" must not be negative")))
                    }
                    // MuJoCo keeps a damping ratio as a positive biasprm[2] until it compiles.
                    (None, Some(z)) => z,
                    (None, None) => start.biasprm[2],
                };
            match number(el, "timeconst")? {
                Some(t) if t < 0.0 => {
                    return Err(error(el, format!("timeconst=\"{t}\" must not be negative")))
                }
                Some(t) if t > 0.0 => {
                    p.dyntype = "filterexact".into();
                    p.dynprm[0] = t;
                }
                Some(_) => {}
                // MuJoCo 4 keeps a position's first-order filter (its own timeconst's, or a
                // <general>'s filterexact) and drops other dynamics.
                None if start.dyntype == "filterexact" => {
                    p.dyntype = start.dyntype.clone();
                    p.dynprm = start.dynprm;
                }
                None => {}
            }
            p.gainprm[0] = kp;
            p.biastype = "affine".into();
            p.biasprm[1] = -kp;
            p.biasprm[2] = damping;
            p.inheritrange = number(el, "inheritrange")?.unwrap_or(start.inheritrange);
            // MuJoCo's integrated-velocity servo: a position servo on the activation, which
            // integrates the control (its dynamics whatever timeconst says).
            if el.name == "intvelocity" {
                p.dyntype = "integrator".into();
            }
        }
        // MuJoCo's pneumatic or hydraulic cylinder: a filtered control times the piston's area
        // (from its diameter where one is given), with an affine bias.
        "cylinder" => {
            let area = match number(el, "diameter")? {
                Some(d) if d >= 0.0 => std::f64::consts::PI / 4.0 * d * d,
                _ => number(el, "area")?.unwrap_or(start.gainprm[0]),
            };
            let mut bias = [start.biasprm[0], start.biasprm[1], start.biasprm[2]];
            if let Some(given) = el.attr("bias") {
                match parse_floats(given) {
                    Some(v) if v.len() == 3 => bias.copy_from_slice(&v),
                    _ => {
                        return Err(error(
                            el,
                            "bias: expected 3 finite numbers (MuJoCo refuses fewer)",
                        ))
                    }
                }
            }
            p.gainprm[0] = area;
            p.biastype = "affine".into();
            p.biasprm[..3].copy_from_slice(&bias);
            p.dyntype = "filter".into();
            p.dynprm[0] = number(el, "timeconst")?.unwrap_or(start.dynprm[0]);
        }
        "velocity" => {
            let kv = number(el, "kv")?.unwrap_or(start.gainprm[0]);
            p.gainprm[0] = kv;
            p.biastype = "affine".into();
            p.biasprm[2] = -kv;
        }
        "damper" => {
            let kv = match start.gaintype.as_str() {
                "affine" => number(el, "kv")?.unwrap_or(-start.gainprm[2]),
                _ => number(el, "kv")?.unwrap_or(0.0),
            };
            if kv < 0.0 {
                return Err(error(
                    el,
                    format!(
                        "a damper's kv (here {kv}) must not be negative (MuJoCo refuses it too)"
                    ),
                ));
            }
            p.gaintype = "affine".into();
            p.gainprm = [0.0; N];
            p.gainprm[2] = -kv;
        }
        "adhesion" => {
            p.gainprm[0] = number(el, "gain")?.unwrap_or(start.gainprm[0]);
        }
        other => unreachable!("shortcut() is called for SCM's shortcuts, not <{other}>"),
    }
    Ok(p)
}

/// Shortest text that reads back as the same number.
fn text(v: f64) -> String {
    format!("{v}")
}

/// A parameter vector as text, without the trailing zeros MuJoCo fills in.
fn vector_text(v: &[f64; N]) -> String {
    let n = v.iter().rposition(|&x| x != 0.0).map_or(1, |i| i + 1);
    v[..n]
        .iter()
        .map(|&x| text(x))
        .collect::<Vec<_>>()
        .join(" ")
}

impl ActuatorDefaults {
    /// The parameters of a child class, which has written nothing yet.
    pub fn inherit(&self) -> Self {
        let mut chain = vec![None];
        chain.extend(self.chain.iter().cloned());
        ActuatorDefaults { chain }
    }

    /// The parameters current in the class: those of the nearest actuator default.
    fn current(&self) -> State {
        self.chain
            .iter()
            .flatten()
            .map(|(_, state)| state.clone())
            .next()
            .unwrap_or(State::Known(Box::default()))
    }

    /// Where a shortcut of kind `kind` starts (`el` is it, for a refusal): the nearest class's
    /// parameters that its kind wrote or that a `<general>` wrote with a gain it reads, else
    /// MuJoCo's defaults.
    fn start(&self, kind: &str, el: &Element) -> Result<Parameters, SceneError> {
        for (written_by, state) in self.chain.iter().flatten() {
            let reads = |p: &Parameters| match kind {
                "damper" => p.gaintype == "affine",
                _ => p.gaintype == "fixed",
            };
            match state {
                State::Known(p) if written_by == kind => return Ok((**p).clone()),
                State::Known(p) if written_by == "general" && reads(p) => return Ok((**p).clone()),
                State::Other(other) if written_by == "general" && kind != "motor" => {
                    return Err(inherits_other(el, other))
                }
                _ => {}
            }
        }
        Ok(Parameters::default())
    }

    /// Reads an actuator default (a child of `<default>`) into the class.
    pub fn read(&mut self, el: &Element) -> Result<(), SceneError> {
        check_parameters(el)?;
        let kind = el.name.as_str();
        let state = if kind == "general" {
            match self.current() {
                State::Known(p) => State::Known(Box::new(general(*p, el)?)),
                other => other,
            }
        } else if PARAMETERS.iter().any(|(k, _)| *k == kind) {
            if kind == "damper" {
                damper_range(el)?;
            }
            let start = self.start(kind, el)?;
            State::Known(Box::new(shortcut(&start, el)?))
        } else {
            State::Other(kind.to_string())
        };
        self.chain[0] = Some((kind.to_string(), state));
        Ok(())
    }

    /// Writes on an actuator element (checked by [`check_parameters`], then given its class's
    /// shared attributes) the parameters it ends up with, in the attributes SCM's
    /// loader reads: `kp` with `kv` or `dampratio` (and `timeconst` if the position has
    /// dynamics) for a position, `kv` for a velocity or a damper, gain, bias and dynamics for
    /// a `<general>`. Elements of kinds SCM does not simulate are left as they are.
    pub fn resolve(&self, el: &mut Element, written_ctrlrange: bool) -> Result<(), SceneError> {
        let kind = el.name.clone();
        let resolved = match kind.as_str() {
            "general" => match self.current() {
                State::Known(p) => general(*p, el)?,
                State::Other(other) => return Err(inherits_other(el, &other)),
            },
            "motor" | "position" | "velocity" | "damper" | "intvelocity" | "cylinder"
            | "adhesion" => {
                let start = self.start(&kind, el)?;
                shortcut(&start, el)?
            }
            _ => return Ok(()),
        };
        // An integrated-velocity servo and a cylinder are read as the <general> they stand
        // for (its dynamics, gain and bias); MuJoCo's inheritrange on the former sets its
        // activation's range, which SCM does not derive.
        let kind = match kind.as_str() {
            "intvelocity" | "cylinder" => {
                if resolved.inheritrange > 0.0 {
                    return Err(error(el, "inheritrange on an <intvelocity> is not supported by SCM: give its actrange (and actlimited) instead"));
                }
                el.name = "general".into();
                "general".to_string()
            }
            _ => kind,
        };
        // A position's inheritrange: refused with a ctrlrange written beside it, passed over
        // for one the element writes itself, and over the class's ctrlrange otherwise.
        let inherits = kind == "position" && resolved.inheritrange > 0.0 && !written_ctrlrange;
        if kind == "position" && el.attr("inheritrange").is_some() && written_ctrlrange {
            return Err(error(
                el,
                "ctrlrange and inheritrange cannot both be given (MuJoCo refuses it too): keep one",
            ));
        }
        el.attrs.retain(|(k, _)| !is_parameter(k));
        if inherits {
            el.attrs
                .retain(|(k, _)| k != "ctrlrange" && k != "ctrllimited");
            el.attrs
                .push(("inheritrange".into(), text(resolved.inheritrange)));
        }
        let mut put = |k: &str, v: String| el.attrs.push((k.to_string(), v));
        match kind.as_str() {
            "position" => {
                put("kp", text(resolved.gainprm[0]));
                match resolved.biasprm[2] {
                    z if z > 0.0 => put("dampratio", text(z)),
                    b => put("kv", text(0.0 - b)),
                }
                if resolved.dyntype != "none" {
                    put("timeconst", text(resolved.dynprm[0]));
                }
            }
            "velocity" => put("kv", text(resolved.gainprm[0])),
            "damper" => put("kv", text(0.0 - resolved.gainprm[2])),
            "adhesion" => put("gain", text(resolved.gainprm[0])),
            "general" => {
                put("gaintype", resolved.gaintype.clone());
                put("gainprm", vector_text(&resolved.gainprm));
                put("biastype", resolved.biastype.clone());
                put("biasprm", vector_text(&resolved.biasprm));
                if resolved.dyntype != "none" {
                    put("dyntype", resolved.dyntype.clone());
                }
                if resolved.dynprm != Parameters::default().dynprm {
                    put("dynprm", vector_text(&resolved.dynprm));
                }
            }
            _ => {}
        }
        Ok(())
    }
}

/// A damper default's control range, which MuJoCo refuses negative as on the element.
fn damper_range(el: &Element) -> Result<(), SceneError> {
    let Some(s) = el.attr("ctrlrange") else {
        return Ok(());
    };
    match s
        .split_whitespace()
        .map(str::parse::<f64>)
        .collect::<Result<Vec<_>, _>>()
    {
        Ok(r) if r.len() == 2 && r.iter().all(|x| x.is_finite()) => {
            if r.iter().any(|&x| x < 0.0) {
                return Err(error(
                    el,
                    "a damper's ctrlrange cannot be negative (MuJoCo refuses it too)",
                ));
            }
            Ok(())
        }
        _ => Err(error(
            el,
            format!("ctrlrange=\"{s}\": expected two numbers"),
        )),
    }
}

/// The refusal of an element whose parameters would come from a default of a kind SCM does
/// not simulate.
fn inherits_other(el: &Element, other: &str) -> SceneError {
    error(
        el,
        format!("this <{}> would take its gain and bias from a <{other}> default of its class, which SCM does not simulate: give it a class without that default", el.name),
    )
}
