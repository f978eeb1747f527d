//! The trait every effect implements, and the types it speaks in.

use std::fmt;

use serde::de::DeserializeOwned;
use serde::Serialize;

use super::{EffectKind, Effects, LearnedAxis};
use crate::param_row::Param;
use crate::Model;

/// Where in the model an effect acts (which outputs and which fits can see it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stage {
    /// The steady map (5)-(7) itself: steady values, ODE (4) (which approaches the map) and
    /// every output see it.
    SteadyMap,
    /// The approach to the map only: no change at steady state, so a fit to settled means
    /// cannot see it.
    Transient,
    /// The observed radii (the measurement), not the physical footprint: steady values as
    /// observed see it, the ODE (4) state does not.
    Observation,
}

/// An input axis of the data, for fit parameters that are locations along one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DataAxis {
    /// Magnet distance z_m.
    Z,
    /// Field frequency f.
    F,
}

/// One parameter of an effect's library form as a fit frees it (fit space, which may differ
/// from the model file's parameters: `phase_lag` is fitted at the data's mid-range field).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitParam {
    /// Name (the model file's field where the fit frees one directly).
    pub name: &'static str,
    /// Unit for people ("-" for dimensionless).
    pub unit: &'static str,
    /// Lower fit bound.
    pub lo: f64,
    /// Upper fit bound.
    pub hi: f64,
    /// Log transform (strictly positive scale) rather than the double-bounded sine.
    pub log: bool,
    /// For a location (step frequency, onset distance): the axis along which it must lie
    /// inside the data's range to describe a residual rather than a trend.
    pub location: Option<DataAxis>,
    /// Which bounds mean "the data want more than the form allows" when reached: (lower,
    /// upper). A bound where the effect vanishes (a share or rate at 0, an onset past the
    /// data) or a sharpness past what the grid resolves is not such a bound.
    pub flag: (bool, bool),
    /// Held at each start's value in the first, coarse stage of a multi-start fit (a
    /// location or a time scale: the parameters that make the cost piecewise smooth).
    pub scan: bool,
}

impl FitParam {
    /// A registry row freed as it is: its fit bounds and transform, its unit.
    pub fn of_row(row: &EffectRow) -> FitParam {
        let p = &row.param;
        let (lo, hi, log) = match p.fit {
            Some(f) => (f.lo, f.hi, f.transform == crate::param_row::Transform::Log),
            // Rows of effects are fittable (tested); a row without fit bounds is held.
            None => (0.0, 0.0, false),
        };
        FitParam {
            name: row.field,
            unit: p.unit.unwrap_or("-"),
            lo,
            hi,
            log,
            location: None,
            flag: (true, true),
            scan: false,
        }
    }
}

/// What an effect's library form needs to know of the data it is fitted to: bounds and starts
/// follow the data's own ranges, so a rig with another workspace is judged on its own.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DataContext {
    /// |B| at the middle of the data's z_m range \[T\].
    pub b_mid: f64,
    /// Smallest z_m of the data \[mm\].
    pub z_min: f64,
    /// Largest z_m of the data \[mm\].
    pub z_max: f64,
    /// Smallest f of the data \[Hz\].
    pub f_min: f64,
    /// Largest f of the data \[Hz\].
    pub f_max: f64,
    /// Smallest positive spacing of rows within a session \[s\].
    pub dt_min: f64,
    /// Longest session \[s\].
    pub t_span: f64,
    /// The baseline's lateral distance of the swarm from the rotation axis \[mm\].
    pub lateral_mm: f64,
    /// The distinct z_m levels of the data, ascending \[mm\].
    pub z_levels: Vec<f64>,
    /// The distinct f levels of the data, ascending \[Hz\].
    pub f_levels: Vec<f64>,
    /// How long each visit of an operating point lasts (time since its input change at its
    /// last row) \[s\], in any order.
    pub visit_durations_s: Vec<f64>,
}

impl DataContext {
    /// Midpoints between neighbouring levels.
    pub fn mids(levels: &[f64]) -> Vec<f64> {
        levels.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect()
    }
}

/// A registry row of an effect parameter, with the place it keeps in the FMU's value
/// references.
#[derive(Debug, Clone, Copy)]
pub struct EffectRow {
    /// Position among all effect rows in the registry (and so in the FMU's value
    /// references): fixed once published; a new row takes the next free slot. The registry
    /// refuses, at compile time, two rows in one slot or a gap.
    pub slot: usize,
    /// The field's name in the effect's section of the model file.
    pub field: &'static str,
    /// The row.
    pub param: Param,
}

/// Where an effect lives in [`Effects`]: implemented for every effect from the list of
/// effects ([`crate::effect_kind`], the one place an effect's name is written).
pub trait Slot: Sized {
    /// Which effect.
    const KIND: EffectKind;
    /// The effect in a model's effects, if on.
    fn of(fx: &Effects) -> Option<&Self>;
    /// The effect's place in a model's effects (None: off).
    fn of_mut(fx: &mut Effects) -> &mut Option<Self>;
}

/// An unmodelled effect: a model term that nests the seed's model, with everything a tool
/// needs to know about it in one place (docs/effects.md describes each).
pub trait Effect:
    Slot + Copy + PartialEq + fmt::Debug + Serialize + DeserializeOwned + Send + Sync + 'static
{
    /// Values with which the plant is the seed's model bit-exactly (what reading a parameter
    /// of an effect that is off gives, and what the parameters a fit does not free keep).
    const NEUTRAL: Self;
    /// Where in the model it acts.
    const STAGE: Stage;
    /// The physical axis its shape shows along (the axis of a learned term standing for it).
    const AXIS: LearnedAxis;
    /// Its parameters: their registry rows (unit, physical and fit bounds, accessors).
    const ROWS: &'static [EffectRow];

    /// The parameters a fit of its library form frees (fit space), bounds following the data.
    fn fit_params(ctx: &DataContext) -> Vec<FitParam>;

    /// Fit-space values with which it is the baseline exactly.
    fn fit_neutral(ctx: &DataContext) -> Vec<f64>;

    /// Starting points of a multi-start fit: a grid over its fit-space parameters, locations
    /// between the data's levels and time scales from the visits' durations.
    fn fit_starts(ctx: &DataContext) -> Vec<Vec<f64>>;

    /// `self` with fit-space values written into the parameters the fit frees (the others
    /// kept); `model` is the rest of the model (for parameters defined relative to it).
    /// Values of another length than [`Effect::fit_params`] leave it unchanged.
    fn with_fit(self, vals: &[f64], ctx: &DataContext, model: &Model) -> Self;

    /// Why the effect as fitted in `model` is not a plausible description of a residual of
    /// the data (empty: plausible), e.g. a location outside the data's range.
    fn implausible(model: &Model, ctx: &DataContext) -> Vec<String> {
        let _ = (model, ctx);
        Vec::new()
    }
}
