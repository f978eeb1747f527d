//! Hostile files: model JSON and measurement logs built to break the readers. Each is read or
//! refused with an error naming the source (and the line for logs); nothing panics, and a
//! command fed one leaves no partial output file.

use proptest::prelude::*;

use magswarm::log::Log;
use magswarm::model::Model;

fn paper_json() -> String {
    Model::paper().to_json().unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// A number of the paper model replaced by something hostile.
    #[test]
    fn model_json_with_a_hostile_value(which in 0usize..400, value in prop::sample::select(vec![
        "1e400", "-1e400", "1e308", "-1e308", "5e-324", "\"text\"", "null", "[]", "{}", "true",
        "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[1]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]",
        "-0", "0", "1e-300", "123456789012345678901234567890",
    ])) {
        let json = paper_json();
        // Positions of numbers in the text (after ':' and optional spaces).
        let starts: Vec<usize> = json.match_indices(": ").map(|(i, _)| i + 2)
            .filter(|&i| json[i..].starts_with(|c: char| c == '-' || c.is_ascii_digit()))
            .collect();
        prop_assume!(!starts.is_empty());
        let i = starts[which % starts.len()];
        let end = i + json[i..].find([',', '\n', '}', ']']).unwrap_or(0);
        let text = format!("{}{}{}", &json[..i], value, &json[end..]);
        match Model::from_json_str(&text, "hostile.json") {
            Ok(m) => prop_assert!(m.validate().is_ok()),
            Err(e) => prop_assert!(e.to_string().contains("hostile.json"), "{e}"),
        }
    }

    /// Garbage and deeply nested JSON.
    #[test]
    fn model_json_garbage(bytes in prop::collection::vec(any::<u8>(), 0..400), depth in 0usize..5000) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = Model::from_json_str(&text, "garbage.json");
        let nested = format!("{}{}", "{\"a\":".repeat(depth), "}".repeat(depth));
        prop_assert!(Model::from_json_str(&nested, "nested.json").is_err());
    }

    /// Logs with BOMs, CRLF, ragged rows, duplicate headers, non-UTF-8 bytes, time going back.
    #[test]
    fn hostile_logs(rows in prop::collection::vec(
        prop::collection::vec(prop::sample::select(vec![
            "0", "1.5", "-1", "nan", "inf", "1e308", "", "x", "\u{feff}0", "\u{fffd}",
        ]), 0..7), 0..30),
        bom in any::<bool>(), crlf in any::<bool>(), dup in any::<bool>(), junk in any::<bool>()) {
        let nl = if crlf { "\r\n" } else { "\n" };
        let mut text = String::new();
        if bom { text.push('\u{feff}'); }
        text.push_str(if dup { "t_s,z_m_mm,f_hz,r1_mm,r2_mm,r1_mm" } else { "t_s,z_m_mm,f_hz,r1_mm,r2_mm" });
        text.push_str(nl);
        for r in &rows {
            text.push_str(&r.join(","));
            text.push_str(nl);
        }
        let mut bytes = text.into_bytes();
        if junk { bytes.extend_from_slice(b"\xff\xfe1,2\n"); }
        match Log::from_reader(&bytes[..], "hostile.csv", Default::default()) {
            Ok(_) => {}
            Err(e) => prop_assert!(e.to_string().contains("hostile.csv"), "{e}"),
        }
    }
}

#[test]
fn one_huge_line_is_an_error_not_a_hang() {
    let mut text = String::from("t_s,z_m_mm,f_hz,r1_mm,r2_mm\n");
    text.push_str(&"1,".repeat(2_000_000));
    text.push('\n');
    let t0 = std::time::Instant::now();
    let r = Log::from_str_named(&text, "huge.csv");
    assert!(r.is_err());
    assert!(t0.elapsed().as_secs() < 10);
}

#[test]
fn a_bad_log_leaves_no_partial_output() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bad.csv");
    std::fs::write(
        &log,
        "t_s,z_m_mm,f_hz\n0,8.5,4\n1,8.5,4\n0.5,8.5,4\n", // time goes backwards at line 4
    )
    .unwrap();
    let out = dir.path().join("out.csv");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_magswarm"))
        .args([
            "predict",
            "--log",
            log.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bad.csv"), "{err}");
    assert!(!out.exists(), "partial output left behind");
}
