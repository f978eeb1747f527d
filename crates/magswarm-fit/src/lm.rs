//! The one Levenberg-Marquardt problem of the project: every least-squares fit (identify's
//! steady map and ODE time scales, the paper's constant-gain fit, diagnose's candidates)
//! describes itself by [`Fit`] (move to u, residuals, Jacobian) and runs through [`minimize`].
//!
//! The adapter to the `levenberg-marquardt` crate ([`LeastSquaresProblem`]) is written once
//! here; a fit keeps only what is its own: its residuals, its parametrisation (u is
//! unconstrained; a fit maps it onto bounded parameters) and how it differentiates them.

pub use levenberg_marquardt::LevenbergMarquardt;
use levenberg_marquardt::{LeastSquaresProblem, MinimizationReport};
use nalgebra::{storage::Owned, DMatrix, DVector, Dyn};

/// A least-squares fit in unconstrained variables u.
pub trait Fit {
    /// Move the fit to u (write the parameters u stands for).
    fn set(&mut self, u: &[f64]);
    /// Residuals at the current u (finite: a fit maps a broken model to large values).
    fn residuals(&self) -> DVector<f64>;
    /// Jacobian of the residuals in u at the current u.
    fn jacobian(&self) -> DMatrix<f64>;
}

/// The `levenberg-marquardt` problem of a [`Fit`].
struct Problem<F> {
    fit: F,
    u: DVector<f64>,
}

impl<F: Fit> LeastSquaresProblem<f64, Dyn, Dyn> for Problem<F> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, u: &DVector<f64>) {
        self.u.copy_from(u);
        self.fit.set(u.as_slice());
    }
    fn params(&self) -> DVector<f64> {
        self.u.clone()
    }
    fn residuals(&self) -> Option<DVector<f64>> {
        Some(self.fit.residuals())
    }
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        Some(self.fit.jacobian())
    }
}

/// The end of a [`minimize`] run.
#[derive(Debug, Clone)]
pub struct Outcome<F> {
    /// The fit, moved to the solution.
    pub fit: F,
    /// Unconstrained variables at the solution.
    pub u: DVector<f64>,
    /// LM's termination was a success.
    pub converged: bool,
    /// Termination reason (text).
    pub termination: String,
    /// Residual evaluations.
    pub evals: usize,
}

/// Minimise the sum of squared residuals of `fit` from `u0` with the solver `lm` (its
/// tolerances and patience set by the caller).
pub fn minimize<F: Fit>(mut fit: F, u0: DVector<f64>, lm: LevenbergMarquardt<f64>) -> Outcome<F> {
    fit.set(u0.as_slice());
    let (p, rep): (Problem<F>, MinimizationReport<f64>) = lm.minimize(Problem { fit, u: u0 });
    Outcome {
        fit: p.fit,
        u: p.u,
        converged: rep.termination.was_successful(),
        termination: format!("{:?}", rep.termination),
        evals: rep.number_of_evaluations,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y = a exp(b x) through points of a = 2, b = -0.5.
    struct Exp {
        x: Vec<f64>,
        y: Vec<f64>,
        ab: [f64; 2],
    }

    impl Fit for Exp {
        fn set(&mut self, u: &[f64]) {
            self.ab = [u[0], u[1]];
        }
        fn residuals(&self) -> DVector<f64> {
            let [a, b] = self.ab;
            DVector::from_iterator(
                self.x.len(),
                self.x
                    .iter()
                    .zip(&self.y)
                    .map(|(x, y)| a * (b * x).exp() - y),
            )
        }
        fn jacobian(&self) -> DMatrix<f64> {
            let [a, b] = self.ab;
            DMatrix::from_fn(self.x.len(), 2, |i, j| {
                let e = (b * self.x[i]).exp();
                if j == 0 {
                    e
                } else {
                    a * self.x[i] * e
                }
            })
        }
    }

    #[test]
    fn recovers_the_parameters_of_exact_data() {
        let x: Vec<f64> = (0..20).map(|i| i as f64 * 0.3).collect();
        let y = x.iter().map(|x| 2.0 * (-0.5 * x).exp()).collect();
        let fit = Exp { x, y, ab: [0.0; 2] };
        let out = minimize(
            fit,
            DVector::from_vec(vec![1.0, -0.1]),
            LevenbergMarquardt::new(),
        );
        assert!(out.converged, "{}", out.termination);
        assert!((out.u[0] - 2.0).abs() < 1e-8 && (out.u[1] + 0.5).abs() < 1e-8);
        assert_eq!(out.fit.ab, [out.u[0], out.u[1]]);
    }
}
