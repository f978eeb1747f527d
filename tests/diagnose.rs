//! `magswarm diagnose`: injection-recovery for every effect, mixtures of two, null logs, the
//! command's outputs and its errors.
//!
//! **The truths are not the candidate forms.** Every log here comes from the virtual lab
//! (`magswarm::lab::presets`, the one generator of the project), whose truths are written in
//! the lab's *foreign* forms, which differ from the model terms diagnose fits
//! (`magswarm_model::effects`, via `magswarm::diagnose::candidates`): phase lag as a logistic
//! roll-off of the swarm's rotation with no field dependence, fed into every term of (6)-(7)
//! (fitted: an Adler step-out at a field-scaled frequency, in Phi and E only); cohesion loss
//! as a per-axis quadratic growth of the radii past 14 mm that lags input changes (fitted: a
//! Gaussian fading of the stiffness); formation lag as a dead time plus first-order filter on
//! the inputs the swarm sees (fitted: a parallel second-order mode on the radii); particle
//! drift as 1 - c sqrt(t) (fitted: exp(rate t)); centroid offset from a tilted rotation axis,
//! growing with depth (fitted: a constant offset); camera bias as a true projection of the
//! rotating ellipse on a tilted image plane plus scale and offset (fitted: a constant offset).
//! The plant itself is the paper model with its gains and exponents moved (the baseline must
//! be identified); visits come in a random order, with rows from 2 s after each change,
//! heteroscedastic per-row and per-visit noise and invalid frames.
//!
//! Each recovery prints one line of the recovery table (run with `--nocapture` to see it):
//! raw withheld RMSE (grouped CV by visit) of the baseline and the augmented model per axis,
//! the pure-error floor and the share of the withheld excess removed.

use magswarm::diagnose::{self, Config, Diagnosis};
use magswarm::lab::presets::Campaign;
use magswarm::log::Log;
use magswarm::model::Model;

fn cfg() -> Config {
    Config {
        boot: 299,
        ..Config::default()
    }
}

fn run(effects: &[(&str, f64)], seed: u64) -> Diagnosis {
    let c = Campaign::seed_grid(effects, seed).expect("campaign");
    let log = c.log("train.csv").expect("lab log");
    diagnose::diagnose(&log, None, &Model::paper(), &cfg()).expect("diagnose runs")
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
    check_recovery("centroid_offset", 1.0, (3.5, 13.5), (0.0, 100.0), None);
}

/// What a camera does to the radii (a scale error, a tilted image plane that foreshortens the
/// rotating ellipse at a phase-dependent amount, a constant offset from thresholding or blur)
/// is, on a steady grid, a smooth monotone map of each radius: the baseline's free gains and
/// exponents (C_i, a_Ki, alpha_i, N) absorb it, so the log shows no gap and nothing may be
/// named, `camera_bias` least of all. This is the honest limit for camera bias: it needs a
/// calibration (a target of known size in the image), not a diagnosis of the radii; the
/// baseline then predicts withheld visits at the noise floor.
#[test]
fn camera_bias_is_absorbed_by_the_baseline_and_not_misnamed() {
    for (label, offset) in [
        ("camera scale+tilt", 0.0),
        ("camera scale+tilt+offset", 0.7),
    ] {
        let mut c = Campaign::seed_grid(&[], 11).unwrap();
        c.scenario.foreign = vec![magswarm::lab::Foreign::CameraProjection {
            tilt_deg: 20.0,
            axis_deg: 30.0,
            scale: 1.08,
            offset_mm: offset,
        }];
        let log = c.log("camera.csv").unwrap();
        let d = diagnose::diagnose(&log, None, &Model::paper(), &cfg()).unwrap();
        eprintln!("{}", line(label, &d));
        assert!(
            d.attr.accepted.is_empty(),
            "{label}: named {:?}",
            d.attr.accepted
        );
        let t = d.rmse_table();
        for a in 0..2 {
            assert!(
                t[0].1.rmse[a] < 1.15 * d.floor[a],
                "{label}: axis {a}: {} vs floor {}",
                t[0].1.rmse[a],
                d.floor[a]
            );
        }
    }
}

/// A gap no candidate describes (a local bump of the radii around one operating point: a
/// resonance of the tank, a reflection the camera picks up there) is found, named by none of
/// the six, and reported as unexplained where it lies, with the discrepancy's withheld
/// recovery: a wrong name is worse than "unexplained".
#[test]
fn a_gap_no_candidate_describes_is_unexplained_not_misnamed() {
    let mut c = Campaign::seed_grid(&[], 5).unwrap();
    c.scenario.foreign = vec![magswarm::lab::Foreign::Bump {
        z_mm: 13.5,
        f_hz: 4.0,
        width_z_mm: 2.5,
        width_f_hz: 1.2,
        amp_mm: [0.3, 1.0],
    }];
    let d = diagnose::diagnose(&c.log("bump.csv").unwrap(), None, &Model::paper(), &cfg()).unwrap();
    eprintln!("{}", line("bump (no candidate)", &d));
    assert!(
        d.tests.significant,
        "the bump was not found (p = {})",
        d.tests.p_value
    );
    assert!(d.attr.accepted.is_empty(), "named {:?}", d.attr.accepted);
    let u = d
        .unexplained
        .iter()
        .find(|u| {
            u.region.z.0 <= 13.5
                && 13.5 <= u.region.z.1
                && u.region.f.0 <= 4.0
                && 4.0 <= u.region.f.1
        })
        .unwrap_or_else(|| panic!("no unexplained region over the bump: {:?}", d.unexplained));
    let shrink = u.heldout_shrink.expect("a discrepancy for an input region");
    assert!(
        shrink > 0.2,
        "the discrepancy recovers only {:.0} % there",
        100.0 * shrink
    );
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

/// Another rig's campaign: another workspace (z_m 5-25 mm in 4 mm steps, f 0.5-11 Hz in
/// 1.5 Hz steps) and a long campaign of three sessions (the swarm formed afresh, `t_s`
/// restarting). The candidates' locations and time scales follow the data, not the seed's grid.
#[test]
fn other_workspaces_and_sessions() {
    let mut c = Campaign::seed_grid(&[("phase_lag", 1.0)], 5).unwrap();
    if let magswarm::lab::Protocol::Grid { z_mm, f_hz, .. } = &mut c.scenario.protocol {
        *z_mm = vec![5.0, 9.0, 13.0, 17.0, 21.0, 25.0];
        *f_hz = vec![0.5, 2.0, 3.5, 5.0, 6.5, 8.0, 9.5, 11.0];
    }
    let d =
        diagnose::diagnose(&c.log("range.csv").unwrap(), None, &Model::paper(), &cfg()).unwrap();
    eprintln!("{}", line("phase_lag, other grid", &d));
    assert_eq!(
        d.attr.accepted.first().map(|s| s.as_str()),
        Some("phase_lag")
    );
    assert!(d.excess_removed()[2].unwrap_or(0.0) > 0.25);
    let mut c = Campaign::seed_grid(&[("particle_drift", 1.0)], 5).unwrap();
    c.scenario.sessions = 3;
    let d = diagnose::diagnose(&c.log("long.csv").unwrap(), None, &Model::paper(), &cfg()).unwrap();
    eprintln!("{}", line("particle_drift, 3 sessions", &d));
    assert_eq!(d.attr.accepted, vec!["particle_drift".to_string()]);
    assert!(d.excess_removed()[2].unwrap_or(0.0) >= 0.5);
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

/// The withheld log is the one test the naming never saw. A phase lag named on one rig's log
/// and a withheld log from a rig without it: the augmented model predicts that log worse than
/// the baseline beyond what the withheld visits' offsets make of chance, and the report says
/// so in its verdict, its summary and report.json; a withheld log from the same rig draws no
/// caution.
#[test]
fn an_augmented_model_worse_on_the_withheld_log_is_flagged() {
    let c = Campaign::seed_grid(&[("phase_lag", 1.0)], 7).unwrap();
    let log = c.log("train.csv").unwrap();
    let same = c.with_seed(1007).log("same.csv").unwrap();
    let other = Campaign::seed_grid(&[], 8)
        .unwrap()
        .log("other.csv")
        .unwrap();
    let run = |w: &Log| diagnose::diagnose(&log, Some(w), &Model::paper(), &cfg()).unwrap();
    let (d_same, d_other) = (run(&same), run(&other));
    for d in [&d_same, &d_other] {
        assert!(
            d.attr.accepted.iter().any(|a| a == "phase_lag"),
            "{:?}",
            d.attr.accepted
        );
    }
    assert_eq!(d_same.worse_on_withheld_log(), Some(false));
    assert_eq!(d_other.worse_on_withheld_log(), Some(true));
    let dir = tempfile::tempdir().unwrap();
    diagnose::report::write(&d_other, dir.path()).unwrap();
    let md = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    let verdict = &md[md.find("## Verdict").unwrap()..md.find("## How far").unwrap()];
    assert!(
        verdict.contains("predicts worse than the baseline"),
        "{verdict}"
    );
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap())
            .unwrap();
    assert_eq!(j["augmented_worse_on_withheld_log"], true);
    assert!(j["augmented_worse_on_withheld_log_p"].as_f64().unwrap() <= 0.05);
    assert!(diagnose::report::summary(&d_other).contains("caution"));
    assert!(!diagnose::report::summary(&d_same).contains("caution"));
}

#[test]
fn command_writes_the_contract_files() {
    let dir = tempfile::tempdir().unwrap();
    let c = Campaign::seed_grid(&[("phase_lag", 1.0)], 5).unwrap();
    let w = c.with_seed(1005);
    std::fs::write(dir.path().join("in.csv"), c.csv().unwrap()).unwrap();
    std::fs::write(dir.path().join("w.csv"), w.csv().unwrap()).unwrap();
    let out = dir.path().join("out");
    let st = std::process::Command::new(env!("CARGO_BIN_EXE_magswarm"))
        .arg("diagnose")
        .arg("--log")
        .arg(dir.path().join("in.csv"))
        .arg("--withheld")
        .arg(dir.path().join("w.csv"))
        .arg("--out")
        .arg(&out)
        .args(["--bootstrap", "199"])
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
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
    // augmented.json is a real model: the accepted effects switched on, and `predict` of the
    // training log through it gives the radii diagnose judged (up to the ODE (4) transient,
    // which diagnose carries over from the baseline rather than re-integrating).
    let accepted: Vec<String> = j["accepted"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect();
    assert!(
        accepted.iter().any(|a| a == "phase_lag"),
        "phase lag not named: {accepted:?}"
    );
    let log = Log::read(&dir.path().join("in.csv")).unwrap();
    for (file, key, effects) in [
        ("baseline.json", "baseline", Vec::new()),
        ("augmented.json", "augmented", accepted.clone()),
    ] {
        let m = Model::load(&out.join(file)).unwrap();
        let mut on: Vec<String> = m.effects.enabled().iter().map(|s| s.to_string()).collect();
        let mut want = effects.clone();
        on.sort();
        want.sort();
        assert_eq!(on, want, "{file}: effects switched on");
        let inputs: Vec<magswarm::predict::InputRow> = log
            .rows
            .iter()
            .map(|r| magswarm::predict::InputRow {
                t: r.t_s,
                z_mm: r.z_m_mm,
                f_hz: r.f_hz,
            })
            .collect();
        let pred = magswarm::predict::replay(&m, &inputs, 1e-6).unwrap();
        let mut ss = [0.0; 2];
        let mut n = 0.0;
        for (r, p) in log.rows.iter().zip(&pred) {
            if let (true, Some(a), Some(b)) = (r.valid, r.r1_mm, r.r2_mm) {
                ss[0] += (a - p[0]).powi(2);
                ss[1] += (b - p[1]).powi(2);
                n += 1.0;
            }
        }
        for (a, axis) in ["r1", "r2"].iter().enumerate() {
            let replayed = (ss[a] / n).sqrt();
            let reported = j[key]["train_rmse_mm"][axis].as_f64().unwrap();
            assert!(
                (replayed - reported).abs() < 0.1 * reported,
                "{file}: {axis} RMSE by predict {replayed:.4} mm vs reported {reported:.4} mm"
            );
        }
    }
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

/// A log visited at two distances only: identify cannot tell the four z_m-dependent
/// parameters from C_1, C_2, and diagnose's refusal names them and the flag that holds them;
/// held at the prior's values (`--fix`, `Config::fix`) the log is diagnosed, and the report
/// says which parameters were held. A log at one distance stays refused, held or not: no
/// effect along z_m can be judged there.
#[test]
fn a_log_at_two_distances_is_diagnosed_with_the_distance_parameters_held() {
    let held: Vec<String> = ["a_K1", "a_K2", "alpha_1", "alpha_2"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let fs = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0];
    let two = Log::from_str_named(&grid(&[8.5, 18.5], &fs, 5), "two.csv").unwrap();
    let e = err_of(&grid(&[8.5, 18.5], &fs, 5));
    assert!(e.contains("--fix a_K1,a_K2,alpha_1,alpha_2"), "{e}");
    let c = Config {
        fix: held.clone(),
        ..cfg()
    };
    let d = diagnose::diagnose(&two, None, &Model::paper(), &c).expect("diagnosed with --fix");
    let free: Vec<&str> = d.ident.steady.free.iter().map(|f| f.name()).collect();
    assert!(held.iter().all(|h| !free.contains(&h.as_str())), "{free:?}");
    let dir = tempfile::tempdir().unwrap();
    diagnose::report::write(&d, dir.path()).unwrap();
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap())
            .unwrap();
    assert_eq!(j["baseline"]["held_parameters"], serde_json::json!(held));
    let md = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    assert!(md.contains("a_K1, a_K2, alpha_1, alpha_2 held at the prior's values"));
    let one = Log::from_str_named(&grid(&[8.5], &fs, 5), "one.csv").unwrap();
    let e = format!(
        "{:#}",
        diagnose::diagnose(&one, None, &Model::paper(), &c).expect_err("one distance")
    );
    assert!(e.contains("one z_m only"), "{e}");
}
