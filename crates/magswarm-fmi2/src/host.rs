//! A minimal importer of an [`FmuModel`] through the shell's C entry points, in process.
//!
//! Tests, the fuzz targets and the soak run drive a model exactly as a C importer drives the
//! exported `fmi2*` symbols (the `export_fmi2!` forwarders only call these same generic
//! functions), with a logger that records every message. [`Host::check`] states the
//! invariants every call must keep: the state machine matches what the calls returned, and
//! an instance that stepped or initialised without error has finite outputs.

use magswarm_fmi_core::Refusal;
use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::marker::PhantomData;
use std::ptr::null_mut;

pub use magswarm_fmi_core::recorder::{LogEntry, Recorder};
use magswarm_fmi_core::{Causality, FmuModel, Instance, Mode, VarType};

use crate::abi::*;
use crate::shell;

/// The logger: the fixed part of the variadic C signature (the shell never passes extra
/// arguments, so this is ABI-compatible).
unsafe extern "C" fn record(
    env: *mut c_void,
    _instance: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let s = |p: *const c_char| {
        if p.is_null() {
            "<null>".to_string()
        } else {
            // SAFETY: the shell passes NUL-terminated strings that live during the call.
            unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
        }
    };
    // SAFETY: `env` is the `Recorder` this host passed as componentEnvironment, alive as
    // long as the instance.
    let rec = unsafe { &*(env as *const Recorder) };
    rec.push(status, s(category), s(message));
}

/// Callback functions that log into `rec`.
pub fn callbacks(rec: &Recorder) -> Fmi2CallbackFunctions {
    type Fixed =
        unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char);
    let logger: Fixed = record;
    Fmi2CallbackFunctions {
        // SAFETY: a C function with the logger's fixed arguments; the shell calls it without
        // variadic arguments, which the x86-64 and AArch64 C ABIs pass identically.
        logger: Some(unsafe { std::mem::transmute::<Fixed, Fmi2CallbackLogger>(logger) }),
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: rec as *const Recorder as *mut c_void,
    }
}

/// One instance of `M`, driven through the shell's entry points; freed on drop.
pub struct Host<M: FmuModel> {
    c: Fmi2Component,
    // Boxed so their addresses stay valid for the instance's lifetime.
    _cb: Box<Fmi2CallbackFunctions>,
    log: Box<Recorder>,
    _m: PhantomData<M>,
}

impl<M: FmuModel> Host<M> {
    /// `fmi2Instantiate` with the model's own GUID. `Err` holds what was logged.
    pub fn instantiate(
        name: &str,
        resource_location: Option<&[u8]>,
    ) -> Result<Self, Vec<LogEntry>> {
        Self::instantiate_as(name, resource_location, FMI2_CO_SIMULATION)
    }

    /// `fmi2Instantiate` as `fmu_type` (`FMI2_MODEL_EXCHANGE` or `FMI2_CO_SIMULATION`, or
    /// anything else, to test that it is refused).
    pub fn instantiate_as(
        name: &str,
        resource_location: Option<&[u8]>,
        fmu_type: c_int,
    ) -> Result<Self, Vec<LogEntry>> {
        let log = Box::<Recorder>::default();
        let cb = Box::new(callbacks(&log));
        let guid = CString::new(magswarm_fmi_core::guid::<M>()).unwrap_or_default();
        let name = CString::new(name.replace('\0', "")).unwrap_or_default();
        let res = resource_location.map(|r| {
            CString::new(r.iter().copied().filter(|&b| b != 0).collect::<Vec<u8>>())
                .unwrap_or_default()
        });
        // SAFETY: every pointer is NULL or a NUL-terminated string / the callbacks above.
        let c = unsafe {
            shell::fmi2_instantiate::<M>(
                name.as_ptr(),
                fmu_type,
                guid.as_ptr(),
                res.as_ref().map_or(std::ptr::null(), |r| r.as_ptr()),
                &*cb,
                FMI2_FALSE,
                FMI2_FALSE,
            )
        };
        if c.is_null() {
            return Err(log.entries());
        }
        Ok(Host {
            c,
            _cb: cb,
            log,
            _m: PhantomData,
        })
    }

    /// The `fmi2Component`.
    pub fn component(&self) -> Fmi2Component {
        self.c
    }

    /// What the instance logged.
    pub fn log(&self) -> &Recorder {
        &self.log
    }

    /// The state-machine state.
    pub fn mode(&self) -> Mode {
        // SAFETY: `c` is a live instance of `M` created by this host.
        unsafe { (*(self.c as *const Instance<M>)).mode() }
    }

    /// Setup, enter and exit initialisation at `start`; the worst status.
    pub fn init(&self, start: f64) -> Fmi2Status {
        // SAFETY: live instance.
        unsafe {
            let a = shell::fmi2_setup_experiment::<M>(self.c, 0, 0.0, start, 0, 0.0);
            if a > Fmi2Status::Warning {
                return a;
            }
            let b = shell::fmi2_enter_initialization_mode::<M>(self.c);
            if b > Fmi2Status::Warning {
                return b;
            }
            a.max(b)
                .max(shell::fmi2_exit_initialization_mode::<M>(self.c))
        }
    }

    /// `fmi2SetReal` of one variable.
    pub fn set_real(&self, vr: u32, x: f64) -> Fmi2Status {
        // SAFETY: live instance, one-element arrays.
        unsafe { shell::fmi2_set_real::<M>(self.c, &vr, 1, &x) }
    }

    /// `fmi2GetReal` of one variable.
    pub fn get_real(&self, vr: u32) -> (Fmi2Status, f64) {
        let mut x = f64::NAN;
        // SAFETY: live instance, one-element arrays.
        let s = unsafe { shell::fmi2_get_real::<M>(self.c, &vr, 1, &mut x) };
        (s, x)
    }

    /// `fmi2SetBoolean` of one variable.
    pub fn set_boolean(&self, vr: u32, b: bool) -> Fmi2Status {
        let x = b as Fmi2Boolean;
        // SAFETY: live instance, one-element arrays.
        unsafe { shell::fmi2_set_boolean::<M>(self.c, &vr, 1, &x) }
    }

    /// `fmi2SetString` of one variable.
    pub fn set_string(&self, vr: u32, s: &str) -> Fmi2Status {
        let c = CString::new(s.replace('\0', "")).unwrap_or_default();
        let p = c.as_ptr();
        // SAFETY: live instance, one-element arrays of a NUL-terminated string.
        unsafe { shell::fmi2_set_string::<M>(self.c, &vr, 1, &p) }
    }

    /// `fmi2DoStep`.
    pub fn step(&self, t: f64, h: f64) -> Fmi2Status {
        // SAFETY: live instance.
        unsafe { shell::fmi2_do_step::<M>(self.c, t, h, FMI2_TRUE) }
    }

    /// `fmi2GetRealStatus(fmi2LastSuccessfulTime)`.
    pub fn time(&self) -> f64 {
        let mut t = f64::NAN;
        // SAFETY: live instance, valid out pointer.
        unsafe { shell::fmi2_get_real_status::<M>(self.c, FMI2_LAST_SUCCESSFUL_TIME, &mut t) };
        t
    }

    /// `fmi2SetTime` (Model Exchange).
    pub fn set_time(&self, t: f64) -> Fmi2Status {
        // SAFETY: live instance.
        unsafe { shell::fmi2_set_time::<M>(self.c, t) }
    }

    /// `fmi2SetContinuousStates` (Model Exchange).
    pub fn set_states(&self, x: &[f64]) -> Fmi2Status {
        // SAFETY: live instance, `x` has `x.len()` elements.
        unsafe { shell::fmi2_set_continuous_states::<M>(self.c, x.as_ptr(), x.len()) }
    }

    /// `fmi2GetContinuousStates` into `n` values (Model Exchange).
    pub fn get_states(&self, n: usize) -> (Fmi2Status, Vec<f64>) {
        let mut x = vec![f64::NAN; n];
        // SAFETY: live instance, `x` has `n` writable elements.
        let s = unsafe { shell::fmi2_get_continuous_states::<M>(self.c, x.as_mut_ptr(), n) };
        (s, x)
    }

    /// `fmi2GetDerivatives` into `n` values (Model Exchange).
    pub fn get_derivatives(&self, n: usize) -> (Fmi2Status, Vec<f64>) {
        let mut x = vec![f64::NAN; n];
        // SAFETY: live instance, `x` has `n` writable elements.
        let s = unsafe { shell::fmi2_get_derivatives::<M>(self.c, x.as_mut_ptr(), n) };
        (s, x)
    }

    /// `fmi2GetNominalsOfContinuousStates` into `n` values (Model Exchange).
    pub fn get_nominals(&self, n: usize) -> (Fmi2Status, Vec<f64>) {
        let mut x = vec![f64::NAN; n];
        // SAFETY: live instance, `x` has `n` writable elements.
        let s = unsafe {
            shell::fmi2_get_nominals_of_continuous_states::<M>(self.c, x.as_mut_ptr(), n)
        };
        (s, x)
    }

    /// `fmi2EnterEventMode` (Model Exchange).
    pub fn enter_event_mode(&self) -> Fmi2Status {
        // SAFETY: live instance.
        unsafe { shell::fmi2_enter_event_mode::<M>(self.c) }
    }

    /// `fmi2NewDiscreteStates` (Model Exchange).
    pub fn new_discrete_states(&self) -> (Fmi2Status, Fmi2EventInfo) {
        let mut e = Fmi2EventInfo {
            new_discrete_states_needed: 7,
            ..Default::default()
        };
        // SAFETY: live instance, valid out pointer.
        let s = unsafe { shell::fmi2_new_discrete_states::<M>(self.c, &mut e) };
        (s, e)
    }

    /// `fmi2EnterContinuousTimeMode` (Model Exchange).
    pub fn enter_continuous_time_mode(&self) -> Fmi2Status {
        // SAFETY: live instance.
        unsafe { shell::fmi2_enter_continuous_time_mode::<M>(self.c) }
    }

    /// `fmi2CompletedIntegratorStep` (Model Exchange): status and enterEventMode.
    pub fn completed_integrator_step(&self) -> (Fmi2Status, bool) {
        let (mut ev, mut term) = (7, 7);
        // SAFETY: live instance, valid out pointers.
        let s = unsafe {
            shell::fmi2_completed_integrator_step::<M>(self.c, FMI2_TRUE, &mut ev, &mut term)
        };
        (s, ev != 0)
    }

    /// `fmi2Terminate`.
    pub fn terminate(&self) -> Fmi2Status {
        // SAFETY: live instance.
        unsafe { shell::fmi2_terminate::<M>(self.c) }
    }

    /// `fmi2Reset`.
    pub fn reset(&self) -> Fmi2Status {
        // SAFETY: live instance.
        unsafe { shell::fmi2_reset::<M>(self.c) }
    }

    /// `fmi2GetFMUstate` into a new state.
    pub fn get_state(&self) -> (Fmi2Status, Fmi2FmuState) {
        let mut s: Fmi2FmuState = null_mut();
        // SAFETY: live instance, valid out pointer holding NULL.
        let st = unsafe { shell::fmi2_get_fmu_state::<M>(self.c, &mut s) };
        (st, s)
    }

    /// `fmi2SetFMUstate`.
    ///
    /// # Safety
    /// `s` must be NULL or a state handle obtained from an instance of this library (the
    /// shell refuses handles it did not hand out to *this* instance without reading them).
    pub unsafe fn set_state(&self, s: Fmi2FmuState) -> Fmi2Status {
        // SAFETY: as the caller promised.
        unsafe { shell::fmi2_set_fmu_state::<M>(self.c, s) }
    }

    /// `fmi2FreeFMUstate`.
    ///
    /// # Safety
    /// As [`Host::set_state`].
    pub unsafe fn free_state(&self, s: &mut Fmi2FmuState) -> Fmi2Status {
        // SAFETY: as the caller promised; `s` is a valid pointer to a handle.
        unsafe { shell::fmi2_free_fmu_state::<M>(self.c, s) }
    }

    /// `fmi2SerializedFMUstateSize` and `fmi2SerializeFMUstate`.
    ///
    /// # Safety
    /// As [`Host::set_state`].
    pub unsafe fn serialize(&self, s: Fmi2FmuState) -> Result<Vec<u8>, Fmi2Status> {
        let mut size = 0usize;
        // SAFETY: as the caller promised; valid out pointer.
        let st = unsafe { shell::fmi2_serialized_fmu_state_size::<M>(self.c, s, &mut size) };
        if st != Fmi2Status::Ok {
            return Err(st);
        }
        let mut bytes = vec![0u8; size];
        // SAFETY: a buffer of exactly `size` bytes.
        let st = unsafe {
            shell::fmi2_serialize_fmu_state::<M>(
                self.c,
                s,
                bytes.as_mut_ptr() as *mut Fmi2Byte,
                size,
            )
        };
        if st != Fmi2Status::Ok {
            return Err(st);
        }
        Ok(bytes)
    }

    /// `fmi2DeSerializeFMUstate` into a new state.
    pub fn deserialize(&self, bytes: &[u8]) -> (Fmi2Status, Fmi2FmuState) {
        let mut s: Fmi2FmuState = null_mut();
        let p = if bytes.is_empty() {
            std::ptr::null()
        } else {
            bytes.as_ptr() as *const Fmi2Byte
        };
        // SAFETY: live instance; `p` points to `bytes.len()` bytes (or is NULL for none).
        let st = unsafe { shell::fmi2_deserialize_fmu_state::<M>(self.c, p, bytes.len(), &mut s) };
        (st, s)
    }

    /// Every Real output's value (name, value), read while the state machine allows it.
    pub fn outputs(&self) -> Vec<(&'static str, Fmi2Status, f64)> {
        M::model_info()
            .variables
            .iter()
            .filter(|v| v.causality == Causality::Output && v.ty == VarType::Real)
            .map(|v| {
                let (s, x) = self.get_real(v.vr);
                (v.name, s, x)
            })
            .collect()
    }

    /// The invariants after any call that returned `status`: a Fatal status leaves the
    /// instance in Fatal, an Error one in Error (or Fatal); in a state where getters are
    /// allowed, every Real output reads OK and finite; every Error or Fatal was explained
    /// through the logger (`logged_before` = number of messages before the call).
    pub fn check(&self, status: Fmi2Status, logged_before: usize) -> Result<(), Refusal> {
        self.broken_invariant(status, logged_before)
            .map_err(Refusal)
    }

    fn broken_invariant(&self, status: Fmi2Status, logged_before: usize) -> Result<(), String> {
        let mode = self.mode();
        match status {
            Fmi2Status::Fatal if mode != Mode::Fatal => {
                return Err(format!(
                    "returned fmi2Fatal but the instance is in {mode:?}"
                ))
            }
            Fmi2Status::Error if !matches!(mode, Mode::Error | Mode::Fatal) => {
                return Err(format!(
                    "returned fmi2Error but the instance is in {mode:?}"
                ))
            }
            Fmi2Status::Pending => return Err("returned fmi2Pending".into()),
            _ => {}
        }
        if status >= Fmi2Status::Error {
            let new = self.log.entries().into_iter().skip(logged_before);
            if !new
                .into_iter()
                .any(|e| e.status >= Fmi2Status::Error as i32)
            {
                return Err(format!("returned {status:?} without logging why"));
            }
        }
        if matches!(
            mode,
            Mode::StepComplete | Mode::Terminated | Mode::EventMode | Mode::ContinuousTimeMode
        ) {
            let before = self.log.len();
            for (name, s, x) in self.outputs() {
                if s != Fmi2Status::Ok {
                    return Err(format!(
                        "fmi2GetReal(\"{name}\") returned {s:?} in {mode:?}"
                    ));
                }
                if !x.is_finite() {
                    return Err(format!("output \"{name}\" = {x} in {mode:?}"));
                }
            }
            // Reading outputs must not have changed anything the importer can see.
            if self.log.len() != before && self.mode() != mode {
                return Err("reading outputs changed the state".into());
            }
        }
        Ok(())
    }
}

impl<M: FmuModel> Drop for Host<M> {
    fn drop(&mut self) {
        // SAFETY: freed exactly once; the callbacks and recorder outlive this call.
        unsafe { shell::fmi2_free_instance::<M>(self.c) }
    }
}
