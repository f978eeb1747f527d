//! Unmodelled effects as model terms: compact, physically motivated extensions of the plant
//! that the seed names (or that a real rig adds), each nesting the seed's model.
//!
//! **One effect is one type in one file** (`effects/<name>.rs`) implementing [`Effect`]: its
//! parameters with units, physical and fit bounds (the registry's rows are derived from them),
//! its neutral value, where it acts, the axis its shape shows along, and its library form for
//! a fit (what it frees, neutral fit values, start grid, how fitted values are written back,
//! when a fit is implausible). Its physics (the terms it adds to (4)-(7)) are the type's own
//! methods, called where the model evaluates that stage. The effect's name is written once,
//! in the list of effects ([`crate::effect_kind`], which makes [`EffectKind`] and, here, the
//! fields of [`Effects`]): that is the model file's boundary (the `effects` section's keys,
//! the registry's names `<effect>.<field>`); code everywhere else names an effect by its type
//! or [`EffectKind`], so a misspelt effect does not compile.
//!
//! **Adding an effect**: a file here with its type and its `impl Effect`, one line in the list
//! of effects ([`crate::effect_kind`]), and its physics hooked into the stage it acts on
//! (`steady`, `dynamics`, `plant` or [`Effects::observation`]). Its parameter rows take the
//! next free value-reference slots.
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
//! ([`crate::registry`], group `Effect(kind)`), so that model-file validation, the FMU's
//! parameter variables and `identify` see them; [`crate::registry::params_of`] and [`neutral`]
//! read them. The rows' types are [`crate::param_row`]'s (the registry only places the rows
//! the effects declare, so the effects need nothing of it).

use serde::{Deserialize, Serialize};

use crate::effect_kind::for_each_effect;
pub use crate::effect_kind::{EffectKind, UnknownEffect, NAMES};
pub use crate::learned::{LearnedAxis, LearnedMode, LearnedTerm};
use crate::param_row::Param;
use crate::steady::SteadyPoint;
use crate::Model;

/// A registry row of an effect parameter: name `<effect>.<field>`, path
/// `effects.<effect>.<field>`, description prefixed with the effect's name, accessors that
/// read the neutral value of an effect that is off and switch it on when written.
macro_rules! effect_row {
    ($ty:ident . $field:ident, slot $slot:literal, $unit:expr, $desc:literal, $physical:expr, $fit:expr $(,)?) => {
        $crate::effects::EffectRow {
            slot: $slot,
            field: stringify!($field),
            param: $crate::param_row::Param {
                name: $crate::conststr::concat_str!(
                    <$ty as $crate::effects::Slot>::KIND.name(),
                    ".",
                    stringify!($field)
                ),
                path: $crate::conststr::concat_str!(
                    "effects.",
                    <$ty as $crate::effects::Slot>::KIND.name(),
                    ".",
                    stringify!($field)
                ),
                group: $crate::param_row::Group::Effect(<$ty as $crate::effects::Slot>::KIND),
                unit: $unit,
                description: $crate::conststr::concat_str!(
                    <$ty as $crate::effects::Slot>::KIND.name(),
                    ": ",
                    $desc
                ),
                physical: $physical,
                fit: $fit,
                fmu: true,
                get: |m: &$crate::Model| {
                    <$ty as $crate::effects::Slot>::of(&m.effects)
                        .copied()
                        .unwrap_or(<$ty as $crate::effects::Effect>::NEUTRAL)
                        .$field
                },
                set: |m: &mut $crate::Model, v: f64| {
                    <$ty as $crate::effects::Slot>::of_mut(&mut m.effects)
                        .get_or_insert(<$ty as $crate::effects::Effect>::NEUTRAL)
                        .$field = v;
                },
            },
        }
    };
}

mod camera_bias;
mod centroid_offset;
mod cohesion_loss;
mod effect;
mod formation_lag;
mod particle_drift;
mod phase_lag;

pub use camera_bias::CameraBias;
pub use centroid_offset::CentroidOffset;
pub use cohesion_loss::CohesionLoss;
pub use formation_lag::FormationLag;
pub use particle_drift::ParticleDrift;
pub use phase_lag::PhaseLag;

pub use effect::{DataAxis, DataContext, Effect, EffectRow, FitParam, Slot, Stage};

/// What the list of effects ([`crate::effect_kind`]) makes of each effect type here: the
/// effect-type side of [`EffectKind`] (stage, axis, rows, library form), the fields of
/// [`Effects`] (the model file's `effects` section), each effect's [`Slot`] and `ROWS`.
macro_rules! effect_list {
    ($($(#[$doc:meta])* $name:ident : $ty:ident),+ $(,)?) => {
        impl EffectKind {
            /// Where in the model it acts.
            pub fn stage(self) -> Stage {
                match self {
                    $(EffectKind::$ty => <$ty as Effect>::STAGE,)+
                }
            }

            /// The physical axis its shape shows along.
            pub fn axis(self) -> LearnedAxis {
                match self {
                    $(EffectKind::$ty => <$ty as Effect>::AXIS,)+
                }
            }

            /// Its registry rows, in the effect's field order.
            pub fn rows(self) -> &'static [EffectRow] {
                match self {
                    $(EffectKind::$ty => <$ty as Effect>::ROWS,)+
                }
            }

            /// [`Effect::fit_params`].
            pub fn fit_params(self, ctx: &DataContext) -> Vec<FitParam> {
                match self {
                    $(EffectKind::$ty => <$ty as Effect>::fit_params(ctx),)+
                }
            }

            /// [`Effect::fit_neutral`].
            pub fn fit_neutral(self, ctx: &DataContext) -> Vec<f64> {
                match self {
                    $(EffectKind::$ty => <$ty as Effect>::fit_neutral(ctx),)+
                }
            }

            /// [`Effect::fit_starts`].
            pub fn fit_starts(self, ctx: &DataContext) -> Vec<Vec<f64>> {
                match self {
                    $(EffectKind::$ty => <$ty as Effect>::fit_starts(ctx),)+
                }
            }

            /// Switch the effect on in `m` (if off, neutral) and write fit-space values into
            /// the parameters its fit frees ([`Effect::with_fit`]).
            pub fn set_fit(self, vals: &[f64], ctx: &DataContext, m: &mut Model) {
                match self {
                    $(EffectKind::$ty => {
                        let cur = m.effects.$name.unwrap_or(<$ty as Effect>::NEUTRAL);
                        let new = cur.with_fit(vals, ctx, m);
                        m.effects.$name = Some(new);
                    })+
                }
            }

            /// [`Effect::implausible`].
            pub fn implausible(self, model: &Model, ctx: &DataContext) -> Vec<String> {
                match self {
                    $(EffectKind::$ty => <$ty as Effect>::implausible(model, ctx),)+
                }
            }
        }

        /// Unmodelled effects switched on in the model (absent: off): the model file's
        /// `effects` section.
        #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct Effects {
            $(
                $(#[$doc])*
                #[serde(default, skip_serializing_if = "Option::is_none")]
                pub $name: Option<$ty>,
            )+
            /// Learned shapes along effects' axes (`magswarm diagnose` writes them where an
            /// effect's shape on the rig is not its parametric form): see [`crate::learned`].
            #[serde(default, skip_serializing_if = "Vec::is_empty")]
            pub learned: Vec<LearnedTerm>,
        }

        $(
            impl Slot for $ty {
                const KIND: EffectKind = EffectKind::$ty;
                fn of(fx: &Effects) -> Option<&Self> {
                    fx.$name.as_ref()
                }
                fn of_mut(fx: &mut Effects) -> &mut Option<Self> {
                    &mut fx.$name
                }
            }
        )+

        impl Effects {
            /// Whether the effect is on, in its parametric form or as a learned term.
            pub fn is_on(&self, kind: EffectKind) -> bool {
                if self.learned.iter().any(|t| t.effect == kind.name()) {
                    return true;
                }
                match kind {
                    $(EffectKind::$ty => self.$name.is_some(),)+
                }
            }

            /// Switch the effect on with its neutral parameters (no-op if already on).
            pub fn switch_on(&mut self, kind: EffectKind) {
                match kind {
                    $(EffectKind::$ty => {
                        self.$name.get_or_insert(<$ty as Effect>::NEUTRAL);
                    })+
                }
            }

            /// Switch the effect off (its learned terms too).
            pub fn switch_off(&mut self, kind: EffectKind) {
                self.learned.retain(|t| t.effect != kind.name());
                match kind {
                    $(EffectKind::$ty => self.$name = None,)+
                }
            }
        }

        /// Every effect's registry rows, in list order (the registry places them by slot).
        pub(crate) const ROWS: [&[EffectRow]; NAMES.len()] = [$(<$ty as Effect>::ROWS),+];
    };
}

for_each_effect!(effect_list);

/// Number of effect rows in the registry.
pub(crate) const fn row_count() -> usize {
    let mut n = 0;
    let mut i = 0;
    while i < ROWS.len() {
        n += ROWS[i].len();
        i += 1;
    }
    n
}

impl Effects {
    /// True when no effect is switched on.
    pub fn is_empty(&self) -> bool {
        *self == Effects::default()
    }

    /// The effects switched on (parametric or learned), in list order.
    pub fn enabled(&self) -> Vec<EffectKind> {
        EffectKind::ALL
            .into_iter()
            .filter(|k| self.is_on(*k))
            .collect()
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
                out[i] += v[i] * delta[i] * term.step_share(delta[i]);
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
            (g, o) = c.reading(g);
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

/// The neutral value of an effect parameter (with it the effect is the seed's model).
pub fn neutral(p: &Param) -> f64 {
    let mut m = Model::paper();
    m.effects = Effects::default();
    (p.get)(&m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neutral_fit_values_give_the_neutral_effect_output() {
        // Writing an effect's neutral fit-space values into a model leaves the plant the
        // seed's model: the same steady radii as with the effect off.
        let ctx = DataContext {
            b_mid: 0.05,
            z_min: 3.5,
            z_max: 23.5,
            f_min: 1.0,
            f_max: 10.0,
            dt_min: 1.0,
            t_span: 600.0,
            lateral_mm: 6.1,
            z_levels: vec![3.5, 8.5, 13.5, 18.5, 23.5],
            f_levels: (1..=10).map(f64::from).collect(),
            visit_durations_s: vec![20.0, 25.0, 30.0],
        };
        for k in EffectKind::ALL {
            let params = k.fit_params(&ctx);
            let neutral = k.fit_neutral(&ctx);
            assert_eq!(params.len(), neutral.len(), "{k}");
            for s in k.fit_starts(&ctx) {
                assert_eq!(s.len(), params.len(), "{k}");
            }
            let mut m = Model::paper();
            k.set_fit(&neutral, &ctx, &mut m);
            assert!(m.effects.is_on(k));
            for (z, f) in crate::seed_grid() {
                let a = observed_steady(&Model::paper(), z, crate::hz_to_rad_s(f), 100.0);
                let b = observed_steady(&m, z, crate::hz_to_rad_s(f), 100.0);
                assert!(
                    (a.r1 - b.r1).abs() < 1e-9 && (a.r2 - b.r2).abs() < 1e-9,
                    "{k}"
                );
            }
        }
    }
}
