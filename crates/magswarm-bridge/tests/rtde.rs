//! The RTDE client against the emulated controller (and the emulator's protocol rules).

use std::time::{Duration, Instant};

use magswarm_bridge::rtde::proto::{runtime_state, Value, VarType};
use magswarm_bridge::rtde::server::{RobotSimConfig, UrEmulator};
use magswarm_bridge::rtde::{RtdeClient, UrLink};
use magswarm_bridge::ur::{self, Dashboard, ServoScript};

fn sim(program_running: bool) -> RobotSimConfig {
    RobotSimConfig {
        start_pose: [0.3, -0.2, 0.41, 0.0, 2.0, 0.0],
        lag_s: 0.02,
        z_limits_m: [0.4035, 0.4235],
        z_rate_m_s: 0.01,
        watchdog_hz: 10.0,
        program_running,
        start_powered_off: false,
        protective_stop_after_s: None,
        drop_link_after_s: None,
    }
}

#[test]
fn handshake_recipes_and_data() {
    let emu = UrEmulator::start("127.0.0.1", 0, None, None, sim(true)).unwrap();
    let to = Duration::from_secs(2);
    let mut c = RtdeClient::connect("127.0.0.1", emu.rtde.port(), to).unwrap();
    c.negotiate_protocol_version().unwrap();
    let v = c.controller_version().unwrap();
    assert_eq!(v.major, 5, "an e-Series controller");
    // An unknown name is refused with NOT_FOUND, named in the error.
    let e = c
        .setup_outputs(125.0, &["actual_TCP_pose", "no_such_variable"])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no_such_variable") && e.contains("NOT_FOUND"),
        "{e}"
    );
    let out = c
        .setup_outputs(
            125.0,
            &[
                "timestamp",
                "actual_TCP_pose",
                "robot_mode",
                "safety_mode",
                "runtime_state",
            ],
        )
        .unwrap();
    assert_eq!(
        out.types,
        [
            VarType::Double,
            VarType::Vector6d,
            VarType::Int32,
            VarType::Int32,
            VarType::Uint32
        ]
    );
    let inp = c
        .setup_inputs(&["input_double_register_24", "input_int_register_24"])
        .unwrap();
    assert_eq!(inp.types, [VarType::Double, VarType::Int32]);
    // A second client may not write the same registers (IN_USE).
    let mut c2 = RtdeClient::connect("127.0.0.1", emu.rtde.port(), to).unwrap();
    c2.negotiate_protocol_version().unwrap();
    let e = c2
        .setup_inputs(&["input_double_register_24"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("IN_USE"), "{e}");
    c.start().unwrap();
    // The rate is read from the controller's own timestamps, not from when this thread got
    // to read the packages (a loaded machine delays the reader, and TCP delivers the
    // backlog at once): the median spacing of 40 packages is the 8 ms of 125 Hz.
    let mut stamps: Vec<f64> = Vec::new();
    while stamps.len() < 40 {
        let v = c.receive(&out).unwrap();
        let ts = v[0].as_f64().unwrap();
        if let Some(&last) = stamps.last() {
            assert!(ts > last, "timestamps must increase ({last} then {ts})");
        }
        stamps.push(ts);
        match v[1] {
            Value::V6(p) => assert!((p[2] - 0.41).abs() < 1e-12),
            ref other => panic!("pose {other:?}"),
        }
    }
    let mut gaps: Vec<f64> = stamps.windows(2).map(|w| w[1] - w[0]).collect();
    gaps.sort_by(f64::total_cmp);
    let median = gaps[gaps.len() / 2];
    assert!(
        (0.006..=0.010).contains(&median),
        "median package spacing {median} s at 125 Hz (8 ms)"
    );
    c.pause().unwrap();
}

#[test]
fn pose_follows_the_register_clamped_and_rate_limited_and_the_watchdog_stops_it() {
    let emu = UrEmulator::start("127.0.0.1", 0, None, None, sim(true)).unwrap();
    let mut link =
        UrLink::connect("127.0.0.1", emu.rtde.port(), 500.0, Duration::from_secs(2)).unwrap();
    let s0 = link.wait_state(Duration::from_secs(1)).unwrap();
    assert_eq!(s0.runtime_state, runtime_state::PLAYING);
    // Ask for far above the upper limit: the program clamps to 0.4235 at 10 mm/s.
    let t0 = Instant::now();
    let mut seen = Vec::new();
    while t0.elapsed() < Duration::from_millis(1800) {
        link.command(0.9).unwrap();
        if let Some(s) = link.state() {
            seen.push((t0.elapsed().as_secs_f64(), s.tcp_pose[2]));
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let zmax = seen.iter().map(|x| x.1).fold(f64::MIN, f64::max);
    assert!(zmax <= 0.4235 + 1e-9, "tool z reached {zmax}");
    assert!(zmax > 0.4235 - 1e-3, "tool z only reached {zmax}");
    // Rate: 10 mm/s, so at 0.5 s no more than 5 mm (+ lag) above the start.
    let at_half = seen.iter().find(|x| x.0 >= 0.5).unwrap().1;
    assert!(
        at_half - 0.41 <= 0.0055,
        "moved {} mm in 0.5 s",
        (at_half - 0.41) * 1e3
    );
    // Stop the heartbeat: the watchdog stops the program at its first check past its
    // period (100 ms at 10 Hz), never before; the emulator records the heartbeat gaps it saw,
    // so this holds however late a loaded machine runs its checks. The client then sees the
    // program stopped (waiting for the state as long as the machine needs).
    let t_stop = Instant::now();
    let stopped = loop {
        let s = link.state().unwrap();
        if s.runtime_state == runtime_state::STOPPED {
            break true;
        }
        if t_stop.elapsed() > Duration::from_secs(5) {
            break false;
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    assert!(
        stopped,
        "the program was not stopped 5 s after the last heartbeat"
    );
    let rec = emu.record();
    assert_eq!(rec.watchdog_stops, 1);
    let fired = rec.watchdog_fired.expect("the watchdog fired");
    assert!(
        fired.previous_gap_s <= 0.1 && fired.gap_s > 0.1,
        "the watchdog fired at a heartbeat gap of {} s after a check at {} s (period 0.1 s)",
        fired.gap_s,
        fired.previous_gap_s
    );
}

#[test]
fn dashboard_and_script_upload() {
    let emu = UrEmulator::start(
        "127.0.0.1",
        0,
        Some(0),
        Some(0),
        RobotSimConfig {
            start_powered_off: true,
            ..sim(false)
        },
    )
    .unwrap();
    let mut d = Dashboard::connect(
        "127.0.0.1",
        emu.dashboard.unwrap().port(),
        Duration::from_secs(1),
    )
    .unwrap();
    assert!(d.greeting.contains("Dashboard"));
    assert_eq!(d.robot_mode().unwrap(), "POWER_OFF");
    d.bring_up(Duration::from_secs(2)).unwrap();
    assert_eq!(d.robot_mode().unwrap(), "RUNNING");
    assert_eq!(d.safety_status().unwrap(), "NORMAL");
    // The client refuses to unlock a protective stop.
    assert!(d.command("unlock protective stop").is_err());
    let prog = ServoScript {
        z_min_m: 0.405,
        z_max_m: 0.42,
        z_rate_m_s: 0.02,
        watchdog_hz: 5.0,
        enable_output: None,
    }
    .program();
    ur::upload_script(
        "127.0.0.1",
        emu.secondary.unwrap().port(),
        &prog,
        Duration::from_secs(1),
    )
    .unwrap();
    let t0 = Instant::now();
    while emu.modes().2 != runtime_state::PLAYING {
        assert!(
            t0.elapsed() < Duration::from_secs(2),
            "the program did not start"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    let rec = emu.record();
    assert_eq!(rec.scripts.len(), 1);
    assert_eq!(
        rec.dashboard
            .iter()
            .filter(|c| c.contains("unlock"))
            .count(),
        0
    );
    // The emulated program uses the script's limits: ask for 0.9 m, get 0.42 m at most.
    let mut link =
        UrLink::connect("127.0.0.1", emu.rtde.port(), 500.0, Duration::from_secs(2)).unwrap();
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_millis(1000) {
        link.command(0.9).unwrap();
        std::thread::sleep(Duration::from_millis(5));
    }
    let z = emu.tool_z();
    assert!(z <= 0.42 + 1e-9 && z > 0.419, "tool z {z}");
}

#[test]
fn recipe_ids_run_out_with_a_refusal_and_the_connection_keeps_working() {
    let emu = UrEmulator::start("127.0.0.1", 0, None, None, sim(true)).unwrap();
    let mut c = RtdeClient::connect("127.0.0.1", emu.rtde.port(), Duration::from_secs(2)).unwrap();
    c.negotiate_protocol_version().unwrap();
    // Output ids 1..=255, input ids 100..=255 (the emulator's numbering): one more of each
    // is refused with id 0, and so is every later one (never wrapped to an id in use).
    for k in 1..=255u8 {
        let r = c.setup_outputs(125.0, &["timestamp"]).unwrap();
        assert_eq!(r.id, k);
    }
    for _ in 0..2 {
        let e = c.setup_outputs(125.0, &["timestamp"]).unwrap_err();
        assert!(e.to_string().contains("refused (id 0)"), "{e}");
    }
    for k in 100..=255u8 {
        let r = c.setup_inputs(&["input_int_register_24"]).unwrap();
        assert_eq!(r.id, k);
    }
    for _ in 0..2 {
        let e = c.setup_inputs(&["input_int_register_24"]).unwrap_err();
        assert!(e.to_string().contains("refused (id 0)"), "{e}");
    }
    assert_eq!(c.controller_version().unwrap().major, 5, "still answering");
}
