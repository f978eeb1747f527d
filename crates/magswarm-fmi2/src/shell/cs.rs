//! Co-Simulation: `fmi2DoStep` and the functions around it that this FMU answers with
//! "not supported" or "not available" (it never interpolates inputs, never returns
//! output derivatives, and its steps are synchronous).

use std::ffi::c_int;

use magswarm_fmi_core::{FmuModel, Instance, Status};

use super::{entry, null_arg};
use crate::abi::*;
use crate::state::Func;

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
            f.name(),
            Status::Error,
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
        i.fail(f.name(), Status::Error, "not supported: this FMU provides no output derivatives (maxOutputDerivativeOrder=\"0\")")
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
    let body = |i: &mut Instance<M>| {
        i.do_step(
            Func::DoStep.name(),
            current_communication_point,
            communication_step_size,
        )
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, Func::DoStep, body) }
}

/// `fmi2CancelStep`: always an illegal call (no step is ever pending).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_cancel_step<M: FmuModel>(c: Fmi2Component) -> Fmi2Status {
    let body = |_: &mut Instance<M>| Status::Error;
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
fn status_unavailable<M: FmuModel>(i: &mut Instance<M>, f: Func, kind: c_int) -> Status {
    match status_kind_name(kind) {
        None => i.fail(f.name(), Status::Error, format!("invalid fmi2StatusKind {kind}")),
        Some(k) => i.fail(
            f.name(),
            Status::Discard,
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
            unsafe { *value = i.time() };
            return Status::Ok;
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
            return Status::Ok;
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
