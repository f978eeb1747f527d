//! modelDescription.xml: generated from the toy table, parsed back, and checked for the
//! things strict importers check (indices, dependencies, start/initial rules, GUID).

mod toy;

use std::collections::HashMap;

use magswarm_fmi2::xml::model_description_xml_for;
use magswarm_fmi2::{
    guid, model_description_xml, try_model_description_xml, ModelInfo, Start, Variable, XmlOptions,
};
use quick_xml::events::Event;
use quick_xml::Reader;

use toy::Lag;

#[derive(Debug, Default, Clone)]
struct Elem {
    name: String,
    attrs: HashMap<String, String>,
    /// Path of ancestors, e.g. "fmiModelDescription/ModelStructure/Outputs".
    parent: String,
}

/// Every element of the document, in order, with unescaped attributes.
fn parse(xml: &str) -> Vec<Elem> {
    let mut r = Reader::from_str(xml);
    let mut stack: Vec<String> = Vec::new();
    let mut out = Vec::new();
    loop {
        match r.read_event().expect("well-formed XML") {
            Event::Start(e) => {
                out.push(elem(&e, &stack));
                stack.push(String::from_utf8(e.name().as_ref().to_vec()).unwrap());
            }
            Event::Empty(e) => out.push(elem(&e, &stack)),
            Event::End(_) => {
                stack.pop();
            }
            Event::Eof => break,
            _ => {}
        }
    }
    assert!(stack.is_empty(), "unbalanced document");
    out
}

fn elem(e: &quick_xml::events::BytesStart<'_>, stack: &[String]) -> Elem {
    let mut attrs = HashMap::new();
    for a in e.attributes() {
        let a = a.expect("valid attribute");
        let k = String::from_utf8(a.key.as_ref().to_vec()).unwrap();
        let v = a.unescape_value().expect("valid escape").into_owned();
        assert!(
            attrs.insert(k.clone(), v).is_none(),
            "duplicate attribute {k}"
        );
    }
    Elem {
        name: String::from_utf8(e.name().as_ref().to_vec()).unwrap(),
        attrs,
        parent: stack.join("/"),
    }
}

fn xml() -> String {
    model_description_xml::<Lag>(&XmlOptions::default())
}

#[test]
fn header_capabilities_and_guid() {
    let doc = parse(&xml());
    let root = &doc[0];
    assert_eq!(root.name, "fmiModelDescription");
    assert_eq!(root.attrs["fmiVersion"], "2.0");
    assert_eq!(root.attrs["guid"], guid::<Lag>());
    assert_eq!(root.attrs["version"], "1.2.3");
    assert_eq!(root.attrs["numberOfEventIndicators"], "0");
    assert_eq!(root.attrs["variableNamingConvention"], "flat");
    let g = &root.attrs["guid"];
    assert!(
        g.starts_with('{') && g.ends_with('}') && g.len() == 38,
        "{g}"
    );
    let cs = doc.iter().find(|e| e.name == "CoSimulation").unwrap();
    assert_eq!(cs.attrs["modelIdentifier"], "Lag");
    for flag in [
        "canHandleVariableCommunicationStepSize",
        "canGetAndSetFMUstate",
        "canSerializeFMUstate",
        "providesDirectionalDerivative",
        "canNotUseMemoryManagementFunctions",
    ] {
        assert_eq!(cs.attrs[flag], "true", "{flag}");
    }
    assert!(doc.iter().all(|e| e.name != "ModelExchange"));
    let de = doc.iter().find(|e| e.name == "DefaultExperiment").unwrap();
    assert_eq!(de.attrs["stepSize"], "0.01");
    assert_eq!(de.attrs["stopTime"], "5.0");
    // Deterministic.
    assert_eq!(xml(), xml());
}

#[test]
fn element_order_follows_the_schema() {
    let doc = parse(&xml());
    let top: Vec<&str> = doc
        .iter()
        .filter(|e| e.parent == "fmiModelDescription")
        .map(|e| e.name.as_str())
        .collect();
    assert_eq!(
        top,
        [
            "CoSimulation",
            "UnitDefinitions",
            "LogCategories",
            "DefaultExperiment",
            "ModelVariables",
            "ModelStructure"
        ]
    );
}

#[test]
fn units_and_display_units() {
    let doc = parse(&xml());
    let units: Vec<&Elem> = doc.iter().filter(|e| e.name == "Unit").collect();
    assert_eq!(units.len(), 4);
    let pos = |name: &str| {
        doc.iter()
            .position(|e| e.name == "Unit" && e.attrs["name"] == name)
            .unwrap()
    };
    let m = pos("m");
    assert_eq!(doc[m + 1].name, "BaseUnit");
    assert_eq!(doc[m + 1].attrs["m"], "1");
    assert_eq!(doc[m + 2].attrs["name"], "mm");
    assert_eq!(doc[m + 2].attrs["factor"].parse::<f64>().unwrap(), 1000.0);
    let w = pos("rad/s");
    assert_eq!(doc[w + 1].attrs["rad"], "1");
    assert_eq!(doc[w + 1].attrs["s"], "-1");
    assert_eq!(doc[w + 2].attrs["name"], "Hz");
    let f: f64 = doc[w + 2].attrs["factor"].parse().unwrap();
    assert_eq!(f, 1.0 / (2.0 * std::f64::consts::PI));
    // Every unit/displayUnit used by a variable is defined.
    let defined: Vec<&str> = units.iter().map(|u| u.attrs["name"].as_str()).collect();
    for e in doc.iter().filter(|e| e.name == "Real") {
        if let Some(u) = e.attrs.get("unit") {
            assert!(defined.contains(&u.as_str()), "{u}");
        }
    }
    // The shell's and the model's log categories.
    let cats: Vec<&str> = doc
        .iter()
        .filter(|e| e.name == "Category")
        .map(|e| e.attrs["name"].as_str())
        .collect();
    assert!(
        cats.contains(&"logStatusError") && cats.contains(&"logLag") && cats.contains(&"logEvents")
    );
}

struct Sv {
    name: String,
    vr: u32,
    causality: String,
    initial: Option<String>,
    ty: String,
    start: Option<String>,
    derivative: Option<usize>,
}

fn variables(doc: &[Elem]) -> Vec<Sv> {
    let mut out = Vec::new();
    for (i, e) in doc.iter().enumerate() {
        if e.name == "ScalarVariable" {
            let t = &doc[i + 1];
            out.push(Sv {
                name: e.attrs["name"].clone(),
                vr: e.attrs["valueReference"].parse().unwrap(),
                causality: e.attrs["causality"].clone(),
                initial: e.attrs.get("initial").cloned(),
                ty: t.name.clone(),
                start: t.attrs.get("start").cloned(),
                derivative: t.attrs.get("derivative").map(|d| d.parse().unwrap()),
            });
        }
    }
    out
}

fn unknowns(doc: &[Elem], section: &str) -> Vec<(usize, Option<Vec<usize>>)> {
    doc.iter()
        .filter(|e| e.name == "Unknown" && e.parent.ends_with(section))
        .map(|e| {
            let deps = e.attrs.get("dependencies").map(|d| {
                d.split_whitespace()
                    .map(|x| x.parse().unwrap())
                    .collect::<Vec<usize>>()
            });
            (e.attrs["index"].parse().unwrap(), deps)
        })
        .collect()
}

#[test]
fn variables_follow_start_and_initial_rules() {
    let doc = parse(&xml());
    let vars = variables(&doc);
    assert_eq!(vars.len(), toy::VARIABLES.len());
    for (sv, v) in vars.iter().zip(toy::VARIABLES.iter()) {
        assert_eq!(sv.name, v.name);
        assert_eq!(sv.vr, v.vr);
        assert_eq!(sv.ty, v.ty.as_str());
        match sv.causality.as_str() {
            "input" => {
                assert!(sv.start.is_some(), "input {} needs start", sv.name);
                assert!(
                    sv.initial.is_none(),
                    "input {} must not have initial",
                    sv.name
                );
            }
            "independent" => assert!(sv.start.is_none() && sv.initial.is_none()),
            "parameter" => {
                assert_eq!(sv.initial.as_deref(), Some("exact"));
                assert!(sv.start.is_some());
            }
            _ => {}
        }
        if sv.initial.as_deref() == Some("calculated") {
            assert!(
                sv.start.is_none(),
                "{} is calculated but has a start",
                sv.name
            );
        }
    }
    let label = vars.iter().find(|v| v.name == "label").unwrap();
    assert_eq!(label.start.as_deref(), Some("lag & <friends> \"quoted\""));
    let der = vars.iter().find(|v| v.name == "der_y").unwrap();
    assert_eq!(vars[der.derivative.unwrap() - 1].name, "y");
    // Reals round-trip exactly.
    let omega = vars.iter().find(|v| v.name == "omega").unwrap();
    assert_eq!(
        omega.start.as_deref().unwrap().parse::<f64>().unwrap(),
        std::f64::consts::TAU
    );
}

#[test]
fn model_structure_is_consistent() {
    let doc = parse(&xml());
    let vars = variables(&doc);
    let name = |i: usize| vars[i - 1].name.as_str();
    let states: Vec<usize> = vars.iter().filter_map(|v| v.derivative).collect();

    let outputs = unknowns(&doc, "Outputs");
    let expected: Vec<usize> = vars
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == "output")
        .map(|(i, _)| i + 1)
        .collect();
    assert_eq!(
        outputs.iter().map(|o| o.0).collect::<Vec<_>>(),
        expected,
        "every output exactly once, in order"
    );
    for (idx, deps) in &outputs {
        let deps = deps
            .as_ref()
            .expect("the toy states every output's dependencies");
        assert!(deps.windows(2).all(|w| w[0] < w[1]), "sorted, unique");
        for d in deps {
            let v = &vars[d - 1];
            assert!(
                v.causality == "input" || states.contains(d),
                "{} depends on {}",
                name(*idx),
                v.name
            );
        }
    }
    let y = vars.iter().position(|v| v.name == "y").unwrap() + 1;
    assert_eq!(
        outputs.iter().find(|o| o.0 == y).unwrap().1.as_deref(),
        Some(&[y][..])
    );
    let n = vars.iter().position(|v| v.name == "n_steps").unwrap() + 1;
    assert_eq!(
        outputs.iter().find(|o| o.0 == n).unwrap().1.as_deref(),
        Some(&[][..])
    );

    let ders = unknowns(&doc, "Derivatives");
    assert_eq!(ders.len(), 1);
    assert_eq!(name(ders[0].0), "der_y");
    let mut dn: Vec<&str> = ders[0]
        .1
        .as_ref()
        .unwrap()
        .iter()
        .map(|&i| name(i))
        .collect();
    dn.sort();
    assert_eq!(dn, ["u", "y"]);

    // InitialUnknowns: outputs with initial calculated/approx, states and derivatives.
    let init = unknowns(&doc, "InitialUnknowns");
    let mut names: Vec<&str> = init.iter().map(|u| name(u.0)).collect();
    names.sort();
    assert_eq!(names, ["der_y", "n_steps", "saturated", "y"]);
    assert!(init.windows(2).all(|w| w[0].0 < w[1].0), "sorted by index");
    for (idx, deps) in &init {
        for d in deps.iter().flatten() {
            let v = &vars[d - 1];
            assert!(
                v.causality == "input" || v.initial.as_deref() == Some("exact"),
                "{} initially depends on {}, which is not known at initialization",
                name(*idx),
                v.name
            );
        }
    }
}

#[test]
fn start_overrides_change_xml_but_not_guid() {
    let opts = XmlOptions {
        generation_date_and_time: Some("2025-01-31T12:00:00Z".into()),
        start_overrides: vec![
            (toy::TAU, Start::Real(2.5)),
            (toy::LABEL, Start::String("baked")),
        ],
    };
    let doc = parse(&model_description_xml::<Lag>(&opts));
    assert_eq!(doc[0].attrs["guid"], guid::<Lag>());
    assert_eq!(
        doc[0].attrs["generationDateAndTime"],
        "2025-01-31T12:00:00Z"
    );
    let vars = variables(&doc);
    assert_eq!(
        vars.iter()
            .find(|v| v.name == "tau")
            .unwrap()
            .start
            .as_deref(),
        Some("2.5")
    );
    assert_eq!(
        vars.iter()
            .find(|v| v.name == "label")
            .unwrap()
            .start
            .as_deref(),
        Some("baked")
    );

    for bad in [
        (toy::Y, Start::Real(1.0)),
        (toy::TAU, Start::Integer(1)),
        (99, Start::Real(1.0)),
        (toy::TAU, Start::Real(f64::NAN)),
    ] {
        let opts = XmlOptions {
            start_overrides: vec![bad],
            ..Default::default()
        };
        assert!(try_model_description_xml::<Lag>(&opts).is_err());
    }
}

fn info_with(vars: &'static [Variable]) -> ModelInfo {
    ModelInfo {
        variables: vars,
        ..toy::INFO.clone()
    }
}

fn problems(vars: Vec<Variable>) -> Vec<String> {
    let vars: &'static [Variable] = Vec::leak(vars);
    model_description_xml_for(&info_with(vars), &XmlOptions::default()).unwrap_err()
}

#[test]
fn invalid_tables_are_refused_with_reasons() {
    let p = problems(vec![
        Variable::real("a", 1).input().start_real(0.0),
        Variable::real("b", 1).output(),
    ]);
    assert!(p.iter().any(|m| m.contains("value reference 1")), "{p:?}");

    let p = problems(vec![Variable::real("a", 1).output().start_real(1.0)]);
    assert!(
        p.iter().any(|m| m.contains("must not have a start")),
        "{p:?}"
    );

    let p = problems(vec![Variable::real("a", 1).input()]);
    assert!(p.iter().any(|m| m.contains("needs a start")), "{p:?}");

    let p = problems(vec![
        Variable::real("p", 1).parameter().start_real(1.0),
        Variable::real("y", 2).output().depends_on(&[1]),
    ]);
    assert!(
        p.iter()
            .any(|m| m.contains("neither an input nor a continuous state")),
        "{p:?}"
    );

    let p = problems(vec![Variable::real("x", 1)
        .input()
        .start_real(0.0)
        .unit("furlong")]);
    assert!(p.iter().any(|m| m.contains("furlong")), "{p:?}");

    let p = problems(vec![Variable::real("x", 1)
        .input()
        .start_real(0.0)
        .unit("m")
        .display_unit("km")]);
    assert!(p.iter().any(|m| m.contains("km")), "{p:?}");

    let p = problems(vec![Variable::integer("i", 1)
        .input()
        .variability(magswarm_fmi2::Variability::Continuous)
        .start_integer(0)]);
    assert!(p.iter().any(|m| m.contains("only Real")), "{p:?}");

    let p = problems(vec![Variable::real("x", 1)
        .parameter()
        .variability(magswarm_fmi2::Variability::Continuous)
        .start_real(0.0)]);
    assert!(p.iter().any(|m| m.contains("not allowed")), "{p:?}");

    let p = problems(vec![
        Variable::real("x", 1).input().start_real(0.0),
        Variable::real("x", 2).output(),
    ]);
    assert!(p.iter().any(|m| m.contains("not unique")), "{p:?}");
}

#[test]
fn guid_tracks_the_table() {
    let g1 = magswarm_fmi2::guid::guid_of(&toy::INFO);
    let changed = ModelInfo {
        version: "1.2.4",
        ..toy::INFO.clone()
    };
    assert_ne!(g1, magswarm_fmi2::guid::guid_of(&changed));
    let mut vars = toy::VARIABLES.to_vec();
    vars[1] = vars[1].clone().start_real(3.0);
    let same = info_with(Vec::leak(vars));
    assert_eq!(
        g1,
        magswarm_fmi2::guid::guid_of(&same),
        "start values are not part of the GUID"
    );
    let mut vars = toy::VARIABLES.to_vec();
    vars[1].name = "u2";
    assert_ne!(
        g1,
        magswarm_fmi2::guid::guid_of(&info_with(Vec::leak(vars)))
    );
}

#[test]
#[ignore = "prints the toy's modelDescription.xml"]
fn print_xml() {
    print!("{}", xml());
}

/// A model that opts into Model Exchange gets a `<ModelExchange>` element first (the schema
/// puts it before `<CoSimulation>`), with the same identifier; one that does not (the toy, a
/// Co-Simulation-only model) gets none, and the GUID is the same either way (it hashes the
/// table, which both interfaces share).
#[test]
fn model_exchange_element_only_for_models_that_opt_in() {
    use magswarm_fmi2::xml::{model_description_xml_with, Capabilities};
    use magswarm_fmi2::FmuModel;
    let info = Lag::model_info();
    let me = model_description_xml_with(info, &XmlOptions::default(), Capabilities::ALL).unwrap();
    let doc = parse(&me);
    let top: Vec<&str> = doc
        .iter()
        .filter(|e| e.parent == "fmiModelDescription")
        .map(|e| e.name.as_str())
        .take(2)
        .collect();
    assert_eq!(top, ["ModelExchange", "CoSimulation"]);
    let ids: Vec<&String> = doc
        .iter()
        .filter(|e| e.name == "ModelExchange" || e.name == "CoSimulation")
        .map(|e| &e.attrs["modelIdentifier"])
        .collect();
    assert_eq!(ids[0], ids[1]);
    assert!(!xml().contains("<ModelExchange"));
    let guid_of = |x: &str| {
        parse(x)
            .into_iter()
            .find(|e| e.name == "fmiModelDescription")
            .unwrap()
            .attrs["guid"]
            .clone()
    };
    assert_eq!(guid_of(&me), guid_of(&xml()));
}
