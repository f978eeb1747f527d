//! Replay source: timing as a camera, index parsing errors, lost frames.

use magswarm_vision::folder::{read_index, write_frame_folder, FolderError};
use magswarm_vision::{Camera, CameraError, GrayImage, ReplayCamera};
use std::time::{Duration, Instant};

fn frame(v: u8) -> GrayImage {
    let mut img = GrayImage::filled(64, 48, 200);
    img.row_mut(10)[5] = v;
    img
}

#[test]
fn frames_arrive_at_their_t_s_from_the_start_of_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let ts = [0.0, 0.05, 0.1, 0.15, 0.3];
    let frames: Vec<(f64, GrayImage)> = ts
        .iter()
        .enumerate()
        .map(|(i, &t)| (t, frame(i as u8)))
        .collect();
    write_frame_folder(dir.path(), &frames).unwrap();
    let mut cam = ReplayCamera::open(dir.path()).unwrap();
    assert!(cam.describe().contains("5 frames"));
    std::thread::sleep(Duration::from_millis(50)); // the decoder runs ahead meanwhile
    let t0 = Instant::now();
    cam.start(t0).unwrap();
    for (i, &t) in ts.iter().enumerate() {
        let f = cam.next_frame(Duration::from_secs(2)).unwrap();
        let at = f.arrived.duration_since(t0).as_secs_f64();
        assert_eq!(f.seq, i as u64);
        assert_eq!(f.t_s, t);
        assert_eq!(f.image, frames[i].1, "frame {i} pixels");
        assert_eq!(
            f.name.as_deref(),
            Some(format!("frame_{i:06}.png").as_str())
        );
        assert!(
            at >= t,
            "frame {i} delivered early: at {at:.4} s, due {t} s"
        );
        assert!(at < t + 0.1, "frame {i} late: at {at:.4} s, due {t} s");
    }
    match cam.next_frame(Duration::from_millis(10)) {
        Err(CameraError::EndOfStream { frames: 5, .. }) => {}
        other => panic!("expected end of stream, got {other:?}"),
    }
}

#[test]
fn a_timeout_shorter_than_the_wait_returns_timeout_and_keeps_the_frame() {
    let dir = tempfile::tempdir().unwrap();
    write_frame_folder(dir.path(), &[(0.0, frame(1)), (0.2, frame(2))]).unwrap();
    let mut cam = ReplayCamera::open(dir.path()).unwrap();
    let t0 = Instant::now();
    cam.start(t0).unwrap();
    assert_eq!(cam.next_frame(Duration::from_millis(500)).unwrap().seq, 0);
    let t = Instant::now();
    let e = cam.next_frame(Duration::from_millis(50)).unwrap_err();
    assert!(
        matches!(e, CameraError::Timeout(_)) && e.is_transient(),
        "{e}"
    );
    let waited = t.elapsed().as_secs_f64();
    assert!(
        (0.045..0.15).contains(&waited),
        "waited {waited} s for a 50 ms timeout"
    );
    let f = cam.next_frame(Duration::from_millis(500)).unwrap();
    assert_eq!((f.seq, f.t_s), (1, 0.2));
    assert!(f.arrived.duration_since(t0).as_secs_f64() >= 0.2);
}

#[test]
fn a_missing_or_corrupt_frame_is_lost_and_the_stream_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    write_frame_folder(
        dir.path(),
        &[(0.0, frame(1)), (0.01, frame(2)), (0.02, frame(3))],
    )
    .unwrap();
    std::fs::write(dir.path().join("frame_000001.png"), b"not a png").unwrap();
    std::fs::write(
        dir.path().join("index.csv"),
        "t_s,file\n0,frame_000000.png\n0.01,frame_000001.png\n0.015,gone.png\n0.02,frame_000002.png\n",
    )
    .unwrap();
    let mut cam = ReplayCamera::open(dir.path()).unwrap();
    let to = Duration::from_secs(1);
    assert_eq!(cam.next_frame(to).unwrap().seq, 0);
    for (seq, what) in [(1u64, "frame_000001.png"), (2, "gone.png")] {
        match cam.next_frame(to) {
            Err(e @ CameraError::FrameLost { .. }) => {
                assert!(e.is_transient());
                let s = e.to_string();
                assert!(
                    s.contains(what) && s.contains(&format!("frame {seq}")),
                    "{s}"
                );
            }
            other => panic!("expected a lost frame, got {other:?}"),
        }
    }
    let f = cam.next_frame(to).unwrap();
    assert_eq!((f.seq, f.t_s), (3, 0.02));
}

fn index_error(content: Option<&str>) -> String {
    let dir = tempfile::tempdir().unwrap();
    if let Some(c) = content {
        std::fs::write(dir.path().join("index.csv"), c).unwrap();
    }
    let e = read_index(dir.path()).unwrap_err();
    let e2 = ReplayCamera::open(dir.path())
        .err()
        .expect("open must fail too");
    assert_eq!(e.to_string(), e2.to_string());
    if content.is_none() {
        assert!(matches!(e, FolderError::NoIndex { .. }));
    }
    e.to_string()
}

#[test]
fn index_errors_name_the_file_and_line() {
    let e = index_error(None);
    assert!(e.contains("index.csv") && e.contains("not found"), "{e}");
    let e = index_error(Some("time,file\n0,a.png\n"));
    assert!(e.contains("index.csv:1") && e.contains("t_s"), "{e}");
    let e = index_error(Some("t_s,file\n0,a.png\nabc,b.png\n"));
    assert!(
        e.contains("index.csv:3") && e.contains("\"abc\" is not a number"),
        "{e}"
    );
    let e = index_error(Some("t_s,file\n0.5,a.png\n0.2,b.png\n"));
    assert!(e.contains("index.csv:3") && e.contains("backwards"), "{e}");
    let e = index_error(Some("t_s,file\n0,a.png\n-1,b.png\n"));
    assert!(e.contains("index.csv:3") && e.contains(">= 0"), "{e}");
    let e = index_error(Some("t_s,file\n0,a.png\n0.1,\n"));
    assert!(
        e.contains("index.csv:3") && e.contains("empty file name"),
        "{e}"
    );
    let e = index_error(Some("t_s,file\n0,a.png\n0.1,b.png,extra\n"));
    assert!(e.contains("index.csv:3"), "{e}");
    let e = index_error(Some("t_s,file\n"));
    assert!(e.contains("no frames"), "{e}");
    let e = index_error(Some("t_s,file\nNaN,a.png\n"));
    assert!(e.contains("index.csv:2") && e.contains("finite"), "{e}");
}

#[test]
fn index_accepts_extra_columns_any_order_and_spaces() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("index.csv"),
        "file, exposure ,t_s\nb.png,3, 0.5\nc.png,3,0.5\n",
    )
    .unwrap();
    let idx = read_index(dir.path()).unwrap();
    assert_eq!(idx.len(), 2);
    assert_eq!(
        (idx[0].t_s, idx[0].file.as_str(), idx[0].line),
        (0.5, "b.png", 2)
    );
}

fn encode(w: u32, h: u32, ct: png::ColorType, depth: png::BitDepth, data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut enc = png::Encoder::new(&mut out, w, h);
    enc.set_color(ct);
    enc.set_depth(depth);
    enc.write_header().unwrap().write_image_data(data).unwrap();
    out
}

#[test]
fn other_png_kinds_are_converted_to_8_bit_gray() {
    use magswarm_vision::folder::decode_png;
    // 2 x 1 pixels: 200 and 40
    let g8 = decode_png(&encode(
        2,
        1,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        &[200, 40],
    ))
    .unwrap();
    assert_eq!(g8.data(), &[200, 40]);
    let g16 = encode(
        2,
        1,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
        &[200, 7, 40, 250],
    );
    assert_eq!(decode_png(&g16).unwrap().data(), &[200, 40]);
    let ga = encode(
        2,
        1,
        png::ColorType::GrayscaleAlpha,
        png::BitDepth::Eight,
        &[200, 255, 40, 0],
    );
    assert_eq!(decode_png(&ga).unwrap().data(), &[200, 40]);
    let rgb = encode(
        2,
        1,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
        &[200, 200, 200, 40, 40, 40],
    );
    assert_eq!(decode_png(&rgb).unwrap().data(), &[200, 40]);
    let rgba = encode(
        2,
        1,
        png::ColorType::Rgba,
        png::BitDepth::Eight,
        &[255, 0, 0, 255, 0, 0, 255, 255],
    );
    assert_eq!(decode_png(&rgba).unwrap().data(), &[76, 29]);
    let g1 = encode(
        2,
        1,
        png::ColorType::Grayscale,
        png::BitDepth::One,
        &[0b1000_0000],
    );
    assert_eq!(decode_png(&g1).unwrap().data(), &[255, 0]);
    let e = decode_png(b"\x89PNG\r\n\x1a\nbroken").unwrap_err();
    assert!(!e.to_string().is_empty());
}
