//! Ready-made lab campaigns: the injection-recovery tests of `diagnose`, its bench and the
//! worked example all draw their logs from here, so there is one generator (the lab) behind
//! every synthetic log of the project.
//!
//! A campaign is a *rig* truth (the paper model with its gains and exponents moved, so the
//! baseline must be identified, not assumed) plus, for each effect named, the lab's **foreign**
//! form of it ([`Foreign`]), at a strength multiplier (1 = the size below). The foreign forms
//! differ from the model terms diagnose fits (docs/lab.md has the table):
//!
//! | effect | foreign form at strength s | model term diagnose fits |
//! | --- | --- | --- |
//! | `phase_lag` | the swarm driven at f (1 - 0.9 s / (1 + exp(-(f - 6 Hz) / 0.6 Hz))), no field dependence, in every term of (6)-(7) | Adler step-out at a field-scaled f_so, in Phi and E only |
//! | `cohesion_loss` | radii x (1 + g_i ((z_m - 14 mm)_+)^2), g = s (0.0008, 0.0015) / mm^2, following changes with a 0.5 s lag | Gaussian fading of the stiffness past z_c |
//! | `formation_lag` | the swarm sees the commands through a 1.5 s dead time and a 5 s first-order filter (x s) | a parallel second-order slow mode on the radii |
//! | `particle_drift` | radii x (1 - 0.18 s sqrt(t / 1 h)) | radii x exp(rate t) |
//! | `centroid_offset` | the centroid off the axis by 10 s mm at z_ref = 13.5 mm, growing with depth by tan(10 s deg) per mm (tilted rotation axis) | a constant radial offset |
//! | `camera_bias` | the rotating ellipse projected onto an image plane tilted by 25 deg about an axis at 30 deg, at each frame's random phase, scaled by 1.03 and offset by 0.7 s mm | a constant offset of the radii (scale absorbed by C_1, C_2) |
//!
//! The protocol is the seed's grid (z_m 3.5-23.5 mm x f 1-10 Hz), each point visited twice in
//! a fresh random order per pass: two approach measurements 2 s and 5 s after each change
//! (formation effects show there), then 20 s settle and 4 repeats 1 s apart (600 rows), with
//! the lab's default noise.

use super::{generate, Foreign, LabError, Noise, Protocol, Scenario};
use magswarm_log::{Layout, Log, LogRow, LogWriter};
use magswarm_model::effects::EffectKind;
use magswarm_model::Model;

/// The paper model with its free steady parameters moved: a rig that is not the paper's.
pub fn rig_truth() -> Model {
    let mut m = Model::paper();
    let s = &mut m.steady;
    s.C_1 *= 1.06;
    s.C_2 *= 0.95;
    s.a_K1 *= 1.2;
    s.a_K2 *= 0.9;
    s.alpha_1 += 0.02;
    s.alpha_2 -= 0.03;
    s.N -= 0.04;
    s.q += 0.03;
    m.name = "rig-truth".into();
    m
}

/// The foreign form of an effect at strength `s` (module table).
pub fn foreign(name: &str, s: f64) -> Result<Foreign, LabError> {
    let Some(kind) = EffectKind::from_name(name) else {
        return Err(LabError::UnknownEffect {
            name: name.to_string(),
            known: magswarm_model::effects::NAMES.join(", "),
        });
    };
    Ok(match kind {
        EffectKind::PhaseLag => Foreign::PhaseLagLogistic {
            f_c_hz: 6.0,
            width_hz: 0.6,
            depth: (0.9 * s).clamp(0.0, 0.99),
        },
        EffectKind::CohesionLoss => Foreign::CohesionPoly {
            z0_mm: 14.0,
            gain: [0.0008 * s, 0.0015 * s],
            power: 2.0,
            tau_s: 0.5,
        },
        EffectKind::FormationLag => Foreign::InputLag {
            tau_s: 5.0 * s,
            delay_s: 1.5 * s,
        },
        EffectKind::ParticleDrift => Foreign::DriftSqrt {
            c_per_sqrt_h: -0.18 * s,
        },
        EffectKind::CentroidOffset => Foreign::AxisTilt {
            offset_mm: 10.0 * s,
            tilt_deg: 10.0 * s,
            z_ref_mm: 13.5,
        },
        EffectKind::CameraBias => Foreign::CameraProjection {
            tilt_deg: 25.0,
            axis_deg: 30.0,
            scale: 1.03,
            offset_mm: 0.7 * s,
        },
    })
}

/// A lab campaign: truth, scenario and seed.
#[derive(Debug, Clone)]
pub struct Campaign {
    /// The truth model (no model-term effects: the effects come as foreign forms).
    pub truth: Model,
    /// The scenario (foreign effects, protocol, noise).
    pub scenario: Scenario,
    /// Seed of the lab run.
    pub seed: u64,
}

impl Campaign {
    /// The seed's grid visited twice (600 rows), with the named effects (name, strength)
    /// in their foreign forms.
    pub fn seed_grid(effects: &[(&str, f64)], seed: u64) -> Result<Campaign, LabError> {
        let foreign = effects
            .iter()
            .map(|(n, s)| foreign(n, *s))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Campaign {
            truth: rig_truth(),
            scenario: Scenario {
                truth: None,
                foreign,
                protocol: Protocol::Grid {
                    z_mm: vec![3.5, 8.5, 13.5, 18.5, 23.5],
                    f_hz: (1..=10).map(f64::from).collect(),
                    visits: 2,
                    repeats: 4,
                    settle_s: 20.0,
                    sample_s: 1.0,
                    approach_s: vec![2.0, 5.0],
                },
                sessions: 1,
                noise: Noise::default(),
            },
            seed,
        })
    }

    /// The seed's grid visited once with 2 approach and 8 settled rows per visit (500 rows):
    /// the bench's size.
    pub fn seed_grid_500(effects: &[(&str, f64)], seed: u64) -> Result<Campaign, LabError> {
        let mut c = Campaign::seed_grid(effects, seed)?;
        if let Protocol::Grid {
            visits, repeats, ..
        } = &mut c.scenario.protocol
        {
            *visits = 1;
            *repeats = 8;
        }
        Ok(c)
    }

    /// The same campaign with another seed (a withheld log of the same rig).
    pub fn with_seed(&self, seed: u64) -> Campaign {
        Campaign {
            seed,
            ..self.clone()
        }
    }

    /// Generate the rows.
    pub fn rows(&self) -> Result<Vec<LogRow>, LabError> {
        generate(&self.truth, &self.scenario, self.seed, |_, _| {})
    }

    /// The log as CSV text (the format `magswarm lab` writes).
    pub fn csv(&self) -> Result<String, LabError> {
        let layout = Layout::standard(true, self.scenario.sessions > 1, true, false);
        let mut w = LogWriter::new(Vec::new(), layout)?;
        for r in self.rows()? {
            w.write_row(&r)?;
        }
        String::from_utf8(w.into_inner()?)
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e).into())
    }

    /// The log, parsed, named `name` in messages.
    pub fn log(&self, name: &str) -> Result<Log, LabError> {
        Ok(Log::from_str_named(&self.csv()?, name)?)
    }
}
