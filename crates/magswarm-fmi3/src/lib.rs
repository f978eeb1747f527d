//! The FMI 3.0 export shell: Co-Simulation, and Model Exchange for models that opt in
//! ([`magswarm_fmi_core::FmuModel::MODEL_EXCHANGE`]), over the version-neutral model
//! interface of [`magswarm_fmi_core`] that the FMI 2.0 shell (`magswarm-fmi2`) uses too.
//!
//! The FMU crate invokes [`export_fmi3!`] (beside `magswarm_fmi2::export_fmi2!`: one
//! library serves both versions) and packaging writes [`model_description_xml`] with the
//! binary under `binaries/<arch>-<os>/` (FMI 3.0's platform tuple, e.g. `x86_64-linux`).
//!
//! What FMI 3.0 adds and how this shell answers it: `Float64` variables with units and
//! display units; FMU state and serialization; directional *and adjoint* derivatives (both
//! from the model's one [`magswarm_fmi_core::FmuModel::jacobian`]); variable dependencies
//! from the table; the independent variable `time`, which FMI 3.0 requires, added to the
//! table if the model has none ([`magswarm_fmi_core::table::with_independent_time`]) and
//! answered by the shell. Not offered (each refused with `fmi3Error` and the reason):
//! Scheduled Execution, clocks, structural parameters, event mode and intermediate update in
//! Co-Simulation, variables of other types than Float64, Int32, Boolean and String.
//!
//! Modules: [`abi`] (C types), [`state`] (FMI 3.0's state machine), [`shell`] (entry
//! points), [`export`] ([`export_fmi3!`]), [`xml`] (modelDescription.xml), [`host`] (an
//! in-process importer for tests, fuzzing and benchmarks).

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

pub use xml::{model_description_xml, try_model_description_xml, XmlOptions};
