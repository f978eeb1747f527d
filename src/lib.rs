//! magswarm: a reduced-order model of magnetic microparticle swarms as software.
//!
//! This package is the `magswarm` program (`src/main.rs` and `src/cli/`: argument parsing and
//! the calls into the library crates; nothing in a library sees its argument types) and a thin
//! facade that re-exports the library crates at their module paths, one job each:
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
//! - [`cosim`] (`magswarm-cosim`): the FMU importer (FMI 2.0 and 3.0), as external tools run
//!   FMUs; the FMUs themselves are `magswarm-fmu` and `magswarm-pid-fmu` behind the FMI 2.0
//!   and 3.0 shells of `magswarm-fmi`.
//!
//! - [`packaging`] (`magswarm-packaging`): what goes into the `.fmu` archives.
//! - [`diagnose`] (`magswarm-diagnose`): the sim-to-real gap report;
//! - [`lab`] (`magswarm-lab`): the virtual lab, synthetic logs with unmodelled effects.
//!
//! The one module of this package is [`perf`], the harness the benchmarks and `perf_table`
//! share.

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

/// The importer side (crate `magswarm-cosim`): run packaged FMUs as external tools do.
pub use magswarm_cosim as cosim;
pub use magswarm_diagnose as diagnose;
pub use magswarm_lab as lab;
/// The `.fmu` archives (crate `magswarm-packaging`).
pub use magswarm_packaging as packaging;
pub mod perf;
