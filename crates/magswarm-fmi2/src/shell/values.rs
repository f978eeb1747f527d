//! `fmi2Get*` and `fmi2Set*`.

use magswarm_fmi_core::ffi::{opt_str, slice, slice_mut};
use magswarm_fmi_core::{FmuModel, Instance};

use super::{entry, null_arg};
use crate::abi::*;
use crate::state::Func;

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
                let Some(vrs) = (unsafe { slice(vr, nvr) }) else { return null_arg(i, $func, "vr") };
                // SAFETY: as above.
                let Some(out) = (unsafe { slice_mut(value, nvr) }) else { return null_arg(i, $func, "value") };
                i.$method($func.name(), vrs, out)
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
                let Some(vrs) = (unsafe { slice(vr, nvr) }) else { return null_arg(i, $func, "vr") };
                // SAFETY: as above.
                let Some(vals) = (unsafe { slice(value, nvr) }) else { return null_arg(i, $func, "value") };
                i.$method($func.name(), vrs, vals)
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
        let Some(vrs) = (unsafe { slice(vr, nvr) }) else {
            return null_arg(i, f, "vr");
        };
        // SAFETY: as above.
        let Some(vals) = (unsafe { slice(value, nvr) }) else {
            return null_arg(i, f, "value");
        };
        let strs: Vec<Option<&str>> = vals
            .iter()
            // SAFETY: each value is NULL or a NUL-terminated string (caller's contract).
            .map(|&p| unsafe { opt_str(p) }.and_then(|s| s.to_str().ok()))
            .collect();
        i.set_string(f.name(), vrs, &strs)
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi2SetBoolean` (any non-zero `fmi2Boolean` is true).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi2_set_boolean<M: FmuModel>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Boolean,
) -> Fmi2Status {
    let f = Func::SetBoolean;
    let body = |i: &mut Instance<M>| {
        // SAFETY: `vr` and `value` are arrays of `nvr` elements (caller's contract).
        let Some(vrs) = (unsafe { slice(vr, nvr) }) else {
            return null_arg(i, f, "vr");
        };
        // SAFETY: as above.
        let Some(vals) = (unsafe { slice(value, nvr) }) else {
            return null_arg(i, f, "value");
        };
        let b: Vec<bool> = vals.iter().map(|&x| x != 0).collect();
        i.set_boolean(f.name(), vrs, &b)
    };
    // SAFETY: `c` is NULL or a component this library returned (caller's contract);
    // `entry` tells which before touching it.
    unsafe { entry::<M>(c, f, body) }
}
