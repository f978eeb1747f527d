//! How far a log's order ties session time to the inputs: in a sweep (z_m outer, f inner)
//! a course over session time is also a shape over (z_m, f), and a drift cannot be told from
//! an effect of the inputs.

use super::*;

/// Share of the visits' session times (adjusted R^2) that the inputs explain above which a
/// drift is not named: in a sweep (z_m outer, f inner) the order makes session time a
/// function of the inputs. A random order leaves chance levels (about the share of columns
/// among visits, which the adjustment removes).
pub(super) const TIME_TIED_TO_INPUTS: f64 = 0.8;

/// How far session time follows the inputs: the adjusted R^2 of the visits' mid times
/// (about each session's mean) on additive levels of z_m and f. Near 1 in a sweep, near 0 in
/// a random order or where points are revisited at other times. 0 where there are too few
/// visits to tell.
pub(super) fn time_tied_to_inputs(ds: &Dataset) -> f64 {
    let (cell, nz, nf) = noise::cells(ds);
    let ns = ds.sessions.len().max(1);
    let p = ns + nz.saturating_sub(1) + nf.saturating_sub(1);
    let n = ds.visits.len();
    if n < p + 5 {
        return 0.0;
    }
    let mut x = DMatrix::zeros(n, p);
    let mut y = DVector::zeros(n);
    for (i, v) in ds.visits.iter().enumerate() {
        let (zi, fi) = cell[i];
        x[(i, v.sess.min(ns - 1))] = 1.0;
        if zi > 0 {
            x[(i, ns + zi - 1)] = 1.0;
        }
        if fi > 0 {
            x[(i, ns + nz - 1 + fi - 1)] = 1.0;
        }
        y[i] = v.t_mid;
    }
    // Total sum of squares about each session's mean.
    let mut sst = 0.0;
    for s in 0..ns {
        let ts: Vec<f64> = ds
            .visits
            .iter()
            .filter(|v| v.sess == s)
            .map(|v| v.t_mid)
            .collect();
        let m = ts.iter().sum::<f64>() / ts.len().max(1) as f64;
        sst += ts.iter().map(|t| (t - m).powi(2)).sum::<f64>();
    }
    let Ok(beta) = x.clone().svd(true, true).solve(&y, 1e-10) else {
        return 0.0;
    };
    let sse = (&y - &x * beta).norm_squared();
    if sst <= 0.0 {
        return 0.0;
    }
    let dof_res = (n - p) as f64;
    let dof_tot = (n - ns) as f64;
    (1.0 - (sse / dof_res) / (sst / dof_tot)).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use magswarm_identify::data::{Row, Session};
    use magswarm_model::Model;

    /// A log visiting `points` in the given order, 5 rows per visit 1 s apart.
    fn log(points: &[(f64, f64)]) -> Dataset {
        let mut rows = Vec::new();
        let mut t = 0.0;
        for (v, &(z, f)) in points.iter().enumerate() {
            for k in 0..5 {
                t += 1.0;
                rows.push(Row {
                    t,
                    z_mm: z,
                    f_hz: f,
                    r: Some([10.0, 12.0]),
                    visit: v,
                    since: 1.0 + k as f64,
                    settled: k >= 2,
                    line: rows.len() + 2,
                });
            }
        }
        let s = Session {
            name: "test".into(),
            rows,
        };
        Dataset::build(&[s], &Model::paper()).expect("a usable log")
    }

    fn grid() -> Vec<(f64, f64)> {
        let mut g = Vec::new();
        for z in [3.5, 8.5, 13.5, 18.5, 23.5] {
            for f in 1..=10 {
                g.push((z, f as f64));
            }
        }
        g
    }

    #[test]
    fn a_sweep_ties_session_time_to_the_inputs_and_a_random_order_does_not() {
        let sweep = time_tied_to_inputs(&log(&grid()));
        assert!(sweep > 0.95, "sweep: {sweep}");
        let mut shuffled = grid();
        shuffled.shuffle(&mut rand::rngs::StdRng::seed_from_u64(7));
        let random = time_tied_to_inputs(&log(&shuffled));
        assert!(random < 0.5, "random order: {random}");
        // The grid swept twice: the second visit of each point comes half a session later.
        let twice: Vec<_> = grid().into_iter().chain(grid()).collect();
        let two = time_tied_to_inputs(&log(&twice));
        assert!(two < TIME_TIED_TO_INPUTS, "swept twice: {two}");
    }
}
