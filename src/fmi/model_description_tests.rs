use super::*;
use crate::fmi::contract::Capabilities;
use crate::fmi::toy_model::toy_info;
use quick_xml::events::BytesStart;
use quick_xml::Reader;

/// (depth, element name, attributes) of an element.
type Element = (usize, String, Vec<(String, String)>);

/// Every start/empty element, in document order.
fn elements(xml: &str) -> Vec<Element> {
    let mut reader = Reader::from_str(xml);
    let mut depth = 0;
    let mut out = Vec::new();
    let attrs = |e: &BytesStart| -> Vec<(String, String)> {
        e.attributes()
            .map(|a| {
                let a = a.unwrap();
                (
                    a.key.as_ref().to_string(),
                    a.normalized_value(quick_xml::XmlVersion::Implicit1_0)
                        .unwrap()
                        .into_owned(),
                )
            })
            .collect()
    };
    loop {
        match reader.read_event().unwrap() {
            Event::Start(e) => {
                out.push((depth, e.name().as_ref().to_string(), attrs(&e)));
                depth += 1;
            }
            Event::Empty(e) => out.push((depth, e.name().as_ref().to_string(), attrs(&e))),
            Event::End(_) => depth -= 1,
            Event::Eof => break,
            _ => {}
        }
    }
    assert_eq!(depth, 0);
    out
}

fn attr<'a>(attrs: &'a [(String, String)], key: &str) -> Option<&'a str> {
    attrs
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.as_str())
}

#[test]
fn top_level_order_follows_the_schema() {
    let xml = model_description_xml(&toy_info());
    let top: Vec<String> = elements(&xml)
        .into_iter()
        .filter(|(d, _, _)| *d == 1)
        .map(|(_, n, _)| n)
        .collect();
    assert_eq!(
        top,
        [
            "ModelExchange",
            "CoSimulation",
            "UnitDefinitions",
            "LogCategories",
            "DefaultExperiment",
            "ModelVariables",
            "ModelStructure"
        ]
    );
    assert!(xml.starts_with("<?xml version=\"1.0\" encoding=\"UTF-8\"?>"));
}

#[test]
fn root_and_interfaces() {
    let xml = model_description_xml(&toy_info());
    let els = elements(&xml);
    let (_, name, root) = &els[0];
    assert_eq!(name, "fmiModelDescription");
    assert_eq!(attr(root, "fmiVersion"), Some("2.0"));
    assert_eq!(attr(root, "modelName"), Some("toy"));
    assert_eq!(attr(root, "guid"), Some(crate::fmi::toy_model::GUID));
    assert_eq!(attr(root, "variableNamingConvention"), Some("structured"));
    assert_eq!(attr(root, "numberOfEventIndicators"), Some("0"));
    assert_eq!(attr(root, "generationDateAndTime"), None);
    let cs = &els.iter().find(|(_, n, _)| n == "CoSimulation").unwrap().2;
    for flag in [
        "canHandleVariableCommunicationStepSize",
        "canGetAndSetFMUstate",
        "canSerializeFMUstate",
        "providesDirectionalDerivative",
        "canNotUseMemoryManagementFunctions",
    ] {
        assert_eq!(attr(cs, flag), Some("true"), "{flag}");
    }
    assert_eq!(attr(cs, "modelIdentifier"), Some("scm"));
    let me = &els.iter().find(|(_, n, _)| n == "ModelExchange").unwrap().2;
    assert_eq!(attr(me, "canGetAndSetFMUstate"), Some("true"));
    assert_eq!(
        attr(me, "canHandleVariableCommunicationStepSize"),
        None,
        "a CS-only attribute"
    );

    let mut cs_only = toy_info();
    cs_only.model_exchange = false;
    assert!(!model_description_xml(&cs_only).contains("<ModelExchange"));
}

#[test]
fn capability_flags_follow_the_model_info() {
    let mut info = toy_info();
    info.capabilities = Capabilities::default();
    let xml = model_description_xml(&info);
    for el in elements(&xml)
        .iter()
        .filter(|(_, n, _)| n == "CoSimulation" || n == "ModelExchange")
    {
        for flag in [
            "canGetAndSetFMUstate",
            "canSerializeFMUstate",
            "providesDirectionalDerivative",
        ] {
            assert_eq!(attr(&el.2, flag), Some("false"), "{} {flag}", el.1);
        }
    }
    info.capabilities.provides_directional_derivative = true;
    let xml = model_description_xml(&info);
    assert_eq!(
        xml.matches("providesDirectionalDerivative=\"true\"")
            .count(),
        2
    );
    assert_eq!(xml.matches("canSerializeFMUstate=\"false\"").count(), 2);
}

#[test]
fn units_have_base_units() {
    let xml = model_description_xml(&toy_info());
    let els = elements(&xml);
    let units: Vec<&str> = els
        .iter()
        .filter(|(_, n, _)| n == "Unit")
        .map(|(_, _, a)| attr(a, "name").unwrap())
        .collect();
    assert_eq!(units, ["m", "m/s", "N", "N/m", "m/s2", "s"]);
    let n = els
        .iter()
        .position(|(_, n, a)| n == "Unit" && attr(a, "name") == Some("N"))
        .unwrap();
    let base = &els[n + 1];
    assert_eq!(base.1, "BaseUnit");
    assert_eq!(
        base.2,
        [
            ("kg".to_string(), "1".to_string()),
            ("m".into(), "1".into()),
            ("s".into(), "-2".into())
        ]
    );

    let e = |u: &str| base_unit(u).unwrap().exponents;
    assert_eq!(e("N.m"), [1, 2, -2, 0, 0, 0, 0, 0]);
    assert_eq!(e("rad/s"), [0, 0, -1, 0, 0, 0, 0, 1]);
    assert_eq!(e("m2"), [0, 2, 0, 0, 0, 0, 0, 0]);
    assert_eq!(e("N/m"), [1, 0, -2, 0, 0, 0, 0, 0]);
    assert_eq!(e("kg.m2"), [1, 2, 0, 0, 0, 0, 0, 0]);
    assert_eq!(e("1"), [0; 8]);
    assert_eq!(e("1/s"), [0, 0, -1, 0, 0, 0, 0, 0]);
    assert_eq!(e("N.m.s/rad"), [1, 2, -1, 0, 0, 0, 0, -1]);
    assert!(base_unit("furlong").is_none());
}

#[test]
fn variables_attributes_and_start_values() {
    let mut info = toy_info();
    if let VarType::Real { start, .. } = &mut info.variables[3].var_type {
        *start = Some(0.1 + 0.2);
    }
    let xml = model_description_xml(&info);
    let els = elements(&xml);
    let svs: Vec<&Element> = els
        .iter()
        .filter(|(_, n, _)| n == "ScalarVariable")
        .collect();
    assert_eq!(svs.len(), info.variables.len());
    let x = &svs[0].2;
    assert_eq!(attr(x, "name"), Some("x"));
    assert_eq!(attr(x, "causality"), Some("output"));
    assert_eq!(attr(x, "variability"), None, "continuous is the default");
    assert_eq!(
        attr(x, "initial"),
        Some("exact"),
        "not the default for outputs"
    );
    let u = &svs[2].2;
    assert_eq!(attr(u, "initial"), None);
    let k = &svs[3].2;
    assert_eq!(attr(k, "variability"), Some("tunable"));
    assert_eq!(
        attr(k, "initial"),
        None,
        "exact is the default for parameters"
    );
    let der_x = &svs[4].2;
    assert_eq!(attr(der_x, "causality"), None, "local is the default");
    // start values round-trip exactly
    let reals: Vec<&Vec<(String, String)>> = els
        .iter()
        .filter(|(_, n, _)| n == "Real")
        .map(|(_, _, a)| a)
        .collect();
    let k_start: f64 = attr(reals[3], "start").unwrap().parse().unwrap();
    assert_eq!(k_start.to_bits(), (0.1f64 + 0.2).to_bits());
    assert_eq!(attr(reals[0], "unit"), Some("m"));
    // derivative = 1-based index of the state
    assert_eq!(attr(reals[4], "derivative"), Some("1"));
    assert_eq!(attr(reals[5], "derivative"), Some("2"));
    // other types, escaping
    let b = &els.iter().find(|(_, n, _)| n == "Boolean").unwrap().2;
    assert_eq!(attr(b, "start"), Some("false"));
    let label = svs
        .iter()
        .find(|(_, _, a)| attr(a, "name") == Some("label"))
        .unwrap();
    assert_eq!(attr(&label.2, "description"), Some("a <label> & \"quote\""));
    assert_eq!(format_real(f64::INFINITY), "INF");
    assert_eq!(format_real(1e-9), "1e-9");
    assert_eq!(format_real(2.0), "2.0");
}

#[test]
fn model_structure_indices_and_dependencies() {
    let xml = model_description_xml(&toy_info());
    let els = elements(&xml);
    let ms = els
        .iter()
        .position(|(_, n, _)| n == "ModelStructure")
        .unwrap();
    let tail: Vec<(String, Option<String>, Option<String>)> = els[ms + 1..]
        .iter()
        .map(|(_, n, a)| {
            (
                n.clone(),
                attr(a, "index").map(String::from),
                attr(a, "dependencies").map(String::from),
            )
        })
        .collect();
    let u = |i: &str, d: Option<&str>| {
        (
            "Unknown".to_string(),
            Some(i.to_string()),
            d.map(String::from),
        )
    };
    let e = |n: &str| (n.to_string(), None, None);
    assert_eq!(
        tail,
        [
            e("Outputs"),
            u("1", Some("1")),
            u("2", Some("2")),
            u("8", Some("")),
            e("Derivatives"),
            u("5", Some("2")),
            u("6", Some("1 3 4")),
            e("InitialUnknowns"),
            u("5", Some("2")),
            u("6", None),
        ]
    );
}

#[test]
fn empty_derivatives_are_omitted() {
    let mut info = toy_info();
    info.structure.derivatives.clear();
    let xml = model_description_xml(&info);
    assert!(!xml.contains("Derivatives"), "{xml}");
    info.structure = Default::default();
    let xml = model_description_xml(&info);
    assert!(xml.contains("<ModelStructure/>"), "{xml}");
}

#[test]
fn output_is_byte_stable() {
    assert_eq!(
        model_description_xml(&toy_info()),
        model_description_xml(&toy_info())
    );
}

#[test]
fn inconsistent_tables_are_reported() {
    let mut info = toy_info();
    info.structure.outputs.push((99, None));
    assert!(matches!(
        try_model_description_xml(&info),
        Err(DescriptionError::UnknownValueReference { vr: 99, .. })
    ));
    let mut info = toy_info();
    let dup = info.variables[0].clone();
    info.variables.push(dup);
    assert!(matches!(
        try_model_description_xml(&info),
        Err(DescriptionError::DuplicateName(_))
    ));
    let mut info = toy_info();
    info.variables[1].value_reference = 0;
    assert!(matches!(
        try_model_description_xml(&info),
        Err(DescriptionError::DuplicateValueReference { vr: 0, .. })
    ));
    let mut info = toy_info();
    info.number_of_event_indicators = 2;
    assert!(try_model_description_xml(&info).is_err());
}

#[test]
fn default_initial_table() {
    use Causality::*;
    use Variability::*;
    assert_eq!(default_initial(Parameter, Fixed), Some(Initial::Exact));
    assert_eq!(
        default_initial(Output, Continuous),
        Some(Initial::Calculated)
    );
    assert_eq!(default_initial(Output, Constant), Some(Initial::Exact));
    assert_eq!(default_initial(Input, Continuous), None);
    assert_eq!(
        default_initial(CalculatedParameter, Fixed),
        Some(Initial::Calculated)
    );
}
