//! `magswarm sweep`: Monte Carlo of the seed's closed-loop tracking scenario under parameter
//! uncertainty, on one machine (rayon). `examples/sweep_dask.py` runs the same study on
//! dask.distributed through the FMUs; both give the same draws and the same results for the
//! same `--runs` and `--seed`, whatever the number of threads or workers.
//!
//! One run: the plant is the nominal model (`--model`, default the paper model) with the
//! uncertain parameters replaced by this run's draws; the controller is the decoupled PID of
//! `magswarm-control` with its default configuration, designed on the nominal model (it does
//! not know the draws: that is the robustness question). The scenario is the seed's
//! (r1* = 7, 8, 9 mm with r2* = 11 mm, 60 s each), starting formed at 8.5 mm, 4 Hz. The loop
//! is the co-simulation loop of `examples/pid_tracking.rs` / `pid_tracking.py`, arithmetic
//! included: radii and setpoints cross the FMI interface in metres, so they are converted to
//! m and back here exactly as the FMUs do, and the Python side reproduces every bit.
//!
//! Tracking error: `rmse_ri_mm = sqrt(mean over samples of (r_i - r_i*)^2)` against the
//! setpoint (the seed's setpoints are partly unreachable, so even the nominal plant has a
//! floor; the spread across runs is what the study shows).
//!
//! Uncertainty, in this order of precedence:
//! - `--uncertainty U.json`, or an `"uncertainty"` member of the model file (the member is
//!   removed before the model itself is read):
//!   `{"ranges": {"C_1": [lo, hi], ...}}` (uniform) or
//!   `{"names": [...], "mean": [...] (optional: the model's values), "cov": [[...], ...]}`
//!   (normal, e.g. identify's Jacobian covariance of the listed parameters);
//! - otherwise [`default_ranges`]: C_1, C_2, alpha_1, alpha_2 within +-10 % and K_tau within
//!   +-30 % of the model's values (uniform).
//!
//! Draws: [`draws`] (counter-based SplitMix64 + Box-Muller, no generator state).

pub mod draws;

use std::path::Path;

use magswarm_control::ConfigError;
use magswarm_model::{ModelError, StepError};

/// Why a sweep cannot run, or one of its runs failed.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The uncertainty description is not usable (the message names the file and field).
    #[error("{0}")]
    Uncertainty(String),
    /// A file cannot be read or written.
    #[error("{what}: {err}")]
    Io {
        /// What was done, with the path.
        what: String,
        /// The cause.
        err: std::io::Error,
    },
    /// A file is not the JSON it should be.
    #[error("{what}: {err}")]
    Json {
        /// Which file, with the path.
        what: String,
        /// The cause.
        err: serde_json::Error,
    },
    /// The results file cannot be written.
    #[error("cannot write {path}: {err}")]
    Csv {
        /// The path.
        path: String,
        /// The cause.
        err: csv::Error,
    },
    /// A model (nominal, or with a run's draws) is not valid.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The controller's configuration is not valid.
    #[error(transparent)]
    Controller(#[from] ConfigError),
    /// The plant could not be integrated.
    #[error("plant integration at t = {t:.2} s: {err}")]
    Step {
        /// Scenario time \[s\].
        t: f64,
        /// The integrator's reason.
        err: StepError,
    },
    /// No thread pool.
    #[error("cannot start the thread pool: {0}")]
    ThreadPool(#[from] rayon::ThreadPoolBuildError),
}

type Result<T, E = SweepError> = std::result::Result<T, E>;

/// Refuse an uncertainty description.
macro_rules! bail {
    ($($t:tt)*) => {
        return Err(SweepError::Uncertainty(format!($($t)*)))
    };
}
use magswarm_control::{seed_scenario, Controller, PidConfig, Segment};
use magswarm_model::{registry, Model, Plant};
use rayon::prelude::*;
use serde::Deserialize;

/// Where the scenario starts: formed at 8.5 mm, 4 Hz (z_m \[m\], omega [rad/s]).
pub const START: (f64, f64) = magswarm_control::sim::SEED_START;

/// Parameter uncertainty of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub enum Uncertainty {
    /// Independent uniform draws in [lo, hi].
    Ranges(Vec<(String, f64, f64)>),
    /// Multivariate normal: mean + L z, L the lower Cholesky factor of the covariance.
    Normal {
        /// Parameter names.
        names: Vec<String>,
        /// Mean.
        mean: Vec<f64>,
        /// Lower Cholesky factor of the covariance.
        chol: Vec<Vec<f64>>,
    },
}

/// The documented default: C_1, C_2, alpha_1, alpha_2 +-10 %, K_tau +-30 % around `model`.
pub fn default_ranges(model: &Model) -> Uncertainty {
    let spec = [
        ("C_1", 0.10),
        ("C_2", 0.10),
        ("alpha_1", 0.10),
        ("alpha_2", 0.10),
        ("K_tau", 0.30),
    ];
    Uncertainty::Ranges(
        spec.iter()
            .map(|&(n, rel)| {
                let v = param(model, n);
                (n.to_string(), v * (1.0 - rel), v * (1.0 + rel))
            })
            .collect(),
    )
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct UncertaintyFile {
    #[serde(default)]
    ranges: Option<std::collections::BTreeMap<String, [f64; 2]>>,
    #[serde(default)]
    names: Option<Vec<String>>,
    #[serde(default)]
    mean: Option<Vec<f64>>,
    #[serde(default)]
    cov: Option<Vec<Vec<f64>>>,
}

/// A parameter the uncertainty may name: an FMU parameter of the registry (what the FMU-based
/// runs of the same study can set).
fn check_name(name: &str, place: &str) -> Result<()> {
    if registry::fmu_params().any(|p| p.name == name) {
        Ok(())
    } else {
        bail!(
            "{place}: unknown parameter {name:?} (one of: {})",
            registry::fmu_params()
                .map(|p| p.name)
                .collect::<Vec<_>>()
                .join(", ")
        )
    }
}

/// A parameter's value in a model, by registry name (names are checked when read).
fn param(model: &Model, name: &str) -> f64 {
    registry::find(name).map_or(f64::NAN, |p| (p.get)(model))
}

/// Write a parameter, by registry name.
fn set_param(model: &mut Model, name: &str, v: f64) {
    if let Some(p) = registry::find(name) {
        (p.set)(model, v);
    }
}

impl Uncertainty {
    /// Read the uncertainty JSON (see the module documentation); `model` supplies a missing
    /// mean. `place` names the file in errors.
    pub fn from_json(v: serde_json::Value, model: &Model, place: &str) -> Result<Uncertainty> {
        let f: UncertaintyFile = serde_json::from_value(v).map_err(|err| SweepError::Json {
            what: format!("{place}: uncertainty"),
            err,
        })?;
        match (f.ranges, f.names, f.cov) {
            (Some(r), None, None) => {
                if r.is_empty() {
                    bail!("{place}: uncertainty.ranges is empty");
                }
                let mut out = Vec::new();
                for (n, [lo, hi]) in r {
                    check_name(&n, place)?;
                    if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                        bail!("{place}: uncertainty.ranges.{n} = [{lo}, {hi}] is not a range");
                    }
                    out.push((n, lo, hi));
                }
                Ok(Uncertainty::Ranges(out))
            }
            (None, Some(names), Some(cov)) => {
                if names.is_empty() || cov.len() != names.len() {
                    bail!(
                        "{place}: uncertainty.cov must be {0} x {0} for {0} names",
                        names.len()
                    );
                }
                for n in &names {
                    check_name(n, place)?;
                }
                let mean = match f.mean {
                    Some(m) if m.len() == names.len() => m,
                    Some(m) => bail!(
                        "{place}: uncertainty.mean has {} entries for {} names",
                        m.len(),
                        names.len()
                    ),
                    None => names.iter().map(|n| param(model, n)).collect(),
                };
                let chol = draws::cholesky(&cov)
                    .map_err(|e| SweepError::Uncertainty(format!("{place}: {e}")))?;
                Ok(Uncertainty::Normal { names, mean, chol })
            }
            _ => bail!(
                "{place}: uncertainty needs either \"ranges\" or \"names\" + \"cov\" (not both)"
            ),
        }
    }

    /// Parameter names, in draw order (= CSV column order).
    pub fn names(&self) -> Vec<String> {
        match self {
            Uncertainty::Ranges(r) => r.iter().map(|x| x.0.clone()).collect(),
            Uncertainty::Normal { names, .. } => names.clone(),
        }
    }

    /// The draws of run `run` for `seed`.
    pub fn draw(&self, seed: u64, run: u64) -> Vec<f64> {
        match self {
            Uncertainty::Ranges(r) => r
                .iter()
                .enumerate()
                .map(|(i, (_, lo, hi))| lo + (hi - lo) * draws::uniform(seed, run, 2 * i as u64))
                .collect(),
            Uncertainty::Normal { mean, chol, .. } => {
                let z: Vec<f64> = (0..mean.len())
                    .map(|i| draws::normal(seed, run, i as u64))
                    .collect();
                (0..mean.len())
                    .map(|i| {
                        let mut v = mean[i];
                        for k in 0..=i {
                            v += chol[i][k] * z[k];
                        }
                        v
                    })
                    .collect()
            }
        }
    }
}

/// The model and uncertainty named on the command line.
pub fn load(model: Option<&Path>, uncertainty: Option<&Path>) -> Result<(Model, Uncertainty)> {
    let (model, embedded) = match model {
        None => (Model::paper(), None),
        Some(p) => {
            let text = std::fs::read_to_string(p).map_err(|err| SweepError::Io {
                what: format!("cannot read --model {}", p.display()),
                err,
            })?;
            let mut v: serde_json::Value =
                serde_json::from_str(&text).map_err(|err| SweepError::Json {
                    what: format!("--model {}: not JSON", p.display()),
                    err,
                })?;
            let unc = v.as_object_mut().and_then(|o| o.remove("uncertainty"));
            let m = Model::from_json_str(&v.to_string(), &p.display().to_string())?;
            (m, unc)
        }
    };
    let unc = match (uncertainty, embedded) {
        (Some(p), _) => {
            let text = std::fs::read_to_string(p).map_err(|err| SweepError::Io {
                what: format!("cannot read --uncertainty {}", p.display()),
                err,
            })?;
            let v = serde_json::from_str(&text).map_err(|err| SweepError::Json {
                what: format!("--uncertainty {}: not JSON", p.display()),
                err,
            })?;
            Uncertainty::from_json(v, &model, &p.display().to_string())?
        }
        (None, Some(v)) => Uncertainty::from_json(v, &model, "--model (uncertainty member)")?,
        (None, None) => default_ranges(&model),
    };
    Ok((model, unc))
}

/// One run's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct RunResult {
    /// Run index.
    pub run: u64,
    /// The drawn parameters (order of [`Uncertainty::names`]).
    pub params: Vec<f64>,
    /// RMS tracking error against the setpoint \[mm\] for r1, r2 (NaN if the run failed).
    pub rmse_mm: [f64; 2],
    /// Largest |r_i - r_i*| over the last 10 s of each segment \[mm\] (NaN if failed).
    pub final_err_mm: f64,
    /// Why the run failed ("" when it did not).
    pub error: String,
}

/// The closed-loop scenario with the plant `plant_model` and the controller designed on
/// `nominal`; returns (rmse r1, rmse r2, worst error over the last 10 s of each segment) \[mm\].
pub fn track(
    nominal: &Model,
    plant_model: Model,
    cfg: &PidConfig,
    segments: &[Segment],
) -> Result<([f64; 2], f64)> {
    let ts = cfg.sample_time_s;
    let mut plant = Plant::new(plant_model, START.0, START.1);
    let mut ctrl = Controller::new(nominal.clone(), cfg.clone())?;
    let mut sum = [0.0f64; 2];
    let mut n = 0usize;
    let mut tail: f64 = 0.0;
    let mut k = 0usize;
    for seg in segments {
        let count = (seg.duration_s / ts).round() as usize;
        let tail_from = count.saturating_sub((10.0 / ts).round() as usize);
        // The setpoint as the controller FMU sees it (set in m, read back in mm).
        let sp = [(seg.r1 * 1e-3) * 1e3, (seg.r2 * 1e-3) * 1e3];
        for i in 0..count {
            // The plant's radii as an FMI master reads them (m) and the controller uses them (mm).
            let r = plant.observed_radii();
            let y = [(r[0] * 1e-3) * 1e3, (r[1] * 1e-3) * 1e3];
            if k == 0 {
                ctrl.reset(START.0, START.1, y);
            }
            let e = [y[0] - seg.r1, y[1] - seg.r2];
            sum[0] += e[0] * e[0];
            sum[1] += e[1] * e[1];
            n += 1;
            if i >= tail_from {
                tail = tail.max(e[0].abs()).max(e[1].abs());
            }
            let (z, w) = ctrl.step(y, sp);
            plant.set_inputs(z, w);
            plant.step(ts).map_err(|err| SweepError::Step {
                t: k as f64 * ts,
                err,
            })?;
            k += 1;
        }
    }
    let nf = n as f64;
    Ok(([(sum[0] / nf).sqrt(), (sum[1] / nf).sqrt()], tail))
}

/// Settings of a sweep.
#[derive(Debug, Clone)]
pub struct Sweep {
    /// Nominal model (the controller's, and the plant's apart from the draws).
    pub model: Model,
    /// What is drawn.
    pub uncertainty: Uncertainty,
    /// Controller configuration.
    pub pid: PidConfig,
    /// Setpoint segments.
    pub segments: Vec<Segment>,
}

impl Sweep {
    /// The seed's scenario with the default controller.
    pub fn new(model: Model, uncertainty: Uncertainty) -> Sweep {
        Sweep {
            model,
            uncertainty,
            pid: PidConfig::default(),
            segments: seed_scenario(),
        }
    }

    /// Run `run` of `seed`.
    pub fn run_one(&self, seed: u64, run: u64) -> RunResult {
        let params = self.uncertainty.draw(seed, run);
        let mut m = self.model.clone();
        for (n, v) in self.uncertainty.names().iter().zip(&params) {
            set_param(&mut m, n, *v);
        }
        let outcome = m
            .validate()
            .map_err(SweepError::from)
            .and_then(|_| track(&self.model, m, &self.pid, &self.segments));
        match outcome {
            Ok((rmse, tail)) => RunResult {
                run,
                params,
                rmse_mm: rmse,
                final_err_mm: tail,
                error: String::new(),
            },
            Err(e) => RunResult {
                run,
                params,
                rmse_mm: [f64::NAN; 2],
                final_err_mm: f64::NAN,
                error: e.to_string(),
            },
        }
    }

    /// Runs 0..runs on `threads` threads (0: rayon's default), in run order; `tick` is
    /// called once per finished run (from any thread).
    pub fn run_all(
        &self,
        seed: u64,
        runs: u64,
        threads: usize,
        tick: &(dyn Fn() + Sync),
    ) -> Result<Vec<RunResult>> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()?;
        Ok(pool.install(|| {
            (0..runs)
                .into_par_iter()
                .map(|r| {
                    let out = self.run_one(seed, r);
                    tick();
                    out
                })
                .collect()
        }))
    }
}

/// Write the results: `run,rmse_r1_mm,rmse_r2_mm,final_err_mm,<parameters...>,error`.
pub fn write_csv(path: &Path, names: &[String], results: &[RunResult]) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|err| SweepError::Io {
            what: format!("cannot create {}", dir.display()),
            err,
        })?;
    }
    let csv_err = |err| SweepError::Csv {
        path: path.display().to_string(),
        err,
    };
    let mut w = csv::Writer::from_path(path).map_err(csv_err)?;
    let mut header = vec![
        "run".to_string(),
        "rmse_r1_mm".into(),
        "rmse_r2_mm".into(),
        "final_err_mm".into(),
    ];
    header.extend(names.iter().cloned());
    header.push("error".into());
    w.write_record(&header).map_err(csv_err)?;
    for r in results {
        let mut row = vec![
            r.run.to_string(),
            format!("{:?}", r.rmse_mm[0]),
            format!("{:?}", r.rmse_mm[1]),
            format!("{:?}", r.final_err_mm),
        ];
        row.extend(r.params.iter().map(|v| format!("{v:?}")));
        row.push(r.error.clone());
        w.write_record(&row).map_err(csv_err)?;
    }
    w.flush().map_err(|err| SweepError::Io {
        what: format!("cannot write {}", path.display()),
        err,
    })?;
    Ok(())
}
