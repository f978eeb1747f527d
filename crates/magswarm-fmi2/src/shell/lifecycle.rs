//! Creating, freeing, initialising, terminating and resetting instances.

use std::ffi::{c_char, c_int};

use magswarm_fmi_core::ffi::{opt_str, slice};
use magswarm_fmi_core::log::{to_c_lossy, LogSink};
use magswarm_fmi_core::{FmuModel, Instance, Interface, Refusal, Request, Status};

use super::{entry, null_arg, INSTANCE_MAGIC};
use crate::abi::*;
use crate::state::{Func, Mode};

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
/// variable table, or a failing (or panicking) model constructor
/// ([`magswarm_fmi_core::create`] does the checks).
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
    // SAFETY: NULL or NUL-terminated strings (caller's contract).
    let text = |p| unsafe { opt_str(p) }.map(|s| s.to_string_lossy().into_owned());
    let name = text(instance_name);
    let info = M::model_info();
    let interface = match fmu_type {
        FMI2_CO_SIMULATION => Ok(Interface::CoSimulation),
        FMI2_MODEL_EXCHANGE => Ok(Interface::ModelExchange),
        other => Err(Refusal(format!(
            "invalid fmuType {other} (expected 0 = fmi2ModelExchange or 1 = fmi2CoSimulation)"
        ))),
    };
    let req = Request {
        magic: INSTANCE_MAGIC,
        info,
        function: "fmi2Instantiate",
        token_arg: "fmuGUID",
        sink: log_sink(callbacks, name.as_deref().unwrap_or("?")),
        name,
        token: text(fmu_guid),
        resource_location: text(fmu_resource_location),
        interface,
        visible: visible != 0,
        logging_on: logging_on != 0,
    };
    match magswarm_fmi_core::create::<M>(req) {
        Some(b) => Box::into_raw(b) as Fmi2Component,
        None => std::ptr::null_mut(),
    }
}

/// The importer's `fmi2CallbackLogger` as a neutral sink: the message is printf-escaped
/// (`%` doubled, since no arguments follow) and passed with the instance name.
fn log_sink(callbacks: &Fmi2CallbackFunctions, instance_name: &str) -> Option<LogSink> {
    let cb = callbacks.logger?;
    let env = callbacks.component_environment as usize;
    let name = to_c_lossy(instance_name);
    Some(Box::new(
        move |status: Status, category: &str, message: &str| {
            let category = to_c_lossy(category);
            let message = to_c_lossy(&message.replace('%', "%%"));
            // SAFETY: the importer promised a valid logger for the instance's lifetime; all
            // strings are NUL-terminated and live until the call returns.
            unsafe {
                cb(
                    env as Fmi2ComponentEnvironment,
                    name.as_ptr(),
                    Fmi2Status::from(status),
                    category.as_ptr(),
                    message.as_ptr(),
                )
            }
        },
    ))
}

/// `fmi2FreeInstance`. NULL or a pointer that is not a live instance is ignored.
///
/// # Safety
/// `c` must be NULL or a pointer returned by [`fmi2_instantiate`] for the same `M`.
pub unsafe fn fmi2_free_instance<M: FmuModel>(c: Fmi2Component) {
    // SAFETY: `c` is NULL or an instance of this library, not used after this (caller's
    // contract).
    unsafe { Instance::<M>::free_handle(c, INSTANCE_MAGIC) }
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
        let Some(cats) = (unsafe { slice(categories, n_categories) }) else {
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
        i.set_debug_logging(Func::SetDebugLogging.name(), logging_on != 0, &names)
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
            Func::SetupExperiment.name(),
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
    let body =
        |i: &mut Instance<M>| i.enter_initialization_mode(Func::EnterInitializationMode.name());
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::EnterInitializationMode, body) }
}

/// `fmi2ExitInitializationMode`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_exit_initialization_mode<M: FmuModel>(c: Fmi2Component) -> Fmi2Status {
    let body = |i: &mut Instance<M>| {
        // Model Exchange continues in event mode, Co-Simulation ready to step.
        let next = if i.is_model_exchange() {
            Mode::EventMode
        } else {
            Mode::StepComplete
        };
        i.exit_initialization_mode(Func::ExitInitializationMode.name(), next)
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::ExitInitializationMode, body) }
}

/// `fmi2Terminate`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_terminate<M: FmuModel>(c: Fmi2Component) -> Fmi2Status {
    let body = |i: &mut Instance<M>| i.terminate(Func::Terminate.name());
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::Terminate, body) }
}

/// `fmi2Reset`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_reset<M: FmuModel>(c: Fmi2Component) -> Fmi2Status {
    let body = |i: &mut Instance<M>| i.reset(Func::Reset.name());
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::Reset, body) }
}
