//! The analytic Jacobian of `MagSwarm.fmu`: every output and state derivative with respect
//! to the inputs and the continuous states, what both shells turn into directional (and in
//! FMI 3.0 adjoint) derivatives. An implicit integrator (CVode's BDF in Model Exchange) gets
//! an exact Jacobian from it.

use super::*;

/// The knowns, in column order: the inputs, then the continuous states (SI).
const KNOWNS: [u32; 8] = [
    vr::Z_M,
    vr::OMEGA_M,
    vr::R1_ODE,
    vr::R2_ODE,
    vr::FORM_X1,
    vr::FORM_V1,
    vr::FORM_X2,
    vr::FORM_V2,
];

/// Column of a known value reference.
pub(crate) fn known_index(known: u32) -> Result<usize, ModelError> {
    KNOWNS.iter().position(|&k| k == known).ok_or_else(|| {
        ModelError::error(format!(
            "derivative with respect to value reference {known}: the knowns are the inputs \
             (z_m, omega_m) and the continuous states (r1_ode, r2_ode, form_x1, form_v1, \
             form_x2, form_v2)"
        ))
    })
}

impl MagSwarm {
    /// The Jacobian row of an unknown with respect to [`KNOWNS`] (SI). The outputs `r1`,
    /// `r2` are the *observed* radii ([`Plant::outputs`]): with `formation_lag` the state of
    /// ODE (4) enters them with the weight `1 - share` and the slow mode with `share`, and
    /// `particle_drift` and `camera_bias` scale them by the observation gain (offsets have
    /// no derivative). Without effects the outputs are the ODE states.
    pub(crate) fn jac_row(&mut self, unknown: u32) -> Result<[f64; 8], ModelError> {
        let plant = self.plant();
        let sp = plant.outputs().steady;
        let f = sp.field;
        let effects = &plant.model().effects;
        let (gain, _) = effects.observation(plant.time());
        let share = effects.formation_lag.map_or(0.0, |fl| fl.share);
        let mut row = [0.0; 8];
        match unknown {
            vr::R1 | vr::R2 => {
                let i = (unknown - vr::R1) as usize;
                row[2 + i] = gain[i] * (1.0 - share);
                row[4 + 2 * i] = gain[i] * share;
            }
            vr::R1_SS | vr::R2_SS => {
                let i = (unknown - vr::R1_SS) as usize;
                row[0] = sp.jac[i][0] * 1e-3;
                row[1] = sp.jac[i][1] * 1e-3;
            }
            vr::S_X | vr::S_Y => {
                let i = (unknown - vr::S_X) as usize;
                row[0] = sp.ds[i][0];
                row[1] = sp.ds[i][1];
            }
            vr::B => row[0] = f.db_dz,
            vr::G_Z => row[0] = f.dg_z_dz,
            vr::K_XX => row[0] = f.dk_xx_dz,
            vr::K_YY => row[0] = f.dk_yy_dz,
            vr::R1_ODE..=vr::FORM_V2 => row[2 + (unknown - vr::R1_ODE) as usize] = 1.0,
            vr::DER_R1 | vr::DER_R2 | vr::DER_FORM_X1..=vr::DER_FORM_V2 => {
                let i = match unknown {
                    vr::DER_R1 => 0,
                    vr::DER_R2 => 1,
                    d => (d - vr::DER_FORM_X1 + 2) as usize,
                };
                // Derivatives in mm/s per mm of state, per m or rad/s of input: the state
                // columns are the same in SI, the input columns scale by 1e-3.
                let j = plant.continuous_jacobian()[i];
                row[0] = j[0] * 1e-3;
                row[1] = j[1] * 1e-3;
                row[2..].copy_from_slice(&j[2..]);
            }
            other => {
                return Err(ModelError::error(format!(
                    "derivative of value reference {other}: not an output, a continuous state or \
                     a state derivative"
                )))
            }
        }
        Ok(row)
    }
}
