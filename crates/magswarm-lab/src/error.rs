//! What can go wrong in the virtual lab, each naming the file, field or option at fault.

use std::path::PathBuf;

/// An error of the virtual lab.
#[derive(Debug, thiserror::Error)]
pub enum LabError {
    /// A scenario file that cannot be read.
    #[error("cannot read scenario {path}: {source}")]
    ReadScenario {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A scenario file that is not a scenario (JSON path of the fault).
    #[error("scenario {path}: {at}: {message}")]
    ParseScenario {
        /// The file.
        path: PathBuf,
        /// Where in it (JSON path).
        at: String,
        /// What is wrong.
        message: String,
    },
    /// A scenario file with a value out of range.
    #[error("scenario {path}: {source}")]
    InScenario {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: Box<LabError>,
    },
    /// A value out of range: the field (`noise.p_invalid`, `protocol.settle_s`, `foreign
    /// particle_drift: c_per_sqrt_h`) and the reason.
    #[error("{field} {message}")]
    Invalid {
        /// The field.
        field: String,
        /// Why it is refused.
        message: String,
    },
    /// The same foreign effect twice.
    #[error("foreign effect {0} given twice")]
    DuplicateForeign(&'static str),
    /// An effect without a foreign form.
    #[error("no foreign form for {name:?}; effects: {known}")]
    UnknownEffect {
        /// The name asked for.
        name: String,
        /// The known names.
        known: String,
    },
    /// An option of the grid protocol given with another protocol.
    #[error("--{0} applies to the grid protocol only (use a scenario file)")]
    GridOnly(&'static str),
    /// A protocol name that is not one.
    #[error("--protocol {0:?}: expected grid, sweep, steps or long")]
    UnknownProtocol(String),
    /// The truth model file.
    #[error("truth model: {0}")]
    Truth(#[from] magswarm_model::ModelError),
    /// The log could not be written.
    #[error("writing the log: {0}")]
    Write(#[from] std::io::Error),
    /// The log as written could not be read back.
    #[error(transparent)]
    Log(#[from] magswarm_log::LogError),
    /// The truth's ODE (4) could not be integrated.
    #[error("session {session} at t = {t} s: ODE (4) could not be integrated at z_m = {z_mm:.3} mm, f = {f_hz:.3} Hz: {message}")]
    Integrate {
        /// Session (1-based).
        session: usize,
        /// Session time \[s\].
        t: f64,
        /// z_m \[mm\].
        z_mm: f64,
        /// f \[Hz\].
        f_hz: f64,
        /// The integrator's message.
        message: String,
    },
}

impl LabError {
    /// A value out of range.
    pub fn invalid(field: impl Into<String>, message: impl Into<String>) -> LabError {
        LabError::Invalid {
            field: field.into(),
            message: message.into(),
        }
    }
}
