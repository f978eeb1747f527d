//! A minimal importer of an [`FmuModel`] through the FMI 3.0 shell's entry points, in
//! process: what the exported `fmi3*` symbols forward to, driven as a C importer drives
//! them, with a logger that records every message. [`Host::check`] states the invariants
//! every call must keep (the same as the FMI 2.0 host's).

use magswarm_fmi_core::Refusal;
use std::ffi::{c_char, c_void, CStr, CString};
use std::marker::PhantomData;
use std::ptr::null_mut;

pub use magswarm_fmi_core::recorder::{LogEntry, Recorder};
use magswarm_fmi_core::{Causality, FmuModel, Instance, Mode, Status, VarType};

use crate::abi::*;
use crate::shell;

unsafe extern "C" fn record(
    env: *mut c_void,
    status: Status,
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
    // SAFETY: `env` is the `Recorder` this host passed as instanceEnvironment, alive as long
    // as the instance.
    let rec = unsafe { &*(env as *const Recorder) };
    rec.push(status as i32, s(category), s(message));
}

/// Which interface to instantiate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `fmi3InstantiateCoSimulation`.
    CoSimulation,
    /// `fmi3InstantiateModelExchange`.
    ModelExchange,
}

/// One instance of `M`, driven through the FMI 3.0 shell's entry points; freed on drop.
pub struct Host<M: FmuModel> {
    c: Fmi3Instance,
    log: Box<Recorder>,
    _m: PhantomData<M>,
}

impl<M: FmuModel> Host<M> {
    /// Instantiate with the model's own instantiation token. `Err` holds what was logged.
    pub fn instantiate(
        name: &str,
        resource_path: Option<&str>,
        kind: Kind,
    ) -> Result<Self, Vec<LogEntry>> {
        let token = magswarm_fmi_core::guid::guid_of(shell::info_of::<M>());
        Self::instantiate_with(name, resource_path, kind, &token)
    }

    /// Instantiate with the given token (to test that a wrong one is refused).
    pub fn instantiate_with(
        name: &str,
        resource_path: Option<&str>,
        kind: Kind,
        token: &str,
    ) -> Result<Self, Vec<LogEntry>> {
        let log = Box::<Recorder>::default();
        let env = &*log as *const Recorder as *mut c_void;
        let cstr = |s: &str| CString::new(s.replace('\0', "")).unwrap_or_default();
        let (name, token) = (cstr(name), cstr(token));
        let res = resource_path.map(cstr);
        let res_p = res.as_ref().map_or(std::ptr::null(), |r| r.as_ptr());
        let cb: Fmi3LogMessageCallback = record;
        // SAFETY: every pointer is NULL or a NUL-terminated string; the callback and its
        // environment outlive the instance (both are owned by the host).
        let c = unsafe {
            match kind {
                Kind::CoSimulation => shell::fmi3_instantiate_co_simulation::<M>(
                    name.as_ptr(),
                    token.as_ptr(),
                    res_p,
                    FMI3_FALSE,
                    FMI3_FALSE,
                    FMI3_FALSE,
                    FMI3_FALSE,
                    std::ptr::null(),
                    0,
                    env,
                    Some(cb),
                    None,
                ),
                Kind::ModelExchange => shell::fmi3_instantiate_model_exchange::<M>(
                    name.as_ptr(),
                    token.as_ptr(),
                    res_p,
                    FMI3_FALSE,
                    FMI3_FALSE,
                    env,
                    Some(cb),
                ),
            }
        };
        if c.is_null() {
            return Err(log.entries());
        }
        Ok(Host {
            c,
            log,
            _m: PhantomData,
        })
    }

    /// The `fmi3Instance`.
    pub fn instance(&self) -> Fmi3Instance {
        self.c
    }

    /// What the instance logged.
    pub fn log(&self) -> &Recorder {
        &self.log
    }

    /// The mode.
    pub fn mode(&self) -> Mode {
        // SAFETY: `c` is a live instance of `M` created by this host.
        unsafe { (*(self.c as *const Instance<M>)).mode() }
    }

    /// The instance's time (communication point, or the last `fmi3SetTime`).
    pub fn time(&self) -> f64 {
        // SAFETY: `c` is a live instance of `M` created by this host.
        unsafe { (*(self.c as *const Instance<M>)).time() }
    }

    /// Enter (with start time `start`, no tolerance or stop time) and exit initialisation;
    /// the worst status.
    pub fn init(&self, start: f64) -> Status {
        // SAFETY: live instance.
        unsafe {
            let a = shell::fmi3_enter_initialization_mode::<M>(self.c, 0, 0.0, start, 0, 0.0);
            if a > Status::Warning {
                return a;
            }
            a.max(shell::fmi3_exit_initialization_mode::<M>(self.c))
        }
    }

    /// `fmi3SetFloat64` of one variable.
    pub fn set_real(&self, vr: u32, x: f64) -> Status {
        // SAFETY: live instance, one-element arrays.
        unsafe { shell::fmi3_set_float64::<M>(self.c, &vr, 1, &x, 1) }
    }

    /// `fmi3GetFloat64` of one variable.
    pub fn get_real(&self, vr: u32) -> (Status, f64) {
        let mut x = f64::NAN;
        // SAFETY: live instance, one-element arrays.
        let s = unsafe { shell::fmi3_get_float64::<M>(self.c, &vr, 1, &mut x, 1) };
        (s, x)
    }

    /// `fmi3SetBoolean` of one variable.
    pub fn set_boolean(&self, vr: u32, b: bool) -> Status {
        let x = b as Fmi3Boolean;
        // SAFETY: live instance, one-element arrays.
        unsafe { shell::fmi3_set_boolean::<M>(self.c, &vr, 1, &x, 1) }
    }

    /// `fmi3SetString` of one variable.
    pub fn set_string(&self, vr: u32, s: &str) -> Status {
        let c = CString::new(s.replace('\0', "")).unwrap_or_default();
        let p = c.as_ptr();
        // SAFETY: live instance, one-element arrays of a NUL-terminated string.
        unsafe { shell::fmi3_set_string::<M>(self.c, &vr, 1, &p, 1) }
    }

    /// `fmi3DoStep`: the status and `lastSuccessfulTime`.
    pub fn step(&self, t: f64, h: f64) -> (Status, f64) {
        let (mut ev, mut term, mut early, mut last) = (7u8, 7u8, 7u8, f64::NAN);
        // SAFETY: live instance, valid out pointers.
        let s = unsafe {
            shell::fmi3_do_step::<M>(
                self.c, t, h, FMI3_TRUE, &mut ev, &mut term, &mut early, &mut last,
            )
        };
        (s, last)
    }

    /// `fmi3SetTime`.
    pub fn set_time(&self, t: f64) -> Status {
        // SAFETY: live instance.
        unsafe { shell::fmi3_set_time::<M>(self.c, t) }
    }

    /// `fmi3SetContinuousStates`.
    pub fn set_states(&self, x: &[f64]) -> Status {
        // SAFETY: live instance, `x` has `x.len()` elements.
        unsafe { shell::fmi3_set_continuous_states::<M>(self.c, x.as_ptr(), x.len()) }
    }

    /// `fmi3GetContinuousStates` into `n` values.
    pub fn get_states(&self, n: usize) -> (Status, Vec<f64>) {
        let mut x = vec![f64::NAN; n];
        // SAFETY: live instance, `x` has `n` writable elements.
        let s = unsafe { shell::fmi3_get_continuous_states::<M>(self.c, x.as_mut_ptr(), n) };
        (s, x)
    }

    /// `fmi3GetContinuousStateDerivatives` into `n` values.
    pub fn get_derivatives(&self, n: usize) -> (Status, Vec<f64>) {
        let mut x = vec![f64::NAN; n];
        // SAFETY: live instance, `x` has `n` writable elements.
        let s =
            unsafe { shell::fmi3_get_continuous_state_derivatives::<M>(self.c, x.as_mut_ptr(), n) };
        (s, x)
    }

    /// `fmi3GetNumberOfContinuousStates`.
    pub fn n_states(&self) -> (Status, usize) {
        let mut n = usize::MAX;
        // SAFETY: live instance, valid out pointer.
        let s = unsafe { shell::fmi3_get_number_of_continuous_states::<M>(self.c, &mut n) };
        (s, n)
    }

    /// `fmi3EnterEventMode`.
    pub fn enter_event_mode(&self) -> Status {
        // SAFETY: live instance.
        unsafe { shell::fmi3_enter_event_mode::<M>(self.c) }
    }

    /// `fmi3UpdateDiscreteStates`: the status and whether any flag came back true.
    pub fn update_discrete_states(&self) -> (Status, bool) {
        let mut flags = [7u8; 5];
        let mut next = f64::NAN;
        let [a, b, c, d, e] = &mut flags;
        // SAFETY: live instance, valid out pointers.
        let s =
            unsafe { shell::fmi3_update_discrete_states::<M>(self.c, a, b, c, d, e, &mut next) };
        (s, flags.iter().any(|&f| f != 0))
    }

    /// `fmi3EnterContinuousTimeMode`.
    pub fn enter_continuous_time_mode(&self) -> Status {
        // SAFETY: live instance.
        unsafe { shell::fmi3_enter_continuous_time_mode::<M>(self.c) }
    }

    /// `fmi3CompletedIntegratorStep`: status and enterEventMode.
    pub fn completed_integrator_step(&self) -> (Status, bool) {
        let (mut ev, mut term) = (7u8, 7u8);
        // SAFETY: live instance, valid out pointers.
        let s = unsafe {
            shell::fmi3_completed_integrator_step::<M>(self.c, FMI3_TRUE, &mut ev, &mut term)
        };
        (s, ev != 0)
    }

    /// `fmi3Terminate`.
    pub fn terminate(&self) -> Status {
        // SAFETY: live instance.
        unsafe { shell::fmi3_terminate::<M>(self.c) }
    }

    /// `fmi3Reset`.
    pub fn reset(&self) -> Status {
        // SAFETY: live instance.
        unsafe { shell::fmi3_reset::<M>(self.c) }
    }

    /// `fmi3GetFMUState` into a new state.
    pub fn get_state(&self) -> (Status, Fmi3FmuState) {
        let mut s: Fmi3FmuState = null_mut();
        // SAFETY: live instance, valid out pointer holding NULL.
        let st = unsafe { shell::fmi3_get_fmu_state::<M>(self.c, &mut s) };
        (st, s)
    }

    /// `fmi3SetFMUState`.
    ///
    /// # Safety
    /// `s` must be NULL or a state handle obtained from an instance of this library (the
    /// shell refuses handles it did not hand out to *this* instance without reading them).
    pub unsafe fn set_state(&self, s: Fmi3FmuState) -> Status {
        // SAFETY: as the caller promised.
        unsafe { shell::fmi3_set_fmu_state::<M>(self.c, s) }
    }

    /// `fmi3FreeFMUState`.
    ///
    /// # Safety
    /// As [`Host::set_state`].
    pub unsafe fn free_state(&self, s: &mut Fmi3FmuState) -> Status {
        // SAFETY: as the caller promised; `s` is a valid pointer to a handle.
        unsafe { shell::fmi3_free_fmu_state::<M>(self.c, s) }
    }

    /// `fmi3SerializedFMUStateSize` and `fmi3SerializeFMUState`.
    ///
    /// # Safety
    /// As [`Host::set_state`].
    pub unsafe fn serialize(&self, s: Fmi3FmuState) -> Result<Vec<u8>, Status> {
        let mut size = 0usize;
        // SAFETY: as the caller promised; valid out pointer.
        let st = unsafe { shell::fmi3_serialized_fmu_state_size::<M>(self.c, s, &mut size) };
        if st != Status::Ok {
            return Err(st);
        }
        let mut bytes = vec![0u8; size];
        // SAFETY: a buffer of exactly `size` bytes.
        let st =
            unsafe { shell::fmi3_serialize_fmu_state::<M>(self.c, s, bytes.as_mut_ptr(), size) };
        if st != Status::Ok {
            return Err(st);
        }
        Ok(bytes)
    }

    /// `fmi3DeserializeFMUState` into a new state.
    pub fn deserialize(&self, bytes: &[u8]) -> (Status, Fmi3FmuState) {
        let mut s: Fmi3FmuState = null_mut();
        let p = if bytes.is_empty() {
            std::ptr::null()
        } else {
            bytes.as_ptr()
        };
        // SAFETY: live instance; `p` points to `bytes.len()` bytes (or is NULL for none).
        let st = unsafe { shell::fmi3_deserialize_fmu_state::<M>(self.c, p, bytes.len(), &mut s) };
        (st, s)
    }

    /// `fmi3GetDirectionalDerivative` (`adjoint = false`) or `fmi3GetAdjointDerivative`.
    pub fn derivative(
        &self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        adjoint: bool,
    ) -> (Status, Vec<f64>) {
        let n_out = if adjoint {
            knowns.len()
        } else {
            unknowns.len()
        };
        let mut out = vec![f64::NAN; n_out];
        let f = if adjoint {
            shell::fmi3_get_adjoint_derivative::<M>
        } else {
            shell::fmi3_get_directional_derivative::<M>
        };
        // SAFETY: live instance; every array has the length passed beside it.
        let s = unsafe {
            f(
                self.c,
                unknowns.as_ptr(),
                unknowns.len(),
                knowns.as_ptr(),
                knowns.len(),
                seed.as_ptr(),
                seed.len(),
                out.as_mut_ptr(),
                out.len(),
            )
        };
        (s, out)
    }

    /// Every Real output's value (name, status, value).
    pub fn outputs(&self) -> Vec<(&'static str, Status, f64)> {
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

    /// The invariants after any call that returned `status` (as the FMI 2.0 host's
    /// `check`): Fatal leaves the instance in Fatal, Error in Error (or Fatal); where getters
    /// are allowed every Real output reads OK and finite; every Error or Fatal was explained
    /// through the logger (`logged_before` = messages before the call).
    pub fn check(&self, status: Status, logged_before: usize) -> Result<(), Refusal> {
        self.broken_invariant(status, logged_before)
            .map_err(Refusal)
    }

    fn broken_invariant(&self, status: Status, logged_before: usize) -> Result<(), String> {
        let mode = self.mode();
        match status {
            Status::Fatal if mode != Mode::Fatal => {
                return Err(format!(
                    "returned fmi3Fatal but the instance is in {mode:?}"
                ))
            }
            Status::Error if !matches!(mode, Mode::Error | Mode::Fatal) => {
                return Err(format!(
                    "returned fmi3Error but the instance is in {mode:?}"
                ))
            }
            _ => {}
        }
        if status >= Status::Error {
            let new = self.log.entries().into_iter().skip(logged_before);
            if !new.into_iter().any(|e| e.status >= Status::Error as i32) {
                return Err(format!("returned {status:?} without logging why"));
            }
        }
        if matches!(
            mode,
            Mode::StepComplete | Mode::Terminated | Mode::EventMode | Mode::ContinuousTimeMode
        ) {
            for (name, s, x) in self.outputs() {
                if s != Status::Ok {
                    return Err(format!(
                        "fmi3GetFloat64(\"{name}\") returned {s:?} in {mode:?}"
                    ));
                }
                if !x.is_finite() {
                    return Err(format!("output \"{name}\" = {x} in {mode:?}"));
                }
            }
        }
        Ok(())
    }
}

impl<M: FmuModel> Drop for Host<M> {
    fn drop(&mut self) {
        // SAFETY: freed exactly once; the recorder outlives this call.
        unsafe { shell::fmi3_free_instance::<M>(self.c) }
    }
}
