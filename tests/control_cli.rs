//! `magswarm inverse` and `magswarm linearize` from the command line.

use std::process::Command;

fn magswarm(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_magswarm"))
        .args(args)
        .output()
        .expect("run magswarm");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn inverse_prints_inputs_radii_and_feasibility() {
    let (ok, out, err) = magswarm(&["inverse", "--r1", "8.5", "--r2", "12"]);
    assert!(ok, "{err}");
    assert!(
        out.contains("z_m =") && out.contains("f =") && out.contains("feasible   yes"),
        "{out}"
    );

    let (ok, out, err) = magswarm(&["inverse", "--r1", "8", "--r2", "11", "--json"]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["feasible"], false);
    let d = v["distance_mm"].as_f64().unwrap();
    assert!(d > 0.0 && d < 0.5, "{d}");
    let z = v["inputs"]["z_m_mm"].as_f64().unwrap();
    let f = v["inputs"]["f_hz"].as_f64().unwrap();
    assert!((3.5..=23.5).contains(&z) && (1.0..=10.0).contains(&f));
    // The printed inputs give the printed radii.
    let m = magswarm_model::Model::paper();
    let sp = magswarm_model::steady::evaluate(&m, z * 1e-3, magswarm_model::hz_to_rad_s(f));
    assert!((sp.r1 - v["achieved_mm"]["r1"].as_f64().unwrap()).abs() < 1e-9);

    let (ok, _, _) = magswarm(&["inverse", "--r1", "-1", "--r2", "11"]);
    assert!(!ok);
}

#[test]
fn linearize_prints_json_matlab_and_python() {
    let (ok, out, err) = magswarm(&["linearize", "--z", "8.5", "--f", "4"]);
    assert!(ok, "{err}");
    let lin: magswarm_control::Linearization = serde_json::from_str(&out).unwrap();
    assert_eq!(lin.input_names, ["z_m".to_string(), "omega_m".to_string()]);
    assert!((lin.u0[0] - 0.0085).abs() < 1e-15);
    assert!(lin.eigenvalues.iter().all(|e| e.0 < 0.0));

    let (ok, out, err) = magswarm(&["linearize", "--z", "8.5", "--f", "4", "--format", "matlab"]);
    assert!(ok, "{err}");
    assert!(
        out.contains("A = [") && out.contains("sys = ss(A, B, C, D"),
        "{out}"
    );

    let (ok, out, err) = magswarm(&["linearize", "--z", "8.5", "--f", "4", "--format", "python"]);
    assert!(ok, "{err}");
    assert!(
        out.contains("import control") && out.contains("sys = control.ss(A, B, C, D"),
        "{out}"
    );
}
