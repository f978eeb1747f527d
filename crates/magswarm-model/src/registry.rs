//! The parameter registry: one table of every numeric parameter of the plant model.
//!
//! Each row says what a parameter is (name, JSON path in the model file, group, unit,
//! description), which values are physical (checked by [`Model::validate`]), how `identify`
//! may fit it (bounds and transform, or not at all), and how to read and write it on a
//! [`Model`]. The consumers iterate over this table instead of keeping lists of their own:
//!
//! - the model file's validation ([`Model::validate`] checks every row's physical bounds);
//! - the FMU's parameter variables (`magswarm-fmu`: value reference `PARAM_BASE + i` for the
//!   i-th row with `fmu: true`, name, unit, description and start value from the row);
//! - `identify`'s free and fixed sets (every row with a [`Fit`]).
//!
//! **Adding a parameter** is one new row plus its field in the model: a plant parameter's row
//! goes here (`BASE`, with its field in `Model` or `params`), an effect parameter's row goes
//! into its effect's file ([`crate::effects::Effect::ROWS`], group [`Group::Effect`], with
//! the next free slot). It then appears in the FMU, in validation and in `identify` by itself.
//! `tests/registry.rs` fails when a row is missing from any consumer or its accessor does not
//! match its JSON path.
//!
//! The order of [`PARAMS`] is the FMU's value-reference order: the plant's rows in `BASE`
//! order, then the effects' rows by slot. Do not reorder rows or move slots.

use crate::effects::{self, EffectKind};
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

/// The swarm plane must stay below the magnet: z_offset above -0.99 magnet radii.
fn z_offset_bounds(m: &Model) -> (f64, f64) {
    (-m.magnet.radius_m * 0.99, 1.0)
}

use Physical::Positive;
use Transform::{Log, Sin};

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

macro_rules! param {
    ($name:literal, $sec:ident . $field:ident, $group:ident, $unit:expr, $desc:literal,
     $physical:expr, $fit:expr $(, fmu: $fmu:expr)?) => {
        Param {
            name: $name,
            path: concat!(stringify!($sec), ".", stringify!($field)),
            group: Group::$group,
            unit: $unit,
            description: $desc,
            physical: $physical,
            fit: $fit,
            fmu: param!(@fmu $($fmu)?),
            get: |m: &Model| m.$sec.$field,
            set: |m: &mut Model, v: f64| m.$sec.$field = v,
        }
    };
    (@fmu) => { true };
    (@fmu $fmu:expr) => { $fmu };
}

/// The plant's own parameters (steady map, ODE (4), magnet, conventions), in the FMU's
/// value-reference order.
#[rustfmt::skip]
const BASE: &[Param] = &[
    param!("C_1", steady.C_1, Steady, Some("mm"), "axis gain of r1 (5) (Table I)", Positive, fit(1e-3, 1e3, Log, false)),
    param!("C_2", steady.C_2, Steady, Some("mm"), "axis gain of r2 (5) (Table I)", Positive, fit(1e-3, 1e3, Log, false)),
    param!("a_K1", steady.a_K1, Steady, None, "curvature gain of S_x (7) (Table I)", range(0.0, 1e6), fit(1e-6, 1e3, Log, true)),
    param!("a_K2", steady.a_K2, Steady, None, "curvature gain of S_y (7) (Table I)", range(0.0, 1e6), fit(1e-6, 1e3, Log, true)),
    param!("alpha_1", steady.alpha_1, Steady, None, "stiffness exponent of r1 (5) (Table I)", range(0.0, 10.0), fit(0.0, 3.0, Sin, false)),
    param!("alpha_2", steady.alpha_2, Steady, None, "stiffness exponent of r2 (5) (Table I)", range(0.0, 10.0), fit(0.0, 3.0, Sin, false)),
    param!("gamma_1", steady.gamma_1, Steady, None, "curvature exponent of S_x (7) (Table I)", range(0.0, 10.0), fit(0.0, 3.0, Sin, true)),
    param!("gamma_2", steady.gamma_2, Steady, None, "curvature exponent of S_y (7) (Table I)", range(0.0, 10.0), fit(0.0, 3.0, Sin, true)),
    param!("s_0", steady.s_0, Steady, None, "baseline stiffness (7) (Table I)", range(-1e6, 1e6), fit(-10.0, 10.0, Sin, true)),
    param!("a_G", steady.a_G, Steady, None, "gradient gain (7) (Table I)", range(-1e6, 1e6), fit(-10.0, 10.0, Sin, true)),
    param!("rho", steady.rho, Steady, None, "gradient exponent (7) (reconstructed)", range(0.0, 10.0), fit(0.0, 3.0, Sin, true)),
    param!("N", steady.N, Steady, None, "amplitude of Phi (6) (Table I)", range(-100.0, 100.0), fit(-20.0, 20.0, Sin, false)),
    param!("q", steady.q, Steady, None, "exponent of Phi (6) (Table I)", range(0.0, 10.0), fit(0.0, 5.0, Sin, false)),
    param!("a_P", steady.a_P, Steady, None, "particle-interaction gain (7) (Table I)", range(-1e6, 1e6), fit(-10.0, 10.0, Sin, true)),
    param!("mu_P", steady.mu_P, Steady, None, "particle-interaction field exponent (7) (Table I)", range(0.0, 10.0), fit(0.0, 3.0, Sin, true)),
    param!("c_P", steady.c_P, Steady, None, "frequency-field interaction coefficient (7) (Table I)", range(-1e3, 1e3), fit(-5.0, 5.0, Sin, false)),
    param!("q_P", steady.q_P, Steady, None, "frequency-field interaction exponent (7) (Table I)", range(0.0, 10.0), fit(0.0, 5.0, Sin, false)),
    param!("f_ref", steady.f_ref, Steady, Some("Hz"), "reference frequency, omega_ref = 2 pi f_ref (Table I)", Positive, None),
    param!("B_ref", steady.B_ref, Steady, Some("T"), "field normalisation of the particle term (reconstructed)", Positive, None),
    param!("K_b1", dynamics.K_b1, Dynamic, None, "confinement gain of r1 in (4) when not scheduled [mm^(1-beta)/s]", range(0.0, 1e9), None),
    param!("K_b2", dynamics.K_b2, Dynamic, None, "confinement gain of r2 in (4) when not scheduled [mm^(1-beta)/s]", range(0.0, 1e9), None),
    param!("beta", dynamics.beta, Dynamic, None, "confinement nonlinearity (1)", range(0.1, 10.0), fit(0.1, 10.0, Sin, false)),
    param!("r1_min", dynamics.r1_min, Dynamic, Some("mm"), "packing limit of r1 (1)", range(0.0, 1e3), fit(0.0, 50.0, Sin, false)),
    param!("r2_min", dynamics.r2_min, Dynamic, Some("mm"), "packing limit of r2 (1)", range(0.0, 1e3), fit(0.0, 50.0, Sin, false)),
    param!("K_tau", dynamics.K_tau, Dynamic, None, "expansion gain (2) [1/(mm s)]", range(0.0, 1e9), fit(1e-6, 1e3, Log, false)),
    param!("p", dynamics.p, Dynamic, None, "expansion frequency exponent (2)", range(0.0, 10.0), None),
    param!("s_B", dynamics.s_B, Dynamic, None, "field scale of the expansion (2) [1/T]", range(0.0, 1e9), None),
    param!("K_d1", dynamics.K_d1, Dynamic, Some("1/s"), "relaxation rate of r1 (3)", range(0.0, 1e9), fit(1e-6, 1e3, Log, false)),
    param!("K_d2", dynamics.K_d2, Dynamic, Some("1/s"), "relaxation rate of r2 (3)", range(0.0, 1e9), fit(1e-6, 1e3, Log, false)),
    param!("magnet_radius", magnet.radius_m, Magnet, Some("m"), "radius of the NdFeB sphere", range(1e-4, 1.0), None),
    param!("remanence", magnet.remanence_t, Magnet, Some("T"), "remanent flux density of the magnet", range(1e-3, 3.0), None),
    param!("z_offset", magnet.z_offset_m, Magnet, Some("m"), "distance added to z_m to reach the swarm plane from the magnet surface", Physical::Computed(z_offset_bounds), None),
    param!("lateral_offset", magnet.lateral_offset_m, Magnet, Some("m"), "lateral distance of the swarm from the rotation axis", range(0.0, 1.0), None),
    param!("k_unit", conventions.k_unit_t2_per_m2, Conventions, Some("T2/m2"), "unit of k_xx, k_yy inside (7) (reconstructed)", Positive, None),
    param!("g_unit", conventions.g_unit_t_per_m, Conventions, Some("T/m"), "unit of g_z inside (7) (reconstructed)", Positive, None),
    param!("s_floor", conventions.s_floor, Conventions, None, "positive floor of S_x, S_y", Positive, None),
    param!("log_arg_floor", conventions.log_arg_floor, Conventions, None, "smallest argument allowed inside the logarithm of (7)", range(1e-300, 1.0), None, fmu: false),
];

/// Number of rows.
const LEN: usize = BASE.len() + effects::row_count();

/// The plant's rows, then every effect's rows placed by their slots (below the plant's so
/// that the plant's value references never move). Built at compile time: a slot used twice
/// or left empty does not compile.
const fn build() -> [Param; LEN] {
    let mut out = [BASE[0]; LEN];
    let mut i = 0;
    while i < BASE.len() {
        out[i] = BASE[i];
        i += 1;
    }
    let mut taken = [false; LEN];
    let mut e = 0;
    while e < effects::ROWS.len() {
        let rows = effects::ROWS[e];
        let mut j = 0;
        while j < rows.len() {
            let at = BASE.len() + rows[j].slot;
            assert!(at < LEN, "effect row slot past the end: slots must be 0..n");
            assert!(!taken[at], "two effect rows in one slot");
            taken[at] = true;
            out[at] = rows[j].param;
            j += 1;
        }
        e += 1;
    }
    out
}

static TABLE: [Param; LEN] = build();

/// Every numeric parameter, in the FMU's value-reference order. Reading a parameter of an
/// effect that is off gives its neutral value; writing it switches the effect on (its other
/// parameters neutral).
pub static PARAMS: &[Param] = &TABLE;

/// The row of a parameter, by name.
pub fn find(name: &str) -> Option<&'static Param> {
    PARAMS.iter().find(|p| p.name == name)
}

/// The rows the FMU exposes as parameter variables, in value-reference order.
pub fn fmu_params() -> impl Iterator<Item = &'static Param> {
    PARAMS.iter().filter(|p| p.fmu)
}

/// The rows `identify` may fit.
pub fn fittable() -> impl Iterator<Item = &'static Param> {
    PARAMS.iter().filter(|p| p.fit.is_some())
}

/// The rows of a group.
pub fn group(g: Group) -> impl Iterator<Item = &'static Param> {
    PARAMS.iter().filter(move |p| p.group == g)
}

/// Check every row against its physical range; the first violation with its path.
pub fn check_all(m: &Model) -> Result<(), (&'static str, ValueError)> {
    for p in PARAMS {
        p.check(m).map_err(|e| (p.path, e))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_paths_are_unique() {
        let mut names = std::collections::HashSet::new();
        let mut paths = std::collections::HashSet::new();
        for p in PARAMS {
            assert!(names.insert(p.name), "duplicate name {}", p.name);
            assert!(paths.insert(p.path), "duplicate path {}", p.path);
        }
    }

    #[test]
    fn accessors_match_the_json_path() {
        let m = Model::paper();
        for (i, p) in PARAMS.iter().enumerate() {
            let mut mm = m.clone();
            let v = (p.get)(&m) * 1.5 + 1e-3 * (i as f64 + 1.0);
            (p.set)(&mut mm, v);
            assert_eq!((p.get)(&mm), v, "{}", p.name);
            let json = serde_json::to_value(&mm).unwrap();
            let at = p
                .path
                .split('.')
                .fold(&json, |j, k| &j[k])
                .as_f64()
                .unwrap_or_else(|| panic!("{}: no number at {}", p.name, p.path));
            assert_eq!(
                at, v,
                "{}: set wrote somewhere else than {}",
                p.name, p.path
            );
        }
    }

    #[test]
    fn paper_model_is_inside_every_physical_range_and_fit_range() {
        let m = Model::paper();
        check_all(&m).unwrap();
        for p in fittable() {
            let f = p.fit.unwrap();
            let v = (p.get)(&m);
            assert!(f.lo < f.hi, "{}", p.name);
            assert!(v >= f.lo && v <= f.hi, "{}: {v} outside fit range", p.name);
        }
    }

    #[test]
    fn every_row_rejects_non_finite_values() {
        for p in PARAMS {
            let mut m = Model::paper();
            (p.set)(&mut m, f64::NAN);
            let (path, err) = check_all(&m).unwrap_err();
            assert_eq!(path, p.path);
            assert!(err.to_string().contains("finite"), "{err}");
        }
    }
}
