//! Steps 2, 3 and 5 of the pipeline: the multi-start steady-map fit under the collinearity
//! policy (auto-fix or ridge), the estimates with their intervals, and the bootstrap over
//! operating points into them. The LM problem itself is [`super::fit`].

use super::config::{Collinear, Config};
use super::data::OpPoint;
use super::fit::{self, Ridge, Run};
use super::params::{self, Free};
use super::result::{AutoFix, Estimate, SteadyFit};
use super::uncertainty;
use crate::Progress;
use magswarm_model::Model;

/// Estimates of the free parameters of a fitted model, with 95 % intervals from the
/// Jacobian covariance (Student t on the fit's degrees of freedom).
pub(super) fn estimates(
    free: &[Free],
    fitted: &Model,
    prior: &Model,
    cov: &uncertainty::Covariance,
) -> Vec<Estimate> {
    let t = uncertainty::t975(cov.dof);
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

/// Multi-start fit of `free` on `points`; runs sorted best first.
pub(super) fn multi_start(
    prior: &Model,
    free: &[Free],
    points: &[OpPoint],
    ridge: Option<&Ridge>,
    cfg: &Config,
    pb: &dyn Progress,
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

pub(super) fn ridge_for(free: &[Free], prior: &Model, policy: Collinear) -> Option<Ridge> {
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
pub(super) fn steady_fit(
    prior: &Model,
    mut free: Vec<Free>,
    points: &[OpPoint],
    cfg: &Config,
    pb: &dyn Progress,
) -> (Model, SteadyFit) {
    let mut auto_fixed = Vec::new();
    let mut cov_initial = None;
    loop {
        let ridge = ridge_for(&free, prior, cfg.collinear);
        let (m, runs) = multi_start(prior, &free, points, ridge.as_ref(), cfg, pb);
        let cov = uncertainty::covariance(&m, &free, points, ridge.as_ref());
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
                    pb.add_total(cfg.starts as u64);
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

/// Step 5: bootstrap over operating points into the estimates.
pub(super) fn bootstrap_step(
    model: &Model,
    sfit: &mut SteadyFit,
    points: &[OpPoint],
    prior: &Model,
    cfg: &Config,
    pb: &dyn Progress,
) {
    if cfg.bootstrap == 0 {
        return;
    }
    let ridge = ridge_for(&sfit.free, prior, cfg.collinear);
    let (stats, ok) = uncertainty::bootstrap(
        model,
        &sfit.free,
        points,
        ridge.as_ref(),
        cfg.bootstrap,
        cfg.seed.wrapping_mul(0x9E37_79B9),
        pb,
    );
    for (e, s) in sfit.estimates.iter_mut().zip(stats) {
        e.boot = Some(s);
    }
    sfit.boot_ok = ok;
}
