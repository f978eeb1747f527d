//! [`crate::export_fmi2!`]: the `#[no_mangle] extern "C"` symbols of an FMU.
//!
//! Rust cannot export a generic function under a C name, so the FMU crate (a `cdylib`)
//! invokes this macro once with its model type; it emits every FMI 2.0 Co-Simulation
//! symbol as a one-line forwarder to the generic functions in [`crate::shell`]. All
//! checking and panic catching happens there, so the forwarders themselves cannot panic.
//!
//! Only one set of these symbols can exist in one linked artefact: if the FMU crate is
//! also used as an `rlib` by a binary that links a second FMU crate, gate the invocation,
//! e.g. `#[cfg(feature = "export")] magswarm_fmi2::export_fmi2!(Plant);`.

/// Emit the FMI 2.0 Co-Simulation C API for a type implementing [`crate::FmuModel`].
///
/// ```ignore
/// magswarm_fmi2::export_fmi2!(my_crate::Plant);
/// ```
#[macro_export]
macro_rules! export_fmi2 {
    ($model:ty) => {
        /// Frees the model's one-time tables ([`$crate::unload::leak`]) when the loader
        /// unloads this library (`dlclose`), so nothing it allocated outlives it.
        #[cfg(target_os = "linux")]
        #[used]
        #[link_section = ".fini_array"]
        static MAGSWARM_FMI2_RELEASE_AT_UNLOAD: extern "C" fn() = {
            extern "C" fn release() {
                // SAFETY: runs when the library is unloaded or the process exits; no fmi2*
                // function of this library runs after that.
                unsafe { $crate::unload::release_all() }
            }
            release
        };

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

        /// FMI 2.0 `fmi2SetDebugLogging`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2SetDebugLogging(
            c: $crate::abi::Fmi2Component,
            loggingOn: $crate::abi::Fmi2Boolean,
            nCategories: usize,
            categories: *const $crate::abi::Fmi2String,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe {
                $crate::shell::fmi2_set_debug_logging::<$model>(
                    c,
                    loggingOn,
                    nCategories,
                    categories,
                )
            }
        }

        /// FMI 2.0 `fmi2Instantiate`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2Instantiate(
            instanceName: $crate::abi::Fmi2String,
            fmuType: ::std::ffi::c_int,
            fmuGUID: $crate::abi::Fmi2String,
            fmuResourceLocation: $crate::abi::Fmi2String,
            functions: *const $crate::abi::Fmi2CallbackFunctions,
            visible: $crate::abi::Fmi2Boolean,
            loggingOn: $crate::abi::Fmi2Boolean,
        ) -> $crate::abi::Fmi2Component {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe {
                $crate::shell::fmi2_instantiate::<$model>(
                    instanceName,
                    fmuType,
                    fmuGUID,
                    fmuResourceLocation,
                    functions,
                    visible,
                    loggingOn,
                )
            }
        }

        /// FMI 2.0 `fmi2FreeInstance`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2FreeInstance(c: $crate::abi::Fmi2Component) {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_free_instance::<$model>(c) }
        }

        /// FMI 2.0 `fmi2SetupExperiment`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2SetupExperiment(
            c: $crate::abi::Fmi2Component,
            toleranceDefined: $crate::abi::Fmi2Boolean,
            tolerance: $crate::abi::Fmi2Real,
            startTime: $crate::abi::Fmi2Real,
            stopTimeDefined: $crate::abi::Fmi2Boolean,
            stopTime: $crate::abi::Fmi2Real,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe {
                $crate::shell::fmi2_setup_experiment::<$model>(
                    c,
                    toleranceDefined,
                    tolerance,
                    startTime,
                    stopTimeDefined,
                    stopTime,
                )
            }
        }

        /// FMI 2.0 `fmi2EnterInitializationMode`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2EnterInitializationMode(
            c: $crate::abi::Fmi2Component,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_enter_initialization_mode::<$model>(c) }
        }

        /// FMI 2.0 `fmi2ExitInitializationMode`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2ExitInitializationMode(
            c: $crate::abi::Fmi2Component,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_exit_initialization_mode::<$model>(c) }
        }

        /// FMI 2.0 `fmi2Terminate`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2Terminate(
            c: $crate::abi::Fmi2Component,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_terminate::<$model>(c) }
        }

        /// FMI 2.0 `fmi2Reset`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2Reset(
            c: $crate::abi::Fmi2Component,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_reset::<$model>(c) }
        }

        /// FMI 2.0 `fmi2GetReal`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetReal(
            c: $crate::abi::Fmi2Component,
            vr: *const $crate::abi::Fmi2ValueReference,
            nvr: usize,
            value: *mut $crate::abi::Fmi2Real,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_get_real::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2GetInteger`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetInteger(
            c: $crate::abi::Fmi2Component,
            vr: *const $crate::abi::Fmi2ValueReference,
            nvr: usize,
            value: *mut $crate::abi::Fmi2Integer,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_get_integer::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2GetBoolean`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetBoolean(
            c: $crate::abi::Fmi2Component,
            vr: *const $crate::abi::Fmi2ValueReference,
            nvr: usize,
            value: *mut $crate::abi::Fmi2Boolean,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_get_boolean::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2GetString`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetString(
            c: $crate::abi::Fmi2Component,
            vr: *const $crate::abi::Fmi2ValueReference,
            nvr: usize,
            value: *mut $crate::abi::Fmi2String,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_get_string::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2SetReal`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2SetReal(
            c: $crate::abi::Fmi2Component,
            vr: *const $crate::abi::Fmi2ValueReference,
            nvr: usize,
            value: *const $crate::abi::Fmi2Real,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_set_real::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2SetInteger`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2SetInteger(
            c: $crate::abi::Fmi2Component,
            vr: *const $crate::abi::Fmi2ValueReference,
            nvr: usize,
            value: *const $crate::abi::Fmi2Integer,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_set_integer::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2SetBoolean`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2SetBoolean(
            c: $crate::abi::Fmi2Component,
            vr: *const $crate::abi::Fmi2ValueReference,
            nvr: usize,
            value: *const $crate::abi::Fmi2Boolean,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_set_boolean::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2SetString`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2SetString(
            c: $crate::abi::Fmi2Component,
            vr: *const $crate::abi::Fmi2ValueReference,
            nvr: usize,
            value: *const $crate::abi::Fmi2String,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_set_string::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2GetFMUstate`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetFMUstate(
            c: $crate::abi::Fmi2Component,
            FMUstate: *mut $crate::abi::Fmi2FmuState,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_get_fmu_state::<$model>(c, FMUstate) }
        }

        /// FMI 2.0 `fmi2SetFMUstate`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2SetFMUstate(
            c: $crate::abi::Fmi2Component,
            FMUstate: $crate::abi::Fmi2FmuState,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_set_fmu_state::<$model>(c, FMUstate) }
        }

        /// FMI 2.0 `fmi2FreeFMUstate`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2FreeFMUstate(
            c: $crate::abi::Fmi2Component,
            FMUstate: *mut $crate::abi::Fmi2FmuState,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_free_fmu_state::<$model>(c, FMUstate) }
        }

        /// FMI 2.0 `fmi2SerializedFMUstateSize`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
            c: $crate::abi::Fmi2Component,
            FMUstate: $crate::abi::Fmi2FmuState,
            size: *mut usize,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_serialized_fmu_state_size::<$model>(c, FMUstate, size) }
        }

        /// FMI 2.0 `fmi2SerializeFMUstate`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2SerializeFMUstate(
            c: $crate::abi::Fmi2Component,
            FMUstate: $crate::abi::Fmi2FmuState,
            serializedState: *mut $crate::abi::Fmi2Byte,
            size: usize,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe {
                $crate::shell::fmi2_serialize_fmu_state::<$model>(
                    c,
                    FMUstate,
                    serializedState,
                    size,
                )
            }
        }

        /// FMI 2.0 `fmi2DeSerializeFMUstate`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
            c: $crate::abi::Fmi2Component,
            serializedState: *const $crate::abi::Fmi2Byte,
            size: usize,
            FMUstate: *mut $crate::abi::Fmi2FmuState,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe {
                $crate::shell::fmi2_deserialize_fmu_state::<$model>(
                    c,
                    serializedState,
                    size,
                    FMUstate,
                )
            }
        }

        /// FMI 2.0 `fmi2GetDirectionalDerivative`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
            c: $crate::abi::Fmi2Component,
            vUnknown_ref: *const $crate::abi::Fmi2ValueReference,
            nUnknown: usize,
            vKnown_ref: *const $crate::abi::Fmi2ValueReference,
            nKnown: usize,
            dvKnown: *const $crate::abi::Fmi2Real,
            dvUnknown: *mut $crate::abi::Fmi2Real,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe {
                $crate::shell::fmi2_get_directional_derivative::<$model>(
                    c,
                    vUnknown_ref,
                    nUnknown,
                    vKnown_ref,
                    nKnown,
                    dvKnown,
                    dvUnknown,
                )
            }
        }

        /// FMI 2.0 `fmi2SetRealInputDerivatives`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
            c: $crate::abi::Fmi2Component,
            vr: *const $crate::abi::Fmi2ValueReference,
            nvr: usize,
            order: *const $crate::abi::Fmi2Integer,
            value: *const $crate::abi::Fmi2Real,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe {
                $crate::shell::fmi2_set_real_input_derivatives::<$model>(c, vr, nvr, order, value)
            }
        }

        /// FMI 2.0 `fmi2GetRealOutputDerivatives`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
            c: $crate::abi::Fmi2Component,
            vr: *const $crate::abi::Fmi2ValueReference,
            nvr: usize,
            order: *const $crate::abi::Fmi2Integer,
            value: *mut $crate::abi::Fmi2Real,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe {
                $crate::shell::fmi2_get_real_output_derivatives::<$model>(c, vr, nvr, order, value)
            }
        }

        /// FMI 2.0 `fmi2DoStep`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2DoStep(
            c: $crate::abi::Fmi2Component,
            currentCommunicationPoint: $crate::abi::Fmi2Real,
            communicationStepSize: $crate::abi::Fmi2Real,
            noSetFMUStatePriorToCurrentPoint: $crate::abi::Fmi2Boolean,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe {
                $crate::shell::fmi2_do_step::<$model>(
                    c,
                    currentCommunicationPoint,
                    communicationStepSize,
                    noSetFMUStatePriorToCurrentPoint,
                )
            }
        }

        /// FMI 2.0 `fmi2SetTime` (Model Exchange).
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2SetTime(
            c: $crate::abi::Fmi2Component,
            time: $crate::abi::Fmi2Real,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_set_time::<$model>(c, time) }
        }

        /// FMI 2.0 `fmi2SetContinuousStates` (Model Exchange).
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2SetContinuousStates(
            c: $crate::abi::Fmi2Component,
            x: *const $crate::abi::Fmi2Real,
            nx: usize,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_set_continuous_states::<$model>(c, x, nx) }
        }

        /// FMI 2.0 `fmi2EnterEventMode` (Model Exchange).
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2EnterEventMode(
            c: $crate::abi::Fmi2Component,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_enter_event_mode::<$model>(c) }
        }

        /// FMI 2.0 `fmi2NewDiscreteStates` (Model Exchange).
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2NewDiscreteStates(
            c: $crate::abi::Fmi2Component,
            eventInfo: *mut $crate::abi::Fmi2EventInfo,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_new_discrete_states::<$model>(c, eventInfo) }
        }

        /// FMI 2.0 `fmi2EnterContinuousTimeMode` (Model Exchange).
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2EnterContinuousTimeMode(
            c: $crate::abi::Fmi2Component,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_enter_continuous_time_mode::<$model>(c) }
        }

        /// FMI 2.0 `fmi2CompletedIntegratorStep` (Model Exchange).
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2CompletedIntegratorStep(
            c: $crate::abi::Fmi2Component,
            noSetFMUStatePriorToCurrentPoint: $crate::abi::Fmi2Boolean,
            enterEventMode: *mut $crate::abi::Fmi2Boolean,
            terminateSimulation: *mut $crate::abi::Fmi2Boolean,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe {
                $crate::shell::fmi2_completed_integrator_step::<$model>(
                    c,
                    noSetFMUStatePriorToCurrentPoint,
                    enterEventMode,
                    terminateSimulation,
                )
            }
        }

        /// FMI 2.0 `fmi2GetDerivatives` (Model Exchange).
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetDerivatives(
            c: $crate::abi::Fmi2Component,
            derivatives: *mut $crate::abi::Fmi2Real,
            nx: usize,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_get_derivatives::<$model>(c, derivatives, nx) }
        }

        /// FMI 2.0 `fmi2GetEventIndicators` (Model Exchange).
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetEventIndicators(
            c: $crate::abi::Fmi2Component,
            eventIndicators: *mut $crate::abi::Fmi2Real,
            ni: usize,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_get_event_indicators::<$model>(c, eventIndicators, ni) }
        }

        /// FMI 2.0 `fmi2GetContinuousStates` (Model Exchange).
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetContinuousStates(
            c: $crate::abi::Fmi2Component,
            x: *mut $crate::abi::Fmi2Real,
            nx: usize,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_get_continuous_states::<$model>(c, x, nx) }
        }

        /// FMI 2.0 `fmi2GetNominalsOfContinuousStates` (Model Exchange).
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetNominalsOfContinuousStates(
            c: $crate::abi::Fmi2Component,
            x_nominal: *mut $crate::abi::Fmi2Real,
            nx: usize,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe {
                $crate::shell::fmi2_get_nominals_of_continuous_states::<$model>(c, x_nominal, nx)
            }
        }

        /// FMI 2.0 `fmi2CancelStep`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2CancelStep(
            c: $crate::abi::Fmi2Component,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_cancel_step::<$model>(c) }
        }

        /// FMI 2.0 `fmi2GetStatus`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetStatus(
            c: $crate::abi::Fmi2Component,
            s: ::std::ffi::c_int,
            value: *mut ::std::ffi::c_int,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_get_status::<$model>(c, s, value) }
        }

        /// FMI 2.0 `fmi2GetRealStatus`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetRealStatus(
            c: $crate::abi::Fmi2Component,
            s: ::std::ffi::c_int,
            value: *mut $crate::abi::Fmi2Real,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_get_real_status::<$model>(c, s, value) }
        }

        /// FMI 2.0 `fmi2GetIntegerStatus`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetIntegerStatus(
            c: $crate::abi::Fmi2Component,
            s: ::std::ffi::c_int,
            value: *mut $crate::abi::Fmi2Integer,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_get_integer_status::<$model>(c, s, value) }
        }

        /// FMI 2.0 `fmi2GetBooleanStatus`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetBooleanStatus(
            c: $crate::abi::Fmi2Component,
            s: ::std::ffi::c_int,
            value: *mut $crate::abi::Fmi2Boolean,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_get_boolean_status::<$model>(c, s, value) }
        }

        /// FMI 2.0 `fmi2GetStringStatus`.
        #[no_mangle]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub unsafe extern "C" fn fmi2GetStringStatus(
            c: $crate::abi::Fmi2Component,
            s: ::std::ffi::c_int,
            value: *mut $crate::abi::Fmi2String,
        ) -> $crate::abi::Fmi2Status {
            // SAFETY: the importer's arguments are passed on unchanged; the shell function
            // relies only on what FMI 2.0 promises about them (its `# Safety` section).
            unsafe { $crate::shell::fmi2_get_string_status::<$model>(c, s, value) }
        }
    };
}

/// Emit `fmu_model_description` and `fmu_free_string`: the FMU library describes itself, so
/// that packaging writes the modelDescription.xml of the very binary it zips (never one from
/// another build). `$describe` is a `fn(Option<&str>) -> Option<String>` mapping the JSON of
/// the defaults to bake in (None: the library's own) to the XML; None means "invalid JSON".
///
/// ```ignore
/// magswarm_fmi2::export_describe!(|json: Option<&str>| Some(my_xml(json)?));
/// ```
#[macro_export]
macro_rules! export_describe {
    ($describe:expr) => {
        /// The modelDescription.xml of this library with the defaults of the JSON `json`
        /// (null: the built-in ones); null if that JSON is invalid. Free the result with
        /// `fmu_free_string`.
        ///
        /// # Safety
        /// `json` must be null or a valid NUL-terminated string.
        #[no_mangle]
        pub unsafe extern "C" fn fmu_model_description(
            json: *const ::std::ffi::c_char,
        ) -> *mut ::std::ffi::c_char {
            // SAFETY: the arguments are passed on unchanged, so the function's contract is
            // this symbol's, stated above.
            unsafe { $crate::export::describe_ffi(json, $describe) }
        }

        /// Free a string returned by `fmu_model_description`.
        ///
        /// # Safety
        /// `s` must come from `fmu_model_description` and not be freed twice.
        #[no_mangle]
        pub unsafe extern "C" fn fmu_free_string(s: *mut ::std::ffi::c_char) {
            // SAFETY: the arguments are passed on unchanged, so the function's contract is
            // this symbol's, stated above.
            unsafe { $crate::export::free_string_ffi(s) }
        }
    };
}

/// The body of `fmu_model_description` (see [`export_describe!`]): no panic crosses.
///
/// # Safety
/// `json` must be null or a valid NUL-terminated string.
pub unsafe fn describe_ffi(
    json: *const std::ffi::c_char,
    describe: impl Fn(Option<&str>) -> Option<String> + std::panic::RefUnwindSafe,
) -> *mut std::ffi::c_char {
    std::panic::catch_unwind(|| {
        let text = if json.is_null() {
            None
        } else {
            // SAFETY: non-NULL, so a NUL-terminated string valid during the call (caller's
            // contract).
            Some(unsafe { std::ffi::CStr::from_ptr(json) }.to_str().ok()?)
        };
        std::ffi::CString::new(describe(text)?)
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
