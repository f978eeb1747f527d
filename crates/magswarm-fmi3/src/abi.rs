//! The C types of the FMI 3.0 ABI, spelled out in Rust (`fmi3PlatformTypes.h`,
//! `fmi3FunctionTypes.h`).
//!
//! As in the FMI 2.0 shell, what comes *in* from the importer is taken in a type that any bit
//! pattern is valid for: `fmi3Boolean` is a C `bool`, which Rust may not receive as `bool`
//! unless it is exactly 0 or 1, so it arrives as a byte and any non-zero byte is true.
//! `fmi3Status` is the neutral [`magswarm_fmi_core::Status`], whose `#[repr(i32)]` values
//! are the standard's.

use std::ffi::{c_char, c_void};

/// `fmi3Instance`: the opaque instance handle handed to the importer.
pub type Fmi3Instance = *mut c_void;
/// `fmi3InstanceEnvironment`: the importer's pointer, passed back to its callbacks.
pub type Fmi3InstanceEnvironment = *mut c_void;
/// `fmi3FMUState`: the opaque handle of a saved FMU state.
pub type Fmi3FmuState = *mut c_void;
/// `fmi3ValueReference`.
pub type Fmi3ValueReference = u32;
/// `fmi3Boolean` as received: a C `bool`, read as a byte (non-zero is true).
pub type Fmi3Boolean = u8;
/// `fmi3String`: a NUL-terminated C string.
pub type Fmi3String = *const c_char;
/// `fmi3Byte`.
pub type Fmi3Byte = u8;
/// `fmi3Binary`: a pointer to bytes whose length is passed beside it.
pub type Fmi3Binary = *const u8;
/// `fmi3Clock`: a C `bool`, read as a byte.
pub type Fmi3Clock = u8;
/// `fmi3Status`: the neutral status, whose values are FMI 3.0's.
pub type Fmi3Status = magswarm_fmi_core::Status;

/// What `fmi3GetVersion` returns.
pub const FMI3_VERSION: &[u8] = b"3.0\0";

/// `fmi3True` as written by the FMU.
pub const FMI3_TRUE: Fmi3Boolean = 1;
/// `fmi3False` as written by the FMU.
pub const FMI3_FALSE: Fmi3Boolean = 0;

/// `fmi3LogMessageCallback`: a plain message (no `printf` formatting in FMI 3.0).
pub type Fmi3LogMessageCallback = unsafe extern "C" fn(
    env: Fmi3InstanceEnvironment,
    status: Fmi3Status,
    category: Fmi3String,
    message: Fmi3String,
);

/// `fmi3IntermediateUpdateCallback` (never called: no intermediate update).
pub type Fmi3IntermediateUpdateCallback = unsafe extern "C" fn(
    env: Fmi3InstanceEnvironment,
    intermediate_update_time: f64,
    intermediate_variable_set_requested: Fmi3Boolean,
    intermediate_variable_get_allowed: Fmi3Boolean,
    intermediate_step_finished: Fmi3Boolean,
    can_return_early: Fmi3Boolean,
    early_return_requested: *mut Fmi3Boolean,
    early_return_time: *mut f64,
);

/// `fmi3ClockUpdateCallback` (never called: no clocks).
pub type Fmi3ClockUpdateCallback = unsafe extern "C" fn(env: Fmi3InstanceEnvironment);
/// `fmi3LockPreemptionCallback` (never called: no Scheduled Execution).
pub type Fmi3LockPreemptionCallback = unsafe extern "C" fn();
/// `fmi3UnlockPreemptionCallback` (never called).
pub type Fmi3UnlockPreemptionCallback = unsafe extern "C" fn();

/// `fmi3DependencyKind`: `fmi3Dependent`, the only kind this shell reports (a variable
/// depends on another in some way the FMU does not detail).
pub const FMI3_DEPENDENT: std::ffi::c_int = 5;
