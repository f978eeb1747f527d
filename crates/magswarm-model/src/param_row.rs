//! One row of the parameter registry: what a parameter is, its physical range, how a fit may
//! free it and how to read and write it on a [`Model`].
//!
//! The row types sit below both the parameter table ([`crate::registry`], which lists the
//! plant's rows and places the effects' by slot) and the effects ([`crate::effects`], each of
//! which declares its own rows): an effect's row names its effect by [`EffectKind`] alone, so
//! neither of the two needs the other to say what a row is.

use crate::effect_kind::EffectKind;
use crate::Model;

/// Which part of the model a parameter belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Group {
    /// Steady map (5)-(7) (`steady.*`): `identify` fits them to settled visit means.
    Steady,
    /// ODE (4) (`dynamics.*`): `identify` fits them to transient rows.
    Dynamic,
    /// Magnet and swarm geometry (`magnet.*`).
    Magnet,
    /// Units and numerical conventions of (7) (`conventions.*`).
    Conventions,
    /// Parameter of an unmodelled effect.
    Effect(EffectKind),
}

/// How an optimiser's unconstrained variable u maps onto a bounded parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Transform {
    /// theta = exp(u): strictly positive scale parameters.
    Log,
    /// theta = lo + (hi - lo) (1 + sin u) / 2 (MINUIT's double-bounded transform).
    Sin,
}

/// The physical range of a parameter: outside it the model file is rejected.
#[derive(Debug, Clone, Copy)]
pub enum Physical {
    /// Strictly positive.
    Positive,
    /// Inside `[lo, hi]`.
    Range(f64, f64),
    /// Inside `[lo, hi]` computed from the rest of the model (a bound that depends on
    /// another parameter, e.g. an offset that must not reach inside the magnet).
    Computed(fn(&Model) -> (f64, f64)),
}

/// How `identify` may fit a parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fit {
    /// Default lower bound of the fit.
    pub lo: f64,
    /// Default upper bound of the fit.
    pub hi: f64,
    /// Default transform.
    pub transform: Transform,
    /// True for the terms of the stiffness (7) that are power laws of the distance (a nearly
    /// collinear family: `identify` fixes them first when the fit is ill-conditioned).
    pub stiffness: bool,
}

/// One numeric parameter of the model.
#[derive(Debug, Clone, Copy)]
pub struct Param {
    /// Name: the seed's symbol where it has one; the FMU variable's name and the name
    /// `identify --free` takes.
    pub name: &'static str,
    /// JSON path in the model file (`steady.C_1`); errors of validation name it.
    pub path: &'static str,
    /// Part of the model.
    pub group: Group,
    /// FMI unit name (one of the FMU's unit definitions), None for dimensionless.
    pub unit: Option<&'static str>,
    /// One line for people (the FMU variable's description).
    pub description: &'static str,
    /// Physical range.
    pub physical: Physical,
    /// Fit bounds and transform; None: `identify` never frees it.
    pub fit: Option<Fit>,
    /// Exposed as an FMU parameter variable.
    pub fmu: bool,
    /// Read the value from a model.
    pub get: fn(&Model) -> f64,
    /// Write the value into a model.
    pub set: fn(&mut Model, f64),
}

/// A value outside its parameter's physical range (the caller names the parameter).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ValueError {
    /// NaN or infinite.
    #[error("must be finite (got {0})")]
    NotFinite(f64),
    /// Zero or negative where only positive values mean something.
    #[error("must be > 0 (got {0})")]
    NotPositive(f64),
    /// Outside `[lo, hi]`.
    #[error("out of range: {v} not in [{lo}, {hi}]")]
    OutOfRange {
        /// The value.
        v: f64,
        /// Lower bound.
        lo: f64,
        /// Upper bound.
        hi: f64,
    },
}

impl Param {
    /// Check the value in `m` against the physical range (the caller adds the path).
    pub fn check(&self, m: &Model) -> Result<(), ValueError> {
        let v = (self.get)(m);
        if !v.is_finite() {
            return Err(ValueError::NotFinite(v));
        }
        match self.physical {
            Physical::Positive if v <= 0.0 => Err(ValueError::NotPositive(v)),
            Physical::Positive => Ok(()),
            Physical::Range(lo, hi) => in_range(v, lo, hi),
            Physical::Computed(f) => {
                let (lo, hi) = f(m);
                in_range(v, lo, hi)
            }
        }
    }
}

fn in_range(v: f64, lo: f64, hi: f64) -> Result<(), ValueError> {
    if v < lo || v > hi {
        Err(ValueError::OutOfRange { v, lo, hi })
    } else {
        Ok(())
    }
}

/// A physical range `[lo, hi]`.
pub(crate) const fn range(lo: f64, hi: f64) -> Physical {
    Physical::Range(lo, hi)
}

/// Fit bounds and transform.
pub(crate) const fn fit(lo: f64, hi: f64, transform: Transform, stiffness: bool) -> Option<Fit> {
    Some(Fit {
        lo,
        hi,
        transform,
        stiffness,
    })
}
