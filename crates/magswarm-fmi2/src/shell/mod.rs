//! The FMI 2.0 entry points (Co-Simulation and Model Exchange) as generic `unsafe fn`s over
//! an [`FmuModel`].
//!
//! One entry point per function of the standard, all with the same prologue (`entry`),
//! grouped as the standard groups them: [`lifecycle`], [`values`], [`fmu_state`] (FMU
//! states and directional derivatives), [`cs`] (Co-Simulation), [`me`] (Model Exchange).
//! Everything after the pointer checks is the version-neutral
//! [`magswarm_fmi_core::Instance`]; this module only speaks FMI 2.0's C types.
//!
//! [`crate::export_fmi2!`] wraps each of these in a `#[no_mangle] extern "C"` function in
//! the FMU's cdylib (generic functions cannot be exported directly). Each one:
//!
//! 1. checks the instance pointer (NULL, or not one of ours → `fmi2Error`);
//! 2. checks the state machine ([`Func::allowed_in`]) → `fmi2Error` and a log message;
//! 3. checks array pointers (NULL with a non-zero count → `fmi2Error`);
//! 4. runs the operation inside the panic barrier ([`magswarm_fmi_core::barrier`]), so a panic anywhere in the model or the
//!    shell becomes `fmi2Error` with the panic message in the log, never unwinding into C
//!    (which would abort the importer's process).
//!
//! # Safety
//!
//! All functions here are `unsafe` because they trust the importer's pointers the way the
//! FMI standard says they may: a non-NULL pointer points to valid memory of the stated
//! size, and an `fmi2Component` / `fmi2FMUstate` is one this library handed out (a stale
//! or foreign pointer is detected by a magic number on a best-effort basis only). The
//! standard also says an instance is never called from two threads at once, which is what
//! makes the `&mut Instance` of each call the only reference to it. Every dereference below
//! carries a `SAFETY` comment naming which of these promises it relies on
//! (`unsafe_op_in_unsafe_fn` is denied crate-wide, so none is implicit).

use magswarm_fmi_core::barrier::{barrier, report_panic};
use magswarm_fmi_core::{FmuModel, Instance, Status};

use crate::abi::*;
use crate::state::{Func, Mode};

pub mod cs;
pub mod fmu_state;
pub mod lifecycle;
pub mod me;
pub mod values;

pub use cs::*;
pub use fmu_state::*;
pub use lifecycle::*;
pub use me::*;
pub use values::*;

/// First word of a live FMI 2.0 instance ("FMI2INST"), to recognise our pointers (an FMI
/// 3.0 instance of the same library has another word, so the versions cannot be mixed).
pub const INSTANCE_MAGIC: u64 = u64::from_le_bytes(*b"FMI2INST");

/// The instance behind `c`, if it is one of ours and alive.
///
/// # Safety
/// `c` is NULL or a component this library returned for model `M`.
pub(crate) unsafe fn instance<M: FmuModel>(c: Fmi2Component) -> Option<*mut Instance<M>> {
    // SAFETY: the caller's contract is `from_handle`'s.
    unsafe { Instance::<M>::from_handle(c, INSTANCE_MAGIC) }
}

/// Common prologue/epilogue: pointer check, interface and state check, panic barrier.
///
/// Inlined into every entry point, where `func` is a constant: the interface, capability
/// and state checks then fold into one test of the mode ([`permitted`]); everything that
/// builds a message (a refused call, a caught panic) is out of line ([`refuse`],
/// [`after_panic`]), so the accepted call pays for the checks and nothing else.
///
/// # Safety
/// `c` is NULL or a component this library returned for model `M`, not used by another
/// thread during the call (FMI 2.0 section 2.1.5).
#[inline(always)]
pub(crate) unsafe fn entry<M: FmuModel>(
    c: Fmi2Component,
    func: Func,
    body: impl FnOnce(&mut Instance<M>) -> Status,
) -> Fmi2Status {
    // SAFETY: `c` is NULL or a component of this library (caller's contract).
    let Some(inst) = (unsafe { instance::<M>(c) }) else {
        // Nothing to log through: the logger lives in the instance.
        return Fmi2Status::Error;
    };
    // The checks first, outside the barrier: they read two fields and compare constants
    // (nothing in them can panic), and here, inlined where `func` is a constant, they fold
    // into one test of the mode.
    // SAFETY: `inst` is a live instance (magic checked) and the importer makes no other
    // call on it while this one runs, so this shared reference is the only one.
    let ok = {
        let i = unsafe { &*inst };
        permitted::<M>(func, i.shell.mode, i.is_model_exchange())
    };
    if !ok {
        // SAFETY: as above (the shared reference has ended).
        return unsafe { refused(inst, func) };
    }
    let result = barrier(|| {
        // SAFETY: as above; this is the only reference for the body's duration.
        body(unsafe { &mut *inst })
    });
    match result {
        Ok(s) => s.into(),
        // SAFETY: as above; the body's reference ended with its panic.
        Err(payload) => unsafe { after_panic(inst, func, payload) },
    }
}

/// A call [`permitted`] refused: explain it in the log ([`refuse`], under the barrier like
/// every other body) and return the error.
///
/// # Safety
/// `inst` is a live instance with no other reference during the call.
#[cold]
#[inline(never)]
unsafe fn refused<M: FmuModel>(inst: *mut Instance<M>, func: Func) -> Fmi2Status {
    // SAFETY: the caller's contract.
    match barrier(|| refuse(unsafe { &mut *inst }, func)) {
        Ok(s) => s.into(),
        // SAFETY: as above; the reference ended with the panic.
        Err(payload) => unsafe { after_panic(inst, func, payload) },
    }
}

/// Whether `func` may run now: it belongs to the instance's interface, the model provides
/// its capability, and the state machine allows it in `mode`. Exactly the conditions
/// [`refuse`] explains; with a constant `func` this folds to a test of `mode`.
#[inline(always)]
fn permitted<M: FmuModel>(func: Func, mode: Mode, model_exchange: bool) -> bool {
    let interface_ok = if model_exchange {
        !func.co_simulation_only()
    } else {
        !func.model_exchange_only()
    };
    let capability_ok = match func.capability() {
        None => true,
        Some((magswarm_fmi_core::Capability::FmuState, _)) => M::CAN_GET_AND_SET_FMU_STATE,
        Some((magswarm_fmi_core::Capability::Derivatives, _)) => M::PROVIDES_DIRECTIONAL_DERIVATIVE,
    };
    interface_ok && capability_ok && func.allowed_in(mode)
}

/// A call [`permitted`] refused: log why (wrong interface, capability not provided, or not
/// allowed in this state, with a hint) and return the error.
#[cold]
#[inline(never)]
fn refuse<M: FmuModel>(i: &mut Instance<M>, func: Func) -> Status {
    let mode = i.shell.mode;
    let me = i.is_model_exchange();
    if me && func.co_simulation_only() {
        return i.fail(
            func.name(),
            Status::Error,
            "illegal call: this instance was instantiated as fmi2ModelExchange and this \
             function belongs to Co-Simulation",
        );
    }
    if !me && func.model_exchange_only() {
        return i.fail(
            func.name(),
            Status::Error,
            "illegal call: this instance was instantiated as fmi2CoSimulation and this \
             function belongs to Model Exchange",
        );
    }
    if let Some((cap, attribute)) = func.capability() {
        if let Some(s) = i.refuse_unsupported(func.name(), cap, attribute) {
            return s;
        }
    }
    let hint = match func {
        Func::CancelStep => {
            " (fmi2DoStep of this FMU never returns fmi2Pending, so there is nothing to cancel)"
        }
        Func::GetStatus
        | Func::GetRealStatus
        | Func::GetIntegerStatus
        | Func::GetBooleanStatus
        | Func::GetStringStatus => " (allowed after fmi2ExitInitializationMode)",
        Func::DoStep if mode == Mode::InitializationMode => {
            " (call fmi2ExitInitializationMode first)"
        }
        Func::DoStep if mode == Mode::Instantiated => {
            " (call fmi2EnterInitializationMode and fmi2ExitInitializationMode first)"
        }
        _ => "",
    };
    let hint = match mode {
        Mode::Error | Mode::Fatal => format!(
            "{hint} (allowed in state {}: {})",
            mode.name(),
            Func::allowed_list(mode)
        ),
        _ => hint.to_string(),
    };
    i.fail(
        func.name(),
        Status::Error,
        format!(
            "illegal call sequence: not allowed in state {}{hint}",
            mode.name()
        ),
    )
}

/// The body panicked: log the panic's message through the importer's logger (itself under
/// the barrier) and return the error.
///
/// # Safety
/// `inst` is the live instance of the call whose body panicked, with no other reference.
#[cold]
#[inline(never)]
unsafe fn after_panic<M: FmuModel>(
    inst: *mut Instance<M>,
    func: Func,
    payload: Box<dyn std::any::Any + Send>,
) -> Fmi2Status {
    report_panic(payload, |msg| {
        // SAFETY: the caller's contract.
        unsafe { &mut *inst }.fail(func.name(), Status::Error, msg)
    })
    .into()
}

pub(crate) fn null_arg<M: FmuModel>(i: &mut Instance<M>, func: Func, arg: &str) -> Status {
    i.fail(
        func.name(),
        Status::Error,
        format!("argument {arg} must not be NULL"),
    )
}
