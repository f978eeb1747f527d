//! Why a figure or a report could not be written, naming the file.

use std::path::PathBuf;

/// A figure or report that could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// No finite value to draw.
    #[error("{}: nothing to plot (no finite points)", .0.display())]
    NoData(PathBuf),
    /// The values do not fit the plot's shape (a caller's mistake, named with the figure).
    #[error("{}: {message}", path.display())]
    Shape {
        /// The figure.
        path: PathBuf,
        /// What does not fit.
        message: String,
    },
    /// plotters could not draw or encode the figure.
    #[error("drawing {}: {message}", path.display())]
    Draw {
        /// The figure.
        path: PathBuf,
        /// plotters' reason (its error types are neither `Send` nor `Sync`, so kept as text).
        message: String,
    },
    /// A folder or file could not be created or written.
    #[error("{what} {}: {err}", path.display())]
    Io {
        /// "creating", "cannot write", ...
        what: &'static str,
        /// The folder or file.
        path: PathBuf,
        /// The cause.
        err: std::io::Error,
    },
}

/// Results of the report crate.
pub type Result<T, E = ReportError> = std::result::Result<T, E>;
