//! `fmi3Get*` and `fmi3Set*`. The table's Reals are `Float64`, its Integers `Int32`; a
//! model of this shell has no variable of the other types (`Float32`, `Int8` ... `UInt64`,
//! `Binary`), so their getters and setters accept only empty calls and name the variable's
//! real type otherwise.

use magswarm_fmi_core::ffi::{opt_str, slice, slice_mut};
use magswarm_fmi_core::{FmuModel, Instance, Status, VarType};

use super::{check_n_values, entry, null_arg};
use crate::abi::*;
use crate::state::Func;

/// FMI 3.0's name of a table type.
pub fn type_name(ty: VarType) -> &'static str {
    match ty {
        VarType::Real => "Float64",
        VarType::Integer => "Int32",
        VarType::Boolean => "Boolean",
        VarType::String => "String",
    }
}

macro_rules! getter {
    ($(#[$doc:meta])* $name:ident, $func:expr, $t:ty, $method:ident) => {
        $(#[$doc])*
        ///
        /// # Safety
        /// See the module documentation.
        pub unsafe fn $name<M: FmuModel>(
            c: Fmi3Instance,
            vr: *const Fmi3ValueReference,
            nvr: usize,
            value: *mut $t,
            n_values: usize,
        ) -> Fmi3Status {
            let body = |i: &mut Instance<M>| {
                if let Err(s) = check_n_values(i, $func, nvr, n_values) {
                    return s;
                }
                // SAFETY: `vr` and `value` are arrays of `nvr` elements (caller's contract);
                // `value` is the importer's output buffer, not aliased by `vr`.
                let Some(vrs) = (unsafe { slice(vr, nvr) }) else { return null_arg(i, $func, "valueReferences") };
                // SAFETY: as above.
                let Some(out) = (unsafe { slice_mut(value, nvr) }) else { return null_arg(i, $func, "values") };
                i.$method($func.name(), vrs, out)
            };
            // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
            unsafe { entry::<M>(c, $func, body) }
        }
    };
}

getter!(
    /// `fmi3GetFloat64`.
    fmi3_get_float64, Func::GetFloat64, f64, get_real);
getter!(
    /// `fmi3GetInt32`.
    fmi3_get_int32, Func::GetInt32, i32, get_integer);
getter!(
    /// `fmi3GetBoolean` (written as 1 or 0).
    fmi3_get_boolean, Func::GetBoolean, Fmi3Boolean, get_boolean);
getter!(
    /// `fmi3GetString`: the returned pointers stay valid until the next `fmi3GetString`
    /// or `fmi3FreeInstance` on this instance.
    fmi3_get_string, Func::GetString, Fmi3String, get_string);

macro_rules! setter {
    ($(#[$doc:meta])* $name:ident, $func:expr, $t:ty, |$i:ident, $vrs:ident, $vals:ident| $set:expr) => {
        $(#[$doc])*
        ///
        /// # Safety
        /// See the module documentation.
        pub unsafe fn $name<M: FmuModel>(
            c: Fmi3Instance,
            vr: *const Fmi3ValueReference,
            nvr: usize,
            value: *const $t,
            n_values: usize,
        ) -> Fmi3Status {
            let body = |$i: &mut Instance<M>| {
                if let Err(s) = check_n_values($i, $func, nvr, n_values) {
                    return s;
                }
                // SAFETY: `vr` and `value` are arrays of `nvr` elements (caller's contract).
                let Some($vrs) = (unsafe { slice(vr, nvr) }) else { return null_arg($i, $func, "valueReferences") };
                // SAFETY: as above.
                let Some($vals) = (unsafe { slice(value, nvr) }) else { return null_arg($i, $func, "values") };
                $set
            };
            // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
            unsafe { entry::<M>(c, $func, body) }
        }
    };
}

setter!(
    /// `fmi3SetFloat64`: NaN and infinities are refused with `fmi3Error` naming the variable.
    fmi3_set_float64, Func::SetFloat64, f64,
    |i, vrs, vals| i.set_real(Func::SetFloat64.name(), vrs, vals));
setter!(
    /// `fmi3SetInt32`.
    fmi3_set_int32, Func::SetInt32, i32,
    |i, vrs, vals| i.set_integer(Func::SetInt32.name(), vrs, vals));
setter!(
/// `fmi3SetBoolean` (any non-zero byte is true).
fmi3_set_boolean, Func::SetBoolean, Fmi3Boolean,
|i, vrs, vals| {
    let b: Vec<bool> = vals.iter().map(|&x| x != 0).collect();
    i.set_boolean(Func::SetBoolean.name(), vrs, &b)
});
setter!(
/// `fmi3SetString` (each non-NULL string must be NUL-terminated).
fmi3_set_string, Func::SetString, Fmi3String,
|i, vrs, vals| {
    let strs: Vec<Option<&str>> = vals
        .iter()
        // SAFETY: each value is NULL or a NUL-terminated string (caller's contract).
        .map(|&p| unsafe { opt_str(p) }.and_then(|s| s.to_str().ok()))
        .collect();
    i.set_string(Func::SetString.name(), vrs, &strs)
});

/// A getter or setter of a type no variable of this shell has: an empty call is fine,
/// anything else names what the value reference really is.
///
/// # Safety
/// `vr` is NULL or an array of `nvr` value references.
unsafe fn no_such_type<M: FmuModel>(
    i: &mut Instance<M>,
    f: Func,
    type_label: &str,
    vr: *const Fmi3ValueReference,
    nvr: usize,
) -> Status {
    // SAFETY: the caller's contract.
    let Some(vrs) = (unsafe { slice(vr, nvr) }) else {
        return null_arg(i, f, "valueReferences");
    };
    let Some(&first) = vrs.first() else {
        return Status::Ok;
    };
    let msg = match i.table.get(first) {
        Some(v) => format!(
            "value reference {first} is variable \"{}\" of type {}, not {type_label}",
            v.name,
            type_name(v.ty)
        ),
        None => format!("unknown value reference {first} (no {type_label} variable has it)"),
    };
    i.fail(f.name(), Status::Error, msg)
}

macro_rules! other_type {
    ($(#[$doc:meta])* $name:ident, $func:expr, $label:literal, $t:ty) => {
        $(#[$doc])*
        ///
        /// # Safety
        /// See the module documentation.
        pub unsafe fn $name<M: FmuModel>(
            c: Fmi3Instance,
            vr: *const Fmi3ValueReference,
            nvr: usize,
            _values: $t,
            n_values: usize,
        ) -> Fmi3Status {
            let body = |i: &mut Instance<M>| {
                if let Err(s) = check_n_values(i, $func, nvr, n_values) {
                    return s;
                }
                // SAFETY: `vr` is NULL or `nvr` references (caller's contract).
                unsafe { no_such_type(i, $func, $label, vr, nvr) }
            };
            // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
            unsafe { entry::<M>(c, $func, body) }
        }
    };
}

other_type!(/// `fmi3GetFloat32` (no such variables).
    fmi3_get_float32, Func::GetFloat32, "Float32", *mut f32);
other_type!(/// `fmi3GetInt8` (no such variables).
    fmi3_get_int8, Func::GetInt8, "Int8", *mut i8);
other_type!(/// `fmi3GetUInt8` (no such variables).
    fmi3_get_uint8, Func::GetUInt8, "UInt8", *mut u8);
other_type!(/// `fmi3GetInt16` (no such variables).
    fmi3_get_int16, Func::GetInt16, "Int16", *mut i16);
other_type!(/// `fmi3GetUInt16` (no such variables).
    fmi3_get_uint16, Func::GetUInt16, "UInt16", *mut u16);
other_type!(/// `fmi3GetUInt32` (no such variables).
    fmi3_get_uint32, Func::GetUInt32, "UInt32", *mut u32);
other_type!(/// `fmi3GetInt64` (no such variables).
    fmi3_get_int64, Func::GetInt64, "Int64", *mut i64);
other_type!(/// `fmi3GetUInt64` (no such variables).
    fmi3_get_uint64, Func::GetUInt64, "UInt64", *mut u64);
other_type!(/// `fmi3SetFloat32` (no such variables).
    fmi3_set_float32, Func::SetFloat32, "Float32", *const f32);
other_type!(/// `fmi3SetInt8` (no such variables).
    fmi3_set_int8, Func::SetInt8, "Int8", *const i8);
other_type!(/// `fmi3SetUInt8` (no such variables).
    fmi3_set_uint8, Func::SetUInt8, "UInt8", *const u8);
other_type!(/// `fmi3SetInt16` (no such variables).
    fmi3_set_int16, Func::SetInt16, "Int16", *const i16);
other_type!(/// `fmi3SetUInt16` (no such variables).
    fmi3_set_uint16, Func::SetUInt16, "UInt16", *const u16);
other_type!(/// `fmi3SetUInt32` (no such variables).
    fmi3_set_uint32, Func::SetUInt32, "UInt32", *const u32);
other_type!(/// `fmi3SetInt64` (no such variables).
    fmi3_set_int64, Func::SetInt64, "Int64", *const i64);
other_type!(/// `fmi3SetUInt64` (no such variables).
    fmi3_set_uint64, Func::SetUInt64, "UInt64", *const u64);

/// `fmi3GetBinary` (no such variables).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_get_binary<M: FmuModel>(
    c: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    _sizes: *mut usize,
    _values: *mut Fmi3Binary,
    n_values: usize,
) -> Fmi3Status {
    let f = Func::GetBinary;
    let body = |i: &mut Instance<M>| {
        if let Err(s) = check_n_values(i, f, nvr, n_values) {
            return s;
        }
        // SAFETY: `vr` is NULL or `nvr` references (caller's contract).
        unsafe { no_such_type(i, f, "Binary", vr, nvr) }
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}

/// `fmi3SetBinary` (no such variables).
///
/// # Safety
/// See the module documentation.
pub unsafe fn fmi3_set_binary<M: FmuModel>(
    c: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    _sizes: *const usize,
    _values: *const Fmi3Binary,
    n_values: usize,
) -> Fmi3Status {
    let f = Func::SetBinary;
    let body = |i: &mut Instance<M>| {
        if let Err(s) = check_n_values(i, f, nvr, n_values) {
            return s;
        }
        // SAFETY: `vr` is NULL or `nvr` references (caller's contract).
        unsafe { no_such_type(i, f, "Binary", vr, nvr) }
    };
    // SAFETY: `c` is NULL or an instance this library returned (caller's contract).
    unsafe { entry::<M>(c, f, body) }
}
