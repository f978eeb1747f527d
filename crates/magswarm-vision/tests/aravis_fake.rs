//! The Aravis source against Aravis' own fake cameras (only with `--features aravis`):
//! the in-process fake interface and a GigE Vision fake camera on 127.0.0.1 (the protocol
//! path of a real GigE camera: GVCP control, GVSP stream over UDP on the loopback).
//!
//! Opening a camera makes Aravis broadcast GigE Vision discovery on every network interface.
//! These tests must talk over the loopback only, so each one re-runs itself in a private network
//! namespace that holds only `lo` (`unshare --net --map-root-user`), and fails if it cannot.

#![cfg(feature = "aravis")]

use magswarm_vision::aravis_camera::{aravis, enable_fake_interface, AravisCamera, AravisConfig};
use magswarm_vision::{Camera, CameraError};
use std::process::Command;
use std::time::{Duration, Instant};

/// True when this process sees no network interface but the loopback. Otherwise runs `test`
/// again in a fresh network namespace (only `lo`, brought up) and checks that it passed.
fn in_private_network(test: &str) -> bool {
    let only_lo = std::fs::read_to_string("/proc/net/dev")
        .map(|s| s.lines().skip(2).all(|l| l.trim_start().starts_with("lo:")))
        .unwrap_or(false);
    if only_lo {
        return true;
    }
    let exe = std::env::current_exe().unwrap();
    let status = Command::new("unshare")
        .args(["--net", "--map-root-user", "sh", "-c"])
        .arg("ip link set lo up && exec \"$0\" --exact \"$1\" --nocapture --test-threads=1")
        .arg(&exe)
        .arg(test)
        .status()
        .unwrap_or_else(|e| {
            panic!(
                "cannot run unshare for a private network namespace ({e}); not running Aravis here"
            )
        });
    assert!(
        status.success(),
        "{test} in a private network namespace: {status}"
    );
    false
}

fn grab(cam: &mut AravisCamera, n: usize) -> Vec<magswarm_vision::Frame> {
    let mut frames = Vec::new();
    let t = Instant::now();
    while frames.len() < n {
        match cam.next_frame(Duration::from_secs(3)) {
            Ok(f) => frames.push(f),
            Err(CameraError::FrameLost { .. }) if t.elapsed() < Duration::from_secs(10) => {}
            Err(e) => panic!("{}: {e}", cam.describe()),
        }
    }
    frames
}

fn check(frames: &[magswarm_vision::Frame]) {
    for w in frames.windows(2) {
        assert!(
            w[1].t_s > w[0].t_s,
            "timestamps must increase: {} then {}",
            w[0].t_s,
            w[1].t_s
        );
        assert!(w[1].seq > w[0].seq);
    }
    let img = &frames[0].image;
    assert!(img.width() > 0 && img.height() > 0);
    // the fake camera's test pattern is not flat
    let (mn, mx) = img
        .data()
        .iter()
        .fold((255u8, 0u8), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(mx > mn, "flat image {mn}..{mx}");
}

#[test]
fn fake_interface_camera_delivers_mono8_frames() {
    if !in_private_network("fake_interface_camera_delivers_mono8_frames") {
        return;
    }
    enable_fake_interface();
    let mut cam = AravisCamera::open(&AravisConfig {
        device: Some("Fake_1".into()),
        fps: Some(50.0),
        buffers: 4,
        ..Default::default()
    })
    .unwrap();
    assert!(cam.describe().contains("Mono8"), "{}", cam.describe());
    cam.start(Instant::now()).unwrap();
    let frames = grab(&mut cam, 5);
    check(&frames);
}

#[test]
fn fake_gige_camera_on_loopback_delivers_mono8_frames() {
    if !in_private_network("fake_gige_camera_on_loopback_delivers_mono8_frames") {
        return;
    }
    let fake = aravis::GvFakeCamera::new(Some("127.0.0.1"), Some("MAGSWARM01"));
    let t = Instant::now();
    while !fake.is_running() && t.elapsed() < Duration::from_secs(5) {
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(
        fake.is_running(),
        "the GigE fake camera did not start on 127.0.0.1"
    );
    let mut cam = AravisCamera::open(&AravisConfig {
        device: Some("127.0.0.1".into()),
        fps: Some(25.0),
        region: Some([0, 0, 320, 240]),
        buffers: 4,
        ..Default::default()
    })
    .unwrap();
    cam.start(Instant::now()).unwrap();
    println!("{}", cam.describe());
    let frames = grab(&mut cam, 5);
    check(&frames);
    assert_eq!(
        (frames[0].image.width(), frames[0].image.height()),
        (320, 240)
    );
    drop(cam);
    drop(fake);
}
