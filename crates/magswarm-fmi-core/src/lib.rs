//! The version-neutral core of magswarm's FMI shells: one model interface ([`FmuModel`]),
//! one variable table, and the logic of every call, for the FMI 2.0 shell
//! (`magswarm-fmi2`) and the FMI 3.0 shell (`magswarm-fmi3`) alike.
//!
//! An FMU is two things that must agree: a shared library exporting C functions, and a
//! `modelDescription.xml` describing its variables. A model implements [`FmuModel`] once
//! and describes its variables once ([`ModelInfo`]); each shell turns that into its
//! version's C symbols and XML. The split follows the Reference FMUs (`model.c` against
//! `fmi2Functions.c` / `fmi3Functions.c`): no type of either standard appears in this crate,
//! and no physics appears in the shells.
//!
//! Modules, one per job:
//! - [`variable`], [`info`]: the variable table and the static description;
//! - [`model`]: the [`FmuModel`] trait; [`status`]: [`Status`] and [`ModelError`];
//! - [`table`]: validation of the table, lookups by value reference;
//! - [`mode`]: the instance's modes and which variables may be set in which;
//! - [`log`]: the importer's logger behind a neutral sink, and [`Ctx`], the model's handle
//!   for warnings;
//! - [`instance`]: one instance and the logic of every call;
//! - [`snapshot`]: FMU states in memory and as bytes;
//! - [`barrier`]: the panic barrier; [`ffi`]: importer pointers to slices;
//! - [`mod@guid`]: the GUID / instantiation token both sides compute; [`uri`]: resource
//!   locations to paths; [`units`]: ready-made unit definitions; [`model::finite_difference`]: the
//!   finite-difference fallback; [`unload`]: one-time tables freed at `dlclose`;
//! - [`xml`]: the parts of `modelDescription.xml` that are the same in both versions.
//!
//! # Example: a gain `y = k u` as an FMU in both versions
//!
//! ```no_run
//! use magswarm_fmi_core::{units, Ctx, FmuModel, InstantiateArgs, ModelError, ModelInfo, VarType, Variable};
//!
//! #[derive(Clone)]
//! pub struct Gain { u: f64, k: f64 }
//!
//! /// What a serialized FMU state holds (the shell encodes and checks it).
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
//!     generation_tool: "magswarm-fmi-core",
//!     naming_convention: magswarm_fmi_core::NamingConvention::Flat,
//!     default_experiment: None,
//!     units: &[units::METRE, units::ONE],
//!     log_categories: &[],
//!     variables: &VARIABLES,
//! };
//!
//! impl FmuModel for Gain {
//!     fn model_info() -> &'static ModelInfo { &INFO }
//!     fn instantiate(_: &mut Ctx<'_>, _: &InstantiateArgs<'_>) -> Result<Self, ModelError> {
//!         Ok(Gain { u: 0.0, k: 2.0 })
//!     }
//!     fn step(&mut self, _: &mut Ctx<'_>, _t: f64, _h: f64) -> Result<(), ModelError> { Ok(()) }
//!     fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
//!         match vr { 0 => Ok(self.u), 1 => Ok(self.k * self.u), 2 => Ok(self.k),
//!                    _ => Err(ModelError::unknown_vr(VarType::Real, vr)) }
//!     }
//!     fn set_real(&mut self, ctx: &mut Ctx<'_>, vr: u32, x: f64) -> Result<(), ModelError> {
//!         match vr {
//!             0 => { if x.abs() > 1.0 { ctx.warning("u outside the validated range") } self.u = x }
//!             2 => self.k = x,
//!             _ => return Err(ModelError::unknown_vr(VarType::Real, vr)),
//!         }
//!         Ok(())
//!     }
//!     type State = GainState;
//!     fn save_state(&self) -> Result<GainState, ModelError> {
//!         Ok(GainState { u: self.u, k: self.k })
//!     }
//!     fn restore_state(&mut self, s: GainState) -> Result<(), ModelError> {
//!         if !s.k.is_finite() { return Err(ModelError::error("state: gain k must be finite")) }
//!         (self.u, self.k) = (s.u, s.k);
//!         Ok(())
//!     }
//! }
//! ```
//!
//! In the FMU's cdylib crate, `magswarm_fmi2::export_fmi2!(Gain);` and
//! `magswarm_fmi3::export_fmi3!(Gain);` emit every `fmi2*` and `fmi3*` symbol into the same
//! library; packaging writes `magswarm_fmi2::model_description_xml::<Gain>(..)` or
//! `magswarm_fmi3::model_description_xml::<Gain>(..)` beside it.
//!
//! Panics never cross the C boundary: every entry point runs under [`barrier::barrier`]
//! (so the FMU must be built with `panic = "unwind"`, which the workspace profile sets).

#![warn(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]

pub mod barrier;
pub mod describe;
pub mod ffi;
pub mod guid;
pub mod info;
pub mod instance;
pub mod log;
pub mod mode;
pub mod model;
pub mod recorder;
pub mod snapshot;
pub mod status;
pub mod table;
pub mod units;
pub mod unload;
pub mod uri;
pub mod variable;
pub mod xml;

/// How far a communication point (or an event time) may be from the instance's time
/// (relative to max(1, |t|)) before a step is refused: generous enough for importers that
/// compute `t = t0 + n*h` instead of summing steps, tight enough to catch a skipped or
/// repeated step.
pub const TIME_TOLERANCE: f64 = 1e-9;

pub use guid::guid;
pub use info::{
    BaseUnit, DefaultExperiment, DisplayUnit, LogCategory, ModelInfo, NamingConvention,
    UnitDefinition,
};
pub use instance::{create, Capability, Instance, Interface, Request};
pub use log::Ctx;
pub use mode::Mode;
pub use model::{FmuModel, InstantiateArgs};
pub use status::{ModelError, Refusal, Status};
pub use variable::{fmt_real, Causality, Initial, Start, VarType, Variability, Variable};
pub use xml::{Capabilities, XmlOptions};
