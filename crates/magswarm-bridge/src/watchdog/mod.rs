//! The stepper watchdog: a small process that owns the stepper's serial line and stops the
//! motor (TMCL MST) when the process that started it dies or goes silent.
//!
//! Why a process: a TMCL module has no host watchdog, and nothing inside a process runs after
//! `kill -9`, a crash or an OOM kill. The kernel, though, closes every file descriptor of a
//! dead process, so the watchdog holds the other end of a socket pair whose bridge end only
//! the bridge holds (close-on-exec, never inherited by its other children): end of file on
//! that socket means the bridge is gone, whatever killed it, and the watchdog sends MST at
//! once. A bridge that hangs (alive, silent) is caught by a heartbeat timeout
//! (`[stepper] watchdog_timeout_s`). The robot side does not need this: the URScript's RTDE
//! watchdog already stops the program when the heartbeat register stops changing.
//!
//! A parent-death signal (`PR_SET_PDEATHSIG`) is not used: it fires when the *thread* that
//! spawned the child ends, which inside an FMU (instantiated from any thread of a host) is
//! not the death of the process.
//!
//! The watchdog runs in its own process group, so a Ctrl-C at the terminal reaches only the
//! bridge, which then stops the motor through it in order. `SIGTERM`, `SIGINT` or `SIGHUP`
//! sent to the watchdog itself stop the motor and end it.
//!
//! The link is one line per message, text, over the socket (the watchdog's standard input):
//!
//! | from | line | meaning |
//! | --- | --- | --- |
//! | bridge | `hz F` | rotate at F magnet revolutions per second (also a heartbeat) |
//! | bridge | `beat` | heartbeat |
//! | bridge | `bye` | stop the motor (MST), answer, exit |
//! | watchdog | `ready TEXT` | the module answered; TEXT describes it |
//! | watchdog | `err NAME TEXT` | a stepper fault (`serial_error`, `stepper_bad_reply`); MST attempted |
//! | watchdog | `silence MS` | no message for MS ms: MST sent, rotation refused from now on |
//! | watchdog | `stopped` | the MST asked by `bye` was acknowledged by the module |
//!
//! Modules: [`guard`] is the watchdog's side (the `magswarm-stepper-watchdog` program),
//! [`link`] the bridge's ([`link::StepperGuard`]).

pub mod guard;
pub mod link;

use std::path::PathBuf;
use std::time::Duration;

use crate::config::StepperCfg;

/// File name of the watchdog program.
pub const PROGRAM: &str = "magswarm-stepper-watchdog";

/// Environment variable naming the watchdog program (beside `[stepper] watchdog_exe`).
pub const PROGRAM_ENV: &str = "MAGSWARM_STEPPER_WATCHDOG";

/// Everything the watchdog needs to open and drive the module (its command line).
#[derive(Debug, Clone, PartialEq)]
pub struct GuardSpec {
    /// Serial device.
    pub device: String,
    /// Baud rate.
    pub baud: u32,
    /// TMCL module address.
    pub address: u8,
    /// Motor number.
    pub motor: u8,
    /// TMCL velocity units per magnet revolution per second.
    pub velocity_per_hz: f64,
    /// Maximum acceleration to set at start (TMCL units).
    pub max_acceleration: Option<i32>,
    /// Reply timeout of a TMCL transaction.
    pub reply_timeout: Duration,
    /// No message from the bridge for this long: stop.
    pub silence_timeout: Duration,
    /// Period of the speed poll that notices a dead module while nothing changes.
    pub poll: Duration,
}

/// A command line the watchdog cannot use.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("magswarm-stepper-watchdog: {0}")]
pub struct SpecError(pub String);

impl GuardSpec {
    /// The spec of a `[stepper]` section.
    pub fn from_config(s: &StepperCfg) -> GuardSpec {
        GuardSpec {
            device: s.device.clone(),
            baud: s.baud,
            address: s.module_address,
            motor: s.motor,
            velocity_per_hz: s.velocity_per_hz,
            max_acceleration: s.max_acceleration,
            reply_timeout: Duration::from_secs_f64(s.reply_timeout_s),
            silence_timeout: Duration::from_secs_f64(s.watchdog_timeout_s),
            poll: Duration::from_millis(100),
        }
    }

    /// The command-line arguments that [`GuardSpec::from_args`] reads back.
    pub fn to_args(&self) -> Vec<String> {
        let mut a = vec![
            "--device".into(),
            self.device.clone(),
            "--baud".into(),
            self.baud.to_string(),
            "--address".into(),
            self.address.to_string(),
            "--motor".into(),
            self.motor.to_string(),
            "--velocity-per-hz".into(),
            format!("{:?}", self.velocity_per_hz),
            "--reply-timeout-s".into(),
            format!("{:?}", self.reply_timeout.as_secs_f64()),
            "--silence-timeout-s".into(),
            format!("{:?}", self.silence_timeout.as_secs_f64()),
            "--poll-s".into(),
            format!("{:?}", self.poll.as_secs_f64()),
        ];
        if let Some(m) = self.max_acceleration {
            a.push("--max-acceleration".into());
            a.push(m.to_string());
        }
        a
    }

    /// Read `--key value` arguments (the watchdog's command line).
    pub fn from_args(args: impl IntoIterator<Item = String>) -> Result<GuardSpec, SpecError> {
        let mut it = args.into_iter();
        let mut kv = std::collections::BTreeMap::new();
        while let Some(k) = it.next() {
            let Some(key) = k.strip_prefix("--") else {
                return Err(SpecError(format!("unexpected argument {k:?}")));
            };
            let v = it
                .next()
                .ok_or_else(|| SpecError(format!("--{key} needs a value")))?;
            kv.insert(key.to_string(), v);
        }
        fn take<T: std::str::FromStr>(
            kv: &mut std::collections::BTreeMap<String, String>,
            key: &str,
        ) -> Result<Option<T>, SpecError> {
            kv.remove(key)
                .map(|v| {
                    v.parse::<T>()
                        .map_err(|_| SpecError(format!("--{key} {v:?} is not a valid value")))
                })
                .transpose()
        }
        let need = |what: Option<String>, key: &str| {
            what.ok_or_else(|| SpecError(format!("--{key} is required")))
        };
        let secs = |x: Option<f64>, key: &str, default: f64| -> Result<Duration, SpecError> {
            let s = x.unwrap_or(default);
            if s.is_finite() && s > 0.0 {
                Ok(Duration::from_secs_f64(s))
            } else {
                Err(SpecError(format!(
                    "--{key} {s} must be a positive number of seconds"
                )))
            }
        };
        let device = need(take(&mut kv, "device")?, "device")?;
        let velocity_per_hz: f64 = take(&mut kv, "velocity-per-hz")?
            .ok_or_else(|| SpecError("--velocity-per-hz is required".into()))?;
        if !(velocity_per_hz.is_finite() && velocity_per_hz > 0.0) {
            return Err(SpecError(format!(
                "--velocity-per-hz {velocity_per_hz} must be a positive number"
            )));
        }
        let spec = GuardSpec {
            device,
            baud: take(&mut kv, "baud")?.unwrap_or(9600),
            address: take(&mut kv, "address")?.unwrap_or(1),
            motor: take(&mut kv, "motor")?.unwrap_or(0),
            velocity_per_hz,
            max_acceleration: take(&mut kv, "max-acceleration")?,
            reply_timeout: secs(take(&mut kv, "reply-timeout-s")?, "reply-timeout-s", 0.1)?,
            silence_timeout: secs(
                take(&mut kv, "silence-timeout-s")?,
                "silence-timeout-s",
                0.25,
            )?,
            poll: secs(take(&mut kv, "poll-s")?, "poll-s", 0.1)?,
        };
        if let Some(k) = kv.keys().next() {
            return Err(SpecError(format!("unknown option --{k}")));
        }
        Ok(spec)
    }
}

/// Where the watchdog program is: `[stepper] watchdog_exe`, else `$MAGSWARM_STEPPER_WATCHDOG`,
/// else beside the running program (or one folder up, for test binaries in `target/*/deps`).
pub fn locate(configured: Option<PathBuf>) -> Result<PathBuf, crate::stepper::StepperError> {
    let mut tried = Vec::new();
    if let Some(p) = configured {
        if p.is_file() {
            return Ok(p);
        }
        tried.push(p);
    } else if let Some(p) = std::env::var_os(PROGRAM_ENV).map(PathBuf::from) {
        if p.is_file() {
            return Ok(p);
        }
        tried.push(p);
    } else if let Ok(exe) = std::env::current_exe() {
        for dir in exe.ancestors().skip(1).take(2) {
            let p = dir.join(PROGRAM);
            if p.is_file() {
                return Ok(p);
            }
            tried.push(p);
        }
    }
    Err(crate::stepper::StepperError::Watchdog(format!(
        "the stepper watchdog program was not found (tried {}); build it with `cargo build \
         --release -p magswarm-bridge` or set [stepper] watchdog_exe",
        tried
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> GuardSpec {
        GuardSpec {
            device: "/dev/ttyACM0".into(),
            baud: 115200,
            address: 3,
            motor: 1,
            velocity_per_hz: 51200.5,
            max_acceleration: Some(2000),
            reply_timeout: Duration::from_millis(80),
            silence_timeout: Duration::from_millis(250),
            poll: Duration::from_millis(100),
        }
    }

    #[test]
    fn command_line_round_trips() {
        let s = spec();
        assert_eq!(GuardSpec::from_args(s.to_args()).unwrap(), s);
        let s = GuardSpec {
            max_acceleration: None,
            ..spec()
        };
        assert_eq!(GuardSpec::from_args(s.to_args()).unwrap(), s);
    }

    #[test]
    fn bad_command_lines_are_named() {
        let e = GuardSpec::from_args(["--baud".to_string(), "9600".into()]).unwrap_err();
        assert!(e.to_string().contains("--device"), "{e}");
        let mut a = spec().to_args();
        a.extend(["--colour".to_string(), "blue".into()]);
        let e = GuardSpec::from_args(a).unwrap_err();
        assert!(e.to_string().contains("--colour"), "{e}");
        let mut a = spec().to_args();
        let i = a.iter().position(|x| x == "--silence-timeout-s").unwrap();
        a[i + 1] = "-1".into();
        let e = GuardSpec::from_args(a).unwrap_err();
        assert!(e.to_string().contains("silence-timeout-s"), "{e}");
    }
}
