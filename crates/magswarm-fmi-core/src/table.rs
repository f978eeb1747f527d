//! Checking a variable table against the rules of FMI 2.0 and 3.0, and looking variables up
//! by value reference.
//!
//! The same checks run when the XML is generated (a bad table fails the build of the FMU)
//! and at `fmi2Instantiate` (a bad table fails loudly in the importer's log instead of
//! misbehaving later). They encode what strict importers (FMI Library, libcosim, fmpy's
//! `validate_fmu`) check, plus the shell's own rule that value references are unique
//! across types, so that dependency lists are unambiguous.

use crate::status::Refusal;
use std::collections::{HashMap, HashSet};

use crate::info::ModelInfo;
use crate::mode::{may_set, Mode};
use crate::variable::{Causality, Initial, Start, VarType, Variability, Variable};

/// [`Table::is_typed`]'s answer for a variable of the asked type: whether it is the
/// independent variable.
pub type IsIndependent = bool;

/// A validated table with a value-reference index.
#[derive(Debug, Clone)]
pub struct Table {
    /// The model's static description.
    pub info: &'static ModelInfo,
    /// (vr, position) sorted by vr.
    by_vr: Vec<(u32, usize)>,
    /// Position by value reference for tables whose references are small (every call of
    /// every getter and setter looks references up: a direct index instead of a search).
    dense: Vec<u32>,
    /// What the getters and setters ask of a reference, by value reference (same range as
    /// `dense`): the type code ([`type_code`]; 0 for no variable) in the low bits, one bit
    /// per [`Mode`] in which [`may_set`] allows setting it, and [`INDEPENDENT`]. Built once
    /// from the same rules, so a call's checks are one load and a mask (refusals still go
    /// through [`Table::typed`] and [`may_set`] for their messages).
    kinds: Vec<u16>,
    /// The independent variable (time), answered by the instance itself.
    independent: Option<u32>,
}

/// Bits of a [`Table`] kind holding the type code.
const TYPE_BITS: u16 = 0b111;
/// Kind bit: the independent variable.
const INDEPENDENT: u16 = 1 << 15;
/// First kind bit of the settable modes (bit `MODE_SHIFT + mode index`).
const MODE_SHIFT: u16 = 3;

/// The bit of `mode` in a kind.
#[inline(always)]
fn mode_bit(mode: Mode) -> u16 {
    let i = match mode {
        Mode::Instantiated => 0,
        Mode::InitializationMode => 1,
        Mode::StepComplete => 2,
        Mode::StepFailed => 3,
        Mode::Terminated => 4,
        Mode::EventMode => 5,
        Mode::ContinuousTimeMode => 6,
        Mode::Error => 7,
        Mode::Fatal => 8,
    };
    1 << (MODE_SHIFT + i)
}

/// Non-zero code of a type in a kind.
#[inline(always)]
fn type_code(ty: VarType) -> u16 {
    match ty {
        VarType::Real => 1,
        VarType::Integer => 2,
        VarType::Boolean => 3,
        VarType::String => 4,
    }
}

impl Table {
    /// Validate `info` and index it.
    pub fn new(info: &'static ModelInfo) -> Result<Table, Vec<String>> {
        validate(info)?;
        let mut by_vr: Vec<(u32, usize)> = info
            .variables
            .iter()
            .enumerate()
            .map(|(i, v)| (v.vr, i))
            .collect();
        by_vr.sort_unstable();
        let independent = info
            .variables
            .iter()
            .find(|v| v.causality == Causality::Independent)
            .map(|v| v.vr);
        // A direct index when the references fit in a small array (all of magswarm's do).
        const DENSE_LIMIT: u32 = 1 << 14;
        let max_vr = by_vr.last().map_or(0, |&(v, _)| v);
        let dense = if max_vr < DENSE_LIMIT {
            let mut d = vec![u32::MAX; max_vr as usize + 1];
            for &(v, p) in &by_vr {
                d[v as usize] = p as u32;
            }
            d
        } else {
            Vec::new()
        };
        let kinds = dense
            .iter()
            .map(|&p| match info.variables.get(p as usize) {
                None => 0,
                Some(v) => {
                    let mut k = type_code(v.ty);
                    for m in Mode::ALL {
                        if may_set(v, m).is_ok() {
                            k |= mode_bit(m);
                        }
                    }
                    if v.causality == Causality::Independent {
                        k |= INDEPENDENT;
                    }
                    k
                }
            })
            .collect();
        Ok(Table {
            info,
            by_vr,
            dense,
            kinds,
            independent,
        })
    }

    /// Whether `vr` is a variable of type `ty` (the check of every getter; [`Table::typed`]
    /// says why not). Also tells whether it is the independent variable.
    #[inline(always)]
    pub fn is_typed(&self, vr: u32, ty: VarType) -> Option<IsIndependent> {
        if !self.kinds.is_empty() {
            let k = self.kinds.get(vr as usize).copied().unwrap_or(0);
            return (k & TYPE_BITS == type_code(ty)).then_some(k & INDEPENDENT != 0);
        }
        match self.get(vr) {
            Some(v) if v.ty == ty => Some(v.causality == Causality::Independent),
            _ => None,
        }
    }

    /// Whether `vr` is a variable of type `ty` that [`may_set`] allows setting in `mode`
    /// (the check of every setter; [`Table::typed`] and [`may_set`] say why not).
    #[inline(always)]
    pub fn is_settable(&self, vr: u32, ty: VarType, mode: Mode) -> bool {
        if !self.kinds.is_empty() {
            let k = self.kinds.get(vr as usize).copied().unwrap_or(0);
            return k & TYPE_BITS == type_code(ty) && k & mode_bit(mode) != 0;
        }
        match self.get(vr) {
            Some(v) if v.ty == ty => may_set(v, mode).is_ok(),
            _ => false,
        }
    }

    /// Value reference of the independent variable, if the table has one.
    pub fn independent(&self) -> Option<u32> {
        self.independent
    }

    /// Position (0-based) of the variable with value reference `vr`.
    #[inline]
    pub fn position(&self, vr: u32) -> Option<usize> {
        if !self.dense.is_empty() {
            return match self.dense.get(vr as usize) {
                Some(&p) if p != u32::MAX => Some(p as usize),
                _ => None,
            };
        }
        self.by_vr
            .binary_search_by_key(&vr, |&(v, _)| v)
            .ok()
            .map(|i| self.by_vr[i].1)
    }

    /// The variable with value reference `vr`.
    #[inline]
    pub fn get(&self, vr: u32) -> Option<&'static Variable> {
        let info: &'static ModelInfo = self.info;
        self.position(vr).map(|i| &info.variables[i])
    }

    /// The variable with value reference `vr` if it has type `ty`, else a message
    /// for the log.
    #[inline]
    pub fn typed(&self, vr: u32, ty: VarType) -> Result<&'static Variable, Refusal> {
        match self.get(vr) {
            Some(v) if v.ty == ty => Ok(v),
            other => Err(type_refusal(vr, ty, other)),
        }
    }
}

/// Why [`Table::typed`] refused `vr` (out of line: only a refused call formats anything).
#[cold]
#[inline(never)]
fn type_refusal(vr: u32, ty: VarType, found: Option<&Variable>) -> Refusal {
    match found {
        Some(v) => Refusal(format!(
            "value reference {vr} is variable \"{}\" of type {}, not {}",
            v.name,
            v.ty.as_str(),
            ty.as_str()
        )),
        None => Refusal(format!(
            "unknown value reference {vr} (no {} variable has it)",
            ty.as_str()
        )),
    }
}

/// `info` with an independent variable `time` \[s\] appended if it has none (value
/// reference 0 if free, else one past the largest): FMI 3.0 requires exactly one, while
/// FMI 2.0 importers are better served without it (FMI Library logs an error for a time
/// variable without a start value, which the standard forbids it to have). Computed once
/// per table and kept until the library is unloaded.
pub fn with_independent_time(info: &'static ModelInfo) -> &'static ModelInfo {
    use std::sync::Mutex;
    static CACHE: Mutex<Vec<(usize, usize)>> = Mutex::new(Vec::new());
    if info
        .variables
        .iter()
        .any(|v| v.causality == Causality::Independent)
    {
        return info;
    }
    let key = info as *const ModelInfo as usize;
    let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(&(_, p)) = cache.iter().find(|(k, _)| *k == key) {
        // SAFETY: `p` points into a slice leaked by `unload::leak` below, alive until the
        // library is unloaded (after which no function of it runs).
        return unsafe { &*(p as *const ModelInfo) };
    }
    let vr = if info.variables.iter().any(|v| v.vr == 0) {
        info.variables.iter().map(|v| v.vr).max().unwrap_or(0) + 1
    } else {
        0
    };
    let mut vars = info.variables.to_vec();
    let mut time = Variable::real("time", vr)
        .independent()
        .description("simulation time");
    if info.units.iter().any(|u| u.name == "s") {
        time = time.unit("s");
    }
    vars.push(time);
    let mut with = info.clone();
    with.variables = crate::unload::leak(vars);
    let leaked: &'static ModelInfo = &crate::unload::leak(vec![with])[0];
    cache.push((key, leaked as *const ModelInfo as usize));
    leaked
}

/// Value references of the continuous states: variables some other variable is the
/// derivative of.
pub fn state_vrs(info: &ModelInfo) -> HashSet<u32> {
    info.variables
        .iter()
        .filter_map(|v| v.derivative_of)
        .collect()
}

/// The continuous states and their derivatives for Model Exchange, as two parallel lists of
/// value references in `<Derivatives>` order (table order of the derivative rows): element
/// `i` of `fmi2GetContinuousStates` is `states[i]`, of `fmi2GetDerivatives` `derivatives[i]`.
pub fn continuous_states(info: &ModelInfo) -> (Vec<u32>, Vec<u32>) {
    info.variables
        .iter()
        .filter_map(|v| v.derivative_of.map(|s| (s, v.vr)))
        .unzip()
}

/// Check every rule; all problems are reported at once.
pub fn validate(info: &ModelInfo) -> Result<(), Vec<String>> {
    let mut p: Vec<String> = Vec::new();
    let id = info.model_identifier;
    if id.is_empty()
        || !id.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        || id.chars().next().is_some_and(|c| c.is_ascii_digit())
    {
        p.push(format!(
            "modelIdentifier \"{id}\" must be a C identifier (it names the shared library)"
        ));
    }
    if info.model_name.is_empty() {
        p.push("modelName must not be empty".into());
    }
    if let Some(de) = &info.default_experiment {
        for (n, x) in [
            ("startTime", de.start_time),
            ("stopTime", de.stop_time),
            ("tolerance", de.tolerance),
            ("stepSize", de.step_size),
        ] {
            if x.is_some_and(|x| !x.is_finite()) {
                p.push(format!("DefaultExperiment {n} must be finite"));
            }
        }
        if de.step_size.is_some_and(|h| h <= 0.0) {
            p.push("DefaultExperiment stepSize must be > 0".into());
        }
        if let (Some(a), Some(b)) = (de.start_time, de.stop_time) {
            if b < a {
                p.push("DefaultExperiment stopTime is before startTime".into());
            }
        }
    }

    let mut unit_names = HashMap::new();
    for u in info.units {
        if unit_names.insert(u.name, u).is_some() {
            p.push(format!("unit \"{}\" is defined twice", u.name));
        }
        if !(u.base.factor.is_finite() && u.base.factor != 0.0 && u.base.offset.is_finite()) {
            p.push(format!(
                "unit \"{}\": BaseUnit factor must be finite and non-zero, offset finite",
                u.name
            ));
        }
        let mut seen = HashSet::new();
        for d in u.display_units {
            if !seen.insert(d.name) {
                p.push(format!(
                    "unit \"{}\": display unit \"{}\" is defined twice",
                    u.name, d.name
                ));
            }
            if !(d.factor.is_finite() && d.factor != 0.0 && d.offset.is_finite()) {
                p.push(format!(
                    "display unit \"{}\": factor must be finite and non-zero, offset finite",
                    d.name
                ));
            }
        }
    }

    let mut names = HashSet::new();
    let mut vrs: HashMap<u32, &Variable> = HashMap::new();
    for v in info.variables {
        if v.name.is_empty() {
            p.push(format!(
                "variable with value reference {} has an empty name",
                v.vr
            ));
        }
        if v.name.chars().any(|c| c.is_control()) {
            p.push(format!(
                "variable \"{}\": name contains a control character",
                v.name.escape_debug()
            ));
        }
        if !names.insert(v.name) {
            p.push(format!("variable name \"{}\" is not unique", v.name));
        }
        if let Some(prev) = vrs.insert(v.vr, v) {
            p.push(format!(
                "value reference {} is used by both \"{}\" and \"{}\" (must be unique across types)",
                v.vr, prev.name, v.name
            ));
        }
    }
    let states = state_vrs(info);
    let independents = info
        .variables
        .iter()
        .filter(|v| v.causality == Causality::Independent)
        .count();
    if independents > 1 {
        p.push("at most one variable may have causality=\"independent\"".into());
    }

    for v in info.variables {
        let n = v.name;
        use Causality as C;
        use Variability as V;
        let legal = matches!(
            (v.causality, v.variability),
            (C::Parameter, V::Fixed | V::Tunable)
                | (C::CalculatedParameter, V::Fixed | V::Tunable)
                | (C::Input, V::Discrete | V::Continuous)
                | (C::Output, V::Constant | V::Discrete | V::Continuous)
                | (C::Local, _)
                | (C::Independent, V::Continuous)
        );
        if !legal {
            p.push(format!(
                "variable \"{n}\": causality=\"{}\" with variability=\"{}\" is not allowed",
                v.causality.as_str(),
                v.variability.as_str()
            ));
        }
        if v.ty != VarType::Real && v.variability == V::Continuous {
            p.push(format!(
                "variable \"{n}\": only Real variables may be continuous"
            ));
        }
        if v.causality == C::Independent && v.ty != VarType::Real {
            p.push(format!(
                "variable \"{n}\": the independent variable must be Real"
            ));
        }
        // Allowed `initial` per causality/variability (FMI 2.0 table in 2.2.7).
        if let Some(init) = v.initial {
            use Initial as I;
            let ok = match (v.causality, v.variability) {
                (C::Input | C::Independent, _) => false,
                (_, V::Constant) => init == I::Exact,
                (C::Parameter, _) => init == I::Exact,
                (C::CalculatedParameter, _) => matches!(init, I::Approx | I::Calculated),
                (C::Local, V::Fixed | V::Tunable) => matches!(init, I::Approx | I::Calculated),
                (C::Output, _) => matches!(init, I::Exact | I::Calculated),
                (C::Local, _) => true,
            };
            if !ok {
                p.push(format!(
                    "variable \"{n}\": initial=\"{}\" is not allowed with causality=\"{}\" variability=\"{}\"",
                    init.as_str(),
                    v.causality.as_str(),
                    v.variability.as_str()
                ));
            }
        }
        let init = v.effective_initial();
        let needs_start =
            v.causality == C::Input || matches!(init, Some(Initial::Exact | Initial::Approx));
        let forbids_start = v.causality == C::Independent || init == Some(Initial::Calculated);
        match &v.start {
            None if needs_start => p.push(format!(
                "variable \"{n}\" needs a start value (causality=\"{}\", initial=\"{}\")",
                v.causality.as_str(),
                init.map_or("-", |i| i.as_str())
            )),
            Some(_) if forbids_start => p.push(format!(
                "variable \"{n}\" must not have a start value (causality=\"{}\", initial=\"{}\")",
                v.causality.as_str(),
                init.map_or("-", |i| i.as_str())
            )),
            Some(s) => {
                if s.var_type() != v.ty {
                    p.push(format!(
                        "variable \"{n}\": start value is not of type {}",
                        v.ty.as_str()
                    ));
                }
                if let Start::Real(x) = s {
                    if !x.is_finite() {
                        p.push(format!("variable \"{n}\": start value must be finite"));
                    }
                    if v.min.is_some_and(|m| *x < m) || v.max.is_some_and(|m| *x > m) {
                        p.push(format!(
                            "variable \"{n}\": start value {x} is outside [min, max]"
                        ));
                    }
                }
            }
            None => {}
        }
        if v.ty != VarType::Real
            && (v.unit.is_some()
                || v.display_unit.is_some()
                || v.min.is_some()
                || v.max.is_some()
                || v.nominal.is_some())
        {
            p.push(format!("variable \"{n}\": unit, displayUnit, min, max and nominal are for Real variables only"));
        }
        for (what, x) in [("min", v.min), ("max", v.max), ("nominal", v.nominal)] {
            if x.is_some_and(|x| !x.is_finite()) {
                p.push(format!("variable \"{n}\": {what} must be finite"));
            }
        }
        if let (Some(a), Some(b)) = (v.min, v.max) {
            if a > b {
                p.push(format!("variable \"{n}\": min > max"));
            }
        }
        match (v.unit, v.display_unit) {
            (Some(u), d) => match unit_names.get(u) {
                None => p.push(format!(
                    "variable \"{n}\": unit \"{u}\" is not in the unit definitions"
                )),
                Some(def) => {
                    if let Some(d) = d {
                        if !def.display_units.iter().any(|x| x.name == d) {
                            p.push(format!("variable \"{n}\": display unit \"{d}\" is not a display unit of \"{u}\""));
                        }
                    }
                }
            },
            (None, Some(_)) => p.push(format!("variable \"{n}\": displayUnit needs a unit")),
            (None, None) => {}
        }
        // Derivatives and states.
        if let Some(s) = v.derivative_of {
            match vrs.get(&s) {
                None => p.push(format!(
                    "variable \"{n}\": derivative of unknown value reference {s}"
                )),
                Some(state) => {
                    if state.ty != VarType::Real || state.variability != V::Continuous {
                        p.push(format!(
                            "variable \"{n}\": state \"{}\" must be a continuous Real",
                            state.name
                        ));
                    }
                }
            }
            if v.ty != VarType::Real || v.variability != V::Continuous {
                p.push(format!(
                    "variable \"{n}\": a state derivative must be a continuous Real"
                ));
            }
            if !matches!(v.causality, C::Local | C::Output) {
                p.push(format!(
                    "variable \"{n}\": a state derivative must be local or output"
                ));
            }
        }
        // Stepping dependencies: only for outputs and derivatives; only inputs and states.
        if let Some(deps) = v.dependencies {
            if !(v.causality == C::Output || v.derivative_of.is_some()) {
                p.push(format!(
                    "variable \"{n}\": dependencies are only for outputs and state derivatives"
                ));
            }
            for d in deps {
                match vrs.get(d) {
                    None => p.push(format!(
                        "variable \"{n}\": dependency on unknown value reference {d}"
                    )),
                    Some(k) => {
                        if !(k.causality == C::Input
                            || k.causality == C::Independent
                            || states.contains(d))
                        {
                            p.push(format!(
                                "variable \"{n}\": dependency \"{}\" is neither an input nor a continuous state",
                                k.name
                            ));
                        }
                    }
                }
            }
        }
        // Initialisation dependencies: only for initial unknowns; only knowns at init.
        if let Some(deps) = v.initial_dependencies {
            if !is_initial_unknown(v, &states) {
                p.push(format!(
                    "variable \"{n}\": initial dependencies are only for initial unknowns (outputs and states with \
                     initial calculated/approx, calculated parameters)"
                ));
            }
            for d in deps {
                match vrs.get(d) {
                    None => p.push(format!(
                        "variable \"{n}\": initial dependency on unknown value reference {d}"
                    )),
                    Some(k) => {
                        let known = matches!(k.causality, C::Input | C::Independent)
                            || k.effective_initial() == Some(Initial::Exact);
                        if !known {
                            p.push(format!(
                                "variable \"{n}\": initial dependency \"{}\" is not known at initialization \
                                 (must be an input, the independent variable or have initial=\"exact\")",
                                k.name
                            ));
                        }
                    }
                }
            }
        }
    }
    if p.is_empty() {
        Ok(())
    } else {
        Err(p)
    }
}

/// Whether `v` belongs in `ModelStructure/InitialUnknowns` (FMI 2.0 section 2.2.8):
/// outputs with initial approx/calculated, calculated parameters, and continuous states
/// and state derivatives with initial approx/calculated.
pub fn is_initial_unknown(v: &Variable, states: &HashSet<u32>) -> bool {
    let approx_or_calc = matches!(
        v.effective_initial(),
        Some(Initial::Approx | Initial::Calculated)
    );
    (v.causality == Causality::Output && approx_or_calc)
        || v.causality == Causality::CalculatedParameter
        || ((states.contains(&v.vr) || v.derivative_of.is_some()) && approx_or_calc)
}
