//! Scoring of a diagnosis against a benchmark scenario's truth (shared by
//! `examples/diagnose_benchmark.rs` and `tests/diagnose_benchmark.rs`).

use magswarm::diagnose::{gap::Kind, Diagnosis};
use magswarm_scenarios::{Scenario, Shape};

fn overlaps(r: (f64, f64), s: (f64, f64)) -> bool {
    r.0 <= s.1 + 1e-9 && s.0 <= r.1 + 1e-9
}

/// A reported region where the shape acts.
fn located(d: &Diagnosis, shape: Shape) -> bool {
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
                .any(|r| overlaps(r.z, z) && overlaps(r.f, f)),
            None => !d.regions.is_empty(),
        },
    }
}

/// The verdict: right, right name, wrong, nothing or unexplained (see the example's header).
pub fn score(sc: &Scenario, d: &Diagnosis) -> &'static str {
    let named = &d.attr.accepted;
    let exp = sc.expected();
    if exp.is_empty() || exp == ["camera_bias"] || exp == ["camera_bias", "camera_bias"] {
        return if named.is_empty() { "right" } else { "wrong" };
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
    let loc = sc.truths.iter().all(|t| located(d, t.shape));
    let shrink = d.excess_removed()[2].unwrap_or(1.0);
    if loc && shrink >= 0.5 {
        "right"
    } else {
        "right name"
    }
}
