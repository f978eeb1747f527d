//! A generic fallback for `fmi2GetDirectionalDerivative`.
//!
//! `providesDirectionalDerivative="true"` is declared for every FMU of this shell, so
//! every model needs *some* implementation. Models with analytic Jacobians (the plant)
//! override [`crate::FmuModel::directional_derivative`]; this fallback perturbs inputs on
//! two clones and takes a central difference. It cannot perturb states (there is no
//! generic way to set them), so a known that is not an input is an error.

use crate::log::Ctx;
use crate::model::{Causality, Fmi2Err, FmuModel};

/// Central finite difference of `unknowns` along the direction `dv_known` in the space of
/// the `knowns` (which must be Real inputs).
pub fn finite_difference<M: FmuModel>(
    model: &M,
    unknowns: &[u32],
    knowns: &[u32],
    dv_known: &[f64],
) -> Result<Vec<f64>, Fmi2Err> {
    let info = M::model_info();
    for k in knowns {
        let v = info.variables.iter().find(|v| v.vr == *k);
        if !v.is_some_and(|v| v.causality == Causality::Input) {
            return Err(Fmi2Err::error(format!(
                "directional derivative with respect to value reference {k}: this model only provides \
                 finite differences with respect to inputs"
            )));
        }
    }
    let norm = dv_known.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    if norm == 0.0 {
        return Ok(vec![0.0; unknowns.len()]);
    }
    let mut base = model.clone();
    let mut scale = 1.0f64;
    for k in knowns {
        scale = scale.max(base.get_real(*k)?.abs());
    }
    // Step along the unit direction: cube root of epsilon balances truncation and rounding.
    let h = f64::EPSILON.cbrt() * scale / norm;
    let mut plus = model.clone();
    let mut minus = model.clone();
    let mut ctx = Ctx::silent();
    for (k, dv) in knowns.iter().zip(dv_known) {
        let x = base.get_real(*k)?;
        plus.set_real(&mut ctx, *k, x + h * dv)?;
        minus.set_real(&mut ctx, *k, x - h * dv)?;
    }
    unknowns
        .iter()
        .map(|u| Ok((plus.get_real(*u)? - minus.get_real(*u)?) / (2.0 * h)))
        .collect()
}
