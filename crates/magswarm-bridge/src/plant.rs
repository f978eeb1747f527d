//! The rig as a [`SwarmPlant`]: the same trait the in-process model and the FMU importer
//! implement, so `magswarm_control::driver::run_loop` and any controller written against the
//! trait close the loop around the rig unchanged.
//!
//! Timing: [`SwarmPlant::step`]`(u, dt)` sends `u` through the safety core at once, then
//! waits (checking every device, heartbeating) until a frame taken at or after
//! `t + dt - half a frame period` arrives, and returns its measurement; the reading's `t_s`
//! is the frame's camera time (the truth, which may differ from `t + dt` by a frame). A fault
//! stops the stepper and holds the robot, and is returned as a [`PlantError`] (and kept:
//! every later call returns it too).

use magswarm_control::plant::{Inputs, PlantError, Reading, SwarmPlant};

use crate::rig::{Measured, Poll, Rig};
use crate::safety::Fault;

/// The rig behind the plant trait.
pub struct RigPlant {
    rig: Rig,
    fps: f64,
    last: Option<Reading>,
    fault: Option<Fault>,
}

fn reading(m: &Measured) -> Reading {
    match &m.radii.invalid {
        None => {
            let mut r = Reading::new(m.frame.t_s, [m.radii.r1_mm, m.radii.r2_mm]);
            r.extra = vec![m.radii.angle_deg, m.radii.cx_px, m.radii.cy_px, m.z_meas_mm];
            r
        }
        Some(_) => Reading::invalid(m.frame.t_s),
    }
}

fn plant_error(f: &Fault) -> PlantError {
    match f {
        Fault::CameraTimeout(_) => PlantError::Timeout(f.to_string()),
        Fault::NanCommand(_) => PlantError::InvalidInput(f.to_string()),
        Fault::Serial(_) | Fault::BadReply(_) | Fault::Camera(_) | Fault::Log(_) => {
            PlantError::Interface(format!("{}: {f}", f.name()))
        }
        _ => PlantError::Fault(format!("{}: {f}", f.name())),
    }
}

impl RigPlant {
    /// Wrap an open rig; `fps` is the camera's frame rate (for the step's frame matching).
    pub fn new(rig: Rig, fps: f64) -> RigPlant {
        RigPlant {
            rig,
            fps,
            last: None,
            fault: None,
        }
    }

    /// The fault that stopped the rig, if any.
    pub fn fault(&self) -> Option<&Fault> {
        self.fault.as_ref()
    }

    /// Stop the stepper and hold the robot (also done on a fault).
    pub fn shutdown(&mut self) {
        self.rig.shutdown(self.fault.is_some());
    }

    fn trip(&mut self, f: Fault) -> PlantError {
        self.rig.shutdown(true);
        let e = plant_error(&f);
        self.fault.get_or_insert(f);
        e
    }

    /// Wait for a frame taken at or after `t_min`.
    fn frame_after(&mut self, t_min: f64) -> Result<Reading, PlantError> {
        if let Some(f) = &self.fault {
            return Err(plant_error(f));
        }
        loop {
            match self.rig.poll() {
                Ok(Poll::Nothing) => {}
                Ok(Poll::Ended) => {
                    return Err(self.trip(Fault::Camera("the recording ended".into())));
                }
                Ok(Poll::Frame(m)) => {
                    let r = reading(&m);
                    self.last = Some(r.clone());
                    if m.frame.t_s >= t_min {
                        return Ok(r);
                    }
                }
                Err(f) => return Err(self.trip(f)),
            }
        }
    }
}

impl SwarmPlant for RigPlant {
    fn time_s(&self) -> f64 {
        self.last
            .as_ref()
            .map(|r| r.t_s)
            .unwrap_or_else(|| self.rig.t0.elapsed().as_secs_f64())
    }

    fn inputs(&self) -> Inputs {
        let (z, f) = self.rig.in_force();
        Inputs::from_mm_hz(z, f)
    }

    fn measure(&mut self) -> Result<Reading, PlantError> {
        self.frame_after(f64::NEG_INFINITY)
    }

    fn step(&mut self, u: Inputs, dt_s: f64) -> Result<Reading, PlantError> {
        if let Some(f) = &self.fault {
            return Err(plant_error(f));
        }
        let t = self.time_s();
        if let Err(f) = self.rig.command((u.z_mm(), u.f_hz())) {
            return Err(self.trip(f));
        }
        self.frame_after(t + dt_s - 0.5 / self.fps)
    }

    fn describe(&self) -> String {
        "rig (magswarm-bridge)".to_string()
    }
}

impl Drop for RigPlant {
    fn drop(&mut self) {
        self.rig.shutdown(self.fault.is_some());
    }
}
