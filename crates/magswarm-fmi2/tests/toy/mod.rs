//! A small model for the shell's tests: a first-order lag `y' = (k u - y) / tau`, stepped
//! exactly, with every variable type, a String parameter, a tunable parameter, an
//! envelope warning on `u`, and switches that make hooks panic.

#![allow(dead_code)]

use magswarm_fmi_core::units;
use magswarm_fmi_core::{
    Ctx, DefaultExperiment, FmuModel, InstantiateArgs, LogCategory, ModelError, ModelInfo,
    NamingConvention, VarType, Variable,
};

pub const U: u32 = 0;
pub const Y: u32 = 1;
pub const DER_Y: u32 = 2;
pub const TAU: u32 = 3;
pub const Y0: u32 = 4;
pub const LABEL: u32 = 5;
pub const K: u32 = 6;
pub const N_STEPS: u32 = 7;
pub const SATURATED: u32 = 8;
pub const PANIC_NOW: u32 = 9;
pub const TIME: u32 = 10;
pub const OMEGA: u32 = 11;

pub static VARIABLES: [Variable; 12] = [
    Variable::real("time", TIME)
        .independent()
        .unit("s")
        .description("simulation time"),
    Variable::real("u", U)
        .input()
        .start_real(0.0)
        .unit("m")
        .display_unit("mm")
        .description("input (valid in [-5, 5])"),
    Variable::real("y", Y)
        .output()
        .unit("m")
        .display_unit("mm")
        .description("lag output (state)")
        .depends_on(&[Y])
        .initially_depends_on(&[Y0]),
    Variable::real("der_y", DER_Y)
        .local()
        .derivative_of(Y)
        .unit("m")
        .description("dy/dt")
        .depends_on(&[U, Y])
        .initially_depends_on(&[U, TAU, Y0, K]),
    Variable::real("tau", TAU)
        .parameter()
        .start_real(0.5)
        .unit("s")
        .range(1e-6, 1e6)
        .description("time constant"),
    Variable::real("y0", Y0)
        .parameter()
        .start_real(0.0)
        .unit("m")
        .description("initial output"),
    Variable::string("label", LABEL)
        .parameter()
        .start_string("lag & <friends> \"quoted\"")
        .description("a String parameter"),
    Variable::real("k", K)
        .tunable_parameter()
        .start_real(1.0)
        .unit("1")
        .description("gain, tunable"),
    Variable::integer("n_steps", N_STEPS)
        .output()
        .depends_on(&[])
        .description("number of steps taken"),
    Variable::boolean("saturated", SATURATED)
        .output()
        .depends_on(&[Y])
        .description("|y| > 10"),
    Variable::boolean("panic_now", PANIC_NOW)
        .input()
        .start_boolean(false)
        .description("makes the next step panic"),
    Variable::real("omega", OMEGA)
        .parameter()
        .start_real(std::f64::consts::TAU)
        .unit("rad/s")
        .display_unit("Hz"),
];

pub static INFO: ModelInfo = ModelInfo {
    model_identifier: "Lag",
    model_name: "Lag",
    description: "first-order lag for the shell's tests",
    version: "1.2.3",
    author: "magswarm",
    copyright: None,
    license: Some("MIT OR Apache-2.0"),
    generation_tool: "magswarm-fmi2 tests",
    naming_convention: NamingConvention::Flat,
    default_experiment: Some(DefaultExperiment {
        start_time: Some(0.0),
        stop_time: Some(5.0),
        tolerance: Some(1e-6),
        step_size: Some(0.01),
    }),
    units: &[
        units::METRE,
        units::SECOND,
        units::ONE,
        units::RAD_PER_SECOND,
    ],
    log_categories: &[LogCategory {
        name: "logLag",
        description: "lag internals",
    }],
    variables: &VARIABLES,
};

#[derive(Clone, Debug, PartialEq)]
pub struct Lag {
    pub u: f64,
    pub y: f64,
    pub tau: f64,
    pub y0: f64,
    pub k: f64,
    pub omega: f64,
    pub label: String,
    pub n_steps: i32,
    pub t: f64,
    pub outside: bool,
    pub panic_now: bool,
    /// Counts live copies (instances and FMU states) per instance name.
    pub probe: Probe,
}

/// Live copies of the model per instance name: clones (FMU states) count too, so a test can
/// see that freeing an instance frees its states.
pub static LIVE: std::sync::Mutex<Vec<(String, i64)>> = std::sync::Mutex::new(Vec::new());

fn live_add(name: &str, d: i64) {
    let mut v = LIVE.lock().unwrap_or_else(|e| e.into_inner());
    match v.iter_mut().find(|(n, _)| n == name) {
        Some((_, k)) => *k += d,
        None => v.push((name.to_string(), d)),
    }
}

/// Live copies of the instance called `name`.
pub fn live(name: &str) -> i64 {
    let v = LIVE.lock().unwrap_or_else(|e| e.into_inner());
    v.iter().find(|(n, _)| n == name).map_or(0, |(_, k)| *k)
}

/// The lag's dynamic state (what `fmi2SerializeFMUstate` saves).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LagState {
    pub u: f64,
    pub y: f64,
    pub tau: f64,
    pub y0: f64,
    pub k: f64,
    pub omega: f64,
    pub t: f64,
    pub label: String,
    pub n_steps: i32,
    pub outside: bool,
    pub panic_now: bool,
}

#[derive(Debug, PartialEq)]
pub struct Probe(pub String);

impl Probe {
    pub fn new(name: &str) -> Probe {
        live_add(name, 1);
        Probe(name.to_string())
    }
}

impl Clone for Probe {
    fn clone(&self) -> Probe {
        Probe::new(&self.0)
    }
}

impl Drop for Probe {
    fn drop(&mut self) {
        live_add(&self.0, -1);
    }
}

impl Lag {
    fn der(&self) -> f64 {
        (self.k * self.u - self.y) / self.tau
    }
}

impl FmuModel for Lag {
    fn model_info() -> &'static ModelInfo {
        &INFO
    }

    fn instantiate(ctx: &mut Ctx<'_>, args: &InstantiateArgs<'_>) -> Result<Self, ModelError> {
        if args.instance_name == "panic-in-constructor" {
            panic!("constructor asked to panic");
        }
        if args.instance_name == "fail-in-constructor" {
            return Err(ModelError::error("constructor asked to fail"));
        }
        ctx.debug("logLag", format!("resources at {:?}", args.resource_dir));
        Ok(Lag {
            u: 0.0,
            y: 0.0,
            tau: 0.5,
            y0: 0.0,
            k: 1.0,
            omega: std::f64::consts::TAU,
            label: "lag & <friends> \"quoted\"".into(),
            n_steps: 0,
            t: 0.0,
            outside: false,
            panic_now: false,
            probe: Probe::new(args.instance_name),
        })
    }

    fn setup_experiment(
        &mut self,
        _ctx: &mut Ctx<'_>,
        _tol: Option<f64>,
        start: f64,
        _stop: Option<f64>,
    ) -> Result<(), ModelError> {
        self.t = start;
        Ok(())
    }

    fn exit_initialization_mode(&mut self, _ctx: &mut Ctx<'_>) -> Result<(), ModelError> {
        self.y = self.y0;
        Ok(())
    }

    fn step(&mut self, _ctx: &mut Ctx<'_>, t: f64, h: f64) -> Result<(), ModelError> {
        if self.panic_now {
            panic!("do_step asked to panic at t = {t}");
        }
        let yss = self.k * self.u;
        self.y = yss + (self.y - yss) * (-h / self.tau).exp();
        self.t = t + h;
        self.n_steps += 1;
        Ok(())
    }

    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        Ok(match vr {
            U => self.u,
            Y => self.y,
            DER_Y => self.der(),
            TAU => self.tau,
            Y0 => self.y0,
            K => self.k,
            TIME => self.t,
            OMEGA => self.omega,
            _ => return Err(ModelError::unknown_vr(VarType::Real, vr)),
        })
    }

    fn set_real(&mut self, ctx: &mut Ctx<'_>, vr: u32, x: f64) -> Result<(), ModelError> {
        match vr {
            U => {
                let outside = !(-5.0..=5.0).contains(&x);
                if outside && !self.outside {
                    ctx.warning(format!("u = {x} is outside the validated envelope [-5, 5]"));
                }
                self.outside = outside;
                self.u = x;
            }
            TAU => {
                if x <= 0.0 {
                    return Err(ModelError::error(format!("tau must be > 0, got {x}")));
                }
                self.tau = x
            }
            Y0 => self.y0 = x,
            K => self.k = x,
            OMEGA => self.omega = x,
            _ => return Err(ModelError::unknown_vr(VarType::Real, vr)),
        }
        Ok(())
    }

    fn get_integer(&mut self, vr: u32) -> Result<i32, ModelError> {
        match vr {
            N_STEPS => Ok(self.n_steps),
            _ => Err(ModelError::unknown_vr(VarType::Integer, vr)),
        }
    }

    fn get_boolean(&mut self, vr: u32) -> Result<bool, ModelError> {
        match vr {
            SATURATED => Ok(self.y.abs() > 10.0),
            PANIC_NOW => Ok(self.panic_now),
            _ => Err(ModelError::unknown_vr(VarType::Boolean, vr)),
        }
    }

    fn set_boolean(&mut self, _ctx: &mut Ctx<'_>, vr: u32, v: bool) -> Result<(), ModelError> {
        match vr {
            PANIC_NOW => {
                self.panic_now = v;
                Ok(())
            }
            _ => Err(ModelError::unknown_vr(VarType::Boolean, vr)),
        }
    }

    fn get_string(&mut self, vr: u32) -> Result<String, ModelError> {
        match vr {
            LABEL => Ok(self.label.clone()),
            _ => Err(ModelError::unknown_vr(VarType::String, vr)),
        }
    }

    fn set_string(&mut self, _ctx: &mut Ctx<'_>, vr: u32, v: &str) -> Result<(), ModelError> {
        match vr {
            LABEL => {
                if v == "panic" {
                    panic!("set_string asked to panic");
                }
                self.label = v.to_string();
                Ok(())
            }
            _ => Err(ModelError::unknown_vr(VarType::String, vr)),
        }
    }

    type State = LagState;

    fn save_state(&self) -> Result<LagState, ModelError> {
        Ok(LagState {
            u: self.u,
            y: self.y,
            tau: self.tau,
            y0: self.y0,
            k: self.k,
            omega: self.omega,
            t: self.t,
            label: self.label.clone(),
            n_steps: self.n_steps,
            outside: self.outside,
            panic_now: self.panic_now,
        })
    }

    fn restore_state(&mut self, s: LagState) -> Result<(), ModelError> {
        if !(s.tau > 0.0 && s.tau.is_finite()) {
            return Err(ModelError::error(format!(
                "tau = {} must be positive",
                s.tau
            )));
        }
        [
            self.u, self.y, self.tau, self.y0, self.k, self.omega, self.t,
        ] = [s.u, s.y, s.tau, s.y0, s.k, s.omega, s.t];
        self.label = s.label;
        self.n_steps = s.n_steps;
        self.outside = s.outside;
        self.panic_now = s.panic_now;
        Ok(())
    }

    fn jacobian(&mut self, unknowns: &[u32], knowns: &[u32]) -> Result<Vec<f64>, ModelError> {
        let partial = |u: u32, k: u32| -> Result<f64, ModelError> {
            Ok(match (u, k) {
                (DER_Y, U) => self.k / self.tau,
                (DER_Y, Y) => -1.0 / self.tau,
                (Y, Y) => 1.0,
                (Y, U) => 0.0,
                _ => {
                    return Err(ModelError::error(format!(
                        "no partial derivative of vr {u} w.r.t. vr {k}"
                    )))
                }
            })
        };
        unknowns
            .iter()
            .flat_map(|&u| knowns.iter().map(move |&k| (u, k)))
            .map(|(u, k)| partial(u, k))
            .collect()
    }
}
