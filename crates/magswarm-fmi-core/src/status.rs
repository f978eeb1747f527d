//! The outcome of a call, as every FMI version knows it, and the error a model hook returns.
//!
//! FMI 2.0 and 3.0 share the statuses OK, Warning, Discard, Error and Fatal with the same
//! numbers (FMI 2.0 adds Pending, which no function of these shells ever returns), so the
//! shells convert [`Status`] to their C enum by value.

/// The status of a call. The order is the standard's severity order, so the `max` of two
/// statuses is the status of a call that did two things.
#[repr(i32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Status {
    /// Done.
    Ok = 0,
    /// Done, but something is questionable (logged).
    Warning = 1,
    /// Not done (e.g. a step that could not be taken); the instance is fine.
    Discard = 2,
    /// The instance cannot continue without a reset or a restored FMU state.
    Error = 3,
    /// The instance can only be freed.
    Fatal = 4,
}

impl Status {
    /// The status's name as the standards spell it after the version prefix (`OK`, `Error`).
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "OK",
            Status::Warning => "Warning",
            Status::Discard => "Discard",
            Status::Error => "Error",
            Status::Fatal => "Fatal",
        }
    }
}

impl From<Status> for i32 {
    /// The C value (the same in FMI 2.0 and 3.0).
    fn from(s: Status) -> i32 {
        s as i32
    }
}

/// An error (or warning) from a model hook: a status and a message for the importer's log.
///
/// Returned as `Err` from hooks whose result type is `()`, a `Warning` means "done, with a
/// warning" and a `Discard` means "not done, but the instance is fine". From getters any
/// status is treated as at least `Error` (there is no value to hand back).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}: {message}", status.name())]
pub struct ModelError {
    /// Warning, Discard, Error or Fatal.
    pub status: Status,
    /// What went wrong, naming the variable where there is one.
    pub message: String,
}

impl ModelError {
    fn with(status: Status, message: impl Into<String>) -> Self {
        ModelError {
            status,
            message: message.into(),
        }
    }
    /// An error: the call fails and the instance goes to the Error state.
    pub fn error(message: impl Into<String>) -> Self {
        Self::with(Status::Error, message)
    }
    /// A warning: the call is done, and returns Warning with this message logged.
    pub fn warning(message: impl Into<String>) -> Self {
        Self::with(Status::Warning, message)
    }
    /// A discard: the call was not carried out; the instance is fine.
    pub fn discard(message: impl Into<String>) -> Self {
        Self::with(Status::Discard, message)
    }
    /// A fatal error: the instance can only be freed.
    pub fn fatal(message: impl Into<String>) -> Self {
        Self::with(Status::Fatal, message)
    }
    /// The standard error for a value reference the model does not know.
    pub fn unknown_vr(ty: crate::VarType, vr: u32) -> Self {
        Self::error(format!("unknown {} value reference {vr}", ty.as_str()))
    }
}

/// Why the shell refuses a call or an instantiation: the message it logs (an unknown or
/// mistyped value reference, a variable that may not be set in this mode, an interface the
/// FMU does not offer).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct Refusal(pub String);

impl From<String> for Refusal {
    fn from(s: String) -> Self {
        Refusal(s)
    }
}

impl From<&str> for Refusal {
    fn from(s: &str) -> Self {
        Refusal(s.to_string())
    }
}

impl AsRef<str> for Refusal {
    fn as_ref(&self) -> &str {
        &self.0
    }
}
