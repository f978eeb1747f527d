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
//! The row types ([`Param`], [`Group`], [`Physical`], [`Fit`], [`Transform`]) live in
//! [`crate::param_row`], below both this table and the effects, and are re-exported here.
//!
//! The order of [`PARAMS`] is the FMU's value-reference order: the plant's rows in `BASE`
//! order, then the effects' rows by slot. Do not reorder rows or move slots.

use crate::effect_kind::EffectKind;
use crate::effects;
use crate::param_row::{fit, range};
use crate::Model;

pub use crate::param_row::{Fit, Group, Param, Physical, Transform, ValueError};

/// The swarm plane must stay below the magnet: z_offset above -0.99 magnet radii.
fn z_offset_bounds(m: &Model) -> (f64, f64) {
    (-m.magnet.radius_m * 0.99, 1.0)
}

use Physical::Positive;
use Transform::{Log, Sin};

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

/// The rows of one effect's parameters (name `effect.field`, unit, physical and fit bounds,
/// accessors), in registry order.
pub fn params_of(kind: EffectKind) -> impl Iterator<Item = &'static Param> {
    group(Group::Effect(kind))
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
    fn registry_covers_every_effect_and_neutral_is_inside_bounds() {
        for k in EffectKind::ALL {
            assert!(params_of(k).count() > 0, "{k} has no parameters");
            assert_eq!(params_of(k).count(), k.rows().len(), "{k}");
        }
        for p in PARAMS {
            let Group::Effect(e) = p.group else { continue };
            assert_eq!(p.path, format!("effects.{}", p.name));
            assert!(p.name.starts_with(&format!("{e}.")), "{}", p.name);
            assert!(p.description.starts_with(&format!("{e}: ")), "{}", p.name);
            let v = effects::neutral(p);
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
