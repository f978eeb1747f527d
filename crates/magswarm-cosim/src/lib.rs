//! The importer side of co-simulation: run a packaged `.fmu` (FMI 2.0 or 3.0 Co-Simulation)
//! exactly as an external tool would, never through the model's Rust functions.
//!
//! - [`Fmu::load`] unpacks the archive into a temporary directory, parses
//!   `modelDescription.xml` and loads `binaries/<platform>/<modelIdentifier>.so` (`linux64`
//!   for FMI 2.0, `x86_64-linux` for FMI 3.0; the `fmi` crate's import types with its `fmi2`
//!   and `fmi3` features; see [`Fmu`]). Variables are resolved by name from the XML
//!   ([`Fmu::variable`], [`Fmu::real_vr`]); no value reference is hard-coded here.
//! - [`FmuSlave`] is one instance behind a safe API: instantiate with a logger that captures
//!   the FMU's messages ([`LogMessage`]: status, category, message), setup/enter/exit
//!   initialisation, get/set values by name or value reference, `do_step`, `reset`, FMU state
//!   get/set/free and (de)serialisation, directional derivatives, `terminate`; dropping it
//!   frees it. Failing calls give [`CosimError::Fmi`] with the FMI function, the status and
//!   what the FMU logged.
//! - [`CoSimulation`] is one FMU as a plant ([`magswarm_control::plant::SwarmPlant`]), so the
//!   one closed-loop driver ([`magswarm_control::driver::run_loop`]) runs it: each
//!   communication step reads the outputs, asks a controller for the inputs, writes one row
//!   of the measurement log (docs/log-format.md) to a [`LogSink`], sets the inputs and calls
//!   `doStep`. [`CoSimulation::run`] is that loop with a closure over [`Measurement`].
//!
//! ```no_run
//! use magswarm_cosim::{Fmu, SlaveOptions};
//!
//! let fmu = Fmu::load("target/fmu/MagSwarm.fmu")?;
//! let mut s = fmu.instantiate("a", SlaveOptions::default())?;
//! s.setup_experiment(None, 0.0, None)?;
//! s.enter_initialization_mode()?;
//! s.set_real_by_name("z_m", 8.5e-3)?;
//! s.exit_initialization_mode()?;
//! let (r1, r2) = (s.get_real_by_name("r1")?, s.get_real_by_name("r2")?);
//! s.set_real_by_name("z_m", 13.5e-3)?;
//! s.do_step(0.0, 0.01)?;
//! let state = s.get_state()?;
//! let bytes = s.serialize_state(&state)?;
//! s.free_state(state)?;
//! # let _ = (r1, r2, bytes);
//! # Ok::<(), magswarm_cosim::CosimError>(())
//! ```

/// Push the name of every symbol the binding `$b` failed to load onto `$missing`.
macro_rules! check_symbols {
    ($b:expr, $missing:expr, $($sym:ident),* $(,)?) => {
        $( if $b.$sym.is_err() { $missing.push(stringify!($sym)); } )*
    };
}
pub(crate) use check_symbols;

mod error;
pub mod extract;
mod import;
mod runner;
mod slave;

pub use error::{CosimError, Result, Status};
/// The `fmi` crate this importer is built on (its raw bindings name [`Api`]'s function types).
pub use fmi;
pub use import::{Capabilities, Causality, Fmu, Start, VarType, Variable};
pub use magswarm_fmi::FmiVersion;
pub use runner::{
    CoSimConfig, CoSimulation, Command, FnSink, LogSink, Measurement, NoLog, ParamValue, RunSummary,
};
pub use slave::{Api, FmuSlave, FmuState, LogMessage, Scalar, SlaveOptions};
