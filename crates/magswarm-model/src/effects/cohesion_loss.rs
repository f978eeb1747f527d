//! `cohesion_loss`: confinement that fades past an onset distance (docs/effects.md).

use serde::{Deserialize, Serialize};

use super::{DataAxis, DataContext, Effect, EffectRow, FitParam, LearnedAxis, Stage};
use crate::param_row::{fit, range, Transform::Sin};
use crate::Model;

/// Confinement that fades past an onset distance (weakening cohesion toward z_off).
///
/// `S_i -> S_i c(z)`, `c(z) = exp(-k ((z_m - z_c)_+)^2)` with z in mm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CohesionLoss {
    /// Onset distance z_c \[mm\].
    pub z_c_mm: f64,
    /// Fading rate k [1/mm^2]; the fading length is 1/sqrt(k).
    pub k_per_mm2: f64,
}

impl CohesionLoss {
    /// Confinement factor c(z) and dc/dz_m [1/m] at z_m \[m\].
    #[inline]
    pub fn factor(&self, z_m: f64) -> (f64, f64) {
        let x = (z_m * 1e3 - self.z_c_mm).max(0.0);
        let c = (-self.k_per_mm2 * x * x).exp();
        (c, -2.0 * self.k_per_mm2 * x * c * 1e3)
    }
}

const Z_C_MM: EffectRow = effect_row!(
    CohesionLoss.z_c_mm, slot 2, Some("mm"),
    "distance past which the confinement fades",
    range(-20.0, 100.0), fit(3.5, 23.5, Sin, false)
);
const K_PER_MM2: EffectRow = effect_row!(
    CohesionLoss.k_per_mm2, slot 3, None,
    "fading rate of the confinement [1/mm2] (fading length 1/sqrt(k))",
    range(0.0, 100.0), fit(0.0, 1.0, Sin, false)
);

impl Effect for CohesionLoss {
    /// No fading (k = 0: c = exp(-0) = 1 exactly).
    const NEUTRAL: CohesionLoss = CohesionLoss {
        z_c_mm: 18.5,
        k_per_mm2: 0.0,
    };
    const STAGE: Stage = Stage::SteadyMap;
    const AXIS: LearnedAxis = LearnedAxis::ZmMm;
    const ROWS: &'static [EffectRow] = &[Z_C_MM, K_PER_MM2];

    fn fit_params(ctx: &DataContext) -> Vec<FitParam> {
        let span_z = (ctx.z_max - ctx.z_min).max(1.0);
        vec![
            FitParam {
                lo: ctx.z_min - 0.5 * span_z,
                hi: ctx.z_max,
                location: Some(DataAxis::Z),
                // At the upper bound the fade starts past the data: no effect.
                flag: (true, false),
                scan: true,
                ..FitParam::of_row(&Z_C_MM)
            },
            FitParam {
                // From a fading length of twice the span (barely visible) to 0.3 mm (a step
                // sharper than any grid resolves, so not a misfit at its bound).
                lo: 0.25 / (span_z * span_z),
                hi: 10.0,
                log: true,
                flag: (false, false),
                unit: "1/mm^2",
                ..FitParam::of_row(&K_PER_MM2)
            },
        ]
    }

    fn fit_neutral(ctx: &DataContext) -> Vec<f64> {
        // Onset at the data's largest z_m: (z - z_c)_+ = 0 everywhere.
        vec![ctx.z_max, 0.1]
    }

    fn fit_starts(ctx: &DataContext) -> Vec<Vec<f64>> {
        let mut locs = DataContext::mids(&ctx.z_levels);
        locs.insert(0, ctx.z_min);
        let mut v = Vec::new();
        for zc in locs {
            let len = (ctx.z_max - zc).max(0.5);
            for k in [0.3, 3.0] {
                v.push(vec![zc, k / (len * len)]);
            }
        }
        v
    }

    fn with_fit(self, vals: &[f64], _: &DataContext, _: &Model) -> CohesionLoss {
        match *vals {
            [z_c_mm, k_per_mm2] => CohesionLoss { z_c_mm, k_per_mm2 },
            _ => self,
        }
    }

    /// A fade that starts before the smallest z_m of the data is a trend over the whole
    /// range, not a loss of cohesion toward its end.
    fn implausible(model: &Model, ctx: &DataContext) -> Vec<String> {
        match model.effects.cohesion_loss {
            Some(c) if c.z_c_mm < ctx.z_min || c.z_c_mm >= ctx.z_max => vec![format!(
                "onset z_c = {:.3} mm outside the data's z_m range [{}, {}) mm",
                c.z_c_mm, ctx.z_min, ctx.z_max
            )],
            _ => Vec::new(),
        }
    }
}
