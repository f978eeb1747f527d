//! The simulated robot behind the emulated controller: its pose, modes and program (what the
//! bridge's URScript does: clamp, rate limit, servo, stop on a missed heartbeat), the uploaded
//! script's parameters, the dashboard commands, and what it saw.

use std::collections::HashMap;
use std::time::{Duration, Instant};

use crate::rtde::proto::{self, robot_mode, runtime_state, safety_mode, Value};

/// How the emulated robot behaves.
#[derive(Debug, Clone)]
pub struct RobotSimConfig {
    /// Tool pose at start (base frame; z \[m\]).
    pub start_pose: [f64; 6],
    /// First-order lag of the tool z behind the program's target \[s\].
    pub lag_s: f64,
    /// z limits of the tool \[m\] used when no script was uploaded (the program is already
    /// running).
    pub z_limits_m: [f64; 2],
    /// Rate limit [m/s] used when no script was uploaded.
    pub z_rate_m_s: f64,
    /// Watchdog frequency \[Hz\] used when no script was uploaded (0: none).
    pub watchdog_hz: f64,
    /// The program is already loaded and playing (no script upload expected).
    pub program_running: bool,
    /// The robot starts powered off (a dashboard client must power on and release brakes).
    pub start_powered_off: bool,
    /// Raise a protective stop this long after the first RTDE start \[s\].
    pub protective_stop_after_s: Option<f64>,
    /// Drop every RTDE connection (and refuse new ones) this long after the first start \[s\].
    pub drop_link_after_s: Option<f64>,
}

/// What the emulated robot saw (for tests and the emulator's report).
#[derive(Debug, Clone, Default)]
pub struct RobotRecord {
    /// Every `input_double_register_24` value received.
    pub targets: Vec<f64>,
    /// Dashboard commands received, in order.
    pub dashboard: Vec<String>,
    /// Scripts received on the secondary interface.
    pub scripts: Vec<String>,
    /// Heartbeats received.
    pub heartbeats: u64,
    /// Times the watchdog stopped the program.
    pub watchdog_stops: u32,
    /// The last time the watchdog fired: the heartbeat gap it saw then, and the gap at the
    /// check before (which did not fire), in seconds. So a test can see that it fired at its first
    /// check past the period, however late the checks ran on a loaded machine.
    pub watchdog_fired: Option<WatchdogFiring>,
}

/// Heartbeat gaps around a watchdog stop (see [`RobotRecord::watchdog_fired`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WatchdogFiring {
    /// Gap since the last heartbeat when the watchdog fired, in seconds (> the period).
    pub gap_s: f64,
    /// Gap at the previous check, in seconds (<= the period, or it would have fired then).
    pub previous_gap_s: f64,
}

pub(crate) struct Sim {
    pub(crate) cfg: RobotSimConfig,
    pub(crate) t0: Instant,
    pub(crate) pose: [f64; 6],
    pub(crate) z_cmd: f64,
    pub(crate) target_reg: Option<f64>,
    pub(crate) robot_mode: i32,
    pub(crate) safety_mode: i32,
    pub(crate) runtime_state: u32,
    pub(crate) program_loaded: bool,
    pub(crate) limits: [f64; 2],
    pub(crate) rate: f64,
    pub(crate) watchdog_hz: f64,
    pub(crate) last_heartbeat: Option<Instant>,
    /// Heartbeat gap at the watchdog's last check that did not fire, in seconds.
    pub(crate) last_watchdog_gap_s: f64,
    pub(crate) first_start: Option<Instant>,
    pub(crate) registers: HashMap<String, Value>,
    pub(crate) writers: HashMap<String, u64>,
    pub(crate) record: RobotRecord,
    /// The output the uploaded program raises to enable the stepper driver, if any.
    pub(crate) enable_output: Option<u8>,
    /// Standard digital outputs 0..=7.
    pub(crate) digital_out: [bool; 8],
}

impl Sim {
    /// A robot as `cfg` describes it at start.
    pub(crate) fn new(cfg: RobotSimConfig) -> Sim {
        Sim {
            t0: Instant::now(),
            pose: cfg.start_pose,
            z_cmd: cfg.start_pose[2],
            target_reg: None,
            robot_mode: if cfg.start_powered_off {
                robot_mode::POWER_OFF
            } else {
                robot_mode::RUNNING
            },
            safety_mode: safety_mode::NORMAL,
            runtime_state: if cfg.program_running {
                runtime_state::PLAYING
            } else {
                runtime_state::STOPPED
            },
            program_loaded: cfg.program_running,
            limits: cfg.z_limits_m,
            rate: cfg.z_rate_m_s,
            watchdog_hz: cfg.watchdog_hz,
            last_heartbeat: None,
            last_watchdog_gap_s: 0.0,
            first_start: None,
            registers: HashMap::new(),
            writers: HashMap::new(),
            record: RobotRecord::default(),
            enable_output: None,
            digital_out: [false; 8],
            cfg,
        }
    }

    pub(crate) fn output(&self, name: &str) -> Value {
        match name {
            "timestamp" => Value::F64(self.t0.elapsed().as_secs_f64()),
            "actual_TCP_pose" => Value::V6(self.pose),
            "target_TCP_pose" => {
                let mut p = self.pose;
                p[2] = self.z_cmd;
                Value::V6(p)
            }
            "robot_mode" => Value::I32(self.robot_mode),
            "safety_mode" | "safety_status" => Value::I32(self.safety_mode),
            "runtime_state" => Value::U32(self.runtime_state),
            "speed_scaling" | "target_speed_fraction" => Value::F64(1.0),
            "actual_main_voltage" | "actual_robot_voltage" => Value::F64(48.0),
            "joint_mode" => Value::V6I([253; 6]),
            _ => {
                if let Some(v) = self.registers.get(name) {
                    return *v;
                }
                proto::variable_type(name)
                    .map(|t| t.zero())
                    .unwrap_or(Value::U8(0))
            }
        }
    }

    pub(crate) fn tick(&mut self, dt: f64) {
        let now = Instant::now();
        if let (Some(t), Some(s)) = (self.first_start, self.cfg.protective_stop_after_s) {
            if self.safety_mode == safety_mode::NORMAL && t.elapsed().as_secs_f64() >= s {
                self.safety_mode = safety_mode::PROTECTIVE_STOP;
                if self.runtime_state == runtime_state::PLAYING {
                    self.runtime_state = runtime_state::PAUSED;
                }
            }
        }
        let playing = self.runtime_state == runtime_state::PLAYING
            && self.robot_mode == robot_mode::RUNNING
            && self.safety_mode == safety_mode::NORMAL;
        if playing && self.watchdog_hz > 0.0 {
            let period = Duration::from_secs_f64(1.0 / self.watchdog_hz);
            if let Some(h) = self.last_heartbeat {
                let gap = now.duration_since(h);
                if gap > period {
                    self.runtime_state = runtime_state::STOPPED;
                    self.record.watchdog_stops += 1;
                    self.record.watchdog_fired = Some(WatchdogFiring {
                        gap_s: gap.as_secs_f64(),
                        previous_gap_s: self.last_watchdog_gap_s,
                    });
                } else {
                    self.last_watchdog_gap_s = gap.as_secs_f64();
                }
            }
        }
        let running = self.runtime_state == runtime_state::PLAYING
            && self.robot_mode == robot_mode::RUNNING
            && self.safety_mode == safety_mode::NORMAL;
        if let Some(n) = self.enable_output {
            // High from the first heartbeat while the program runs; "Low when not running".
            self.digital_out[n as usize] = running && self.last_heartbeat.is_some();
        }
        if running {
            // The program: hold until the first heartbeat, then clamp, rate limit, servo.
            if let (Some(target), Some(_)) = (self.target_reg, self.last_heartbeat) {
                let t = target.clamp(self.limits[0], self.limits[1]);
                let step = (t - self.z_cmd).clamp(-self.rate * dt, self.rate * dt);
                self.z_cmd += step;
            }
            let a = if self.cfg.lag_s > 0.0 {
                1.0 - (-dt / self.cfg.lag_s).exp()
            } else {
                1.0
            };
            self.pose[2] += a * (self.z_cmd - self.pose[2]);
        } else {
            // Stopped, paused or stopped by safety: the robot holds where it is.
            self.z_cmd = self.pose[2];
        }
    }

    pub(crate) fn load_script(&mut self, script: &str) {
        self.record.scripts.push(script.to_string());
        let num = |key: &str| -> Option<f64> {
            script.lines().find_map(|l| {
                let l = l.trim();
                let rest = l.strip_prefix(key)?.trim_start().strip_prefix('=')?;
                rest.trim().parse::<f64>().ok()
            })
        };
        if let (Some(lo), Some(hi)) = (num("magswarm_z_min"), num("magswarm_z_max")) {
            self.limits = [lo, hi];
        }
        if let Some(v) = num("magswarm_z_rate") {
            self.rate = v;
        }
        // rtde_set_watchdog("input_int_register_24", F, "stop")
        self.watchdog_hz = script
            .lines()
            .find_map(|l| {
                let l = l.trim();
                let args = l.strip_prefix("rtde_set_watchdog(")?;
                let mut it = args.split(',');
                let reg = it.next()?.trim().trim_matches('"');
                (reg == "input_int_register_24").then_some(())?;
                it.next()?.trim().parse::<f64>().ok()
            })
            .unwrap_or(0.0);
        // set_standard_digital_out(N, True): the stepper driver's enable output.
        self.enable_output = script.lines().find_map(|l| {
            let args = l.trim().strip_prefix("set_standard_digital_out(")?;
            let (n, v) = args.trim_end_matches(')').split_once(',')?;
            (v.trim() == "True").then_some(())?;
            n.trim().parse::<u8>().ok().filter(|n| *n < 8)
        });
        self.program_loaded = true;
        if self.robot_mode == robot_mode::RUNNING && self.safety_mode == safety_mode::NORMAL {
            self.runtime_state = runtime_state::PLAYING;
            self.z_cmd = self.pose[2];
            self.last_heartbeat = None;
        }
    }

    pub(crate) fn dashboard(&mut self, cmd: &str) -> (String, bool) {
        self.record.dashboard.push(cmd.to_string());
        let r = match cmd {
            "power on" => {
                if self.robot_mode == robot_mode::POWER_OFF {
                    self.robot_mode = robot_mode::IDLE;
                }
                "Powering on".to_string()
            }
            "power off" => {
                self.robot_mode = robot_mode::POWER_OFF;
                self.runtime_state = runtime_state::STOPPED;
                "Powering off".to_string()
            }
            "brake release" => {
                if self.robot_mode == robot_mode::IDLE {
                    self.robot_mode = robot_mode::RUNNING;
                }
                "Brake releasing".to_string()
            }
            "play" => {
                if self.program_loaded
                    && self.robot_mode == robot_mode::RUNNING
                    && self.safety_mode == safety_mode::NORMAL
                {
                    self.runtime_state = runtime_state::PLAYING;
                    "Starting program".to_string()
                } else {
                    "Failed to execute: Play".to_string()
                }
            }
            "stop" => {
                self.runtime_state = runtime_state::STOPPED;
                "Stopped".to_string()
            }
            "pause" => {
                if self.runtime_state == runtime_state::PLAYING {
                    self.runtime_state = runtime_state::PAUSED;
                }
                "Pausing program".to_string()
            }
            "robotmode" => format!("Robotmode: {}", robot_mode::name(self.robot_mode)),
            "safetystatus" => format!("Safetystatus: {}", safety_mode::name(self.safety_mode)),
            "safetymode" => format!("Safetymode: {}", safety_mode::name(self.safety_mode)),
            "programState" => format!(
                "{} magswarm_servo.urp",
                runtime_state::name(self.runtime_state)
            ),
            "PolyscopeVersion" => "URSoftware 5.11.0.108249 (emulated)".to_string(),
            "unlock protective stop" => {
                if self.safety_mode == safety_mode::PROTECTIVE_STOP {
                    self.safety_mode = safety_mode::NORMAL;
                }
                "Protective stop releasing".to_string()
            }
            "close popup" | "close safety popup" => "closing popup".to_string(),
            "quit" => return ("Disconnected".to_string(), true),
            other => format!("Could not understand: '{other}'"),
        };
        (r, false)
    }
}
