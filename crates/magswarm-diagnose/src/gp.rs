//! The nonparametric discrepancy for what no candidate explains: a Gaussian process over the
//! normalised inputs of the visits (squared-exponential kernel), in the spirit of Kennedy and
//! O'Hagan's model discrepancy delta(x) added to the calibrated simulator. Hyperparameters
//! (length scale, signal variance) by the largest marginal likelihood on a small grid; the
//! noise variance is the visit-level residual variance.

use nalgebra::{DMatrix, DVector};

/// A fitted GP.
#[derive(Debug, Clone)]
pub struct Gp {
    x: Vec<Vec<f64>>,
    alpha: DVector<f64>,
    ell: f64,
    s2: f64,
    mean: f64,
}

fn k(a: &[f64], b: &[f64], ell: f64, s2: f64) -> f64 {
    let d2: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    s2 * (-d2 / (2.0 * ell * ell)).exp()
}

impl Gp {
    /// Fit to (x, y) with noise variance `noise2`; None when the system is singular.
    pub fn fit(x: &[Vec<f64>], y: &[f64], noise2: f64) -> Option<Gp> {
        let n = y.len();
        if n < 3 {
            return None;
        }
        let mean = y.iter().sum::<f64>() / n as f64;
        let var = y.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
        let yc = DVector::from_iterator(n, y.iter().map(|v| v - mean));
        let mut best: Option<(f64, Gp)> = None;
        for &ell in &[0.08, 0.15, 0.3, 0.6] {
            for &sf in &[0.25, 1.0, 4.0] {
                let s2 = (var * sf).max(1e-12);
                let mut km = DMatrix::zeros(n, n);
                for i in 0..n {
                    for j in 0..n {
                        km[(i, j)] = k(&x[i], &x[j], ell, s2);
                    }
                    km[(i, i)] += noise2.max(1e-12);
                }
                let Some(ch) = km.cholesky() else { continue };
                let alpha = ch.solve(&yc);
                let logdet: f64 = (0..n).map(|i| ch.l()[(i, i)].ln()).sum::<f64>() * 2.0;
                let ll = -0.5 * yc.dot(&alpha) - 0.5 * logdet;
                if best.as_ref().map(|b| ll > b.0).unwrap_or(true) {
                    best = Some((
                        ll,
                        Gp {
                            x: x.to_vec(),
                            alpha,
                            ell,
                            s2,
                            mean,
                        },
                    ));
                }
            }
        }
        best.map(|b| b.1)
    }

    /// Posterior mean at `x`.
    pub fn predict(&self, x: &[f64]) -> f64 {
        self.mean
            + self
                .x
                .iter()
                .zip(self.alpha.iter())
                .map(|(xi, a)| k(xi, x, self.ell, self.s2) * a)
                .sum::<f64>()
    }
}

/// Grouped cross-validated GP predictions: for each fold, fit on the other folds' points and
/// predict this fold's. `fold[i]` is the fold of point i.
pub fn cv_predict(x: &[Vec<f64>], y: &[f64], fold: &[usize], noise2: f64) -> Vec<f64> {
    let k = fold.iter().copied().max().map(|m| m + 1).unwrap_or(0);
    let mut out = vec![0.0; y.len()];
    for f in 0..k {
        let tr: Vec<usize> = (0..y.len()).filter(|&i| fold[i] != f).collect();
        let xt: Vec<Vec<f64>> = tr.iter().map(|&i| x[i].clone()).collect();
        let yt: Vec<f64> = tr.iter().map(|&i| y[i]).collect();
        let gp = Gp::fit(&xt, &yt, noise2);
        for i in (0..y.len()).filter(|&i| fold[i] == f) {
            out[i] = gp.as_ref().map(|g| g.predict(&x[i])).unwrap_or(0.0);
        }
    }
    out
}
