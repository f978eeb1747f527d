//! The rig as one object: robot (RTDE link, dashboard, servo program), stepper (on its own
//! thread), camera (on its own thread) and the vision; every command through the safety core.
//!
//! [`Rig::poll`] waits (up to 10 ms) for the next frame while checking every device and
//! keeping the heartbeat going; [`Rig::command`] shapes and sends inputs; [`Rig::shutdown`]
//! stops the stepper and holds the robot. `run` drives it frame by frame; the plant trait
//! of `magswarm-control` drives it step by step (see `plant`).

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::camera::{self, CameraError, Frame, Measurer, Radii, Threaded};
use crate::config::RigConfig;
use crate::rtde::proto::{runtime_state, safety_mode};
use crate::rtde::{RobotState, UrLink};
use crate::run::Signals;
use crate::safety::{Envelope, Fault, Shaper};
use crate::stepper::{self, StepperError, StepperThread};
use crate::ur::{self, Dashboard, ServoScript};

/// The robot side: RTDE link, optional dashboard.
pub(crate) struct Robot {
    pub(crate) link: UrLink,
    dash: Option<Dashboard>,
    z0_m: f64,
    timeout: Duration,
    program_expected: bool,
}

impl Robot {
    fn check(&self) -> Result<RobotState, Fault> {
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

    fn command(&mut self, z_mm: f64) -> Result<(), Fault> {
        self.link
            .command(self.z0_m + z_mm * 1e-3)
            .map_err(|e| Fault::RtdeLost(format!("sending the target: {e}")))
    }

    /// Hold: target = where the tool is; stop the program through the dashboard.
    fn hold(&mut self) {
        if let Some(s) = self.link.state() {
            let _ = self.link.command(s.tcp_pose[2]);
        }
        if let Some(d) = self.dash.as_mut() {
            let _ = d.command("stop");
        }
    }

    /// Connect, check, bring up, upload the servo program and wait for it to play.
    fn open(cfg: &RigConfig, env: &Envelope) -> anyhow::Result<Robot> {
        let r = &cfg.robot;
        let link = UrLink::connect(&r.host, r.rtde_port, r.frequency_hz, Duration::from_secs(2))
            .map_err(|e| anyhow::anyhow!("[robot] {e}"))?;
        let first = link.wait_state(Duration::from_secs(2)).ok_or_else(|| {
            anyhow::anyhow!(
                "[robot] RTDE {}:{}: no data package within 2 s{}",
                r.host,
                r.rtde_port,
                link.error().map(|e| format!(" ({e})")).unwrap_or_default()
            )
        })?;
        if first.safety_mode != safety_mode::NORMAL {
            // Never unlocked automatically: the operator clears it on the pendant.
            anyhow::bail!("{}", Fault::SafetyMode(first.safety_mode));
        }
        let dash = if r.dashboard_port != 0 {
            let mut d = Dashboard::connect(&r.host, r.dashboard_port, Duration::from_secs(2))
                .map_err(|e| anyhow::anyhow!("[robot] {e}"))?;
            d.bring_up(Duration::from_secs(10))
                .map_err(|e| anyhow::anyhow!("[robot] {e}"))?;
            Some(d)
        } else {
            None
        };
        let mut rb = Robot {
            link,
            dash,
            z0_m: r.z_tcp_at_zero_m,
            timeout: Duration::from_secs_f64(r.timeout_s),
            program_expected: false,
        };
        // First target: where the tool is, clamped to the envelope (the program rate limits).
        let z_now = rb.z_mm(&first).clamp(env.z_mm[0], env.z_mm[1]);
        rb.command(z_now).map_err(|f| anyhow::anyhow!("{f}"))?;
        if r.script_port != 0 {
            let prog = ServoScript {
                z_min_m: r.z_tcp_at_zero_m + env.z_mm[0] * 1e-3,
                z_max_m: r.z_tcp_at_zero_m + env.z_mm[1] * 1e-3,
                z_rate_m_s: env.z_rate_mm_s * 1e-3,
                watchdog_hz: r.watchdog_hz,
            }
            .program();
            ur::upload_script(&r.host, r.script_port, &prog, Duration::from_secs(2))
                .map_err(|e| anyhow::anyhow!("[robot] {e}"))?;
        }
        // Wait for the program to play, heartbeating.
        let t0 = Instant::now();
        loop {
            rb.command(z_now).map_err(|f| anyhow::anyhow!("{f}"))?;
            if let Some(s) = rb.link.state() {
                if s.runtime_state == runtime_state::PLAYING {
                    break;
                }
            }
            if t0.elapsed() > Duration::from_secs(3) {
                anyhow::bail!(
                    "[robot] the servo program is not playing 3 s after {} (runtime_state {})",
                    if r.script_port != 0 {
                        "the upload"
                    } else {
                        "start"
                    },
                    rb.link
                        .state()
                        .map(|s| runtime_state::name(s.runtime_state))
                        .unwrap_or("unknown")
                );
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        rb.program_expected = true;
        Ok(rb)
    }
}

fn stepper_fault(e: StepperError) -> Fault {
    match e {
        StepperError::BadReply(w) => Fault::BadReply(w),
        StepperError::Serial(w) => Fault::Serial(w),
        StepperError::Command(w) => Fault::NanCommand(w),
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
    robot: Option<Robot>,
    stepper: Option<StepperThread>,
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
    ) -> anyhow::Result<Rig> {
        let env = Envelope::from(&cfg.limits);
        let measurer = Measurer::new(cfg.vision.as_ref(), cfg.camera.mm_per_px)
            .map_err(|e| anyhow::anyhow!(e))?;
        let mut robot = None;
        let mut stepper_dev = None;
        if !dry_run {
            let mut tm = stepper::open_serial(
                &cfg.stepper.device,
                cfg.stepper.baud,
                cfg.stepper.module_address,
                cfg.stepper.motor,
                cfg.stepper.velocity_per_hz,
                Duration::from_secs_f64(cfg.stepper.reply_timeout_s),
            )
            .map_err(|e| anyhow::anyhow!("[stepper] {e}"))?;
            if let Some(a) = cfg.stepper.max_acceleration {
                tm.set_max_acceleration(a)
                    .map_err(|e| anyhow::anyhow!("[stepper] setting max_acceleration: {e}"))?;
            }
            use crate::stepper::Stepper as _;
            tm.stop().map_err(|e| anyhow::anyhow!("[stepper] {e}"))?;
            stepper_dev = Some(StepperThread::spawn(
                Box::new(tm),
                Duration::from_millis(100),
            ));
            robot = Some(Robot::open(cfg, &env)?);
        }
        let mut shaper = Shaper::new(env, Some(start));
        if let Some(rb) = &robot {
            if let Some(s) = rb.link.state() {
                shaper = Shaper::new(env, Some((rb.z_mm(&s), start.1)));
            }
        }
        // The emulated swarm starts where the devices are.
        let cam_start = shaper.last().expect("started");
        let t0 = Instant::now();
        let (probe_cell, probe) = camera::command_probe();
        let source = match camera_override {
            Some(c) => c,
            None => camera::from_config(cfg, cam_start, probe).map_err(|e| anyhow::anyhow!(e))?,
        };
        let cam = Threaded::spawn(source, t0, cfg.emulator.camera_stops_after_s)
            .map_err(|e| anyhow::anyhow!("[camera] {e}"))?;
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
            anyhow::bail!("{f}");
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
        if let Some(st) = self.stepper.as_ref() {
            st.rotate_hz(c.f_hz);
        }
        self.in_force = (c.z_mm, c.f_hz);
        Ok(self.in_force)
    }

    /// Check every device, keep the heartbeat going, and wait up to 10 ms for a frame.
    /// A fault (device, signal, camera timeout) is an error.
    pub fn poll(&mut self) -> Result<Poll, Fault> {
        self.signals.check()?;
        if let Some(e) = self.stepper.as_ref().and_then(|s| s.take_error()) {
            return Err(stepper_fault(e));
        }
        if let Some(rb) = &self.robot {
            let s = rb.check()?;
            self.last_z_meas = rb.z_mm(&s);
            *self.probe.lock().unwrap_or_else(|p| p.into_inner()) =
                Some((self.last_z_meas, self.in_force.1));
        } else {
            *self.probe.lock().unwrap_or_else(|p| p.into_inner()) = Some(self.in_force);
        }
        let frame = match self.cam.next(Duration::from_millis(10)) {
            Ok(f) => f,
            // A replay has delivered all its frames.
            Err(CameraError::EndOfStream { .. }) => return Ok(Poll::Ended),
            Err(e) if e.is_transient() => {
                eprintln!("magswarm-bridge: warning: {e}");
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
            st.stop();
        }
        if let Some(rb) = self.robot.as_mut() {
            rb.hold();
        }
    }

    /// z_m from the robot's last reported pose \[mm\] (NaN in a dry run).
    pub fn z_meas_mm(&self) -> f64 {
        self.last_z_meas
    }
}

impl Drop for Rig {
    fn drop(&mut self) {
        if let Some(st) = self.stepper.as_mut() {
            st.stop();
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
