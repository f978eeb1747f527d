//! Turning an importer's pointers into Rust references, the same way in every shell.
//!
//! # Safety
//!
//! The FMI standards let an FMU trust that a non-NULL array argument points to as many
//! valid elements as the count beside it says, and that a non-NULL string is
//! NUL-terminated; NULL with a non-zero count is the importer's mistake and is refused
//! (`None`), never dereferenced.

use std::ffi::{c_char, CStr};

/// A slice from an importer's array: `Some(&[])` for `n == 0` whatever the pointer,
/// `None` for NULL with `n > 0`.
///
/// # Safety
/// `p` is NULL or points to `n` valid elements not mutated during the call.
pub unsafe fn slice<'a, T>(p: *const T, n: usize) -> Option<&'a [T]> {
    if n == 0 {
        Some(&[])
    } else if p.is_null() {
        None
    } else {
        // SAFETY: a non-NULL array argument points to `n` valid elements that stay alive and
        // unaliased for the duration of the call (caller's contract: FMI 2.0 section 2.1.2, FMI 3.0 section 2.2.3).
        Some(unsafe { std::slice::from_raw_parts(p, n) })
    }
}

/// As [`slice()`], for an output array the FMU writes.
///
/// # Safety
/// `p` is NULL or points to `n` writable elements not aliased during the call.
pub unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> Option<&'a mut [T]> {
    if n == 0 {
        Some(&mut [])
    } else if p.is_null() {
        None
    } else {
        // SAFETY: as in `slice`; the importer gives the FMU this output array to write.
        Some(unsafe { std::slice::from_raw_parts_mut(p, n) })
    }
}

/// A C string argument, `None` for NULL.
///
/// # Safety
/// `p` is NULL or a NUL-terminated string valid during the call.
pub unsafe fn opt_str<'a>(p: *const c_char) -> Option<&'a CStr> {
    if p.is_null() {
        None
    } else {
        // SAFETY: a non-NULL string argument is NUL-terminated and valid during the call
        // (caller's contract).
        Some(unsafe { CStr::from_ptr(p) })
    }
}
