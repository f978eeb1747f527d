//! `magswarm diagnose`: injection-recovery for every effect, mixtures of two, null logs, the
//! command's outputs and its errors.
//!
//! **The truths are not the candidate forms.** Every log here comes from
//! `magswarm::diagnose::synth`, whose effects are written in forms that differ from the forms
//! diagnose fits (`magswarm::diagnose::candidates`): phase lag as a saturating-exponential
//! ramp above 5.5 Hz with no field dependence (fitted: a logistic step at a field-scaled
//! step-out frequency); cohesion loss as a quadratic onset past 14 mm (fitted: a logistic
//! fade); formation lag as a 6 s dead time before the swarm sees an input change (fitted: a
//! first-order lag); particle drift as an exponential particle loss (fitted: linear in session
//! time); centroid offset as a rational decay (6 mm / (z_m + 6 mm))^2 (fitted: an exponential
//! decay in z_m); camera bias as a blurred, rescaled edge sqrt((s r)^2 + b^2) (fitted: a
//! constant offset). The plant itself is the paper model with its gains and exponents moved
//! (the baseline must be identified), the visits come in a random order with approach rows,
//! per-row and per-visit noise and occasional invalid frames.
//!
//! Each recovery prints one line of the recovery table (run with `--nocapture` to see it):
//! raw withheld RMSE (grouped CV by visit) of the baseline and the augmented model per axis,
//! the pure-error floor and the share of the withheld excess removed.

use magswarm::diagnose::{self, synth::Campaign, Config, Diagnosis};
use magswarm::log::Log;
use magswarm::model::Model;

fn cfg() -> Config {
    Config {
        permutations: 299,
        ..Config::default()
    }
}

fn run(effects: &[(&str, f64)], seed: u64) -> Diagnosis {
    let c = Campaign::seed_grid(effects, seed);
    diagnose::diagnose(&c.log("train.csv"), None, &Model::paper(), &cfg()).expect("diagnose runs")
}

fn line(name: &str, d: &Diagnosis) -> String {
    let t = d.rmse_table();
    let ex = d.excess_removed();
    let pct = |x: Option<f64>| {
        x.map(|v| format!("{:.0} %", 100.0 * v))
            .unwrap_or("-".into())
    };
    format!(
        "recovery | {name:<16} | accepted {:<32} | withheld RMSE r1 {:.3} -> {:.3}, r2 {:.3} -> {:.3} mm | floor {:.3} / {:.3} mm | excess removed {} (r1 {}, r2 {})",
        d.attr.accepted.join(","),
        t[0].1.rmse[0],
        t[1].1.rmse[0],
        t[0].1.rmse[1],
        t[1].1.rmse[1],
        d.floor[0],
        d.floor[1],
        pct(ex[2]),
        pct(ex[0]),
        pct(ex[1])
    )
}

/// A region of the report overlaps the truth: `z` and `f` ranges of the truth's action, or a
/// time-type region for the time effects.
fn overlaps(
    d: &Diagnosis,
    z: (f64, f64),
    f: (f64, f64),
    kind: Option<diagnose::gap::Kind>,
) -> bool {
    d.regions.iter().any(|r| match kind {
        Some(k) => r.kind == k,
        None => r.z.0 <= z.1 && z.0 <= r.z.1 && r.f.0 <= f.1 && f.0 <= r.f.1,
    })
}

fn check_recovery(
    name: &str,
    strength: f64,
    z: (f64, f64),
    f: (f64, f64),
    kind: Option<diagnose::gap::Kind>,
) {
    let d = run(&[(name, strength)], 11);
    eprintln!("{}", line(name, &d));
    assert!(
        d.tests.significant,
        "{name}: no significant gap found (p = {})",
        d.tests.p_value
    );
    assert_eq!(
        d.attr.accepted.first().map(|s| s.as_str()),
        Some(name),
        "{name}: accepted {:?}",
        d.attr.accepted
    );
    assert!(
        overlaps(&d, z, f, kind),
        "{name}: no region overlaps the truth: {:?}",
        d.regions
    );
    let ex = d.excess_removed()[2].expect("a withheld excess over the floor");
    assert!(
        ex >= 0.5,
        "{name}: only {:.0} % of the withheld excess removed",
        100.0 * ex
    );
}

#[test]
fn recovers_phase_lag() {
    check_recovery("phase_lag", 1.0, (0.0, 100.0), (5.5, 10.0), None);
}

#[test]
fn recovers_cohesion_loss() {
    check_recovery("cohesion_loss", 1.0, (14.0, 23.5), (0.0, 100.0), None);
}

#[test]
fn recovers_formation_lag() {
    check_recovery(
        "formation_lag",
        1.0,
        (0.0, 0.0),
        (0.0, 0.0),
        Some(diagnose::gap::Kind::Formation),
    );
}

#[test]
fn recovers_particle_drift() {
    check_recovery(
        "particle_drift",
        1.0,
        (0.0, 0.0),
        (0.0, 0.0),
        Some(diagnose::gap::Kind::Drift),
    );
}

#[test]
fn recovers_centroid_offset() {
    check_recovery("centroid_offset", 4.0, (3.5, 13.5), (0.0, 100.0), None);
}

/// A camera that rescales and blurs the edge (sqrt((s r)^2 + b^2)) is a smooth monotone map
/// of each radius: the baseline's free gains and exponents (C_i, a_Ki, alpha_i) absorb it, so
/// the log shows no gap and nothing may be named. This is the honest limit for this kind of
/// camera bias: it needs a camera calibration (a target of known size), not a diagnosis of the
/// radii. The test checks that diagnose says so (no gap, no name) and that the baseline indeed
/// predicts withheld visits at the noise floor.
#[test]
fn camera_scale_and_blur_are_absorbed_by_the_baseline_and_not_misnamed() {
    let d = run(&[("camera_bias", 4.0)], 11);
    eprintln!("{}", line("camera_bias x4", &d));
    assert!(d.attr.accepted.is_empty(), "named {:?}", d.attr.accepted);
    let t = d.rmse_table();
    for a in 0..2 {
        assert!(
            t[0].1.rmse[a] < 1.1 * d.floor[a],
            "axis {a}: {} vs floor {}",
            t[0].1.rmse[a],
            d.floor[a]
        );
    }
}

#[test]
fn names_both_effects_of_a_mixture() {
    for mix in [
        [("phase_lag", 1.0), ("particle_drift", 1.0)],
        [("cohesion_loss", 1.0), ("formation_lag", 1.0)],
    ] {
        let d = run(&mix, 23);
        eprintln!("{}", line(&format!("{}+{}", mix[0].0, mix[1].0), &d));
        for (n, _) in mix {
            assert!(
                d.attr.accepted.iter().any(|a| a == n),
                "mixture {mix:?}: {n} not named ({:?})",
                d.attr.accepted
            );
        }
    }
}

#[test]
fn null_logs_rarely_show_a_gap() {
    let n = 20;
    let mut false_pos = Vec::new();
    for seed in 0..n {
        let d = run(&[], 100 + seed);
        if d.tests.significant || !d.attr.accepted.is_empty() {
            false_pos.push((seed, d.tests.p_value, d.attr.accepted.clone()));
        }
        if !d.tests.significant {
            assert!(d.attr.accepted.is_empty() && d.regions.is_empty());
        }
    }
    let rate = false_pos.len() as f64 / n as f64;
    eprintln!(
        "null: {} of {n} seeds flagged a gap or named an effect ({:.0} %): {false_pos:?}",
        false_pos.len(),
        100.0 * rate
    );
    assert!(
        rate <= 0.05,
        "false-positive rate {rate} over {n} null logs: {false_pos:?}"
    );
}

#[test]
fn command_writes_the_contract_files() {
    let dir = tempfile::tempdir().unwrap();
    let c = Campaign::seed_grid(&[("phase_lag", 1.0)], 5);
    let mut w = Campaign::seed_grid(&[("phase_lag", 1.0)], 1005);
    w.points.truncate(20);
    std::fs::write(dir.path().join("in.csv"), c.csv()).unwrap();
    std::fs::write(dir.path().join("w.csv"), w.csv()).unwrap();
    let out = dir.path().join("out");
    diagnose::run(&diagnose::DiagnoseArgs {
        log: dir.path().join("in.csv"),
        withheld: Some(dir.path().join("w.csv")),
        model: None,
        out: out.clone(),
        alpha: 0.01,
        folds: 5,
        permutations: 199,
        seed: 1,
        lenient: false,
    })
    .unwrap();
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert!(j["gap"]["significant"].is_boolean());
    assert!(j["gap"]["p_value"].is_number());
    for r in j["gap"]["regions"].as_array().unwrap() {
        assert!(matches!(r["output"].as_str(), Some("r1" | "r2")));
        assert_eq!(r["z_m_mm"].as_array().unwrap().len(), 2);
        assert_eq!(r["f_hz"].as_array().unwrap().len(), 2);
        assert!(r["t_s"].is_null() || r["t_s"].as_array().unwrap().len() == 2);
        assert!(r["mean_residual_mm"].is_number() && r["p_value"].is_number());
    }
    for e in j["effects"].as_array().unwrap() {
        assert!(diagnose::candidates::NAMES.contains(&e["name"].as_str().unwrap()));
        assert!(e["accepted"].is_boolean() && e["params"].is_object());
        for k in ["train_rmse_mm", "heldout_rmse_mm"] {
            assert!(e[k]["r1"].is_number() && e[k]["r2"].is_number(), "{k}");
        }
    }
    assert!(j["accepted"].is_array() && j["unexplained"].is_array());
    for m in ["baseline", "augmented"] {
        for k in ["train_rmse_mm", "heldout_rmse_mm"] {
            assert!(
                j[m][k]["r1"].is_number() && j[m][k]["r2"].is_number(),
                "{m}.{k}"
            );
        }
    }
    assert!(j["augmented"]["withheld_log_rmse_mm"]["r1"].is_number());
    Model::load(&out.join("baseline.json")).unwrap();
    Model::load(&out.join("augmented.json")).unwrap();
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    for png in [
        "residual_before_r2.png",
        "residual_after_r2.png",
        "residuals_time.png",
    ] {
        assert!(md.contains(png), "{png} not in report.md");
        assert!(
            std::fs::metadata(out.join(png)).unwrap().len() > 1000,
            "{png}"
        );
    }
}

fn err_of(text: &str) -> String {
    let log = Log::from_str_named(text, "bad.csv").unwrap();
    match diagnose::diagnose(&log, None, &Model::paper(), &cfg()) {
        Ok(_) => panic!("diagnose accepted an unusable log"),
        Err(e) => format!("{e:#}"),
    }
}

fn grid(zs: &[f64], fs: &[f64], reps: usize) -> String {
    let m = Model::paper();
    let mut s = String::from("t_s,z_m_mm,f_hz,r1_mm,r2_mm\n");
    let mut t = 0.0;
    for &z in zs {
        for &f in fs {
            let r = magswarm::identify::fit::predict_point(&m, z, f);
            for k in 0..reps {
                t += if k == 0 { 60.0 } else { 1.0 };
                let e = 0.05 * ((k * 7 + (z as usize) * 3 + f as usize) % 5) as f64 - 0.1;
                s.push_str(&format!("{t},{z},{f},{},{}\n", r[0] + e, r[1] - e));
            }
        }
    }
    s
}

#[test]
fn unusable_logs_are_refused_naming_what_is_missing() {
    let e = err_of(&grid(&[3.5, 8.5], &[2.0, 5.0], 5));
    assert!(
        e.contains("too few operating points") || e.contains("distinct z_m"),
        "{e}"
    );
    let e = err_of(&grid(&[3.5, 8.5, 13.5, 18.5, 23.5, 6.0, 11.0], &[4.0], 5));
    assert!(e.contains("frequency"), "{e}");
    let e = err_of(&grid(&[3.5, 8.5, 13.5, 18.5], &[2.0, 4.0, 6.0, 8.0], 1));
    assert!(e.contains("no repeats"), "{e}");
}
