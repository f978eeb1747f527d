//! Fit the plant to measured logs (`magswarm identify`), with uncertainty and
//! identifiability, and replay logs through a model ([`predict`], `magswarm predict`).
//!
//! The public face is [`identify()`] with its [`Config`] and the [`Identification`] it
//! returns; [`data`] (sessions, visits, the settle rule), [`params`] (the fittable registry
//! rows and their transforms), [`predict_point`] / [`predict_mean`] (the observed steady map a
//! fit compares with) and [`predict`] are what other fits (diagnose) build on. The option names
//! below (`--free`, ...) are the command's; the library takes them as [`Config`] fields.
//!
//! The pipeline (each step documented in its module):
//!
//! 1. [`data`]: logs -> sessions -> visits (runs of constant commanded inputs); settled rows
//!    (the settle rule: `--settle-s`, or `--settle-factor` x the model's slowest time constant
//!    at the visit's inputs) vs transient rows; operating points with mean, repeat SD, MAD;
//!    weights from the repeat variance (shrunk toward the pooled variance).
//! 2. [`fit`]: bounded Levenberg-Marquardt on the free steady-map parameters (default
//!    [`params::DEFAULT_FREE_STEADY`]; `--free` / `--fix` / `--bound` change it), from several
//!    starts; Jacobian covariance scaled by the reduced chi^2; t-based 95 % CIs. The model
//!    side is the observed steady map: the prior's effects act (drift at each row's session
//!    time, camera terms on the reading), and freed parameters of effects that act at steady
//!    state are fitted here ([`fits_steady`]).
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
//!    (crate `magswarm-report`).
//!
//! The prior model (`--model`, default the paper model) supplies the start, every fixed
//! parameter, the conventions, the magnet geometry and the dynamics not fitted.

mod config;
pub mod data;
pub mod dynfit;
mod error;
pub mod fit;
pub mod params;
pub mod predict;
mod prepare;
mod progress;
mod result;
mod steady_fit;
mod transient;
mod uncertainty;

pub use config::{fits_steady, unknown_parameter, Collinear, Config};
pub use error::{IdentifyError, PredictError};
pub use fit::{predict_mean, predict_point, predict_point_at};
pub use progress::{Progress, Silent};
pub use result::{
    errors, AutoFix, Counts, DynFit, Errors, Estimate, Identification, Predictions, SteadyFit,
    TracePoint,
};
pub use transient::MIN_TRANSIENT_SIGNAL;

use magswarm_log::Log;
use magswarm_model::Model;
use prepare::{check_identifiable, prepare, Prepared};
use result::errors_of;
use std::time::Instant;
use steady_fit::{bootstrap_step, steady_fit};
use transient::{dynamics_step, transient_trace};

/// Identify a model from parsed logs: the steps of the module docs, each in its function.
pub fn identify(
    logs: &[Log],
    prior: &Model,
    cfg: &Config,
) -> Result<Identification, IdentifyError> {
    identify_with_progress(logs, prior, cfg, &Silent)
}

/// [`identify`], reporting its progress (LM starts and bootstrap replicates) to `progress`.
pub fn identify_with_progress(
    logs: &[Log],
    prior: &Model,
    cfg: &Config,
    progress: &dyn Progress,
) -> Result<Identification, IdentifyError> {
    let t0 = Instant::now();
    let (free_st, free_dy) = cfg.resolve()?;
    for l in logs {
        if !l.has_radii() {
            return Err(IdentifyError::NoRadii {
                log: l.source.clone(),
            });
        }
    }
    // 1. Sessions, visits, settled rows, points.
    let mut sessions = data::sessions(logs);
    data::classify(&mut sessions, cfg.settle, prior);
    let mut prep = prepare(&sessions, cfg.withhold_every);
    let counts = prep.counts;
    if counts.rows == counts.invalid {
        return Err(IdentifyError::NoUsableRows { rows: counts.rows });
    }
    check_identifiable(&prep.points, &free_st, &counts)?;
    let pb = progress;
    pb.start((cfg.starts + cfg.bootstrap) as u64);
    // 2-3. Steady fit with the collinearity policy.
    let (mut model, mut sfit) = steady_fit(prior, free_st, &prep.points, cfg, pb);
    // 4. Dynamics (and the settle split redone).
    let (dynamics, dynamics_note) = dynamics_step(
        &mut sessions,
        &mut model,
        &mut sfit,
        &mut prep,
        prior,
        &free_dy,
        cfg,
        pb,
    );
    let trace = dynamics
        .as_ref()
        .and_then(|_| transient_trace(&model, &sessions));
    // 5. Bootstrap.
    bootstrap_step(&model, &mut sfit, &prep.points, prior, cfg, pb);
    pb.finish();
    // 6. Figures of merit (from predictions computed once) and the model file's provenance.
    let pred = Predictions::of(&model, &prep.points, &prep.withheld);
    let train = errors_of(&pred.points, &prep.points);
    let heldout = (!prep.withheld.is_empty()).then(|| errors_of(&pred.withheld, &prep.withheld));
    let sx: Vec<f64> = pred.stiffness.iter().map(|s| s[0]).collect();
    let sy: Vec<f64> = pred.stiffness.iter().map(|s| s[1]).collect();
    let median_s = [data::median_mad(&sx).0, data::median_mad(&sy).0];
    let sources: Vec<String> = logs.iter().map(|l| l.source.clone()).collect();
    model.name = if prior.name.is_empty() {
        "identified".into()
    } else {
        format!("{}-identified", prior.name)
    };
    model.provenance = provenance(&sources, &prep, &sfit, dynamics.as_ref(), prior, &train);
    model.validate().map_err(IdentifyError::Invalid)?;
    Ok(Identification {
        model,
        prior: prior.clone(),
        points: prep.points,
        withheld: prep.withheld,
        weighting: prep.weighting,
        steady: sfit,
        dynamics,
        dynamics_note,
        train,
        heldout,
        median_s,
        counts: prep.counts,
        settle: cfg.settle,
        elapsed: t0.elapsed(),
        sources,
        trace,
        pred,
    })
}

/// The provenance line of an identified model.
fn provenance(
    sources: &[String],
    prep: &Prepared,
    sfit: &SteadyFit,
    dynamics: Option<&DynFit>,
    prior: &Model,
    train: &Errors,
) -> String {
    let free: Vec<&str> = sfit
        .free
        .iter()
        .map(|f| f.name())
        .chain(
            dynamics
                .iter()
                .flat_map(|d| d.estimates.iter().map(|e| e.name.as_str())),
        )
        .collect();
    let fixed: Vec<&str> = sfit.auto_fixed.iter().map(|a| a.name.as_str()).collect();
    format!(
        "magswarm identify {} from {} ({} operating points, {} settled + {} transient rows); \
         free: {}; auto-fixed: {}; dynamics: {}; prior: {}; RMSE r1 {:.3} mm, r2 {:.3} mm",
        env!("CARGO_PKG_VERSION"),
        sources.join(", "),
        prep.points.len(),
        prep.counts.settled,
        prep.counts.transient,
        free.join(","),
        if fixed.is_empty() {
            "none".to_string()
        } else {
            fixed.join(",")
        },
        if dynamics.is_some() {
            "fitted"
        } else {
            "prior"
        },
        prior.name,
        train.rmse[0],
        train.rmse[1]
    )
}
