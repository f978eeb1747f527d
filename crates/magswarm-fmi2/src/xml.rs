//! `modelDescription.xml` from the variable table.
//!
//! Generated, never hand-written, so that names, value references, units and the
//! ModelStructure always match what the binary does, and the GUID (a hash of the same
//! table, see [`mod@crate::guid`]) always matches the binary's check in `fmi2Instantiate`.
//!
//! Choices that keep strict importers (FMI Library / libcosim, fmpy's `validate_fmu`) happy:
//! - `initial` is written explicitly wherever the standard allows it, so no tool has to
//!   know the defaults table to find the InitialUnknowns;
//! - `start` is written exactly where it is required, never where it is forbidden;
//! - ModelStructure lists every output, every state derivative, and exactly the initial
//!   unknowns of section 2.2.8, with 1-based indices sorted ascending; `dependencies` is
//!   omitted (= "depends on all knowns") where the table does not state them, and `""` is
//!   written for an explicit empty list;
//! - Reals are written in the shortest form that parses back to the same `f64`.

use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, Event};
use quick_xml::Writer;

use crate::guid::guid_of;
use crate::log::all_categories;
use crate::model::{fmt_real, FmuModel, ModelInfo, Start, Variable};
use crate::table::{is_initial_unknown, state_vrs, validate};

/// Options that change the XML without changing the GUID.
#[derive(Debug, Clone, Default)]
pub struct XmlOptions {
    /// `generationDateAndTime` (an `xs:dateTime` such as `2025-01-31T12:00:00Z`); omitted if `None`.
    pub generation_date_and_time: Option<String>,
    /// Start values to write instead of the table's, by value reference (for FMUs whose
    /// resources bake in other defaults: the model must then start from these values too).
    /// Only variables that have a start value in the table can be overridden.
    pub start_overrides: Vec<(u32, Start)>,
}

/// The modelDescription.xml of model `M`. Panics with every problem listed if the table
/// is invalid (a programming error that must stop packaging); see
/// [`try_model_description_xml`] for a `Result`.
pub fn model_description_xml<M: FmuModel>(options: &XmlOptions) -> String {
    match try_model_description_xml::<M>(options) {
        Ok(s) => s,
        Err(p) => panic!("invalid FMU variable table:\n  - {}", p.join("\n  - ")),
    }
}

/// The modelDescription.xml of model `M`, or the list of problems with its table.
pub fn try_model_description_xml<M: FmuModel>(options: &XmlOptions) -> Result<String, Vec<String>> {
    let caps = Capabilities {
        model_exchange: M::MODEL_EXCHANGE,
        fmu_state: M::CAN_GET_AND_SET_FMU_STATE,
        directional_derivative: M::PROVIDES_DIRECTIONAL_DERIVATIVE,
    };
    model_description_xml_caps(M::model_info(), options, caps)
}

/// What the XML declares beside the variables: the interfaces and the optional functions
/// (from the model's [`FmuModel`] constants).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Capabilities {
    /// A `<ModelExchange>` element beside `<CoSimulation>`.
    pub model_exchange: bool,
    /// `canGetAndSetFMUstate` and `canSerializeFMUstate`.
    pub fmu_state: bool,
    /// `providesDirectionalDerivative`.
    pub directional_derivative: bool,
}

fn b(x: bool) -> &'static str {
    if x {
        "true"
    } else {
        "false"
    }
}

fn join_indices(v: &[usize]) -> String {
    v.iter()
        .map(|i| i.to_string())
        .collect::<Vec<_>>()
        .join(" ")
}

/// Non-generic core of [`model_description_xml`].
pub fn model_description_xml_for(
    info: &ModelInfo,
    options: &XmlOptions,
) -> Result<String, Vec<String>> {
    model_description_xml_with(info, options, false)
}

/// [`model_description_xml_for`], with a `<ModelExchange>` element beside `<CoSimulation>`
/// when `model_exchange` (the model's [`FmuModel::MODEL_EXCHANGE`]).
pub fn model_description_xml_with(
    info: &ModelInfo,
    options: &XmlOptions,
    model_exchange: bool,
) -> Result<String, Vec<String>> {
    let caps = Capabilities {
        model_exchange,
        fmu_state: true,
        directional_derivative: true,
    };
    model_description_xml_caps(info, options, caps)
}

/// [`model_description_xml_with`] with every capability given.
pub fn model_description_xml_caps(
    info: &ModelInfo,
    options: &XmlOptions,
    caps: Capabilities,
) -> Result<String, Vec<String>> {
    validate(info)?;
    let mut problems = Vec::new();
    for (vr, start) in &options.start_overrides {
        match info.variables.iter().find(|v| v.vr == *vr) {
            None => problems.push(format!("start override for unknown value reference {vr}")),
            Some(v) if v.start.is_none() => problems.push(format!(
                "start override for \"{}\", which has no start value in the table",
                v.name
            )),
            Some(v) if start.var_type() != v.ty => problems.push(format!(
                "start override for \"{}\" is not of type {}",
                v.name,
                v.ty.as_str()
            )),
            Some(v) => {
                if let Start::Real(x) = start {
                    if !x.is_finite() {
                        problems.push(format!("start override for \"{}\" is not finite", v.name));
                    }
                }
            }
        }
    }
    if !problems.is_empty() {
        return Err(problems);
    }
    write_xml(info, options, caps).map_err(|e| vec![format!("XML writer error: {e}")])
}

fn index_of(info: &ModelInfo, vr: u32) -> usize {
    info.variables
        .iter()
        .position(|v| v.vr == vr)
        .expect("validated reference")
        + 1
}

fn sorted_indices(info: &ModelInfo, vrs: &[u32]) -> Vec<usize> {
    let mut v: Vec<usize> = vrs.iter().map(|&vr| index_of(info, vr)).collect();
    v.sort_unstable();
    v.dedup();
    v
}

fn write_xml(
    info: &ModelInfo,
    options: &XmlOptions,
    caps: Capabilities,
) -> std::io::Result<String> {
    let mut w = Writer::new_with_indent(Vec::new(), b' ', 2);
    w.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))?;

    let guid = guid_of(info);
    let mut root = BytesStart::new("fmiModelDescription");
    root.push_attribute(("fmiVersion", "2.0"));
    root.push_attribute(("modelName", info.model_name));
    root.push_attribute(("guid", guid.as_str()));
    if !info.description.is_empty() {
        root.push_attribute(("description", info.description));
    }
    if !info.author.is_empty() {
        root.push_attribute(("author", info.author));
    }
    if !info.version.is_empty() {
        root.push_attribute(("version", info.version));
    }
    if let Some(c) = info.copyright {
        root.push_attribute(("copyright", c));
    }
    if let Some(l) = info.license {
        root.push_attribute(("license", l));
    }
    if !info.generation_tool.is_empty() {
        root.push_attribute(("generationTool", info.generation_tool));
    }
    if let Some(d) = &options.generation_date_and_time {
        root.push_attribute(("generationDateAndTime", d.as_str()));
    }
    root.push_attribute((
        "variableNamingConvention",
        match info.naming_convention {
            crate::model::NamingConvention::Flat => "flat",
            crate::model::NamingConvention::Structured => "structured",
        },
    ));
    root.push_attribute(("numberOfEventIndicators", "0"));
    w.write_event(Event::Start(root))?;

    // Capabilities: what the shell implements, identical for every model.
    let (state, dd) = (b(caps.fmu_state), b(caps.directional_derivative));
    if caps.model_exchange {
        let mut me = BytesStart::new("ModelExchange");
        me.push_attribute(("modelIdentifier", info.model_identifier));
        me.push_attribute(("needsExecutionTool", b(false)));
        me.push_attribute(("completedIntegratorStepNotNeeded", b(true)));
        me.push_attribute(("canBeInstantiatedOnlyOncePerProcess", b(false)));
        me.push_attribute(("canNotUseMemoryManagementFunctions", b(true)));
        me.push_attribute(("canGetAndSetFMUstate", state));
        me.push_attribute(("canSerializeFMUstate", state));
        me.push_attribute(("providesDirectionalDerivative", dd));
        w.write_event(Event::Empty(me))?;
    }
    let mut cs = BytesStart::new("CoSimulation");
    cs.push_attribute(("modelIdentifier", info.model_identifier));
    cs.push_attribute(("needsExecutionTool", b(false)));
    cs.push_attribute(("canHandleVariableCommunicationStepSize", b(true)));
    cs.push_attribute(("canInterpolateInputs", b(false)));
    cs.push_attribute(("maxOutputDerivativeOrder", "0"));
    cs.push_attribute(("canRunAsynchronuously", b(false)));
    cs.push_attribute(("canBeInstantiatedOnlyOncePerProcess", b(false)));
    cs.push_attribute(("canNotUseMemoryManagementFunctions", b(true)));
    cs.push_attribute(("canGetAndSetFMUstate", state));
    cs.push_attribute(("canSerializeFMUstate", state));
    cs.push_attribute(("providesDirectionalDerivative", dd));
    w.write_event(Event::Empty(cs))?;

    if !info.units.is_empty() {
        w.write_event(Event::Start(BytesStart::new("UnitDefinitions")))?;
        for u in info.units {
            let mut e = BytesStart::new("Unit");
            e.push_attribute(("name", u.name));
            w.write_event(Event::Start(e))?;
            let mut bu = BytesStart::new("BaseUnit");
            let bx = &u.base;
            for (k, x) in [
                ("kg", bx.kg),
                ("m", bx.m),
                ("s", bx.s),
                ("A", bx.a),
                ("K", bx.k),
                ("mol", bx.mol),
                ("cd", bx.cd),
                ("rad", bx.rad),
            ] {
                if x != 0 {
                    bu.push_attribute((k, x.to_string().as_str()));
                }
            }
            if bx.factor != 1.0 {
                bu.push_attribute(("factor", fmt_real(bx.factor).as_str()));
            }
            if bx.offset != 0.0 {
                bu.push_attribute(("offset", fmt_real(bx.offset).as_str()));
            }
            w.write_event(Event::Empty(bu))?;
            for d in u.display_units {
                let mut de = BytesStart::new("DisplayUnit");
                de.push_attribute(("name", d.name));
                if d.factor != 1.0 {
                    de.push_attribute(("factor", fmt_real(d.factor).as_str()));
                }
                if d.offset != 0.0 {
                    de.push_attribute(("offset", fmt_real(d.offset).as_str()));
                }
                w.write_event(Event::Empty(de))?;
            }
            w.write_event(Event::End(BytesEnd::new("Unit")))?;
        }
        w.write_event(Event::End(BytesEnd::new("UnitDefinitions")))?;
    }

    w.write_event(Event::Start(BytesStart::new("LogCategories")))?;
    for c in all_categories(info.log_categories) {
        let mut e = BytesStart::new("Category");
        e.push_attribute(("name", c.name));
        if !c.description.is_empty() {
            e.push_attribute(("description", c.description));
        }
        w.write_event(Event::Empty(e))?;
    }
    w.write_event(Event::End(BytesEnd::new("LogCategories")))?;

    if let Some(de) = &info.default_experiment {
        let mut e = BytesStart::new("DefaultExperiment");
        for (k, x) in [
            ("startTime", de.start_time),
            ("stopTime", de.stop_time),
            ("tolerance", de.tolerance),
            ("stepSize", de.step_size),
        ] {
            if let Some(x) = x {
                e.push_attribute((k, fmt_real(x).as_str()));
            }
        }
        w.write_event(Event::Empty(e))?;
    }

    w.write_event(Event::Start(BytesStart::new("ModelVariables")))?;
    for v in info.variables {
        write_variable(&mut w, info, options, v)?;
    }
    w.write_event(Event::End(BytesEnd::new("ModelVariables")))?;

    write_model_structure(&mut w, info)?;

    w.write_event(Event::End(BytesEnd::new("fmiModelDescription")))?;
    let mut s = String::from_utf8(w.into_inner()).expect("the writer only writes UTF-8");
    s.push('\n');
    Ok(s)
}

fn write_variable(
    w: &mut Writer<Vec<u8>>,
    info: &ModelInfo,
    options: &XmlOptions,
    v: &Variable,
) -> std::io::Result<()> {
    let mut sv = BytesStart::new("ScalarVariable");
    sv.push_attribute(("name", v.name));
    sv.push_attribute(("valueReference", v.vr.to_string().as_str()));
    if !v.description.is_empty() {
        sv.push_attribute(("description", v.description));
    }
    sv.push_attribute(("causality", v.causality.as_str()));
    sv.push_attribute(("variability", v.variability.as_str()));
    if let Some(init) = v.effective_initial() {
        sv.push_attribute(("initial", init.as_str()));
    }
    w.write_event(Event::Start(sv))?;

    let mut t = BytesStart::new(v.ty.as_str());
    if let Some(u) = v.unit {
        t.push_attribute(("unit", u));
    }
    if let Some(d) = v.display_unit {
        t.push_attribute(("displayUnit", d));
    }
    if let Some(x) = v.min {
        t.push_attribute(("min", fmt_real(x).as_str()));
    }
    if let Some(x) = v.max {
        t.push_attribute(("max", fmt_real(x).as_str()));
    }
    if let Some(x) = v.nominal {
        t.push_attribute(("nominal", fmt_real(x).as_str()));
    }
    let start = options
        .start_overrides
        .iter()
        .rev()
        .find(|(vr, _)| *vr == v.vr)
        .map(|(_, s)| s)
        .or(v.start.as_ref());
    if let Some(s) = start {
        t.push_attribute(("start", s.to_xml_text().as_str()));
    }
    if let Some(state) = v.derivative_of {
        t.push_attribute(("derivative", index_of(info, state).to_string().as_str()));
    }
    w.write_event(Event::Empty(t))?;
    w.write_event(Event::End(BytesEnd::new("ScalarVariable")))?;
    Ok(())
}

fn write_unknown(
    w: &mut Writer<Vec<u8>>,
    index: usize,
    deps: Option<Vec<usize>>,
) -> std::io::Result<()> {
    let mut e = BytesStart::new("Unknown");
    e.push_attribute(("index", index.to_string().as_str()));
    if let Some(d) = deps {
        e.push_attribute(("dependencies", join_indices(&d).as_str()));
    }
    w.write_event(Event::Empty(e))
}

fn write_model_structure(w: &mut Writer<Vec<u8>>, info: &ModelInfo) -> std::io::Result<()> {
    let states = state_vrs(info);
    let vars = info.variables;
    w.write_event(Event::Start(BytesStart::new("ModelStructure")))?;

    let outputs: Vec<(usize, &Variable)> = vars
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == crate::model::Causality::Output)
        .collect();
    if !outputs.is_empty() {
        w.write_event(Event::Start(BytesStart::new("Outputs")))?;
        for (i, v) in outputs {
            write_unknown(w, i + 1, v.dependencies.map(|d| sorted_indices(info, d)))?;
        }
        w.write_event(Event::End(BytesEnd::new("Outputs")))?;
    }

    let derivatives: Vec<(usize, &Variable)> = vars
        .iter()
        .enumerate()
        .filter(|(_, v)| v.derivative_of.is_some())
        .collect();
    if !derivatives.is_empty() {
        w.write_event(Event::Start(BytesStart::new("Derivatives")))?;
        for (i, v) in derivatives {
            write_unknown(w, i + 1, v.dependencies.map(|d| sorted_indices(info, d)))?;
        }
        w.write_event(Event::End(BytesEnd::new("Derivatives")))?;
    }

    let initial: Vec<(usize, &Variable)> = vars
        .iter()
        .enumerate()
        .filter(|(_, v)| is_initial_unknown(v, &states))
        .collect();
    if !initial.is_empty() {
        w.write_event(Event::Start(BytesStart::new("InitialUnknowns")))?;
        for (i, v) in initial {
            write_unknown(
                w,
                i + 1,
                v.initial_dependencies.map(|d| sorted_indices(info, d)),
            )?;
        }
        w.write_event(Event::End(BytesEnd::new("InitialUnknowns")))?;
    }

    w.write_event(Event::End(BytesEnd::new("ModelStructure")))?;
    Ok(())
}
