//! Errors of the importer side: what failed, with the FMI function, its status and what the
//! FMU logged while it ran (the same for FMI 2.0 and 3.0 FMUs).

use std::fmt;
use std::path::PathBuf;

/// The status an FMI function returned (`fmi2Status` or `fmi3Status`: the same numbers;
/// FMI 2.0 adds Pending).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Status {
    /// OK.
    Ok,
    /// Warning: the call did its work; the FMU logged why it warns.
    Warning,
    /// Discard.
    Discard,
    /// Error.
    Error,
    /// Fatal.
    Fatal,
    /// `fmi2Pending` (asynchronous doStep; MagSwarm never returns it).
    Pending,
}

impl Status {
    /// From the C value (the same in FMI 2.0 and 3.0); anything unknown counts as Fatal.
    pub fn from_raw(s: i32) -> Status {
        match s {
            0 => Status::Ok,
            1 => Status::Warning,
            2 => Status::Discard,
            3 => Status::Error,
            5 => Status::Pending,
            _ => Status::Fatal,
        }
    }

    /// The status's name without the version prefix (`OK`, `Warning`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "OK",
            Status::Warning => "Warning",
            Status::Discard => "Discard",
            Status::Error => "Error",
            Status::Fatal => "Fatal",
            Status::Pending => "Pending",
        }
    }

    /// OK or Warning: the call did its work.
    pub fn is_success(self) -> bool {
        matches!(self, Status::Ok | Status::Warning)
    }
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Everything that can go wrong on the importer side.
#[derive(Debug, thiserror::Error)]
pub enum CosimError {
    /// The archive could not be unpacked or its modelDescription.xml parsed, or the shared
    /// library could not be loaded.
    #[error("cannot import {}: {source}", path.display())]
    Import {
        /// The .fmu.
        path: PathBuf,
        /// What the `fmi` crate reported.
        #[source]
        source: fmi::Error,
    },
    /// The archive is not an FMU this importer will unpack (zip-slip path, symbolic link,
    /// zip bomb, missing modelDescription.xml, not a zip at all).
    #[error("cannot import {}: {message}", path.display())]
    BadArchive {
        /// The .fmu.
        path: PathBuf,
        /// What is wrong, naming the entry.
        message: String,
    },
    /// The FMU is not what this importer can run (not FMI 2.0 or 3.0 Co-Simulation, missing
    /// symbols, a capability flag that is off).
    #[error("{0}")]
    Unsupported(String),
    /// No variable of that name in modelDescription.xml.
    #[error("no variable named {0:?} in modelDescription.xml")]
    UnknownVariable(String),
    /// The variable exists but has another type than the accessor used.
    #[error("variable {name:?} is {found}, not {expected}")]
    VariableType {
        /// Variable name.
        name: String,
        /// Type the accessor needs.
        expected: &'static str,
        /// Type in modelDescription.xml.
        found: &'static str,
    },
    /// Instantiation (`fmi2Instantiate`, `fmi3InstantiateCoSimulation`) returned NULL.
    #[error("{function} returned NULL for instance {instance:?}: {message}")]
    Instantiate {
        /// The C function.
        function: &'static str,
        /// Instance name.
        instance: String,
        /// What the FMU logged during the call.
        message: String,
    },
    /// An FMI function returned Discard, Error, Fatal (or `fmi2Pending`).
    #[error("{function} returned {status}: {message}")]
    Fmi {
        /// The C function, e.g. `fmi2SetReal`, `fmi3SetFloat64`.
        function: &'static str,
        /// Its status.
        status: Status,
        /// The messages the FMU logged during the call (joined with " | "), or a note that it
        /// logged nothing.
        message: String,
    },
    /// An FMU state was used with an instance that did not create it.
    #[error("the FMU state belongs to another instance")]
    ForeignState,
    /// Bad arguments to the importer (lengths that do not match, a string with NUL, ...).
    #[error("{0}")]
    Usage(String),
    /// Writing the log.
    #[error("log sink: {0}")]
    Io(#[from] std::io::Error),
}

impl CosimError {
    /// The FMI status, for [`CosimError::Fmi`].
    pub fn status(&self) -> Option<Status> {
        match self {
            CosimError::Fmi { status, .. } => Some(*status),
            _ => None,
        }
    }

    /// The FMI function that failed, for [`CosimError::Fmi`].
    pub fn function(&self) -> Option<&'static str> {
        match self {
            CosimError::Fmi { function, .. } => Some(function),
            _ => None,
        }
    }

    /// What the FMU logged, for [`CosimError::Fmi`] and [`CosimError::Instantiate`].
    pub fn fmu_message(&self) -> Option<&str> {
        match self {
            CosimError::Fmi { message, .. } | CosimError::Instantiate { message, .. } => {
                Some(message)
            }
            _ => None,
        }
    }
}

/// Result of the importer side.
pub type Result<T, E = CosimError> = std::result::Result<T, E>;
