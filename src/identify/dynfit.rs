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
use super::fit::{self, Covariance, Run};
use super::params::{self, Free};
use crate::optim;
use crate::predict::{replay, InputRow};
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use magswarm_model::Model;
use nalgebra::{storage::Owned, DMatrix, DVector, Dyn};

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
                .map(|r| InputRow {
                    t: r.t,
                    z_mm: r.z_mm,
                    f_hz: r.f_hz,
                })
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

impl LeastSquaresProblem<f64, Dyn, Dyn> for DynProblem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, u: &DVector<f64>) {
        self.u.copy_from(u);
        params::set_from_u(&mut self.model, self.free, u.as_slice());
    }
    fn params(&self) -> DVector<f64> {
        self.u.clone()
    }
    fn residuals(&self) -> Option<DVector<f64>> {
        Some(DVector::from_vec(residuals(
            &self.model,
            self.data,
            self.sd,
        )))
    }
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let base = residuals(&self.model, self.data, self.sd);
        let theta = self.theta();
        let chain = params::dthetas_du(self.free, self.u.as_slice());
        let mut m = self.model.clone();
        Some(optim::forward_jacobian(
            &base,
            &theta,
            &fd_steps(&theta),
            &chain,
            |c, v| {
                params::set(&mut m, self.free[c].name(), v);
                let r = residuals(&m, self.data, self.sd);
                params::set(&mut m, self.free[c].name(), theta[c]);
                r
            },
        ))
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
    let mut prob = DynProblem {
        model: model.clone(),
        free,
        data,
        sd,
        u: u0.clone(),
    };
    prob.set_params(&u0);
    let (prob, rep) = LevenbergMarquardt::new()
        .with_ftol(1e-10)
        .with_xtol(1e-10)
        .with_gtol(1e-10)
        .with_patience(50)
        .minimize(prob);
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
    let cov = fit::diagnostics(jac, &base, None);
    let run = Run {
        u: prob.u.clone(),
        theta,
        cost,
        converged: rep.termination.was_successful(),
        termination: format!("{:?}", rep.termination),
        evals: rep.number_of_evaluations,
    };
    (fitted, run, cov)
}
