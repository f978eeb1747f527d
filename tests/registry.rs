//! The parameter registry is the one list of parameters: every row must reach every consumer
//! (model-file validation, the FMU's variables, identify's free/fixed sets). This fails when
//! a consumer keeps a list of its own that lacks a row, or a row's accessor, unit or path
//! does not match what the consumer shows.

use magswarm::identify::params;
use magswarm::model::registry::{self, PARAMS};
use magswarm::model::Model;

/// `name="..." valueReference="..."` and the rest of the ScalarVariable element, for a name.
fn scalar_variable<'a>(xml: &'a str, name: &str) -> Option<&'a str> {
    let key = format!("name=\"{name}\"");
    let at = xml.find(&key)?;
    let start = xml[..at].rfind("<ScalarVariable")?;
    let end = at + xml[at..].find("</ScalarVariable>")?;
    Some(&xml[start..end])
}

#[test]
fn every_row_is_validated_by_the_model_file() {
    for p in PARAMS {
        let mut m = Model::paper();
        (p.set)(&mut m, f64::NAN);
        let e = m.validate().expect_err(p.name);
        assert_eq!(e.path, p.path, "{}: {e}", p.name);
        // And the model file names the same field: a JSON with the value out of range is
        // rejected at that path.
        // (Writing a row's own value switches an unmodelled effect on, so its section exists.)
        let mut on = Model::paper();
        (p.set)(&mut on, (p.get)(&Model::paper()));
        let mut v = serde_json::to_value(on).unwrap();
        let at = p.path.split('.').fold(&mut v, |j, k| &mut j[k]);
        assert!(at.is_number(), "{}: no number at {}", p.name, p.path);
        *at = (-1e300).into();
        let e = Model::from_json_str(&v.to_string(), "m.json").expect_err(p.name);
        assert_eq!(e.path, p.path, "{}: {e}", p.name);
    }
}

#[test]
fn every_fmu_row_is_an_fmu_parameter_with_its_unit_and_start() {
    let mut m = Model::paper();
    // Distinct start values, so a variable showing another row's value is caught.
    for (i, p) in PARAMS.iter().enumerate() {
        let v = (p.get)(&m) * (1.0 + 1e-3 * (i as f64 + 1.0));
        (p.set)(&mut m, v);
    }
    let xml = magswarm_fmu::model_description(&m, None);
    let mut vr = magswarm_fmu::vr::PARAM_BASE;
    for p in PARAMS {
        let var = scalar_variable(&xml, p.name);
        if !p.fmu {
            assert!(
                var.is_none(),
                "{} is marked fmu: false but is in the XML",
                p.name
            );
            continue;
        }
        let var = var.unwrap_or_else(|| panic!("{} missing from the FMU's XML", p.name));
        assert!(
            var.contains(&format!("valueReference=\"{vr}\"")),
            "{}: expected value reference {vr}: {var}",
            p.name
        );
        assert!(var.contains("causality=\"parameter\""), "{var}");
        match p.unit {
            Some(u) => {
                assert!(var.contains(&format!("unit=\"{u}\"")), "{var}");
                assert!(
                    xml.contains(&format!("<Unit name=\"{u}\"")),
                    "{}: unit {u} has no unit definition",
                    p.name
                );
            }
            None => assert!(!var.contains("unit="), "{var}"),
        }
        let start = var
            .split("start=\"")
            .nth(1)
            .and_then(|s| s.split('"').next())
            .and_then(|s| s.parse::<f64>().ok())
            .unwrap_or_else(|| panic!("{}: no start value: {var}", p.name));
        assert_eq!(start, (p.get)(&m), "{}", p.name);
        vr += 1;
    }
    // And nothing else sits in the parameter range of value references.
    assert!(
        !xml.contains(&format!("valueReference=\"{vr}\"")),
        "the FMU has a parameter at {vr} that is not in the registry"
    );
}

#[test]
fn every_fittable_row_is_known_to_identify_and_no_other() {
    for p in PARAMS {
        let def = params::def(p.name);
        match p.fit {
            Some(f) => {
                let d = def.unwrap_or_else(|| panic!("identify does not know {}", p.name));
                assert_eq!((d.lo, d.hi, d.transform), (f.lo, f.hi, f.transform));
                assert_eq!(d.group, p.group);
                let free = params::Free::new(p.name).unwrap();
                let mut m = Model::paper();
                let theta = (f.lo + f.hi) / 2.0;
                params::set(&mut m, free.name(), theta);
                assert_eq!((p.get)(&m), theta, "{}", p.name);
            }
            None => assert!(
                def.is_none(),
                "identify frees {} without fit bounds",
                p.name
            ),
        }
        // Every row, fittable or not, can be read by name (fixed parameters are reported).
        assert_eq!(
            params::get(&Model::paper(), p.name),
            (p.get)(&Model::paper())
        );
    }
    assert_eq!(params::PARAMS.len(), registry::fittable().count());
    for n in params::DEFAULT_FREE_STEADY
        .iter()
        .chain(params::DEFAULT_FREE_DYNAMIC)
    {
        assert!(registry::find(n).and_then(|p| p.fit).is_some(), "{n}");
    }
}
