//! The FMI 2.0 export shell: Co-Simulation, and Model Exchange for models that opt in
//! ([`FmuModel::MODEL_EXCHANGE`]; both interfaces in one binary and one XML), over the
//! version-neutral model interface of [`magswarm_fmi_core`].
//!
//! A model implements [`FmuModel`] (see the core's example); the FMU crate invokes
//! [`export_fmi2!`] for the `fmi2*` C symbols, and packaging calls
//! [`model_description_xml`]. Everything here is FMI 2.0's C types and rules; the logic of
//! the calls (checks, FMU states, the model hooks) is the core's, shared with the FMI 3.0
//! shell (`magswarm-fmi3`).
//!
//! Modules, one per job:
//! - [`abi`]: the C types of the standard;
//! - [`state`]: which function is allowed in which mode (FMI 2.0's tables);
//! - [`shell`]: the generic `unsafe fn` entry points (pointers, state checks, panic barrier);
//! - [`export`]: [`export_fmi2!`], the `#[no_mangle] extern "C"` forwarders;
//! - [`xml`]: `modelDescription.xml` (FMI 2.0);
//! - [`host`]: an in-process importer for tests, fuzzing and benchmarks.
//!
//! The core's names are re-exported here, so a model written against the FMI 2.0-only
//! shell of earlier versions needs only the renames listed in `docs/fmi.md`.

#![warn(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]

pub mod abi;
pub mod export;
pub mod host;
pub mod shell;
pub mod state;
pub mod xml;

#[doc(hidden)]
pub use magswarm_fmi_core;
/// `fmu_model_description` / `fmu_free_string`, which packaging calls for the XML.
pub use magswarm_fmi_core::export_describe;

pub use abi::Fmi2Status;
pub use magswarm_fmi_core::{
    guid, units, unload, BaseUnit, Causality, Ctx, DefaultExperiment, DisplayUnit, FmuModel,
    Initial, InstantiateArgs, LogCategory, ModelError, ModelInfo, NamingConvention, Start, Status,
    UnitDefinition, VarType, Variability, Variable,
};
pub use state::Mode;
pub use xml::{model_description_xml, try_model_description_xml, XmlOptions};
