//! Logging through the importer's logger callback, and [`Ctx`], the handle model hooks use
//! to report warnings and debug messages.
//!
//! Policy (as in the Reference FMUs): messages with status Warning or worse are always
//! passed to the logger, because an importer that got an error needs to know why; debug
//! messages (status OK) only when debug logging is on for their category (`loggingOn` at
//! instantiation, `fmi2SetDebugLogging` / `fmi3SetDebugLogging`).
//!
//! The logger callbacks differ between the versions (FMI 2.0's is variadic, printf-style,
//! and takes the instance name; FMI 3.0's takes a plain message): each shell wraps its
//! callback in a [`LogSink`], so everything here is the same for both.

use crate::info::LogCategory;
use crate::status::Status;

/// Where an instance's messages go: the shell's wrapper around the importer's callback,
/// called with (status, category, message). The messages are complete texts; a shell whose
/// logger formats them (FMI 2.0) escapes them itself.
pub type LogSink = Box<dyn Fn(Status, &str, &str)>;

/// Debug messages about the life of the instance (state transitions, resources).
pub const CAT_EVENTS: &str = "logEvents";
/// Messages accompanying a Warning status.
pub const CAT_WARNING: &str = "logStatusWarning";
/// Messages accompanying a Discard status.
pub const CAT_DISCARD: &str = "logStatusDiscard";
/// Messages accompanying an Error status (misuse, bad input, model errors, caught panics).
pub const CAT_ERROR: &str = "logStatusError";
/// Messages accompanying a Fatal status.
pub const CAT_FATAL: &str = "logStatusFatal";
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
        description: "Messages of calls that return a warning (e.g. inputs outside the validated envelope)",
    },
    LogCategory {
        name: CAT_DISCARD,
        description: "Messages of calls that return Discard",
    },
    LogCategory {
        name: CAT_ERROR,
        description: "Messages of calls that return an error (illegal calls, invalid arguments, model errors)",
    },
    LogCategory {
        name: CAT_FATAL,
        description: "Messages of calls that return Fatal",
    },
    LogCategory {
        name: CAT_ALL,
        description: "All of the above and every model category",
    },
];

/// The log category the shell uses for a message of this status.
pub fn category_of(status: Status) -> &'static str {
    match status {
        Status::Ok => CAT_EVENTS,
        Status::Warning => CAT_WARNING,
        Status::Discard => CAT_DISCARD,
        Status::Error => CAT_ERROR,
        Status::Fatal => CAT_FATAL,
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
/// instance for its whole life (also across reset).
pub struct Logger {
    sink: Option<LogSink>,
    name: String,
    debug_on: bool,
    /// `None`: every category is enabled while `debug_on`.
    enabled: Option<Vec<String>>,
    known: Vec<&'static str>,
}

impl Logger {
    /// A logger for an instance called `instance_name` writing to `sink` (`None`: the
    /// importer gave no logger, nothing is logged).
    pub fn new(
        sink: Option<LogSink>,
        instance_name: &str,
        logging_on: bool,
        known: Vec<&'static str>,
    ) -> Logger {
        Logger {
            sink,
            name: instance_name.to_string(),
            debug_on: logging_on,
            enabled: None,
            known,
        }
    }

    /// The instance name as given at instantiation.
    pub fn instance_name(&self) -> &str {
        &self.name
    }

    /// Whether a message of this status and category would reach the importer.
    pub fn is_enabled(&self, status: Status, category: &str) -> bool {
        if self.sink.is_none() {
            return false;
        }
        if status >= Status::Warning {
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
    pub fn log(&self, status: Status, category: &str, message: &str) {
        if !self.is_enabled(status, category) {
            return;
        }
        if let Some(sink) = &self.sink {
            sink(status, category, message);
        }
    }

    /// `SetDebugLogging`. Returns the categories that are not known to this FMU
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
pub fn to_c_lossy(s: &str) -> std::ffi::CString {
    use std::ffi::CString;
    match CString::new(s) {
        Ok(c) => c,
        Err(_) => CString::new(s.replace('\0', "\\0")).unwrap_or_default(),
    }
}

/// The handle a model hook gets for reporting: warnings raise the status the FMI call
/// returns to at least Warning; debug messages go out only if enabled.
pub struct Ctx<'a> {
    logger: Option<&'a Logger>,
    function: &'static str,
    status: Status,
}

impl<'a> Ctx<'a> {
    /// A context for the FMI function `function` logging through `logger`.
    pub fn new(logger: &'a Logger, function: &'static str) -> Ctx<'a> {
        Ctx {
            logger: Some(logger),
            function,
            status: Status::Ok,
        }
    }

    /// A context that logs nowhere (for tests and for work on clones, e.g. finite differences).
    pub fn silent() -> Ctx<'static> {
        Ctx {
            logger: None,
            function: "",
            status: Status::Ok,
        }
    }

    /// Report a warning: logged under `logStatusWarning`, and the FMI call returns Warning
    /// (unless something worse happens).
    pub fn warning(&mut self, message: impl AsRef<str>) {
        self.status = self.status.max(Status::Warning);
        if let Some(l) = self.logger {
            l.log(
                Status::Warning,
                CAT_WARNING,
                &format!("{}: {}", self.function, message.as_ref()),
            );
        }
    }

    /// Whether a debug message in `category` would be passed on (check before formatting
    /// anything expensive).
    pub fn debug_enabled(&self, category: &str) -> bool {
        self.logger
            .is_some_and(|l| l.is_enabled(Status::Ok, category))
    }

    /// A debug message (status OK) in `category`, if enabled.
    pub fn debug(&self, category: &str, message: impl AsRef<str>) {
        if let Some(l) = self.logger {
            l.log(Status::Ok, category, message.as_ref());
        }
    }

    /// The worst status reported so far through this context.
    pub fn status(&self) -> Status {
        self.status
    }

    /// The instance name (empty for a silent context).
    pub fn instance_name(&self) -> &str {
        self.logger.map_or("", |l| l.instance_name())
    }
}
