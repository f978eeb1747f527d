//! `magswarm sweep`: its arguments and the run (the study of [`magswarm::sweep`] with a progress
//! bar, the results CSV and a summary).

use std::path::PathBuf;

use anyhow::{bail, Result};
use magswarm::sweep::{load, write_csv, Sweep};

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

/// Run `magswarm sweep`.
pub fn run(a: &SweepArgs) -> Result<()> {
    if a.runs == 0 {
        bail!("--runs must be at least 1");
    }
    let (model, unc) = load(a.model.as_deref(), a.uncertainty.as_deref())?;
    let sweep = Sweep::new(model, unc);
    let names = sweep.uncertainty.names();
    let bar = if a.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(a.runs)
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} runs  {per_sec}  eta {eta}")
            .expect("valid template"),
    );
    let t0 = std::time::Instant::now();
    let tick = || bar.inc(1);
    let results = sweep.run_all(a.seed, a.runs, a.threads, &tick)?;
    bar.finish_and_clear();
    let secs = t0.elapsed().as_secs_f64();
    write_csv(&a.out, &names, &results)?;
    let failed = results.iter().filter(|r| !r.error.is_empty()).count();
    let mut r1: Vec<f64> = results
        .iter()
        .map(|r| r.rmse_mm[0])
        .filter(|v| v.is_finite())
        .collect();
    let mut r2: Vec<f64> = results
        .iter()
        .map(|r| r.rmse_mm[1])
        .filter(|v| v.is_finite())
        .collect();
    r1.sort_by(f64::total_cmp);
    r2.sort_by(f64::total_cmp);
    let q = |v: &[f64], p: f64| {
        if v.is_empty() {
            f64::NAN
        } else {
            v[((v.len() - 1) as f64 * p).round() as usize]
        }
    };
    println!(
        "{} runs in {secs:.2} s ({:.1} runs/s, {} threads); {failed} failed; {}",
        a.runs,
        a.runs as f64 / secs,
        if a.threads == 0 {
            std::thread::available_parallelism().map_or(1, |n| n.get())
        } else {
            a.threads
        },
        a.out.display()
    );
    println!(
        "rmse r1 [mm]: median {:.3}, 5-95 % {:.3}-{:.3}; rmse r2 [mm]: median {:.3}, 5-95 % {:.3}-{:.3}",
        q(&r1, 0.5),
        q(&r1, 0.05),
        q(&r1, 0.95),
        q(&r2, 0.5),
        q(&r2, 0.05),
        q(&r2, 0.95)
    );
    Ok(())
}
