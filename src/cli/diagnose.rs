//! Arguments of `magswarm diagnose` (run by [`crate::diagnose::run`]).

use std::path::PathBuf;

/// Arguments of `magswarm diagnose`.
#[derive(Debug, Clone, clap::Args)]
pub struct DiagnoseArgs {
    /// Measurement log (docs/log-format.md format) the baseline and the candidates are fitted to.
    #[arg(long)]
    pub log: PathBuf,
    /// A log withheld from every fit, used only to validate.
    #[arg(long)]
    pub withheld: Option<PathBuf>,
    /// Prior model JSON (start values, fixed parameters, conventions; default: paper model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Output directory (report.json, baseline.json, augmented.json, report.md, figures).
    #[arg(long)]
    pub out: PathBuf,
    /// Significance level of the gap decision and of the attribution.
    #[arg(long, default_value_t = 0.01)]
    pub alpha: f64,
    /// Cross-validation folds (groups of whole visits).
    #[arg(long, default_value_t = 5)]
    pub folds: usize,
    /// Simulated logs (parametric bootstrap) that calibrate the gap tests and the naming of
    /// effects; p-values below 1/(N+1) are extrapolated from a gamma fit to the simulations.
    #[arg(long, default_value_t = 499, alias = "permutations")]
    pub bootstrap: usize,
    /// Random seed (folds, simulations).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Skip bad rows (each reported on stderr) instead of failing.
    #[arg(long)]
    pub lenient: bool,
}
