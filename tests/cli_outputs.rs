//! Errors before work: a command's output folder is created when missing, and refused up
//! front (naming the option and the path) when it cannot be, before any fitting starts.

use std::path::Path;
use std::process::Command;

fn magswarm(args: &[&str]) -> (bool, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_magswarm"))
        .args(args)
        .output()
        .unwrap();
    (
        o.status.success(),
        format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        ),
    )
}

fn small_log(dir: &Path) -> String {
    let p = dir.join("in.csv");
    let mut s = String::from("t_s,z_m_mm,f_hz,r1_mm,r2_mm\n");
    for i in 0..40 {
        let t = i as f64 * 0.5;
        let z = if i < 20 { 8.5 } else { 12.0 };
        s.push_str(&format!("{t},{z},4,7.9,11.5\n"));
    }
    std::fs::write(&p, s).unwrap();
    p.display().to_string()
}

#[test]
fn a_missing_output_folder_is_created() {
    let dir = tempfile::tempdir().unwrap();
    let log = small_log(dir.path());
    let out = dir.path().join("new/deeper/M.csv");
    let (ok, text) = magswarm(&["predict", "--log", &log, "--out", out.to_str().unwrap()]);
    assert!(ok, "{text}");
    assert!(out.is_file());
}

#[test]
fn an_unusable_output_folder_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let log = small_log(dir.path());
    let blocker = dir.path().join("a-file");
    std::fs::write(&blocker, b"x").unwrap();
    let out = blocker.join("M.json");
    let t0 = std::time::Instant::now();
    let (ok, text) = magswarm(&["identify", "--log", &log, "--out", out.to_str().unwrap()]);
    assert!(!ok);
    assert!(text.contains("--out") && text.contains("a-file"), "{text}");
    assert_eq!(
        text.matches(out.to_str().unwrap()).count(),
        1,
        "the path once, not twice: {text}"
    );
    assert!(t0.elapsed().as_secs_f64() < 5.0);
    assert!(!out.exists());
    // A folder where a file is expected.
    let (ok, text) = magswarm(&[
        "predict",
        "--log",
        &log,
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("is a folder"), "{text}");
}

/// `diagnose --fix` takes the names identify's refusal gives; a name that is not one of the
/// baseline's free parameters is refused before any work, listing those that are.
#[test]
fn diagnose_refuses_a_parameter_it_cannot_hold() {
    let dir = tempfile::tempdir().unwrap();
    let log = small_log(dir.path());
    let out = dir.path().join("d");
    let (ok, text) = magswarm(&[
        "diagnose",
        "--log",
        &log,
        "--out",
        out.to_str().unwrap(),
        "--fix",
        "a_K1,alpha_3",
    ]);
    assert!(!ok);
    assert!(
        text.contains("--fix alpha_3") && text.contains("C_1, C_2, a_K1"),
        "{text}"
    );
    assert!(!out.join("report.json").exists());
}
