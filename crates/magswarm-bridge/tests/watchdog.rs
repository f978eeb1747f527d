//! The stepper watchdog: `magswarm-bridge run` killed (SIGKILL), hung (SIGSTOP), or its
//! watchdog killed, against the emulated robot and an independent TMCL module on a pty
//! (`support::tmcl_peer`, which shares no code with the bridge's TMCL).
//!
//! The bound asserted is the 150 ms the rig needs; the delays measured here on a pty are a
//! few milliseconds (the watchdog wakes on the end of file and sends MST at once). The
//! margin covers a loaded machine (the watchdog process has to be scheduled) but not a
//! real module's serial line: at 9600 baud one TMCL transaction takes about 20 ms, so the
//! stop may wait for one transaction in flight and then needs its own (about 40 ms worst).

mod support;

use std::time::{Duration, Instant};

use magswarm_bridge::rig::{Poll, Rig as BridgeRig};
use magswarm_bridge::run::Signals;
use magswarm_bridge::safety::Fault;
use nix::sys::signal::{kill, Signal};
use nix::unistd::Pid;
use support::tmcl_peer::{TmclPeer, MST, ROR};
use support::*;

const LIMIT: Duration = Duration::from_millis(150);

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

#[test]
fn sigkill_of_run_stops_an_independent_module_within_150_ms() {
    let mut delays = Vec::new();
    for round in 0..3 {
        let rig = rig(&config_text("", "", ""));
        let peer = TmclPeer::start(1);
        let cfg = rig.config_with_stepper(&peer.path);
        let mut child = rig.spawn_run(&cfg, &["--duration", "30"]);
        rig.wait_rows(15, Duration::from_secs(20));
        assert!(
            peer.seen()
                .iter()
                .any(|s| s.instruction == ROR && s.value > 0),
            "the magnet was not turning before the kill: {:?}",
            peer.seen()
        );
        let cue = Instant::now();
        kill(Pid::from_raw(child.id() as i32), Signal::SIGKILL).unwrap();
        let stop = peer.wait_for(MST, cue, Duration::from_secs(2));
        let _ = child.wait();
        let stop = stop.expect("no MST reached the module after SIGKILL of the bridge");
        let d = stop.at.duration_since(cue);
        eprintln!(
            "round {round}: SIGKILL -> MST at the module {:.2} ms",
            ms(d)
        );
        delays.push(d);
        // Nothing after the stop turns the magnet again.
        assert!(
            peer.seen()
                .iter()
                .filter(|s| s.at > stop.at)
                .all(|s| s.instruction != ROR),
            "{:?}",
            peer.seen()
        );
    }
    let worst = delays.iter().max().unwrap();
    eprintln!(
        "SIGKILL -> MST over {} kills: {:?} ms (limit {} ms)",
        delays.len(),
        delays
            .iter()
            .map(|d| (ms(*d) * 100.0).round() / 100.0)
            .collect::<Vec<_>>(),
        ms(LIMIT)
    );
    assert!(*worst <= LIMIT, "a stop took {:.1} ms", ms(*worst));
}

#[test]
fn a_hung_bridge_is_stopped_by_the_heartbeat_timeout() {
    // SIGSTOP: the bridge is alive (its end of the link stays open) but silent.
    let rig = rig(&config_text("", "", ""));
    let peer = TmclPeer::start(1);
    let cfg = rig.config_with_stepper(&peer.path);
    let mut child = rig.spawn_run(&cfg, &["--duration", "30"]);
    rig.wait_rows(15, Duration::from_secs(20));
    let pid = Pid::from_raw(child.id() as i32);
    let cue = Instant::now();
    kill(pid, Signal::SIGSTOP).unwrap();
    let stop = peer.wait_for(MST, cue, Duration::from_secs(2));
    kill(pid, Signal::SIGKILL).unwrap();
    let _ = child.wait();
    let d = stop
        .expect("no MST after the bridge went silent")
        .at
        .duration_since(cue);
    // watchdog_timeout_s = 0.5 s in the tests' config; the last heartbeat was at most ~20 ms
    // before the SIGSTOP.
    eprintln!("SIGSTOP -> MST {:.1} ms (heartbeat timeout 500 ms)", ms(d));
    assert!(
        d >= Duration::from_millis(450) && d <= Duration::from_millis(500) + LIMIT,
        "MST {:.1} ms after the bridge went silent",
        ms(d)
    );
}

#[test]
fn a_dead_watchdog_is_a_fault_and_the_bridge_stops_the_motor_itself() {
    let rig = rig(&config_text("", "", ""));
    let peer = TmclPeer::start(1);
    let mut cfg = rig.cfg.clone();
    cfg.stepper.device = peer.path.clone();
    let mut r = BridgeRig::open(&cfg, false, (10.0, 4.0), Signals::default(), None).unwrap();
    r.command((10.0, 5.0)).unwrap();
    let pid = r.stepper_watchdog_pid().expect("a watchdog process");
    kill(Pid::from_raw(pid as i32), Signal::SIGKILL).unwrap();
    let t0 = Instant::now();
    let fault = loop {
        match r.poll() {
            Ok(Poll::Nothing) | Ok(Poll::Frame(_)) => {}
            Ok(Poll::Ended) => panic!("the camera ended"),
            Err(f) => break f,
        }
        assert!(t0.elapsed() < Duration::from_secs(2), "no fault");
    };
    assert!(matches!(fault, Fault::Watchdog(_)), "{fault:?}");
    assert_eq!(fault.name(), "stepper_watchdog");
    let cue = Instant::now();
    r.shutdown(true);
    assert!(
        peer.first_after(MST, cue).is_some(),
        "the bridge did not send MST itself: {:?}",
        peer.seen()
    );
}
