//! The one closed-loop driver: any [`SwarmPlant`], any controller, one measurement-log row
//! ([`magswarm_log::LogRow`]) per sample.
//!
//! # Timing (one sample `k`, step `dt`)
//!
//! 1. the plant's reading at `t_k` (the first from [`SwarmPlant::measure`], the next ones as
//!    returned by [`SwarmPlant::step`]);
//! 2. the controller maps the [`Tick`] (sample index, reading, inputs in force) to a
//!    [`Command`] (inputs, optional setpoints);
//! 3. one log row goes to the sink: the measurement taken at `t_k` and the inputs commanded
//!    from `t_k` on, as the log's row-time convention says (`magswarm_log`'s docs);
//! 4. the plant applies the inputs and advances `dt` ([`SwarmPlant::step`]).
//!
//! This is a sequential (Gauss-Seidel) loop: the controller sees the outputs of the step that
//! just finished. After the last step the final reading is taken and returned in the
//! [`LoopSummary`] (it has no row: no command was issued for it).
//!
//! Used by the in-process tracking scenario ([`crate::sim::closed_loop`]), the FMU importer
//! (`magswarm::cosim::CoSimulation::run`), the `pid_tracking` harness, and next by the lab
//! and the bridge.

use std::io::Write;

use magswarm_log::{LogRow, LogWriter};

use crate::plant::{Inputs, PlantError, Reading, SwarmPlant};

/// What the controller commands from a sample on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    /// Inputs (SI).
    pub inputs: Inputs,
    /// Setpoints `[r1*, r2*]` [mm] for the log's `r1_ref_mm`, `r2_ref_mm` (None: not logged).
    pub reference_mm: Option<[f64; 2]>,
}

impl Command {
    /// Inputs in SI (z_m [m], omega_m [rad/s]), no setpoint.
    pub fn new(z_m: f64, omega_m: f64) -> Command {
        Command {
            inputs: Inputs::new(z_m, omega_m),
            reference_mm: None,
        }
    }

    /// Inputs in the log's units (z_m [mm], f [Hz]).
    pub fn from_mm_hz(z_mm: f64, f_hz: f64) -> Command {
        Command {
            inputs: Inputs::from_mm_hz(z_mm, f_hz),
            reference_mm: None,
        }
    }

    /// With setpoints [mm].
    pub fn with_reference_mm(mut self, r1: f64, r2: f64) -> Command {
        self.reference_mm = Some([r1, r2]);
        self
    }
}

/// What the controller sees at a sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Tick<'a> {
    /// Sample index since the start of the run.
    pub k: u64,
    /// The reading at this sample.
    pub reading: &'a Reading,
    /// Inputs in force up to now (the last command, or the plant's initial inputs).
    pub inputs: Inputs,
}

/// Where log rows go: a [`LogWriter`] (the contract's CSV), a `Vec<LogRow>`, [`FnSink`] (any
/// closure) or [`NoLog`].
pub trait LogSink {
    /// Take one row.
    fn write_row(&mut self, row: &LogRow) -> std::io::Result<()>;

    /// Whether the sink keeps rows at all: the driver builds a sample's row only for a sink
    /// that does (true unless the sink says otherwise; [`NoLog`] does not).
    #[inline]
    fn takes_rows(&self) -> bool {
        true
    }
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

    #[inline]
    fn takes_rows(&self) -> bool {
        false
    }
}

/// What a run did.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopSummary {
    /// Steps taken.
    pub steps: u64,
    /// The plant's time at the end [s].
    pub t_end_s: f64,
    /// The reading after the last step.
    pub last: Reading,
}

/// Why a run stopped early. The rows of the samples before have been written.
#[derive(Debug, thiserror::Error)]
pub enum LoopError {
    /// The plant failed at sample `k` (time `t_s`).
    #[error("{plant} at sample {k} (t = {t_s} s): {source}")]
    Plant {
        /// Which plant.
        plant: String,
        /// Sample index.
        k: u64,
        /// The plant's time [s].
        t_s: f64,
        /// What went wrong.
        #[source]
        source: PlantError,
    },
    /// The sink could not take a row.
    #[error("log: {0}")]
    Log(#[from] std::io::Error),
}

/// The log row of one sample: the reading at `t_s`, the command in force from then on.
pub fn log_row(reading: &Reading, cmd: &Command) -> LogRow {
    let mut row = LogRow::new(
        reading.t_s,
        cmd.inputs.z_mm(),
        cmd.inputs.f_hz(),
        reading.radii_mm(),
    );
    row.valid = reading.valid;
    if let Some(r) = cmd.reference_mm {
        row.r1_ref_mm = Some(r[0]);
        row.r2_ref_mm = Some(r[1]);
    }
    row
}

/// Run `steps` samples of read, control, log, step (`dt_s` each) on `plant`. Stops at the
/// first plant or sink error.
pub fn run_loop<P, C, S>(
    plant: &mut P,
    steps: u64,
    dt_s: f64,
    mut controller: C,
    sink: &mut S,
) -> Result<LoopSummary, LoopError>
where
    P: SwarmPlant + ?Sized,
    C: FnMut(&Tick<'_>) -> Command,
    S: LogSink + ?Sized,
{
    let fail = |plant: &P, k: u64, source: PlantError| LoopError::Plant {
        plant: plant.describe(),
        k,
        t_s: plant.time_s(),
        source,
    };
    let mut reading = plant.measure().map_err(|e| fail(plant, 0, e))?;
    for k in 0..steps {
        let cmd = controller(&Tick {
            k,
            reading: &reading,
            inputs: plant.inputs(),
        });
        if sink.takes_rows() {
            sink.write_row(&log_row(&reading, &cmd))?;
        }
        reading = plant
            .step(cmd.inputs, dt_s)
            .map_err(|e| fail(plant, k, e))?;
    }
    Ok(LoopSummary {
        steps,
        t_end_s: plant.time_s(),
        last: reading,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use magswarm_model::{hz_to_rad_s, Model, Plant};

    /// A plant that drops every third frame and faults at a set time: what a rig may do.
    struct Flaky {
        inner: Plant,
        fault_at_s: f64,
        n: u64,
    }

    impl SwarmPlant for Flaky {
        fn time_s(&self) -> f64 {
            self.inner.time()
        }
        fn inputs(&self) -> Inputs {
            SwarmPlant::inputs(&self.inner)
        }
        fn measure(&mut self) -> Result<Reading, PlantError> {
            self.n += 1;
            #[allow(clippy::manual_is_multiple_of)] // is_multiple_of needs Rust 1.87; MSRV 1.80
            if self.n % 3 == 0 {
                return Ok(Reading::invalid(self.inner.time()));
            }
            SwarmPlant::measure(&mut self.inner)
        }
        fn step(&mut self, u: Inputs, dt_s: f64) -> Result<Reading, PlantError> {
            if self.inner.time() + dt_s > self.fault_at_s {
                return Err(PlantError::Fault("safety stop".into()));
            }
            SwarmPlant::step(&mut self.inner, u, dt_s)?;
            self.measure()
        }
    }

    #[test]
    fn rows_follow_the_row_time_convention_and_invalid_readings_are_kept() {
        let mut p = Flaky {
            inner: Plant::new(Model::paper(), 0.0085, hz_to_rad_s(4.0)),
            fault_at_s: 10.0,
            n: 0,
        };
        let mut rows = Vec::new();
        let mut seen_invalid = 0;
        let sum = run_loop(
            &mut p,
            20,
            0.1,
            |t| {
                if !t.reading.valid {
                    seen_invalid += 1;
                }
                let z = if t.k < 10 { 8.5 } else { 12.0 };
                Command::from_mm_hz(z, 4.0).with_reference_mm(8.0, 11.0)
            },
            &mut rows,
        )
        .unwrap();
        assert_eq!(rows.len(), 20);
        assert_eq!(sum.steps, 20);
        assert!((sum.t_end_s - 2.0).abs() < 1e-12);
        assert_eq!(rows[0].t_s, 0.0);
        // The command issued at t_k is on the row of the reading at t_k.
        assert_eq!(rows[10].z_m_mm, 12.0);
        assert_eq!(rows[9].z_m_mm, 8.5);
        let invalid: Vec<_> = rows.iter().filter(|r| !r.valid).collect();
        assert_eq!(invalid.len(), seen_invalid);
        assert!(!invalid.is_empty() && invalid.iter().all(|r| r.r1_mm.is_none()));
        assert_eq!(rows[5].r1_ref_mm, Some(8.0));
    }

    #[test]
    fn a_fault_stops_the_loop_and_names_the_sample() {
        let mut p = Flaky {
            inner: Plant::new(Model::paper(), 0.0085, hz_to_rad_s(4.0)),
            fault_at_s: 0.25,
            n: 0,
        };
        let mut rows = Vec::new();
        let e = run_loop(
            &mut p,
            10,
            0.1,
            |_| Command::from_mm_hz(8.5, 4.0),
            &mut rows,
        )
        .unwrap_err();
        assert_eq!(rows.len(), 3, "rows before the fault are written");
        let msg = e.to_string();
        assert!(
            msg.contains("sample 2") && msg.contains("safety stop"),
            "{msg}"
        );
    }
}
