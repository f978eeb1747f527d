//! [`FmuSlave`]: one Co-Simulation instance of an FMI 2.0 or 3.0 FMU behind a safe API.
//!
//! # Why not the `fmi` crate's instances
//!
//! `fmi` 0.8's `Instance` types call `fmi2Instantiate` / `fmi3InstantiateCoSimulation` with
//! fixed callbacks whose logger forwards every message to the global `log` crate with no
//! instance environment, so an importer cannot capture an instance's messages (and cannot
//! put them into its errors); its FMI 2.0 states are indices freed only when the instance is
//! dropped. `FmuSlave` therefore calls the FMU through the same crate's raw bindings
//! (`Fmi2Binding`, `Fmi3Binding`: the function tables that crate loads from the shared
//! library with `libloading`), with its own callbacks ([`log`]). Every symbol is checked
//! when the FMU is loaded ([`crate::Fmu::load`]), so no call can hit a missing one; the
//! per-version calls are in [`call`].
//!
//! FMI 3.0 has no `SetupExperiment`: [`FmuSlave::setup_experiment`] keeps the experiment and
//! [`FmuSlave::enter_initialization_mode`] passes it to `fmi3EnterInitializationMode`. Its
//! `fmi3DoStep` reports the last successful time, which [`FmuSlave::last_successful_time`]
//! returns.

use std::ffi::{c_char, CString};
use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};

mod call;
mod log;

pub use crate::import::Api;
pub use call::Scalar;
use call::{Call, Experiment, Ptr};
pub use log::LogMessage;
use log::{join_messages, lossy, Callbacks, Instantiation, LogBuffer};

use crate::error::{CosimError, Result, Status};
use crate::import::{Fmu, VarType};
use crate::FmiVersion;

/// How to instantiate.
#[derive(Debug, Clone, Default)]
pub struct SlaveOptions {
    /// `loggingOn` at instantiation: debug messages of all categories. Messages with status
    /// Warning or worse are logged (and captured) regardless.
    pub logging_on: bool,
    /// `visible` at instantiation.
    pub visible: bool,
    /// If not empty, `SetDebugLogging(true, categories)` right after instantiation.
    pub debug_categories: Vec<String>,
    /// Also forward every message to the `log` crate (target `fmu`) as it arrives.
    pub echo: bool,
    /// Pass this GUID / instantiation token instead of the one in modelDescription.xml (to
    /// test an FMU's check).
    pub guid_override: Option<String>,
    /// Pass this resource location instead of the unpacked FMU's resources folder (to test
    /// an FMU's check).
    pub resource_uri_override: Option<String>,
}

static NEXT_ID: AtomicU64 = AtomicU64::new(1);

/// An FMU state owned by the [`FmuSlave`] that made it. Free it with
/// [`FmuSlave::free_state`]; states still alive are freed when their slave is dropped.
#[derive(Debug)]
pub struct FmuState {
    ptr: Ptr,
    owner: u64,
}

/// One Co-Simulation instance of an imported [`Fmu`].
///
/// Every method calls the FMI function of the same name (in the FMU's version). Calls return
/// `Ok(status)` for OK and Warning (the FMU logged the warning: see [`FmuSlave::log`]) and
/// [`CosimError::Fmi`] for anything worse, with the messages the FMU logged during the call.
/// Dropping the slave frees its FMU states and the instance.
pub struct FmuSlave {
    fmu: Fmu,
    component: Ptr,
    name: String,
    id: u64,
    states: Vec<Ptr>,
    experiment: Experiment,
    last_successful_time: f64,
    // Must outlive `component` (the FMU may keep pointers to both): dropped after Drop::drop.
    _callbacks: Callbacks,
    log: Box<LogBuffer>,
}

impl fmt::Debug for FmuSlave {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("FmuSlave")
            .field("name", &self.name)
            .field("component", &self.component)
            .field("fmu", &self.fmu.model_identifier())
            .field("version", &self.fmu.fmi_version())
            .finish()
    }
}

fn cstring(s: &str, what: &str) -> Result<CString> {
    CString::new(s).map_err(|_| CosimError::Usage(format!("{what} contains a NUL byte")))
}

impl FmuSlave {
    /// Instantiate for Co-Simulation with a logger that captures the messages.
    pub fn instantiate(fmu: &Fmu, instance_name: &str, options: SlaveOptions) -> Result<FmuSlave> {
        let name = cstring(instance_name, "instance name")?;
        let token = match &options.guid_override {
            Some(g) => cstring(g, "GUID")?,
            None => fmu.inner.guid.clone(),
        };
        let resources = match &options.resource_uri_override {
            Some(r) => cstring(r, "resource location")?,
            None => fmu.inner.resource_uri.clone(),
        };
        let log = Box::new(LogBuffer::new(instance_name, options.echo));
        let how = Instantiation {
            name: &name,
            token: &token,
            resources: &resources,
            visible: options.visible,
            logging_on: options.logging_on,
        };
        let (component, callbacks) = fmu.inner.api.instantiate_cs(&how, &log);
        if component.is_null() {
            return Err(CosimError::Instantiate {
                function: match fmu.fmi_version() {
                    FmiVersion::V2 => "fmi2Instantiate",
                    FmiVersion::V3 => "fmi3InstantiateCoSimulation",
                },
                instance: instance_name.to_string(),
                message: join_messages(&log.all()),
            });
        }
        let mut slave = FmuSlave {
            fmu: fmu.clone(),
            component,
            name: instance_name.to_string(),
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
            states: Vec::new(),
            experiment: Experiment::default(),
            last_successful_time: 0.0,
            _callbacks: callbacks,
            log,
        };
        if !options.debug_categories.is_empty() {
            let cats: Vec<&str> = options
                .debug_categories
                .iter()
                .map(String::as_str)
                .collect();
            slave.set_debug_logging(true, &cats)?;
        }
        Ok(slave)
    }

    /// The function table this instance calls (for benchmarks that call the C ABI directly
    /// with [`FmuSlave::component`]).
    #[inline]
    pub fn api(&self) -> &Api {
        &self.fmu.inner.api
    }

    /// Run one raw call and turn its status into a result with what the FMU logged. Inline
    /// (with the calls over it that a co-simulation makes every step), the error path out of
    /// line: a master loop pays for the call and a test of its status.
    #[inline]
    fn run(&self, call: impl FnOnce(&Api, Ptr) -> Call) -> Result<Status> {
        let mark = self.log.mark();
        let (function, raw) = call(self.api(), self.component);
        let status = Status::from_raw(raw as i32);
        if status.is_success() {
            Ok(status)
        } else {
            Err(self.failed(function, status, mark))
        }
    }

    /// The error of a call that did not succeed, with what the FMU logged since `mark`.
    #[cold]
    #[inline(never)]
    fn failed(&self, function: &'static str, status: Status, mark: usize) -> CosimError {
        CosimError::Fmi {
            function,
            status,
            message: join_messages(&self.log.since(mark)),
        }
    }

    fn need(&self, ok: bool, what: &str) -> Result<()> {
        if ok {
            Ok(())
        } else {
            Err(CosimError::Unsupported(format!(
                "{}: the FMU does not declare {what}",
                self.fmu.model_identifier()
            )))
        }
    }

    /// The FMU this instance belongs to.
    pub fn fmu(&self) -> &Fmu {
        &self.fmu
    }

    /// The instance name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The raw instance (`fmi2Component` / `fmi3Instance`), for benchmarks that call the C
    /// ABI directly through [`FmuSlave::api`]. Do not free it.
    pub fn component(&self) -> *mut std::ffi::c_void {
        self.component
    }

    // ------------------------------------------------------------------------- log

    /// All messages still held (see [`FmuSlave::take_log`]), oldest first.
    pub fn log(&self) -> Vec<LogMessage> {
        self.log.all()
    }

    /// Remove and return the messages held so far.
    pub fn take_log(&mut self) -> Vec<LogMessage> {
        self.log.take()
    }

    /// How many messages the FMU has logged since instantiation (including taken ones).
    pub fn log_count(&self) -> usize {
        self.log.mark()
    }

    // ------------------------------------------------------------------------- lifecycle

    /// `SetDebugLogging`.
    pub fn set_debug_logging(&mut self, logging_on: bool, categories: &[&str]) -> Result<Status> {
        let cs: Vec<CString> = categories
            .iter()
            .map(|c| cstring(c, "category"))
            .collect::<Result<_>>()?;
        let ptrs: Vec<*const c_char> = cs.iter().map(|c| c.as_ptr()).collect();
        // SAFETY: live instance and an array of `ptrs.len()` strings.
        self.run(|a, c| unsafe { a.set_debug_logging(c, logging_on, &ptrs) })
    }

    /// `fmi2SetupExperiment`; FMI 3.0 keeps the experiment for `fmi3EnterInitializationMode`.
    pub fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> Result<Status> {
        let e = Experiment {
            tolerance,
            start: start_time,
            stop: stop_time,
        };
        // SAFETY: live instance.
        let s = self.run(|a, c| unsafe { a.setup_experiment(c, e) })?;
        self.experiment = e;
        self.last_successful_time = start_time;
        Ok(s)
    }

    /// `EnterInitializationMode`.
    pub fn enter_initialization_mode(&mut self) -> Result<Status> {
        let e = self.experiment;
        // SAFETY: live instance.
        self.run(|a, c| unsafe { a.enter_initialization_mode(c, e) })
    }

    /// `ExitInitializationMode`.
    pub fn exit_initialization_mode(&mut self) -> Result<Status> {
        // SAFETY: live instance.
        self.run(|a, c| unsafe { a.exit_initialization_mode(c) })
    }

    /// Setup, enter and exit initialisation with nothing set in between; the worst status.
    pub fn initialize(&mut self, start_time: f64, stop_time: Option<f64>) -> Result<Status> {
        let a = self.setup_experiment(None, start_time, stop_time)?;
        let b = self.enter_initialization_mode()?;
        let c = self.exit_initialization_mode()?;
        Ok(a.max(b).max(c))
    }

    /// `DoStep(t, h, noSetFMUStatePriorToCurrentPoint = true)`.
    #[inline]
    pub fn do_step(&mut self, current_time: f64, step: f64) -> Result<Status> {
        self.do_step_with(current_time, step, true)
    }

    /// `DoStep` with an explicit `noSetFMUStatePriorToCurrentPoint`.
    #[inline]
    pub fn do_step_with(
        &mut self,
        current_time: f64,
        step: f64,
        no_set_state_prior: bool,
    ) -> Result<Status> {
        let mut last = self.last_successful_time;
        // SAFETY: live instance.
        let r = self
            .run(|a, c| unsafe { a.do_step(c, current_time, step, no_set_state_prior, &mut last) });
        self.last_successful_time = last;
        r
    }

    /// The last successful time: `fmi2GetRealStatus(fmi2LastSuccessfulTime)`, or what the
    /// last `fmi3DoStep` reported.
    pub fn last_successful_time(&mut self) -> Result<f64> {
        let mut t = self.last_successful_time;
        // SAFETY: live instance and out-pointer.
        self.run(|a, c| unsafe { a.last_successful_time(c, &mut t) })?;
        Ok(t)
    }

    /// `Reset`: back to the state right after instantiation.
    pub fn reset(&mut self) -> Result<Status> {
        // SAFETY: live instance.
        let s = self.run(|a, c| unsafe { a.reset(c) })?;
        self.experiment = Experiment::default();
        self.last_successful_time = 0.0;
        Ok(s)
    }

    /// `Terminate`.
    pub fn terminate(&mut self) -> Result<Status> {
        // SAFETY: live instance.
        self.run(|a, c| unsafe { a.terminate(c) })
    }

    // ------------------------------------------------------------------------- values

    #[inline]
    fn same_len(a: usize, b: usize) -> Result<()> {
        if a == b {
            Ok(())
        } else {
            Err(Self::different_lengths(a, b))
        }
    }

    #[cold]
    #[inline(never)]
    fn different_lengths(a: usize, b: usize) -> CosimError {
        CosimError::Usage(format!("{a} value references but {b} values"))
    }

    /// Set values of one type (`f64`: Real / Float64, `i32`: Integer / Int32, `bool`).
    #[inline]
    pub fn set<T: Scalar>(&mut self, vrs: &[u32], values: &[T]) -> Result<Status> {
        Self::same_len(vrs.len(), values.len())?;
        // SAFETY: live instance, arrays of the same length.
        self.run(|a, c| unsafe { T::set(a, c, vrs, values) })
    }

    /// Get values of one type into `values`.
    #[inline]
    pub fn get<T: Scalar>(&mut self, vrs: &[u32], values: &mut [T]) -> Result<Status> {
        Self::same_len(vrs.len(), values.len())?;
        // SAFETY: live instance, arrays of the same length.
        self.run(|a, c| unsafe { T::get(a, c, vrs, values) })
    }

    /// Set the variable `name` (its type checked against `T`).
    pub fn set_by_name<T: Scalar>(&mut self, name: &str, value: T) -> Result<Status> {
        let vr = self.fmu.vr_of(name, T::VAR_TYPE)?;
        self.set(&[vr], &[value])
    }

    /// Get the variable `name` (its type checked against `T`).
    pub fn get_by_name<T: Scalar>(&mut self, name: &str) -> Result<T> {
        let vr = self.fmu.vr_of(name, T::VAR_TYPE)?;
        let mut v = [T::default()];
        self.get(&[vr], &mut v)?;
        Ok(v[0])
    }

    /// Set Reals ([`FmuSlave::set`] for `f64`).
    #[inline]
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<Status> {
        self.set(vrs, values)
    }

    /// Get Reals into `values`.
    #[inline]
    pub fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> Result<Status> {
        self.get(vrs, values)
    }

    /// Set the Real variable `name`.
    pub fn set_real_by_name(&mut self, name: &str, value: f64) -> Result<Status> {
        self.set_by_name(name, value)
    }

    /// Get the Real variable `name`.
    pub fn get_real_by_name(&mut self, name: &str) -> Result<f64> {
        self.get_by_name(name)
    }

    /// Get several Real variables by name.
    pub fn get_reals_by_name(&mut self, names: &[&str]) -> Result<Vec<f64>> {
        let vrs = self.fmu.real_vrs(names)?;
        let mut v = vec![0.0; vrs.len()];
        self.get(&vrs, &mut v)?;
        Ok(v)
    }

    /// Set Integers.
    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Result<Status> {
        self.set(vrs, values)
    }

    /// Get Integers into `values`.
    pub fn get_integer(&mut self, vrs: &[u32], values: &mut [i32]) -> Result<Status> {
        self.get(vrs, values)
    }

    /// Set Booleans.
    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Result<Status> {
        self.set(vrs, values)
    }

    /// Get Booleans.
    pub fn get_boolean(&mut self, vrs: &[u32]) -> Result<Vec<bool>> {
        let mut v = vec![false; vrs.len()];
        self.get(vrs, &mut v)?;
        Ok(v)
    }

    /// Set the Boolean variable `name`.
    pub fn set_boolean_by_name(&mut self, name: &str, value: bool) -> Result<Status> {
        self.set_by_name(name, value)
    }

    /// Get the Boolean variable `name`.
    pub fn get_boolean_by_name(&mut self, name: &str) -> Result<bool> {
        self.get_by_name(name)
    }

    /// Set Strings.
    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Result<Status> {
        Self::same_len(vrs.len(), values.len())?;
        let cs: Vec<CString> = values
            .iter()
            .map(|v| cstring(v, "string value"))
            .collect::<Result<_>>()?;
        let ptrs: Vec<*const c_char> = cs.iter().map(|c| c.as_ptr()).collect();
        // SAFETY: arrays of vrs.len() elements; strings alive during the call.
        self.run(|a, c| unsafe { a.set_string(c, vrs, &ptrs) })
    }

    /// Get Strings (copied out before any other call can invalidate the FMU's buffers).
    pub fn get_string(&mut self, vrs: &[u32]) -> Result<Vec<String>> {
        let mut ptrs: Vec<*const c_char> = vec![std::ptr::null(); vrs.len()];
        // SAFETY: arrays of vrs.len() elements.
        self.run(|a, c| unsafe { a.get_string(c, vrs, &mut ptrs) })?;
        Ok(ptrs.into_iter().map(lossy).collect())
    }

    /// Set the String variable `name`.
    pub fn set_string_by_name(&mut self, name: &str, value: &str) -> Result<Status> {
        let vr = self.fmu.vr_of(name, VarType::String)?;
        self.set_string(&[vr], &[value])
    }

    /// Get the String variable `name`.
    pub fn get_string_by_name(&mut self, name: &str) -> Result<String> {
        let vr = self.fmu.vr_of(name, VarType::String)?;
        Ok(self.get_string(&[vr])?.remove(0))
    }

    // ------------------------------------------------------------------------- derivatives

    /// `GetDirectionalDerivative`: `dv_unknown = J[unknowns, knowns] * dv_known`.
    pub fn directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        dv_known: &[f64],
    ) -> Result<Vec<f64>> {
        self.need(
            self.fmu.capabilities().directional_derivative,
            "providesDirectionalDerivative",
        )?;
        Self::same_len(knowns.len(), dv_known.len())?;
        let mut out = vec![0.0; unknowns.len()];
        // SAFETY: arrays of the stated lengths.
        self.run(|a, c| unsafe {
            a.directional_derivative(c, unknowns, knowns, dv_known, &mut out)
        })?;
        Ok(out)
    }

    /// The partial derivatives `d unknowns[i] / d knowns[j]` (Real variables by name), one
    /// directional derivative per column: `result[i][j]`.
    pub fn jacobian(&mut self, unknowns: &[&str], knowns: &[&str]) -> Result<Vec<Vec<f64>>> {
        let u = self.fmu.real_vrs(unknowns)?;
        let k = self.fmu.real_vrs(knowns)?;
        let mut jac = vec![vec![0.0; k.len()]; u.len()];
        for j in 0..k.len() {
            let col = self.directional_derivative(&u, &k[j..=j], &[1.0])?;
            for (row, v) in jac.iter_mut().zip(col) {
                row[j] = v;
            }
        }
        Ok(jac)
    }

    // ------------------------------------------------------------------------- FMU state

    fn own(&self, s: &FmuState) -> Result<()> {
        if s.owner == self.id && self.states.contains(&s.ptr) {
            Ok(())
        } else {
            Err(CosimError::ForeignState)
        }
    }

    /// A state the FMU just made: kept for freeing, refused when NULL.
    fn adopt(&mut self, ptr: Ptr, function: &'static str) -> Result<FmuState> {
        if ptr.is_null() {
            return Err(CosimError::Fmi {
                function,
                status: Status::Error,
                message: "the FMU returned a NULL state".into(),
            });
        }
        self.states.push(ptr);
        Ok(FmuState {
            ptr,
            owner: self.id,
        })
    }

    /// `GetFMUState` into a new state.
    pub fn get_state(&mut self) -> Result<FmuState> {
        self.need(
            self.fmu.capabilities().get_set_state,
            "canGetAndSetFMUstate",
        )?;
        let mut ptr: Ptr = std::ptr::null_mut();
        // SAFETY: live instance; a NULL state asks the FMU for a new one.
        self.run(|a, c| unsafe { a.get_state(c, &mut ptr) })?;
        self.adopt(ptr, self.api().get_state_name())
    }

    /// `GetFMUState` into an existing state (overwrites it).
    pub fn update_state(&mut self, state: &mut FmuState) -> Result<Status> {
        self.own(state)?;
        let mut ptr = state.ptr;
        // SAFETY: live instance and a state of this instance.
        let st = self.run(|a, c| unsafe { a.get_state(c, &mut ptr) })?;
        if ptr != state.ptr {
            // The FMU may reallocate; keep the bookkeeping right.
            if let Some(p) = self.states.iter_mut().find(|p| **p == state.ptr) {
                *p = ptr;
            }
            state.ptr = ptr;
        }
        Ok(st)
    }

    /// `SetFMUState`.
    pub fn set_state(&mut self, state: &FmuState) -> Result<Status> {
        self.own(state)?;
        // SAFETY: live instance and a live state of this instance.
        self.run(|a, c| unsafe { a.set_state(c, state.ptr) })
    }

    /// `FreeFMUState`.
    pub fn free_state(&mut self, state: FmuState) -> Result<Status> {
        self.own(&state)?;
        self.states.retain(|p| *p != state.ptr);
        let mut ptr = state.ptr;
        // SAFETY: live instance and a live state of this instance, freed once.
        self.run(|a, c| unsafe { a.free_state(c, &mut ptr) })
    }

    /// `SerializedFMUStateSize` + `SerializeFMUState`.
    pub fn serialize_state(&mut self, state: &FmuState) -> Result<Vec<u8>> {
        self.need(
            self.fmu.capabilities().serialize_state,
            "canSerializeFMUstate",
        )?;
        self.own(state)?;
        let mut size = 0usize;
        // SAFETY: live instance, live state, out-pointer.
        self.run(|a, c| unsafe { a.serialized_size(c, state.ptr, &mut size) })?;
        let mut buf = vec![0u8; size];
        // SAFETY: buffer of `size` bytes.
        self.run(|a, c| unsafe { a.serialize(c, state.ptr, &mut buf) })?;
        Ok(buf)
    }

    /// `DeserializeFMUState` into a new state of this instance (the bytes may come from
    /// another instance of the same FMU).
    pub fn deserialize_state(&mut self, bytes: &[u8]) -> Result<FmuState> {
        self.need(
            self.fmu.capabilities().serialize_state,
            "canSerializeFMUstate",
        )?;
        let mut ptr: Ptr = std::ptr::null_mut();
        // SAFETY: buffer of bytes.len() bytes, out-pointer.
        self.run(|a, c| unsafe { a.deserialize(c, bytes, &mut ptr) })?;
        self.adopt(ptr, self.api().deserialize_name())
    }
}

impl Drop for FmuSlave {
    fn drop(&mut self) {
        let api = &self.fmu.inner.api;
        for mut p in std::mem::take(&mut self.states) {
            // SAFETY: live states of this instance, each freed once.
            unsafe {
                api.free_state(self.component, &mut p);
            }
        }
        // SAFETY: the instance is freed exactly once; the callbacks and the log buffer are
        // dropped after this (struct fields drop after Drop::drop).
        unsafe { api.free_instance(self.component) };
    }
}

impl Fmu {
    /// Instantiate a Co-Simulation slave (shorthand for [`FmuSlave::instantiate`]).
    pub fn instantiate(&self, instance_name: &str, options: SlaveOptions) -> Result<FmuSlave> {
        FmuSlave::instantiate(self, instance_name, options)
    }
}
