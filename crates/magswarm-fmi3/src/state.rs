//! The state machine of FMI 3.0 (standard, sections 3.2 for Model Exchange and 4.2 for
//! Co-Simulation): which function may be called in which mode. A function of the other
//! interface is refused before this table is consulted ([`Func::interface`]); which
//! variables may be set in which mode is the core's ([`magswarm_fmi_core::mode::may_set`]).
//!
//! The modes are the core's ([`Mode`]); FMI 3.0 calls `StepComplete` "Step Mode". This shell
//! has no clocks, no structural parameters and no Scheduled Execution, and Co-Simulation
//! without event mode (`hasEventMode` is absent), so Configuration Mode, Clock Activation
//! Mode, Intermediate Update Mode and Reconfiguration Mode never occur: the functions that
//! belong to them are refused with a message saying why.

pub use magswarm_fmi_core::mode::{may_set, Mode};
use magswarm_fmi_core::Capability;

/// Which interface a function belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Belongs {
    /// Both interfaces.
    Both,
    /// Model Exchange only.
    ModelExchange,
    /// Co-Simulation only.
    CoSimulation,
}

macro_rules! funcs {
    ($($v:ident = $name:literal, $belongs:ident;)*) => {
        /// Every instance function of FMI 3.0 that this shell checks against the modes.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        #[allow(missing_docs)]
        pub enum Func { $($v),* }

        impl Func {
    /// The optional group this function belongs to, with the XML attribute that declares it.
    #[inline(always)]
    pub fn capability(self) -> Option<(Capability, &'static str)> {
        match self {
            Func::GetFmuState
            | Func::SetFmuState
            | Func::FreeFmuState
            | Func::SerializedFmuStateSize
            | Func::SerializeFmuState
            | Func::DeserializeFmuState => Some((Capability::FmuState, "canGetAndSetFMUState")),
            Func::GetDirectionalDerivative => {
                Some((Capability::Derivatives, "providesDirectionalDerivatives"))
            }
            Func::GetAdjointDerivative => {
                Some((Capability::Derivatives, "providesAdjointDerivatives"))
            }
            _ => None,
        }
    }

            /// Every function, in the order of `fmi3Functions.h`.
            pub const ALL: &'static [Func] = &[$(Func::$v),*];

            /// The C name, used as the prefix of log messages (inline: a constant where the function
            /// is one, as in every entry point).
            #[inline(always)]
            pub fn name(self) -> &'static str {
                match self { $(Func::$v => $name),* }
            }

            /// The interface the function belongs to.
            #[inline(always)]
            pub fn interface(self) -> Belongs {
                match self { $(Func::$v => Belongs::$belongs),* }
            }
        }
    };
}

funcs! {
    SetDebugLogging = "fmi3SetDebugLogging", Both;
    FreeInstance = "fmi3FreeInstance", Both;
    EnterInitializationMode = "fmi3EnterInitializationMode", Both;
    ExitInitializationMode = "fmi3ExitInitializationMode", Both;
    EnterEventMode = "fmi3EnterEventMode", Both;
    Terminate = "fmi3Terminate", Both;
    Reset = "fmi3Reset", Both;
    GetFloat32 = "fmi3GetFloat32", Both;
    GetFloat64 = "fmi3GetFloat64", Both;
    GetInt8 = "fmi3GetInt8", Both;
    GetUInt8 = "fmi3GetUInt8", Both;
    GetInt16 = "fmi3GetInt16", Both;
    GetUInt16 = "fmi3GetUInt16", Both;
    GetInt32 = "fmi3GetInt32", Both;
    GetUInt32 = "fmi3GetUInt32", Both;
    GetInt64 = "fmi3GetInt64", Both;
    GetUInt64 = "fmi3GetUInt64", Both;
    GetBoolean = "fmi3GetBoolean", Both;
    GetString = "fmi3GetString", Both;
    GetBinary = "fmi3GetBinary", Both;
    GetClock = "fmi3GetClock", Both;
    SetFloat32 = "fmi3SetFloat32", Both;
    SetFloat64 = "fmi3SetFloat64", Both;
    SetInt8 = "fmi3SetInt8", Both;
    SetUInt8 = "fmi3SetUInt8", Both;
    SetInt16 = "fmi3SetInt16", Both;
    SetUInt16 = "fmi3SetUInt16", Both;
    SetInt32 = "fmi3SetInt32", Both;
    SetUInt32 = "fmi3SetUInt32", Both;
    SetInt64 = "fmi3SetInt64", Both;
    SetUInt64 = "fmi3SetUInt64", Both;
    SetBoolean = "fmi3SetBoolean", Both;
    SetString = "fmi3SetString", Both;
    SetBinary = "fmi3SetBinary", Both;
    SetClock = "fmi3SetClock", Both;
    GetNumberOfVariableDependencies = "fmi3GetNumberOfVariableDependencies", Both;
    GetVariableDependencies = "fmi3GetVariableDependencies", Both;
    GetFmuState = "fmi3GetFMUState", Both;
    SetFmuState = "fmi3SetFMUState", Both;
    FreeFmuState = "fmi3FreeFMUState", Both;
    SerializedFmuStateSize = "fmi3SerializedFMUStateSize", Both;
    SerializeFmuState = "fmi3SerializeFMUState", Both;
    DeserializeFmuState = "fmi3DeserializeFMUState", Both;
    GetDirectionalDerivative = "fmi3GetDirectionalDerivative", Both;
    GetAdjointDerivative = "fmi3GetAdjointDerivative", Both;
    EnterConfigurationMode = "fmi3EnterConfigurationMode", Both;
    ExitConfigurationMode = "fmi3ExitConfigurationMode", Both;
    GetIntervalDecimal = "fmi3GetIntervalDecimal", Both;
    GetIntervalFraction = "fmi3GetIntervalFraction", Both;
    GetShiftDecimal = "fmi3GetShiftDecimal", Both;
    GetShiftFraction = "fmi3GetShiftFraction", Both;
    SetIntervalDecimal = "fmi3SetIntervalDecimal", Both;
    SetIntervalFraction = "fmi3SetIntervalFraction", Both;
    SetShiftDecimal = "fmi3SetShiftDecimal", Both;
    SetShiftFraction = "fmi3SetShiftFraction", Both;
    EvaluateDiscreteStates = "fmi3EvaluateDiscreteStates", Both;
    UpdateDiscreteStates = "fmi3UpdateDiscreteStates", ModelExchange;
    EnterContinuousTimeMode = "fmi3EnterContinuousTimeMode", ModelExchange;
    CompletedIntegratorStep = "fmi3CompletedIntegratorStep", ModelExchange;
    SetTime = "fmi3SetTime", ModelExchange;
    SetContinuousStates = "fmi3SetContinuousStates", ModelExchange;
    GetContinuousStateDerivatives = "fmi3GetContinuousStateDerivatives", ModelExchange;
    GetEventIndicators = "fmi3GetEventIndicators", ModelExchange;
    GetContinuousStates = "fmi3GetContinuousStates", ModelExchange;
    GetNominalsOfContinuousStates = "fmi3GetNominalsOfContinuousStates", ModelExchange;
    GetNumberOfEventIndicators = "fmi3GetNumberOfEventIndicators", ModelExchange;
    GetNumberOfContinuousStates = "fmi3GetNumberOfContinuousStates", ModelExchange;
    EnterStepMode = "fmi3EnterStepMode", CoSimulation;
    GetOutputDerivatives = "fmi3GetOutputDerivatives", CoSimulation;
    DoStep = "fmi3DoStep", CoSimulation;
    ActivateModelPartition = "fmi3ActivateModelPartition", Both;
}

/// FMI 3.0's name of a mode, for messages.
pub fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::StepComplete => "StepMode",
        Mode::StepFailed => "StepDiscarded",
        m => m.name(),
    }
}

impl Func {
    /// The functions allowed in `mode`, as text for messages, read from
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

    /// Whether the standard allows this call in `mode`.
    #[inline(always)]
    pub fn allowed_in(self, mode: Mode) -> bool {
        use Func as F;
        use Mode::*;
        if mode == Fatal {
            return self == F::FreeInstance;
        }
        // Getters are allowed in Error for diagnostics, as in FMI 2.0.
        let readable = matches!(
            mode,
            Instantiated
                | InitializationMode
                | EventMode
                | ContinuousTimeMode
                | StepComplete
                | StepFailed
                | Terminated
                | Error
        );
        match self {
            F::SetDebugLogging | F::FreeInstance | F::Reset => true,
            F::EnterInitializationMode => mode == Instantiated,
            F::ExitInitializationMode => mode == InitializationMode,
            F::EnterEventMode => matches!(mode, ContinuousTimeMode | StepComplete),
            F::Terminate => matches!(
                mode,
                ContinuousTimeMode | StepComplete | StepFailed | EventMode
            ),
            F::GetFloat32
            | F::GetFloat64
            | F::GetInt8
            | F::GetUInt8
            | F::GetInt16
            | F::GetUInt16
            | F::GetInt32
            | F::GetUInt32
            | F::GetInt64
            | F::GetUInt64
            | F::GetBoolean
            | F::GetString
            | F::GetBinary => readable,
            F::SetFloat32 | F::SetFloat64 => matches!(
                mode,
                Instantiated | InitializationMode | EventMode | ContinuousTimeMode | StepComplete
            ),
            F::SetInt8
            | F::SetUInt8
            | F::SetInt16
            | F::SetUInt16
            | F::SetInt32
            | F::SetUInt32
            | F::SetInt64
            | F::SetUInt64
            | F::SetBoolean
            | F::SetString
            | F::SetBinary => matches!(
                mode,
                Instantiated | InitializationMode | EventMode | StepComplete
            ),
            F::GetNumberOfVariableDependencies | F::GetVariableDependencies => true,
            F::GetFmuState
            | F::SetFmuState
            | F::FreeFmuState
            | F::SerializedFmuStateSize
            | F::SerializeFmuState
            | F::DeserializeFmuState => true,
            F::GetDirectionalDerivative | F::GetAdjointDerivative => matches!(
                mode,
                InitializationMode
                    | StepComplete
                    | StepFailed
                    | EventMode
                    | ContinuousTimeMode
                    | Terminated
                    | Error
            ),
            // No structural parameters: Configuration Mode is never entered; asking for it
            // gets an explanation where the standard would allow it.
            F::EnterConfigurationMode => matches!(mode, Instantiated | StepComplete | EventMode),
            F::ExitConfigurationMode => false,
            // No clocks: answered with an explanation in any mode.
            F::GetClock
            | F::SetClock
            | F::GetIntervalDecimal
            | F::GetIntervalFraction
            | F::GetShiftDecimal
            | F::GetShiftFraction
            | F::SetIntervalDecimal
            | F::SetIntervalFraction
            | F::SetShiftDecimal
            | F::SetShiftFraction
            | F::EvaluateDiscreteStates
            | F::ActivateModelPartition => true,
            F::UpdateDiscreteStates => mode == EventMode,
            F::EnterContinuousTimeMode => mode == EventMode,
            F::CompletedIntegratorStep | F::SetContinuousStates => mode == ContinuousTimeMode,
            F::SetTime => matches!(mode, EventMode | ContinuousTimeMode),
            F::GetContinuousStateDerivatives
            | F::GetEventIndicators
            | F::GetContinuousStates
            | F::GetNominalsOfContinuousStates => matches!(
                mode,
                InitializationMode | EventMode | ContinuousTimeMode | Terminated | Error
            ),
            F::GetNumberOfEventIndicators | F::GetNumberOfContinuousStates => true,
            // Only from event mode, which a Co-Simulation instance of this shell never has.
            F::EnterStepMode => mode == EventMode,
            F::GetOutputDerivatives => matches!(mode, StepComplete | StepFailed | Terminated),
            F::DoStep => mode == StepComplete,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn do_step_only_in_step_mode() {
        for &m in &[
            Mode::Instantiated,
            Mode::InitializationMode,
            Mode::EventMode,
            Mode::Terminated,
            Mode::Error,
            Mode::Fatal,
        ] {
            assert!(!Func::DoStep.allowed_in(m), "{m:?}");
        }
        assert!(Func::DoStep.allowed_in(Mode::StepComplete));
    }

    #[test]
    fn fatal_allows_only_free_and_error_no_stepping() {
        assert_eq!(Func::allowed_list(Mode::Fatal), "fmi3FreeInstance");
        let e = Func::allowed_list(Mode::Error);
        assert!(
            e.contains("fmi3GetFloat64") && e.contains("fmi3Reset"),
            "{e}"
        );
        assert!(
            !e.contains("fmi3DoStep") && !e.contains("fmi3Terminate"),
            "{e}"
        );
    }

    #[test]
    fn every_function_has_a_unique_c_name() {
        let mut names: Vec<&str> = Func::ALL.iter().map(|f| f.name()).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), Func::ALL.len());
        assert!(names.iter().all(|n| n.starts_with("fmi3")));
    }
}
