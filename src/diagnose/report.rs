//! The gap report: `DIR/report.json` (fields fixed by CONTRACTS.md, plus evidence),
//! `DIR/baseline.json`, `DIR/augmented.json`, `DIR/report.md` and its figures. Everything is
//! rendered from the [`Diagnosis`]; nothing is recomputed here except the residual tables the
//! figures draw.

use super::gap::{self, Kind, Region};
use super::{candidates, Diagnosis, Rmse};
use crate::plot::{self, Heatmap, Labels, Panel, Series};
use anyhow::{Context, Result};
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::Path;

const AXES: [&str; 2] = ["r1", "r2"];

fn g(v: f64) -> String {
    plot::fmt_g(v)
}

fn axes(v: [f64; 2]) -> Value {
    json!({"r1": v[0], "r2": v[1]})
}

fn range(r: (f64, f64)) -> Value {
    json!([r.0, r.1])
}

fn region_json(r: &Region) -> Value {
    json!({
        "output": AXES[r.axis],
        "kind": match r.kind { Kind::Inputs => "inputs", Kind::Drift => "drift", Kind::Formation => "formation", Kind::Pattern => "inputs_pattern" },
        "z_m_mm": range(r.z),
        "f_hz": range(r.f),
        "t_s": r.t.map(range),
        "since_change_s": r.since.map(range),
        "mean_residual_mm": r.mean,
        "p_value": r.p,
        "visits": r.visits.len(),
    })
}

/// Pooled RMSE of two row sets.
fn pool(a: Rmse, b: Option<Rmse>) -> [f64; 2] {
    match b {
        None => a.rmse,
        Some(b) => {
            let n = (a.n + b.n).max(1) as f64;
            let f = |x: f64, y: f64| ((x * x * a.n as f64 + y * y * b.n as f64) / n).sqrt();
            [f(a.rmse[0], b.rmse[0]), f(a.rmse[1], b.rmse[1])]
        }
    }
}

/// The parameters of a candidate's effect in a fitted model, as `name = value unit` strings.
fn param_strings(name: &str, m: &magswarm_model::Model) -> Vec<String> {
    candidates::model_params(name, m)
        .into_iter()
        .map(|(p, u, v)| format!("{p} = {} {u}", g(v)))
        .collect()
}

/// The augmented model's own model file: the baseline's refitted parameters with every
/// accepted effect switched on at its fitted values (runs as is in the FMU and `predict`).
fn augmented_model(d: &Diagnosis) -> magswarm_model::Model {
    let mut m = d.attr.augmented.full.aug.synced();
    m.name = format!("{}-augmented", d.ident.model.name);
    m.provenance = format!(
        "magswarm diagnose {} from {}: baseline refitted with the accepted effects [{}] switched on",
        env!("CARGO_PKG_VERSION"),
        d.sources.join(", "),
        d.attr.accepted.join(", ")
    );
    m
}

/// report.json as a value.
pub fn json(d: &Diagnosis) -> Value {
    let t = d.rmse_table();
    let w = d.withheld.as_ref();
    let effects: Vec<Value> = d
        .attr
        .evals
        .iter()
        .map(|e| {
            let fitted = e.model.full.aug.synced();
            let mp = candidates::model_params(&e.name, &fitted);
            let params: serde_json::Map<String, Value> =
                mp.iter().map(|(p, _, v)| (p.to_string(), json!(v))).collect();
            let tr = super::rmse(&d.ds, &e.model.pred);
            let cv = super::rmse(&d.ds, &e.model.cv);
            json!({
                "name": e.name,
                "accepted": e.accepted,
                "params": params,
                "param_units": mp.iter().map(|(p, u, _)| (*p, *u)).collect::<std::collections::BTreeMap<_,_>>(),
                "train_rmse_mm": axes(tr.rmse),
                "heldout_rmse_mm": axes(cv.rmse),
                "round": e.round,
                "heldout_loglik_gain": e.gain,
                "bic_penalty": e.penalty,
                "p_value": e.p,
                "plausible": e.implausible.is_empty(),
                "implausible": e.implausible,
                "signature_share": e.signature.0,
                "signature_region": e.signature.1,
                "passed": e.passed,
                "ambiguous_with": e.ambiguous_with,
            })
        })
        .collect();
    let unexplained: Vec<Value> = d
        .unexplained
        .iter()
        .map(|u| {
            let mut v = region_json(&u.region);
            v["mean_residual_after_mm"] = json!(u.mean_after);
            v["heldout_shrink"] = json!(u.heldout_shrink);
            v
        })
        .collect();
    let ex = d.excess_removed();
    let gt = &d.tests;
    json!({
        "schema": "magswarm-diagnose/1",
        "sources": d.sources,
        "residual": "measured minus model [mm]",
        "gap": {
            "significant": gt.significant,
            "p_value": gt.p_value,
            "alpha": d.cfg.alpha,
            "families": gt.families,
            "tests": {
                "lack_of_fit": {
                    "F": [gt.lof[0].f, gt.lof[1].f],
                    "dof": [[gt.lof[0].dof.0, gt.lof[0].dof.1], [gt.lof[1].dof.0, gt.lof[1].dof.1]],
                    "p_value": [gt.lof[0].p, gt.lof[1].p],
                    "pure_error_from": if gt.lof_from_visits { "repeat visits" } else { "rows within visits" },
                    "in_decision": gt.lof_from_visits,
                },
                "inputs_p_value": gt.space_p,
                "drift_p_value": gt.drift_p,
                "formation_p_value": gt.trans_p,
                "formation_visits": gt.trans_visits,
                "visit_sd_mm": gt.visit_sd,
            },
            "regions": d.regions.iter().map(region_json).collect::<Vec<_>>(),
        },
        "effects": effects,
        "accepted": d.attr.accepted,
        "ambiguous": d.attr.ambiguous.iter().map(|(a, b)| json!([a, b])).collect::<Vec<_>>(),
        "unexplained": unexplained,
        "baseline": {
            "train_rmse_mm": axes(t[0].0.rmse),
            "heldout_rmse_mm": axes(pool(t[0].1, w.map(|w| w.baseline))),
            "heldout_cv_rmse_mm": axes(t[0].1.rmse),
            "withheld_log_rmse_mm": w.map(|w| axes(w.baseline.rmse)),
        },
        "augmented": {
            "effects": d.attr.accepted,
            "train_rmse_mm": axes(t[1].0.rmse),
            "heldout_rmse_mm": axes(pool(t[1].1, w.map(|w| w.augmented))),
            "heldout_cv_rmse_mm": axes(t[1].1.rmse),
            "withheld_log_rmse_mm": w.map(|w| axes(w.augmented.rmse)),
        },
        "floor_rmse_mm": axes(d.floor),
        "floor_between_visit_sd_mm": axes(d.pe_aug.between_sd),
        "excess_removed": {"r1": ex[0], "r2": ex[1], "both": ex[2]},
        "pure_error": {
            "within_visit_sd_mm": axes(d.pe.within_sd),
            "within_visit_dof": d.pe.within_dof,
            "between_visit_sd_mm": axes(d.pe.between_sd),
            "between_visit_dof": d.pe.between_dof,
            "points_visited_twice_or_more": d.pe.repeat_points,
        },
        "data": {
            "rows": d.ds.rows_total,
            "valid_rows": d.ds.rows.len(),
            "visits": d.ds.visits.len(),
            "operating_points": d.ds.points.len(),
            "sessions": d.ds.sessions.len(),
            "folds": d.attr.fold_of_visit.iter().copied().max().map(|m| m + 1).unwrap_or(0),
        },
        "withheld_log": w.map(|w| w.source.clone()),
        "elapsed_s": d.elapsed.as_secs_f64(),
    })
}

/// A few lines for the terminal.
pub fn summary(d: &Diagnosis) -> String {
    let mut s = String::new();
    let t = d.rmse_table();
    let _ = writeln!(
        s,
        "diagnose: {} rows, {} visits, {} points; gap {} (p = {:.3e}); {:.2} s",
        d.ds.rows.len(),
        d.ds.visits.len(),
        d.ds.points.len(),
        if d.tests.significant {
            "significant"
        } else {
            "not significant"
        },
        d.tests.p_value,
        d.elapsed.as_secs_f64()
    );
    for r in &d.regions {
        let _ = writeln!(s, "  region: {}", describe_region(r));
    }
    let _ = writeln!(
        s,
        "  accepted: {}",
        if d.attr.accepted.is_empty() {
            "none".to_string()
        } else {
            d.attr.accepted.join(", ")
        }
    );
    for (a, b) in &d.attr.ambiguous {
        let _ = writeln!(s, "  ambiguous: {a} / {b} (neither named)");
    }
    for u in &d.unexplained {
        let _ = writeln!(s, "  unexplained: {}", describe_region(&u.region));
    }
    let _ = writeln!(
        s,
        "  withheld RMSE (CV by visit) r1 {:.3} -> {:.3} mm, r2 {:.3} -> {:.3} mm; floor {:.3} / {:.3} mm",
        t[0].1.rmse[0], t[1].1.rmse[0], t[0].1.rmse[1], t[1].1.rmse[1], d.floor[0], d.floor[1]
    );
    if let Some(w) = &d.withheld {
        let _ = writeln!(
            s,
            "  withheld log {}: r1 {:.3} -> {:.3} mm, r2 {:.3} -> {:.3} mm",
            w.source,
            w.baseline.rmse[0],
            w.augmented.rmse[0],
            w.baseline.rmse[1],
            w.augmented.rmse[1]
        );
    }
    s
}

fn describe_region(r: &Region) -> String {
    let mut s = format!(
        "{}: z_m {}-{} mm, f {}-{} Hz",
        AXES[r.axis],
        g(r.z.0),
        g(r.z.1),
        g(r.f.0),
        g(r.f.1)
    );
    if let Some(t) = r.t {
        let _ = write!(s, ", session time {}-{} s", g(t.0), g(t.1));
    }
    if let Some(t) = r.since {
        let _ = write!(s, ", {}-{} s after an input change", g(t.0), g(t.1));
    }
    let _ = write!(
        s,
        " ({} {} mm, p = {:.2e}, {} visits)",
        match r.kind {
            Kind::Formation => "lag contrast",
            Kind::Pattern => "RMS of the smoothed residual",
            _ => "mean residual",
        },
        g(r.mean),
        r.p,
        r.visits.len()
    );
    s
}

/// Write every output into `dir`.
pub fn write(d: &Diagnosis, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let j = json(d);
    std::fs::write(
        dir.join("report.json"),
        serde_json::to_string_pretty(&j)? + "\n",
    )
    .with_context(|| format!("cannot write {}", dir.join("report.json").display()))?;
    d.ident
        .model
        .save(&dir.join("baseline.json"))
        .with_context(|| format!("cannot write {}", dir.join("baseline.json").display()))?;
    augmented_model(d)
        .save(&dir.join("augmented.json"))
        .with_context(|| format!("cannot write {}", dir.join("augmented.json").display()))?;
    let figs = plots(d, dir)?;
    std::fs::write(dir.join("report.md"), markdown(d, &figs))
        .with_context(|| format!("cannot write {}", dir.join("report.md").display()))?;
    Ok(())
}

fn markdown(d: &Diagnosis, figs: &[(String, String)]) -> String {
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
            let cv = super::rmse(&d.ds, &e.model.cv);
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
                "| {} | {} | {} | {} | {:.2e} | {} | {:.0} % | {:.3} / {:.3} | {} | {} |",
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
                cv.rmse[0],
                cv.rmse[1],
                ps.join(", "),
                verdict
            );
        }
        let _ = writeln!(w, "\nRules (all must hold): withheld log-likelihood gain over the model of the previous round above the BIC penalty (k/2 ln visits); per-visit gains positive by a paired t test at alpha; no parameter at a fit bound and locations inside the data; and, refitted on all data, at least half of a significant region's residual removed. Forward selection adds effects one at a time. The candidates are the model's own effect terms (docs/effects.md), refitted with the baseline; what each frees is in `src/diagnose/candidates.rs`. An accepted effect is switched on in `augmented.json` with these parameters.\n");
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

/// Mean visit residual per point (NaN where a point has no visit).
fn point_means(d: &Diagnosis, pred: &[[f64; 2]], a: usize) -> Vec<f64> {
    let res: Vec<[f64; 2]> =
        d.ds.rows
            .iter()
            .zip(pred)
            .map(|(r, p)| [r.r[0] - p[0], r.r[1] - p[1]])
            .collect();
    let vr = gap::visit_residuals(&d.ds, &res);
    let mut s = vec![(0.0, 0usize); d.ds.points.len()];
    for (v, e) in vr.e.iter().enumerate() {
        let p = d.ds.visits[v].point;
        s[p].0 += e[a];
        s[p].1 += 1;
    }
    s.iter()
        .map(|(x, n)| if *n > 0 { x / *n as f64 } else { f64::NAN })
        .collect()
}

fn plots(d: &Diagnosis, dir: &Path) -> Result<Vec<(String, String)>> {
    let mut out = Vec::new();
    let (zs, fs) = d.ds.levels();
    let grid_ok = zs.len() >= 2 && fs.len() >= 2 && zs.len() * fs.len() <= 40_000;
    if grid_ok {
        for a in 0..2 {
            let before = point_means(d, &d.attr.baseline.pred, a);
            let after = point_means(d, &d.attr.augmented.pred, a);
            let vmax = before
                .iter()
                .chain(&after)
                .filter(|v| v.is_finite())
                .fold(1e-9f64, |m, v| m.max(v.abs()));
            let in_region: Vec<(f64, f64)> =
                d.ds.points
                    .iter()
                    .enumerate()
                    .filter(|(p, _)| {
                        d.regions.iter().any(|r| {
                            r.axis == a
                                && r.kind == Kind::Inputs
                                && r.visits.iter().any(|&v| d.ds.visits[v].point == *p)
                        })
                    })
                    .map(|(_, &x)| x)
                    .collect();
            for (tag, vals, title) in [
                (
                    "before",
                    &before,
                    format!("Residual r{} (measured - baseline) over (z_m, f)", a + 1),
                ),
                (
                    "after",
                    &after,
                    format!("Residual r{} (measured - augmented) over (z_m, f)", a + 1),
                ),
            ] {
                let mut grid = vec![vec![f64::NAN; zs.len()]; fs.len()];
                for (p, &(z, f)) in d.ds.points.iter().enumerate() {
                    let i = zs.iter().position(|x| (x - z).abs() < 1e-6).unwrap_or(0);
                    let j = fs.iter().position(|x| (x - f).abs() < 1e-6).unwrap_or(0);
                    grid[j][i] = vals[p];
                }
                let name = format!("residual_{tag}_r{}.png", a + 1);
                plot::heatmap_diverging(
                    &dir.join(&name),
                    &Labels {
                        title: &title,
                        x: "z_m [mm]",
                        y: "f [Hz]",
                    },
                    &Heatmap {
                        xs: &zs,
                        ys: &fs,
                        values: &grid,
                        colorbar_label: "residual [mm]",
                        marks: if tag == "before" { &in_region } else { &[] },
                        marks_label: if tag == "before" && !in_region.is_empty() {
                            "in a significant region"
                        } else {
                            ""
                        },
                        range: Some((-vmax, vmax)),
                    },
                )?;
                out.push((
                    name,
                    format!(
                        "Mean residual of r{} per operating point {} the accepted effects (blue: model too large, red: too small){}",
                        a + 1,
                        if tag == "before" { "before" } else { "after" },
                        if tag == "before" && !in_region.is_empty() { "; circles: points in a significant region" } else { "" }
                    ),
                ));
            }
        }
    }
    // Residuals over session time.
    let vb = gap::visit_residuals(
        &d.ds,
        &d.ds
            .rows
            .iter()
            .zip(&d.attr.baseline.pred)
            .map(|(r, p)| [r.r[0] - p[0], r.r[1] - p[1]])
            .collect::<Vec<_>>(),
    );
    let va = gap::visit_residuals(
        &d.ds,
        &d.ds
            .rows
            .iter()
            .zip(&d.attr.augmented.pred)
            .map(|(r, p)| [r.r[0] - p[0], r.r[1] - p[1]])
            .collect::<Vec<_>>(),
    );
    let panels: Vec<Panel> = (0..2)
        .map(|a| Panel {
            y_label: format!("residual r{} [mm]", a + 1),
            series: vec![
                Series::points(
                    "baseline",
                    d.ds.visits
                        .iter()
                        .zip(&vb.e)
                        .map(|(v, e)| (v.t_mid, e[a]))
                        .collect(),
                ),
                Series::points(
                    "augmented",
                    d.ds.visits
                        .iter()
                        .zip(&va.e)
                        .map(|(v, e)| (v.t_mid, e[a]))
                        .collect(),
                ),
            ],
        })
        .collect();
    plot::time_panels(
        &dir.join("residuals_time.png"),
        "Visit residuals (measured - model) over session time",
        "session time [s]",
        &panels,
    )?;
    out.push((
        "residuals_time.png".into(),
        "Mean residual of each visit against session time, baseline and augmented".into(),
    ));
    // Residuals after input changes.
    let rows_since = |pred: &[[f64; 2]], a: usize| -> Vec<(f64, f64)> {
        d.ds.rows
            .iter()
            .zip(pred)
            .filter(|(r, _)| d.ds.visits[r.visit].prev.is_some())
            .map(|(r, p)| (r.since, r.r[a] - p[a]))
            .collect()
    };
    let panels: Vec<Panel> = (0..2)
        .map(|a| Panel {
            y_label: format!("residual r{} [mm]", a + 1),
            series: vec![
                Series::points("baseline", rows_since(&d.attr.baseline.pred, a)),
                Series::points("augmented", rows_since(&d.attr.augmented.pred, a)),
            ],
        })
        .collect();
    plot::time_panels(
        &dir.join("residuals_since_change.png"),
        "Row residuals (measured - model) against time since the input change",
        "time since the input change [s]",
        &panels,
    )?;
    out.push((
        "residuals_since_change.png".into(),
        "Row residuals against the time since the last input change".into(),
    ));
    Ok(out)
}
