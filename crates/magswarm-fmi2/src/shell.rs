//! The FMI 2.0 entry points (Co-Simulation and Model Exchange) as generic `unsafe fn`s over
//! an [`FmuModel`].
//!
//! A long file that is one cohesive thing: one entry point per function of the standard, all
//! with the same prologue, in the order of the standard's API.
//!
//! [`crate::export_fmi2!`] wraps each of these in a `#[no_mangle] extern "C"` function in
//! the FMU's cdylib (generic functions cannot be exported directly). Each one:
//!
//! 1. checks the instance pointer (NULL, or not one of ours → `fmi2Error`);
//! 2. checks the state machine ([`Func::allowed_in`]) → `fmi2Error` and a log message;
//! 3. checks array pointers (NULL with a non-zero count → `fmi2Error`);
//! 4. runs the operation inside `catch_unwind`, so a panic anywhere in the model or the
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

use std::ffi::{c_char, c_int, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};

use crate::abi::*;
use crate::guid::guid_u128;
use crate::instance::{Instance, INSTANCE_MAGIC};
use crate::log::{all_categories, Ctx, Logger, CAT_EVENTS};
use crate::model::{FmuModel, InstantiateArgs};
use crate::snapshot::{self, ShellState, Snapshot, SNAPSHOT_MAGIC};
use crate::state::{Func, Mode};
use crate::table::Table;
use crate::uri::resource_dir;

fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic payload".to_string()
    }
}

/// Drop a panic payload without letting a panicking destructor escape.
fn drop_payload(payload: Box<dyn std::any::Any + Send>) {
    let _ = barrier(move || drop(payload));
}

thread_local! {
    /// How deep this thread is inside the shell's panic barrier.
    static IN_BARRIER: std::cell::Cell<u32> = const { std::cell::Cell::new(0) };
}

/// The panic hook in force before the shell installed its own (called for panics outside
/// the barrier, so a Rust host linking the shell keeps its own reporting).
static PREVIOUS_HOOK: std::sync::OnceLock<PanicHook> = std::sync::OnceLock::new();
/// A panic hook as `std::panic::take_hook` returns it.
type PanicHook = Box<dyn Fn(&std::panic::PanicHookInfo<'_>) + Sync + Send>;
static HOOK: std::sync::Once = std::sync::Once::new();

/// Install (once) a panic hook that stays silent for panics inside the barrier: an FMU must
/// never write to its host's stderr; the message reaches the importer through the logger
/// instead. Panics elsewhere go to the previous hook. In the FMU's own shared library this
/// hook belongs to the library's private copy of std, so the host's hook is not touched.
fn quiet_panics() {
    // `set_hook` panics when called while the thread is panicking (e.g. a Rust host freeing
    // instances while unwinding): try again at a later call.
    if std::thread::panicking() {
        return;
    }
    HOOK.call_once(|| {
        let _ = PREVIOUS_HOOK.set(std::panic::take_hook());
        std::panic::set_hook(Box::new(|info| {
            if IN_BARRIER.with(|d| d.get()) > 0 {
                return;
            }
            if let Some(prev) = PREVIOUS_HOOK.get() {
                prev(info);
            }
        }));
    });
}

/// `catch_unwind` with the quiet hook in force: the panic barrier of every entry point.
pub(crate) fn barrier<R>(f: impl FnOnce() -> R) -> std::thread::Result<R> {
    quiet_panics();
    IN_BARRIER.with(|d| d.set(d.get() + 1));
    let r = catch_unwind(AssertUnwindSafe(f));
    IN_BARRIER.with(|d| d.set(d.get().saturating_sub(1)));
    r
}

/// The instance behind `c`, if it is one of ours and alive.
unsafe fn instance<M: FmuModel>(c: Fmi2Component) -> Option<*mut Instance<M>> {
    // SAFETY: a non-NULL component is one fmi2Instantiate returned (caller's contract): a
    // `#[repr(C)]` Instance whose first field is the u64 magic, so reading 8 bytes is in bounds.
    if c.is_null() || unsafe { (c as *const u64).read() } != INSTANCE_MAGIC {
        return None;
    }
    Some(c as *mut Instance<M>)
}

/// Common prologue/epilogue: pointer check, state check, panic barrier.
unsafe fn entry<M: FmuModel>(
    c: Fmi2Component,
    func: Func,
    body: impl FnOnce(&mut Instance<M>) -> Fmi2Status,
) -> Fmi2Status {
    // SAFETY: `c` is NULL or a component of this library (caller's contract).
    let Some(inst) = (unsafe { instance::<M>(c) }) else {
        // Nothing to log through: the logger lives in the instance.
        return Fmi2Status::Error;
    };
    let result = barrier(|| {
        // SAFETY: `inst` is a live instance (magic checked) and the importer makes no other
        // call on it while this one runs, so this is the only reference.
        let i = unsafe { &mut *inst };
        let mode = i.shell.mode;
        if i.model_exchange && func.co_simulation_only() {
            return i.fail(
                func,
                Fmi2Status::Error,
                "illegal call: this instance was instantiated as fmi2ModelExchange and this \
                 function belongs to Co-Simulation",
            );
        }
        if !i.model_exchange && func.model_exchange_only() {
            return i.fail(
                func,
                Fmi2Status::Error,
                "illegal call: this instance was instantiated as fmi2CoSimulation and this \
                 function belongs to Model Exchange",
            );
        }
        let unsupported = match func {
            Func::GetFmuState
            | Func::SetFmuState
            | Func::FreeFmuState
            | Func::SerializedFmuStateSize
            | Func::SerializeFmuState
            | Func::DeSerializeFmuState => !M::CAN_GET_AND_SET_FMU_STATE,
            Func::GetDirectionalDerivative => !M::PROVIDES_DIRECTIONAL_DERIVATIVE,
            _ => false,
        };
        if unsupported {
            return i.fail(
                func,
                Fmi2Status::Error,
                "not supported by this FMU (its modelDescription.xml says canGetAndSetFMUstate, \
                 canSerializeFMUstate or providesDirectionalDerivative = false)",
            );
        }
        if !func.allowed_in(mode) {
            let hint = match func {
                Func::CancelStep => " (fmi2DoStep of this FMU never returns fmi2Pending, so there is nothing to cancel)",
                Func::GetStatus
                | Func::GetRealStatus
                | Func::GetIntegerStatus
                | Func::GetBooleanStatus
                | Func::GetStringStatus => " (allowed after fmi2ExitInitializationMode)",
                Func::DoStep if mode == Mode::InitializationMode => " (call fmi2ExitInitializationMode first)",
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
            return i.fail(
                func,
                Fmi2Status::Error,
                format!(
                    "illegal call sequence: not allowed in state {}{hint}",
                    mode.name()
                ),
            );
        }
        body(i)
    });
    match result {
        Ok(s) => s,
        Err(payload) => {
            let msg = panic_message(&*payload);
            drop_payload(payload);
            let logged = barrier(|| {
                // SAFETY: as above; the body's reference ended with its panic.
                unsafe { &mut *inst }.fail(
                    func,
                    Fmi2Status::Error,
                    format!("internal error: the model panicked: {msg}"),
                )
            });
            match logged {
                Ok(s) => s,
                Err(p) => {
                    drop_payload(p);
                    Fmi2Status::Error
                }
            }
        }
    }
}

/// A slice from an importer's array: `Ok(&[])` for `n == 0` whatever the pointer,
/// `Err` for NULL with `n > 0`.
unsafe fn slice<'a, T>(p: *const T, n: usize) -> Result<&'a [T], ()> {
    if n == 0 {
        Ok(&[])
    } else if p.is_null() {
        Err(())
    } else {
        // SAFETY: a non-NULL array argument points to `n` valid elements that stay alive and
        // unaliased for the duration of the call (caller's contract, FMI 2.0 section 2.1.2).
        Ok(unsafe { std::slice::from_raw_parts(p, n) })
    }
}

unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> Result<&'a mut [T], ()> {
    if n == 0 {
        Ok(&mut [])
    } else if p.is_null() {
        Err(())
    } else {
        // SAFETY: as in `slice`; the importer gives the FMU this output array to write.
        Ok(unsafe { std::slice::from_raw_parts_mut(p, n) })
    }
}

fn null_arg<M: FmuModel>(i: &mut Instance<M>, func: Func, arg: &str) -> Fmi2Status {
    i.fail(
        func,
        Fmi2Status::Error,
        format!("argument {arg} must not be NULL"),
    )
}

unsafe fn opt_str<'a>(p: *const c_char) -> Option<&'a CStr> {
    if p.is_null() {
        None
    } else {
        // SAFETY: a non-NULL string argument is NUL-terminated and valid during the call
        // (caller's contract).
        Some(unsafe { CStr::from_ptr(p) })
    }
}

// ---------------------------------------------------------------------------------------
// Functions without an instance
// ---------------------------------------------------------------------------------------

/// `fmi2GetTypesPlatform`.
pub fn fmi2_get_types_platform() -> *const c_char {
    FMI2_TYPES_PLATFORM.as_ptr() as *const c_char
}

/// `fmi2GetVersion`.
pub fn fmi2_get_version() -> *const c_char {
    FMI2_VERSION.as_ptr() as *const c_char
}

/// `fmi2Instantiate`. Returns NULL (after logging why, if there is a logger) on: NULL
/// callbacks, missing instance name or GUID, GUID mismatch, Model Exchange for a model
/// without it ([`FmuModel::MODEL_EXCHANGE`]), an unknown fmuType, an invalid
/// variable table, or a failing (or panicking) model constructor.
///
/// # Safety
/// String arguments must be NULL or NUL-terminated; `functions` NULL or valid.
pub unsafe fn fmi2_instantiate<M: FmuModel>(
    instance_name: Fmi2String,
    fmu_type: c_int,
    fmu_guid: Fmi2String,
    fmu_resource_location: Fmi2String,
    functions: *const Fmi2CallbackFunctions,
    visible: Fmi2Boolean,
    logging_on: Fmi2Boolean,
) -> Fmi2Component {
    // SAFETY: `functions` is NULL or points to the importer's callback struct, which must
    // outlive the instance (FMI 2.0 section 2.1.5); it is copied into the logger here.
    let Some(callbacks) = (unsafe { functions.as_ref() }) else {
        return std::ptr::null_mut();
    };
    // SAFETY: NULL or a NUL-terminated string (caller's contract).
    let name = unsafe { opt_str(instance_name) }.map(|s| s.to_string_lossy().into_owned());
    let info = M::model_info();
    let known: Vec<&'static str> = all_categories(info.log_categories)
        .iter()
        .map(|c| c.name)
        .collect();
    let logger = Logger::new(
        Some(callbacks),
        name.as_deref().unwrap_or("?"),
        logging_on != 0,
        known,
    );
    let fail = |logger: &Logger, msg: String| -> Fmi2Component {
        logger.log(
            Fmi2Status::Error,
            crate::log::CAT_ERROR,
            &format!("fmi2Instantiate: {msg}"),
        );
        std::ptr::null_mut()
    };
    let result = barrier(|| -> Result<Fmi2Component, String> {
        let name = match name.as_deref() {
            Some(n) if !n.is_empty() => n.to_string(),
            Some(_) => return Err("instanceName must not be empty".into()),
            None => return Err("instanceName must not be NULL".into()),
        };
        let model_exchange = match fmu_type {
            FMI2_CO_SIMULATION => false,
            FMI2_MODEL_EXCHANGE if M::MODEL_EXCHANGE => true,
            FMI2_MODEL_EXCHANGE => {
                return Err(format!(
                    "fmuType fmi2ModelExchange requested, but {} implements FMI 2.0 Co-Simulation only \
                     (instantiate it as fmi2CoSimulation)",
                    info.model_identifier
                ))
            }
            other => {
                return Err(format!(
                    "invalid fmuType {other} (expected 0 = fmi2ModelExchange or 1 = fmi2CoSimulation)"
                ))
            }
        };
        let table = Table::new(info).map_err(|p| {
            format!(
                "the FMU's variable table is invalid (a bug in the FMU): {}",
                p.join("; ")
            )
        })?;
        let guid = guid_u128(info);
        let expected = crate::guid::format_guid(guid);
        // SAFETY: NULL or a NUL-terminated string (caller's contract).
        let given = match unsafe { opt_str(fmu_guid) } {
            None => return Err("fmuGUID must not be NULL".into()),
            Some(g) => g.to_string_lossy().into_owned(),
        };
        if given.trim() != expected {
            return Err(format!(
                "GUID mismatch: the importer passed {given} but this binary is {expected}; the \
                 modelDescription.xml does not belong to this binary"
            ));
        }
        // SAFETY: NULL or a NUL-terminated string (caller's contract).
        let location =
            unsafe { opt_str(fmu_resource_location) }.map(|s| s.to_string_lossy().into_owned());
        let (dir, uri_problem) = match location.as_deref().map(resource_dir) {
            None => (None, None),
            Some(Ok(d)) => (d, None),
            Some(Err(e)) => (None, Some(e.to_string())),
        };
        if let Some(p) = uri_problem {
            logger.log(
                Fmi2Status::Warning,
                crate::log::CAT_WARNING,
                &format!("fmi2Instantiate: {p}; continuing without resources"),
            );
        }
        // A location that names no folder is the importer's mistake: say so, and give the
        // model no resource folder (it decides whether it can do without).
        let dir = match dir {
            Some(d) if !d.is_dir() => {
                logger.log(
                    Fmi2Status::Warning,
                    crate::log::CAT_WARNING,
                    &format!(
                        "fmi2Instantiate: resource location {:?} names the folder {} which does \
                         not exist; continuing without resources",
                        location.as_deref().unwrap_or_default(),
                        d.display()
                    ),
                );
                None
            }
            d => d,
        };
        let packaged = crate::uri::packaged_resources();
        let args = InstantiateArgs {
            instance_name: &name,
            resource_location: location.as_deref(),
            resource_dir: dir.as_deref(),
            packaged_resources: packaged.as_deref(),
            visible: visible != 0,
            logging_on: logging_on != 0,
        };
        let mut ctx = Ctx::new(&logger, "fmi2Instantiate");
        let model = M::instantiate(&mut ctx, &args)
            .map_err(|e| format!("the model could not be created: {}", e.message))?;
        Ok(Box::into_raw(Box::new(Instance {
            magic: INSTANCE_MAGIC,
            guid,
            table,
            logger: Logger::new(
                Some(callbacks),
                &name,
                logging_on != 0,
                all_categories(info.log_categories)
                    .iter()
                    .map(|c| c.name)
                    .collect(),
            ),
            resource_location: location.clone(),
            resource_dir: dir.clone(),
            packaged_resources: packaged.clone(),
            visible: visible != 0,
            logging_on_at_instantiation: logging_on != 0,
            shell: ShellState::fresh(),
            model,
            strings: Vec::new(),
            states: Vec::new(),
            model_exchange,
            me_states: if model_exchange {
                crate::table::continuous_states(info)
            } else {
                (Vec::new(), Vec::new())
            },
        })) as Fmi2Component)
    });
    match result {
        Ok(Ok(c)) => {
            // SAFETY: `c` is the box just leaked above; nothing else holds it yet.
            let i = unsafe { &*(c as *const Instance<M>) };
            if i.logger.is_enabled(Fmi2Status::Ok, CAT_EVENTS) {
                i.logger.log(
                    Fmi2Status::Ok,
                    CAT_EVENTS,
                    &format!(
                        "fmi2Instantiate: {} {} instantiated (resources: {})",
                        info.model_identifier,
                        info.version,
                        i.resource_dir
                            .as_ref()
                            .map_or("none".to_string(), |d| d.display().to_string())
                    ),
                );
            }
            c
        }
        Ok(Err(msg)) => fail(&logger, msg),
        Err(payload) => {
            let msg = panic_message(&*payload);
            drop_payload(payload);
            fail(
                &logger,
                format!("internal error: the model panicked: {msg}"),
            )
        }
    }
}

/// `fmi2FreeInstance`. NULL or a pointer that is not a live instance is ignored.
///
/// # Safety
/// `c` must be NULL or a pointer returned by [`fmi2_instantiate`] for the same `M`.
pub unsafe fn fmi2_free_instance<M: FmuModel>(c: Fmi2Component) {
    // SAFETY: `c` is NULL or a component of this library (caller's contract).
    let Some(inst) = (unsafe { instance::<M>(c) }) else {
        return;
    };
    let r = barrier(|| {
        // SAFETY: `inst` is a live instance leaked from a Box by fmi2Instantiate; after
        // fmi2FreeInstance the importer never uses it again, so it is dropped exactly once.
        // The magic is cleared first so a stale use is refused on a best-effort basis.
        unsafe {
            (*inst).magic = 0;
            drop(Box::from_raw(inst));
        }
    });
    if let Err(p) = r {
        drop_payload(p);
    }
}

/// `fmi2SetDebugLogging`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_set_debug_logging<M: FmuModel>(
    c: Fmi2Component,
    logging_on: Fmi2Boolean,
    n_categories: usize,
    categories: *const Fmi2String,
) -> Fmi2Status {
    let body = |i: &mut Instance<M>| {
        // SAFETY: `categories` holds `n_categories` string pointers (caller's contract).
        let Ok(cats) = (unsafe { slice(categories, n_categories) }) else {
            return null_arg(i, Func::SetDebugLogging, "categories");
        };
        let mut names = Vec::with_capacity(cats.len());
        for &p in cats {
            // SAFETY: each category is NULL or a NUL-terminated string (caller's contract).
            match unsafe { opt_str(p) } {
                Some(s) => names.push(s.to_string_lossy().into_owned()),
                None => return null_arg(i, Func::SetDebugLogging, "categories[i]"),
            }
        }
        i.set_debug_logging(logging_on != 0, &names)
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::SetDebugLogging, body) }
}

/// `fmi2SetupExperiment`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_setup_experiment<M: FmuModel>(
    c: Fmi2Component,
    tolerance_defined: Fmi2Boolean,
    tolerance: Fmi2Real,
    start_time: Fmi2Real,
    stop_time_defined: Fmi2Boolean,
    stop_time: Fmi2Real,
) -> Fmi2Status {
    let body = |i: &mut Instance<M>| {
        i.setup_experiment(
            (tolerance_defined != 0).then_some(tolerance),
            start_time,
            (stop_time_defined != 0).then_some(stop_time),
        )
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::SetupExperiment, body) }
}

/// `fmi2EnterInitializationMode`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_enter_initialization_mode<M: FmuModel>(c: Fmi2Component) -> Fmi2Status {
    let body = |i: &mut Instance<M>| i.enter_initialization_mode();
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::EnterInitializationMode, body) }
}

/// `fmi2ExitInitializationMode`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_exit_initialization_mode<M: FmuModel>(c: Fmi2Component) -> Fmi2Status {
    let body = |i: &mut Instance<M>| i.exit_initialization_mode();
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::ExitInitializationMode, body) }
}

/// `fmi2Terminate`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_terminate<M: FmuModel>(c: Fmi2Component) -> Fmi2Status {
    let body = |i: &mut Instance<M>| i.terminate();
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::Terminate, body) }
}

/// `fmi2Reset`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_reset<M: FmuModel>(c: Fmi2Component) -> Fmi2Status {
    let body = |i: &mut Instance<M>| i.reset();
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::Reset, body) }
}

macro_rules! getter {
    ($(#[$doc:meta])* $name:ident, $func:expr, $t:ty, $method:ident) => {
        $(#[$doc])*
        ///
        /// # Safety
        /// See the module documentation.
        pub unsafe fn $name<M: FmuModel>(
            c: Fmi2Component,
            vr: *const Fmi2ValueReference,
            nvr: usize,
            value: *mut $t,
        ) -> Fmi2Status {
            let body = |i: &mut Instance<M>| {
                // SAFETY: `vr` and `value` are arrays of `nvr` elements (caller's contract);
                // `value` is the importer's output buffer, not aliased by `vr`.
                let Ok(vrs) = (unsafe { slice(vr, nvr) }) else { return null_arg(i, $func, "vr") };
                // SAFETY: as above.
                let Ok(out) = (unsafe { slice_mut(value, nvr) }) else { return null_arg(i, $func, "value") };
                i.$method(vrs, out)
            };
            // SAFETY: `c` is NULL or a component this library returned (caller's contract);
            // `entry` tells which before touching it.
            unsafe { entry::<M>(c, $func, body) }
        }
    };
}

getter!(
    /// `fmi2GetReal`.
    fmi2_get_real, Func::GetReal, Fmi2Real, get_real);
getter!(
    /// `fmi2GetInteger`.
    fmi2_get_integer, Func::GetInteger, Fmi2Integer, get_integer);
getter!(
    /// `fmi2GetBoolean`.
    fmi2_get_boolean, Func::GetBoolean, Fmi2Boolean, get_boolean);
getter!(
    /// `fmi2GetString`: the returned pointers stay valid until the next `fmi2GetString`
    /// or `fmi2FreeInstance` on this instance.
    fmi2_get_string, Func::GetString, Fmi2String, get_string);

macro_rules! setter {
    ($(#[$doc:meta])* $name:ident, $func:expr, $t:ty, $method:ident) => {
        $(#[$doc])*
        ///
        /// # Safety
        /// See the module documentation.
        pub unsafe fn $name<M: FmuModel>(
            c: Fmi2Component,
            vr: *const Fmi2ValueReference,
            nvr: usize,
            value: *const $t,
        ) -> Fmi2Status {
            let body = |i: &mut Instance<M>| {
                // SAFETY: `vr` and `value` are arrays of `nvr` elements (caller's contract).
                let Ok(vrs) = (unsafe { slice(vr, nvr) }) else { return null_arg(i, $func, "vr") };
                // SAFETY: as above.
                let Ok(vals) = (unsafe { slice(value, nvr) }) else { return null_arg(i, $func, "value") };
                i.$method(vrs, vals)
            };
            // SAFETY: `c` is NULL or a component this library returned (caller's contract);
            // `entry` tells which before touching it.
            unsafe { entry::<M>(c, $func, body) }
        }
    };
}

setter!(
    /// `fmi2SetReal`: NaN and infinities are rejected with `fmi2Error` naming the variable.
    fmi2_set_real, Func::SetReal, Fmi2Real, set_real);
setter!(
    /// `fmi2SetInteger`.
    fmi2_set_integer, Func::SetInteger, Fmi2Integer, set_integer);
setter!(
    /// `fmi2SetBoolean`.
    fmi2_set_boolean, Func::SetBoolean, Fmi2Boolean, set_boolean);

/// `fmi2SetString`.
///
/// # Safety
/// See the module documentation; each non-NULL string must be NUL-terminated.
pub unsafe fn fmi2_set_string<M: FmuModel>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2String,
) -> Fmi2Status {
    let f = Func::SetString;
    let body = |i: &mut Instance<M>| {
        // SAFETY: `vr` and `value` are arrays of `nvr` elements (caller's contract).
        let Ok(vrs) = (unsafe { slice(vr, nvr) }) else {
            return null_arg(i, f, "vr");
        };
        // SAFETY: as above.
        let Ok(vals) = (unsafe { slice(value, nvr) }) else {
            return null_arg(i, f, "value");
        };
        let strs: Vec<Option<&str>> = vals
            .iter()
            // SAFETY: each value is NULL or a NUL-terminated string (caller's contract).
            .map(|&p| unsafe { opt_str(p) }.and_then(|s| s.to_str().ok()))
            .collect();
        i.set_string(vrs, &strs)
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// The snapshot behind an `fmi2FMUstate`, if this instance handed it out and it was not
/// freed. The pointer is compared with the instance's list before it is read, so a handle
/// of another instance, a freed handle or garbage is refused without touching its memory.
fn snapshot_of<M: FmuModel>(
    i: &mut Instance<M>,
    f: Func,
    s: Fmi2FmuState,
) -> Result<*mut Snapshot<M>, Fmi2Status> {
    if s.is_null() {
        return Err(null_arg(i, f, "FMUstate"));
    }
    let snap = s as *mut Snapshot<M>;
    if !i.states.contains(&snap) {
        return Err(i.fail(
            f,
            Fmi2Status::Error,
            "FMUstate is not an FMU state of this instance (freed already, made by another \
             instance, or not an FMU state)",
        ));
    }
    Ok(snap)
}

/// `fmi2GetFMUstate`: a new snapshot if `*state` is NULL, else overwrite the snapshot it
/// points to (which the standard says was returned earlier and not freed).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_get_fmu_state<M: FmuModel>(
    c: Fmi2Component,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    let f = Func::GetFmuState;
    let body = |i: &mut Instance<M>| {
        if state.is_null() {
            return null_arg(i, f, "FMUstate");
        }
        // SAFETY: `state` is non-NULL and points to the importer's fmi2FMUstate variable
        // (caller's contract), readable and writable.
        let current = unsafe { *state };
        if current.is_null() {
            let snap = Box::new(Snapshot {
                magic: SNAPSHOT_MAGIC,
                guid: i.guid,
                shell: i.shell,
                model: i.model.clone(),
                cached: None,
            });
            let p = Box::into_raw(snap);
            i.states.push(p);
            // SAFETY: as above.
            unsafe { *state = p as Fmi2FmuState };
        } else {
            let snap = match snapshot_of(i, f, current) {
                Ok(s) => s,
                Err(st) => return st,
            };
            // SAFETY: the snapshot is a live box of this instance (`snapshot_of` found it in
            // `i.states`), and nothing else references it during this call.
            let snap = unsafe { &mut *snap };
            snap.shell = i.shell;
            snap.model = i.model.clone();
            snap.cached = None;
        }
        Fmi2Status::Ok
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi2SetFMUstate`: the instance becomes what it was, state machine included.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_set_fmu_state<M: FmuModel>(c: Fmi2Component, state: Fmi2FmuState) -> Fmi2Status {
    let f = Func::SetFmuState;
    let body = |i: &mut Instance<M>| {
        let snap = match snapshot_of(i, f, state) {
            Ok(s) => s,
            Err(st) => return st,
        };
        // SAFETY: the snapshot is a live box of this instance (`snapshot_of` found it in
        // `i.states`), and nothing else references it during this call.
        let snap = unsafe { &*snap };
        // A state saved by an instance of the other interface (serialized bytes carry the
        // mode) would leave this one in a mode it has no way out of.
        let foreign = match snap.shell.mode {
            Mode::StepComplete | Mode::StepFailed => i.model_exchange,
            Mode::EventMode | Mode::ContinuousTimeMode => !i.model_exchange,
            _ => false,
        };
        if foreign {
            let kind = if i.model_exchange {
                "fmi2ModelExchange"
            } else {
                "fmi2CoSimulation"
            };
            return i.fail(
                f,
                Fmi2Status::Error,
                format!(
                    "the FMU state was saved in mode {} by an instance of the other interface; \
                     this instance was instantiated as {kind}",
                    snap.shell.mode.name()
                ),
            );
        }
        i.model = snap.model.clone();
        i.shell = snap.shell;
        Fmi2Status::Ok
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi2FreeFMUstate`: frees `*state` and sets it to NULL (NULL `*state` is a no-op).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_free_fmu_state<M: FmuModel>(
    c: Fmi2Component,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    let f = Func::FreeFmuState;
    let body = |i: &mut Instance<M>| {
        if state.is_null() {
            return null_arg(i, f, "FMUstate");
        }
        // SAFETY: `state` is non-NULL and points to the importer's fmi2FMUstate variable
        // (caller's contract), readable and writable.
        let current = unsafe { *state };
        if current.is_null() {
            return Fmi2Status::Ok;
        }
        let snap = match snapshot_of(i, f, current) {
            Ok(s) => s,
            Err(st) => return st,
        };
        i.states.retain(|&p| p != snap);
        // SAFETY: the snapshot is a live box of this instance (`snapshot_of` found it in
        // `i.states`), and nothing else references it during this call; it was leaked from a Box by this
        // library and, just removed from the list, is dropped exactly once.
        unsafe {
            (*snap).magic = 0;
            drop(Box::from_raw(snap));
        }
        // SAFETY: as above for `state`.
        unsafe { *state = std::ptr::null_mut() };
        Fmi2Status::Ok
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// The serialized form of `snap`, computed once and cached in it.
///
/// # Safety
/// `snap` must be a live snapshot of `i` (from [`snapshot_of`]) that nothing else references
/// while the returned slice is in use.
unsafe fn serialized<'a, M: FmuModel>(
    i: &mut Instance<M>,
    f: Func,
    snap: *mut Snapshot<M>,
) -> Result<&'a [u8], Fmi2Status> {
    // SAFETY: the caller's promise above.
    let snap = unsafe { &mut *snap };
    if snap.cached.is_none() {
        match snapshot::serialize(i.guid, &snap.shell, &snap.model) {
            Ok(b) => snap.cached = Some(b),
            Err(e) => {
                let s = e.status.max(Fmi2Status::Error);
                return Err(i.fail(f, s, format!("could not serialize: {}", e.message)));
            }
        }
    }
    Ok(snap.cached.as_deref().unwrap_or_default())
}

/// `fmi2SerializedFMUstateSize`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_serialized_fmu_state_size<M: FmuModel>(
    c: Fmi2Component,
    state: Fmi2FmuState,
    size: *mut usize,
) -> Fmi2Status {
    let f = Func::SerializedFmuStateSize;
    let body = |i: &mut Instance<M>| {
        if size.is_null() {
            return null_arg(i, f, "size");
        }
        let snap = match snapshot_of(i, f, state) {
            Ok(s) => s,
            Err(st) => return st,
        };
        // SAFETY: `snap` is a live snapshot of `i` (from `snapshot_of`); the slice is used
        // only within this call.
        match unsafe { serialized(i, f, snap) } {
            Ok(b) => {
                // SAFETY: non-NULL (checked above) and pointing to the importer's output
                // variable (caller's contract).
                unsafe { *size = b.len() };
                Fmi2Status::Ok
            }
            Err(s) => s,
        }
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi2SerializeFMUstate`: `size` must equal what `fmi2SerializedFMUstateSize` returned.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_serialize_fmu_state<M: FmuModel>(
    c: Fmi2Component,
    state: Fmi2FmuState,
    serialized_state: *mut Fmi2Byte,
    size: usize,
) -> Fmi2Status {
    let f = Func::SerializeFmuState;
    let body = |i: &mut Instance<M>| {
        let snap = match snapshot_of(i, f, state) {
            Ok(s) => s,
            Err(st) => return st,
        };
        // SAFETY: `snap` is a live snapshot of `i` (from `snapshot_of`); the slice is used
        // only within this call.
        let bytes = match unsafe { serialized(i, f, snap) } {
            Ok(b) => b,
            Err(s) => return s,
        };
        if size != bytes.len() {
            return i.fail(
                f,
                Fmi2Status::Error,
                format!("size = {size} but the serialized state has {} bytes (see fmi2SerializedFMUstateSize)", bytes.len()),
            );
        }
        // SAFETY: the importer's buffer of `size` bytes (caller's contract), which is not
        // the snapshot's cache it is copied from.
        let Ok(out) = (unsafe { slice_mut(serialized_state as *mut u8, size) }) else {
            return null_arg(i, f, "serializedState");
        };
        out.copy_from_slice(bytes);
        Fmi2Status::Ok
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi2DeSerializeFMUstate`: always allocates a new FMU state (the incoming `*state`
/// is not read, since importers often pass it uninitialised).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_deserialize_fmu_state<M: FmuModel>(
    c: Fmi2Component,
    serialized_state: *const Fmi2Byte,
    size: usize,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    let f = Func::DeSerializeFmuState;
    let body = |i: &mut Instance<M>| {
        if state.is_null() {
            return null_arg(i, f, "FMUstate");
        }
        // SAFETY: the importer's buffer of `size` bytes (caller's contract).
        let Ok(bytes) = (unsafe { slice(serialized_state as *const u8, size) }) else {
            return null_arg(i, f, "serializedState");
        };
        match snapshot::deserialize(i.guid, bytes, i.model.clone()) {
            Ok((shell, model)) => {
                let snap = Box::new(Snapshot {
                    magic: SNAPSHOT_MAGIC,
                    guid: i.guid,
                    shell,
                    model,
                    cached: None,
                });
                let p = Box::into_raw(snap);
                i.states.push(p);
                // SAFETY: non-NULL (checked above) and pointing to the importer's
                // fmi2FMUstate variable (caller's contract).
                unsafe { *state = p as Fmi2FmuState };
                Fmi2Status::Ok
            }
            Err(e) => {
                let s = e.status.max(Fmi2Status::Error);
                i.fail(f, s, format!("invalid serialized state: {}", e.message))
            }
        }
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi2GetDirectionalDerivative`.
///
/// # Safety
/// See the module documentation.
#[allow(clippy::too_many_arguments)]
pub unsafe fn fmi2_get_directional_derivative<M: FmuModel>(
    c: Fmi2Component,
    v_unknown_ref: *const Fmi2ValueReference,
    n_unknown: usize,
    v_known_ref: *const Fmi2ValueReference,
    n_known: usize,
    dv_known: *const Fmi2Real,
    dv_unknown: *mut Fmi2Real,
) -> Fmi2Status {
    let f = Func::GetDirectionalDerivative;
    let body = |i: &mut Instance<M>| {
        // SAFETY (all four): arrays of the counts the importer passes (caller's contract);
        // `dvUnknown` is its output buffer, aliased by none of the inputs.
        let Ok(unknowns) = (unsafe { slice(v_unknown_ref, n_unknown) }) else {
            return null_arg(i, f, "vUnknown_ref");
        };
        let Ok(knowns) = (unsafe { slice(v_known_ref, n_known) }) else {
            return null_arg(i, f, "vKnown_ref");
        };
        let Ok(dvk) = (unsafe { slice(dv_known, n_known) }) else {
            return null_arg(i, f, "dvKnown");
        };
        let Ok(dvu) = (unsafe { slice_mut(dv_unknown, n_unknown) }) else {
            return null_arg(i, f, "dvUnknown");
        };
        i.directional_derivative(unknowns, knowns, dvk, dvu)
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi2SetRealInputDerivatives`: not supported (`canInterpolateInputs="false"`).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_set_real_input_derivatives<M: FmuModel>(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _nvr: usize,
    _order: *const Fmi2Integer,
    _value: *const Fmi2Real,
) -> Fmi2Status {
    let f = Func::SetRealInputDerivatives;
    let body = |i: &mut Instance<M>| {
        i.fail(
            f,
            Fmi2Status::Error,
            "not supported: this FMU cannot interpolate inputs (canInterpolateInputs=\"false\")",
        )
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi2GetRealOutputDerivatives`: not supported (`maxOutputDerivativeOrder="0"`).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_get_real_output_derivatives<M: FmuModel>(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _nvr: usize,
    _order: *const Fmi2Integer,
    _value: *mut Fmi2Real,
) -> Fmi2Status {
    let f = Func::GetRealOutputDerivatives;
    let body = |i: &mut Instance<M>| {
        i.fail(f, Fmi2Status::Error, "not supported: this FMU provides no output derivatives (maxOutputDerivativeOrder=\"0\")")
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi2DoStep`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_do_step<M: FmuModel>(
    c: Fmi2Component,
    current_communication_point: Fmi2Real,
    communication_step_size: Fmi2Real,
    _no_set_fmu_state_prior_to_current_point: Fmi2Boolean,
) -> Fmi2Status {
    let body =
        |i: &mut Instance<M>| i.do_step(current_communication_point, communication_step_size);
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::DoStep, body) }
}

/// `fmi2CancelStep`: always an illegal call (no step is ever pending).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_cancel_step<M: FmuModel>(c: Fmi2Component) -> Fmi2Status {
    let body = |_: &mut Instance<M>| Fmi2Status::Error;
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::CancelStep, body) }
}

fn status_kind_name(kind: c_int) -> Option<&'static str> {
    match kind {
        FMI2_DO_STEP_STATUS => Some("fmi2DoStepStatus"),
        FMI2_PENDING_STATUS => Some("fmi2PendingStatus"),
        FMI2_LAST_SUCCESSFUL_TIME => Some("fmi2LastSuccessfulTime"),
        FMI2_TERMINATED => Some("fmi2Terminated"),
        _ => None,
    }
}

/// Status kinds that exist but have no value here: `fmi2Discard` with an explanation
/// (the standard's answer for "not available"); unknown kinds are an error.
fn status_unavailable<M: FmuModel>(i: &mut Instance<M>, f: Func, kind: c_int) -> Fmi2Status {
    match status_kind_name(kind) {
        None => i.fail(f, Fmi2Status::Error, format!("invalid fmi2StatusKind {kind}")),
        Some(k) => i.fail(
            f,
            Fmi2Status::Discard,
            format!("{k} is not available from {} (fmi2DoStep is synchronous and never requests termination)", f.name()),
        ),
    }
}

/// `fmi2GetStatus`: nothing is ever pending, so every kind is `fmi2Discard`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_get_status<M: FmuModel>(
    c: Fmi2Component,
    kind: c_int,
    value: *mut c_int,
) -> Fmi2Status {
    let f = Func::GetStatus;
    let body = |i: &mut Instance<M>| {
        if value.is_null() {
            return null_arg(i, f, "value");
        }
        status_unavailable(i, f, kind)
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi2GetRealStatus`: `fmi2LastSuccessfulTime` is the current communication point.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_get_real_status<M: FmuModel>(
    c: Fmi2Component,
    kind: c_int,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    let f = Func::GetRealStatus;
    let body = |i: &mut Instance<M>| {
        if value.is_null() {
            return null_arg(i, f, "value");
        }
        if kind == FMI2_LAST_SUCCESSFUL_TIME {
            // SAFETY: non-NULL (checked above) and pointing to the importer's output
            // variable (caller's contract).
            unsafe { *value = i.shell.time };
            return Fmi2Status::Ok;
        }
        status_unavailable(i, f, kind)
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi2GetIntegerStatus`: no integer status exists in FMI 2.0 (`fmi2Discard`).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_get_integer_status<M: FmuModel>(
    c: Fmi2Component,
    kind: c_int,
    value: *mut Fmi2Integer,
) -> Fmi2Status {
    let f = Func::GetIntegerStatus;
    let body = |i: &mut Instance<M>| {
        if value.is_null() {
            return null_arg(i, f, "value");
        }
        status_unavailable(i, f, kind)
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi2GetBooleanStatus`: `fmi2Terminated` is always false (the FMU never asks to stop).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_get_boolean_status<M: FmuModel>(
    c: Fmi2Component,
    kind: c_int,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    let f = Func::GetBooleanStatus;
    let body = |i: &mut Instance<M>| {
        if value.is_null() {
            return null_arg(i, f, "value");
        }
        if kind == FMI2_TERMINATED {
            // SAFETY: non-NULL (checked above) and pointing to the importer's output
            // variable (caller's contract).
            unsafe { *value = FMI2_FALSE };
            return Fmi2Status::Ok;
        }
        status_unavailable(i, f, kind)
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi2GetStringStatus`: `fmi2PendingStatus` only exists while pending (`fmi2Discard`).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_get_string_status<M: FmuModel>(
    c: Fmi2Component,
    kind: c_int,
    value: *mut Fmi2String,
) -> Fmi2Status {
    let f = Func::GetStringStatus;
    let body = |i: &mut Instance<M>| {
        if value.is_null() {
            return null_arg(i, f, "value");
        }
        status_unavailable(i, f, kind)
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

// ---------------------------------------------------------------------------------------
// Model Exchange
// ---------------------------------------------------------------------------------------

/// `fmi2SetTime`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_set_time<M: FmuModel>(c: Fmi2Component, time: Fmi2Real) -> Fmi2Status {
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::SetTime, |i: &mut Instance<M>| i.set_time(time)) }
}

/// `fmi2SetContinuousStates`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_set_continuous_states<M: FmuModel>(
    c: Fmi2Component,
    x: *const Fmi2Real,
    nx: usize,
) -> Fmi2Status {
    let body = |i: &mut Instance<M>| {
        // SAFETY: `x` is NULL or points to `nx` reals (caller's contract).
        match unsafe { slice(x, nx) } {
            Ok(x) => i.set_continuous_states(x),
            Err(()) => null_arg(i, Func::SetContinuousStates, "x"),
        }
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::SetContinuousStates, body) }
}

/// `fmi2EnterEventMode`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_enter_event_mode<M: FmuModel>(c: Fmi2Component) -> Fmi2Status {
    let body = |i: &mut Instance<M>| i.enter_mode(Func::EnterEventMode, Mode::EventMode);
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::EnterEventMode, body) }
}

/// `fmi2NewDiscreteStates`: the model has no discrete states and no time events, so the
/// event iteration ends at once.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_new_discrete_states<M: FmuModel>(
    c: Fmi2Component,
    event_info: *mut Fmi2EventInfo,
) -> Fmi2Status {
    let body = |i: &mut Instance<M>| {
        if event_info.is_null() {
            return null_arg(i, Func::NewDiscreteStates, "fmi2eventInfo");
        }
        // SAFETY: non-NULL, points to the importer's fmi2EventInfo (caller's contract).
        unsafe { event_info.write(Fmi2EventInfo::default()) };
        Fmi2Status::Ok
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::NewDiscreteStates, body) }
}

/// `fmi2EnterContinuousTimeMode`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_enter_continuous_time_mode<M: FmuModel>(c: Fmi2Component) -> Fmi2Status {
    let body =
        |i: &mut Instance<M>| i.enter_mode(Func::EnterContinuousTimeMode, Mode::ContinuousTimeMode);
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::EnterContinuousTimeMode, body) }
}

/// `fmi2CompletedIntegratorStep`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_completed_integrator_step<M: FmuModel>(
    c: Fmi2Component,
    _no_set_fmu_state_prior: Fmi2Boolean,
    enter_event_mode: *mut Fmi2Boolean,
    terminate_simulation: *mut Fmi2Boolean,
) -> Fmi2Status {
    let body = |i: &mut Instance<M>| {
        if enter_event_mode.is_null() {
            return null_arg(i, Func::CompletedIntegratorStep, "enterEventMode");
        }
        if terminate_simulation.is_null() {
            return null_arg(i, Func::CompletedIntegratorStep, "terminateSimulation");
        }
        let (s, ev) = i.completed_integrator_step();
        // SAFETY: both non-NULL and point to the importer's fmi2Boolean (caller's contract).
        unsafe {
            enter_event_mode.write(ev as Fmi2Boolean);
            terminate_simulation.write(0);
        }
        s
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::CompletedIntegratorStep, body) }
}

macro_rules! me_array_getter {
    ($(#[$doc:meta])* $name:ident, $func:expr, $arg:literal, $method:ident) => {
        $(#[$doc])*
        ///
        /// # Safety
        /// See the module documentation.
        pub unsafe fn $name<M: FmuModel>(c: Fmi2Component, out: *mut Fmi2Real, n: usize) -> Fmi2Status {
            let body = |i: &mut Instance<M>| {
                // SAFETY: `out` is NULL or points to `n` writable reals (caller's contract).
                match unsafe { slice_mut(out, n) } {
                    Ok(o) => i.$method(o),
                    Err(()) => null_arg(i, $func, $arg),
                }
            };
            // SAFETY: `c` is NULL or a component this library returned (caller's contract);
            // `entry` tells which before touching it.
            unsafe { entry::<M>(c, $func, body) }
        }
    };
}

me_array_getter!(
    /// `fmi2GetDerivatives`.
    fmi2_get_derivatives, Func::GetDerivatives, "derivatives", get_derivatives
);
me_array_getter!(
    /// `fmi2GetContinuousStates`.
    fmi2_get_continuous_states, Func::GetContinuousStates, "x", get_continuous_states
);
me_array_getter!(
    /// `fmi2GetNominalsOfContinuousStates`.
    fmi2_get_nominals_of_continuous_states,
    Func::GetNominalsOfContinuousStates,
    "x_nominal",
    get_nominals
);

/// `fmi2GetEventIndicators` (the shell's models have none: only `ni = 0` is accepted).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_get_event_indicators<M: FmuModel>(
    c: Fmi2Component,
    _indicators: *mut Fmi2Real,
    ni: usize,
) -> Fmi2Status {
    let body = |i: &mut Instance<M>| i.get_event_indicators(ni);
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::GetEventIndicators, body) }
}
