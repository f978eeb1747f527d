//! The gap report: `DIR/report.json` (the fields scripts rely on, docs/diagnose.md, plus evidence),
//! `DIR/baseline.json`, `DIR/augmented.json`, `DIR/report.md` and its figures. Everything is
//! rendered from the [`Diagnosis`]; nothing is recomputed here except the residual tables the
//! figures draw. `report.md` is written by `markdown.rs`, its figures by `figures.rs`.

use super::gap::{self, Kind, Region};
use super::DiagnoseError;
use super::{candidates, Diagnosis, Rmse};
use magswarm_model::effects::EffectKind;
use magswarm_report::plot::{self, Panel, Series};
use magswarm_report::{ReportError, Result};
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::Path;

mod figures;
mod markdown;

use figures::plots;
use markdown::markdown;

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
fn param_strings(kind: EffectKind, m: &magswarm_model::Model) -> Vec<String> {
    candidates::model_params(kind, m)
        .into_iter()
        .map(|(p, u, v)| format!("{p} = {} {u}", g(v)))
        .collect()
}

/// The augmented model's own model file: the baseline's refitted parameters with every
/// accepted effect switched on at its fitted values (runs as is in the FMU and `predict`).
fn augmented_model(d: &Diagnosis) -> magswarm_model::Model {
    // Nothing named: the augmented model is the baseline itself.
    let mut m = match d.attr.named_model() {
        None => d.ident.model.clone(),
        Some(aug) => aug.model_file(),
    };
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
            let mp = candidates::model_params(e.kind, &fitted);
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
                "notes": e.notes,
                "signature_share": e.signature.0,
                "signature_region": e.signature.1,
                "closes_gap": e.closes_gap,
                "passed": e.passed,
                "ambiguous_with": e.ambiguous_with,
                "variant": e.variant,
                "null_quantile": e.penalty,
                "form": match &e.form {
                    super::attribute::Form::Parametric => json!("library"),
                    super::attribute::Form::Learned(sh) => json!({
                        "learned_axis": sh.family.axis.key(),
                        "mode": sh.family.mode.key(),
                        "knots": sh.family.knots,
                        "r1": sh.values[0], "r2": sh.values[1],
                        "sd_r1": sh.sd[0], "sd_r2": sh.sd[1],
                    }),
                },
                "form_gains": e.form_gains.map(|(p, l)| json!({"library": p, "learned": l})),
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
            "tests_p_value": d.detection.tests_p,
            "opened_by": d.attr.verdict.opened_by.as_ref().map(|(e, p)| json!({"effect": e, "p_value": p})),
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
                "bootstrap": {
                    "replicates": d.cfg.boot,
                    "alternatives": d.detection.alts.iter().map(|a| json!({
                        "family": a.family, "alternative": a.name, "statistic": a.stat, "p_value": a.p,
                    })).collect::<Vec<_>>(),
                    "family_p_value": d.detection.family_p.iter().map(|(f, p)| (f.to_string(), json!(p))).collect::<serde_json::Map<_, _>>(),
                    "after_each_effect": d.attr.rounds.iter().map(|r| json!({
                        "p_value": r.verdict.p_value, "significant": r.verdict.significant, "families": r.detection.families,
                        "tests_p_value": r.detection.tests_p,
                        "opened_by": r.verdict.opened_by.as_ref().map(|(e, p)| json!({"effect": e, "p_value": p})),
                    })).collect::<Vec<_>>(),
                },
            },
            "noise": {
                "within_visit_sd_mm": axes(d.noise.within),
                "row_lag1_correlation": axes(d.noise.ar),
                "row_lag1_correlation_differences": {"r1": d.noise.ar_evidence[0].diffs, "r2": d.noise.ar_evidence[1].diffs},
                "row_lag1_correlation_likelihood_ratio": axes(d.noise.ar_evidence.map(|e| e.lr)),
                "row_lag1_correlation_upper": axes(d.noise.ar_evidence.map(|e| e.upper)),
                "visit_sd_mm": axes(d.noise.visit),
                "between_visit_sd_mm": axes(d.noise.between),
                "neighbour_pairs": d.noise.pairs,
                "repeat_pairs": d.noise.repeat_pairs,
            },
            "regions": d.regions.iter().map(region_json).collect::<Vec<_>>(),
        },
        "effects": effects,
        "accepted": d.attr.accepted,
        "local_anomaly": d.attr.anomaly.map(|(g, q, p)| json!({"heldout_loglik_gain": g, "null_quantile": q, "p_value": p, "beat_every_effect": d.attr.anomaly_won})),
        "ambiguous": d.attr.ambiguous.iter().map(|(a, b)| json!([a, b])).collect::<Vec<_>>(),
        "unexplained": unexplained,
        "baseline": {
            "free_parameters": d.ident.steady.free.iter().map(|f| f.name()).collect::<Vec<_>>(),
            "held_parameters": d.cfg.fix,
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
        "augmented_worse_on_withheld_log": d.worse_on_withheld_log(),
        "augmented_worse_on_withheld_log_p": w.map(|w| w.worse_p),
        "elapsed_s": d.elapsed.as_secs_f64(),
    })
}

/// The RMSE per radius going from `before` to `after` \[mm\], as the report and the
/// terminal print it: "r1 0.406 -> 0.306 mm, r2 0.683 -> 0.540 mm".
fn rmse_change(before: [f64; 2], after: [f64; 2]) -> String {
    format!(
        "r1 {:.3} -> {:.3} mm, r2 {:.3} -> {:.3} mm",
        before[0], after[0], before[1], after[1]
    )
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
        let _ = writeln!(s, "  close alternative to {a}: {b}");
    }
    for u in &d.unexplained {
        let _ = writeln!(s, "  unexplained: {}", describe_region(&u.region));
    }
    let _ = writeln!(
        s,
        "  withheld RMSE (CV by visit) {}; floor {:.3} / {:.3} mm",
        rmse_change(t[0].1.rmse, t[1].1.rmse),
        d.floor[0],
        d.floor[1]
    );
    if let Some(w) = &d.withheld {
        let _ = writeln!(
            s,
            "  withheld log {}: {}",
            w.source,
            rmse_change(w.baseline.rmse, w.augmented.rmse)
        );
        if d.worse_on_withheld_log() == Some(true) {
            let _ = writeln!(
                s,
                "  caution: the augmented model predicts the withheld log worse than the baseline; treat the names as provisional"
            );
        }
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
pub fn write(d: &Diagnosis, dir: &Path) -> std::result::Result<(), DiagnoseError> {
    let io = |what: &'static str, path: std::path::PathBuf| {
        move |err: std::io::Error| ReportError::Io { what, path, err }
    };
    std::fs::create_dir_all(dir).map_err(io("cannot create", dir.to_path_buf()))?;
    let text = serde_json::to_string_pretty(&json(d)).unwrap_or_else(|_| "{}".into()) + "\n";
    let path = dir.join("report.json");
    std::fs::write(&path, text).map_err(io("cannot write", path.clone()))?;
    d.ident.model.save(&dir.join("baseline.json"))?;
    augmented_model(d).save(&dir.join("augmented.json"))?;
    let figs = plots(d, dir)?;
    let path = dir.join("report.md");
    std::fs::write(&path, markdown(d, &figs)).map_err(io("cannot write", path.clone()))?;
    Ok(())
}
