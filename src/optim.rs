//! Optimisation helpers shared by the commands. Least squares go through the
//! `levenberg-marquardt` crate; what is here is what no kept crate in the build offers.

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
