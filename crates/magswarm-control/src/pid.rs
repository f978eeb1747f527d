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
use crate::reference::Reference;

/// How finely the controller computes the parts of a sample that the PID's action does not
/// resolve: its reference model, the decoupler's schedule and the command's resolution.
///
/// [`Fidelity::Lean`] (the default) moves the commands by amounts far below what the
/// actuators resolve and the radii by far less than any tracking error (below 1e-12 mm in
/// the seed's scenario at 1 kHz, docs/performance.md "Round perf18"), for about half the
/// controller's work per sample and, through the plant, a quarter of the input changes.
/// [`Fidelity::Full`] is the controller as it was before: the yardstick the closed-loop
/// tests compare the lean one with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Fidelity {
    /// Reference from ODE (4) by fixed-step fourth-order Runge-Kutta (`crate::reference`),
    /// commands held within [`COMMAND_RESOLUTION`] of the last one, errors within
    /// [`INTEGRAL_DEADBAND_MM`] not integrated, the derivative's filter snapped to its input
    /// within [`DERIVATIVE_SNAP_MM`], and a sample that finds the controller at rest under
    /// the same measurement and setpoint answered from the last one.
    #[default]
    Lean,
    /// Reference from the full plant model (its Dormand-Prince integrator at rtol 1e-8),
    /// every command passed on to its last bit, every error integrated, every sample
    /// computed: the controller as it was before round perf18 of docs/performance.md.
    Full,
}

/// Resolution of the decoupler's schedule, in fractions of the envelope's spans (see
/// `Controller::decoupler`). Both fidelities: a coarser one (1e-3 of the spans, which
/// would skip nine in ten Jacobians during a ramp at 1 kHz) left the loop with a plant 1 %
/// off the model in a limit cycle of about 8e-4 of the frequency's span at 20 Hz, where
/// this one settles (docs/performance.md, round perf18).
const DECOUPLER_RESOLUTION: f64 = 1e-12;

/// Smallest change of the command that [`Fidelity::Lean`] passes on, in fractions of the
/// envelope's spans on either input (2e-12 m of z_m, 1e-9 Hz of the frequency with the
/// default limits): a smaller one is held at the last command. The PID's corrections move
/// the command in its last bits on most samples of a transient (1e-16 of a span: the
/// measurement and the model's prediction differ by rounding), and each such change costs
/// the plant an input change (an FMU: the map, the gains and a fresh integration step) for
/// nothing an actuator could carry out. The radii it holds back are at most the map's
/// slope times this, about 1e-9 mm; the integral keeps integrating the error behind it, so
/// a correction that matters still comes through, one resolution at a time.
pub const COMMAND_RESOLUTION: f64 = 1e-10;

/// Tracking errors at most this large \[mm\] are not integrated with [`Fidelity::Lean`].
/// The controller's model and the plant it models tell equilibria apart by about this much
/// and less even when they are the same model: a plant (an FMU) evaluating its map from
/// tables answers within the tables' proven bound (2.9e-11 mm), and two integrators come to
/// rest at fixed points of their own steps (about 1e-12 mm apart). The integral would
/// integrate such an error for as long as the run lasts and move the command by a
/// resolution now and then (each time starting a transient of the plant of some seconds);
/// the proportional and derivative parts still see it, and any error larger than this is
/// integrated as before. The radii it leaves are within this of the reference.
pub const INTEGRAL_DEADBAND_MM: f64 = 1e-9;

/// With [`Fidelity::Lean`] the derivative's filter takes its input's value once within this
/// of it \[mm\]. Without it the filter creeps towards a constant input for ever (each sample
/// closes a hundredth of the gap at 1 kHz; towards an input of exactly zero it reaches the
/// subnormal numbers after about 70 s, whose arithmetic is slow), so a controller whose
/// plant has come to rest never comes to rest itself. The derivative this adds is at most
/// this over the sample time, times kd (2e-11 mm at the defaults and 1 kHz).
pub const DERIVATIVE_SNAP_MM: f64 = 1e-12;

/// The resolutions of a [`Fidelity`] (a negative one: none).
#[derive(Debug, Clone, Copy)]
struct Resolutions {
    /// Of the command, fractions of the spans.
    command: f64,
    /// The integral's deadband \[mm\].
    integral_mm: f64,
    /// Where the derivative's filter snaps to its input \[mm\].
    derivative_mm: f64,
    /// Whether a sample that finds the controller where the last one left it, with the
    /// same measurement and setpoint, returns the last command (see `Controller::step`).
    memo: bool,
}

impl Fidelity {
    fn resolutions(self) -> Resolutions {
        match self {
            Fidelity::Lean => Resolutions {
                command: COMMAND_RESOLUTION,
                integral_mm: INTEGRAL_DEADBAND_MM,
                derivative_mm: DERIVATIVE_SNAP_MM,
                memo: true,
            },
            Fidelity::Full => Resolutions {
                command: -1.0,
                integral_mm: -1.0,
                derivative_mm: -1.0,
                memo: false,
            },
        }
    }
}

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
    model_plant: Option<RefModel>,
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
    /// The measurement and setpoint (bits) of the last sample, if that sample left the
    /// state as it found it (see [`Controller::step`]; a cache: not in snapshots).
    quiet: Option<[u64; 4]>,
}

/// Sets `slot` to `v` and says whether that changed its bits (the state changes a sample
/// makes, see `Controller::step`).
#[inline(always)]
fn set2(slot: &mut [f64; 2], v: [f64; 2]) -> bool {
    let moved = slot[0].to_bits() != v[0].to_bits() || slot[1].to_bits() != v[1].to_bits();
    *slot = v;
    moved
}

/// The controller's model of the plant, whose state is the reference (see [`Fidelity`]).
#[derive(Debug, Clone)]
enum RefModel {
    Lean(Reference),
    Full(Box<Plant>),
}

impl RefModel {
    /// At state `r` \[mm\] under inputs `u` (z_m \[m\], omega [rad/s]).
    fn new(fidelity: Fidelity, model: &Model, u: [f64; 2], r: [f64; 2]) -> RefModel {
        match fidelity {
            Fidelity::Lean => RefModel::Lean(Reference::new(model, u, r)),
            Fidelity::Full => {
                let mut p = Plant::new(model.clone(), u[0], u[1]);
                p.set_state(r);
                RefModel::Full(Box::new(p))
            }
        }
    }

    fn from_snapshot(fidelity: Fidelity, model: &Model, s: &PlantSnapshot) -> RefModel {
        match fidelity {
            Fidelity::Lean => RefModel::Lean(Reference::from_snapshot(model, s)),
            Fidelity::Full => RefModel::Full(Box::new(Plant::from_snapshot(model.clone(), s))),
        }
    }

    fn snapshot(&self, model: &Model) -> PlantSnapshot {
        match self {
            RefModel::Lean(r) => r.snapshot(model),
            RefModel::Full(p) => p.snapshot(),
        }
    }

    /// The reference \[mm\].
    #[inline]
    fn state(&self) -> [f64; 2] {
        match self {
            RefModel::Lean(r) => r.state(),
            RefModel::Full(p) => p.state(),
        }
    }

    /// Advanced by `ts` under inputs `u`; whether that changed anything the next advance
    /// reads (true for the full model, whose clock and step counts always move).
    #[inline]
    fn advance(&mut self, model: &Model, u: [f64; 2], ts: f64) -> bool {
        match self {
            RefModel::Lean(r) => {
                let changed = r.set_inputs(model, u);
                r.advance(ts) || changed
            }
            RefModel::Full(p) => {
                p.set_inputs(u[0], u[1]);
                if p.step(ts).is_err() {
                    // Never expected inside the envelope; fall back to the map.
                    p.settle();
                }
                true
            }
        }
    }
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
    fidelity: Fidelity,
    /// `fidelity.resolutions()`.
    res: Resolutions,
    scale: Scale,
    derived: Derived,
    st: State,
}

impl Controller {
    /// A controller for `model` (used for the feedforward, the decoupler and the reference),
    /// [`Fidelity::Lean`].
    pub fn new(model: Model, cfg: PidConfig) -> Result<Controller, ConfigError> {
        Controller::with_fidelity(model, cfg, Fidelity::default())
    }

    /// A controller for `model` with the given [`Fidelity`].
    pub fn with_fidelity(
        model: Model,
        cfg: PidConfig,
        fidelity: Fidelity,
    ) -> Result<Controller, ConfigError> {
        cfg.validate()?;
        let scale = Scale::new(&cfg.limits.envelope());
        let derived = Derived::of(&cfg, &scale);
        Ok(Controller {
            model,
            cfg,
            fidelity,
            res: fidelity.resolutions(),
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
                quiet: None,
            },
        })
    }

    /// The configuration.
    pub fn config(&self) -> &PidConfig {
        &self.cfg
    }

    /// How finely the controller computes a sample (see [`Fidelity`]).
    pub fn fidelity(&self) -> Fidelity {
        self.fidelity
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
        st.quiet = None;
        st.r_pre = measurement;
        st.d_filt = if self.cfg.feedforward {
            [0.0; 2]
        } else {
            [-measurement[0], -measurement[1]]
        };
        st.model_plant = self
            .cfg
            .feedforward
            .then(|| RefModel::new(self.fidelity, &self.model, u, measurement));
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
            model_plant: st.model_plant.as_ref().map(|m| m.snapshot(&self.model)),
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
                .map(|p| RefModel::from_snapshot(self.fidelity, model, p)),
            setpoint: s.setpoint.unwrap_or([f64::NAN; 2]),
            status: s.status,
            x_goal: s
                .status
                .map_or([0.0; 2], |st| self.scale.x_of([st.z_m, st.omega])),
            last: s.last,
            gains_before: s.gains_before,
            decoupler: None,
            quiet: None,
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
        self.st.quiet = None;
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
    /// Also says whether it was computed now (a change of the state).
    fn decoupler(&mut self, u: [f64; 2], x: [f64; 2]) -> (mat2::M2, bool) {
        let res = DECOUPLER_RESOLUTION;
        if let Some(d) = self.st.decoupler {
            let x_at = d.x_at;
            if (x[0] - x_at[0]).abs() <= res && (x[1] - x_at[1]).abs() <= res {
                return (d.m, false);
            }
        }
        // The lean reference keeps the map's Jacobian at its inputs, the feedforward: during
        // a ramp the command is the feedforward but for corrections far below the schedule's
        // resolution, so the map need not be evaluated a second time at (nearly) the same
        // point.
        if let Some(RefModel::Lean(r)) = &self.st.model_plant {
            let at = r.inputs();
            let x_at = self.scale.x_of(at);
            if (x[0] - x_at[0]).abs() <= res && (x[1] - x_at[1]).abs() <= res {
                let d = self.decoupler_from(at, &r.map_jacobian());
                self.st.decoupler = Some(d);
                return (d.m, true);
            }
        }
        let d = self.decoupler_at(u);
        self.st.decoupler = Some(d);
        (d.m, true)
    }

    /// Damped inverse of the normalised Jacobian at inputs u, computed.
    fn decoupler_at(&self, u: [f64; 2]) -> Decoupler {
        let sp = steady::evaluate(&self.model, u[0], u[1]);
        self.decoupler_from(u, &sp.jac)
    }

    /// Damped inverse of the normalised Jacobian at inputs u, from the map's Jacobian there.
    fn decoupler_from(&self, u: [f64; 2], jac: &mat2::M2) -> Decoupler {
        let jx = self.scale.jac_x(jac);
        let lambda = self.cfg.decoupler_damping * mat2::singular_values(&jx)[0];
        Decoupler {
            at: u,
            x_at: self.scale.x_of(u),
            m: mat2::damped_inverse(&jx, lambda),
        }
    }

    /// The model for the reference advanced by one sample under the feedforward `u_ff` of
    /// this sample (its state is the reference of the next one).
    /// Whether that changed anything the next advance reads.
    #[inline]
    fn advance_model(&mut self, ts: f64) -> bool {
        let u_ff = self.st.u_ff;
        let p = self.st.model_plant.as_mut().expect("reset made it");
        p.advance(&self.model, u_ff, ts)
    }

    /// One sample: measurement (r1, r2) [mm] and setpoint (r1*, r2*) [mm] in, inputs
    /// (z_m [m], omega [rad/s]) to hold until the next sample out. The first call without
    /// [`Controller::reset`] starts at the feedforward of the setpoint.
    ///
    /// With [`Fidelity::Lean`], a sample that comes with the measurement and setpoint of the
    /// last one, when that one left the controller's state bit for bit as it found it,
    /// returns the last command without computing it: the sample is a deterministic
    /// function of the state and those two, so it would compute the same command and leave
    /// the state as it is (the same `last()` too). Once the plant and the controller's
    /// model have come to rest (the deadbands above let the controller's state come to rest
    /// with them), that is most samples of a tracking run.
    pub fn step(&mut self, measurement: [f64; 2], setpoint: [f64; 2]) -> (f64, f64) {
        let now = [measurement, setpoint];
        let key = [
            now[0][0].to_bits(),
            now[0][1].to_bits(),
            now[1][0].to_bits(),
            now[1][1].to_bits(),
        ];
        if self.st.quiet == Some(key) {
            return (self.st.u[0], self.st.u[1]);
        }
        let (out, moved) = self.compute(measurement, setpoint);
        self.st.quiet = (self.res.memo && !moved).then_some(key);
        out
    }

    /// [`Controller::step`], computed, and whether the sample changed anything in the state
    /// that a sample reads (`moved`: every write below that may change a bit says so).
    #[inline(always)]
    fn compute(&mut self, measurement: [f64; 2], setpoint: [f64; 2]) -> ((f64, f64), bool) {
        let ts = self.cfg.sample_time_s;
        let g = self.cfg.gains;
        let y = measurement;
        let mut moved = false;

        // Setpoint -> nearest reachable goal and feedforward target (only when it changes).
        if self.st.status.is_none() || setpoint != self.st.setpoint {
            moved = true;
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
            moved = true;
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
            let u_ff = self.scale.u_of(x_new);
            moved |= set2(&mut self.st.u_ff, u_ff);
            moved |= set2(&mut self.st.x_ff, self.scale.x_of(u_ff));
            // The model is advanced under `u_ff` at the end of the sample (`advance_model`),
            // after the command: nothing in the command reads it, and the command is what
            // the plant waits for.
            r_ref
        } else {
            let tau = self.cfg.reference_filter_s;
            let a = ts / (tau + ts);
            let r = self.st.r_pre;
            moved |= set2(
                &mut self.st.r_pre,
                [r[0] + a * (goal[0] - r[0]), r[1] + a * (goal[1] - r[1])],
            );
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
        let mut d_filt = self.st.d_filt;
        for i in 0..2 {
            let prev = d_filt[i];
            let mut next = prev + a * (sig[i] - prev);
            if (sig[i] - next).abs() <= self.res.derivative_mm {
                next = sig[i];
            }
            deriv[i] = (next - prev) / ts;
            d_filt[i] = next;
        }
        moved |= set2(&mut self.st.d_filt, d_filt);
        let dterm = [g.kd[0] * deriv[0], g.kd[1] * deriv[1]];

        // Decoupled correction.
        let x_prev = self.scale.x_of(self.st.u);
        let (jinv, rescheduled) = self.decoupler(self.st.u, x_prev);
        moved |= rescheduled;
        if let Some(old) = self.st.gains_before.take() {
            moved = true;
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

        // Integral with anti-windup (errors within the deadband not integrated, see
        // INTEGRAL_DEADBAND_MM; written so that a NaN error stays NaN).
        let db = self.res.integral_mm;
        let ei = e.map(|x| if x.abs() <= db { 0.0 } else { x });
        let inc = mat2::mul_v(&jinv, [g.ki[0] * ei[0] * ts, g.ki[1] * ei[1] * ts]);
        let mut integ = self.st.integ;
        for i in 0..2 {
            let excess = x_des[i] - x_cmd[i];
            let mut di = inc[i];
            if g.conditional_integration && excess.abs() > 1e-12 && di * excess > 0.0 {
                di = 0.0;
            }
            if g.tracking_time_s > 0.0 {
                di -= self.derived.track * excess;
            }
            integ[i] += di;
        }
        moved |= set2(&mut self.st.integ, integ);

        // A change below the command's resolution is held back (Fidelity::Lean; see
        // COMMAND_RESOLUTION): the integral above has taken the sample's error either way.
        let res = self.res.command;
        let hold = (x_cmd[0] - x_prev[0]).abs() <= res && (x_cmd[1] - x_prev[1]).abs() <= res;
        let u_cmd = if hold {
            self.st.u
        } else {
            self.scale.u_of(x_cmd)
        };
        moved |= set2(&mut self.st.u, u_cmd);
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
            moved |= self.advance_model(ts);
        }
        ((u_cmd[0], u_cmd[1]), moved)
    }
}
