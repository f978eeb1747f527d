//! FMI 2.0 `modelDescription.xml` from the variable table (the parts FMI 3.0 writes the
//! same way are [`magswarm_fmi_core::xml`]'s).
//!
//! Generated, never hand-written, so that names, value references, units and the
//! ModelStructure always match what the binary does, and the GUID (a hash of the same
//! table, see [`mod@magswarm_fmi_core::guid`]) always matches the binary's check in
//! `fmi2Instantiate`.
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

use magswarm_fmi_core::guid::guid_of;
use magswarm_fmi_core::table::{is_initial_unknown, state_vrs, validate};
use magswarm_fmi_core::xml::{self as common, b, check_overrides, join};
use magswarm_fmi_core::{fmt_real, Causality, FmuModel, ModelInfo, Variable};

pub use magswarm_fmi_core::xml::{Capabilities, XmlOptions};

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
    model_description_xml_with(M::model_info(), options, Capabilities::of::<M>())
}

/// Non-generic core of [`model_description_xml`].
pub fn model_description_xml_for(
    info: &ModelInfo,
    options: &XmlOptions,
) -> Result<String, Vec<String>> {
    model_description_xml_with(info, options, Capabilities::CO_SIMULATION)
}

/// [`model_description_xml_for`] with the capabilities `caps` (a `<ModelExchange>` element
/// beside `<CoSimulation>`, FMU state, directional derivatives).
pub fn model_description_xml_with(
    info: &ModelInfo,
    options: &XmlOptions,
    caps: Capabilities,
) -> Result<String, Vec<String>> {
    validate(info)?;
    check_overrides(info, options)?;
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
    common::push_root_attributes(&mut root, info, options);
    root.push_attribute(("numberOfEventIndicators", "0"));
    w.write_event(Event::Start(root))?;

    // Capabilities: what the shell implements and the model declares.
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

    common::write_unit_definitions(&mut w, info, true)?;
    common::write_log_categories(&mut w, info)?;
    common::write_default_experiment(&mut w, info)?;

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
    let start = options.start_of(v.vr, v.start.as_ref());
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
        e.push_attribute(("dependencies", join(&d).as_str()));
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
        .filter(|(_, v)| v.causality == Causality::Output)
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
