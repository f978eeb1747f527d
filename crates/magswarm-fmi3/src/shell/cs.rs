//! Co-Simulation (`fmi3DoStep` and the functions around it), and the clock, interval and
//! Scheduled Execution functions, which every FMI 3.0 FMU exports but which this one has
//! nothing to act on (no clocks): each answers `fmi3Error` with the reason, as the
//! standard's answer for an unsupported function.

use std::ffi::c_int;

use magswarm_fmi_core::{FmuModel, Instance, Mode, Status};

use super::{entry, null_arg, unsupported};
use crate::abi::*;
use crate::state::Func;

/// `fmi3EnterStepMode`: only from event mode, which a Co-Simulation instance of this FMU
/// never has (the state table refuses it with that explanation).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_enter_step_mode<M: FmuModel>(c: Fmi3Instance) -> Fmi3Status {
    let f = Func::EnterStepMode;
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe {
        entry::<M>(c, f, |i: &mut Instance<M>| {
            i.enter_mode(f.name(), Mode::StepComplete)
        })
    }
}

/// `fmi3DoStep`. The FMU never asks for event handling, never terminates the simulation
/// and never returns early; `lastSuccessfulTime` is the time reached (the start of the step
/// if it failed).
///
/// # Safety
/// See the module documentation.
#[allow(clippy::too_many_arguments)]
pub unsafe fn fmi3_do_step<M: FmuModel>(
    c: Fmi3Instance,
    current_communication_point: f64,
    communication_step_size: f64,
    _no_set_fmu_state_prior: Fmi3Boolean,
    event_handling_needed: *mut Fmi3Boolean,
    terminate_simulation: *mut Fmi3Boolean,
    early_return: *mut Fmi3Boolean,
    last_successful_time: *mut f64,
) -> Fmi3Status {
    let f = Func::DoStep;
    let body = |i: &mut Instance<M>| {
        // One test of the four output pointers on the way in; which one is NULL is looked
        // for only when one is (in the order of the arguments).
        if event_handling_needed.is_null()
            || terminate_simulation.is_null()
            || early_return.is_null()
            || last_successful_time.is_null()
        {
            let name = if event_handling_needed.is_null() {
                "eventHandlingNeeded"
            } else if terminate_simulation.is_null() {
                "terminateSimulation"
            } else if early_return.is_null() {
                "earlyReturn"
            } else {
                "lastSuccessfulTime"
            };
            return null_arg(i, f, name);
        }
        let s = i.do_step(
            f.name(),
            current_communication_point,
            communication_step_size,
        );
        // FMI 3.0 has no StepFailed state: a discarded step leaves the instance in Step
        // Mode at the time it reached.
        if s == Status::Discard && i.mode() == Mode::StepFailed {
            i.shell.mode = Mode::StepComplete;
        }
        // SAFETY: the four pointers are non-NULL (checked above) and point to the
        // importer's output variables (caller's contract).
        unsafe {
            *event_handling_needed = FMI3_FALSE;
            *terminate_simulation = FMI3_FALSE;
            *early_return = FMI3_FALSE;
            *last_successful_time = i.time();
        }
        s
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3GetOutputDerivatives`: not provided (`maxOutputDerivativeOrder` is 0).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_get_output_derivatives<M: FmuModel>(
    c: Fmi3Instance,
    _vr: *const Fmi3ValueReference,
    _nvr: usize,
    _orders: *const i32,
    _values: *mut f64,
    _n_values: usize,
) -> Fmi3Status {
    let f = Func::GetOutputDerivatives;
    let body = |i: &mut Instance<M>| {
        unsupported(
            i,
            f,
            "this FMU provides no output derivatives (maxOutputDerivativeOrder = 0)",
        )
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// The reason every clock-related function gives.
const NO_CLOCKS: &str =
    "this FMU has no clocks (no clocked variables, intervals or model partitions)";

macro_rules! no_clocks {
    ($(#[$doc:meta])* $name:ident, $func:expr, ($($arg:ident : $t:ty),*)) => {
        $(#[$doc])*
        ///
        /// # Safety
        /// See the module documentation.
        pub unsafe fn $name<M: FmuModel>(c: Fmi3Instance, $($arg: $t),*) -> Fmi3Status {
            $(let _ = $arg;)*
            // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
            unsafe { entry::<M>(c, $func, |i: &mut Instance<M>| unsupported(i, $func, NO_CLOCKS)) }
        }
    };
}

no_clocks!(/// `fmi3GetClock` (no clocks).
    fmi3_get_clock, Func::GetClock, (vr: *const u32, nvr: usize, values: *mut Fmi3Clock));
no_clocks!(/// `fmi3SetClock` (no clocks).
    fmi3_set_clock, Func::SetClock, (vr: *const u32, nvr: usize, values: *const Fmi3Clock));
no_clocks!(/// `fmi3GetIntervalDecimal` (no clocks).
    fmi3_get_interval_decimal, Func::GetIntervalDecimal,
    (vr: *const u32, nvr: usize, intervals: *mut f64, qualifiers: *mut c_int));
no_clocks!(/// `fmi3GetIntervalFraction` (no clocks).
    fmi3_get_interval_fraction, Func::GetIntervalFraction,
    (vr: *const u32, nvr: usize, counters: *mut u64, resolutions: *mut u64, qualifiers: *mut c_int));
no_clocks!(/// `fmi3GetShiftDecimal` (no clocks).
    fmi3_get_shift_decimal, Func::GetShiftDecimal, (vr: *const u32, nvr: usize, shifts: *mut f64));
no_clocks!(/// `fmi3GetShiftFraction` (no clocks).
    fmi3_get_shift_fraction, Func::GetShiftFraction,
    (vr: *const u32, nvr: usize, counters: *mut u64, resolutions: *mut u64));
no_clocks!(/// `fmi3SetIntervalDecimal` (no clocks).
    fmi3_set_interval_decimal, Func::SetIntervalDecimal, (vr: *const u32, nvr: usize, intervals: *const f64));
no_clocks!(/// `fmi3SetIntervalFraction` (no clocks).
    fmi3_set_interval_fraction, Func::SetIntervalFraction,
    (vr: *const u32, nvr: usize, counters: *const u64, resolutions: *const u64));
no_clocks!(/// `fmi3SetShiftDecimal` (no clocks).
    fmi3_set_shift_decimal, Func::SetShiftDecimal, (vr: *const u32, nvr: usize, shifts: *const f64));
no_clocks!(/// `fmi3SetShiftFraction` (no clocks).
    fmi3_set_shift_fraction, Func::SetShiftFraction,
    (vr: *const u32, nvr: usize, counters: *const u64, resolutions: *const u64));
no_clocks!(/// `fmi3EvaluateDiscreteStates` (no clocked partitions).
    fmi3_evaluate_discrete_states, Func::EvaluateDiscreteStates, ());
no_clocks!(/// `fmi3ActivateModelPartition` (no Scheduled Execution).
    fmi3_activate_model_partition, Func::ActivateModelPartition, (clock: u32, time: f64));
