//! [`CoSimulation`]: one MagSwarm-like FMU as a [`SwarmPlant`] (the FMU importer's plant),
//! run by the one closed-loop driver [`magswarm_control::driver::run_loop`].
//!
//! # Timing (one communication step `h`)
//!
//! At each sample `t_k = t_0 + k h` (accumulated as `t += h`, like the in-process plant):
//!
//! 1. the outputs are read (the radii the FMU holds at `t_k`, plus any `extra_outputs`);
//! 2. the controller maps them to a [`Command`] (inputs, optional setpoints);
//! 3. one log row `(t_k, command, measured radii, setpoints)` goes to the sink: the inputs in a
//!    row are the ones commanded from `t_k` on (zero-order hold), as the log format asks (docs/log-format.md);
//! 4. the inputs are set (`fmi2SetReal`) and the FMU advances `fmi2DoStep(t_k, h)`.
//!
//! This is a sequential (Gauss-Seidel) loop: the controller sees the outputs of the step that
//! just finished. A Jacobi master (libcosim with connections) adds one sample of delay.
//!
//! Units: everything in the API is SI as on the FMU's interface (m, rad/s), except the
//! readings and log rows, which are in the contract's mm and Hz, and
//! [`Command::reference_mm`] (setpoints are logged in mm, as the controller library works in
//! mm).

use magswarm_control::driver::{run_loop, LoopError, Tick};
use magswarm_control::plant::{Inputs, PlantError, Reading, SwarmPlant};

use crate::error::{CosimError, Result, Status};
use crate::import::Fmu;
use crate::slave::{FmuSlave, SlaveOptions};

pub use magswarm_control::driver::{Command, FnSink, LogSink, NoLog};

/// A parameter value to set before initialisation.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    /// Real.
    Real(f64),
    /// Boolean.
    Boolean(bool),
    /// String (e.g. `model_file`).
    String(String),
}

/// Configuration of a [`CoSimulation`].
#[derive(Debug, Clone)]
pub struct CoSimConfig {
    /// Communication step size `h` \[s\].
    pub step_s: f64,
    /// Start time \[s\].
    pub start_time_s: f64,
    /// Stop time passed to `fmi2SetupExperiment` (None: open-ended).
    pub stop_time_s: Option<f64>,
    /// Tolerance passed to `fmi2SetupExperiment` (None: the FMU's default).
    pub tolerance: Option<f64>,
    /// Inputs before the first step `[z_m [m], omega_m [rad/s]]`, set before initialisation
    /// (the FMU starts formed at them unless `settle_at_start` is false).
    pub initial_inputs: [f64; 2],
    /// Names of the two inputs (default `z_m`, `omega_m`).
    pub input_names: [String; 2],
    /// Names of the two measured outputs (default `r1`, `r2`).
    pub output_names: [String; 2],
    /// More Real outputs read at every sample into [`Measurement::extra`] (e.g. `r1_ss`).
    pub extra_outputs: Vec<String>,
    /// Parameters set before initialisation, by name.
    pub parameters: Vec<(String, ParamValue)>,
    /// Instance name.
    pub instance_name: String,
    /// How to instantiate.
    pub slave: SlaveOptions,
}

impl Default for CoSimConfig {
    fn default() -> Self {
        CoSimConfig {
            step_s: 0.01,
            start_time_s: 0.0,
            stop_time_s: None,
            tolerance: None,
            initial_inputs: [0.0085, 4.0 * std::f64::consts::TAU],
            input_names: ["z_m".into(), "omega_m".into()],
            output_names: ["r1".into(), "r2".into()],
            extra_outputs: Vec::new(),
            parameters: Vec::new(),
            instance_name: "swarm".into(),
            slave: SlaveOptions::default(),
        }
    }
}

/// What the controller sees at a sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    /// Sample index `k` since the start.
    pub k: u64,
    /// Time `t_k` \[s\].
    pub t_s: f64,
    /// Inputs in force up to `t_k` `[z_m [m], omega_m [rad/s]]` (the last command, or the
    /// initial inputs).
    pub inputs: [f64; 2],
    /// Measured outputs `[r1, r2]` \[m\].
    pub radii_m: [f64; 2],
    /// Values of [`CoSimConfig::extra_outputs`], same order (SI).
    pub extra: Vec<f64>,
}

impl Measurement {
    /// The radii in mm (the controller library's unit).
    pub fn radii_mm(&self) -> [f64; 2] {
        [self.radii_m[0] * 1e3, self.radii_m[1] * 1e3]
    }
}

/// What a run did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunSummary {
    /// Communication steps taken.
    pub steps: u64,
    /// Time at the end \[s\].
    pub t_end_s: f64,
    /// Calls that returned `fmi2Warning` (the messages are in the slave's log).
    pub warnings: u64,
    /// The last measurement (after the last step).
    pub last: Option<Measurement>,
}

/// A fixed-step co-simulation of one FMU with two inputs and two measured outputs, driven
/// by a controller closure (see the module documentation for the timing).
///
/// ```no_run
/// use magswarm_cosim::{CoSimConfig, CoSimulation, Command, Fmu};
/// use magswarm_log::{Layout, LogWriter};
///
/// let fmu = Fmu::load("target/fmu/MagSwarm.fmu")?;
/// let mut sim = CoSimulation::new(&fmu, &CoSimConfig { step_s: 0.01, ..Default::default() })?;
/// let mut out = LogWriter::create("run.csv".as_ref(), Layout::standard(true, false, false, true))?;
/// // open loop: a step of z_m to 13.5 mm at 6 Hz for 40 s
/// sim.run_for(40.0, |_m| Command::from_mm_hz(13.5, 6.0).with_reference_mm(9.0, 11.0), &mut out)?;
/// out.finish()?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct CoSimulation {
    slave: FmuSlave,
    h: f64,
    t: f64,
    k: u64,
    in_vr: [u32; 2],
    out_vr: Vec<u32>,
    inputs: [f64; 2],
    /// The input values (bits) the instance is known to hold, when only this runner set them
    /// since: an unchanged command is not set again (FMI inputs keep their values until set).
    /// Cleared whenever the instance is handed out ([`CoSimulation::slave`]).
    sent: Option<[u64; 2]>,
    warnings: u64,
    buf: Vec<f64>,
    /// The importer's error behind the last [`PlantError`], so that [`CoSimulation::run`]
    /// returns it with its FMI function and status.
    last_error: Option<CosimError>,
}

impl CoSimulation {
    /// Instantiate `fmu`, set the parameters and initial inputs, and initialise it at
    /// `start_time_s` (setup, enter and exit initialisation mode).
    pub fn new(fmu: &Fmu, cfg: &CoSimConfig) -> Result<CoSimulation> {
        if !(cfg.step_s > 0.0 && cfg.step_s.is_finite()) {
            return Err(CosimError::Usage(format!(
                "communication step {} s must be positive",
                cfg.step_s
            )));
        }
        let in_vr = [
            fmu.real_vr(&cfg.input_names[0])?,
            fmu.real_vr(&cfg.input_names[1])?,
        ];
        let mut out_vr = vec![
            fmu.real_vr(&cfg.output_names[0])?,
            fmu.real_vr(&cfg.output_names[1])?,
        ];
        for n in &cfg.extra_outputs {
            out_vr.push(fmu.real_vr(n)?);
        }
        let mut slave = FmuSlave::instantiate(fmu, &cfg.instance_name, cfg.slave.clone())?;
        let mut warnings = 0;
        let mut count = |s: Status| {
            if s == Status::Warning {
                warnings += 1;
            }
        };
        count(slave.setup_experiment(cfg.tolerance, cfg.start_time_s, cfg.stop_time_s)?);
        for (name, v) in &cfg.parameters {
            count(match v {
                ParamValue::Real(x) => slave.set_real_by_name(name, *x)?,
                ParamValue::Boolean(b) => slave.set_boolean_by_name(name, *b)?,
                ParamValue::String(s) => slave.set_string_by_name(name, s)?,
            });
        }
        count(slave.set_real(&in_vr, &cfg.initial_inputs)?);
        count(slave.enter_initialization_mode()?);
        count(slave.exit_initialization_mode()?);
        let n = out_vr.len();
        Ok(CoSimulation {
            slave,
            h: cfg.step_s,
            t: cfg.start_time_s,
            k: 0,
            in_vr,
            out_vr,
            inputs: cfg.initial_inputs,
            sent: Some(cfg.initial_inputs.map(f64::to_bits)),
            warnings,
            buf: vec![0.0; n],
            last_error: None,
        })
    }

    /// The current time \[s\].
    pub fn time(&self) -> f64 {
        self.t
    }

    /// The communication step \[s\].
    pub fn step_size(&self) -> f64 {
        self.h
    }

    /// Samples taken so far.
    pub fn samples(&self) -> u64 {
        self.k
    }

    /// Calls that returned `fmi2Warning` so far.
    pub fn warnings(&self) -> u64 {
        self.warnings
    }

    /// The instance, for anything else (FMU state, directional derivatives, the log).
    pub fn slave(&mut self) -> &mut FmuSlave {
        // The caller may set the inputs (or reset, or restore a state) behind our back.
        self.sent = None;
        &mut self.slave
    }

    /// Give the instance back (e.g. to terminate it explicitly).
    pub fn into_slave(self) -> FmuSlave {
        self.slave
    }

    /// Read the outputs now.
    #[inline(always)]
    pub fn measure(&mut self) -> Result<Measurement> {
        let s = self.slave.get_real(&self.out_vr, &mut self.buf)?;
        if s == Status::Warning {
            self.warnings += 1;
        }
        Ok(Measurement {
            k: self.k,
            t_s: self.t,
            inputs: self.inputs,
            radii_m: [self.buf[0], self.buf[1]],
            extra: self.buf[2..].to_vec(),
        })
    }

    /// Set the inputs of `cmd` and advance one communication step.
    pub fn advance(&mut self, cmd: &Command) -> Result<Status> {
        self.advance_by(cmd.inputs, self.h)
    }

    /// Set the inputs and advance `dt` seconds (the communication step of [`SwarmPlant::step`]).
    #[inline]
    fn advance_by(&mut self, u: Inputs, dt: f64) -> Result<Status> {
        let bits = [u.z_m.to_bits(), u.omega_m.to_bits()];
        // The inputs are stored where they stay (`self.inputs`) and handed to `SetReal` from
        // there, rather than from a copy on the stack that is read back afterwards: that
        // read, 16 bytes of two 8-byte stores, cannot be forwarded and waited for the
        // controller's command to retire (docs/performance.md).
        let before = self.inputs;
        self.inputs = [u.z_m, u.omega_m];
        let a = if self.sent == Some(bits) {
            Status::Ok
        } else {
            self.sent = None;
            let a = match self.slave.set_real(&self.in_vr, &self.inputs) {
                Ok(a) => a,
                Err(e) => {
                    self.inputs = before;
                    return Err(e);
                }
            };
            self.sent = Some(bits);
            a
        };
        let b = self.slave.do_step(self.t, dt)?;
        for s in [a, b] {
            if s == Status::Warning {
                self.warnings += 1;
            }
        }
        self.t += dt;
        self.k += 1;
        Ok(a.max(b))
    }

    /// Run `steps` samples of measure, control, log, set inputs, step, with the one
    /// closed-loop driver ([`run_loop`]). The controller gets every measurement; the sink one
    /// row per sample. Stops at the first FMI error (the rows before it have been written).
    pub fn run<C, S>(&mut self, steps: u64, mut controller: C, sink: &mut S) -> Result<RunSummary>
    where
        C: FnMut(&Measurement) -> Command,
        S: LogSink + ?Sized,
    {
        let w0 = self.warnings;
        let h = self.h;
        self.last_error = None;
        let outcome = run_loop(
            self,
            steps,
            h,
            |t: &Tick<'_>| controller(&Measurement::from_tick(t)),
            sink,
        );
        match outcome {
            Ok(_) => {}
            Err(LoopError::Log(e)) => return Err(CosimError::Io(e)),
            Err(LoopError::Plant { source, .. }) => {
                return Err(self
                    .last_error
                    .take()
                    .unwrap_or_else(|| CosimError::Usage(source.to_string())))
            }
        }
        let last = self.measure()?;
        Ok(RunSummary {
            steps,
            t_end_s: self.t,
            warnings: self.warnings - w0,
            last: Some(last),
        })
    }

    /// [`CoSimulation::run`] for `duration_s` (rounded to whole steps).
    pub fn run_for<C, S>(
        &mut self,
        duration_s: f64,
        controller: C,
        sink: &mut S,
    ) -> Result<RunSummary>
    where
        C: FnMut(&Measurement) -> Command,
        S: LogSink + ?Sized,
    {
        let n = (duration_s / self.h).round().max(0.0) as u64;
        self.run(n, controller, sink)
    }
}

impl Measurement {
    /// The measurement of a driver tick (radii back in m, as the FMU gives them).
    fn from_tick(t: &Tick<'_>) -> Measurement {
        Measurement {
            k: t.k,
            t_s: t.reading.t_s,
            inputs: t.inputs.to_array(),
            radii_m: [t.reading.r_mm[0] * 1e-3, t.reading.r_mm[1] * 1e-3],
            extra: t.reading.extra.clone(),
        }
    }
}

/// The FMU importer's plant: inputs `z_m`, `omega_m` (or [`CoSimConfig::input_names`]),
/// radii from `r1`, `r2` (or [`CoSimConfig::output_names`]) converted to mm, the
/// `extra_outputs` in [`Reading::extra`] (SI). Readings are always valid (the FMU has no
/// camera); an FMI error is [`PlantError::Interface`] with the function, status and the
/// FMU's message.
impl SwarmPlant for CoSimulation {
    #[inline]
    fn time_s(&self) -> f64 {
        self.t
    }

    #[inline]
    fn inputs(&self) -> Inputs {
        Inputs::new(self.inputs[0], self.inputs[1])
    }

    #[inline(always)]
    fn measure(&mut self) -> std::result::Result<Reading, PlantError> {
        match CoSimulation::measure(self) {
            Ok(m) => Ok(Reading {
                t_s: m.t_s,
                r_mm: m.radii_mm(),
                valid: true,
                extra: m.extra,
            }),
            Err(e) => Err(self.plant_error(e)),
        }
    }

    #[inline]
    fn step(&mut self, u: Inputs, dt_s: f64) -> std::result::Result<Reading, PlantError> {
        if let Err(e) = self.advance_by(u, dt_s) {
            return Err(self.plant_error(e));
        }
        SwarmPlant::measure(self)
    }

    fn describe(&self) -> String {
        format!("FMU instance {:?}", self.slave.name())
    }
}

impl CoSimulation {
    #[cold]
    #[inline(never)]
    fn plant_error(&mut self, e: CosimError) -> PlantError {
        let p = PlantError::Interface(e.to_string());
        self.last_error = Some(e);
        p
    }
}
