//! The safety core: envelope clamps, rate limits, fault kinds and the fault latch.
//!
//! Every command that leaves the bridge passes [`Shaper::shape`]: a non-finite request is a
//! fault (never clamped into something plausible), a finite one is clamped to the envelope
//! and then rate limited from the last command sent.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use crate::config::LimitsCfg;

/// Why the bridge stopped.
#[derive(Debug, Clone, PartialEq)]
pub enum Fault {
    /// No RTDE package within the timeout, or the connection closed.
    RtdeLost(String),
    /// `safety_mode` other than 1 (normal).
    SafetyMode(i32),
    /// The robot program stopped (watchdog, operator) or the robot is not running.
    RobotNotRunning(String),
    /// No camera frame within the timeout.
    CameraTimeout(f64),
    /// The camera failed.
    Camera(String),
    /// Serial line error talking to the stepper.
    Serial(String),
    /// The stepper answered wrongly.
    BadReply(String),
    /// The plan or the controller asked for a non-finite input.
    NanCommand(String),
    /// SIGINT or SIGTERM.
    Signal(String),
    /// Writing the log failed.
    Log(String),
    /// The stepper watchdog process died, or stopped the motor because the bridge was silent.
    Watchdog(String),
    /// The host of the rig FMU stopped calling it (no `fmi2DoStep` long after it was due).
    HostStalled(String),
}

impl Fault {
    /// A short fixed name (the log's `fault` column).
    pub fn name(&self) -> &'static str {
        match self {
            Fault::RtdeLost(_) => "rtde_lost",
            Fault::SafetyMode(_) => "safety_mode",
            Fault::RobotNotRunning(_) => "robot_not_running",
            Fault::CameraTimeout(_) => "camera_timeout",
            Fault::Camera(_) => "camera_error",
            Fault::Serial(_) => "serial_error",
            Fault::BadReply(_) => "stepper_bad_reply",
            Fault::NanCommand(_) => "nan_command",
            Fault::Signal(_) => "signal",
            Fault::Log(_) => "log_error",
            Fault::Watchdog(_) => "stepper_watchdog",
            Fault::HostStalled(_) => "host_stalled",
        }
    }
}

impl std::fmt::Display for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Fault::RtdeLost(w) => write!(f, "RTDE link lost: {w}"),
            Fault::SafetyMode(m) => write!(
                f,
                "robot safety_mode {m} ({}), not NORMAL; an operator must clear it on the pendant",
                crate::rtde::proto::safety_mode::name(*m)
            ),
            Fault::RobotNotRunning(w) => write!(f, "robot program not running: {w}"),
            Fault::CameraTimeout(s) => write!(f, "camera timeout: no frame for {s:.3} s"),
            Fault::Camera(w) => write!(f, "camera error: {w}"),
            Fault::Serial(w) => write!(f, "stepper serial error: {w}"),
            Fault::BadReply(w) => write!(f, "stepper bad reply: {w}"),
            Fault::NanCommand(w) => write!(f, "non-finite command: {w}"),
            Fault::Signal(s) => write!(f, "stopped by {s}"),
            Fault::Log(w) => write!(f, "log write failed: {w}"),
            Fault::Watchdog(w) => write!(f, "stepper watchdog: {w}"),
            Fault::HostStalled(w) => write!(f, "the FMU's host stalled: {w}"),
        }
    }
}

/// The fault latch: the first fault wins and stays until [`FaultLatch::reset`] (an operator
/// action; the bridge itself never resets it).
#[derive(Clone, Default)]
pub struct FaultLatch {
    set: Arc<AtomicBool>,
    fault: Arc<Mutex<Option<Fault>>>,
}

impl FaultLatch {
    /// A clear latch.
    pub fn new() -> FaultLatch {
        FaultLatch::default()
    }

    /// Latch `f` unless a fault is already latched. Returns the latched fault.
    pub fn trip(&self, f: Fault) -> Fault {
        let mut g = self.fault.lock().unwrap_or_else(|p| p.into_inner());
        if g.is_none() {
            *g = Some(f);
            self.set.store(true, Ordering::SeqCst);
        }
        g.clone().expect("just set")
    }

    /// Whether a fault is latched.
    pub fn is_set(&self) -> bool {
        self.set.load(Ordering::SeqCst)
    }

    /// The latched fault.
    pub fn fault(&self) -> Option<Fault> {
        self.fault.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Clear (operator).
    pub fn reset(&self) {
        *self.fault.lock().unwrap_or_else(|p| p.into_inner()) = None;
        self.set.store(false, Ordering::SeqCst);
    }
}

/// The envelope and rate limits, human units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Envelope {
    /// z_m limits \[mm\].
    pub z_mm: [f64; 2],
    /// Frequency limits \[Hz\].
    pub f_hz: [f64; 2],
    /// z_m rate [mm/s].
    pub z_rate_mm_s: f64,
    /// Frequency rate [Hz/s].
    pub f_rate_hz_s: f64,
}

impl From<&LimitsCfg> for Envelope {
    fn from(l: &LimitsCfg) -> Envelope {
        Envelope {
            z_mm: l.z_m_mm,
            f_hz: l.f_hz,
            z_rate_mm_s: l.z_rate_mm_s,
            f_rate_hz_s: l.f_rate_hz_s,
        }
    }
}

/// A shaped command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shaped {
    /// z_m to send \[mm\].
    pub z_mm: f64,
    /// Frequency to send \[Hz\].
    pub f_hz: f64,
    /// The request was outside the envelope (clamped).
    pub clamped: bool,
    /// The rate limit cut the step.
    pub rate_limited: bool,
}

/// Clamps and rate limits commands; remembers the last one sent.
#[derive(Debug, Clone)]
pub struct Shaper {
    env: Envelope,
    last: Option<(f64, f64)>,
}

impl Shaper {
    /// A shaper whose first command is only clamped (rate limited from `start` if given).
    pub fn new(env: Envelope, start: Option<(f64, f64)>) -> Shaper {
        Shaper {
            env,
            last: start.map(|(z, f)| {
                (
                    z.clamp(env.z_mm[0], env.z_mm[1]),
                    f.clamp(env.f_hz[0], env.f_hz[1]),
                )
            }),
        }
    }

    /// The envelope.
    pub fn envelope(&self) -> &Envelope {
        &self.env
    }

    /// The last command sent.
    pub fn last(&self) -> Option<(f64, f64)> {
        self.last
    }

    /// Shape a request (z_m \[mm\], f \[Hz\]) after `dt` seconds since the last command.
    pub fn shape(&mut self, z_mm: f64, f_hz: f64, dt: f64) -> Result<Shaped, Fault> {
        if !z_mm.is_finite() || !f_hz.is_finite() {
            return Err(Fault::NanCommand(format!("z_m = {z_mm} mm, f = {f_hz} Hz")));
        }
        let e = &self.env;
        let zc = z_mm.clamp(e.z_mm[0], e.z_mm[1]);
        let fc = f_hz.clamp(e.f_hz[0], e.f_hz[1]);
        let clamped = zc != z_mm || fc != f_hz;
        let (z, f, rl) = match self.last {
            None => (zc, fc, false),
            Some((z0, f0)) => {
                let dt = if dt.is_finite() { dt.max(0.0) } else { 0.0 };
                let dz = (zc - z0).clamp(-e.z_rate_mm_s * dt, e.z_rate_mm_s * dt);
                let df = (fc - f0).clamp(-e.f_rate_hz_s * dt, e.f_rate_hz_s * dt);
                let (z, f) = (
                    (z0 + dz).clamp(e.z_mm[0], e.z_mm[1]),
                    (f0 + df).clamp(e.f_hz[0], e.f_hz[1]),
                );
                (z, f, z != zc || f != fc)
            }
        };
        self.last = Some((z, f));
        Ok(Shaped {
            z_mm: z,
            f_hz: f,
            clamped,
            rate_limited: rl,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env() -> Envelope {
        Envelope {
            z_mm: [3.5, 23.5],
            f_hz: [1.0, 10.0],
            z_rate_mm_s: 10.0,
            f_rate_hz_s: 2.0,
        }
    }

    #[test]
    fn clamps_then_rate_limits() {
        let mut s = Shaper::new(env(), Some((10.0, 4.0)));
        let c = s.shape(100.0, 50.0, 0.1).unwrap();
        assert!(c.clamped && c.rate_limited);
        assert!((c.z_mm - 11.0).abs() < 1e-12 && (c.f_hz - 4.2).abs() < 1e-12);
        // Many steps later the clamp holds.
        for _ in 0..1000 {
            let c = s.shape(-100.0, -5.0, 0.1).unwrap();
            assert!(c.z_mm >= 3.5 && c.f_hz >= 1.0);
        }
        assert_eq!(s.last(), Some((3.5, 1.0)));
    }

    #[test]
    fn nan_is_a_fault_not_a_clamp() {
        let mut s = Shaper::new(env(), Some((10.0, 4.0)));
        assert!(matches!(
            s.shape(f64::NAN, 4.0, 0.1),
            Err(Fault::NanCommand(_))
        ));
        assert!(matches!(
            s.shape(10.0, f64::INFINITY, 0.1),
            Err(Fault::NanCommand(_))
        ));
        assert_eq!(s.last(), Some((10.0, 4.0)));
    }

    #[test]
    fn latch_keeps_the_first_fault() {
        let l = FaultLatch::new();
        assert!(!l.is_set());
        l.trip(Fault::CameraTimeout(0.5));
        let f = l.trip(Fault::Signal("SIGINT".into()));
        assert_eq!(f, Fault::CameraTimeout(0.5));
        assert!(l.is_set());
        l.reset();
        assert!(l.fault().is_none());
    }
}
