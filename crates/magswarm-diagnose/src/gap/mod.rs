//! Is there a gap, and where: lack of fit against the pure error of the repeats, residual
//! structure over the inputs and over time, and the regions where it lies.
//!
//! Residuals are *measured minus model* \[mm\]. The unit of every test is the visit (rows of one
//! visit share a visit-to-visit error and are not independent):
//!
//! - **lack of fit** (reported; in the decision only when the pure error comes from repeat
//!   visits): F = (SS_lof / (m - p)) / (SS_pe / dof_pe) per axis, SS_lof from the point means,
//!   SS_pe from the repeats. With one visit per point the pure error of the rows within a visit
//!   cannot see the visit-to-visit error, and F would call that error a gap;
//! - **structure over (z_m, f)**: a leave-one-out kernel smoother of the visit residuals over
//!   the normalised inputs; statistic = share of the residual variance it predicts, best of two
//!   bandwidths; p-value by permutation of the residuals over the visits (no assumption on the
//!   noise level);
//! - **structure over session time** (drift): |correlation| of the visit residuals with
//!   session time and its square, by the same permutations;
//! - **structure over time since the input change** (formation): within each visit, the mean
//!   residual of its first half minus its second half, signed against the direction of the
//!   model's change from the previous visit (a lag makes the early rows stay behind); a
//!   t test over visits (the visit's own offset cancels).
//!
//! The gap is significant when the smallest of these family p-values, Bonferroni-corrected
//! for the number of families, is below alpha. Regions are then searched only within the
//! families that are significant: contiguous boxes of input levels (and of session time),
//! each tested by its mean visit residual against a robust visit-level SD, with
//! Benjamini-Hochberg control over all boxes; the strongest non-overlapping boxes are kept,
//! trimmed of edge slices that carry no residual, and reported with a p-value corrected for
//! the number of boxes searched.
//!
//! This module holds the tests; `regions.rs` the localisation.

use super::data::{Dataset, PureError};
use super::stats;
use rand::{seq::SliceRandom, SeedableRng};

mod regions;
/// Kept at these paths for the report and the tests.
pub use super::data::{level_bins, visit_residuals, VisitRes};
pub use regions::*;

/// Lack-of-fit test of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lof {
    /// F statistic.
    pub f: f64,
    /// Degrees of freedom (lack of fit, pure error).
    pub dof: (f64, f64),
    /// p-value.
    pub p: f64,
}

/// The family tests.
#[derive(Debug, Clone, PartialEq)]
pub struct GapTests {
    /// Lack of fit per axis.
    pub lof: [Lof; 2],
    /// The pure error is from repeat visits (then the lack of fit is in the decision).
    pub lof_from_visits: bool,
    /// Structure over (z_m, f): p per axis.
    pub space_p: [f64; 2],
    /// Drift over session time: p per axis.
    pub drift_p: [f64; 2],
    /// Formation after input changes: p per axis (1 when untestable).
    pub trans_p: [f64; 2],
    /// Visits that entered the formation test.
    pub trans_visits: usize,
    /// Combined p-value (Bonferroni over families and axes).
    pub p_value: f64,
    /// Significant at alpha.
    pub significant: bool,
    /// Families significant at alpha after correction: "lack_of_fit", "inputs", "drift",
    /// "formation".
    pub families: Vec<&'static str>,
    /// Robust SD of a visit residual around the smooth structure, per axis \[mm\].
    pub visit_sd: [f64; 2],
}

/// Normalised (z, f) coordinates of the visits.
pub fn coords(ds: &Dataset) -> Vec<[f64; 2]> {
    let (zs, fs) = ds.levels();
    let span = |v: &[f64]| (v.last().unwrap_or(&1.0) - v.first().unwrap_or(&0.0)).max(1e-9);
    let (z0, zspan, f0, fspan) = (
        zs.first().copied().unwrap_or(0.0),
        span(&zs),
        fs.first().copied().unwrap_or(0.0),
        span(&fs),
    );
    ds.visits
        .iter()
        .map(|v| {
            let (z, f) = ds.points[v.point];
            [(z - z0) / zspan, (f - f0) / fspan]
        })
        .collect()
}

/// Leave-one-out Nadaraya-Watson predictions of `y` at each `x` (Gaussian kernel, bandwidth h).
pub fn loo_smooth(x: &[[f64; 2]], y: &[f64], h: f64) -> Vec<f64> {
    let n = x.len();
    let mut out = vec![0.0; n];
    for i in 0..n {
        let (mut sw, mut swy) = (0.0, 0.0);
        for j in 0..n {
            if j == i {
                continue;
            }
            let d2 = (x[i][0] - x[j][0]).powi(2) + (x[i][1] - x[j][1]).powi(2);
            let w = (-d2 / (2.0 * h * h)).exp();
            sw += w;
            swy += w * y[j];
        }
        out[i] = if sw > 1e-12 { swy / sw } else { 0.0 };
    }
    out
}

const BANDWIDTHS: [f64; 2] = [0.12, 0.25];

/// Leave-one-out kernel weights (row-normalised, zero diagonal) for each bandwidth.
fn loo_weights(x: &[[f64; 2]]) -> Vec<Vec<f64>> {
    let n = x.len();
    BANDWIDTHS
        .iter()
        .map(|&h| {
            let mut w = vec![0.0; n * n];
            for i in 0..n {
                let mut s = 0.0;
                for j in 0..n {
                    if j != i {
                        let d2 = (x[i][0] - x[j][0]).powi(2) + (x[i][1] - x[j][1]).powi(2);
                        w[i * n + j] = (-d2 / (2.0 * h * h)).exp();
                        s += w[i * n + j];
                    }
                }
                if s > 1e-12 {
                    for j in 0..n {
                        w[i * n + j] /= s;
                    }
                }
            }
            w
        })
        .collect()
}

fn space_stat(w: &[Vec<f64>], y: &[f64]) -> f64 {
    let n = y.len();
    let m = stats::mean(y);
    let tot: f64 = y.iter().map(|v| (v - m).powi(2)).sum::<f64>().max(1e-300);
    w.iter()
        .map(|wk| {
            let mut sse = 0.0;
            for i in 0..n {
                let s: f64 = (0..n).map(|j| wk[i * n + j] * (y[j] - m)).sum();
                sse += (y[i] - m - s).powi(2);
            }
            1.0 - sse / tot
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Permutation p-value: the empirical (1 + #{perm >= obs}) / (1 + B); where no permutation
/// reaches the observed value, the tail of a normal fitted to the permutation distribution
/// (never above the empirical bound), so that a strong structure is not capped at 1 / (1 + B).
fn perm_p(obs: f64, perm: &[f64]) -> f64 {
    let b = perm.len();
    let ge = perm.iter().filter(|&&v| v >= obs).count();
    let emp = (1 + ge) as f64 / (1 + b) as f64;
    if ge > 0 || b < 20 {
        return emp;
    }
    let m = stats::mean(perm);
    let sd = (perm.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (b - 1) as f64).sqrt();
    if sd <= 0.0 {
        return emp;
    }
    (stats::z_two_sided((obs - m) / sd) / 2.0).min(emp)
}

fn drift_stat(t: &[f64], y: &[f64]) -> f64 {
    let tm = stats::mean(t);
    let t2: Vec<f64> = t.iter().map(|v| (v - tm).powi(2)).collect();
    stats::corr(t, y).abs().max(stats::corr(&t2, y).abs())
}

/// Run the family tests. `n_free` is the number of free steady parameters of the baseline.
#[allow(clippy::too_many_arguments)]
pub fn tests(
    ds: &Dataset,
    res: &[[f64; 2]],
    pe: &PureError,
    base_map: &[[f64; 2]],
    n_free: usize,
    alpha: f64,
    perms: usize,
    seed: u64,
) -> GapTests {
    let vr = visit_residuals(ds, res);
    let nv = ds.visits.len();
    let x = coords(ds);
    let wts = loo_weights(&x);
    let t: Vec<f64> = ds.visits.iter().map(|v| v.t_mid).collect();
    let lof_from_visits = pe.between_dof >= 5 && pe.repeat_points >= 3;
    let p_ax = n_free.div_ceil(2) as f64;
    let mut lof = [Lof {
        f: f64::NAN,
        dof: (0.0, 0.0),
        p: 1.0,
    }; 2];
    let mut space_p = [1.0; 2];
    let mut drift_p = [1.0; 2];
    let mut trans_p = [1.0; 2];
    let mut visit_sd = [0.0; 2];
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut trans_visits = 0;
    for a in 0..2 {
        // Lack of fit.
        let m = ds.points.len() as f64;
        let (mut ss_lof, mut ss_pe, mut dof_pe) = (0.0, 0.0, 0.0);
        for p in 0..ds.points.len() {
            let visits = (0..nv).filter(|&v| ds.visits[v].point == p);
            let es: Vec<f64> = if lof_from_visits {
                visits.map(|v| vr.e[v][a]).collect()
            } else {
                visits
                    .flat_map(|v| ds.mean_rows(v))
                    .map(|i| res[i][a])
                    .collect()
            };
            if es.is_empty() {
                continue;
            }
            let mu = stats::mean(&es);
            ss_lof += es.len() as f64 * mu * mu;
            ss_pe += es.iter().map(|e| (e - mu).powi(2)).sum::<f64>();
            dof_pe += (es.len() - 1) as f64;
        }
        let d1 = (m - p_ax).max(1.0);
        if dof_pe > 0.0 && ss_pe > 0.0 {
            let f = (ss_lof / d1) / (ss_pe / dof_pe);
            lof[a] = Lof {
                f,
                dof: (d1, dof_pe),
                p: stats::f_sf(f, d1, dof_pe),
            };
        }

        // Structure over inputs and time, by permutation.
        let y: Vec<f64> = vr.e.iter().map(|e| e[a]).collect();
        let s_obs = space_stat(&wts, &y);
        let d_obs = drift_stat(&t, &y);
        let (mut ps, mut pd) = (Vec::with_capacity(perms), Vec::with_capacity(perms));
        let mut yp = y.clone();
        for _ in 0..perms {
            yp.shuffle(&mut rng);
            ps.push(space_stat(&wts, &yp));
            pd.push(drift_stat(&t, &yp));
        }
        space_p[a] = perm_p(s_obs, &ps);
        drift_p[a] = perm_p(d_obs, &pd);
        let sm = loo_smooth(&x, &y, BANDWIDTHS[1]);
        let dev: Vec<f64> = y.iter().zip(&sm).map(|(a, b)| a - b).collect();
        let floor = (pe.within_sd[a].powi(2) / 5.0 + pe.between_sd[a].powi(2)).sqrt();
        visit_sd[a] = stats::robust_sd(&dev).max(floor).max(1e-6);

        // Formation: signed early-minus-late contrast within visits.
        let s = formation_contrasts(ds, res, base_map, a);
        trans_visits = trans_visits.max(s.len());
        trans_p[a] = stats::one_sample_t(&s).2;
    }
    let mut fam: Vec<(&'static str, f64)> = vec![
        ("inputs", 2.0 * space_p[0].min(space_p[1])),
        ("drift", 2.0 * drift_p[0].min(drift_p[1])),
        ("formation", 2.0 * trans_p[0].min(trans_p[1])),
    ];
    if lof_from_visits {
        fam.push(("lack_of_fit", 2.0 * lof[0].p.min(lof[1].p)));
    }
    let k = fam.len() as f64;
    let p_value = fam
        .iter()
        .map(|f| (f.1 * k).min(1.0))
        .fold(1.0f64, f64::min);
    let families: Vec<&'static str> = fam
        .iter()
        .filter(|f| f.1 * k < alpha)
        .map(|f| f.0)
        .collect();
    GapTests {
        lof,
        lof_from_visits,
        space_p,
        drift_p,
        trans_p,
        trans_visits,
        p_value,
        significant: p_value < alpha,
        families,
        visit_sd,
    }
}

/// Per visit (with a previous visit and at least 4 rows): -(sign of the model's change from
/// the previous visit) x (mean residual of the first half of the rows - of the second half).
/// Positive: the measurement stays behind the model after a change.
pub fn formation_contrasts(
    ds: &Dataset,
    res: &[[f64; 2]],
    base_map: &[[f64; 2]],
    a: usize,
) -> Vec<f64> {
    let mut out = Vec::new();
    for v in &ds.visits {
        let Some(pv) = v.prev else { continue };
        if v.rows.len() < 4 {
            continue;
        }
        let d = base_map[v.point][a] - base_map[ds.visits[pv].point][a];
        if d.abs() < 1e-9 {
            continue;
        }
        let h = v.rows.len() / 2;
        let first: Vec<f64> = v.rows[..h].iter().map(|&i| res[i][a]).collect();
        let second: Vec<f64> = v.rows[h..].iter().map(|&i| res[i][a]).collect();
        out.push(-d.signum() * (stats::mean(&first) - stats::mean(&second)));
    }
    out
}

impl GapTests {
    /// The family tests as the bootstrap-calibrated detection decides them
    /// ([`super::detect`]), the gap as `verdict` declares it; the lack-of-fit F test of `old`
    /// is kept for the report.
    pub fn from_detection(
        old: GapTests,
        det: &super::detect::Detection,
        verdict: &super::detect::Verdict,
    ) -> GapTests {
        let fam = |n: &str| {
            det.family_p
                .iter()
                .find(|f| f.0 == n)
                .map(|f| f.1)
                .unwrap_or(1.0)
        };
        GapTests {
            space_p: [fam("inputs"); 2],
            drift_p: [fam("drift"); 2],
            trans_p: [fam("formation"); 2],
            p_value: verdict.p_value,
            significant: verdict.significant,
            families: det.families.clone(),
            visit_sd: det.visit_sd,
            ..old
        }
    }
}
