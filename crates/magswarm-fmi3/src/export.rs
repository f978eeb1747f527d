//! [`crate::export_fmi3!`]: the `#[no_mangle] extern "C"` symbols of an FMI 3.0 FMU.
//!
//! As in the FMI 2.0 shell, the FMU crate (a `cdylib`) invokes the macro once with its
//! model type; it emits all 75 functions of `fmi3Functions.h` as one-line forwarders to the
//! generic functions in [`crate::shell`] (fmpy binds every one of them when it loads an FMU,
//! so a missing symbol would stop the FMU from loading at all; the ones this FMU has no use
//! for answer `fmi3Error` with the reason). `magswarm_fmi2::export_fmi2!` may be invoked in
//! the same crate: the `fmi2*` and `fmi3*` names do not clash, so one library serves both
//! versions.

/// Forwarders `extern "C" fn name(args) -> ret` to `shell::target::<Model>(args)`.
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi3_forward {
    ($model:ty; $( $cname:ident ( $($arg:ident : $ty:ty),* ) $(-> $ret:ty)? = $target:ident; )*) => {
        $(
            #[doc = concat!("FMI 3.0 `", stringify!($cname), "` (see `magswarm_fmi3::shell::", stringify!($target), "`).")]
            #[no_mangle]
            #[allow(non_snake_case, clippy::missing_safety_doc, clippy::too_many_arguments)]
            pub unsafe extern "C" fn $cname($($arg: $ty),*) $(-> $ret)? {
                // SAFETY: the importer's arguments are passed on unchanged; the shell function
                // relies only on what FMI 3.0 promises about them (its `# Safety` section).
                unsafe { $crate::shell::$target::<$model>($($arg),*) }
            }
        )*
    };
}

/// Emit the FMI 3.0 C API (Co-Simulation and Model Exchange; every `fmi3*` symbol) for a
/// type implementing [`magswarm_fmi_core::FmuModel`].
///
/// ```ignore
/// magswarm_fmi3::export_fmi3!(my_crate::Plant);
/// ```
#[macro_export]
macro_rules! export_fmi3 {
    ($model:ty) => {
        $crate::magswarm_fmi_core::export_unload!(MAGSWARM_FMI3_RELEASE_AT_UNLOAD);

        /// FMI 3.0 `fmi3GetVersion`.
        #[no_mangle]
        pub extern "C" fn fmi3GetVersion() -> *const ::std::ffi::c_char {
            $crate::shell::fmi3_get_version()
        }

        $crate::__fmi3_forward! { $model;
            fmi3SetDebugLogging(c: $crate::abi::Fmi3Instance, on: $crate::abi::Fmi3Boolean, n: usize, cats: *const $crate::abi::Fmi3String) -> $crate::abi::Fmi3Status = fmi3_set_debug_logging;
            fmi3InstantiateModelExchange(name: $crate::abi::Fmi3String, token: $crate::abi::Fmi3String, resources: $crate::abi::Fmi3String, visible: $crate::abi::Fmi3Boolean, logging_on: $crate::abi::Fmi3Boolean, env: *mut ::std::ffi::c_void, log: Option<$crate::abi::Fmi3LogMessageCallback>) -> $crate::abi::Fmi3Instance = fmi3_instantiate_model_exchange;
            fmi3InstantiateCoSimulation(name: $crate::abi::Fmi3String, token: $crate::abi::Fmi3String, resources: $crate::abi::Fmi3String, visible: $crate::abi::Fmi3Boolean, logging_on: $crate::abi::Fmi3Boolean, event_mode_used: $crate::abi::Fmi3Boolean, early_return_allowed: $crate::abi::Fmi3Boolean, required: *const u32, n_required: usize, env: *mut ::std::ffi::c_void, log: Option<$crate::abi::Fmi3LogMessageCallback>, intermediate: Option<$crate::abi::Fmi3IntermediateUpdateCallback>) -> $crate::abi::Fmi3Instance = fmi3_instantiate_co_simulation;
            fmi3InstantiateScheduledExecution(name: $crate::abi::Fmi3String, token: $crate::abi::Fmi3String, resources: $crate::abi::Fmi3String, visible: $crate::abi::Fmi3Boolean, logging_on: $crate::abi::Fmi3Boolean, env: *mut ::std::ffi::c_void, log: Option<$crate::abi::Fmi3LogMessageCallback>, clock_update: Option<$crate::abi::Fmi3ClockUpdateCallback>, lock: Option<$crate::abi::Fmi3LockPreemptionCallback>, unlock: Option<$crate::abi::Fmi3UnlockPreemptionCallback>) -> $crate::abi::Fmi3Instance = fmi3_instantiate_scheduled_execution;
            fmi3FreeInstance(c: $crate::abi::Fmi3Instance) = fmi3_free_instance;
            fmi3EnterInitializationMode(c: $crate::abi::Fmi3Instance, tol_defined: $crate::abi::Fmi3Boolean, tol: f64, start: f64, stop_defined: $crate::abi::Fmi3Boolean, stop: f64) -> $crate::abi::Fmi3Status = fmi3_enter_initialization_mode;
            fmi3ExitInitializationMode(c: $crate::abi::Fmi3Instance) -> $crate::abi::Fmi3Status = fmi3_exit_initialization_mode;
            fmi3EnterEventMode(c: $crate::abi::Fmi3Instance) -> $crate::abi::Fmi3Status = fmi3_enter_event_mode;
            fmi3Terminate(c: $crate::abi::Fmi3Instance) -> $crate::abi::Fmi3Status = fmi3_terminate;
            fmi3Reset(c: $crate::abi::Fmi3Instance) -> $crate::abi::Fmi3Status = fmi3_reset;
            fmi3GetFloat32(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *mut f32, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_float32;
            fmi3GetFloat64(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *mut f64, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_float64;
            fmi3GetInt8(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *mut i8, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_int8;
            fmi3GetUInt8(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *mut u8, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_uint8;
            fmi3GetInt16(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *mut i16, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_int16;
            fmi3GetUInt16(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *mut u16, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_uint16;
            fmi3GetInt32(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *mut i32, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_int32;
            fmi3GetUInt32(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *mut u32, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_uint32;
            fmi3GetInt64(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *mut i64, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_int64;
            fmi3GetUInt64(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *mut u64, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_uint64;
            fmi3GetBoolean(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *mut $crate::abi::Fmi3Boolean, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_boolean;
            fmi3GetString(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *mut $crate::abi::Fmi3String, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_string;
            fmi3GetBinary(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, sizes: *mut usize, v: *mut $crate::abi::Fmi3Binary, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_binary;
            fmi3GetClock(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *mut $crate::abi::Fmi3Clock) -> $crate::abi::Fmi3Status = fmi3_get_clock;
            fmi3SetFloat32(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *const f32, n: usize) -> $crate::abi::Fmi3Status = fmi3_set_float32;
            fmi3SetFloat64(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *const f64, n: usize) -> $crate::abi::Fmi3Status = fmi3_set_float64;
            fmi3SetInt8(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *const i8, n: usize) -> $crate::abi::Fmi3Status = fmi3_set_int8;
            fmi3SetUInt8(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *const u8, n: usize) -> $crate::abi::Fmi3Status = fmi3_set_uint8;
            fmi3SetInt16(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *const i16, n: usize) -> $crate::abi::Fmi3Status = fmi3_set_int16;
            fmi3SetUInt16(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *const u16, n: usize) -> $crate::abi::Fmi3Status = fmi3_set_uint16;
            fmi3SetInt32(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *const i32, n: usize) -> $crate::abi::Fmi3Status = fmi3_set_int32;
            fmi3SetUInt32(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *const u32, n: usize) -> $crate::abi::Fmi3Status = fmi3_set_uint32;
            fmi3SetInt64(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *const i64, n: usize) -> $crate::abi::Fmi3Status = fmi3_set_int64;
            fmi3SetUInt64(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *const u64, n: usize) -> $crate::abi::Fmi3Status = fmi3_set_uint64;
            fmi3SetBoolean(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *const $crate::abi::Fmi3Boolean, n: usize) -> $crate::abi::Fmi3Status = fmi3_set_boolean;
            fmi3SetString(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *const $crate::abi::Fmi3String, n: usize) -> $crate::abi::Fmi3Status = fmi3_set_string;
            fmi3SetBinary(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, sizes: *const usize, v: *const $crate::abi::Fmi3Binary, n: usize) -> $crate::abi::Fmi3Status = fmi3_set_binary;
            fmi3SetClock(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, v: *const $crate::abi::Fmi3Clock) -> $crate::abi::Fmi3Status = fmi3_set_clock;
            fmi3GetNumberOfVariableDependencies(c: $crate::abi::Fmi3Instance, vr: u32, n: *mut usize) -> $crate::abi::Fmi3Status = fmi3_get_number_of_variable_dependencies;
            fmi3GetVariableDependencies(c: $crate::abi::Fmi3Instance, dependent: u32, ed: *mut usize, ind: *mut u32, ei: *mut usize, kinds: *mut ::std::ffi::c_int, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_variable_dependencies;
            fmi3GetFMUState(c: $crate::abi::Fmi3Instance, s: *mut $crate::abi::Fmi3FmuState) -> $crate::abi::Fmi3Status = fmi3_get_fmu_state;
            fmi3SetFMUState(c: $crate::abi::Fmi3Instance, s: $crate::abi::Fmi3FmuState) -> $crate::abi::Fmi3Status = fmi3_set_fmu_state;
            fmi3FreeFMUState(c: $crate::abi::Fmi3Instance, s: *mut $crate::abi::Fmi3FmuState) -> $crate::abi::Fmi3Status = fmi3_free_fmu_state;
            fmi3SerializedFMUStateSize(c: $crate::abi::Fmi3Instance, s: $crate::abi::Fmi3FmuState, size: *mut usize) -> $crate::abi::Fmi3Status = fmi3_serialized_fmu_state_size;
            fmi3SerializeFMUState(c: $crate::abi::Fmi3Instance, s: $crate::abi::Fmi3FmuState, bytes: *mut u8, size: usize) -> $crate::abi::Fmi3Status = fmi3_serialize_fmu_state;
            fmi3DeserializeFMUState(c: $crate::abi::Fmi3Instance, bytes: *const u8, size: usize, s: *mut $crate::abi::Fmi3FmuState) -> $crate::abi::Fmi3Status = fmi3_deserialize_fmu_state;
            fmi3GetDirectionalDerivative(c: $crate::abi::Fmi3Instance, unknowns: *const u32, nu: usize, knowns: *const u32, nk: usize, seed: *const f64, ns: usize, sens: *mut f64, nsens: usize) -> $crate::abi::Fmi3Status = fmi3_get_directional_derivative;
            fmi3GetAdjointDerivative(c: $crate::abi::Fmi3Instance, unknowns: *const u32, nu: usize, knowns: *const u32, nk: usize, seed: *const f64, ns: usize, sens: *mut f64, nsens: usize) -> $crate::abi::Fmi3Status = fmi3_get_adjoint_derivative;
            fmi3EnterConfigurationMode(c: $crate::abi::Fmi3Instance) -> $crate::abi::Fmi3Status = fmi3_enter_configuration_mode;
            fmi3ExitConfigurationMode(c: $crate::abi::Fmi3Instance) -> $crate::abi::Fmi3Status = fmi3_exit_configuration_mode;
            fmi3GetIntervalDecimal(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, intervals: *mut f64, qualifiers: *mut ::std::ffi::c_int) -> $crate::abi::Fmi3Status = fmi3_get_interval_decimal;
            fmi3GetIntervalFraction(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, counters: *mut u64, resolutions: *mut u64, qualifiers: *mut ::std::ffi::c_int) -> $crate::abi::Fmi3Status = fmi3_get_interval_fraction;
            fmi3GetShiftDecimal(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, shifts: *mut f64) -> $crate::abi::Fmi3Status = fmi3_get_shift_decimal;
            fmi3GetShiftFraction(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, counters: *mut u64, resolutions: *mut u64) -> $crate::abi::Fmi3Status = fmi3_get_shift_fraction;
            fmi3SetIntervalDecimal(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, intervals: *const f64) -> $crate::abi::Fmi3Status = fmi3_set_interval_decimal;
            fmi3SetIntervalFraction(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, counters: *const u64, resolutions: *const u64) -> $crate::abi::Fmi3Status = fmi3_set_interval_fraction;
            fmi3SetShiftDecimal(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, shifts: *const f64) -> $crate::abi::Fmi3Status = fmi3_set_shift_decimal;
            fmi3SetShiftFraction(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, counters: *const u64, resolutions: *const u64) -> $crate::abi::Fmi3Status = fmi3_set_shift_fraction;
            fmi3EvaluateDiscreteStates(c: $crate::abi::Fmi3Instance) -> $crate::abi::Fmi3Status = fmi3_evaluate_discrete_states;
            fmi3UpdateDiscreteStates(c: $crate::abi::Fmi3Instance, need_update: *mut $crate::abi::Fmi3Boolean, terminate: *mut $crate::abi::Fmi3Boolean, nominals_changed: *mut $crate::abi::Fmi3Boolean, values_changed: *mut $crate::abi::Fmi3Boolean, next_defined: *mut $crate::abi::Fmi3Boolean, next: *mut f64) -> $crate::abi::Fmi3Status = fmi3_update_discrete_states;
            fmi3EnterContinuousTimeMode(c: $crate::abi::Fmi3Instance) -> $crate::abi::Fmi3Status = fmi3_enter_continuous_time_mode;
            fmi3CompletedIntegratorStep(c: $crate::abi::Fmi3Instance, no_prior: $crate::abi::Fmi3Boolean, enter_event_mode: *mut $crate::abi::Fmi3Boolean, terminate: *mut $crate::abi::Fmi3Boolean) -> $crate::abi::Fmi3Status = fmi3_completed_integrator_step;
            fmi3SetTime(c: $crate::abi::Fmi3Instance, t: f64) -> $crate::abi::Fmi3Status = fmi3_set_time;
            fmi3SetContinuousStates(c: $crate::abi::Fmi3Instance, x: *const f64, nx: usize) -> $crate::abi::Fmi3Status = fmi3_set_continuous_states;
            fmi3GetContinuousStateDerivatives(c: $crate::abi::Fmi3Instance, dx: *mut f64, nx: usize) -> $crate::abi::Fmi3Status = fmi3_get_continuous_state_derivatives;
            fmi3GetEventIndicators(c: $crate::abi::Fmi3Instance, z: *mut f64, ni: usize) -> $crate::abi::Fmi3Status = fmi3_get_event_indicators;
            fmi3GetContinuousStates(c: $crate::abi::Fmi3Instance, x: *mut f64, nx: usize) -> $crate::abi::Fmi3Status = fmi3_get_continuous_states;
            fmi3GetNominalsOfContinuousStates(c: $crate::abi::Fmi3Instance, x: *mut f64, nx: usize) -> $crate::abi::Fmi3Status = fmi3_get_nominals_of_continuous_states;
            fmi3GetNumberOfEventIndicators(c: $crate::abi::Fmi3Instance, n: *mut usize) -> $crate::abi::Fmi3Status = fmi3_get_number_of_event_indicators;
            fmi3GetNumberOfContinuousStates(c: $crate::abi::Fmi3Instance, n: *mut usize) -> $crate::abi::Fmi3Status = fmi3_get_number_of_continuous_states;
            fmi3EnterStepMode(c: $crate::abi::Fmi3Instance) -> $crate::abi::Fmi3Status = fmi3_enter_step_mode;
            fmi3GetOutputDerivatives(c: $crate::abi::Fmi3Instance, vr: *const u32, nvr: usize, orders: *const i32, v: *mut f64, n: usize) -> $crate::abi::Fmi3Status = fmi3_get_output_derivatives;
            fmi3DoStep(c: $crate::abi::Fmi3Instance, t: f64, h: f64, no_prior: $crate::abi::Fmi3Boolean, event_handling_needed: *mut $crate::abi::Fmi3Boolean, terminate: *mut $crate::abi::Fmi3Boolean, early_return: *mut $crate::abi::Fmi3Boolean, last_successful_time: *mut f64) -> $crate::abi::Fmi3Status = fmi3_do_step;
            fmi3ActivateModelPartition(c: $crate::abi::Fmi3Instance, clock: u32, time: f64) -> $crate::abi::Fmi3Status = fmi3_activate_model_partition;
        }
    };
}
