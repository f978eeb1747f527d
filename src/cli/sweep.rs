//! Arguments of `magswarm sweep` (run by [`crate::sweep::run`]).

use std::path::PathBuf;

/// `magswarm sweep`.
#[derive(Debug, Clone, clap::Args)]
pub struct SweepArgs {
    /// Number of Monte Carlo runs.
    #[arg(long)]
    pub runs: u64,
    /// Seed of the draws (same seed, same draws, on any machine or thread count).
    #[arg(long)]
    pub seed: u64,
    /// Results CSV: one row per run, ordered by run.
    #[arg(long)]
    pub out: PathBuf,
    /// Nominal model (magswarm-model JSON; may carry an "uncertainty" member). Default: the
    /// paper model.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Parameter uncertainty JSON ({"ranges": {...}} or {"names", "mean", "cov"}); default
    /// C_1, C_2, alpha_1, alpha_2 +-10 %, K_tau +-30 %.
    #[arg(long)]
    pub uncertainty: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}
