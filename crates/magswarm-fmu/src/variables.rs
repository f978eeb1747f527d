//! The variable table of `MagSwarm.fmu` (value references, parameters from the model's
//! registry, units, log categories) and the modelDescription.xml generated from it in either
//! FMI version: one source for the binary's behaviour and the XML.

use super::*;

/// Model identifier (file name of the shared library and of the FMU).
pub const MODEL_IDENTIFIER: &str = "MagSwarm";
/// Name of the model JSON inside the FMU's `resources/`.
pub const RESOURCE_MODEL: &str = "model.json";

/// Value references of the interface variables.
pub mod vr {
    /// Input: magnet-swarm distance \[m\].
    pub const Z_M: u32 = 1;
    /// Input: field angular velocity [rad/s].
    pub const OMEGA_M: u32 = 2;
    /// Output: radius r1 from ODE (4) \[m\].
    pub const R1: u32 = 10;
    /// Output: radius r2 from ODE (4) \[m\].
    pub const R2: u32 = 11;
    /// Output: steady map r1 \[m\].
    pub const R1_SS: u32 = 12;
    /// Output: steady map r2 \[m\].
    pub const R2_SS: u32 = 13;
    /// Output: stiffness S_x.
    pub const S_X: u32 = 14;
    /// Output: stiffness S_y.
    pub const S_Y: u32 = 15;
    /// Output: field magnitude \[T\].
    pub const B: u32 = 16;
    /// Output: axial gradient [T/m].
    pub const G_Z: u32 = 17;
    /// Output: curvature k_xx [T2/m2].
    pub const K_XX: u32 = 18;
    /// Output: curvature k_yy [T2/m2].
    pub const K_YY: u32 = 19;
    /// Output (Boolean): inputs inside the validated envelope.
    pub const IN_ENVELOPE: u32 = 20;
    /// Local: dr1/dt [m/s].
    pub const DER_R1: u32 = 30;
    /// Local: dr2/dt [m/s].
    pub const DER_R2: u32 = 31;
    /// Parameter (Boolean): start on the steady map of the initial inputs.
    pub const SETTLE_AT_START: u32 = 40;
    /// Parameter: initial r1 \[m\] when not settled.
    pub const R1_START: u32 = 41;
    /// Parameter: initial r2 \[m\] when not settled.
    pub const R2_START: u32 = 42;
    /// Parameter (Boolean): confinement gains scheduled so that (4)'s equilibrium is the map.
    pub const SCHEDULED: u32 = 43;
    /// Parameter (String): path of a model JSON replacing the defaults.
    pub const MODEL_FILE: u32 = 50;
    /// First value reference of the numeric model parameters (see [`super::PARAMS`]).
    pub const PARAM_BASE: u32 = 100;
    /// Local, continuous state: radius r1 of ODE (4) \[m\] (what `r1` observes).
    pub const R1_ODE: u32 = 60;
    /// Local, continuous state: radius r2 of ODE (4) \[m\].
    pub const R2_ODE: u32 = 61;
    /// Local, continuous state: slow formation mode x1 of `formation_lag` \[m\].
    pub const FORM_X1: u32 = 62;
    /// Local, continuous state: its rate dx1/dt [m/s].
    pub const FORM_V1: u32 = 63;
    /// Local, continuous state: slow formation mode x2 \[m\].
    pub const FORM_X2: u32 = 64;
    /// Local, continuous state: its rate dx2/dt [m/s].
    pub const FORM_V2: u32 = 65;
    /// Local: d(form_x1)/dt [m/s].
    pub const DER_FORM_X1: u32 = 72;
    /// Local: d(form_v1)/dt [m/s2].
    pub const DER_FORM_V1: u32 = 73;
    /// Local: d(form_x2)/dt [m/s].
    pub const DER_FORM_X2: u32 = 74;
    /// Local: d(form_v2)/dt [m/s2].
    pub const DER_FORM_V2: u32 = 75;
    /// The continuous states in Model Exchange order (the order of their derivative rows).
    pub const STATES: [u32; 6] = [R1_ODE, R2_ODE, FORM_X1, FORM_V1, FORM_X2, FORM_V2];
}

/// Default inputs: the seed's mid-envelope operating point (z_m 8.5 mm, f 4 Hz).
pub const Z_START: f64 = 0.0085;
/// Largest `z_m` accepted \[m\]: far beyond the envelope (23.5 mm) the field is numerically
/// zero and the model's outputs stop being numbers.
pub const MAX_Z_M: f64 = 1.0;
/// Largest `|omega_m|` accepted [rad/s] (about 1.6 kHz; the envelope ends at 10 Hz).
pub const MAX_OMEGA: f64 = 1e4;
/// Default field angular velocity [rad/s] (4 Hz).
pub const OMEGA_START: f64 = 4.0 * std::f64::consts::TAU;

/// A numeric model parameter exposed as an FMI parameter: a row of the model's parameter
/// registry ([`magswarm_model::registry`]), which is the one list of parameters.
pub use magswarm_model::registry::Param as ParamSpec;

/// Numeric parameters in value-reference order (vr = PARAM_BASE + index): the registry's rows
/// marked for the FMU. A parameter added to the registry appears here by itself.
/// (Freed when the library is unloaded, like the variable table.)
pub static PARAMS: LazyLock<&'static [&'static ParamSpec]> =
    LazyLock::new(|| magswarm_fmi::unload::leak(magswarm_model::registry::fmu_params().collect()));

/// Unit definitions used by the table.
static UNITS: &[UnitDefinition] = &[
    units::METRE,
    units::RAD_PER_SECOND,
    units::TESLA,
    units::TESLA_PER_METRE,
    units::TESLA2_PER_METRE2,
    units::ONE,
    units::MILLIMETRE,
    units::HERTZ,
    units::PER_SECOND,
    units::METRE_PER_SECOND,
    units::METRE_PER_SECOND2,
    units::SECOND,
];

static LOG_CATEGORIES: &[LogCategory] = &[
    LogCategory {
        name: "logEnvelope",
        description: "inputs leaving or re-entering the validated envelope",
    },
    LogCategory {
        name: "logModel",
        description: "model loading (resources/model.json, model_file)",
    },
];

const INPUTS: &[u32] = &[vr::Z_M, vr::OMEGA_M];
const Z_ONLY: &[u32] = &[vr::Z_M];
// r1, r2 observe the continuous states (ODE (4) and the formation mode): no direct
// feedthrough from the inputs, which is what lets a controller close the loop without an
// algebraic loop.
const R1_DEP: &[u32] = &[vr::R1_ODE, vr::FORM_X1];
const R2_DEP: &[u32] = &[vr::R2_ODE, vr::FORM_X2];
const DER_DEP: &[u32] = &[vr::Z_M, vr::OMEGA_M, vr::R1_ODE, vr::R2_ODE];
const DER_X1_DEP: &[u32] = &[vr::FORM_V1];
const DER_V1_DEP: &[u32] = &[vr::Z_M, vr::OMEGA_M, vr::FORM_X1, vr::FORM_V1];
const DER_X2_DEP: &[u32] = &[vr::FORM_V2];
const DER_V2_DEP: &[u32] = &[vr::Z_M, vr::OMEGA_M, vr::FORM_X2, vr::FORM_V2];

fn build_variables() -> Vec<Variable> {
    let paper = Model::paper();
    let mut v = vec![
        Variable::real("z_m", vr::Z_M)
            .input()
            .start_real(Z_START)
            .unit("m")
            .display_unit("mm")
            .nominal(0.01)
            .description("magnet-swarm distance (validated 3.5-23.5 mm)"),
        Variable::real("omega_m", vr::OMEGA_M)
            .input()
            .start_real(OMEGA_START)
            .unit("rad/s")
            .display_unit("Hz")
            .nominal(30.0)
            .description("field angular velocity 2 pi f_m (validated 1-10 Hz)"),
        Variable::real("r1", vr::R1)
            .output()
            .unit("m")
            .display_unit("mm")
            .nominal(0.01)
            .depends_on(R1_DEP)
            .description("principal radius r1 from ODE (4)"),
        Variable::real("r2", vr::R2)
            .output()
            .unit("m")
            .display_unit("mm")
            .nominal(0.01)
            .depends_on(R2_DEP)
            .description("principal radius r2 from ODE (4)"),
        Variable::real("r1_ss", vr::R1_SS)
            .output()
            .unit("m")
            .display_unit("mm")
            .nominal(0.01)
            .depends_on(INPUTS)
            .description("steady-state map (5) r1 at the current inputs"),
        Variable::real("r2_ss", vr::R2_SS)
            .output()
            .unit("m")
            .display_unit("mm")
            .nominal(0.01)
            .depends_on(INPUTS)
            .description("steady-state map (5) r2 at the current inputs"),
        Variable::real("S_x", vr::S_X)
            .output()
            .unit("1")
            .depends_on(INPUTS)
            .description("anisotropic stiffness S_x (7), floored positive"),
        Variable::real("S_y", vr::S_Y)
            .output()
            .unit("1")
            .depends_on(INPUTS)
            .description("anisotropic stiffness S_y (7), floored positive"),
        Variable::real("B", vr::B)
            .output()
            .unit("T")
            .display_unit("mT")
            .depends_on(Z_ONLY)
            .description("field magnitude at the swarm (RMS over one turn)"),
        Variable::real("g_z", vr::G_Z)
            .output()
            .unit("T/m")
            .depends_on(Z_ONLY)
            .description("axial gradient |d|B|/dz| at the swarm"),
        Variable::real("k_xx", vr::K_XX)
            .output()
            .unit("T2/m2")
            .depends_on(Z_ONLY)
            .description("curvature d2<B^2>/dx2 at the swarm (tangential)"),
        Variable::real("k_yy", vr::K_YY)
            .output()
            .unit("T2/m2")
            .depends_on(Z_ONLY)
            .description("curvature d2<B^2>/dy2 at the swarm (radial)"),
        Variable::boolean("in_envelope", vr::IN_ENVELOPE)
            .output()
            .depends_on(INPUTS)
            .description("true while the inputs are inside the validated envelope"),
        Variable::real("der_r1", vr::DER_R1)
            .local()
            .unit("m/s")
            .derivative_of(vr::R1_ODE)
            .depends_on(DER_DEP)
            .description("dr1/dt of ODE (4)"),
        Variable::real("der_r2", vr::DER_R2)
            .local()
            .unit("m/s")
            .derivative_of(vr::R2_ODE)
            .depends_on(DER_DEP)
            .description("dr2/dt of ODE (4)"),
        Variable::boolean("settle_at_start", vr::SETTLE_AT_START)
            .parameter()
            .start_boolean(true)
            .description("start formed: r1, r2 on the steady map of the initial inputs"),
        Variable::real("r1_start", vr::R1_START)
            .parameter()
            .start_real(0.005)
            .unit("m")
            .display_unit("mm")
            .description("initial r1 when settle_at_start is false"),
        Variable::real("r2_start", vr::R2_START)
            .parameter()
            .start_real(0.005)
            .unit("m")
            .display_unit("mm")
            .description("initial r2 when settle_at_start is false"),
        Variable::boolean("scheduled_confinement", vr::SCHEDULED)
            .parameter()
            .start_boolean(paper.dynamics.confinement == Confinement::Scheduled)
            .description("schedule K_b1, K_b2 on the inputs so the equilibrium of (4) is the map"),
        Variable::string("model_file", vr::MODEL_FILE)
            .parameter()
            .start_string("")
            .description("path of a model JSON (magswarm-model/2, or /1) replacing the defaults; empty: resources/model.json"),
    ];
    for (i, p) in PARAMS.iter().enumerate() {
        let mut var = Variable::real(p.name, vr::PARAM_BASE + i as u32)
            .parameter()
            .start_real((p.get)(&paper))
            .description(p.description);
        if let Some(u) = p.unit {
            var = var.unit(u);
        }
        v.push(var);
    }
    v.extend(state_variables());
    v
}

/// The continuous states Model Exchange integrates and their derivatives, appended after
/// the parameters (new value references, so every earlier variable keeps its index): the
/// radii of ODE (4), which `r1`, `r2` observe, and the slow formation mode of the
/// `formation_lag` effect (constant when the effect is off).
fn state_variables() -> Vec<Variable> {
    let mm = |v: Variable| v.unit("m").display_unit("mm").nominal(0.01);
    vec![
        mm(Variable::real("r1_ode", vr::R1_ODE).local())
            .description("radius r1 of ODE (4), the continuous state r1 observes"),
        mm(Variable::real("r2_ode", vr::R2_ODE).local())
            .description("radius r2 of ODE (4), the continuous state r2 observes"),
        mm(Variable::real("form_x1", vr::FORM_X1).local())
            .description("slow formation mode of the formation_lag effect, axis 1"),
        Variable::real("form_v1", vr::FORM_V1)
            .local()
            .unit("m/s")
            .description("rate of the slow formation mode, axis 1"),
        mm(Variable::real("form_x2", vr::FORM_X2).local())
            .description("slow formation mode of the formation_lag effect, axis 2"),
        Variable::real("form_v2", vr::FORM_V2)
            .local()
            .unit("m/s")
            .description("rate of the slow formation mode, axis 2"),
        Variable::real("der_form_x1", vr::DER_FORM_X1)
            .local()
            .unit("m/s")
            .derivative_of(vr::FORM_X1)
            .depends_on(DER_X1_DEP)
            .description("d(form_x1)/dt"),
        Variable::real("der_form_v1", vr::DER_FORM_V1)
            .local()
            .unit("m/s2")
            .derivative_of(vr::FORM_V1)
            .depends_on(DER_V1_DEP)
            .description("d(form_v1)/dt (zero without formation_lag)"),
        Variable::real("der_form_x2", vr::DER_FORM_X2)
            .local()
            .unit("m/s")
            .derivative_of(vr::FORM_X2)
            .depends_on(DER_X2_DEP)
            .description("d(form_x2)/dt"),
        Variable::real("der_form_v2", vr::DER_FORM_V2)
            .local()
            .unit("m/s2")
            .derivative_of(vr::FORM_V2)
            .depends_on(DER_V2_DEP)
            .description("d(form_v2)/dt (zero without formation_lag)"),
    ]
}

pub(crate) static INFO: LazyLock<ModelInfo> = LazyLock::new(|| ModelInfo {
    model_identifier: MODEL_IDENTIFIER,
    model_name: "MagSwarm",
    description: "Reduced-order model of a magnetic microparticle swarm under a rotating \
                  spherical magnet: ellipse radii r1, r2 from magnet distance z_m and field \
                  angular velocity omega_m (steady map (5)-(7) and ODE (4) of the seed paper)",
    version: env!("CARGO_PKG_VERSION"),
    author: "magswarm",
    copyright: None,
    license: Some("MIT OR Apache-2.0"),
    generation_tool: concat!("magswarm ", env!("CARGO_PKG_VERSION")),
    naming_convention: Default::default(),
    default_experiment: Some(DefaultExperiment {
        start_time: Some(0.0),
        stop_time: Some(60.0),
        tolerance: Some(1e-8),
        step_size: Some(0.01),
    }),
    units: UNITS,
    log_categories: LOG_CATEGORIES,
    variables: magswarm_fmi::unload::leak(build_variables()),
});

/// The FMI 2.0 modelDescription.xml for an FMU whose default model is `baked`: the
/// parameter start values are the baked model's, everything else comes from the static
/// table.
pub fn model_description(baked: &Model, generated_at: Option<String>) -> String {
    model_description_for(baked, generated_at, FmiVersion::V2)
}

/// [`model_description`] in FMI `version`.
pub fn model_description_for(
    baked: &Model,
    generated_at: Option<String>,
    version: FmiVersion,
) -> String {
    let mut overrides: Vec<(u32, Start)> = PARAMS
        .iter()
        .enumerate()
        .map(|(i, p)| (vr::PARAM_BASE + i as u32, Start::Real((p.get)(baked))))
        .collect();
    overrides.push((
        vr::SCHEDULED,
        Start::Boolean(baked.dynamics.confinement == Confinement::Scheduled),
    ));
    let options = XmlOptions {
        generation_date_and_time: generated_at,
        start_overrides: overrides,
    };
    magswarm_fmi::model_description_xml::<MagSwarm>(version, &options)
}

/// The static model information (variable table, units), for docs and packaging.
pub fn model_info() -> &'static ModelInfo {
    &INFO
}
