//! The FMU's variable table (value references, parameters with their bounds and start values,
//! units, log categories) and the modelDescription.xml generated from it: one source for the
//! binary's behaviour and the XML.

use super::*;
use magswarm_fmi::FmiVersion;

/// Model identifier (file name of the shared library and of the FMU).
pub const MODEL_IDENTIFIER: &str = "MagSwarmPID";
/// Name of the plant model JSON inside the FMU's `resources/`.
pub const RESOURCE_MODEL: &str = "model.json";
/// Name of the controller configuration JSON inside the FMU's `resources/`.
pub const RESOURCE_CONFIG: &str = "pid.json";

/// Value references.
pub mod vr {
    /// Input: setpoint r1* \[m\].
    pub const R1_REF: u32 = 1;
    /// Input: setpoint r2* \[m\].
    pub const R2_REF: u32 = 2;
    /// Input: measured r1 \[m\].
    pub const R1: u32 = 3;
    /// Input: measured r2 \[m\].
    pub const R2: u32 = 4;
    /// Output: commanded z_m \[m\].
    pub const Z_M: u32 = 10;
    /// Output: commanded omega_m [rad/s].
    pub const OMEGA_M: u32 = 11;
    /// Output: nearest reachable r1 \[m\].
    pub const R1_GOAL: u32 = 12;
    /// Output: nearest reachable r2 \[m\].
    pub const R2_GOAL: u32 = 13;
    /// Output: distance setpoint - goal \[m\].
    pub const TARGET_DISTANCE: u32 = 14;
    /// Output: reference tracked at the last sample, r1 \[m\].
    pub const R1_REFERENCE: u32 = 15;
    /// Output: reference tracked at the last sample, r2 \[m\].
    pub const R2_REFERENCE: u32 = 16;
    /// Output: feedforward z_m \[m\].
    pub const Z_M_FF: u32 = 17;
    /// Output: feedforward omega_m [rad/s].
    pub const OMEGA_M_FF: u32 = 18;
    /// Output (Boolean): setpoint reachable.
    pub const TARGET_FEASIBLE: u32 = 20;
    /// Output (Boolean): last command clipped by the envelope.
    pub const SATURATED: u32 = 21;
    /// Output (Boolean): last command clipped by a rate limit.
    pub const RATE_LIMITED: u32 = 22;
    /// Output (Integer): samples taken.
    pub const SAMPLES: u32 = 23;
    /// Parameter: z_m in force when the loop closes \[m\].
    pub const Z_START: u32 = 30;
    /// Parameter: omega_m in force when the loop closes [rad/s].
    pub const OMEGA_START: u32 = 31;
    /// Parameter (Boolean): feedforward + model reference.
    pub const FEEDFORWARD: u32 = 32;
    /// Parameter (Boolean, tunable): conditional integration.
    pub const CONDITIONAL_INTEGRATION: u32 = 33;
    /// Parameter (String): plant model JSON.
    pub const MODEL_FILE: u32 = 40;
    /// Parameter (String): controller configuration JSON.
    pub const CONFIG_FILE: u32 = 41;
    /// First value reference of the numeric configuration parameters ([`super::PARAMS`]).
    pub const PARAM_BASE: u32 = 100;
}

/// Default setpoint (the seed scenario's first segment) \[m\].
pub const R_REF_START: [f64; 2] = [0.007, 0.011];
/// Default measurement start values (the plant's formed radii near 8.5 mm, 4 Hz) \[m\].
pub const R_START: [f64; 2] = [0.008, 0.011];
/// Default `z_start` \[m\] (the seed's start, z_m 8.5 mm).
pub const Z_START: f64 = 0.0085;
/// Default `omega_start` [rad/s] (4 Hz).
pub const OMEGA_START: f64 = 4.0 * std::f64::consts::TAU;

type Get = fn(&PidConfig) -> f64;
type Set = fn(&mut PidConfig, f64);

/// A numeric field of [`PidConfig`] as an FMI parameter (SI on the interface).
pub struct ParamSpec {
    /// FMI name.
    pub name: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// Display unit, if any.
    pub display_unit: Option<&'static str>,
    /// Tunable while stepping (the gains).
    pub tunable: bool,
    /// Values accepted (SI, inclusive): anything outside is refused when set, read from a
    /// configuration or restored from a state, so no absurd value reaches the arithmetic.
    pub range: (f64, f64),
    /// Description (names the `PidConfig` field).
    pub description: &'static str,
    /// SI value from a configuration.
    pub get: Get,
    /// Write an SI value into a configuration.
    pub set: Set,
}

pub(crate) const MM: f64 = 1e-3;

/// Most controller samples one `fmi2DoStep` may take (at about 13 us per sample, about a
/// second of work): a longer communication step is refused with a message naming this limit,
/// so one call never blocks the importer for minutes.
pub const MAX_SAMPLES_PER_STEP: u64 = 100_000;
/// Smallest accepted `sample_time` \[s\].
pub const MIN_SAMPLE_TIME: f64 = 1e-6;
/// Largest accepted magnitude of a radius input (`r1`, `r2`, `r1_ref`, `r2_ref`) \[m\]: the
/// swarm is millimetres across, so anything beyond a metre is a broken signal.
pub const MAX_RADIUS: f64 = 1.0;
/// Largest accepted magnitude of `z_start` \[m\].
pub const MAX_Z_START: f64 = 1.0;
/// Largest accepted magnitude of `omega_start` [rad/s].
pub const MAX_OMEGA_START: f64 = 1e5;
/// Largest accepted magnitude of the experiment's start time \[s\].
pub const MAX_TIME: f64 = 1e12;

/// Whether every numeric parameter of `cfg` lies in its [`ParamSpec::range`] and the
/// configuration is consistent ([`PidConfig::validate`]); the error names the parameter.
pub fn check_config(cfg: &PidConfig) -> Result<(), ModelError> {
    for p in PARAMS {
        check_param(p, (p.get)(cfg))?;
    }
    cfg.validate()
        .map_err(|e| ModelError::error(format!("controller configuration: {e}")))
}

pub(crate) fn check_param(p: &ParamSpec, v: f64) -> Result<(), ModelError> {
    let (lo, hi) = p.range;
    if v >= lo && v <= hi {
        Ok(())
    } else {
        Err(ModelError::error(format!(
            "{} = {v} {} is outside the accepted range [{lo}, {hi}] {}",
            p.name, p.unit, p.unit
        )))
    }
}

pub(crate) fn check_abs(name: &str, v: f64, max: f64, unit: &str) -> Result<(), ModelError> {
    if v.is_finite() && v.abs() <= max {
        Ok(())
    } else {
        Err(ModelError::error(format!(
            "{name} = {v} {unit} is outside the accepted range [-{max}, {max}] {unit}"
        )))
    }
}

/// Numeric parameters in value-reference order (vr = PARAM_BASE + index).
pub static PARAMS: &[ParamSpec] = &[
    ParamSpec { name: "sample_time", unit: "s", display_unit: None, tunable: false, range: (MIN_SAMPLE_TIME, 3600.0),
        description: "controller sample time (sample_time_s); use it as the communication step",
        get: |c| c.sample_time_s, set: |c, v| c.sample_time_s = v },
    ParamSpec { name: "kp_r1", unit: "1", display_unit: None, tunable: true, range: (0.0, 1e6),
        description: "proportional gain of r1 in radius space, mm per mm (gains.kp[0])",
        get: |c| c.gains.kp[0], set: |c, v| c.gains.kp[0] = v },
    ParamSpec { name: "kp_r2", unit: "1", display_unit: None, tunable: true, range: (0.0, 1e6),
        description: "proportional gain of r2 (gains.kp[1])",
        get: |c| c.gains.kp[1], set: |c, v| c.gains.kp[1] = v },
    ParamSpec { name: "ki_r1", unit: "1/s", display_unit: None, tunable: true, range: (0.0, 1e6),
        description: "integral gain of r1 (gains.ki[0])",
        get: |c| c.gains.ki[0], set: |c, v| c.gains.ki[0] = v },
    ParamSpec { name: "ki_r2", unit: "1/s", display_unit: None, tunable: true, range: (0.0, 1e6),
        description: "integral gain of r2 (gains.ki[1])",
        get: |c| c.gains.ki[1], set: |c, v| c.gains.ki[1] = v },
    ParamSpec { name: "kd_r1", unit: "s", display_unit: None, tunable: true, range: (0.0, 1e6),
        description: "derivative gain of r1 (gains.kd[0])",
        get: |c| c.gains.kd[0], set: |c, v| c.gains.kd[0] = v },
    ParamSpec { name: "kd_r2", unit: "s", display_unit: None, tunable: true, range: (0.0, 1e6),
        description: "derivative gain of r2 (gains.kd[1])",
        get: |c| c.gains.kd[1], set: |c, v| c.gains.kd[1] = v },
    ParamSpec { name: "derivative_filter", unit: "s", display_unit: None, tunable: true, range: (0.0, 1e6),
        description: "time constant of the derivative's first-order filter (gains.derivative_filter_s)",
        get: |c| c.gains.derivative_filter_s, set: |c, v| c.gains.derivative_filter_s = v },
    ParamSpec { name: "tracking_time", unit: "s", display_unit: None, tunable: true, range: (0.0, 1e6),
        description: "anti-windup back-calculation time constant, 0 disables (gains.tracking_time_s)",
        get: |c| c.gains.tracking_time_s, set: |c, v| c.gains.tracking_time_s = v },
    ParamSpec { name: "z_min", unit: "m", display_unit: Some("mm"), tunable: false, range: (-1.0, 1.0),
        description: "smallest commanded z_m (limits.z_min_mm)",
        get: |c| c.limits.z_min_mm * MM, set: |c, v| c.limits.z_min_mm = v / MM },
    ParamSpec { name: "z_max", unit: "m", display_unit: Some("mm"), tunable: false, range: (-1.0, 1.0),
        description: "largest commanded z_m (limits.z_max_mm)",
        get: |c| c.limits.z_max_mm * MM, set: |c, v| c.limits.z_max_mm = v / MM },
    ParamSpec { name: "f_min", unit: "Hz", display_unit: None, tunable: false, range: (0.0, 1e4),
        description: "lowest commanded field frequency (limits.f_min_hz)",
        get: |c| c.limits.f_min_hz, set: |c, v| c.limits.f_min_hz = v },
    ParamSpec { name: "f_max", unit: "Hz", display_unit: None, tunable: false, range: (0.0, 1e4),
        description: "highest commanded field frequency (limits.f_max_hz)",
        get: |c| c.limits.f_max_hz, set: |c, v| c.limits.f_max_hz = v },
    ParamSpec { name: "z_rate", unit: "m/s", display_unit: Some("mm/s"), tunable: false, range: (0.0, 1e3),
        description: "rate limit of z_m, the robot arm (limits.z_rate_mm_s)",
        get: |c| c.limits.z_rate_mm_s * MM, set: |c, v| c.limits.z_rate_mm_s = v / MM },
    ParamSpec { name: "f_rate", unit: "Hz/s", display_unit: None, tunable: false, range: (0.0, 1e6),
        description: "rate limit of the field frequency, the stepper (limits.f_rate_hz_s)",
        get: |c| c.limits.f_rate_hz_s, set: |c, v| c.limits.f_rate_hz_s = v },
    ParamSpec { name: "reference_filter", unit: "s", display_unit: None, tunable: false, range: (0.0, 1e6),
        description: "setpoint prefilter time constant without feedforward (reference_filter_s)",
        get: |c| c.reference_filter_s, set: |c, v| c.reference_filter_s = v },
    ParamSpec { name: "decoupler_damping", unit: "1", display_unit: None, tunable: false, range: (0.0, 1e6),
        description: "damping of the decoupler's inverse relative to the largest singular value (decoupler_damping)",
        get: |c| c.decoupler_damping, set: |c, v| c.decoupler_damping = v },
    ParamSpec { name: "feasible_tol", unit: "m", display_unit: Some("mm"), tunable: false, range: (0.0, 1.0),
        description: "distance above which a setpoint is reported infeasible (feasible_tol_mm)",
        get: |c| c.feasible_tol_mm * MM, set: |c, v| c.feasible_tol_mm = v / MM },
];

pub(crate) fn param_index(vr: u32) -> Option<usize> {
    vr.checked_sub(vr::PARAM_BASE)
        .map(|i| i as usize)
        .filter(|&i| i < PARAMS.len())
}

pub(crate) static UNITS: &[UnitDefinition] = &[
    units::METRE,
    units::RAD_PER_SECOND,
    units::SECOND,
    units::HERTZ,
    units::ONE,
    units::PER_SECOND,
    units::METRE_PER_SECOND,
    units::HERTZ_PER_SECOND,
];

pub(crate) static LOG_CATEGORIES: &[LogCategory] = &[
    LogCategory {
        name: "logSetpoint",
        description: "new setpoints: feasible, or the nearest reachable radii",
    },
    LogCategory {
        name: "logConfig",
        description: "configuration and model loading (config_file, model_file, resources)",
    },
];

/// Outputs change only in doStep: no direct feedthrough from any input (which is what lets a
/// master close the loop without an algebraic loop).
pub(crate) const NONE: &[u32] = &[];

pub(crate) fn build_variables() -> Vec<Variable> {
    let cfg = PidConfig::default();
    let m = |v: Variable| v.unit("m").display_unit("mm").nominal(0.01);
    let out = |v: Variable| {
        v.output()
            .variability(magswarm_fmi::Variability::Discrete)
            .depends_on(NONE)
    };
    let mut v = vec![
        m(Variable::real("r1_ref", vr::R1_REF).input().start_real(R_REF_START[0]))
            .description("setpoint r1*"),
        m(Variable::real("r2_ref", vr::R2_REF).input().start_real(R_REF_START[1]))
            .description("setpoint r2*"),
        m(Variable::real("r1", vr::R1).input().start_real(R_START[0]))
            .description("measured radius r1 (connect the plant's r1)"),
        m(Variable::real("r2", vr::R2).input().start_real(R_START[1]))
            .description("measured radius r2 (connect the plant's r2)"),
        m(out(Variable::real("z_m", vr::Z_M)))
            .description("commanded magnet-swarm distance (connect to the plant's z_m)"),
        out(Variable::real("omega_m", vr::OMEGA_M))
            .unit("rad/s")
            .display_unit("Hz")
            .nominal(30.0)
            .description("commanded field angular velocity (connect to the plant's omega_m)"),
        m(out(Variable::real("r1_goal", vr::R1_GOAL)))
            .description("nearest reachable r1 to the setpoint (the setpoint when feasible)"),
        m(out(Variable::real("r2_goal", vr::R2_GOAL)))
            .description("nearest reachable r2 to the setpoint (the setpoint when feasible)"),
        m(out(Variable::real("target_distance", vr::TARGET_DISTANCE)))
            .description("distance from the setpoint to the nearest reachable radii"),
        m(out(Variable::real("r1_reference", vr::R1_REFERENCE)))
            .description("reference tracked at the last sample (model prediction with feedforward)"),
        m(out(Variable::real("r2_reference", vr::R2_REFERENCE)))
            .description("reference tracked at the last sample (model prediction with feedforward)"),
        m(out(Variable::real("z_m_ff", vr::Z_M_FF)))
            .description("feedforward z_m (rate-limited ramp to the inverse map)"),
        out(Variable::real("omega_m_ff", vr::OMEGA_M_FF))
            .unit("rad/s")
            .display_unit("Hz")
            .description("feedforward omega_m (rate-limited ramp to the inverse map)"),
        out(Variable::boolean("target_feasible", vr::TARGET_FEASIBLE))
            .description("the setpoint is reachable (distance <= feasible_tol)"),
        out(Variable::boolean("saturated", vr::SATURATED))
            .description("the last command was clipped by the envelope"),
        out(Variable::boolean("rate_limited", vr::RATE_LIMITED))
            .description("the last command was clipped by a rate limit"),
        out(Variable::integer("samples", vr::SAMPLES)).description("controller samples taken"),
        Variable::real("z_start", vr::Z_START)
            .parameter()
            .start_real(Z_START)
            .unit("m")
            .display_unit("mm")
            .description("z_m in force when the loop closes (the plant's initial input): bumpless start"),
        Variable::real("omega_start", vr::OMEGA_START)
            .parameter()
            .start_real(OMEGA_START)
            .unit("rad/s")
            .display_unit("Hz")
            .description("omega_m in force when the loop closes (the plant's initial input)"),
        Variable::boolean("feedforward", vr::FEEDFORWARD)
            .parameter()
            .start_boolean(cfg.feedforward)
            .description("feedforward from the inverse map with the model-predicted reference (feedforward)"),
        Variable::boolean("conditional_integration", vr::CONDITIONAL_INTEGRATION)
            .tunable_parameter()
            .start_boolean(cfg.gains.conditional_integration)
            .description("do not integrate into a saturation (gains.conditional_integration)"),
        Variable::string("model_file", vr::MODEL_FILE)
            .parameter()
            .start_string("")
            .description("model JSON (magswarm-model/1) of the plant the controller assumes; empty: resources/model.json or the paper model"),
        Variable::string("config_file", vr::CONFIG_FILE)
            .parameter()
            .start_string("")
            .description("controller configuration JSON (magswarm-pid/1); empty: resources/pid.json or the defaults; parameters set to other values than their start override it"),
    ];
    for (i, p) in PARAMS.iter().enumerate() {
        let mut var = Variable::real(p.name, vr::PARAM_BASE + i as u32)
            .start_real((p.get)(&cfg))
            .unit(p.unit)
            .description(p.description);
        var = if p.tunable {
            var.tunable_parameter()
        } else {
            var.parameter()
        };
        if let Some(d) = p.display_unit {
            var = var.display_unit(d);
        }
        v.push(var);
    }
    v
}

pub(crate) static INFO: LazyLock<ModelInfo> = LazyLock::new(|| ModelInfo {
    model_identifier: MODEL_IDENTIFIER,
    model_name: "MagSwarmPID",
    description: "Decoupled 2x2 PID with feedforward from the inverse steady map for the MagSwarm \
                  plant: setpoints and measured radii in, magnet distance z_m and field angular \
                  velocity omega_m out (discrete time, sample_time)",
    version: env!("CARGO_PKG_VERSION"),
    author: "magswarm",
    copyright: None,
    license: Some("MIT OR Apache-2.0"),
    generation_tool: concat!("magswarm ", env!("CARGO_PKG_VERSION")),
    naming_convention: Default::default(),
    default_experiment: Some(DefaultExperiment {
        start_time: Some(0.0),
        stop_time: Some(180.0),
        // The controller is discrete and ignores it, but strict importers (FMI Library's
        // compliance checker) warn when a DefaultExperiment has none; the plant's value, so
        // a system of both FMUs runs at one tolerance.
        tolerance: Some(1e-8),
        step_size: Some(0.05),
    }),
    units: UNITS,
    log_categories: LOG_CATEGORIES,
    variables: magswarm_fmi::unload::leak(build_variables()),
});

/// The static model information (variable table, units).
pub fn model_info() -> &'static ModelInfo {
    &INFO
}

/// The modelDescription.xml of an FMU whose default configuration is `baked` (the parameter
/// start values are its values).
pub fn model_description(baked: &PidConfig, generated_at: Option<String>) -> String {
    model_description_for(baked, generated_at, FmiVersion::V2)
}

/// [`model_description`] in FMI `version`.
pub fn model_description_for(
    baked: &PidConfig,
    generated_at: Option<String>,
    version: FmiVersion,
) -> String {
    let mut overrides: Vec<(u32, Start)> = PARAMS
        .iter()
        .enumerate()
        .map(|(i, p)| (vr::PARAM_BASE + i as u32, Start::Real((p.get)(baked))))
        .collect();
    overrides.push((vr::FEEDFORWARD, Start::Boolean(baked.feedforward)));
    overrides.push((
        vr::CONDITIONAL_INTEGRATION,
        Start::Boolean(baked.gains.conditional_integration),
    ));
    let options = magswarm_fmi::xml::XmlOptions {
        generation_date_and_time: generated_at,
        start_overrides: overrides,
    };
    magswarm_fmi::model_description_xml::<MagSwarmPid>(version, &options)
}
