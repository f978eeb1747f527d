//! FMU states, directional and adjoint derivatives, and variable dependencies. The checks
//! (whose handle, which interface saved it, the frame of serialized bytes, finite seeds and
//! derivatives) are the core's; these functions read and write the importer's arrays.

use std::ffi::c_int;

use magswarm_fmi_core::ffi::{slice, slice_mut};
use magswarm_fmi_core::{Causality, FmuModel, Instance, Status};

use super::{entry, null_arg};
use crate::abi::*;
use crate::state::Func;

/// `fmi3GetFMUState`: a new snapshot if `*state` is NULL, else overwrite the snapshot it
/// points to.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_get_fmu_state<M: FmuModel>(
    c: Fmi3Instance,
    state: *mut Fmi3FmuState,
) -> Fmi3Status {
    let f = Func::GetFmuState;
    // SAFETY: the importer's pointers, as the core method requires (caller's contract).
    let body = |i: &mut Instance<M>| unsafe { i.get_fmu_state_at(f.name(), state, "FMUState") };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3SetFMUState`: the instance becomes what it was, mode included.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_set_fmu_state<M: FmuModel>(c: Fmi3Instance, state: Fmi3FmuState) -> Fmi3Status {
    let f = Func::SetFmuState;
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, |i: &mut Instance<M>| i.set_fmu_state(f.name(), state)) }
}

/// `fmi3FreeFMUState`: frees `*state` and sets it to NULL (NULL `*state` is a no-op).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_free_fmu_state<M: FmuModel>(
    c: Fmi3Instance,
    state: *mut Fmi3FmuState,
) -> Fmi3Status {
    let f = Func::FreeFmuState;
    // SAFETY: the importer's pointers, as the core method requires (caller's contract).
    let body = |i: &mut Instance<M>| unsafe { i.free_fmu_state_at(f.name(), state, "FMUState") };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3SerializedFMUStateSize`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_serialized_fmu_state_size<M: FmuModel>(
    c: Fmi3Instance,
    state: Fmi3FmuState,
    size: *mut usize,
) -> Fmi3Status {
    let f = Func::SerializedFmuStateSize;
    // SAFETY: the importer's pointers, as the core method requires (caller's contract).
    let body = |i: &mut Instance<M>| unsafe { i.serialized_size_at(f.name(), state, size) };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3SerializeFMUState`: `size` must equal what `fmi3SerializedFMUStateSize` returned.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_serialize_fmu_state<M: FmuModel>(
    c: Fmi3Instance,
    state: Fmi3FmuState,
    serialized_state: *mut Fmi3Byte,
    size: usize,
) -> Fmi3Status {
    let f = Func::SerializeFmuState;
    let buffer = serialized_state;
    // SAFETY: the importer's pointers, as the core method requires (caller's contract).
    let body = |i: &mut Instance<M>| unsafe {
        i.serialize_into(f.name(), state, buffer, size, "fmi3SerializedFMUStateSize")
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3DeserializeFMUState`: always a new FMU state (the incoming `*state` is not read).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_deserialize_fmu_state<M: FmuModel>(
    c: Fmi3Instance,
    serialized_state: *const Fmi3Byte,
    size: usize,
    state: *mut Fmi3FmuState,
) -> Fmi3Status {
    let f = Func::DeserializeFmuState;
    let bytes = serialized_state;
    // SAFETY: the importer's pointers, as the core method requires (caller's contract).
    let body =
        |i: &mut Instance<M>| unsafe { i.deserialize_at(f.name(), bytes, size, state, "FMUState") };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// The four arrays of a derivative call, with their lengths checked: (unknowns, knowns,
/// seed, sensitivity). `seed_over_knowns` is true for directional derivatives (seed over
/// the knowns, sensitivity over the unknowns) and false for adjoint ones.
///
/// # Safety
/// Each pointer is NULL or an array of its count.
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
unsafe fn derivative_args<'a, M: FmuModel>(
    i: &mut Instance<M>,
    f: Func,
    (unknowns, n_unknowns): (*const u32, usize),
    (knowns, n_knowns): (*const u32, usize),
    (seed, n_seed): (*const f64, usize),
    (sensitivity, n_sensitivity): (*mut f64, usize),
    seed_over_knowns: bool,
) -> Result<(&'a [u32], &'a [u32], &'a [f64], &'a mut [f64]), Status> {
    let (want_seed, want_sens) = if seed_over_knowns {
        (n_knowns, n_unknowns)
    } else {
        (n_unknowns, n_knowns)
    };
    if n_seed != want_seed || n_sensitivity != want_sens {
        return Err(i.fail(
            f.name(),
            Status::Error,
            format!(
                "nSeed = {n_seed} and nSensitivity = {n_sensitivity}, but {n_unknowns} unknowns \
                 and {n_knowns} knowns (all scalars) need {want_seed} and {want_sens}"
            ),
        ));
    }
    // SAFETY (all four): arrays of the counts the importer passes (caller's contract);
    // `sensitivity` is its output buffer, aliased by none of the inputs.
    let Some(u) = (unsafe { slice(unknowns, n_unknowns) }) else {
        return Err(null_arg(i, f, "unknowns"));
    };
    let Some(k) = (unsafe { slice(knowns, n_knowns) }) else {
        return Err(null_arg(i, f, "knowns"));
    };
    let Some(s) = (unsafe { slice(seed, n_seed) }) else {
        return Err(null_arg(i, f, "seed"));
    };
    let Some(out) = (unsafe { slice_mut(sensitivity, n_sensitivity) }) else {
        return Err(null_arg(i, f, "sensitivity"));
    };
    Ok((u, k, s, out))
}

/// `fmi3GetDirectionalDerivative`: `sensitivity = J seed`.
///
/// # Safety
/// See the module documentation.
#[allow(clippy::too_many_arguments)]
pub unsafe fn fmi3_get_directional_derivative<M: FmuModel>(
    c: Fmi3Instance,
    unknowns: *const Fmi3ValueReference,
    n_unknowns: usize,
    knowns: *const Fmi3ValueReference,
    n_knowns: usize,
    seed: *const f64,
    n_seed: usize,
    sensitivity: *mut f64,
    n_sensitivity: usize,
) -> Fmi3Status {
    let f = Func::GetDirectionalDerivative;
    let body = |i: &mut Instance<M>| {
        let args = (unknowns, n_unknowns);
        let k = (knowns, n_knowns);
        // SAFETY: the caller's contract.
        match unsafe {
            derivative_args(
                i,
                f,
                args,
                k,
                (seed, n_seed),
                (sensitivity, n_sensitivity),
                true,
            )
        } {
            Ok((u, k, s, out)) => i.directional_derivative(f.name(), (u, k), s, "seed", out),
            Err(s) => s,
        }
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3GetAdjointDerivative`: `sensitivity = seed^T J` (seed over the unknowns).
///
/// # Safety
/// See the module documentation.
#[allow(clippy::too_many_arguments)]
pub unsafe fn fmi3_get_adjoint_derivative<M: FmuModel>(
    c: Fmi3Instance,
    unknowns: *const Fmi3ValueReference,
    n_unknowns: usize,
    knowns: *const Fmi3ValueReference,
    n_knowns: usize,
    seed: *const f64,
    n_seed: usize,
    sensitivity: *mut f64,
    n_sensitivity: usize,
) -> Fmi3Status {
    let f = Func::GetAdjointDerivative;
    let body = |i: &mut Instance<M>| {
        let args = (unknowns, n_unknowns);
        let k = (knowns, n_knowns);
        // SAFETY: the caller's contract.
        match unsafe {
            derivative_args(
                i,
                f,
                args,
                k,
                (seed, n_seed),
                (sensitivity, n_sensitivity),
                false,
            )
        } {
            Ok((u, k, s, out)) => i.adjoint_derivative(f.name(), (u, k), s, out),
            Err(s) => s,
        }
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// What `dependent` depends on while stepping, from the table (`ModelStructure`): its
/// stated dependencies, or, where the table states none, every input and continuous state.
fn dependencies_of<M: FmuModel>(
    i: &mut Instance<M>,
    f: Func,
    dependent: u32,
) -> Result<Vec<u32>, Status> {
    let Some(v) = i.table.get(dependent) else {
        return Err(i.fail(
            f.name(),
            Status::Error,
            format!("unknown value reference {dependent}"),
        ));
    };
    if !(v.causality == Causality::Output || v.derivative_of.is_some()) {
        return Err(i.fail(
            f.name(),
            Status::Error,
            format!(
                "variable \"{}\" is neither an output nor a state derivative: it has no \
                 dependencies in the model structure",
                v.name
            ),
        ));
    }
    Ok(match v.dependencies {
        Some(d) => d.to_vec(),
        None => {
            let info = i.table.info;
            let states = magswarm_fmi_core::table::state_vrs(info);
            info.variables
                .iter()
                .filter(|w| w.causality == Causality::Input || states.contains(&w.vr))
                .map(|w| w.vr)
                .collect()
        }
    })
}

/// `fmi3GetNumberOfVariableDependencies`.
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_get_number_of_variable_dependencies<M: FmuModel>(
    c: Fmi3Instance,
    dependent: Fmi3ValueReference,
    n_dependencies: *mut usize,
) -> Fmi3Status {
    let f = Func::GetNumberOfVariableDependencies;
    let body = |i: &mut Instance<M>| {
        if n_dependencies.is_null() {
            return null_arg(i, f, "nDependencies");
        }
        match dependencies_of(i, f, dependent) {
            Ok(d) => {
                // SAFETY: non-NULL (checked above), the importer's output variable.
                unsafe { *n_dependencies = d.len() };
                Status::Ok
            }
            Err(s) => s,
        }
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3GetVariableDependencies`: every dependency is reported as `fmi3Dependent` between
/// scalars (element index 0).
///
/// # Safety
/// See the module documentation.
#[allow(clippy::too_many_arguments)]
pub unsafe fn fmi3_get_variable_dependencies<M: FmuModel>(
    c: Fmi3Instance,
    dependent: Fmi3ValueReference,
    element_indices_of_dependent: *mut usize,
    independents: *mut Fmi3ValueReference,
    element_indices_of_independents: *mut usize,
    dependency_kinds: *mut c_int,
    n_dependencies: usize,
) -> Fmi3Status {
    let f = Func::GetVariableDependencies;
    let body = |i: &mut Instance<M>| {
        let deps = match dependencies_of(i, f, dependent) {
            Ok(d) => d,
            Err(s) => return s,
        };
        if deps.len() != n_dependencies {
            let msg = format!(
                "nDependencies = {n_dependencies} but the variable has {} (see \
                 fmi3GetNumberOfVariableDependencies)",
                deps.len()
            );
            return i.fail(f.name(), Status::Error, msg);
        }
        // SAFETY (all four): output arrays of `n_dependencies` elements (caller's contract).
        let arrays = unsafe {
            (
                slice_mut(element_indices_of_dependent, n_dependencies),
                slice_mut(independents, n_dependencies),
                slice_mut(element_indices_of_independents, n_dependencies),
                slice_mut(dependency_kinds, n_dependencies),
            )
        };
        let (Some(ed), Some(ind), Some(ei), Some(kinds)) = arrays else {
            return null_arg(i, f, "the output arrays");
        };
        for (k, vr) in deps.into_iter().enumerate() {
            ed[k] = 0;
            ind[k] = vr;
            ei[k] = 0;
            kinds[k] = FMI3_DEPENDENT;
        }
        Status::Ok
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}
