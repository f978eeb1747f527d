//! `magswarm identify`: fit the plant to measured logs, with uncertainty and identifiability.
//!
//! The pipeline (each step documented in its module):
//!
//! 1. [`data`]: logs -> sessions -> visits (runs of constant commanded inputs); settled rows
//!    (the settle rule: `--settle-s`, or `--settle-factor` x the model's slowest time constant
//!    at the visit's inputs) vs transient rows; operating points with mean, repeat SD, MAD;
//!    weights from the repeat variance (shrunk toward the pooled variance).
//! 2. [`fit`]: bounded Levenberg-Marquardt on the free steady-map parameters (default
//!    [`params::DEFAULT_FREE_STEADY`]; `--free` / `--fix` / `--bound` change it), from several
//!    starts; Jacobian covariance scaled by the reduced chi^2; t-based 95 % CIs.
//! 3. Collinearity: the correlation matrix and the condition number of the column-scaled
//!    J^T J are always reported. Policy `--collinear fix` (default): while the condition
//!    number exceeds `--cond-max`, the parameter with the largest weight in the weakest
//!    direction (stiffness terms first) is fixed at its prior value and the fit repeated.
//!    `--collinear ridge`: every free stiffness term is pulled toward its prior value by a
//!    ridge term of strength `--ridge-lambda` (scale max(|prior|, 0.1)); the covariance then
//!    includes that prior. `--collinear report`: nothing is changed.
//! 4. [`dynfit`]: where the log holds transients, the ODE (4) time scales (default K_tau;
//!    K_d1, K_d2 on request; scheduled confinement keeps the equilibrium on the map) are fitted to the
//!    transient rows; the settle split is then redone with the fitted time constants and the
//!    steady fit repeated if it changed.
//! 5. Bootstrap over operating points (`--bootstrap N`) checks the Jacobian CIs.
//! 6. The model file (`Model::save`, with provenance) and, with `--report DIR`, a report
//!    ([`report`]).
//!
//! The prior model (`--model`, default the paper model) supplies the start, every fixed
//! parameter, the conventions, the magnet geometry and the dynamics not fitted.

pub mod data;
pub mod dynfit;
pub mod fit;
pub mod params;
pub mod report;

use crate::log::{Log, ReadOptions};
use anyhow::{bail, Context, Result};
use data::{OpPoint, SettleRule, Weighting};
use fit::{BootStat, Covariance, Ridge, Run};
use magswarm_model::{hz_to_rad_s, steady, Model};
use params::{Free, Group};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Arguments of `magswarm identify`.
#[derive(Debug, Clone, clap::Args)]
pub struct IdentifyArgs {
    /// Measurement log(s) (CONTRACTS.md format); repeat for several.
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
    /// Fixed settle time [s] after an input change (overrides --settle-factor).
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

/// Collinearity policy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Collinear {
    /// Fix the weakest parameter while cond > cond_max.
    Fix {
        /// Threshold.
        cond_max: f64,
    },
    /// Ridge toward the prior on the stiffness terms.
    Ridge {
        /// Strength.
        lambda: f64,
    },
    /// Only report.
    Report,
}

/// Configuration of an identification (the library face of the flags).
#[derive(Debug, Clone)]
pub struct Config {
    /// Free parameter names (steady and dynamic).
    pub free: Vec<String>,
    /// Bounds overrides.
    pub bounds: Vec<(String, f64, f64)>,
    /// Settle rule.
    pub settle: SettleRule,
    /// LM starts.
    pub starts: usize,
    /// Bootstrap replicates.
    pub bootstrap: usize,
    /// Seed.
    pub seed: u64,
    /// Collinearity policy.
    pub collinear: Collinear,
    /// Fit ODE time scales where possible.
    pub dynamics: bool,
    /// Withhold every K-th point (0: none).
    pub withhold_every: usize,
    /// Show a progress bar (only drawn on a terminal).
    pub progress: bool,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            free: params::DEFAULT_FREE_STEADY
                .iter()
                .chain(params::DEFAULT_FREE_DYNAMIC)
                .map(|s| s.to_string())
                .collect(),
            bounds: Vec::new(),
            settle: SettleRule::TimeConstants(5.0),
            starts: 8,
            bootstrap: 200,
            seed: 1,
            collinear: Collinear::Fix { cond_max: 1e8 },
            dynamics: true,
            withhold_every: 0,
            progress: false,
        }
    }
}

impl Config {
    /// Build from the command-line flags.
    pub fn from_args(a: &IdentifyArgs) -> Result<Config> {
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
                bail!(
                    "--fix {n}: unknown parameter (known: {})",
                    params::known_names()
                );
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
        c.progress = true;
        Ok(c)
    }

    fn resolve(&self) -> Result<(Vec<Free>, Vec<Free>)> {
        let mut st = Vec::new();
        let mut dy = Vec::new();
        for n in &self.free {
            let mut f = Free::new(n).ok_or_else(|| {
                anyhow::anyhow!(
                    "--free {n}: unknown parameter (known: {})",
                    params::known_names()
                )
            })?;
            if let Some((_, lo, hi)) = self.bounds.iter().find(|b| &b.0 == n) {
                f.lo = *lo;
                f.hi = *hi;
            }
            let list = if f.def.group == Group::Steady {
                &mut st
            } else {
                &mut dy
            };
            if !list.iter().any(|x: &Free| x.name() == f.name()) {
                list.push(f);
            }
        }
        for (n, _, _) in &self.bounds {
            if params::def(n).is_none() {
                bail!(
                    "--bound {n}: unknown parameter (known: {})",
                    params::known_names()
                );
            }
        }
        Ok((st, dy))
    }
}

/// A fitted parameter with its uncertainty.
#[derive(Debug, Clone)]
pub struct Estimate {
    /// Name.
    pub name: String,
    /// Prior (start) value.
    pub prior: f64,
    /// Fitted value.
    pub value: f64,
    /// Standard error (Jacobian covariance).
    pub se: f64,
    /// 95 % CI (t quantile x SE).
    pub ci: (f64, f64),
    /// Bootstrap summary, when run.
    pub boot: Option<BootStat>,
    /// Ended within 0.1 % of a bound (the CI is then not meaningful).
    pub at_bound: bool,
}

/// A parameter fixed by the collinearity policy.
#[derive(Debug, Clone)]
pub struct AutoFix {
    /// Name.
    pub name: String,
    /// Value it was fixed at (the prior's).
    pub value: f64,
    /// Condition number that triggered it.
    pub cond: f64,
}

/// Result of the steady fit.
#[derive(Debug, Clone)]
pub struct SteadyFit {
    /// Free parameters in the final fit.
    pub free: Vec<Free>,
    /// Estimates, same order.
    pub estimates: Vec<Estimate>,
    /// Covariance and diagnostics of the final fit.
    pub cov: Covariance,
    /// Diagnostics of the first fit (before any auto-fix), when the policy changed something.
    pub cov_initial: Option<(Vec<String>, Covariance)>,
    /// Every LM run of the final multi-start (best first).
    pub runs: Vec<Run>,
    /// Parameters fixed by the policy.
    pub auto_fixed: Vec<AutoFix>,
    /// The policy in force.
    pub policy: Collinear,
    /// Bootstrap replicates that converged.
    pub boot_ok: usize,
}

/// Result of the dynamic fit.
#[derive(Debug, Clone)]
pub struct DynFit {
    /// Estimates.
    pub estimates: Vec<Estimate>,
    /// Diagnostics.
    pub cov: Covariance,
    /// LM run.
    pub run: Run,
    /// Transient rows used.
    pub rows: usize,
    /// RMS of the transient residuals [mm] per axis, with the prior dynamics and fitted.
    pub rms_before: [f64; 2],
    /// After the fit.
    pub rms_after: [f64; 2],
}

/// Error figures of a model on a set of points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Errors {
    /// RMSE of the point means [mm].
    pub rmse: [f64; 2],
    /// Mean absolute error relative to the measured mean [%].
    pub mae_pct: [f64; 2],
    /// Number of points.
    pub n: usize,
}

/// Row and point counts.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Counts {
    /// Rows in all logs.
    pub rows: usize,
    /// Rows with valid = 0 or without radii.
    pub invalid: usize,
    /// Settled rows.
    pub settled: usize,
    /// Transient rows.
    pub transient: usize,
    /// Sessions.
    pub sessions: usize,
    /// Visits (runs of constant inputs).
    pub visits: usize,
    /// Operating points (fitted + withheld).
    pub points: usize,
}

/// (t [s], replayed radii [mm], measured radii [mm]) of the report's transient plot.
pub type TracePoint = (f64, [f64; 2], Option<[f64; 2]>);

/// Everything an identification produced.
#[derive(Debug, Clone)]
pub struct Identification {
    /// The identified model.
    pub model: Model,
    /// The prior.
    pub prior: Model,
    /// Operating points used by the fit.
    pub points: Vec<OpPoint>,
    /// Withheld points.
    pub withheld: Vec<OpPoint>,
    /// Weighting summary.
    pub weighting: Weighting,
    /// Steady fit.
    pub steady: SteadyFit,
    /// Dynamic fit, where the log held transients.
    pub dynamics: Option<DynFit>,
    /// Why the dynamics were or were not fitted.
    pub dynamics_note: String,
    /// Errors on the fitted points.
    pub train: Errors,
    /// Errors on withheld points.
    pub heldout: Option<Errors>,
    /// Median S_x, S_y over the fitted points.
    pub median_s: [f64; 2],
    /// Counts.
    pub counts: Counts,
    /// Settle rule used.
    pub settle: SettleRule,
    /// Wall time.
    pub elapsed: Duration,
    /// Names of the input logs.
    pub sources: Vec<String>,
    /// (t, replayed radii, measured radii) over the start of the session with the most
    /// transient rows (for the report), when the dynamics were fitted.
    pub trace: Option<Vec<TracePoint>>,
}

/// Error figures of `m` on `points`.
pub fn errors(m: &Model, points: &[OpPoint]) -> Errors {
    let mut se = [0.0; 2];
    let mut ae = [0.0; 2];
    for p in points {
        let r = fit::predict_point(m, p.z_mm, p.f_hz);
        for a in 0..2 {
            let d = r[a] - p.mean[a];
            se[a] += d * d;
            ae[a] += d.abs() / p.mean[a].abs().max(1e-9);
        }
    }
    let n = points.len().max(1) as f64;
    Errors {
        rmse: [(se[0] / n).sqrt(), (se[1] / n).sqrt()],
        mae_pct: [100.0 * ae[0] / n, 100.0 * ae[1] / n],
        n: points.len(),
    }
}

fn distinct(v: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut x: Vec<f64> = v.collect();
    x.sort_by(|a, b| a.total_cmp(b));
    x.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    x
}

/// Refuse data that cannot identify the free parameters, saying what is missing.
/// Estimates of the free parameters of a fitted model, with 95 % intervals from the
/// Jacobian covariance (Student t on the fit's degrees of freedom).
fn estimates(free: &[Free], fitted: &Model, prior: &Model, cov: &fit::Covariance) -> Vec<Estimate> {
    let t = fit::t975(cov.dof);
    free.iter()
        .enumerate()
        .map(|(j, f)| {
            let v = params::get(fitted, f.name());
            Estimate {
                name: f.name().to_string(),
                prior: params::get(prior, f.name()),
                value: v,
                se: cov.se[j],
                ci: (v - t * cov.se[j], v + t * cov.se[j]),
                boot: None,
                at_bound: f.at_bound(v),
            }
        })
        .collect()
}

fn check_identifiable(points: &[OpPoint], free: &[Free], counts: &Counts) -> Result<()> {
    if counts.settled == 0 {
        bail!(
            "no settled rows: all {} valid rows lie within the settle time of an input change \
             ({} transient). Record longer at each operating point, or pass --settle-s 0 if \
             the log holds only settled measurements",
            counts.transient,
            counts.transient
        );
    }
    let p = free.len();
    if p == 0 {
        bail!("no free steady parameters (check --free / --fix)");
    }
    let need = (p + 2).div_ceil(2);
    if points.len() < need {
        bail!(
            "too few operating points: {} settled point(s) (visits pooled by inputs) for {p} \
             free steady parameters; need at least {need} (2 radii per point, >= 2 residual \
             degrees of freedom). Add visits at more (z_m, f) pairs or fix parameters with --fix",
            points.len()
        );
    }
    let zs = distinct(points.iter().map(|p| p.z_mm));
    let fs = distinct(points.iter().map(|p| p.f_hz));
    let z_shape: Vec<&str> = free
        .iter()
        .map(|f| f.name())
        .filter(|n| !matches!(*n, "C_1" | "C_2" | "N" | "q" | "c_P" | "q_P"))
        .collect();
    if !z_shape.is_empty() && zs.len() < 3 {
        bail!(
            "{} distinct z_m value(s) ({} mm): the z_m-dependent parameters {} need at least \
             3 distinct z_m values to be told apart from C_1, C_2. Add visits at other \
             distances or fix them with --fix {}",
            zs.len(),
            zs.iter()
                .map(|z| format!("{z}"))
                .collect::<Vec<_>>()
                .join(", "),
            z_shape.join(", "),
            z_shape.join(",")
        );
    }
    let f_shape: Vec<&str> = free
        .iter()
        .map(|f| f.name())
        .filter(|n| matches!(*n, "N" | "q" | "c_P" | "q_P"))
        .collect();
    if !f_shape.is_empty() && fs.len() < 3 {
        bail!(
            "{} distinct frequency value(s) ({} Hz): the frequency parameters {} need at least \
             3 distinct f values. Add visits at other frequencies or fix them with --fix {}",
            fs.len(),
            fs.iter()
                .map(|f| format!("{f}"))
                .collect::<Vec<_>>()
                .join(", "),
            f_shape.join(", "),
            f_shape.join(",")
        );
    }
    Ok(())
}

fn progress_bar(show: bool, len: u64, msg: &str) -> indicatif::ProgressBar {
    if show && std::io::stderr().is_terminal() {
        let pb = indicatif::ProgressBar::new(len);
        pb.set_style(
            indicatif::ProgressStyle::with_template("{msg:>12} [{bar:30}] {pos}/{len} {elapsed}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        pb.set_message(msg.to_string());
        pb
    } else {
        indicatif::ProgressBar::hidden()
    }
}

/// Multi-start fit of `free` on `points`; runs sorted best first.
fn multi_start(
    prior: &Model,
    free: &[Free],
    points: &[OpPoint],
    ridge: Option<&Ridge>,
    cfg: &Config,
    pb: &indicatif::ProgressBar,
) -> (Model, Vec<Run>) {
    let theta0: Vec<f64> = free.iter().map(|f| params::get(prior, f.name())).collect();
    let idx: Vec<usize> = (0..points.len()).collect();
    let mut runs: Vec<Run> = fit::starts(free, &theta0, cfg.starts, cfg.seed)
        .into_iter()
        .map(|u| {
            let r = fit::run_lm(prior, free, points, &idx, ridge, u);
            pb.inc(1);
            r
        })
        .collect();
    runs.sort_by(|a, b| a.cost.total_cmp(&b.cost));
    let mut m = prior.clone();
    for (f, &t) in free.iter().zip(&runs[0].theta) {
        params::set(&mut m, f.name(), t);
    }
    (m, runs)
}

fn ridge_for(free: &[Free], prior: &Model, policy: Collinear) -> Option<Ridge> {
    match policy {
        Collinear::Ridge { lambda } => Some(Ridge {
            lambda,
            terms: free
                .iter()
                .map(|f| {
                    f.def.stiffness.then(|| {
                        let p = params::get(prior, f.name());
                        (p, p.abs().max(0.1))
                    })
                })
                .collect(),
        }),
        _ => None,
    }
}

/// The steady fit with the collinearity policy.
fn steady_fit(
    prior: &Model,
    mut free: Vec<Free>,
    points: &[OpPoint],
    cfg: &Config,
    pb: &indicatif::ProgressBar,
) -> (Model, SteadyFit) {
    let mut auto_fixed = Vec::new();
    let mut cov_initial = None;
    loop {
        let ridge = ridge_for(&free, prior, cfg.collinear);
        let (m, runs) = multi_start(prior, &free, points, ridge.as_ref(), cfg, pb);
        let cov = fit::covariance(&m, &free, points, ridge.as_ref());
        if let Collinear::Fix { cond_max } = cfg.collinear {
            if cov.cond_scaled > cond_max && free.len() > 1 {
                if cov_initial.is_none() {
                    cov_initial = Some((
                        free.iter().map(|f| f.name().to_string()).collect(),
                        cov.clone(),
                    ));
                }
                // The parameter that carries most of the weakest direction; stiffness terms
                // first, the axis gains C_i last.
                let pick = |only_stiff: bool| {
                    free.iter()
                        .enumerate()
                        .filter(|(_, f)| !only_stiff || f.def.stiffness)
                        .filter(|(_, f)| !matches!(f.name(), "C_1" | "C_2"))
                        .max_by(|a, b| cov.weakest[a.0].abs().total_cmp(&cov.weakest[b.0].abs()))
                        .filter(|(j, _)| cov.weakest[*j].abs() > 0.1)
                        .map(|(j, _)| j)
                };
                if let Some(j) = pick(true).or_else(|| pick(false)) {
                    let f = free.remove(j);
                    auto_fixed.push(AutoFix {
                        name: f.name().to_string(),
                        value: params::get(prior, f.name()),
                        cond: cov.cond_scaled,
                    });
                    pb.inc_length(cfg.starts as u64);
                    continue;
                }
            }
        }
        let estimates = estimates(&free, &m, prior, &cov);
        return (
            m,
            SteadyFit {
                free,
                estimates,
                cov,
                cov_initial,
                runs,
                auto_fixed,
                policy: cfg.collinear,
                boot_ok: 0,
            },
        );
    }
}

fn rms_axes(res: &[f64], sd: [f64; 2]) -> [f64; 2] {
    let mut s = [0.0; 2];
    for (i, r) in res.iter().enumerate() {
        s[i % 2] += (r * sd[i % 2]).powi(2);
    }
    let n = (res.len() / 2).max(1) as f64;
    [(s[0] / n).sqrt(), (s[1] / n).sqrt()]
}

/// Smallest RMS (in repeat SDs) of the modelled transient over the transient rows for the
/// ODE fit to be attempted.
pub const MIN_TRANSIENT_SIGNAL: f64 = 0.5;

/// Per-row noise SD per axis for the transient fit.
fn sd_rows(w: &Weighting) -> [f64; 2] {
    if w.from_repeats {
        [w.pooled_sd[0].max(1e-3), w.pooled_sd[1].max(1e-3)]
    } else {
        [1.0; 2]
    }
}

/// RMS over the transient rows of (replay - steady map) / sd: how much transient the model
/// shows where the data are.
fn transient_signal(m: &Model, trans: &[dynfit::TransientSession], sd: [f64; 2]) -> f64 {
    let (mut ss, mut n) = (0.0, 0usize);
    for s in trans {
        let Ok(pred) = crate::predict::replay(m, &s.inputs, 1e-6) else {
            return f64::INFINITY;
        };
        for &(i, _) in &s.targets {
            let inp = s.inputs[i];
            let r = fit::predict_point(m, inp.z_mm, inp.f_hz);
            for a in 0..2 {
                ss += ((pred[i][a] - r[a]) / sd[a]).powi(2);
                n += 1;
            }
        }
    }
    (ss / n.max(1) as f64).sqrt()
}

/// Measured and replayed radii around the largest input change (by the change of the steady
/// map) of the session with the most transient rows: 10 s before to 8 time constants after.
fn transient_trace(m: &Model, sessions: &[data::Session]) -> Option<Vec<TracePoint>> {
    let s = sessions.iter().max_by_key(|s| {
        s.rows
            .iter()
            .filter(|r| r.r.is_some() && !r.settled)
            .count()
    })?;
    let rows: Vec<crate::predict::InputRow> = s
        .rows
        .iter()
        .map(|r| crate::predict::InputRow {
            t: r.t,
            z_mm: r.z_mm,
            f_hz: r.f_hz,
        })
        .collect();
    let pred = crate::predict::replay(m, &rows, 1e-6).ok()?;
    let (mut best, mut jump) = (None, 0.0);
    for k in 1..rows.len() {
        if s.rows[k].visit != s.rows[k - 1].visit {
            let a = fit::predict_point(m, rows[k - 1].z_mm, rows[k - 1].f_hz);
            let b = fit::predict_point(m, rows[k].z_mm, rows[k].f_hz);
            let d = (a[0] - b[0]).abs() + (a[1] - b[1]).abs();
            if d > jump {
                jump = d;
                best = Some(k);
            }
        }
    }
    let k = best?;
    let t_c = rows[k - 1].t;
    let tau = data::time_constant(m, rows[k].z_mm, rows[k].f_hz);
    let t_end = t_c + (8.0 * tau).clamp(5.0, 120.0);
    Some(
        s.rows
            .iter()
            .zip(pred)
            .filter(|(r, _)| r.t >= t_c - 10.0 && r.t <= t_end)
            .map(|(r, p)| (r.t, p, r.r))
            .collect(),
    )
}

/// Identify a model from parsed logs.
pub fn identify(logs: &[Log], prior: &Model, cfg: &Config) -> Result<Identification> {
    let t0 = Instant::now();
    let (free_st, free_dy) = cfg.resolve()?;
    for l in logs {
        if !l.has_radii() {
            bail!(
                "{}: no r1_mm, r2_mm columns: identify needs measured radii",
                l.source
            );
        }
    }
    let mut sessions = data::sessions(logs);
    data::classify(&mut sessions, cfg.settle, prior);
    let count = |sessions: &[data::Session]| {
        let mut c = Counts {
            sessions: sessions.len(),
            ..Counts::default()
        };
        for s in sessions {
            c.visits += s.rows.last().map(|r| r.visit + 1).unwrap_or(0);
            for r in &s.rows {
                c.rows += 1;
                match (r.r, r.settled) {
                    (None, _) => c.invalid += 1,
                    (Some(_), true) => c.settled += 1,
                    (Some(_), false) => c.transient += 1,
                }
            }
        }
        c
    };
    let mut counts = count(&sessions);
    if counts.rows == counts.invalid {
        bail!(
            "no usable rows: {} row(s), none valid with radii",
            counts.rows
        );
    }
    let split = |all: Vec<OpPoint>| -> (Vec<OpPoint>, Vec<OpPoint>) {
        if cfg.withhold_every == 0 {
            return (all, Vec::new());
        }
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for (i, p) in all.into_iter().enumerate() {
            if (i + 1) % cfg.withhold_every == 0 {
                b.push(p);
            } else {
                a.push(p);
            }
        }
        (a, b)
    };
    let (mut points, mut withheld) = split(data::op_points(&sessions));
    counts.points = points.len() + withheld.len();
    check_identifiable(&points, &free_st, &counts)?;
    let mut weighting = data::assign_weights(&mut points);
    for w in withheld.iter_mut() {
        // Withheld points are weighted like the fitted ones (pooled SD) for reporting only.
        w.se = [1.0; 2];
    }

    let pb = progress_bar(
        cfg.progress,
        (cfg.starts + cfg.bootstrap) as u64,
        "identify",
    );
    let (mut model, mut sfit) = steady_fit(prior, free_st.clone(), &points, cfg, &pb);

    // Dynamics.
    let mut dynamics = None;
    let dynamics_note;
    let trans = dynfit::transients(&sessions);
    let n_trans: usize = trans.iter().map(|t| t.targets.len()).sum();
    if !cfg.dynamics {
        dynamics_note = "not fitted (--no-dynamics): the prior model's ODE (4) kept".into();
    } else if free_dy.is_empty() {
        dynamics_note = "not fitted: no free dynamic parameter".into();
    } else if n_trans < 2 * free_dy.len() + 2 {
        dynamics_note = format!(
            "not fitted: {n_trans} transient row(s) after input changes (need at least {}); \
             the prior model's ODE (4) time scales kept",
            2 * free_dy.len() + 2
        );
    } else if transient_signal(&model, &trans, sd_rows(&weighting)) < MIN_TRANSIENT_SIGNAL {
        dynamics_note = format!(
            "not fitted: the {n_trans} transient row(s) after input changes lie where the \
             model's transient has already decayed (RMS of replay minus steady map below {} \
             repeat SD), so they carry no information on the time scales; the prior model's \
             ODE (4) kept",
            MIN_TRANSIENT_SIGNAL
        );
    } else {
        let sd = sd_rows(&weighting);
        let before = rms_axes(&dynfit::residuals(&model, &trans, sd), sd);
        let (m2, run, cov) = dynfit::fit(&model, &free_dy, &trans, sd);
        let after = rms_axes(&dynfit::residuals(&m2, &trans, sd), sd);
        let estimates = estimates(&free_dy, &m2, prior, &cov);
        model = m2;
        dynamics = Some(DynFit {
            estimates,
            cov,
            run,
            rows: n_trans,
            rms_before: before,
            rms_after: after,
        });
        // Redo the settle split with the fitted time constants.
        let old: Vec<bool> = sessions
            .iter()
            .flat_map(|s| s.rows.iter().map(|r| r.settled))
            .collect();
        data::classify(&mut sessions, cfg.settle, &model);
        let new: Vec<bool> = sessions
            .iter()
            .flat_map(|s| s.rows.iter().map(|r| r.settled))
            .collect();
        if old != new {
            let (p2, w2) = split(data::op_points(&sessions));
            let mut p2 = p2;
            if check_identifiable(&p2, &sfit.free, &count(&sessions)).is_ok() {
                weighting = data::assign_weights(&mut p2);
                points = p2;
                withheld = w2;
                for w in withheld.iter_mut() {
                    w.se = [1.0; 2];
                }
                counts = count(&sessions);
                counts.points = points.len() + withheld.len();
                let cfg1 = Config {
                    starts: 1,
                    ..cfg.clone()
                };
                let free_now = sfit.free.clone();
                let auto = std::mem::take(&mut sfit.auto_fixed);
                let initial = sfit.cov_initial.take();
                let (m3, mut s3) = steady_fit(&model, free_now, &points, &cfg1, &pb);
                s3.auto_fixed = auto;
                s3.cov_initial = initial;
                // Keep the priors of the estimates as the original prior.
                for e in s3.estimates.iter_mut() {
                    e.prior = params::get(prior, &e.name);
                }
                model = m3;
                sfit = s3;
            }
        }
        dynamics_note = format!(
            "fitted to {n_trans} transient row(s); the settle split was {}",
            if old != new {
                "redone with the fitted time constants and the steady fit repeated"
            } else {
                "unchanged by the fitted time constants"
            }
        );
    }

    let trace = if dynamics.is_some() {
        transient_trace(&model, &sessions)
    } else {
        None
    };

    // Bootstrap over operating points.
    if cfg.bootstrap > 0 {
        let ridge = ridge_for(&sfit.free, prior, cfg.collinear);
        let (stats, ok) = fit::bootstrap(
            &model,
            &sfit.free,
            &points,
            ridge.as_ref(),
            cfg.bootstrap,
            cfg.seed.wrapping_mul(0x9E37_79B9),
            &pb,
        );
        for (e, s) in sfit.estimates.iter_mut().zip(stats) {
            e.boot = Some(s);
        }
        sfit.boot_ok = ok;
    }
    pb.finish_and_clear();

    let train = errors(&model, &points);
    let heldout = (!withheld.is_empty()).then(|| errors(&model, &withheld));
    let mut sx: Vec<f64> = Vec::new();
    let mut sy: Vec<f64> = Vec::new();
    for p in &points {
        let sp = steady::evaluate(&model, p.z_mm * 1e-3, hz_to_rad_s(p.f_hz));
        sx.push(sp.s_x);
        sy.push(sp.s_y);
    }
    let median_s = [data::median_mad(&sx).0, data::median_mad(&sy).0];
    let sources: Vec<String> = logs.iter().map(|l| l.source.clone()).collect();
    model.name = if prior.name.is_empty() {
        "identified".into()
    } else {
        format!("{}-identified", prior.name)
    };
    model.provenance = format!(
        "magswarm identify {} from {} ({} operating points, {} settled + {} transient rows); \
         free: {}; auto-fixed: {}; dynamics: {}; prior: {}; RMSE r1 {:.3} mm, r2 {:.3} mm",
        env!("CARGO_PKG_VERSION"),
        sources.join(", "),
        points.len(),
        counts.settled,
        counts.transient,
        sfit.free
            .iter()
            .map(|f| f.name())
            .chain(
                dynamics
                    .iter()
                    .flat_map(|d| d.estimates.iter().map(|e| e.name.as_str()))
            )
            .collect::<Vec<_>>()
            .join(","),
        if sfit.auto_fixed.is_empty() {
            "none".to_string()
        } else {
            sfit.auto_fixed
                .iter()
                .map(|a| a.name.clone())
                .collect::<Vec<_>>()
                .join(",")
        },
        if dynamics.is_some() {
            "fitted"
        } else {
            "prior"
        },
        prior.name,
        train.rmse[0],
        train.rmse[1]
    );
    model
        .validate()
        .context("the identified model does not validate")?;
    Ok(Identification {
        model,
        prior: prior.clone(),
        points,
        withheld,
        weighting,
        steady: sfit,
        dynamics,
        dynamics_note,
        train,
        heldout,
        median_s,
        counts,
        settle: cfg.settle,
        elapsed: t0.elapsed(),
        sources,
        trace,
    })
}

/// Run the command.
pub fn run(a: &IdentifyArgs) -> Result<()> {
    let cfg = Config::from_args(a)?;
    let prior = match &a.model {
        Some(p) => Model::load(p)?,
        None => Model::paper(),
    };
    let mut logs = Vec::new();
    for p in &a.log {
        let l = Log::read_with(p, ReadOptions { lenient: a.lenient })?;
        for s in &l.skipped {
            eprintln!("identify: warning: {}: skipped {s}", l.source);
        }
        logs.push(l);
    }
    let id = identify(&logs, &prior, &cfg)?;
    id.model
        .save(&a.out)
        .with_context(|| format!("cannot save {}", a.out.display()))?;
    eprint!("{}", report::summary(&id));
    if let Some(dir) = &a.report {
        report::write(&id, dir)?;
        eprintln!(
            "identify: report written to {}",
            dir.join("report.md").display()
        );
    }
    eprintln!("identify: model written to {}", a.out.display());
    Ok(())
}
