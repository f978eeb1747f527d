//! An in-process closed loop (controller + [`magswarm_model::Plant`]) and the seed's
//! tracking scenario. The FMU-driven harness runs the same loop through an FMU; this one is
//! for fast tests and for the figures.

use magswarm_model::Plant;
use serde::{Deserialize, Serialize};

use crate::pid::Controller;

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

/// One sample of a closed-loop run (one row of the measurement log).
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

/// Run `segments` in closed loop: at each sample the plant's radii are measured, the
/// controller computes the inputs and the plant is advanced by one sample time under them
/// (zero-order hold). The plant starts in the state it is in; the controller is reset
/// (bumplessly) to the plant's inputs and radii unless `keep_controller`.
pub fn closed_loop(
    plant: &mut Plant,
    ctrl: &mut Controller,
    segments: &[Segment],
    keep_controller: bool,
) -> Vec<Sample> {
    let ts = ctrl.sample_time();
    if !keep_controller {
        let (z, w) = plant.inputs();
        ctrl.reset(z, w, plant.state());
    }
    let mut out = Vec::new();
    let mut t = 0.0;
    for (k, seg) in segments.iter().enumerate() {
        let n = (seg.duration_s / ts).round() as usize;
        for _ in 0..n {
            let y = plant.state();
            let (z, w) = ctrl.step(y, [seg.r1, seg.r2]);
            let goal = ctrl.reachable_setpoint().unwrap_or([seg.r1, seg.r2]);
            out.push(Sample {
                t_s: t,
                z_m_mm: z * 1e3,
                f_hz: magswarm_model::rad_s_to_hz(w),
                r1_mm: y[0],
                r2_mm: y[1],
                r1_ref_mm: seg.r1,
                r2_ref_mm: seg.r2,
                segment: k,
                r1_goal_mm: goal[0],
                r2_goal_mm: goal[1],
            });
            plant.set_inputs(z, w);
            plant
                .step(ts)
                .expect("plant integrates inside the envelope");
            t += ts;
        }
    }
    out
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
