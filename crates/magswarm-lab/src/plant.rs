//! The virtual lab as a [`SwarmPlant`]: the lab's swarm (truth model plus foreign effects)
//! measured with the lab's noise, so the closed-loop driver, the bridge's emulated camera and
//! any controller can run against it like against the rig.
//!
//! Noise as in the lab's logs: per measurement (heteroscedastic), an offset redrawn at every
//! input change (a "visit": the swarm re-forms a little differently each time), and invalid
//! frames (`valid = false`, radii of a fragment) with probability `p_invalid`. Deterministic
//! for a seed.

use magswarm_control::plant::{Inputs, PlantError, Reading, SwarmPlant};
use magswarm_model::Model;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};

use super::{Foreign, LabSwarm, Noise};

/// The lab's swarm behind the plant trait.
#[derive(Debug)]
pub struct LabPlant {
    swarm: LabSwarm,
    noise: Noise,
    rng: StdRng,
    inputs: Inputs,
    offset: [f64; 2],
}

impl LabPlant {
    /// A swarm formed at rest at `u` at time 0, measured with `noise`, draws from `seed`.
    pub fn new(
        model: Model,
        foreign: Vec<Foreign>,
        noise: Noise,
        u: Inputs,
        seed: u64,
    ) -> LabPlant {
        let mut p = LabPlant {
            swarm: LabSwarm::new(model, foreign, u.z_m, u.omega_m),
            noise,
            rng: StdRng::seed_from_u64(seed),
            inputs: u,
            offset: [0.0; 2],
        };
        p.new_visit();
        p
    }

    fn gauss(&mut self) -> f64 {
        StandardNormal.sample(&mut self.rng)
    }

    fn new_visit(&mut self) {
        self.offset = [
            self.noise.visit_sd_mm[0] * self.gauss(),
            self.noise.visit_sd_mm[1] * self.gauss(),
        ];
    }

    /// The swarm (truth) behind the measurements.
    pub fn swarm(&self) -> &LabSwarm {
        &self.swarm
    }
}

impl SwarmPlant for LabPlant {
    fn time_s(&self) -> f64 {
        self.swarm.time()
    }

    fn inputs(&self) -> Inputs {
        self.inputs
    }

    fn measure(&mut self) -> Result<Reading, PlantError> {
        let truth = self.swarm.true_radii(&mut self.rng);
        let t = self.swarm.time();
        if self.noise.p_invalid > 0.0 && self.rng.random::<f64>() < self.noise.p_invalid {
            let mut r = Reading::invalid(t);
            r.r_mm = [
                truth[0] * self.rng.random_range(0.3..0.8),
                truth[1] * self.rng.random_range(0.3..0.8),
            ];
            return Ok(r);
        }
        let sd = self.noise.sd_at(truth);
        let e = [self.gauss(), self.gauss()];
        Ok(Reading::new(
            t,
            [
                (truth[0] + self.offset[0] + sd[0] * e[0]).max(0.0),
                (truth[1] + self.offset[1] + sd[1] * e[1]).max(0.0),
            ],
        ))
    }

    fn step(&mut self, u: Inputs, dt_s: f64) -> Result<Reading, PlantError> {
        if !(u.z_m.is_finite() && u.omega_m.is_finite()) {
            return Err(PlantError::InvalidInput(format!(
                "non-finite inputs z_m = {} m, omega_m = {} rad/s",
                u.z_m, u.omega_m
            )));
        }
        self.swarm
            .model()
            .check_inputs(u.z_m, u.omega_m)
            .map_err(|e| PlantError::InvalidInput(e.to_string()))?;
        if u != self.inputs {
            self.inputs = u;
            self.swarm.set_inputs(u.z_m, u.omega_m);
            self.new_visit();
        }
        let t_end = self.swarm.time() + dt_s;
        self.swarm
            .advance_to(t_end)
            .map_err(|e| PlantError::Model(format!("{e:#}")))?;
        self.measure()
    }

    fn describe(&self) -> String {
        format!("virtual lab (truth '{}')", self.swarm.model().name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use magswarm_model::effects::CameraBias;

    #[test]
    fn noise_free_lab_plant_is_the_model_and_noisy_one_is_deterministic() {
        let mut m = Model::paper();
        m.effects.camera_bias = Some(CameraBias {
            scale: 1.1,
            offset_mm: 0.0,
            tilt_deg: 0.0,
        });
        let u0 = Inputs::from_mm_hz(8.5, 4.0);
        let mut lab = LabPlant::new(m.clone(), vec![], Noise::none(), u0, 1);
        let mut plant = magswarm_model::Plant::new(m.clone(), u0.z_m, u0.omega_m);
        let u = Inputs::from_mm_hz(13.5, 7.0);
        for _ in 0..20 {
            let a = lab.step(u, 0.5).unwrap();
            plant.set_inputs(u.z_m, u.omega_m);
            plant.step(0.5).unwrap();
            let o = plant.outputs();
            assert!((a.r_mm[0] - o.r1).abs() < 1e-6 && (a.r_mm[1] - o.r2).abs() < 1e-6);
            assert!((a.t_s - plant.time()).abs() < 1e-9);
        }
        let run = |seed| {
            let mut lab = LabPlant::new(m.clone(), vec![], Noise::default(), u0, seed);
            (0..50)
                .map(|k| {
                    lab.step(Inputs::from_mm_hz(8.5 + (k / 10) as f64, 4.0), 1.0)
                        .unwrap()
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(run(3), run(3));
        assert_ne!(run(3), run(4));
        let mut bad = LabPlant::new(m, vec![], Noise::none(), u0, 1);
        assert!(matches!(
            bad.step(Inputs::new(f64::NAN, 1.0), 0.1),
            Err(PlantError::InvalidInput(_))
        ));
    }
}
