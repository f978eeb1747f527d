//! The ODE (4) time-scale fit on the transient rows.
//!
//! With the steady map fixed at its fitted values and the confinement gains scheduled (so the
//! equilibrium stays the map), the remaining dynamic parameters
//! set how fast the swarm reforms after an input change (default K_tau only). They are fitted by the same bounded
//! LM to the transient rows (valid rows within the settle time of an input change, first
//! visit of each session excluded since the state before it is unknown), replaying each
//! session through the plant exactly as `magswarm predict` does. Residuals are weighted by the
//! pooled repeat SD of each axis.

use super::data::Session;
use super::fit::Run;
use super::params::{self, Free};
use super::uncertainty::{self, Covariance};
use crate::predict::{replay, InputRow};
use magswarm_fit::lm::{self, LevenbergMarquardt};
use magswarm_fit::optim;
use magswarm_model::Model;
use nalgebra::{DMatrix, DVector};

/// Integrator tolerance of the fit's replays (mm, relative): far below the noise.
const FIT_RTOL: f64 = 1e-6;

/// The transient data of one session.
#[derive(Debug, Clone)]
pub struct TransientSession {
    /// Input rows to replay (the whole session up to its last transient row).
    pub inputs: Vec<InputRow>,
    /// (row index in `inputs`, measured radii) of the transient rows.
    pub targets: Vec<(usize, [f64; 2])>,
}

/// Collect the transient rows.
pub fn transients(sessions: &[Session]) -> Vec<TransientSession> {
    let mut out = Vec::new();
    for s in sessions {
        let mut targets = Vec::new();
        for (i, r) in s.rows.iter().enumerate() {
            if let (Some(v), false, true) = (r.r, r.settled, r.visit > 0) {
                targets.push((i, v));
            }
        }
        if let Some(&(last, _)) = targets.last() {
            let inputs = s.rows[..=last]
                .iter()
                .map(crate::data::Row::input)
                .collect();
            out.push(TransientSession { inputs, targets });
        }
    }
    out
}

/// Weighted residuals (prediction - measurement) / sd of every transient row.
pub fn residuals(model: &Model, data: &[TransientSession], sd: [f64; 2]) -> Vec<f64> {
    let mut v = Vec::new();
    for s in data {
        match replay(model, &s.inputs, FIT_RTOL) {
            Ok(pred) => {
                for &(i, m) in &s.targets {
                    v.push((pred[i][0] - m[0]) / sd[0]);
                    v.push((pred[i][1] - m[1]) / sd[1]);
                }
            }
            Err(_) => v.extend(std::iter::repeat_n(1e6, 2 * s.targets.len())),
        }
    }
    v
}

/// Finite-difference steps of the time-scale parameters: relative, 1e-4.
fn fd_steps(theta: &[f64]) -> Vec<f64> {
    theta.iter().map(|t| 1e-4 * t.abs().max(1e-6)).collect()
}

struct DynProblem<'a> {
    model: Model,
    free: &'a [Free],
    data: &'a [TransientSession],
    sd: [f64; 2],
    u: DVector<f64>,
}

impl DynProblem<'_> {
    fn theta(&self) -> Vec<f64> {
        params::thetas(self.free, self.u.as_slice())
    }
}

impl lm::Fit for DynProblem<'_> {
    fn set(&mut self, u: &[f64]) {
        self.u.copy_from_slice(u);
        params::set_from_u(&mut self.model, self.free, u);
    }
    fn residuals(&self) -> DVector<f64> {
        DVector::from_vec(residuals(&self.model, self.data, self.sd))
    }
    fn jacobian(&self) -> DMatrix<f64> {
        let base = residuals(&self.model, self.data, self.sd);
        let theta = self.theta();
        let chain = params::dthetas_du(self.free, self.u.as_slice());
        let mut m = self.model.clone();
        optim::forward_jacobian(&base, &theta, &fd_steps(&theta), &chain, |c, v| {
            params::set(&mut m, self.free[c].name(), v);
            let r = residuals(&m, self.data, self.sd);
            params::set(&mut m, self.free[c].name(), theta[c]);
            r
        })
    }
}

/// Fit the dynamic parameters; returns the run and the covariance at the solution.
pub fn fit(
    model: &Model,
    free: &[Free],
    data: &[TransientSession],
    sd: [f64; 2],
) -> (Model, Run, Covariance) {
    let u0 = DVector::from_iterator(
        free.len(),
        free.iter().map(|f| f.to_u(params::get(model, f.name()))),
    );
    let prob = DynProblem {
        model: model.clone(),
        free,
        data,
        sd,
        u: u0.clone(),
    };
    let out = lm::minimize(
        prob,
        u0,
        LevenbergMarquardt::new()
            .with_ftol(1e-10)
            .with_xtol(1e-10)
            .with_gtol(1e-10)
            .with_patience(50),
    );
    let prob = out.fit;
    let theta = prob.theta();
    let fitted = prob.model.clone();
    let base = residuals(&fitted, data, sd);
    let cost = base.iter().map(|r| r * r).sum();
    // Central-difference Jacobian in theta for the covariance.
    let mut m = fitted.clone();
    let jac = optim::central_jacobian(base.len(), &theta, &fd_steps(&theta), |c, v| {
        params::set(&mut m, free[c].name(), v);
        let r = residuals(&m, data, sd);
        params::set(&mut m, free[c].name(), theta[c]);
        r
    });
    let cov = uncertainty::diagnostics(jac, &base, None);
    let run = Run {
        u: out.u,
        theta,
        cost,
        converged: out.converged,
        termination: out.termination,
        evals: out.evals,
    };
    (fitted, run, cov)
}
