//! Arguments of `magswarm inverse` and `magswarm linearize` (run by [`crate::control_cli`]).

use std::path::PathBuf;

/// Arguments of `magswarm inverse`.
#[derive(Debug, clap::Args)]
pub struct InverseArgs {
    /// Target r1 \[mm\].
    #[arg(long)]
    pub r1: f64,
    /// Target r2 \[mm\].
    #[arg(long)]
    pub r2: f64,
    /// Model JSON (default: the built-in paper model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Output format of `magswarm linearize`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum LinFormat {
    /// JSON with the matrices, operating point, names and units.
    #[default]
    Json,
    /// A MATLAB script (`A = [..]; ... sys = ss(A,B,C,D);`).
    Matlab,
    /// A python-control script (`sys = control.ss(A, B, C, D)`).
    Python,
}

/// Arguments of `magswarm linearize`.
#[derive(Debug, clap::Args)]
pub struct LinearizeArgs {
    /// Operating point z_m \[mm\].
    #[arg(long)]
    pub z: f64,
    /// Operating point f \[Hz\].
    #[arg(long)]
    pub f: f64,
    /// Model JSON (default: the built-in paper model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = LinFormat::Json)]
    pub format: LinFormat,
}
