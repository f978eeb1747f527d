//! magswarm: a reduced-order model of magnetic microparticle swarms as software.
//!
//! The physics lives in [`model`] (crate `magswarm-model`, no FFI); the FMU is the crate
//! `magswarm-fmu` (a generic FMI 2.0 shell from `magswarm-fmi2` over the plant); control
//! lives in [`control`]. This crate adds what works on files: the measurement log, the
//! paper figures, identification, prediction, packaging, plots.

pub use magswarm_control as control;
pub use magswarm_model as model;

pub mod control_cli;
pub mod cosim;
pub mod identify;
pub mod log;
pub mod packaging;
pub mod paper;
pub mod perf;
pub mod plot;
pub mod predict;
pub mod sweep;
