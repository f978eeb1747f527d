//! `magswarm-bridge run`: a plan of inputs or the PID on setpoints, on the rig.
//!
//! One iteration per camera frame: measure the radii, compute the request (the plan's row in
//! force, or one step of the same `magswarm_control::Controller` that runs around the FMU),
//! shape it (clamps, rate limits; a non-finite request is a fault), send it (tool z and
//! heartbeat over RTDE, ROR over TMCL), advance the shadow model, write one log row (flushed).
//! Between frames the heartbeat keeps going. Any fault: stop the stepper, hold the robot,
//! write `valid=0` rows naming the fault, flush, return the fault (the binary exits non-zero).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use magswarm_control::{Controller, PidConfig};
use magswarm_log::{Layout, LogRow, LogWriter};
use magswarm_model::{Model, Plant};

use crate::camera::{self, CameraError, Measurer, Threaded};
use crate::config::RigConfig;
use crate::rtde::proto::{runtime_state, safety_mode};
use crate::rtde::{RobotState, UrLink};
use crate::safety::{Envelope, Fault, FaultLatch, Shaper};
use crate::schedule::Schedule;
use crate::stepper::{self, StepperError, StepperThread};
use crate::ur::{self, Dashboard, ServoScript};

/// A caller's law: (t [s], measured radii [mm] when the frame is valid) -> (z_m [mm], f [Hz]).
pub type Law = Arc<std::sync::Mutex<dyn FnMut(f64, Option<[f64; 2]>) -> (f64, f64) + Send>>;

/// What to run.
#[derive(Clone)]
pub enum Mode {
    /// A plan of inputs.
    Plan(Schedule),
    /// The PID on setpoints.
    Targets(Schedule),
    /// Any other law (tests, other controllers), run for `--duration`.
    Law(Law),
}

impl std::fmt::Debug for Mode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Mode::Plan(s) => write!(f, "Plan({} rows)", s.rows.len()),
            Mode::Targets(s) => write!(f, "Targets({} rows)", s.rows.len()),
            Mode::Law(_) => write!(f, "Law"),
        }
    }
}

/// A run's options.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Plan or targets.
    pub mode: Mode,
    /// The measurement log to write.
    pub log: PathBuf,
    /// Run length [s] (default: the schedule's).
    pub duration: Option<f64>,
    /// Talk to no actuator.
    pub dry_run: bool,
}

/// SIGINT / SIGTERM flags.
#[derive(Clone, Default)]
pub struct Signals {
    /// SIGINT seen.
    pub int: Arc<AtomicBool>,
    /// SIGTERM seen.
    pub term: Arc<AtomicBool>,
}

impl Signals {
    /// Register the handlers (the flags are set; the loop notices within one poll).
    pub fn install() -> std::io::Result<Signals> {
        let s = Signals::default();
        signal_hook::flag::register(signal_hook::consts::SIGINT, s.int.clone())?;
        signal_hook::flag::register(signal_hook::consts::SIGTERM, s.term.clone())?;
        Ok(s)
    }

    fn check(&self) -> Result<(), Fault> {
        if self.int.load(Ordering::SeqCst) {
            return Err(Fault::Signal("SIGINT".into()));
        }
        if self.term.load(Ordering::SeqCst) {
            return Err(Fault::Signal("SIGTERM".into()));
        }
        Ok(())
    }
}

/// How a run ended.
#[derive(Debug, Clone)]
pub struct RunReport {
    /// The latched fault (None: completed).
    pub fault: Option<Fault>,
    /// Rows written.
    pub rows: usize,
    /// Frame arrival -> command sent, per frame [s].
    pub latencies_s: Vec<f64>,
    /// Frames whose measurement was invalid.
    pub invalid_frames: usize,
}

/// The robot side: RTDE link, optional dashboard.
struct Robot {
    link: UrLink,
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
}

fn stepper_fault(e: StepperError) -> Fault {
    match e {
        StepperError::BadReply(w) => Fault::BadReply(w),
        StepperError::Serial(w) => Fault::Serial(w),
        StepperError::Command(w) => Fault::NanCommand(w),
    }
}

/// The log's columns.
struct LogCols {
    z_meas: usize,
    shadow_r1: Option<usize>,
    shadow_r2: Option<usize>,
    fault: usize,
    n_extra: usize,
}

fn load_model(cfg: &RigConfig, p: &Option<PathBuf>, what: &str) -> anyhow::Result<Model> {
    Ok(match p {
        Some(p) => {
            let p = cfg.resolve(p);
            Model::load(&p).map_err(|e| anyhow::anyhow!("{what} model {}: {e}", p.display()))?
        }
        None => Model::paper(),
    })
}

/// Run. Setup errors (config, files, devices that cannot be reached) are `Err`; faults
/// during the run are in the report.
pub fn run(
    cfg: &RigConfig,
    opts: &RunOptions,
    signals: &Signals,
    latch: &FaultLatch,
) -> anyhow::Result<RunReport> {
    run_with_camera(cfg, opts, signals, latch, None)
}

/// [`run`] with a camera given by the caller instead of the config's (benches, other
/// sources).
pub fn run_with_camera(
    cfg: &RigConfig,
    opts: &RunOptions,
    signals: &Signals,
    latch: &FaultLatch,
    camera_override: Option<Box<dyn magswarm_vision::camera::Camera>>,
) -> anyhow::Result<RunReport> {
    let env = Envelope::from(&cfg.limits);
    let duration = match (opts.duration, &opts.mode) {
        (Some(d), _) => d,
        (None, Mode::Plan(s)) | (None, Mode::Targets(s)) => s
            .default_duration()
            .ok_or_else(|| anyhow::anyhow!("the schedule has a single row: give --duration"))?,
        (None, Mode::Law(_)) => anyhow::bail!("a law needs a duration"),
    };
    if !(duration.is_finite() && duration > 0.0) {
        anyhow::bail!("--duration {duration} must be a positive number of seconds");
    }

    // Controller (targets) and start inputs.
    let ctrl_model = load_model(cfg, &cfg.control.model, "[control]")?;
    let mut controller = match &opts.mode {
        Mode::Targets(_) => {
            let pid = match &cfg.control.pid {
                Some(p) => {
                    let p = cfg.resolve(p);
                    let t = std::fs::read_to_string(&p)
                        .map_err(|e| anyhow::anyhow!("[control] pid {}: {e}", p.display()))?;
                    PidConfig::from_json(&t)
                        .map_err(|e| anyhow::anyhow!("[control] pid {}: {e}", p.display()))?
                }
                None => PidConfig::default(),
            };
            Some(Controller::new(ctrl_model.clone(), pid).map_err(|e| anyhow::anyhow!("{e}"))?)
        }
        Mode::Plan(_) | Mode::Law(_) => None,
    };
    let start = match (&cfg.control.start, &opts.mode) {
        (Some(s), _) => (s[0], s[1]),
        (None, Mode::Plan(s)) => s.at(0.0),
        (None, Mode::Targets(_)) | (None, Mode::Law(_)) => (8.5, 4.0),
    };
    let start = (
        start.0.clamp(env.z_mm[0], env.z_mm[1]),
        start.1.clamp(env.f_hz[0], env.f_hz[1]),
    );

    // Shadow model.
    let mut shadow = if cfg.shadow.enabled {
        let m = load_model(cfg, &cfg.shadow.model, "[shadow]")?;
        Some(Plant::new(
            m,
            start.0 * 1e-3,
            magswarm_model::hz_to_rad_s(start.1),
        ))
    } else {
        None
    };

    // The log, flushed every row.
    let mut layout = Layout::standard(true, false, true, controller.is_some());
    let z_meas = layout.add_extra("z_meas_mm");
    let (shadow_r1, shadow_r2) = if shadow.is_some() {
        (
            Some(layout.add_extra("shadow_r1_mm")),
            Some(layout.add_extra("shadow_r2_mm")),
        )
    } else {
        (None, None)
    };
    let fault_col = layout.add_extra("fault");
    let cols = LogCols {
        z_meas,
        shadow_r1,
        shadow_r2,
        fault: fault_col,
        n_extra: layout.extra_columns.len(),
    };
    let mut log = LogWriter::create(&opts.log, layout)
        .map_err(|e| anyhow::anyhow!("log {}: {e}", opts.log.display()))?;
    log.flush()
        .map_err(|e| anyhow::anyhow!("log {}: {e}", opts.log.display()))?;

    let mut measurer =
        Measurer::new(cfg.vision.as_ref(), cfg.camera.mm_per_px).map_err(|e| anyhow::anyhow!(e))?;

    // Devices.
    let mut robot: Option<Robot> = None;
    let mut stepper_dev: Option<StepperThread> = None;
    if !opts.dry_run {
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
        robot = Some(rb);
    }

    // Camera.
    let t0 = Instant::now();
    let (probe_cell, probe) = camera::command_probe();
    let source: Box<dyn magswarm_vision::camera::Camera> = match camera_override {
        Some(c) => c,
        None => camera::from_config(cfg, start, probe).map_err(|e| anyhow::anyhow!(e))?,
    };
    let mut cam = Threaded::spawn(source, t0, cfg.emulator.camera_stops_after_s)
        .map_err(|e| anyhow::anyhow!("[camera] {e}"))?;

    let mut shaper = Shaper::new(env, Some(start));
    if let Some(rb) = &robot {
        if let Some(s) = rb.link.state() {
            shaper = Shaper::new(env, Some((rb.z_mm(&s), start.1)));
        }
    }
    let mut in_force = shaper.last().expect("started");
    let mut last_cmd_at = t0;
    let mut last_frame_at = Instant::now();
    let mut last_z_meas = f64::NAN;
    let mut rows = 0usize;
    let mut invalid_frames = 0usize;
    let mut latencies = Vec::new();
    let mut refs: Option<(f64, f64)> = None;
    let mut ctrl_ready = false;
    let mut next_ctrl_t = 0.0;
    let cam_timeout = Duration::from_secs_f64(cfg.camera.timeout_s);

    // Send a command through the safety core to the actuators.
    let send = |req: (f64, f64),
                robot: &mut Option<Robot>,
                stepper_dev: &mut Option<StepperThread>,
                shaper: &mut Shaper,
                last_cmd_at: &mut Instant|
     -> Result<(f64, f64), Fault> {
        let now = Instant::now();
        let dt = now.duration_since(*last_cmd_at).as_secs_f64();
        let c = shaper.shape(req.0, req.1, dt)?;
        *last_cmd_at = now;
        if let Some(rb) = robot.as_mut() {
            rb.command(c.z_mm)?;
        }
        if let Some(st) = stepper_dev.as_mut() {
            st.rotate_hz(c.f_hz);
        }
        Ok((c.z_mm, c.f_hz))
    };

    let result: Result<(), Fault> = (|| {
        // Start inputs.
        in_force = send(
            start,
            &mut robot,
            &mut stepper_dev,
            &mut shaper,
            &mut last_cmd_at,
        )?;
        loop {
            signals.check()?;
            if let Some(e) = stepper_dev.as_ref().and_then(|s| s.take_error()) {
                return Err(stepper_fault(e));
            }
            if let Some(rb) = &robot {
                let s = rb.check()?;
                last_z_meas = rb.z_mm(&s);
                *probe_cell.lock().unwrap() = Some((last_z_meas, in_force.1));
            } else {
                *probe_cell.lock().unwrap() = Some(in_force);
            }
            let frame = match cam.next(Duration::from_millis(10)) {
                Ok(f) => f,
                // A replay has delivered all its frames: the run is complete.
                Err(CameraError::EndOfStream { .. }) => return Ok(()),
                Err(e) if e.is_transient() => {
                    eprintln!("magswarm-bridge: warning: {e}");
                    invalid_frames += 1;
                    None
                }
                Err(e) => return Err(Fault::Camera(e.to_string())),
            };
            let Some(frame) = frame else {
                let since = last_frame_at.elapsed();
                if since > cam_timeout {
                    return Err(Fault::CameraTimeout(since.as_secs_f64()));
                }
                // Heartbeat between frames (the target does not change).
                if let Some(rb) = robot.as_mut() {
                    rb.command(in_force.0)?;
                }
                continue;
            };
            last_frame_at = frame.arrived;
            let t = frame.t_s;
            if t > duration || t0.elapsed().as_secs_f64() > duration + cam_timeout.as_secs_f64() {
                return Ok(());
            }
            let m = measurer.measure(&frame.image);
            let valid = m.invalid.is_none();
            if !valid {
                invalid_frames += 1;
            }
            // The inputs in force while this frame was taken.
            let applied = in_force;
            // The request.
            let req = match &opts.mode {
                Mode::Plan(s) => s.at(t),
                Mode::Law(l) => {
                    let mut l = l.lock().unwrap_or_else(|p| p.into_inner());
                    (*l)(t, valid.then_some([m.r1_mm, m.r2_mm]))
                }
                Mode::Targets(s) => {
                    let r = s.at(t);
                    refs = Some(r);
                    let c = controller.as_mut().expect("targets have a controller");
                    if valid && t + 1e-9 >= next_ctrl_t {
                        if !ctrl_ready {
                            c.reset(
                                applied.0 * 1e-3,
                                magswarm_model::hz_to_rad_s(applied.1),
                                [m.r1_mm, m.r2_mm],
                            );
                            ctrl_ready = true;
                        }
                        let (z, w) = c.step([m.r1_mm, m.r2_mm], [r.0, r.1]);
                        next_ctrl_t = t + c.sample_time() - 1e-9;
                        (z * 1e3, magswarm_model::rad_s_to_hz(w))
                    } else {
                        // Invalid frame or between controller samples: hold.
                        applied
                    }
                }
            };
            in_force = send(
                req,
                &mut robot,
                &mut stepper_dev,
                &mut shaper,
                &mut last_cmd_at,
            )?;
            latencies.push(frame.arrived.elapsed().as_secs_f64());
            // Shadow model under the inputs in force up to t.
            let mut sh = None;
            if let Some(p) = shadow.as_mut() {
                let dt = t - p.time();
                if dt > 0.0 {
                    p.set_inputs(applied.0 * 1e-3, magswarm_model::hz_to_rad_s(applied.1));
                    let _ = p.step(dt);
                }
                sh = Some(p.state());
            }
            let mut row = LogRow::new(t, applied.0, applied.1, valid.then_some([m.r1_mm, m.r2_mm]));
            row.valid = valid;
            if let Some(r) = refs {
                row.r1_ref_mm = Some(r.0);
                row.r2_ref_mm = Some(r.1);
            }
            row.extra = vec![String::new(); cols.n_extra];
            row.extra[cols.z_meas] = if last_z_meas.is_finite() {
                format!("{last_z_meas}")
            } else {
                String::new()
            };
            if let (Some(a), Some(b), Some(s)) = (cols.shadow_r1, cols.shadow_r2, sh) {
                row.extra[a] = format!("{}", s[0]);
                row.extra[b] = format!("{}", s[1]);
            }
            if !valid {
                row.extra[cols.fault] = String::new();
            }
            log.write_row(&row)
                .and_then(|_| log.flush())
                .map_err(|e| Fault::Log(e.to_string()))?;
            rows += 1;
        }
    })();

    let fault = match result {
        Ok(()) => None,
        Err(f) => Some(latch.trip(f)),
    };
    // Stop: stepper first (fast), then hold the robot.
    if let Some(st) = stepper_dev.as_mut() {
        st.stop();
    }
    if let Some(rb) = robot.as_mut() {
        if fault.is_some() {
            rb.hold();
        } else {
            // Completed: hold where the tool is and stop the program.
            rb.hold();
        }
    }
    drop(stepper_dev);
    if let Some(f) = &fault {
        let t = t0.elapsed().as_secs_f64();
        let mut row = LogRow::new(t.max(0.0), in_force.0, in_force.1, None);
        row.valid = false;
        if let Some(r) = refs {
            row.r1_ref_mm = Some(r.0);
            row.r2_ref_mm = Some(r.1);
        }
        row.extra = vec![String::new(); cols.n_extra];
        row.extra[cols.fault] = f.name().to_string();
        row.extra[cols.z_meas] = if last_z_meas.is_finite() {
            format!("{last_z_meas}")
        } else {
            String::new()
        };
        let _ = log.write_row(&row).and_then(|_| log.flush());
        rows += 1;
    }
    let _ = log.finish();
    drop(robot);
    Ok(RunReport {
        fault,
        rows,
        latencies_s: latencies,
        invalid_frames,
    })
}

/// Percentile (nearest rank) of samples.
pub fn percentile(v: &[f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let k = ((p / 100.0) * s.len() as f64).ceil() as usize;
    s[k.clamp(1, s.len()) - 1]
}

/// Read a PLAN or TARGETS file.
pub fn read_mode(plan: Option<&Path>, targets: Option<&Path>) -> anyhow::Result<Mode> {
    match (plan, targets) {
        (Some(p), None) => Ok(Mode::Plan(
            Schedule::read(p, ["z_m_mm", "f_hz"]).map_err(|e| anyhow::anyhow!(e))?,
        )),
        (None, Some(t)) => Ok(Mode::Targets(
            Schedule::read(t, ["r1_ref_mm", "r2_ref_mm"]).map_err(|e| anyhow::anyhow!(e))?,
        )),
        _ => anyhow::bail!("give exactly one of --plan PLAN.csv and --targets TARGETS.csv"),
    }
}
