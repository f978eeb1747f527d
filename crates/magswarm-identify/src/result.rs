//! What an identification produces: estimates, the steady and dynamic fits, counts, and the
//! predictions of the identified model at the points, computed once so that the figures of
//! merit and the report read the same numbers.

use super::config::Collinear;
use super::data::{OpPoint, SettleRule, Weighting};
use super::fit::{self, Run};
use super::params::Free;
use super::uncertainty::{BootStat, Covariance};
use magswarm_model::{hz_to_rad_s, steady, Model};
use std::time::Duration;

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
    /// RMS of the transient residuals \[mm\] per axis, with the prior dynamics and fitted.
    pub rms_before: [f64; 2],
    /// After the fit.
    pub rms_after: [f64; 2],
}

/// Error figures of a model on a set of points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Errors {
    /// RMSE of the point means \[mm\].
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

/// (t \[s\], replayed radii \[mm\], measured radii \[mm\]) of the report's transient plot.
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
    /// Predictions of the identified model at the points (computed once).
    pub pred: Predictions,
}

/// Predictions of the identified model, computed once (errors, medians and the report all
/// read them).
#[derive(Debug, Clone, PartialEq)]
pub struct Predictions {
    /// Steady radii at the fitted points \[mm\] (same order as `Identification::points`).
    pub points: Vec<[f64; 2]>,
    /// Steady radii at the withheld points \[mm\].
    pub withheld: Vec<[f64; 2]>,
    /// (S_x, S_y) at the fitted points.
    pub stiffness: Vec<[f64; 2]>,
}

impl Predictions {
    pub(super) fn of(m: &Model, points: &[OpPoint], withheld: &[OpPoint]) -> Predictions {
        let r = |ps: &[OpPoint]| -> Vec<[f64; 2]> {
            ps.iter().map(|p| fit::predict_mean(m, p)).collect()
        };
        Predictions {
            points: r(points),
            withheld: r(withheld),
            stiffness: points
                .iter()
                .map(|p| {
                    let sp = steady::evaluate(m, p.z_mm * 1e-3, hz_to_rad_s(p.f_hz));
                    [sp.s_x, sp.s_y]
                })
                .collect(),
        }
    }
}

/// Error figures of `m` on `points`.
pub fn errors(m: &Model, points: &[OpPoint]) -> Errors {
    let pred: Vec<[f64; 2]> = points.iter().map(|p| fit::predict_mean(m, p)).collect();
    errors_of(&pred, points)
}

/// Error figures of predictions against point means.
pub(super) fn errors_of(pred: &[[f64; 2]], points: &[OpPoint]) -> Errors {
    let mut se = [0.0; 2];
    let mut ae = [0.0; 2];
    for (r, p) in pred.iter().zip(points) {
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
