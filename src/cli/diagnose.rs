//! Arguments of `magswarm diagnose` and the command itself over the library (`magswarm::diagnose`).

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
    /// Steady parameters to hold at the prior model's values in the baseline, comma-separated
    /// (as identify's --fix): for a log that cannot tell them apart, e.g. one distance only.
    #[arg(long, value_delimiter = ',')]
    pub fix: Vec<String>,
}

impl DiagnoseArgs {
    /// The library's options.
    pub fn config(&self) -> anyhow::Result<magswarm::diagnose::Config> {
        if !(self.alpha > 0.0 && self.alpha < 0.5) {
            anyhow::bail!("--alpha {}: must lie in (0, 0.5)", self.alpha);
        }
        // Checked by the library against the baseline's free set.
        let fix = self
            .fix
            .iter()
            .map(|n| n.trim().to_string())
            .filter(|n| !n.is_empty())
            .collect();
        Ok(magswarm::diagnose::Config {
            alpha: self.alpha,
            fix,
            folds: self.folds.max(2),
            boot: self.bootstrap.max(19),
            seed: self.seed,
            ..magswarm::diagnose::Config::default()
        })
    }
}

/// Run `magswarm diagnose`: read the logs, diagnose, write the report, print its summary.
pub fn run(a: &DiagnoseArgs) -> anyhow::Result<()> {
    use magswarm::log::{Log, ReadOptions};
    use magswarm_model::Model;
    let cfg = a.config()?;
    let prior = Model::load_or_paper(a.model.as_deref())?;
    let opts = ReadOptions { lenient: a.lenient };
    let log = Log::read_with(&a.log, opts)?;
    for s in &log.skipped {
        eprintln!("diagnose: warning: {}: skipped {s}", log.source);
    }
    let w = match &a.withheld {
        Some(p) => Some(Log::read_with(p, opts)?),
        None => None,
    };
    let d = magswarm::diagnose::diagnose_with_progress(
        &log,
        w.as_ref(),
        &prior,
        &cfg,
        &super::progress::Bar::new("diagnose"),
    )?;
    magswarm::diagnose::report::write(&d, &a.out)?;
    eprint!("{}", magswarm::diagnose::report::summary(&d));
    eprintln!(
        "diagnose: report written to {}",
        a.out.join("report.md").display()
    );
    Ok(())
}
