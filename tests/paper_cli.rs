//! `magswarm paper` as a user runs it: the figures table (JSON), the plots, and bad input.
//!
//! Tolerances on the seed's figures are what the reconstructed paper model actually achieves
//! (see `magswarm paper`'s table and docs/reconstruction.md), not the seed's own precision:
//! they guard against regressions and state the known misses explicitly.

use serde_json::Value;
use std::path::Path;
use std::process::Command;

fn magswarm() -> Command {
    Command::new(env!("CARGO_BIN_EXE_magswarm"))
}

fn f(v: &Value, path: &str) -> f64 {
    let mut cur = v;
    for k in path.split('.') {
        cur = match k.parse::<usize>() {
            Ok(i) => &cur[i],
            Err(_) => &cur[k],
        };
    }
    cur.as_f64()
        .unwrap_or_else(|| panic!("{path} is not a number: {cur}"))
}

fn b(v: &Value, path: &str) -> bool {
    let mut cur = v;
    for k in path.split('.') {
        cur = &cur[k];
    }
    cur.as_bool()
        .unwrap_or_else(|| panic!("{path} is not a bool: {cur}"))
}

fn within(name: &str, model: f64, seed: f64, tol: f64) {
    let dev = model / seed - 1.0;
    assert!(
        dev.abs() <= tol,
        "{name}: model {model} vs seed {seed}: deviation {:+.1} % exceeds {:.0} %",
        dev * 100.0,
        tol * 100.0
    );
}

#[test]
fn paper_json_reports_the_seed_figures() {
    let out = magswarm().args(["paper", "--json"]).output().unwrap();
    assert!(
        out.status.success(),
        "paper --json failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).expect("paper --json prints JSON");

    // Show the table in the test output (cargo test -- --nocapture).
    for r in v["table"].as_array().expect("table") {
        println!(
            "{:<58} {:<20} {:<24} {}",
            r["figure"].as_str().unwrap(),
            r["seed"].as_str().unwrap(),
            r["model"].as_str().unwrap(),
            r["deviation"].as_str().unwrap()
        );
    }

    // Table I medians and the anisotropy (Sec. III-C d). S_x is close; S_y, and with it the
    // ratio, are known misses of the reconstruction (about -20 % and +32 %).
    within("median S_x", f(&v, "grid.median_s_x"), 0.393, 0.15);
    within("median S_y", f(&v, "grid.median_s_y"), 2.455, 0.25);
    within("S_x/S_y", f(&v, "grid.s_ratio"), 0.16, 0.40);
    within("k_xx/k_yy", f(&v, "grid.median_k_ratio"), 1.04, 0.02);
    // Ranges of the radii: r1 close, r2 a known miss (about -32 %).
    within("r1 range", f(&v, "grid.r1_range_mm"), 2.02, 0.10);
    within("r2 range", f(&v, "grid.r2_range_mm"), 5.66, 0.40);

    // Qualitative trends of Sec. III-C a.
    assert!(b(&v, "grid.r2_gt_r1_everywhere"), "r2 > r1 everywhere");
    assert!(f(&v, "grid.worst_r2_minus_r1_mm") > 1.0);
    assert!(b(&v, "grid.radii_grow_with_z"), "radii grow with z_m");
    assert!(b(&v, "dynamics.r2_gt_r1_fine") && b(&v, "dynamics.grow_with_z_fine"));
    // Falling then rising with frequency: interior minima at all but the closest z_m (where
    // the model's radii keep falling up to 10 Hz: a known miss).
    let shape = v["grid"]["frequency_shape"].as_array().unwrap();
    assert_eq!(shape.len(), 5);
    for axis in ["r1_interior", "r2_interior"] {
        let n = shape.iter().filter(|s| s[axis].as_bool().unwrap()).count();
        assert!(n >= 4, "{axis}: only {n} of 5 z_m have an interior minimum");
    }

    // The closed-loop model points of Sec. III-D are (nearly) reachable in the envelope.
    let cl = v["closed_loop"].as_array().unwrap();
    assert_eq!(cl.len(), 3);
    for (k, p) in cl.iter().enumerate() {
        let d = p["distance_mm"].as_f64().unwrap();
        let tol = if k == 0 { 0.25 } else { 0.05 };
        assert!(
            d <= tol,
            "closed-loop point {k}: nearest reachable is {d} mm away"
        );
        let z = p["z_m_mm"].as_f64().unwrap();
        let fq = p["f_hz"].as_f64().unwrap();
        assert!((3.5..=23.5).contains(&z) && (1.0..=10.0).contains(&fq));
    }

    // ODE (4) is consistent with the map, with a unique stable equilibrium and seconds-scale
    // formation.
    assert!(f(&v, "dynamics.max_rel_error") < 0.01);
    assert!(b(&v, "dynamics.unique_everywhere"), "unique equilibrium");
    assert!(b(&v, "dynamics.stable_everywhere"), "stable equilibrium");
    assert_eq!(f(&v, "dynamics.clamped_points"), 0.0);
    let (t0, t1) = (
        f(&v, "dynamics.time_constant_s.0"),
        f(&v, "dynamics.time_constant_s.1"),
    );
    assert!(t0 > 0.05 && t1 < 20.0, "formation time {t0}..{t1} s");

    // Constant gains cannot reproduce the map: the best fits miss by far
    // more than 1 %, and freeing K_tau and p does not make it worse.
    let kb = f(&v, "constant_fit.kb_only.max_rel_error");
    let full = f(&v, "constant_fit.full.max_rel_error");
    assert!(
        kb > 0.05 && full > 0.05,
        "constant fits: max errors {kb}, {full}"
    );
    assert!(
        f(&v, "constant_fit.full.rms_rel_error")
            <= f(&v, "constant_fit.kb_only.rms_rel_error") + 1e-3
    );

    // Fig. 5 collapse: exact for the model, within the seed's 5-10 % with noise.
    assert!(f(&v, "collapse.exact_max_dev") < 1e-12);
    assert!(f(&v, "collapse.max_median_dev.0") < 0.10);
    assert!(f(&v, "collapse.max_median_dev.1") < 0.10);

    // Field and magnet constants in SI.
    within(
        "dipole moment",
        f(&v, "magnet.dipole_moment_a_m2"),
        35.2,
        0.01,
    );
    assert!(f(&v, "dynamics.b_t.0") > 0.0 && f(&v, "dynamics.b_t.1") < 1.0);
}

/// Width and height from a PNG's IHDR chunk, after checking the signature.
fn png_size(p: &Path) -> (u32, u32) {
    let bytes = std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    assert_eq!(
        &bytes[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} is not a PNG",
        p.display()
    );
    assert_eq!(&bytes[12..16], b"IHDR");
    assert!(
        bytes.len() > 20_000,
        "{}: only {} bytes",
        p.display(),
        bytes.len()
    );
    let be = |i: usize| u32::from_be_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    (be(16), be(20))
}

#[test]
fn paper_plots_writes_readable_pngs() {
    let dir = tempfile::tempdir().unwrap();
    let plots = dir.path().join("plots");
    let out = magswarm()
        .args(["paper", "--plots"])
        .arg(&plots)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}");
    assert!(
        out.status.success(),
        "paper --plots failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("median S_x") && stdout.contains("closed-loop"));
    for name in [
        "fig4a_r1.png",
        "fig4b_r2.png",
        "fig5_collapse.png",
        "stiffness_s_x.png",
        "stiffness_s_y.png",
        "radii_vs_f.png",
        "formation_time_constant.png",
        "constant_kb_error.png",
    ] {
        let p = plots.join(name);
        let (w, h) = png_size(&p);
        assert!(w >= 800 && h >= 600, "{name}: {w}x{h}");
        assert!(stdout.contains(name), "{name} not listed");
    }
}

#[test]
fn paper_with_a_bad_model_file_names_it() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("broken-model.json");
    std::fs::write(
        &bad,
        r#"{"schema": "magswarm-model/1", "steady": {"C_1": "x"}}"#,
    )
    .unwrap();
    let out = magswarm()
        .args(["paper", "--model"])
        .arg(&bad)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("broken-model.json"), "stderr: {err}");
}
