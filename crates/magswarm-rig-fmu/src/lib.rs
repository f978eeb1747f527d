//! `MagSwarmRig.fmu`: the hardware rig as an FMI 2.0 Co-Simulation FMU, with the interface
//! of `MagSwarm.fmu`, so a controller designed against the model (Simulink with FMI Kit,
//! OpenModelica, fmpy, libcosim) drives the rig unchanged.
//!
//! This crate only maps FMI variables onto a [`RigSession`] of `magswarm-bridge` (the same
//! rig, safety core and stepper watchdog as `magswarm-bridge run`); the FMI plumbing (C ABI,
//! state machine, panic barrier, XML) is `magswarm-fmi2`'s. What a rig changes:
//!
//! - `fmi2ExitInitializationMode` opens the rig (robot, stepper watchdog, camera) with the
//!   inputs set so far, and waits for the first frame;
//! - `fmi2DoStep(t, h)` sends `z_m`, `omega_m` through the safety core at once and returns
//!   when the wall clock reaches `t + h` (the first step anchors FMU time to the wall clock);
//!   `r1`, `r2` are then the newest valid camera measurement (`valid` says whether the newest
//!   frame had one). A step called after its end was due returns at once with `fmi2Warning`,
//!   and `late`, `late_steps` say by how much and how often;
//! - a fault (protective stop, lost link, camera timeout, stepper error, a host stalled for
//!   more than `max_late`) stops the stepper and holds the robot at once, and the next (or
//!   current) `fmi2DoStep` returns `fmi2Error` with the fault's name in the log message;
//! - `fmi2Terminate` and `fmi2FreeInstance` stop the stepper and hold the robot; if the host
//!   dies instead, the stepper watchdog (shipped in `resources/`) stops the motor and the
//!   arm's program stops on its own heartbeat watchdog;
//! - the FMU cannot save or restore its state (`canGetAndSetFMUstate="false"`): a rig does
//!   not go back in time.

pub mod params;
pub mod table;

use std::collections::BTreeMap;
use std::f64::consts::TAU;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use magswarm_bridge::config::RigConfig;
use magswarm_bridge::safety::Fault;
use magswarm_bridge::session::{RigSession, SessionOptions};
use magswarm_bridge::watchdog;
use magswarm_fmi2::{Ctx, Fmi2Err, FmuModel, InstantiateArgs, ModelInfo, VarType};

use table::{vr, LOG_RIG, MAX_LATE_DEFAULT, RESOURCE_CONFIG};

/// How long after `fmi2ExitInitializationMode` the first `fmi2DoStep` may come (at least
/// `max_late`): importers such as Simulink set up the rest of a model in between.
pub const FIRST_STEP_WITHIN_S: f64 = 10.0;

/// The outputs, refreshed after every step.
#[derive(Debug, Clone, Copy, Default)]
struct Outputs {
    r: [f64; 2],
    valid: bool,
    shadow: [f64; 2],
    applied: (f64, f64),
    z_measured: f64,
    t_frame: f64,
}

/// One instance: the rig config, the parameters, and the session once initialised.
///
/// `Clone` is required by the shell's trait; a clone shares the session. The shell never
/// clones this model (it declares no FMU state).
#[derive(Clone)]
pub struct RigFmu {
    /// The config in `resources/`.
    baked: RigConfig,
    /// The config in force (`config_file`, or the baked one).
    cfg: RigConfig,
    config_file: String,
    resources: PathBuf,
    /// Limit and calibration values the importer set (value reference -> SI).
    set: BTreeMap<u32, f64>,
    max_late: f64,
    z_m: f64,
    omega: f64,
    t_start: f64,
    session: Option<Arc<Mutex<RigSession>>>,
    out: Outputs,
    late: f64,
    late_steps: i32,
    /// FMU time of the last late-step warning (one per second of FMU time at most).
    warned_at: Option<f64>,
}

fn var_name(v: u32) -> &'static str {
    table::model_info()
        .variables
        .iter()
        .find(|x| x.vr == v)
        .map_or("?", |x| x.name)
}

/// The fault as the importer sees it: `fmi2Error`, its name first.
fn fault_error(f: &Fault) -> Fmi2Err {
    Fmi2Err::error(format!(
        "rig fault {}: {f}; the stepper is stopped and the robot holds (the fault stays \
         latched: check the rig, then start a new simulation)",
        f.name()
    ))
}

/// The watchdog program shipped in `resources/`, made executable (importers unzip without
/// file modes); a copy in the temporary folder when `resources/` is read-only.
fn watchdog_program(resources: &Path) -> Result<Option<PathBuf>, Fmi2Err> {
    use std::os::unix::fs::PermissionsExt;
    let p = resources.join(watchdog::PROGRAM);
    if !p.is_file() {
        return Ok(None);
    }
    let mode = std::fs::metadata(&p)
        .map(|m| m.permissions().mode())
        .unwrap_or(0);
    if mode & 0o111 == 0o111 {
        return Ok(Some(p));
    }
    if std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).is_ok() {
        return Ok(Some(p));
    }
    let copy = std::env::temp_dir().join(format!("{}-{}", watchdog::PROGRAM, std::process::id()));
    std::fs::copy(&p, &copy)
        .and_then(|_| std::fs::set_permissions(&copy, std::fs::Permissions::from_mode(0o755)))
        .map_err(|e| {
            Fmi2Err::error(format!(
                "{} is not executable and cannot be copied to {}: {e}",
                p.display(),
                copy.display()
            ))
        })?;
    Ok(Some(copy))
}

impl RigFmu {
    /// An instance whose rig config is `resources/rig.toml`.
    pub fn new(resources: &Path) -> Result<RigFmu, Fmi2Err> {
        let path = resources.join(RESOURCE_CONFIG);
        let cfg = RigConfig::load(&path).map_err(|e| {
            Fmi2Err::error(format!(
                "the rig config of this FMU: {e} (build the FMU with `magswarm-bridge fmu \
                 --config RIG.toml`)"
            ))
        })?;
        Ok(RigFmu {
            baked: cfg.clone(),
            cfg: cfg.clone(),
            config_file: String::new(),
            resources: resources.to_path_buf(),
            set: BTreeMap::new(),
            max_late: MAX_LATE_DEFAULT,
            z_m: table::start_inputs(&cfg).0 * 1e-3,
            omega: table::start_inputs(&cfg).1 * TAU,
            t_start: 0.0,
            session: None,
            out: Outputs::default(),
            late: 0.0,
            late_steps: 0,
            warned_at: None,
        })
    }

    fn refresh(&mut self) {
        let Some(s) = &self.session else { return };
        let s = s.lock().unwrap_or_else(|p| p.into_inner());
        let v = s.view();
        let o = &mut self.out;
        o.applied = v.in_force;
        if let Some(l) = &v.latest {
            o.valid = l.radii.is_some();
            if let Some(sh) = l.shadow {
                o.shadow = sh;
            }
            if l.z_meas_mm.is_finite() {
                o.z_measured = l.z_meas_mm;
            }
        }
        if let Some(lv) = &v.last_valid {
            o.r = lv.radii.unwrap_or(o.r);
            o.t_frame = self.t_start + s.time_of(lv.at);
        }
    }

    fn shutdown(&mut self) {
        if let Some(s) = self.session.take() {
            s.lock().unwrap_or_else(|p| p.into_inner()).shutdown();
        }
    }
}

impl FmuModel for RigFmu {
    fn model_info() -> &'static ModelInfo {
        table::model_info()
    }

    fn instantiate(ctx: &mut Ctx<'_>, args: &InstantiateArgs<'_>) -> Result<Self, Fmi2Err> {
        let has = |d: &Path| d.join(RESOURCE_CONFIG).is_file();
        let dir = match (args.resource_dir, args.packaged_resources) {
            (Some(d), _) if has(d) => d,
            (_, Some(p)) if has(p) => {
                ctx.warning(format!(
                    "the resource location passed to fmi2Instantiate ({}) holds no {RESOURCE_CONFIG}; \
                     using the FMU's own {}",
                    args.resource_location.unwrap_or("none"),
                    p.display()
                ));
                p
            }
            _ => {
                return Err(Fmi2Err::error(format!(
                    "no {RESOURCE_CONFIG} in the resources of this FMU (resource location {}): \
                     build it with `magswarm-bridge fmu --config RIG.toml --out MagSwarmRig.fmu`",
                    args.resource_location.unwrap_or("none")
                )))
            }
        };
        let m = RigFmu::new(dir)?;
        ctx.debug(
            LOG_RIG,
            format!("rig config {}", dir.join(RESOURCE_CONFIG).display()),
        );
        Ok(m)
    }

    fn setup_experiment(
        &mut self,
        _ctx: &mut Ctx<'_>,
        _tolerance: Option<f64>,
        start_time: f64,
        _stop_time: Option<f64>,
    ) -> Result<(), Fmi2Err> {
        self.t_start = start_time;
        Ok(())
    }

    fn exit_initialization_mode(&mut self, ctx: &mut Ctx<'_>) -> Result<(), Fmi2Err> {
        let mut cfg = params::apply(&self.cfg, &self.set, var_name).map_err(Fmi2Err::error)?;
        if cfg.stepper.watchdog_exe.is_none() {
            cfg.stepper.watchdog_exe = watchdog_program(&self.resources)?;
        }
        let opts = SessionOptions {
            start: (self.z_m * 1e3, self.omega / TAU),
            max_late: Duration::from_secs_f64(self.max_late),
            first_step_within: Duration::from_secs_f64(FIRST_STEP_WITHIN_S),
        };
        let s = RigSession::open(&cfg, &opts)
            .map_err(|e| Fmi2Err::error(format!("the rig could not be opened: {e:#}")))?;
        for l in &s.description {
            ctx.debug(LOG_RIG, l);
        }
        self.session = Some(Arc::new(Mutex::new(s)));
        self.refresh();
        self.out.t_frame = self.out.t_frame.min(self.t_start);
        Ok(())
    }

    fn do_step(&mut self, ctx: &mut Ctx<'_>, t: f64, h: f64) -> Result<(), Fmi2Err> {
        let Some(s) = &self.session else {
            return Err(Fmi2Err::error("the rig is not open (terminated)"));
        };
        let u = (self.z_m * 1e3, self.omega / TAU);
        let r = s
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .step(t - self.t_start, h, u);
        self.refresh();
        let late = r.map_err(|f| fault_error(&f))?;
        if late.is_zero() {
            self.late = 0.0;
            return Ok(());
        }
        self.late = late.as_secs_f64();
        self.late_steps = self.late_steps.saturating_add(1);
        if self.warned_at.is_none_or(|w| t - w >= 1.0) {
            self.warned_at = Some(t);
            ctx.warning(format!(
                "late step: the step {t} s -> {} s ended {:.1} ms late (the host is slower than \
                 real time; {} late steps so far; the rig stops when a step is more than \
                 max_late = {} s late)",
                t + h,
                self.late * 1e3,
                self.late_steps,
                self.max_late
            ));
        }
        Ok(())
    }

    fn terminate(&mut self, ctx: &mut Ctx<'_>) -> Result<(), Fmi2Err> {
        let fault = self
            .session
            .as_ref()
            .and_then(|s| s.lock().unwrap_or_else(|p| p.into_inner()).fault());
        self.shutdown();
        ctx.debug(LOG_RIG, "terminated: stepper stopped, robot held");
        match fault {
            Some(f) => {
                ctx.debug(
                    LOG_RIG,
                    format!("the session had ended with {}: {f}", f.name()),
                );
                Ok(())
            }
            None => Ok(()),
        }
    }

    fn get_real(&mut self, v: u32) -> Result<f64, Fmi2Err> {
        let o = &self.out;
        Ok(match v {
            vr::Z_M => self.z_m,
            vr::OMEGA_M => self.omega,
            vr::R1 => o.r[0] * 1e-3,
            vr::R2 => o.r[1] * 1e-3,
            vr::R1_SHADOW => o.shadow[0] * 1e-3,
            vr::R2_SHADOW => o.shadow[1] * 1e-3,
            vr::Z_M_APPLIED => o.applied.0 * 1e-3,
            vr::OMEGA_M_APPLIED => o.applied.1 * TAU,
            vr::Z_M_MEASURED => o.z_measured * 1e-3,
            vr::T_FRAME => o.t_frame,
            vr::LATE => self.late,
            vr::MAX_LATE => self.max_late,
            p if params::is_rig_parameter(p) => match self.set.get(&p) {
                Some(x) => *x,
                None => params::config_value(&self.cfg, p)
                    .ok_or_else(|| Fmi2Err::unknown_vr(VarType::Real, p))?,
            },
            other => return Err(Fmi2Err::unknown_vr(VarType::Real, other)),
        })
    }

    fn set_real(&mut self, _ctx: &mut Ctx<'_>, v: u32, x: f64) -> Result<(), Fmi2Err> {
        match v {
            // Any finite request: the safety core clamps and rate limits it (z_m_applied,
            // omega_m_applied show what went out).
            vr::Z_M => self.z_m = x,
            vr::OMEGA_M => self.omega = x,
            vr::MAX_LATE => {
                if x <= 0.0 {
                    return Err(Fmi2Err::error(format!("max_late = {x} s must be positive")));
                }
                self.max_late = x;
            }
            p if params::is_rig_parameter(p) => {
                // Checked now against the config in force, and again at initialisation.
                let one = BTreeMap::from([(p, x)]);
                params::apply(&self.cfg, &one, var_name).map_err(Fmi2Err::error)?;
                self.set.insert(p, x);
            }
            other => return Err(Fmi2Err::unknown_vr(VarType::Real, other)),
        }
        Ok(())
    }

    fn get_integer(&mut self, v: u32) -> Result<i32, Fmi2Err> {
        match v {
            vr::LATE_STEPS => Ok(self.late_steps),
            other => Err(Fmi2Err::unknown_vr(VarType::Integer, other)),
        }
    }

    fn get_boolean(&mut self, v: u32) -> Result<bool, Fmi2Err> {
        match v {
            vr::VALID => Ok(self.out.valid),
            other => Err(Fmi2Err::unknown_vr(VarType::Boolean, other)),
        }
    }

    fn get_string(&mut self, v: u32) -> Result<String, Fmi2Err> {
        match v {
            vr::CONFIG_FILE => Ok(self.config_file.clone()),
            other => Err(Fmi2Err::unknown_vr(VarType::String, other)),
        }
    }

    fn set_string(&mut self, ctx: &mut Ctx<'_>, v: u32, value: &str) -> Result<(), Fmi2Err> {
        match v {
            vr::CONFIG_FILE => {
                self.cfg = if value.is_empty() {
                    self.baked.clone()
                } else {
                    RigConfig::load(Path::new(value))
                        .map_err(|e| Fmi2Err::error(format!("config_file: {e}")))?
                };
                self.config_file = value.to_string();
                ctx.debug(LOG_RIG, format!("config_file {value:?} loaded"));
                Ok(())
            }
            other => Err(Fmi2Err::unknown_vr(VarType::String, other)),
        }
    }

    type State = ();

    const CAN_GET_AND_SET_FMU_STATE: bool = false;
    const PROVIDES_DIRECTIONAL_DERIVATIVE: bool = false;

    fn save_state(&self) -> Result<(), Fmi2Err> {
        Err(Fmi2Err::error("a rig cannot save its state"))
    }

    fn restore_state(&mut self, _state: ()) -> Result<(), Fmi2Err> {
        Err(Fmi2Err::error("a rig cannot go back to a saved state"))
    }

    fn directional_derivative(
        &mut self,
        _unknowns: &[u32],
        _knowns: &[u32],
        _dv_known: &[f64],
    ) -> Result<Vec<f64>, Fmi2Err> {
        Err(Fmi2Err::error("a rig has no Jacobian"))
    }
}

#[cfg(feature = "export")]
magswarm_fmi2::export_fmi2!(RigFmu);

// `magswarm-bridge fmu` asks the compiled library for its own XML, passing the text of the
// rig config to bake in.
#[cfg(feature = "export")]
magswarm_fmi2::export_describe!(|toml: Option<&str>| {
    match toml {
        None => Some(magswarm_fmi2::model_description_xml::<RigFmu>(
            &Default::default(),
        )),
        Some(text) => {
            let cfg = RigConfig::parse(text, Path::new(RESOURCE_CONFIG)).ok()?;
            Some(table::model_description(&cfg, None))
        }
    }
});
