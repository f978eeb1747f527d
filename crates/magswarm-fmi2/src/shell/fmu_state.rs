//! FMU states (`fmi2GetFMUstate` ... `fmi2DeSerializeFMUstate`) and
//! `fmi2GetDirectionalDerivative`. The checks (whose handle, which interface saved it, the
//! frame of serialized bytes) are the core's ([`magswarm_fmi_core::instance::fmu_state`]);
//! these functions only read and write the importer's variables.

use magswarm_fmi_core::ffi::{slice, slice_mut};
use magswarm_fmi_core::{FmuModel, Instance};

use super::{entry, null_arg};
use crate::abi::*;
use crate::state::Func;

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
    // SAFETY: the importer's pointers, as the core method requires (caller's contract).
    let body = |i: &mut Instance<M>| unsafe { i.get_fmu_state_at(f.name(), state, "FMUstate") };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi2SetFMUstate`: the instance becomes what it was, state machine included.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_set_fmu_state<M: FmuModel>(c: Fmi2Component, state: Fmi2FmuState) -> Fmi2Status {
    let f = Func::SetFmuState;
    let body = |i: &mut Instance<M>| i.set_fmu_state(f.name(), state);
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
    // SAFETY: the importer's pointers, as the core method requires (caller's contract).
    let body = |i: &mut Instance<M>| unsafe { i.free_fmu_state_at(f.name(), state, "FMUstate") };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
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
    // SAFETY: the importer's pointers, as the core method requires (caller's contract).
    let body = |i: &mut Instance<M>| unsafe { i.serialized_size_at(f.name(), state, size) };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
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
    let buffer = serialized_state as *mut u8;
    // SAFETY: the importer's pointers, as the core method requires (caller's contract).
    let body = |i: &mut Instance<M>| unsafe {
        i.serialize_into(f.name(), state, buffer, size, "fmi2SerializedFMUstateSize")
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
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
    let bytes = serialized_state as *const u8;
    // SAFETY: the importer's pointers, as the core method requires (caller's contract).
    let body =
        |i: &mut Instance<M>| unsafe { i.deserialize_at(f.name(), bytes, size, state, "FMUstate") };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
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
        let Some(unknowns) = (unsafe { slice(v_unknown_ref, n_unknown) }) else {
            return null_arg(i, f, "vUnknown_ref");
        };
        let Some(knowns) = (unsafe { slice(v_known_ref, n_known) }) else {
            return null_arg(i, f, "vKnown_ref");
        };
        let Some(dvk) = (unsafe { slice(dv_known, n_known) }) else {
            return null_arg(i, f, "dvKnown");
        };
        let Some(dvu) = (unsafe { slice_mut(dv_unknown, n_unknown) }) else {
            return null_arg(i, f, "dvUnknown");
        };
        i.directional_derivative(f.name(), (unknowns, knowns), dvk, "dvKnown", dvu)
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}
