//! Ready-made unit definitions (SI on the interface, friendlier display units for people).
//!
//! FMI describes a unit by its exponents of the SI base units plus `rad`, and a display
//! unit by `display = factor * value + offset`. Getting these right by hand is error-prone
//! (T = kg·s⁻²·A⁻¹), so the ones magnetic-actuation models need are defined once here.

use crate::info::{BaseUnit, DisplayUnit, UnitDefinition};

/// Base-unit exponents (kg, m, s, A, K, mol, cd, rad) with factor 1, offset 0.
#[allow(clippy::too_many_arguments)]
pub const fn base(
    kg: i32,
    m: i32,
    s: i32,
    a: i32,
    k: i32,
    mol: i32,
    cd: i32,
    rad: i32,
) -> BaseUnit {
    BaseUnit {
        kg,
        m,
        s,
        a,
        k,
        mol,
        cd,
        rad,
        factor: 1.0,
        offset: 0.0,
    }
}

/// A display unit with a factor and no offset.
pub const fn display(name: &'static str, factor: f64) -> DisplayUnit {
    DisplayUnit {
        name,
        factor,
        offset: 0.0,
    }
}

/// 1/(2π): rad/s → Hz.
pub const INV_TWO_PI: f64 = 1.0 / (2.0 * std::f64::consts::PI);

/// `m`, displayed as `mm` (factor 1000).
pub const METRE: UnitDefinition = UnitDefinition {
    name: "m",
    base: base(0, 1, 0, 0, 0, 0, 0, 0),
    display_units: &[display("mm", 1000.0)],
};
/// `rad/s`, displayed as `Hz` (factor 1/(2π)): ω = 2πf.
pub const RAD_PER_SECOND: UnitDefinition = UnitDefinition {
    name: "rad/s",
    base: base(0, 0, -1, 0, 0, 0, 0, 1),
    display_units: &[display("Hz", INV_TWO_PI)],
};
/// `s`.
pub const SECOND: UnitDefinition = UnitDefinition {
    name: "s",
    base: base(0, 0, 1, 0, 0, 0, 0, 0),
    display_units: &[],
};
/// `Hz` (1/s).
pub const HERTZ: UnitDefinition = UnitDefinition {
    name: "Hz",
    base: base(0, 0, -1, 0, 0, 0, 0, 0),
    display_units: &[],
};
/// `T` = kg·s⁻²·A⁻¹, displayed as `mT`.
pub const TESLA: UnitDefinition = UnitDefinition {
    name: "T",
    base: base(1, 0, -2, -1, 0, 0, 0, 0),
    display_units: &[display("mT", 1000.0)],
};
/// `T/m` = kg·m⁻¹·s⁻²·A⁻¹.
pub const TESLA_PER_METRE: UnitDefinition = UnitDefinition {
    name: "T/m",
    base: base(1, -1, -2, -1, 0, 0, 0, 0),
    display_units: &[],
};
/// `T2/m2` = kg²·m⁻²·s⁻⁴·A⁻² (curvature of B²).
pub const TESLA2_PER_METRE2: UnitDefinition = UnitDefinition {
    name: "T2/m2",
    base: base(2, -2, -4, -2, 0, 0, 0, 0),
    display_units: &[],
};
/// `1` (dimensionless).
pub const ONE: UnitDefinition = UnitDefinition {
    name: "1",
    base: BaseUnit::ONE,
    display_units: &[],
};
/// `mm` as a unit of its own (factor 0.001 to m), for parameters that keep a paper's units.
pub const MILLIMETRE: UnitDefinition = UnitDefinition {
    name: "mm",
    base: BaseUnit {
        factor: 0.001,
        ..base(0, 1, 0, 0, 0, 0, 0, 0)
    },
    display_units: &[],
};
/// `1/s` (rates, gains).
pub const PER_SECOND: UnitDefinition = UnitDefinition {
    name: "1/s",
    base: base(0, 0, -1, 0, 0, 0, 0, 0),
    display_units: &[],
};
/// `m/s`, displayed as `mm/s`.
pub const METRE_PER_SECOND: UnitDefinition = UnitDefinition {
    name: "m/s",
    base: base(0, 1, -1, 0, 0, 0, 0, 0),
    display_units: &[display("mm/s", 1000.0)],
};
/// `m/s2` (an acceleration, e.g. of a formation mode).
pub const METRE_PER_SECOND2: UnitDefinition = UnitDefinition {
    name: "m/s2",
    base: base(0, 1, -2, 0, 0, 0, 0, 0),
    display_units: &[display("mm/s2", 1000.0)],
};
/// `Hz/s` (rate of a frequency).
pub const HERTZ_PER_SECOND: UnitDefinition = UnitDefinition {
    name: "Hz/s",
    base: base(0, 0, -2, 0, 0, 0, 0, 0),
    display_units: &[],
};
