//! The shadow model: a model run beside the rig on the inputs in force, compared with what
//! the camera measures (`[shadow]`; the paper model unless `model` names a model file).
//! `run` writes it to the log's `shadow_r1_mm`, `shadow_r2_mm`; the rig FMU outputs it as
//! `r1_shadow`, `r2_shadow`.

use magswarm_model::{hz_to_rad_s, Plant};

use crate::config::{ConfigError, RigConfig};

/// A model advanced frame by frame.
pub struct Shadow {
    plant: Plant,
}

impl Shadow {
    /// The config's shadow model starting on its map at `start` (z_m \[mm\], f \[Hz\]); `None`
    /// when `[shadow] enabled = false`.
    pub fn from_config(cfg: &RigConfig, start: (f64, f64)) -> Result<Option<Shadow>, ConfigError> {
        if !cfg.shadow.enabled {
            return Ok(None);
        }
        let m = cfg.model("shadow.model", cfg.shadow.model.as_ref())?;
        Ok(Some(Shadow {
            plant: Plant::new(m, start.0 * 1e-3, hz_to_rad_s(start.1)),
        }))
    }

    /// Advance to the camera time `t` \[s\] under the inputs `applied` (z_m \[mm\], f \[Hz\]) in
    /// force since the last call, and return the radii a camera would see \[mm\] (the model's
    /// observed outputs: formation mode, drift and camera bias applied).
    pub fn advance(&mut self, t: f64, applied: (f64, f64)) -> [f64; 2] {
        let p = &mut self.plant;
        let dt = t - p.time();
        if dt > 0.0 {
            p.set_inputs(applied.0 * 1e-3, hz_to_rad_s(applied.1));
            if p.step(dt).is_err() {
                // Keep the last state; the comparison shows the model stuck, not a made-up value.
                p.set_time(t);
            }
        }
        p.observed_radii()
    }
}
