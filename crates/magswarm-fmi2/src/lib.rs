//! A generic FMI 2.0 export shell: Co-Simulation, and Model Exchange for models that opt in
//! ([`FmuModel::MODEL_EXCHANGE`]; both interfaces in one binary and one XML).
//!
//! An FMU is two things that must agree: a shared library exporting the `fmi2*` C
//! functions, and a `modelDescription.xml` describing its variables. This crate makes both
//! from one Rust description of a model, so they cannot disagree, and keeps every piece of
//! FMI plumbing (pointer checks, the state machine, logging, FMU state, panics) in one
//! place, out of the physics. The split follows the Reference FMUs (`model.c` vs
//! `fmi2Functions.c`): the model implements [`FmuModel`]; the FMU crate invokes
//! [`export_fmi2!`]; packaging calls [`model_description_xml`].
//!
//! Modules, one per job:
//! - [`abi`]: the C types of the standard;
//! - [`model`]: the variable table and the [`FmuModel`] trait;
//! - [`table`]: validation of the table against FMI 2.0 rules, lookups by value reference;
//! - [`state`]: the Co-Simulation and Model Exchange state machine and causality rules for
//!   setters;
//! - [`log`]: the importer's logger and [`Ctx`], the model's handle for warnings;
//! - [`instance`]: one instance and the logic of every call;
//! - [`shell`]: the generic `unsafe fn` entry points (pointers, state checks, panic barrier);
//! - [`export`]: [`export_fmi2!`], the `#[no_mangle] extern "C"` forwarders;
//! - [`snapshot`]: FMU states in memory and as bytes (the model's serde state type, framed
//!   with a version and a checksum);
//! - [`xml`]: `modelDescription.xml`; [`mod@guid`]: the GUID both sides compute;
//! - [`uri`]: `fmuResourceLocation` to a path; [`units`]: ready-made unit definitions;
//! - [`jacobian`]: the finite-difference fallback for directional derivatives.
//!
//! # Example: a gain `y = k u` as an FMU
//!
//! ```no_run
//! use magswarm_fmi2::{units, Ctx, Fmi2Err, FmuModel, InstantiateArgs, ModelInfo, VarType, Variable};
//!
//! #[derive(Clone)]
//! pub struct Gain { u: f64, k: f64 }
//!
//! /// What `fmi2SerializeFMUstate` saves (the shell encodes and checks it).
//! #[derive(serde::Serialize, serde::Deserialize)]
//! pub struct GainState { u: f64, k: f64 }
//!
//! static VARIABLES: [Variable; 3] = [
//!     Variable::real("u", 0).input().start_real(0.0).unit("m").display_unit("mm"),
//!     Variable::real("y", 1).output().unit("m").display_unit("mm").depends_on(&[0]),
//!     Variable::real("k", 2).tunable_parameter().start_real(2.0).unit("1"),
//! ];
//!
//! static INFO: ModelInfo = ModelInfo {
//!     model_identifier: "Gain", // the binary must be binaries/<platform>/Gain.so
//!     model_name: "Gain",
//!     description: "y = k u",
//!     version: env!("CARGO_PKG_VERSION"),
//!     author: "",
//!     copyright: None,
//!     license: None,
//!     generation_tool: "magswarm-fmi2",
//!     naming_convention: magswarm_fmi2::NamingConvention::Flat,
//!     default_experiment: None,
//!     units: &[units::METRE, units::ONE],
//!     log_categories: &[],
//!     variables: &VARIABLES,
//! };
//!
//! impl FmuModel for Gain {
//!     fn model_info() -> &'static ModelInfo { &INFO }
//!     fn instantiate(_: &mut Ctx<'_>, _: &InstantiateArgs<'_>) -> Result<Self, Fmi2Err> {
//!         Ok(Gain { u: 0.0, k: 2.0 })
//!     }
//!     fn do_step(&mut self, _: &mut Ctx<'_>, _t: f64, _h: f64) -> Result<(), Fmi2Err> { Ok(()) }
//!     fn get_real(&mut self, vr: u32) -> Result<f64, Fmi2Err> {
//!         match vr { 0 => Ok(self.u), 1 => Ok(self.k * self.u), 2 => Ok(self.k),
//!                    _ => Err(Fmi2Err::unknown_vr(VarType::Real, vr)) }
//!     }
//!     fn set_real(&mut self, ctx: &mut Ctx<'_>, vr: u32, x: f64) -> Result<(), Fmi2Err> {
//!         match vr {
//!             0 => { if x.abs() > 1.0 { ctx.warning("u outside the validated range") } self.u = x }
//!             2 => self.k = x,
//!             _ => return Err(Fmi2Err::unknown_vr(VarType::Real, vr)),
//!         }
//!         Ok(())
//!     }
//!     type State = GainState;
//!     fn save_state(&self) -> Result<GainState, Fmi2Err> {
//!         Ok(GainState { u: self.u, k: self.k })
//!     }
//!     fn restore_state(&mut self, s: GainState) -> Result<(), Fmi2Err> {
//!         if !s.k.is_finite() { return Err(Fmi2Err::error("state: gain k must be finite")) }
//!         (self.u, self.k) = (s.u, s.k);
//!         Ok(())
//!     }
//! }
//!
//! // In the cdylib crate: every fmi2* symbol.
//! magswarm_fmi2::export_fmi2!(Gain);
//!
//! fn main() {
//!     // In packaging: the XML that goes next to the binary.
//!     let xml = magswarm_fmi2::model_description_xml::<Gain>(&Default::default());
//!     std::fs::write("modelDescription.xml", xml).unwrap();
//! }
//! ```
//!
//! Panics never cross the C boundary: every entry point runs under `catch_unwind` (so the
//! FMU must be built with `panic = "unwind"`, which the workspace profile sets).

#![warn(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]

pub mod abi;
pub mod export;
pub mod guid;
pub mod host;
pub mod instance;
pub mod jacobian;
pub mod log;
pub mod model;
pub mod shell;
pub mod snapshot;
pub mod state;
pub mod table;
pub mod units;
pub mod unload;
pub mod uri;
pub mod xml;

pub use abi::Fmi2Status;
pub use guid::guid;
pub use log::Ctx;
pub use model::{
    BaseUnit, Causality, DefaultExperiment, DisplayUnit, Fmi2Err, FmuModel, Initial,
    InstantiateArgs, LogCategory, ModelInfo, NamingConvention, Start, UnitDefinition, VarType,
    Variability, Variable,
};
pub use state::Mode;
pub use xml::{model_description_xml, try_model_description_xml, XmlOptions};
