//! [`FmuSlave`]: one FMI 2.0 Co-Simulation instance behind a safe API.
//!
//! # Why not the `fmi` crate's `Instance<CS>`
//!
//! `fmi` 0.8's [`fmi::fmi2::instance::Instance`] calls `fmi2Instantiate` with fixed callbacks
//! whose logger forwards every message to the global `log` crate with no
//! `componentEnvironment`, so an importer cannot capture an instance's messages (and cannot
//! put them into its errors); its FMU states are indices that are only freed when the instance
//! is dropped (no `fmi2FreeFMUstate`). `FmuSlave` therefore calls the FMU through the same
//! crate's raw bindings ([`fmi::fmi2::binding::Fmi2Binding`], the function table that crate
//! loads from the shared library with `libloading`), with its own callbacks. Every symbol is
//! checked when the FMU is loaded ([`super::Fmu::load`]), so no call can hit a missing one.
//!
//! # The logger
//!
//! The FMI 2.0 logger is a C variadic function (`printf`-style `message, ...`). Stable Rust
//! cannot define variadic functions, so the logger given to the FMU is a non-variadic
//! `extern "C"` function cast to the variadic pointer type: on the x86-64 System V and
//! AArch64 Linux ABIs (the `linux64` platform of FMI 2.0) the named arguments are passed the
//! same way in both cases, and the variadic ones are simply not read. The message is taken
//! as-is except that `%%` becomes `%` (FMUs that pass no extra arguments, such as MagSwarm,
//! escape `%` that way); FMUs that pass `printf` arguments show their raw format string.

use std::ffi::{c_char, c_void, CStr, CString};
use std::fmt;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;

use fmi::fmi2::binding::{self, Fmi2Binding};

use super::error::{CosimError, Result, Status};
use super::import::{Fmu, VarType};

/// One message the FMU passed to the logger.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogMessage {
    /// Instance name the FMU gave.
    pub instance: String,
    /// Status of the message.
    pub status: Status,
    /// Log category (e.g. `logStatusError`, `logEnvelope`).
    pub category: String,
    /// The message.
    pub message: String,
}

impl fmt::Display for LogMessage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "[{}] {} {}: {}",
            self.instance, self.status, self.category, self.message
        )
    }
}

/// How to instantiate.
#[derive(Debug, Clone, Default)]
pub struct SlaveOptions {
    /// `loggingOn` of `fmi2Instantiate`: debug messages of all categories. Messages with
    /// status Warning or worse are logged (and captured) regardless.
    pub logging_on: bool,
    /// `visible` of `fmi2Instantiate`.
    pub visible: bool,
    /// If not empty, `fmi2SetDebugLogging(true, categories)` right after instantiation.
    pub debug_categories: Vec<String>,
    /// Also print every message to stderr as it arrives.
    pub echo: bool,
    /// Pass this GUID instead of the one in modelDescription.xml (to test an FMU's check).
    pub guid_override: Option<String>,
    /// Pass this `fmuResourceLocation` instead of the unpacked FMU's resources folder (to
    /// test an FMU's check).
    pub resource_uri_override: Option<String>,
}

/// The log of one instance; `componentEnvironment` points at it.
struct LogBuffer {
    /// (number of messages removed by `take`, messages kept).
    inner: Mutex<(usize, Vec<LogMessage>)>,
    /// Messages received so far (never decreases).
    count: AtomicUsize,
    echo: bool,
}

impl LogBuffer {
    fn push(&self, m: LogMessage) {
        if self.echo {
            eprintln!("{m}");
        }
        let mut g = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        g.1.push(m);
        self.count.fetch_add(1, Ordering::Release);
    }

    fn mark(&self) -> usize {
        self.count.load(Ordering::Acquire)
    }

    /// The messages received since `mark`, still held.
    fn since(&self, mark: usize) -> Vec<LogMessage> {
        let g = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        let skip = mark.saturating_sub(g.0).min(g.1.len());
        g.1[skip..].to_vec()
    }

    fn all(&self) -> Vec<LogMessage> {
        self.inner
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .1
            .clone()
    }

    fn take(&self) -> Vec<LogMessage> {
        let mut g = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        let out = std::mem::take(&mut g.1);
        g.0 += out.len();
        out
    }
}

fn lossy(p: *const c_char) -> String {
    if p.is_null() {
        String::new()
    } else {
        // SAFETY: the FMU passes NUL-terminated strings valid during the call.
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    }
}

/// The logger handed to the FMU (see the module documentation for the variadic cast).
unsafe extern "C" fn capture_log(
    env: binding::fmi2ComponentEnvironment,
    instance: binding::fmi2String,
    status: binding::fmi2Status,
    category: binding::fmi2String,
    message: binding::fmi2String,
) {
    // No panic may unwind into the FMU.
    let _ = std::panic::catch_unwind(|| {
        if env.is_null() {
            return;
        }
        // SAFETY: env is the LogBuffer this instance was created with; it lives until after
        // fmi2FreeInstance.
        let buf = unsafe { &*(env as *const LogBuffer) };
        buf.push(LogMessage {
            instance: lossy(instance),
            status: Status::from_raw(status),
            category: lossy(category),
            message: lossy(message).replace("%%", "%"),
        });
    });
}

type VariadicLogger = unsafe extern "C" fn(
    binding::fmi2ComponentEnvironment,
    binding::fmi2String,
    binding::fmi2Status,
    binding::fmi2String,
    binding::fmi2String,
    ...
);
type FixedLogger = unsafe extern "C" fn(
    binding::fmi2ComponentEnvironment,
    binding::fmi2String,
    binding::fmi2Status,
    binding::fmi2String,
    binding::fmi2String,
);

fn logger() -> VariadicLogger {
    let f: FixedLogger = capture_log;
    // SAFETY: see the module documentation: on the linux64 ABIs a call through the variadic
    // pointer passes the five named arguments exactly as the non-variadic callee reads them.
    unsafe { std::mem::transmute::<FixedLogger, VariadicLogger>(f) }
}

extern "C" {
    fn calloc(nobj: usize, size: usize) -> *mut c_void;
    fn free(obj: *mut c_void);
}

static NEXT_ID: AtomicU64 = AtomicU64::new(1);

/// An FMU state (`fmi2FMUstate`) owned by the [`FmuSlave`] that made it. Free it with
/// [`FmuSlave::free_state`]; states still alive are freed when their slave is dropped.
#[derive(Debug)]
pub struct FmuState {
    ptr: binding::fmi2FMUstate,
    owner: u64,
}

/// One Co-Simulation instance of an imported [`Fmu`].
///
/// Every method calls the FMI function of the same name. Calls return `Ok(status)` for
/// `fmi2OK` and `fmi2Warning` (the FMU logged the warning: see [`FmuSlave::log`]) and
/// [`CosimError::Fmi`] for anything worse, with the messages the FMU logged during the call.
/// Dropping the slave frees its FMU states and calls `fmi2FreeInstance`.
pub struct FmuSlave {
    fmu: Fmu,
    component: binding::fmi2Component,
    name: String,
    id: u64,
    states: Vec<binding::fmi2FMUstate>,
    // Must outlive `component` (the FMU may keep pointers to both): dropped after Drop::drop.
    _callbacks: Box<binding::fmi2CallbackFunctions>,
    log: Box<LogBuffer>,
}

impl fmt::Debug for FmuSlave {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("FmuSlave")
            .field("name", &self.name)
            .field("component", &self.component)
            .field("fmu", &self.fmu.model_identifier())
            .finish()
    }
}

fn join_messages(msgs: &[LogMessage]) -> String {
    let bad: Vec<&LogMessage> = msgs
        .iter()
        .filter(|m| m.status >= Status::Warning)
        .collect();
    let pick: Vec<&LogMessage> = if bad.is_empty() {
        msgs.iter().collect()
    } else {
        bad
    };
    if pick.is_empty() {
        "(the FMU logged nothing)".to_string()
    } else {
        pick.iter()
            .map(|m| m.message.as_str())
            .collect::<Vec<_>>()
            .join(" | ")
    }
}

impl FmuSlave {
    /// `fmi2Instantiate` (Co-Simulation) with a logger that captures the messages.
    pub fn instantiate(fmu: &Fmu, instance_name: &str, options: SlaveOptions) -> Result<FmuSlave> {
        let cname = CString::new(instance_name)
            .map_err(|_| CosimError::Usage("instance name contains a NUL byte".into()))?;
        let guid = match &options.guid_override {
            Some(g) => CString::new(g.as_str())
                .map_err(|_| CosimError::Usage("GUID contains a NUL byte".into()))?,
            None => fmu.inner.guid.clone(),
        };
        let resource_uri = match &options.resource_uri_override {
            Some(r) => CString::new(r.as_str())
                .map_err(|_| CosimError::Usage("resource location contains a NUL byte".into()))?,
            None => fmu.inner.resource_uri.clone(),
        };
        let log = Box::new(LogBuffer {
            inner: Mutex::new((0, Vec::new())),
            count: AtomicUsize::new(0),
            echo: options.echo,
        });
        let callbacks = Box::new(binding::fmi2CallbackFunctions {
            logger: Some(logger()),
            allocateMemory: Some(calloc),
            freeMemory: Some(free),
            stepFinished: None,
            componentEnvironment: &*log as *const LogBuffer as *mut c_void,
        });
        let b = &fmu.inner.binding;
        // SAFETY: all pointers are valid NUL-terminated strings / a callbacks struct that
        // outlives the instance (both boxes are owned by the returned slave).
        let component = unsafe {
            b.fmi2Instantiate(
                cname.as_ptr(),
                binding::fmi2Type_fmi2CoSimulation,
                guid.as_ptr(),
                resource_uri.as_ptr(),
                &*callbacks,
                options.visible as binding::fmi2Boolean,
                options.logging_on as binding::fmi2Boolean,
            )
        };
        if component.is_null() {
            return Err(CosimError::Instantiate {
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

    fn b(&self) -> &Fmi2Binding {
        &self.fmu.inner.binding
    }

    fn check(
        &self,
        function: &'static str,
        raw: binding::fmi2Status,
        mark: usize,
    ) -> Result<Status> {
        let status = Status::from_raw(raw);
        if status.is_success() {
            Ok(status)
        } else {
            Err(CosimError::Fmi {
                function,
                status,
                message: join_messages(&self.log.since(mark)),
            })
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

    /// The raw `fmi2Component`, for benchmarks that call the C ABI directly through
    /// [`FmuSlave::raw_binding`]. Do not free it.
    pub fn component(&self) -> *mut c_void {
        self.component
    }

    /// The FMI function table (the `fmi` crate's raw bindings) this instance calls.
    pub fn raw_binding(&self) -> &Fmi2Binding {
        self.b()
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

    /// `fmi2SetDebugLogging`.
    pub fn set_debug_logging(&mut self, logging_on: bool, categories: &[&str]) -> Result<Status> {
        let cs: Vec<CString> = categories
            .iter()
            .map(|c| CString::new(*c))
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| CosimError::Usage("category contains a NUL byte".into()))?;
        let ptrs: Vec<*const c_char> = cs.iter().map(|c| c.as_ptr()).collect();
        let mark = self.log.mark();
        // SAFETY: valid component and an array of `ptrs.len()` strings.
        let s = unsafe {
            self.b().fmi2SetDebugLogging(
                self.component,
                logging_on as binding::fmi2Boolean,
                ptrs.len(),
                ptrs.as_ptr(),
            )
        };
        self.check("fmi2SetDebugLogging", s, mark)
    }

    /// `fmi2SetupExperiment`.
    pub fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> Result<Status> {
        let mark = self.log.mark();
        // SAFETY: valid component.
        let s = unsafe {
            self.b().fmi2SetupExperiment(
                self.component,
                tolerance.is_some() as binding::fmi2Boolean,
                tolerance.unwrap_or(0.0),
                start_time,
                stop_time.is_some() as binding::fmi2Boolean,
                stop_time.unwrap_or(0.0),
            )
        };
        self.check("fmi2SetupExperiment", s, mark)
    }

    /// `fmi2EnterInitializationMode`.
    pub fn enter_initialization_mode(&mut self) -> Result<Status> {
        let mark = self.log.mark();
        // SAFETY: valid component.
        let s = unsafe { self.b().fmi2EnterInitializationMode(self.component) };
        self.check("fmi2EnterInitializationMode", s, mark)
    }

    /// `fmi2ExitInitializationMode`.
    pub fn exit_initialization_mode(&mut self) -> Result<Status> {
        let mark = self.log.mark();
        // SAFETY: valid component.
        let s = unsafe { self.b().fmi2ExitInitializationMode(self.component) };
        self.check("fmi2ExitInitializationMode", s, mark)
    }

    /// Setup, enter and exit initialisation with nothing set in between; the worst status.
    pub fn initialize(&mut self, start_time: f64, stop_time: Option<f64>) -> Result<Status> {
        let a = self.setup_experiment(None, start_time, stop_time)?;
        let b = self.enter_initialization_mode()?;
        let c = self.exit_initialization_mode()?;
        Ok(a.max(b).max(c))
    }

    /// `fmi2DoStep(t, h, noSetFMUStatePriorToCurrentPoint = true)`.
    pub fn do_step(&mut self, current_time: f64, step: f64) -> Result<Status> {
        self.do_step_with(current_time, step, true)
    }

    /// `fmi2DoStep` with an explicit `noSetFMUStatePriorToCurrentPoint`.
    pub fn do_step_with(
        &mut self,
        current_time: f64,
        step: f64,
        no_set_state_prior: bool,
    ) -> Result<Status> {
        let mark = self.log.mark();
        // SAFETY: valid component.
        let s = unsafe {
            self.b().fmi2DoStep(
                self.component,
                current_time,
                step,
                no_set_state_prior as binding::fmi2Boolean,
            )
        };
        self.check("fmi2DoStep", s, mark)
    }

    /// `fmi2GetRealStatus(fmi2LastSuccessfulTime)`.
    pub fn last_successful_time(&mut self) -> Result<f64> {
        let mut t = 0.0;
        let mark = self.log.mark();
        // SAFETY: valid component and out-pointer.
        let s = unsafe {
            self.b().fmi2GetRealStatus(
                self.component,
                binding::fmi2StatusKind_fmi2LastSuccessfulTime,
                &mut t,
            )
        };
        self.check("fmi2GetRealStatus", s, mark)?;
        Ok(t)
    }

    /// `fmi2Reset`: back to the state right after instantiation.
    pub fn reset(&mut self) -> Result<Status> {
        let mark = self.log.mark();
        // SAFETY: valid component.
        let s = unsafe { self.b().fmi2Reset(self.component) };
        self.check("fmi2Reset", s, mark)
    }

    /// `fmi2Terminate`.
    pub fn terminate(&mut self) -> Result<Status> {
        let mark = self.log.mark();
        // SAFETY: valid component.
        let s = unsafe { self.b().fmi2Terminate(self.component) };
        self.check("fmi2Terminate", s, mark)
    }

    // ------------------------------------------------------------------------- values

    fn vr(&self, name: &str, t: VarType) -> Result<u32> {
        self.fmu.vr_of(name, t)
    }

    fn same_len(a: usize, b: usize) -> Result<()> {
        if a == b {
            Ok(())
        } else {
            Err(CosimError::Usage(format!(
                "{a} value references but {b} values"
            )))
        }
    }

    /// `fmi2SetReal`.
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<Status> {
        Self::same_len(vrs.len(), values.len())?;
        let mark = self.log.mark();
        // SAFETY: two arrays of vrs.len() elements.
        let s = unsafe {
            self.b()
                .fmi2SetReal(self.component, vrs.as_ptr(), vrs.len(), values.as_ptr())
        };
        self.check("fmi2SetReal", s, mark)
    }

    /// `fmi2GetReal` into `values`.
    pub fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> Result<Status> {
        Self::same_len(vrs.len(), values.len())?;
        let mark = self.log.mark();
        // SAFETY: two arrays of vrs.len() elements.
        let s = unsafe {
            self.b()
                .fmi2GetReal(self.component, vrs.as_ptr(), vrs.len(), values.as_mut_ptr())
        };
        self.check("fmi2GetReal", s, mark)
    }

    /// `fmi2SetReal` of the Real variable `name`.
    pub fn set_real_by_name(&mut self, name: &str, value: f64) -> Result<Status> {
        let vr = self.vr(name, VarType::Real)?;
        self.set_real(&[vr], &[value])
    }

    /// `fmi2GetReal` of the Real variable `name`.
    pub fn get_real_by_name(&mut self, name: &str) -> Result<f64> {
        let vr = self.vr(name, VarType::Real)?;
        let mut v = [0.0];
        self.get_real(&[vr], &mut v)?;
        Ok(v[0])
    }

    /// `fmi2GetReal` of several Real variables by name.
    pub fn get_reals_by_name(&mut self, names: &[&str]) -> Result<Vec<f64>> {
        let vrs = self.fmu.real_vrs(names)?;
        let mut v = vec![0.0; vrs.len()];
        self.get_real(&vrs, &mut v)?;
        Ok(v)
    }

    /// `fmi2SetInteger`.
    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Result<Status> {
        Self::same_len(vrs.len(), values.len())?;
        let mark = self.log.mark();
        // SAFETY: two arrays of vrs.len() elements.
        let s = unsafe {
            self.b()
                .fmi2SetInteger(self.component, vrs.as_ptr(), vrs.len(), values.as_ptr())
        };
        self.check("fmi2SetInteger", s, mark)
    }

    /// `fmi2GetInteger`.
    pub fn get_integer(&mut self, vrs: &[u32], values: &mut [i32]) -> Result<Status> {
        Self::same_len(vrs.len(), values.len())?;
        let mark = self.log.mark();
        // SAFETY: two arrays of vrs.len() elements.
        let s = unsafe {
            self.b()
                .fmi2GetInteger(self.component, vrs.as_ptr(), vrs.len(), values.as_mut_ptr())
        };
        self.check("fmi2GetInteger", s, mark)
    }

    /// `fmi2SetBoolean`.
    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Result<Status> {
        Self::same_len(vrs.len(), values.len())?;
        let raw: Vec<binding::fmi2Boolean> = values.iter().map(|&b| b as _).collect();
        let mark = self.log.mark();
        // SAFETY: two arrays of vrs.len() elements.
        let s = unsafe {
            self.b()
                .fmi2SetBoolean(self.component, vrs.as_ptr(), vrs.len(), raw.as_ptr())
        };
        self.check("fmi2SetBoolean", s, mark)
    }

    /// `fmi2GetBoolean`.
    pub fn get_boolean(&mut self, vrs: &[u32]) -> Result<Vec<bool>> {
        let mut raw: Vec<binding::fmi2Boolean> = vec![0; vrs.len()];
        let mark = self.log.mark();
        // SAFETY: two arrays of vrs.len() elements.
        let s = unsafe {
            self.b()
                .fmi2GetBoolean(self.component, vrs.as_ptr(), vrs.len(), raw.as_mut_ptr())
        };
        self.check("fmi2GetBoolean", s, mark)?;
        Ok(raw.into_iter().map(|b| b != 0).collect())
    }

    /// `fmi2SetBoolean` of the Boolean variable `name`.
    pub fn set_boolean_by_name(&mut self, name: &str, value: bool) -> Result<Status> {
        let vr = self.vr(name, VarType::Boolean)?;
        self.set_boolean(&[vr], &[value])
    }

    /// `fmi2GetBoolean` of the Boolean variable `name`.
    pub fn get_boolean_by_name(&mut self, name: &str) -> Result<bool> {
        let vr = self.vr(name, VarType::Boolean)?;
        Ok(self.get_boolean(&[vr])?[0])
    }

    /// `fmi2SetString`.
    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Result<Status> {
        Self::same_len(vrs.len(), values.len())?;
        let cs: Vec<CString> = values
            .iter()
            .map(|v| CString::new(*v))
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| CosimError::Usage("string value contains a NUL byte".into()))?;
        let ptrs: Vec<binding::fmi2String> = cs.iter().map(|c| c.as_ptr()).collect();
        let mark = self.log.mark();
        // SAFETY: two arrays of vrs.len() elements; strings alive during the call.
        let s = unsafe {
            self.b()
                .fmi2SetString(self.component, vrs.as_ptr(), vrs.len(), ptrs.as_ptr())
        };
        self.check("fmi2SetString", s, mark)
    }

    /// `fmi2GetString` (copied out before any other call can invalidate the FMU's buffers).
    pub fn get_string(&mut self, vrs: &[u32]) -> Result<Vec<String>> {
        let mut ptrs: Vec<binding::fmi2String> = vec![std::ptr::null(); vrs.len()];
        let mark = self.log.mark();
        // SAFETY: two arrays of vrs.len() elements.
        let s = unsafe {
            self.b()
                .fmi2GetString(self.component, vrs.as_ptr(), vrs.len(), ptrs.as_mut_ptr())
        };
        self.check("fmi2GetString", s, mark)?;
        Ok(ptrs.into_iter().map(lossy).collect())
    }

    /// `fmi2SetString` of the String variable `name`.
    pub fn set_string_by_name(&mut self, name: &str, value: &str) -> Result<Status> {
        let vr = self.vr(name, VarType::String)?;
        self.set_string(&[vr], &[value])
    }

    /// `fmi2GetString` of the String variable `name`.
    pub fn get_string_by_name(&mut self, name: &str) -> Result<String> {
        let vr = self.vr(name, VarType::String)?;
        Ok(self.get_string(&[vr])?.remove(0))
    }

    // ------------------------------------------------------------------------- derivatives

    /// `fmi2GetDirectionalDerivative`: `dv_unknown = J[unknowns, knowns] * dv_known`.
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
        let mark = self.log.mark();
        // SAFETY: arrays of the stated lengths.
        let s = unsafe {
            self.b().fmi2GetDirectionalDerivative(
                self.component,
                unknowns.as_ptr(),
                unknowns.len(),
                knowns.as_ptr(),
                knowns.len(),
                dv_known.as_ptr(),
                out.as_mut_ptr(),
            )
        };
        self.check("fmi2GetDirectionalDerivative", s, mark)?;
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

    /// `fmi2GetFMUstate` into a new state.
    pub fn get_state(&mut self) -> Result<FmuState> {
        self.need(
            self.fmu.capabilities().get_set_state,
            "canGetAndSetFMUstate",
        )?;
        let mut ptr: binding::fmi2FMUstate = std::ptr::null_mut();
        let mark = self.log.mark();
        // SAFETY: valid component; a NULL state asks the FMU for a new one.
        let s = unsafe { self.b().fmi2GetFMUstate(self.component, &mut ptr) };
        self.check("fmi2GetFMUstate", s, mark)?;
        if ptr.is_null() {
            return Err(CosimError::Fmi {
                function: "fmi2GetFMUstate",
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

    /// `fmi2GetFMUstate` into an existing state (overwrites it).
    pub fn update_state(&mut self, state: &mut FmuState) -> Result<Status> {
        self.own(state)?;
        let mut ptr = state.ptr;
        let mark = self.log.mark();
        // SAFETY: valid component and a state of this instance.
        let s = unsafe { self.b().fmi2GetFMUstate(self.component, &mut ptr) };
        let st = self.check("fmi2GetFMUstate", s, mark)?;
        if ptr != state.ptr {
            // The FMU may reallocate; keep the bookkeeping right.
            if let Some(p) = self.states.iter_mut().find(|p| **p == state.ptr) {
                *p = ptr;
            }
            state.ptr = ptr;
        }
        Ok(st)
    }

    /// `fmi2SetFMUstate`.
    pub fn set_state(&mut self, state: &FmuState) -> Result<Status> {
        self.own(state)?;
        let mark = self.log.mark();
        // SAFETY: valid component and a live state of this instance.
        let s = unsafe { self.b().fmi2SetFMUstate(self.component, state.ptr) };
        self.check("fmi2SetFMUstate", s, mark)
    }

    /// `fmi2FreeFMUstate`.
    pub fn free_state(&mut self, state: FmuState) -> Result<Status> {
        self.own(&state)?;
        self.states.retain(|p| *p != state.ptr);
        let mut ptr = state.ptr;
        let mark = self.log.mark();
        // SAFETY: valid component and a live state of this instance, freed once.
        let s = unsafe { self.b().fmi2FreeFMUstate(self.component, &mut ptr) };
        self.check("fmi2FreeFMUstate", s, mark)
    }

    /// `fmi2SerializedFMUstateSize` + `fmi2SerializeFMUstate`.
    pub fn serialize_state(&mut self, state: &FmuState) -> Result<Vec<u8>> {
        self.need(
            self.fmu.capabilities().serialize_state,
            "canSerializeFMUstate",
        )?;
        self.own(state)?;
        let mut size = 0usize;
        let mark = self.log.mark();
        // SAFETY: valid component, live state, out-pointer.
        let s = unsafe {
            self.b()
                .fmi2SerializedFMUstateSize(self.component, state.ptr, &mut size)
        };
        self.check("fmi2SerializedFMUstateSize", s, mark)?;
        let mut buf = vec![0u8; size];
        let mark = self.log.mark();
        // SAFETY: buffer of `size` bytes.
        let s = unsafe {
            self.b().fmi2SerializeFMUstate(
                self.component,
                state.ptr,
                buf.as_mut_ptr() as *mut binding::fmi2Byte,
                size,
            )
        };
        self.check("fmi2SerializeFMUstate", s, mark)?;
        Ok(buf)
    }

    /// `fmi2DeSerializeFMUstate` into a new state of this instance (the bytes may come from
    /// another instance of the same FMU).
    pub fn deserialize_state(&mut self, bytes: &[u8]) -> Result<FmuState> {
        self.need(
            self.fmu.capabilities().serialize_state,
            "canSerializeFMUstate",
        )?;
        let mut ptr: binding::fmi2FMUstate = std::ptr::null_mut();
        let mark = self.log.mark();
        // SAFETY: buffer of bytes.len() bytes, out-pointer.
        let s = unsafe {
            self.b().fmi2DeSerializeFMUstate(
                self.component,
                bytes.as_ptr() as *const binding::fmi2Byte,
                bytes.len(),
                &mut ptr,
            )
        };
        self.check("fmi2DeSerializeFMUstate", s, mark)?;
        if ptr.is_null() {
            return Err(CosimError::Fmi {
                function: "fmi2DeSerializeFMUstate",
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
}

impl Drop for FmuSlave {
    fn drop(&mut self) {
        let b = &self.fmu.inner.binding;
        for mut p in std::mem::take(&mut self.states) {
            // SAFETY: live states of this instance, each freed once.
            unsafe {
                b.fmi2FreeFMUstate(self.component, &mut p);
            }
        }
        // SAFETY: the component is freed exactly once; the callbacks and the log buffer are
        // dropped after this (struct fields drop after Drop::drop).
        unsafe { b.fmi2FreeInstance(self.component) };
    }
}
