//! The seed's tracking scenario (setpoint segments) with the PID in closed loop, run by the
//! one driver ([`crate::driver::run_loop`]) on any [`SwarmPlant`]: the in-process
//! [`magswarm_model::Plant`] for fast tests and figures ([`closed_loop`]), the FMU importer
//! in the `pid_tracking` harness ([`tracking`]).

use magswarm_log::LogRow;
use magswarm_model::Plant;
use serde::{Deserialize, Serialize};

use crate::driver::{run_loop, Command, LogSink, LoopError, LoopSummary, NoLog, Tick};
use crate::pid::Controller;
use crate::plant::SwarmPlant;

/// One constant-setpoint segment of a scenario.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Segment {
    /// Duration [s].
    pub duration_s: f64,
    /// Setpoint r1* [mm].
    pub r1: f64,
    /// Setpoint r2* [mm].
    pub r2: f64,
}

/// The seed's scenario (Sec. III-D, Fig. 6): r1* = 7 -> 8 -> 9 mm with r2* = 11 mm, 60 s a
/// segment.
pub fn seed_scenario() -> Vec<Segment> {
    [7.0, 8.0, 9.0]
        .iter()
        .map(|&r1| Segment {
            duration_s: 60.0,
            r1,
            r2: 11.0,
        })
        .collect()
}

/// Where the seed's scenario starts: at rest at z_m = 8.5 mm, f = 4 Hz (the middle of the
/// seed's grid), as (z_m [m], omega [rad/s]).
pub const SEED_START: (f64, f64) = (0.0085, 4.0 * std::f64::consts::TAU);

/// One sample of a tracking run: the row of the measurement log ([`Sample::log_row`]) plus
/// what the scenario knows (segment, nearest reachable radii, feasibility).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Sample {
    /// Time [s].
    pub t_s: f64,
    /// Commanded z_m from this instant [mm].
    pub z_m_mm: f64,
    /// Commanded frequency from this instant [Hz].
    pub f_hz: f64,
    /// Measured r1 [mm].
    pub r1_mm: f64,
    /// Measured r2 [mm].
    pub r2_mm: f64,
    /// Setpoint r1* [mm].
    pub r1_ref_mm: f64,
    /// Setpoint r2* [mm].
    pub r2_ref_mm: f64,
    /// Index of the segment.
    pub segment: usize,
    /// Nearest reachable r1 [mm].
    pub r1_goal_mm: f64,
    /// Nearest reachable r2 [mm].
    pub r2_goal_mm: f64,
}

impl Sample {
    /// The sample as a row of the measurement log (inputs, radii, setpoints).
    pub fn log_row(&self) -> LogRow {
        let mut row = LogRow::new(
            self.t_s,
            self.z_m_mm,
            self.f_hz,
            Some([self.r1_mm, self.r2_mm]),
        );
        row.r1_ref_mm = Some(self.r1_ref_mm);
        row.r2_ref_mm = Some(self.r2_ref_mm);
        row
    }
}

/// A tracking run: one [`Sample`] per step, and whether the controller found each sample's
/// setpoint feasible.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracking {
    /// The samples.
    pub samples: Vec<Sample>,
    /// `!target_infeasible()` at each sample.
    pub feasible: Vec<bool>,
    /// The driver's summary (last reading, end time).
    pub summary: LoopSummary,
}

/// Run `segments` with `ctrl` on any plant, by the one driver: at each sample the plant's
/// radii are read, the controller computes the inputs, one row goes to `sink`, and the plant
/// is advanced by one sample time under them (zero-order hold). The controller is reset
/// (bumplessly) to the plant's inputs and first reading unless `keep_controller`. Sample
/// times count from 0 at the start of the run. Invalid readings are passed to the
/// controller unchanged (the PID has no notion of them yet).
pub fn tracking<P, S>(
    plant: &mut P,
    ctrl: &mut Controller,
    segments: &[Segment],
    keep_controller: bool,
    sink: &mut S,
) -> Result<Tracking, LoopError>
where
    P: SwarmPlant + ?Sized,
    S: LogSink + ?Sized,
{
    let ts = ctrl.sample_time();
    // Samples per segment; the driver calls the controller once per sample, in order, so
    // the segment of a sample is followed with a count-down rather than looked up.
    let counts: Vec<usize> = segments
        .iter()
        .map(|s| (s.duration_s / ts).round() as usize)
        .collect();
    let total: usize = counts.iter().sum();
    let mut samples = Vec::with_capacity(total);
    let mut feasible = Vec::with_capacity(total);
    let mut t = 0.0;
    let mut segment = 0;
    let mut left = counts.first().copied().unwrap_or(0);
    let summary = run_loop(
        plant,
        total as u64,
        ts,
        |tick: &Tick<'_>| {
            let k = tick.k as usize;
            while left == 0 {
                segment += 1;
                left = counts[segment];
            }
            left -= 1;
            let seg = segments[segment];
            let y = tick.reading.r_mm;
            if k == 0 && !keep_controller {
                ctrl.reset(tick.inputs.z_m, tick.inputs.omega_m, y);
            }
            let (z, w) = ctrl.step(y, [seg.r1, seg.r2]);
            let goal = ctrl.reachable_setpoint().unwrap_or([seg.r1, seg.r2]);
            samples.push(Sample {
                t_s: t,
                z_m_mm: z * 1e3,
                f_hz: magswarm_model::rad_s_to_hz(w),
                r1_mm: y[0],
                r2_mm: y[1],
                r1_ref_mm: seg.r1,
                r2_ref_mm: seg.r2,
                segment,
                r1_goal_mm: goal[0],
                r2_goal_mm: goal[1],
            });
            feasible.push(!ctrl.target_infeasible());
            t += ts;
            Command::new(z, w).with_reference_mm(seg.r1, seg.r2)
        },
        sink,
    )?;
    Ok(Tracking {
        samples,
        feasible,
        summary,
    })
}

/// [`tracking`] on the in-process plant, without a log: the plant starts in the state it is
/// in and is left where the run ends.
///
/// # Panics
///
/// When the plant cannot be integrated (inputs far outside the envelope); the PID's limits
/// keep it inside.
pub fn closed_loop(
    plant: &mut Plant,
    ctrl: &mut Controller,
    segments: &[Segment],
    keep_controller: bool,
) -> Vec<Sample> {
    tracking(plant, ctrl, segments, keep_controller, &mut NoLog)
        .expect("plant integrates inside the envelope")
        .samples
}

/// Per-segment figures of a run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SegmentSummary {
    /// Setpoint (r1*, r2*) [mm].
    pub setpoint: [f64; 2],
    /// Nearest reachable radii [mm].
    pub goal: [f64; 2],
    /// Radii at the end of the segment [mm].
    pub final_radii: [f64; 2],
    /// Inputs at the end of the segment (z_m [mm], f [Hz]).
    pub final_inputs: [f64; 2],
    /// |final - goal| (max over the two radii) [mm].
    pub final_error_mm: f64,
    /// Time after the segment's start from which both radii stay within `band` of the
    /// goal [s] (`None` if never).
    pub settling_time_s: Option<f64>,
    /// Largest excursion beyond the goal in the direction of the step, over the two radii
    /// [mm].
    pub overshoot_mm: f64,
}

/// Summarise each segment of a run, settling band `band` [mm].
pub fn summarize(samples: &[Sample], band: f64) -> Vec<SegmentSummary> {
    let mut out = Vec::new();
    let nseg = samples.iter().map(|s| s.segment + 1).max().unwrap_or(0);
    for k in 0..nseg {
        let seg: Vec<&Sample> = samples.iter().filter(|s| s.segment == k).collect();
        let (first, last) = (seg[0], *seg.last().expect("non-empty"));
        let goal = [last.r1_goal_mm, last.r2_goal_mm];
        let start = [first.r1_mm, first.r2_mm];
        let within =
            |s: &Sample| (s.r1_mm - goal[0]).abs() <= band && (s.r2_mm - goal[1]).abs() <= band;
        let settle_idx = seg.iter().rposition(|s| !within(s));
        let settling_time_s = match settle_idx {
            None => Some(0.0),
            Some(i) if i + 1 < seg.len() => Some(seg[i + 1].t_s - first.t_s),
            Some(_) => None,
        };
        let mut overshoot: f64 = 0.0;
        for s in &seg {
            for (i, r) in [s.r1_mm, s.r2_mm].iter().enumerate() {
                let dir = (goal[i] - start[i]).signum();
                if (goal[i] - start[i]).abs() > 1e-9 {
                    overshoot = overshoot.max(dir * (r - goal[i]));
                }
            }
        }
        out.push(SegmentSummary {
            setpoint: [first.r1_ref_mm, first.r2_ref_mm],
            goal,
            final_radii: [last.r1_mm, last.r2_mm],
            final_inputs: [last.z_m_mm, last.f_hz],
            final_error_mm: (last.r1_mm - goal[0])
                .abs()
                .max((last.r2_mm - goal[1]).abs()),
            settling_time_s,
            overshoot_mm: overshoot,
        });
    }
    out
}
