//! Arguments of `magswarm identify` (turned into an [`crate::identify::Config`] by
//! `Config::from_args`, run by [`crate::identify::run`]).

use std::path::PathBuf;

/// Arguments of `magswarm identify`.
#[derive(Debug, Clone, clap::Args)]
pub struct IdentifyArgs {
    /// Measurement log(s) (docs/log-format.md format); repeat for several.
    #[arg(long, required = true)]
    pub log: Vec<PathBuf>,
    /// Output model JSON.
    #[arg(long)]
    pub out: PathBuf,
    /// Write report.md and plots into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Prior model JSON: start values, fixed parameters, conventions (default: paper model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Free parameters, comma-separated (replaces the default set
    /// C_1,C_2,a_K1,a_K2,alpha_1,alpha_2,N,q,K_tau).
    #[arg(long, value_delimiter = ',')]
    pub free: Option<Vec<String>>,
    /// Parameters to hold at the prior value, comma-separated (removed from the free set).
    #[arg(long, value_delimiter = ',')]
    pub fix: Vec<String>,
    /// Bounds override NAME=LO:HI (repeatable).
    #[arg(long)]
    pub bound: Vec<String>,
    /// Fixed settle time \[s\] after an input change (overrides --settle-factor).
    #[arg(long)]
    pub settle_s: Option<f64>,
    /// Settle time as a multiple of the model's slowest time constant at the inputs.
    #[arg(long, default_value_t = 5.0)]
    pub settle_factor: f64,
    /// Number of LM starts (the prior plus random perturbations).
    #[arg(long, default_value_t = 8)]
    pub starts: usize,
    /// Bootstrap replicates over operating points (0: none).
    #[arg(long, default_value_t = 200)]
    pub bootstrap: usize,
    /// Random seed (starts, bootstrap).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Collinearity policy: fix, ridge or report.
    #[arg(long, default_value = "fix")]
    pub collinear: String,
    /// Largest acceptable condition number of the column-scaled J^T J (policy fix).
    #[arg(long, default_value_t = 1e8)]
    pub cond_max: f64,
    /// Ridge strength (policy ridge).
    #[arg(long, default_value_t = 1.0)]
    pub ridge_lambda: f64,
    /// Do not fit the ODE time scales even when the log holds transients.
    #[arg(long)]
    pub no_dynamics: bool,
    /// Withhold every K-th operating point from the fit and report its error (0: none).
    #[arg(long, default_value_t = 0)]
    pub withhold_every: usize,
    /// Skip bad rows (each reported on stderr) instead of failing.
    #[arg(long)]
    pub lenient: bool,
}
