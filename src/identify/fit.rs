//! The steady-map fit: weighted least squares on the operating-point means by a bounded
//! Levenberg-Marquardt (crate `levenberg-marquardt`), with several starts, the Jacobian
//! covariance, the collinearity diagnostics and a bootstrap over operating points.
//!
//! Residuals are `(model - mean) / se` per point and axis, `se` from the repeat variance
//! ([`super::data::assign_weights`]). LM runs on unconstrained variables u with
//! theta = transform(u) ([`super::params::Transform`]), which keeps every parameter inside its
//! bounds; covariance and CIs are computed in theta, from a central-difference Jacobian at the
//! optimum, scaled by the reduced chi^2 (so they stay honest when the weights are off).
//!
//! The model side of every residual is the *observed* steady map
//! ([`magswarm_model::effects::observed_steady`]): the map (5)-(7) with every effect the model
//! has switched on, as the camera reads it at the session time of the measurement. A prior
//! with drift or camera effects is thus fitted with those effects acting (held at their
//! values unless freed); with no effects the observed map is the physical one, bit for bit.

use super::data::OpPoint;
use super::params::{self, Free, Transform};
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use magswarm_model::{effects, hz_to_rad_s, steady, Model};
use nalgebra::{storage::Owned, DMatrix, DVector, Dyn, SymmetricEigen};
use rand::{RngExt, SeedableRng};

/// A ridge (Tikhonov) term pulling chosen parameters toward prior values.
#[derive(Debug, Clone, PartialEq)]
pub struct Ridge {
    /// Strength: each penalty residual is sqrt(lambda) (theta - prior) / scale.
    pub lambda: f64,
    /// Per free parameter: Some((prior, scale)) when penalised.
    pub terms: Vec<Option<(f64, f64)>>,
}

/// Steady prediction at one point [mm] as observed at session time 0, with a large finite
/// value where the model breaks (see [`predict_point_at`]).
pub fn predict_point(m: &Model, z_mm: f64, f_hz: f64) -> [f64; 2] {
    predict_point_at(m, z_mm, f_hz, 0.0)
}

/// Steady prediction at one point [mm] as observed at session time `t_s` [s]: the observed
/// steady map, so drift (which depends on session time) and camera terms act as they do on a
/// measurement; a large finite value where the model breaks (keeps LM's residuals finite).
pub fn predict_point_at(m: &Model, z_mm: f64, f_hz: f64, t_s: f64) -> [f64; 2] {
    let sp = effects::observed_steady(m, z_mm * 1e-3, hz_to_rad_s(f_hz), t_s);
    finite([sp.r1, sp.r2])
}

/// Prediction of an operating point's mean [mm]: the observed steady map averaged over the
/// session times of the settled rows pooled into the point (drift makes rows of one point
/// taken at different times differ). Without observation effects, or without recorded times,
/// it is the prediction at t = 0, which then does not depend on time.
pub fn predict_mean(m: &Model, p: &OpPoint) -> [f64; 2] {
    if !m.effects.observes() || p.t_s.is_empty() {
        return predict_point(m, p.z_mm, p.f_hz);
    }
    // observed_steady at each row time, with the physical map evaluated once per point.
    let sp = steady::evaluate(m, p.z_mm * 1e-3, hz_to_rad_s(p.f_hz));
    let mut sum = [0.0; 2];
    for &t in &p.t_s {
        let o = m.effects.observe_steady(&sp, t);
        sum[0] += o.r1;
        sum[1] += o.r2;
    }
    let n = p.t_s.len() as f64;
    finite([sum[0] / n, sum[1] / n])
}

/// Large finite stand-ins for non-finite radii.
fn finite(r: [f64; 2]) -> [f64; 2] {
    let ok = |v: f64| if v.is_finite() { v } else { 1e6 };
    [ok(r[0]), ok(r[1])]
}

/// The LM problem on a subset (with repetition) of the points.
pub struct SteadyProblem<'a> {
    model: Model,
    free: &'a [Free],
    points: &'a [OpPoint],
    idx: &'a [usize],
    ridge: Option<&'a Ridge>,
    u: DVector<f64>,
}

impl<'a> SteadyProblem<'a> {
    /// A problem starting at `u`.
    pub fn new(
        model: &Model,
        free: &'a [Free],
        points: &'a [OpPoint],
        idx: &'a [usize],
        ridge: Option<&'a Ridge>,
        u: DVector<f64>,
    ) -> Self {
        let mut p = SteadyProblem {
            model: model.clone(),
            free,
            points,
            idx,
            ridge,
            u: u.clone(),
        };
        p.set_params(&u);
        p
    }

    fn theta(&self) -> Vec<f64> {
        self.free
            .iter()
            .zip(self.u.iter())
            .map(|(f, &u)| f.to_theta(u))
            .collect()
    }

    fn n_res(&self) -> usize {
        2 * self.idx.len()
            + self
                .ridge
                .map(|r| r.terms.iter().filter(|t| t.is_some()).count())
                .unwrap_or(0)
    }

    /// Residuals at the model's current parameters.
    fn res_of(&self, m: &Model, theta: &[f64]) -> DVector<f64> {
        let mut out = DVector::zeros(self.n_res());
        for (k, &i) in self.idx.iter().enumerate() {
            let p = &self.points[i];
            let r = predict_mean(m, p);
            out[2 * k] = (r[0] - p.mean[0]) / p.se[0];
            out[2 * k + 1] = (r[1] - p.mean[1]) / p.se[1];
        }
        if let Some(rg) = self.ridge {
            let mut k = 2 * self.idx.len();
            for (j, t) in rg.terms.iter().enumerate() {
                if let Some((prior, scale)) = t {
                    out[k] = rg.lambda.sqrt() * (theta[j] - prior) / scale;
                    k += 1;
                }
            }
        }
        out
    }

    /// The fitted model at the current u.
    pub fn model(&self) -> &Model {
        &self.model
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for SteadyProblem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, u: &DVector<f64>) {
        self.u.copy_from(u);
        for (f, &ui) in self.free.iter().zip(u.iter()) {
            params::set(&mut self.model, f.name(), f.to_theta(ui));
        }
    }

    fn params(&self) -> DVector<f64> {
        self.u.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        Some(self.res_of(&self.model, &self.theta()))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        // Forward differences in theta, chain rule to u.
        let theta = self.theta();
        let base = self.res_of(&self.model, &theta);
        let mut j = DMatrix::zeros(base.len(), theta.len());
        let mut m = self.model.clone();
        for (c, f) in self.free.iter().enumerate() {
            let h = f.fd_step(theta[c]);
            let mut th = theta.clone();
            th[c] += h;
            params::set(&mut m, f.name(), th[c]);
            let r = self.res_of(&m, &th);
            params::set(&mut m, f.name(), theta[c]);
            let dtheta_du = f.dtheta_du(self.u[c]);
            for i in 0..base.len() {
                j[(i, c)] = (r[i] - base[i]) / h * dtheta_du;
            }
        }
        Some(j)
    }
}

/// Result of one LM run.
#[derive(Debug, Clone)]
pub struct Run {
    /// Unconstrained variables at the end.
    pub u: DVector<f64>,
    /// Parameters at the end.
    pub theta: Vec<f64>,
    /// Sum of squared residuals.
    pub cost: f64,
    /// LM's termination was a success.
    pub converged: bool,
    /// Termination reason (text).
    pub termination: String,
    /// Residual evaluations.
    pub evals: usize,
}

/// One LM run from `u0`.
pub fn run_lm(
    model: &Model,
    free: &[Free],
    points: &[OpPoint],
    idx: &[usize],
    ridge: Option<&Ridge>,
    u0: DVector<f64>,
) -> Run {
    let prob = SteadyProblem::new(model, free, points, idx, ridge, u0);
    let (prob, rep) = LevenbergMarquardt::new()
        .with_ftol(1e-12)
        .with_xtol(1e-12)
        .with_gtol(1e-12)
        .with_patience(200)
        .minimize(prob);
    let theta = prob.theta();
    let res = prob.residuals().unwrap_or_else(|| DVector::zeros(0));
    let cost = res.norm_squared();
    Run {
        u: prob.u.clone(),
        theta,
        cost: if cost.is_finite() {
            cost
        } else {
            f64::INFINITY
        },
        converged: rep.termination.was_successful(),
        termination: format!("{:?}", rep.termination),
        evals: rep.number_of_evaluations,
    }
}

/// Start points: the prior first, then random perturbations in u (log-normal factor e^N(0,0.5)
/// for scale parameters, +-N(0, 0.25) of the half-range for bounded ones).
pub fn starts(free: &[Free], theta0: &[f64], n: usize, seed: u64) -> Vec<DVector<f64>> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let u0 = DVector::from_iterator(free.len(), free.iter().zip(theta0).map(|(f, &t)| f.to_u(t)));
    let mut out = vec![u0.clone()];
    let normal = rand_distr::Normal::new(0.0, 1.0).expect("unit normal");
    for _ in 1..n.max(1) {
        let mut u = u0.clone();
        for (j, f) in free.iter().enumerate() {
            let z: f64 = rng.sample(normal);
            u[j] = match f.def.transform {
                Transform::Log => u0[j] + 0.5 * z,
                Transform::Sin => {
                    // Perturb theta by 25 % of |theta| + 5 % of the range, mapped back to u.
                    let t = f.to_theta(u0[j]);
                    let s = 0.25 * t.abs() + 0.05 * (f.hi - f.lo).min(2.0);
                    f.to_u(t + s * z)
                }
            };
        }
        out.push(u);
    }
    out
}

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
    let p = free.len();
    let base = data_residuals(model, points);
    let m = base.len();
    let mut jac = DMatrix::zeros(m, p);
    let mut mm = model.clone();
    for (c, f) in free.iter().enumerate() {
        let t = params::get(model, f.name());
        let h = f.fd_step(t);
        params::set(&mut mm, f.name(), t + h);
        let rp = data_residuals(&mm, points);
        params::set(&mut mm, f.name(), t - h);
        let rm = data_residuals(&mm, points);
        params::set(&mut mm, f.name(), t);
        for i in 0..m {
            jac[(i, c)] = (rp[i] - rm[i]) / (2.0 * h);
        }
    }
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
    progress: &indicatif::ProgressBar,
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
