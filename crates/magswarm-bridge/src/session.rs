//! A rig session for callers that step in wall-clock time and may pause between steps: the
//! rig FMU (`magswarm-rig-fmu`), whose host calls `fmi2DoStep` when it pleases.
//!
//! The rig cannot wait for its caller: the arm's program stops when its heartbeat stops, the
//! stepper watchdog stops the motor when the bridge goes silent, and the camera delivers
//! frames whether anyone reads them or not. So a keeper thread owns the [`Rig`] and runs its
//! loop all the time (poll every device, heartbeat, measure every frame, advance the shadow
//! model), while [`RigSession::step`] only hands it the inputs and waits for the wall clock:
//!
//! - `step(t, h, u)`: `u` goes through the safety core at once (the keeper sends it within
//!   5 ms); the call returns when the wall clock reaches the end of the step, `t + h` after
//!   the session's origin (the first step anchors FMU time to the wall clock). A step called
//!   after its end was due returns at once and reports how late it is: the host is slower
//!   than real time.
//! - Between steps the host is due at the end of the last step; when it is more than
//!   `max_late` overdue (stopped, stuck, paused in a debugger) the keeper trips the
//!   `host_stalled` fault: stepper stopped, robot held. The first step may come up to
//!   `first_step_within` after the session opened (hosts set up between initialisation and
//!   their first step).
//! - Any fault stops the stepper and holds the robot at once (on the keeper thread), and is
//!   returned by every later call.

use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::config::RigConfig;
use crate::error::SetupError;
use crate::rig::{Poll, Rig};
use crate::safety::Fault;
use crate::shadow::Shadow;
use crate::signals::Signals;

/// How long the keeper waits for a frame in one turn of its loop: the latest a new input
/// goes out after `step` hands it over.
const KEEPER_TURN: Duration = Duration::from_millis(5);

/// How a session starts.
#[derive(Debug, Clone, Copy)]
pub struct SessionOptions {
    /// Inputs sent at once (z_m \[mm\], f \[Hz\]), shaped like any other.
    pub start: (f64, f64),
    /// The host may be this much overdue before the session stops the rig.
    pub max_late: Duration,
    /// The first step may come this long after the session opened (a host often does more
    /// set-up between initialisation and its first step); the rig holds its start inputs
    /// meanwhile.
    pub first_step_within: Duration,
}

/// One measured frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// When the frame was taken.
    pub at: Instant,
    /// Its radii \[mm\] (None: the vision found no valid swarm, see `invalid`).
    pub radii: Option<[f64; 2]>,
    /// Why the frame is invalid.
    pub invalid: Option<String>,
    /// The inputs in force while it was taken (z_m \[mm\], f \[Hz\]).
    pub applied: (f64, f64),
    /// z_m from the arm's reported pose \[mm\].
    pub z_meas_mm: f64,
    /// The shadow model at that time \[mm\] (None: `[shadow] enabled = false`).
    pub shadow: Option<[f64; 2]>,
}

/// What the rig shows now.
#[derive(Debug, Clone, Default)]
pub struct RigView {
    /// The newest frame.
    pub latest: Option<Sample>,
    /// The newest frame with valid radii.
    pub last_valid: Option<Sample>,
    /// The inputs in force (z_m \[mm\], f \[Hz\]).
    pub in_force: (f64, f64),
    /// Frames measured.
    pub frames: u64,
    /// Frames without a valid swarm.
    pub invalid_frames: u64,
}

#[derive(Default)]
struct Shared {
    request: Option<(f64, f64)>,
    /// The host is due by then (None: inside a step, or before the first frame), and may be
    /// this much overdue.
    due: Option<(Instant, Duration)>,
    stop: bool,
    fault: Option<Fault>,
    view: RigView,
}

type Cell = Arc<(Mutex<Shared>, Condvar)>;

fn lock(c: &Cell) -> MutexGuard<'_, Shared> {
    c.0.lock().unwrap_or_else(|p| p.into_inner())
}

/// A running rig, kept alive between steps by its keeper thread.
pub struct RigSession {
    cell: Cell,
    keeper: Option<JoinHandle<()>>,
    origin: Instant,
    anchored: bool,
    max_late: Duration,
    /// The arm, the stepper and the camera, one line each.
    pub description: Vec<String>,
}

impl RigSession {
    /// Open every device of `cfg` (through the safety core, the stepper through its
    /// watchdog), send the start inputs and wait for the first measured frame.
    pub fn open(cfg: &RigConfig, opts: &SessionOptions) -> Result<RigSession, SetupError> {
        if opts.max_late.is_zero() {
            return Err(SetupError::Duration("max_late must be positive".into()));
        }
        let shadow = Shadow::from_config(cfg, opts.start)?;
        let rig = Rig::open(cfg, false, opts.start, Signals::default(), None)?;
        let description = rig.describe();
        let cell: Cell = Arc::new((Mutex::new(Shared::default()), Condvar::new()));
        lock(&cell).view.in_force = rig.in_force();
        let c2 = cell.clone();
        let keeper = std::thread::Builder::new()
            .name("rig-keeper".into())
            .spawn(move || keep(rig, shadow, c2))
            .map_err(|e| SetupError::Thread {
                what: "the rig keeper",
                source: e,
            })?;
        let mut s = RigSession {
            cell,
            keeper: Some(keeper),
            origin: Instant::now(),
            anchored: false,
            max_late: opts.max_late,
            description,
        };
        let wait = Duration::from_secs_f64(cfg.camera.timeout_s) + Duration::from_secs(1);
        let t0 = Instant::now();
        let mut g = lock(&s.cell);
        while g.view.frames == 0 && g.fault.is_none() && t0.elapsed() < wait {
            g = s
                .cell
                .1
                .wait_timeout(g, wait / 10)
                .map(|x| x.0)
                .unwrap_or_else(|p| p.into_inner().0);
        }
        let failed = g.fault.clone();
        let frames = g.view.frames;
        // From now on the host is due: its first step.
        g.due = Some((Instant::now(), opts.first_step_within.max(opts.max_late)));
        drop(g);
        s.origin = Instant::now();
        if let Some(f) = failed {
            s.shutdown();
            return Err(SetupError::Fault(f));
        }
        if frames == 0 {
            s.shutdown();
            return Err(SetupError::NoFirstFrame(wait.as_secs_f64()));
        }
        Ok(s)
    }

    /// The latched fault, if any.
    pub fn fault(&self) -> Option<Fault> {
        lock(&self.cell).fault.clone()
    }

    /// What the rig shows now.
    pub fn view(&self) -> RigView {
        lock(&self.cell).view.clone()
    }

    /// The session time \[s\] of an instant (0 at the first step's start).
    pub fn time_of(&self, at: Instant) -> f64 {
        if at >= self.origin {
            at.duration_since(self.origin).as_secs_f64()
        } else {
            -self.origin.duration_since(at).as_secs_f64()
        }
    }

    /// One step: send `u` (z_m \[mm\], f \[Hz\]) and return when the wall clock reaches
    /// `t + h` \[s\] of session time. Returns how late that end was already when the step was
    /// called (zero when on time). A fault, now or while waiting, is returned (latched).
    pub fn step(&mut self, t: f64, h: f64, u: (f64, f64)) -> Result<Duration, Fault> {
        if !self.anchored {
            // The first step starts now: session time t is this instant.
            self.origin = Instant::now()
                .checked_sub(Duration::from_secs_f64(t.max(0.0)))
                .unwrap_or_else(Instant::now);
            self.anchored = true;
        }
        let end = self.origin + Duration::from_secs_f64((t + h).max(0.0));
        let late = Instant::now().saturating_duration_since(end);
        let mut g = lock(&self.cell);
        if let Some(f) = &g.fault {
            return Err(f.clone());
        }
        g.request = Some(u);
        g.due = None;
        loop {
            if let Some(f) = &g.fault {
                return Err(f.clone());
            }
            let now = Instant::now();
            if now >= end {
                break;
            }
            g = self
                .cell
                .1
                .wait_timeout(g, end - now)
                .map(|x| x.0)
                .unwrap_or_else(|p| p.into_inner().0);
        }
        g.due = Some((Instant::now(), self.max_late));
        Ok(late)
    }

    /// Stop the stepper and hold the robot (also on drop). Idempotent.
    pub fn shutdown(&mut self) {
        lock(&self.cell).stop = true;
        self.cell.1.notify_all();
        if let Some(h) = self.keeper.take() {
            let _ = h.join();
        }
    }
}

impl Drop for RigSession {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// The keeper's loop: the rig's run loop without a schedule.
fn keep(mut rig: Rig, mut shadow: Option<Shadow>, cell: Cell) {
    let fault = loop {
        let request = {
            let mut g = lock(&cell);
            if g.stop {
                break None;
            }
            if let Some((due, limit)) = g.due {
                let over = Instant::now().saturating_duration_since(due);
                if over > limit {
                    break Some(Fault::HostStalled(format!(
                        "no step for {:.3} s after one was due (limit {:.3} s): the host \
                         stopped calling, or is much slower than real time",
                        over.as_secs_f64(),
                        limit.as_secs_f64()
                    )));
                }
            }
            g.request.take()
        };
        if let Some(u) = request {
            match rig.command(u) {
                Ok(sent) => lock(&cell).view.in_force = sent,
                Err(f) => break Some(f),
            }
        }
        let m = match rig.poll_within(KEEPER_TURN) {
            Ok(Poll::Nothing) => continue,
            Ok(Poll::Ended) => break Some(Fault::Camera("the recording ended".into())),
            Ok(Poll::Frame(m)) => m,
            Err(f) => break Some(f),
        };
        let t = m.frame.t_s;
        let valid = m.radii.invalid.is_none();
        let sample = Sample {
            at: rig.t0 + Duration::from_secs_f64(t.max(0.0)),
            radii: valid.then_some([m.radii.r1_mm, m.radii.r2_mm]),
            invalid: m.radii.invalid.clone(),
            applied: m.applied,
            z_meas_mm: m.z_meas_mm,
            shadow: shadow.as_mut().map(|s| s.advance(t, m.applied)),
        };
        let mut g = lock(&cell);
        g.view.frames += 1;
        if valid {
            g.view.last_valid = Some(sample.clone());
        } else {
            g.view.invalid_frames += 1;
        }
        g.view.latest = Some(sample);
        drop(g);
        cell.1.notify_all();
    };
    // Stepper first, then the arm; on a fault before anyone is told.
    rig.shutdown(fault.is_some());
    let mut g = lock(&cell);
    if let Some(f) = fault {
        g.fault.get_or_insert(f);
    }
    g.view.in_force = rig.in_force();
    drop(g);
    cell.1.notify_all();
}
