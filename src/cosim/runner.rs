//! [`CoSimulation`]: a fixed-step master for one MagSwarm-like FMU and a controller closure.
//!
//! # Timing (one communication step `h`)
//!
//! At each sample `t_k = t_0 + k h` (accumulated as `t += h`, like the in-process loop of
//! `magswarm_control::sim::closed_loop`):
//!
//! 1. the outputs are read ([`Measurement`]: the radii the FMU holds at `t_k`, plus any
//!    `extra_outputs`);
//! 2. the controller closure maps the measurement to a [`Command`] (inputs, optional
//!    setpoints);
//! 3. one log row `(t_k, command, measured radii, setpoints)` goes to the sink: the inputs in a
//!    row are the ones commanded from `t_k` on (zero-order hold), as CONTRACTS.md's log asks;
//! 4. the inputs are set (`fmi2SetReal`) and the FMU advances `fmi2DoStep(t_k, h)`.
//!
//! This is a sequential (Gauss-Seidel) loop: the controller sees the outputs of the step that
//! just finished. A Jacobi master (libcosim with connections) adds one sample of delay.
//!
//! Units: everything in the API is SI as on the FMU's interface (m, rad/s), except the log
//! rows, which are in the contract's mm and Hz, and [`Command::reference_mm`] (setpoints are
//! logged in mm, as the controller library works in mm).

use std::io::Write;

use magswarm_model::rad_s_to_hz;

use super::error::{CosimError, Result, Status};
use super::import::Fmu;
use super::slave::{FmuSlave, SlaveOptions};
use crate::log::{LogRow, LogWriter};

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
    /// Communication step size `h` [s].
    pub step_s: f64,
    /// Start time [s].
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
    /// Time `t_k` [s].
    pub t_s: f64,
    /// Inputs in force up to `t_k` `[z_m [m], omega_m [rad/s]]` (the last command, or the
    /// initial inputs).
    pub inputs: [f64; 2],
    /// Measured outputs `[r1, r2]` [m].
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

/// What the controller commands from a sample on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    /// Inputs `[z_m [m], omega_m [rad/s]]`.
    pub inputs: [f64; 2],
    /// Setpoints `[r1*, r2*]` [mm] for the log's `r1_ref_mm`, `r2_ref_mm` (None: not logged).
    pub reference_mm: Option<[f64; 2]>,
}

impl Command {
    /// Inputs in SI (z_m [m], omega_m [rad/s]), no setpoint.
    pub fn new(z_m: f64, omega_m: f64) -> Command {
        Command {
            inputs: [z_m, omega_m],
            reference_mm: None,
        }
    }

    /// Inputs in the log's units (z_m [mm], f [Hz]).
    pub fn from_mm_hz(z_mm: f64, f_hz: f64) -> Command {
        Command::new(z_mm * 1e-3, f_hz * std::f64::consts::TAU)
    }

    /// With setpoints [mm].
    pub fn with_reference_mm(mut self, r1: f64, r2: f64) -> Command {
        self.reference_mm = Some([r1, r2]);
        self
    }
}

/// Where log rows go. Implemented for [`crate::log::LogWriter`] (the contract's CSV), for
/// `Vec<LogRow>`, for [`FnSink`] (any closure) and for [`NoLog`].
pub trait LogSink {
    /// Take one row.
    fn write_row(&mut self, row: &LogRow) -> std::io::Result<()>;
}

impl<W: Write> LogSink for LogWriter<W> {
    fn write_row(&mut self, row: &LogRow) -> std::io::Result<()> {
        LogWriter::write_row(self, row)
    }
}

impl LogSink for Vec<LogRow> {
    fn write_row(&mut self, row: &LogRow) -> std::io::Result<()> {
        self.push(row.clone());
        Ok(())
    }
}

/// A closure as a sink.
pub struct FnSink<F>(pub F);

impl<F: FnMut(&LogRow) -> std::io::Result<()>> LogSink for FnSink<F> {
    fn write_row(&mut self, row: &LogRow) -> std::io::Result<()> {
        (self.0)(row)
    }
}

/// A sink that drops the rows.
pub struct NoLog;

impl LogSink for NoLog {
    fn write_row(&mut self, _row: &LogRow) -> std::io::Result<()> {
        Ok(())
    }
}

/// What a run did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunSummary {
    /// Communication steps taken.
    pub steps: u64,
    /// Time at the end [s].
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
/// use magswarm::cosim::{CoSimConfig, CoSimulation, Command, Fmu};
/// use magswarm::log::{Layout, LogWriter};
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
    warnings: u64,
    buf: Vec<f64>,
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
            warnings,
            buf: vec![0.0; n],
        })
    }

    /// The current time [s].
    pub fn time(&self) -> f64 {
        self.t
    }

    /// The communication step [s].
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
        &mut self.slave
    }

    /// Give the instance back (e.g. to terminate it explicitly).
    pub fn into_slave(self) -> FmuSlave {
        self.slave
    }

    /// Read the outputs now.
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
        let a = self.slave.set_real(&self.in_vr, &cmd.inputs)?;
        self.inputs = cmd.inputs;
        let b = self.slave.do_step(self.t, self.h)?;
        for s in [a, b] {
            if s == Status::Warning {
                self.warnings += 1;
            }
        }
        self.t += self.h;
        self.k += 1;
        Ok(a.max(b))
    }

    /// Run `steps` samples of measure, control, log, set inputs, step. The controller gets
    /// every measurement; the sink one row per sample. Stops at the first FMI error (the rows
    /// before it have been written).
    pub fn run<C, S>(&mut self, steps: u64, mut controller: C, sink: &mut S) -> Result<RunSummary>
    where
        C: FnMut(&Measurement) -> Command,
        S: LogSink + ?Sized,
    {
        let w0 = self.warnings;
        for _ in 0..steps {
            let m = self.measure()?;
            let cmd = controller(&m);
            sink.write_row(&log_row(m.t_s, &cmd, m.radii_m))?;
            self.advance(&cmd)?;
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

/// The contract log row of one sample.
pub fn log_row(t_s: f64, cmd: &Command, radii_m: [f64; 2]) -> LogRow {
    let mut row = LogRow::new(
        t_s,
        cmd.inputs[0] * 1e3,
        rad_s_to_hz(cmd.inputs[1]),
        Some([radii_m[0] * 1e3, radii_m[1] * 1e3]),
    );
    if let Some(r) = cmd.reference_mm {
        row.r1_ref_mm = Some(r[0]);
        row.r2_ref_mm = Some(r[1]);
    }
    row
}
