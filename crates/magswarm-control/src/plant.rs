//! The plant as the control loop sees it: [`SwarmPlant`], something that takes the inputs
//! (z_m [m], omega_m [rad/s]) and yields timestamped radii (r1, r2) with a validity flag.
//!
//! Implemented here for the in-process model ([`magswarm_model::Plant`]); the `magswarm`
//! crate implements it for the FMU importer (`magswarm::cosim::CoSimulation`), and the
//! virtual lab and the hardware bridge implement it too. The one closed-loop driver
//! ([`crate::driver::run_loop`]) runs any of them.
//!
//! # The contract
//!
//! - **Time.** [`SwarmPlant::time_s`] is the plant's clock in seconds since the start of the
//!   session. A simulated plant advances it by exactly `dt_s` per [`SwarmPlant::step`]
//!   (accumulated, `t += dt`); a real rig reads its wall clock, so the time of a reading may
//!   differ from the requested step (late frames), and [`Reading::t_s`] is the truth.
//! - **Inputs** are held from one step to the next (zero-order hold, as in FMI
//!   co-simulation): `step(u, dt)` applies `u` at the current time and keeps it for `dt`.
//!   A plant may refuse inputs it cannot take ([`PlantError::InvalidInput`]: non-finite, the
//!   swarm plane inside the magnet); limits of a rig (rates, envelope) are its own business
//!   and may also be reported that way.
//! - **Readings.** [`SwarmPlant::measure`] returns the latest measurement without advancing
//!   (a rig: the newest camera frame; a model: its state now); [`SwarmPlant::step`] returns
//!   the measurement at the end of the step (a rig: the newest frame when the wall clock
//!   reaches `t + dt`). A reading may be invalid (`valid == false`: the camera lost the
//!   swarm, a frame was dropped, a virtual lab injected a failure): the loop goes on, the
//!   log row is kept with `valid = 0`, and the controller decides what to do (hold its
//!   output, say).
//! - **Faults** (a safety stop, a lost device, an integration failure) are errors
//!   ([`PlantError`]): the driver stops there and reports which sample failed.
//! - **Units:** inputs SI (m, rad/s) as on the FMU's interface; radii in mm (the camera's,
//!   the log's and the controller's unit).

use magswarm_model::{Plant, StepError};

/// The inputs of the plant, SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inputs {
    /// Magnet-swarm distance [m].
    pub z_m: f64,
    /// Field angular velocity [rad/s] (2 pi f).
    pub omega_m: f64,
}

impl Inputs {
    /// Inputs in SI.
    pub fn new(z_m: f64, omega_m: f64) -> Inputs {
        Inputs { z_m, omega_m }
    }

    /// Inputs in the log's units (z_m [mm], f [Hz]).
    pub fn from_mm_hz(z_mm: f64, f_hz: f64) -> Inputs {
        Inputs::new(z_mm * 1e-3, f_hz * std::f64::consts::TAU)
    }

    /// z_m [mm].
    pub fn z_mm(&self) -> f64 {
        self.z_m * 1e3
    }

    /// f [Hz].
    pub fn f_hz(&self) -> f64 {
        magswarm_model::rad_s_to_hz(self.omega_m)
    }

    /// As `[z_m, omega_m]`.
    pub fn to_array(self) -> [f64; 2] {
        [self.z_m, self.omega_m]
    }
}

/// One measurement of the swarm.
#[derive(Debug, Clone, PartialEq)]
pub struct Reading {
    /// When it was taken: seconds since the start of the session, on the plant's clock.
    pub t_s: f64,
    /// Radii (r1, r2) [mm]; not meaningful (may be NaN) when `valid` is false.
    pub r_mm: [f64; 2],
    /// False when the measurement failed (lost swarm, dropped frame): kept, not fitted.
    pub valid: bool,
    /// More outputs a plant may report alongside (an FMU's extra output variables in SI, a
    /// camera's angle or centroid); empty for most plants.
    pub extra: Vec<f64>,
}

impl Reading {
    /// A valid reading.
    pub fn new(t_s: f64, r_mm: [f64; 2]) -> Reading {
        Reading {
            t_s,
            r_mm,
            valid: true,
            extra: Vec::new(),
        }
    }

    /// An invalid reading (no radii).
    pub fn invalid(t_s: f64) -> Reading {
        Reading {
            t_s,
            r_mm: [f64::NAN; 2],
            valid: false,
            extra: Vec::new(),
        }
    }

    /// The radii when the reading is valid.
    pub fn radii_mm(&self) -> Option<[f64; 2]> {
        self.valid.then_some(self.r_mm)
    }
}

/// Why a plant could not go on.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlantError {
    /// Inputs the plant cannot take (non-finite, the swarm inside the magnet, outside a rig's
    /// hard limits).
    #[error("invalid input: {0}")]
    InvalidInput(String),
    /// The model could not advance (integration failure).
    #[error("model: {0}")]
    Model(String),
    /// A call into the plant's interface failed (an FMU function, a device protocol).
    #[error("interface: {0}")]
    Interface(String),
    /// A hardware fault (safety stop, lost device, emergency stop).
    #[error("fault: {0}")]
    Fault(String),
    /// The plant did not answer in time (no camera frame, no robot state).
    #[error("timeout: {0}")]
    Timeout(String),
}

/// Something that takes (z_m, omega_m) and yields timestamped (r1, r2) with validity. See
/// the module documentation for the contract (time, inputs, readings, faults, units).
pub trait SwarmPlant {
    /// The plant's clock: seconds since the start of the session.
    fn time_s(&self) -> f64;

    /// The inputs in force (the last applied, or the initial ones).
    fn inputs(&self) -> Inputs;

    /// The latest measurement, without advancing the plant.
    fn measure(&mut self) -> Result<Reading, PlantError>;

    /// Apply `u` now, hold it for `dt_s` seconds, and return the measurement at the end.
    fn step(&mut self, u: Inputs, dt_s: f64) -> Result<Reading, PlantError>;

    /// A short name for messages ("in-process model 'paper'", "MagSwarm.fmu", "rig").
    fn describe(&self) -> String {
        "plant".to_string()
    }
}

/// The in-process model: exact readings (always valid), its own clock, the model's input
/// rule (the swarm plane must stay outside the magnet).
impl SwarmPlant for Plant {
    fn time_s(&self) -> f64 {
        self.time()
    }

    fn inputs(&self) -> Inputs {
        let (z, w) = Plant::inputs(self);
        Inputs::new(z, w)
    }

    /// The observed radii ([`Plant::observed_radii`]: formation mode, drift and camera bias
    /// of the model applied), which is what a measurement of this plant reads; the ODE state
    /// is the physical footprint behind it.
    fn measure(&mut self) -> Result<Reading, PlantError> {
        Ok(Reading::new(self.time(), self.observed_radii()))
    }

    fn step(&mut self, u: Inputs, dt_s: f64) -> Result<Reading, PlantError> {
        self.try_set_inputs(u.z_m, u.omega_m)
            .map_err(|e| PlantError::InvalidInput(e.to_string()))?;
        Plant::step(self, dt_s).map_err(|e: StepError| {
            PlantError::Model(format!(
                "ODE (4) could not be integrated at z_m = {:.4} mm, f = {:.4} Hz ({}): {e}",
                u.z_mm(),
                u.f_hz().abs(),
                self.validity().describe()
            ))
        })?;
        SwarmPlant::measure(self)
    }

    fn describe(&self) -> String {
        format!("in-process model '{}'", self.model().name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use magswarm_model::{hz_to_rad_s, Model};

    #[test]
    fn in_process_plant_steps_on_its_clock_and_refuses_a_swarm_inside_the_magnet() {
        let mut p = Plant::new(Model::paper(), 0.0085, hz_to_rad_s(4.0));
        let r0 = SwarmPlant::measure(&mut p).unwrap();
        assert_eq!(r0.t_s, 0.0);
        assert!(r0.valid);
        let u = Inputs::from_mm_hz(13.5, 6.0);
        let r1 = SwarmPlant::step(&mut p, u, 0.05).unwrap();
        assert_eq!(r1.t_s, 0.05);
        assert_ne!(r1.r_mm, r0.r_mm);
        assert_eq!(SwarmPlant::inputs(&p), u);
        let inside = Inputs::new(-p.model().magnet.z_offset_m - 1e-3, u.omega_m);
        let e = SwarmPlant::step(&mut p, inside, 0.05).unwrap_err();
        assert!(matches!(e, PlantError::InvalidInput(_)), "{e}");
        assert!(e.to_string().contains("inside the magnet"), "{e}");
        // Refused inputs leave the plant where it was.
        assert_eq!(p.time(), 0.05);
        assert_eq!(SwarmPlant::inputs(&p), u);
        let nan = SwarmPlant::step(&mut p, Inputs::new(f64::NAN, u.omega_m), 0.05);
        assert!(matches!(nan, Err(PlantError::InvalidInput(_))));
    }

    /// The simulated measurement is what a camera reads: with a camera offset switched on,
    /// every reading (at rest and after steps) is the ODE state plus the offset.
    #[test]
    fn in_process_readings_are_the_observed_radii() {
        let mut m = Model::paper();
        m.effects.camera_bias = Some(magswarm_model::effects::CameraBias {
            scale: 1.0,
            offset_mm: 0.25,
            tilt_deg: 0.0,
        });
        let mut p = Plant::new(m, 0.0085, hz_to_rad_s(4.0));
        let r = SwarmPlant::measure(&mut p).unwrap();
        let s = p.state();
        assert!(
            (r.r_mm[0] - s[0] - 0.25).abs() < 1e-12,
            "{:?} vs {s:?}",
            r.r_mm
        );
        assert!(
            (r.r_mm[1] - s[1] - 0.25).abs() < 1e-12,
            "{:?} vs {s:?}",
            r.r_mm
        );
        let r = SwarmPlant::step(&mut p, Inputs::from_mm_hz(13.5, 6.0), 0.2).unwrap();
        let s = p.state();
        assert!(
            (r.r_mm[0] - s[0] - 0.25).abs() < 1e-12,
            "{:?} vs {s:?}",
            r.r_mm
        );
    }
}
