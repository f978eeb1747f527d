//! `phase_lag`: step-out of the swarm rotation above a field-dependent frequency
//! (docs/effects.md).

use serde::{Deserialize, Serialize};

use super::{DataAxis, DataContext, Effect, EffectRow, FitParam, LearnedAxis, Stage};
use crate::field::FieldAtSwarm;
use crate::param_row::{fit, range, Transform::Log, Transform::Sin};
use crate::Model;

/// Step-out of the swarm's rotation above a field-dependent frequency.
///
/// Below the step-out frequency `f_so(z) = f_so_hz (B(z)/B_ref)^nu` the swarm follows the
/// field (rotation rate |omega|); above it the swarm slips and its average rotation rate is
/// that of an overdriven synchronous rotor, `omega - sqrt(omega^2 - omega_so^2)`. That rate
/// replaces |omega| in Phi (6) and in the expansion term of (4).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhaseLag {
    /// Step-out frequency at the field B_ref \[Hz\].
    pub f_so_hz: f64,
    /// Exponent of the field in the step-out frequency [-] (1: magnetic torque ~ B).
    pub nu: f64,
    /// Spread of the step-out frequency over the swarm's particles and chains: the SD of
    /// ln f_so [-] (0: one sharp step-out; absent in a model file written before it
    /// existed: 0).
    #[serde(default)]
    pub spread: f64,
}

/// Nodes and weights (normalised to 1) of 7-point Gauss-Hermite quadrature for the standard
/// normal distribution: the average over a log-normal spread of step-out frequencies.
const GH7: [(f64, f64); 7] = [
    (-3.750439717725742, 0.000548268855972),
    (-2.366759410734541, 0.030757123967586),
    (-1.154405394739968, 0.240123178605013),
    (0.0, 0.457142857142857),
    (1.154405394739968, 0.240123178605013),
    (2.366759410734541, 0.030757123967586),
    (3.750439717725742, 0.000548268855972),
];

impl PhaseLag {
    /// Effective normalised rotation rate of the swarm and its derivatives:
    /// `(w_eff, dw_eff/domega, dw_eff/dz_m)`, given `w = |omega|/omega_ref` and dw/domega.
    #[inline]
    pub fn effective(
        &self,
        model: &Model,
        w: f64,
        dw: f64,
        field: &FieldAtSwarm,
    ) -> (f64, f64, f64) {
        let bn = field.b / model.steady.B_ref;
        let w_so = self.f_so_hz / model.steady.f_ref * bn.powf(self.nu);
        // d ln w_so / dz_m: the same for every particle of the spread.
        let dln_dz = self.nu * field.db_dz / field.b;
        if self.spread <= 0.0 {
            return adler(w, dw, w_so, dln_dz);
        }
        // A swarm whose particles step out over a spread of frequencies rotates at the
        // average of their rates: the corner at w = w_so is rounded.
        let mut acc = (0.0, 0.0, 0.0);
        for (x, p) in GH7 {
            let r = adler(w, dw, w_so * (self.spread * x).exp(), dln_dz);
            acc = (acc.0 + p * r.0, acc.1 + p * r.1, acc.2 + p * r.2);
        }
        acc
    }

    /// The step-out frequency \[Hz\] at z_m \[mm\] in `model` (its field, with every effect
    /// that moves it): `f_so_hz (B(z_m)/B_ref)^nu`.
    pub fn step_out_hz(&self, model: &Model, z_mm: f64) -> f64 {
        let b = field_b(model, z_mm) / model.steady.B_ref;
        self.f_so_hz * b.powf(self.nu)
    }
}

/// |B| at a z_m \[mm\] in a model \[T\].
fn field_b(model: &Model, z_mm: f64) -> f64 {
    crate::steady::evaluate(model, z_mm * 1e-3, 1.0).field.b
}

/// The average rotation rate of a rotor driven at w with step-out rate w_so (Adler):
/// `(w_eff, dw_eff/domega, dw_eff/dz_m)` given dw/domega and d ln w_so / dz_m.
#[inline]
fn adler(w: f64, dw: f64, w_so: f64, dln_dz: f64) -> (f64, f64, f64) {
    // Not above step-out (or a NaN rate): the swarm follows the drive.
    if w.partial_cmp(&w_so) != Some(std::cmp::Ordering::Greater) {
        return (w, dw, 0.0);
    }
    let s = (w * w - w_so * w_so).sqrt();
    let w_eff = w - s;
    // The slope is infinite at step-out itself; keep it finite for Newton and Jacobians.
    let sd = s.max(1e-6 * w);
    let dw_eff_dw = 1.0 - w / sd;
    let dw_eff_dwso = w_so / sd;
    (w_eff, dw_eff_dw * dw, dw_eff_dwso * w_so * dln_dz)
}

const F_SO_HZ: EffectRow = effect_row!(
    PhaseLag.f_so_hz, slot 0, Some("Hz"),
    "step-out frequency of the swarm rotation at the field B_ref",
    range(0.1, 1.0e6), fit(2.0, 1.0e4, Log, false)
);
const NU: EffectRow = effect_row!(
    PhaseLag.nu, slot 1, None,
    "field exponent of the step-out frequency",
    range(0.0, 4.0), fit(0.0, 3.0, Sin, false)
);
const SPREAD: EffectRow = effect_row!(
    PhaseLag.spread, slot 12, None,
    "spread of the step-out frequency over the particles (SD of ln f_so)",
    range(0.0, 3.0), fit(0.0, 1.5, Sin, false)
);

/// The library form is fitted at the data's mid-range field: `f_mid` \[Hz\] (the step-out
/// frequency there), `nu`, `spread`, written back as `f_so_hz = f_mid (B_ref / B_mid)^nu`.
/// Fitting at mid-range rather than at B_ref keeps the step-out location and its field
/// exponent nearly uncorrelated (a better-conditioned fit), and lets the plausibility rule
/// ask the question that matters: does the step-out lie inside the frequencies measured?
impl Effect for PhaseLag {
    /// Step-out far above any frequency in use.
    const NEUTRAL: PhaseLag = PhaseLag {
        f_so_hz: 1.0e4,
        nu: 1.0,
        spread: 0.0,
    };
    const STAGE: Stage = Stage::SteadyMap;
    const AXIS: LearnedAxis = LearnedAxis::FHz;
    const ROWS: &'static [EffectRow] = &[F_SO_HZ, NU, SPREAD];

    fn fit_params(ctx: &DataContext) -> Vec<FitParam> {
        vec![
            FitParam {
                name: "f_mid",
                unit: "Hz",
                lo: (0.3 * ctx.f_min).max(0.05),
                hi: 3.0 * ctx.f_max,
                log: true,
                location: Some(DataAxis::F),
                // At the upper bound the step-out lies past the data: no effect.
                flag: (true, false),
                scan: true,
            },
            FitParam {
                // nu = 0 (a step-out independent of the field) is a physical limit, not a
                // misfit.
                flag: (false, true),
                ..FitParam::of_row(&NU)
            },
            FitParam {
                // 0 (one sharp step-out) is a physical limit, not a misfit.
                flag: (false, true),
                ..FitParam::of_row(&SPREAD)
            },
        ]
    }

    fn fit_neutral(ctx: &DataContext) -> Vec<f64> {
        // Step-out above every frequency of the data at every field: w_eff = w.
        vec![3.0 * ctx.f_max, 0.0, 0.0]
    }

    fn fit_starts(ctx: &DataContext) -> Vec<Vec<f64>> {
        // A step-out between two measured frequencies (at mid-range field), or just below
        // the lowest.
        let mut locs = DataContext::mids(&ctx.f_levels);
        locs.insert(0, 0.8 * ctx.f_min);
        let mut v = Vec::new();
        for f in locs {
            for nu in [0.3, 1.5] {
                v.push(vec![f, nu, 0.3]);
            }
        }
        v
    }

    fn with_fit(self, vals: &[f64], ctx: &DataContext, model: &Model) -> PhaseLag {
        let &[f_mid, nu, spread] = vals else {
            return self;
        };
        let b = (ctx.b_mid / model.steady.B_ref).max(1e-300);
        PhaseLag {
            f_so_hz: f_mid * b.powf(-nu),
            nu,
            spread,
        }
    }

    /// A step-out that no measured frequency reaches, or one below every measured frequency
    /// at every field, is a trend over the whole grid, not a step-out.
    fn implausible(model: &Model, ctx: &DataContext) -> Vec<String> {
        let Some(pl) = model.effects.phase_lag else {
            return Vec::new();
        };
        let (a, b) = (
            pl.step_out_hz(model, ctx.z_min),
            pl.step_out_hz(model, ctx.z_max),
        );
        let (lo, hi) = (a.min(b), a.max(b));
        if hi < ctx.f_min || lo > ctx.f_max {
            vec![format!(
                "step-out frequency {lo:.3}-{hi:.3} Hz over the data's z_m outside the \
                 measured frequencies [{}, {}] Hz",
                ctx.f_min, ctx.f_max
            )]
        } else {
            Vec::new()
        }
    }
}
