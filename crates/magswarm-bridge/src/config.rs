//! The rig configuration (TOML). The keys fixed by the contract are `[robot]`, `[stepper]`,
//! `[camera]`, `[limits]`; the rest (`[control]`, `[shadow]`, `[safety]`, `[emulator]`,
//! `[vision]`) are the bridge's own. Unknown keys are kept (and listed as warnings).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

/// The kinds of arm this build drives (`[robot] kind`), one per arm of
/// [`crate::robots::open`].
pub const ROBOT_KINDS: &[&str] = &["ur"];

/// A configuration error, naming the key.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file cannot be read.
    #[error("{path}: {source}")]
    Read {
        /// File.
        path: PathBuf,
        /// Error.
        source: std::io::Error,
    },
    /// TOML syntax or a wrong type (the message names the key and the line).
    #[error("{path}: {message}")]
    Parse {
        /// File.
        path: PathBuf,
        /// toml's message.
        message: String,
    },
    /// A model file named by the config cannot be read.
    #[error("{key} = {path}: {message}")]
    Model {
        /// Dotted key path (`shadow.model`).
        key: &'static str,
        /// The model file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
    /// A value out of range.
    #[error("{path}: `{key}`: {message}")]
    Invalid {
        /// File.
        path: PathBuf,
        /// Dotted key path.
        key: String,
        /// What is wrong.
        message: String,
    },
}

type Extra = BTreeMap<String, toml::Value>;

/// `[robot]`.
#[derive(Debug, Clone, Deserialize)]
pub struct Robot {
    /// Which arm (`"ur"`, the default: a UR e-Series controller).
    #[serde(default = "d_ur")]
    pub kind: String,
    /// Controller address.
    pub host: String,
    /// RTDE port (30004).
    #[serde(default = "d_rtde")]
    pub rtde_port: u16,
    /// Secondary interface port for the URScript (30002; 0: do not upload).
    #[serde(default = "d_script")]
    pub script_port: u16,
    /// Dashboard port (29999; 0: no dashboard client).
    #[serde(default = "d_dash")]
    pub dashboard_port: u16,
    /// Tool z (base frame) \[m\] at z_m = 0.
    pub z_tcp_at_zero_m: f64,
    /// RTDE output frequency \[Hz\] (e-Series: up to 500).
    #[serde(default = "d_freq")]
    pub frequency_hz: f64,
    /// No RTDE package for this long is a lost link \[s\].
    #[serde(default = "d_rtde_timeout")]
    pub timeout_s: f64,
    /// URScript watchdog frequency on the heartbeat register \[Hz\].
    #[serde(default = "d_watchdog")]
    pub watchdog_hz: f64,
    /// Standard digital output (0..=7) wired to the stepper driver's enable: the servo
    /// program sets it high; PolyScope's "Low when not running" drops it when it stops.
    #[serde(default)]
    pub stepper_enable_output: Option<u8>,
    /// Keys not known to the bridge.
    #[serde(flatten)]
    pub extra: Extra,
}

/// `[stepper]`.
#[derive(Debug, Clone, Deserialize)]
pub struct StepperCfg {
    /// Driver kind ("tmcl").
    #[serde(default = "d_tmcl")]
    pub kind: String,
    /// Serial device.
    pub device: String,
    /// Baud rate.
    #[serde(default = "d_baud")]
    pub baud: u32,
    /// TMCL module address.
    #[serde(default = "d_one")]
    pub module_address: u8,
    /// Motor number.
    #[serde(default)]
    pub motor: u8,
    /// TMCL velocity units per magnet revolution per second.
    pub velocity_per_hz: f64,
    /// Maximum acceleration to set on the module (TMCL units; absent: leave the module's).
    #[serde(default)]
    pub max_acceleration: Option<i32>,
    /// Reply timeout \[s\].
    #[serde(default = "d_reply_timeout")]
    pub reply_timeout_s: f64,
    /// The stepper watchdog stops the motor when the bridge sends nothing for this long \[s\]
    /// (a hung bridge; a dead one is noticed at once).
    #[serde(default = "d_watchdog_timeout")]
    pub watchdog_timeout_s: f64,
    /// The watchdog program (default: `magswarm-stepper-watchdog` beside the running program).
    #[serde(default)]
    pub watchdog_exe: Option<PathBuf>,
    /// Keys not known to the bridge.
    #[serde(flatten)]
    pub extra: Extra,
}

/// `[camera]`.
#[derive(Debug, Clone, Deserialize)]
pub struct CameraCfg {
    /// "replay" | "aravis" | "emulated".
    pub kind: String,
    /// Replay: the frame folder.
    #[serde(default)]
    pub dir: Option<PathBuf>,
    /// Pixel size in the swarm's plane \[mm\].
    pub mm_per_px: f64,
    /// No frame for this long is a camera timeout \[s\].
    #[serde(default = "d_cam_timeout")]
    pub timeout_s: f64,
    /// Emulated: frames per second.
    #[serde(default = "d_fps")]
    pub fps: f64,
    /// Emulated: frame width \[px\].
    #[serde(default = "d_w")]
    pub width: u32,
    /// Emulated: frame height \[px\].
    #[serde(default = "d_h")]
    pub height: u32,
    /// Emulated: the model of the virtual swarm (default: the paper model).
    #[serde(default)]
    pub model: Option<PathBuf>,
    /// Emulated: pixel noise (standard deviation, grey levels).
    #[serde(default = "d_noise")]
    pub noise: f64,
    /// Aravis: device id, serial number or IP (default: the first camera found).
    #[serde(default)]
    pub device: Option<String>,
    /// Aravis: exposure time \[us\] (default: the camera's).
    #[serde(default)]
    pub exposure_us: Option<f64>,
    /// Aravis: sensor region `[x, y, w, h]` \[px\] (default: the full sensor).
    #[serde(default)]
    pub region: Option<[i32; 4]>,
    /// Keys not known to the bridge.
    #[serde(flatten)]
    pub extra: Extra,
}

/// `[limits]`.
#[derive(Debug, Clone, Deserialize)]
pub struct LimitsCfg {
    /// z_m envelope \[mm\].
    pub z_m_mm: [f64; 2],
    /// Frequency envelope \[Hz\].
    pub f_hz: [f64; 2],
    /// z_m rate limit [mm/s].
    pub z_rate_mm_s: f64,
    /// Frequency rate limit [Hz/s].
    pub f_rate_hz_s: f64,
    /// Keys not known to the bridge.
    #[serde(flatten)]
    pub extra: Extra,
}

/// `[control]`: the PID (the same controller as around the FMU).
#[derive(Debug, Clone, Deserialize, Default)]
pub struct ControlCfg {
    /// A PID configuration file (JSON, `magswarm-pid/1`); default: the built-in gains.
    #[serde(default)]
    pub pid: Option<PathBuf>,
    /// The model the controller's feedforward and decoupling use (default: paper model).
    #[serde(default)]
    pub model: Option<PathBuf>,
    /// Inputs at start (z_m \[mm\], f \[Hz\]) before the first plan row / controller step.
    #[serde(default)]
    pub start: Option<[f64; 2]>,
    /// Keys not known to the bridge.
    #[serde(flatten)]
    pub extra: Extra,
}

/// `[shadow]`: a model run beside the rig on the same inputs.
#[derive(Debug, Clone, Deserialize)]
pub struct ShadowCfg {
    /// Model file (default: the paper model). `enabled = false` turns it off.
    #[serde(default)]
    pub model: Option<PathBuf>,
    /// Run the shadow model (default true).
    #[serde(default = "d_true")]
    pub enabled: bool,
    /// Keys not known to the bridge.
    #[serde(flatten)]
    pub extra: Extra,
}

/// `[emulator]`: how `magswarm-bridge emulate` behaves.
#[derive(Debug, Clone, Deserialize, Default)]
pub struct EmulatorCfg {
    /// Lag of the tool z behind its target \[s\].
    #[serde(default)]
    pub lag_s: Option<f64>,
    /// Raise a protective stop this long after the first RTDE start \[s\].
    #[serde(default)]
    pub protective_stop_after_s: Option<f64>,
    /// Drop the RTDE link this long after the first RTDE start \[s\].
    #[serde(default)]
    pub drop_link_after_s: Option<f64>,
    /// The stepper misbehaves this long after its first rotation \[s\].
    #[serde(default)]
    pub stepper_fault_after_s: Option<f64>,
    /// How: "status" | "checksum" | "silent".
    #[serde(default)]
    pub stepper_fault: Option<String>,
    /// The emulated camera (inside `run`) stops delivering frames after this time \[s\].
    #[serde(default)]
    pub camera_stops_after_s: Option<f64>,
    /// Keys not known to the bridge.
    #[serde(flatten)]
    pub extra: Extra,
}

/// The whole configuration.
#[derive(Debug, Clone, Deserialize)]
pub struct RigConfig {
    /// `[robot]`.
    pub robot: Robot,
    /// `[stepper]`.
    pub stepper: StepperCfg,
    /// `[camera]`.
    pub camera: CameraCfg,
    /// `[limits]`.
    pub limits: LimitsCfg,
    /// `[control]`.
    #[serde(default)]
    pub control: ControlCfg,
    /// `[shadow]`.
    #[serde(default)]
    pub shadow: ShadowCfg,
    /// `[emulator]`.
    #[serde(default)]
    pub emulator: EmulatorCfg,
    /// `[vision]` (passed to the measurement as it is).
    #[serde(default)]
    pub vision: Option<toml::Table>,
    /// Unknown top-level tables.
    #[serde(flatten)]
    pub extra: Extra,
    /// Where the file is (relative paths in it are relative to its folder).
    #[serde(skip)]
    pub base: PathBuf,
}

impl Default for ShadowCfg {
    fn default() -> Self {
        ShadowCfg {
            model: None,
            enabled: true,
            extra: Extra::new(),
        }
    }
}

fn d_ur() -> String {
    "ur".into()
}
fn d_rtde() -> u16 {
    30004
}
fn d_script() -> u16 {
    30002
}
fn d_dash() -> u16 {
    29999
}
fn d_freq() -> f64 {
    500.0
}
fn d_rtde_timeout() -> f64 {
    0.1
}
fn d_watchdog() -> f64 {
    10.0
}
fn d_tmcl() -> String {
    "tmcl".into()
}
fn d_baud() -> u32 {
    9600
}
fn d_one() -> u8 {
    1
}
fn d_reply_timeout() -> f64 {
    0.1
}
fn d_watchdog_timeout() -> f64 {
    0.25
}
fn d_cam_timeout() -> f64 {
    0.5
}
fn d_fps() -> f64 {
    20.0
}
fn d_w() -> u32 {
    640
}
fn d_h() -> u32 {
    480
}
fn d_noise() -> f64 {
    4.0
}
fn d_true() -> bool {
    true
}

impl RigConfig {
    /// Read and validate a file.
    pub fn load(path: &Path) -> Result<RigConfig, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|e| ConfigError::Read {
            path: path.into(),
            source: e,
        })?;
        let mut c = RigConfig::parse(&text, path)?;
        c.base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Ok(c)
    }

    /// Parse and validate text (`path` names it in errors).
    pub fn parse(text: &str, path: &Path) -> Result<RigConfig, ConfigError> {
        let c: RigConfig = toml::from_str(text).map_err(|e| ConfigError::Parse {
            path: path.into(),
            message: e.to_string().trim_end().replace('\n', " | "),
        })?;
        c.validate(path)?;
        Ok(c)
    }

    /// A path from the config, relative to the config's folder.
    pub fn resolve(&self, p: &Path) -> PathBuf {
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.base.join(p)
        }
    }

    /// The model a key names (`[shadow] model`, `[control] model`, `[camera] model`), or the
    /// paper model when the key is absent.
    pub fn model(
        &self,
        key: &'static str,
        p: Option<&PathBuf>,
    ) -> Result<magswarm_model::Model, ConfigError> {
        match p {
            None => Ok(magswarm_model::Model::paper()),
            Some(p) => {
                let path = self.resolve(p);
                magswarm_model::Model::load(&path).map_err(|e| ConfigError::Model {
                    key,
                    path,
                    message: e.to_string(),
                })
            }
        }
    }

    fn validate(&self, path: &Path) -> Result<(), ConfigError> {
        let bad = |key: &str, message: String| ConfigError::Invalid {
            path: path.into(),
            key: key.into(),
            message,
        };
        let l = &self.limits;
        let range = |key: &str, r: [f64; 2], lo: f64, hi: f64| {
            if !(r[0].is_finite() && r[1].is_finite() && r[0] < r[1]) {
                return Err(bad(
                    key,
                    format!("{r:?} is not an increasing pair of numbers"),
                ));
            }
            if r[0] < lo || r[1] > hi {
                return Err(bad(key, format!("{r:?} leaves [{lo}, {hi}]")));
            }
            Ok(())
        };
        // z_m below the magnet's radius would put the swarm inside the magnet; the model's
        // envelope is 3.5-23.5 mm, the bridge accepts up to 100 mm.
        range("limits.z_m_mm", l.z_m_mm, 0.5, 100.0)?;
        range("limits.f_hz", l.f_hz, 0.0, 100.0)?;
        for (k, v) in [
            ("limits.z_rate_mm_s", l.z_rate_mm_s),
            ("limits.f_rate_hz_s", l.f_rate_hz_s),
            ("robot.frequency_hz", self.robot.frequency_hz),
            ("robot.timeout_s", self.robot.timeout_s),
            ("robot.watchdog_hz", self.robot.watchdog_hz),
            ("stepper.velocity_per_hz", self.stepper.velocity_per_hz),
            ("stepper.reply_timeout_s", self.stepper.reply_timeout_s),
            (
                "stepper.watchdog_timeout_s",
                self.stepper.watchdog_timeout_s,
            ),
            ("camera.mm_per_px", self.camera.mm_per_px),
            ("camera.timeout_s", self.camera.timeout_s),
            ("camera.fps", self.camera.fps),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(k, format!("{v} must be a positive number")));
            }
        }
        if self.robot.frequency_hz > 500.0 {
            return Err(bad(
                "robot.frequency_hz",
                format!(
                    "{} Hz is above the controller's 500 Hz",
                    self.robot.frequency_hz
                ),
            ));
        }
        if !self.robot.z_tcp_at_zero_m.is_finite() {
            return Err(bad("robot.z_tcp_at_zero_m", "must be a number [m]".into()));
        }
        if self.robot.host.trim().is_empty() {
            return Err(bad("robot.host", "empty".into()));
        }
        if let Some(n) = self.robot.stepper_enable_output {
            if n > 7 {
                return Err(bad(
                    "robot.stepper_enable_output",
                    format!("{n}: the control box has standard digital outputs 0 to 7"),
                ));
            }
        }
        if !ROBOT_KINDS.contains(&self.robot.kind.as_str()) {
            return Err(bad(
                "robot.kind",
                format!(
                    "{:?} is not a known robot (known: {:?})",
                    self.robot.kind, ROBOT_KINDS
                ),
            ));
        }
        if self.stepper.kind != "tmcl" {
            return Err(bad(
                "stepper.kind",
                format!(
                    "{:?} is not a known driver (known: \"tmcl\")",
                    self.stepper.kind
                ),
            ));
        }
        match self.camera.kind.as_str() {
            "replay" => {
                if self.camera.dir.is_none() {
                    return Err(bad(
                        "camera.dir",
                        "a replay camera needs a frame folder".into(),
                    ));
                }
            }
            "emulated" | "aravis" => {}
            k => {
                return Err(bad(
                    "camera.kind",
                    format!("{k:?} is not a known camera (\"replay\", \"aravis\", \"emulated\")"),
                ))
            }
        }
        if let Some(f) = &self.emulator.stepper_fault {
            if !["status", "checksum", "silent"].contains(&f.as_str()) {
                return Err(bad(
                    "emulator.stepper_fault",
                    format!("{f:?} (known: \"status\", \"checksum\", \"silent\")"),
                ));
            }
        }
        Ok(())
    }

    /// Unknown keys, as dotted paths (kept in the config, reported as warnings).
    pub fn unknown_keys(&self) -> Vec<String> {
        let mut out = Vec::new();
        let mut add = |sec: &str, e: &Extra| {
            for k in e.keys() {
                out.push(if sec.is_empty() {
                    k.clone()
                } else {
                    format!("{sec}.{k}")
                });
            }
        };
        add("robot", &self.robot.extra);
        add("stepper", &self.stepper.extra);
        add("camera", &self.camera.extra);
        add("limits", &self.limits.extra);
        add("control", &self.control.extra);
        add("shadow", &self.shadow.extra);
        add("emulator", &self.emulator.extra);
        add("", &self.extra);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) const CONTRACT_EXAMPLE: &str = r#"
[robot]
host = "127.0.0.1"
rtde_port = 30004
script_port = 30002          # 0: do not upload the URScript (it is already running)
dashboard_port = 29999       # 0: no dashboard client
z_tcp_at_zero_m = 0.400      # tool z (base frame, m) at z_m = 0; tool z = this + z_m

[stepper]
kind = "tmcl"
device = "/dev/ttyACM0"
baud = 9600
module_address = 1
motor = 0
velocity_per_hz = 51200.0    # TMCL velocity units for one magnet revolution per second

[camera]
kind = "replay"              # "replay" | "aravis" | "emulated"
dir = "frames/"              # replay: a frame folder (below)
mm_per_px = 0.05

[limits]
z_m_mm = [3.5, 23.5]
f_hz = [1.0, 10.0]
z_rate_mm_s = 10.0
f_rate_hz_s = 2.0
"#;

    #[test]
    fn contract_example_parses() {
        let c = RigConfig::parse(CONTRACT_EXAMPLE, Path::new("RIG.toml")).unwrap();
        assert_eq!(c.robot.rtde_port, 30004);
        assert_eq!(c.stepper.velocity_per_hz, 51200.0);
        assert_eq!(c.limits.z_m_mm, [3.5, 23.5]);
        assert!(c.unknown_keys().is_empty());
    }

    #[test]
    fn unknown_keys_are_kept_and_listed() {
        let t = CONTRACT_EXAMPLE.replace("baud = 9600", "baud = 9600\nparity = \"none\"")
            + "\n[lab]\nroom = 3\n";
        let c = RigConfig::parse(&t, Path::new("RIG.toml")).unwrap();
        assert_eq!(c.unknown_keys(), vec!["stepper.parity", "lab"]);
        assert_eq!(c.stepper.extra["parity"].as_str(), Some("none"));
    }

    #[test]
    fn errors_name_the_key() {
        let t = CONTRACT_EXAMPLE.replace("z_rate_mm_s = 10.0", "z_rate_mm_s = -1.0");
        let e = RigConfig::parse(&t, Path::new("RIG.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("limits.z_rate_mm_s"), "{e}");
        let t = CONTRACT_EXAMPLE.replace("z_m_mm = [3.5, 23.5]", "z_m_mm = [23.5, 3.5]");
        let e = RigConfig::parse(&t, Path::new("RIG.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("limits.z_m_mm"), "{e}");
        let t = CONTRACT_EXAMPLE.replace("velocity_per_hz = 51200.0", "velocity_per_hz = \"fast\"");
        let e = RigConfig::parse(&t, Path::new("RIG.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("velocity_per_hz"), "{e}");
        let t = CONTRACT_EXAMPLE.replace("z_tcp_at_zero_m = 0.400", "");
        let e = RigConfig::parse(&t, Path::new("RIG.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("z_tcp_at_zero_m"), "{e}");
    }
}
