//! The parameters `identify` can fit: names (the seed's symbols, as in the model file),
//! accessors on [`Model`], default bounds, and the transforms that make LM bounded.

use magswarm_model::Model;

/// Which part of the model a parameter belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Group {
    /// Steady map (5)-(7): fitted to the settled visit means.
    Steady,
    /// ODE (4): fitted to the transient rows.
    Dynamic,
}

/// How LM's unconstrained variable u maps onto the bounded parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Transform {
    /// theta = exp(u): strictly positive scale parameters.
    Log,
    /// theta = lo + (hi - lo) (1 + sin u) / 2 (MINUIT's double-bounded transform).
    Sin,
}

/// Static description of one fittable parameter.
#[derive(Debug, Clone, Copy)]
pub struct ParamDef {
    /// Name (the seed's symbol, as in the model file).
    pub name: &'static str,
    /// Steady or dynamic.
    pub group: Group,
    /// Default lower bound.
    pub lo: f64,
    /// Default upper bound.
    pub hi: f64,
    /// Default transform.
    pub transform: Transform,
    /// True for the terms of the stiffness (7) that are power laws of the distance (the
    /// nearly collinear family the issue warns about).
    pub stiffness: bool,
}

const fn d(
    name: &'static str,
    group: Group,
    lo: f64,
    hi: f64,
    transform: Transform,
    stiffness: bool,
) -> ParamDef {
    ParamDef {
        name,
        group,
        lo,
        hi,
        transform,
        stiffness,
    }
}

use Group::{Dynamic as D, Steady as S};
use Transform::{Log as L, Sin as B};

/// Every parameter `identify` knows, in Table I order.
pub const PARAMS: &[ParamDef] = &[
    d("C_1", S, 1e-3, 1e3, L, false),
    d("C_2", S, 1e-3, 1e3, L, false),
    d("a_K1", S, 1e-6, 1e3, L, true),
    d("a_K2", S, 1e-6, 1e3, L, true),
    d("alpha_1", S, 0.0, 3.0, B, false),
    d("alpha_2", S, 0.0, 3.0, B, false),
    d("gamma_1", S, 0.0, 3.0, B, true),
    d("gamma_2", S, 0.0, 3.0, B, true),
    d("s_0", S, -10.0, 10.0, B, true),
    d("a_G", S, -10.0, 10.0, B, true),
    d("rho", S, 0.0, 3.0, B, true),
    d("N", S, -20.0, 20.0, B, false),
    d("q", S, 0.0, 5.0, B, false),
    d("a_P", S, -10.0, 10.0, B, true),
    d("mu_P", S, 0.0, 3.0, B, true),
    d("c_P", S, -5.0, 5.0, B, false),
    d("q_P", S, 0.0, 5.0, B, false),
    d("K_tau", D, 1e-6, 1e3, L, false),
    d("K_d1", D, 1e-6, 1e3, L, false),
    d("K_d2", D, 1e-6, 1e3, L, false),
    d("beta", D, 0.1, 10.0, B, false),
    d("r1_min", D, 0.0, 50.0, B, false),
    d("r2_min", D, 0.0, 50.0, B, false),
];

/// Default free steady parameters: the axis gains and exponents, the curvature gains and the
/// frequency term. The remaining stiffness terms are power laws of the same distance as the
/// curvature term and stay at the prior model's values unless freed.
pub const DEFAULT_FREE_STEADY: &[&str] =
    &["C_1", "C_2", "a_K1", "a_K2", "alpha_1", "alpha_2", "N", "q"];

/// Default free dynamic parameters (fitted only where the log holds transients). K_tau scales
/// every formation time (with scheduled confinement the equilibrium does not move); the
/// relaxation rates K_d1, K_d2 only reshape the transient slightly and are poorly determined
/// by seed-like data (they run to their bounds), so they are freed only on request.
pub const DEFAULT_FREE_DYNAMIC: &[&str] = &["K_tau"];

/// Look a parameter up by name.
pub fn def(name: &str) -> Option<&'static ParamDef> {
    PARAMS.iter().find(|p| p.name == name)
}

/// Names of every known parameter (for error messages).
pub fn known_names() -> String {
    PARAMS.iter().map(|p| p.name).collect::<Vec<_>>().join(", ")
}

fn slot<'a>(m: &'a mut Model, name: &str) -> &'a mut f64 {
    let s = &mut m.steady;
    let dy = &mut m.dynamics;
    match name {
        "C_1" => &mut s.C_1,
        "C_2" => &mut s.C_2,
        "a_K1" => &mut s.a_K1,
        "a_K2" => &mut s.a_K2,
        "alpha_1" => &mut s.alpha_1,
        "alpha_2" => &mut s.alpha_2,
        "gamma_1" => &mut s.gamma_1,
        "gamma_2" => &mut s.gamma_2,
        "s_0" => &mut s.s_0,
        "a_G" => &mut s.a_G,
        "rho" => &mut s.rho,
        "N" => &mut s.N,
        "q" => &mut s.q,
        "a_P" => &mut s.a_P,
        "mu_P" => &mut s.mu_P,
        "c_P" => &mut s.c_P,
        "q_P" => &mut s.q_P,
        "K_tau" => &mut dy.K_tau,
        "K_d1" => &mut dy.K_d1,
        "K_d2" => &mut dy.K_d2,
        "beta" => &mut dy.beta,
        "r1_min" => &mut dy.r1_min,
        "r2_min" => &mut dy.r2_min,
        _ => panic!("unknown parameter {name}"),
    }
}

/// Read a parameter of a model.
pub fn get(m: &Model, name: &str) -> f64 {
    let mut c = m.clone();
    *slot(&mut c, name)
}

/// Write a parameter of a model.
pub fn set(m: &mut Model, name: &str, v: f64) {
    *slot(m, name) = v;
}

/// A free parameter with its (possibly overridden) bounds.
#[derive(Debug, Clone, Copy)]
pub struct Free {
    /// Definition.
    pub def: &'static ParamDef,
    /// Lower bound in force.
    pub lo: f64,
    /// Upper bound in force.
    pub hi: f64,
}

impl Free {
    /// Free parameter with default bounds.
    pub fn new(name: &str) -> Option<Free> {
        let def = def(name)?;
        Some(Free {
            def,
            lo: def.lo,
            hi: def.hi,
        })
    }

    /// Parameter name.
    pub fn name(&self) -> &'static str {
        self.def.name
    }

    /// theta(u).
    pub fn to_theta(&self, u: f64) -> f64 {
        match self.def.transform {
            Transform::Log => u.exp().clamp(self.lo, self.hi),
            Transform::Sin => self.lo + (self.hi - self.lo) * (1.0 + u.sin()) / 2.0,
        }
    }

    /// d theta / d u: the chain-rule factor from finite differences in theta to the
    /// Jacobian in the optimiser's unbounded u.
    pub fn dtheta_du(&self, u: f64) -> f64 {
        match self.def.transform {
            Transform::Log => u.exp(),
            Transform::Sin => (self.hi - self.lo) / 2.0 * u.cos(),
        }
    }

    /// u(theta), theta clamped into the bounds first.
    pub fn to_u(&self, theta: f64) -> f64 {
        let t = theta.clamp(self.lo, self.hi);
        match self.def.transform {
            Transform::Log => t.max(1e-300).ln(),
            Transform::Sin => (2.0 * (t - self.lo) / (self.hi - self.lo) - 1.0)
                .clamp(-1.0, 1.0)
                .asin(),
        }
    }

    /// True when theta lies within 0.1 % of the range (or a factor 1.001) of a bound.
    pub fn at_bound(&self, theta: f64) -> bool {
        match self.def.transform {
            Transform::Log => theta <= self.lo * 1.001 || theta >= self.hi / 1.001,
            Transform::Sin => {
                let tol = 1e-3 * (self.hi - self.lo);
                theta <= self.lo + tol || theta >= self.hi - tol
            }
        }
    }

    /// Finite-difference step for theta.
    pub fn fd_step(&self, theta: f64) -> f64 {
        1e-6 * theta.abs().max(1e-3 * (1.0 + (self.hi - self.lo).min(1.0)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn get_set_every_param() {
        let mut m = Model::paper();
        for p in PARAMS {
            let v = get(&m, p.name);
            set(&mut m, p.name, v + 0.5);
            assert_eq!(get(&m, p.name), v + 0.5, "{}", p.name);
        }
    }

    #[test]
    fn transforms_round_trip() {
        for p in PARAMS {
            let f = Free::new(p.name).unwrap();
            let theta = get(&Model::paper(), p.name).clamp(f.lo, f.hi);
            let back = f.to_theta(f.to_u(theta));
            assert!(
                (back - theta).abs() < 1e-9 * theta.abs().max(1.0),
                "{}",
                p.name
            );
        }
    }
}
