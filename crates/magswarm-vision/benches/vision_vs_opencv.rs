//! The vision bench: magswarm-vision against OpenCV (opencv-python-headless) on the same
//! 1920x1200 8-bit frame, one core each, in one run.
//!
//!     cargo bench -p magswarm-vision --bench vision_vs_opencv [-- --reps N] [-- --frame F.png]
//!
//! Renders a swarm frame (ellipse r1 = 160 px, r2 = 230 px at 30 deg, blur 1.5 px, noise 4 gray
//! levels, three debris specks), writes it as PNG, times `Vision::measure` on it (Otsu, runs,
//! largest component, moments) and `benches/opencv_otsu_moments.py` on the same PNG, in
//! alternating blocks of 20 repetitions (the Python process serves timing requests)
//! (Python: $MAGSWARM_PYTHON, else the workspace .venv, else python3) and prints both medians and
//! minima and their ratios (on a shared machine the minima are the fairer figure: the two sides
//! run one after the other and see different loads). Exits 2 when the OpenCV side cannot run
//! (and says why).

use magswarm_vision::folder::{read_png, write_png};
use magswarm_vision::synth::{add_ellipse_coverage, finish, EllipseSpec};
use magswarm_vision::{Vision, VisionConfig};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

fn bench_frame(path: &Path) {
    let (w, h) = (1920, 1200);
    let spec = EllipseSpec {
        cx: 951.3,
        cy: 612.8,
        r1: 160.0,
        r2: 230.0,
        angle_deg: 30.0,
        swarm: 60,
        background: 190,
        blur_sigma_px: 1.5,
        noise_sigma: 4.0,
    };
    let mut cover = vec![0f32; w * h];
    add_ellipse_coverage(&mut cover, w, h, &spec, 1.0);
    for (x, y, r) in [
        (200.0, 150.0, 6.0),
        (1700.0, 1000.0, 9.0),
        (1500.0, 200.0, 4.0),
    ] {
        let d = EllipseSpec {
            cx: x,
            cy: y,
            r1: r,
            r2: r,
            angle_deg: 0.0,
            ..spec
        };
        add_ellipse_coverage(&mut cover, w, h, &d, 1.0);
    }
    let img = finish(
        w,
        h,
        cover,
        spec.swarm,
        spec.background,
        spec.blur_sigma_px,
        spec.noise_sigma,
        1,
    );
    write_png(path, &img).expect("write bench frame");
}

fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("MAGSWARM_PYTHON") {
        return p.into();
    }
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../.venv/bin/python");
    if venv.exists() {
        return venv;
    }
    "python3".into()
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let reps: usize = arg("--reps")
        .map(|s| s.parse().expect("--reps N"))
        .unwrap_or(300);
    let tmp = tempfile::tempdir().expect("temp dir");
    let frame = match arg("--frame") {
        Some(f) => PathBuf::from(f),
        None => {
            let p = tmp.path().join("bench_frame.png");
            bench_frame(&p);
            p
        }
    };
    let img = read_png(&frame).expect("read frame");
    let cfg = VisionConfig::default();
    let mut v = Vision::new();
    for _ in 0..20 {
        std::hint::black_box(v.measure(img.view(), &cfg));
    }
    println!(
        "frame {}x{} ({})",
        img.width(),
        img.height(),
        frame.display()
    );

    // OpenCV in a Python process that times blocks on request: blocks of ours and of OpenCV's
    // alternate, so both sides see the same machine load
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/opencv_otsu_moments.py");
    let py = python();
    let mut child = match Command::new(&py)
        .arg(&script)
        .arg(&frame)
        .arg("--serve")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
    {
        Ok(c) => c,
        Err(e) => {
            eprintln!("OpenCV side not run: cannot start {}: {e}", py.display());
            std::process::exit(2);
        }
    };
    let mut to_py = child.stdin.take().unwrap();
    let mut from_py = BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    from_py.read_line(&mut line).ok();
    if line.trim() != "ready" {
        let out = child.wait_with_output().expect("python output");
        eprintln!(
            "OpenCV side failed ({}): {line}{}",
            py.display(),
            String::from_utf8_lossy(&out.stderr)
        );
        std::process::exit(2);
    }
    let block = 20usize;
    let blocks = reps.div_ceil(block);
    let mut ts = Vec::with_capacity(blocks * block);
    let mut m = None;
    for _ in 0..blocks {
        for _ in 0..block {
            let t0 = Instant::now();
            let r = v.measure(std::hint::black_box(img.view()), &cfg);
            ts.push(t0.elapsed().as_secs_f64() * 1e3);
            m = Some(r);
        }
        writeln!(to_py, "{block}").expect("write to python");
        line.clear();
        from_py.read_line(&mut line).expect("read from python");
    }
    drop(to_py);
    let m = m.unwrap();
    let min = ts.iter().cloned().fold(f64::INFINITY, f64::min);
    let ours = median(&mut ts);
    println!(
        "magswarm-vision  Otsu + runs + largest component + moments: median {ours:.3} ms, min {min:.3} ms \
         ({} reps in blocks of {block} alternating with OpenCV's, 1 thread); T={} r1={:.3} r2={:.3} px \
         angle={:.2} deg c=({:.2}, {:.2}) area={} valid={}",
        ts.len(),
        m.threshold,
        m.r1_px,
        m.r2_px,
        m.angle_deg,
        m.cx_px,
        m.cy_px,
        m.area_px,
        m.valid()
    );
    // the summary over all blocks follows the end of input
    let mut text = String::new();
    std::io::Read::read_to_string(&mut from_py, &mut text).expect("read from python");
    let status = child.wait().expect("python exit");
    if !status.success() {
        eprintln!("OpenCV side failed ({}, {status}): {text}", py.display());
        std::process::exit(2);
    }
    let j: serde_json::Value =
        serde_json::from_str(text.trim()).expect("JSON from the OpenCV script");
    for (name, what) in [
        ("otsu_moments", "Otsu + moments (whole image)"),
        (
            "otsu_cc_moments",
            "Otsu + connectedComponentsWithStats + moments of the largest",
        ),
    ] {
        let r = &j[name];
        let cv = r["median_ms"].as_f64().unwrap();
        println!(
            "OpenCV {} {what}: median {cv:.3} ms, min {:.3} ms; T={} r1={:.3} r2={:.3} px c=({:.2}, {:.2}) area={}",
            j["opencv"].as_str().unwrap_or("?"),
            r["min_ms"].as_f64().unwrap(),
            r["threshold"],
            r["r1"].as_f64().unwrap_or(f64::NAN),
            r["r2"].as_f64().unwrap_or(f64::NAN),
            r["cx"].as_f64().unwrap_or(f64::NAN),
            r["cy"].as_f64().unwrap_or(f64::NAN),
            r["area"]
        );
        let cv_min = r["min_ms"].as_f64().unwrap();
        println!(
            "ratio OpenCV {name} / magswarm-vision: {:.2}x (medians), {:.2}x (minima)",
            cv / ours,
            cv_min / min
        );
    }
}
