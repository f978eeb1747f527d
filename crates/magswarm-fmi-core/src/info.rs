//! Static facts about a model beside its variables: units, log categories, the default
//! experiment and the [`ModelInfo`] that gathers them with the variable table.

use crate::variable::Variable;

/// SI base-unit exponents and the factor/offset to the SI unit (`<BaseUnit>`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaseUnit {
    /// kilogram exponent.
    pub kg: i32,
    /// metre exponent.
    pub m: i32,
    /// second exponent.
    pub s: i32,
    /// ampere exponent.
    pub a: i32,
    /// kelvin exponent.
    pub k: i32,
    /// mole exponent.
    pub mol: i32,
    /// candela exponent.
    pub cd: i32,
    /// radian exponent.
    pub rad: i32,
    /// value_SI = factor * value + offset.
    pub factor: f64,
    /// value_SI = factor * value + offset.
    pub offset: f64,
}

impl BaseUnit {
    /// Dimensionless, factor 1.
    pub const ONE: BaseUnit = BaseUnit {
        kg: 0,
        m: 0,
        s: 0,
        a: 0,
        k: 0,
        mol: 0,
        cd: 0,
        rad: 0,
        factor: 1.0,
        offset: 0.0,
    };
}

/// A display unit: value_display = factor * value + offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DisplayUnit {
    /// Name, e.g. `mm`.
    pub name: &'static str,
    /// Multiplier from the unit to the display unit (1000 for m → mm).
    pub factor: f64,
    /// Offset (e.g. K → degC).
    pub offset: f64,
}

/// `<Unit>`: a unit with its base-unit exponents and display units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnitDefinition {
    /// Name used in the `unit` attribute of variables.
    pub name: &'static str,
    /// SI decomposition.
    pub base: BaseUnit,
    /// Display units of this unit.
    pub display_units: &'static [DisplayUnit],
}

/// A log category the model may log under (beside the shell's own).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LogCategory {
    /// Category name passed to the logger.
    pub name: &'static str,
    /// Description in `<LogCategories>`.
    pub description: &'static str,
}

/// `<DefaultExperiment>`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DefaultExperiment {
    /// `startTime`.
    pub start_time: Option<f64>,
    /// `stopTime`.
    pub stop_time: Option<f64>,
    /// `tolerance`.
    pub tolerance: Option<f64>,
    /// `stepSize`.
    pub step_size: Option<f64>,
}

/// `variableNamingConvention`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NamingConvention {
    /// Any names (fmpy validates "structured" names with an extra parser: flat avoids that).
    #[default]
    Flat,
    /// Modelica-style names (`a.b[1]`, `der(x)`).
    Structured,
}

/// Everything static about a model: metadata, units, log categories and the variable table.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelInfo {
    /// `modelIdentifier`: also the shared library's file name without extension.
    pub model_identifier: &'static str,
    /// `modelName`.
    pub model_name: &'static str,
    /// `description`.
    pub description: &'static str,
    /// `version`: pass the implementing crate's `env!("CARGO_PKG_VERSION")`.
    pub version: &'static str,
    /// `author`.
    pub author: &'static str,
    /// `copyright` (optional).
    pub copyright: Option<&'static str>,
    /// `license` (optional).
    pub license: Option<&'static str>,
    /// `generationTool`.
    pub generation_tool: &'static str,
    /// `variableNamingConvention`.
    pub naming_convention: NamingConvention,
    /// `<DefaultExperiment>` (omitted if `None`).
    pub default_experiment: Option<DefaultExperiment>,
    /// `<UnitDefinitions>`.
    pub units: &'static [UnitDefinition],
    /// Model-specific log categories (the shell adds its own, see [`crate::log`]).
    pub log_categories: &'static [LogCategory],
    /// The variable table, in `<ModelVariables>` order (index = position + 1).
    pub variables: &'static [Variable],
}
