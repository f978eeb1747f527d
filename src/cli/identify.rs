//! `magswarm identify`: its arguments, their library face ([`IdentifyArgs::config`]) and the
//! run (read the logs, [`magswarm::identify::identify`], write the model and the report).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use magswarm::identify::data::SettleRule;
use magswarm::identify::{self, params, Collinear, Config};
use magswarm::log::{Log, ReadOptions};
use magswarm::model::Model;

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

impl IdentifyArgs {
    /// The identification's configuration these flags ask for.
    pub fn config(&self) -> Result<Config> {
        let a = self;
        let mut c = Config::default();
        if let Some(f) = &a.free {
            c.free = f
                .iter()
                .map(|s| s.trim().to_string())
                .filter(|s| !s.is_empty())
                .collect();
        }
        for n in &a.fix {
            let n = n.trim();
            if params::def(n).is_none() {
                return Err(identify::unknown_parameter("--fix", n).into());
            }
            c.free.retain(|x| x != n);
        }
        for b in &a.bound {
            let parsed = b.split_once('=').and_then(|(n, r)| {
                let (lo, hi) = r.split_once(':')?;
                Some((
                    n.trim().to_string(),
                    lo.trim().parse().ok()?,
                    hi.trim().parse().ok()?,
                ))
            });
            match parsed {
                Some((n, lo, hi)) if lo < hi => c.bounds.push((n, lo, hi)),
                _ => bail!("--bound {b:?}: expected NAME=LO:HI with LO < HI"),
            }
        }
        c.settle = match a.settle_s {
            Some(s) if s >= 0.0 && s.is_finite() => SettleRule::Fixed(s),
            Some(s) => bail!("--settle-s {s}: must be a finite number >= 0"),
            None if a.settle_factor >= 0.0 && a.settle_factor.is_finite() => {
                SettleRule::TimeConstants(a.settle_factor)
            }
            None => bail!("--settle-factor {}: must be >= 0", a.settle_factor),
        };
        c.starts = a.starts.max(1);
        c.bootstrap = a.bootstrap;
        c.seed = a.seed;
        c.collinear = match a.collinear.as_str() {
            "fix" => Collinear::Fix {
                cond_max: a.cond_max,
            },
            "ridge" => Collinear::Ridge {
                lambda: a.ridge_lambda,
            },
            "report" => Collinear::Report,
            o => bail!("--collinear {o}: expected fix, ridge or report"),
        };
        c.dynamics = !a.no_dynamics;
        c.withhold_every = a.withhold_every;
        Ok(c)
    }
}

/// Run `magswarm identify`.
pub fn run(a: &IdentifyArgs) -> Result<()> {
    let cfg = a.config()?;
    let prior = Model::load_or_paper(a.model.as_deref())?;
    let mut logs = Vec::new();
    for p in &a.log {
        let l = Log::read_with(p, ReadOptions { lenient: a.lenient })?;
        for s in &l.skipped {
            eprintln!("identify: warning: {}: skipped {s}", l.source);
        }
        logs.push(l);
    }
    let id = identify::identify_with_progress(
        &logs,
        &prior,
        &cfg,
        &super::progress::Bar::new("identify"),
    )?;
    id.model
        .save(&a.out)
        .with_context(|| format!("cannot save {}", a.out.display()))?;
    eprint!("{}", magswarm::report::identify::summary(&id));
    if let Some(dir) = &a.report {
        magswarm::report::identify::write(&id, dir)?;
        eprintln!(
            "identify: report written to {}",
            dir.join("report.md").display()
        );
    }
    eprintln!("identify: model written to {}", a.out.display());
    Ok(())
}
