//! Creating, freeing, initialising, terminating and resetting instances, event mode and
//! configuration mode.

use std::ffi::c_char;

use magswarm_fmi_core::barrier::barrier;
use magswarm_fmi_core::ffi::{opt_str, slice};
use magswarm_fmi_core::log::{to_c_lossy, LogSink};
use magswarm_fmi_core::{FmuModel, Instance, Interface, Refusal, Request, Status};

use super::{entry, null_arg, unsupported, INSTANCE_MAGIC};
use crate::abi::*;
use crate::state::{Func, Mode};

/// The model's table as FMI 3.0 sees it: with the independent variable `time`, which
/// FMI 3.0 requires (see [`magswarm_fmi_core::table::with_independent_time`]).
pub fn info_of<M: FmuModel>() -> &'static magswarm_fmi_core::ModelInfo {
    magswarm_fmi_core::table::with_independent_time(M::model_info())
}

/// `fmi3GetVersion`.
pub fn fmi3_get_version() -> *const c_char {
    FMI3_VERSION.as_ptr() as *const c_char
}

/// The importer's `fmi3LogMessageCallback` as a neutral sink (FMI 3.0 messages are plain
/// text: nothing is escaped).
fn log_sink(cb: Option<Fmi3LogMessageCallback>, env: Fmi3InstanceEnvironment) -> Option<LogSink> {
    let cb = cb?;
    let env = env as usize;
    Some(Box::new(
        move |status: Status, category: &str, message: &str| {
            let category = to_c_lossy(category);
            let message = to_c_lossy(message);
            // SAFETY: the importer promised a valid callback for the instance's lifetime; both
            // strings are NUL-terminated and live until the call returns.
            unsafe {
                cb(
                    env as Fmi3InstanceEnvironment,
                    status,
                    category.as_ptr(),
                    message.as_ptr(),
                )
            }
        },
    ))
}

/// The common part of the two instantiation functions.
///
/// # Safety
/// String arguments must be NULL or NUL-terminated.
#[allow(clippy::too_many_arguments)]
unsafe fn instantiate<M: FmuModel>(
    function: &'static str,
    interface: Result<Interface, Refusal>,
    instance_name: Fmi3String,
    instantiation_token: Fmi3String,
    resource_path: Fmi3String,
    visible: Fmi3Boolean,
    logging_on: Fmi3Boolean,
    env: Fmi3InstanceEnvironment,
    log_message: Option<Fmi3LogMessageCallback>,
) -> Fmi3Instance {
    // SAFETY: NULL or NUL-terminated strings (caller's contract).
    let text = |p| unsafe { opt_str(p) }.map(|s| s.to_string_lossy().into_owned());
    let req = Request {
        magic: INSTANCE_MAGIC,
        info: info_of::<M>(),
        function,
        token_arg: "instantiationToken",
        name: text(instance_name),
        token: text(instantiation_token),
        resource_location: text(resource_path),
        interface,
        sink: log_sink(log_message, env),
        visible: visible != 0,
        logging_on: logging_on != 0,
    };
    match magswarm_fmi_core::create::<M>(req) {
        Some(b) => Box::into_raw(b) as Fmi3Instance,
        None => std::ptr::null_mut(),
    }
}

/// `fmi3InstantiateModelExchange`. NULL (after logging why) for a model without Model
/// Exchange and on every failure [`magswarm_fmi_core::create`] names.
///
/// # Safety
/// String arguments must be NULL or NUL-terminated; the callback NULL or valid for the
/// instance's lifetime.
#[allow(clippy::too_many_arguments)]
pub unsafe fn fmi3_instantiate_model_exchange<M: FmuModel>(
    instance_name: Fmi3String,
    instantiation_token: Fmi3String,
    resource_path: Fmi3String,
    visible: Fmi3Boolean,
    logging_on: Fmi3Boolean,
    env: Fmi3InstanceEnvironment,
    log_message: Option<Fmi3LogMessageCallback>,
) -> Fmi3Instance {
    // SAFETY: the caller's contract is `instantiate`'s.
    unsafe {
        instantiate::<M>(
            "fmi3InstantiateModelExchange",
            Ok(Interface::ModelExchange),
            instance_name,
            instantiation_token,
            resource_path,
            visible,
            logging_on,
            env,
            log_message,
        )
    }
}

/// `fmi3InstantiateCoSimulation`. Event mode and intermediate update are not offered
/// (`hasEventMode`, `providesIntermediateUpdate` are false), so asking for either is an
/// error; early return is allowed but never used.
///
/// # Safety
/// As [`fmi3_instantiate_model_exchange`]; `required` NULL or `n_required` references.
#[allow(clippy::too_many_arguments)]
pub unsafe fn fmi3_instantiate_co_simulation<M: FmuModel>(
    instance_name: Fmi3String,
    instantiation_token: Fmi3String,
    resource_path: Fmi3String,
    visible: Fmi3Boolean,
    logging_on: Fmi3Boolean,
    event_mode_used: Fmi3Boolean,
    _early_return_allowed: Fmi3Boolean,
    _required: *const Fmi3ValueReference,
    n_required: usize,
    env: Fmi3InstanceEnvironment,
    log_message: Option<Fmi3LogMessageCallback>,
    _intermediate_update: Option<Fmi3IntermediateUpdateCallback>,
) -> Fmi3Instance {
    let interface = if event_mode_used != 0 {
        Err(
            "eventModeUsed = true, but this FMU has no event mode in Co-Simulation \
             (hasEventMode is not declared): instantiate with eventModeUsed = false"
                .into(),
        )
    } else if n_required > 0 {
        Err(Refusal(format!(
            "{n_required} requiredIntermediateVariables, but this FMU provides no intermediate \
             update (providesIntermediateUpdate is not declared)"
        )))
    } else {
        Ok(Interface::CoSimulation)
    };
    // SAFETY: the caller's contract is `instantiate`'s.
    unsafe {
        instantiate::<M>(
            "fmi3InstantiateCoSimulation",
            interface,
            instance_name,
            instantiation_token,
            resource_path,
            visible,
            logging_on,
            env,
            log_message,
        )
    }
}

/// `fmi3InstantiateScheduledExecution`: not offered; NULL, with the reason logged.
///
/// # Safety
/// The callback NULL or valid during the call.
#[allow(clippy::too_many_arguments)]
pub unsafe fn fmi3_instantiate_scheduled_execution<M: FmuModel>(
    _instance_name: Fmi3String,
    _instantiation_token: Fmi3String,
    _resource_path: Fmi3String,
    _visible: Fmi3Boolean,
    _logging_on: Fmi3Boolean,
    env: Fmi3InstanceEnvironment,
    log_message: Option<Fmi3LogMessageCallback>,
    _clock_update: Option<Fmi3ClockUpdateCallback>,
    _lock: Option<Fmi3LockPreemptionCallback>,
    _unlock: Option<Fmi3UnlockPreemptionCallback>,
) -> Fmi3Instance {
    if let Some(sink) = log_sink(log_message, env) {
        let msg = format!(
            "fmi3InstantiateScheduledExecution: {} offers Co-Simulation and Model Exchange, not \
             Scheduled Execution",
            M::model_info().model_identifier
        );
        let _ = barrier(|| sink(Status::Error, "logStatusError", &msg));
    }
    std::ptr::null_mut()
}

/// `fmi3FreeInstance`. NULL or a pointer that is not a live instance is ignored.
///
/// # Safety
/// `c` must be NULL or a pointer returned by this library's instantiation for the same `M`.
pub unsafe fn fmi3_free_instance<M: FmuModel>(c: Fmi3Instance) {
    // SAFETY: `c` is NULL or an instance of this library, not used after this (caller's
    // contract).
    unsafe { Instance::<M>::free_handle(c, INSTANCE_MAGIC) }
}

/// `fmi3SetDebugLogging`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_set_debug_logging<M: FmuModel>(
    c: Fmi3Instance,
    logging_on: Fmi3Boolean,
    n_categories: usize,
    categories: *const Fmi3String,
) -> Fmi3Status {
    let f = Func::SetDebugLogging;
    let body = |i: &mut Instance<M>| {
        // SAFETY: `categories` holds `n_categories` string pointers (caller's contract).
        let Some(cats) = (unsafe { slice(categories, n_categories) }) else {
            return null_arg(i, f, "categories");
        };
        let mut names = Vec::with_capacity(cats.len());
        for &p in cats {
            // SAFETY: each category is NULL or a NUL-terminated string (caller's contract).
            match unsafe { opt_str(p) } {
                Some(s) => names.push(s.to_string_lossy().into_owned()),
                None => return null_arg(i, f, "categories[i]"),
            }
        }
        i.set_debug_logging(f.name(), logging_on != 0, &names)
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3EnterInitializationMode`: the experiment (tolerance, start and stop time) and
/// then initialisation mode, as FMI 2.0's `fmi2SetupExperiment` and
/// `fmi2EnterInitializationMode` do together.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_enter_initialization_mode<M: FmuModel>(
    c: Fmi3Instance,
    tolerance_defined: Fmi3Boolean,
    tolerance: f64,
    start_time: f64,
    stop_time_defined: Fmi3Boolean,
    stop_time: f64,
) -> Fmi3Status {
    let f = Func::EnterInitializationMode;
    let body = |i: &mut Instance<M>| {
        let a = i.setup_experiment(
            f.name(),
            (tolerance_defined != 0).then_some(tolerance),
            start_time,
            (stop_time_defined != 0).then_some(stop_time),
        );
        if a > Status::Warning {
            return a;
        }
        a.max(i.enter_initialization_mode(f.name()))
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3ExitInitializationMode`: Model Exchange continues in event mode, Co-Simulation in
/// step mode (no event mode is used).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_exit_initialization_mode<M: FmuModel>(c: Fmi3Instance) -> Fmi3Status {
    let f = Func::ExitInitializationMode;
    let body = |i: &mut Instance<M>| {
        let next = if i.is_model_exchange() {
            Mode::EventMode
        } else {
            Mode::StepComplete
        };
        i.exit_initialization_mode(f.name(), next)
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3EnterEventMode`: Model Exchange, from continuous-time mode (a Co-Simulation
/// instance of this FMU has no event mode).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_enter_event_mode<M: FmuModel>(c: Fmi3Instance) -> Fmi3Status {
    let f = Func::EnterEventMode;
    let body = |i: &mut Instance<M>| {
        if !i.is_model_exchange() {
            return unsupported(
                i,
                f,
                "this FMU has no event mode in Co-Simulation (hasEventMode is not declared)",
            );
        }
        i.enter_mode(f.name(), Mode::EventMode)
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3Terminate`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_terminate<M: FmuModel>(c: Fmi3Instance) -> Fmi3Status {
    let f = Func::Terminate;
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, |i: &mut Instance<M>| i.terminate(f.name())) }
}

/// `fmi3Reset`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_reset<M: FmuModel>(c: Fmi3Instance) -> Fmi3Status {
    let f = Func::Reset;
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, |i: &mut Instance<M>| i.reset(f.name())) }
}

/// `fmi3EnterConfigurationMode`: there are no structural parameters to configure.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_enter_configuration_mode<M: FmuModel>(c: Fmi3Instance) -> Fmi3Status {
    let f = Func::EnterConfigurationMode;
    let body = |i: &mut Instance<M>| unsupported(i, f, "this FMU has no structural parameters");
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3ExitConfigurationMode`: never allowed (configuration mode is never entered).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_exit_configuration_mode<M: FmuModel>(c: Fmi3Instance) -> Fmi3Status {
    let f = Func::ExitConfigurationMode;
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, |_: &mut Instance<M>| Status::Error) }
}
