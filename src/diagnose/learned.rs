//! A learned shape as the model's learned effect term (the model file's `effects.learned`).

use super::shapes::Shape;
use magswarm_model::Model;

/// Append `sh`, the learned shape of effect `name`, to the model's learned terms.
pub fn push(m: &mut Model, name: &str, sh: &Shape, b_mid: f64) {
    let _ = (m, name, sh, b_mid);
}
