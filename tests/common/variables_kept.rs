//! The golden check that an FMU keeps every variable it had before FMI 3.0 and the exposed
//! Model Exchange states: `tests/fixtures/*_fmi2_variables.csv` (read from the XML of that
//! version) against the FMI 2.0 and 3.0 XML generated now. Shared by the plant's test
//! (tests/model_description.rs) and the controller's (crates/magswarm-pid-fmu/tests), which
//! are separate test binaries because no binary may link both FMU crates (they export the
//! same C symbols).
//!
//! Use with `#[path = ".../tests/common/variables_kept.rs"] mod variables_kept;`.
#![allow(dead_code)]

use magswarm_fmi::FmiVersion;

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

fn fixture(fixtures_dir: &str, name: &str) -> Vec<[String; 7]> {
    let path = format!("{fixtures_dir}/{name}");
    let text = std::fs::read_to_string(path).expect("fixture");
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<String> = l.split(',').map(str::to_string).collect();
            [0, 1, 2, 3, 4, 5, 6].map(|i| f.get(i).cloned().unwrap_or_default())
        })
        .collect()
}

/// Every row of the fixture `name` (under tests/fixtures) is in the XML of both versions
/// unchanged, and the value references stay unique.
pub fn assert_kept(fixtures_dir: &str, name: &str, xml_of: &dyn Fn(FmiVersion) -> String) {
    let before = fixture(fixtures_dir, name);
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
