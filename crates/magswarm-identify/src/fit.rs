//! The steady-map fit: weighted least squares on the operating-point means by a bounded
//! Levenberg-Marquardt (crate `levenberg-marquardt`), with several starts. The Jacobian
//! covariance, the collinearity diagnostics and the bootstrap over operating points are in
//! `identify/uncertainty.rs` (re-exported here).
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
use magswarm_fit::lm::{self, LevenbergMarquardt};
use magswarm_fit::optim;
use magswarm_model::{effects, hz_to_rad_s, steady, Model};
use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};

/// A ridge (Tikhonov) term pulling chosen parameters toward prior values.
#[derive(Debug, Clone, PartialEq)]
pub struct Ridge {
    /// Strength: each penalty residual is sqrt(lambda) (theta - prior) / scale.
    pub lambda: f64,
    /// Per free parameter: Some((prior, scale)) when penalised.
    pub terms: Vec<Option<(f64, f64)>>,
}

/// Steady prediction at one point \[mm\] as observed at session time 0, with a large finite
/// value where the model breaks (see [`predict_point_at`]).
pub fn predict_point(m: &Model, z_mm: f64, f_hz: f64) -> [f64; 2] {
    predict_point_at(m, z_mm, f_hz, 0.0)
}

/// Steady prediction at one point \[mm\] as observed at session time `t_s` \[s\]: the observed
/// steady map, so drift (which depends on session time) and camera terms act as they do on a
/// measurement; a large finite value where the model breaks (keeps LM's residuals finite).
pub fn predict_point_at(m: &Model, z_mm: f64, f_hz: f64, t_s: f64) -> [f64; 2] {
    let sp = effects::observed_steady(m, z_mm * 1e-3, hz_to_rad_s(f_hz), t_s);
    finite([sp.r1, sp.r2])
}

/// Prediction of an operating point's mean \[mm\]: the observed steady map averaged over the
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
        lm::Fit::set(&mut p, u.as_slice());
        p
    }

    fn theta(&self) -> Vec<f64> {
        params::thetas(self.free, self.u.as_slice())
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

impl lm::Fit for SteadyProblem<'_> {
    fn set(&mut self, u: &[f64]) {
        self.u.copy_from_slice(u);
        params::set_from_u(&mut self.model, self.free, u);
    }

    fn residuals(&self) -> DVector<f64> {
        self.res_of(&self.model, &self.theta())
    }

    fn jacobian(&self) -> DMatrix<f64> {
        // Forward differences in theta, chain rule to u.
        let theta = self.theta();
        let base = self.res_of(&self.model, &theta);
        let h: Vec<f64> = self
            .free
            .iter()
            .zip(&theta)
            .map(|(f, &t)| f.fd_step(t))
            .collect();
        let chain = params::dthetas_du(self.free, self.u.as_slice());
        let mut m = self.model.clone();
        let mut th = theta.clone();
        optim::forward_jacobian(base.as_slice(), &theta, &h, &chain, |c, v| {
            let name = self.free[c].name();
            params::set(&mut m, name, v);
            th[c] = v;
            let r = self.res_of(&m, &th);
            params::set(&mut m, name, theta[c]);
            th[c] = theta[c];
            r.as_slice().to_vec()
        })
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
    let prob = SteadyProblem::new(model, free, points, idx, ridge, u0.clone());
    let out = lm::minimize(
        prob,
        u0,
        LevenbergMarquardt::new()
            .with_ftol(1e-12)
            .with_xtol(1e-12)
            .with_gtol(1e-12)
            .with_patience(200),
    );
    let theta = out.fit.theta();
    let cost = lm::Fit::residuals(&out.fit).norm_squared();
    Run {
        u: out.u,
        theta,
        cost: if cost.is_finite() {
            cost
        } else {
            f64::INFINITY
        },
        converged: out.converged,
        termination: out.termination,
        evals: out.evals,
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
