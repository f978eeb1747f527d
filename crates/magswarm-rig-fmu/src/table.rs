//! The variable table of `MagSwarmRig.fmu`: the interface names of `MagSwarm.fmu` (`z_m`,
//! `omega_m` in; `r1`, `r2` out, SI units with mm/Hz display units), plus what a rig has and a
//! model does not (a validity flag, the shadow model, the inputs actually applied, lateness)
//! and the rig config's limits and calibration as parameters.
//!
//! The table is the one source of the binary's behaviour and of `modelDescription.xml`; the
//! start values of the parameters are overridden with the baked config's values
//! ([`model_description`]), which does not change the GUID.

use magswarm_bridge::config::RigConfig;
use magswarm_fmi2::units::{self, base, display, INV_TWO_PI};
use magswarm_fmi2::{
    DefaultExperiment, LogCategory, ModelInfo, Start, UnitDefinition, Variable, XmlOptions,
};

use crate::RigFmu;

/// Model identifier (file name of the shared library and of the FMU).
pub const MODEL_IDENTIFIER: &str = "MagSwarmRig";
/// The rig config inside the FMU's `resources/`.
pub const RESOURCE_CONFIG: &str = "rig.toml";

/// Value references: the names MagSwarm.fmu also has keep its value references (`z_m` 1,
/// `omega_m` 2, `r1` 10, `r2` 11), so a tool's connections by reference carry over.
pub mod vr {
    /// Input: magnet-swarm distance \[m\].
    pub const Z_M: u32 = 1;
    /// Input: field angular velocity \[rad/s\].
    pub const OMEGA_M: u32 = 2;
    /// Output: r1 measured by the camera \[m\].
    pub const R1: u32 = 10;
    /// Output: r2 measured by the camera \[m\].
    pub const R2: u32 = 11;
    /// Output (Boolean): the newest frame had a valid swarm.
    pub const VALID: u32 = 12;
    /// Output: r1 of the shadow model \[m\].
    pub const R1_SHADOW: u32 = 13;
    /// Output: r2 of the shadow model \[m\].
    pub const R2_SHADOW: u32 = 14;
    /// Output: z_m sent to the arm after the safety core \[m\].
    pub const Z_M_APPLIED: u32 = 15;
    /// Output: omega_m sent to the stepper after the safety core \[rad/s\].
    pub const OMEGA_M_APPLIED: u32 = 16;
    /// Output: z_m from the arm's reported tool pose \[m\].
    pub const Z_M_MEASURED: u32 = 17;
    /// Output: time of the frame behind r1, r2 \[s\].
    pub const T_FRAME: u32 = 18;
    /// Output: how late the last step ended \[s\].
    pub const LATE: u32 = 19;
    /// Output (Integer): steps that ended late.
    pub const LATE_STEPS: u32 = 20;
    /// Parameter (String): the rig config.
    pub const CONFIG_FILE: u32 = 50;
    /// Parameter: lower z_m limit \[m\] (may only narrow the config's).
    pub const Z_M_MIN: u32 = 60;
    /// Parameter: upper z_m limit \[m\].
    pub const Z_M_MAX: u32 = 61;
    /// Parameter: lower omega_m limit \[rad/s\].
    pub const OMEGA_M_MIN: u32 = 62;
    /// Parameter: upper omega_m limit \[rad/s\].
    pub const OMEGA_M_MAX: u32 = 63;
    /// Parameter: z_m rate limit \[m/s\].
    pub const Z_M_RATE_MAX: u32 = 64;
    /// Parameter: omega_m rate limit \[rad/s2\].
    pub const OMEGA_M_RATE_MAX: u32 = 65;
    /// Parameter (read-only): tool z at z_m = 0 \[m\].
    pub const Z_TCP_AT_ZERO: u32 = 70;
    /// Parameter (read-only): pixel size in the swarm's plane \[m\].
    pub const PIXEL_SIZE: u32 = 71;
    /// Parameter (read-only): TMCL velocity units per revolution per second.
    pub const VELOCITY_PER_HZ: u32 = 72;
    /// Parameter: the host may be this late before the rig is stopped \[s\].
    pub const MAX_LATE: u32 = 80;
}

/// `rad/s2`, displayed as `Hz/s`.
pub const RAD_PER_SECOND2: UnitDefinition = UnitDefinition {
    name: "rad/s2",
    base: base(0, 0, -2, 0, 0, 0, 0, 1),
    display_units: &[display("Hz/s", INV_TWO_PI)],
};

static UNITS: &[UnitDefinition] = &[
    units::METRE,
    units::RAD_PER_SECOND,
    RAD_PER_SECOND2,
    units::METRE_PER_SECOND,
    units::SECOND,
    units::ONE,
];

/// The model's log category (the shell adds its own).
pub const LOG_RIG: &str = "logRig";

static LOG_CATEGORIES: &[LogCategory] = &[LogCategory {
    name: LOG_RIG,
    description: "the rig: devices opened, late steps, faults, shutdown",
}];

/// Default start inputs: 8.5 mm, 4 Hz (MagSwarm.fmu's).
pub const Z_START: f64 = 0.0085;
/// Default start angular velocity \[rad/s\] (4 Hz).
pub const OMEGA_START: f64 = 4.0 * std::f64::consts::TAU;
/// Default `max_late` \[s\].
pub const MAX_LATE_DEFAULT: f64 = 1.0;

const NONE: &[u32] = &[];

const fn out_m(name: &'static str, vr: u32, description: &'static str) -> Variable {
    Variable::real(name, vr)
        .output()
        .unit("m")
        .display_unit("mm")
        .depends_on(NONE)
        .description(description)
}

const fn fixed(name: &'static str, vr: u32, start: f64, description: &'static str) -> Variable {
    Variable::real(name, vr)
        .parameter()
        .start_real(start)
        .description(description)
}

static VARIABLES: [Variable; 24] = [
    Variable::real("z_m", vr::Z_M)
        .input()
        .start_real(Z_START)
        .unit("m")
        .display_unit("mm")
        .nominal(0.01)
        .description("magnet-swarm distance asked of the arm (clamped and rate limited by the rig's safety core)"),
    Variable::real("omega_m", vr::OMEGA_M)
        .input()
        .start_real(OMEGA_START)
        .unit("rad/s")
        .display_unit("Hz")
        .nominal(30.0)
        .description("field angular velocity 2 pi f asked of the stepper (clamped and rate limited by the rig's safety core)"),
    out_m("r1", vr::R1, "principal radius r1 measured by the camera (newest valid frame)"),
    out_m("r2", vr::R2, "principal radius r2 measured by the camera (newest valid frame)"),
    Variable::boolean("valid", vr::VALID)
        .output()
        .depends_on(NONE)
        .description("true when the newest frame showed a valid swarm (r1, r2 are its radii); false: r1, r2 hold the last valid frame's"),
    out_m("r1_shadow", vr::R1_SHADOW, "r1 of the shadow model run beside the rig on the applied inputs, at the frame's time"),
    out_m("r2_shadow", vr::R2_SHADOW, "r2 of the shadow model run beside the rig on the applied inputs, at the frame's time"),
    out_m("z_m_applied", vr::Z_M_APPLIED, "z_m sent to the arm after the safety core (clamps, rate limit)"),
    Variable::real("omega_m_applied", vr::OMEGA_M_APPLIED)
        .output()
        .unit("rad/s")
        .display_unit("Hz")
        .depends_on(NONE)
        .description("omega_m sent to the stepper after the safety core (clamps, rate limit)"),
    out_m("z_m_measured", vr::Z_M_MEASURED, "z_m from the arm's reported tool pose"),
    Variable::real("t_frame", vr::T_FRAME)
        .output()
        .unit("s")
        .depends_on(NONE)
        .description("time (the FMU's) at which the frame behind r1, r2 was taken"),
    Variable::real("late", vr::LATE)
        .output()
        .unit("s")
        .depends_on(NONE)
        .description("how late the last step ended (0: on time; > 0: the host is slower than real time)"),
    Variable::integer("late_steps", vr::LATE_STEPS)
        .output()
        .depends_on(NONE)
        .description("steps that ended late so far"),
    Variable::string("config_file", vr::CONFIG_FILE)
        .parameter()
        .start_string("")
        .description("rig config (TOML, as magswarm-bridge run reads it); empty: resources/rig.toml, the config this FMU was built with"),
    fixed("z_m_min", vr::Z_M_MIN, 0.0035, "lower z_m limit; may narrow the rig config's [limits], never widen it")
        .unit("m")
        .display_unit("mm"),
    fixed("z_m_max", vr::Z_M_MAX, 0.0235, "upper z_m limit; may narrow the rig config's [limits], never widen it")
        .unit("m")
        .display_unit("mm"),
    fixed("omega_m_min", vr::OMEGA_M_MIN, std::f64::consts::TAU, "lower omega_m limit; may narrow the rig config's [limits], never widen it")
        .unit("rad/s")
        .display_unit("Hz"),
    fixed("omega_m_max", vr::OMEGA_M_MAX, 10.0 * std::f64::consts::TAU, "upper omega_m limit; may narrow the rig config's [limits], never widen it")
        .unit("rad/s")
        .display_unit("Hz"),
    fixed("z_m_rate_max", vr::Z_M_RATE_MAX, 0.01, "z_m rate limit; may lower the rig config's, never raise it")
        .unit("m/s")
        .display_unit("mm/s"),
    fixed("omega_m_rate_max", vr::OMEGA_M_RATE_MAX, 2.0 * std::f64::consts::TAU, "omega_m rate limit; may lower the rig config's, never raise it")
        .unit("rad/s2")
        .display_unit("Hz/s"),
    fixed("z_tcp_at_zero", vr::Z_TCP_AT_ZERO, 0.4, "calibration, read-only: tool z (robot base frame) at z_m = 0 (robot.z_tcp_at_zero_m of the rig config)")
        .unit("m")
        .display_unit("mm"),
    fixed("pixel_size", vr::PIXEL_SIZE, 5e-5, "calibration, read-only: pixel size in the swarm's plane (camera.mm_per_px of the rig config)")
        .unit("m")
        .display_unit("mm"),
    fixed("velocity_per_hz", vr::VELOCITY_PER_HZ, 51200.0, "calibration, read-only: TMCL velocity units per magnet revolution per second (stepper.velocity_per_hz)")
        .unit("1"),
    fixed("max_late", vr::MAX_LATE, MAX_LATE_DEFAULT, "the host may be this late for a step before the rig stops (stepper stopped, robot held: fault host_stalled)")
        .unit("s"),
];

static INFO: ModelInfo = ModelInfo {
    model_identifier: MODEL_IDENTIFIER,
    model_name: "MagSwarmRig",
    description: "The magnetic swarm rig (UR arm moving the magnet along z, stepper spinning it, \
                  camera measuring the swarm) behind the interface of MagSwarm.fmu: doStep \
                  paces to the wall clock; every command passes the bridge's safety core",
    version: env!("CARGO_PKG_VERSION"),
    author: "magswarm",
    copyright: None,
    license: Some("MIT OR Apache-2.0"),
    generation_tool: concat!("magswarm-bridge ", env!("CARGO_PKG_VERSION")),
    naming_convention: magswarm_fmi2::NamingConvention::Flat,
    default_experiment: Some(DefaultExperiment {
        start_time: Some(0.0),
        stop_time: Some(10.0),
        tolerance: None,
        step_size: Some(0.05),
    }),
    units: UNITS,
    log_categories: LOG_CATEGORIES,
    variables: &VARIABLES,
};

/// The static model information (variable table, units).
pub fn model_info() -> &'static ModelInfo {
    &INFO
}

/// The start inputs of a config: `[control] start` if given, else 8.5 mm / 4 Hz, clamped to
/// the config's limits (z_m \[mm\], f \[Hz\]).
pub fn start_inputs(cfg: &RigConfig) -> (f64, f64) {
    let l = &cfg.limits;
    let s = cfg
        .control
        .start
        .unwrap_or([Z_START * 1e3, OMEGA_START * INV_TWO_PI]);
    (
        s[0].clamp(l.z_m_mm[0], l.z_m_mm[1]),
        s[1].clamp(l.f_hz[0], l.f_hz[1]),
    )
}

/// The start values that `cfg` gives the table (limits, calibration, start inputs).
pub fn start_values(cfg: &RigConfig) -> Vec<(u32, Start)> {
    let l = &cfg.limits;
    let tau = std::f64::consts::TAU;
    let (z0, f0) = start_inputs(cfg);
    vec![
        (vr::Z_M, Start::Real(z0 * 1e-3)),
        (vr::OMEGA_M, Start::Real(f0 * tau)),
        (vr::Z_M_MIN, Start::Real(l.z_m_mm[0] * 1e-3)),
        (vr::Z_M_MAX, Start::Real(l.z_m_mm[1] * 1e-3)),
        (vr::OMEGA_M_MIN, Start::Real(l.f_hz[0] * tau)),
        (vr::OMEGA_M_MAX, Start::Real(l.f_hz[1] * tau)),
        (vr::Z_M_RATE_MAX, Start::Real(l.z_rate_mm_s * 1e-3)),
        (vr::OMEGA_M_RATE_MAX, Start::Real(l.f_rate_hz_s * tau)),
        (vr::Z_TCP_AT_ZERO, Start::Real(cfg.robot.z_tcp_at_zero_m)),
        (vr::PIXEL_SIZE, Start::Real(cfg.camera.mm_per_px * 1e-3)),
        (
            vr::VELOCITY_PER_HZ,
            Start::Real(cfg.stepper.velocity_per_hz),
        ),
    ]
}

/// The modelDescription.xml of an FMU built for `cfg`: the parameters' start values are
/// the config's.
pub fn model_description(cfg: &RigConfig, generated_at: Option<String>) -> String {
    magswarm_fmi2::model_description_xml::<RigFmu>(&XmlOptions {
        generation_date_and_time: generated_at,
        start_overrides: start_values(cfg),
    })
}
