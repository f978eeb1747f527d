//! A generic fallback for [`crate::FmuModel::jacobian`].
//!
//! Directional (and in FMI 3.0 adjoint) derivatives are declared for every FMU of these
//! shells, so every model needs *some* Jacobian. Models with analytic Jacobians (the plant)
//! override [`crate::FmuModel::jacobian`]; this fallback perturbs each input on two clones
//! and takes a central difference. It cannot perturb states (there is no generic way to set
//! them), so a known that is not an input is an error.

use crate::log::Ctx;
use crate::model::FmuModel;
use crate::status::ModelError;
use crate::variable::Causality;

/// Central finite differences of `unknowns` with respect to each of the `knowns` (which
/// must be Real inputs): the Jacobian, row-major.
pub fn finite_difference<M: FmuModel>(
    model: &M,
    unknowns: &[u32],
    knowns: &[u32],
) -> Result<Vec<f64>, ModelError> {
    let info = M::model_info();
    for k in knowns {
        let v = info.variables.iter().find(|v| v.vr == *k);
        if !v.is_some_and(|v| v.causality == Causality::Input) {
            return Err(ModelError::error(format!(
                "derivative with respect to value reference {k}: this model only provides \
                 finite differences with respect to inputs"
            )));
        }
    }
    let mut j = vec![0.0; unknowns.len() * knowns.len()];
    let mut base = model.clone();
    let mut ctx = Ctx::silent();
    for (c, &k) in knowns.iter().enumerate() {
        let x = base.get_real(k)?;
        // Cube root of epsilon balances truncation and rounding.
        let h = f64::EPSILON.cbrt() * x.abs().max(1.0);
        let mut plus = model.clone();
        let mut minus = model.clone();
        plus.set_real(&mut ctx, k, x + h)?;
        minus.set_real(&mut ctx, k, x - h)?;
        for (r, &u) in unknowns.iter().enumerate() {
            j[r * knowns.len() + c] = (plus.get_real(u)? - minus.get_real(u)?) / (2.0 * h);
        }
    }
    Ok(j)
}
