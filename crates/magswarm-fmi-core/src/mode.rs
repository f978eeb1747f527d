//! The modes an instance can be in, and which variables may be set in which mode.
//!
//! The modes are the union of what FMI 2.0 and FMI 3.0 call them (FMI 2.0's stepComplete is
//! FMI 3.0's Step Mode); each shell keeps its own table of which function is allowed in
//! which mode (`magswarm_fmi2::state`, `magswarm_fmi3::state`) and checks it before anything
//! else in every entry point, so a model never sees a call out of sequence. The rules for
//! setting variables ([`may_set`]) are the same in both versions for the causalities these
//! shells use.

use crate::status::Refusal;
use crate::variable::{Causality, Initial, Variability, Variable};

/// The state of an instance (the importer sees it only through what calls are allowed).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Mode {
    /// After instantiation or reset.
    Instantiated,
    /// Between entering and leaving initialisation mode.
    InitializationMode,
    /// Co-Simulation, ready to step (FMI 2.0 stepComplete, FMI 3.0 Step Mode).
    StepComplete,
    /// FMI 2.0: the last `fmi2DoStep` returned `fmi2Discard`.
    StepFailed,
    /// After termination.
    Terminated,
    /// Model Exchange: event mode (after initialisation or entering event mode).
    EventMode,
    /// Model Exchange: continuous-time mode (the importer's integrator runs).
    ContinuousTimeMode,
    /// A call returned an error: only getters, FMU-state functions, reset and free.
    Error,
    /// A call returned Fatal: only free.
    Fatal,
}

impl Mode {
    /// Every mode, in declaration order (the order of the variable table's per-mode bits).
    pub const ALL: [Mode; 9] = [
        Mode::Instantiated,
        Mode::InitializationMode,
        Mode::StepComplete,
        Mode::StepFailed,
        Mode::Terminated,
        Mode::EventMode,
        Mode::ContinuousTimeMode,
        Mode::Error,
        Mode::Fatal,
    ];

    /// Stable byte for serialized FMU states.
    pub fn to_byte(self) -> u8 {
        match self {
            Mode::Instantiated => 1,
            Mode::InitializationMode => 2,
            Mode::StepComplete => 3,
            Mode::StepFailed => 4,
            Mode::Terminated => 5,
            Mode::Error => 6,
            Mode::Fatal => 7,
            Mode::EventMode => 8,
            Mode::ContinuousTimeMode => 9,
        }
    }

    /// Inverse of [`Mode::to_byte`].
    pub fn from_byte(b: u8) -> Option<Mode> {
        Some(match b {
            1 => Mode::Instantiated,
            2 => Mode::InitializationMode,
            3 => Mode::StepComplete,
            4 => Mode::StepFailed,
            5 => Mode::Terminated,
            6 => Mode::Error,
            7 => Mode::Fatal,
            8 => Mode::EventMode,
            9 => Mode::ContinuousTimeMode,
            _ => return None,
        })
    }

    /// Human-readable name for log messages.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Instantiated => "Instantiated",
            Mode::InitializationMode => "InitializationMode",
            Mode::StepComplete => "StepComplete",
            Mode::StepFailed => "StepFailed",
            Mode::Terminated => "Terminated",
            Mode::Error => "Error",
            Mode::Fatal => "Fatal",
            Mode::EventMode => "EventMode",
            Mode::ContinuousTimeMode => "ContinuousTimeMode",
        }
    }
}

/// Whether `var` may be set in `mode` (footnotes of the standards' state tables):
/// - Instantiated: variability ≠ constant with initial exact or approx, and inputs;
/// - InitializationMode: variability ≠ constant with initial exact, and inputs;
/// - StepComplete: inputs and tunable parameters.
///
/// `Err` carries the reason, for the log message.
#[inline]
pub fn may_set(var: &Variable, mode: Mode) -> Result<(), Refusal> {
    // The common case first (an input, every call of a master): no table of rules needed.
    if var.causality == Causality::Input && var.variability != Variability::Constant {
        match mode {
            Mode::Instantiated
            | Mode::InitializationMode
            | Mode::StepComplete
            | Mode::EventMode => return Ok(()),
            Mode::ContinuousTimeMode if var.variability == Variability::Continuous => return Ok(()),
            _ => {}
        }
    }
    may_set_by_rules(var, mode)
}

#[inline(never)]
fn may_set_by_rules(var: &Variable, mode: Mode) -> Result<(), Refusal> {
    let what = || {
        format!(
            "variable \"{}\" (causality={}, variability={}{})",
            var.name,
            var.causality.as_str(),
            var.variability.as_str(),
            var.effective_initial()
                .map(|i| format!(", initial={}", i.as_str()))
                .unwrap_or_default()
        )
    };
    if var.variability == Variability::Constant {
        return Err(Refusal(format!(
            "{} is a constant and cannot be set",
            what()
        )));
    }
    if matches!(var.causality, Causality::Independent) {
        return Err(Refusal(format!(
            "{} is the independent variable and cannot be set",
            what()
        )));
    }
    let is_input = var.causality == Causality::Input;
    let initial = var.effective_initial();
    let ok = match mode {
        Mode::Instantiated => is_input || matches!(initial, Some(Initial::Exact | Initial::Approx)),
        Mode::InitializationMode => is_input || initial == Some(Initial::Exact),
        Mode::StepComplete | Mode::EventMode => {
            is_input
                || (var.causality == Causality::Parameter
                    && var.variability == Variability::Tunable)
        }
        // Model Exchange, continuous-time mode: only continuous inputs.
        Mode::ContinuousTimeMode => is_input && var.variability == Variability::Continuous,
        _ => false,
    };
    if ok {
        Ok(())
    } else {
        let rule = match mode {
            Mode::Instantiated => "only inputs and variables with initial=exact or approx can be set before initialization",
            Mode::InitializationMode => "only inputs and variables with initial=exact can be set during initialization",
            Mode::StepComplete | Mode::EventMode => "only inputs and tunable parameters can be set after initialization",
            Mode::ContinuousTimeMode => "only continuous inputs can be set in continuous-time mode (tunable parameters in event mode)",
            _ => "no variable can be set in this state",
        };
        Err(Refusal(format!(
            "{} cannot be set in state {}: {rule}",
            what(),
            mode.name()
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mode_bytes_round_trip() {
        for b in 0..=255u8 {
            if let Some(m) = Mode::from_byte(b) {
                assert_eq!(m.to_byte(), b);
            }
        }
    }

    #[test]
    fn set_rules_follow_causality() {
        let input = Variable::real("u", 0).input().start_real(0.0);
        let fixed = Variable::real("p", 1).parameter().start_real(1.0);
        let tunable = Variable::real("k", 2).tunable_parameter().start_real(1.0);
        let output = Variable::real("y", 3).output();
        let constant = Variable::real("c", 4)
            .variability(Variability::Constant)
            .start_real(1.0);
        for m in [
            Mode::Instantiated,
            Mode::InitializationMode,
            Mode::StepComplete,
        ] {
            assert!(may_set(&input, m).is_ok());
            assert!(may_set(&output, m).is_err());
            assert!(may_set(&constant, m).is_err());
            assert!(may_set(&tunable, m).is_ok());
        }
        assert!(may_set(&fixed, Mode::Instantiated).is_ok());
        assert!(may_set(&fixed, Mode::InitializationMode).is_ok());
        let e = may_set(&fixed, Mode::StepComplete).unwrap_err();
        assert!(e.0.contains("\"p\"") && e.0.contains("tunable"), "{e}");
        assert!(may_set(&input, Mode::Terminated).is_err());
    }
}
