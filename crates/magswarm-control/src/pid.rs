//! The decoupled 2x2 PID with feedforward from the inverse steady map.
//!
//! # Structure (one sample, period `Ts`)
//!
//! ```text
//!  setpoint r* --> inverse map --> r_goal (nearest reachable), u_goal (feedforward target)
//!  u_ff  <- u_ff moved toward u_goal on a straight line in normalised inputs, both
//!           inputs arriving together, at the rate limit of the slower one (feedforward ramp)
//!  r_ref <- internal model (ODE (4)) driven by u_ff                 (with feedforward)
//!           or first-order prefilter of r_goal, time constant tau_r  (without)
//!  e     = r_ref - y                                                 [mm]
//!  D     = kd d/dt LPF(r_ref - y)   (with feedforward: r_ref is the model's smooth output)
//!        = -kd d/dt LPF(y)           (without: on the measurement only)
//!  du    = Jd^-1 (kp e + D) + I      (I: integral, kept in input units)
//!  u     = rate_limit(saturate(u_ff + du))
//!  I    += Ts Jd^-1 (ki e)   (skipped on an axis that is saturated in that direction)
//!        + Ts/Tt (u - (u_ff + du))                                   (back-calculation)
//! ```
//!
//! The PID acts in radius space (gains per radius, in mm per mm); the decoupler `Jd^-1` maps
//! a radius correction into an input correction through the inverse of the steady map's
//! Jacobian, scheduled at the inputs currently applied. Inputs are handled in normalised
//! units (the envelope's spans), in which the inverse is damped (damped least squares, damping
//! `decoupler_damping` times the largest singular value) because the map folds inside the
//! envelope and its Jacobian is singular along the fold.
//!
//! With feedforward (the default) the loop is two-degree-of-freedom: the feedforward moves
//! the inputs to where the model says the target is, as fast as the rate limits allow, and
//! the reference the PID tracks is what the model predicts for that very input trajectory.
//! With a perfect model the PID therefore does nothing; it corrects model error and
//! disturbances, and a setpoint change neither kicks the proportional part nor winds up the
//! integral during the transient (bumpless).
//!
//! Infeasible targets: the setpoint is replaced by the nearest reachable radii of the
//! controller's model over the controller's input limits ([`crate::inverse`]), which the loop
//! then tracks; [`Controller::setpoint_status`] says so. Whatever the integral cannot reach
//! (a plant that differs from the model, a disturbance) is held by the anti-windup
//! (conditional integration plus back-calculation against saturation and rate limits).

use magswarm_model::{steady, Envelope, Model, Plant, PlantSnapshot};
use serde::{Deserialize, Serialize};

use crate::inverse::{inverse_with, InverseOptions, InverseResult, Scale};
use crate::mat2;

/// Resolution of the decoupler's schedule, in fractions of the envelope's spans (see
/// `Controller::decoupler`).
const DECOUPLER_RESOLUTION: f64 = 1e-12;

/// Schema tag of a controller configuration.
pub const CONFIG_SCHEMA: &str = "magswarm-pid/1";

/// PID gains, per radius axis (r1, r2), acting in radius space.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Gains {
    /// Proportional gains [mm/mm].
    pub kp: [f64; 2],
    /// Integral gains [1/s].
    pub ki: [f64; 2],
    /// Derivative gains [s].
    pub kd: [f64; 2],
    /// Time constant of the first-order filter on the derivative's signal [s].
    pub derivative_filter_s: f64,
    /// Back-calculation (tracking) time constant of the anti-windup [s]; 0 disables it.
    pub tracking_time_s: f64,
    /// Conditional integration: do not integrate into a saturation.
    pub conditional_integration: bool,
}

impl Default for Gains {
    fn default() -> Self {
        Gains {
            kp: [0.3, 0.3],
            ki: [0.8, 0.8],
            kd: [0.02, 0.02],
            derivative_filter_s: 0.1,
            tracking_time_s: 0.5,
            conditional_integration: true,
        }
    }
}

/// Input limits: the envelope and the actuators' rate limits (human units).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Limits {
    /// Smallest magnet-swarm distance [mm].
    pub z_min_mm: f64,
    /// Largest magnet-swarm distance [mm] (z_off: beyond it the swarm fragments).
    pub z_max_mm: f64,
    /// Lowest field frequency [Hz].
    pub f_min_hz: f64,
    /// Highest field frequency [Hz].
    pub f_max_hz: f64,
    /// Fastest change of z_m the UR10e is allowed [mm/s].
    pub z_rate_mm_s: f64,
    /// Fastest change of the field frequency the stepper is allowed [Hz/s].
    pub f_rate_hz_s: f64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            z_min_mm: 3.5,
            z_max_mm: 23.5,
            f_min_hz: 1.0,
            f_max_hz: 10.0,
            z_rate_mm_s: 10.0,
            f_rate_hz_s: 2.0,
        }
    }
}

impl Limits {
    /// The input box as an [`Envelope`] (SI z_m).
    pub fn envelope(&self) -> Envelope {
        Envelope {
            z_min_m: self.z_min_mm * 1e-3,
            z_max_m: self.z_max_mm * 1e-3,
            f_min_hz: self.f_min_hz,
            f_max_hz: self.f_max_hz,
        }
    }
}

/// Everything that configures the controller; the same JSON serves the Rust harness, the
/// Python script and a controller FMU.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PidConfig {
    /// Always [`CONFIG_SCHEMA`].
    pub schema: String,
    /// Sample time [s].
    pub sample_time_s: f64,
    /// PID gains.
    pub gains: Gains,
    /// Envelope and rate limits.
    pub limits: Limits,
    /// Feedforward from the inverse map, with the model-predicted reference (2-DOF).
    pub feedforward: bool,
    /// Time constant of the setpoint prefilter used without feedforward [s] (0: none).
    pub reference_filter_s: f64,
    /// Damping of the decoupler's inverse, relative to the largest singular value of the
    /// normalised Jacobian [-].
    pub decoupler_damping: f64,
    /// Distance above which a target is reported infeasible [mm].
    pub feasible_tol_mm: f64,
}

impl Default for PidConfig {
    fn default() -> Self {
        PidConfig {
            schema: CONFIG_SCHEMA.to_string(),
            sample_time_s: 0.05,
            gains: Gains::default(),
            limits: Limits::default(),
            feedforward: true,
            reference_filter_s: 1.0,
            decoupler_damping: 0.05,
            feasible_tol_mm: 1e-3,
        }
    }
}

/// A configuration that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// The JSON does not parse or has unknown fields.
    #[error("controller config: {0}")]
    Json(String),
    /// A value is out of range.
    #[error("controller config: {field}: {message}")]
    Invalid {
        /// The offending field.
        field: &'static str,
        /// What is wrong.
        message: String,
    },
}

impl PidConfig {
    /// Parse and validate from JSON.
    pub fn from_json(text: &str) -> Result<PidConfig, ConfigError> {
        let c: PidConfig =
            serde_json::from_str(text).map_err(|e| ConfigError::Json(e.to_string()))?;
        c.validate()?;
        Ok(c)
    }

    /// Pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("config serialises")
    }

    /// Check ranges.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let bad = |field: &'static str, message: &str| {
            Err(ConfigError::Invalid {
                field,
                message: message.to_string(),
            })
        };
        if self.schema != CONFIG_SCHEMA {
            return bad("schema", &format!("expected {CONFIG_SCHEMA:?}"));
        }
        if !(self.sample_time_s > 0.0 && self.sample_time_s.is_finite()) {
            return bad("sample_time_s", "must be positive");
        }
        let g = &self.gains;
        for (name, v) in [("gains.kp", g.kp), ("gains.ki", g.ki), ("gains.kd", g.kd)] {
            if !v.iter().all(|x| x.is_finite() && *x >= 0.0) {
                return bad(name, "must be finite and >= 0");
            }
        }
        if !(g.derivative_filter_s >= 0.0 && g.tracking_time_s >= 0.0) {
            return bad("gains", "filter and tracking time constants must be >= 0");
        }
        let l = &self.limits;
        if !(l.z_min_mm < l.z_max_mm && l.f_min_hz < l.f_max_hz && l.f_min_hz > 0.0) {
            return bad("limits", "need z_min < z_max and 0 < f_min < f_max");
        }
        if !(l.z_rate_mm_s > 0.0 && l.f_rate_hz_s > 0.0) {
            return bad("limits", "rate limits must be positive");
        }
        if self.reference_filter_s.is_nan() || self.reference_filter_s < 0.0 {
            return bad("reference_filter_s", "must be >= 0");
        }
        if self.decoupler_damping.is_nan() || self.decoupler_damping < 0.0 {
            return bad("decoupler_damping", "must be >= 0");
        }
        Ok(())
    }
}

/// What the last sample did (for logs and tests).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct StepInfo {
    /// Reference the PID tracked at this sample (r1, r2) [mm].
    pub reference_mm: [f64; 2],
    /// Reachable setpoint in force (r1, r2) [mm].
    pub goal_mm: [f64; 2],
    /// Tracking error r_ref - y [mm].
    pub error_mm: [f64; 2],
    /// Feedforward inputs (rate-limited ramp) (z_m [m], omega [rad/s]).
    pub feedforward: [f64; 2],
    /// Inputs the PID asked for before limiting (z_m [m], omega [rad/s]).
    pub requested: [f64; 2],
    /// Inputs commanded (z_m [m], omega [rad/s]).
    pub commanded: [f64; 2],
    /// Clipped by the envelope (z_m, f).
    pub saturated: [bool; 2],
    /// Clipped by a rate limit (z_m, f).
    pub rate_limited: [bool; 2],
    /// Integral term in normalised input units (fractions of the envelope's spans).
    pub integral: [f64; 2],
}

/// The controller's mutable state (everything `Clone`: saving an FMU state is a copy).
#[derive(Debug, Clone)]
struct State {
    initialized: bool,
    /// Inputs applied last (z_m [m], omega [rad/s]).
    u: [f64; 2],
    /// Feedforward ramp (z_m [m], omega [rad/s]).
    u_ff: [f64; 2],
    /// `u_ff` in normalised units (`Scale::x_of`, kept with it rather than divided out
    /// twice a sample).
    x_ff: [f64; 2],
    /// Integral term, normalised input units.
    integ: [f64; 2],
    /// Filtered derivative signal [mm].
    d_filt: [f64; 2],
    /// Prefiltered setpoint (without feedforward) [mm].
    r_pre: [f64; 2],
    /// Internal model (with feedforward).
    model_plant: Option<Plant>,
    /// Setpoint the status below belongs to.
    setpoint: [f64; 2],
    status: Option<InverseResult>,
    /// The status's feedforward target in normalised units (kept with it).
    x_goal: [f64; 2],
    last: StepInfo,
    /// Gains in force before a [`Controller::set_gains`] not yet absorbed.
    gains_before: Option<Gains>,
    /// The decoupler in force, the inputs it was computed at and those in normalised units
    /// (see [`Controller::decoupler`]).
    decoupler: Option<Decoupler>,
}

/// The decoupler in force (see [`Controller::decoupler`]).
#[derive(Debug, Clone, Copy)]
struct Decoupler {
    /// The inputs it was computed at (z_m [m], omega [rad/s]).
    at: [f64; 2],
    /// `at` in normalised units (`Scale::x_of`: kept rather than divided out every sample).
    x_at: [f64; 2],
    /// The damped inverse of the normalised Jacobian at `at`.
    m: mat2::M2,
}

/// Per-sample constants of the controller, derived once from its configuration (the same
/// expressions the sample evaluated each time, so the same values): the rate limits per
/// sample in normalised units, the derivative filter's coefficient and the back-calculation
/// gain. Rederived whenever the gains change.
#[derive(Debug, Clone, Copy)]
struct Derived {
    max_dx: [f64; 2],
    deriv_a: f64,
    track: f64,
}

/// The controller's mutable state as plain data: what an FMU state or a checkpoint of a
/// long experiment stores. Restoring it into a controller built with the same model and
/// configuration continues bit-identically (see [`Controller::snapshot`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSnapshot {
    initialized: bool,
    u: [f64; 2],
    u_ff: [f64; 2],
    integ: [f64; 2],
    d_filt: [f64; 2],
    r_pre: [f64; 2],
    model_plant: Option<PlantSnapshot>,
    /// None before the first setpoint (the live state marks that with NaN, which JSON lacks).
    setpoint: Option<[f64; 2]>,
    status: Option<InverseResult>,
    last: StepInfo,
    /// Gains in force (they may differ from the configuration after `set_gains`).
    gains: Gains,
    gains_before: Option<Gains>,
    /// The inputs the decoupler in force was computed at (absent in a state written before
    /// the decoupler was scheduled with a resolution: none, computed at the next sample).
    #[serde(default)]
    decoupler_at: Option<[f64; 2]>,
}

impl Derived {
    fn of(cfg: &PidConfig, scale: &Scale) -> Derived {
        let ts = cfg.sample_time_s;
        let l = &cfg.limits;
        let g = &cfg.gains;
        Derived {
            max_dx: [
                l.z_rate_mm_s * 1e-3 * ts / scale.dz,
                l.f_rate_hz_s * std::f64::consts::TAU * ts / scale.dw,
            ],
            deriv_a: ts / (g.derivative_filter_s + ts),
            track: ts / g.tracking_time_s.max(ts),
        }
    }
}

/// The discrete-time decoupled PID.
#[derive(Debug, Clone)]
pub struct Controller {
    model: Model,
    cfg: PidConfig,
    scale: Scale,
    derived: Derived,
    st: State,
}

impl Controller {
    /// A controller for `model` (used for the feedforward, the decoupler and the reference).
    pub fn new(model: Model, cfg: PidConfig) -> Result<Controller, ConfigError> {
        cfg.validate()?;
        let scale = Scale::new(&cfg.limits.envelope());
        let derived = Derived::of(&cfg, &scale);
        Ok(Controller {
            model,
            cfg,
            scale,
            derived,
            st: State {
                initialized: false,
                u: [0.0; 2],
                u_ff: [0.0; 2],
                x_ff: scale.x_of([0.0; 2]),
                integ: [0.0; 2],
                d_filt: [0.0; 2],
                r_pre: [0.0; 2],
                model_plant: None,
                setpoint: [f64::NAN; 2],
                status: None,
                x_goal: [0.0; 2],
                last: StepInfo::default(),
                gains_before: None,
                decoupler: None,
            },
        })
    }

    /// The configuration.
    pub fn config(&self) -> &PidConfig {
        &self.cfg
    }

    /// The model the controller uses.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// Sample time [s].
    pub fn sample_time(&self) -> f64 {
        self.cfg.sample_time_s
    }

    /// Bumpless start (or transfer from manual) at the inputs in force (z_m [m],
    /// omega [rad/s]) with the current measurement (r1, r2) [mm]: no integral, references
    /// and filters start at the measurement, the feedforward ramps from these inputs.
    pub fn reset(&mut self, z_m: f64, omega: f64, measurement: [f64; 2]) {
        let env = self.cfg.limits.envelope();
        let (z, w) = env.clamp(z_m, omega.abs());
        let u = [z, w];
        let st = &mut self.st;
        st.initialized = true;
        st.u = u;
        st.u_ff = u;
        st.x_ff = self.scale.x_of(u);
        st.integ = [0.0; 2];
        st.gains_before = None;
        st.decoupler = None;
        st.r_pre = measurement;
        st.d_filt = if self.cfg.feedforward {
            [0.0; 2]
        } else {
            [-measurement[0], -measurement[1]]
        };
        st.model_plant = if self.cfg.feedforward {
            let mut p = Plant::new(self.model.clone(), u[0], u[1]);
            p.set_state(measurement);
            Some(p)
        } else {
            None
        };
    }

    /// The mutable state as data (sizes do not grow with the run's length).
    pub fn snapshot(&self) -> ControllerSnapshot {
        let st = &self.st;
        ControllerSnapshot {
            initialized: st.initialized,
            u: st.u,
            u_ff: st.u_ff,
            integ: st.integ,
            d_filt: st.d_filt,
            r_pre: st.r_pre,
            model_plant: st.model_plant.as_ref().map(Plant::snapshot),
            setpoint: (!st.setpoint[0].is_nan()).then_some(st.setpoint),
            status: st.status,
            last: st.last,
            gains: self.cfg.gains,
            gains_before: st.gains_before,
            decoupler_at: st.decoupler.map(|d| d.at),
        }
    }

    /// Restore a state taken with [`Controller::snapshot`] (from a controller with the same
    /// model and configuration).
    pub fn restore(&mut self, s: &ControllerSnapshot) {
        let model = &self.model;
        self.cfg.gains = s.gains;
        self.derived = Derived::of(&self.cfg, &self.scale);
        self.st = State {
            initialized: s.initialized,
            u: s.u,
            u_ff: s.u_ff,
            x_ff: self.scale.x_of(s.u_ff),
            integ: s.integ,
            d_filt: s.d_filt,
            r_pre: s.r_pre,
            model_plant: s
                .model_plant
                .as_ref()
                .map(|p| Plant::from_snapshot(model.clone(), p)),
            setpoint: s.setpoint.unwrap_or([f64::NAN; 2]),
            status: s.status,
            x_goal: s
                .status
                .map_or([0.0; 2], |st| self.scale.x_of([st.z_m, st.omega])),
            last: s.last,
            gains_before: s.gains_before,
            decoupler: None,
        };
        self.st.decoupler = s.decoupler_at.map(|u| self.decoupler_at(u));
    }

    /// Change the gains without a bump in the output: at the next sample the integral absorbs
    /// the change of the proportional and derivative parts, so that sample's command is the
    /// one the old gains would have given; the new gains act on what changes from then on.
    pub fn set_gains(&mut self, gains: Gains) {
        if self.st.initialized && self.st.gains_before.is_none() {
            self.st.gains_before = Some(self.cfg.gains);
        }
        self.cfg.gains = gains;
        self.derived = Derived::of(&self.cfg, &self.scale);
    }

    /// The inverse-map result for the setpoint in force: the reachable setpoint, whether the
    /// target is feasible, the distance, and the feedforward inputs.
    pub fn setpoint_status(&self) -> Option<&InverseResult> {
        self.st.status.as_ref()
    }

    /// The nearest reachable radii to the setpoint in force [mm].
    pub fn reachable_setpoint(&self) -> Option<[f64; 2]> {
        self.st.status.map(|s| s.radii())
    }

    /// True when the setpoint in force cannot be reached (its distance exceeds
    /// `feasible_tol_mm`).
    pub fn target_infeasible(&self) -> bool {
        self.st
            .status
            .is_some_and(|s| s.distance_mm > self.cfg.feasible_tol_mm)
    }

    /// "target infeasible, nearest reachable (x, y) mm, distance d mm" or "target feasible".
    pub fn status_message(&self) -> String {
        match &self.st.status {
            None => "no setpoint yet".to_string(),
            Some(s) if self.target_infeasible() => format!(
                "target ({:.3}, {:.3}) mm infeasible, nearest reachable ({:.3}, {:.3}) mm, \
                 distance {:.3} mm",
                s.target[0], s.target[1], s.r1, s.r2, s.distance_mm
            ),
            Some(s) => format!(
                "target ({:.3}, {:.3}) mm feasible",
                s.target[0], s.target[1]
            ),
        }
    }

    /// What the last sample did.
    pub fn last(&self) -> &StepInfo {
        &self.st.last
    }

    /// Inputs commanded last (z_m [m], omega [rad/s]).
    pub fn inputs(&self) -> (f64, f64) {
        (self.st.u[0], self.st.u[1])
    }

    /// Damped inverse of the normalised Jacobian, scheduled on the inputs u with a
    /// resolution of [`DECOUPLER_RESOLUTION`] of the envelope's spans: the one in force is
    /// kept while u stays that close to where it was computed, else recomputed at u.
    ///
    /// Why: the PID's corrections move the inputs in their last bits on most samples (the
    /// measurement and the model's prediction differ by rounding), and evaluating the map's
    /// Jacobian for each was most of the controller's time. Over 1e-12 of the spans the
    /// Jacobian changes by about 1e-11 relative at most (it varies on the scale of the
    /// envelope), far below the 5 % damping the decoupler applies anyway; during a ramp the
    /// inputs move by 1e-4 to 1e-2 of the spans per sample and it is recomputed every
    /// sample. In the seed's tracking scenario at 1 kHz it is computed on 4 % of the
    /// samples, and the run's inputs and radii are bit for bit those of computing it on
    /// every sample. The inputs it was computed at are part of the state ([`ControllerSnapshot`]),
    /// so a restored controller continues bit for bit.
    ///
    /// `x` is `u` in normalised units (`Scale::x_of(u)`, which the caller has at hand).
    fn decoupler(&mut self, u: [f64; 2], x: [f64; 2]) -> mat2::M2 {
        if let Some(d) = self.st.decoupler {
            let x_at = d.x_at;
            if (x[0] - x_at[0]).abs() <= DECOUPLER_RESOLUTION
                && (x[1] - x_at[1]).abs() <= DECOUPLER_RESOLUTION
            {
                return d.m;
            }
        }
        let d = self.decoupler_at(u);
        self.st.decoupler = Some(d);
        d.m
    }

    /// Damped inverse of the normalised Jacobian at inputs u, computed.
    fn decoupler_at(&self, u: [f64; 2]) -> Decoupler {
        let sp = steady::evaluate(&self.model, u[0], u[1]);
        let jx = self.scale.jac_x(&sp.jac);
        let lambda = self.cfg.decoupler_damping * mat2::singular_values(&jx)[0];
        Decoupler {
            at: u,
            x_at: self.scale.x_of(u),
            m: mat2::damped_inverse(&jx, lambda),
        }
    }

    /// The model for the reference advanced by one sample under the feedforward `u_ff` of
    /// this sample (its state is the reference of the next one).
    #[inline]
    fn advance_model(&mut self, ts: f64) {
        let u_ff = self.st.u_ff;
        let p = self.st.model_plant.as_mut().expect("reset made it");
        p.set_inputs(u_ff[0], u_ff[1]);
        if p.step(ts).is_err() {
            // Never expected inside the envelope; fall back to the map.
            p.settle();
        }
    }

    /// One sample: measurement (r1, r2) [mm] and setpoint (r1*, r2*) [mm] in, inputs
    /// (z_m [m], omega [rad/s]) to hold until the next sample out. The first call without
    /// [`Controller::reset`] starts at the feedforward of the setpoint.
    pub fn step(&mut self, measurement: [f64; 2], setpoint: [f64; 2]) -> (f64, f64) {
        let ts = self.cfg.sample_time_s;
        let g = self.cfg.gains;
        let y = measurement;

        // Setpoint -> nearest reachable goal and feedforward target (only when it changes).
        if self.st.status.is_none() || setpoint != self.st.setpoint {
            let opt = InverseOptions {
                bounds: Some(self.cfg.limits.envelope()),
                ..InverseOptions::default()
            };
            let status = inverse_with(&self.model, setpoint[0], setpoint[1], &opt);
            self.st.x_goal = self.scale.x_of([status.z_m, status.omega]);
            self.st.status = Some(status);
            self.st.setpoint = setpoint;
        }
        let status = self.st.status.expect("set above");
        let goal = status.radii();
        let u_goal = [status.z_m, status.omega];
        if !self.st.initialized {
            self.reset(u_goal[0], u_goal[1], y);
        }

        // Per-sample steps allowed by the rate limits, in normalised units.
        let max_dx = self.derived.max_dx;

        // Reference.
        let r_ref = if self.cfg.feedforward {
            // The model's prediction for the feedforward applied so far...
            let r_ref = self.st.model_plant.as_ref().expect("reset made it").state();
            // ...then the feedforward for this sample, ramped at the rate limits (the model
            // is advanced under it for the next sample once the command is made).
            let x_ff = self.st.x_ff;
            let x_goal = self.st.x_goal;
            // A straight line in normalised inputs, both inputs arriving together, at the
            // speed of the axis with the longer way to go.
            let d = [x_goal[0] - x_ff[0], x_goal[1] - x_ff[1]];
            let mut k: f64 = 1.0;
            for i in 0..2 {
                if d[i].abs() > max_dx[i] {
                    k = k.min(max_dx[i] / d[i].abs());
                }
            }
            let x_new = [x_ff[0] + k * d[0], x_ff[1] + k * d[1]];
            self.st.u_ff = self.scale.u_of(x_new);
            self.st.x_ff = self.scale.x_of(self.st.u_ff);
            // The model is advanced under `u_ff` at the end of the sample (`advance_model`),
            // after the command: nothing in the command reads it, and the command is what
            // the plant waits for.
            r_ref
        } else {
            let tau = self.cfg.reference_filter_s;
            let a = ts / (tau + ts);
            for (i, r) in self.st.r_pre.iter_mut().enumerate() {
                *r += a * (goal[i] - *r);
            }
            self.st.r_pre
        };
        let e = [r_ref[0] - y[0], r_ref[1] - y[1]];

        // Derivative on the filtered measurement (relative to the model's prediction with
        // feedforward), never on the setpoint.
        let sig = if self.cfg.feedforward {
            e
        } else {
            [-y[0], -y[1]]
        };
        let a = self.derived.deriv_a;
        let mut deriv = [0.0; 2];
        for i in 0..2 {
            let prev = self.st.d_filt[i];
            let next = prev + a * (sig[i] - prev);
            deriv[i] = (next - prev) / ts;
            self.st.d_filt[i] = next;
        }
        let dterm = [g.kd[0] * deriv[0], g.kd[1] * deriv[1]];

        // Decoupled correction.
        let x_prev = self.scale.x_of(self.st.u);
        let jinv = self.decoupler(self.st.u, x_prev);
        if let Some(old) = self.st.gains_before.take() {
            // Bumpless gain change: the integral takes over the difference.
            let dv = [
                (old.kp[0] - g.kp[0]) * e[0] + (old.kd[0] - g.kd[0]) * deriv[0],
                (old.kp[1] - g.kp[1]) * e[1] + (old.kd[1] - g.kd[1]) * deriv[1],
            ];
            let di = mat2::mul_v(&jinv, dv);
            self.st.integ[0] += di[0];
            self.st.integ[1] += di[1];
        }
        let v = [g.kp[0] * e[0] + dterm[0], g.kp[1] * e[1] + dterm[1]];
        let dv = mat2::mul_v(&jinv, v);
        let x_ff = self.st.x_ff;
        let x_des = [
            x_ff[0] + dv[0] + self.st.integ[0],
            x_ff[1] + dv[1] + self.st.integ[1],
        ];
        let mut x_cmd = [0.0; 2];
        let mut saturated = [false; 2];
        let mut rate_limited = [false; 2];
        for i in 0..2 {
            let sat = x_des[i].clamp(0.0, 1.0);
            saturated[i] = (sat - x_des[i]).abs() > 1e-12;
            let lim = sat.clamp(x_prev[i] - max_dx[i], x_prev[i] + max_dx[i]);
            rate_limited[i] = (lim - sat).abs() > 1e-9 * max_dx[i];
            x_cmd[i] = lim.clamp(0.0, 1.0);
        }

        // Integral with anti-windup.
        let inc = mat2::mul_v(&jinv, [g.ki[0] * e[0] * ts, g.ki[1] * e[1] * ts]);
        for i in 0..2 {
            let excess = x_des[i] - x_cmd[i];
            let mut di = inc[i];
            if g.conditional_integration && excess.abs() > 1e-12 && di * excess > 0.0 {
                di = 0.0;
            }
            if g.tracking_time_s > 0.0 {
                di -= self.derived.track * excess;
            }
            self.st.integ[i] += di;
        }

        let u_cmd = self.scale.u_of(x_cmd);
        self.st.u = u_cmd;
        self.st.last = StepInfo {
            reference_mm: r_ref,
            goal_mm: goal,
            error_mm: e,
            feedforward: self.st.u_ff,
            requested: self.scale.u_of(x_des),
            commanded: u_cmd,
            saturated,
            rate_limited,
            integral: self.st.integ,
        };
        if self.cfg.feedforward {
            self.advance_model(ts);
        }
        (u_cmd[0], u_cmd[1])
    }
}
