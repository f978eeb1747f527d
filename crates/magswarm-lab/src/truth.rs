//! The lab's swarm: a truth model (a model file with any effects) plus optional *foreign*
//! effects, written in forms that differ from the candidate forms of `magswarm_model::effects`
//! (so that a diagnosis tested on lab data does not merely recover its own generator).
//!
//! | foreign kind | stands for | form (differs from the candidate by) |
//! | --- | --- | --- |
//! | `phase_lag_logistic` | phase lag | the swarm is driven at omega (1 - depth / (1 + exp(-(f - f_c)/width))): a smooth logistic roll-off, fed as the plant's omega (so it also enters the particle term of (7)) instead of a sharp field-dependent step-out in Phi and E only |
//! | `cohesion_poly` | cohesion loss | radii grow by 1 + gain_i ((z - z0)_+)^power (polynomial, per axis, output-level with a first-order lag) instead of a Gaussian fading of S |
//! | `input_lag` | formation lag | the swarm sees the commanded inputs through a dead time and a first-order filter (inputs lag) instead of a parallel second-order mode on the radii |
//! | `drift_sqrt` | particle drift | radii scale by 1 + c sqrt(t / 1 h) instead of exp(rate t) |
//! | `camera_projection` | camera bias | the rotating ellipse is projected onto an image plane tilted about an arbitrary in-plane axis, at the rotation phase of each frame, then scaled and offset, instead of cos(tilt) on r2 |
//! | `axis_tilt` | centroid offset | the centroid's distance from the axis grows with depth (tilted rotation axis): rho = rho_0 + offset + tan(tilt) (z - z_ref) |
//! | `bump` | none: an effect no candidate describes | a smooth local change of the radii around one operating point, amp_i exp(-((z - z0)/w_z)^2/2 - ((f - f0)/w_f)^2/2) mm (a resonance of the tank, a reflection the camera picks up there): what diagnose must report as unexplained rather than misname |

use super::LabError;
use magswarm_model::effects::EffectKind;
use magswarm_model::{hz_to_rad_s, Model, Plant};
use rand::rngs::StdRng;
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// A foreign effect of the lab's truth (see the module table).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Foreign {
    /// Logistic roll-off of the swarm's effective rotation frequency.
    PhaseLagLogistic {
        /// Centre of the roll-off \[Hz\].
        f_c_hz: f64,
        /// Width of the roll-off \[Hz\].
        width_hz: f64,
        /// Fraction of the rotation lost far above f_c [-] (0..1).
        depth: f64,
    },
    /// Polynomial growth of the radii past z0.
    CohesionPoly {
        /// Onset \[mm\].
        z0_mm: f64,
        /// Relative growth per mm^power, per axis [r1, r2].
        gain: [f64; 2],
        /// Power of the growth [-].
        power: f64,
        /// Time constant with which the growth follows an input change \[s\].
        #[serde(default = "two")]
        tau_s: f64,
    },
    /// Dead time and first-order lag of the inputs the swarm sees.
    InputLag {
        /// Time constant \[s\].
        tau_s: f64,
        /// Dead time \[s\].
        #[serde(default)]
        delay_s: f64,
    },
    /// Square-root-in-time change of the radii over a session.
    DriftSqrt {
        /// Relative change after one hour [-] (negative: shrinking).
        c_per_sqrt_h: f64,
    },
    /// True projection of the rotating ellipse onto a tilted image plane.
    CameraProjection {
        /// Tilt of the image plane \[deg\].
        tilt_deg: f64,
        /// Direction of the tilt axis in the swarm plane, from the r1 axis \[deg\].
        #[serde(default)]
        axis_deg: f64,
        /// Scale [-].
        #[serde(default = "one")]
        scale: f64,
        /// Offset \[mm\].
        #[serde(default)]
        offset_mm: f64,
    },
    /// Centroid distance from the axis growing with depth (tilted rotation axis).
    AxisTilt {
        /// Extra radial offset at z_ref \[mm\].
        #[serde(default)]
        offset_mm: f64,
        /// Tilt of the rotation axis \[deg\].
        tilt_deg: f64,
        /// Distance at which the extra offset is `offset_mm` \[mm\].
        #[serde(default = "z_ref")]
        z_ref_mm: f64,
    },
    /// A local change of the radii around one operating point that no candidate describes.
    Bump {
        /// Centre z_m \[mm\].
        z_mm: f64,
        /// Centre frequency \[Hz\].
        f_hz: f64,
        /// Width in z_m (SD) \[mm\].
        width_z_mm: f64,
        /// Width in f (SD) \[Hz\].
        width_f_hz: f64,
        /// Change of r1, r2 at the centre \[mm\].
        amp_mm: [f64; 2],
    },
}

fn two() -> f64 {
    2.0
}
fn one() -> f64 {
    1.0
}
fn z_ref() -> f64 {
    13.5
}

impl Foreign {
    /// Name of the effect this foreign form stands for.
    pub fn effect(&self) -> &'static str {
        match self {
            Foreign::PhaseLagLogistic { .. } => EffectKind::PhaseLag.name(),
            Foreign::CohesionPoly { .. } => EffectKind::CohesionLoss.name(),
            Foreign::InputLag { .. } => EffectKind::FormationLag.name(),
            Foreign::DriftSqrt { .. } => EffectKind::ParticleDrift.name(),
            Foreign::CameraProjection { .. } => EffectKind::CameraBias.name(),
            Foreign::AxisTilt { .. } => EffectKind::CentroidOffset.name(),
            Foreign::Bump { .. } => "bump (no candidate)",
        }
    }

    /// Check the values; the message names the kind and field.
    pub fn validate(&self) -> Result<(), LabError> {
        let fin = |name: &str, v: f64, lo: f64, hi: f64| -> Result<(), LabError> {
            if !(v.is_finite() && v >= lo && v <= hi) {
                return Err(LabError::invalid(
                    format!("foreign {}: {name}", self.effect()),
                    format!("= {v} not in [{lo}, {hi}]"),
                ));
            }
            Ok(())
        };
        match *self {
            Foreign::PhaseLagLogistic {
                f_c_hz,
                width_hz,
                depth,
            } => {
                fin("f_c_hz", f_c_hz, 0.0, 1e3)?;
                fin("width_hz", width_hz, 1e-3, 1e3)?;
                fin("depth", depth, 0.0, 0.99)
            }
            Foreign::CohesionPoly {
                z0_mm,
                gain,
                power,
                tau_s,
            } => {
                fin("z0_mm", z0_mm, -50.0, 200.0)?;
                fin("gain[0]", gain[0], -1.0, 10.0)?;
                fin("gain[1]", gain[1], -1.0, 10.0)?;
                fin("power", power, 0.5, 6.0)?;
                fin("tau_s", tau_s, 1e-3, 1e4)
            }
            Foreign::InputLag { tau_s, delay_s } => {
                fin("tau_s", tau_s, 1e-3, 1e4)?;
                fin("delay_s", delay_s, 0.0, 1e3)
            }
            Foreign::DriftSqrt { c_per_sqrt_h } => fin("c_per_sqrt_h", c_per_sqrt_h, -0.9, 5.0),
            Foreign::CameraProjection {
                tilt_deg,
                axis_deg,
                scale,
                offset_mm,
            } => {
                fin("tilt_deg", tilt_deg, -80.0, 80.0)?;
                fin("axis_deg", axis_deg, -360.0, 360.0)?;
                fin("scale", scale, 0.2, 5.0)?;
                fin("offset_mm", offset_mm, -20.0, 20.0)
            }
            Foreign::AxisTilt {
                offset_mm,
                tilt_deg,
                z_ref_mm,
            } => {
                fin("offset_mm", offset_mm, -50.0, 50.0)?;
                fin("tilt_deg", tilt_deg, -45.0, 45.0)?;
                fin("z_ref_mm", z_ref_mm, -50.0, 200.0)
            }
            Foreign::Bump {
                z_mm,
                f_hz,
                width_z_mm,
                width_f_hz,
                amp_mm,
            } => {
                fin("z_mm", z_mm, -50.0, 200.0)?;
                fin("f_hz", f_hz, 0.0, 1e3)?;
                fin("width_z_mm", width_z_mm, 1e-3, 1e3)?;
                fin("width_f_hz", width_f_hz, 1e-3, 1e3)?;
                fin("amp_mm[0]", amp_mm[0], -20.0, 20.0)?;
                fin("amp_mm[1]", amp_mm[1], -20.0, 20.0)
            }
        }
    }
}

/// The lab's swarm: truth plant, foreign effects and their state. Inputs are SI
/// (z_m \[m\], omega [rad/s]), as for every plant in magswarm; radii are in mm.
#[derive(Debug, Clone)]
pub struct LabSwarm {
    model: Model,
    foreign: Vec<Foreign>,
    plant: Plant,
    /// Commanded inputs (z_m [mm], f [Hz]) and the time they were commanded, newest last
    /// (a dead time needs the recent history).
    commands: Vec<(f64, f64, f64)>,
    /// Inputs the swarm sees after `input_lag` (z_m [mm], f [Hz]).
    seen: [f64; 2],
    /// Output factor of `cohesion_poly` per axis, lagging its target.
    growth: [f64; 2],
    t: f64,
}

impl LabSwarm {
    /// A swarm formed at rest at (z_m \[m\], omega [rad/s]) at session time 0.
    pub fn new(model: Model, foreign: Vec<Foreign>, z_m: f64, omega: f64) -> LabSwarm {
        let (z, f) = (z_m * 1e3, omega.abs() / std::f64::consts::TAU);
        let mut s = LabSwarm {
            plant: Plant::new(model.clone(), z_m, omega),
            model,
            foreign,
            commands: vec![(f64::NEG_INFINITY, z, f)],
            seen: [z, f],
            growth: [1.0, 1.0],
            t: 0.0,
        };
        s.apply_inputs();
        s.plant.settle();
        s.growth = s.growth_target();
        s
    }

    /// Session time \[s\].
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Command new inputs (z_m \[m\], omega [rad/s]) from now on.
    pub fn set_inputs(&mut self, z_m: f64, omega: f64) {
        let (z, f) = (z_m * 1e3, omega.abs() / std::f64::consts::TAU);
        let last = self.commands.last().copied();
        if last.map(|c| (c.1, c.2)) != Some((z, f)) {
            self.commands.push((self.t, z, f));
        }
        if !self.has_input_lag() {
            self.seen = [z, f];
            self.apply_inputs();
        }
    }

    fn has_input_lag(&self) -> bool {
        self.foreign
            .iter()
            .any(|f| matches!(f, Foreign::InputLag { .. }))
    }

    /// Commanded inputs in force at time t (mm, Hz).
    fn command_at(&self, t: f64) -> [f64; 2] {
        let c = self
            .commands
            .iter()
            .rev()
            .find(|c| c.0 <= t)
            .unwrap_or(&self.commands[0]);
        [c.1, c.2]
    }

    /// Feed the seen inputs, through the foreign input transforms, to the plant.
    fn apply_inputs(&mut self) {
        let [z, f] = self.seen;
        let mut f_eff = f;
        for fx in &self.foreign {
            if let Foreign::PhaseLagLogistic {
                f_c_hz,
                width_hz,
                depth,
            } = *fx
            {
                f_eff *= 1.0 - depth / (1.0 + (-(f - f_c_hz) / width_hz).exp());
            }
        }
        for fx in &self.foreign {
            if let Foreign::AxisTilt {
                offset_mm,
                tilt_deg,
                z_ref_mm,
            } = *fx
            {
                let mut m = self.model.clone();
                let extra = offset_mm + tilt_deg.to_radians().tan() * (z - z_ref_mm);
                m.magnet.lateral_offset_m = (m.magnet.lateral_offset_m + extra * 1e-3).abs();
                if m != *self.plant.model() {
                    self.plant.set_model(m);
                }
            }
        }
        self.plant.set_inputs(z * 1e-3, hz_to_rad_s(f_eff));
    }

    fn growth_target(&self) -> [f64; 2] {
        let mut g = [1.0, 1.0];
        for fx in &self.foreign {
            if let Foreign::CohesionPoly {
                z0_mm, gain, power, ..
            } = *fx
            {
                let x = (self.seen[0] - z0_mm).max(0.0).powf(power);
                g = [g[0] * (1.0 + gain[0] * x), g[1] * (1.0 + gain[1] * x)];
            }
        }
        g
    }

    fn growth_tau(&self) -> Option<f64> {
        self.foreign.iter().find_map(|f| match *f {
            Foreign::CohesionPoly { tau_s, .. } => Some(tau_s),
            _ => None,
        })
    }

    /// Advance to session time `t_end` \[s\] under the commanded inputs.
    pub fn advance_to(&mut self, t_end: f64) -> Result<(), StepFailed> {
        let lag = self.foreign.iter().find_map(|f| match *f {
            Foreign::InputLag { tau_s, delay_s } => Some((tau_s, delay_s)),
            _ => None,
        });
        while self.t < t_end {
            let mut h = t_end - self.t;
            if let Some((tau, _)) = lag {
                h = h.min((tau / 10.0).clamp(0.01, 0.25));
            }
            if let Some((tau, delay)) = lag {
                // Exact first-order update toward the delayed command, held over the substep.
                let target = self.command_at(self.t + 0.5 * h - delay);
                let a = (-h / tau).exp();
                for i in 0..2 {
                    self.seen[i] = target[i] + (self.seen[i] - target[i]) * a;
                }
                self.apply_inputs();
            }
            step_robust(&mut self.plant, h)?;
            if let Some(tau) = self.growth_tau() {
                let target = self.growth_target();
                let a = (-h / tau).exp();
                for i in 0..2 {
                    self.growth[i] = target[i] + (self.growth[i] - target[i]) * a;
                }
            }
            self.t += h;
        }
        Ok(())
    }

    /// The radii a perfect measurement at this instant reads \[mm\] (truth model with its
    /// effects, then the foreign ones). `rng` draws the rotation phase of a projected frame.
    pub fn true_radii(&self, rng: &mut StdRng) -> [f64; 2] {
        let o = self.plant.observed_radii();
        let mut r = [o[0] * self.growth[0], o[1] * self.growth[1]];
        for fx in &self.foreign {
            match *fx {
                Foreign::DriftSqrt { c_per_sqrt_h } => {
                    let g = 1.0 + c_per_sqrt_h * (self.t.max(0.0) / 3600.0).sqrt();
                    r = [r[0] * g, r[1] * g];
                }
                Foreign::Bump {
                    z_mm,
                    f_hz,
                    width_z_mm,
                    width_f_hz,
                    amp_mm,
                } => {
                    let (dz, df) = (
                        (self.seen[0] - z_mm) / width_z_mm,
                        (self.seen[1] - f_hz) / width_f_hz,
                    );
                    let g = (-0.5 * (dz * dz + df * df)).exp();
                    r = [r[0] + amp_mm[0] * g, r[1] + amp_mm[1] * g];
                }
                Foreign::CameraProjection {
                    tilt_deg,
                    axis_deg,
                    scale,
                    offset_mm,
                } => {
                    let phase = rng.random::<f64>() * std::f64::consts::TAU;
                    let p = project_ellipse(r, phase, tilt_deg, axis_deg);
                    r = [scale * p[0] + offset_mm, scale * p[1] + offset_mm];
                }
                _ => {}
            }
        }
        r
    }

    /// The truth model in use (with the foreign centroid applied, if any).
    pub fn model(&self) -> &Model {
        self.plant.model()
    }
}

/// Principal radii (minor, major) of the image of an ellipse with radii `r` = (r1 along the
/// swarm's x, r2 along y) turned by `phase` \[rad\], seen by a camera whose image plane is
/// tilted by `tilt_deg` about an in-plane axis at `axis_deg` from x (orthographic projection).
pub fn project_ellipse(r: [f64; 2], phase: f64, tilt_deg: f64, axis_deg: f64) -> [f64; 2] {
    // Ellipse as x^T Q x = 1, Q = R diag(1/a^2, 1/b^2) R^T.
    let (s, c) = phase.sin_cos();
    let (ia, ib) = (1.0 / (r[0] * r[0]), 1.0 / (r[1] * r[1]));
    let q = [
        [c * c * ia + s * s * ib, c * s * (ia - ib)],
        [c * s * (ia - ib), s * s * ia + c * c * ib],
    ];
    // Projection P shrinks the direction u (perpendicular to the tilt axis) by cos(tilt).
    let (sa, ca) = axis_deg.to_radians().sin_cos();
    let u = [-sa, ca];
    let k = tilt_deg.to_radians().cos();
    // P^-1 = I + (1/k - 1) u u^T.
    let m = 1.0 / k - 1.0;
    let pinv = [
        [1.0 + m * u[0] * u[0], m * u[0] * u[1]],
        [m * u[1] * u[0], 1.0 + m * u[1] * u[1]],
    ];
    // Q' = P^-T Q P^-1 (P^-1 symmetric).
    let mul = |a: [[f64; 2]; 2], b: [[f64; 2]; 2]| {
        let mut o = [[0.0; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                o[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j];
            }
        }
        o
    };
    let qp = mul(mul(pinv, q), pinv);
    let tr = qp[0][0] + qp[1][1];
    let det = qp[0][0] * qp[1][1] - qp[0][1] * qp[1][0];
    let d = (tr * tr / 4.0 - det).max(0.0).sqrt();
    let (lmax, lmin) = (tr / 2.0 + d, tr / 2.0 - d);
    [1.0 / lmax.sqrt(), 1.0 / lmin.sqrt()]
}

/// The truth's ODE (4) could not be integrated: where, and the integrator's message.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("lab: ODE (4) could not be integrated at z_m = {z_mm:.3} mm, f = {f_hz:.3} Hz: {message}")]
pub struct StepFailed {
    /// z_m \[mm\].
    pub z_mm: f64,
    /// f \[Hz\].
    pub f_hz: f64,
    /// The integrator's message.
    pub message: String,
}

/// Step, retrying in smaller pieces if the integrator gives up.
fn step_robust(plant: &mut Plant, h: f64) -> Result<(), StepFailed> {
    if plant.step(h).is_ok() {
        return Ok(());
    }
    let n = 64;
    for _ in 0..n {
        if let Err(e) = plant.step(h / n as f64) {
            let (z, w) = plant.inputs();
            return Err(StepFailed {
                z_mm: z * 1e3,
                f_hz: w / std::f64::consts::TAU,
                message: e.to_string(),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_without_tilt_is_the_ellipse_and_tilt_shrinks_it() {
        let r = [6.0, 10.0];
        for ph in [0.0, 0.7, 2.0] {
            let p = project_ellipse(r, ph, 0.0, 0.0);
            assert!(
                (p[0] - 6.0).abs() < 1e-9 && (p[1] - 10.0).abs() < 1e-9,
                "{p:?}"
            );
        }
        // Tilt about x with the major axis along y: major foreshortened by cos.
        let p = project_ellipse(r, 0.0, 60.0, 0.0);
        assert!(
            (p[0] - 5.0).abs() < 1e-9 && (p[1] - 6.0).abs() < 1e-9,
            "{p:?}"
        );
        // Major axis along the tilt axis: unchanged major, minor foreshortened.
        let p = project_ellipse(r, std::f64::consts::FRAC_PI_2, 60.0, 0.0);
        assert!(
            (p[0] - 3.0).abs() < 1e-9 && (p[1] - 10.0).abs() < 1e-9,
            "{p:?}"
        );
    }
}
