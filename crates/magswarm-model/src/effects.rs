//! Unmodelled effects as model terms: compact, physically motivated extensions of the plant
//! that the seed names (or that a real rig adds), each nesting the seed's model.
//!
//! An effect is switched on by its presence in the model file's `effects` section
//! (`magswarm-model/2`); absent means off. Every effect has neutral parameter values with
//! which the plant is the seed's model bit-exactly (tested), so the baseline is a special case
//! of every augmented model and likelihood-ratio style comparisons are nested.
//!
//! Where each acts (docs/effects.md has the physics and the equations):
//!
//! | effect | acts on | where in the code |
//! | --- | --- | --- |
//! | `phase_lag` | the swarm's rotation rate in Phi (6) and in the expansion of (4) | [`crate::steady::evaluate`], [`crate::dynamics::InputTerms`] |
//! | `cohesion_loss` | stiffness S_x, S_y (7) past an onset distance | [`crate::steady::evaluate`] |
//! | `centroid_offset` | where the field is evaluated (radial distance from the axis) | [`crate::steady::evaluate`] |
//! | `formation_lag` | a slow, possibly oscillating formation mode in parallel with (4) | [`crate::plant::Plant`] |
//! | `particle_drift` | the swarm's size over session time (plant time) | [`Effects::observe`] |
//! | `camera_bias` | the measurement: scale, offset, tilt foreshortening | [`Effects::observe`] |
//!
//! The first three change the steady map (5)-(7) itself, so the steady map, ODE (4) (whose
//! scheduled confinement targets the map) and every output see them. `formation_lag` is a
//! dynamic effect (no change at steady state). `particle_drift` and `camera_bias` act on the
//! observed radii: `Plant::outputs` and [`observed_steady`] apply them; the ODE state stays
//! the physical footprint.
//!
//! Parameter metadata (units, physical bounds, fit bounds) are rows of the parameter registry
//! ([`crate::registry`], group `Effect(name)`), so that model-file validation, the FMU's
//! parameter variables and `identify` see them; [`params_of`] and [`neutral`] read them.

#![allow(non_snake_case)]

use serde::{Deserialize, Serialize};

use crate::field::{FieldAtSwarm, MagnetConfig};
pub use crate::learned::{LearnedAxis, LearnedMode, LearnedTerm};
use crate::registry::{Group, Param};
use crate::steady::SteadyPoint;
use crate::Model;

/// Names of the effects, as in the model file and docs/effects.md.
pub const NAMES: [&str; 6] = [
    "phase_lag",
    "cohesion_loss",
    "formation_lag",
    "particle_drift",
    "centroid_offset",
    "camera_bias",
];

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

/// A slow formation mode in parallel with ODE (4).
///
/// A share `share` of the footprint forms through a second-order mode
/// `x'' + 2 zeta x'/tau + (x - r_ss)/tau^2 = 0` (vortex merging, particle recruitment;
/// oscillating for zeta < 1); the output is `(1 - share) r + share x`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FormationLag {
    /// Share of the footprint that forms through the slow mode [-].
    pub share: f64,
    /// Time scale of the slow mode 1/omega_n \[s\].
    pub tau_s: f64,
    /// Damping ratio of the slow mode [-] (< 1: oscillating formation).
    pub zeta: f64,
}

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

/// The swarm's centroid further from the rotation axis than the model's geometry says.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CentroidOffset {
    /// Extra radial distance of the centroid from the rotation axis \[mm\] (may be negative:
    /// closer to the axis).
    pub offset_mm: f64,
}

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

impl PhaseLag {
    /// Neutral values: step-out far above any frequency in use.
    pub const NEUTRAL: PhaseLag = PhaseLag {
        f_so_hz: 1.0e4,
        nu: 1.0,
        spread: 0.0,
    };

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

impl CohesionLoss {
    /// Neutral values: no fading.
    pub const NEUTRAL: CohesionLoss = CohesionLoss {
        z_c_mm: 18.5,
        k_per_mm2: 0.0,
    };

    /// Confinement factor c(z) and dc/dz_m [1/m] at z_m \[m\].
    #[inline]
    pub fn factor(&self, z_m: f64) -> (f64, f64) {
        let x = (z_m * 1e3 - self.z_c_mm).max(0.0);
        let c = (-self.k_per_mm2 * x * x).exp();
        (c, -2.0 * self.k_per_mm2 * x * c * 1e3)
    }
}

impl FormationLag {
    /// Neutral values: no share through the slow mode.
    pub const NEUTRAL: FormationLag = FormationLag {
        share: 0.0,
        tau_s: 10.0,
        zeta: 1.0,
    };

    /// The footprint radius of one axis \[mm\]: the ODE (4) radius `r` blended with the slow
    /// mode's `x` by the share that forms through it.
    #[inline]
    pub fn blend(&self, r: f64, x: f64) -> f64 {
        (1.0 - self.share) * r + self.share * x
    }

    /// Propagate the slow mode `(x, v)` of one axis by `h` seconds toward the target `r_ss`,
    /// exactly (the target is constant between input changes).
    pub fn propagate(&self, xv: [f64; 2], r_ss: f64, h: f64) -> [f64; 2] {
        let wn = 1.0 / self.tau_s;
        let a = [[0.0, 1.0], [-wn * wn, -2.0 * self.zeta * wn]];
        let e = expm2(a, h);
        let d = xv[0] - r_ss;
        [
            r_ss + e[0][0] * d + e[0][1] * xv[1],
            e[1][0] * d + e[1][1] * xv[1],
        ]
    }
}

/// exp(A h) of a real 2x2 matrix whose eigenvalues have non-positive real parts, in closed
/// form, without overflow for large h.
fn expm2(a: [[f64; 2]; 2], h: f64) -> [[f64; 2]; 2] {
    let s = 0.5 * (a[0][0] + a[1][1]);
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    let disc = s * s - det;
    // exp(A h) = c0 I + c1 A.
    let (c0, c1) = if disc > 1e-14 * s * s {
        let q = disc.sqrt();
        let (ep, em) = (((s + q) * h).exp(), ((s - q) * h).exp());
        let ch = 0.5 * (ep + em);
        let sh = 0.5 * (ep - em) / q;
        (ch - s * sh, sh)
    } else if disc < -1e-14 * s * s {
        let q = (-disc).sqrt();
        let es = (s * h).exp();
        let (sn, cs) = (q * h).sin_cos();
        (es * (cs - s * sn / q), es * sn / q)
    } else {
        let es = (s * h).exp();
        (es * (1.0 - s * h), es * h)
    };
    [
        [c0 + c1 * a[0][0], c1 * a[0][1]],
        [c1 * a[1][0], c0 + c1 * a[1][1]],
    ]
}

impl ParticleDrift {
    /// Neutral values: no drift.
    pub const NEUTRAL: ParticleDrift = ParticleDrift { rate_per_h: 0.0 };

    /// Size factor at session time t \[s\].
    #[inline]
    pub fn factor(&self, t: f64) -> f64 {
        (self.rate_per_h * t / 3600.0).exp()
    }
}

impl CentroidOffset {
    /// Neutral values: the centroid where the model's geometry puts it.
    pub const NEUTRAL: CentroidOffset = CentroidOffset { offset_mm: 0.0 };

    /// The magnet geometry with the centroid moved.
    #[inline]
    pub fn magnet(&self, m: &MagnetConfig) -> MagnetConfig {
        MagnetConfig {
            lateral_offset_m: (m.lateral_offset_m + self.offset_mm * 1e-3).abs(),
            ..*m
        }
    }
}

impl CameraBias {
    /// Neutral values: a perfect camera.
    pub const NEUTRAL: CameraBias = CameraBias {
        scale: 1.0,
        offset_mm: 0.0,
        tilt_deg: 0.0,
    };
}

/// Unmodelled effects switched on in the model (absent: off).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Effects {
    /// Step-out of the swarm rotation (rotation reversal / phase lag near f_off).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase_lag: Option<PhaseLag>,
    /// Weakening confinement toward z_off.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cohesion_loss: Option<CohesionLoss>,
    /// Slow or oscillating formation after an input change.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub formation_lag: Option<FormationLag>,
    /// Slow change of the swarm over a session.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub particle_drift: Option<ParticleDrift>,
    /// Swarm off the field axis.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub centroid_offset: Option<CentroidOffset>,
    /// Scale, offset or tilt of the measurement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera_bias: Option<CameraBias>,
    /// Learned shapes along effects' axes (`magswarm diagnose` writes them where an effect's
    /// shape on the rig is not its parametric form): see [`crate::learned`].
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub learned: Vec<LearnedTerm>,
}

impl Effects {
    /// True when no effect is switched on.
    pub fn is_empty(&self) -> bool {
        *self == Effects::default()
    }

    /// Names of the effects switched on, in [`NAMES`] order.
    pub fn enabled(&self) -> Vec<&'static str> {
        NAMES.iter().copied().filter(|n| self.is_on(n)).collect()
    }

    /// Whether the named effect is on, in its parametric form or as a learned term (false
    /// for an unknown name).
    pub fn is_on(&self, name: &str) -> bool {
        if self.learned.iter().any(|t| t.effect == name) {
            return true;
        }
        match name {
            "phase_lag" => self.phase_lag.is_some(),
            "cohesion_loss" => self.cohesion_loss.is_some(),
            "formation_lag" => self.formation_lag.is_some(),
            "particle_drift" => self.particle_drift.is_some(),
            "centroid_offset" => self.centroid_offset.is_some(),
            "camera_bias" => self.camera_bias.is_some(),
            _ => false,
        }
    }

    /// Switch the named effect on with its neutral parameters (no-op if already on).
    /// Returns false for an unknown name.
    pub fn switch_on(&mut self, name: &str) -> bool {
        match name {
            "phase_lag" => {
                self.phase_lag.get_or_insert(PhaseLag::NEUTRAL);
            }
            "cohesion_loss" => {
                self.cohesion_loss.get_or_insert(CohesionLoss::NEUTRAL);
            }
            "formation_lag" => {
                self.formation_lag.get_or_insert(FormationLag::NEUTRAL);
            }
            "particle_drift" => {
                self.particle_drift.get_or_insert(ParticleDrift::NEUTRAL);
            }
            "centroid_offset" => {
                self.centroid_offset.get_or_insert(CentroidOffset::NEUTRAL);
            }
            "camera_bias" => {
                self.camera_bias.get_or_insert(CameraBias::NEUTRAL);
            }
            _ => return false,
        }
        true
    }

    /// Switch the named effect off (its learned terms too). Returns false for an unknown name.
    pub fn switch_off(&mut self, name: &str) -> bool {
        self.learned.retain(|t| t.effect != name);
        match name {
            "phase_lag" => self.phase_lag = None,
            "cohesion_loss" => self.cohesion_loss = None,
            "formation_lag" => self.formation_lag = None,
            "particle_drift" => self.particle_drift = None,
            "centroid_offset" => self.centroid_offset = None,
            "camera_bias" => self.camera_bias = None,
            _ => return false,
        }
        true
    }

    /// True when an effect acts on the observed radii (drift, camera, a learned term over
    /// session time).
    #[inline]
    pub fn observes(&self) -> bool {
        self.particle_drift.is_some()
            || self.camera_bias.is_some()
            || self.learned.iter().any(|t| t.axis == LearnedAxis::TS)
    }

    /// Learned corrections over session time at t [s]: per radius, (gain, offset) of
    /// `r -> gain r + offset`, applied after drift and camera.
    #[inline]
    fn learned_time(&self, t: f64) -> ([f64; 2], [f64; 2]) {
        let (mut g, mut o) = ([1.0, 1.0], [0.0, 0.0]);
        for term in self.learned.iter().filter(|x| x.axis == LearnedAxis::TS) {
            let (v, _) = term.value(t);
            for i in 0..2 {
                match term.mode {
                    LearnedMode::Relative => {
                        g[i] *= 1.0 + v[i];
                        o[i] *= 1.0 + v[i];
                    }
                    _ => o[i] += v[i],
                }
            }
        }
        (g, o)
    }

    /// The learned corrections over the time since the last input change: `tau` \[s\] since
    /// it, `delta` the step of the observed steady map it made \[mm\]; added to the observed
    /// radii (zero when no term runs along that axis).
    #[inline]
    pub fn since_change(&self, tau: f64, delta: [f64; 2]) -> [f64; 2] {
        let mut out = [0.0; 2];
        for term in self
            .learned
            .iter()
            .filter(|x| x.axis == LearnedAxis::SinceChangeS)
        {
            let (v, _) = term.value(tau);
            for i in 0..2 {
                out[i] += v[i] * delta[i];
            }
        }
        out
    }

    /// True when a learned term runs along the time since the last input change.
    pub fn tracks_changes(&self) -> bool {
        self.learned
            .iter()
            .any(|x| x.axis == LearnedAxis::SinceChangeS)
    }

    /// Measurement map at session time t \[s\]: observed `r_i = gain_i r_i + offset_i` (drift,
    /// camera, then the learned terms over session time).
    #[inline]
    pub fn observation(&self, t: f64) -> ([f64; 2], [f64; 2]) {
        let mut g = [1.0, 1.0];
        let mut o = 0.0;
        if let Some(d) = self.particle_drift {
            let f = d.factor(t);
            g = [f, f];
        }
        if let Some(c) = self.camera_bias {
            let ct = c.tilt_deg.to_radians().cos();
            g = [g[0] * c.scale, g[1] * c.scale * ct];
            o = c.offset_mm;
        }
        let (lg, lo) = self.learned_time(t);
        (
            [lg[0] * g[0], lg[1] * g[1]],
            [lg[0] * o + lo[0], lg[1] * o + lo[1]],
        )
    }

    /// Observed radii \[mm\] of physical radii `r` \[mm\] at session time t \[s\].
    #[inline]
    pub fn observe(&self, r: [f64; 2], t: f64) -> [f64; 2] {
        if !self.observes() {
            return r;
        }
        let (g, o) = self.observation(t);
        [g[0] * r[0] + o[0], g[1] * r[1] + o[1]]
    }

    /// A steady point as observed at session time t \[s\] (radii and their Jacobian).
    pub fn observe_steady(&self, sp: &SteadyPoint, t: f64) -> SteadyPoint {
        if !self.observes() {
            return *sp;
        }
        let (g, o) = self.observation(t);
        let mut out = *sp;
        out.r1 = g[0] * sp.r1 + o[0];
        out.r2 = g[1] * sp.r2 + o[1];
        for j in 0..2 {
            out.jac[0][j] = g[0] * sp.jac[0][j];
            out.jac[1][j] = g[1] * sp.jac[1][j];
        }
        out
    }
}

/// The steady map (5)-(7) with every effect, as observed at session time t \[s\]:
/// what a measurement after complete formation gives.
pub fn observed_steady(model: &Model, z_m: f64, omega: f64, t: f64) -> SteadyPoint {
    let sp = crate::steady::evaluate(model, z_m, omega);
    model.effects.observe_steady(&sp, t)
}

/// The registry rows of one effect's parameters (name `effect.field`, unit, physical and fit
/// bounds, accessors): see [`crate::registry`].
pub fn params_of(effect: &str) -> impl Iterator<Item = &'static Param> + '_ {
    crate::registry::PARAMS
        .iter()
        .filter(move |p| matches!(p.group, Group::Effect(e) if e == effect))
}

/// The neutral value of an effect parameter (with it the effect is the seed's model).
pub fn neutral(p: &Param) -> f64 {
    let mut m = Model::paper();
    m.effects = Effects::default();
    (p.get)(&m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::registry::Physical;

    #[test]
    fn registry_covers_every_effect_and_neutral_is_inside_bounds() {
        for n in NAMES {
            assert!(params_of(n).count() > 0, "{n} has no parameters");
        }
        for p in crate::registry::PARAMS {
            let Group::Effect(e) = p.group else { continue };
            assert!(NAMES.contains(&e));
            assert_eq!(p.path, format!("effects.{}", p.name));
            let v = neutral(p);
            let Physical::Range(lo, hi) = p.physical else {
                panic!("{}: effect bounds are ranges", p.name)
            };
            assert!(lo <= v && v <= hi, "{}", p.name);
            let f = p.fit.expect("effect parameters are fittable");
            assert!(lo <= f.lo && f.hi <= hi);
            let mut m = Model::paper();
            assert!(!m.effects.is_on(e));
            (p.set)(&mut m, f.hi);
            assert!(m.effects.is_on(e));
            assert_eq!((p.get)(&m), f.hi);
        }
    }

    #[test]
    fn expm2_matches_series() {
        for a in [
            [[0.0, 1.0], [-4.0, -0.4]],
            [[0.0, 1.0], [-1.0, -2.0]],
            [[0.0, 1.0], [-1.0, -5.0]],
        ] {
            let h = 0.7;
            // Taylor series with many terms.
            let mut term = [[1.0, 0.0], [0.0, 1.0]];
            let mut sum = term;
            for k in 1..60 {
                let mut n = [[0.0; 2]; 2];
                for i in 0..2 {
                    for j in 0..2 {
                        n[i][j] = (term[i][0] * a[0][j] + term[i][1] * a[1][j]) * h / k as f64;
                    }
                }
                term = n;
                for i in 0..2 {
                    for j in 0..2 {
                        sum[i][j] += term[i][j];
                    }
                }
            }
            let e = expm2(a, h);
            for i in 0..2 {
                for j in 0..2 {
                    assert!((e[i][j] - sum[i][j]).abs() < 1e-12, "{a:?} {e:?} {sum:?}");
                }
            }
        }
        // Large steps neither overflow nor lose the steady state.
        let e = expm2([[0.0, 1.0], [-1e-4, -20.0]], 1e7);
        assert!(e.iter().flatten().all(|v| v.is_finite()));
    }

    #[test]
    fn formation_mode_is_step_size_independent_and_settles() {
        let f = FormationLag {
            share: 0.5,
            tau_s: 3.0,
            zeta: 0.3,
        };
        let mut a = [5.0, 0.0];
        for _ in 0..100 {
            a = f.propagate(a, 8.0, 0.1);
        }
        let b = f.propagate([5.0, 0.0], 8.0, 10.0);
        assert!((a[0] - b[0]).abs() < 1e-10 && (a[1] - b[1]).abs() < 1e-10);
        // Underdamped: overshoots the target.
        let peak = (0..200)
            .map(|i| f.propagate([5.0, 0.0], 8.0, i as f64 * 0.1)[0])
            .fold(f64::MIN, f64::max);
        assert!(peak > 8.5, "peak {peak}");
        let late = f.propagate([5.0, 0.0], 8.0, 400.0);
        assert!((late[0] - 8.0).abs() < 1e-9);
    }
}
