//! magswarm: a reduced-order model of magnetic microparticle swarms as software.
//!
//! The physics lives in [`model`] (crate `magswarm-model`, no FFI); the FMU is the crate
//! `magswarm-fmu` (the plant behind the FMI 2.0 and 3.0 shells of `magswarm-fmi`); control
//! lives in [`control`]. The measurement log is [`log`] (crate
//! `magswarm-log`). This crate adds what works on files: the
//! paper figures, identification, prediction, packaging, plots.

pub use magswarm_control as control;
/// The measurement log (crate `magswarm-log`), kept at `magswarm::log` for existing paths.
pub use magswarm_log as log;
pub use magswarm_model as model;

pub mod cli;
pub mod control_cli;
/// The importer side (crate `magswarm-cosim`): run packaged FMUs as external tools do.
pub use magswarm_cosim as cosim;
pub mod diagnose;
pub mod identify;
pub mod lab;
pub mod optim;
pub mod outputs;
pub mod packaging;
pub mod paper;
pub mod perf;
pub mod plot;
pub mod predict;
pub mod sweep;
