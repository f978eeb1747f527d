//! The state machine of FMI 2.0 (standard, sections 3.2.3 for Model Exchange and 4.2.4 for
//! Co-Simulation): which function may be called in which state, and which variables may be
//! set in which state. A function of the other interface is refused before this table is
//! consulted (`Func::model_exchange_only`, `Func::co_simulation_only`).
//!
//! Checked before anything else in every entry point, so a model never sees a call out of
//! sequence. `StepInProgress` and `StepCanceled` do not exist here because `fmi2DoStep`
//! never returns `fmi2Pending`.

use crate::model::{Causality, Initial, Variability, Variable};

/// The state of an instance (the importer sees it only through what calls are allowed).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Mode {
    /// After `fmi2Instantiate` or `fmi2Reset`.
    Instantiated,
    /// Between `fmi2EnterInitializationMode` and `fmi2ExitInitializationMode`.
    InitializationMode,
    /// Ready for `fmi2DoStep` ("slaveInitialized" / stepComplete).
    StepComplete,
    /// The last `fmi2DoStep` returned `fmi2Discard`.
    StepFailed,
    /// After `fmi2Terminate`.
    Terminated,
    /// Model Exchange: event mode (after `fmi2ExitInitializationMode` or `fmi2EnterEventMode`).
    EventMode,
    /// Model Exchange: continuous-time mode (the importer's integrator runs).
    ContinuousTimeMode,
    /// A call returned `fmi2Error`: only getters, FMU-state functions, reset and free.
    Error,
    /// A call returned `fmi2Fatal`: only free.
    Fatal,
}

impl Mode {
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

/// Every instance function of the FMI 2.0 Co-Simulation API.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[allow(missing_docs)]
pub enum Func {
    SetDebugLogging,
    FreeInstance,
    SetupExperiment,
    EnterInitializationMode,
    ExitInitializationMode,
    Terminate,
    Reset,
    GetReal,
    GetInteger,
    GetBoolean,
    GetString,
    SetReal,
    SetInteger,
    SetBoolean,
    SetString,
    GetFmuState,
    SetFmuState,
    FreeFmuState,
    SerializedFmuStateSize,
    SerializeFmuState,
    DeSerializeFmuState,
    GetDirectionalDerivative,
    SetRealInputDerivatives,
    GetRealOutputDerivatives,
    DoStep,
    CancelStep,
    GetStatus,
    GetRealStatus,
    GetIntegerStatus,
    GetBooleanStatus,
    GetStringStatus,
    SetTime,
    SetContinuousStates,
    EnterEventMode,
    NewDiscreteStates,
    EnterContinuousTimeMode,
    CompletedIntegratorStep,
    GetDerivatives,
    GetEventIndicators,
    GetContinuousStates,
    GetNominalsOfContinuousStates,
}

impl Func {
    /// The C name, used as the prefix of log messages.
    pub fn name(self) -> &'static str {
        match self {
            Func::SetDebugLogging => "fmi2SetDebugLogging",
            Func::FreeInstance => "fmi2FreeInstance",
            Func::SetupExperiment => "fmi2SetupExperiment",
            Func::EnterInitializationMode => "fmi2EnterInitializationMode",
            Func::ExitInitializationMode => "fmi2ExitInitializationMode",
            Func::Terminate => "fmi2Terminate",
            Func::Reset => "fmi2Reset",
            Func::GetReal => "fmi2GetReal",
            Func::GetInteger => "fmi2GetInteger",
            Func::GetBoolean => "fmi2GetBoolean",
            Func::GetString => "fmi2GetString",
            Func::SetReal => "fmi2SetReal",
            Func::SetInteger => "fmi2SetInteger",
            Func::SetBoolean => "fmi2SetBoolean",
            Func::SetString => "fmi2SetString",
            Func::GetFmuState => "fmi2GetFMUstate",
            Func::SetFmuState => "fmi2SetFMUstate",
            Func::FreeFmuState => "fmi2FreeFMUstate",
            Func::SerializedFmuStateSize => "fmi2SerializedFMUstateSize",
            Func::SerializeFmuState => "fmi2SerializeFMUstate",
            Func::DeSerializeFmuState => "fmi2DeSerializeFMUstate",
            Func::GetDirectionalDerivative => "fmi2GetDirectionalDerivative",
            Func::SetRealInputDerivatives => "fmi2SetRealInputDerivatives",
            Func::GetRealOutputDerivatives => "fmi2GetRealOutputDerivatives",
            Func::DoStep => "fmi2DoStep",
            Func::CancelStep => "fmi2CancelStep",
            Func::GetStatus => "fmi2GetStatus",
            Func::GetRealStatus => "fmi2GetRealStatus",
            Func::GetIntegerStatus => "fmi2GetIntegerStatus",
            Func::GetBooleanStatus => "fmi2GetBooleanStatus",
            Func::GetStringStatus => "fmi2GetStringStatus",
            Func::SetTime => "fmi2SetTime",
            Func::SetContinuousStates => "fmi2SetContinuousStates",
            Func::EnterEventMode => "fmi2EnterEventMode",
            Func::NewDiscreteStates => "fmi2NewDiscreteStates",
            Func::EnterContinuousTimeMode => "fmi2EnterContinuousTimeMode",
            Func::CompletedIntegratorStep => "fmi2CompletedIntegratorStep",
            Func::GetDerivatives => "fmi2GetDerivatives",
            Func::GetEventIndicators => "fmi2GetEventIndicators",
            Func::GetContinuousStates => "fmi2GetContinuousStates",
            Func::GetNominalsOfContinuousStates => "fmi2GetNominalsOfContinuousStates",
        }
    }

    /// Every function, in the order of the standard's table.
    pub const ALL: [Func; 41] = [
        Func::SetDebugLogging,
        Func::FreeInstance,
        Func::SetupExperiment,
        Func::EnterInitializationMode,
        Func::ExitInitializationMode,
        Func::Terminate,
        Func::Reset,
        Func::GetReal,
        Func::GetInteger,
        Func::GetBoolean,
        Func::GetString,
        Func::SetReal,
        Func::SetInteger,
        Func::SetBoolean,
        Func::SetString,
        Func::GetFmuState,
        Func::SetFmuState,
        Func::FreeFmuState,
        Func::SerializedFmuStateSize,
        Func::SerializeFmuState,
        Func::DeSerializeFmuState,
        Func::GetDirectionalDerivative,
        Func::SetRealInputDerivatives,
        Func::GetRealOutputDerivatives,
        Func::DoStep,
        Func::CancelStep,
        Func::GetStatus,
        Func::GetRealStatus,
        Func::GetIntegerStatus,
        Func::GetBooleanStatus,
        Func::GetStringStatus,
        Func::SetTime,
        Func::SetContinuousStates,
        Func::EnterEventMode,
        Func::NewDiscreteStates,
        Func::EnterContinuousTimeMode,
        Func::CompletedIntegratorStep,
        Func::GetDerivatives,
        Func::GetEventIndicators,
        Func::GetContinuousStates,
        Func::GetNominalsOfContinuousStates,
    ];

    /// Whether the function belongs to Model Exchange only (refused on a Co-Simulation
    /// instance, whatever its state).
    pub fn model_exchange_only(self) -> bool {
        matches!(
            self,
            Func::SetTime
                | Func::SetContinuousStates
                | Func::EnterEventMode
                | Func::NewDiscreteStates
                | Func::EnterContinuousTimeMode
                | Func::CompletedIntegratorStep
                | Func::GetDerivatives
                | Func::GetEventIndicators
                | Func::GetContinuousStates
                | Func::GetNominalsOfContinuousStates
        )
    }

    /// Whether the function belongs to Co-Simulation only (refused on a Model Exchange
    /// instance, whatever its state).
    pub fn co_simulation_only(self) -> bool {
        matches!(
            self,
            Func::SetRealInputDerivatives
                | Func::GetRealOutputDerivatives
                | Func::DoStep
                | Func::CancelStep
                | Func::GetStatus
                | Func::GetRealStatus
                | Func::GetIntegerStatus
                | Func::GetBooleanStatus
                | Func::GetStringStatus
        )
    }

    /// The functions allowed in `mode`, as text for messages ("a, b and c"), read from
    /// [`Func::allowed_in`] so the message and the table cannot disagree.
    pub fn allowed_list(mode: Mode) -> String {
        let names: Vec<&str> = Func::ALL
            .iter()
            .filter(|f| f.allowed_in(mode))
            .map(|f| f.name())
            .collect();
        match names.split_last() {
            None => "nothing".to_string(),
            Some((last, [])) => last.to_string(),
            Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
        }
    }

    /// Whether the standard allows this call in `mode` (the CS calling-sequence table).
    pub fn allowed_in(self, mode: Mode) -> bool {
        use Mode::*;
        // Fatal: the instance may only be freed.
        if mode == Fatal {
            return self == Func::FreeInstance;
        }
        match self {
            Func::SetDebugLogging | Func::FreeInstance | Func::Reset => true,
            Func::SetupExperiment | Func::EnterInitializationMode => mode == Instantiated,
            Func::ExitInitializationMode => mode == InitializationMode,
            // Not in Error: there the standard allows only getters, the FMU-state functions,
            // fmi2Reset and fmi2FreeInstance (plus fmi2SetDebugLogging).
            Func::Terminate => {
                matches!(
                    mode,
                    StepComplete | StepFailed | EventMode | ContinuousTimeMode
                )
            }
            Func::GetReal | Func::GetInteger | Func::GetBoolean | Func::GetString => {
                matches!(
                    mode,
                    InitializationMode
                        | StepComplete
                        | StepFailed
                        | Terminated
                        | Error
                        | EventMode
                        | ContinuousTimeMode
                )
            }
            // Which variables may be set is decided per variable by `may_set`.
            Func::SetReal => matches!(
                mode,
                Instantiated | InitializationMode | StepComplete | EventMode | ContinuousTimeMode
            ),
            Func::SetInteger | Func::SetBoolean | Func::SetString => {
                matches!(
                    mode,
                    Instantiated | InitializationMode | StepComplete | EventMode
                )
            }
            Func::SetTime => matches!(mode, EventMode | ContinuousTimeMode),
            Func::SetContinuousStates | Func::CompletedIntegratorStep => mode == ContinuousTimeMode,
            Func::EnterEventMode => matches!(mode, EventMode | ContinuousTimeMode),
            Func::NewDiscreteStates | Func::EnterContinuousTimeMode => mode == EventMode,
            Func::GetDerivatives | Func::GetEventIndicators | Func::GetContinuousStates => {
                matches!(
                    mode,
                    InitializationMode | EventMode | ContinuousTimeMode | Terminated | Error
                )
            }
            Func::GetNominalsOfContinuousStates => matches!(
                mode,
                Instantiated | EventMode | ContinuousTimeMode | Terminated | Error
            ),
            Func::GetFmuState
            | Func::SetFmuState
            | Func::FreeFmuState
            | Func::SerializedFmuStateSize
            | Func::SerializeFmuState
            | Func::DeSerializeFmuState => true,
            Func::GetDirectionalDerivative => {
                matches!(
                    mode,
                    InitializationMode
                        | StepComplete
                        | StepFailed
                        | Terminated
                        | Error
                        | EventMode
                        | ContinuousTimeMode
                )
            }
            Func::SetRealInputDerivatives => {
                matches!(mode, Instantiated | InitializationMode | StepComplete)
            }
            Func::GetRealOutputDerivatives => {
                matches!(mode, StepComplete | StepFailed | Terminated | Error)
            }
            Func::DoStep => mode == StepComplete,
            // Only while a step is pending, which never happens.
            Func::CancelStep => false,
            Func::GetStatus
            | Func::GetRealStatus
            | Func::GetIntegerStatus
            | Func::GetBooleanStatus
            | Func::GetStringStatus => matches!(mode, StepComplete | StepFailed | Terminated),
        }
    }
}

/// Whether `var` may be set with `fmi2Set*` in `mode` (footnotes of the CS state table):
/// - Instantiated: variability ≠ constant with initial exact or approx, and inputs;
/// - InitializationMode: variability ≠ constant with initial exact, and inputs;
/// - StepComplete: inputs and tunable parameters.
///
/// `Err` carries the reason, for the log message.
pub fn may_set(var: &Variable, mode: Mode) -> Result<(), String> {
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
        return Err(format!("{} is a constant and cannot be set", what()));
    }
    if matches!(var.causality, Causality::Independent) {
        return Err(format!(
            "{} is the independent variable and cannot be set",
            what()
        ));
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
        Err(format!(
            "{} cannot be set in state {}: {rule}",
            what(),
            mode.name()
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn do_step_only_in_step_complete() {
        for m in [
            Mode::Instantiated,
            Mode::InitializationMode,
            Mode::StepFailed,
            Mode::Terminated,
            Mode::Error,
            Mode::Fatal,
        ] {
            assert!(!Func::DoStep.allowed_in(m), "{m:?}");
        }
        assert!(Func::DoStep.allowed_in(Mode::StepComplete));
    }

    #[test]
    fn fatal_allows_only_free() {
        assert!(Func::FreeInstance.allowed_in(Mode::Fatal));
        assert!(!Func::Reset.allowed_in(Mode::Fatal));
        assert!(!Func::GetReal.allowed_in(Mode::Fatal));
    }

    #[test]
    fn error_allows_get_reset_and_state() {
        for f in [
            Func::GetReal,
            Func::Reset,
            Func::SetFmuState,
            Func::FreeInstance,
        ] {
            assert!(f.allowed_in(Mode::Error), "{f:?}");
        }
        for f in [
            Func::SetReal,
            Func::DoStep,
            Func::ExitInitializationMode,
            Func::Terminate,
        ] {
            assert!(!f.allowed_in(Mode::Error), "{f:?}");
        }
    }

    #[test]
    fn allowed_list_reads_the_table() {
        let e = Func::allowed_list(Mode::Error);
        assert!(e.contains("fmi2GetReal") && e.contains("fmi2Reset"), "{e}");
        assert!(
            !e.contains("fmi2Terminate") && !e.contains("fmi2DoStep"),
            "{e}"
        );
        assert_eq!(Func::allowed_list(Mode::Fatal), "fmi2FreeInstance");
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
        assert!(e.contains("\"p\"") && e.contains("tunable"), "{e}");
        assert!(may_set(&input, Mode::Terminated).is_err());
    }
}
