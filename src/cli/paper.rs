//! Arguments of `magswarm paper` (run by [`crate::paper::run`]).

use std::path::PathBuf;

/// Arguments of `magswarm paper`.
#[derive(Debug, clap::Args)]
pub struct PaperArgs {
    /// Model JSON (default: the built-in paper model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Write Fig. 4/5-style PNG plots into this directory.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Print the figures as JSON (machine-readable) instead of the table.
    #[arg(long)]
    pub json: bool,
}
