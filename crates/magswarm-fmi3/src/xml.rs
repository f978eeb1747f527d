//! FMI 3.0 `modelDescription.xml` from the variable table (the parts FMI 2.0 writes the
//! same way are [`magswarm_fmi_core::xml`]'s).
//!
//! Differences from FMI 2.0 that matter here: variables are elements named by their type
//! (`<Float64>`, `<Int32>`, `<Boolean>`, `<String>` with a `<Start>` child) instead of
//! `<ScalarVariable>`; `derivative` and the model structure refer to value references, not
//! indices; the GUID is the `instantiationToken`; the independent variable `time` is
//! required (it is added to the table if the model has none, as the shell does); the
//! capability flags are spelled `canGetAndSetFMUState`, `providesDirectionalDerivatives`,
//! and there are adjoint derivatives.
//!
//! Units, display units and nominals go through `<TypeDefinitions>`: one `<Float64Type>` per
//! (unit, display unit, nominal) the table uses, named by them, and `declaredType` on the
//! variable. FMI 3.0 allows the attributes on the variable itself too, but rust-fmi's XML
//! schema (`fmi-schema` 0.8: `fmi-sim`, the `fmi` crate) refuses them there, while every
//! importer resolves a declared type; so the one form all of them load is this one.

use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, Event};
use quick_xml::Writer;

use magswarm_fmi_core::guid::guid_of;
use magswarm_fmi_core::table::{is_initial_unknown, state_vrs, validate};
use magswarm_fmi_core::xml::{self as common, b, check_overrides, join};
use magswarm_fmi_core::{fmt_real, Causality, FmuModel, ModelInfo, Start, VarType, Variable};

pub use magswarm_fmi_core::xml::{Capabilities, XmlOptions};

use crate::shell::{info_of, type_name};

/// The FMI 3.0 modelDescription.xml of model `M`. Panics with every problem listed if the
/// table is invalid (a programming error that must stop packaging); see
/// [`try_model_description_xml`] for a `Result`.
pub fn model_description_xml<M: FmuModel>(options: &XmlOptions) -> String {
    match try_model_description_xml::<M>(options) {
        Ok(s) => s,
        Err(p) => panic!("invalid FMU variable table:\n  - {}", p.join("\n  - ")),
    }
}

/// The FMI 3.0 modelDescription.xml of model `M`, or the list of problems with its table.
pub fn try_model_description_xml<M: FmuModel>(options: &XmlOptions) -> Result<String, Vec<String>> {
    model_description_xml_with(info_of::<M>(), options, Capabilities::of::<M>())
}

/// The FMI 3.0 modelDescription.xml of a table (which must have its independent variable:
/// see [`magswarm_fmi_core::table::with_independent_time`]) with the capabilities `caps`.
pub fn model_description_xml_with(
    info: &ModelInfo,
    options: &XmlOptions,
    caps: Capabilities,
) -> Result<String, Vec<String>> {
    validate(info)?;
    check_overrides(info, options)?;
    if !info
        .variables
        .iter()
        .any(|v| v.causality == Causality::Independent)
    {
        return Err(vec![
            "FMI 3.0 needs exactly one independent variable (add it with \
             magswarm_fmi_core::table::with_independent_time)"
                .into(),
        ]);
    }
    write_xml(info, options, caps).map_err(|e| vec![format!("XML writer error: {e}")])
}

fn write_xml(
    info: &ModelInfo,
    options: &XmlOptions,
    caps: Capabilities,
) -> std::io::Result<String> {
    let mut w = Writer::new_with_indent(Vec::new(), b' ', 2);
    w.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))?;

    let token = guid_of(info);
    let mut root = BytesStart::new("fmiModelDescription");
    root.push_attribute(("fmiVersion", "3.0"));
    root.push_attribute(("modelName", info.model_name));
    root.push_attribute(("instantiationToken", token.as_str()));
    common::push_root_attributes(&mut root, info, options);
    w.write_event(Event::Start(root))?;

    // Capabilities: what the shell implements and the model declares.
    let (state, dd) = (b(caps.fmu_state), b(caps.directional_derivative));
    if caps.model_exchange {
        let mut me = BytesStart::new("ModelExchange");
        me.push_attribute(("modelIdentifier", info.model_identifier));
        me.push_attribute(("canBeInstantiatedOnlyOncePerProcess", b(false)));
        me.push_attribute(("canGetAndSetFMUState", state));
        me.push_attribute(("canSerializeFMUState", state));
        me.push_attribute(("providesDirectionalDerivatives", dd));
        me.push_attribute(("providesAdjointDerivatives", dd));
        me.push_attribute(("needsCompletedIntegratorStep", b(false)));
        w.write_event(Event::Empty(me))?;
    }
    let mut cs = BytesStart::new("CoSimulation");
    cs.push_attribute(("modelIdentifier", info.model_identifier));
    cs.push_attribute(("canBeInstantiatedOnlyOncePerProcess", b(false)));
    cs.push_attribute(("canGetAndSetFMUState", state));
    cs.push_attribute(("canSerializeFMUState", state));
    cs.push_attribute(("providesDirectionalDerivatives", dd));
    cs.push_attribute(("providesAdjointDerivatives", dd));
    cs.push_attribute(("canHandleVariableCommunicationStepSize", b(true)));
    cs.push_attribute(("maxOutputDerivativeOrder", "0"));
    w.write_event(Event::Empty(cs))?;

    common::write_unit_definitions(&mut w, info, false)?;
    let types = float_types(info);
    if !types.is_empty() {
        w.write_event(Event::Start(BytesStart::new("TypeDefinitions")))?;
        for t in &types {
            let mut e = BytesStart::new("Float64Type");
            e.push_attribute(("name", t.name().as_str()));
            if let Some(u) = t.unit {
                e.push_attribute(("unit", u));
            }
            if let Some(d) = t.display_unit {
                e.push_attribute(("displayUnit", d));
            }
            if let Some(n) = t.nominal {
                e.push_attribute(("nominal", fmt_real(n).as_str()));
            }
            w.write_event(Event::Empty(e))?;
        }
        w.write_event(Event::End(BytesEnd::new("TypeDefinitions")))?;
    }
    common::write_log_categories(&mut w, info)?;
    common::write_default_experiment(&mut w, info)?;

    w.write_event(Event::Start(BytesStart::new("ModelVariables")))?;
    for v in info.variables {
        write_variable(&mut w, options, v)?;
    }
    w.write_event(Event::End(BytesEnd::new("ModelVariables")))?;

    write_model_structure(&mut w, info)?;

    w.write_event(Event::End(BytesEnd::new("fmiModelDescription")))?;
    let mut s = String::from_utf8(w.into_inner()).expect("the writer only writes UTF-8");
    s.push('\n');
    Ok(s)
}

/// The declared type of a Float64 variable: its unit, display unit and nominal.
#[derive(Debug, Clone, Copy, PartialEq)]
struct FloatType {
    unit: Option<&'static str>,
    display_unit: Option<&'static str>,
    nominal: Option<f64>,
}

impl FloatType {
    fn of(v: &Variable) -> Option<FloatType> {
        let t = FloatType {
            unit: v.unit,
            display_unit: v.display_unit,
            nominal: v.nominal,
        };
        (v.ty == VarType::Real && t != FloatType::NONE).then_some(t)
    }

    const NONE: FloatType = FloatType {
        unit: None,
        display_unit: None,
        nominal: None,
    };

    /// A readable unique name: `m`, `m in mm`, `m in mm, nominal 0.01`.
    fn name(&self) -> String {
        let mut n = self.unit.unwrap_or("1").to_string();
        if let Some(d) = self.display_unit {
            n.push_str(&format!(" in {d}"));
        }
        if let Some(x) = self.nominal {
            n.push_str(&format!(", nominal {}", fmt_real(x)));
        }
        n
    }
}

/// The distinct declared types of the table's Float64 variables, in order of first use.
fn float_types(info: &ModelInfo) -> Vec<FloatType> {
    let mut out: Vec<FloatType> = Vec::new();
    for t in info.variables.iter().filter_map(FloatType::of) {
        if !out.contains(&t) {
            out.push(t);
        }
    }
    out
}

fn write_variable(
    w: &mut Writer<Vec<u8>>,
    options: &XmlOptions,
    v: &Variable,
) -> std::io::Result<()> {
    let mut e = BytesStart::new(type_name(v.ty));
    e.push_attribute(("name", v.name));
    e.push_attribute(("valueReference", v.vr.to_string().as_str()));
    if !v.description.is_empty() {
        e.push_attribute(("description", v.description));
    }
    e.push_attribute(("causality", v.causality.as_str()));
    e.push_attribute(("variability", v.variability.as_str()));
    if let Some(init) = v.effective_initial() {
        e.push_attribute(("initial", init.as_str()));
    }
    if let Some(t) = FloatType::of(v) {
        e.push_attribute(("declaredType", t.name().as_str()));
    }
    for (k, x) in [("min", v.min), ("max", v.max)] {
        if let Some(x) = x {
            e.push_attribute((k, fmt_real(x).as_str()));
        }
    }
    let start = options.start_of(v.vr, v.start.as_ref());
    if let Some(state) = v.derivative_of {
        e.push_attribute(("derivative", state.to_string().as_str()));
    }
    match (v.ty, start) {
        // A String's start value is a child element in FMI 3.0.
        (VarType::String, Some(s)) => {
            w.write_event(Event::Start(e))?;
            let mut st = BytesStart::new("Start");
            st.push_attribute(("value", s.to_xml_text().as_str()));
            w.write_event(Event::Empty(st))?;
            w.write_event(Event::End(BytesEnd::new(type_name(v.ty))))
        }
        (_, Some(s)) => {
            let text = match s {
                Start::Boolean(x) => b(*x).to_string(),
                s => s.to_xml_text(),
            };
            e.push_attribute(("start", text.as_str()));
            w.write_event(Event::Empty(e))
        }
        (_, None) => w.write_event(Event::Empty(e)),
    }
}

fn write_unknown(
    w: &mut Writer<Vec<u8>>,
    element: &str,
    vr: u32,
    deps: Option<Vec<u32>>,
) -> std::io::Result<()> {
    let mut e = BytesStart::new(element);
    e.push_attribute(("valueReference", vr.to_string().as_str()));
    if let Some(mut d) = deps {
        d.sort_unstable();
        d.dedup();
        e.push_attribute(("dependencies", join(&d).as_str()));
    }
    w.write_event(Event::Empty(e))
}

fn write_model_structure(w: &mut Writer<Vec<u8>>, info: &ModelInfo) -> std::io::Result<()> {
    let states = state_vrs(info);
    let vars = info.variables;
    w.write_event(Event::Start(BytesStart::new("ModelStructure")))?;
    for v in vars.iter().filter(|v| v.causality == Causality::Output) {
        write_unknown(w, "Output", v.vr, v.dependencies.map(<[u32]>::to_vec))?;
    }
    for v in vars.iter().filter(|v| v.derivative_of.is_some()) {
        write_unknown(
            w,
            "ContinuousStateDerivative",
            v.vr,
            v.dependencies.map(<[u32]>::to_vec),
        )?;
    }
    for v in vars.iter().filter(|v| is_initial_unknown(v, &states)) {
        write_unknown(
            w,
            "InitialUnknown",
            v.vr,
            v.initial_dependencies.map(<[u32]>::to_vec),
        )?;
    }
    w.write_event(Event::End(BytesEnd::new("ModelStructure")))
}
