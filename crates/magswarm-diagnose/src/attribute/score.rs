//! One round of selection: every candidate's withheld gain on top of the current design and
//! its null distribution from logs simulated under the current model.

use super::*;

/// Withheld gain (halved drop of the withheld SSE, per axis studentised by `rho`) of `cand`
/// over `cur` on the weighted residual `y`.
pub(super) fn gain(cur: &Solver, cand: &Solver, y: &DVector<f64>, rho: [f64; 2]) -> f64 {
    let s0 = linear::sse_axes(&cur.cv_residual(y));
    gain_over(s0, linear::sse_axes(&cand.cv_residual(y)), rho)
}

/// The within-visit part of a row's variance in the weighted residual's units (a row's whole
/// noise, its visit's offset included): what a gain judged within the visits is scaled by.
pub(super) fn rho_within(lin: &Linear) -> [f64; 2] {
    std::array::from_fn(|a| {
        let r = (lin.noise.within[a] * lin.rc.w[a]).powi(2);
        if r.is_finite() && r > 0.0 {
            r.min(1.0)
        } else {
            1.0
        }
    })
}

/// [`gain`] from the current design's withheld sums of squares `s0` (the same for every
/// variant of a log) and the candidate's, `s1`.
fn gain_over(s0: [f64; 2], s1: [f64; 2], rho: [f64; 2]) -> f64 {
    0.5 * ((s0[0] - s1[0]) / rho[0] + (s0[1] - s1[1]) / rho[1])
}

/// `f` of every fixed variant's solver, per candidate and variant (None where a variant has
/// no solver).
fn map_fixed<T>(fixed: &[Vec<Option<Solver>>], f: impl Fn(&Solver) -> T) -> Vec<Vec<Option<T>>> {
    fixed
        .iter()
        .map(|vs| vs.iter().map(|s| s.as_ref().map(&f)).collect())
        .collect()
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
    /// The smallest raw p-value over its kinds of variant (unadjusted).
    pub(super) raw_p: f64,
    /// Each simulated log's smallest p over the kinds, read as the real log's
    /// (`noise::replicate_ps`), by replicate number (NaN: not evaluated). The simulated logs
    /// are the gap tests' own: the round's gate pairs them replicate by replicate.
    pub(super) rep_p: Vec<f64>,
    /// Kinds of variant judged (statistics this candidate adds to a joint min-p).
    pub(super) kinds: usize,
}

/// Score every candidate on top of design `cur` by its withheld gain and its bootstrap null.
pub(super) fn score_round(
    lin: &Linear,
    cur: &Design,
    cands: &[(Cand, Vec<Variant>)],
    st: &Settings,
) -> Option<Vec<Scored>> {
    let ds = lin.ds;
    let cur_s = Solver::new(cur, &lin.fold_of_stacked, lin.k)?;
    let one = vec![0usize; lin.y.len()];
    let cur_in = Solver::new(cur, &one, 1)?;
    // A shape within the visits extends the current design as it varies within the visits
    // (its columns less each visit's mean): against the current columns themselves, which
    // vary between visits (a time scale, the steady parameters), the shape's refit would move
    // them, and the visits' offsets, several times the row noise, would pass into its gain.
    // Not with the gap tests' within-only nuisance (the rig's own approach at the baseline's
    // time constant): that takes most of a rate-limited formation's gain (a third-generator
    // log on streamed steps, named at p = 0.006 without it, was left at p = 0.05), and a
    // formation is named only where those tests, nuisance included, see one.
    let within = |v: &Variant| matches!(v, Variant::Shape(f) if f.within);
    let cur_w = cands.iter().flat_map(|c| &c.1).any(within).then(|| {
        let mut d = cur.clone();
        shapes::within_visits(&lin.rc.visit, &mut d.a);
        d
    });
    let cur_ws = match &cur_w {
        Some(d) => Some(Solver::new(d, &lin.fold_of_stacked, lin.k)?),
        None => None,
    };
    // Fixed variants factor once.
    let fixed: Vec<Vec<Option<Solver>>> = cands
        .iter()
        .map(|(_, vs)| {
            vs.iter()
                .map(|v| {
                    let base = match &cur_w {
                        Some(d) if within(v) => d,
                        _ => cur,
                    };
                    columns_of(v, &lin.rc).and_then(|more| {
                        Solver::new(&base.append(&more), &lin.fold_of_stacked, lin.k)
                    })
                })
                .collect()
        })
        .collect();
    let rough = noise::Roughness::new(ds);
    let rho_within = rho_within(lin);
    // Gains of every candidate (best variant) on one weighted residual, each variant's
    // studentised by the visit noise its own fit leaves (an F-type ratio: a structure that
    // inflates the current residual's visit noise, a drift that makes repeat visits at other
    // times differ, is judged against the noise left once it is fitted), and those noises.
    // `real` holds the real log's noises per candidate and variant: a simulated log's gains
    // are studentised relative to them.
    type Noises = Vec<Vec<[f64; 2]>>;
    // What the variants fixed in advance leave of one log: the visit noise of the full fit
    // (None where too few pairs of visits read it) and the withheld sums of squares, per
    // candidate and variant (None: no solver for that variant).
    type FixedFits = Vec<Vec<Option<(Option<[f64; 2]>, [f64; 2])>>>;
    // One log (real or simulated): its weighted residual, the current design's in-sample
    // residual and withheld sums of squares (and as the shapes within the visits see it),
    // and the fixed variants' fits.
    struct LogFit {
        y: DVector<f64>,
        e0: DVector<f64>,
        s0: [f64; 2],
        s0w: Option<[f64; 2]>,
        fixed: FixedFits,
    }
    // The real log, one product at a time.
    let log_fit = |y: DVector<f64>| -> LogFit {
        let fixed: FixedFits = map_fixed(&fixed, |s| {
            let (r, cv) = s.fits(&y);
            (
                rough.visit_sd_stacked(&r, lin.rc.w).ok(),
                linear::sse_axes(&cv),
            )
        });
        LogFit {
            e0: cur_in.residual(&y),
            s0: linear::sse_axes(&cur_s.cv_residual(&y)),
            s0w: cur_ws
                .as_ref()
                .map(|w| linear::sse_axes(&w.cv_residual(&y))),
            fixed,
            y,
        }
    };
    // Simulated logs, a batch at a time: the products with the tall design become matrix
    // products (the bulk of a long log's diagnosis), each column what `log_fit` gives.
    let batch_fits = |ys: Vec<DVector<f64>>| -> Vec<LogFit> {
        let ym = DMatrix::from_columns(&ys);
        let cols = |m: &DMatrix<f64>| -> Vec<DVector<f64>> {
            (0..m.ncols()).map(|j| m.column(j).into_owned()).collect()
        };
        let sse_cols = |m: &DMatrix<f64>| -> Vec<[f64; 2]> {
            (0..m.ncols())
                .map(|j| linear::sse_axes_of(m.column(j).iter()))
                .collect()
        };
        let e0 = cols(&cur_in.residual_batch(&ym));
        let s0 = sse_cols(&cur_s.cv_batch(&ym));
        let s0w: Vec<Option<[f64; 2]>> = match &cur_ws {
            Some(w) => sse_cols(&w.cv_batch(&ym)).into_iter().map(Some).collect(),
            None => vec![None; ys.len()],
        };
        // Per candidate and variant, each log's (visit noise, withheld sums of squares).
        type Fits = Vec<(Option<[f64; 2]>, [f64; 2])>;
        let per: Vec<Vec<Option<Fits>>> = map_fixed(&fixed, |s| {
            let (r, cv) = s.fits_batch(&ym);
            (0..ym.ncols())
                .map(|j| {
                    let rj = r.column(j).into_owned();
                    (
                        rough.visit_sd_stacked(&rj, lin.rc.w).ok(),
                        linear::sse_axes_of(cv.column(j).iter()),
                    )
                })
                .collect()
        });
        ys.into_iter()
            .enumerate()
            .map(|(j, y)| LogFit {
                fixed: per
                    .iter()
                    .map(|vs| vs.iter().map(|f| f.as_ref().map(|f| f[j])).collect())
                    .collect(),
                e0: e0[j].clone(),
                s0: s0[j],
                s0w: s0w[j],
                y,
            })
            .collect()
    };
    // Gains of every candidate (best variant) on one weighted residual, each variant's
    // studentised by the visit noise its own fit leaves (an F-type ratio: a structure that
    // inflates the current residual's visit noise, a drift that makes repeat visits at other
    // times differ, is judged against the noise left once it is fitted), and those noises.
    // `real` holds the real log's noises per candidate and variant: a simulated log's gains
    // are studentised relative to them.
    let gains_of = |lf: &LogFit, real: Option<&Noises>| -> Option<(Vec<Vec<f64>>, Noises)> {
        let (y, e0, s0, s0w) = (&lf.y, &lf.e0, lf.s0, lf.s0w);
        // The variants found on each log (a box, a band) are fitted here, the real log's with
        // the exact arithmetic (`Solver::for_simulated`); the fixed ones were fitted with
        // the log.
        let solver = if real.is_none() {
            Solver::new
        } else {
            Solver::for_simulated
        };
        let mut out = Vec::with_capacity(cands.len());
        let mut sds: Noises = Vec::with_capacity(cands.len());
        for (ci, (_, vs)) in cands.iter().enumerate() {
            let mut gs = Vec::with_capacity(vs.len());
            let mut sd_c = Vec::with_capacity(vs.len());
            for (vi, v) in vs.iter().enumerate() {
                let found = match v {
                    Variant::Anomaly => {
                        let (c, p) = anomaly_columns(lin, e0);
                        Some(solver(&cur.extend(&c, &p), &lin.fold_of_stacked, lin.k))
                    }
                    Variant::Band => Some(band_family(lin, e0).and_then(|f| {
                        solver(
                            &cur.append(&shapes::design(&f, &lin.rc)),
                            &lin.fold_of_stacked,
                            lin.k,
                        )
                    })),
                    _ => None,
                };
                let fit = match found {
                    Some(s) => s.map(|s| {
                        let (r, cv) = s.fits(y);
                        (
                            rough.visit_sd_stacked(&r, lin.rc.w).ok(),
                            linear::sse_axes(&cv),
                        )
                    }),
                    None => lf.fixed[ci][vi],
                };
                let Some((sd, s1)) = fit else {
                    sd_c.push([1.0, 1.0]);
                    gs.push(f64::NEG_INFINITY);
                    continue;
                };
                let sd = sd?;
                sd_c.push(sd);
                // A shape within the visits is blind to their noise: its gain is a
                // log-likelihood in units of the noise of a row about its visit's mean
                // (the weighted residual's unit is a row's whole noise, visit offset
                // included), against the current design as it varies within them.
                let (rho, from) = match (real, s0w) {
                    (_, Some(w)) if within(v) => (rho_within, w),
                    (Some(r), _) => {
                        let r = r[ci][vi];
                        ([(sd[0] / r[0]).powi(2), (sd[1] / r[1]).powi(2)], s0)
                    }
                    (None, _) => ([1.0, 1.0], s0),
                };
                let g = gain_over(from, s1, rho);
                if real.is_none() {
                    log::debug!("{}: {} gains {g:.1}", cands[ci].0.name(), describe(v));
                }
                gs.push(g);
            }
            out.push(gs);
            sds.push(sd_c);
        }
        Some((out, sds))
    };
    let (obs, real_sds) = gains_of(&log_fit(lin.y.clone()), None)?;
    // The gap tests' simulated logs (`setting`'s seed): replicate b here is replicate b there.
    let seed = st.seed ^ detect::SEED;
    let chunks: Vec<Vec<Option<Vec<Vec<f64>>>>> = (0..st.boot.div_ceil(linear::BATCH))
        .into_par_iter()
        .map(|c| {
            let ys = (c * linear::BATCH..((c + 1) * linear::BATCH).min(st.boot))
                .map(|b| noise::simulate(ds, &lin.noise, lin.rc.w, seed, b))
                .collect();
            batch_fits(ys)
                .iter()
                .map(|lf| gains_of(lf, Some(&real_sds)).map(|x| x.0))
                .collect()
        })
        .collect();
    let by_rep: Vec<Option<Vec<Vec<f64>>>> = chunks.into_iter().flatten().collect();
    let null: Vec<&Vec<Vec<f64>>> = by_rep.iter().flatten().collect();
    let one_fold_e0 = cur_in.residual(&lin.y);
    Some(
        cands
            .iter()
            .enumerate()
            .map(|(ci, (name, vs))| {
                // Variants of one kind (shapes that move the visits' means) compete by
                // their raw gain; kinds (those and the shapes within each visit) by min-p.
                let kind = |v: &Variant| usize::from(within(v));
                let kinds: Vec<usize> = (0..2)
                    .filter(|&k| vs.iter().any(|v| kind(v) == k))
                    .collect();
                // The best variant of a kind (the first among equal gains).
                let best_of = |gs: &[f64], k: usize| -> (f64, usize) {
                    let mut of_kind = (0..vs.len()).filter(|&vi| kind(&vs[vi]) == k);
                    let first = of_kind.next().expect("a kind has a variant");
                    of_kind.fold((gs[first], first), |a, vi| {
                        if gs[vi] > a.0 {
                            (gs[vi], vi)
                        } else {
                            a
                        }
                    })
                };
                let obs_k: Vec<(f64, usize)> =
                    kinds.iter().map(|&k| best_of(&obs[ci], k)).collect();
                let null_k: Vec<Vec<f64>> = kinds
                    .iter()
                    .map(|&k| null.iter().map(|r| best_of(&r[ci], k).0).collect())
                    .collect();
                let obs_g: Vec<f64> = obs_k.iter().map(|x| x.0).collect();
                let MinP {
                    kind: ki,
                    p,
                    null: nl,
                    raw,
                    rep_min,
                } = min_p(&obs_g, &null_k);
                let (g, vi) = obs_k[ki];
                if kinds.len() > 1 {
                    log::debug!(
                        "{}: best kind {} (gain {g:.1}, p {p:.2e})",
                        name.name(),
                        describe(&vs[vi]),
                    );
                }
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
                    p,
                    null: nl,
                    variant: describe(&vs[vi]),
                    best,
                    raw_p: raw,
                    rep_p: noise::by_replicate_number(&by_rep, &rep_min),
                    kinds: kinds.len(),
                }
            })
            .collect(),
    )
}

/// A candidate judged over its kinds of variant by the smallest p-value.
pub(super) struct MinP {
    /// The kind (index into the gains given) with the smallest p (the larger gain among ties).
    pub(super) kind: usize,
    /// Its p-value calibrated for the choice among the kinds.
    pub(super) p: f64,
    /// The null of the best kind's gain with the choice among the kinds priced in: each
    /// replicate's smallest p, read back as a gain on the best kind's own null.
    pub(super) null: Vec<f64>,
    /// The smallest raw p over the kinds.
    pub(super) raw: f64,
    /// Each replicate's smallest p over the kinds, read as the observed ones.
    pub(super) rep_min: Vec<f64>,
}

/// Min-p over kinds of a candidate's variants (Westfall and Young): each kind's gain is read
/// against its own null, and the smallest p against the smallest p of each simulated log.
/// Kinds are not alike in spread: a shape within the visits, blind to their offsets, has a
/// null a tenth as wide as a shape that moves the visits' means; the largest raw gain would
/// let the widest null decide, and a transient plain to the within-visit test would never
/// pass the candidate's null.
pub(super) fn min_p(obs: &[f64], null: &[Vec<f64>]) -> MinP {
    if let ([g], [nl]) = (obs, null) {
        // One kind: its own p and null, as they are.
        let p = noise::boot_p(*g, nl);
        return MinP {
            kind: 0,
            p,
            null: nl.clone(),
            raw: p,
            rep_min: noise::replicate_ps(*g, nl),
        };
    }
    let obs_p: Vec<f64> = obs
        .iter()
        .zip(null)
        .map(|(&g, nl)| {
            if g.is_finite() {
                noise::boot_p(g, nl)
            } else {
                1.0
            }
        })
        .collect();
    let mut kind = 0;
    let mut best = f64::INFINITY;
    for (k, (&g, &p)) in obs.iter().zip(&obs_p).enumerate() {
        if p < best || (p == best && g > obs[kind]) {
            (kind, best) = (k, p);
        }
    }
    // Each replicate's p read as the observed one's (against the other draws, with the same
    // extrapolated tail: `noise::replicate_ps`), so that an observed gain beyond every
    // replicate of one kind does not win by a p no replicate can reach.
    let rep_p: Vec<Vec<f64>> = (0..obs.len())
        .map(|k| {
            let g = if obs[k].is_finite() {
                obs[k]
            } else {
                f64::NEG_INFINITY
            };
            noise::replicate_ps(g, &null[k])
        })
        .collect();
    let (p, rep_min) = noise::min_p(&obs_p, &rep_p);
    let null = rep_min
        .iter()
        .map(|&m| quantile(&null[kind], 1.0 - m))
        .collect();
    MinP {
        kind,
        p,
        null,
        raw: best,
        rep_min,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// Two kinds of variant, one with a null ten times as wide: a gain far out in the narrow
    /// one's null names it although the wide one's raw gain is larger, and on replicates of
    /// the null itself the calibrated p rejects at about the level set.
    #[test]
    fn min_p_reads_each_kind_against_its_own_null() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
        let null: Vec<Vec<f64>> = [10.0, 1.0]
            .iter()
            .map(|s| (0..499).map(|_| s * g()).collect())
            .collect();
        // One kind alone is read as it always was.
        let one = min_p(&[12.0], &null[..1]);
        assert_eq!(one.p, noise::boot_p(12.0, &null[0]));
        assert_eq!(one.null, null[0]);
        let r = min_p(&[12.0, 5.0], &null);
        assert_eq!(r.kind, 1);
        assert!(r.p < 0.01, "{}", r.p);
        assert!(quantile(&r.null, 0.99) < 5.0);
        // The wide variant's gain alone (2.2 of its SDs) is not enough once the choice is paid.
        assert!(min_p(&[22.0, 0.0], &null).p > 0.01);
        let fresh: Vec<[f64; 2]> = (0..1000).map(|_| [10.0 * g(), g()]).collect();
        let rejected = fresh
            .iter()
            .filter(|o| noise::rejects(min_p(&o[..], &null).p, 0.05))
            .count();
        assert!((30..=75).contains(&rejected), "{rejected} of 1000 at 0.05");
    }
}
