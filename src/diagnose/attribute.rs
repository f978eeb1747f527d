//! Attribution: which candidate effect explains the gap, by grouped cross-validation.
//!
//! Folds are groups of whole visits (rows of one visit share a visit-to-visit error). For a
//! model (the baseline plus a set of effects) every fold is refitted on the other folds' rows
//! (the baseline's free steady parameters and every effect parameter together) and predicts
//! its own rows. A candidate c added to the accepted set A is accepted when, all at once:
//!
//! 1. its withheld log-likelihood gain over A, sum over visits of
//!    (SSE_A - SSE_c) / 2 in units of the row SD, exceeds the BIC penalty k/2 ln(visits);
//! 2. the per-visit gains are positive by a one-sided paired t test at `alpha`;
//! 3. its parameters are physically plausible: none at a fit bound, a location (step-out
//!    frequency, cohesion distance) inside the data's range;
//! 4. its residual signature matches: refitted on all data it removes at least half of the
//!    residual of at least one significant region (in later rounds: a region of the residual
//!    the accepted effects leave, found by the same gap tests and localisation), or, with it,
//!    the gap tests find no significant gap left at all (a region of the baseline's residual
//!    can be partly the baseline's compensation, which the joint refit moves elsewhere).
//!
//! Forward selection repeats this on top of the accepted set (up to three effects). When the
//! best two passing candidates cannot be told apart (the better one is not better by a paired
//! test at 0.05) and explain the same residual (their corrections correlate > 0.7 over the
//! visits, or they explain the same region best), neither is named: both are reported as
//! ambiguous and the gap stays unexplained.

use super::candidates::{self, Augmented, Ctx};
use super::data::Dataset;
use super::fitter::{self, FitResult};
use super::gap::{self, Region};
use super::stats;
use crate::identify::params::Free;
use rand::{seq::SliceRandom, SeedableRng};

/// Settings.
#[derive(Debug, Clone, Copy)]
pub struct Settings {
    /// Folds.
    pub folds: usize,
    /// Significance of the withheld gain.
    pub alpha: f64,
    /// Most effects accepted.
    pub max_effects: usize,
    /// Seed of the fold assignment.
    pub seed: u64,
}

/// A model fitted on all rows and cross-validated.
#[derive(Debug, Clone)]
pub struct Evaluated {
    /// Effects (names, in order of addition).
    pub names: Vec<String>,
    /// Fit on all rows.
    pub full: FitResult,
    /// Predictions of the full fit at every row.
    pub pred: Vec<[f64; 2]>,
    /// Withheld predictions (each row by the fit that did not see its visit).
    pub cv: Vec<[f64; 2]>,
}

/// The evaluation of one candidate in one round.
#[derive(Debug, Clone)]
pub struct CandidateEval {
    /// Name.
    pub name: String,
    /// Round (1 = on top of the baseline).
    pub round: usize,
    /// The model with it.
    pub model: Evaluated,
    /// Withheld log-likelihood gain over the accepted set.
    pub gain: f64,
    /// BIC penalty.
    pub penalty: f64,
    /// One-sided paired p-value of the gain.
    pub p: f64,
    /// Problems of plausibility (empty: plausible).
    pub implausible: Vec<String>,
    /// Largest share of a significant region's residual it removes, and that region's index.
    pub signature: (f64, Option<usize>),
    /// With it, the gap tests on the residual find no significant gap left (checked only for
    /// a candidate that passes every other rule but removes less than half of every region:
    /// a region found on the baseline's residual can be partly the baseline's compensation,
    /// which a refit moves elsewhere).
    pub closes_gap: bool,
    /// Passed all four rules.
    pub passed: bool,
    /// Accepted.
    pub accepted: bool,
    /// Candidates it cannot be told apart from.
    pub ambiguous_with: Vec<String>,
}

/// Everything attribution produced.
#[derive(Debug, Clone)]
pub struct Attribution {
    /// The baseline, evaluated the same way.
    pub baseline: Evaluated,
    /// The final model (baseline plus accepted effects).
    pub augmented: Evaluated,
    /// Accepted effects, most important first.
    pub accepted: Vec<String>,
    /// Latest evaluation of every candidate.
    pub evals: Vec<CandidateEval>,
    /// Pairs that could not be told apart.
    pub ambiguous: Vec<(String, String)>,
    /// Fold of each visit.
    pub fold_of_visit: Vec<usize>,
}

/// Fold of each visit: shuffled, then dealt round-robin.
pub fn folds(nv: usize, k: usize, seed: u64) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..nv).collect();
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ 0xF01D);
    idx.shuffle(&mut rng);
    let mut f = vec![0; nv];
    for (r, &v) in idx.iter().enumerate() {
        f[v] = r % k.max(1);
    }
    f
}

struct Env<'a> {
    ds: &'a Dataset,
    ctx: &'a Ctx,
    free: &'a [Free],
    sd: [f64; 2],
    fold_of_visit: &'a [usize],
    k: usize,
}

impl Env<'_> {
    fn evaluate(&self, start: &Augmented, names: Vec<String>, starts: &[Vec<f64>]) -> Evaluated {
        let all: Vec<usize> = (0..self.ds.rows.len()).collect();
        let full = fitter::fit(start, self.free, self.ds, self.ctx, &all, self.sd, starts);
        let pred = candidates::predict(&full.aug, self.ds);
        let mut cv = vec![[0.0; 2]; self.ds.rows.len()];
        for f in 0..self.k {
            let train: Vec<usize> = all
                .iter()
                .copied()
                .filter(|&i| self.fold_of_visit[self.ds.rows[i].visit] != f)
                .collect();
            if train.len() == all.len() {
                continue;
            }
            let fr = fitter::fit(
                &full.aug,
                self.free,
                self.ds,
                self.ctx,
                &train,
                self.sd,
                &[],
            );
            let p = candidates::predict(&fr.aug, self.ds);
            for i in 0..self.ds.rows.len() {
                if self.fold_of_visit[self.ds.rows[i].visit] == f {
                    cv[i] = p[i];
                }
            }
        }
        Evaluated {
            names,
            full,
            pred,
            cv,
        }
    }

    /// Per-visit withheld SSE in row-SD units.
    fn visit_sse(&self, e: &Evaluated) -> Vec<f64> {
        let mut s = vec![0.0; self.ds.visits.len()];
        for (i, r) in self.ds.rows.iter().enumerate() {
            for a in 0..2 {
                let d = (e.cv[i][a] - r.r[a]) / self.sd[a];
                s[r.visit] += d * d;
            }
        }
        s
    }
}

fn residuals(ds: &Dataset, pred: &[[f64; 2]]) -> Vec<[f64; 2]> {
    ds.rows
        .iter()
        .zip(pred)
        .map(|(r, p)| [r.r[0] - p[0], r.r[1] - p[1]])
        .collect()
}

fn visit_means(ds: &Dataset, v: &[[f64; 2]]) -> Vec<f64> {
    let vr = gap::visit_residuals(ds, v);
    vr.e.iter().flat_map(|e| [e[0], e[1]]).collect()
}

/// Run the attribution.
#[allow(clippy::too_many_arguments)]
pub fn attribute(
    ds: &Dataset,
    ctx: &Ctx,
    baseline: &Augmented,
    free: &[Free],
    sd: [f64; 2],
    regions: &[Region],
    base_map: &[[f64; 2]],
    st: Settings,
    relocalise: &(dyn Fn(&[[f64; 2]]) -> Vec<Region> + Sync),
    progress: &indicatif::ProgressBar,
) -> Attribution {
    let nv = ds.visits.len();
    let k = st.folds.min(nv).max(2);
    let fold_of_visit = folds(nv, k, st.seed);
    let env = Env {
        ds,
        ctx,
        free,
        sd,
        fold_of_visit: &fold_of_visit,
        k,
    };
    let base = env.evaluate(baseline, Vec::new(), &[]);
    progress.inc(1);
    let mut current = base.clone();
    let mut accepted: Vec<String> = Vec::new();
    let mut evals: Vec<CandidateEval> = Vec::new();
    let mut ambiguous = Vec::new();
    if regions.is_empty() {
        // No significant gap: nothing to attribute.
        for n in candidates::NAMES {
            progress.inc(1);
            let _ = n;
        }
        return Attribution {
            baseline: base.clone(),
            augmented: base,
            accepted,
            evals,
            ambiguous,
            fold_of_visit,
        };
    }
    let mut regions: Vec<Region> = regions.to_vec();
    for round in 1..=st.max_effects {
        let sse_cur = env.visit_sse(&current);
        let res_cur = residuals(ds, &current.pred);
        if round > 1 {
            // The next effect must explain what the accepted ones leave: the gap tests and the
            // regions on the current residuals. No gap left: stop.
            regions = relocalise(&res_cur);
            if regions.is_empty() {
                break;
            }
        }
        let todo: Vec<&str> = candidates::NAMES
            .iter()
            .copied()
            .filter(|n| !accepted.iter().any(|a| a == n))
            .collect();
        // Fit the candidates in parallel (each is independent).
        let threads = std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
            .clamp(1, 4);
        let results: Vec<(usize, Evaluated)> = std::thread::scope(|sc| {
            let env = &env;
            let current = &current;
            let todo = &todo;
            let handles: Vec<_> = (0..threads)
                .map(|t| {
                    sc.spawn(move || {
                        let mut out = Vec::new();
                        for (j, name) in todo.iter().enumerate().skip(t).step_by(threads) {
                            let mut start = current.full.aug.clone();
                            start
                                .effects
                                .push((name.to_string(), candidates::neutral(name, env.ctx)));
                            let starts = candidates::starts(name, env.ctx, env.ds);
                            let mut names = current.names.clone();
                            names.push(name.to_string());
                            out.push((j, env.evaluate(&start, names, &starts)));
                            progress.inc(1);
                        }
                        out
                    })
                })
                .collect();
            let mut all: Vec<(usize, Evaluated)> = handles
                .into_iter()
                .flat_map(|h| h.join().expect("candidate thread"))
                .collect();
            all.sort_by_key(|x| x.0);
            all
        });
        let mut round_evals: Vec<CandidateEval> = Vec::new();
        for (j, model) in results {
            let name = todo[j].to_string();
            let sse = env.visit_sse(&model);
            let gains: Vec<f64> = sse_cur
                .iter()
                .zip(&sse)
                .map(|(a, b)| (a - b) / 2.0)
                .collect();
            let gain: f64 = gains.iter().sum();
            let (_, t, _) = stats::one_sample_t(&gains);
            let p = if gains.len() >= 3 && t.is_finite() {
                stats::t_sf(t, (gains.len() - 1) as f64)
            } else if t == f64::INFINITY {
                0.0
            } else {
                1.0
            };
            let npar = candidates::params(&name, ctx).len();
            let penalty = npar as f64 / 2.0 * (nv as f64).ln();
            let mut implausible: Vec<String> = model
                .full
                .at_bound
                .iter()
                .filter(|(e, _)| *e == name)
                .map(|(_, p)| format!("{p} at its bound"))
                .collect();
            implausible.extend(candidates::implausible(&name, &model.full.aug, ctx));
            let res_new = residuals(ds, &model.pred);
            let mut signature = (0.0f64, None);
            for (ri, r) in regions.iter().enumerate() {
                let before = gap::region_mean(ds, &res_cur, base_map, r);
                let after = gap::region_mean(ds, &res_new, base_map, r);
                if before.abs() > 1e-12 {
                    let share = 1.0 - after.abs() / before.abs();
                    if share > signature.0 {
                        signature = (share, Some(ri));
                    }
                }
            }
            let others = gain > penalty && p < st.alpha && implausible.is_empty();
            let closes_gap = others && signature.0 < 0.5 && relocalise(&res_new).is_empty();
            if closes_gap && signature.1.is_none() {
                signature.1 = Some(0);
            }
            let passed = others && (signature.0 >= 0.5 || closes_gap);
            round_evals.push(CandidateEval {
                name,
                round,
                model,
                gain,
                penalty,
                p,
                implausible,
                signature,
                closes_gap,
                passed,
                accepted: false,
                ambiguous_with: Vec::new(),
            });
        }
        // Best passing, and who it cannot be told apart from.
        let mut passing: Vec<usize> = (0..round_evals.len())
            .filter(|&i| round_evals[i].passed)
            .collect();
        passing.sort_by(|&a, &b| round_evals[b].gain.total_cmp(&round_evals[a].gain));
        let mut chosen = None;
        if let Some(&b) = passing.first() {
            let sse_b = env.visit_sse(&round_evals[b].model);
            let d_b: Vec<f64> = {
                let p = visit_means(ds, &round_evals[b].model.pred);
                let c = visit_means(ds, &current.pred);
                p.iter().zip(&c).map(|(x, y)| x - y).collect()
            };
            let mut amb = Vec::new();
            for &o in passing.iter().skip(1) {
                let sse_o = env.visit_sse(&round_evals[o].model);
                let diff: Vec<f64> = sse_o
                    .iter()
                    .zip(&sse_b)
                    .map(|(a, b)| (a - b) / 2.0)
                    .collect();
                let (_, t, _) = stats::one_sample_t(&diff);
                let p = if t.is_finite() {
                    stats::t_sf(t, (diff.len().max(2) - 1) as f64)
                } else {
                    0.0
                };
                let d_o: Vec<f64> = {
                    let p = visit_means(ds, &round_evals[o].model.pred);
                    let c = visit_means(ds, &current.pred);
                    p.iter().zip(&c).map(|(x, y)| x - y).collect()
                };
                let same_region = round_evals[o].signature.1.is_some()
                    && round_evals[o].signature.1 == round_evals[b].signature.1;
                if p > 0.05 && (stats::corr(&d_b, &d_o) > 0.7 || same_region) {
                    amb.push(o);
                }
            }
            if amb.is_empty() {
                chosen = Some(b);
            } else {
                let names: Vec<String> = std::iter::once(b)
                    .chain(amb.iter().copied())
                    .map(|i| round_evals[i].name.clone())
                    .collect();
                for &i in std::iter::once(&b).chain(amb.iter()) {
                    round_evals[i].ambiguous_with = names
                        .iter()
                        .filter(|n| **n != round_evals[i].name)
                        .cloned()
                        .collect();
                }
                for o in &amb {
                    ambiguous.push((round_evals[b].name.clone(), round_evals[*o].name.clone()));
                }
            }
        }
        let stop = chosen.is_none();
        if let Some(b) = chosen {
            round_evals[b].accepted = true;
            accepted.push(round_evals[b].name.clone());
            current = round_evals[b].model.clone();
        }
        // Keep the latest evaluation of each candidate.
        for e in round_evals {
            if let Some(old) = evals.iter_mut().find(|x| x.name == e.name) {
                if !old.accepted {
                    *old = e;
                }
            } else {
                evals.push(e);
            }
        }
        if stop {
            break;
        }
    }
    Attribution {
        baseline: base,
        augmented: current,
        accepted,
        evals,
        ambiguous,
        fold_of_visit,
    }
}
