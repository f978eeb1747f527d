//! What a model provides: the static description (variable table, units, metadata) and
//! the [`FmuModel`] trait.
//!
//! The table is the single source of truth. The shell uses it to decide which calls are
//! legal (causality, variability, initial), to name variables in error messages and to
//! reject non-finite Reals; the XML generator writes `modelDescription.xml` from it; and the
//! GUID is a hash of it, so the XML and the binary cannot drift apart.
//!
//! Everything here is plain data with `const fn` builders, so a model can write its
//! table as a `static`. A model whose table needs run-time data (e.g. defaults computed
//! by the physics crate) can build it once in a `std::sync::LazyLock` and leak the vectors.

use serde::{de::DeserializeOwned, Serialize};
use std::fmt;
use std::path::Path;

use crate::abi::Fmi2Status;
use crate::log::Ctx;

/// FMI 2.0 base type of a scalar variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VarType {
    /// `<Real>`.
    Real,
    /// `<Integer>`.
    Integer,
    /// `<Boolean>`.
    Boolean,
    /// `<String>`.
    String,
}

impl VarType {
    /// The XML element name.
    pub fn as_str(self) -> &'static str {
        match self {
            VarType::Real => "Real",
            VarType::Integer => "Integer",
            VarType::Boolean => "Boolean",
            VarType::String => "String",
        }
    }
}

/// FMI 2.0 `causality`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Causality {
    /// Set by the importer before initialisation (or while stepping if tunable).
    Parameter,
    /// Computed from parameters during initialisation.
    CalculatedParameter,
    /// Set by the importer at communication points.
    Input,
    /// Read by the importer.
    Output,
    /// Internal but exposed for inspection.
    Local,
    /// The independent variable (time).
    Independent,
}

impl Causality {
    /// The XML attribute value.
    pub fn as_str(self) -> &'static str {
        match self {
            Causality::Parameter => "parameter",
            Causality::CalculatedParameter => "calculatedParameter",
            Causality::Input => "input",
            Causality::Output => "output",
            Causality::Local => "local",
            Causality::Independent => "independent",
        }
    }
}

/// FMI 2.0 `variability`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Variability {
    /// Never changes.
    Constant,
    /// Fixed after initialisation.
    Fixed,
    /// May be changed by the importer between steps (parameters only).
    Tunable,
    /// Changes only at events / communication points.
    Discrete,
    /// Changes continuously (Real only).
    Continuous,
}

impl Variability {
    /// The XML attribute value.
    pub fn as_str(self) -> &'static str {
        match self {
            Variability::Constant => "constant",
            Variability::Fixed => "fixed",
            Variability::Tunable => "tunable",
            Variability::Discrete => "discrete",
            Variability::Continuous => "continuous",
        }
    }
}

/// FMI 2.0 `initial`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Initial {
    /// Initialised with the start value.
    Exact,
    /// The start value is a guess; the model may change it during initialisation.
    Approx,
    /// Computed by the model; no start value.
    Calculated,
}

impl Initial {
    /// The XML attribute value.
    pub fn as_str(self) -> &'static str {
        match self {
            Initial::Exact => "exact",
            Initial::Approx => "approx",
            Initial::Calculated => "calculated",
        }
    }
}

/// A start value. Its variant must match the variable's [`VarType`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Start {
    /// For Real variables (must be finite).
    Real(f64),
    /// For Integer variables.
    Integer(i32),
    /// For Boolean variables.
    Boolean(bool),
    /// For String variables.
    String(&'static str),
}

impl Start {
    /// The base type this start value belongs to.
    pub fn var_type(&self) -> VarType {
        match self {
            Start::Real(_) => VarType::Real,
            Start::Integer(_) => VarType::Integer,
            Start::Boolean(_) => VarType::Boolean,
            Start::String(_) => VarType::String,
        }
    }

    /// The text written into the XML `start` attribute (Reals round-trip exactly).
    pub fn to_xml_text(&self) -> String {
        match self {
            Start::Real(x) => fmt_real(*x),
            Start::Integer(i) => i.to_string(),
            Start::Boolean(b) => b.to_string(),
            Start::String(s) => (*s).to_string(),
        }
    }
}

/// Shortest text that parses back to the same `f64` and is a valid `xs:double`
/// (Rust's `Debug` gives `1e-7` rather than `0.0000001`).
pub fn fmt_real(x: f64) -> String {
    format!("{x:?}")
}

/// One row of the variable table: everything `<ScalarVariable>` and `<ModelStructure>` need.
///
/// Build it with the `const fn` helpers, e.g.
/// `Variable::real("z_m", 0).input().start_real(0.0085).unit("m").display_unit("mm")`.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// Unique variable name.
    pub name: &'static str,
    /// Value reference. Unique across *all* types in this shell, so that dependencies
    /// (given as value references) are unambiguous.
    pub vr: u32,
    /// Base type.
    pub ty: VarType,
    /// Causality.
    pub causality: Causality,
    /// Variability.
    pub variability: Variability,
    /// `initial`; `None` means the standard's default for the causality/variability pair
    /// (the XML always writes the effective value where the attribute is allowed).
    pub initial: Option<Initial>,
    /// Human-readable description (may be empty).
    pub description: &'static str,
    /// Unit (Real only); must be one of the model's [`UnitDefinition`]s.
    pub unit: Option<&'static str>,
    /// Display unit (Real only); must be a display unit of `unit`.
    pub display_unit: Option<&'static str>,
    /// Start value; required for inputs, parameters and `initial` exact/approx, forbidden
    /// for `initial="calculated"` and the independent variable.
    pub start: Option<Start>,
    /// `min` attribute (Real only). Documentation for importers; the shell does not enforce it.
    pub min: Option<f64>,
    /// `max` attribute (Real only). Documentation for importers; the shell does not enforce it.
    pub max: Option<f64>,
    /// `nominal` attribute (Real only).
    pub nominal: Option<f64>,
    /// For outputs and state derivatives: value references of the inputs/states this
    /// variable depends on while stepping (`ModelStructure/Outputs` and `Derivatives`).
    /// `None` writes no `dependencies` attribute, which means "depends on everything".
    pub dependencies: Option<&'static [u32]>,
    /// For initial unknowns: value references of the knowns (inputs, parameters, exact
    /// variables) this variable depends on during initialisation. `None` (the safe
    /// default) writes no `dependencies` attribute.
    pub initial_dependencies: Option<&'static [u32]>,
    /// If this variable is the derivative of a continuous state: that state's value reference.
    pub derivative_of: Option<u32>,
}

impl Variable {
    /// A new variable of the given type: a continuous (or discrete for non-Real) local
    /// with no start value. Refine with the builders below.
    pub const fn new(name: &'static str, vr: u32, ty: VarType) -> Self {
        let variability = match ty {
            VarType::Real => Variability::Continuous,
            _ => Variability::Discrete,
        };
        Variable {
            name,
            vr,
            ty,
            causality: Causality::Local,
            variability,
            initial: None,
            description: "",
            unit: None,
            display_unit: None,
            start: None,
            min: None,
            max: None,
            nominal: None,
            dependencies: None,
            initial_dependencies: None,
            derivative_of: None,
        }
    }
    /// A Real variable.
    pub const fn real(name: &'static str, vr: u32) -> Self {
        Self::new(name, vr, VarType::Real)
    }
    /// An Integer variable.
    pub const fn integer(name: &'static str, vr: u32) -> Self {
        Self::new(name, vr, VarType::Integer)
    }
    /// A Boolean variable.
    pub const fn boolean(name: &'static str, vr: u32) -> Self {
        Self::new(name, vr, VarType::Boolean)
    }
    /// A String variable.
    pub const fn string(name: &'static str, vr: u32) -> Self {
        Self::new(name, vr, VarType::String)
    }
    /// `causality="input"` (variability stays continuous for Real, discrete otherwise).
    pub const fn input(self) -> Self {
        Variable {
            causality: Causality::Input,
            ..self
        }
    }
    /// `causality="output"`.
    pub const fn output(self) -> Self {
        Variable {
            causality: Causality::Output,
            ..self
        }
    }
    /// `causality="parameter" variability="fixed"`.
    pub const fn parameter(self) -> Self {
        Variable {
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            ..self
        }
    }
    /// `causality="parameter" variability="tunable"`: may be set between steps.
    pub const fn tunable_parameter(self) -> Self {
        Variable {
            causality: Causality::Parameter,
            variability: Variability::Tunable,
            ..self
        }
    }
    /// `causality="calculatedParameter" variability="fixed"`.
    pub const fn calculated_parameter(self) -> Self {
        Variable {
            causality: Causality::CalculatedParameter,
            variability: Variability::Fixed,
            ..self
        }
    }
    /// `causality="local"`.
    pub const fn local(self) -> Self {
        Variable {
            causality: Causality::Local,
            ..self
        }
    }
    /// `causality="independent"` (time). Optional in FMI 2.0 Co-Simulation, and best left
    /// out: the standard forbids a start value on it (fmpy's `validate_fmu` enforces that),
    /// while FMI Library (libcosim) logs an error when it has none.
    pub const fn independent(self) -> Self {
        Variable {
            causality: Causality::Independent,
            variability: Variability::Continuous,
            ..self
        }
    }
    /// Override the causality.
    pub const fn causality(self, causality: Causality) -> Self {
        Variable { causality, ..self }
    }
    /// Override the variability.
    pub const fn variability(self, variability: Variability) -> Self {
        Variable {
            variability,
            ..self
        }
    }
    /// Set `initial` explicitly.
    pub const fn initial(self, initial: Initial) -> Self {
        Variable {
            initial: Some(initial),
            ..self
        }
    }
    /// Description.
    pub const fn description(self, description: &'static str) -> Self {
        Variable {
            description,
            ..self
        }
    }
    /// Unit.
    pub const fn unit(self, unit: &'static str) -> Self {
        Variable {
            unit: Some(unit),
            ..self
        }
    }
    /// Display unit.
    pub const fn display_unit(self, display_unit: &'static str) -> Self {
        Variable {
            display_unit: Some(display_unit),
            ..self
        }
    }
    /// Real start value.
    pub const fn start_real(self, x: f64) -> Self {
        Variable {
            start: Some(Start::Real(x)),
            ..self
        }
    }
    /// Integer start value.
    pub const fn start_integer(self, x: i32) -> Self {
        Variable {
            start: Some(Start::Integer(x)),
            ..self
        }
    }
    /// Boolean start value.
    pub const fn start_boolean(self, x: bool) -> Self {
        Variable {
            start: Some(Start::Boolean(x)),
            ..self
        }
    }
    /// String start value.
    pub const fn start_string(self, x: &'static str) -> Self {
        Variable {
            start: Some(Start::String(x)),
            ..self
        }
    }
    /// `min` and `max`.
    pub const fn range(self, min: f64, max: f64) -> Self {
        Variable {
            min: Some(min),
            max: Some(max),
            ..self
        }
    }
    /// `nominal`.
    pub const fn nominal(self, nominal: f64) -> Self {
        Variable {
            nominal: Some(nominal),
            ..self
        }
    }
    /// Stepping dependencies (value references of inputs/states).
    pub const fn depends_on(self, vrs: &'static [u32]) -> Self {
        Variable {
            dependencies: Some(vrs),
            ..self
        }
    }
    /// Initialisation dependencies (value references of knowns at initialisation).
    pub const fn initially_depends_on(self, vrs: &'static [u32]) -> Self {
        Variable {
            initial_dependencies: Some(vrs),
            ..self
        }
    }
    /// Marks this variable as the derivative of the state with value reference `state_vr`.
    pub const fn derivative_of(self, state_vr: u32) -> Self {
        Variable {
            derivative_of: Some(state_vr),
            ..self
        }
    }

    /// The effective `initial`: the explicit one, or the standard's default
    /// (FMI 2.0 section 2.2.7, table of `initial` per causality/variability).
    /// `None` where the attribute is not allowed (inputs, independent).
    pub fn effective_initial(&self) -> Option<Initial> {
        if let Some(i) = self.initial {
            return Some(i);
        }
        match (self.causality, self.variability) {
            (Causality::Input | Causality::Independent, _) => None,
            (_, Variability::Constant) => Some(Initial::Exact),
            (Causality::Parameter, _) => Some(Initial::Exact),
            _ => Some(Initial::Calculated),
        }
    }
}

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

/// An error (or warning) from a model hook: a status and a message for the importer's log.
///
/// Returned as `Err` from hooks whose result type is `()` a `Warning` means "done, with a
/// warning" and a `Discard` means "not done, but the instance is fine". From getters any
/// status is treated as at least `Error` (there is no value to hand back).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Fmi2Err {
    /// Warning, Discard, Error or Fatal.
    pub status: Fmi2Status,
    /// What went wrong, naming the variable where there is one.
    pub message: String,
}

impl Fmi2Err {
    /// An `fmi2Error`.
    pub fn error(message: impl Into<String>) -> Self {
        Fmi2Err {
            status: Fmi2Status::Error,
            message: message.into(),
        }
    }
    /// An `fmi2Warning`.
    pub fn warning(message: impl Into<String>) -> Self {
        Fmi2Err {
            status: Fmi2Status::Warning,
            message: message.into(),
        }
    }
    /// An `fmi2Discard`.
    pub fn discard(message: impl Into<String>) -> Self {
        Fmi2Err {
            status: Fmi2Status::Discard,
            message: message.into(),
        }
    }
    /// An `fmi2Fatal`.
    pub fn fatal(message: impl Into<String>) -> Self {
        Fmi2Err {
            status: Fmi2Status::Fatal,
            message: message.into(),
        }
    }
    /// The standard error for a value reference the model does not know.
    pub fn unknown_vr(ty: VarType, vr: u32) -> Self {
        Fmi2Err::error(format!("unknown {} value reference {vr}", ty.as_str()))
    }
}

impl fmt::Display for Fmi2Err {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}: {}", self.status, self.message)
    }
}

impl std::error::Error for Fmi2Err {}

/// What `fmi2Instantiate` tells the model.
#[derive(Debug, Clone)]
pub struct InstantiateArgs<'a> {
    /// The importer's name for this instance.
    pub instance_name: &'a str,
    /// `fmuResourceLocation` exactly as passed (a URI), if any.
    pub resource_location: Option<&'a str>,
    /// The same decoded to a local directory, if it was a decodable `file:` URI or path.
    pub resource_dir: Option<&'a Path>,
    /// The `resources/` folder next to this binary's `binaries/` folder in the unpacked FMU,
    /// if there is one (see [`crate::uri::packaged_resources`]): what the FMU was packaged
    /// with, whatever the importer passed.
    pub packaged_resources: Option<&'a Path>,
    /// `visible` (ignored by the shell).
    pub visible: bool,
    /// `loggingOn` at instantiation.
    pub logging_on: bool,
}

/// The model behind the shell. No FMI types appear here: the shell checks pointers, the
/// state machine, causality rules and finiteness before any of these is called, and turns
/// results (and panics) into `fmi2Status` plus a log message.
///
/// `Clone` is the FMU state: `fmi2GetFMUstate` clones the model. `Send` because importers
/// may drive an instance from a different thread than the one that created it.
pub trait FmuModel: Clone + Send + Sized + 'static {
    /// The static description (also the source of `modelDescription.xml` and the GUID).
    fn model_info() -> &'static ModelInfo;

    /// Construct a fresh instance with every variable at its start value. Also used by
    /// `fmi2Reset`, so it must not depend on anything but its arguments.
    fn instantiate(ctx: &mut Ctx<'_>, args: &InstantiateArgs<'_>) -> Result<Self, Fmi2Err>;

    /// `fmi2SetupExperiment`. `stop_time` is `None` if not defined.
    fn setup_experiment(
        &mut self,
        _ctx: &mut Ctx<'_>,
        _tolerance: Option<f64>,
        _start_time: f64,
        _stop_time: Option<f64>,
    ) -> Result<(), Fmi2Err> {
        Ok(())
    }

    /// `fmi2EnterInitializationMode`.
    fn enter_initialization_mode(&mut self, _ctx: &mut Ctx<'_>) -> Result<(), Fmi2Err> {
        Ok(())
    }

    /// `fmi2ExitInitializationMode`: compute calculated parameters and initial outputs.
    fn exit_initialization_mode(&mut self, _ctx: &mut Ctx<'_>) -> Result<(), Fmi2Err> {
        Ok(())
    }

    /// Advance from `current_time` by `step` (> 0, finite; checked by the shell).
    fn do_step(&mut self, ctx: &mut Ctx<'_>, current_time: f64, step: f64) -> Result<(), Fmi2Err>;

    /// `fmi2Terminate`.
    fn terminate(&mut self, _ctx: &mut Ctx<'_>) -> Result<(), Fmi2Err> {
        Ok(())
    }

    /// Value of a Real variable (any causality). `&mut self` so outputs may be computed lazily.
    fn get_real(&mut self, vr: u32) -> Result<f64, Fmi2Err>;
    /// Set a Real variable. The shell has already checked that the value is finite and that
    /// the variable may be set now; warnings (e.g. outside the validated envelope) go through
    /// [`Ctx::warning`].
    fn set_real(&mut self, ctx: &mut Ctx<'_>, vr: u32, value: f64) -> Result<(), Fmi2Err>;

    /// Value of an Integer variable.
    fn get_integer(&mut self, vr: u32) -> Result<i32, Fmi2Err> {
        Err(Fmi2Err::unknown_vr(VarType::Integer, vr))
    }
    /// Set an Integer variable.
    fn set_integer(&mut self, _ctx: &mut Ctx<'_>, vr: u32, _value: i32) -> Result<(), Fmi2Err> {
        Err(Fmi2Err::unknown_vr(VarType::Integer, vr))
    }
    /// Value of a Boolean variable.
    fn get_boolean(&mut self, vr: u32) -> Result<bool, Fmi2Err> {
        Err(Fmi2Err::unknown_vr(VarType::Boolean, vr))
    }
    /// Set a Boolean variable.
    fn set_boolean(&mut self, _ctx: &mut Ctx<'_>, vr: u32, _value: bool) -> Result<(), Fmi2Err> {
        Err(Fmi2Err::unknown_vr(VarType::Boolean, vr))
    }
    /// Value of a String variable (the shell keeps the C copy alive for the importer).
    fn get_string(&mut self, vr: u32) -> Result<String, Fmi2Err> {
        Err(Fmi2Err::unknown_vr(VarType::String, vr))
    }
    /// Set a String variable.
    fn set_string(&mut self, _ctx: &mut Ctx<'_>, vr: u32, _value: &str) -> Result<(), Fmi2Err> {
        Err(Fmi2Err::unknown_vr(VarType::String, vr))
    }

    /// The model's complete dynamic state as data, for `fmi2SerializeFMUstate` and
    /// `fmi2DeSerializeFMUstate`. The shell alone encodes it (CBOR, with a header naming the
    /// GUID, [`FmuModel::STATE_VERSION`], the length and a CRC-32; see [`crate::snapshot`]),
    /// so a model declares *what* its state is and never writes paired byte code. Floats
    /// keep their exact bits, so a restored state replays bit-identically. In-memory states
    /// (`fmi2GetFMUstate`) do not use it: they are clones of the model.
    type State: Serialize + DeserializeOwned;

    /// Version of [`FmuModel::State`]'s layout, written into every serialized state. Bump it
    /// when the state type changes, so that bytes saved by another build of the FMU are
    /// refused with a message saying so instead of being misread.
    const STATE_VERSION: u32 = 1;

    /// The current dynamic state.
    fn save_state(&self) -> Result<Self::State, Fmi2Err>;

    /// Put `self` (a clone of the live instance, so anything not in the state, like
    /// configuration read from resources, is already there) into `state`. The bytes it came
    /// from passed the shell's checksum, which proves them intact, not honest: validate the
    /// values as if they had been set (`Err` leaves `self` unusable; the shell discards it).
    fn restore_state(&mut self, state: Self::State) -> Result<(), Fmi2Err>;

    /// Whether the instance can save and restore its state (`canGetAndSetFMUstate` and
    /// `canSerializeFMUstate` in the XML). A model driving hardware cannot go back in time:
    /// it sets this to `false`, and the shell refuses the six FMU-state functions, naming the
    /// capability, without cloning or serializing the model.
    const CAN_GET_AND_SET_FMU_STATE: bool = true;

    /// Whether the instance answers `fmi2GetDirectionalDerivative`
    /// (`providesDirectionalDerivative` in the XML); `false` makes the shell refuse the call.
    const PROVIDES_DIRECTIONAL_DERIVATIVE: bool = true;

    /// `fmi2GetDirectionalDerivative`: `dv_unknown = J * dv_known` with J the Jacobian of the
    /// `unknowns` with respect to the `knowns` (inputs and states) at the current point. The
    /// shell has checked the references exist and are Real, and that `dv_known` is finite.
    ///
    /// The default is a central finite difference that perturbs *inputs* on clones (see
    /// [`crate::jacobian::finite_difference`]); models with states or analytic Jacobians
    /// should override it.
    fn directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        dv_known: &[f64],
    ) -> Result<Vec<f64>, Fmi2Err> {
        crate::jacobian::finite_difference(self, unknowns, knowns, dv_known)
    }

    // ---------------------------------------------------------------------------------
    // Model Exchange (optional). Every hook has a default, so a Co-Simulation-only model
    // (such as a rig) implements none of them and keeps `MODEL_EXCHANGE = false`: the XML
    // then has no `<ModelExchange>` element and `fmi2Instantiate` refuses that type.
    // ---------------------------------------------------------------------------------

    /// Whether the FMU also offers FMI 2.0 Model Exchange. When `true`, the continuous
    /// states are the table's variables that a `derivative_of` row points at (in
    /// `<Derivatives>` order, see [`crate::table::continuous_states`]), and the model must
    /// implement [`FmuModel::set_continuous_states`] and return the states and their
    /// derivatives from [`FmuModel::get_real`] (or override the getters below).
    const MODEL_EXCHANGE: bool = false;

    /// `fmi2SetTime` (Model Exchange): the integrator's time. The shell has checked it is
    /// finite and does not go backwards.
    fn set_time(&mut self, _time: f64) -> Result<(), Fmi2Err> {
        Ok(())
    }

    /// `fmi2SetContinuousStates`: `x` in the order of [`crate::table::continuous_states`],
    /// already checked finite and of the right length by the shell.
    fn set_continuous_states(&mut self, _ctx: &mut Ctx<'_>, _x: &[f64]) -> Result<(), Fmi2Err> {
        Err(Fmi2Err::error("this model has no continuous states to set"))
    }

    /// `fmi2GetContinuousStates`: default reads each state's value reference with
    /// [`FmuModel::get_real`].
    fn get_continuous_states(&mut self, states: &[u32], x: &mut [f64]) -> Result<(), Fmi2Err> {
        for (xi, &vr) in x.iter_mut().zip(states) {
            *xi = self.get_real(vr)?;
        }
        Ok(())
    }

    /// `fmi2GetDerivatives`: default reads each derivative's value reference with
    /// [`FmuModel::get_real`]. A model with a faster joint evaluation overrides it.
    fn get_derivatives(&mut self, derivatives: &[u32], dx: &mut [f64]) -> Result<(), Fmi2Err> {
        for (di, &vr) in dx.iter_mut().zip(derivatives) {
            *di = self.get_real(vr)?;
        }
        Ok(())
    }

    /// `fmi2CompletedIntegratorStep`: a point the integrator accepted (for models that
    /// check validity or log envelope crossings there). Returning `true` asks the importer
    /// to enter event mode.
    fn completed_integrator_step(&mut self, _ctx: &mut Ctx<'_>) -> Result<bool, Fmi2Err> {
        Ok(false)
    }
}
