//! `modelDescription.xml` (FMI 2.0) from a [`ModelInfo`], written with quick-xml.
//!
//! The output is byte-stable (no generation date) and follows the element order of the FMI 2.0
//! schema: `ModelExchange`, `CoSimulation`, `UnitDefinitions`, `LogCategories`,
//! `DefaultExperiment`, `ModelVariables`, `ModelStructure`. Attributes equal to the standard's
//! default (causality `local`, variability `continuous`, the default `initial`) are omitted;
//! empty `Outputs`/`Derivatives`/`InitialUnknowns` are omitted (the schema requires at least
//! one `Unknown` in each).
//!
//! Value references in `ModelStructure` are resolved to variables by preferring a `Real`
//! variable; a value reference carried only by variables of other types must be unique.

use std::collections::{BTreeSet, HashMap};
use std::io::Cursor;

use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, Event};
use quick_xml::Writer;

use super::contract::{Causality, Initial, LogCategory, ModelInfo, VarType, Variability};

/// An inconsistent [`ModelInfo`] (a bug in the model's variable table).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DescriptionError {
    /// Two variables have the same name.
    #[error("two variables are named {0:?}")]
    DuplicateName(String),
    /// Two variables of one type have the same value reference.
    #[error("two {kind} variables have value reference {vr}")]
    DuplicateValueReference {
        /// `Real`, `Integer`, ...
        kind: &'static str,
        /// The value reference.
        vr: u32,
    },
    /// A value reference in `ModelStructure` or `derivative` names no variable.
    #[error("{context}: no variable has value reference {vr}")]
    UnknownValueReference {
        /// Where the reference was found.
        context: String,
        /// The value reference.
        vr: u32,
    },
    /// A value reference in `ModelStructure` is carried by several non-Real variables.
    #[error("{context}: value reference {vr} is ambiguous (several variables of different types have it)")]
    AmbiguousValueReference {
        /// Where the reference was found.
        context: String,
        /// The value reference.
        vr: u32,
    },
    /// The plumbing offers no event indicators.
    #[error(
        "numberOfEventIndicators must be 0 (the FMI plumbing offers no event indicators), got {0}"
    )]
    EventIndicators(usize),
    /// quick-xml failed (out of memory, ...).
    #[error("XML writer: {0}")]
    Xml(String),
}

/// Writes `modelDescription.xml` for `info`.
///
/// # Panics
/// If `info` is inconsistent (see [`try_model_description_xml`]): a bug in the model's table.
pub fn model_description_xml(info: &ModelInfo) -> String {
    match try_model_description_xml(info) {
        Ok(xml) => xml,
        Err(e) => panic!("invalid ModelInfo for modelDescription.xml: {e}"),
    }
}

/// Base-unit exponents of a unit: `kg m s A K mol cd rad`, and a factor to SI.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BaseUnit {
    /// Exponents of kg, m, s, A, K, mol, cd, rad.
    pub exponents: [i32; 8],
    /// Factor: value in SI = factor · value in this unit.
    pub factor: f64,
}

const BASE_NAMES: [&str; 8] = ["kg", "m", "s", "A", "K", "mol", "cd", "rad"];

fn symbol(sym: &str) -> Option<([i32; 8], f64)> {
    //                 kg  m   s  A  K mol cd rad
    Some(match sym {
        "kg" => ([1, 0, 0, 0, 0, 0, 0, 0], 1.0),
        "g" => ([1, 0, 0, 0, 0, 0, 0, 0], 1e-3),
        "m" => ([0, 1, 0, 0, 0, 0, 0, 0], 1.0),
        "mm" => ([0, 1, 0, 0, 0, 0, 0, 0], 1e-3),
        "s" => ([0, 0, 1, 0, 0, 0, 0, 0], 1.0),
        "A" => ([0, 0, 0, 1, 0, 0, 0, 0], 1.0),
        "K" => ([0, 0, 0, 0, 1, 0, 0, 0], 1.0),
        "mol" => ([0, 0, 0, 0, 0, 1, 0, 0], 1.0),
        "cd" => ([0, 0, 0, 0, 0, 0, 1, 0], 1.0),
        "rad" => ([0, 0, 0, 0, 0, 0, 0, 1], 1.0),
        "deg" => ([0, 0, 0, 0, 0, 0, 0, 1], std::f64::consts::PI / 180.0),
        "N" => ([1, 1, -2, 0, 0, 0, 0, 0], 1.0),
        "J" => ([1, 2, -2, 0, 0, 0, 0, 0], 1.0),
        "W" => ([1, 2, -3, 0, 0, 0, 0, 0], 1.0),
        "Pa" => ([1, -1, -2, 0, 0, 0, 0, 0], 1.0),
        "Hz" => ([0, 0, -1, 0, 0, 0, 0, 0], 1.0),
        "1" => ([0; 8], 1.0),
        _ => return None,
    })
}

/// Parses a unit such as `N.m`, `m/s2`, `kg.m2`, `N.m.s/rad`, `1/s` into base-unit exponents
/// (Modelica unit syntax: `.` multiplies, one `/` divides, a trailing integer is a power).
/// `None` for a symbol it does not know.
pub fn base_unit(unit: &str) -> Option<BaseUnit> {
    let mut exponents = [0i32; 8];
    let mut factor = 1.0;
    let (num, den) = match unit.split_once('/') {
        Some((n, d)) => (n, Some(d)),
        None => (unit, None),
    };
    for (part, sign) in [(Some(num), 1), (den, -1)] {
        let Some(part) = part else { continue };
        for token in part.split('.') {
            let digits = token.trim_start_matches(|c: char| !(c.is_ascii_digit() || c == '-'));
            let (sym, power) = if digits.is_empty() || digits.len() == token.len() {
                (token, 1)
            } else {
                (
                    &token[..token.len() - digits.len()],
                    digits.parse::<i32>().ok()?,
                )
            };
            let (e, f) = symbol(sym)?;
            for (acc, x) in exponents.iter_mut().zip(e) {
                *acc += sign * power * x;
            }
            factor *= f.powi(sign * power);
        }
    }
    Some(BaseUnit { exponents, factor })
}

/// Formats an `f64` so that it reads back exactly (shortest round-trip form; `INF`, `-INF`,
/// `NaN` as in XML Schema).
pub fn format_real(x: f64) -> String {
    if x.is_nan() {
        "NaN".into()
    } else if x == f64::INFINITY {
        "INF".into()
    } else if x == f64::NEG_INFINITY {
        "-INF".into()
    } else {
        format!("{x:?}")
    }
}

/// The causality's name in `modelDescription.xml`.
pub fn causality_name(c: Causality) -> &'static str {
    match c {
        Causality::Parameter => "parameter",
        Causality::CalculatedParameter => "calculatedParameter",
        Causality::Input => "input",
        Causality::Output => "output",
        Causality::Local => "local",
        Causality::Independent => "independent",
    }
}

/// The variability's name in `modelDescription.xml`.
pub fn variability_name(v: Variability) -> &'static str {
    match v {
        Variability::Constant => "constant",
        Variability::Fixed => "fixed",
        Variability::Tunable => "tunable",
        Variability::Discrete => "discrete",
        Variability::Continuous => "continuous",
    }
}

fn initial_name(i: Initial) -> &'static str {
    match i {
        Initial::Exact => "exact",
        Initial::Approx => "approx",
        Initial::Calculated => "calculated",
    }
}

/// The `initial` the standard assumes when the attribute is omitted (FMI 2.0, table in 2.2.7);
/// `None` where `initial` must not be given (inputs, the independent variable).
pub fn default_initial(causality: Causality, variability: Variability) -> Option<Initial> {
    use Causality::*;
    use Variability::*;
    match (causality, variability) {
        (Input | Independent, _) => None,
        (Parameter, _) => Some(Initial::Exact),
        (CalculatedParameter, _) => Some(Initial::Calculated),
        (Output | Local, Constant) => Some(Initial::Exact),
        (Output | Local, _) => Some(Initial::Calculated),
    }
}

fn kind_name(t: &VarType) -> &'static str {
    match t {
        VarType::Real { .. } => "Real",
        VarType::Integer { .. } => "Integer",
        VarType::Boolean { .. } => "Boolean",
        VarType::String { .. } => "String",
    }
}

/// Value reference -> 1-based index in `<ModelVariables>`.
struct Indices {
    real: HashMap<u32, usize>,
    other: HashMap<u32, Vec<usize>>,
}

impl Indices {
    fn resolve(&self, vr: u32, context: &str) -> Result<usize, DescriptionError> {
        if let Some(&i) = self.real.get(&vr) {
            return Ok(i);
        }
        match self.other.get(&vr).map(Vec::as_slice) {
            Some([i]) => Ok(*i),
            Some(_) => Err(DescriptionError::AmbiguousValueReference {
                context: context.into(),
                vr,
            }),
            None => Err(DescriptionError::UnknownValueReference {
                context: context.into(),
                vr,
            }),
        }
    }
}

fn xml_err(e: impl std::fmt::Display) -> DescriptionError {
    DescriptionError::Xml(e.to_string())
}

/// Writes `modelDescription.xml` for `info`, or says what is inconsistent in it.
pub fn try_model_description_xml(info: &ModelInfo) -> Result<String, DescriptionError> {
    if info.number_of_event_indicators != 0 {
        return Err(DescriptionError::EventIndicators(
            info.number_of_event_indicators,
        ));
    }
    let mut names = BTreeSet::new();
    let mut seen = BTreeSet::new();
    let mut indices = Indices {
        real: HashMap::new(),
        other: HashMap::new(),
    };
    for (i, v) in info.variables.iter().enumerate() {
        if !names.insert(v.name.as_str()) {
            return Err(DescriptionError::DuplicateName(v.name.clone()));
        }
        let kind = kind_name(&v.var_type);
        if !seen.insert((kind, v.value_reference)) {
            return Err(DescriptionError::DuplicateValueReference {
                kind,
                vr: v.value_reference,
            });
        }
        if kind == "Real" {
            indices.real.insert(v.value_reference, i + 1);
        } else {
            indices
                .other
                .entry(v.value_reference)
                .or_default()
                .push(i + 1);
        }
    }

    let mut w = Writer::new_with_indent(Cursor::new(Vec::new()), b' ', 2);
    w.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))
        .map_err(xml_err)?;

    let mut root = BytesStart::new("fmiModelDescription");
    root.push_attribute(("fmiVersion", "2.0"));
    root.push_attribute(("modelName", info.model_name.as_str()));
    root.push_attribute(("guid", info.guid.as_str()));
    if !info.description.is_empty() {
        root.push_attribute(("description", info.description.as_str()));
    }
    if !info.generation_tool.is_empty() {
        root.push_attribute(("generationTool", info.generation_tool.as_str()));
    }
    root.push_attribute(("variableNamingConvention", "structured"));
    root.push_attribute(("numberOfEventIndicators", "0"));
    w.write_event(Event::Start(root)).map_err(xml_err)?;

    // Interfaces: ModelExchange before CoSimulation (schema order).
    let flag = |b: bool| if b { "true" } else { "false" };
    let caps = &info.capabilities;
    let common = [
        ("modelIdentifier", "scm"),
        ("canNotUseMemoryManagementFunctions", "true"),
        ("canGetAndSetFMUstate", flag(caps.can_get_and_set_fmu_state)),
        ("canSerializeFMUstate", flag(caps.can_serialize_fmu_state)),
        (
            "providesDirectionalDerivative",
            flag(caps.provides_directional_derivative),
        ),
    ];
    if info.model_exchange {
        w.create_element("ModelExchange")
            .with_attributes(common)
            .write_empty()
            .map_err(xml_err)?;
    }
    w.create_element("CoSimulation")
        .with_attributes(common)
        .with_attribute(("canHandleVariableCommunicationStepSize", "true"))
        .write_empty()
        .map_err(xml_err)?;

    // Units, in order of first use.
    let mut units: Vec<&str> = Vec::new();
    for v in &info.variables {
        if let VarType::Real { unit: Some(u), .. } = v.var_type {
            if !units.contains(&u) {
                units.push(u);
            }
        }
    }
    if !units.is_empty() {
        w.write_event(Event::Start(BytesStart::new("UnitDefinitions")))
            .map_err(xml_err)?;
        for u in &units {
            let el = w.create_element("Unit").with_attribute(("name", *u));
            match base_unit(u) {
                Some(b) if b.exponents != [0; 8] || b.factor != 1.0 => {
                    let mut attrs: Vec<(&str, String)> = Vec::new();
                    for (name, e) in BASE_NAMES.iter().zip(b.exponents) {
                        if e != 0 {
                            attrs.push((name, e.to_string()));
                        }
                    }
                    if b.factor != 1.0 {
                        attrs.push(("factor", format_real(b.factor)));
                    }
                    el.write_inner_content(|w| {
                        w.create_element("BaseUnit")
                            .with_attributes(attrs.iter().map(|(k, v)| (*k, v.as_str())))
                            .write_empty()?;
                        Ok::<(), std::io::Error>(())
                    })
                    .map_err(xml_err)?;
                }
                // dimensionless ("1") or a symbol we do not know: no BaseUnit
                _ => {
                    el.write_empty().map_err(xml_err)?;
                }
            }
        }
        w.write_event(Event::End(BytesEnd::new("UnitDefinitions")))
            .map_err(xml_err)?;
    }

    w.write_event(Event::Start(BytesStart::new("LogCategories")))
        .map_err(xml_err)?;
    for c in LogCategory::ALL {
        w.create_element("Category")
            .with_attribute(("name", c.name()))
            .with_attribute(("description", c.description()))
            .write_empty()
            .map_err(xml_err)?;
    }
    w.write_event(Event::End(BytesEnd::new("LogCategories")))
        .map_err(xml_err)?;

    let de = &info.default_experiment;
    let experiment: Vec<(&str, String)> = [
        ("startTime", de.start_time),
        ("stopTime", de.stop_time),
        ("tolerance", de.tolerance),
        ("stepSize", de.step_size),
    ]
    .into_iter()
    .filter_map(|(k, v)| v.map(|v| (k, format_real(v))))
    .collect();
    if !experiment.is_empty() {
        w.create_element("DefaultExperiment")
            .with_attributes(experiment.iter().map(|(k, v)| (*k, v.as_str())))
            .write_empty()
            .map_err(xml_err)?;
    }

    w.write_event(Event::Start(BytesStart::new("ModelVariables")))
        .map_err(xml_err)?;
    for v in &info.variables {
        let mut sv: Vec<(&str, String)> = vec![
            ("name", v.name.clone()),
            ("valueReference", v.value_reference.to_string()),
        ];
        if !v.description.is_empty() {
            sv.push(("description", v.description.clone()));
        }
        if v.causality != Causality::Local {
            sv.push(("causality", causality_name(v.causality).into()));
        }
        if v.variability != Variability::Continuous {
            sv.push(("variability", variability_name(v.variability).into()));
        }
        let default = default_initial(v.causality, v.variability);
        if let (Some(initial), Some(default)) = (v.initial, default) {
            if initial != default {
                sv.push(("initial", initial_name(initial).into()));
            }
        }
        let mut ty: Vec<(&str, String)> = Vec::new();
        let type_name = kind_name(&v.var_type);
        match &v.var_type {
            VarType::Real {
                start,
                unit,
                derivative,
            } => {
                if let Some(u) = unit {
                    ty.push(("unit", (*u).into()));
                }
                if let Some(s) = start {
                    ty.push(("start", format_real(*s)));
                }
                if let Some(d) = derivative {
                    let index = indices.real.get(d).copied().ok_or_else(|| {
                        DescriptionError::UnknownValueReference {
                            context: format!("derivative of {}", v.name),
                            vr: *d,
                        }
                    })?;
                    ty.push(("derivative", index.to_string()));
                }
            }
            VarType::Integer { start } => {
                if let Some(s) = start {
                    ty.push(("start", s.to_string()));
                }
            }
            VarType::Boolean { start } => {
                if let Some(s) = start {
                    ty.push(("start", s.to_string()));
                }
            }
            VarType::String { start } => {
                if let Some(s) = start {
                    ty.push(("start", s.clone()));
                }
            }
        }
        w.create_element("ScalarVariable")
            .with_attributes(sv.iter().map(|(k, v)| (*k, v.as_str())))
            .write_inner_content(|w| {
                w.create_element(type_name)
                    .with_attributes(ty.iter().map(|(k, v)| (*k, v.as_str())))
                    .write_empty()?;
                Ok::<(), std::io::Error>(())
            })
            .map_err(xml_err)?;
    }
    w.write_event(Event::End(BytesEnd::new("ModelVariables")))
        .map_err(xml_err)?;

    let s = &info.structure;
    let lists = [
        ("Outputs", &s.outputs),
        ("Derivatives", &s.derivatives),
        ("InitialUnknowns", &s.initial_unknowns),
    ];
    if lists.iter().all(|(_, l)| l.is_empty()) {
        w.write_event(Event::Empty(BytesStart::new("ModelStructure")))
            .map_err(xml_err)?;
    } else {
        w.write_event(Event::Start(BytesStart::new("ModelStructure")))
            .map_err(xml_err)?;
        for (element, list) in lists {
            if list.is_empty() {
                continue;
            }
            w.write_event(Event::Start(BytesStart::new(element)))
                .map_err(xml_err)?;
            for (vr, deps) in list.iter() {
                let context = format!("ModelStructure/{element}");
                let index = indices.resolve(*vr, &context)?;
                let mut attrs = vec![("index", index.to_string())];
                if let Some(deps) = deps {
                    let d: Result<Vec<String>, _> = deps
                        .iter()
                        .map(|d| {
                            indices
                                .resolve(*d, &format!("{context} dependencies of {vr}"))
                                .map(|i| i.to_string())
                        })
                        .collect();
                    attrs.push(("dependencies", d?.join(" ")));
                }
                w.create_element("Unknown")
                    .with_attributes(attrs.iter().map(|(k, v)| (*k, v.as_str())))
                    .write_empty()
                    .map_err(xml_err)?;
            }
            w.write_event(Event::End(BytesEnd::new(element)))
                .map_err(xml_err)?;
        }
        w.write_event(Event::End(BytesEnd::new("ModelStructure")))
            .map_err(xml_err)?;
    }

    w.write_event(Event::End(BytesEnd::new("fmiModelDescription")))
        .map_err(xml_err)?;
    let mut bytes = w.into_inner().into_inner();
    bytes.push(b'\n');
    String::from_utf8(bytes).map_err(xml_err)
}

#[cfg(test)]
#[path = "model_description_tests.rs"]
mod tests;
