//! The emulated camera films what the model says, and measure_folder re-measures a recorded
//! folder end to end (including lost and invalid frames).

use magswarm_vision::measure::{measure_folder, write_rows, write_rows_csv, COLUMNS};
use magswarm_vision::{
    measure_frame, Camera, EmulatedCamera, EmulatorConfig, FrameFolderWriter, SharedSwarm,
    SwarmRenderer, SwarmState, VisionConfig,
};
use std::time::{Duration, Instant};

fn small_cfg() -> EmulatorConfig {
    EmulatorConfig {
        width: 480,
        height: 400,
        mm_per_px: 0.1,
        fps: 100.0,
        realtime: false,
        ..Default::default()
    }
}

fn angle_err(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(180.0);
    d.min(180.0 - d)
}

#[test]
fn the_emulated_camera_films_the_shared_state_and_turns_at_omega() {
    let swarm = SharedSwarm::new(SwarmState {
        r1_mm: 7.0,
        r2_mm: 11.0,
        omega_rad_s: 0.0,
    });
    let mut cam = EmulatedCamera::new(small_cfg(), swarm.source());
    let cfg = VisionConfig::default();
    let to = Duration::from_secs(1);
    let f = cam.next_frame(to).unwrap();
    let m = measure_frame(f.image.view(), &cfg);
    assert!(m.valid(), "{m:?}");
    // particles fill the ellipse, the edge is blurred and noisy: within half a pixel
    assert!(
        (m.r1_px - 70.0).abs() < 0.5 && (m.r2_px - 110.0).abs() < 0.5,
        "{m:?}"
    );
    assert!(
        (m.cx_px - 239.5).abs() < 0.5 && (m.cy_px - 199.5).abs() < 0.5,
        "{m:?}"
    );
    assert!(angle_err(m.angle_deg, 0.0) < 0.5, "{m:?}");
    assert!(
        m.components > 1,
        "debris specks should be in the frame: {m:?}"
    );

    // the model changes the swarm: the next frame shows it, turning at omega (t_s steps 10 ms)
    let omega = 2.0 * std::f64::consts::PI * 2.0; // 2 rev/s: 7.2 degrees per frame
    swarm.set(SwarmState {
        r1_mm: 5.0,
        r2_mm: 9.5,
        omega_rad_s: omega,
    });
    let mut last_angle = 0.0;
    for k in 1..=3 {
        let f = cam.next_frame(to).unwrap();
        assert_eq!(f.seq, k);
        assert!((f.t_s - k as f64 * 0.01).abs() < 1e-12);
        let m = measure_frame(f.image.view(), &cfg);
        assert!(
            (m.r1_px - 50.0).abs() < 0.5 && (m.r2_px - 95.0).abs() < 0.5,
            "{m:?}"
        );
        let expect = (omega * f.t_s).to_degrees();
        assert!(
            angle_err(m.angle_deg, expect) < 0.5,
            "frame {k}: angle {} expected {expect}",
            m.angle_deg
        );
        assert!(angle_err(m.angle_deg, last_angle) > 6.0, "it turns");
        last_angle = m.angle_deg;
    }
}

#[test]
fn a_realtime_emulated_camera_paces_its_frames_and_times_out() {
    let cfg = EmulatorConfig {
        fps: 50.0,
        realtime: true,
        ..small_cfg()
    };
    let mut cam = EmulatedCamera::new(cfg, |_t| SwarmState {
        r1_mm: 6.0,
        r2_mm: 8.0,
        omega_rad_s: 1.0,
    });
    let t0 = Instant::now();
    cam.start(t0).unwrap();
    for k in 0..4 {
        let f = cam.next_frame(Duration::from_secs(1)).unwrap();
        let at = f.arrived.duration_since(t0).as_secs_f64();
        assert!(at >= k as f64 * 0.02, "frame {k} early at {at}");
    }
    // at 5 fps, frame 1 is due 200 ms after frame 0: a 1 ms timeout expires first
    let cfg = EmulatorConfig {
        fps: 5.0,
        realtime: true,
        ..small_cfg()
    };
    let mut cam = EmulatedCamera::new(cfg, |_t| SwarmState {
        r1_mm: 6.0,
        r2_mm: 8.0,
        omega_rad_s: 1.0,
    });
    cam.next_frame(Duration::from_secs(1)).unwrap();
    let e = cam.next_frame(Duration::from_millis(1)).unwrap_err();
    assert!(e.is_transient(), "{e}");
    assert_eq!(cam.next_frame(Duration::from_secs(1)).unwrap().seq, 1);
}

#[test]
fn measure_folder_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    let mm = 0.1;
    let mut r = SwarmRenderer::new(small_cfg());
    let mut w = FrameFolderWriter::create(&frames).unwrap();
    let truth = [(6.0, 9.0, 10.0), (6.5, 9.0, 40.0), (7.0, 10.0, -30.0)];
    for (i, &(r1, r2, a)) in truth.iter().enumerate() {
        w.push(
            i as f64 * 0.02,
            &r.render(r1 / mm, r2 / mm, f64::to_radians(a)),
        )
        .unwrap();
    }
    // a swarm that drifted to the frame's edge: cut off
    let mut edge = SwarmRenderer::new(EmulatorConfig {
        center_px: Some((60.0, 200.0)),
        ..small_cfg()
    });
    w.push(0.06, &edge.render(7.0 / mm, 9.0 / mm, 0.0)).unwrap();
    // an empty frame (no swarm)
    w.push(0.08, &r.render(0.0, 0.0, 0.0)).unwrap();
    // a corrupt frame
    let name = w.push(0.10, &r.render(6.0 / mm, 9.0 / mm, 0.0)).unwrap();
    drop(w);
    std::fs::write(frames.join(&name), b"\x89PNG garbage").unwrap();

    let rows = measure_folder(&frames, mm, &VisionConfig::default()).unwrap();
    assert_eq!(rows.len(), 6);
    for (i, &(r1, r2, a)) in truth.iter().enumerate() {
        let row = &rows[i];
        assert!(row.valid, "{row:?}");
        assert_eq!(row.file, format!("frame_{i:06}.png"));
        assert!((row.t_s - i as f64 * 0.02).abs() < 1e-12);
        // half a pixel in mm
        assert!(
            (row.r1_mm - r1).abs() < 0.5 * mm && (row.r2_mm - r2).abs() < 0.5 * mm,
            "{row:?}"
        );
        assert!(angle_err(row.angle_deg, a) < 0.5, "{row:?}");
    }
    assert!(
        !rows[3].valid && rows[3].reason.as_deref().unwrap().contains("edge"),
        "{:?}",
        rows[3]
    );
    assert!(
        !rows[4].valid && rows[4].reason.as_deref().unwrap().contains("no swarm"),
        "{:?}",
        rows[4]
    );
    assert!(
        !rows[5].valid && rows[5].reason.as_deref().unwrap().contains("decode"),
        "{:?}",
        rows[5]
    );
    assert!(rows[5].r1_mm.is_nan());

    let out = dir.path().join("out.csv");
    write_rows_csv(&out, &rows).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), COLUMNS.join(","));
    let body: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    assert_eq!(body.len(), 6);
    assert_eq!(
        body.iter().map(|r| r[7].as_str()).collect::<Vec<_>>(),
        ["1", "1", "1", "0", "0", "0"]
    );
    let r1: f64 = body[0][2].parse().unwrap();
    assert!((r1 - rows[0].r1_mm).abs() < 1e-6);
    assert_eq!(body[5][2], "nan");
    // the same rows through the generic writer
    let mut buf = Vec::new();
    write_rows(&mut buf, &rows).unwrap();
    assert_eq!(String::from_utf8(buf).unwrap(), text);
}

#[test]
fn measure_folder_errors() {
    let dir = tempfile::tempdir().unwrap();
    let e = measure_folder(dir.path(), 0.05, &VisionConfig::default()).unwrap_err();
    assert!(e.to_string().contains("index.csv"), "{e}");
    std::fs::write(dir.path().join("index.csv"), "t_s,file\n0,a.png\nx,b.png\n").unwrap();
    let e = measure_folder(dir.path(), 0.05, &VisionConfig::default()).unwrap_err();
    assert!(e.to_string().contains("index.csv:3"), "{e}");
    for bad in [0.0, -1.0, f64::NAN] {
        let e = measure_folder(dir.path(), bad, &VisionConfig::default()).unwrap_err();
        assert!(e.to_string().contains("mm-per-px"), "{e}");
    }
}

#[test]
fn full_size_emulated_frames_measure_within_half_a_pixel() {
    // the rig's scale: 1920x1200 at 0.05 mm/px, r = 7.5 and 11.5 mm -> 150 and 230 px, a textured
    // (particle-filled) swarm with blur, noise and debris
    let mut r = SwarmRenderer::new(EmulatorConfig::default());
    let cfg = VisionConfig::default();
    for k in 0..6 {
        let a = -80.0 + 31.0 * k as f64;
        let img = r.render(150.0, 230.0, a.to_radians());
        let m = measure_frame(img.view(), &cfg);
        assert!(m.valid(), "{m:?}");
        assert!(
            (m.r1_px - 150.0).abs() < 0.5 && (m.r2_px - 230.0).abs() < 0.5,
            "angle {a}: {m:?}"
        );
        assert!(
            angle_err(m.angle_deg, a) * std::f64::consts::PI / 180.0 * 230.0 < 0.5,
            "angle {a}: {m:?}"
        );
        assert!(
            (m.cx_px - 959.5).abs() < 0.5 && (m.cy_px - 599.5).abs() < 0.5,
            "{m:?}"
        );
    }
}
