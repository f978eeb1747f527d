//! Fault injection, one test per fault: the bridge against the emulated rig.
//!
//! Each test checks that the fault is named, that the stepper saw a stop (MST) within
//! 100 ms of the fault, that the robot never received a tool z outside the limits, and that
//! the log is parseable up to the fault with `valid=0` last row naming it.

mod support;

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use magswarm_bridge::run::{self, Mode, RunOptions, RunReport, Signals};
use magswarm_bridge::safety::{Fault, FaultLatch};
use magswarm_bridge::schedule::Schedule;
use magswarm_log::Log;
use support::*;

const STOP_LIMIT: Duration = Duration::from_millis(100);

fn plan(text: &str) -> Mode {
    Mode::Plan(Schedule::parse(text, ["z_m_mm", "f_hz"], "PLAN").unwrap())
}

fn opts(rig: &Rig, mode: Mode, duration: f64) -> RunOptions {
    RunOptions {
        mode,
        log: rig.log_path(),
        duration: Some(duration),
        dry_run: false,
    }
}

/// Run in a thread; `cue` runs on this thread after `after` and returns the fault instant.
fn run_with_cue(
    rig: &Rig,
    mode: Mode,
    duration: f64,
    signals: Signals,
    after: Duration,
    cue: impl FnOnce(&Rig),
) -> (RunReport, Instant) {
    let cfg = rig.cfg.clone();
    let o = opts(rig, mode, duration);
    let h = std::thread::spawn(move || {
        let latch = FaultLatch::new();
        run::run(&cfg, &o, &signals, &latch).unwrap()
    });
    std::thread::sleep(after);
    let at = Instant::now();
    cue(rig);
    (h.join().unwrap(), at)
}

/// The log is parseable and its last row is `valid=0` naming `fault`.
fn assert_log_ends_with_fault(rig: &Rig, fault: &str) -> Log {
    let log = Log::read(&rig.log_path()).expect("the log parses up to the fault");
    assert!(
        log.rows.len() >= 5,
        "only {} rows before the fault",
        log.rows.len()
    );
    let last = log.rows.last().unwrap();
    assert!(!last.valid, "the last row is not valid=0");
    let fcol = log
        .layout
        .extra_columns
        .iter()
        .position(|c| c == "fault")
        .expect("a fault column");
    assert_eq!(last.extra[fcol], fault);
    // Every earlier row is a measurement with inputs inside the envelope.
    for r in &log.rows {
        assert!(
            (3.5..=23.5).contains(&r.z_m_mm),
            "z_m_mm {} in the log",
            r.z_m_mm
        );
        assert!((1.0..=10.0).contains(&r.f_hz), "f_hz {} in the log", r.f_hz);
    }
    log
}

const STEADY: &str = "t_s,z_m_mm,f_hz\n0,10,4\n1,12,5\n";

#[test]
fn plan_completes_and_every_target_is_clamped() {
    // The plan asks for z_m far outside the envelope in both directions and for 30 Hz.
    let rig = rig(&config_text("", "", ""));
    let latch = FaultLatch::new();
    let r = run::run(
        &rig.cfg,
        &opts(
            &rig,
            plan("t_s,z_m_mm,f_hz\n0,60,30\n1.0,-20,-3\n2.0,1e6,4\n"),
            2.5,
        ),
        &Signals::default(),
        &latch,
    )
    .unwrap();
    assert!(r.fault.is_none(), "{:?}", r.fault);
    assert!(!latch.is_set());
    rig.assert_targets_inside();
    let log = Log::read(&rig.log_path()).unwrap();
    assert!(log.rows.len() >= 40, "{} rows", log.rows.len());
    assert!(log.rows.iter().all(|r| r.valid));
    // It went to the upper limit at the rate limit, then down.
    let zmax = log.rows.iter().map(|r| r.z_m_mm).fold(f64::MIN, f64::max);
    assert!(zmax <= 23.5 && zmax > 13.0, "z_m reached {zmax}");
    // The rate limit: 10 mm/s. The shaper limits per command on the wall clock, the rows carry
    // camera times: a frame handled late (a loaded machine) puts a command that covered more
    // wall time between two rows 0.05 s apart. Over half a second, a 1 mm allowance covers a
    // 0.1 s hiccup; without the limit the plan's jump (10 -> 23.5 mm) would be one step.
    for w in log.rows.windows(11) {
        let dz = (w[10].z_m_mm - w[0].z_m_mm).abs();
        let dt = w[10].t_s - w[0].t_s;
        assert!(dz <= 10.0 * dt + 1.0, "z_m moved {dz} mm in {dt} s");
    }
    // The stepper ran at the clamped rate: never above 10 Hz (512000 units).
    let max_v = rig
        .emu
        .stepper
        .received()
        .iter()
        .filter(|r| r.instruction == magswarm_bridge::stepper::cmd::ROR)
        .map(|r| r.value)
        .max()
        .unwrap();
    assert!(max_v <= 512_000 && max_v > 51_200 * 4, "ROR {max_v}");
    // After the run the stepper was stopped.
    let last = rig.emu.stepper.received().last().copied().unwrap();
    assert_eq!(last.instruction, magswarm_bridge::stepper::cmd::MST);
}

#[test]
fn controller_asking_outside_the_envelope_is_clamped() {
    let rig = rig(&config_text("", "", ""));
    let law: run::Law = Arc::new(Mutex::new(
        |t: f64, _m: Option<[f64; 2]>| {
            if t < 1.0 {
                (-1e9, 100.0)
            } else {
                (1e9, 0.0)
            }
        },
    ));
    let r = run::run(
        &rig.cfg,
        &opts(&rig, Mode::Law(law), 2.0),
        &Signals::default(),
        &FaultLatch::new(),
    )
    .unwrap();
    assert!(r.fault.is_none(), "{:?}", r.fault);
    rig.assert_targets_inside();
}

#[test]
fn protective_stop_is_a_fault_and_never_unlocked() {
    let rig = rig(&config_text("", "", ""));
    let (r, cue) = run_with_cue(
        &rig,
        plan(STEADY),
        10.0,
        Signals::default(),
        Duration::from_millis(1500),
        |rig| rig.emu.robot.protective_stop(),
    );
    assert_eq!(r.fault, Some(Fault::SafetyMode(3)));
    assert_stop_within(&rig, cue, STOP_LIMIT);
    rig.assert_targets_inside();
    assert_log_ends_with_fault(&rig, "safety_mode");
    // Still in protective stop: the bridge did not clear it.
    assert_eq!(rig.emu.robot.modes().1, 3);
}

#[test]
fn rtde_loss_is_a_fault() {
    let rig = rig(&config_text("", "", ""));
    let (r, cue) = run_with_cue(
        &rig,
        plan(STEADY),
        10.0,
        Signals::default(),
        Duration::from_millis(1500),
        |rig| rig.emu.robot.drop_link(),
    );
    assert!(matches!(r.fault, Some(Fault::RtdeLost(_))), "{:?}", r.fault);
    assert_stop_within(&rig, cue, STOP_LIMIT);
    rig.assert_targets_inside();
    assert_log_ends_with_fault(&rig, "rtde_lost");
}

#[test]
fn camera_timeout_is_a_fault() {
    // The emulated camera stops after 1 s; the timeout is 0.3 s.
    let rig = rig(&config_text(
        "",
        "",
        "[emulator]\ncamera_stops_after_s = 1.0\n",
    ));
    let latch = FaultLatch::new();
    let r = run::run(
        &rig.cfg,
        &opts(&rig, plan(STEADY), 10.0),
        &Signals::default(),
        &latch,
    )
    .unwrap();
    let done = Instant::now();
    assert!(
        matches!(r.fault, Some(Fault::CameraTimeout(s)) if s >= 0.3),
        "{:?}",
        r.fault
    );
    assert!(latch.is_set());
    // The stop went out before run returned, within 100 ms of the timeout being declared:
    // the last frame came at ~0.95 s, the timeout at ~1.25 s.
    let stop = rig
        .emu
        .stepper
        .received()
        .iter()
        .rev()
        .find(|x| x.instruction == magswarm_bridge::stepper::cmd::MST)
        .map(|x| x.at)
        .expect("an MST");
    assert!(stop <= done);
    rig.assert_targets_inside();
    assert_log_ends_with_fault(&rig, "camera_timeout");
}

#[test]
fn nan_command_is_a_fault() {
    let rig = rig(&config_text("", "", ""));
    let first_nan: Arc<Mutex<Option<Instant>>> = Arc::new(Mutex::new(None));
    let fnan = first_nan.clone();
    let law: run::Law = Arc::new(Mutex::new(move |t: f64, _m: Option<[f64; 2]>| {
        if t < 1.0 {
            (10.0, 4.0)
        } else {
            fnan.lock().unwrap().get_or_insert(Instant::now());
            (f64::NAN, 4.0)
        }
    }));
    let r = run::run(
        &rig.cfg,
        &opts(&rig, Mode::Law(law), 5.0),
        &Signals::default(),
        &FaultLatch::new(),
    )
    .unwrap();
    assert!(
        matches!(r.fault, Some(Fault::NanCommand(_))),
        "{:?}",
        r.fault
    );
    let cue = first_nan
        .lock()
        .unwrap()
        .expect("the law was asked after 1 s");
    assert_stop_within(&rig, cue, STOP_LIMIT);
    rig.assert_targets_inside();
    assert!(rig.emu.robot.record().targets.iter().all(|z| z.is_finite()));
    assert_log_ends_with_fault(&rig, "nan_command");
}

fn stepper_fault(kind: &str) -> RunReport {
    let rig = rig(&config_text(
        "",
        "",
        &format!("[emulator]\nstepper_fault_after_s = 1.0\nstepper_fault = \"{kind}\"\n"),
    ));
    let r = run::run(
        &rig.cfg,
        &opts(&rig, plan(STEADY), 10.0),
        &Signals::default(),
        &FaultLatch::new(),
    )
    .unwrap();
    rig.assert_targets_inside();
    let name = match &r.fault {
        Some(Fault::BadReply(_)) => "stepper_bad_reply",
        Some(Fault::Serial(_)) => "serial_error",
        other => panic!("{kind}: unexpected {other:?}"),
    };
    assert_log_ends_with_fault(&rig, name);
    // The module saw an MST after its fault began (it may answer it badly).
    let rec = rig.emu.stepper.received();
    let first_rot = rec
        .iter()
        .find(|x| x.instruction == magswarm_bridge::stepper::cmd::ROR)
        .unwrap()
        .at;
    assert!(rig
        .first_stop_after(first_rot + Duration::from_millis(1000))
        .is_some());
    r
}

#[test]
fn stepper_bad_status_is_a_fault() {
    let r = stepper_fault("status");
    assert!(
        matches!(&r.fault, Some(Fault::BadReply(w)) if w.contains("status 2")),
        "{:?}",
        r.fault
    );
}

#[test]
fn stepper_bad_checksum_is_a_fault() {
    let r = stepper_fault("checksum");
    assert!(
        matches!(&r.fault, Some(Fault::BadReply(w)) if w.contains("checksum")),
        "{:?}",
        r.fault
    );
}

#[test]
fn stepper_silent_is_a_serial_fault() {
    let r = stepper_fault("silent");
    assert!(matches!(&r.fault, Some(Fault::Serial(_))), "{:?}", r.fault);
}

#[test]
fn signals_are_faults() {
    for (name, pick) in [("SIGINT", 0), ("SIGTERM", 1)] {
        let rig = rig(&config_text("", "", ""));
        let s = Signals::default();
        let flag = if pick == 0 {
            s.int.clone()
        } else {
            s.term.clone()
        };
        let (r, cue) = run_with_cue(
            &rig,
            plan(STEADY),
            10.0,
            s,
            Duration::from_millis(1200),
            move |_| flag.store(true, std::sync::atomic::Ordering::SeqCst),
        );
        assert_eq!(r.fault, Some(Fault::Signal(name.into())));
        assert_stop_within(&rig, cue, STOP_LIMIT);
        assert_log_ends_with_fault(&rig, "signal");
    }
}

#[test]
fn a_protective_stop_before_the_start_refuses_to_run() {
    let rig = rig(&config_text("", "", ""));
    rig.emu.robot.protective_stop();
    let e = run::run(
        &rig.cfg,
        &opts(&rig, plan(STEADY), 2.0),
        &Signals::default(),
        &FaultLatch::new(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("PROTECTIVE_STOP") && e.contains("operator"),
        "{e}"
    );
    assert!(rig.emu.robot.record().targets.is_empty());
    assert!(rig
        .emu
        .stepper
        .received()
        .iter()
        .all(|r| r.instruction != magswarm_bridge::stepper::cmd::ROR));
}
