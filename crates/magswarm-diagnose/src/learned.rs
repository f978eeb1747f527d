//! A learned shape as the model's learned effect term (the model file's `effects.learned`),
//! so that `predict`, the FMU and the bridge's shadow model run what diagnose fitted.

use super::shapes::{Axis, Mode, Shape};
use magswarm_model::effects::EffectKind;
use magswarm_model::learned::{LearnedAxis, LearnedMode, LearnedTerm};
use magswarm_model::Model;

/// The learned term of `sh`, the shape of effect `name`. Diagnose measures the field relative
/// to its value at the middle of the data's z_m range (`b_mid` \[T\]); the model file relative to
/// the model's B_ref: knots of a field-scaled frequency and field-scaled heights are converted.
pub fn term(m: &Model, kind: EffectKind, sh: &Shape, b_mid: f64) -> LearnedTerm {
    let f = &sh.family;
    let ratio = (m.steady.B_ref / b_mid.max(1e-300)).max(1e-300);
    let (axis, nu) = match f.axis {
        Axis::F { nu } => (LearnedAxis::FHz, nu),
        Axis::Z => (LearnedAxis::ZmMm, 0.0),
        Axis::T => (LearnedAxis::TS, 0.0),
        Axis::Since => (LearnedAxis::SinceChangeS, 0.0),
    };
    let kscale = ratio.powf(nu);
    let vscale = ratio.powf(f.amp);
    let scaled = |v: &[f64]| -> Vec<f64> { v.iter().map(|x| x * vscale).collect() };
    LearnedTerm {
        effect: kind.name().to_string(),
        axis,
        mode: match f.mode {
            Mode::Add => LearnedMode::AddMm,
            // An aspect change is a relative change with opposite heights (the shape holds
            // them per radius).
            Mode::Relative | Mode::Aspect | Mode::Common => LearnedMode::Relative,
            Mode::StepFraction => LearnedMode::StepFraction,
            Mode::Rate => LearnedMode::RateHz,
        },
        knots: f.knots.iter().map(|k| k * kscale).collect(),
        r1: scaled(&sh.values[0]),
        r2: scaled(&sh.values[1]),
        sd_r1: Some(scaled(&sh.sd[0])),
        sd_r2: Some(scaled(&sh.sd[1])),
        field_exponent: nu,
        amplitude_exponent: f.amp,
        steps: f.steps,
        step_size_mm: f.size_mm,
    }
}

/// Append `sh`, the learned shape of effect `name`, to the model's learned terms.
pub fn push(m: &mut Model, kind: EffectKind, sh: &Shape, b_mid: f64) {
    let t = term(m, kind, sh, b_mid);
    m.effects.learned.push(t);
}
