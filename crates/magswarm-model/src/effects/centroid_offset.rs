//! `centroid_offset`: the swarm off the field axis (docs/effects.md).

use serde::{Deserialize, Serialize};

use super::{DataContext, Effect, EffectRow, FitParam, LearnedAxis, Stage};
use crate::field::MagnetConfig;
use crate::param_row::{fit, range, Transform::Sin};
use crate::Model;

/// The swarm's centroid further from the rotation axis than the model's geometry says.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CentroidOffset {
    /// Extra radial distance of the centroid from the rotation axis \[mm\] (may be negative:
    /// closer to the axis).
    pub offset_mm: f64,
}

impl CentroidOffset {
    /// The magnet geometry with the centroid moved.
    #[inline]
    pub fn magnet(&self, m: &MagnetConfig) -> MagnetConfig {
        MagnetConfig {
            lateral_offset_m: (m.lateral_offset_m + self.offset_mm * 1e-3).abs(),
            ..*m
        }
    }
}

const OFFSET_MM: EffectRow = effect_row!(
    CentroidOffset.offset_mm, slot 8, Some("mm"),
    "extra radial distance of the swarm centroid from the rotation axis",
    range(-50.0, 50.0), fit(-6.0, 15.0, Sin, false)
);

impl Effect for CentroidOffset {
    /// The centroid where the model's geometry puts it.
    const NEUTRAL: CentroidOffset = CentroidOffset { offset_mm: 0.0 };
    const STAGE: Stage = Stage::SteadyMap;
    const AXIS: LearnedAxis = LearnedAxis::ZmMm;
    const ROWS: &'static [EffectRow] = &[OFFSET_MM];

    fn fit_params(ctx: &DataContext) -> Vec<FitParam> {
        vec![FitParam {
            // From the swarm on the axis (lateral distance 0, a physical limit) to 30 mm
            // further out than the model's geometry.
            lo: -ctx.lateral_mm,
            hi: 30.0,
            flag: (false, true),
            ..FitParam::of_row(&OFFSET_MM)
        }]
    }

    fn fit_neutral(_: &DataContext) -> Vec<f64> {
        vec![0.0]
    }

    fn fit_starts(_: &DataContext) -> Vec<Vec<f64>> {
        [2.0, 5.0, 9.0, 15.0].map(|o| vec![o]).to_vec()
    }

    fn with_fit(self, vals: &[f64], _: &DataContext, _: &Model) -> CentroidOffset {
        match *vals {
            [offset_mm] => CentroidOffset { offset_mm },
            _ => self,
        }
    }
}
