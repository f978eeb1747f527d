//! [`crate::export_describe!`]: the FMU library describes itself, so that packaging writes the
//! modelDescription.xml of the very binary it zips (never one from another build), in the
//! FMI version it asks for.

/// Emit `fmu_model_description` and `fmu_free_string`. `$describe` is a
/// `fn(Option<&str>, u32) -> Option<String>` mapping the JSON of the defaults to bake in
/// (None: the library's own) and the FMI major version (2 or 3) to the XML; None means
/// "invalid JSON" or "no such version".
///
/// ```ignore
/// magswarm_fmi_core::export_describe!(|json: Option<&str>, version: u32| my_xml(json?, version));
/// ```
#[macro_export]
macro_rules! export_describe {
    ($describe:expr) => {
        /// The modelDescription.xml of this library for FMI `fmi_version` (2 or 3) with the
        /// defaults of the JSON `json` (null: the built-in ones); null if that JSON is
        /// invalid or the version unknown. Free the result with `fmu_free_string`.
        ///
        /// # Safety
        /// `json` must be null or a valid NUL-terminated string.
        #[no_mangle]
        pub unsafe extern "C" fn fmu_model_description(
            json: *const ::std::ffi::c_char,
            fmi_version: ::std::ffi::c_uint,
        ) -> *mut ::std::ffi::c_char {
            // SAFETY: the arguments are passed on unchanged, so the function's contract is
            // this symbol's, stated above.
            unsafe { $crate::describe::describe_ffi(json, fmi_version, $describe) }
        }

        /// Free a string returned by `fmu_model_description`.
        ///
        /// # Safety
        /// `s` must come from `fmu_model_description` and not be freed twice.
        #[no_mangle]
        pub unsafe extern "C" fn fmu_free_string(s: *mut ::std::ffi::c_char) {
            // SAFETY: the arguments are passed on unchanged, so the function's contract is
            // this symbol's, stated above.
            unsafe { $crate::describe::free_string_ffi(s) }
        }
    };
}

/// The body of `fmu_model_description` (see [`crate::export_describe!`]): no panic crosses.
///
/// # Safety
/// `json` must be null or a valid NUL-terminated string.
pub unsafe fn describe_ffi(
    json: *const std::ffi::c_char,
    fmi_version: std::ffi::c_uint,
    describe: impl Fn(Option<&str>, u32) -> Option<String> + std::panic::RefUnwindSafe,
) -> *mut std::ffi::c_char {
    crate::barrier::barrier(|| {
        let text = if json.is_null() {
            None
        } else {
            // SAFETY: non-NULL, so a NUL-terminated string valid during the call (caller's
            // contract).
            Some(unsafe { std::ffi::CStr::from_ptr(json) }.to_str().ok()?)
        };
        std::ffi::CString::new(describe(text, fmi_version)?)
            .ok()
            .map(std::ffi::CString::into_raw)
    })
    .ok()
    .flatten()
    .unwrap_or(std::ptr::null_mut())
}

/// The body of `fmu_free_string`.
///
/// # Safety
/// `s` must be null or come from [`describe_ffi`], and not be freed twice.
pub unsafe fn free_string_ffi(s: *mut std::ffi::c_char) {
    if !s.is_null() {
        // SAFETY: `s` came from `CString::into_raw` in `describe_ffi` and is freed once
        // (caller's contract).
        drop(unsafe { std::ffi::CString::from_raw(s) });
    }
}

/// Emit the `.fini_array` entry that frees the model's one-time tables
/// ([`crate::unload::leak`]) when the loader unloads the FMU library (`dlclose`), so nothing
/// they allocated outlives it. The shells' export macros invoke it; invoking it twice in one
/// library is harmless (the second run finds nothing left to free).
#[macro_export]
macro_rules! export_unload {
    ($name:ident) => {
        /// Frees the model's one-time tables when the loader unloads this library.
        #[cfg(target_os = "linux")]
        #[used]
        #[link_section = ".fini_array"]
        static $name: extern "C" fn() = {
            extern "C" fn release() {
                // SAFETY: runs when the library is unloaded or the process exits; no function
                // of this library runs after that.
                unsafe { $crate::unload::release_all() }
            }
            release
        };
    };
}
