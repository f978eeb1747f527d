//! Scoring of a diagnosis against a benchmark scenario's truth (shared by
//! `examples/diagnose_benchmark.rs` and `tests/diagnose_benchmark.rs`).
//!
//! Verdicts: **right** (the true effect named first, both in a two-effect log; a reported
//! region overlaps where it acts; at least half of the withheld log's excess over the true
//! noise floor removed; null logs: nothing named; camera biases, which the baseline's gains
//! absorb: nothing named, or `camera_bias`; anomalies: nothing named and an unexplained region
//! at the anomaly), **right name** (named right, region or shrink short), **wrong** (another
//! effect named first), **nothing** (nothing named, nothing unexplained), **unexplained**
//! (nothing named, the gap reported unexplained).

use magswarm::diagnose::{gap::Kind, Diagnosis};
use magswarm_scenarios::{Realised, Scenario, Shape};

fn overlaps(r: (f64, f64), s: (f64, f64)) -> bool {
    r.0 <= s.1 + 1e-9 && s.0 <= r.1 + 1e-9
}

/// A reported region where the shape acts, or where what the baseline cannot absorb of it
/// shows (`visible`: operating points; a residual can only be found where it is).
fn located(d: &Diagnosis, shape: Shape, visible: &[(f64, f64)]) -> bool {
    let regions = d
        .regions
        .iter()
        .chain(d.unexplained.iter().map(|u| &u.region));
    let kinds: Vec<Kind> = regions.clone().map(|r| r.kind).collect();
    match shape.effect() {
        "particle_drift" => kinds.contains(&Kind::Drift) || !d.regions.is_empty(),
        "formation_lag" => kinds.contains(&Kind::Formation) || !d.regions.is_empty(),
        _ => match shape.region() {
            Some((z, f)) => regions
                .filter(|r| matches!(r.kind, Kind::Inputs | Kind::Pattern))
                .any(|r| {
                    (overlaps(r.z, z) && overlaps(r.f, f))
                        || visible
                            .iter()
                            .any(|p| overlaps(r.z, (p.0, p.0)) && overlaps(r.f, (p.1, p.1)))
                }),
            None => !d.regions.is_empty(),
        },
    }
}

/// Share of the withheld log's excess over the noise floor that the augmented model removes,
/// both radii together (each in units of the lab's visit noise). The excess is measured
/// against the generator's noise-free withheld rows, so it is exactly what the excess of the
/// RMSE over the floor estimates, without the noise of 20 withheld visits. None where the
/// baseline's excess there is under a tenth of the visit noise's variance (the effect does
/// not show at the withheld points).
pub fn withheld_shrink(re: &Realised, d: &Diagnosis) -> Option<f64> {
    let w = d.withheld.as_ref()?;
    let (mut eb, mut ea, mut n) = (0.0, 0.0, 0usize);
    for (line, b, a) in &w.rows {
        let Some(t) = line.checked_sub(2).and_then(|i| re.withheld_truth.get(i)) else {
            continue;
        };
        for i in 0..2 {
            let s2 = re.visit_sd[i] * re.visit_sd[i];
            eb += (b[i] - t[i]).powi(2) / s2;
            ea += (a[i] - t[i]).powi(2) / s2;
        }
        n += 1;
    }
    (n > 0 && eb / n as f64 > 0.2).then(|| 1.0 - ea / eb)
}

/// The verdict: right, right name, wrong, nothing or unexplained (see the module's header).
pub fn score(sc: &Scenario, re: &Realised, d: &Diagnosis) -> &'static str {
    let named = &d.attr.accepted;
    let exp = sc.expected();
    if exp.is_empty() {
        return if named.is_empty() { "right" } else { "wrong" };
    }
    if exp.iter().all(|e| *e == "camera_bias") {
        return match named.first().map(String::as_str) {
            None | Some("camera_bias") => "right",
            Some(_) => "wrong",
        };
    }
    if exp == ["anomaly"] {
        let shape = sc.truths[0].shape;
        if !named.is_empty() {
            return "wrong";
        }
        let at = shape.region().map(|(z, f)| {
            d.unexplained
                .iter()
                .any(|u| overlaps(u.region.z, z) && overlaps(u.region.f, f))
        });
        return match (d.unexplained.is_empty(), at) {
            (true, _) => "nothing",
            (false, Some(true)) => "right",
            _ => "unexplained",
        };
    }
    let name_ok = if exp.len() == 1 {
        named.first().map(String::as_str) == Some(exp[0])
    } else {
        exp.iter().all(|e| named.iter().any(|n| n == e))
    };
    if !name_ok {
        return if named.is_empty() {
            if d.unexplained.is_empty() {
                "nothing"
            } else {
                "unexplained"
            }
        } else {
            "wrong"
        };
    }
    let loc = sc
        .truths
        .iter()
        .zip(&re.visible_at)
        .all(|(t, v)| located(d, t.shape, v));
    let shrink = withheld_shrink(re, d).unwrap_or(1.0);
    if loc && shrink >= 0.5 {
        "right"
    } else {
        "right name"
    }
}
