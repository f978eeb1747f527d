//! `magswarm-bridge run`: a plan of inputs or the PID on setpoints, on the rig.
//!
//! One iteration per camera frame: measure the radii, compute the request (the plan's row in
//! force, or one step of the same `magswarm_control::Controller` that runs around the FMU),
//! shape it (clamps, rate limits; a non-finite request is a fault), send it (tool z and
//! heartbeat over RTDE, ROR over TMCL), advance the shadow model, write one log row (flushed).
//! Between frames the heartbeat keeps going. Any fault: stop the stepper, hold the robot,
//! write `valid=0` rows naming the fault, flush, return the fault (the binary exits non-zero).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use magswarm_control::{Controller, PidConfig};
use magswarm_log::{Layout, LogRow, LogWriter};

use crate::config::RigConfig;
use crate::error::SetupError;
use crate::rig::{Poll, Rig};
use crate::safety::{Envelope, Fault, FaultLatch};
use crate::schedule::Schedule;
use crate::shadow::Shadow;
/// The SIGINT / SIGTERM flags a run checks (kept at this path for the program).
pub use crate::signals::Signals;

/// A caller's law: (t \[s\], measured radii \[mm\] when the frame is valid) -> (z_m \[mm\], f \[Hz\]).
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
    /// Run length \[s\] (default: the schedule's).
    pub duration: Option<f64>,
    /// Talk to no actuator.
    pub dry_run: bool,
}

/// How a run ended.
#[derive(Debug, Clone)]
pub struct RunReport {
    /// The latched fault (None: completed).
    pub fault: Option<Fault>,
    /// Rows written.
    pub rows: usize,
    /// Frame arrival -> command sent, per frame \[s\].
    pub latencies_s: Vec<f64>,
    /// Frames whose measurement was invalid.
    pub invalid_frames: usize,
}

/// The log's columns.
struct LogCols {
    z_meas: usize,
    shadow_r1: Option<usize>,
    shadow_r2: Option<usize>,
    fault: usize,
    n_extra: usize,
}

/// Run. Setup errors (config, files, devices that cannot be reached) are `Err`; faults
/// during the run are in the report.
pub fn run(
    cfg: &RigConfig,
    opts: &RunOptions,
    signals: &Signals,
    latch: &FaultLatch,
) -> Result<RunReport, SetupError> {
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
) -> Result<RunReport, SetupError> {
    let env = Envelope::from(&cfg.limits);
    let duration = match (opts.duration, &opts.mode) {
        (Some(d), _) => d,
        (None, Mode::Plan(s)) | (None, Mode::Targets(s)) => {
            s.default_duration().ok_or_else(|| {
                SetupError::Duration("the schedule has a single row: give --duration".into())
            })?
        }
        (None, Mode::Law(_)) => return Err(SetupError::Duration("a law needs a duration".into())),
    };
    if !(duration.is_finite() && duration > 0.0) {
        return Err(SetupError::Duration(format!(
            "--duration {duration} must be a positive number of seconds"
        )));
    }

    // Controller (targets) and start inputs.
    let ctrl_model = cfg.model("control.model", cfg.control.model.as_ref())?;
    let mut controller = match &opts.mode {
        Mode::Targets(_) => {
            let pid = match &cfg.control.pid {
                Some(p) => {
                    let p = cfg.resolve(p);
                    let t = std::fs::read_to_string(&p).map_err(|e| SetupError::File {
                        path: p.clone(),
                        source: e,
                    })?;
                    PidConfig::from_json(&t).map_err(|e| SetupError::Controller {
                        what: format!("pid {}", p.display()),
                        source: e,
                    })?
                }
                None => PidConfig::default(),
            };
            Some(
                Controller::new(ctrl_model.clone(), pid).map_err(|e| SetupError::Controller {
                    what: "the controller".into(),
                    source: e,
                })?,
            )
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
    let mut shadow = Shadow::from_config(cfg, start)?;

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
    let log_err = |e| SetupError::File {
        path: opts.log.clone(),
        source: e,
    };
    let mut log = LogWriter::create(&opts.log, layout).map_err(log_err)?;
    log.flush().map_err(log_err)?;

    let mut rig = Rig::open(cfg, opts.dry_run, start, signals.clone(), camera_override)?;
    let t0 = rig.t0;
    let cam_timeout = cfg.camera.timeout_s;
    let mut rows = 0usize;
    let mut invalid_frames = 0usize;
    let mut latencies = Vec::new();
    let mut refs: Option<(f64, f64)> = None;
    let mut ctrl_ready = false;
    let mut next_ctrl_t = 0.0;

    let result: Result<(), Fault> = (|| {
        loop {
            let m = match rig.poll()? {
                Poll::Nothing => continue,
                Poll::Ended => return Ok(()),
                Poll::Frame(m) => m,
            };
            let t = m.frame.t_s;
            if t > duration || t0.elapsed().as_secs_f64() > duration + cam_timeout {
                return Ok(());
            }
            let r = &m.radii;
            let valid = r.invalid.is_none();
            if !valid {
                invalid_frames += 1;
            }
            // The inputs in force while this frame was taken.
            let applied = m.applied;
            // The request.
            let req = match &opts.mode {
                Mode::Plan(s) => s.at(t),
                Mode::Law(l) => {
                    let mut l = l.lock().unwrap_or_else(|p| p.into_inner());
                    (*l)(t, valid.then_some([r.r1_mm, r.r2_mm]))
                }
                Mode::Targets(s) => {
                    let sp = s.at(t);
                    refs = Some(sp);
                    let c = controller.as_mut().expect("targets have a controller");
                    if valid && t + 1e-9 >= next_ctrl_t {
                        if !ctrl_ready {
                            c.reset(
                                applied.0 * 1e-3,
                                magswarm_model::hz_to_rad_s(applied.1),
                                [r.r1_mm, r.r2_mm],
                            );
                            ctrl_ready = true;
                        }
                        let (z, w) = c.step([r.r1_mm, r.r2_mm], [sp.0, sp.1]);
                        next_ctrl_t = t + c.sample_time() - 1e-9;
                        (z * 1e3, magswarm_model::rad_s_to_hz(w))
                    } else {
                        // Invalid frame or between controller samples: hold.
                        applied
                    }
                }
            };
            rig.command(req)?;
            latencies.push(m.frame.arrived.elapsed().as_secs_f64());
            // Shadow model under the inputs in force up to t.
            let sh = shadow.as_mut().map(|p| p.advance(t, applied));
            let mut row = LogRow::new(t, applied.0, applied.1, valid.then_some([r.r1_mm, r.r2_mm]));
            row.valid = valid;
            if let Some(sp) = refs {
                row.r1_ref_mm = Some(sp.0);
                row.r2_ref_mm = Some(sp.1);
            }
            row.extra = vec![String::new(); cols.n_extra];
            if m.z_meas_mm.is_finite() {
                row.extra[cols.z_meas] = format!("{}", m.z_meas_mm);
            }
            if let (Some(a), Some(b), Some(s)) = (cols.shadow_r1, cols.shadow_r2, sh) {
                row.extra[a] = format!("{}", s[0]);
                row.extra[b] = format!("{}", s[1]);
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
    // Stop: stepper first (fast), then hold the robot and stop its program.
    rig.shutdown(fault.is_some());
    let in_force = rig.in_force();
    let last_z_meas = rig.z_meas_mm();
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
    drop(rig);
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
pub fn read_mode(plan: Option<&Path>, targets: Option<&Path>) -> Result<Mode, SetupError> {
    match (plan, targets) {
        (Some(p), None) => Ok(Mode::Plan(Schedule::read(p, ["z_m_mm", "f_hz"])?)),
        (None, Some(t)) => Ok(Mode::Targets(Schedule::read(
            t,
            ["r1_ref_mm", "r2_ref_mm"],
        )?)),
        _ => Err(SetupError::PlanOrTargets),
    }
}
