//! `magswarm predict`: replay of a log's inputs through a model.
#[path = "common/cli.rs"]
mod cli;
#[path = "common/synth.rs"]
mod common;

/// The flags of `magswarm predict`.
struct PredictArgs {
    model: Option<std::path::PathBuf>,
    log: std::path::PathBuf,
    out: std::path::PathBuf,
}

/// Run the `magswarm predict` of this build as a user does; its error message on failure.
fn run_predict(a: &PredictArgs) -> Result<(), String> {
    let mut c = cli::magswarm();
    c.arg("predict")
        .arg("--log")
        .arg(&a.log)
        .arg("--out")
        .arg(&a.out);
    if let Some(m) = &a.model {
        c.arg("--model").arg(m);
    }
    cli::run(c)
}

use common::Spec;
use magswarm::log::Log;
use magswarm::model::{hz_to_rad_s, steady, Model};

#[test]
fn replay_reproduces_the_generating_plant() {
    // A noise-free log with transients, made by stepping the true plant: predict with the
    // true model must give back the same radii.
    let truth = common::perturbed_truth();
    let mut spec = Spec::seed_like(truth.clone(), 1);
    spec.points.truncate(12);
    spec.sigma = [0.0, 0.0];
    spec.transient_rows = 6;
    spec.repeats = 3;
    let dir = tempfile::tempdir().unwrap();
    let inp = dir.path().join("in.csv");
    std::fs::write(&inp, common::csv(&spec)).unwrap();
    let mtruth = dir.path().join("truth.json");
    truth.save(&mtruth).unwrap();
    let out = dir.path().join("out.csv");
    run_predict(&PredictArgs {
        model: Some(mtruth),
        log: inp.clone(),
        out: out.clone(),
    })
    .unwrap();
    let a = Log::read(&inp).unwrap();
    let b = Log::read(&out).unwrap();
    assert_eq!(a.rows.len(), b.rows.len());
    let i1 = b
        .layout
        .extra_columns
        .iter()
        .position(|c| c == "r1_meas_mm")
        .unwrap();
    let mut worst: f64 = 0.0;
    for (x, y) in a.rows.iter().zip(&b.rows) {
        assert_eq!(
            (x.t_s, x.z_m_mm, x.f_hz, &x.session),
            (y.t_s, y.z_m_mm, y.f_hz, &y.session)
        );
        assert_eq!(y.extra[i1], format!("{}", x.r1_mm.unwrap()));
        worst = worst.max((x.r1_mm.unwrap() - y.r1_mm.unwrap()).abs());
        worst = worst.max((x.r2_mm.unwrap() - y.r2_mm.unwrap()).abs());
    }
    assert!(worst < 1e-4, "largest difference {worst} mm");
    // The transients are really there: the paper model's map differs from the replay.
    let moving = a
        .rows
        .iter()
        .filter(|r| {
            let sp = steady::evaluate(&truth, r.z_m_mm * 1e-3, hz_to_rad_s(r.f_hz));
            (sp.r1 - r.r1_mm.unwrap()).abs() > 0.05
        })
        .count();
    assert!(moving > 5, "only {moving} rows off the map");
}

#[test]
fn inputs_only_log_with_sessions_and_unknown_columns() {
    let text = "t_s,z_m_mm,f_hz,session,operator\n\
                0,8.5,4,a,x\n\
                0,23.5,9,b,y\n\
                0.5,18.5,4,a,x\n\
                60,18.5,4,a,x\n\
                1,23.5,9,b,y\n";
    let dir = tempfile::tempdir().unwrap();
    let inp = dir.path().join("in.csv");
    std::fs::write(&inp, text).unwrap();
    let out = dir.path().join("out.csv");
    run_predict(&PredictArgs {
        model: None,
        log: inp,
        out: out.clone(),
    })
    .unwrap();
    let o = Log::read(&out).unwrap();
    assert_eq!(
        o.layout.header(),
        vec![
            "t_s", "z_m_mm", "f_hz", "session", "operator", "r1_mm", "r2_mm", "r1_ss_mm",
            "r2_ss_mm"
        ]
    );
    let m = Model::paper();
    let ss = |z: f64, f: f64| steady::evaluate(&m, z * 1e-3, hz_to_rad_s(f));
    let r = &o.rows;
    // Each session starts settled at its first inputs.
    assert!((r[0].r1_mm.unwrap() - ss(8.5, 4.0).r1).abs() < 1e-9);
    assert!((r[1].r2_mm.unwrap() - ss(23.5, 9.0).r2).abs() < 1e-9);
    // Half a second after the change the swarm is on its way, a minute later it has arrived.
    let (a, b) = (ss(8.5, 4.0).r1, ss(18.5, 4.0).r1);
    let mid = r[2].r1_mm.unwrap();
    assert!(mid > a + 0.01 && mid < b - 0.01, "{a} {mid} {b}");
    assert!((r[3].r1_mm.unwrap() - b).abs() < 1e-4);
    // Session b is unaffected by session a's change.
    assert!((r[4].r1_mm.unwrap() - ss(23.5, 9.0).r1).abs() < 1e-6);
    assert_eq!(r[2].extra[0], "x");
}

#[test]
fn predict_reports_bad_input_with_line_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let inp = dir.path().join("in.csv");
    std::fs::write(&inp, "t_s,z_m_mm,f_hz\n0,8.5,4\n1,,4\n").unwrap();
    let e = run_predict(&PredictArgs {
        model: None,
        log: inp,
        out: dir.path().join("o.csv"),
    })
    .unwrap_err();
    assert!(e.contains("line 3, column z_m_mm"), "{e}");
}
