//! Linearisation of ODE (4) at an equilibrium, for control-design tools.
//!
//! ```text
//! d(dx)/dt = A dx + B du,   dy = C dx + D du
//! x = (r1, r2) [m],  u = (z_m [m], omega_m [rad/s]),  y = (r1, r2) [m]
//! ```
//!
//! All quantities are SI, like the FMU's interface (the model computes radii in mm; the
//! conversion is done here): A [1/s] is unit-free in the radius scale, B's columns are
//! [m/s per m] and [m/s per rad/s], C = I, D = 0. The equilibrium is the steady map (5)-(7)
//! with the model's scheduled confinement (the equilibrium of (4) found by Newton otherwise),
//! and the steady-state gain `-C A^-1 B` is then the map's Jacobian d(r1, r2)/d(z_m, omega)
//! (converted to m), which the tests check.

use magswarm_model::dynamics::{self, InputTerms};
use magswarm_model::params::Confinement;
use magswarm_model::Model;
use serde::{Deserialize, Serialize};

use crate::mat2::{self, M2};

/// A linear state-space model at an operating point (SI units).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Linearization {
    /// State matrix d f / d x [1/s].
    pub a: M2,
    /// Input matrix d f / d u [(m/s)/m, (m/s)/(rad/s)].
    pub b: M2,
    /// Output matrix [-] (identity: the outputs are the states).
    pub c: M2,
    /// Feedthrough [m/m, m/(rad/s)] (zero).
    pub d: M2,
    /// Equilibrium state (r1, r2) [m].
    pub x0: [f64; 2],
    /// Operating point (z_m [m], omega_m [rad/s]).
    pub u0: [f64; 2],
    /// Outputs at the equilibrium (r1, r2) [m].
    pub y0: [f64; 2],
    /// Steady-state gain -C A^-1 B + D [m/m, m/(rad/s)].
    pub steady_state_gain: M2,
    /// The steady map's analytic Jacobian at u0, in the same units.
    pub map_jacobian: M2,
    /// Eigenvalues of A as (re, im) [1/s].
    pub eigenvalues: [(f64, f64); 2],
    /// State names.
    pub state_names: [String; 2],
    /// State units.
    pub state_units: [String; 2],
    /// Input names (the FMU's variable names).
    pub input_names: [String; 2],
    /// Input units.
    pub input_units: [String; 2],
    /// Output names.
    pub output_names: [String; 2],
    /// Output units.
    pub output_units: [String; 2],
}

/// Linearise ODE (4) of `model` at inputs (z_m [m], omega [rad/s]).
pub fn linearize(model: &Model, z_m: f64, omega: f64) -> Linearization {
    let terms = InputTerms::new(model, z_m, omega);
    let r_mm = match model.dynamics.confinement {
        Confinement::Scheduled if !terms.steady.validity.dynamics_clamped => terms.steady.radii(),
        _ => dynamics::equilibria(model, &terms).r,
    };
    let a = terms.jac_state(model, r_mm);
    let b_mm = terms.jac_input(model, r_mm);
    let b = scale(&b_mm, 1e-3);
    let c = [[1.0, 0.0], [0.0, 1.0]];
    let d = [[0.0; 2]; 2];
    let gain = match mat2::inv(&a) {
        Some(ai) => scale(&mat2::mul(&ai, &b), -1.0),
        None => [[f64::NAN; 2]; 2],
    };
    let x0 = [r_mm[0] * 1e-3, r_mm[1] * 1e-3];
    let s = |v: [&str; 2]| [v[0].to_string(), v[1].to_string()];
    Linearization {
        a,
        b,
        c,
        d,
        x0,
        u0: [z_m, omega],
        y0: x0,
        steady_state_gain: gain,
        map_jacobian: scale(&terms.steady.jac, 1e-3),
        eigenvalues: dynamics::eig2(a),
        state_names: s(["r1", "r2"]),
        state_units: s(["m", "m"]),
        input_names: s(["z_m", "omega_m"]),
        input_units: s(["m", "rad/s"]),
        output_names: s(["r1", "r2"]),
        output_units: s(["m", "m"]),
    }
}

fn scale(m: &M2, k: f64) -> M2 {
    [[m[0][0] * k, m[0][1] * k], [m[1][0] * k, m[1][1] * k]]
}

fn num(v: f64) -> String {
    format!("{v:e}")
}

fn matlab_mat(m: &M2) -> String {
    format!(
        "[{} {}; {} {}]",
        num(m[0][0]),
        num(m[0][1]),
        num(m[1][0]),
        num(m[1][1])
    )
}

fn py_mat(m: &M2) -> String {
    format!(
        "[[{}, {}], [{}, {}]]",
        num(m[0][0]),
        num(m[0][1]),
        num(m[1][0]),
        num(m[1][1])
    )
}

impl Linearization {
    /// Pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("linearization serialises")
    }

    /// A MATLAB script: `A = [..; ..]; ... sys = ss(A,B,C,D);` with names and units.
    pub fn to_matlab(&self) -> String {
        format!(
            "% magswarm linearisation of ODE (4) at z_m = {z} m, omega_m = {w} rad/s (SI units)\n\
             % states x = (r1, r2) [m], inputs u = (z_m [m], omega_m [rad/s]), outputs y = (r1, r2) [m]\n\
             A = {a};\n\
             B = {b};\n\
             C = {c};\n\
             D = {d};\n\
             x0 = [{x0}; {x1}];\n\
             u0 = [{u0}; {u1}];\n\
             sys = ss(A, B, C, D, 'StateName', {{'r1', 'r2'}}, 'StateUnit', {{'m', 'm'}}, \
             'InputName', {{'z_m', 'omega_m'}}, 'InputUnit', {{'m', 'rad/s'}}, \
             'OutputName', {{'r1', 'r2'}}, 'OutputUnit', {{'m', 'm'}});\n",
            z = num(self.u0[0]),
            w = num(self.u0[1]),
            a = matlab_mat(&self.a),
            b = matlab_mat(&self.b),
            c = matlab_mat(&self.c),
            d = matlab_mat(&self.d),
            x0 = num(self.x0[0]),
            x1 = num(self.x0[1]),
            u0 = num(self.u0[0]),
            u1 = num(self.u0[1]),
        )
    }

    /// A python-control script: `import control; sys = control.ss(A, B, C, D, ...)`.
    pub fn to_python(&self) -> String {
        format!(
            "# magswarm linearisation of ODE (4) at z_m = {z} m, omega_m = {w} rad/s (SI units)\n\
             # states x = (r1, r2) [m], inputs u = (z_m [m], omega_m [rad/s]), outputs y = (r1, r2) [m]\n\
             import control\n\
             A = {a}\n\
             B = {b}\n\
             C = {c}\n\
             D = {d}\n\
             x0 = [{x0}, {x1}]\n\
             u0 = [{u0}, {u1}]\n\
             sys = control.ss(A, B, C, D, states=['r1', 'r2'], inputs=['z_m', 'omega_m'], \
             outputs=['r1', 'r2'])\n",
            z = num(self.u0[0]),
            w = num(self.u0[1]),
            a = py_mat(&self.a),
            b = py_mat(&self.b),
            c = py_mat(&self.c),
            d = py_mat(&self.d),
            x0 = num(self.x0[0]),
            x1 = num(self.x0[1]),
            u0 = num(self.u0[0]),
            u1 = num(self.u0[1]),
        )
    }
}
