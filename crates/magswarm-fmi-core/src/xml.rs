//! The parts of `modelDescription.xml` that FMI 2.0 and 3.0 write the same way: unit
//! definitions, log categories, the default experiment, and the options (generation time,
//! baked start values) both writers take.
//!
//! The XML is generated, never hand-written, so names, value references, units and the
//! model structure always match what the binary does, and the GUID (a hash of the same
//! table, see [`mod@crate::guid`]) always matches the binary's check at instantiation.

use quick_xml::events::{BytesEnd, BytesStart, Event};
use quick_xml::Writer;

use crate::info::{ModelInfo, UnitDefinition};
use crate::log::all_categories;
use crate::model::FmuModel;
use crate::variable::{fmt_real, Start};

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

impl XmlOptions {
    /// The start value to write for the variable with value reference `vr` whose table
    /// start is `table` (the last override wins).
    pub fn start_of<'a>(&'a self, vr: u32, table: Option<&'a Start>) -> Option<&'a Start> {
        self.start_overrides
            .iter()
            .rev()
            .find(|(v, _)| *v == vr)
            .map(|(_, s)| s)
            .or(table)
    }
}

/// What the XML declares beside the variables: the interfaces and the optional functions
/// (from the model's [`FmuModel`] constants).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Capabilities {
    /// A `<ModelExchange>` element beside `<CoSimulation>`.
    pub model_exchange: bool,
    /// `canGetAndSetFMUstate` and `canSerializeFMUstate`.
    pub fmu_state: bool,
    /// `providesDirectionalDerivative(s)` (and FMI 3.0's `providesAdjointDerivatives`).
    pub directional_derivative: bool,
}

impl Capabilities {
    /// Everything: Model Exchange, FMU state, derivatives.
    pub const ALL: Capabilities = Capabilities {
        model_exchange: true,
        fmu_state: true,
        directional_derivative: true,
    };

    /// Co-Simulation only, with FMU state and derivatives.
    pub const CO_SIMULATION: Capabilities = Capabilities {
        model_exchange: false,
        ..Capabilities::ALL
    };

    /// What model `M` declares.
    pub fn of<M: FmuModel>() -> Capabilities {
        Capabilities {
            model_exchange: M::MODEL_EXCHANGE,
            fmu_state: M::CAN_GET_AND_SET_FMU_STATE,
            directional_derivative: M::PROVIDES_DIRECTIONAL_DERIVATIVE,
        }
    }
}

/// `"true"` / `"false"`.
pub fn b(x: bool) -> &'static str {
    if x {
        "true"
    } else {
        "false"
    }
}

/// Every problem with the start overrides of `options` for the table of `info`.
pub fn check_overrides(info: &ModelInfo, options: &XmlOptions) -> Result<(), Vec<String>> {
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
    if problems.is_empty() {
        Ok(())
    } else {
        Err(problems)
    }
}

/// The attributes of `<fmiModelDescription>` that both versions share, after `fmiVersion`,
/// `modelName` and the GUID / instantiation token the writer puts first.
pub fn push_root_attributes(root: &mut BytesStart<'_>, info: &ModelInfo, options: &XmlOptions) {
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
            crate::info::NamingConvention::Flat => "flat",
            crate::info::NamingConvention::Structured => "structured",
        },
    ));
}

/// `<UnitDefinitions>` (nothing if the model has no units). With `ampere_kelvin = false`
/// a unit whose SI decomposition has an ampere or kelvin exponent gets no `<BaseUnit>`
/// (which both standards make optional): the FMI 3.0 writer does that because rust-fmi's
/// XML schema (`fmi-schema` 0.8, used by `fmi-sim` and the `fmi` crate) spells those two
/// attributes `a` and `k` and rejects the standard's `A` and `K`, so it could not load the
/// FMU at all.
pub fn write_unit_definitions(
    w: &mut Writer<Vec<u8>>,
    info: &ModelInfo,
    ampere_kelvin: bool,
) -> std::io::Result<()> {
    if info.units.is_empty() {
        return Ok(());
    }
    w.write_event(Event::Start(BytesStart::new("UnitDefinitions")))?;
    for u in info.units {
        let mut e = BytesStart::new("Unit");
        e.push_attribute(("name", u.name));
        w.write_event(Event::Start(e))?;
        let bx = &u.base;
        if !ampere_kelvin && (bx.a != 0 || bx.k != 0) {
            write_display_units(w, u)?;
            w.write_event(Event::End(BytesEnd::new("Unit")))?;
            continue;
        }
        let mut bu = BytesStart::new("BaseUnit");
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
        write_display_units(w, u)?;
        w.write_event(Event::End(BytesEnd::new("Unit")))?;
    }
    w.write_event(Event::End(BytesEnd::new("UnitDefinitions")))
}

fn write_display_units(w: &mut Writer<Vec<u8>>, u: &UnitDefinition) -> std::io::Result<()> {
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
    Ok(())
}

/// `<LogCategories>`: the shell's categories, then the model's.
pub fn write_log_categories(w: &mut Writer<Vec<u8>>, info: &ModelInfo) -> std::io::Result<()> {
    w.write_event(Event::Start(BytesStart::new("LogCategories")))?;
    for c in all_categories(info.log_categories) {
        let mut e = BytesStart::new("Category");
        e.push_attribute(("name", c.name));
        if !c.description.is_empty() {
            e.push_attribute(("description", c.description));
        }
        w.write_event(Event::Empty(e))?;
    }
    w.write_event(Event::End(BytesEnd::new("LogCategories")))
}

/// `<DefaultExperiment>` (nothing if the model has none).
pub fn write_default_experiment(w: &mut Writer<Vec<u8>>, info: &ModelInfo) -> std::io::Result<()> {
    let Some(de) = &info.default_experiment else {
        return Ok(());
    };
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
    w.write_event(Event::Empty(e))
}

/// Space-separated numbers (indices or value references) for `dependencies`.
pub fn join<T: std::fmt::Display>(v: &[T]) -> String {
    v.iter()
        .map(|i| i.to_string())
        .collect::<Vec<_>>()
        .join(" ")
}
