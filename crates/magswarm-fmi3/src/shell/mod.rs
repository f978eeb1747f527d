//! The FMI 3.0 entry points (Co-Simulation and Model Exchange) as generic `unsafe fn`s over
//! an [`FmuModel`].
//!
//! One entry point per function of the standard, all with the same prologue (`entry`),
//! grouped as the standard groups them: [`lifecycle`], [`values`], [`fmu_state`] (FMU
//! states, derivatives, dependencies), [`cs`] (Co-Simulation, and the clock functions this
//! FMU has no use for), [`me`] (Model Exchange). Everything after the pointer checks is the
//! version-neutral [`magswarm_fmi_core::Instance`], shared with the FMI 2.0 shell, so the
//! two versions check and answer every call the same way.
//!
//! [`crate::export_fmi3!`] wraps each of these in a `#[no_mangle] extern "C"` function in
//! the FMU's cdylib. Each one:
//!
//! 1. checks the instance pointer (NULL, or not one of ours → `fmi3Error`);
//! 2. refuses a function of the other interface, then checks the mode
//!    ([`Func::allowed_in`]) → `fmi3Error` and a log message;
//! 3. checks array pointers (NULL with a non-zero count → `fmi3Error`) and array lengths;
//! 4. runs the operation inside the panic barrier ([`magswarm_fmi_core::barrier`]), so a
//!    panic anywhere becomes `fmi3Error` with the panic message in the log.
//!
//! # Safety
//!
//! All functions here are `unsafe` because they trust the importer's pointers the way the
//! FMI 3.0 standard says they may: a non-NULL pointer points to valid memory of the stated
//! size, and an `fmi3Instance` / `fmi3FMUState` is one this library handed out (a stale or
//! foreign pointer is detected by a magic number on a best-effort basis only). The standard
//! also says an instance is never called from two threads at once, which is what makes the
//! `&mut Instance` of each call the only reference to it.

use magswarm_fmi_core::barrier::{barrier, report_panic};
use magswarm_fmi_core::{FmuModel, Instance, Status};

use crate::abi::*;
use crate::state::{mode_name, Belongs, Func, Mode};

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

/// First word of a live FMI 3.0 instance ("FMI3INST"): an FMI 2.0 instance of the same
/// library has another word, so a handle of one version is refused by the other.
pub const INSTANCE_MAGIC: u64 = u64::from_le_bytes(*b"FMI3INST");

/// The instance behind `c`, if it is one of ours and alive.
///
/// # Safety
/// `c` is NULL or an instance this library returned for model `M`.
pub(crate) unsafe fn instance<M: FmuModel>(c: Fmi3Instance) -> Option<*mut Instance<M>> {
    // SAFETY: the caller's contract is `from_handle`'s.
    unsafe { Instance::<M>::from_handle(c, INSTANCE_MAGIC) }
}

/// Common prologue/epilogue: pointer check, interface and state check, panic barrier.
///
/// Inlined into every entry point, where `func` is a constant: the interface, capability
/// and state checks then fold into one test of the mode ([`permitted`]); everything that
/// builds a message (a refused call, a caught panic) is out of line ([`refuse`],
/// [`after_panic`]).
///
/// # Safety
/// `c` is NULL or an instance this library returned for model `M`, not used by another
/// thread during the call.
#[inline(always)]
pub(crate) unsafe fn entry<M: FmuModel>(
    c: Fmi3Instance,
    func: Func,
    body: impl FnOnce(&mut Instance<M>) -> Status,
) -> Fmi3Status {
    // SAFETY: `c` is NULL or an instance of this library (caller's contract).
    let Some(inst) = (unsafe { instance::<M>(c) }) else {
        // Nothing to log through: the logger lives in the instance.
        return Status::Error;
    };
    // The checks first, outside the barrier: they read two fields and compare constants
    // (nothing in them can panic), and here, inlined where `func` is a constant, they fold
    // into one test of the mode.
    // SAFETY: `inst` is a live instance (magic checked) and the importer makes no other
    // call on it while this one runs, so this shared reference is the only one.
    let ok = {
        let i = unsafe { &*inst };
        permitted::<M>(func, i.mode(), i.is_model_exchange())
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
        Ok(s) => s,
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
unsafe fn refused<M: FmuModel>(inst: *mut Instance<M>, func: Func) -> Fmi3Status {
    // SAFETY: the caller's contract.
    match barrier(|| refuse(unsafe { &mut *inst }, func)) {
        Ok(s) => s,
        // SAFETY: as above; the reference ended with the panic.
        Err(payload) => unsafe { after_panic(inst, func, payload) },
    }
}

/// Whether `func` may run now: it belongs to the instance's interface, the model provides
/// its capability, and the state machine allows it in `mode`. Exactly the conditions
/// [`refuse`] explains; with a constant `func` this folds to a test of `mode`.
#[inline(always)]
fn permitted<M: FmuModel>(func: Func, mode: Mode, model_exchange: bool) -> bool {
    let interface_ok = match func.interface() {
        Belongs::Both => true,
        Belongs::ModelExchange => model_exchange,
        Belongs::CoSimulation => !model_exchange,
    };
    let capability_ok = match func.capability() {
        None => true,
        Some((magswarm_fmi_core::Capability::FmuState, _)) => M::CAN_GET_AND_SET_FMU_STATE,
        Some((magswarm_fmi_core::Capability::Derivatives, _)) => M::PROVIDES_DIRECTIONAL_DERIVATIVE,
    };
    interface_ok && capability_ok && func.allowed_in(mode)
}

/// A call [`permitted`] refused: log why and return the error.
#[cold]
#[inline(never)]
fn refuse<M: FmuModel>(i: &mut Instance<M>, func: Func) -> Status {
    let me = i.is_model_exchange();
    let wrong = match func.interface() {
        Belongs::Both => None,
        Belongs::ModelExchange if !me => Some(("Co-Simulation", "Model Exchange")),
        Belongs::CoSimulation if me => Some(("Model Exchange", "Co-Simulation")),
        _ => None,
    };
    if let Some((is, belongs)) = wrong {
        return i.fail(
            func.name(),
            Status::Error,
            format!(
                "illegal call: this instance was instantiated for {is} and this function \
                 belongs to {belongs}"
            ),
        );
    }
    if let Some((cap, attribute)) = func.capability() {
        if let Some(s) = i.refuse_unsupported(func.name(), cap, attribute) {
            return s;
        }
    }
    let mode = i.mode();
    let hint = match (func, mode) {
        (Func::DoStep, Mode::Instantiated) => {
            " (call fmi3EnterInitializationMode and fmi3ExitInitializationMode first)".to_string()
        }
        (Func::DoStep, Mode::InitializationMode) => {
            " (call fmi3ExitInitializationMode first)".to_string()
        }
        (Func::EnterStepMode, _) => " (this FMU has no event mode in Co-Simulation: \
             fmi3ExitInitializationMode leads to Step Mode directly)"
            .to_string(),
        (Func::ExitConfigurationMode, _) => {
            " (this FMU has no structural parameters, so no configuration mode)".to_string()
        }
        (_, Mode::Error | Mode::Fatal) => format!(
            " (allowed in state {}: {})",
            mode_name(mode),
            Func::allowed_list(mode)
        ),
        _ => String::new(),
    };
    i.fail(
        func.name(),
        Status::Error,
        format!(
            "illegal call sequence: not allowed in state {}{hint}",
            mode_name(mode)
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
) -> Fmi3Status {
    report_panic(payload, |msg| {
        // SAFETY: the caller's contract.
        unsafe { &mut *inst }.fail(func.name(), Status::Error, msg)
    })
}

/// Log "argument `arg` must not be NULL" as an error of `func`.
pub(crate) fn null_arg<M: FmuModel>(i: &mut Instance<M>, func: Func, arg: &str) -> Status {
    i.fail(
        func.name(),
        Status::Error,
        format!("argument {arg} must not be NULL"),
    )
}

/// FMI 3.0 passes the length of value arrays beside the number of value references
/// (arrays of arrays): every variable here is a scalar, so the two must be equal.
pub(crate) fn check_n_values<M: FmuModel>(
    i: &mut Instance<M>,
    func: Func,
    nvr: usize,
    n_values: usize,
) -> Result<(), Status> {
    if nvr == n_values {
        Ok(())
    } else {
        Err(i.fail(
            func.name(),
            Status::Error,
            format!(
                "nValues = {n_values} but nValueReferences = {nvr}: every variable of this FMU \
                 is a scalar, so they must be equal"
            ),
        ))
    }
}

/// The function exists in the standard but has nothing to act on here: an error naming
/// why (`fmi3Error` is the standard's answer for an unsupported function).
pub(crate) fn unsupported<M: FmuModel>(i: &mut Instance<M>, func: Func, why: &str) -> Status {
    i.fail(func.name(), Status::Error, format!("not supported: {why}"))
}
