//! `DIR/report.md`: the human report, rendered from the [`Diagnosis`] and the figures' files.

use super::*;
use crate::noise::{self, Noise};

pub(super) fn markdown(d: &Diagnosis, figs: &[(String, String)]) -> String {
    let mut w = String::new();
    let t = d.rmse_table();
    let gt = &d.tests;
    let _ = writeln!(w, "# Sim-to-real gap report\n");
    let _ = writeln!(
        w,
        "Log: {}. Baseline: `{}` fitted by identify ({} free steady parameters{}). {} rows ({} valid), {} visits, {} operating points, {} session(s). Residual = measured minus model. Wall time {:.2} s.\n",
        d.sources.join(", "),
        d.ident.prior.name,
        d.ident.steady.free.len(),
        if d.cfg.fix.is_empty() {
            String::new()
        } else {
            format!(
                "; {} held at the prior's values: a log that disagrees with a held value shows it as a gap like any other",
                d.cfg.fix.join(", ")
            )
        },
        d.ds.rows_total,
        d.ds.rows.len(),
        d.ds.visits.len(),
        d.ds.points.len(),
        d.ds.sessions.len(),
        d.elapsed.as_secs_f64()
    );
    let _ = writeln!(w, "## Verdict\n");
    if !gt.significant {
        let _ = writeln!(
            w,
            "**No significant gap** (combined p = {:.3e} > alpha = {}): neither the baseline's residuals (structure over the inputs, over session time or after input changes) nor any candidate effect's withheld gain lie beyond what the log's own noise makes, once the choice among the tests and the candidates is paid. No effect is accepted.\n",
            Pv(gt.p_value), d.cfg.alpha
        );
    } else {
        let _ = writeln!(
            w,
            "**Significant gap** (combined p = {:.3e} <= alpha = {}; {}).\n",
            Pv(gt.p_value),
            d.cfg.alpha,
            match &d.attr.verdict.opened_by {
                Some((e, q)) => format!(
                    "found by the candidate `{e}`: its withheld gain, adjusted over every gap test and candidate, p = {:.2e}, where the gap tests' own smallest p, adjusted the same way, did not reach alpha (the tests alone: min-p = {:.2e}){}",
                    Pv(*q),
                    Pv(d.detection.tests_p),
                    if gt.families.is_empty() { String::new() } else { format!("; families: {}", gt.families.join(", ")) }
                ),
                None => format!("families: {}", if gt.families.is_empty() { "none alone (only the smallest p over all of them)".to_string() } else { gt.families.join(", ") }),
            }
        );
        if d.attr.accepted.is_empty() {
            let why = if d.attr.anomaly_won {
                "A local anomaly (a small box of operating points that no effect describes) explains it better than any effect"
            } else if d.attr.evals.iter().any(|e| e.passed) {
                "No candidate effect is named (those beyond their null were passed over or dropped: the candidate table's notes say why)"
            } else {
                "No candidate effect lies beyond its null"
            };
            let _ = writeln!(w, "{why}: the gap is reported as **unexplained** rather than given a name the data do not support.\n");
        } else {
            let _ = writeln!(
                w,
                "Accepted effects, most important first: **{}**.\n",
                d.attr.accepted.join(", ")
            );
        }
        for (a, b) in &d.attr.ambiguous {
            let _ = writeln!(w, "Close alternative: `{b}` came within 80 % of `{a}`'s excess over its null on withheld visits; `{a}` is named (see the candidate table).\n");
        }
        if let Some(x) = d.withheld.as_ref().filter(|_| !d.attr.accepted.is_empty()) {
            let change = super::rmse_change(x.baseline.rmse, x.augmented.rmse);
            if d.worse_on_withheld_log() == Some(true) {
                let _ = writeln!(
                    w,
                    "**Caution:** on the withheld log {} the augmented model predicts worse than the baseline (RMSE {change}; paired over its {} visits, one-sided p = {:.2e}). The named effects improve the withheld visits of this log but do not carry over to those operating points: treat the names as provisional, and check the effect's course along its axis in the figures below before using augmented.json.\n",
                    x.source,
                    x.visits,
                    Pv(x.worse_p)
                );
            } else if x.augmented_higher() {
                let _ = writeln!(
                    w,
                    "On the withheld log {} the augmented model's error is higher than the baseline's (RMSE {change}), but by less than its {} visits' own offsets make of chance (paired over the visits, one-sided p = {:.2e}): no evidence either way.\n",
                    x.source,
                    x.visits,
                    Pv(x.worse_p)
                );
            }
        }
    }
    let ex = d.excess_removed();
    let _ = writeln!(w, "## How far it shrinks\n");
    let _ = writeln!(w, "| | r1 [mm] | r2 [mm] |\n|---|---|---|");
    let _ = writeln!(
        w,
        "| baseline, train | {:.3} | {:.3} |",
        t[0].0.rmse[0], t[0].0.rmse[1]
    );
    let _ = writeln!(
        w,
        "| augmented, train | {:.3} | {:.3} |",
        t[1].0.rmse[0], t[1].0.rmse[1]
    );
    let _ = writeln!(
        w,
        "| baseline, withheld visits (CV) | {:.3} | {:.3} |",
        t[0].1.rmse[0], t[0].1.rmse[1]
    );
    let _ = writeln!(
        w,
        "| augmented, withheld visits (CV) | {:.3} | {:.3} |",
        t[1].1.rmse[0], t[1].1.rmse[1]
    );
    if let Some(x) = &d.withheld {
        let _ = writeln!(
            w,
            "| baseline (baseline.json), withheld log {} | {:.3} | {:.3} |",
            x.source, x.baseline.rmse[0], x.baseline.rmse[1]
        );
        let _ = writeln!(
            w,
            "| augmented (augmented.json), withheld log | {:.3} | {:.3} |",
            x.augmented.rmse[0], x.augmented.rmse[1]
        );
    }
    let _ = writeln!(
        w,
        "| pure-error floor (row SD) | {:.3} | {:.3} |",
        d.floor[0], d.floor[1]
    );
    let _ = writeln!(
        w,
        "| share of the withheld excess over the floor removed | {} | {} |\n",
        share_removed(ex[0]),
        share_removed(ex[1])
    );
    let _ = writeln!(
        w,
        "Row-level RMSE over every valid row. Withheld visits: {}-fold cross-validation grouped by visit (each fold refitted without its visits). The floor is the pure error of a row: within-visit SD {} / {} mm{}. Excess = MSE above the floor squared; both axes together: {}.\n",
        d.attr.fold_of_visit.iter().copied().max().map(|m| m + 1).unwrap_or(0),
        g(d.pe_aug.within_sd[0]),
        g(d.pe_aug.within_sd[1]),
        if d.pe_aug.between_dof > 0 {
            format!(", visit-to-visit SD {} / {} mm from {} point(s) visited more than once (repeat visits compared around the augmented model, so that a drift it models does not count as noise)", g(d.pe_aug.between_sd[0]), g(d.pe_aug.between_sd[1]), d.pe_aug.repeat_points)
        } else {
            " (no point was visited twice: the visit-to-visit part of the noise cannot be estimated and the floor is a lower bound)".into()
        },
        share_removed(ex[2])
    );
    let _ = writeln!(w, "## Is there a gap\n");
    let _ = writeln!(w, "{}\n", noise_line(&d.noise));
    let _ = writeln!(
        w,
        "| family | alternative | statistic | bootstrap p |\n|---|---|---|---|"
    );
    for a in &d.detection.alts {
        let _ = writeln!(
            w,
            "| {} | {} | {} | {:.2e} |",
            a.family,
            a.name,
            g(a.stat),
            Pv(a.p)
        );
    }
    let _ = writeln!(
        w,
        "\nEach alternative is a smooth shape (over f, over z_m, a surface over both, over session time, over the time since an input change scaled by the step, after every change or only after those that make a radius grow, or shrink) or the strongest box of neighbouring operating points, refitted jointly with the baseline's free parameters; the statistic is the drop of the residual sum of squares in row-noise units, studentised by the visit noise of the same residual (the biweight scale of its neighbour differences; the MAD for the transients after a change). The `_within` alternatives take each visit's mean out of the shape and of the baseline's columns, and the rig's own first-order approach at the baseline's time constant (its time scale also varying linearly with z_m, on visits with a row within that time constant of the change) with them: they see only what varies within a visit, judged against the row noise. `since_size_within` is a transient that grows with the step's size (the coarse shape times each change's centred step size), judged within the visits beside every course linear in the step (a free dense shape after each change, the coarse shape modulated by the depth and its square, the baseline's own transient): no rig's approach law makes it, a rate limit does. Each statistic's null distribution comes from {} logs of pure noise with this log's design and noise structure (visit offsets and row noise), each refitted and re-estimated like the real one. Each smooth alternative is judged per radius, and all but the transients after a change also on both radii together (r1+r2, the sum of their drops). Family p: the smallest p-value over the family's alternatives, calibrated by the same simulations (min-p: each simulated log's p-values read like the real one's, against the other draws); the tests' min-p over every alternative: {:.2e}. The candidates below are scored on the same simulated logs, and the gap's combined p is the smaller of the tests' smallest p and the named candidate's (on the baseline; after a named effect, the tests' alone), each adjusted over every test and every candidate together (a single-step min-p, each candidate's p weighted at a tenth of a test's: the chance of a gap declared on a log with none stays at alpha whichever of them finds it). For the record, the classical lack-of-fit F test (pure error from {}): r1 F = {} (p = {:.2e}), r2 F = {} (p = {:.2e}).\n",
        d.cfg.boot,
        Pv(d.detection.tests_p),
        if gt.lof_from_visits { "repeat visits" } else { "rows within visits, which cannot see the visit-to-visit error: not in the decision" },
        g(gt.lof[0].f), gt.lof[0].p, g(gt.lof[1].f), gt.lof[1].p,
    );
    let _ = writeln!(w, "## Where\n");
    if d.regions.is_empty() {
        let _ = writeln!(w, "No region (no significant gap).\n");
    } else {
        let _ = writeln!(w, "| output | kind | z_m [mm] | f [Hz] | session time [s] | after change [s] | mean residual [mm] | p (search-corrected) | visits |\n|---|---|---|---|---|---|---|---|---|");
        for r in &d.regions {
            let rg = |x: Option<(f64, f64)>| {
                x.map(|x| format!("{}-{}", g(x.0), g(x.1)))
                    .unwrap_or_else(|| "-".into())
            };
            let _ = writeln!(
                w,
                "| {} | {:?} | {}-{} | {}-{} | {} | {} | {} | {:.2e} | {} |",
                AXES[r.axis],
                r.kind,
                g(r.z.0),
                g(r.z.1),
                g(r.f.0),
                g(r.f.1),
                rg(r.t),
                rg(r.since),
                g(r.mean),
                Pv(r.p),
                r.visits.len()
            );
        }
        let _ = writeln!(w, "\nFor a pattern region (structure over the inputs that no single box isolates) the value is the RMS of the smoothed visit residuals. For a formation region the mean residual is the lag contrast: the first half of a visit's rows minus its second half, signed so that positive means the measurement stays behind the model after a change.\n");
    }
    let _ = writeln!(w, "## Which effect: candidates and evidence\n");
    if d.attr.evals.is_empty() {
        let _ = writeln!(
            w,
            "Not evaluated: the candidates could not be scored on this log (a design the linear refits cannot solve).\n"
        );
    } else {
        let _ = writeln!(w, "| effect | round | withheld gain | null {:.0} % quantile | bootstrap p | best variant | form in the model (gain library / learned) | notes | share of a region removed | withheld RMSE r1 / r2 [mm] | parameters | verdict |\n|---|---|---|---|---|---|---|---|---|---|---|---|", 100.0 * (1.0 - d.cfg.alpha));
        for e in &d.attr.evals {
            let cv = crate::rmse(&d.ds, &e.model.cv);
            let form = match &e.form {
                crate::attribute::Form::Learned(sh) => format!(
                    "learned shape over {}, {} ({} knots)",
                    sh.family.axis.label(),
                    sh.family.mode.key(),
                    sh.family.knots.len()
                ),
                crate::attribute::Form::Parametric if e.accepted => "library form".into(),
                _ => "-".into(),
            };
            let form = match e.form_gains {
                Some((l, s)) => format!("{form} ({} / {})", g(l), g(s)),
                None => form,
            };
            let ps = if e.accepted && matches!(e.form, crate::attribute::Form::Parametric) {
                param_strings(e.kind, &e.model.full.aug.synced())
            } else {
                Vec::new()
            };
            let verdict = if e.accepted {
                if e.ambiguous_with.is_empty() {
                    "**named**".to_string()
                } else {
                    format!("**named** (close: {})", e.ambiguous_with.join(", "))
                }
            } else if e.passed {
                "beyond its null, not the best".into()
            } else {
                "within its null".into()
            };
            let _ = writeln!(
                w,
                "| {} | {} | {} | {} | {:.2e} | {} | {} | {} | {:.0} %{} | {:.3} / {:.3} | {} | {} |",
                e.name,
                e.round,
                g(e.gain),
                g(e.penalty),
                Pv(e.p),
                e.variant,
                form,
                if e.implausible.is_empty() && e.notes.is_empty() {
                    "-".to_string()
                } else {
                    e.implausible
                        .iter()
                        .chain(&e.notes)
                        .cloned()
                        .collect::<Vec<_>>()
                        .join("; ")
                },
                100.0 * e.signature.0,
                if e.closes_gap {
                    "; no gap left with it"
                } else {
                    ""
                },
                cv.rmse[0],
                cv.rmse[1],
                if ps.is_empty() { "-".to_string() } else { ps.join(", ") },
                verdict
            );
        }
        if let Some((gain, q, p)) = d.attr.anomaly {
            let _ = writeln!(
                w,
                "\nThe local anomaly (the strongest small box of operating points, which no effect describes): withheld gain {} against a null quantile of {} (p = {:.2e}){}.",
                g(gain),
                g(q),
                Pv(p),
                if d.attr.anomaly_won { ": it beat every effect, so the gap is reported unexplained" } else { "" }
            );
        }
        let _ = writeln!(w, "\nHow an effect is named: every candidate is a family of shapes along its physical axis (or its library form's correction, for effects without one), refitted with the baseline's free parameters on {}-fold cross-validation grouped by visit. Its withheld gain (half the drop of the withheld sum of squares, in units of a row's noise, best variant; for a shape judged within the visits, in units of a row's noise about its visit's mean) is compared with its null distribution from logs simulated from the current model with this log's design and noise, refitted the same way. A candidate beyond its null (p <= alpha, gain >= {}) is named when it lies furthest beyond its null's {:.0} % quantile and there is a gap (combined p <= alpha, above: the tests and the candidates judged together); forward selection continues while a gap remains, judged the same way on what the named effects leave (there, a new name only for a candidate whose own family of gap tests finds what is left: drift, formation, or the operating points). Plausibility and the share of a region removed are reasons, not vetoes. Each named effect enters `augmented.json` in its library form where that gains at least 90 % of what the learned shape gains on withheld visits, otherwise as a learned effect term (docs/effects.md).\n", d.attr.fold_of_visit.iter().copied().max().map(|m| m + 1).unwrap_or(0), crate::attribute::MIN_GAIN, 100.0 * (1.0 - d.cfg.alpha));
    }
    let _ = writeln!(w, "## Unexplained\n");
    if d.unexplained.is_empty() {
        let _ = writeln!(
            w,
            "{}\n",
            if d.regions.is_empty() {
                "Nothing to explain."
            } else {
                "Every significant region is explained by the accepted effects."
            }
        );
    } else {
        let _ = writeln!(w, "Regions of the augmented model's residual that the gap tests still find (with no accepted effect: the baseline's regions).\n");
        let _ = writeln!(w, "| region | value on the augmented residual [mm] | withheld error recovered by the discrepancy |\n|---|---|---|");
        for u in &d.unexplained {
            let _ = writeln!(
                w,
                "| {} | {} | {} |",
                describe_region(&u.region),
                g(u.mean_after),
                u.heldout_shrink
                    .map(|s| format!("{:.0} %", 100.0 * s))
                    .unwrap_or_else(|| "n/a".into())
            );
        }
        let _ = writeln!(w, "\nThe discrepancy is a Gaussian process over the normalised inputs (over session time for a drift region) fitted to the augmented model's visit residuals, in the spirit of Kennedy-O'Hagan calibration; its recovery is measured on visits its fit did not see (same folds).\n");
    }
    let _ = writeln!(w, "## Figures\n");
    for (f, cap) in figs {
        let _ = writeln!(w, "![{cap}]({f})\n\n*{cap}*\n");
    }
    let _ = writeln!(w, "Files: `report.json` (all figures above as data), `baseline.json` (the model fitted without effects), `augmented.json` (the baseline refitted with the accepted effects switched on: it runs as is in `magswarm predict`, the FMU (`magswarm fmu --model`, or its `model_file` parameter) and the bridge's shadow model).");
    w
}

/// A share of the withheld excess removed, as the report prints it. Above 100 % the augmented
/// model's withheld error lies below the floor, which is an estimate from this log's rows and
/// repeats (a lower bound without repeats): the excess is all removed, and the figure says by
/// how far the estimate is passed.
fn share_removed(x: Option<f64>) -> String {
    match x {
        Some(v) if v > 1.0 => format!(
            "{:.0} % (below the floor estimate: all of the excess)",
            100.0 * v
        ),
        Some(v) => format!("{:.0} %", 100.0 * v),
        None => "- (no excess)".into(),
    }
}

/// A p-value as the tables print it: in scientific notation at the formatter's precision,
/// and "< 1e-300" where it lies beyond what a double resolves (a bootstrap tail that far out
/// is a statement of "far beyond", not a number to quote).
struct Pv(f64);

impl std::fmt::LowerExp for Pv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.0 < 1e-300 {
            write!(f, "< 1e-300")
        } else {
            match f.precision() {
                Some(k) => write!(f, "{:.*e}", k, self.0),
                None => write!(f, "{:e}", self.0),
            }
        }
    }
}

/// The noise the gap tests are calibrated against, in one paragraph: the row noise and how
/// far successive rows follow each other (with how well the log fixes that, and a caution
/// where the log cannot tell independent rows from correlated ones: correlated rows read as
/// independent make the within-visit tests too ready to find a transient), and the visit
/// noise with what it was estimated from.
fn noise_line(n: &Noise) -> String {
    let unsure: Vec<String> = (0..2)
        .filter(|&a| n.ar[a] == 0.0 && n.ar_evidence[a].upper >= noise::AR_UNSURE)
        .map(|a| format!("r{} up to {:.2}", a + 1, n.ar_evidence[a].upper))
        .collect();
    format!(
        "Noise the tests are calibrated against (per axis r1 / r2): a row around its visit's mean {} / {} mm, successive rows correlated {:.2} / {:.2} (AR(1) along a visit's rows, simulated as such; read by likelihood from {} / {} differences of settled rows within the visits, likelihood ratio {:.1} / {:.1} against independent rows, kept from {}; correlations up to {:.2} / {:.2} fit the log as well, at 95 %); a visit's mean around the truth {} / {} mm, from {} differences of neighbouring or repeated visits ({} repeats) -- with each point visited once, the roughness of the residual surface.{}",
        g(n.within[0]),
        g(n.within[1]),
        n.ar[0],
        n.ar[1],
        n.ar_evidence[0].diffs,
        n.ar_evidence[1].diffs,
        n.ar_evidence[0].lr,
        n.ar_evidence[1].lr,
        noise::AR_KEEP,
        n.ar_evidence[0].upper,
        n.ar_evidence[1].upper,
        g(n.visit[0]),
        g(n.visit[1]),
        n.pairs,
        n.repeat_pairs,
        if unsure.is_empty() {
            String::new()
        } else {
            format!(
                "\n\n**The rows' correlation is poorly determined:** the rows are simulated independent, but this log's settled rows within the visits cannot tell that from rows that follow each other ({}). Correlated rows read as independent make the tests within the visits too ready to find a transient: before trusting a `formation_lag` named on this log, record more settled rows per visit (a longer dwell, or rows more often).",
                unsure.join(", ")
            )
        }
    )
}

#[cfg(test)]
mod tests {
    use super::{noise_line, share_removed, Noise, Pv};
    use crate::noise::RowEvidence;

    #[test]
    fn a_p_value_beyond_what_a_double_resolves_is_not_printed_as_a_number() {
        assert_eq!(format!("{:.2e}", Pv(0.0123)), "1.23e-2");
        assert_eq!(format!("{:.2e}", Pv(4.45e-308)), "< 1e-300");
        assert_eq!(format!("{:.3e}", Pv(0.0)), "< 1e-300");
    }

    /// Where a log's differences within its visits cannot tell independent rows from rows
    /// correlated 0.3 or more, the noise paragraph says so and what to do; where they can,
    /// it gives the figures without the caution.
    #[test]
    fn a_poorly_determined_row_correlation_is_flagged() {
        let noise = |upper: [f64; 2]| Noise {
            within: [0.08, 0.13],
            ar: [0.31, 0.0],
            ar_evidence: [
                RowEvidence {
                    diffs: 113,
                    lr: 6.2,
                    upper: upper[0],
                },
                RowEvidence {
                    diffs: 111,
                    lr: 0.4,
                    upper: upper[1],
                },
            ],
            visit: [0.2, 0.3],
            between: [0.18, 0.27],
            rows_per_visit: 3.0,
            pairs: 85,
            repeat_pairs: 0,
        };
        let short = noise_line(&noise([0.5, 0.44]));
        assert!(short.contains("correlated 0.31 / 0.00"), "{short}");
        assert!(short.contains("from 113 / 111 differences"), "{short}");
        assert!(short.contains("likelihood ratio 6.2 / 0.4"), "{short}");
        assert!(
            short.contains("up to 0.50 / 0.44 fit the log as well"),
            "{short}"
        );
        // r1's correlation is kept (and simulated): only r2 is flagged.
        assert!(short.contains("poorly determined:**"), "{short}");
        assert!(short.contains("(r2 up to 0.44)"), "{short}");
        let long = noise_line(&noise([0.4, 0.08]));
        assert!(!long.contains("poorly determined"), "{long}");
    }

    #[test]
    fn a_share_past_the_floor_says_the_excess_is_all_removed() {
        assert_eq!(share_removed(Some(0.42)), "42 %");
        assert_eq!(share_removed(Some(1.0)), "100 %");
        let past = share_removed(Some(1.61));
        assert!(
            past.starts_with("161 %") && past.contains("below the floor"),
            "{past}"
        );
        assert_eq!(share_removed(None), "- (no excess)");
    }
}
