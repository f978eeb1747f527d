//! `particle_drift`: slow change of the swarm over a session (docs/effects.md).

use serde::{Deserialize, Serialize};

use super::{DataContext, Effect, EffectRow, FitParam, LearnedAxis, Stage};
use crate::param_row::{fit, range, Transform::Sin};
use crate::Model;

/// Slow change of the swarm over session time (particle loss or clumping).
///
/// Radii scale by `exp(rate_per_h t / 3600 s)`, t the plant's (session) time: particle loss
/// at a relative rate lambda shrinks the footprint area as exp(-lambda t), the radii as
/// exp(-lambda t / 2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticleDrift {
    /// Relative growth rate of the radii [1/h] (negative: shrinking).
    pub rate_per_h: f64,
}

impl ParticleDrift {
    /// Size factor at session time t \[s\].
    #[inline]
    pub fn factor(&self, t: f64) -> f64 {
        (self.rate_per_h * t / 3600.0).exp()
    }
}

const RATE_PER_H: EffectRow = effect_row!(
    ParticleDrift.rate_per_h, slot 7, None,
    "relative growth rate of the radii over session time [1/h] (negative: shrinking)",
    range(-10.0, 10.0), fit(-2.0, 2.0, Sin, false)
);

impl Effect for ParticleDrift {
    /// No drift.
    const NEUTRAL: ParticleDrift = ParticleDrift { rate_per_h: 0.0 };
    const STAGE: Stage = Stage::Observation;
    const AXIS: LearnedAxis = LearnedAxis::TS;
    const ROWS: &'static [EffectRow] = &[RATE_PER_H];

    fn fit_params(_: &DataContext) -> Vec<FitParam> {
        vec![FitParam::of_row(&RATE_PER_H)]
    }

    fn fit_neutral(_: &DataContext) -> Vec<f64> {
        vec![0.0]
    }

    fn fit_starts(_: &DataContext) -> Vec<Vec<f64>> {
        [-0.4, -0.1, 0.1, 0.4].map(|r| vec![r]).to_vec()
    }

    fn with_fit(self, vals: &[f64], _: &DataContext, _: &Model) -> ParticleDrift {
        match *vals {
            [rate_per_h] => ParticleDrift { rate_per_h },
            _ => self,
        }
    }
}
