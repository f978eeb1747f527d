//! Physics of the magswarm plant, with no FFI in it.
//!
//! The seed paper ("Physics-Based Reduced-Order Modeling of Magnetic Microparticle Swarms for
//! Biomedical Control") describes a swarm of NdFeB microparticles under a rotating spherical
//! magnet by the principal radii (r1, r2) of its elliptical footprint. This crate holds:
//!
//! - [`field`]: the dipole field of the magnet and the quantities (7) needs at the swarm
//!   (B, g_z, k_xx, k_yy), in closed form;
//! - [`steady`]: stiffness (7), frequency term (6) and steady-state map (5), with Jacobians;
//! - [`dynamics`]: ODE (4) and its Jacobians, with confinement gains scheduled so that its
//!   equilibrium is the map;
//! - [`integrate`]: an allocation-free Dormand-Prince integrator for the FMU's hot path;
//! - [`plant`]: the plant as a stateful object (inputs in, radii out) that the FMU, the
//!   virtual lab and `predict` all drive;
//! - [`effects`]: the unmodelled effects as model terms (phase lag, cohesion loss, formation
//!   lag, particle drift, centroid offset, camera bias), each nesting the seed's model;
//! - [`model_file`]: the versioned JSON model file (`magswarm-model/2`, reads `/1`);
//! - [`effect_kind`]: the list of effects (each effect's name, written once) and
//!   [`effects::EffectKind`], the handle reports and options name an effect by;
//! - [`registry`]: one table of every numeric parameter (name, unit, bounds, accessors),
//!   which validation, the FMU's parameters and `identify` iterate over (effect parameters
//!   included), of rows whose types are [`param_row`]'s;
//! - [`reconstruction`]: the constants Table I leaves out, and why they have their values.
//!
//! Units: inputs are SI (z_m in m, omega_m in rad/s); radii are in mm (Table I's unit for
//! C_i); the FMU converts radii to m at its boundary.

// 2x2 matrix code reads best with explicit indices.
#![allow(clippy::needless_range_loop)]

mod conststr;
pub mod dynamics;
pub mod effect_kind;
pub mod effects;
pub mod envelope;
pub mod fastpow;
pub mod field;
pub mod integrate;
pub mod learned;
pub mod maptable;
pub mod model_file;
pub mod param_row;
pub mod params;
pub mod plant;
pub mod reconstruction;
pub mod registry;
pub mod steady;

pub use envelope::{Envelope, Validity};
pub use field::{FieldAtSwarm, MagnetConfig};
pub use integrate::StepError;
pub use model_file::{Effects, Model, ModelError, SCHEMA, SCHEMA_V1};
pub use params::{Confinement, Conventions, DynParams, LogBase, SteadyParams};
pub use plant::{InputError, Plant, PlantOutputs, PlantSnapshot};
pub use steady::SteadyPoint;

/// Field frequency \[Hz\] to angular velocity [rad/s].
pub fn hz_to_rad_s(f: f64) -> f64 {
    f * std::f64::consts::TAU
}

/// Angular velocity [rad/s] to field frequency \[Hz\].
pub fn rad_s_to_hz(w: f64) -> f64 {
    w / std::f64::consts::TAU
}

/// The seed's 50-point validation grid: z_m 3.5, 8.5, ..., 23.5 mm x f 1..10 Hz, as
/// (z_m \[m\], f \[Hz\]) pairs, z-major.
pub fn seed_grid() -> Vec<(f64, f64)> {
    let mut v = Vec::with_capacity(50);
    for i in 0..5 {
        for j in 1..=10 {
            v.push((0.0035 + 0.005 * i as f64, j as f64));
        }
    }
    v
}
