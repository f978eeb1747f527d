//! One round of selection: every candidate's withheld gain on top of the current design and
//! its null distribution from logs simulated under the current model.

use super::*;

/// Withheld gain (halved drop of the withheld SSE, per axis studentised by `rho`) of `cand`
/// over `cur` on the weighted residual `y`.
pub(super) fn gain(cur: &Solver, cand: &Solver, y: &DVector<f64>, rho: [f64; 2]) -> f64 {
    let s0 = linear::sse_axes(&cur.cv_residual(y));
    let s1 = linear::sse_axes(&cand.cv_residual(y));
    0.5 * ((s0[0] - s1[0]) / rho[0] + (s0[1] - s1[1]) / rho[1])
}

/// Quantile of a sample.
pub(super) fn quantile(x: &[f64], q: f64) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    let mut v = x.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// How far a candidate's withheld gain lies beyond its null's (1 - alpha) quantile: the
/// calibrated penalty for flexibility that orders candidates and the rules beside it.
pub(super) fn excess(s: &Scored, alpha: f64) -> f64 {
    s.gain - quantile(&s.null, 1.0 - alpha)
}

/// One candidate's result in a round.
pub(super) struct Scored {
    pub(super) name: Cand,
    pub(super) gain: f64,
    pub(super) null: Vec<f64>,
    pub(super) p: f64,
    pub(super) best: Option<Variant>,
    pub(super) variant: String,
}

/// Score every candidate on top of design `cur` by its withheld gain and its bootstrap null.
pub(super) fn score_round(
    lin: &Linear,
    cur: &Design,
    cands: &[(Cand, Vec<Variant>)],
    st: &Settings,
    round: usize,
) -> Option<Vec<Scored>> {
    let ds = lin.ds;
    let cur_s = Solver::new(cur, &lin.fold_of_stacked, lin.k)?;
    let one = vec![0usize; lin.y.len()];
    let cur_in = Solver::new(cur, &one, 1)?;
    // Fixed variants factor once.
    let fixed: Vec<Vec<Option<Solver>>> = cands
        .iter()
        .map(|(_, vs)| {
            vs.iter()
                .map(|v| {
                    columns_of(v, &lin.rc).and_then(|more| {
                        Solver::new(&cur.append(&more), &lin.fold_of_stacked, lin.k)
                    })
                })
                .collect()
        })
        .collect();
    let rough = noise::Roughness::new(ds);
    // Gains of every candidate (best variant) on one weighted residual, each variant's
    // studentised by the visit noise its own fit leaves (an F-type ratio: a structure that
    // inflates the current residual's visit noise, a drift that makes repeat visits at other
    // times differ, is judged against the noise left once it is fitted), and those noises.
    // `real` holds the real log's noises per candidate and variant: a simulated log's gains
    // are studentised relative to them.
    type Noises = Vec<Vec<[f64; 2]>>;
    let gains_of =
        |y: &DVector<f64>, real: Option<&Noises>| -> Option<(Vec<(f64, usize)>, Noises)> {
            let e0 = cur_in.residual(y);
            let mut out = Vec::with_capacity(cands.len());
            let mut sds: Noises = Vec::with_capacity(cands.len());
            for (ci, (_, vs)) in cands.iter().enumerate() {
                let mut best = (f64::NEG_INFINITY, 0);
                let mut sd_c = Vec::with_capacity(vs.len());
                for (vi, v) in vs.iter().enumerate() {
                    let found;
                    let solver = match v {
                        Variant::Anomaly => {
                            let (c, p) = anomaly_columns(lin, &e0);
                            found = Solver::new(&cur.extend(&c, &p), &lin.fold_of_stacked, lin.k);
                            found.as_ref()
                        }
                        Variant::Band => {
                            found = band_family(lin, &e0).and_then(|f| {
                                Solver::new(
                                    &cur.append(&shapes::design(&f, &lin.rc)),
                                    &lin.fold_of_stacked,
                                    lin.k,
                                )
                            });
                            found.as_ref()
                        }
                        _ => fixed[ci][vi].as_ref(),
                    };
                    let Some(s) = solver else {
                        sd_c.push([1.0, 1.0]);
                        continue;
                    };
                    let sd = rough.visit_sd_stacked(&s.residual(y), lin.rc.w).ok()?;
                    sd_c.push(sd);
                    let rho = match real {
                        Some(r) => {
                            let r = r[ci][vi];
                            [(sd[0] / r[0]).powi(2), (sd[1] / r[1]).powi(2)]
                        }
                        None => [1.0, 1.0],
                    };
                    let g = gain(&cur_s, s, y, rho);
                    if real.is_none() {
                        log::debug!("{}: {} gains {g:.1}", cands[ci].0.name(), describe(v));
                    }
                    if g > best.0 {
                        best = (g, vi);
                    }
                }
                out.push(best);
                sds.push(sd_c);
            }
            Some((out, sds))
        };
    let (obs, real_sds) = gains_of(&lin.y, None)?;
    let seed = st.seed ^ (round as u64).wrapping_mul(0xA77_0001);
    let null: Vec<Vec<(f64, usize)>> = (0..st.boot)
        .into_par_iter()
        .filter_map(|b| {
            let y = noise::simulate(ds, &lin.noise, lin.rc.w, seed, b);
            gains_of(&y, Some(&real_sds)).map(|x| x.0)
        })
        .collect();
    let one_fold_e0 = cur_in.residual(&lin.y);
    Some(
        cands
            .iter()
            .enumerate()
            .map(|(ci, (name, vs))| {
                let nl: Vec<f64> = null.iter().map(|v| v[ci].0).collect();
                let (g, vi) = obs[ci];
                let best = match &vs[vi] {
                    Variant::Anomaly => {
                        let (c, _) = anomaly_columns(lin, &one_fold_e0);
                        Some(Variant::Column("box", c))
                    }
                    Variant::Band => band_family(lin, &one_fold_e0).map(Variant::Shape),
                    v => Some(v.clone()),
                };
                Scored {
                    name: *name,
                    gain: g,
                    p: noise::boot_p(g, &nl),
                    null: nl,
                    variant: describe(&vs[vi]),
                    best,
                }
            })
            .collect(),
    )
}
