//! Learned effect terms: a tabulated correction along one effect's physical axis, for an
//! effect whose shape on a rig is not the library's parametric form.
//!
//! `magswarm diagnose` writes them (a shape learned from the residual along the effect's axis,
//! with its uncertainty) into the model file's `effects.learned`; the plant, `predict`, the
//! FMU and the bridge's shadow model run them like every effect. Each term is a
//! piecewise-linear function of its axis variable with heights at knots per radius, flat
//! beyond the end knots:
//!
//! | axis | the variable | where it acts |
//! | --- | --- | --- |
//! | `f_hz` | `f (B(z_m)/B_ref)^-field_exponent` \[Hz\] (an onset that moves with the field) | the steady map (5)-(7), so the ODE (4) approaches it |
//! | `z_m_mm` | z_m \[mm\] | the steady map |
//! | `t_s` | session (plant) time \[s\] | the observed radii |
//! | `since_change_s` | time since the last input change \[s\] | the observed radii |
//!
//! | mode | value | acts as |
//! | --- | --- | --- |
//! | `add_mm` | mm | added to the radius |
//! | `relative` | - | the radius times (1 + v) |
//! | `rate_hz` | Hz (one value for both radii: the r1 heights) | the steady map at the drive frequency less v (a deficit of the swarm's rotation) |
//! | `step_fraction` | - (only with `since_change_s`) | v times the step of the steady map at the last input change |
//!
//! A value acts scaled by `(B(z_m)/B_ref)^amplitude_exponent` (0 by default: unscaled).
//!
//! The time since a change: only the most recent input change counts; a change while a
//! transient runs starts the next one from the new step (Delta = the observed steady map at
//! the new inputs less at the old ones, the since-change terms themselves excluded). Before the
//! first change the correction is 0.

use serde::{Deserialize, Serialize};

/// The variable a learned term runs along.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum LearnedAxis {
    /// Field frequency \[Hz\], scaled by the field.
    #[serde(rename = "f_hz")]
    FHz,
    /// Magnet distance \[mm\].
    #[serde(rename = "z_m_mm")]
    ZmMm,
    /// Session time \[s\].
    #[serde(rename = "t_s")]
    TS,
    /// Time since the last input change \[s\].
    #[serde(rename = "since_change_s")]
    SinceChangeS,
}

/// How a learned term's value acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum LearnedMode {
    /// Millimetres added.
    #[serde(rename = "add_mm")]
    AddMm,
    /// Relative change.
    #[serde(rename = "relative")]
    Relative,
    /// A deficit of the swarm's rotation rate \[Hz\].
    #[serde(rename = "rate_hz")]
    RateHz,
    /// Fraction of the last input change's step.
    #[serde(rename = "step_fraction")]
    StepFraction,
}

/// The input changes a `step_fraction` term follows, per radius by the sign of that radius'
/// step: a swarm need not form the same way when it grows as when it contracts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum LearnedSteps {
    /// Every change.
    #[default]
    #[serde(rename = "all")]
    All,
    /// Changes that make the radius grow (a positive step).
    #[serde(rename = "growing")]
    Growing,
    /// Changes that make the radius shrink (a negative step).
    #[serde(rename = "shrinking")]
    Shrinking,
}

impl LearnedSteps {
    /// Share (1 or 0) of a step `delta` \[mm\] the term follows.
    #[inline]
    pub fn of(self, delta: f64) -> f64 {
        match self {
            LearnedSteps::All => 1.0,
            LearnedSteps::Growing => f64::from(u8::from(delta > 0.0)),
            LearnedSteps::Shrinking => f64::from(u8::from(delta < 0.0)),
        }
    }

    fn is_all(&self) -> bool {
        *self == LearnedSteps::All
    }
}

/// The multiplier of a `step_fraction` term's heights for a step `delta` \[mm\]: whether
/// the term follows that step (`steps`), times `|delta| / step_size_mm` where that is set
/// (> 0). One formula for the model that runs a term and the fit that learns it, so that a
/// written term acts as it was fitted.
pub fn step_share(steps: LearnedSteps, step_size_mm: f64, delta: f64) -> f64 {
    let size = if step_size_mm > 0.0 {
        delta.abs() / step_size_mm
    } else {
        1.0
    };
    steps.of(delta) * size
}

/// One learned term.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LearnedTerm {
    /// The effect the shape stands for (one of the effect names).
    pub effect: String,
    /// Its axis.
    pub axis: LearnedAxis,
    /// How it acts.
    pub mode: LearnedMode,
    /// Knots on the axis, strictly increasing.
    pub knots: Vec<f64>,
    /// Heights for r1 at the knots.
    pub r1: Vec<f64>,
    /// Heights for r2 at the knots.
    pub r2: Vec<f64>,
    /// 1-SD uncertainty of the r1 heights (informational).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sd_r1: Option<Vec<f64>>,
    /// 1-SD uncertainty of the r2 heights (informational).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sd_r2: Option<Vec<f64>>,
    /// Field exponent of the f axis' argument [-].
    #[serde(default, skip_serializing_if = "is_zero")]
    pub field_exponent: f64,
    /// Field exponent of the value's amplitude [-].
    #[serde(default, skip_serializing_if = "is_zero")]
    pub amplitude_exponent: f64,
    /// The input changes a `step_fraction` term follows (default `all`).
    #[serde(default, skip_serializing_if = "LearnedSteps::is_all")]
    pub steps: LearnedSteps,
    /// A `step_fraction` term whose share grows with the size of the step \[mm\]: the
    /// heights are scaled by `|step| / step_size_mm`, so the missing part goes as
    /// `step |step|`. A transient that is not proportional to its step (a rate limit makes a
    /// large change take longer, a small one not) needs it beside a plain term. Default 0:
    /// off (the share of the step does not depend on its size).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub step_size_mm: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// A learned term that cannot be used: the field at fault (relative to the term) and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct LearnedError {
    /// Field of the term, e.g. `knots`.
    pub field: String,
    /// What is wrong.
    pub message: String,
}

fn err(field: &str, message: String) -> LearnedError {
    LearnedError {
        field: field.into(),
        message,
    }
}

impl LearnedTerm {
    /// Check the term: a known effect (one of `known_effects`, the model file's effect names,
    /// passed in so this module stays below the effects), at least two strictly increasing
    /// finite knots, heights (and SDs) of the knots' length, finite (SDs non-negative),
    /// `step_fraction` only along `since_change_s` (and `steps` other than `all` only with it),
    /// finite exponents.
    pub fn validate(&self, known_effects: &[&str]) -> Result<(), LearnedError> {
        if !known_effects.contains(&self.effect.as_str()) {
            return Err(err(
                "effect",
                format!(
                    "unknown effect {:?} (known: {})",
                    self.effect,
                    known_effects.join(", ")
                ),
            ));
        }
        let k = self.knots.len();
        if k < 2 {
            return Err(err("knots", format!("{k} knot(s): at least 2 needed")));
        }
        for (i, x) in self.knots.iter().enumerate() {
            if !x.is_finite() {
                return Err(err(
                    "knots",
                    format!("knot {i} is {x}, not a finite number"),
                ));
            }
            if i > 0 && *x <= self.knots[i - 1] {
                return Err(err(
                    "knots",
                    format!(
                        "not strictly increasing at index {i} ({x} after {})",
                        self.knots[i - 1]
                    ),
                ));
            }
        }
        for (name, v, sd) in [
            ("r1", Some(&self.r1), false),
            ("r2", Some(&self.r2), false),
            ("sd_r1", self.sd_r1.as_ref(), true),
            ("sd_r2", self.sd_r2.as_ref(), true),
        ] {
            let Some(v) = v else { continue };
            if v.len() != k {
                return Err(err(name, format!("{} value(s) for {k} knots", v.len())));
            }
            for (i, x) in v.iter().enumerate() {
                if !x.is_finite() || (sd && *x < 0.0) {
                    return Err(err(
                        name,
                        format!(
                            "value {i} is {x}: must be a finite number{}",
                            if sd { ", not negative" } else { "" }
                        ),
                    ));
                }
            }
        }
        if (self.mode == LearnedMode::StepFraction) != (self.axis == LearnedAxis::SinceChangeS) {
            return Err(err(
                "mode",
                "step_fraction goes with the axis since_change_s, and since_change_s with step_fraction only".into(),
            ));
        }
        if !(self.step_size_mm.is_finite() && self.step_size_mm >= 0.0) {
            return Err(err(
                "step_size_mm",
                format!(
                    "{} is not a finite size >= 0 mm (0: off)",
                    self.step_size_mm
                ),
            ));
        }
        if self.step_size_mm != 0.0 && self.mode != LearnedMode::StepFraction {
            return Err(err(
                "step_size_mm",
                "only a step_fraction term scales with the step's size".into(),
            ));
        }
        if self.steps != LearnedSteps::All && self.mode != LearnedMode::StepFraction {
            return Err(err(
                "steps",
                "only a step_fraction term follows growing or shrinking steps".into(),
            ));
        }
        if self.mode == LearnedMode::RateHz
            && self.axis != LearnedAxis::FHz
            && self.axis != LearnedAxis::ZmMm
        {
            return Err(err(
                "mode",
                "rate_hz acts on the steady map: its axis must be f_hz or z_m_mm".into(),
            ));
        }
        if self.amplitude_exponent != 0.0 && !self.on_steady_map() {
            return Err(err(
                "amplitude_exponent",
                "a field-scaled amplitude needs the field: only along f_hz or z_m_mm".into(),
            ));
        }
        for (name, v) in [
            ("field_exponent", self.field_exponent),
            ("amplitude_exponent", self.amplitude_exponent),
        ] {
            if !v.is_finite() {
                return Err(err(name, format!("{v} is not a finite number")));
            }
        }
        Ok(())
    }

    /// The multiplier of a `step_fraction` term's heights for a step `delta` \[mm\] of one
    /// radius: whether the term follows that step at all (`steps`), times the step's size
    /// relative to `step_size_mm` where that is set.
    pub fn step_share(&self, delta: f64) -> f64 {
        step_share(self.steps, self.step_size_mm, delta)
    }

    /// Heights at `x` per radius and their slopes d/dx (piecewise linear, flat beyond the end
    /// knots, slope 0 there).
    pub fn value(&self, x: f64) -> ([f64; 2], [f64; 2]) {
        let k = &self.knots;
        let n = k.len();
        let h = [&self.r1, &self.r2];
        if n == 0 {
            return ([0.0; 2], [0.0; 2]);
        }
        // At or below the first knot (or a NaN argument): the first height.
        if x.partial_cmp(&k[0]) != Some(std::cmp::Ordering::Greater) {
            return ([h[0][0], h[1][0]], [0.0; 2]);
        }
        if x >= k[n - 1] {
            return ([h[0][n - 1], h[1][n - 1]], [0.0; 2]);
        }
        let j = k.partition_point(|&v| v <= x).saturating_sub(1).min(n - 2);
        let dx = k[j + 1] - k[j];
        let u = (x - k[j]) / dx;
        let mut v = [0.0; 2];
        let mut s = [0.0; 2];
        for a in 0..2 {
            v[a] = (1.0 - u) * h[a][j] + u * h[a][j + 1];
            s[a] = (h[a][j + 1] - h[a][j]) / dx;
        }
        (v, s)
    }

    /// True when the term acts on the steady map (f and z_m axes).
    pub fn on_steady_map(&self) -> bool {
        matches!(self.axis, LearnedAxis::FHz | LearnedAxis::ZmMm)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn term() -> LearnedTerm {
        LearnedTerm {
            effect: "cohesion_loss".into(),
            axis: LearnedAxis::ZmMm,
            mode: LearnedMode::AddMm,
            knots: vec![13.5, 18.5, 23.5],
            r1: vec![0.0, 0.5, 1.5],
            r2: vec![0.0, 1.0, 3.0],
            sd_r1: None,
            sd_r2: None,
            field_exponent: 0.0,
            amplitude_exponent: 0.0,
            steps: LearnedSteps::All,
            step_size_mm: 0.0,
        }
    }

    #[test]
    fn interpolates_and_holds_flat_beyond_the_ends() {
        let t = term();
        let (v, s) = t.value(16.0);
        assert!((v[0] - 0.25).abs() < 1e-12 && (v[1] - 0.5).abs() < 1e-12);
        assert!((s[0] - 0.1).abs() < 1e-12 && (s[1] - 0.2).abs() < 1e-12);
        assert_eq!(t.value(3.0), ([0.0, 0.0], [0.0, 0.0]));
        assert_eq!(t.value(40.0), ([1.5, 3.0], [0.0, 0.0]));
    }

    #[test]
    fn bad_terms_are_refused_naming_the_field() {
        let mut t = term();
        t.knots[2] = 18.5;
        let e = t.validate(&crate::effect_kind::NAMES).unwrap_err();
        assert_eq!(e.field, "knots");
        assert!(
            e.message.contains("not strictly increasing at index 2"),
            "{e}"
        );
        // A direction only for a transient's step.
        let mut t = term();
        t.steps = LearnedSteps::Growing;
        let e = t.validate(&crate::effect_kind::NAMES).unwrap_err();
        assert_eq!(e.field, "steps", "{e}");
        t.axis = LearnedAxis::SinceChangeS;
        t.mode = LearnedMode::StepFraction;
        t.effect = "formation_lag".into();
        assert!(t.validate(&crate::effect_kind::NAMES).is_ok());
        let json = serde_json::to_string(&t).unwrap();
        assert!(json.contains(r#""steps":"growing""#), "{json}");
        assert!(!serde_json::to_string(&term()).unwrap().contains("steps"));
        let mut t = term();
        t.r2.pop();
        assert_eq!(
            t.validate(&crate::effect_kind::NAMES).unwrap_err().field,
            "r2"
        );
        let mut t = term();
        t.mode = LearnedMode::StepFraction;
        assert_eq!(
            t.validate(&crate::effect_kind::NAMES).unwrap_err().field,
            "mode"
        );
        let mut t = term();
        t.effect = "magic".into();
        assert!(t
            .validate(&crate::effect_kind::NAMES)
            .unwrap_err()
            .message
            .contains("phase_lag"));
        let mut t = term();
        t.sd_r1 = Some(vec![0.1, -0.1, 0.1]);
        assert_eq!(
            t.validate(&crate::effect_kind::NAMES).unwrap_err().field,
            "sd_r1"
        );
        assert!(term().validate(&crate::effect_kind::NAMES).is_ok());
    }

    #[test]
    fn json_names_are_the_documented_ones() {
        let j = serde_json::to_value(term()).unwrap();
        assert_eq!(j["axis"], "z_m_mm");
        assert_eq!(j["mode"], "add_mm");
        let back: LearnedTerm = serde_json::from_value(j).unwrap();
        assert_eq!(back, term());
    }
}
