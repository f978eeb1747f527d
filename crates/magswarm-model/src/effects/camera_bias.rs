//! `camera_bias`: scale, offset and tilt of the measurement (docs/effects.md).

use serde::{Deserialize, Serialize};

use super::{DataContext, Effect, EffectRow, FitParam, LearnedAxis, Stage};
use crate::param_row::{fit, range, Transform::Log, Transform::Sin};
use crate::Model;

/// Measurement bias of the camera: `r1' = scale r1 + offset`,
/// `r2' = scale cos(tilt) r2 + offset` (a camera tilted about the r1 axis foreshortens r2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraBias {
    /// Scale error (mm per px calibration) [-].
    pub scale: f64,
    /// Offset \[mm\] (thresholding, blur).
    pub offset_mm: f64,
    /// Tilt of the image plane about the r1 axis \[deg\].
    pub tilt_deg: f64,
}

impl CameraBias {
    /// The camera's reading of radii that reach it with gains `g` (drift): per radius the
    /// gain, and the offset, of `r -> gain r + offset`.
    #[inline]
    pub fn reading(&self, g: [f64; 2]) -> ([f64; 2], f64) {
        let ct = self.tilt_deg.to_radians().cos();
        ([g[0] * self.scale, g[1] * self.scale * ct], self.offset_mm)
    }
}

const SCALE: EffectRow = effect_row!(
    CameraBias.scale, slot 9, None,
    "scale error of the measured radii",
    range(0.2, 5.0), fit(0.7, 1.4, Log, false)
);
const OFFSET_MM: EffectRow = effect_row!(
    CameraBias.offset_mm, slot 10, Some("mm"),
    "offset of the measured radii",
    range(-20.0, 20.0), fit(-3.0, 3.0, Sin, false)
);
const TILT_DEG: EffectRow = effect_row!(
    CameraBias.tilt_deg, slot 11, None,
    "tilt of the image plane about the r1 axis [deg] (foreshortens r2 by cos)",
    range(-80.0, 80.0), fit(0.0, 60.0, Sin, false)
);

/// A fit frees the offset only: a gain on each radius is the baseline's C_1, C_2 (refitted
/// with every candidate), so the scale and the cos(tilt) of r2 cannot be told from radii.
impl Effect for CameraBias {
    /// A perfect camera.
    const NEUTRAL: CameraBias = CameraBias {
        scale: 1.0,
        offset_mm: 0.0,
        tilt_deg: 0.0,
    };
    const STAGE: Stage = Stage::Observation;
    const AXIS: LearnedAxis = LearnedAxis::ZmMm;
    const ROWS: &'static [EffectRow] = &[SCALE, OFFSET_MM, TILT_DEG];

    fn fit_params(_: &DataContext) -> Vec<FitParam> {
        vec![FitParam::of_row(&OFFSET_MM)]
    }

    fn fit_neutral(_: &DataContext) -> Vec<f64> {
        vec![0.0]
    }

    fn fit_starts(_: &DataContext) -> Vec<Vec<f64>> {
        [-0.6, -0.2, 0.2, 0.6].map(|o| vec![o]).to_vec()
    }

    fn with_fit(self, vals: &[f64], _: &DataContext, _: &Model) -> CameraBias {
        match *vals {
            [offset_mm] => CameraBias { offset_mm, ..self },
            _ => self,
        }
    }
}
