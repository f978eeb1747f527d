//! One FMU instance: the model plus everything a shell keeps around it, and the logic of
//! each call once the shell has turned the importer's pointers into slices and checked the
//! state machine.
//!
//! Every operation follows the same pattern: check arguments against the variable table
//! and the mode, call the model hook with a [`Ctx`], then turn the hook's result into a
//! [`Status`], a log message and a mode change (`Instance::conclude`). Because all of that
//! lives here, once, for both FMI versions, a model cannot forget a check and the two
//! shells cannot disagree. Each operation takes the name of the C function it serves
//! (`f`), which prefixes its log messages.
//!
//! Parts: [`values`] (get/set), [`step`] (Co-Simulation steps, directional and adjoint
//! derivatives), [`me`] (Model Exchange), [`fmu_state`] (FMU states and their bytes).

use crate::status::Refusal;
use std::ffi::CString;
use std::path::PathBuf;

use crate::info::ModelInfo;
use crate::log::{all_categories, Ctx, LogSink, Logger, CAT_ERROR, CAT_EVENTS, CAT_WARNING};
use crate::mode::Mode;
use crate::model::{FmuModel, InstantiateArgs};
use crate::snapshot::{ShellState, Snapshot};
use crate::status::{ModelError, Status};
use crate::table::Table;

pub mod fmu_state;
pub mod me;
pub mod step;
pub mod values;

pub use crate::TIME_TOLERANCE;

/// Which interface an instance was created for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Interface {
    /// Co-Simulation (the FMU integrates itself; `DoStep`).
    CoSimulation,
    /// Model Exchange (the importer's solver integrates the continuous states).
    ModelExchange,
}

/// What the importer passed at instantiation, as a shell read it from its C arguments.
pub struct Request {
    /// The shell's magic word for its live instances (first field of the instance).
    pub magic: u64,
    /// The variable table (a shell may have added the independent variable to the model's).
    pub info: &'static ModelInfo,
    /// The C function, for messages (`fmi2Instantiate`, `fmi3InstantiateCoSimulation`).
    pub function: &'static str,
    /// The argument that carries the GUID, for messages (`fmuGUID`, `instantiationToken`).
    pub token_arg: &'static str,
    /// The instance name (`None`: NULL).
    pub name: Option<String>,
    /// The GUID / instantiation token passed (`None`: NULL).
    pub token: Option<String>,
    /// The resource location passed (`None`: NULL).
    pub resource_location: Option<String>,
    /// The interface asked for, or why the request names none the FMU offers.
    pub interface: Result<Interface, Refusal>,
    /// Where the messages go (`None`: the importer gave no logger).
    pub sink: Option<LogSink>,
    /// `visible`.
    pub visible: bool,
    /// `loggingOn`.
    pub logging_on: bool,
}

/// Create an instance for `req`: every check of instantiation (name, interface, table,
/// GUID, resource location) and the model's constructor, under the panic barrier. `None`
/// after logging why through the importer's logger (if it gave one).
pub fn create<M: FmuModel>(req: Request) -> Option<Box<Instance<M>>> {
    let info = req.info;
    let f = req.function;
    let known = all_categories(info.log_categories)
        .iter()
        .map(|c| c.name)
        .collect();
    let logger = Logger::new(
        req.sink,
        req.name.as_deref().unwrap_or("?"),
        req.logging_on,
        known,
    );
    let warn = |logger: &Logger, msg: String| {
        logger.log(Status::Warning, CAT_WARNING, &format!("{f}: {msg}"));
    };
    let checked = (|| -> Result<(String, Interface, Table, u128), Refusal> {
        let name = match req.name {
            Some(n) if !n.trim().is_empty() => n,
            Some(_) => return Err("instanceName must not be empty".into()),
            None => return Err("instanceName must not be NULL".into()),
        };
        let interface = req.interface?;
        if interface == Interface::ModelExchange && !M::MODEL_EXCHANGE {
            return Err(Refusal(format!(
                "Model Exchange requested, but {} implements Co-Simulation only (instantiate \
                 it for Co-Simulation)",
                info.model_identifier
            )));
        }
        let table = Table::new(info).map_err(|p| {
            format!(
                "the FMU's variable table is invalid (a bug in the FMU): {}",
                p.join("; ")
            )
        })?;
        let guid = crate::guid::guid_u128(info);
        let expected = crate::guid::format_guid(guid);
        let given = req
            .token
            .ok_or_else(|| format!("{} must not be NULL", req.token_arg))?;
        if given.trim() != expected {
            return Err(Refusal(format!(
                "{} mismatch: the importer passed {given} but this binary is {expected}; the \
                 modelDescription.xml does not belong to this binary",
                req.token_arg
            )));
        }
        Ok((name, interface, table, guid))
    })();
    let (name, interface, table, guid) = match checked {
        Ok(c) => c,
        Err(msg) => {
            logger.log(Status::Error, CAT_ERROR, &format!("{f}: {msg}"));
            return None;
        }
    };
    let location = req.resource_location;
    let dir = match location.as_deref().map(crate::uri::resource_dir) {
        None => None,
        Some(Ok(d)) => d,
        Some(Err(e)) => {
            warn(&logger, format!("{e}; continuing without resources"));
            None
        }
    };
    // A location that names no folder is the importer's mistake: say so, and give the
    // model no resource folder (it decides whether it can do without).
    let dir = match dir {
        Some(d) if !d.is_dir() => {
            warn(
                &logger,
                format!(
                    "resource location {:?} names the folder {} which does not exist; \
                     continuing without resources",
                    location.as_deref().unwrap_or_default(),
                    d.display()
                ),
            );
            None
        }
        d => d,
    };
    let packaged = crate::uri::packaged_resources();
    let built = crate::barrier::barrier(|| {
        let args = InstantiateArgs {
            instance_name: &name,
            resource_location: location.as_deref(),
            resource_dir: dir.as_deref(),
            packaged_resources: packaged.as_deref(),
            visible: req.visible,
            logging_on: req.logging_on,
        };
        let mut ctx = Ctx::new(&logger, f);
        M::instantiate(&mut ctx, &args)
    });
    let model = match built {
        Ok(Ok(m)) => m,
        Ok(Err(e)) => {
            let msg = format!("{f}: the model could not be created: {}", e.message);
            logger.log(Status::Error, CAT_ERROR, &msg);
            return None;
        }
        Err(payload) => {
            let msg = crate::barrier::panic_message(&*payload);
            crate::barrier::drop_payload(payload);
            let msg = format!("{f}: internal error: the model panicked: {msg}");
            logger.log(Status::Error, CAT_ERROR, &msg);
            return None;
        }
    };
    let me_states = match interface {
        Interface::ModelExchange => crate::table::continuous_states(info),
        Interface::CoSimulation => (Vec::new(), Vec::new()),
    };
    let inst = Box::new(Instance {
        magic: req.magic,
        guid,
        table,
        logger,
        resource_location: location,
        resource_dir: dir,
        packaged_resources: packaged,
        visible: req.visible,
        logging_on_at_instantiation: req.logging_on,
        shell: ShellState::fresh(),
        model,
        strings: Vec::new(),
        states: Vec::new(),
        interface,
        me_states,
    });
    inst.debug(|| {
        format!(
            "{f}: {} {} instantiated for {} (resources: {})",
            info.model_identifier,
            info.version,
            match interface {
                Interface::CoSimulation => "Co-Simulation",
                Interface::ModelExchange => "Model Exchange",
            },
            inst.resource_dir
                .as_ref()
                .map_or("none".to_string(), |d| d.display().to_string())
        )
    });
    Some(inst)
}

/// An instance of model `M` behind the importer's opaque handle.
#[repr(C)]
pub struct Instance<M: FmuModel> {
    /// The shell's magic word while alive; first field so that a shell can check a handle
    /// through a `*const u64` before trusting it ([`Instance::from_handle`]).
    magic: u64,
    /// GUID / instantiation token of the table, as 128 bits.
    pub guid: u128,
    /// The validated variable table.
    pub table: Table,
    /// The importer's logger and the debug-logging settings.
    pub logger: Logger,
    resource_location: Option<String>,
    resource_dir: Option<PathBuf>,
    packaged_resources: Option<PathBuf>,
    visible: bool,
    logging_on_at_instantiation: bool,
    /// Mode, time and experiment.
    pub shell: ShellState,
    /// The model.
    pub model: M,
    /// C copies of the strings last returned by a String getter: valid until the next one
    /// (or free), which is longer than the standards require.
    strings: Vec<CString>,
    /// Every FMU state handed out through this instance and not freed yet: only these are
    /// accepted back (a handle of another instance, a freed one or garbage is refused
    /// without being read), and freeing the instance frees the ones the importer did not.
    states: Vec<*mut Snapshot<M>>,
    /// The interface this instance was created for: decides which functions exist for it
    /// and where leaving initialisation mode leads.
    pub interface: Interface,
    /// Model Exchange: value references of the continuous states and of their derivatives
    /// (parallel lists, from [`crate::table::continuous_states`]).
    me_states: (Vec<u32>, Vec<u32>),
}

impl<M: FmuModel> Drop for Instance<M> {
    fn drop(&mut self) {
        for s in std::mem::take(&mut self.states) {
            // SAFETY: each pointer came from `Box::into_raw` in this instance and was removed
            // from the list when freed, so it is live and owned here.
            drop(unsafe { Box::from_raw(s) });
        }
    }
}

/// An optional group of functions a model may decline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Capability {
    /// Get, set, free, serialize and deserialize the FMU state.
    FmuState,
    /// Directional and adjoint derivatives.
    Derivatives,
}

impl<M: FmuModel> Instance<M> {
    /// The instance behind an importer's handle, if it carries `magic` (a live instance of
    /// the shell that uses that word).
    ///
    /// # Safety
    /// `p` must be NULL or a handle this library's shell returned for model `M` (a live or
    /// freed instance): the first 8 bytes behind it are read.
    pub unsafe fn from_handle(p: *mut std::ffi::c_void, magic: u64) -> Option<*mut Instance<M>> {
        // SAFETY: a non-NULL handle is one the shell returned (caller's contract): a
        // `#[repr(C)]` Instance whose first field is the u64 magic, so reading 8 bytes is in
        // bounds.
        if p.is_null() || unsafe { (p as *const u64).read() } != magic {
            return None;
        }
        Some(p as *mut Instance<M>)
    }

    /// Mark the instance dead before it is dropped, so a stale handle is refused on a
    /// best-effort basis.
    pub fn kill(&mut self) {
        self.magic = 0;
    }

    /// `FreeInstance` of either version: free the instance behind `p` (NULL, or a pointer
    /// that is not a live instance with this `magic`, is ignored), marking it dead first, with
    /// no panic escaping.
    ///
    /// # Safety
    /// `p` must be NULL or a handle this library's shell returned for model `M`, not used
    /// by the importer after this call.
    pub unsafe fn free_handle(p: *mut std::ffi::c_void, magic: u64) {
        // SAFETY: the caller's contract is `from_handle`'s.
        let Some(inst) = (unsafe { Self::from_handle(p, magic) }) else {
            return;
        };
        let r = crate::barrier::barrier(|| {
            // SAFETY: a live instance leaked from a Box at instantiation; after this call the
            // importer never uses it again, so it is dropped exactly once.
            unsafe {
                (*inst).kill();
                drop(Box::from_raw(inst));
            }
        });
        if let Err(payload) = r {
            crate::barrier::drop_payload(payload);
        }
    }

    /// Mode.
    pub fn mode(&self) -> Mode {
        self.shell.mode
    }

    /// Current time (communication point, or the time of the last `SetTime`).
    pub fn time(&self) -> f64 {
        self.shell.time
    }

    /// The model (for tests and diagnostics).
    pub fn model(&self) -> &M {
        &self.model
    }

    /// Whether this is a Model Exchange instance.
    pub fn is_model_exchange(&self) -> bool {
        self.interface == Interface::ModelExchange
    }

    /// The resource folder the instance was given, if any.
    pub fn resource_dir(&self) -> Option<&std::path::Path> {
        self.resource_dir.as_deref()
    }

    pub(crate) fn args(&self) -> InstantiateArgs<'_> {
        InstantiateArgs {
            instance_name: self.logger.instance_name(),
            resource_location: self.resource_location.as_deref(),
            resource_dir: self.resource_dir.as_deref(),
            packaged_resources: self.packaged_resources.as_deref(),
            visible: self.visible,
            logging_on: self.logging_on_at_instantiation,
        }
    }

    /// Refuse a call of an optional group the model declared it does not provide
    /// ([`FmuModel::CAN_GET_AND_SET_FMU_STATE`], [`FmuModel::PROVIDES_DIRECTIONAL_DERIVATIVE`]);
    /// `attribute` is the XML attribute that says so, as the shell's version spells it.
    pub fn refuse_unsupported(
        &mut self,
        func: &'static str,
        capability: Capability,
        attribute: &str,
    ) -> Option<Status> {
        let provided = match capability {
            Capability::FmuState => M::CAN_GET_AND_SET_FMU_STATE,
            Capability::Derivatives => M::PROVIDES_DIRECTIONAL_DERIVATIVE,
        };
        (!provided).then(|| {
            self.fail(
                func,
                Status::Error,
                format!(
                    "not supported by this FMU (its modelDescription.xml says {attribute}=\"false\")"
                ),
            )
        })
    }

    /// Log `message` with `status` and move the state machine: Error → Error state,
    /// Fatal → Fatal state (never downgraded). Returns `status`.
    pub fn fail(&mut self, func: &'static str, status: Status, message: impl AsRef<str>) -> Status {
        self.logger.log(
            status,
            crate::log::category_of(status),
            &format!("{}: {}", func, message.as_ref()),
        );
        self.raise(func, status);
        status
    }

    fn raise(&mut self, func: &'static str, status: Status) {
        if func.ends_with("FreeInstance") {
            return;
        }
        match status {
            Status::Error if self.shell.mode != Mode::Fatal => self.shell.mode = Mode::Error,
            Status::Fatal => self.shell.mode = Mode::Fatal,
            _ => {}
        }
    }

    /// Turn a hook result into the call's status: `Ok` gives whatever the hook reported
    /// through its context (OK or Warning); `Err` is logged with its status (an `Err` with
    /// status OK makes no sense and is taken as Warning).
    pub fn conclude(
        &mut self,
        func: &'static str,
        ctx_status: Status,
        r: Result<(), ModelError>,
    ) -> Status {
        match r {
            Ok(()) => ctx_status,
            Err(e) => {
                let s = match e.status {
                    Status::Ok => Status::Warning,
                    s => s,
                };
                self.fail(func, s, e.message).max(ctx_status)
            }
        }
    }

    /// A debug message under `logEvents`, formatted only if it would be passed on.
    pub fn debug(&self, message: impl FnOnce() -> String) {
        if self.logger.is_enabled(Status::Ok, CAT_EVENTS) {
            self.logger.log(Status::Ok, CAT_EVENTS, &message());
        }
    }

    /// `SetDebugLogging` with the category list already read.
    pub fn set_debug_logging(
        &mut self,
        f: &'static str,
        on: bool,
        categories: &[String],
    ) -> Status {
        let unknown = self.logger.set_debug_logging(on, categories);
        if unknown.is_empty() {
            Status::Ok
        } else {
            self.fail(
                f,
                Status::Warning,
                format!("unknown log categories ignored: {}", unknown.join(", ")),
            )
        }
    }

    /// The experiment (FMI 2.0 `fmi2SetupExperiment`; FMI 3.0 the arguments of
    /// `fmi3EnterInitializationMode`).
    pub fn setup_experiment(
        &mut self,
        f: &'static str,
        tolerance: Option<f64>,
        start: f64,
        stop: Option<f64>,
    ) -> Status {
        if !start.is_finite() {
            return self.fail(
                f,
                Status::Error,
                format!("startTime must be finite, got {start}"),
            );
        }
        if let Some(stop) = stop {
            if stop.is_nan() || stop < start {
                return self.fail(
                    f,
                    Status::Error,
                    format!("stopTime {stop} is before startTime {start}"),
                );
            }
        }
        // Some importers pass toleranceDefined with a meaningless tolerance: not worth an error.
        let mut warn = Status::Ok;
        let tolerance = match tolerance {
            Some(tol) if !(tol.is_finite() && tol > 0.0) => {
                warn = self.fail(
                    f,
                    Status::Warning,
                    format!("tolerance {tol} ignored (must be finite and > 0)"),
                );
                None
            }
            t => t,
        };
        let mut ctx = Ctx::new(&self.logger, f);
        let r = self
            .model
            .setup_experiment(&mut ctx, tolerance, start, stop);
        let cs = ctx.status().max(warn);
        let s = self.conclude(f, cs, r);
        if s <= Status::Warning {
            self.shell.start_time = start;
            self.shell.time = start;
            self.shell.stop_time = stop;
            self.shell.tolerance = tolerance;
        }
        s
    }

    /// Entering initialisation mode.
    pub fn enter_initialization_mode(&mut self, f: &'static str) -> Status {
        let mut ctx = Ctx::new(&self.logger, f);
        let r = self.model.enter_initialization_mode(&mut ctx);
        let cs = ctx.status();
        let s = self.conclude(f, cs, r);
        if s <= Status::Warning {
            self.shell.mode = Mode::InitializationMode;
            self.debug(|| {
                format!(
                    "{}: entered initialization mode at t = {}",
                    f, self.shell.time
                )
            });
        }
        s
    }

    /// Leaving initialisation mode.
    /// `next` is where the instance goes: event mode (Model Exchange, or FMI 3.0
    /// Co-Simulation with event mode) or step mode.
    pub fn exit_initialization_mode(&mut self, f: &'static str, next: Mode) -> Status {
        let mut ctx = Ctx::new(&self.logger, f);
        let r = self.model.exit_initialization_mode(&mut ctx);
        let cs = ctx.status();
        let s = self.conclude(f, cs, r);
        if s <= Status::Warning {
            self.shell.mode = next;
            self.debug(|| {
                format!(
                    "{}: initialized, ready to step at t = {}",
                    f, self.shell.time
                )
            });
        }
        s
    }

    /// Termination.
    pub fn terminate(&mut self, f: &'static str) -> Status {
        let mut ctx = Ctx::new(&self.logger, f);
        let r = self.model.terminate(&mut ctx);
        let cs = ctx.status();
        let s = self.conclude(f, cs, r);
        if s <= Status::Warning {
            self.shell.mode = Mode::Terminated;
            self.debug(|| format!("{}: terminated at t = {}", f, self.shell.time));
        }
        s
    }

    /// Reset: a fresh model from the constructor; logger and settings are kept.
    pub fn reset(&mut self, f: &'static str) -> Status {
        let mut ctx = Ctx::new(&self.logger, f);
        let r = M::instantiate(&mut ctx, &self.args());
        let cs = ctx.status();
        match r {
            Ok(model) => {
                self.model = model;
                self.shell = ShellState::fresh();
                self.strings.clear();
                self.debug(|| format!("{}: instance reset to its freshly instantiated state", f));
                cs
            }
            Err(e) => {
                let s = e.status.max(Status::Error);
                self.fail(
                    f,
                    s,
                    format!("the model could not be re-created: {}", e.message),
                )
            }
        }
    }
}
