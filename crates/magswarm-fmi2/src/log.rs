//! Logging through the importer's `fmi2CallbackLogger`, and [`Ctx`], the handle model
//! hooks use to report warnings and debug messages.
//!
//! Policy (as in the Reference FMUs): messages with status Warning or worse are always
//! passed to the logger, because an importer that got `fmi2Error` needs to know why;
//! debug messages (status OK) only when debug logging is on for their category
//! (`fmi2Instantiate(loggingOn)` / `fmi2SetDebugLogging`).
//!
//! The C logger is variadic with a printf-style `message`; we never pass extra arguments,
//! so every `%` in a message is doubled. Importers that print the message without
//! formatting it will show `%%`; that is the lesser evil compared to a crash in `vsnprintf`.

use std::ffi::{c_void, CString};

use crate::abi::{Fmi2CallbackFunctions, Fmi2CallbackLogger, Fmi2Status};
use crate::model::LogCategory;

/// Debug messages about the life of the instance (state transitions, resources).
pub const CAT_EVENTS: &str = "logEvents";
/// Messages accompanying `fmi2Warning`.
pub const CAT_WARNING: &str = "logStatusWarning";
/// Messages accompanying `fmi2Discard`.
pub const CAT_DISCARD: &str = "logStatusDiscard";
/// Messages accompanying `fmi2Error` (misuse, bad input, model errors, caught panics).
pub const CAT_ERROR: &str = "logStatusError";
/// Messages accompanying `fmi2Fatal`.
pub const CAT_FATAL: &str = "logStatusFatal";
/// Messages accompanying `fmi2Pending` (never produced).
pub const CAT_PENDING: &str = "logStatusPending";
/// Enabling this category enables every category.
pub const CAT_ALL: &str = "logAll";

/// The categories the shell itself logs under; written to `<LogCategories>` before the
/// model's own.
pub const SHELL_CATEGORIES: &[LogCategory] = &[
    LogCategory {
        name: CAT_EVENTS,
        description: "Instance life cycle: state transitions, resources, steps",
    },
    LogCategory {
        name: CAT_WARNING,
        description: "Messages for fmi2Warning (e.g. inputs outside the validated envelope)",
    },
    LogCategory {
        name: CAT_DISCARD,
        description: "Messages for fmi2Discard",
    },
    LogCategory {
        name: CAT_ERROR,
        description: "Messages for fmi2Error (illegal calls, invalid arguments, model errors)",
    },
    LogCategory {
        name: CAT_FATAL,
        description: "Messages for fmi2Fatal",
    },
    LogCategory {
        name: CAT_PENDING,
        description: "Messages for fmi2Pending (not used: fmi2DoStep is synchronous)",
    },
    LogCategory {
        name: CAT_ALL,
        description: "All of the above and every model category",
    },
];

/// The log category the shell uses for a message of this status.
pub fn category_of(status: Fmi2Status) -> &'static str {
    match status {
        Fmi2Status::Ok => CAT_EVENTS,
        Fmi2Status::Warning => CAT_WARNING,
        Fmi2Status::Discard => CAT_DISCARD,
        Fmi2Status::Error => CAT_ERROR,
        Fmi2Status::Fatal => CAT_FATAL,
        Fmi2Status::Pending => CAT_PENDING,
    }
}

/// The shell's categories followed by the model's, without duplicates.
pub fn all_categories(model: &[LogCategory]) -> Vec<LogCategory> {
    let mut out: Vec<LogCategory> = SHELL_CATEGORIES.to_vec();
    for c in model {
        if !out.iter().any(|o| o.name == c.name) {
            out.push(*c);
        }
    }
    out
}

/// The importer's logger plus the instance's debug-logging settings. Kept by the
/// instance for its whole life (also across `fmi2Reset`).
pub struct Logger {
    callback: Option<Fmi2CallbackLogger>,
    env: *mut c_void,
    instance_name: CString,
    name: String,
    debug_on: bool,
    /// `None`: every category is enabled while `debug_on`.
    enabled: Option<Vec<String>>,
    known: Vec<&'static str>,
}

impl Logger {
    /// A logger for an instance called `instance_name`, from the importer's callbacks.
    pub fn new(
        callbacks: Option<&Fmi2CallbackFunctions>,
        instance_name: &str,
        logging_on: bool,
        known: Vec<&'static str>,
    ) -> Logger {
        Logger {
            callback: callbacks.and_then(|c| c.logger),
            env: callbacks.map_or(std::ptr::null_mut(), |c| c.component_environment),
            instance_name: to_c_lossy(instance_name),
            name: instance_name.to_string(),
            debug_on: logging_on,
            enabled: None,
            known,
        }
    }

    /// The instance name as given to `fmi2Instantiate`.
    pub fn instance_name(&self) -> &str {
        &self.name
    }

    /// Whether a message of this status and category would reach the importer.
    pub fn is_enabled(&self, status: Fmi2Status, category: &str) -> bool {
        if self.callback.is_none() {
            return false;
        }
        if status >= Fmi2Status::Warning {
            return true;
        }
        if !self.debug_on {
            return false;
        }
        match &self.enabled {
            None => true,
            Some(list) => list.iter().any(|c| c == category || c == CAT_ALL),
        }
    }

    /// Pass a message to the importer (if enabled).
    pub fn log(&self, status: Fmi2Status, category: &str, message: &str) {
        if !self.is_enabled(status, category) {
            return;
        }
        let Some(cb) = self.callback else { return };
        let category = to_c_lossy(category);
        let message = to_c_lossy(&message.replace('%', "%%"));
        // SAFETY: the importer promised a valid logger for the instance's lifetime; all
        // strings are NUL-terminated and live until the call returns.
        unsafe {
            cb(
                self.env,
                self.instance_name.as_ptr(),
                status,
                category.as_ptr(),
                message.as_ptr(),
            );
        }
    }

    /// `fmi2SetDebugLogging`. Returns the categories that are not known to this FMU
    /// (they are ignored; the caller reports a warning).
    pub fn set_debug_logging(&mut self, logging_on: bool, categories: &[String]) -> Vec<String> {
        let unknown: Vec<String> = categories
            .iter()
            .filter(|c| !self.known.contains(&c.as_str()))
            .cloned()
            .collect();
        let known: Vec<String> = categories
            .iter()
            .filter(|c| self.known.contains(&c.as_str()))
            .cloned()
            .collect();
        if categories.is_empty() {
            self.debug_on = logging_on;
            self.enabled = None;
        } else if logging_on {
            self.debug_on = true;
            self.enabled = Some(known);
        } else {
            // Switch off only the listed categories (and `logAll`, which would re-enable them).
            let current: Vec<String> = match (&self.enabled, self.debug_on) {
                (_, false) => Vec::new(),
                (None, true) => self.known.iter().map(|s| s.to_string()).collect(),
                (Some(list), true) => list.clone(),
            };
            let remaining: Vec<String> = current
                .into_iter()
                .filter(|c| !known.contains(c) && c != CAT_ALL)
                .collect();
            self.debug_on = !remaining.is_empty();
            self.enabled = Some(remaining);
        }
        unknown
    }
}

/// A C string from arbitrary text: interior NULs become `\0` so nothing is lost silently.
pub(crate) fn to_c_lossy(s: &str) -> CString {
    match CString::new(s) {
        Ok(c) => c,
        Err(_) => CString::new(s.replace('\0', "\\0")).unwrap_or_default(),
    }
}

/// The handle a model hook gets for reporting: warnings raise the status the FMI call
/// returns to at least `fmi2Warning`; debug messages go out only if enabled.
pub struct Ctx<'a> {
    logger: Option<&'a Logger>,
    function: &'static str,
    status: Fmi2Status,
}

impl<'a> Ctx<'a> {
    /// A context for the FMI function `function` logging through `logger`.
    pub fn new(logger: &'a Logger, function: &'static str) -> Ctx<'a> {
        Ctx {
            logger: Some(logger),
            function,
            status: Fmi2Status::Ok,
        }
    }

    /// A context that logs nowhere (for tests and for work on clones, e.g. finite differences).
    pub fn silent() -> Ctx<'static> {
        Ctx {
            logger: None,
            function: "",
            status: Fmi2Status::Ok,
        }
    }

    /// Report a warning: logged under `logStatusWarning`, and the FMI call returns
    /// `fmi2Warning` (unless something worse happens).
    pub fn warning(&mut self, message: impl AsRef<str>) {
        self.status = self.status.max(Fmi2Status::Warning);
        if let Some(l) = self.logger {
            l.log(
                Fmi2Status::Warning,
                CAT_WARNING,
                &format!("{}: {}", self.function, message.as_ref()),
            );
        }
    }

    /// Whether a debug message in `category` would be passed on (check before formatting
    /// anything expensive).
    pub fn debug_enabled(&self, category: &str) -> bool {
        self.logger
            .is_some_and(|l| l.is_enabled(Fmi2Status::Ok, category))
    }

    /// A debug message (status OK) in `category`, if enabled.
    pub fn debug(&self, category: &str, message: impl AsRef<str>) {
        if let Some(l) = self.logger {
            l.log(Fmi2Status::Ok, category, message.as_ref());
        }
    }

    /// The worst status reported so far through this context.
    pub fn status(&self) -> Fmi2Status {
        self.status
    }

    /// The instance name (empty for a silent context).
    pub fn instance_name(&self) -> &str {
        self.logger.map_or("", |l| l.instance_name())
    }
}
