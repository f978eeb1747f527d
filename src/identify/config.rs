//! The configuration of an identification: the command's flags (`IdentifyArgs`), their
//! library face ([`Config`]) and the free/fixed split they resolve to.

use super::data::SettleRule;
use super::params::{self, Free, Group};
use crate::cli::IdentifyArgs;
use anyhow::{bail, Result};
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
    /// Show a progress bar (only drawn on a terminal).
    pub progress: bool,
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
            progress: false,
        }
    }
}

impl Config {
    /// Build from the command-line flags.
    pub fn from_args(a: &IdentifyArgs) -> Result<Config> {
        let mut c = Config::default();
        if let Some(f) = &a.free {
            c.free = f
                .iter()
                .map(|s| s.trim().to_string())
                .filter(|s| !s.is_empty())
                .collect();
        }
        for n in &a.fix {
            let n = n.trim();
            if params::def(n).is_none() {
                bail!(
                    "--fix {n}: unknown parameter (known: {})",
                    params::known_names()
                );
            }
            c.free.retain(|x| x != n);
        }
        for b in &a.bound {
            let parsed = b.split_once('=').and_then(|(n, r)| {
                let (lo, hi) = r.split_once(':')?;
                Some((
                    n.trim().to_string(),
                    lo.trim().parse().ok()?,
                    hi.trim().parse().ok()?,
                ))
            });
            match parsed {
                Some((n, lo, hi)) if lo < hi => c.bounds.push((n, lo, hi)),
                _ => bail!("--bound {b:?}: expected NAME=LO:HI with LO < HI"),
            }
        }
        c.settle = match a.settle_s {
            Some(s) if s >= 0.0 && s.is_finite() => SettleRule::Fixed(s),
            Some(s) => bail!("--settle-s {s}: must be a finite number >= 0"),
            None if a.settle_factor >= 0.0 && a.settle_factor.is_finite() => {
                SettleRule::TimeConstants(a.settle_factor)
            }
            None => bail!("--settle-factor {}: must be >= 0", a.settle_factor),
        };
        c.starts = a.starts.max(1);
        c.bootstrap = a.bootstrap;
        c.seed = a.seed;
        c.collinear = match a.collinear.as_str() {
            "fix" => Collinear::Fix {
                cond_max: a.cond_max,
            },
            "ridge" => Collinear::Ridge {
                lambda: a.ridge_lambda,
            },
            "report" => Collinear::Report,
            o => bail!("--collinear {o}: expected fix, ridge or report"),
        };
        c.dynamics = !a.no_dynamics;
        c.withhold_every = a.withhold_every;
        c.progress = true;
        Ok(c)
    }

    pub(super) fn resolve(&self) -> Result<(Vec<Free>, Vec<Free>)> {
        let mut st = Vec::new();
        let mut dy = Vec::new();
        for n in &self.free {
            let mut f = Free::new(n).ok_or_else(|| {
                anyhow::anyhow!(
                    "--free {n}: unknown parameter (known: {})",
                    params::known_names()
                )
            })?;
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
                bail!(
                    "--bound {n}: unknown parameter (known: {})",
                    params::known_names()
                );
            }
        }
        Ok((st, dy))
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
