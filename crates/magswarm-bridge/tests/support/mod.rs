//! An emulated rig for the bridge's tests: emulators on free ports and a pty, and the
//! matching config.
#![allow(dead_code)]

pub mod tmcl_peer;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use magswarm_bridge::config::RigConfig;
use magswarm_bridge::emulate::{self, Emulators};
use magswarm_bridge::stepper::cmd;

pub struct Rig {
    pub emu: Emulators,
    pub cfg: RigConfig,
    pub cfg_path: PathBuf,
    pub dir: tempfile::TempDir,
}

/// The config text; `{RTDE}`, `{DASH}`, `{SCRIPT}`, `{TTY}` are filled in once the emulators
/// listen. `extra` is appended (more sections, e.g. `[emulator]` cues).
///
/// The link timeouts are longer than the defaults (RTDE 0.5 s instead of 0.1 s, the URScript
/// watchdog 4 Hz instead of 10 Hz, the stepper watchdog 0.5 s instead of 0.25 s, a TMCL reply
/// 0.5 s instead of 0.1 s): on a machine
/// where several builds share two cores the emulator's 500 Hz stream, or the bridge's loop,
/// can stall for 100 ms, which is not the fault under test. Faults are injected as events
/// (a closed link, a protective stop, a killed process), whose detection does not wait for
/// these timeouts.
pub fn config_text(robot_extra: &str, camera_extra: &str, extra: &str) -> String {
    format!(
        r#"
[robot]
host = "127.0.0.1"
rtde_port = {{RTDE}}
script_port = {{SCRIPT}}
dashboard_port = {{DASH}}
z_tcp_at_zero_m = 0.400
timeout_s = 0.5
watchdog_hz = 4.0
{robot_extra}

[stepper]
kind = "tmcl"
device = "{{TTY}}"
baud = 9600
module_address = 1
motor = 0
velocity_per_hz = 51200.0
watchdog_timeout_s = 0.5
reply_timeout_s = 0.5

[camera]
kind = "emulated"
mm_per_px = 0.15
fps = 20.0
width = 480
height = 360
timeout_s = 0.3
{camera_extra}

[limits]
z_m_mm = [3.5, 23.5]
f_hz = [1.0, 10.0]
z_rate_mm_s = 10.0
f_rate_hz_s = 2.0

{extra}
"#
    )
}

/// Start the emulators for `text` and write the config that points at them.
pub fn rig(text: &str) -> Rig {
    let dir = tempfile::tempdir().unwrap();
    let first = text
        .replace("{RTDE}", "30004")
        .replace("{SCRIPT}", "30002")
        .replace("{DASH}", "29999")
        .replace("{TTY}", "/dev/null");
    let cfg0 = RigConfig::parse(&first, std::path::Path::new("test.toml")).unwrap();
    let emu = emulate::start(&cfg0, false).unwrap();
    let t = text
        .replace("{RTDE}", &emu.robot.rtde.port().to_string())
        .replace(
            "{SCRIPT}",
            &emu.robot
                .secondary
                .map(|a| a.port())
                .unwrap_or(0)
                .to_string(),
        )
        .replace(
            "{DASH}",
            &emu.robot
                .dashboard
                .map(|a| a.port())
                .unwrap_or(0)
                .to_string(),
        )
        .replace("{TTY}", &emu.stepper.path);
    let cfg_path = dir.path().join("rig.toml");
    std::fs::write(&cfg_path, &t).unwrap();
    let cfg = RigConfig::load(&cfg_path).unwrap();
    Rig {
        emu,
        cfg,
        cfg_path,
        dir,
    }
}

impl Rig {
    /// Time of the first MST at or after `after`.
    pub fn first_stop_after(&self, after: Instant) -> Option<Instant> {
        self.emu
            .stepper
            .received()
            .iter()
            .find(|r| r.at >= after && r.instruction == cmd::MST)
            .map(|r| r.at)
    }

    /// Every tool z target the robot received is inside the limits.
    pub fn assert_targets_inside(&self) {
        let rec = self.emu.robot.record();
        assert!(!rec.targets.is_empty(), "the robot received no target");
        let (lo, hi) = (0.400 + 3.5e-3, 0.400 + 23.5e-3);
        for z in &rec.targets {
            assert!(
                *z >= lo - 1e-12 && *z <= hi + 1e-12,
                "the robot received tool z {z} m outside [{lo}, {hi}]"
            );
        }
        assert!(
            !rec.dashboard.iter().any(|c| c.contains("unlock")),
            "the bridge sent {:?}",
            rec.dashboard
        );
    }

    pub fn log_path(&self) -> PathBuf {
        self.dir.path().join("log.csv")
    }

    /// A copy of the config whose stepper is the serial device `device` (another module
    /// than the emulator's, e.g. an independent peer).
    pub fn config_with_stepper(&self, device: &str) -> PathBuf {
        let text = std::fs::read_to_string(&self.cfg_path).unwrap();
        let p = self.dir.path().join("rig-peer.toml");
        std::fs::write(&p, text.replace(&self.emu.stepper.path, device)).unwrap();
        p
    }

    /// Start `magswarm-bridge run` with the config `cfg` on a two-row plan (10 mm / 4 Hz,
    /// then 12 mm / 5 Hz from 1 s), stdout and stderr piped.
    pub fn spawn_run(&self, cfg: &Path, args: &[&str]) -> Child {
        let plan = self.dir.path().join("plan.csv");
        std::fs::write(&plan, "t_s,z_m_mm,f_hz\n0,10,4\n1,12,5\n").unwrap();
        Command::new(env!("CARGO_BIN_EXE_magswarm-bridge"))
            .args(["run", "--config"])
            .arg(cfg)
            .arg("--plan")
            .arg(&plan)
            .arg("--log")
            .arg(self.log_path())
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    }

    /// Wait until the log has `n` rows (the run is under way).
    pub fn wait_rows(&self, n: usize, limit: Duration) {
        let t0 = Instant::now();
        loop {
            let rows = std::fs::read_to_string(self.log_path())
                .map(|t| t.lines().count().saturating_sub(1))
                .unwrap_or(0);
            if rows >= n {
                return;
            }
            assert!(t0.elapsed() < limit, "only {rows} rows after {limit:?}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

/// Assert a stop reached the stepper within `limit` of `cue`.
pub fn assert_stop_within(rig: &Rig, cue: Instant, limit: Duration) {
    let stop = rig
        .first_stop_after(cue)
        .unwrap_or_else(|| panic!("the stepper saw no MST after the fault"));
    let d = stop.duration_since(cue);
    eprintln!(
        "stepper MST {:.1} ms after the fault",
        d.as_secs_f64() * 1e3
    );
    assert!(
        d <= limit,
        "the stepper saw the stop {:.1} ms after the fault (limit {:.0} ms)",
        d.as_secs_f64() * 1e3,
        limit.as_secs_f64() * 1e3
    );
}
