//! Model Exchange: time, continuous states and derivatives, the event iteration (which ends
//! at once: no discrete states, no event indicators) and completed integrator steps.

use magswarm_fmi_core::ffi::{slice, slice_mut};
use magswarm_fmi_core::{FmuModel, Instance, Mode, Status};

use super::{entry, null_arg};
use crate::abi::*;
use crate::state::Func;

/// `fmi3SetTime`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_set_time<M: FmuModel>(c: Fmi3Instance, time: f64) -> Fmi3Status {
    let f = Func::SetTime;
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, |i: &mut Instance<M>| i.set_time(f.name(), time)) }
}

/// `fmi3SetContinuousStates`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_set_continuous_states<M: FmuModel>(
    c: Fmi3Instance,
    x: *const f64,
    nx: usize,
) -> Fmi3Status {
    let f = Func::SetContinuousStates;
    let body = |i: &mut Instance<M>| {
        // SAFETY: `x` is NULL or points to `nx` reals (caller's contract).
        match unsafe { slice(x, nx) } {
            Some(x) => i.set_continuous_states(f.name(), x),
            None => null_arg(i, f, "continuousStates"),
        }
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3EnterContinuousTimeMode`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_enter_continuous_time_mode<M: FmuModel>(c: Fmi3Instance) -> Fmi3Status {
    let f = Func::EnterContinuousTimeMode;
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe {
        entry::<M>(c, f, |i: &mut Instance<M>| {
            i.enter_mode(f.name(), Mode::ContinuousTimeMode)
        })
    }
}

/// `fmi3UpdateDiscreteStates`: no discrete states and no time events, so the event
/// iteration ends at once (every flag false).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_update_discrete_states<M: FmuModel>(
    c: Fmi3Instance,
    discrete_states_need_update: *mut Fmi3Boolean,
    terminate_simulation: *mut Fmi3Boolean,
    nominals_changed: *mut Fmi3Boolean,
    values_changed: *mut Fmi3Boolean,
    next_event_time_defined: *mut Fmi3Boolean,
    next_event_time: *mut f64,
) -> Fmi3Status {
    let f = Func::UpdateDiscreteStates;
    let body = |i: &mut Instance<M>| {
        let flags = [
            (discrete_states_need_update, "discreteStatesNeedUpdate"),
            (terminate_simulation, "terminateSimulation"),
            (nominals_changed, "nominalsOfContinuousStatesChanged"),
            (values_changed, "valuesOfContinuousStatesChanged"),
            (next_event_time_defined, "nextEventTimeDefined"),
        ];
        if let Some((_, name)) = flags.iter().find(|(p, _)| p.is_null()) {
            return null_arg(i, f, name);
        }
        if next_event_time.is_null() {
            return null_arg(i, f, "nextEventTime");
        }
        for (p, _) in flags {
            // SAFETY: non-NULL (checked above), the importer's output variables.
            unsafe { *p = FMI3_FALSE };
        }
        // SAFETY: as above.
        unsafe { *next_event_time = 0.0 };
        Status::Ok
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3CompletedIntegratorStep`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_completed_integrator_step<M: FmuModel>(
    c: Fmi3Instance,
    _no_set_fmu_state_prior: Fmi3Boolean,
    enter_event_mode: *mut Fmi3Boolean,
    terminate_simulation: *mut Fmi3Boolean,
) -> Fmi3Status {
    let f = Func::CompletedIntegratorStep;
    let body = |i: &mut Instance<M>| {
        if enter_event_mode.is_null() {
            return null_arg(i, f, "enterEventMode");
        }
        if terminate_simulation.is_null() {
            return null_arg(i, f, "terminateSimulation");
        }
        let (s, ev) = i.completed_integrator_step(f.name());
        // SAFETY: both non-NULL (checked above), the importer's output variables.
        unsafe {
            *enter_event_mode = ev as Fmi3Boolean;
            *terminate_simulation = FMI3_FALSE;
        }
        s
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

macro_rules! me_array_getter {
    ($(#[$doc:meta])* $name:ident, $func:expr, $arg:literal, $method:ident) => {
        $(#[$doc])*
        ///
        /// # Safety
        /// See the module documentation.
        pub unsafe fn $name<M: FmuModel>(c: Fmi3Instance, out: *mut f64, n: usize) -> Fmi3Status {
            let body = |i: &mut Instance<M>| {
                // SAFETY: `out` is NULL or points to `n` writable reals (caller's contract).
                match unsafe { slice_mut(out, n) } {
                    Some(o) => i.$method($func.name(), o),
                    None => null_arg(i, $func, $arg),
                }
            };
            // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
            unsafe { entry::<M>(c, $func, body) }
        }
    };
}

me_array_getter!(
    /// `fmi3GetContinuousStateDerivatives`.
    fmi3_get_continuous_state_derivatives,
    Func::GetContinuousStateDerivatives,
    "derivatives",
    get_derivatives
);
me_array_getter!(
    /// `fmi3GetContinuousStates`.
    fmi3_get_continuous_states, Func::GetContinuousStates, "continuousStates", get_continuous_states
);
me_array_getter!(
    /// `fmi3GetNominalsOfContinuousStates`.
    fmi3_get_nominals_of_continuous_states,
    Func::GetNominalsOfContinuousStates,
    "nominals",
    get_nominals
);

/// `fmi3GetEventIndicators` (none: only `nEventIndicators = 0` is accepted).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_get_event_indicators<M: FmuModel>(
    c: Fmi3Instance,
    _indicators: *mut f64,
    ni: usize,
) -> Fmi3Status {
    let f = Func::GetEventIndicators;
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe {
        entry::<M>(c, f, |i: &mut Instance<M>| {
            i.get_event_indicators(f.name(), ni)
        })
    }
}

/// `fmi3GetNumberOfEventIndicators`: 0.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_get_number_of_event_indicators<M: FmuModel>(
    c: Fmi3Instance,
    n: *mut usize,
) -> Fmi3Status {
    let f = Func::GetNumberOfEventIndicators;
    let body = |i: &mut Instance<M>| {
        if n.is_null() {
            return null_arg(i, f, "nEventIndicators");
        }
        // SAFETY: non-NULL (checked above), the importer's output variable.
        unsafe { *n = 0 };
        Status::Ok
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3GetNumberOfContinuousStates`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_get_number_of_continuous_states<M: FmuModel>(
    c: Fmi3Instance,
    n: *mut usize,
) -> Fmi3Status {
    let f = Func::GetNumberOfContinuousStates;
    let body = |i: &mut Instance<M>| {
        if n.is_null() {
            return null_arg(i, f, "nContinuousStates");
        }
        // SAFETY: non-NULL (checked above), the importer's output variable.
        unsafe { *n = i.n_states() };
        Status::Ok
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}
