//! `MagSwarmPID.fmu`: the decoupled 2x2 PID of `magswarm-control` behind the generic FMI 2.0
//! Co-Simulation shell of `magswarm-fmi2`, so that the closed loop (plant FMU + controller FMU) runs in any
//! co-simulation master (fmpy, libcosim, an SSP or OSP system file wiring it to `MagSwarm.fmu`).
//!
//! This crate only maps FMI variables onto [`magswarm_control::Controller`]; the controller
//! (feedforward from the inverse steady map, a model-predicted reference, decoupling, anti-windup,
//! saturation and rate limits) is the library's, unchanged, so this FMU, the Rust harness
//! (`examples/pid_tracking.rs`, controller in-process) and the fmpy script
//! (`examples/pid_tracking.py`, this FMU) compute the same commands.
//!
//! Layout: the variable table and the XML generated from it are in `variables`, the state
//! type in `state`, reading configuration files in `config`, the C symbols in `ffi`, the unit
//! tests in `tests`; this file is the instance (its fields, how it is built, and the calls of
//! `FmuModel` that map variables onto the controller).
//!
//! # Interface (SI, display units for people)
//!
//! | name | causality | unit | meaning |
//! | --- | --- | --- | --- |
//! | `r1_ref`, `r2_ref` | input | m (mm) | setpoints r1*, r2* |
//! | `r1`, `r2` | input | m (mm) | measured radii (connect to the plant's `r1`, `r2`) |
//! | `z_m` | output | m (mm) | commanded magnet-swarm distance (connect to the plant's `z_m`) |
//! | `omega_m` | output | rad/s (Hz) | commanded field angular velocity (to the plant's `omega_m`) |
//! | `target_feasible` | output, Boolean | | the setpoint is reachable (distance <= `feasible_tol`) |
//! | `r1_goal`, `r2_goal` | output | m (mm) | the nearest reachable radii the loop settles on |
//! | `target_distance` | output | m (mm) | distance from the setpoint to the reachable goal |
//! | `r1_reference`, `r2_reference` | output | m (mm) | the reference the PID tracked at the last sample (model prediction) |
//! | `z_m_ff`, `omega_m_ff` | output | m, rad/s | feedforward (rate-limited ramp to the inverse map) |
//! | `saturated`, `rate_limited` | output, Boolean | | the last command was clipped by the envelope / a rate limit |
//! | `samples` | output, Integer | | controller samples taken |
//!
//! Parameters ([`PARAMS`]; the `PidConfig` JSON field each one maps to in brackets):
//! `sample_time` \[s\] (`sample_time_s`); gains, tunable while stepping (bumpless, through
//! `Controller::set_gains`): `kp_r1`, `kp_r2` \[1\] (`gains.kp`), `ki_r1`, `ki_r2` [1/s]
//! (`gains.ki`), `kd_r1`, `kd_r2` \[s\] (`gains.kd`), `derivative_filter` \[s\]
//! (`gains.derivative_filter_s`), `tracking_time` \[s\] (`gains.tracking_time_s`), Boolean
//! `conditional_integration`; limits: `z_min`, `z_max` \[m\], `f_min`, `f_max` \[Hz\],
//! `z_rate` [m/s], `f_rate` [Hz/s] (`limits.*`); Boolean `feedforward`, `reference_filter` \[s\],
//! `decoupler_damping` \[1\], `feasible_tol` \[m\]; the bumpless start `z_start` \[m\],
//! `omega_start` [rad/s] (the inputs in force when the loop closes, i.e. the plant's initial
//! inputs); String `model_file` (a `magswarm-model/1` JSON: the plant the controller assumes;
//! empty: `resources/model.json`, else the built-in paper model) and String `config_file`
//! (a `magswarm-pid/1` JSON; empty: `resources/pid.json`, else the library's defaults).
//!
//! Precedence: the configuration is `config_file`'s (or the FMU's default); every numeric or
//! Boolean parameter that is set to a value *other than its start value* overrides the
//! corresponding field, whatever the order of the calls. (Setting a parameter to its start value
//! is therefore a no-op before initialisation: importers that write every start value do not
//! erase `config_file`.) The configuration is validated at `fmi2ExitInitializationMode`.
//!
//! # Timing
//!
//! The controller is discrete: it samples at `t_k = t_start + k * sample_time` (t_start from
//! `fmi2SetupExperiment`). `fmi2DoStep(t, h)` takes every sample with `t_k` in `[t, t + h)`:
//! each uses the inputs set before that `doStep` (the master holds them over the step), and the
//! outputs after the `doStep` are the command of the last sample taken, held until the next. So
//! with `h = sample_time` (the intended use) each `doStep(t_k, h)` computes the command for
//! `[t_k, t_k + h)` from the measurement at `t_k`: a sequential master (read plant, set controller
//! inputs, step controller, read command, set plant inputs, step plant) has no extra delay, a
//! Jacobi master (libcosim) one sample. With `h` a multiple `n * sample_time` each doStep takes
//! `n` samples of the same (held) measurement. With `h` not a multiple, samples fall inside
//! communication steps: they still happen at `t_k`, with the inputs of the communication point
//! before it, and their command becomes visible at the next communication point (a delay of up
//! to `h`); steps shorter than `sample_time` hold the outputs. Times within `1e-6 * sample_time`
//! of a sample instant count as that instant.
//!
//! At the first sample the controller starts bumplessly (`Controller::reset`) from
//! `(z_start, omega_start)` and the first measurement. Before it, the outputs are
//! `(z_start, omega_start)` and the goal outputs are the inverse map of the initial setpoint.
//!
//! # FMU state
//!
//! The serialized FMU state is [`MagSwarmPidState`]: the controller's configuration, model and
//! the controller's state as data (`Controller::snapshot`: fixed size, whatever the run's
//! length), which the generic shell encodes and checks; restoring rebuilds the controller and
//! restores that state, bit-identically. In-memory states (`fmi2GetFMUstate`) are plain clones.

// The fmi2*/fmi3* forwarders that `export_fmu!` expands here are unsafe fns: every unsafe call
// in them has its own block and SAFETY comment.
#![deny(unsafe_op_in_unsafe_fn)]

use std::path::Path;
use std::sync::LazyLock;

use magswarm_control::{inverse_with, Controller, ControllerSnapshot, InverseOptions, PidConfig};
use magswarm_fmi::units;
use magswarm_fmi::{
    Ctx, DefaultExperiment, FmuModel, InstantiateArgs, LogCategory, ModelError, ModelInfo, Start,
    UnitDefinition, VarType, Variable,
};
use magswarm_model::Model;
use serde::{Deserialize, Serialize};

use config::{first_absurd_number, load_config};

mod config;
mod state;
#[cfg(test)]
mod tests;
// The C symbols live in their own module (their own codegen unit), so that linking this
// crate as an rlib next to another FMU crate never pulls them in.
#[cfg(feature = "export")]
mod ffi;
mod variables;

pub use state::{MagSwarmPidState, RunningState};
pub use variables::*;

/// One FMU instance.
#[derive(Debug, Clone)]
pub struct MagSwarmPid {
    default_model: Model,
    default_cfg: PidConfig,
    model: Model,
    model_file: String,
    base_cfg: PidConfig,
    config_file: String,
    /// Numeric parameters set to other values than their start: (index into PARAMS, value).
    overrides: Vec<(usize, f64)>,
    feedforward: Option<bool>,
    conditional_integration: Option<bool>,
    z_start: f64,
    omega_start: f64,
    /// Inputs [m].
    r_ref: [f64; 2],
    y: [f64; 2],
    /// Start time of the experiment (sample 0).
    t0: f64,
    /// The configuration and model the controller was built with.
    cfg_init: Option<PidConfig>,
    ctrl: Option<Controller>,
    /// Samples taken.
    k: u64,
    /// Outputs.
    u: [f64; 2],
    goal: [f64; 2],
    distance: f64,
    feasible: bool,
    /// Setpoint the goal outputs belong to (mm).
    goal_for: [f64; 2],
}

impl MagSwarmPid {
    /// A fresh instance; defaults from `resource_dir/model.json` and `resource_dir/pid.json`
    /// when present.
    pub fn new(resource_dir: Option<&Path>) -> Result<MagSwarmPid, ModelError> {
        Self::with_resources(resource_dir, None)
    }

    /// As [`MagSwarmPid::new`], knowing the `resources/` folder this FMU was packaged with:
    /// a packaged `model.json` or `pid.json` that the importer's resource location lacks is
    /// an error naming both folders (the defaults would silently be the wrong ones).
    pub fn with_resources(
        resource_dir: Option<&Path>,
        packaged: Option<&Path>,
    ) -> Result<MagSwarmPid, ModelError> {
        let resource = |name| magswarm_fmi::uri::packaged_resource(resource_dir, packaged, name);
        let (model_json, config_json) = (resource(RESOURCE_MODEL)?, resource(RESOURCE_CONFIG)?);
        let default_model = match model_json {
            Some(p) => Model::load(&p).map_err(|e| ModelError::error(format!("resources: {e}")))?,
            None => Model::paper(),
        };
        let default_cfg = match config_json {
            Some(p) => load_config(&p)?,
            None => PidConfig::default(),
        };
        Ok(MagSwarmPid {
            model: default_model.clone(),
            default_model,
            base_cfg: default_cfg.clone(),
            default_cfg,
            model_file: String::new(),
            config_file: String::new(),
            overrides: Vec::new(),
            feedforward: None,
            conditional_integration: None,
            z_start: Z_START,
            omega_start: OMEGA_START,
            r_ref: R_REF_START,
            y: R_START,
            t0: 0.0,
            cfg_init: None,
            ctrl: None,
            k: 0,
            u: [Z_START, OMEGA_START],
            goal: R_REF_START,
            distance: 0.0,
            feasible: true,
            goal_for: [f64::NAN; 2],
        })
    }

    /// The configuration in force: `config_file` (or the default) plus the overrides.
    pub fn effective_config(&self) -> PidConfig {
        let mut c = self.base_cfg.clone();
        for &(i, v) in &self.overrides {
            (PARAMS[i].set)(&mut c, v);
        }
        if let Some(b) = self.feedforward {
            c.feedforward = b;
        }
        if let Some(b) = self.conditional_integration {
            c.gains.conditional_integration = b;
        }
        c
    }

    /// The model the controller assumes.
    pub fn model(&self) -> &Model {
        &self.model
    }

    fn set_override(&mut self, i: usize, v: f64) {
        self.overrides.retain(|(j, _)| *j != i);
        self.overrides.push((i, v));
    }

    fn setpoint_mm(&self) -> [f64; 2] {
        [self.r_ref[0] * 1e3, self.r_ref[1] * 1e3]
    }

    /// Goal outputs for the current setpoint before the first sample (the controller's own
    /// inverse with the same options once it runs).
    fn update_goal_before_start(&mut self) {
        let sp = self.setpoint_mm();
        if sp == self.goal_for {
            return;
        }
        let cfg = self.effective_config();
        let opt = InverseOptions {
            bounds: Some(cfg.limits.envelope()),
            ..InverseOptions::default()
        };
        let inv = inverse_with(&self.model, sp[0], sp[1], &opt);
        self.goal = [inv.r1 * 1e-3, inv.r2 * 1e-3];
        self.distance = inv.distance_mm * 1e-3;
        self.feasible = inv.distance_mm <= cfg.feasible_tol_mm;
        self.goal_for = sp;
    }

    /// One controller sample with the inputs in force.
    fn sample(&mut self, ctx: &mut Ctx<'_>) -> Result<(), ModelError> {
        let y = [self.y[0] * 1e3, self.y[1] * 1e3];
        let sp = self.setpoint_mm();
        for (name, v) in [
            ("r1", y[0]),
            ("r2", y[1]),
            ("r1_ref", sp[0]),
            ("r2_ref", sp[1]),
        ] {
            if v <= 0.0 {
                return Err(ModelError::error(format!(
                    "{name} = {v} mm at sample {}: radii must be positive",
                    self.k
                )));
            }
        }
        let new_setpoint = self.k == 0 || sp != self.goal_for;
        let before = (self.u, self.goal, self.distance);
        self.apply(y, sp);
        if !(self.u.iter().chain(&self.goal).all(|x| x.is_finite()) && self.distance.is_finite()) {
            (self.u, self.goal, self.distance) = before;
            return Err(ModelError::error(format!(
                "the controller produced a non-finite command at sample {} from r1 = {} mm, \
                 r2 = {} mm, r1_ref = {} mm, r2_ref = {} mm; outputs keep their last values",
                self.k - 1,
                y[0],
                y[1],
                sp[0],
                sp[1]
            )));
        }
        if new_setpoint {
            let ctrl = self.ctrl.as_ref().expect("sampled after initialisation");
            ctx.debug(
                "logSetpoint",
                format!(
                    "t = {:.3} s: {}",
                    self.t0 + self.k as f64 * ctrl.sample_time(),
                    ctrl.status_message()
                ),
            );
        }
        Ok(())
    }

    /// One controller sample: measurement `y` and setpoint `sp` [mm]; updates the outputs.
    fn apply(&mut self, y: [f64; 2], sp: [f64; 2]) {
        let ctrl = self
            .ctrl
            .as_mut()
            .expect("controller built at initialisation");
        if self.k == 0 {
            ctrl.reset(self.z_start, self.omega_start, y);
        }
        let (z, w) = ctrl.step(y, sp);
        self.u = [z, w];
        if let Some(s) = ctrl.setpoint_status() {
            self.goal = [s.r1 * 1e-3, s.r2 * 1e-3];
            self.distance = s.distance_mm * 1e-3;
        }
        self.feasible = !ctrl.target_infeasible();
        self.goal_for = sp;
        self.k += 1;
    }

    /// A restored state must be one this FMU could have reached: the same checks as set
    /// values and configurations get, plus finite controller internals (a checksum proves the
    /// bytes intact, not honest).
    fn validate_restored(&self) -> Result<(), ModelError> {
        check_abs("z_start", self.z_start, MAX_Z_START, "m")?;
        check_abs("omega_start", self.omega_start, MAX_OMEGA_START, "rad/s")?;
        for (name, v) in [
            ("r1_ref", self.r_ref[0]),
            ("r2_ref", self.r_ref[1]),
            ("r1", self.y[0]),
            ("r2", self.y[1]),
        ] {
            check_abs(name, v, MAX_RADIUS, "m")?;
        }
        check_abs("start time", self.t0, MAX_TIME, "s")?;
        check_config(&self.effective_config())?;
        if let (Some(cfg), Some(ctrl)) = (&self.cfg_init, &self.ctrl) {
            check_config(cfg)?;
            let t_next = self.t0 + self.k as f64 * cfg.sample_time_s;
            check_abs("time of the next sample", t_next, MAX_TIME, "s")?;
            for (name, v) in [
                ("z_m", self.u[0]),
                ("omega_m", self.u[1]),
                ("r1_goal", self.goal[0]),
                ("r2_goal", self.goal[1]),
                ("target_distance", self.distance),
            ] {
                check_abs(name, v, MAX_OMEGA_START, "(SI)")?;
            }
            let snap = serde_json::to_value(ctrl.snapshot())
                .map_err(|e| ModelError::error(format!("controller state: {e}")))?;
            if let Some(x) = first_absurd_number(&snap, 1e12) {
                return Err(ModelError::error(format!(
                    "controller state holds {x}, beyond any value the controller reaches"
                )));
            }
        }
        Ok(())
    }

    fn build_controller(&mut self) -> Result<(), ModelError> {
        let cfg = self.effective_config();
        check_config(&cfg)?;
        let ctrl = Controller::new(self.model.clone(), cfg.clone())
            .map_err(|e| ModelError::error(e.to_string()))?;
        self.cfg_init = Some(cfg);
        self.ctrl = Some(ctrl);
        self.k = 0;
        self.u = [self.z_start, self.omega_start];
        Ok(())
    }
}

impl FmuModel for MagSwarmPid {
    fn model_info() -> &'static ModelInfo {
        &INFO
    }

    fn instantiate(ctx: &mut Ctx<'_>, args: &InstantiateArgs<'_>) -> Result<Self, ModelError> {
        let m = MagSwarmPid::with_resources(args.resource_dir, args.packaged_resources)?;
        ctx.debug(
            "logConfig",
            format!(
                "default model \"{}\", sample time {} s",
                m.model.name, m.default_cfg.sample_time_s
            ),
        );
        Ok(m)
    }

    fn setup_experiment(
        &mut self,
        _ctx: &mut Ctx<'_>,
        _tolerance: Option<f64>,
        start_time: f64,
        _stop_time: Option<f64>,
    ) -> Result<(), ModelError> {
        check_abs("startTime", start_time, MAX_TIME, "s")?;
        self.t0 = start_time;
        Ok(())
    }

    fn exit_initialization_mode(&mut self, ctx: &mut Ctx<'_>) -> Result<(), ModelError> {
        self.build_controller()?;
        self.goal_for = [f64::NAN; 2];
        self.update_goal_before_start();
        ctx.debug(
            "logConfig",
            format!("configuration: {}", self.effective_config().to_json()),
        );
        Ok(())
    }

    fn step(&mut self, ctx: &mut Ctx<'_>, current_time: f64, step: f64) -> Result<(), ModelError> {
        let ts = self
            .ctrl
            .as_ref()
            .map(|c| c.sample_time())
            .ok_or_else(|| ModelError::error("doStep before initialisation"))?;
        let t_end = current_time + step;
        let eps = 1e-6 * ts;
        let next = self.t0 + self.k as f64 * ts;
        let needed = ((t_end - eps - next) / ts).ceil();
        if !next.is_finite() || needed > MAX_SAMPLES_PER_STEP as f64 {
            return Err(ModelError::error(format!(
                "a step to t = {t_end} s needs {needed} controller samples of sample_time = {ts} s \
                 from t = {next} s, more than the limit of {MAX_SAMPLES_PER_STEP} samples per \
                 fmi2DoStep; use communication steps of at most {} s",
                ts * MAX_SAMPLES_PER_STEP as f64
            )));
        }
        // Samples left behind (the master started later than the experiment's start time, or
        // jumped): catch up with the inputs in force.
        while self.t0 + self.k as f64 * ts < t_end - eps {
            self.sample(ctx)?;
        }
        Ok(())
    }

    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        if let Some(i) = param_index(vr) {
            return Ok((PARAMS[i].get)(&self.effective_config()));
        }
        if self.k == 0 {
            self.update_goal_before_start();
        }
        let last = self.ctrl.as_ref().filter(|_| self.k > 0).map(|c| *c.last());
        Ok(match vr {
            vr::R1_REF => self.r_ref[0],
            vr::R2_REF => self.r_ref[1],
            vr::R1 => self.y[0],
            vr::R2 => self.y[1],
            vr::Z_M => self.u[0],
            vr::OMEGA_M => self.u[1],
            vr::R1_GOAL => self.goal[0],
            vr::R2_GOAL => self.goal[1],
            vr::TARGET_DISTANCE => self.distance,
            vr::R1_REFERENCE => last.map_or(self.y[0], |l| l.reference_mm[0] * 1e-3),
            vr::R2_REFERENCE => last.map_or(self.y[1], |l| l.reference_mm[1] * 1e-3),
            vr::Z_M_FF => last.map_or(self.u[0], |l| l.feedforward[0]),
            vr::OMEGA_M_FF => last.map_or(self.u[1], |l| l.feedforward[1]),
            vr::Z_START => self.z_start,
            vr::OMEGA_START => self.omega_start,
            other => return Err(ModelError::unknown_vr(VarType::Real, other)),
        })
    }

    fn set_real(&mut self, _ctx: &mut Ctx<'_>, vr: u32, value: f64) -> Result<(), ModelError> {
        if let Some(i) = param_index(vr) {
            let p = &PARAMS[i];
            // Through the configuration's own units (mm), so an overflow there is caught too.
            let mut probe = self.effective_config();
            (p.set)(&mut probe, value);
            check_param(p, (p.get)(&probe))?;
            if let Some(ctrl) = self.ctrl.as_mut() {
                // Stepping: only the tunable gains get here (the shell refuses the others).
                let mut cfg = self.cfg_init.clone().expect("built with the controller");
                cfg.gains = ctrl.config().gains;
                (p.set)(&mut cfg, value);
                cfg.validate()
                    .map_err(|e| ModelError::error(format!("{}: {e}", p.name)))?;
                ctrl.set_gains(cfg.gains);
                self.set_override(i, value);
                return Ok(());
            }
            if value == (p.get)(&self.default_cfg) {
                self.overrides.retain(|(j, _)| *j != i);
            } else {
                self.set_override(i, value);
            }
            return Ok(());
        }
        let radius = |name: &str| check_abs(name, value, MAX_RADIUS, "m");
        match vr {
            vr::R1_REF => {
                radius("r1_ref")?;
                self.r_ref[0] = value
            }
            vr::R2_REF => {
                radius("r2_ref")?;
                self.r_ref[1] = value
            }
            vr::R1 => {
                radius("r1")?;
                self.y[0] = value
            }
            vr::R2 => {
                radius("r2")?;
                self.y[1] = value
            }
            vr::Z_START => {
                check_abs("z_start", value, MAX_Z_START, "m")?;
                self.z_start = value
            }
            vr::OMEGA_START => {
                check_abs("omega_start", value, MAX_OMEGA_START, "rad/s")?;
                self.omega_start = value
            }
            other => return Err(ModelError::unknown_vr(VarType::Real, other)),
        }
        Ok(())
    }

    fn get_boolean(&mut self, vr: u32) -> Result<bool, ModelError> {
        if self.k == 0 {
            self.update_goal_before_start();
        }
        let last = self.ctrl.as_ref().filter(|_| self.k > 0).map(|c| *c.last());
        match vr {
            vr::TARGET_FEASIBLE => Ok(self.feasible),
            vr::SATURATED => Ok(last.is_some_and(|l| l.saturated.iter().any(|&s| s))),
            vr::RATE_LIMITED => Ok(last.is_some_and(|l| l.rate_limited.iter().any(|&s| s))),
            vr::FEEDFORWARD => Ok(self.effective_config().feedforward),
            vr::CONDITIONAL_INTEGRATION => {
                Ok(self.effective_config().gains.conditional_integration)
            }
            other => Err(ModelError::unknown_vr(VarType::Boolean, other)),
        }
    }

    fn set_boolean(&mut self, _ctx: &mut Ctx<'_>, vr: u32, value: bool) -> Result<(), ModelError> {
        match vr {
            vr::FEEDFORWARD => {
                self.feedforward = (value != self.default_cfg.feedforward).then_some(value);
            }
            vr::CONDITIONAL_INTEGRATION => {
                if let Some(ctrl) = self.ctrl.as_mut() {
                    let mut g = ctrl.config().gains;
                    g.conditional_integration = value;
                    ctrl.set_gains(g);
                    self.conditional_integration = Some(value);
                } else {
                    self.conditional_integration =
                        (value != self.default_cfg.gains.conditional_integration).then_some(value);
                }
            }
            other => return Err(ModelError::unknown_vr(VarType::Boolean, other)),
        }
        Ok(())
    }

    fn get_integer(&mut self, vr: u32) -> Result<i32, ModelError> {
        match vr {
            vr::SAMPLES => Ok(self.k.min(i32::MAX as u64) as i32),
            other => Err(ModelError::unknown_vr(VarType::Integer, other)),
        }
    }

    fn get_string(&mut self, vr: u32) -> Result<String, ModelError> {
        match vr {
            vr::MODEL_FILE => Ok(self.model_file.clone()),
            vr::CONFIG_FILE => Ok(self.config_file.clone()),
            other => Err(ModelError::unknown_vr(VarType::String, other)),
        }
    }

    fn set_string(&mut self, ctx: &mut Ctx<'_>, vr: u32, value: &str) -> Result<(), ModelError> {
        match vr {
            vr::MODEL_FILE => {
                self.model = if value.is_empty() {
                    self.default_model.clone()
                } else {
                    Model::load(Path::new(value))
                        .map_err(|e| ModelError::error(format!("model_file: {e}")))?
                };
                self.model_file = value.to_string();
                self.goal_for = [f64::NAN; 2];
                ctx.debug(
                    "logConfig",
                    format!("model_file {value:?}: \"{}\"", self.model.name),
                );
            }
            vr::CONFIG_FILE => {
                self.base_cfg = if value.is_empty() {
                    self.default_cfg.clone()
                } else {
                    load_config(Path::new(value))
                        .map_err(|e| ModelError::error(format!("config_file: {}", e.message)))?
                };
                self.config_file = value.to_string();
                self.goal_for = [f64::NAN; 2];
                ctx.debug("logConfig", format!("config_file {value:?} loaded"));
            }
            other => return Err(ModelError::unknown_vr(VarType::String, other)),
        }
        Ok(())
    }

    type State = MagSwarmPidState;

    fn save_state(&self) -> Result<MagSwarmPidState, ModelError> {
        let running = match (&self.cfg_init, &self.ctrl) {
            (Some(cfg), Some(ctrl)) => Some(RunningState {
                cfg: cfg.clone(),
                controller: ctrl.snapshot(),
                k: self.k,
                u: self.u,
                goal: self.goal,
                distance: self.distance,
                goal_for: self.goal_for,
                feasible: self.feasible,
            }),
            _ => None,
        };
        Ok(MagSwarmPidState {
            model: self.model.clone(),
            model_file: self.model_file.clone(),
            base_cfg: self.base_cfg.clone(),
            config_file: self.config_file.clone(),
            overrides: self.overrides.clone(),
            feedforward: self.feedforward,
            conditional_integration: self.conditional_integration,
            start: [self.z_start, self.omega_start],
            r_ref: self.r_ref,
            y: self.y,
            t0: self.t0,
            running,
        })
    }

    fn restore_state(&mut self, s: MagSwarmPidState) -> Result<(), ModelError> {
        let bad = |e: String| ModelError::error(format!("FMU state: {e}"));
        s.model.validate().map_err(|e| bad(format!("model: {e}")))?;
        s.base_cfg
            .validate()
            .map_err(|e| bad(format!("configuration: {e}")))?;
        if let Some(&(i, _)) = s.overrides.iter().find(|(i, _)| *i >= PARAMS.len()) {
            return Err(bad(format!(
                "parameter index {i} (this FMU has {} numeric parameters)",
                PARAMS.len()
            )));
        }
        let mut fresh = self.clone();
        fresh.model = s.model;
        fresh.model_file = s.model_file;
        fresh.base_cfg = s.base_cfg;
        fresh.config_file = s.config_file;
        fresh.overrides = s.overrides;
        fresh.feedforward = s.feedforward;
        fresh.conditional_integration = s.conditional_integration;
        [fresh.z_start, fresh.omega_start] = s.start;
        fresh.r_ref = s.r_ref;
        fresh.y = s.y;
        fresh.t0 = s.t0;
        match s.running {
            Some(r) => {
                let mut ctrl = Controller::new(fresh.model.clone(), r.cfg.clone())
                    .map_err(|e| bad(e.to_string()))?;
                ctrl.restore(&r.controller);
                fresh.cfg_init = Some(r.cfg);
                fresh.ctrl = Some(ctrl);
                fresh.k = r.k;
                fresh.u = r.u;
                fresh.goal = r.goal;
                fresh.distance = r.distance;
                fresh.goal_for = r.goal_for;
                fresh.feasible = r.feasible;
            }
            None => {
                fresh.cfg_init = None;
                fresh.ctrl = None;
                fresh.k = 0;
                fresh.goal_for = [f64::NAN; 2];
                fresh.u = [fresh.z_start, fresh.omega_start];
            }
        }
        fresh.validate_restored().map_err(|e| bad(e.message))?;
        *self = fresh;
        Ok(())
    }

    /// The outputs change only in doStep, so within a communication point they do not depend
    /// on the inputs: the directional derivatives with respect to inputs are exactly zero.
    fn jacobian(&mut self, unknowns: &[u32], knowns: &[u32]) -> Result<Vec<f64>, ModelError> {
        for k in knowns {
            if ![vr::R1_REF, vr::R2_REF, vr::R1, vr::R2].contains(k) {
                return Err(ModelError::error(format!(
                    "directional derivative: value reference {k} is not an input"
                )));
            }
        }
        Ok(vec![0.0; unknowns.len() * knowns.len()])
    }
}
