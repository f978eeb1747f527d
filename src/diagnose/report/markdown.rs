//! `DIR/report.md`: the human report, rendered from the [`Diagnosis`] and the figures' files.

use super::*;

pub(super) fn markdown(d: &Diagnosis, figs: &[(String, String)]) -> String {
    let mut w = String::new();
    let t = d.rmse_table();
    let gt = &d.tests;
    let _ = writeln!(w, "# Sim-to-real gap report\n");
    let _ = writeln!(
        w,
        "Log: {}. Baseline: `{}` fitted by identify ({} free steady parameters). {} rows ({} valid), {} visits, {} operating points, {} session(s). Residual = measured minus model. Wall time {:.2} s.\n",
        d.sources.join(", "),
        d.ident.prior.name,
        d.ident.steady.free.len(),
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
            "**No significant gap** (combined p = {:.3e} >= alpha = {}): the baseline's residuals show no structure over the inputs, over session time or after input changes beyond what the repeats' noise explains. No effect is accepted.\n",
            gt.p_value, d.cfg.alpha
        );
    } else {
        let _ = writeln!(
            w,
            "**Significant gap** (combined p = {:.3e} < alpha = {}; families: {}).\n",
            gt.p_value,
            d.cfg.alpha,
            gt.families.join(", ")
        );
        if d.attr.accepted.is_empty() {
            let _ = writeln!(w, "No candidate effect passed every rule: the gap is reported as **unexplained** rather than given a name the data do not support.\n");
        } else {
            let _ = writeln!(
                w,
                "Accepted effects, most important first: **{}**.\n",
                d.attr.accepted.join(", ")
            );
        }
        for (a, b) in &d.attr.ambiguous {
            let _ = writeln!(w, "Ambiguous: `{a}` and `{b}` explain the same residual equally well on withheld visits; neither is named.\n");
        }
    }
    let ex = d.excess_removed();
    let pct = |x: Option<f64>| {
        x.map(|v| format!("{:.0} %", 100.0 * v))
            .unwrap_or_else(|| "- (no excess)".into())
    };
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
            "| baseline, withheld log {} | {:.3} | {:.3} |",
            x.source, x.baseline.rmse[0], x.baseline.rmse[1]
        );
        let _ = writeln!(
            w,
            "| augmented, withheld log | {:.3} | {:.3} |",
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
        pct(ex[0]),
        pct(ex[1])
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
        pct(ex[2])
    );
    let _ = writeln!(w, "## Is there a gap\n");
    let _ = writeln!(w, "| test | r1 | r2 | in the decision |\n|---|---|---|---|");
    let _ =
        writeln!(
        w,
        "| lack of fit F (pure error from {}) | F = {} (p = {:.2e}) | F = {} (p = {:.2e}) | {} |",
        if gt.lof_from_visits { "repeat visits" } else { "rows within visits" },
        g(gt.lof[0].f), gt.lof[0].p, g(gt.lof[1].f), gt.lof[1].p,
        if gt.lof_from_visits { "yes" } else { "no: visit-to-visit error would look like a gap" }
    );
    let _ = writeln!(
        w,
        "| structure over (z_m, f), permutation | p = {:.3} | p = {:.3} | yes |",
        gt.space_p[0], gt.space_p[1]
    );
    let _ = writeln!(
        w,
        "| drift over session time, permutation | p = {:.3} | p = {:.3} | yes |",
        gt.drift_p[0], gt.drift_p[1]
    );
    let _ = writeln!(
        w,
        "| lag after input changes ({} visits), paired t | p = {:.3} | p = {:.3} | yes |\n",
        gt.trans_visits, gt.trans_p[0], gt.trans_p[1]
    );
    let _ = writeln!(
        w,
        "Combined p = min over families x number of families x 2 axes (Bonferroni).\n"
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
                r.p,
                r.visits.len()
            );
        }
        let _ = writeln!(w, "\nFor a pattern region (structure over the inputs that no single box isolates) the value is the RMS of the smoothed visit residuals. For a formation region the mean residual is the lag contrast: the first half of a visit's rows minus its second half, signed so that positive means the measurement stays behind the model after a change.\n");
    }
    let _ = writeln!(w, "## Which effect: candidates and evidence\n");
    if d.attr.evals.is_empty() {
        let _ = writeln!(
            w,
            "Not evaluated: there is no significant gap to attribute.\n"
        );
    } else {
        let _ = writeln!(w, "| effect | round | withheld log-lik gain | BIC penalty | p (paired, one-sided) | plausible | signature (share of a region removed) | withheld RMSE r1 / r2 [mm] | parameters | verdict |\n|---|---|---|---|---|---|---|---|---|---|");
        for e in &d.attr.evals {
            let cv = crate::diagnose::rmse(&d.ds, &e.model.cv);
            let ps = param_strings(&e.name, &e.model.full.aug.synced());
            let verdict = if e.accepted {
                "**accepted**".to_string()
            } else if !e.ambiguous_with.is_empty() {
                format!("ambiguous with {}", e.ambiguous_with.join(", "))
            } else if e.passed {
                "passed, not needed".into()
            } else {
                "rejected".into()
            };
            let _ = writeln!(
                w,
                "| {} | {} | {} | {} | {:.2e} | {} | {:.0} %{} | {:.3} / {:.3} | {} | {} |",
                e.name,
                e.round,
                g(e.gain),
                g(e.penalty),
                e.p,
                if e.implausible.is_empty() {
                    "yes".to_string()
                } else {
                    e.implausible.join("; ")
                },
                100.0 * e.signature.0,
                if e.closes_gap {
                    "; no gap left with it"
                } else {
                    ""
                },
                cv.rmse[0],
                cv.rmse[1],
                ps.join(", "),
                verdict
            );
        }
        let _ = writeln!(w, "\nRules (all must hold): withheld log-likelihood gain over the model of the previous round above the BIC penalty (k/2 ln visits); per-visit gains positive by a paired t test at alpha; no parameter at a fit bound and locations inside the data; and, refitted on all data, at least half of a significant region's residual removed, or no significant gap left with it. Forward selection adds effects one at a time. The candidates are the model's own effect terms (docs/effects.md), refitted with the baseline; what each frees is in `src/diagnose/candidates.rs`. An accepted effect is switched on in `augmented.json` with these parameters.\n");
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
