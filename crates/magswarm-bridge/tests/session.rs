//! The rig session behind the rig FMU, against the emulated rig: steps paced to the wall
//! clock, late steps reported, a stalled host and a protective stop stop the stepper.

mod support;

use std::time::{Duration, Instant};

use magswarm_bridge::safety::Fault;
use magswarm_bridge::session::{RigSession, SessionOptions};
use support::*;

fn open_with(rig: &Rig, max_late_s: f64, first_step_within_s: f64) -> RigSession {
    RigSession::open(
        &rig.cfg,
        &SessionOptions {
            start: (12.0, 4.0),
            max_late: Duration::from_secs_f64(max_late_s),
            first_step_within: Duration::from_secs_f64(first_step_within_s),
        },
    )
    .unwrap()
}

fn open(rig: &Rig, max_late_s: f64) -> RigSession {
    open_with(rig, max_late_s, 10.0)
}

#[test]
fn steps_follow_the_wall_clock_and_late_ones_are_reported() {
    let rig = rig(&config_text("", "", ""));
    let mut s = open(&rig, 1.0);
    let h = 0.05;
    let t0 = Instant::now();
    let mut late_steps = 0;
    for k in 0..30 {
        let late = s.step(k as f64 * h, h, (12.0, 5.0)).unwrap();
        if !late.is_zero() {
            late_steps += 1;
        }
    }
    let wall = t0.elapsed().as_secs_f64();
    eprintln!("30 steps of {h} s took {wall:.3} s of wall time ({late_steps} late)");
    assert!((1.5 - 1e-3..1.5 + 0.2).contains(&wall), "{wall} s");
    assert!(late_steps <= 3, "{late_steps} late steps");
    let v = s.view();
    let last = v.last_valid.expect("a valid frame");
    assert!(last.radii.is_some() && last.shadow.is_some());
    assert!(v.frames >= 25, "{} frames in 1.5 s at 20 fps", v.frames);
    // The frame behind the outputs is at most a frame period and a step old.
    let age = s.time_of(Instant::now()) - s.time_of(last.at);
    assert!(age < 0.2, "newest valid frame {age} s old");
    // A host that comes 0.12 s late for a 0.05 s step: the step ends ~0.07 s late.
    std::thread::sleep(Duration::from_millis(120));
    let late = s.step(1.5, h, (12.0, 5.0)).unwrap();
    eprintln!(
        "step after a 120 ms pause: {:.1} ms late",
        late.as_secs_f64() * 1e3
    );
    assert!(
        late > Duration::from_millis(40) && late < Duration::from_millis(200),
        "{late:?}"
    );
    // The stepper turns at the requested 5 Hz (rate limited from 4 Hz at 2 Hz/s).
    assert_eq!(rig.emu.stepper.velocity().0, 5.0 * 51200.0);
    s.shutdown();
    let last = rig.emu.stepper.received().last().copied().unwrap();
    assert_eq!(last.instruction, magswarm_bridge::stepper::cmd::MST);
    rig.assert_targets_inside();
}

#[test]
fn a_stalled_host_stops_the_rig() {
    let rig = rig(&config_text("", "", ""));
    let mut s = open(&rig, 0.3);
    for k in 0..5 {
        s.step(k as f64 * 0.05, 0.05, (12.0, 5.0)).unwrap();
    }
    let due = Instant::now();
    std::thread::sleep(Duration::from_millis(600));
    let f = s.step(0.25, 0.05, (12.0, 5.0)).unwrap_err();
    assert!(matches!(f, Fault::HostStalled(_)), "{f:?}");
    assert_eq!(f.name(), "host_stalled");
    let stop = rig.first_stop_after(due).expect("an MST after the stall");
    let d = stop.duration_since(due);
    eprintln!(
        "host due, stalled: MST {:.1} ms later (max_late 300 ms)",
        d.as_secs_f64() * 1e3
    );
    assert!(
        d >= Duration::from_millis(300) && d <= Duration::from_millis(450),
        "{d:?}"
    );
}

#[test]
fn the_first_step_may_come_late_but_not_never() {
    let rig = rig(&config_text("", "", ""));
    let mut s = open_with(&rig, 0.2, 0.8);
    // 0.5 s of set-up by the host before its first step: more than max_late, allowed.
    std::thread::sleep(Duration::from_millis(500));
    assert_eq!(s.step(0.0, 0.05, (12.0, 4.0)), Ok(Duration::ZERO));
    drop(s);
    let mut s = open_with(&rig, 0.2, 0.4);
    std::thread::sleep(Duration::from_millis(700));
    let f = s.step(0.0, 0.05, (12.0, 4.0)).unwrap_err();
    assert_eq!(f.name(), "host_stalled");
}

#[test]
fn a_protective_stop_ends_the_session_with_its_fault() {
    let rig = rig(&config_text("", "", ""));
    let mut s = open(&rig, 1.0);
    for k in 0..5 {
        s.step(k as f64 * 0.05, 0.05, (12.0, 5.0)).unwrap();
    }
    let cue = Instant::now();
    rig.emu.robot.protective_stop();
    let mut fault = None;
    for k in 5..40 {
        if let Err(f) = s.step(k as f64 * 0.05, 0.05, (12.0, 5.0)) {
            fault = Some(f);
            break;
        }
    }
    assert_eq!(fault, Some(Fault::SafetyMode(3)), "{fault:?}");
    assert_stop_within(&rig, cue, Duration::from_millis(100));
    // Latched.
    assert!(s.step(2.0, 0.05, (12.0, 5.0)).is_err());
}
