//! The form of each named effect: its library (parametric) form where it gains as much on
//! withheld visits as the learned shape, the learned shape otherwise.

use super::*;

/// For each named effect, its library form against its learned shape; the final model and
/// its design.
pub(super) fn choose_forms(
    lin: &Linear,
    named: &[(EffectKind, Vec<Variant>)],
    named_within: &[EffectKind],
    out: &mut Attribution,
    st: Settings,
    progress: &dyn Progress,
) -> (Augmented, Design, Vec<(EffectKind, Family)>) {
    let ds = lin.ds;
    let mut design = lin.jac.clone();
    // The same, in the directions the model file can carry (no transient directions): where
    // the library form and the learned shape are compared, both without them, as the nonlinear
    // refits of the library form are.
    let mut model_d = lin.model_jac();
    let mut learned: Vec<(EffectKind, Family)> = Vec::new();
    let mut parametric: Vec<EffectKind> = Vec::new();
    // The last library fit (free parameters and library forms fitted together).
    let mut last_lib: Option<Augmented> = None;
    let one = vec![0usize; lin.y.len()];
    for (name, vs) in named {
        let vs = &prune_axes(lin, &design, vs);
        let before = Solver::new(&design, &lin.fold_of_stacked, lin.k);
        let mut shape_design = Some(design.clone());
        for v in vs {
            shape_design = match (shape_design, columns_of(v, &lin.rc)) {
                (Some(d), Some(more)) => Some(d.append(&more)),
                _ => None,
            };
        }
        let is_shape = vs.iter().all(|v| matches!(v, Variant::Shape(_)));
        let mut shape_model_d = Some(model_d.clone());
        for v in vs {
            shape_model_d = match (shape_model_d, columns_of(v, &lin.rc)) {
                (Some(d), Some(more)) => Some(d.append(&more)),
                _ => None,
            };
        }
        let g_learned_model = match (
            Solver::new(&model_d, &lin.fold_of_stacked, lin.k),
            shape_model_d
                .as_ref()
                .and_then(|d| Solver::new(d, &lin.fold_of_stacked, lin.k)),
        ) {
            (Some(b), Some(s)) => gain(&b, &s, &lin.y, [1.0, 1.0]),
            _ => f64::NEG_INFINITY,
        };
        let g_learned = match (&before, &shape_design) {
            (Some(b), Some(d)) => Solver::new(d, &lin.fold_of_stacked, lin.k)
                .map(|s| gain(b, &s, &lin.y, [1.0, 1.0]))
                .unwrap_or(f64::NEG_INFINITY),
            _ => f64::NEG_INFINITY,
        };
        // The library form: fitted by the nonlinear fitter on top of the baseline and the
        // library forms named before it, its correction then one column of the design.
        let lin_start = linear_model(lin, &learned).unwrap_or_else(|| lin.base.clone());
        let mut start = match &last_lib {
            Some(l) => Augmented {
                learned: lin_start.learned.clone(),
                ..l.clone()
            },
            None => lin_start,
        };
        // The same nonlinear refits per fold without it: what the library form's withheld
        // gain is measured against (refitting nonlinearly gains by itself over the linear
        // design; that must not count for the form).
        let without = start.clone();
        start.effects.push((*name, name.fit_neutral(lin.ctx)));
        let starts = name.fit_starts(lin.ctx);
        let all: Vec<usize> = (0..ds.rows.len()).collect();
        let fr = fitter::fit(
            &start,
            lin.free,
            ds,
            lin.ctx,
            &all,
            lin.noise.row(),
            None,
            &starts,
        );
        progress.inc(1);
        let p_fit = candidates::predict(&fr.aug, ds);
        let col = DMatrix::from_fn(2 * ds.rows.len(), 1, |s, _| {
            let (i, ax) = (s / 2, s % 2);
            let d = lin.rc.w[ax] * (p_fit[i][ax] - lin.p0[i][ax]);
            if d.is_finite() {
                d
            } else {
                0.0
            }
        });
        // The library form's correction less what the free parameters already span.
        let col = match Solver::new(&lin.jac, &one, 1) {
            Some(s) => {
                let r = s.residual(&DVector::from_column_slice(col.as_slice()));
                DMatrix::from_column_slice(r.len(), 1, r.as_slice())
            }
            None => col,
        };
        let param_design = design.extend(&col, &(DMatrix::identity(1, 1) * 1e-8));
        // The library form's withheld gain: each fold refitted by the nonlinear fitter, held
        // near the baseline by the anchor as every per-fold refit is (a column from the full
        // fit with a free amplitude would know the withheld visits through the fitted
        // location), against the same refits without it. A form with a location (a step-out
        // frequency, an onset distance) finds it on each fold's own rows; the others (time
        // scales, rates: global, and costly to search per fold for a transient) refit
        // locally from the full fit.
        let cv_sse =
            |m: &Augmented, starts: &[Vec<f64>]| sse_rows(lin, &library_cv_from(lin, m, starts));
        let located = name
            .fit_params(lin.ctx)
            .iter()
            .any(|p| p.location.is_some());
        let g_param = if before.is_some() && col.norm() > 1e-9 {
            let e0 = cv_sse(&without, &[]);
            let e1 = if located {
                cv_sse(&start, &starts)
            } else {
                cv_sse(&fr.aug, &[])
            };
            log::debug!(
                "{}: withheld SS of the library form {e1:?}, {e0:?} without it",
                name.name()
            );
            0.5 * (e0[0] - e1[0] + e0[1] - e1[1])
        } else {
            f64::NEG_INFINITY
        };
        log::debug!(
            "{}: withheld gain of the library form {g_param:.1}, of the learned shape {g_learned_model:.1} (model directions) / {g_learned:.1}",
            name.name()
        );
        // The library form where it gains at least 90 % of what the learned shape gains, and
        // where its fit is a plausible description of the effect: a fit the form's own
        // physics rules out (a formation mode slower than every visit, an onset outside the
        // data) gains on withheld visits of this session by standing in for something else,
        // and replays wrongly on a log with other visits; the learned shape, tabulated where
        // the data lie, is written instead when it gains by itself.
        let learned_ok = is_shape && g_learned_model.is_finite();
        let lib_as_good = g_param >= 0.9 * g_learned_model;
        // Why the library form is set aside for its implausible fit alone (it gains as much
        // as the learned shape, which gains by itself); None where it is not.
        let set_aside = (learned_ok && lib_as_good && g_learned >= MIN_GAIN)
            .then(|| name.implausible(&fr.aug.synced(), lin.ctx).join("; "))
            .filter(|why| !why.is_empty());
        let use_learned = learned_ok && (!lib_as_good || set_aside.is_some());
        if let Some(why) = &set_aside {
            log::debug!(
                "{}: library form not used ({why}): the learned shape is written",
                name.name()
            );
        }
        let learned_pred = shape_design
            .as_ref()
            .filter(|_| is_shape)
            .and_then(|d| lin.evaluate(d))
            .map(|x| x.0);
        let mut e = out.evals.iter_mut().find(|e| e.kind == *name);
        if let Some(e) = e.as_deref_mut() {
            e.curves = Some((p_fit.clone(), learned_pred.unwrap_or_default()));
        }
        // An effect named on what varies within the visits is judged again the same way: its
        // shape's gain within the visits, against the row noise, on top of the effects named
        // before it. Its whole shape's gain on withheld visits counts each visit's mean as
        // many times as the visit has rows, at the row's whole noise: on long visits whose
        // offsets are several times the row noise that gain is those offsets' chance (seen:
        // a growing formation beside a drift, gain within the visits 393 after the drift, the
        // whole shape -102 on withheld visits).
        let g_within = if is_shape && named_within.contains(name) {
            within_gain(lin, &design, shape_design.as_ref())
        } else {
            f64::NEG_INFINITY
        };
        // Given the effects named before it (in whichever form they took), an effect that no
        // longer gains what names an effect is dropped: it was explaining their leftovers. So
        // is one whose variant cannot be written as a learned term (the library form's
        // correction with an amplitude over z_m) while its library form, refitted per fold,
        // gains nothing on withheld visits: the model file would carry a form that predicts
        // worse than leaving the effect out (seen: a 16 mm centroid offset with the free
        // parameters dragged to compensate, twice the withheld error of the baseline).
        let writable = if is_shape {
            g_param.max(g_learned).max(g_within)
        } else {
            g_param
        };
        if writable < MIN_GAIN {
            if let Some(e) = e {
                e.form_gains = Some((g_param, g_learned));
                e.accepted = false;
                e.implausible.push(if is_shape {
                    format!("dropped: with the effects named before it, its withheld gain is {writable:.2} < {MIN_GAIN}")
                } else {
                    format!("dropped: its library form gains {writable:.2} < {MIN_GAIN} on withheld visits, and the variant that named it has no form in a model file")
                });
            }
            out.accepted.retain(|a| a != name.name());
            continue;
        }
        if g_param.max(g_learned) < MIN_GAIN {
            if let Some(e) = e.as_deref_mut() {
                e.notes.push(format!(
                    "kept on what varies within the visits (gain {g_within:.1} there with the effects named before it); on withheld visits its whole shape gains {g_learned:.1}, its library form {g_param:.1}: the visits' offsets, which it does not describe, weigh there"
                ));
            }
        }
        if use_learned {
            for v in vs {
                if let Variant::Shape(f) = v {
                    learned.push((*name, f.clone()));
                }
            }
            design = shape_design.expect("shape design");
            model_d = shape_model_d.expect("shape design");
            if let Some(e) = e {
                e.form_gains = Some((g_param, g_learned_model));
                if let Some(why) = set_aside {
                    e.notes.push(format!(
                        "learned shape written: its library form's fit is implausible ({why})"
                    ));
                }
            }
        } else {
            parametric.push(*name);
            // The fit refitted the earlier library forms and the free parameters with it.
            last_lib = Some(fr.aug.clone());
            design = param_design;
            model_d = model_d.extend(&col, &(DMatrix::identity(1, 1) * 1e-8));
            if let Some(e) = e {
                e.form_gains = Some((g_param, g_learned_model));
            }
        }
        let _ = st;
    }
    // The final model: learned heights and the free parameters from the linear fit; the
    // library forms refitted by the nonlinear fitter with the learned shapes held.
    let aug = linear_model(lin, &learned).unwrap_or_else(|| lin.base.clone());
    let all: Vec<usize> = (0..ds.rows.len()).collect();
    let mut aug = written(lin, aug, last_lib.as_ref(), &all, None);
    aug.sync_model();
    for (name, sh) in &aug.learned {
        if let Some(e) = out.evals.iter_mut().find(|e| e.kind == *name) {
            e.form = Form::Learned(sh.clone());
        }
    }
    (aug, design, learned)
}

/// Withheld predictions of a fitted augmented model: each fold refitted on the other folds'
/// rows by the nonlinear fitter, from the full fit.
pub(super) fn library_cv(lin: &Linear, full: &Augmented) -> Vec<[f64; 2]> {
    library_cv_from(lin, full, &[])
}

/// Withheld predictions of a model refitted per fold by the nonlinear fitter from `start`,
/// with `starts` for its last effect's multi-start search (empty: a local refit from `start`).
/// With starts, every fold finds the effect's location on its own training rows: a refit
/// from the full fit would start where all rows put it, the withheld ones included.
fn library_cv_from(lin: &Linear, start: &Augmented, starts: &[Vec<f64>]) -> Vec<[f64; 2]> {
    let ds = lin.ds;
    let mut cv = vec![[0.0; 2]; ds.rows.len()];
    let fold_of_row: Vec<usize> = (0..ds.rows.len())
        .map(|i| lin.fold_of_stacked[2 * i])
        .collect();
    for f in 0..lin.k {
        let train: Vec<usize> = (0..ds.rows.len())
            .filter(|&i| fold_of_row[i] != f)
            .collect();
        if train.len() == ds.rows.len() {
            continue;
        }
        let fr = fitter::fit(
            start,
            lin.free,
            ds,
            lin.ctx,
            &train,
            lin.noise.row(),
            Some(&lin.anchor),
            starts,
        );
        let p = candidates::predict(&fr.aug, ds);
        for i in 0..ds.rows.len() {
            if fold_of_row[i] == f {
                cv[i] = p[i];
            }
        }
    }
    cv
}

/// The radii each learned shape of a named effect acts on: a shape on both radii where the
/// second radius gains at least one unit of withheld log-likelihood, else on the one radius
/// that gains (an effect that shows in r2 alone does not also fit r1's noise).
fn prune_axes(lin: &Linear, design: &Design, vs: &[Variant]) -> Vec<Variant> {
    let mut out: Vec<Variant> = Vec::new();
    let mut d = design.clone();
    for v in vs {
        let mut best = v.clone();
        if let Variant::Shape(f) = v {
            if !matches!(f.mode, Mode::Rate | Mode::Aspect | Mode::Common) {
                let score = |axes: [bool; 2]| -> Option<f64> {
                    let g = Family { axes, ..f.clone() };
                    let s0 = Solver::new(&d, &lin.fold_of_stacked, lin.k)?;
                    let s1 = Solver::new(
                        &d.append(&shapes::design(&g, &lin.rc)),
                        &lin.fold_of_stacked,
                        lin.k,
                    )?;
                    Some(gain(&s0, &s1, &lin.y, [1.0, 1.0]))
                };
                if let Some(both) = score([true, true]) {
                    let one = [[true, false], [false, true]]
                        .into_iter()
                        .filter_map(|a| score(a).map(|g| (g, a)))
                        .max_by(|a, b| a.0.total_cmp(&b.0));
                    if let Some((g, axes)) = one {
                        if g >= both - 1.0 {
                            best = Variant::Shape(Family { axes, ..f.clone() });
                        }
                    }
                }
            }
        }
        if let Some(more) = columns_of(&best, &lin.rc) {
            d = d.append(&more);
        }
        out.push(best);
    }
    out
}

/// Withheld gain of `with` over `design`, both as they vary within the visits (each visit's
/// mean taken out of every column), in units of a row's noise about its visit's mean: how a
/// shape judged within the visits is named.
fn within_gain(lin: &Linear, design: &Design, with: Option<&Design>) -> f64 {
    let Some(with) = with else {
        return f64::NEG_INFINITY;
    };
    let folds = (lin.fold_of_stacked.as_slice(), lin.k);
    within_gain_of(&lin.rc.visit, folds, &lin.y, rho_within(lin), design, with)
}

/// [`within_gain`] on weighted stacked rows `y` whose row `i` (stacked `2 i`, `2 i + 1`)
/// belongs to visit `visit[i]`, with folds `(fold of each stacked row, count)` and the
/// within-visit share of a row's variance `rho`.
fn within_gain_of(
    visit: &[usize],
    (fold_of_stacked, k): (&[usize], usize),
    y: &DVector<f64>,
    rho: [f64; 2],
    design: &Design,
    with: &Design,
) -> f64 {
    let solver = |d: &Design| {
        let mut d = d.clone();
        shapes::within_visits(visit, &mut d.a);
        Solver::new(&d, fold_of_stacked, k)
    };
    match (solver(design), solver(with)) {
        (Some(s0), Some(s1)) => gain(&s0, &s1, y, rho),
        _ => f64::NEG_INFINITY,
    }
}

/// Weighted sum of squares per axis of the rows' errors against predictions `p`.
fn sse_rows(lin: &Linear, p: &[[f64; 2]]) -> [f64; 2] {
    let ds = lin.ds;
    linear::sse_axes(&DVector::from_fn(lin.y.len(), |s, _| {
        let (i, a) = (s / 2, s % 2);
        let v = lin.rc.w[a] * (ds.rows[i].r[a] - p[i][a]);
        if v.is_finite() {
            v
        } else {
            1e3
        }
    }))
}

/// The model file written from a linear fit `aug` (learned heights and the free parameters
/// moved by their coefficients) on the rows `rows`: with library forms (`lib`, the last
/// library fit, which fitted the free parameters and every library form together: a joint
/// refit from neutral values would stay where the effects vanish), those refitted with the
/// learned heights held; otherwise the free parameters refitted with the heights held, from
/// the linear step and from the baseline's values (the linear step is exact only near the
/// baseline: on a fold that lacks some operating points it can move a barely determined
/// combination far enough for the nonlinear model to extrapolate wildly), keeping the better
/// fit; a learned rate deficit's heights refitted with the rest.
fn written(
    lin: &Linear,
    aug: Augmented,
    lib: Option<&Augmented>,
    rows: &[usize],
    anchor: Option<&fitter::Anchor>,
) -> Augmented {
    let (ds, sd) = (lin.ds, lin.noise.row());
    let fit = |a: &Augmented| fitter::fit(a, lin.free, ds, lin.ctx, rows, sd, anchor, &[]);
    let aug = if let Some(lib) = lib {
        let mut l = lib.clone();
        l.learned = aug.learned.clone();
        fit(&l).aug
    } else if !aug.learned.is_empty() {
        let from_step = fit(&aug);
        let mut at_base = aug.clone();
        at_base.model = lin.base.model.clone();
        let from_base = fit(&at_base);
        if from_base.cost < from_step.cost {
            from_base.aug
        } else {
            from_step.aug
        }
    } else {
        aug
    };
    fitter::refit_rates(&aug, lin.free, ds, lin.ctx, rows, sd, anchor)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// Long visits whose offsets are three times the row noise, a transient after each change
    /// in proportion to its step, and a design whose one column moves whole visits (as the
    /// baseline's gains do): judged within the visits, the transient's shape gains far beyond
    /// what names an effect, more than its whole shape does on withheld visits (whose gain
    /// the offsets' chance dominates); on the same log without the transient it gains nothing
    /// that names one.
    #[test]
    fn a_transient_beside_large_visit_offsets_keeps_its_gain_within_the_visits() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
        let (nv, per) = (40usize, 25usize);
        let n = nv * per;
        // A row's whole noise is sqrt(1 + 9): the weighted residual is in its units.
        let w = 1.0 / 10f64.sqrt();
        let step: Vec<f64> = (0..nv)
            .map(|v| if v % 2 == 0 { 1.0 } else { -1.0 } * (1.0 + (v % 3) as f64))
            .collect();
        let visit: Vec<usize> = (0..n).map(|i| i / per).collect();
        let since = |i: usize| (i % per) as f64;
        let transient = |i: usize| step[visit[i]] * (-since(i) / 3.0).exp();
        let offsets: Vec<[f64; 2]> = (0..nv).map(|_| [3.0 * g(), 3.0 * g()]).collect();
        let noise: Vec<f64> = (0..2 * n).map(|_| g()).collect();
        let log = |amp: f64| {
            DVector::from_fn(2 * n, |s, _| {
                let i = s / 2;
                w * (offsets[visit[i]][s % 2] + amp * transient(i) + noise[s])
            })
        };
        let fold: Vec<usize> = (0..2 * n).map(|s| visit[s / 2] % 5).collect();
        let tiny = |c: usize| DMatrix::identity(c, c) * 1e-8;
        let design = Design::new(
            DMatrix::from_fn(2 * n, 1, |s, _| w * step[visit[s / 2]]),
            tiny(1),
        );
        let shape = DMatrix::from_fn(2 * n, 1, |s, _| w * transient(s / 2));
        let with = design.extend(&shape, &tiny(1));
        let rho = [0.1, 0.1];
        let within = |y: &DVector<f64>| within_gain_of(&visit, (&fold, 5), y, rho, &design, &with);
        let y = log(0.6);
        let g_within = within(&y);
        let whole = gain(
            &Solver::new(&design, &fold, 5).unwrap(),
            &Solver::new(&with, &fold, 5).unwrap(),
            &y,
            [1.0, 1.0],
        );
        assert!(
            g_within > 50.0 && g_within > whole,
            "within the visits {g_within:.1}, whole shape {whole:.1}"
        );
        let g_null = within(&log(0.0));
        assert!(g_null < MIN_GAIN, "without the transient: {g_null:.1}");
    }
}
