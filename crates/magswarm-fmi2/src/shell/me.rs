//! Model Exchange: time, continuous states and derivatives, the event iteration (which
//! ends at once: no discrete states, no event indicators) and completed integrator steps.

use magswarm_fmi_core::ffi::{slice, slice_mut};
use magswarm_fmi_core::{FmuModel, Instance, Status};

use super::{entry, null_arg};
use crate::abi::*;
use crate::state::{Func, Mode};

/// `fmi2SetTime`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_set_time<M: FmuModel>(c: Fmi2Component, time: Fmi2Real) -> Fmi2Status {
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe {
        entry::<M>(c, Func::SetTime, |i: &mut Instance<M>| {
            i.set_time(Func::SetTime.name(), time)
        })
    }
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
            Some(x) => i.set_continuous_states(Func::SetContinuousStates.name(), x),
            None => null_arg(i, Func::SetContinuousStates, "x"),
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
    let body = |i: &mut Instance<M>| i.enter_mode(Func::EnterEventMode.name(), Mode::EventMode);
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
        Status::Ok
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
    let body = |i: &mut Instance<M>| {
        i.enter_mode(
            Func::EnterContinuousTimeMode.name(),
            Mode::ContinuousTimeMode,
        )
    };
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
        let (s, ev) = i.completed_integrator_step(Func::CompletedIntegratorStep.name());
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
                    Some(o) => i.$method($func.name(), o),
                    None => null_arg(i, $func, $arg),
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
    let body = |i: &mut Instance<M>| i.get_event_indicators(Func::GetEventIndicators.name(), ni);
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::GetEventIndicators, body) }
}
