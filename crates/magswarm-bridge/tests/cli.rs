//! The `magswarm-bridge` binary against the emulated rig: signals, SIGKILL, check, measure,
//! and the end-to-end closed loop (bridge -> emulated devices -> frames -> radii -> PID).

mod support;

use std::process::Command;
use std::time::{Duration, Instant};

use magswarm_bridge::rtde::proto::runtime_state;
use magswarm_log::Log;
use nix::sys::signal::{kill, Signal};
use nix::unistd::Pid;
use support::*;

const BIN: &str = env!("CARGO_BIN_EXE_magswarm-bridge");

#[test]
fn sigterm_and_sigint_stop_the_rig_and_exit_nonzero() {
    for sig in [Signal::SIGTERM, Signal::SIGINT] {
        let rig = rig(&config_text("", "", ""));
        let child = rig.spawn_run(&rig.cfg_path, &["--duration", "30"]);
        rig.wait_rows(15, Duration::from_secs(20));
        let cue = Instant::now();
        kill(Pid::from_raw(child.id() as i32), sig).unwrap();
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(3), "{sig}: {stderr}");
        assert!(
            stderr.contains("FAULT signal") && stderr.contains(sig.as_str()),
            "{stderr}"
        );
        assert_stop_within(&rig, cue, Duration::from_millis(100));
        rig.assert_targets_inside();
        let log = Log::read(&rig.log_path()).unwrap();
        let last = log.rows.last().unwrap();
        assert!(!last.valid);
        let f = log
            .layout
            .extra_columns
            .iter()
            .position(|c| c == "fault")
            .unwrap();
        assert_eq!(last.extra[f], "signal");
        // The bridge stopped the program through the dashboard.
        assert!(rig.emu.robot.record().dashboard.iter().any(|c| c == "stop"));
    }
}

#[test]
fn sigkill_leaves_a_parseable_log_and_the_watchdogs_stop_stepper_and_robot() {
    let rig = rig(&config_text("stepper_enable_output = 2", "", ""));
    let mut child = rig.spawn_run(&rig.cfg_path, &["--duration", "30"]);
    rig.wait_rows(20, Duration::from_secs(20));
    assert!(
        rig.emu.robot.digital_out(2),
        "the servo program did not enable the stepper"
    );
    let cue = Instant::now();
    kill(Pid::from_raw(child.id() as i32), Signal::SIGKILL).unwrap();
    let st = child.wait().unwrap();
    assert_eq!(st.code(), None, "killed by a signal");
    // The stepper watchdog saw the bridge's end of its link close and stopped the motor.
    let t0 = Instant::now();
    while rig.first_stop_after(cue).is_none() && t0.elapsed() < Duration::from_secs(2) {
        std::thread::sleep(Duration::from_millis(5));
    }
    assert_stop_within(&rig, cue, Duration::from_millis(150));
    assert_eq!(
        rig.emu.stepper.velocity(),
        (0.0, 0.0),
        "the magnet still turns"
    );
    let log = Log::read(&rig.log_path()).expect("the log parses after SIGKILL");
    assert!(log.rows.len() >= 20, "{} rows", log.rows.len());
    assert!(log.rows.iter().all(|r| r.valid));
    // No heartbeat any more: the program stops within the watchdog period (0.25 s here).
    let t0 = Instant::now();
    while rig.emu.robot.modes().2 != runtime_state::STOPPED && t0.elapsed() < Duration::from_secs(3)
    {
        std::thread::sleep(Duration::from_millis(10));
    }
    assert_eq!(rig.emu.robot.modes().2, runtime_state::STOPPED);
    // The hardware layer: the enable output dropped with the program.
    assert!(
        !rig.emu.robot.digital_out(2),
        "the stepper enable output is still high"
    );
    assert!(rig.emu.robot.record().watchdog_stops >= 1);
    rig.assert_targets_inside();
}

#[test]
fn check_probes_every_device() {
    let rig = rig(&config_text("", "", ""));
    let out = Command::new(BIN)
        .args(["check", "--config"])
        .arg(&rig.cfg_path)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for dev in [
        "robot rtde",
        "robot dashboard",
        "robot secondary",
        "stepper",
        "camera",
    ] {
        let line = stdout
            .lines()
            .find(|l| l.starts_with(dev))
            .unwrap_or_else(|| panic!("no line for {dev}: {stdout}"));
        assert!(line.contains(" ok "), "{line}");
    }
    assert!(stdout.contains("controller 5."), "{stdout}");
    assert!(stdout.contains("firmware"), "{stdout}");
    // check moves nothing.
    assert!(rig.emu.robot.record().targets.is_empty());
    assert!(rig.emu.robot.record().scripts.is_empty());
    // With the robot in protective stop, check fails and says so.
    rig.emu.robot.protective_stop();
    let out = Command::new(BIN)
        .args(["check", "--config"])
        .arg(&rig.cfg_path)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stdout).contains("PROTECTIVE_STOP"));
}

#[test]
fn measure_re_measures_a_frame_folder() {
    use magswarm_vision::synth::{ellipse_frame, EllipseSpec};
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    let truth = [(60.0, 90.0), (70.0, 100.0), (80.0, 85.0)];
    let imgs: Vec<(f64, _)> = truth
        .iter()
        .enumerate()
        .map(|(k, &(r1, r2))| {
            let spec = EllipseSpec {
                cx: 200.0,
                cy: 150.0,
                r1,
                r2,
                angle_deg: 20.0,
                swarm: 40,
                background: 200,
                blur_sigma_px: 1.0,
                noise_sigma: 3.0,
            };
            (k as f64 * 0.05, ellipse_frame(400, 300, &spec, k as u64))
        })
        .collect();
    magswarm_vision::folder::write_frame_folder(&frames, &imgs).unwrap();
    let out = dir.path().join("m.csv");
    let st = Command::new(BIN)
        .args(["measure", "--frames"])
        .arg(&frames)
        .args(["--mm-per-px", "0.1", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t_s,file,r1_mm,r2_mm,angle_deg,cx_px,cy_px,valid"
    );
    for ((r1, r2), line) in truth.iter().zip(lines) {
        let c: Vec<&str> = line.split(',').collect();
        let (m1, m2): (f64, f64) = (c[2].parse().unwrap(), c[3].parse().unwrap());
        assert!(
            (m1 - r1 * 0.1).abs() < 0.05 && (m2 - r2 * 0.1).abs() < 0.05,
            "{line}"
        );
        assert_eq!(c[7], "1");
    }
}

#[test]
fn end_to_end_emulated_closed_loop_tracks_the_targets() {
    // The PID of magswarm-control on setpoints, through RTDE, TMCL and the emulated camera.
    let rig = rig(&config_text("", "", ""));
    let targets = rig.dir.path().join("targets.csv");
    // From the emulated robot's start (z_m 13.5 mm, 4 Hz) to a setpoint the model reaches at
    // about (6.3 mm, 9 Hz).
    std::fs::write(&targets, "t_s,r1_ref_mm,r2_ref_mm\n0,8.05,10.98\n").unwrap();
    let out = Command::new(BIN)
        .args(["run", "--config"])
        .arg(&rig.cfg_path)
        .arg("--targets")
        .arg(&targets)
        .arg("--log")
        .arg(rig.log_path())
        .args(["--duration", "8"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let log = Log::read(&rig.log_path()).unwrap();
    assert!(log.rows.len() >= 100, "{} rows", log.rows.len());
    let err = |r: &magswarm_log::LogRow| {
        let m = r.radii().unwrap();
        (m[0] - 8.05).abs().max((m[1] - 10.98).abs())
    };
    let first = err(&log.rows[0]);
    let tail: Vec<f64> = log.rows[log.rows.len() - 20..].iter().map(err).collect();
    let final_err = tail.iter().sum::<f64>() / tail.len() as f64;
    assert!(
        first > 0.5,
        "the run started at the target already ({first})"
    );
    assert!(
        final_err < 0.15,
        "tracking error {final_err} mm at the end (start {first})"
    );
    // Setpoints are logged, the robot moved toward ~6.3 mm, and never left the limits.
    assert!(log.rows.iter().all(|r| r.r1_ref_mm == Some(8.05)));
    let zlast = log.rows.last().unwrap().z_m_mm;
    assert!((zlast - 6.3).abs() < 2.0, "z_m ended at {zlast}");
    // The robot's reported pose followed the command.
    let zc = log
        .layout
        .extra_columns
        .iter()
        .position(|c| c == "z_meas_mm")
        .unwrap();
    let zmeas: f64 = log.rows.last().unwrap().extra[zc].parse().unwrap();
    assert!(
        (zmeas - zlast).abs() < 0.3,
        "robot at {zmeas} mm, commanded {zlast} mm"
    );
    rig.assert_targets_inside();
}
