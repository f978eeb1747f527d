//! The rig as one object: the arm (a [`Robot`]), the stepper (through its watchdog process,
//! [`StepperGuard`]), the camera (on its own thread) and the vision; every command through the
//! safety core.
//!
//! [`Rig::poll`] waits (up to 10 ms) for the next frame while checking every device and
//! keeping the heartbeats going (the arm's and the stepper watchdog's); [`Rig::command`]
//! shapes and sends inputs; [`Rig::shutdown`] stops the stepper and holds the robot. `run`
//! drives it frame by frame; the plant trait of `magswarm-control` drives it step by step
//! (see `plant`); the rig FMU's session drives it from a keeper thread (see `session`).

use std::process::Stdio;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::camera::{self, CameraError, Frame, Measurer, Radii, Threaded};
use crate::config::RigConfig;
use crate::error::SetupError;
use crate::robot::Robot;
use crate::safety::{Envelope, Fault, Shaper};
use crate::signals::Signals;
use crate::stepper::StepperError;
use crate::watchdog::link::StepperGuard;
use crate::watchdog::{self, GuardSpec};

fn stepper_fault(e: StepperError) -> Fault {
    match e {
        StepperError::BadReply(w) => Fault::BadReply(w),
        StepperError::Serial(w) => Fault::Serial(w),
        StepperError::Command(w) => Fault::NanCommand(w),
        StepperError::Watchdog(w) => Fault::Watchdog(w),
    }
}

/// One measured frame.
pub struct Measured {
    /// The frame (its `t_s` is the camera time since the start of the run).
    pub frame: Frame,
    /// Its radii.
    pub radii: Radii,
    /// The inputs in force while it was taken (z_m \[mm\], f \[Hz\]).
    pub applied: (f64, f64),
    /// z_m from the robot's reported pose \[mm\] (NaN in a dry run).
    pub z_meas_mm: f64,
}

/// The rig.
pub struct Rig {
    robot: Option<Box<dyn Robot>>,
    stepper: Option<StepperGuard>,
    cam: Threaded,
    measurer: Measurer,
    shaper: Shaper,
    in_force: (f64, f64),
    last_cmd_at: Instant,
    last_frame_at: Instant,
    last_z_meas: f64,
    probe: Arc<Mutex<Option<(f64, f64)>>>,
    cam_timeout: Duration,
    signals: Signals,
    /// Start of the run (t_s = 0 of the camera).
    pub t0: Instant,
    /// Frames whose camera delivery failed transiently (lost frames).
    pub lost_frames: usize,
}

impl Rig {
    /// Open every device (none but the camera in a dry run) and start the camera, with the
    /// inputs `start` (z_m \[mm\], f \[Hz\]) sent at once.
    pub fn open(
        cfg: &RigConfig,
        dry_run: bool,
        start: (f64, f64),
        signals: Signals,
        camera_override: Option<Box<dyn camera::Camera>>,
    ) -> Result<Rig, SetupError> {
        let env = Envelope::from(&cfg.limits);
        let measurer = Measurer::new(cfg.vision.as_ref(), cfg.camera.mm_per_px)?;
        let mut robot: Option<Box<dyn Robot>> = None;
        let mut stepper_dev = None;
        let mut z_now = None;
        if !dry_run {
            // The stepper first, through its watchdog, which stops it from now on whenever
            // this process dies or hangs.
            let stepper_err = |source| SetupError::Stepper {
                device: cfg.stepper.device.clone(),
                source,
            };
            let exe = watchdog::locate(cfg.stepper.watchdog_exe.as_ref().map(|p| cfg.resolve(p)))
                .map_err(stepper_err)?;
            let guard = StepperGuard::spawn(
                &exe,
                &GuardSpec::from_config(&cfg.stepper),
                Stdio::inherit(),
            )
            .map_err(stepper_err)?;
            stepper_dev = Some(guard);
            let mut rb = crate::robots::open(cfg, &env)?;
            z_now = Some(rb.check().map_err(SetupError::Fault)?);
            robot = Some(rb);
        }
        let shaper = Shaper::new(env, Some((z_now.unwrap_or(start.0), start.1)));
        // The emulated swarm starts where the devices are.
        let cam_start = shaper.last().expect("started");
        let t0 = Instant::now();
        let (probe_cell, probe) = camera::command_probe();
        let source = match camera_override {
            Some(c) => c,
            None => camera::from_config(cfg, cam_start, probe)?,
        };
        let cam = Threaded::spawn(source, t0, cfg.emulator.camera_stops_after_s)?;
        let in_force = shaper.last().expect("started");
        let mut rig = Rig {
            robot,
            stepper: stepper_dev,
            cam,
            measurer,
            shaper,
            in_force,
            last_cmd_at: t0,
            last_frame_at: Instant::now(),
            last_z_meas: f64::NAN,
            probe: probe_cell,
            cam_timeout: Duration::from_secs_f64(cfg.camera.timeout_s),
            signals,
            t0,
            lost_frames: 0,
        };
        if let Err(f) = rig.command(start) {
            rig.shutdown(true);
            return Err(SetupError::Fault(f));
        }
        Ok(rig)
    }

    /// The inputs in force (z_m \[mm\], f \[Hz\]).
    pub fn in_force(&self) -> (f64, f64) {
        self.in_force
    }

    /// Shape `req` (z_m \[mm\], f \[Hz\]) and send it; returns what was sent.
    pub fn command(&mut self, req: (f64, f64)) -> Result<(f64, f64), Fault> {
        let now = Instant::now();
        let dt = now.duration_since(self.last_cmd_at).as_secs_f64();
        let c = self.shaper.shape(req.0, req.1, dt)?;
        self.last_cmd_at = now;
        if let Some(rb) = self.robot.as_mut() {
            rb.command(c.z_mm)?;
        }
        if let Some(st) = self.stepper.as_mut() {
            st.rotate_hz(c.f_hz);
        }
        self.in_force = (c.z_mm, c.f_hz);
        Ok(self.in_force)
    }

    /// Check every device, keep the heartbeats going, and wait up to 10 ms for a frame.
    /// A fault (device, signal, camera timeout) is an error.
    pub fn poll(&mut self) -> Result<Poll, Fault> {
        self.poll_within(Duration::from_millis(10))
    }

    /// [`Rig::poll`], waiting up to `wait` for a frame.
    pub fn poll_within(&mut self, wait: Duration) -> Result<Poll, Fault> {
        self.signals.check()?;
        if let Some(st) = self.stepper.as_mut() {
            if let Some(e) = st.take_error() {
                return Err(stepper_fault(e));
            }
            st.beat();
        }
        if let Some(rb) = self.robot.as_mut() {
            self.last_z_meas = rb.check()?;
            *self.probe.lock().unwrap_or_else(|p| p.into_inner()) =
                Some((self.last_z_meas, self.in_force.1));
        } else {
            *self.probe.lock().unwrap_or_else(|p| p.into_inner()) = Some(self.in_force);
        }
        let frame = match self.cam.next(wait) {
            Ok(f) => f,
            // A replay has delivered all its frames.
            Err(CameraError::EndOfStream { .. }) => return Ok(Poll::Ended),
            Err(e) if e.is_transient() => {
                log::warn!("{e}");
                self.lost_frames += 1;
                None
            }
            Err(e) => return Err(Fault::Camera(e.to_string())),
        };
        let Some(frame) = frame else {
            let since = self.last_frame_at.elapsed();
            if since > self.cam_timeout {
                return Err(Fault::CameraTimeout(since.as_secs_f64()));
            }
            // Heartbeat between frames (the target does not change).
            let z = self.in_force.0;
            if let Some(rb) = self.robot.as_mut() {
                rb.command(z)?;
            }
            return Ok(Poll::Nothing);
        };
        self.last_frame_at = frame.arrived;
        let radii = self.measurer.measure(&frame.image);
        Ok(Poll::Frame(Box::new(Measured {
            frame,
            radii,
            applied: self.in_force,
            z_meas_mm: self.last_z_meas,
        })))
    }

    /// Stop the stepper (first), then hold the robot and stop its program.
    pub fn shutdown(&mut self, _fault: bool) {
        if let Some(st) = self.stepper.as_mut() {
            if let Err(e) = st.stop() {
                log::error!("stopping the stepper: {e}");
            }
        }
        if let Some(rb) = self.robot.as_mut() {
            rb.hold();
        }
    }

    /// z_m from the robot's last reported pose \[mm\] (NaN in a dry run).
    pub fn z_meas_mm(&self) -> f64 {
        self.last_z_meas
    }

    /// The stepper watchdog's process id (None in a dry run or once it ended).
    pub fn stepper_watchdog_pid(&self) -> Option<u32> {
        self.stepper.as_ref().and_then(StepperGuard::pid)
    }

    /// The arm, the stepper and the camera, one line each.
    pub fn describe(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let Some(rb) = &self.robot {
            out.push(format!("robot: {}", rb.describe()));
        }
        if let Some(st) = &self.stepper {
            out.push(format!(
                "stepper: {} (through its watchdog)",
                st.description
            ));
        }
        out.push(format!("camera: {}", self.cam.describe()));
        out
    }
}

impl Drop for Rig {
    fn drop(&mut self) {
        if let Some(st) = self.stepper.as_mut() {
            let _ = st.stop();
        }
    }
}

/// What [`Rig::poll`] found.
pub enum Poll {
    /// No frame within the poll period.
    Nothing,
    /// A measured frame.
    Frame(Box<Measured>),
    /// The recording (replay) ended.
    Ended,
}
