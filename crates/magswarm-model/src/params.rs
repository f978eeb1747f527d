//! Parameters of the plant, named with the seed's symbols.
//!
//! `SteadyParams` are the symbols of the steady map (5)-(7) (Table I plus what Table I leaves
//! out), `Conventions` the units and constants the seed never states but which decide the
//! numbers (units of k, g_z and B inside (7), the base of its logarithm, the floor of S), and
//! `DynParams` the symbols of ODE (4). Field names are the seed's symbols on purpose: the model
//! file, the FMU's variable names and the docs all use them, so a user can read Table I against
//! any of the three.

#![allow(non_snake_case)]

use serde::{Deserialize, Serialize};

/// Parameters of the steady-state map (5)-(7). Table I values are the defaults.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SteadyParams {
    /// Axis gain of r1 \[mm\].
    pub C_1: f64,
    /// Axis gain of r2 \[mm\].
    pub C_2: f64,
    /// Curvature gain of S_x [-].
    pub a_K1: f64,
    /// Curvature gain of S_y [-].
    pub a_K2: f64,
    /// Stiffness exponent of r1 [-].
    pub alpha_1: f64,
    /// Stiffness exponent of r2 [-].
    pub alpha_2: f64,
    /// Curvature exponent in S_x [-].
    pub gamma_1: f64,
    /// Curvature exponent in S_y [-].
    pub gamma_2: f64,
    /// Baseline stiffness [-].
    pub s_0: f64,
    /// Gradient gain [-].
    pub a_G: f64,
    /// Gradient exponent [-] (not in Table I: reconstructed).
    pub rho: f64,
    /// Amplitude of the frequency term Phi (6) [-].
    pub N: f64,
    /// Exponent of the frequency term Phi (6) [-].
    pub q: f64,
    /// Particle-interaction gain [-].
    pub a_P: f64,
    /// Particle-interaction field exponent [-].
    pub mu_P: f64,
    /// Frequency-field interaction coefficient [-].
    pub c_P: f64,
    /// Frequency-field interaction exponent [-].
    pub q_P: f64,
    /// Reference frequency \[Hz\]; omega_ref = 2 pi f_ref.
    pub f_ref: f64,
    /// Field normalisation of the particle term \[T\] (not in Table I: reconstructed).
    pub B_ref: f64,
}

/// Base of the logarithm in (7). The seed writes `log` without a base.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LogBase {
    /// Natural logarithm (as numpy's `log`).
    E,
    /// Decimal logarithm.
    Ten,
}

impl LogBase {
    /// log in this base.
    pub fn log(self, x: f64) -> f64 {
        match self {
            LogBase::E => x.ln(),
            LogBase::Ten => x.log10(),
        }
    }
    /// d/dx log(x) in this base.
    pub fn dlog(self, x: f64) -> f64 {
        match self {
            LogBase::E => 1.0 / x,
            LogBase::Ten => 1.0 / (x * std::f64::consts::LN_10),
        }
    }
}

/// Units and numerical conventions of (7) that the seed leaves implicit.
///
/// The exponents gamma and rho make the numbers of (7) depend on the units of k, g_z and B:
/// `(k / unit)^gamma`. These are therefore part of the model, not of the presentation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Conventions {
    /// The unit k_xx, k_yy are expressed in inside (7), as its value in T^2/m^2.
    pub k_unit_t2_per_m2: f64,
    /// The unit g_z is expressed in inside (7), as its value in T/m.
    pub g_unit_t_per_m: f64,
    /// Base of the logarithm in (7).
    pub log_base: LogBase,
    /// Positive floor of S_x, S_y [-] ("numerical flooring" in the seed).
    pub s_floor: f64,
    /// Smallest argument allowed inside the logarithm of (7); below it (only far above the
    /// envelope, where `1 + c_P (w)^q_P` would turn negative) the argument is clamped and the
    /// evaluation is flagged as extrapolating.
    pub log_arg_floor: f64,
}

/// How the confinement gains K_b,i of (4) are set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Confinement {
    /// K_b,i scheduled on the inputs so that the equilibrium of (4) is the steady map exactly.
    Scheduled,
    /// K_b,i constant (the values K_b1, K_b2): (4) as the seed writes it; its equilibrium
    /// deviates from the map (see `magswarm paper`).
    Constant,
}

/// Parameters of ODE (4). The seed gives none of their values.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DynParams {
    /// How K_b,i are set.
    pub confinement: Confinement,
    /// Confinement gain of r1 [mm^(1-beta)/s], used when `confinement = constant`.
    pub K_b1: f64,
    /// Confinement gain of r2 [mm^(1-beta)/s], used when `confinement = constant`.
    pub K_b2: f64,
    /// Confinement nonlinearity [-].
    pub beta: f64,
    /// Packing limit of r1 \[mm\].
    pub r1_min: f64,
    /// Packing limit of r2 \[mm\].
    pub r2_min: f64,
    /// Expansion gain [1/(mm s)].
    pub K_tau: f64,
    /// Expansion frequency exponent [-].
    pub p: f64,
    /// Field scale of the expansion [1/T].
    pub s_B: f64,
    /// Relaxation rate of r1 [1/s].
    pub K_d1: f64,
    /// Relaxation rate of r2 [1/s].
    pub K_d2: f64,
}
