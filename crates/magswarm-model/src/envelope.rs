//! The validated envelope of the seed and the flags that say when a result leaves it.
//!
//! Outside the envelope the model still evaluates (a controller probing its limits, a
//! user sweeping past them): it never refuses, it says it is extrapolating.

use serde::{Deserialize, Serialize};

/// Input ranges over which the seed validated the model (z_m 3.5-23.5 mm, f 1-10 Hz).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Envelope {
    /// Smallest validated z_m \[m\].
    pub z_min_m: f64,
    /// Largest validated z_m \[m\].
    pub z_max_m: f64,
    /// Smallest validated field frequency \[Hz\].
    pub f_min_hz: f64,
    /// Largest validated field frequency \[Hz\].
    pub f_max_hz: f64,
}

impl Default for Envelope {
    fn default() -> Self {
        Envelope {
            z_min_m: 0.0035,
            z_max_m: 0.0235,
            f_min_hz: 1.0,
            f_max_hz: 10.0,
        }
    }
}

/// Tolerance for "inside": grid points on the boundary (3.5 mm, 10 Hz) must count as inside
/// although unit conversions leave them a few ulps off.
const EDGE_TOL: f64 = 1e-9;

impl Envelope {
    /// Flags for an input pair (z_m \[m\], omega [rad/s]).
    pub fn classify(&self, z_m: f64, omega: f64) -> Validity {
        let f = omega.abs() / std::f64::consts::TAU;
        Validity {
            z_below: z_m < self.z_min_m * (1.0 - EDGE_TOL),
            z_above: z_m > self.z_max_m * (1.0 + EDGE_TOL),
            f_below: f < self.f_min_hz * (1.0 - EDGE_TOL),
            f_above: f > self.f_max_hz * (1.0 + EDGE_TOL),
            ..Validity::default()
        }
    }

    /// Clamp inputs into the envelope (z_m \[m\], omega [rad/s]); keeps the sign of omega.
    pub fn clamp(&self, z_m: f64, omega: f64) -> (f64, f64) {
        let f = (omega.abs() / std::f64::consts::TAU).clamp(self.f_min_hz, self.f_max_hz);
        let sign = if omega < 0.0 { -1.0 } else { 1.0 };
        (
            z_m.clamp(self.z_min_m, self.z_max_m),
            sign * f * std::f64::consts::TAU,
        )
    }
}

/// Where an evaluation stands. All false: inside the envelope, no floor active.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct Validity {
    /// z_m below the envelope (magnet closer than validated).
    pub z_below: bool,
    /// z_m above the envelope (beyond z_off, where the seed saw fragmentation).
    pub z_above: bool,
    /// Frequency below the envelope.
    pub f_below: bool,
    /// Frequency above the envelope.
    pub f_above: bool,
    /// The logarithm's argument in (7) was clamped (far above the envelope).
    pub log_clamped: bool,
    /// S_x or S_y hit the positive floor.
    pub s_floored: bool,
    /// Scheduled confinement gains had to be clamped: the ODE cannot reach the map here.
    pub dynamics_clamped: bool,
}

impl Validity {
    /// True when the inputs lie outside the validated envelope.
    pub fn extrapolating(&self) -> bool {
        self.z_below || self.z_above || self.f_below || self.f_above
    }

    /// True when any flag is set.
    pub fn any(&self) -> bool {
        self.extrapolating() || self.log_clamped || self.s_floored || self.dynamics_clamped
    }

    /// Merge the flags of two evaluations.
    pub fn merge(self, o: Validity) -> Validity {
        Validity {
            z_below: self.z_below || o.z_below,
            z_above: self.z_above || o.z_above,
            f_below: self.f_below || o.f_below,
            f_above: self.f_above || o.f_above,
            log_clamped: self.log_clamped || o.log_clamped,
            s_floored: self.s_floored || o.s_floored,
            dynamics_clamped: self.dynamics_clamped || o.dynamics_clamped,
        }
    }

    /// Human-readable list of the flags that are set, e.g. "z_m above the envelope".
    pub fn describe(&self) -> String {
        let mut v = Vec::new();
        if self.z_below {
            v.push("z_m below the validated envelope");
        }
        if self.z_above {
            v.push("z_m above the validated envelope");
        }
        if self.f_below {
            v.push("frequency below the validated envelope");
        }
        if self.f_above {
            v.push("frequency above the validated envelope");
        }
        if self.log_clamped {
            v.push("log argument of (7) clamped");
        }
        if self.s_floored {
            v.push("stiffness floored");
        }
        if self.dynamics_clamped {
            v.push("confinement gain clamped (ODE cannot reach the map)");
        }
        if v.is_empty() {
            "inside the validated envelope".to_string()
        } else {
            v.join(", ")
        }
    }
}
