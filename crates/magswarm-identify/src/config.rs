//! The configuration of an identification ([`Config`], what the command's flags set) and the
//! free/fixed split it resolves to.

use super::data::SettleRule;
use super::params::{self, Free, Group};
use crate::IdentifyError;
use magswarm_model::effects::Stage;

/// Collinearity policy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Collinear {
    /// Fix the weakest parameter while cond > cond_max.
    Fix {
        /// Threshold.
        cond_max: f64,
    },
    /// Ridge toward the prior on the stiffness terms.
    Ridge {
        /// Strength.
        lambda: f64,
    },
    /// Only report.
    Report,
}

/// Configuration of an identification (the library face of the flags).
#[derive(Debug, Clone)]
pub struct Config {
    /// Free parameter names (steady and dynamic).
    pub free: Vec<String>,
    /// Bounds overrides.
    pub bounds: Vec<(String, f64, f64)>,
    /// Settle rule.
    pub settle: SettleRule,
    /// LM starts.
    pub starts: usize,
    /// Bootstrap replicates.
    pub bootstrap: usize,
    /// Seed.
    pub seed: u64,
    /// Collinearity policy.
    pub collinear: Collinear,
    /// Fit ODE time scales where possible.
    pub dynamics: bool,
    /// Withhold every K-th point (0: none).
    pub withhold_every: usize,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            free: params::DEFAULT_FREE_STEADY
                .iter()
                .chain(params::DEFAULT_FREE_DYNAMIC)
                .map(|s| s.to_string())
                .collect(),
            bounds: Vec::new(),
            settle: SettleRule::TimeConstants(5.0),
            starts: 8,
            bootstrap: 200,
            seed: 1,
            collinear: Collinear::Fix { cond_max: 1e8 },
            dynamics: true,
            withhold_every: 0,
        }
    }
}

impl Config {
    pub(super) fn resolve(&self) -> Result<(Vec<Free>, Vec<Free>), IdentifyError> {
        let mut st = Vec::new();
        let mut dy = Vec::new();
        for n in &self.free {
            let mut f = Free::new(n).ok_or_else(|| unknown_parameter("--free", n))?;
            if let Some((_, lo, hi)) = self.bounds.iter().find(|b| &b.0 == n) {
                f.lo = *lo;
                f.hi = *hi;
            }
            let list = if fits_steady(f.def.group) {
                &mut st
            } else {
                &mut dy
            };
            if !list.iter().any(|x: &Free| x.name() == f.name()) {
                list.push(f);
            }
        }
        for (n, _, _) in &self.bounds {
            if params::def(n).is_none() {
                return Err(unknown_parameter("--bound", n));
            }
        }
        Ok((st, dy))
    }
}

/// A parameter name identify does not know, named with the option that gave it.
pub fn unknown_parameter(option: &'static str, name: &str) -> IdentifyError {
    IdentifyError::UnknownParameter {
        option,
        name: name.to_string(),
        known: params::known_names(),
    }
}

/// Whether `identify` fits a parameter of this group to the settled point means rather than
/// to the transient rows: the steady map's own parameters, and the parameters of every effect
/// that the observed steady map sees (the fit goes through `effects::observed_steady`). An
/// effect that shapes transients alone ([`Stage::Transient`]: no change at steady state) has
/// its parameters fitted to the transient rows with the time scales.
pub fn fits_steady(group: Group) -> bool {
    match group {
        Group::Steady => true,
        Group::Effect(effect) => effect.stage() != Stage::Transient,
        _ => false,
    }
}
