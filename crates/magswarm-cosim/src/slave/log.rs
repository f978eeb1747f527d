//! The instance's log and the callbacks handed to the FMU at instantiation.
//!
//! # The FMI 2.0 logger
//!
//! The FMI 2.0 logger is a C variadic function (`printf`-style `message, ...`). Stable Rust
//! cannot define variadic functions, so the logger given to the FMU is a non-variadic
//! `extern "C"` function cast to the variadic pointer type: on the x86-64 System V and
//! AArch64 Linux ABIs (the `linux64` platform of FMI 2.0) the named arguments are passed the
//! same way in both cases, and the variadic ones are simply not read. The message is taken
//! as-is except that `%%` becomes `%` (FMUs that pass no extra arguments, such as MagSwarm,
//! escape `%` that way); FMUs that pass `printf` arguments show their raw format string.
//!
//! The FMI 3.0 logger is an ordinary function (the message is already formatted) and names
//! no instance: the slave's name is recorded instead.

use std::ffi::{c_char, c_void, CStr, CString};
use std::fmt;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use fmi::fmi2::binding as b2;
use fmi::fmi3::binding as b3;

use super::call::Ptr;
use crate::error::Status;
use crate::import::Api;

/// One message the FMU passed to the logger.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogMessage {
    /// Instance name the FMU gave (FMI 3.0: the instance's name, as the logger names none).
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

/// The log of one instance; the instance environment points at it.
pub(crate) struct LogBuffer {
    /// The instance's name (FMI 3.0 messages carry none).
    name: String,
    /// (number of messages removed by `take`, messages kept).
    inner: Mutex<(usize, Vec<LogMessage>)>,
    /// Messages received so far (never decreases).
    count: AtomicUsize,
    /// Forward every message to the `log` crate as it arrives.
    echo: bool,
}

impl LogBuffer {
    pub(crate) fn new(name: &str, echo: bool) -> LogBuffer {
        LogBuffer {
            name: name.to_string(),
            inner: Mutex::new((0, Vec::new())),
            count: AtomicUsize::new(0),
            echo,
        }
    }

    fn push(&self, m: LogMessage) {
        if self.echo {
            let level = match m.status {
                Status::Ok | Status::Pending => log::Level::Info,
                Status::Warning | Status::Discard => log::Level::Warn,
                Status::Error | Status::Fatal => log::Level::Error,
            };
            log::log!(target: "fmu", level, "{m}");
        }
        let mut g = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        g.1.push(m);
        self.count.fetch_add(1, Ordering::Release);
    }

    #[inline]
    pub(crate) fn mark(&self) -> usize {
        self.count.load(Ordering::Acquire)
    }

    /// The messages received since `mark`, still held.
    pub(crate) fn since(&self, mark: usize) -> Vec<LogMessage> {
        let g = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        let skip = mark.saturating_sub(g.0).min(g.1.len());
        g.1[skip..].to_vec()
    }

    pub(crate) fn all(&self) -> Vec<LogMessage> {
        self.inner
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .1
            .clone()
    }

    pub(crate) fn take(&self) -> Vec<LogMessage> {
        let mut g = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        let out = std::mem::take(&mut g.1);
        g.0 += out.len();
        out
    }
}

/// What the FMU logged, for an error message: the warnings and worse, else everything.
pub(crate) fn join_messages(msgs: &[LogMessage]) -> String {
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

pub(crate) fn lossy(p: *const c_char) -> String {
    if p.is_null() {
        String::new()
    } else {
        // SAFETY: the FMU passes NUL-terminated strings valid during the call.
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    }
}

/// Record one message in the buffer `env` points at.
fn record(
    env: *mut c_void,
    instance: Option<*const c_char>,
    status: i32,
    cat: *const c_char,
    msg: String,
) {
    // No panic may unwind into the FMU.
    let _ = std::panic::catch_unwind(|| {
        if env.is_null() {
            return;
        }
        // SAFETY: env is the LogBuffer this instance was created with; it lives until after
        // the instance is freed.
        let buf = unsafe { &*(env as *const LogBuffer) };
        buf.push(LogMessage {
            instance: instance.map_or_else(|| buf.name.clone(), lossy),
            status: Status::from_raw(status),
            category: lossy(cat),
            message: msg,
        });
    });
}

/// The FMI 2.0 logger (see the module documentation for the variadic cast).
unsafe extern "C" fn capture_log2(
    env: b2::fmi2ComponentEnvironment,
    instance: b2::fmi2String,
    status: b2::fmi2Status,
    category: b2::fmi2String,
    message: b2::fmi2String,
) {
    record(
        env,
        Some(instance),
        status as i32,
        category,
        lossy(message).replace("%%", "%"),
    );
}

/// The FMI 3.0 logger.
unsafe extern "C" fn capture_log3(
    env: b3::fmi3InstanceEnvironment,
    status: b3::fmi3Status,
    category: b3::fmi3String,
    message: b3::fmi3String,
) {
    record(env, None, status as i32, category, lossy(message));
}

type VariadicLogger = unsafe extern "C" fn(
    b2::fmi2ComponentEnvironment,
    b2::fmi2String,
    b2::fmi2Status,
    b2::fmi2String,
    b2::fmi2String,
    ...
);
type FixedLogger = unsafe extern "C" fn(
    b2::fmi2ComponentEnvironment,
    b2::fmi2String,
    b2::fmi2Status,
    b2::fmi2String,
    b2::fmi2String,
);

fn logger2() -> VariadicLogger {
    let f: FixedLogger = capture_log2;
    // SAFETY: see the module documentation: on the linux64 ABIs a call through the variadic
    // pointer passes the five named arguments exactly as the non-variadic callee reads them.
    unsafe { std::mem::transmute::<FixedLogger, VariadicLogger>(f) }
}

extern "C" {
    fn calloc(nobj: usize, size: usize) -> *mut c_void;
    fn free(obj: *mut c_void);
}

/// What instantiation needs besides the function table.
pub(crate) struct Instantiation<'a> {
    pub(crate) name: &'a CString,
    pub(crate) token: &'a CString,
    pub(crate) resources: &'a CString,
    pub(crate) visible: bool,
    pub(crate) logging_on: bool,
}

/// The FMI 2.0 callbacks struct, which must outlive its instance (FMI 3.0 passes the callbacks
/// as arguments and needs nothing kept).
pub(crate) type Callbacks = Option<Box<b2::fmi2CallbackFunctions>>;

impl Api {
    /// Instantiate for Co-Simulation with `log` as the instance environment; NULL when the
    /// FMU refuses.
    pub(crate) fn instantiate_cs(
        &self,
        i: &Instantiation<'_>,
        log: &LogBuffer,
    ) -> (Ptr, Callbacks) {
        let env = log as *const LogBuffer as *mut c_void;
        match self {
            Api::V2(b) => {
                let callbacks = Box::new(b2::fmi2CallbackFunctions {
                    logger: Some(logger2()),
                    allocateMemory: Some(calloc),
                    freeMemory: Some(free),
                    stepFinished: None,
                    componentEnvironment: env,
                });
                // SAFETY: valid NUL-terminated strings and a callbacks struct that the caller
                // keeps alive as long as the instance.
                let c = unsafe {
                    b.fmi2Instantiate(
                        i.name.as_ptr(),
                        b2::fmi2Type_fmi2CoSimulation,
                        i.token.as_ptr(),
                        i.resources.as_ptr(),
                        &*callbacks,
                        i.visible as b2::fmi2Boolean,
                        i.logging_on as b2::fmi2Boolean,
                    )
                };
                (c, Some(callbacks))
            }
            Api::V3(b) => {
                // SAFETY: valid NUL-terminated strings; no intermediate variables; the
                // environment outlives the instance.
                let c = unsafe {
                    b.fmi3InstantiateCoSimulation(
                        i.name.as_ptr(),
                        i.token.as_ptr(),
                        i.resources.as_ptr(),
                        i.visible,
                        i.logging_on,
                        false,
                        false,
                        std::ptr::null(),
                        0,
                        env,
                        Some(capture_log3),
                        None,
                    )
                };
                (c, None)
            }
        }
    }
}
