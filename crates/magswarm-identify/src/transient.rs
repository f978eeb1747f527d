//! Step 4 of the pipeline: the ODE (4) time scales from the transient rows (when the log holds
//! transients that carry information), the settle split redone with the fitted time
//! constants, and the transient trace the report plots.

use super::config::Config;
use super::data::{self, Weighting};
use super::dynfit;
use super::fit;
use super::params::{self, Free};
use super::prepare::{check_identifiable, prepare, Prepared};
use super::result::{DynFit, SteadyFit, TracePoint};
use super::steady_fit::{estimates, steady_fit};
use crate::Progress;
use magswarm_model::Model;

pub(super) fn rms_axes(res: &[f64], sd: [f64; 2]) -> [f64; 2] {
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
pub(super) fn sd_rows(w: &Weighting) -> [f64; 2] {
    if w.from_repeats {
        [w.pooled_sd[0].max(1e-3), w.pooled_sd[1].max(1e-3)]
    } else {
        [1.0; 2]
    }
}

/// RMS over the transient rows of (replay - steady map) / sd: how much transient the model
/// shows where the data are.
pub(super) fn transient_signal(m: &Model, trans: &[dynfit::TransientSession], sd: [f64; 2]) -> f64 {
    let (mut ss, mut n) = (0.0, 0usize);
    for s in trans {
        let Ok(pred) = crate::predict::replay(m, &s.inputs, 1e-6) else {
            return f64::INFINITY;
        };
        for &(i, _) in &s.targets {
            let inp = s.inputs[i];
            let r = fit::predict_point_at(m, inp.z_mm, inp.f_hz, inp.t);
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
pub(super) fn transient_trace(m: &Model, sessions: &[data::Session]) -> Option<Vec<TracePoint>> {
    let s = sessions.iter().max_by_key(|s| {
        s.rows
            .iter()
            .filter(|r| r.r.is_some() && !r.settled)
            .count()
    })?;
    let rows: Vec<crate::predict::InputRow> = s.rows.iter().map(data::Row::input).collect();
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

/// Why the dynamics cannot be fitted from these transients (None: they can).
pub(super) fn dynamics_refusal(
    cfg: &Config,
    free_dy: &[Free],
    model: &Model,
    trans: &[dynfit::TransientSession],
    weighting: &Weighting,
) -> Option<String> {
    let n_trans: usize = trans.iter().map(|t| t.targets.len()).sum();
    if !cfg.dynamics {
        Some("not fitted (--no-dynamics): the prior model's ODE (4) kept".into())
    } else if free_dy.is_empty() {
        Some("not fitted: no free dynamic parameter".into())
    } else if n_trans < 2 * free_dy.len() + 2 {
        Some(format!(
            "not fitted: {n_trans} transient row(s) after input changes (need at least {}); \
             the prior model's ODE (4) time scales kept",
            2 * free_dy.len() + 2
        ))
    } else if transient_signal(model, trans, sd_rows(weighting)) < MIN_TRANSIENT_SIGNAL {
        Some(format!(
            "not fitted: the {n_trans} transient row(s) after input changes lie where the \
             model's transient has already decayed (RMS of replay minus steady map below {} \
             repeat SD), so they carry no information on the time scales; the prior model's \
             ODE (4) kept",
            MIN_TRANSIENT_SIGNAL
        ))
    } else {
        None
    }
}

/// Step 4: fit the ODE time scales to the transients; with the fitted time constants redo
/// the settle split and, where it changed, the steady fit (one start from the solution).
/// Returns the dynamic fit and its note; `model`, `sfit`, `sessions` and `prep` are updated.
#[allow(clippy::too_many_arguments)]
pub(super) fn dynamics_step(
    sessions: &mut [data::Session],
    model: &mut Model,
    sfit: &mut SteadyFit,
    prep: &mut Prepared,
    prior: &Model,
    free_dy: &[Free],
    cfg: &Config,
    pb: &dyn Progress,
) -> (Option<DynFit>, String) {
    let trans = dynfit::transients(sessions);
    if let Some(note) = dynamics_refusal(cfg, free_dy, model, &trans, &prep.weighting) {
        return (None, note);
    }
    let n_trans: usize = trans.iter().map(|t| t.targets.len()).sum();
    let sd = sd_rows(&prep.weighting);
    let before = rms_axes(&dynfit::residuals(model, &trans, sd), sd);
    let (m2, run, cov) = dynfit::fit(model, free_dy, &trans, sd);
    let after = rms_axes(&dynfit::residuals(&m2, &trans, sd), sd);
    let dynamics = DynFit {
        estimates: estimates(free_dy, &m2, prior, &cov),
        cov,
        run,
        rows: n_trans,
        rms_before: before,
        rms_after: after,
    };
    *model = m2;
    let settled = |s: &[data::Session]| -> Vec<bool> {
        s.iter()
            .flat_map(|s| s.rows.iter().map(|r| r.settled))
            .collect()
    };
    let old = settled(sessions);
    data::classify(sessions, cfg.settle, model);
    let changed = old != settled(sessions);
    if changed {
        let p2 = prepare(sessions, cfg.withhold_every);
        if check_identifiable(&p2.points, &sfit.free, &p2.counts).is_ok() {
            *prep = p2;
            let cfg1 = Config {
                starts: 1,
                ..cfg.clone()
            };
            let (m3, mut s3) = steady_fit(model, sfit.free.clone(), &prep.points, &cfg1, pb);
            s3.auto_fixed = std::mem::take(&mut sfit.auto_fixed);
            s3.cov_initial = sfit.cov_initial.take();
            // Keep the priors of the estimates as the original prior.
            for e in s3.estimates.iter_mut() {
                e.prior = params::get(prior, &e.name);
            }
            *model = m3;
            *sfit = s3;
        }
    }
    let note = format!(
        "fitted to {n_trans} transient row(s); the settle split was {}",
        if changed {
            "redone with the fitted time constants and the steady fit repeated"
        } else {
            "unchanged by the fitted time constants"
        }
    );
    (Some(dynamics), note)
}
