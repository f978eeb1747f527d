//! Uncertainty of the steady fit: the Jacobian covariance with its collinearity diagnostics
//! (correlation, condition numbers, the weakest direction), Student-t intervals, and the
//! bootstrap over operating points (re-exported from [`super::fit`], where they used to live).

use super::data::OpPoint;
use super::fit::{predict_mean, run_lm, Ridge};
use super::params::{self, Free};
use crate::Progress;
use magswarm_fit::optim;
use magswarm_model::Model;
use nalgebra::{DMatrix, DVector, SymmetricEigen};
use rand::{RngExt, SeedableRng};

/// Covariance and collinearity diagnostics at a solution.
#[derive(Debug, Clone)]
pub struct Covariance {
    /// Weighted residual Jacobian in theta (central differences), data rows only.
    pub jac: DMatrix<f64>,
    /// Parameter covariance (s^2 (J^T J)^-1, pseudo-inverse on a numerically null space).
    pub cov: DMatrix<f64>,
    /// Standard errors.
    pub se: Vec<f64>,
    /// Correlation matrix.
    pub corr: DMatrix<f64>,
    /// Condition number of J^T J after scaling its columns to unit diagonal.
    pub cond_scaled: f64,
    /// Condition number of J^T J as is (depends on the parameters' units).
    pub cond_raw: f64,
    /// Eigenvector (in the scaled problem) of the smallest eigenvalue: the direction the data
    /// cannot see.
    pub weakest: Vec<f64>,
    /// chi^2 of the data residuals.
    pub chi2: f64,
    /// Degrees of freedom (residuals - free parameters).
    pub dof: usize,
    /// Reduced chi^2 used to scale the covariance (1 when dof = 0).
    pub s2: f64,
}

/// Weighted data residuals at a model.
pub fn data_residuals(m: &Model, points: &[OpPoint]) -> Vec<f64> {
    let mut v = Vec::with_capacity(2 * points.len());
    for p in points {
        let r = predict_mean(m, p);
        v.push((r[0] - p.mean[0]) / p.se[0]);
        v.push((r[1] - p.mean[1]) / p.se[1]);
    }
    v
}

/// Covariance at `model` (its free parameters at their fitted values).
pub fn covariance(
    model: &Model,
    free: &[Free],
    points: &[OpPoint],
    ridge: Option<&Ridge>,
) -> Covariance {
    let base = data_residuals(model, points);
    let theta: Vec<f64> = free.iter().map(|f| params::get(model, f.name())).collect();
    let h: Vec<f64> = free
        .iter()
        .zip(&theta)
        .map(|(f, &t)| f.fd_step(t))
        .collect();
    let mut mm = model.clone();
    let jac = optim::central_jacobian(base.len(), &theta, &h, |c, v| {
        params::set(&mut mm, free[c].name(), v);
        let r = data_residuals(&mm, points);
        params::set(&mut mm, free[c].name(), theta[c]);
        r
    });
    diagnostics(jac, &base, ridge)
}

/// Covariance and collinearity diagnostics from a weighted data Jacobian (theta) and the
/// data residuals at the solution.
pub fn diagnostics(jac: DMatrix<f64>, base: &[f64], ridge: Option<&Ridge>) -> Covariance {
    let (m, p) = jac.shape();
    let chi2: f64 = base.iter().map(|r| r * r).sum();
    let dof = m.saturating_sub(p);
    let s2 = if dof > 0 { chi2 / dof as f64 } else { 1.0 };
    let mut jtj = jac.transpose() * &jac;
    if let Some(rg) = ridge {
        for (j, t) in rg.terms.iter().enumerate() {
            if let Some((_, scale)) = t {
                // Prior information, in units of the data's chi^2 (divided by s2 below).
                jtj[(j, j)] += rg.lambda / (scale * scale);
            }
        }
    }
    let diag: Vec<f64> = (0..p).map(|j| jtj[(j, j)].max(1e-300).sqrt()).collect();
    let mut scaled = jtj.clone();
    for i in 0..p {
        for j in 0..p {
            scaled[(i, j)] /= diag[i] * diag[j];
        }
    }
    let eig_s = SymmetricEigen::new(scaled.clone());
    let (mut lmin, mut lmax, mut imin) = (f64::INFINITY, 0.0f64, 0);
    for (i, &l) in eig_s.eigenvalues.iter().enumerate() {
        if l < lmin {
            lmin = l;
            imin = i;
        }
        lmax = lmax.max(l);
    }
    let cond_scaled = if lmin > 0.0 {
        lmax / lmin
    } else {
        f64::INFINITY
    };
    let weakest: Vec<f64> = eig_s.eigenvectors.column(imin).iter().copied().collect();
    let eig_r = SymmetricEigen::new(jtj.clone());
    let (rmin, rmax) = eig_r
        .eigenvalues
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &l| (a.min(l), b.max(l)));
    let cond_raw = if rmin > 0.0 {
        rmax / rmin
    } else {
        f64::INFINITY
    };
    // Pseudo-inverse of the scaled matrix (eigenvalues below 1e-14 lmax dropped), unscaled.
    let mut inv_s = DMatrix::zeros(p, p);
    for (k, &l) in eig_s.eigenvalues.iter().enumerate() {
        if l > 1e-14 * lmax {
            let v = eig_s.eigenvectors.column(k);
            inv_s += (v * v.transpose()) / l;
        }
    }
    let mut cov = DMatrix::zeros(p, p);
    for i in 0..p {
        for j in 0..p {
            cov[(i, j)] = s2 * inv_s[(i, j)] / (diag[i] * diag[j]);
        }
    }
    let se: Vec<f64> = (0..p).map(|j| cov[(j, j)].max(0.0).sqrt()).collect();
    let mut corr = DMatrix::zeros(p, p);
    for i in 0..p {
        for j in 0..p {
            corr[(i, j)] = cov[(i, j)] / (se[i] * se[j]).max(1e-300);
        }
    }
    Covariance {
        jac,
        cov,
        se,
        corr,
        cond_scaled,
        cond_raw,
        weakest,
        chi2,
        dof,
        s2,
    }
}

/// Two-sided 97.5 % quantile of Student's t with `dof` degrees of freedom (Cornish-Fisher
/// expansion; error < 1e-3 for dof >= 3, exact limit 1.95996 as dof grows).
pub fn t975(dof: usize) -> f64 {
    let z: f64 = 1.959_963_985;
    match dof {
        0 => f64::INFINITY,
        1 => 12.706,
        2 => 4.303,
        _ => {
            let n = dof as f64;
            z + (z.powi(3) + z) / (4.0 * n)
                + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * n * n)
                + (3.0 * z.powi(7) + 19.0 * z.powi(5) + 17.0 * z.powi(3) - 15.0 * z)
                    / (384.0 * n.powi(3))
        }
    }
}

/// Bootstrap summary of one parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BootStat {
    /// Robust standard deviation over replicates: (97.5 % - 2.5 % percentile) / 3.92.
    pub sd: f64,
    /// 2.5 % percentile.
    pub lo: f64,
    /// 97.5 % percentile.
    pub hi: f64,
}

/// Bootstrap over operating points (visits pooled by inputs), stratified by z_m: within each
/// distinct z_m the points are resampled with replacement, `n` times; each replicate is
/// refitted from the solution (one LM run) and each parameter summarised. Runs on all cores.
pub fn bootstrap(
    model: &Model,
    free: &[Free],
    points: &[OpPoint],
    ridge: Option<&Ridge>,
    n: usize,
    seed: u64,
    progress: &dyn Progress,
) -> (Vec<BootStat>, usize) {
    let u_hat = DVector::from_iterator(
        free.len(),
        free.iter().map(|f| f.to_u(params::get(model, f.name()))),
    );
    // Strata: the distinct z_m values (the design has few; a plain resample often drops one
    // and leaves the stiffness terms unidentified, which is not the sampling variability the
    // bootstrap is meant to show).
    let mut strata: Vec<Vec<usize>> = Vec::new();
    let mut zs: Vec<f64> = Vec::new();
    for (i, p) in points.iter().enumerate() {
        match zs.iter().position(|z| (z - p.z_mm).abs() < 1e-6) {
            Some(k) => strata[k].push(i),
            None => {
                zs.push(p.z_mm);
                strata.push(vec![i]);
            }
        }
    }
    let strata = &strata;
    let threads = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .clamp(1, 8);
    let reps: Vec<Option<Vec<f64>>> = std::thread::scope(|sc| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let u_hat = u_hat.clone();
                sc.spawn(move || {
                    let mut out = Vec::new();
                    for b in (t..n).step_by(threads) {
                        let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ (b as u64 + 1));
                        let mut idx = Vec::with_capacity(points.len());
                        for st in strata {
                            for _ in 0..st.len() {
                                idx.push(st[rng.random_range(0..st.len())]);
                            }
                        }
                        let r = run_lm(model, free, points, &idx, ridge, u_hat.clone());
                        progress.inc(1);
                        out.push(if r.cost.is_finite() {
                            Some(r.theta)
                        } else {
                            None
                        });
                    }
                    out
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("bootstrap thread"))
            .collect()
    });
    let ok: Vec<Vec<f64>> = reps.into_iter().flatten().collect();
    let stats = (0..free.len())
        .map(|j| {
            let mut v: Vec<f64> = ok.iter().map(|t| t[j]).collect();
            v.sort_by(|a, b| a.total_cmp(b));
            if v.len() < 2 {
                return BootStat {
                    sd: f64::NAN,
                    lo: f64::NAN,
                    hi: f64::NAN,
                };
            }
            let q = |p: f64| {
                let x = p * (v.len() - 1) as f64;
                let (i, fr) = (x.floor() as usize, x - x.floor());
                v[i] + fr * (v[(i + 1).min(v.len() - 1)] - v[i])
            };
            // A robust SD (from the central 95 %): a few replicates that wander off in a
            // flat direction must not dominate the comparison with the Jacobian SE.
            let sd = (q(0.975) - q(0.025)) / (2.0 * 1.959_964);
            BootStat {
                sd,
                lo: q(0.025),
                hi: q(0.975),
            }
        })
        .collect();
    (stats, ok.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t_quantiles() {
        assert!((t975(10) - 2.228).abs() < 2e-3);
        assert!((t975(30) - 2.042).abs() < 1e-3);
        assert!((t975(1000) - 1.962).abs() < 1e-3);
    }
}
