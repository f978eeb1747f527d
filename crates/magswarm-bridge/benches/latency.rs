//! Latency bench: frame arrival (handover from the camera thread) to command sent (tool z and
//! heartbeat written to the RTDE socket, frequency handed to the stepper thread), p50 and
//! p99, for 1920x1200 8-bit frames (the EXO174CU3's format) at 160 fps, on the emulated rig.
//!
//!     cargo bench -p magswarm-bridge --bench latency [-- SECONDS]
//!
//! Two laws: the plan (a schedule lookup) and the PID of magswarm-control on setpoints. The
//! frames are pre-rendered (rendering is the camera's business, not the bridge's) and
//! delivered in real time at 160 fps.

use std::path::Path;
use std::time::{Duration, Instant};

use magswarm_bridge::config::RigConfig;
use magswarm_bridge::run::{self, Mode, RunOptions, Signals};
use magswarm_bridge::safety::FaultLatch;
use magswarm_bridge::schedule::Schedule;
use magswarm_vision::camera::{Camera, CameraError, Frame};
use magswarm_vision::emulated::{EmulatorConfig, SwarmRenderer};
use magswarm_vision::GrayImage;

const FPS: f64 = 160.0;

struct Memory {
    frames: Vec<GrayImage>,
    t0: Option<Instant>,
    seq: u64,
}

impl Camera for Memory {
    fn start(&mut self, t0: Instant) -> Result<(), CameraError> {
        self.t0 = Some(t0);
        Ok(())
    }
    fn next_frame(&mut self, timeout: Duration) -> Result<Frame, CameraError> {
        let t0 = *self.t0.get_or_insert_with(Instant::now);
        let t_s = self.seq as f64 / FPS;
        let due = t0 + Duration::from_secs_f64(t_s);
        let now = Instant::now();
        if due > now + timeout {
            std::thread::sleep(timeout);
            return Err(CameraError::Timeout(timeout));
        }
        if due > now {
            std::thread::sleep(due - now);
        }
        let image = self.frames[self.seq as usize % self.frames.len()].clone();
        let seq = self.seq;
        self.seq += 1;
        Ok(Frame {
            seq,
            t_s,
            arrived: Instant::now(),
            image,
            name: None,
        })
    }
    fn describe(&self) -> String {
        format!("{} pre-rendered frames at {FPS} fps", self.frames.len())
    }
}

fn frames() -> Vec<GrayImage> {
    let mut r = SwarmRenderer::new(EmulatorConfig {
        width: 1920,
        height: 1200,
        mm_per_px: 0.05,
        ..EmulatorConfig::default()
    });
    // Radii about those at (8.5 mm, 4 Hz), turning.
    (0..16)
        .map(|k| r.render(8.31 / 0.05, 11.49 / 0.05, k as f64 * 0.1))
        .collect()
}

fn main() {
    let secs: f64 = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(5.0);
    let text = format!(
        r#"
[robot]
host = "127.0.0.1"
z_tcp_at_zero_m = 0.400
[stepper]
device = "/dev/null"
velocity_per_hz = 51200.0
[camera]
kind = "emulated"
mm_per_px = 0.05
fps = {FPS}
timeout_s = 0.5
[limits]
z_m_mm = [3.5, 23.5]
f_hz = [1.0, 10.0]
z_rate_mm_s = 10.0
f_rate_hz_s = 2.0
[shadow]
enabled = false
"#
    );
    let cfg0 = RigConfig::parse(&text, Path::new("bench.toml")).unwrap();
    let imgs = frames();
    println!(
        "latency bench: frame arrival -> command sent, {}x{} frames at {FPS} fps, {secs} s per law",
        imgs[0].width(),
        imgs[0].height()
    );
    for law in ["plan", "pid"] {
        let emu = magswarm_bridge::emulate::start(&cfg0, false).unwrap();
        let t = text
            .replace(
                "host = \"127.0.0.1\"",
                &format!(
                    "host = \"127.0.0.1\"\nrtde_port = {}\ndashboard_port = {}\nscript_port = {}",
                    emu.robot.rtde.port(),
                    emu.robot.dashboard.unwrap().port(),
                    emu.robot.secondary.unwrap().port()
                ),
            )
            .replace("/dev/null", &emu.stepper.path);
        let cfg = RigConfig::parse(&t, Path::new("bench.toml")).unwrap();
        let mode = match law {
            "plan" => Mode::Plan(
                Schedule::parse(
                    "t_s,z_m_mm,f_hz\n0,8.5,4\n1,10,5\n",
                    ["z_m_mm", "f_hz"],
                    "plan",
                )
                .unwrap(),
            ),
            _ => Mode::Targets(
                Schedule::parse(
                    "t_s,r1_ref_mm,r2_ref_mm\n0,8.4,11.7\n",
                    ["r1_ref_mm", "r2_ref_mm"],
                    "t",
                )
                .unwrap(),
            ),
        };
        let dir =
            std::env::temp_dir().join(format!("magswarm-bridge-bench-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let opts = RunOptions {
            mode,
            log: dir.join(format!("{law}.csv")),
            duration: Some(secs),
            dry_run: false,
        };
        let cam = Box::new(Memory {
            frames: imgs.clone(),
            t0: None,
            seq: 0,
        });
        let r = run::run_with_camera(
            &cfg,
            &opts,
            &Signals::default(),
            &FaultLatch::new(),
            Some(cam),
        )
        .unwrap();
        assert!(r.fault.is_none(), "{:?}", r.fault);
        let ms: Vec<f64> = r.latencies_s.iter().map(|s| s * 1e3).collect();
        let expected = (secs * FPS) as usize;
        println!(
            "{law:>5}: {} frames ({} expected, {} invalid), p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms",
            ms.len(),
            expected,
            r.invalid_frames,
            run::percentile(&ms, 50.0),
            run::percentile(&ms, 99.0),
            ms.iter().cloned().fold(0.0, f64::max)
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
