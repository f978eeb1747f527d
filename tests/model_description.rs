//! The modelDescription.xml files: the checked-in copies must be what the code generates, and
//! every variable of the FMUs as they were before FMI 3.0 and the exposed Model Exchange
//! states (`tests/fixtures/*_fmi2_variables.csv`, read from the XML of that version) must keep
//! its name, value reference, causality, variability, type, unit and display unit, in the
//! FMI 2.0 and the FMI 3.0 XML alike. New variables may only be added.

use magswarm::model::Model;
use magswarm_fmi::FmiVersion;

#[test]
fn checked_in_model_descriptions_are_up_to_date() {
    for (file, version, cmd) in [
        ("modelDescription.xml", FmiVersion::V2, ""),
        (
            "fmi3/modelDescription.xml",
            FmiVersion::V3,
            " --fmi-version 3",
        ),
    ] {
        let path = format!("{}/modelDescription/{file}", env!("CARGO_MANIFEST_DIR"));
        let on_disk = std::fs::read_to_string(&path).expect("checked-in modelDescription");
        let generated = magswarm_fmu::model_description_for(&Model::paper(), None, version);
        assert!(
            on_disk == generated,
            "modelDescription/{file} is stale: regenerate it with \
             `target/release/magswarm fmu{cmd} --xml modelDescription/{file}`"
        );
    }
}

/// Value of attribute `name` in one XML element's text.
fn attr(elem: &str, name: &str) -> Option<String> {
    let key = format!(" {name}=\"");
    let s = elem.find(&key)? + key.len();
    let e = elem[s..].find('"')?;
    Some(elem[s..s + e].to_string())
}

/// (name, vr, causality, variability, type, unit, display unit) of every variable of a
/// generated modelDescription, in FMI 2.0 or 3.0 form (types named as FMI 2.0 does).
fn variables(xml: &str) -> Vec<[String; 7]> {
    let lines: Vec<&str> = xml.lines().map(str::trim).collect();
    let types: Vec<(String, String, String)> = lines
        .iter()
        .filter(|l| l.starts_with("<Float64Type "))
        .map(|l| {
            let a = |n| attr(l, n).unwrap_or_default();
            (a("name"), a("unit"), a("displayUnit"))
        })
        .collect();
    let body = xml
        .split("<ModelVariables>")
        .nth(1)
        .and_then(|b| b.split("</ModelVariables>").next())
        .expect("ModelVariables");
    let body_lines: Vec<&str> = body.lines().map(str::trim).collect();
    let fmi3 = xml.contains("fmiVersion=\"3.0\"");
    let mut out = Vec::new();
    for (i, l) in body_lines.iter().enumerate() {
        let v2 = !fmi3 && l.starts_with("<ScalarVariable ");
        let v3 = fmi3
            && ["<Float64 ", "<Int32 ", "<Boolean ", "<String "]
                .iter()
                .any(|p| l.starts_with(p));
        if !(v2 || v3) {
            continue;
        }
        let a = |n| attr(l, n).unwrap_or_default();
        let (ty, unit, display) = if v2 {
            let t = body_lines[i + 1];
            let tag = t[1..]
                .split([' ', '/', '>'])
                .next()
                .unwrap_or("")
                .to_string();
            (
                tag,
                attr(t, "unit").unwrap_or_default(),
                attr(t, "displayUnit").unwrap_or_default(),
            )
        } else {
            let tag = l[1..].split(' ').next().unwrap_or("");
            let tag = match tag {
                "Float64" => "Real",
                "Int32" => "Integer",
                t => t,
            }
            .to_string();
            let decl = a("declaredType");
            let (u, d) = types
                .iter()
                .find(|t| t.0 == decl)
                .map(|t| (t.1.clone(), t.2.clone()))
                .unwrap_or_default();
            (tag, u, d)
        };
        out.push([
            a("name"),
            a("valueReference"),
            a("causality"),
            a("variability"),
            ty,
            unit,
            display,
        ]);
    }
    out
}

fn fixture(name: &str) -> Vec<[String; 7]> {
    let path = format!("{}/tests/fixtures/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(path).expect("fixture");
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<String> = l.split(',').map(str::to_string).collect();
            [0, 1, 2, 3, 4, 5, 6].map(|i| f.get(i).cloned().unwrap_or_default())
        })
        .collect()
}

#[test]
fn the_variables_of_both_fmus_are_kept_in_both_versions() {
    let plant = |v| magswarm_fmu::model_description_for(&Model::paper(), None, v);
    let pid = |v| magswarm_pid_fmu::model_description_for(&Default::default(), None, v);
    for (name, xml_of) in [
        (
            "plant_fmi2_variables.csv",
            &plant as &dyn Fn(FmiVersion) -> String,
        ),
        ("pid_fmi2_variables.csv", &pid),
    ] {
        let before = fixture(name);
        assert!(before.len() > 30, "{name}: {} rows", before.len());
        for version in [FmiVersion::V2, FmiVersion::V3] {
            let now = variables(&xml_of(version));
            for row in &before {
                let found = now.iter().find(|r| r[0] == row[0]);
                assert_eq!(found, Some(row), "{name}, {version}: variable {}", row[0]);
            }
            // Only additions, each with a value reference of its own.
            let mut vrs: Vec<&String> = now.iter().map(|r| &r[1]).collect();
            vrs.sort();
            vrs.dedup();
            assert_eq!(
                vrs.len(),
                now.len(),
                "{name}, {version}: duplicate references"
            );
        }
    }
}
