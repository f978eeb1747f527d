//! The rig FMU through the FMI shell's entry points (in process, `magswarm_fmi2::host`),
//! against the emulated rig: a resources folder with a rig config, as the packaged FMU has.

use std::path::Path;
use std::time::{Duration, Instant};

use magswarm_bridge::config::RigConfig;
use magswarm_bridge::emulate::{self, Emulators};
use magswarm_bridge::stepper::cmd;
use magswarm_fmi2::host::Host;
use magswarm_fmi2::Fmi2Status;
use magswarm_rig_fmu::table::{self, vr};
use magswarm_rig_fmu::RigFmu;

const CONFIG: &str = r#"
[robot]
host = "127.0.0.1"
rtde_port = RTDE
script_port = SCRIPT
dashboard_port = DASH
z_tcp_at_zero_m = 0.400
# Longer than the defaults: a loaded test machine can stall the emulator's stream 100 ms.
timeout_s = 0.5
watchdog_hz = 4.0

[stepper]
device = "TTY"
velocity_per_hz = 51200.0
watchdog_timeout_s = 0.5
reply_timeout_s = 0.5
WATCHDOG

[camera]
kind = "emulated"
mm_per_px = 0.15
fps = 20.0
width = 480
height = 360

[limits]
z_m_mm = [3.5, 23.5]
f_hz = [1.0, 10.0]
z_rate_mm_s = 10.0
f_rate_hz_s = 2.0
"#;

struct Rig {
    emu: Emulators,
    res: tempfile::TempDir,
}

fn rig() -> Rig {
    let text = CONFIG
        .replace("RTDE", "30004")
        .replace("SCRIPT", "30002")
        .replace("DASH", "29999")
        .replace("TTY", "/dev/null")
        .replace("WATCHDOG", "");
    let cfg0 = RigConfig::parse(&text, Path::new("t.toml")).unwrap();
    let emu = emulate::start(&cfg0, false).unwrap();
    let wd = magswarm_bridge::watchdog::locate(None).unwrap_or_else(|e| {
        panic!("{e} (the rig FMU's tests need `cargo build --release -p magswarm-bridge` first)")
    });
    let port = |a: Option<std::net::SocketAddr>| a.map_or(0, |a| a.port()).to_string();
    let text = CONFIG
        .replace("RTDE", &emu.robot.rtde.port().to_string())
        .replace("SCRIPT", &port(emu.robot.secondary))
        .replace("DASH", &port(emu.robot.dashboard))
        .replace("TTY", &emu.stepper.path)
        .replace(
            "WATCHDOG",
            &format!("watchdog_exe = {:?}", wd.display().to_string()),
        );
    let res = tempfile::tempdir().unwrap();
    std::fs::write(res.path().join(table::RESOURCE_CONFIG), text).unwrap();
    Rig { emu, res }
}

fn uri(dir: &Path) -> Vec<u8> {
    format!("file://{}", dir.display()).into_bytes()
}

fn host(rig: &Rig) -> Host<RigFmu> {
    Host::<RigFmu>::instantiate("rig", Some(&uri(rig.res.path())))
        .unwrap_or_else(|log| panic!("{log:?}"))
}

#[test]
fn steps_drive_the_rig_and_terminate_stops_it() {
    let rig = rig();
    let h = host(&rig);
    assert_eq!(h.set_real(vr::Z_M, 0.012), Fmi2Status::Ok);
    assert_eq!(
        h.set_real(vr::OMEGA_M, std::f64::consts::TAU * 5.0),
        Fmi2Status::Ok
    );
    assert_eq!(h.init(0.0), Fmi2Status::Ok, "{:?}", h.log().entries());
    let t0 = Instant::now();
    for k in 0..10 {
        assert_eq!(
            h.step(k as f64 * 0.05, 0.05),
            Fmi2Status::Ok,
            "{:?}",
            h.log().entries()
        );
    }
    let wall = t0.elapsed();
    assert!(
        wall >= Duration::from_millis(499),
        "10 steps of 50 ms took {wall:?}"
    );
    for (name, st, x) in h.outputs() {
        assert_eq!(st, Fmi2Status::Ok, "{name}");
        assert!(x.is_finite(), "{name} = {x}");
    }
    let (_, r1) = h.get_real(vr::R1);
    let (_, sh) = h.get_real(vr::R1_SHADOW);
    assert!(
        r1 > 1e-3 && (r1 - sh).abs() < 0.5e-3,
        "r1 {r1} m, shadow {sh} m"
    );
    let (_, f) = h.get_real(vr::OMEGA_M_APPLIED);
    assert!(f > std::f64::consts::TAU * 4.0, "omega applied {f}");
    // No FMU state and no Jacobian: refused, saying why.
    let (st, _) = h.get_state();
    assert_eq!(st, Fmi2Status::Error);
    assert!(h.log().has(Fmi2Status::Error, "canGetAndSetFMUstate"));
    // The refusal put the instance in the error state; freeing it stops the rig.
    let cue = Instant::now();
    drop(h);
    let rec = rig.emu.stepper.received();
    let last = rec.last().unwrap();
    assert_eq!(last.instruction, cmd::MST);
    assert!(last.at >= cue);
    assert!(rec.iter().any(|r| r.instruction == cmd::ROR));
}

#[test]
fn terminate_stops_the_stepper_and_holds_the_robot() {
    let rig = rig();
    let h = host(&rig);
    assert_eq!(h.init(0.0), Fmi2Status::Ok, "{:?}", h.log().entries());
    for k in 0..4 {
        assert_eq!(h.step(k as f64 * 0.05, 0.05), Fmi2Status::Ok);
    }
    let cue = Instant::now();
    assert_eq!(h.terminate(), Fmi2Status::Ok);
    let rec = rig.emu.stepper.received();
    assert!(rec.iter().any(|r| r.at >= cue && r.instruction == cmd::MST));
    assert!(rig.emu.robot.record().dashboard.iter().any(|c| c == "stop"));
}

#[test]
fn limits_narrow_calibration_is_read_only_and_config_errors_are_named() {
    let rig = rig();
    let h = host(&rig);
    assert_eq!(h.set_real(vr::Z_M_MAX, 0.030), Fmi2Status::Error);
    assert!(h.log().has(Fmi2Status::Error, "z_m_max"));
    let h = host(&rig);
    assert_eq!(h.set_real(vr::Z_TCP_AT_ZERO, 0.35), Fmi2Status::Error);
    assert!(h.log().has(Fmi2Status::Error, "read-only"));
    let h = host(&rig);
    assert_eq!(
        h.set_string(vr::CONFIG_FILE, "/no/such/rig.toml"),
        Fmi2Status::Error
    );
    assert!(h.log().has(Fmi2Status::Error, "/no/such/rig.toml"));
    // Narrowing is applied: the robot never gets a target above the narrowed 15 mm.
    let h = host(&rig);
    assert_eq!(h.set_real(vr::Z_M_MAX, 0.015), Fmi2Status::Ok);
    assert_eq!(h.set_real(vr::Z_M, 0.020), Fmi2Status::Ok);
    assert_eq!(h.init(0.0), Fmi2Status::Ok, "{:?}", h.log().entries());
    for k in 0..10 {
        assert_eq!(h.step(k as f64 * 0.05, 0.05), Fmi2Status::Ok);
    }
    assert_eq!(h.get_real(vr::Z_M_MAX).1, 0.015);
    let zmax = rig
        .emu
        .robot
        .record()
        .targets
        .iter()
        .cloned()
        .fold(f64::MIN, f64::max);
    assert!(zmax <= 0.400 + 0.015 + 1e-12, "tool z target {zmax}");
}

#[test]
fn an_fmu_without_a_rig_config_is_refused_at_instantiation() {
    let empty = tempfile::tempdir().unwrap();
    let log = Host::<RigFmu>::instantiate("rig", Some(&uri(empty.path())))
        .err()
        .expect("instantiated without a config");
    assert!(
        log.iter()
            .any(|e| e.message.contains("magswarm-bridge fmu")),
        "{log:?}"
    );
}

#[test]
fn the_xml_says_what_a_rig_cannot_do_and_carries_the_config() {
    let rig = rig();
    let cfg = RigConfig::load(&rig.res.path().join(table::RESOURCE_CONFIG)).unwrap();
    let xml = table::model_description(&cfg, None);
    assert!(xml.contains(r#"canGetAndSetFMUstate="false""#));
    assert!(xml.contains(r#"canSerializeFMUstate="false""#));
    assert!(xml.contains(r#"providesDirectionalDerivative="false""#));
    assert!(!xml.contains("<ModelExchange"));
    for name in [
        "z_m",
        "omega_m",
        "r1",
        "r2",
        "valid",
        "r1_shadow",
        "r2_shadow",
        "late",
    ] {
        assert!(xml.contains(&format!(r#"name="{name}""#)), "{name}");
    }
    assert!(xml.contains(r#"name="z_tcp_at_zero""#) && xml.contains(r#"start="0.4""#));
}
