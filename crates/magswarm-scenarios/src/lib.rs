//! An independent benchmark for `magswarm diagnose`: logs from "another lab", with unmodelled
//! effects in shapes that are not the library's forms, and the truth to score against.
//!
//! What makes it independent of what diagnose fits:
//!
//! - **Its own lab conventions** (`lab.rs`): every scenario draws its own rig (gains and
//!   exponents of the steady map moved, the magnet's distance offset and remanence off by up
//!   to a millimetre and 10 %), its own visit noise and row noise, its own transient (a
//!   first-order approach with its own time constant, not ODE (4)). Only the baseline steady
//!   map (5)-(7) of `magswarm-model` is used, as the physics both labs share.
//! - **Foreign shapes** ([`Shape`]): the effects are written here from their physical
//!   description, in six shapes each (three in the tuning set, three held out), none of them
//!   the library's parametric form or the piecewise-linear tables diagnose fits (bands, tanh and
//!   logistic roll-offs, knees, power-law and exponential onsets, sudden and stepwise losses,
//!   ringing, overshoot, dead-time and heavy-tailed transients, off-axis geometry). A test on
//!   this crate's source checks that it names no item of `magswarm_model::effects`.
//! - **Protocols** ([`Protocol`]): the seed's 50-point grid visited once with 10 rows per
//!   visit, the grid visited twice with 5 rows, and far-apart setpoint steps; each scenario
//!   also has a withheld log at operating points between the grid's.
//! - **Honest strength** ([`strength`]): the strength of a scenario is the largest deviation of
//!   its noise-free log from the best imitation by the baseline's free parameters, in units of
//!   the lab's visit noise, not the raw size of the shape.
//! - **A held-out set** ([`heldout`]): other shapes, other draws, other withheld points, kept
//!   apart from the set diagnose is tuned on ([`scenarios`]), so that the benchmark's figures
//!   on it say how diagnose does on what it was not built for.

mod lab;
mod protocol;
mod sets;
mod shape;
pub mod strength;

pub use protocol::Protocol;
pub use sets::{heldout, scenarios};
pub use shape::{Shape, EFFECTS};

use lab::Lab;
use strength::Absorb;

/// The seed's grid of distances \[mm\].
pub const GRID_Z: [f64; 5] = [3.5, 8.5, 13.5, 18.5, 23.5];
/// The seed's grid of frequencies \[Hz\].
pub const GRID_F: [f64; 10] = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0];

/// Which part of the benchmark a scenario belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Set {
    /// The shapes and draws diagnose may be tuned on.
    Tuning,
    /// Other shapes and draws, looked at only to report.
    HeldOut,
}

impl Set {
    /// Name for tables.
    pub fn name(self) -> &'static str {
        match self {
            Set::Tuning => "tuning",
            Set::HeldOut => "held-out",
        }
    }
}

/// One effect in a scenario: a shape at a strength (in visit-noise units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Truth {
    /// The shape.
    pub shape: Shape,
    /// Strength asked for [visit-noise SDs of the part the baseline cannot absorb].
    pub strength: f64,
}

/// A scenario: a lab, a protocol, the truths, and its logs.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Index.
    pub id: usize,
    /// Protocol.
    pub protocol: Protocol,
    /// The effects (empty: a null log).
    pub truths: Vec<Truth>,
    /// Seed of its draws.
    pub seed: u64,
    /// Tuning or held out.
    pub set: Set,
}

/// A scenario's logs and what its truths became.
#[derive(Debug, Clone, PartialEq)]
pub struct Realised {
    /// The training log (CSV in the project's log format).
    pub train: String,
    /// The withheld log (other operating points, same rig and effects).
    pub withheld: String,
    /// Strength each truth reached [visit-noise SDs of the unabsorbable part].
    pub strengths: Vec<f64>,
    /// Each truth's amplitude in its shape's own unit.
    pub amplitudes: Vec<f64>,
    /// Each truth's operating points where what the baseline cannot absorb shows (a visit's
    /// mean deviation at least half the largest): where a residual can locate it.
    pub visible_at: Vec<Vec<(f64, f64)>>,
    /// SD of one row around the truth per axis \[mm\] (visit and row noise): the floor of the
    /// withheld RMSE.
    pub floor: [f64; 2],
    /// The withheld log's rows without noise \[mm\], in the file's order (row i on line i + 2).
    pub withheld_truth: Vec<[f64; 2]>,
    /// The lab's visit noise SD per axis \[mm\].
    pub visit_sd: [f64; 2],
}

impl Scenario {
    /// What a right diagnosis names ("none" for null logs, "anomaly" for unexplained).
    pub fn expected(&self) -> Vec<&'static str> {
        self.truths.iter().map(|t| t.shape.effect()).collect()
    }

    /// A one-line description.
    pub fn describe(&self) -> String {
        if self.truths.is_empty() {
            return format!("null, {}", self.protocol.name());
        }
        let t: Vec<String> = self
            .truths
            .iter()
            .map(|t| format!("{} {} x{}", t.shape.effect(), t.shape.label(), t.strength))
            .collect();
        format!("{}, {}", t.join(" + "), self.protocol.name())
    }

    /// The logs, with each truth's amplitude calibrated to its strength on the training
    /// plan (camera shapes keep their nominal amplitude: they test what cannot be seen).
    pub fn realise(&self) -> Realised {
        let mut lab = Lab::draw(self.seed);
        let plan = self.protocol.plan(self.seed);
        lab.drift_span = Some(lab.duration(&plan));
        let absorb = Absorb::new(&lab, &plan);
        let mut effects = Vec::new();
        let mut strengths = Vec::new();
        let mut visible_at = Vec::new();
        for t in &self.truths {
            let (x, s) = if t.shape.effect() == "camera_bias" {
                (t.strength, absorb.visible(&[(t.shape, t.strength)]))
            } else {
                absorb.calibrate(t.shape, t.strength)
            };
            effects.push((t.shape, x));
            strengths.push(s);
            visible_at.push(absorb.where_visible(&[(t.shape, x)]));
        }
        let (zs, fs): (&[f64], &[f64]) = match self.set {
            Set::Tuning => (&[6.0, 11.0, 16.0, 21.0], &[1.5, 4.5, 5.5, 7.5, 9.5]),
            Set::HeldOut => (&[5.0, 10.0, 15.5, 20.5], &[2.5, 3.5, 6.5, 8.5]),
        };
        let wplan = self.protocol.withheld(zs, fs, self.seed ^ 0xBEEF);
        Realised {
            train: lab.csv(&effects, &plan, self.seed ^ 0x7A11),
            withheld: lab.csv(&effects, &wplan, self.seed ^ 0x3E1D),
            amplitudes: effects.iter().map(|e| e.1).collect(),
            visible_at,
            strengths,
            floor: lab.floor(),
            withheld_truth: lab.rows(&effects, &wplan).iter().map(|r| r.r).collect(),
            visit_sd: lab.visit_sd,
        }
    }

    /// The training log and the withheld log (CSV in the project's log format).
    pub fn logs(&self) -> (String, String) {
        let r = self.realise();
        (r.train, r.withheld)
    }
}

#[cfg(test)]
mod tests;
