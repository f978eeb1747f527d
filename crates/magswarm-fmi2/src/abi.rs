//! The C types of the FMI 2.0 ABI, spelled out in Rust.
//!
//! These mirror `fmi2TypesPlatform.h` and `fmi2FunctionTypes.h` of the standard; this module
//! depends on nothing else in the crate. They are
//! written by hand because no crate exports (as opposed to imports) FMI 2.0 well, and
//! because the exact widths matter: `fmi2Boolean` is a C `int`, not a Rust `bool`, and
//! enums that *come in* from the importer are taken as plain `c_int` so that an
//! out-of-range value is a logged error rather than undefined behaviour in Rust.

use std::ffi::{c_char, c_int, c_uint, c_void};

/// `fmi2Component`: the opaque instance handle handed to the importer.
pub type Fmi2Component = *mut c_void;
/// `fmi2ComponentEnvironment`: the importer's opaque pointer, passed back to its logger.
pub type Fmi2ComponentEnvironment = *mut c_void;
/// `fmi2FMUstate`: the opaque handle of a saved FMU state.
pub type Fmi2FmuState = *mut c_void;
/// `fmi2ValueReference`.
pub type Fmi2ValueReference = c_uint;
/// `fmi2Real`.
pub type Fmi2Real = f64;
/// `fmi2Integer`.
pub type Fmi2Integer = c_int;
/// `fmi2Boolean`: a C `int`; any non-zero value is true on input, we write 1 or 0.
pub type Fmi2Boolean = c_int;
/// `fmi2Char`.
pub type Fmi2Char = c_char;
/// `fmi2String`: a NUL-terminated C string owned by whoever passed it.
pub type Fmi2String = *const c_char;
/// `fmi2Byte`.
pub type Fmi2Byte = c_char;

/// `fmi2True`.
pub const FMI2_TRUE: Fmi2Boolean = 1;
/// `fmi2False`.
pub const FMI2_FALSE: Fmi2Boolean = 0;

/// What `fmi2GetTypesPlatform` returns (NUL-terminated so it can be handed out as is).
pub const FMI2_TYPES_PLATFORM: &[u8] = b"default\0";
/// What `fmi2GetVersion` returns.
pub const FMI2_VERSION: &[u8] = b"2.0\0";

/// `fmi2Status` (the neutral [`magswarm_fmi_core::Status`] plus `fmi2Pending`).
///
/// The order is the severity order of the standard, so `max` of two statuses is the
/// status to report for a call that did two things.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Fmi2Status {
    /// `fmi2OK`.
    Ok = 0,
    /// `fmi2Warning`: done, but something is questionable (logged).
    Warning = 1,
    /// `fmi2Discard`: the call was not carried out (e.g. a step that could not be taken).
    Discard = 2,
    /// `fmi2Error`: the instance cannot continue without `fmi2Reset` or `fmi2SetFMUstate`.
    Error = 3,
    /// `fmi2Fatal`: the instance can only be freed.
    Fatal = 4,
    /// `fmi2Pending`: never produced here (no asynchronous `fmi2DoStep`).
    Pending = 5,
}

impl From<magswarm_fmi_core::Status> for Fmi2Status {
    /// The neutral status by value (the numbers are the same in FMI 2.0).
    fn from(s: magswarm_fmi_core::Status) -> Self {
        use magswarm_fmi_core::Status as S;
        match s {
            S::Ok => Fmi2Status::Ok,
            S::Warning => Fmi2Status::Warning,
            S::Discard => Fmi2Status::Discard,
            S::Error => Fmi2Status::Error,
            S::Fatal => Fmi2Status::Fatal,
        }
    }
}

impl From<Fmi2Status> for i32 {
    /// The C value.
    fn from(s: Fmi2Status) -> i32 {
        s as i32
    }
}

/// `fmi2Type` as an integer: `fmi2ModelExchange`.
pub const FMI2_MODEL_EXCHANGE: c_int = 0;
/// `fmi2Type` as an integer: `fmi2CoSimulation`.
pub const FMI2_CO_SIMULATION: c_int = 1;

/// `fmi2StatusKind` as an integer: `fmi2DoStepStatus`.
pub const FMI2_DO_STEP_STATUS: c_int = 0;
/// `fmi2StatusKind` as an integer: `fmi2PendingStatus`.
pub const FMI2_PENDING_STATUS: c_int = 1;
/// `fmi2StatusKind` as an integer: `fmi2LastSuccessfulTime`.
pub const FMI2_LAST_SUCCESSFUL_TIME: c_int = 2;
/// `fmi2StatusKind` as an integer: `fmi2Terminated`.
pub const FMI2_TERMINATED: c_int = 3;

/// `fmi2CallbackLogger`. It is variadic in C (`message` is a printf format), so the shell
/// always passes a fully formatted message with `%` doubled and no extra arguments.
pub type Fmi2CallbackLogger = unsafe extern "C" fn(
    env: Fmi2ComponentEnvironment,
    instance_name: Fmi2String,
    status: Fmi2Status,
    category: Fmi2String,
    message: Fmi2String,
    ...
);

/// `fmi2CallbackAllocateMemory` (never called: `canNotUseMemoryManagementFunctions="true"`).
pub type Fmi2CallbackAllocateMemory = unsafe extern "C" fn(n: usize, size: usize) -> *mut c_void;
/// `fmi2CallbackFreeMemory` (never called).
pub type Fmi2CallbackFreeMemory = unsafe extern "C" fn(obj: *mut c_void);
/// `fmi2StepFinished` (never called: `fmi2DoStep` is synchronous).
pub type Fmi2StepFinished = unsafe extern "C" fn(env: Fmi2ComponentEnvironment, status: Fmi2Status);

/// `fmi2CallbackFunctions`. Function pointers are `Option` because importers may pass
/// NULL for the ones they do not provide; only `logger` is ever used.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct Fmi2CallbackFunctions {
    /// The importer's logger (NULL tolerated: then nothing is logged).
    pub logger: Option<Fmi2CallbackLogger>,
    /// Ignored.
    pub allocate_memory: Option<Fmi2CallbackAllocateMemory>,
    /// Ignored.
    pub free_memory: Option<Fmi2CallbackFreeMemory>,
    /// Ignored.
    pub step_finished: Option<Fmi2StepFinished>,
    /// Passed back as the first argument of every logger call.
    pub component_environment: Fmi2ComponentEnvironment,
}

/// `fmi2EventInfo` (Model Exchange), filled by `fmi2NewDiscreteStates`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct Fmi2EventInfo {
    /// `newDiscreteStatesNeeded`.
    pub new_discrete_states_needed: Fmi2Boolean,
    /// `terminateSimulation`.
    pub terminate_simulation: Fmi2Boolean,
    /// `nominalsOfContinuousStatesChanged`.
    pub nominals_of_continuous_states_changed: Fmi2Boolean,
    /// `valuesOfContinuousStatesChanged`.
    pub values_of_continuous_states_changed: Fmi2Boolean,
    /// `nextEventTimeDefined`.
    pub next_event_time_defined: Fmi2Boolean,
    /// `nextEventTime`.
    pub next_event_time: Fmi2Real,
}
