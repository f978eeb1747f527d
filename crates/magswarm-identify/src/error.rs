//! Why an identification or a replay could not be done: each variant names what is wrong and
//! where, in the words of the command's options (`--free`, `--settle-s`, ...) since that is
//! what a user changes.

use magswarm_model::{InputError, ModelError, StepError};

/// An identification that cannot be done.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// A parameter name that is not a fittable row of the registry.
    #[error("{option} {name}: unknown parameter (known: {known})")]
    UnknownParameter {
        /// The option that named it (`--free`, `--fix`, `--bound`).
        option: &'static str,
        /// The name given.
        name: String,
        /// The names identify knows, comma-separated.
        known: String,
    },
    /// A log without radius columns.
    #[error("{log}: no r1_mm, r2_mm columns: identify needs measured radii")]
    NoRadii {
        /// The log's source (file name).
        log: String,
    },
    /// No valid row with radii.
    #[error("no usable rows: {rows} row(s), none valid with radii")]
    NoUsableRows {
        /// Rows read.
        rows: usize,
    },
    /// The data cannot determine the free parameters (the message says why and what to do).
    #[error("{0}")]
    NotIdentifiable(String),
    /// The fitted model is outside the physical ranges of the model file.
    #[error("the identified model does not validate: {0}")]
    Invalid(ModelError),
}

/// A log that cannot be replayed through a model.
#[derive(Debug, thiserror::Error)]
pub enum PredictError {
    /// A row's inputs break the model's input rule.
    #[error("{at}row at t = {t} s: {err}")]
    Input {
        /// Where (the log and session, with a trailing `: `, or empty).
        at: String,
        /// The row's time \[s\].
        t: f64,
        /// The rule broken.
        err: InputError,
    },
    /// The integrator gave up between two rows.
    #[error(
        "{at}integrating ODE (4) from t = {from} s to {to} s at z_m {z_mm} mm, f {f_hz} Hz: \
         integrator failed: {err:?}"
    )]
    Integrate {
        /// Where (the log and session, with a trailing `: `, or empty).
        at: String,
        /// Start of the interval \[s\].
        from: f64,
        /// End of the interval \[s\].
        to: f64,
        /// z_m in force \[mm\].
        z_mm: f64,
        /// f in force \[Hz\].
        f_hz: f64,
        /// The integrator's reason.
        err: StepError,
    },
}

impl PredictError {
    /// The same error located in a log (and session).
    pub fn within(mut self, place: &str) -> PredictError {
        let at = match &mut self {
            PredictError::Input { at, .. } | PredictError::Integrate { at, .. } => at,
        };
        *at = format!("{place}: {at}");
        self
    }
}
