//! magswarm: a reduced-order model of magnetic microparticle swarms as software.
//!
//! This package is the `magswarm` program ([`cli`]: argument parsing and the calls into the
//! library crates) and a thin facade that re-exports the library crates at their module paths,
//! one job each:
//!
//! - [`model`] (`magswarm-model`): the physics, effects, model file and parameter registry;
//! - [`control`] (`magswarm-control`): the plant trait, the closed loop, the PID;
//! - [`log`] (`magswarm-log`): the one measurement-log format;
//! - [`identify`] and [`predict`] (`magswarm-identify`): fitting a model to logs, replaying
//!   logs through a model;
//! - [`optim`] and [`lm`] (`magswarm-fit`): the one Levenberg-Marquardt problem, Nelder-Mead;
//! - [`paper`] (`magswarm-paper`): the seed's figures and table;
//! - [`sweep`] (`magswarm-sweep`): Monte Carlo of the seed's tracking scenario;
//! - [`plot`] and [`report`] (`magswarm-report`): every plot and report.
//!
//! The modules still in this package are `diagnose`, `lab`, `cosim` (the FMU importer),
//! `perf`, `packaging`, `control_cli` and `outputs`.

pub use magswarm_control as control;
pub use magswarm_fit::{lm, optim};
pub use magswarm_identify as identify;
pub use magswarm_identify::predict;
/// The measurement log (crate `magswarm-log`), kept at `magswarm::log` for existing paths.
pub use magswarm_log as log;
pub use magswarm_model as model;
pub use magswarm_paper as paper;
pub use magswarm_report as report;
pub use magswarm_report::plot;
pub use magswarm_sweep as sweep;

pub mod cli;
pub mod control_cli;
pub mod cosim;
pub mod diagnose;
pub mod lab;
pub mod outputs;
pub mod packaging;
pub mod perf;
