//! Optimisation helpers shared by the commands. Least squares go through the
//! `levenberg-marquardt` crate; what is here is what no kept crate in the build offers: a
//! box-constrained Nelder-Mead (`magswarm paper`'s closed-loop points) and the finite-difference
//! Jacobians of the identify fits.

use nalgebra::DMatrix;

/// Minimise `f` over a box by Nelder-Mead (trial points are clamped into the box).
pub fn nelder_mead(
    f: &dyn Fn(&[f64]) -> f64,
    x0: &[f64],
    step: &[f64],
    bounds: (&[f64], &[f64]),
    iters: usize,
) -> (Vec<f64>, f64) {
    let n = x0.len();
    let (lo, hi) = bounds;
    let clamp = |x: &mut Vec<f64>| {
        for k in 0..n {
            x[k] = x[k].clamp(lo[k], hi[k]);
        }
    };
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    let mut p0 = x0.to_vec();
    clamp(&mut p0);
    simplex.push((p0.clone(), f(&p0)));
    for k in 0..n {
        let mut p = p0.clone();
        p[k] += step[k];
        if p[k] > hi[k] {
            p[k] = p0[k] - step[k];
        }
        clamp(&mut p);
        let v = f(&p);
        simplex.push((p, v));
    }
    for _ in 0..iters {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let spread = simplex[n].1 - simplex[0].1;
        if spread.abs() <= 1e-15 * (1.0 + simplex[0].1.abs()) {
            break;
        }
        let mut c = vec![0.0; n];
        for (p, _) in &simplex[..n] {
            for k in 0..n {
                c[k] += p[k] / n as f64;
            }
        }
        let at = |t: f64| {
            let mut p: Vec<f64> = (0..n)
                .map(|k| c[k] + t * (simplex[n].0[k] - c[k]))
                .collect();
            clamp(&mut p);
            let v = f(&p);
            (p, v)
        };
        let r = at(-1.0);
        if r.1 < simplex[0].1 {
            let e = at(-2.0);
            simplex[n] = if e.1 < r.1 { e } else { r };
        } else if r.1 < simplex[n - 1].1 {
            simplex[n] = r;
        } else {
            let cpt = if r.1 < simplex[n].1 {
                at(-0.5)
            } else {
                at(0.5)
            };
            if cpt.1 < simplex[n].1.min(r.1) {
                simplex[n] = cpt;
            } else {
                let best = simplex[0].0.clone();
                for s in simplex.iter_mut().skip(1) {
                    let mut p: Vec<f64> =
                        (0..n).map(|k| best[k] + 0.5 * (s.0[k] - best[k])).collect();
                    clamp(&mut p);
                    s.1 = f(&p);
                    s.0 = p;
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex.swap_remove(0)
}

/// Forward-difference Jacobian of a residual vector at `x`, column c scaled by `chain[c]` (the
/// chain rule to the variable the optimiser moves, e.g. an unconstrained transform of x):
/// `J[i][c] = (r(x + h_c e_c)_i - r0_i) / h_c * chain[c]`. `eval(c, v)` returns the residuals
/// with component c at v and every other component at x; `r0` are the residuals at x.
pub fn forward_jacobian(
    r0: &[f64],
    x: &[f64],
    h: &[f64],
    chain: &[f64],
    mut eval: impl FnMut(usize, f64) -> Vec<f64>,
) -> DMatrix<f64> {
    let mut j = DMatrix::zeros(r0.len(), x.len());
    for c in 0..x.len() {
        let r = eval(c, x[c] + h[c]);
        for i in 0..r0.len() {
            j[(i, c)] = (r[i] - r0[i]) / h[c] * chain[c];
        }
    }
    j
}

/// Central-difference Jacobian of an `m`-vector of residuals at `x`:
/// `J[i][c] = (r(x + h_c e_c)_i - r(x - h_c e_c)_i) / (2 h_c)`, `eval` as in
/// [`forward_jacobian`]. Used for covariances, where the forward error would bias the SEs.
pub fn central_jacobian(
    m: usize,
    x: &[f64],
    h: &[f64],
    mut eval: impl FnMut(usize, f64) -> Vec<f64>,
) -> DMatrix<f64> {
    let mut j = DMatrix::zeros(m, x.len());
    for c in 0..x.len() {
        let rp = eval(c, x[c] + h[c]);
        let rm = eval(c, x[c] - h[c]);
        for i in 0..m {
            j[(i, c)] = (rp[i] - rm[i]) / (2.0 * h[c]);
        }
    }
    j
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nelder_mead_finds_a_box_constrained_minimum() {
        // Rosenbrock with its minimum (1, 1) inside the box, and a box that cuts it off.
        let rosen = |x: &[f64]| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2);
        let (x, v) = nelder_mead(
            &rosen,
            &[-1.0, 2.0],
            &[0.5, 0.5],
            (&[-2.0, -2.0], &[2.0, 2.0]),
            5000,
        );
        assert!(
            (x[0] - 1.0).abs() < 1e-4 && (x[1] - 1.0).abs() < 1e-4 && v < 1e-8,
            "{x:?} {v}"
        );
        let (x, _) = nelder_mead(
            &rosen,
            &[-1.0, 0.0],
            &[0.2, 0.2],
            (&[-2.0, -2.0], &[0.5, 2.0]),
            5000,
        );
        assert!((x[0] - 0.5).abs() < 1e-6, "{x:?}");
    }

    #[test]
    fn difference_jacobians_of_a_known_map() {
        // r(x) = (x0^2, x0 x1, 3 x1): J = [[2 x0, 0], [x1, x0], [0, 3]].
        let r = |x: &[f64]| vec![x[0] * x[0], x[0] * x[1], 3.0 * x[1]];
        let x = [1.5, -2.0];
        let h = [1e-6, 1e-6];
        let at = |c: usize, v: f64| {
            let mut y = x;
            y[c] = v;
            r(&y)
        };
        let exact = [[3.0, 0.0], [-2.0, 1.5], [0.0, 3.0]];
        let jc = central_jacobian(3, &x, &h, at);
        let jf = forward_jacobian(&r(&x), &x, &h, &[1.0, 2.0], at);
        for i in 0..3 {
            for c in 0..2 {
                assert!((jc[(i, c)] - exact[i][c]).abs() < 1e-6, "central {i},{c}");
                let want = exact[i][c] * [1.0, 2.0][c];
                assert!((jf[(i, c)] - want).abs() < 1e-4, "forward {i},{c}");
            }
        }
    }
}
