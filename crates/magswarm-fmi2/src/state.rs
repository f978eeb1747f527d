//! The state machine of FMI 2.0 (standard, sections 3.2.3 for Model Exchange and 4.2.4 for
//! Co-Simulation): which function may be called in which state, and which variables may be
//! set in which state. A function of the other interface is refused before this table is
//! consulted (`Func::model_exchange_only`, `Func::co_simulation_only`).
//!
//! Checked before anything else in every entry point, so a model never sees a call out of
//! sequence. `StepInProgress` and `StepCanceled` do not exist here because `fmi2DoStep`
//! never returns `fmi2Pending`.

pub use magswarm_fmi_core::mode::{may_set, Mode};
use magswarm_fmi_core::Capability;

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
    /// The C name, used as the prefix of log messages (inline: a constant where the function
    /// is one, as in every entry point).
    #[inline(always)]
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

    /// The optional group this function belongs to, with the XML attribute that declares it.
    #[inline(always)]
    pub fn capability(self) -> Option<(Capability, &'static str)> {
        match self {
            Func::GetFmuState
            | Func::SetFmuState
            | Func::FreeFmuState
            | Func::SerializedFmuStateSize
            | Func::SerializeFmuState
            | Func::DeSerializeFmuState => Some((Capability::FmuState, "canGetAndSetFMUstate")),
            Func::GetDirectionalDerivative => {
                Some((Capability::Derivatives, "providesDirectionalDerivative"))
            }
            _ => None,
        }
    }

    /// Whether the function belongs to Model Exchange only (refused on a Co-Simulation
    /// instance, whatever its state).
    #[inline(always)]
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
    #[inline(always)]
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
    #[inline(always)]
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
}
