//! The variable table: one row ([`Variable`]) per variable, with `const fn` builders.
//!
//! The table is the single source of truth. The shell uses it to decide which calls are
//! legal (causality, variability, initial), to name variables in error messages and to
//! reject non-finite Reals; the XML generator writes `modelDescription.xml` from it; and the
//! GUID is a hash of it, so the XML and the binary cannot drift apart.
//!
//! Everything here is plain data with `const fn` builders, so a model can write its
//! table as a `static`. A model whose table needs run-time data (e.g. defaults computed
//! by the physics crate) can build it once in a `std::sync::LazyLock` and leak the vectors.

/// Base type of a variable. Each shell names it in its own version's words: `Real` is FMI
/// 2.0 `<Real>` and FMI 3.0 `<Float64>`, `Integer` is `<Integer>` and `<Int32>`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VarType {
    /// A 64-bit float (`<Real>`, `<Float64>`).
    Real,
    /// A 32-bit signed integer (`<Integer>`, `<Int32>`).
    Integer,
    /// `<Boolean>`.
    Boolean,
    /// `<String>`.
    String,
}

impl VarType {
    /// The FMI 2.0 element name (used in messages of both shells).
    pub fn as_str(self) -> &'static str {
        match self {
            VarType::Real => "Real",
            VarType::Integer => "Integer",
            VarType::Boolean => "Boolean",
            VarType::String => "String",
        }
    }
}

/// `causality` (the same values in FMI 2.0 and 3.0, which adds structural parameters that
/// these shells do not use).
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

/// `variability`.
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

/// `initial`.
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
    /// Unit (Real only); must be one of the model's [`UnitDefinition`](crate::UnitDefinition)s.
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
    /// (FMI 2.0 section 2.2.7 and FMI 3.0 section 2.4.7.5, tables of `initial` per
    /// causality/variability, which agree for the causalities used here).
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
