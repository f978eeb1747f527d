//! [`crate::export_fmi2!`]: the `#[no_mangle] extern "C"` symbols of an FMI 2.0 FMU.
//!
//! Rust cannot export a generic function under a C name, so the FMU crate (a `cdylib`)
//! invokes this macro once with its model type; it emits every FMI 2.0 symbol (Co-Simulation
//! and Model Exchange) as a one-line forwarder to the generic functions in [`crate::shell`].
//! All checking and panic catching happens there, so the forwarders themselves cannot panic.
//! The FMI 3.0 macro (`magswarm_fmi3::export_fmi3!`) may be invoked in the same crate: the
//! two sets of names (`fmi2*`, `fmi3*`) do not clash, so one library serves both versions.
//!
//! Only one set of these symbols can exist in one linked artefact: if the FMU crate is
//! also used as an `rlib` by a binary that links a second FMU crate, gate the invocation,
//! e.g. `#[cfg(feature = "export")] magswarm_fmi2::export_fmi2!(Plant);`.

/// Forwarders `extern "C" fn name(args) -> ret` to `shell::target::<Model>(args)`.
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi2_forward {
    ($model:ty; $( $cname:ident ( $($arg:ident : $ty:ty),* ) $(-> $ret:ty)? = $target:ident; )*) => {
        $(
            #[doc = concat!("FMI 2.0 `", stringify!($cname), "` (see `magswarm_fmi2::shell::", stringify!($target), "`).")]
            #[no_mangle]
            #[allow(non_snake_case, clippy::missing_safety_doc)]
            pub unsafe extern "C" fn $cname($($arg: $ty),*) $(-> $ret)? {
                // SAFETY: the importer's arguments are passed on unchanged; the shell function
                // relies only on what FMI 2.0 promises about them (its `# Safety` section).
                unsafe { $crate::shell::$target::<$model>($($arg),*) }
            }
        )*
    };
}

/// Emit the FMI 2.0 C API (Co-Simulation and Model Exchange) for a type implementing
/// [`magswarm_fmi_core::FmuModel`].
///
/// ```ignore
/// magswarm_fmi2::export_fmi2!(my_crate::Plant);
/// ```
#[macro_export]
macro_rules! export_fmi2 {
    ($model:ty) => {
        $crate::magswarm_fmi_core::export_unload!(MAGSWARM_FMI2_RELEASE_AT_UNLOAD);

        /// FMI 2.0 `fmi2GetTypesPlatform`.
        #[no_mangle]
        pub extern "C" fn fmi2GetTypesPlatform() -> *const ::std::ffi::c_char {
            $crate::shell::fmi2_get_types_platform()
        }

        /// FMI 2.0 `fmi2GetVersion`.
        #[no_mangle]
        pub extern "C" fn fmi2GetVersion() -> *const ::std::ffi::c_char {
            $crate::shell::fmi2_get_version()
        }

        $crate::__fmi2_forward! { $model;
            fmi2SetDebugLogging(c: $crate::abi::Fmi2Component, on: $crate::abi::Fmi2Boolean, n: usize, cats: *const $crate::abi::Fmi2String) -> $crate::abi::Fmi2Status = fmi2_set_debug_logging;
            fmi2Instantiate(name: $crate::abi::Fmi2String, ty: ::std::ffi::c_int, guid: $crate::abi::Fmi2String, resources: $crate::abi::Fmi2String, functions: *const $crate::abi::Fmi2CallbackFunctions, visible: $crate::abi::Fmi2Boolean, logging_on: $crate::abi::Fmi2Boolean) -> $crate::abi::Fmi2Component = fmi2_instantiate;
            fmi2FreeInstance(c: $crate::abi::Fmi2Component) = fmi2_free_instance;
            fmi2SetupExperiment(c: $crate::abi::Fmi2Component, tol_defined: $crate::abi::Fmi2Boolean, tol: f64, start: f64, stop_defined: $crate::abi::Fmi2Boolean, stop: f64) -> $crate::abi::Fmi2Status = fmi2_setup_experiment;
            fmi2EnterInitializationMode(c: $crate::abi::Fmi2Component) -> $crate::abi::Fmi2Status = fmi2_enter_initialization_mode;
            fmi2ExitInitializationMode(c: $crate::abi::Fmi2Component) -> $crate::abi::Fmi2Status = fmi2_exit_initialization_mode;
            fmi2Terminate(c: $crate::abi::Fmi2Component) -> $crate::abi::Fmi2Status = fmi2_terminate;
            fmi2Reset(c: $crate::abi::Fmi2Component) -> $crate::abi::Fmi2Status = fmi2_reset;
            fmi2GetReal(c: $crate::abi::Fmi2Component, vr: *const u32, n: usize, v: *mut f64) -> $crate::abi::Fmi2Status = fmi2_get_real;
            fmi2GetInteger(c: $crate::abi::Fmi2Component, vr: *const u32, n: usize, v: *mut ::std::ffi::c_int) -> $crate::abi::Fmi2Status = fmi2_get_integer;
            fmi2GetBoolean(c: $crate::abi::Fmi2Component, vr: *const u32, n: usize, v: *mut $crate::abi::Fmi2Boolean) -> $crate::abi::Fmi2Status = fmi2_get_boolean;
            fmi2GetString(c: $crate::abi::Fmi2Component, vr: *const u32, n: usize, v: *mut $crate::abi::Fmi2String) -> $crate::abi::Fmi2Status = fmi2_get_string;
            fmi2SetReal(c: $crate::abi::Fmi2Component, vr: *const u32, n: usize, v: *const f64) -> $crate::abi::Fmi2Status = fmi2_set_real;
            fmi2SetInteger(c: $crate::abi::Fmi2Component, vr: *const u32, n: usize, v: *const ::std::ffi::c_int) -> $crate::abi::Fmi2Status = fmi2_set_integer;
            fmi2SetBoolean(c: $crate::abi::Fmi2Component, vr: *const u32, n: usize, v: *const $crate::abi::Fmi2Boolean) -> $crate::abi::Fmi2Status = fmi2_set_boolean;
            fmi2SetString(c: $crate::abi::Fmi2Component, vr: *const u32, n: usize, v: *const $crate::abi::Fmi2String) -> $crate::abi::Fmi2Status = fmi2_set_string;
            fmi2GetFMUstate(c: $crate::abi::Fmi2Component, s: *mut $crate::abi::Fmi2FmuState) -> $crate::abi::Fmi2Status = fmi2_get_fmu_state;
            fmi2SetFMUstate(c: $crate::abi::Fmi2Component, s: $crate::abi::Fmi2FmuState) -> $crate::abi::Fmi2Status = fmi2_set_fmu_state;
            fmi2FreeFMUstate(c: $crate::abi::Fmi2Component, s: *mut $crate::abi::Fmi2FmuState) -> $crate::abi::Fmi2Status = fmi2_free_fmu_state;
            fmi2SerializedFMUstateSize(c: $crate::abi::Fmi2Component, s: $crate::abi::Fmi2FmuState, size: *mut usize) -> $crate::abi::Fmi2Status = fmi2_serialized_fmu_state_size;
            fmi2SerializeFMUstate(c: $crate::abi::Fmi2Component, s: $crate::abi::Fmi2FmuState, bytes: *mut $crate::abi::Fmi2Byte, size: usize) -> $crate::abi::Fmi2Status = fmi2_serialize_fmu_state;
            fmi2DeSerializeFMUstate(c: $crate::abi::Fmi2Component, bytes: *const $crate::abi::Fmi2Byte, size: usize, s: *mut $crate::abi::Fmi2FmuState) -> $crate::abi::Fmi2Status = fmi2_deserialize_fmu_state;
            fmi2GetDirectionalDerivative(c: $crate::abi::Fmi2Component, unknowns: *const u32, n_unknown: usize, knowns: *const u32, n_known: usize, dv_known: *const f64, dv_unknown: *mut f64) -> $crate::abi::Fmi2Status = fmi2_get_directional_derivative;
            fmi2SetRealInputDerivatives(c: $crate::abi::Fmi2Component, vr: *const u32, n: usize, order: *const ::std::ffi::c_int, v: *const f64) -> $crate::abi::Fmi2Status = fmi2_set_real_input_derivatives;
            fmi2GetRealOutputDerivatives(c: $crate::abi::Fmi2Component, vr: *const u32, n: usize, order: *const ::std::ffi::c_int, v: *mut f64) -> $crate::abi::Fmi2Status = fmi2_get_real_output_derivatives;
            fmi2DoStep(c: $crate::abi::Fmi2Component, t: f64, h: f64, no_prior: $crate::abi::Fmi2Boolean) -> $crate::abi::Fmi2Status = fmi2_do_step;
            fmi2CancelStep(c: $crate::abi::Fmi2Component) -> $crate::abi::Fmi2Status = fmi2_cancel_step;
            fmi2GetStatus(c: $crate::abi::Fmi2Component, kind: ::std::ffi::c_int, v: *mut ::std::ffi::c_int) -> $crate::abi::Fmi2Status = fmi2_get_status;
            fmi2GetRealStatus(c: $crate::abi::Fmi2Component, kind: ::std::ffi::c_int, v: *mut f64) -> $crate::abi::Fmi2Status = fmi2_get_real_status;
            fmi2GetIntegerStatus(c: $crate::abi::Fmi2Component, kind: ::std::ffi::c_int, v: *mut ::std::ffi::c_int) -> $crate::abi::Fmi2Status = fmi2_get_integer_status;
            fmi2GetBooleanStatus(c: $crate::abi::Fmi2Component, kind: ::std::ffi::c_int, v: *mut $crate::abi::Fmi2Boolean) -> $crate::abi::Fmi2Status = fmi2_get_boolean_status;
            fmi2GetStringStatus(c: $crate::abi::Fmi2Component, kind: ::std::ffi::c_int, v: *mut $crate::abi::Fmi2String) -> $crate::abi::Fmi2Status = fmi2_get_string_status;
            fmi2SetTime(c: $crate::abi::Fmi2Component, t: f64) -> $crate::abi::Fmi2Status = fmi2_set_time;
            fmi2SetContinuousStates(c: $crate::abi::Fmi2Component, x: *const f64, nx: usize) -> $crate::abi::Fmi2Status = fmi2_set_continuous_states;
            fmi2EnterEventMode(c: $crate::abi::Fmi2Component) -> $crate::abi::Fmi2Status = fmi2_enter_event_mode;
            fmi2NewDiscreteStates(c: $crate::abi::Fmi2Component, info: *mut $crate::abi::Fmi2EventInfo) -> $crate::abi::Fmi2Status = fmi2_new_discrete_states;
            fmi2EnterContinuousTimeMode(c: $crate::abi::Fmi2Component) -> $crate::abi::Fmi2Status = fmi2_enter_continuous_time_mode;
            fmi2CompletedIntegratorStep(c: $crate::abi::Fmi2Component, no_prior: $crate::abi::Fmi2Boolean, enter_event_mode: *mut $crate::abi::Fmi2Boolean, terminate: *mut $crate::abi::Fmi2Boolean) -> $crate::abi::Fmi2Status = fmi2_completed_integrator_step;
            fmi2GetDerivatives(c: $crate::abi::Fmi2Component, dx: *mut f64, nx: usize) -> $crate::abi::Fmi2Status = fmi2_get_derivatives;
            fmi2GetEventIndicators(c: $crate::abi::Fmi2Component, z: *mut f64, ni: usize) -> $crate::abi::Fmi2Status = fmi2_get_event_indicators;
            fmi2GetContinuousStates(c: $crate::abi::Fmi2Component, x: *mut f64, nx: usize) -> $crate::abi::Fmi2Status = fmi2_get_continuous_states;
            fmi2GetNominalsOfContinuousStates(c: $crate::abi::Fmi2Component, x: *mut f64, nx: usize) -> $crate::abi::Fmi2Status = fmi2_get_nominals_of_continuous_states;
        }
    };
}
