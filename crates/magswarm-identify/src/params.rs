//! The parameters `identify` can fit: the rows of the model's parameter registry
//! ([`magswarm_model::registry`]) that carry fit bounds, with the transforms that make LM
//! bounded. A parameter added to the registry with a [`registry::Fit`] can be freed here by
//! itself; nothing in this file lists parameters.

use std::sync::LazyLock;

use magswarm_model::registry;
use magswarm_model::Model;

/// Which part of the model a parameter belongs to (the registry's groups). `identify` fits
/// [`Group::Steady`] parameters to the settled visit means and every other group to the
/// transient rows.
pub use registry::Group;
/// How LM's unconstrained variable u maps onto the bounded parameter.
pub use registry::Transform;

/// Static description of one fittable parameter (built from its registry row).
#[derive(Debug, Clone, Copy)]
pub struct ParamDef {
    /// Name (the seed's symbol, as in the model file).
    pub name: &'static str,
    /// Part of the model.
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
    /// The registry row (accessors, unit, physical range).
    pub param: &'static registry::Param,
}

/// Every parameter `identify` knows: the registry's fittable rows, in registry order.
pub static PARAMS: LazyLock<Vec<ParamDef>> = LazyLock::new(|| {
    registry::fittable()
        .map(|p| {
            let f = p.fit.expect("fittable rows have fit bounds");
            ParamDef {
                name: p.name,
                group: p.group,
                lo: f.lo,
                hi: f.hi,
                transform: f.transform,
                stiffness: f.stiffness,
                param: p,
            }
        })
        .collect()
});

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

fn row(name: &str) -> &'static registry::Param {
    match registry::find(name) {
        Some(p) => p,
        None => panic!("unknown parameter {name}"),
    }
}

/// Read a parameter of a model (any registry row, fittable or not).
pub fn get(m: &Model, name: &str) -> f64 {
    (row(name).get)(m)
}

/// Write a parameter of a model (any registry row, fittable or not).
pub fn set(m: &mut Model, name: &str, v: f64) {
    (row(name).set)(m, v)
}

/// The parameters theta of the free set at LM's unconstrained variables u.
pub fn thetas(free: &[Free], u: &[f64]) -> Vec<f64> {
    free.iter().zip(u).map(|(f, &u)| f.to_theta(u)).collect()
}

/// d theta / d u of the free set at u (the chain rule from theta to LM's variables).
pub fn dthetas_du(free: &[Free], u: &[f64]) -> Vec<f64> {
    free.iter().zip(u).map(|(f, &u)| f.dtheta_du(u)).collect()
}

/// Put the free set's parameters at u into `m`.
pub fn set_from_u(m: &mut Model, free: &[Free], u: &[f64]) {
    for (f, &ui) in free.iter().zip(u) {
        set(m, f.name(), f.to_theta(ui));
    }
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
        for p in PARAMS.iter() {
            let v = get(&m, p.name);
            set(&mut m, p.name, v + 0.5);
            assert_eq!(get(&m, p.name), v + 0.5, "{}", p.name);
        }
    }

    #[test]
    fn transforms_round_trip() {
        for p in PARAMS.iter() {
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
