//! [`UrRobot`]: a UR e-Series arm behind the [`Robot`] trait. The RTDE link carries the tool
//! z target and the heartbeat (input registers 24) and brings back the pose and the modes;
//! the dashboard powers the arm on and stops its program; the servo program (uploaded to the
//! secondary interface) follows the target, clamped and rate limited again on the controller,
//! and stops itself when the heartbeat stops (RTDE watchdog).

use std::time::{Duration, Instant};

use super::{upload_script, Dashboard, ServoScript, UrError};
use crate::config::RigConfig;
use crate::robot::Robot;
use crate::rtde::proto::{runtime_state, safety_mode};
use crate::rtde::{RobotState, UrLink};
use crate::safety::{Envelope, Fault};

/// A UR e-Series arm.
pub struct UrRobot {
    link: UrLink,
    dash: Option<Dashboard>,
    z0_m: f64,
    timeout: Duration,
    program_expected: bool,
    addr: String,
}

impl UrRobot {
    fn state(&self) -> Result<RobotState, Fault> {
        if let Some(e) = self.link.error() {
            return Err(Fault::RtdeLost(e));
        }
        let s = self
            .link
            .state()
            .ok_or_else(|| Fault::RtdeLost("no data package received".into()))?;
        let age = s.received.elapsed();
        if age > self.timeout {
            return Err(Fault::RtdeLost(format!(
                "no data package for {:.3} s (timeout {:.3} s)",
                age.as_secs_f64(),
                self.timeout.as_secs_f64()
            )));
        }
        if s.safety_mode != safety_mode::NORMAL {
            return Err(Fault::SafetyMode(s.safety_mode));
        }
        if self.program_expected && s.runtime_state != runtime_state::PLAYING {
            return Err(Fault::RobotNotRunning(format!(
                "runtime_state {} ({})",
                s.runtime_state,
                runtime_state::name(s.runtime_state)
            )));
        }
        Ok(s)
    }

    fn z_mm(&self, s: &RobotState) -> f64 {
        (s.tcp_pose[2] - self.z0_m) * 1e3
    }

    /// Connect, check, bring up, upload the servo program and wait for it to play.
    pub fn open(cfg: &RigConfig, env: &Envelope) -> Result<UrRobot, UrError> {
        let r = &cfg.robot;
        let link = UrLink::connect(&r.host, r.rtde_port, r.frequency_hz, Duration::from_secs(2))?;
        let first = link.wait_state(Duration::from_secs(2)).ok_or_else(|| {
            UrError::NotReady(format!(
                "RTDE {}:{}: no data package within 2 s{}",
                r.host,
                r.rtde_port,
                link.error().map(|e| format!(" ({e})")).unwrap_or_default()
            ))
        })?;
        if first.safety_mode != safety_mode::NORMAL {
            // Never unlocked automatically: the operator clears it on the pendant.
            return Err(UrError::Fault(Fault::SafetyMode(first.safety_mode)));
        }
        let dash = if r.dashboard_port != 0 {
            let mut d = Dashboard::connect(&r.host, r.dashboard_port, Duration::from_secs(2))?;
            d.bring_up(Duration::from_secs(10))?;
            Some(d)
        } else {
            None
        };
        let mut rb = UrRobot {
            addr: format!(
                "UR controller {} at {}:{}",
                link.version, r.host, r.rtde_port
            ),
            link,
            dash,
            z0_m: r.z_tcp_at_zero_m,
            timeout: Duration::from_secs_f64(r.timeout_s),
            program_expected: false,
        };
        // First target: where the tool is, clamped to the envelope (the program rate limits).
        let z_now = rb.z_mm(&first).clamp(env.z_mm[0], env.z_mm[1]);
        rb.command(z_now).map_err(UrError::Fault)?;
        if r.script_port != 0 {
            let prog = ServoScript {
                z_min_m: r.z_tcp_at_zero_m + env.z_mm[0] * 1e-3,
                z_max_m: r.z_tcp_at_zero_m + env.z_mm[1] * 1e-3,
                z_rate_m_s: env.z_rate_mm_s * 1e-3,
                watchdog_hz: r.watchdog_hz,
                enable_output: r.stepper_enable_output,
            }
            .program();
            upload_script(&r.host, r.script_port, &prog, Duration::from_secs(2))?;
        }
        // Wait for the program to play, heartbeating.
        let t0 = Instant::now();
        loop {
            rb.command(z_now).map_err(UrError::Fault)?;
            if let Some(s) = rb.link.state() {
                if s.runtime_state == runtime_state::PLAYING {
                    break;
                }
            }
            if t0.elapsed() > Duration::from_secs(3) {
                return Err(UrError::NotReady(format!(
                    "the servo program is not playing 3 s after {} (runtime_state {})",
                    if r.script_port != 0 {
                        "the upload"
                    } else {
                        "start"
                    },
                    rb.link
                        .state()
                        .map(|s| runtime_state::name(s.runtime_state))
                        .unwrap_or("unknown")
                )));
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        rb.program_expected = true;
        Ok(rb)
    }
}

impl Robot for UrRobot {
    fn check(&mut self) -> Result<f64, Fault> {
        let s = self.state()?;
        Ok(self.z_mm(&s))
    }

    fn command(&mut self, z_mm: f64) -> Result<(), Fault> {
        self.link
            .command(self.z0_m + z_mm * 1e-3)
            .map_err(|e| Fault::RtdeLost(format!("sending the target: {e}")))
    }

    /// Target = where the tool is (the heartbeat then stops, so the program's watchdog ends
    /// it), and `stop` through the dashboard when there is one.
    fn hold(&mut self) {
        if let Some(s) = self.link.state() {
            let _ = self.link.command(s.tcp_pose[2]);
        }
        if let Some(d) = self.dash.as_mut() {
            let _ = d.command("stop");
        }
    }

    fn describe(&self) -> String {
        self.addr.clone()
    }
}
