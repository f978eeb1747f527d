//! Recovery, coverage and error tests of `magswarm identify` on synthetic seed-like logs.
#[path = "common/cli.rs"]
mod cli;
#[path = "common/synth.rs"]
mod common;

use common::Spec;
use magswarm::identify::{self, params, Collinear, Config};
use magswarm::log::Log;
use magswarm::model::Model;

fn rmse_rows(m: &Model, pts: &[identify::data::OpPoint], axis: usize) -> f64 {
    let (mut ss, mut n) = (0.0, 0);
    for p in pts {
        let r = identify::fit::predict_point(m, p.z_mm, p.f_hz)[axis];
        for s in &p.samples {
            ss += (r - s[axis]).powi(2);
            n += 1;
        }
    }
    (ss / n as f64).sqrt()
}

#[test]
fn recovers_parameters_and_predicts_withheld_points_at_the_noise_floor() {
    let truth = common::perturbed_truth();
    let log = common::log(&Spec::seed_like(truth.clone(), 42));
    assert_eq!(log.rows.len(), 500);
    let cfg = Config {
        withhold_every: 5,
        bootstrap: 50,
        ..Config::default()
    };
    let id = identify::identify(&[log], &Model::paper(), &cfg).unwrap();
    assert_eq!(id.points.len(), 40);
    assert_eq!(id.withheld.len(), 10);
    for e in &id.steady.estimates {
        let t = params::get(&truth, &e.name);
        assert!(
            e.ci.0 <= t && t <= e.ci.1,
            "{}: truth {t} outside {:?}",
            e.name,
            e.ci
        );
        assert!(e.boot.is_some());
    }
    // Withheld rows: the fitted model's RMSE is within 10 % of the noise floor (the RMSE
    // of the true model on the same rows).
    for a in 0..2 {
        let fitted = rmse_rows(&id.model, &id.withheld, a);
        let floor = rmse_rows(&truth, &id.withheld, a);
        println!(
            "axis r{}: withheld RMSE {fitted:.4} mm, noise floor {floor:.4} mm",
            a + 1
        );
        assert!(
            fitted <= 1.10 * floor,
            "r{}: {fitted} vs floor {floor}",
            a + 1
        );
    }
    // Point means: RMSE near the standard error of a 10-repeat mean.
    assert!(
        id.train.rmse[0] < 0.12 && id.train.rmse[1] < 0.2,
        "{:?}",
        id.train
    );
    // The model file is valid and carries provenance.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("m.json");
    id.model.save(&p).unwrap();
    let back = Model::load(&p).unwrap();
    assert!(
        back.provenance.contains("magswarm identify"),
        "{}",
        back.provenance
    );
    assert_eq!(back.steady, id.model.steady);
}

#[test]
fn true_parameters_fall_inside_the_95_percent_cis_at_about_the_nominal_rate() {
    let truth = common::perturbed_truth();
    let seeds = 20;
    let mut inside = 0;
    let mut total = 0;
    let mut per_param = std::collections::BTreeMap::<String, usize>::new();
    for seed in 0..seeds {
        let log = common::log(&Spec::seed_like(truth.clone(), 100 + seed));
        let cfg = Config {
            bootstrap: 0,
            starts: 2,
            ..Config::default()
        };
        let id = identify::identify(&[log], &Model::paper(), &cfg).unwrap();
        for e in &id.steady.estimates {
            let t = params::get(&truth, &e.name);
            let ok = e.ci.0 <= t && t <= e.ci.1;
            inside += ok as usize;
            total += 1;
            *per_param.entry(e.name.clone()).or_default() += ok as usize;
        }
    }
    let rate = inside as f64 / total as f64;
    println!("coverage {inside}/{total} = {rate:.3}; per parameter {per_param:?}");
    assert!(rate >= 0.85, "coverage {rate}");
    for (n, k) in per_param {
        assert!(k >= 16, "{n}: inside in only {k}/{seeds} seeds");
    }
}

#[test]
fn transients_identify_the_ode_time_scale() {
    let mut truth = common::perturbed_truth();
    truth.dynamics.K_tau *= 1.6;
    let mut spec = Spec::seed_like(truth.clone(), 5);
    spec.transient_rows = 10;
    spec.wait_s = 25.0;
    let log = common::log(&spec);
    let cfg = Config {
        bootstrap: 0,
        starts: 4,
        ..Config::default()
    };
    let id = identify::identify(&[log], &Model::paper(), &cfg).unwrap();
    let d = id.dynamics.as_ref().expect("dynamics fitted");
    let k = &d.estimates[0];
    assert_eq!(k.name, "K_tau");
    println!(
        "K_tau {} CI {:?} truth {}",
        k.value, k.ci, truth.dynamics.K_tau
    );
    assert!(k.ci.0 <= truth.dynamics.K_tau && truth.dynamics.K_tau <= k.ci.1);
    assert!(d.rms_after[0] <= d.rms_before[0] + 1e-9 && d.rms_after[1] <= d.rms_before[1] + 1e-9);
    assert!((id.model.dynamics.K_tau - k.value).abs() < 1e-12);
    assert!(id.trace.is_some());
}

#[test]
fn settled_only_logs_do_not_fit_dynamics() {
    let log = common::log(&Spec::seed_like(common::perturbed_truth(), 3));
    let cfg = Config {
        bootstrap: 0,
        starts: 1,
        ..Config::default()
    };
    let id = identify::identify(&[log], &Model::paper(), &cfg).unwrap();
    assert!(id.dynamics.is_none());
    assert!(
        id.dynamics_note.contains("not fitted"),
        "{}",
        id.dynamics_note
    );
    assert_eq!(id.model.dynamics, Model::paper().dynamics);
}

fn all_steady() -> Vec<String> {
    params::PARAMS
        .iter()
        .filter(|p| p.group == params::Group::Steady)
        .map(|p| p.name.to_string())
        .filter(|n| n != "c_P" && n != "q_P")
        .collect()
}

#[test]
fn collinear_stiffness_terms_are_detected_and_fixed() {
    let log = common::log(&Spec::seed_like(common::perturbed_truth(), 9));
    let cfg = Config {
        free: all_steady(),
        bootstrap: 0,
        starts: 2,
        withhold_every: 5,
        ..Config::default()
    };
    let id = identify::identify(&[log], &Model::paper(), &cfg).unwrap();
    let (names0, cov0) = id.steady.cov_initial.as_ref().expect("policy triggered");
    assert_eq!(names0.len(), 15);
    assert!(cov0.cond_scaled > 1e8, "{}", cov0.cond_scaled);
    assert!(!id.steady.auto_fixed.is_empty());
    assert!(id.steady.cov.cond_scaled <= 1e8);
    for a in &id.steady.auto_fixed {
        assert!(params::def(&a.name).unwrap().stiffness, "{} fixed", a.name);
        assert_eq!(
            params::get(&id.model, &a.name),
            params::get(&Model::paper(), &a.name)
        );
    }
    let h = id.heldout.unwrap();
    println!(
        "auto-fixed {:?}; withheld RMSE {:?}",
        id.steady
            .auto_fixed
            .iter()
            .map(|a| &a.name)
            .collect::<Vec<_>>(),
        h.rmse
    );
    assert!(h.rmse[0] < 0.3 && h.rmse[1] < 0.4, "{h:?}");
}

#[test]
fn ridge_policy_keeps_every_parameter_and_reports() {
    let log = common::log(&Spec::seed_like(common::perturbed_truth(), 11));
    let cfg = Config {
        free: all_steady(),
        bootstrap: 0,
        starts: 2,
        collinear: Collinear::Ridge { lambda: 1.0 },
        ..Config::default()
    };
    let id = identify::identify(&[log], &Model::paper(), &cfg).unwrap();
    assert_eq!(id.steady.free.len(), 15);
    assert!(id.steady.auto_fixed.is_empty());
    assert!(id.steady.cov.cond_scaled.is_finite());
    assert!(
        id.train.rmse[0] < 0.15 && id.train.rmse[1] < 0.25,
        "{:?}",
        id.train
    );
}

fn write_log(dir: &std::path::Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// The flags of `magswarm identify` these tests vary (the rest at their defaults, with fewer
/// starts and bootstrap replicates than a user would run, for speed).
struct IdentifyArgs {
    log: Vec<std::path::PathBuf>,
    out: std::path::PathBuf,
    report: Option<std::path::PathBuf>,
    free: Option<Vec<String>>,
    fix: Vec<String>,
    bound: Vec<String>,
    settle_s: Option<f64>,
    lenient: bool,
}

fn args(logs: Vec<std::path::PathBuf>, out: std::path::PathBuf) -> IdentifyArgs {
    IdentifyArgs {
        log: logs,
        out,
        report: None,
        free: None,
        fix: vec![],
        bound: vec![],
        settle_s: None,
        lenient: false,
    }
}

/// Run the `magswarm identify` of this build as a user does; its error message on failure.
fn run_identify(a: &IdentifyArgs) -> Result<(), String> {
    let mut c = cli::magswarm();
    c.arg("identify");
    for l in &a.log {
        c.arg("--log").arg(l);
    }
    c.arg("--out").arg(&a.out);
    c.args(["--starts", "2", "--bootstrap", "20", "--seed", "1"]);
    if let Some(r) = &a.report {
        c.arg("--report").arg(r);
    }
    if let Some(f) = &a.free {
        c.arg("--free").arg(f.join(","));
    }
    if !a.fix.is_empty() {
        c.arg("--fix").arg(a.fix.join(","));
    }
    for b in &a.bound {
        c.arg("--bound").arg(b);
    }
    if let Some(s) = a.settle_s {
        c.arg("--settle-s").arg(s.to_string());
    }
    if a.lenient {
        c.arg("--lenient");
    }
    cli::run(c)
}

#[test]
fn command_writes_model_and_report() {
    let dir = tempfile::tempdir().unwrap();
    let mut spec = Spec::seed_like(common::perturbed_truth(), 21);
    spec.transient_rows = 4;
    // Two logs: the grid split in halves, each its own file.
    let (a, b) = spec.points.split_at(25);
    let mut sa = spec.clone();
    sa.points = a.to_vec();
    let mut sb = spec.clone();
    sb.points = b.to_vec();
    let la = write_log(dir.path(), "a.csv", &common::csv(&sa));
    let lb = write_log(dir.path(), "b.csv", &common::csv(&sb));
    let out = dir.path().join("m.json");
    let rep = dir.path().join("rep");
    let mut a = args(vec![la, lb], out.clone());
    a.report = Some(rep.clone());
    run_identify(&a).unwrap();
    let m = Model::load(&out).unwrap();
    assert!(m.provenance.contains("a.csv") && m.provenance.contains("b.csv"));
    let md = std::fs::read_to_string(rep.join("report.md")).unwrap();
    for s in [
        "Table I",
        "RMSE [mm]",
        "MAE [%]",
        "Median stiffness",
        "Condition number",
        "| corr |",
        "bootstrap",
        "Dynamics",
    ] {
        assert!(md.contains(s), "report lacks {s:?}");
    }
    for f in [
        "pred_vs_meas.png",
        "residual_r1.png",
        "residual_r2.png",
        "collapse.png",
        "transients.png",
    ] {
        let b = std::fs::read(rep.join(f)).unwrap_or_else(|_| panic!("{f} missing"));
        assert_eq!(&b[..4], b"\x89PNG", "{f}");
        assert!(md.contains(f), "report does not show {f}");
    }
}

fn err_of(text: &str, a: impl FnOnce(&mut IdentifyArgs)) -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = write_log(dir.path(), "in.csv", text);
    let mut ar = args(vec![p], dir.path().join("m.json"));
    a(&mut ar);
    run_identify(&ar).unwrap_err()
}

fn grid_text(zs: &[f64], fs: &[f64], reps: usize) -> String {
    let m = Model::paper();
    let mut s = String::from("t_s,z_m_mm,f_hz,r1_mm,r2_mm\n");
    let mut t = 0.0;
    for &z in zs {
        for &f in fs {
            let r = identify::fit::predict_point(&m, z, f);
            for k in 0..reps {
                t += 30.0;
                s += &format!(
                    "{t},{z},{f},{},{}\n",
                    r[0] + 0.01 * k as f64,
                    r[1] - 0.01 * k as f64
                );
            }
        }
    }
    s
}

#[test]
fn bad_logs_give_clear_errors() {
    // Bad rows: every problem with its line number.
    let e = err_of(
        "t_s,z_m_mm,f_hz,r1_mm,r2_mm\n0,8.5,4,8,11\n1,8.5,four,8,11\n2,8.5,4,-3,11\n1.5,8.5,4,8,11\n",
        |_| {},
    );
    assert!(e.contains("line 3, column f_hz"), "{e}");
    assert!(e.contains("line 4, column r1_mm: negative radius"), "{e}");
    assert!(e.contains("line 5, column t_s: time goes backwards"), "{e}");
    // A single z_m.
    let e = err_of(
        &grid_text(&[8.5], &[1.0, 2.0, 4.0, 6.0, 8.0, 10.0], 3),
        |_| {},
    );
    assert!(e.contains("1 distinct z_m value(s) (8.5 mm)"), "{e}");
    assert!(e.contains("--fix"), "{e}");
    // Too few points.
    let e = err_of(&grid_text(&[3.5, 13.5], &[2.0], 3), |_| {});
    assert!(e.contains("too few operating points: 2"), "{e}");
    // A single frequency with N, q free.
    let e = err_of(&grid_text(&[3.5, 8.5, 13.5, 18.5, 23.5], &[4.0], 3), |_| {});
    assert!(e.contains("distinct frequency"), "{e}");
    // ... but fine once they are fixed.
    let dir = tempfile::tempdir().unwrap();
    let p = write_log(
        dir.path(),
        "in.csv",
        &grid_text(&[3.5, 8.5, 13.5, 18.5, 23.5], &[4.0], 3),
    );
    let mut a = args(vec![p], dir.path().join("m.json"));
    a.fix = vec!["N".into(), "q".into()];
    a.free = Some(vec![
        "C_1".into(),
        "C_2".into(),
        "alpha_1".into(),
        "N".into(),
        "q".into(),
    ]);
    run_identify(&a).unwrap();
    // No radius columns.
    let e = err_of("t_s,z_m_mm,f_hz\n0,8.5,4\n", |_| {});
    assert!(e.contains("no r1_mm, r2_mm columns"), "{e}");
    // Everything inside the settle time.
    let e = err_of(&grid_text(&[3.5, 8.5, 13.5], &[2.0, 4.0, 6.0], 3), |a| {
        a.settle_s = Some(1e6)
    });
    assert!(e.contains("no settled rows"), "{e}");
    // Unknown parameter and bad flags.
    let e = err_of(&grid_text(&[3.5], &[2.0], 3), |a| {
        a.free = Some(vec!["C_9".into()])
    });
    assert!(e.contains("unknown parameter") && e.contains("C_1"), "{e}");
    let e = err_of(&grid_text(&[3.5], &[2.0], 3), |a| {
        a.bound = vec!["C_1=5".into()]
    });
    assert!(e.contains("NAME=LO:HI"), "{e}");
    // Lenient mode skips bad rows and still fits.
    let mut text = grid_text(&[3.5, 8.5, 13.5, 18.5], &[1.0, 3.0, 5.0, 7.0, 9.0], 3);
    text += "999999,8.5,4,NaN,1\n";
    let e = err_of(&text, |_| {});
    assert!(e.contains("line 62, column r1_mm"), "{e}");
    let dir = tempfile::tempdir().unwrap();
    let p = write_log(dir.path(), "in.csv", &text);
    let mut a = args(vec![p], dir.path().join("m.json"));
    a.lenient = true;
    run_identify(&a).unwrap();
}

#[test]
fn invalid_rows_are_kept_but_not_fitted() {
    let truth = common::perturbed_truth();
    let mut log = common::log(&Spec::seed_like(truth, 4));
    // Mark a visit's rows invalid with absurd radii: the fit must not see them.
    for r in log.rows.iter_mut().skip(100).take(10) {
        r.valid = false;
        r.r1_mm = Some(100.0);
    }
    let id = identify::identify(
        &[log.clone()],
        &Model::paper(),
        &Config {
            bootstrap: 0,
            starts: 2,
            ..Config::default()
        },
    )
    .unwrap();
    assert_eq!(id.counts.invalid, 10);
    assert!(id.train.rmse[0] < 0.15, "{:?}", id.train);
    let text = log.to_csv_string();
    let back = Log::from_str_named(&text, "x").unwrap();
    assert_eq!(back.rows.iter().filter(|r| !r.valid).count(), 10);
}

/// A noise-free log of the seed's design in a shuffled visiting order (so session time, and
/// with it drift, is not confounded with z_m or f), the radii replayed through `truth` with
/// every effect it has switched on (drift with session time, camera bias on the reading).
fn observed_log(truth: &Model) -> Log {
    use rand::seq::SliceRandom;
    use rand::SeedableRng;
    let mut spec = Spec::seed_like(truth.clone(), 0);
    spec.points
        .shuffle(&mut rand::rngs::StdRng::seed_from_u64(17));
    let inputs: Vec<magswarm::predict::InputRow> = common::schedule(&spec)
        .into_iter()
        .map(|(t, z_mm, f_hz)| magswarm::predict::InputRow { t, z_mm, f_hz })
        .collect();
    let radii = magswarm::predict::replay(truth, &inputs, 1e-9).unwrap();
    let mut w = magswarm::log::LogWriter::new(
        Vec::new(),
        magswarm::log::Layout::standard(true, false, false, false),
    )
    .unwrap();
    for (i, r) in inputs.iter().zip(radii) {
        w.write_row(&magswarm::log::LogRow::new(i.t, i.z_mm, i.f_hz, Some(r)))
            .unwrap();
    }
    let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
    Log::from_str_named(&text, "observed.csv").unwrap()
}

#[test]
fn a_prior_with_drift_and_camera_effects_is_fitted_through_the_observed_map() {
    use magswarm::model::effects::{CameraBias, ParticleDrift};
    let effects = magswarm::model::Effects {
        particle_drift: Some(ParticleDrift { rate_per_h: -0.4 }),
        camera_bias: Some(CameraBias {
            scale: 1.06,
            offset_mm: 0.25,
            tilt_deg: 12.0,
        }),
        ..Default::default()
    };
    let mut truth = common::perturbed_truth();
    truth.effects = effects.clone();
    let log = observed_log(&truth);
    // The session lasts about half an hour: the drift is a real part of the signal.
    let t_end = log.rows.last().unwrap().t_s;
    assert!(t_end > 1500.0, "{t_end}");
    let cfg = Config {
        bootstrap: 0,
        ..Config::default()
    };
    // Prior: the paper's base parameters (away from the truth) with the effects as they are.
    let mut prior = Model::paper();
    prior.effects = effects.clone();
    let id = identify::identify(std::slice::from_ref(&log), &prior, &cfg).unwrap();
    assert!(
        id.steady.auto_fixed.is_empty(),
        "{:?}",
        id.steady.auto_fixed
    );
    assert_eq!(id.steady.estimates.len(), 8);
    for e in &id.steady.estimates {
        let t = params::get(&truth, &e.name);
        let p = params::get(&prior, &e.name);
        println!("{}: prior {p}, fitted {}, truth {t}", e.name, e.value);
        assert!(
            (e.value - t).abs() <= 1e-3 * t.abs().max(0.1),
            "{}: fitted {} vs truth {t} (prior {p})",
            e.name,
            e.value
        );
    }
    assert_eq!(
        id.model.effects, effects,
        "effects are kept as in the prior"
    );
    // Fitted through the observed map, the noise-free means are reproduced.
    assert!(
        id.train.rmse[0] < 1e-3 && id.train.rmse[1] < 1e-3,
        "{:?}",
        id.train
    );

    // The same log with the effects switched off cannot be fitted as well: the camera and
    // the drift over the session are not in the physical map.
    let off = identify::identify(&[log], &Model::paper(), &cfg).unwrap();
    println!("effects on: {:?}\neffects off: {:?}", id.train, off.train);
    for a in 0..2 {
        assert!(
            off.train.rmse[a] > 0.05 && off.train.rmse[a] > 50.0 * id.train.rmse[a],
            "r{}: RMSE {} with effects off vs {} with them",
            a + 1,
            off.train.rmse[a],
            id.train.rmse[a]
        );
    }
}

#[test]
fn drift_and_camera_offset_are_fitted_with_the_steady_map_when_freed() {
    use magswarm::model::effects::{CameraBias, Effect, ParticleDrift};
    let mut truth = common::perturbed_truth();
    truth.effects.particle_drift = Some(ParticleDrift { rate_per_h: -0.4 });
    truth.effects.camera_bias = Some(CameraBias {
        offset_mm: 0.25,
        ..CameraBias::NEUTRAL
    });
    let log = observed_log(&truth);
    // Prior: the paper model with both effects switched on at their neutral values.
    let mut prior = Model::paper();
    prior.effects.particle_drift = Some(ParticleDrift { rate_per_h: 0.0 });
    prior.effects.camera_bias = Some(CameraBias::NEUTRAL);
    let mut free = Config::default().free;
    free.extend(["particle_drift.rate_per_h", "camera_bias.offset_mm"].map(String::from));
    let cfg = Config {
        free,
        bootstrap: 0,
        ..Config::default()
    };
    assert!(identify::fits_steady(
        params::def("particle_drift.rate_per_h").unwrap().group
    ));
    assert!(!identify::fits_steady(
        params::def("formation_lag.tau_s").unwrap().group
    ));
    let id = identify::identify(&[log], &prior, &cfg).unwrap();
    let names: Vec<&str> = id
        .steady
        .estimates
        .iter()
        .map(|e| e.name.as_str())
        .collect();
    assert!(names.contains(&"particle_drift.rate_per_h"), "{names:?}");
    assert!(names.contains(&"camera_bias.offset_mm"), "{names:?}");
    for e in &id.steady.estimates {
        let t = params::get(&truth, &e.name);
        println!("{}: fitted {}, truth {t}", e.name, e.value);
        assert!(
            (e.value - t).abs() <= 2e-3 * t.abs().max(0.1),
            "{}: fitted {} vs truth {t}",
            e.name,
            e.value
        );
    }
}
