//! Arguments of `magswarm predict` (run by [`crate::predict::run`]).

use std::path::PathBuf;

/// Arguments of `magswarm predict`.
#[derive(Debug, clap::Args)]
pub struct PredictArgs {
    /// Model JSON (default: the built-in paper model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Input log (docs/log-format.md format; needs t_s, z_m_mm, f_hz).
    #[arg(long)]
    pub log: PathBuf,
    /// Output log with predicted r1_mm, r2_mm.
    #[arg(long)]
    pub out: PathBuf,
}
