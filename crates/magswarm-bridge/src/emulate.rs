//! `magswarm-bridge emulate`: the rig's devices as the config describes them.

use crate::config::RigConfig;
use crate::rtde::server::{RobotSimConfig, UrEmulator};
use crate::stepper_emu::{PtyError, StepperEmulator, StepperFault, StepperSimConfig};

/// The running emulators.
pub struct Emulators {
    /// UR controller (RTDE, dashboard, secondary interface).
    pub robot: UrEmulator,
    /// TMCL stepper on a pty.
    pub stepper: StepperEmulator,
}

/// The robot emulator's settings from a config (`[robot]`, `[limits]`, `[emulator]`).
pub fn robot_sim_config(cfg: &RigConfig) -> RobotSimConfig {
    let r = &cfg.robot;
    let l = &cfg.limits;
    let z_start = r.z_tcp_at_zero_m + 0.5 * (l.z_m_mm[0] + l.z_m_mm[1]) * 1e-3;
    RobotSimConfig {
        start_pose: [0.3, -0.2, z_start, 0.0, std::f64::consts::PI, 0.0],
        lag_s: cfg.emulator.lag_s.unwrap_or(0.05),
        z_limits_m: [
            r.z_tcp_at_zero_m + l.z_m_mm[0] * 1e-3,
            r.z_tcp_at_zero_m + l.z_m_mm[1] * 1e-3,
        ],
        z_rate_m_s: l.z_rate_mm_s * 1e-3,
        watchdog_hz: r.watchdog_hz,
        program_running: r.script_port == 0,
        start_powered_off: r.dashboard_port != 0,
        protective_stop_after_s: cfg.emulator.protective_stop_after_s,
        drop_link_after_s: cfg.emulator.drop_link_after_s,
    }
}

/// An emulator that could not be started.
#[derive(Debug, thiserror::Error)]
pub enum EmulateError {
    /// The UR controller's ports could not be bound.
    #[error("emulated robot on {host}: {source}")]
    Robot {
        /// `robot.host`.
        host: String,
        /// The error.
        source: std::io::Error,
    },
    /// The TMCL module's pty could not be opened.
    #[error("emulated stepper: {0}")]
    Stepper(#[from] PtyError),
}

/// Start every emulator. `ports_from_config`: bind the config's ports (else free ports).
pub fn start(cfg: &RigConfig, ports_from_config: bool) -> Result<Emulators, EmulateError> {
    let r = &cfg.robot;
    let p = |port: u16| if ports_from_config { port } else { 0 };
    let robot = UrEmulator::start(
        &r.host,
        p(r.rtde_port),
        (r.dashboard_port != 0).then(|| p(r.dashboard_port)),
        (r.script_port != 0).then(|| p(r.script_port)),
        robot_sim_config(cfg),
    )
    .map_err(|e| EmulateError::Robot {
        host: r.host.clone(),
        source: e,
    })?;
    let fault = match cfg.emulator.stepper_fault.as_deref() {
        Some("checksum") => StepperFault::Checksum,
        Some("silent") => StepperFault::Silent,
        _ => StepperFault::Status,
    };
    let stepper = StepperEmulator::start(StepperSimConfig {
        address: cfg.stepper.module_address,
        reply_address: 2,
        acceleration: cfg
            .stepper
            .max_acceleration
            .map(|a| a as f64)
            .unwrap_or(cfg.limits.f_rate_hz_s * cfg.stepper.velocity_per_hz),
        fault_after_s: cfg.emulator.stepper_fault_after_s,
        fault,
    })?;
    Ok(Emulators { robot, stepper })
}

impl Emulators {
    /// Where each device listens (one line each).
    pub fn describe(&self, cfg: &RigConfig) -> Vec<String> {
        let mut out = vec![format!("rtde {}", self.robot.rtde)];
        if let Some(a) = self.robot.dashboard {
            out.push(format!("dashboard {a}"));
        }
        if let Some(a) = self.robot.secondary {
            out.push(format!("secondary {a}"));
        }
        out.push(format!("stepper {}", self.stepper.path));
        out.push(format!(
            "camera {} (runs inside `magswarm-bridge run`: set [camera] kind = \"emulated\")",
            cfg.camera.kind
        ));
        out
    }
}
