//! One FMU instance: the model plus everything the shell keeps around it, and the logic of
//! each FMI call once pointers have been turned into slices (see [`crate::shell`]).
//!
//! Every operation follows the same pattern: check arguments against the variable table
//! and the state machine, call the model hook with a [`Ctx`], then turn the hook's result
//! into an `fmi2Status`, a log message and a state transition (`Instance::conclude`).
//! Because all of that lives here, once, a model cannot forget a check.

use std::ffi::CString;
use std::path::PathBuf;

use crate::abi::Fmi2Status;
use crate::log::{Ctx, Logger, CAT_EVENTS};
use crate::model::{Fmi2Err, FmuModel, InstantiateArgs, VarType, Variable};
use crate::snapshot::{ShellState, Snapshot};
use crate::state::{may_set, Func, Mode};
use crate::table::Table;

/// First word of a live instance ("FMI2INST"), to recognise our pointers.
pub(crate) const INSTANCE_MAGIC: u64 = u64::from_le_bytes(*b"FMI2INST");

/// How far `currentCommunicationPoint` may be from the instance's time (relative to
/// max(1, |t|)) before `fmi2DoStep` refuses: generous enough for importers that compute
/// `t = t0 + n*h` instead of summing steps, tight enough to catch a skipped or repeated step.
pub const TIME_TOLERANCE: f64 = 1e-9;

/// An instance of model `M` behind an `fmi2Component`.
#[repr(C)]
pub struct Instance<M: FmuModel> {
    /// [`INSTANCE_MAGIC`] while alive; first field so it can be checked through a `*const u64`.
    pub(crate) magic: u64,
    pub(crate) guid: u128,
    pub(crate) table: Table,
    pub(crate) logger: Logger,
    pub(crate) resource_location: Option<String>,
    pub(crate) resource_dir: Option<PathBuf>,
    pub(crate) packaged_resources: Option<PathBuf>,
    pub(crate) visible: bool,
    pub(crate) logging_on_at_instantiation: bool,
    pub(crate) shell: ShellState,
    pub(crate) model: M,
    /// C copies of the strings last returned by `fmi2GetString`: valid until the next
    /// `fmi2GetString` (or free), which is longer than the standard requires.
    pub(crate) strings: Vec<CString>,
    /// Every FMU state handed out through this instance and not freed yet: only these are
    /// accepted back (a handle of another instance, a freed one or garbage is refused
    /// without being read), and `fmi2FreeInstance` frees the ones the importer did not.
    pub(crate) states: Vec<*mut Snapshot<M>>,
    /// Instantiated as `fmi2ModelExchange` (else Co-Simulation): decides which functions
    /// exist for this instance and where `fmi2ExitInitializationMode` leads.
    pub(crate) model_exchange: bool,
    /// Model Exchange: value references of the continuous states and of their derivatives
    /// (parallel lists, from [`crate::table::continuous_states`]).
    pub(crate) me_states: (Vec<u32>, Vec<u32>),
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

impl<M: FmuModel> Instance<M> {
    /// State-machine state.
    pub fn mode(&self) -> Mode {
        self.shell.mode
    }

    /// Current communication point.
    pub fn time(&self) -> f64 {
        self.shell.time
    }

    /// The model (for tests and diagnostics).
    pub fn model(&self) -> &M {
        &self.model
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

    /// Log `message` with `status` and move the state machine: Error → Error state,
    /// Fatal → Fatal state (never downgraded). Returns `status`.
    pub(crate) fn fail(
        &mut self,
        func: Func,
        status: Fmi2Status,
        message: impl AsRef<str>,
    ) -> Fmi2Status {
        self.logger.log(
            status,
            crate::log::category_of(status),
            &format!("{}: {}", func.name(), message.as_ref()),
        );
        self.raise(func, status);
        status
    }

    fn raise(&mut self, func: Func, status: Fmi2Status) {
        if func == Func::FreeInstance {
            return;
        }
        match status {
            Fmi2Status::Error | Fmi2Status::Pending if self.shell.mode != Mode::Fatal => {
                self.shell.mode = Mode::Error
            }
            Fmi2Status::Fatal => self.shell.mode = Mode::Fatal,
            _ => {}
        }
    }

    /// Turn a hook result into the call's status: `Ok` gives whatever the hook reported
    /// through its context (OK or Warning); `Err` is logged with its status (an `Err` with
    /// status OK or Pending makes no sense and is taken as Warning or Error).
    pub(crate) fn conclude(
        &mut self,
        func: Func,
        ctx_status: Fmi2Status,
        r: Result<(), Fmi2Err>,
    ) -> Fmi2Status {
        match r {
            Ok(()) => ctx_status,
            Err(e) => {
                let s = match e.status {
                    Fmi2Status::Ok => Fmi2Status::Warning,
                    Fmi2Status::Pending => Fmi2Status::Error,
                    s => s,
                };
                self.fail(func, s, e.message).max(ctx_status)
            }
        }
    }

    fn debug(&self, message: impl FnOnce() -> String) {
        if self.logger.is_enabled(Fmi2Status::Ok, CAT_EVENTS) {
            self.logger.log(Fmi2Status::Ok, CAT_EVENTS, &message());
        }
    }

    /// `fmi2SetDebugLogging` with the category list already read.
    pub fn set_debug_logging(&mut self, on: bool, categories: &[String]) -> Fmi2Status {
        let unknown = self.logger.set_debug_logging(on, categories);
        if unknown.is_empty() {
            Fmi2Status::Ok
        } else {
            self.fail(
                Func::SetDebugLogging,
                Fmi2Status::Warning,
                format!("unknown log categories ignored: {}", unknown.join(", ")),
            )
        }
    }

    /// `fmi2SetupExperiment`.
    pub fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start: f64,
        stop: Option<f64>,
    ) -> Fmi2Status {
        let f = Func::SetupExperiment;
        if !start.is_finite() {
            return self.fail(
                f,
                Fmi2Status::Error,
                format!("startTime must be finite, got {start}"),
            );
        }
        if let Some(stop) = stop {
            if stop.is_nan() || stop < start {
                return self.fail(
                    f,
                    Fmi2Status::Error,
                    format!("stopTime {stop} is before startTime {start}"),
                );
            }
        }
        // Some importers pass toleranceDefined with a meaningless tolerance: not worth an error.
        let mut warn = Fmi2Status::Ok;
        let tolerance = match tolerance {
            Some(tol) if !(tol.is_finite() && tol > 0.0) => {
                warn = self.fail(
                    f,
                    Fmi2Status::Warning,
                    format!("tolerance {tol} ignored (must be finite and > 0)"),
                );
                None
            }
            t => t,
        };
        let mut ctx = Ctx::new(&self.logger, f.name());
        let r = self
            .model
            .setup_experiment(&mut ctx, tolerance, start, stop);
        let cs = ctx.status().max(warn);
        let s = self.conclude(f, cs, r);
        if s <= Fmi2Status::Warning {
            self.shell.start_time = start;
            self.shell.time = start;
            self.shell.stop_time = stop;
            self.shell.tolerance = tolerance;
        }
        s
    }

    /// `fmi2EnterInitializationMode`.
    pub fn enter_initialization_mode(&mut self) -> Fmi2Status {
        let f = Func::EnterInitializationMode;
        let mut ctx = Ctx::new(&self.logger, f.name());
        let r = self.model.enter_initialization_mode(&mut ctx);
        let cs = ctx.status();
        let s = self.conclude(f, cs, r);
        if s <= Fmi2Status::Warning {
            self.shell.mode = Mode::InitializationMode;
            self.debug(|| {
                format!(
                    "{}: entered initialization mode at t = {}",
                    f.name(),
                    self.shell.time
                )
            });
        }
        s
    }

    /// `fmi2ExitInitializationMode`.
    pub fn exit_initialization_mode(&mut self) -> Fmi2Status {
        let f = Func::ExitInitializationMode;
        let mut ctx = Ctx::new(&self.logger, f.name());
        let r = self.model.exit_initialization_mode(&mut ctx);
        let cs = ctx.status();
        let s = self.conclude(f, cs, r);
        if s <= Fmi2Status::Warning {
            self.shell.mode = if self.model_exchange {
                Mode::EventMode
            } else {
                Mode::StepComplete
            };
            self.debug(|| {
                format!(
                    "{}: initialized, ready to step at t = {}",
                    f.name(),
                    self.shell.time
                )
            });
        }
        s
    }

    /// `fmi2Terminate`.
    pub fn terminate(&mut self) -> Fmi2Status {
        let f = Func::Terminate;
        let mut ctx = Ctx::new(&self.logger, f.name());
        let r = self.model.terminate(&mut ctx);
        let cs = ctx.status();
        let s = self.conclude(f, cs, r);
        if s <= Fmi2Status::Warning {
            self.shell.mode = Mode::Terminated;
            self.debug(|| format!("{}: terminated at t = {}", f.name(), self.shell.time));
        }
        s
    }

    /// `fmi2Reset`: a fresh model from the constructor; logger and settings are kept.
    pub fn reset(&mut self) -> Fmi2Status {
        let f = Func::Reset;
        let mut ctx = Ctx::new(&self.logger, f.name());
        let r = M::instantiate(&mut ctx, &self.args());
        let cs = ctx.status();
        match r {
            Ok(model) => {
                self.model = model;
                self.shell = ShellState::fresh();
                self.strings.clear();
                self.debug(|| {
                    format!(
                        "{}: instance reset to its freshly instantiated state",
                        f.name()
                    )
                });
                cs
            }
            Err(e) => {
                let s = e.status.max(Fmi2Status::Error);
                self.fail(
                    f,
                    s,
                    format!("the model could not be re-created: {}", e.message),
                )
            }
        }
    }

    fn check_get(&mut self, f: Func, vrs: &[u32], ty: VarType) -> Result<(), Fmi2Status> {
        for &vr in vrs {
            if let Err(m) = self.table.typed(vr, ty) {
                return Err(self.fail(f, Fmi2Status::Error, m));
            }
        }
        Ok(())
    }

    fn getter_error(&mut self, f: Func, var_vr: u32, e: Fmi2Err) -> Fmi2Status {
        let name = self.table.get(var_vr).map_or("?", |v| v.name);
        self.fail(
            f,
            e.status.max(Fmi2Status::Error),
            format!("variable \"{name}\": {}", e.message),
        )
    }

    /// `fmi2GetReal`.
    pub fn get_real(&mut self, vrs: &[u32], out: &mut [f64]) -> Fmi2Status {
        let f = Func::GetReal;
        if let Err(s) = self.check_get(f, vrs, VarType::Real) {
            return s;
        }
        for (&vr, o) in vrs.iter().zip(out.iter_mut()) {
            match self.model.get_real(vr) {
                Ok(x) => *o = x,
                Err(e) => return self.getter_error(f, vr, e),
            }
        }
        Fmi2Status::Ok
    }

    /// `fmi2GetInteger`.
    pub fn get_integer(&mut self, vrs: &[u32], out: &mut [i32]) -> Fmi2Status {
        let f = Func::GetInteger;
        if let Err(s) = self.check_get(f, vrs, VarType::Integer) {
            return s;
        }
        for (&vr, o) in vrs.iter().zip(out.iter_mut()) {
            match self.model.get_integer(vr) {
                Ok(x) => *o = x,
                Err(e) => return self.getter_error(f, vr, e),
            }
        }
        Fmi2Status::Ok
    }

    /// `fmi2GetBoolean` (written as C ints 1/0).
    pub fn get_boolean(&mut self, vrs: &[u32], out: &mut [i32]) -> Fmi2Status {
        let f = Func::GetBoolean;
        if let Err(s) = self.check_get(f, vrs, VarType::Boolean) {
            return s;
        }
        for (&vr, o) in vrs.iter().zip(out.iter_mut()) {
            match self.model.get_boolean(vr) {
                Ok(x) => *o = x as i32,
                Err(e) => return self.getter_error(f, vr, e),
            }
        }
        Fmi2Status::Ok
    }

    /// `fmi2GetString`: fills `out` with pointers into strings owned by the instance.
    pub fn get_string(&mut self, vrs: &[u32], out: &mut [*const std::ffi::c_char]) -> Fmi2Status {
        let f = Func::GetString;
        if let Err(s) = self.check_get(f, vrs, VarType::String) {
            return s;
        }
        self.strings.clear();
        for &vr in vrs {
            match self.model.get_string(vr) {
                Ok(s) => match CString::new(s) {
                    Ok(c) => self.strings.push(c),
                    Err(_) => {
                        let e = Fmi2Err::error("value contains a NUL character");
                        return self.getter_error(f, vr, e);
                    }
                },
                Err(e) => return self.getter_error(f, vr, e),
            }
        }
        for (o, c) in out.iter_mut().zip(&self.strings) {
            *o = c.as_ptr();
        }
        Fmi2Status::Ok
    }

    /// Check every reference before setting anything, so a bad call leaves no variable
    /// half-set.
    fn check_set(&mut self, f: Func, vrs: &[u32], ty: VarType) -> Result<(), Fmi2Status> {
        let mode = self.shell.mode;
        for &vr in vrs {
            let var: &Variable = match self.table.typed(vr, ty) {
                Ok(v) => v,
                Err(m) => return Err(self.fail(f, Fmi2Status::Error, m)),
            };
            if let Err(m) = may_set(var, mode) {
                return Err(self.fail(f, Fmi2Status::Error, m));
            }
        }
        Ok(())
    }

    fn setter_result(
        &mut self,
        f: Func,
        vr: u32,
        r: Result<(), Fmi2Err>,
        worst: &mut Fmi2Status,
    ) -> bool {
        if let Err(mut e) = r {
            let name = self.table.get(vr).map_or("?", |v| v.name);
            e.message = format!("variable \"{name}\": {}", e.message);
            let s = self.conclude(f, Fmi2Status::Ok, Err(e));
            *worst = (*worst).max(s);
            return s <= Fmi2Status::Warning;
        }
        true
    }

    /// `fmi2SetReal`: non-finite values are refused, naming the variable.
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Fmi2Status {
        let f = Func::SetReal;
        if let Err(s) = self.check_set(f, vrs, VarType::Real) {
            return s;
        }
        for (&vr, &x) in vrs.iter().zip(values) {
            if !x.is_finite() {
                let var = self.table.get(vr).expect("checked");
                let msg = format!(
                    "value {x} for variable \"{}\" (value reference {vr}) is not finite; rejected, the variable keeps its value",
                    var.name
                );
                return self.fail(f, Fmi2Status::Error, msg);
            }
        }
        let mut worst = Fmi2Status::Ok;
        for (&vr, &x) in vrs.iter().zip(values) {
            let mut ctx = Ctx::new(&self.logger, f.name());
            let r = self.model.set_real(&mut ctx, vr, x);
            worst = worst.max(ctx.status());
            if !self.setter_result(f, vr, r, &mut worst) {
                break;
            }
        }
        worst
    }

    /// `fmi2SetInteger`.
    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Fmi2Status {
        let f = Func::SetInteger;
        if let Err(s) = self.check_set(f, vrs, VarType::Integer) {
            return s;
        }
        let mut worst = Fmi2Status::Ok;
        for (&vr, &x) in vrs.iter().zip(values) {
            let mut ctx = Ctx::new(&self.logger, f.name());
            let r = self.model.set_integer(&mut ctx, vr, x);
            worst = worst.max(ctx.status());
            if !self.setter_result(f, vr, r, &mut worst) {
                break;
            }
        }
        worst
    }

    /// `fmi2SetBoolean` (any non-zero C int is true).
    pub fn set_boolean(&mut self, vrs: &[u32], values: &[i32]) -> Fmi2Status {
        let f = Func::SetBoolean;
        if let Err(s) = self.check_set(f, vrs, VarType::Boolean) {
            return s;
        }
        let mut worst = Fmi2Status::Ok;
        for (&vr, &x) in vrs.iter().zip(values) {
            let mut ctx = Ctx::new(&self.logger, f.name());
            let r = self.model.set_boolean(&mut ctx, vr, x != 0);
            worst = worst.max(ctx.status());
            if !self.setter_result(f, vr, r, &mut worst) {
                break;
            }
        }
        worst
    }

    /// `fmi2SetString` with the C strings already decoded (`None`: NULL or not UTF-8).
    pub fn set_string(&mut self, vrs: &[u32], values: &[Option<&str>]) -> Fmi2Status {
        let f = Func::SetString;
        if let Err(s) = self.check_set(f, vrs, VarType::String) {
            return s;
        }
        for (&vr, v) in vrs.iter().zip(values) {
            if v.is_none() {
                let name = self.table.get(vr).map_or("?", |v| v.name);
                let msg = format!("value for variable \"{name}\" is NULL or not valid UTF-8");
                return self.fail(f, Fmi2Status::Error, msg);
            }
        }
        let mut worst = Fmi2Status::Ok;
        for (&vr, v) in vrs.iter().zip(values) {
            let mut ctx = Ctx::new(&self.logger, f.name());
            let r = self.model.set_string(&mut ctx, vr, v.unwrap_or_default());
            worst = worst.max(ctx.status());
            if !self.setter_result(f, vr, r, &mut worst) {
                break;
            }
        }
        worst
    }

    /// `fmi2DoStep`.
    pub fn do_step(&mut self, current: f64, step: f64) -> Fmi2Status {
        let f = Func::DoStep;
        if !(step.is_finite() && step > 0.0) {
            return self.fail(
                f,
                Fmi2Status::Error,
                format!("communicationStepSize must be finite and > 0, got {step}"),
            );
        }
        if !current.is_finite() {
            return self.fail(
                f,
                Fmi2Status::Error,
                format!("currentCommunicationPoint must be finite, got {current}"),
            );
        }
        let t = self.shell.time;
        let tol = TIME_TOLERANCE * t.abs().max(1.0);
        if (current - t).abs() > tol {
            return self.fail(
                f,
                Fmi2Status::Error,
                format!(
                    "currentCommunicationPoint = {current:?} but the FMU is at t = {t:?} (difference {:e}); \
                     steps must be contiguous (use fmi2SetFMUstate to go back)",
                    current - t
                ),
            );
        }
        let next = current + step;
        if let Some(stop) = self.shell.stop_time {
            if next > stop + TIME_TOLERANCE * stop.abs().max(1.0) {
                return self.fail(
                    f,
                    Fmi2Status::Error,
                    format!("step from {current:?} by {step:?} would pass the stopTime {stop:?} set in fmi2SetupExperiment"),
                );
            }
        }
        let mut ctx = Ctx::new(&self.logger, f.name());
        let r = self.model.do_step(&mut ctx, current, step);
        let cs = ctx.status();
        let discarded = matches!(&r, Err(e) if e.status == Fmi2Status::Discard);
        let s = self.conclude(f, cs, r);
        if s <= Fmi2Status::Warning {
            self.shell.time = next;
        } else if discarded {
            self.shell.mode = Mode::StepFailed;
        }
        s
    }

    /// `fmi2GetDirectionalDerivative`.
    pub fn directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        dv_known: &[f64],
        dv_unknown: &mut [f64],
    ) -> Fmi2Status {
        let f = Func::GetDirectionalDerivative;
        for &vr in unknowns.iter().chain(knowns) {
            if let Err(m) = self.table.typed(vr, VarType::Real) {
                return self.fail(f, Fmi2Status::Error, m);
            }
        }
        if let Some((i, x)) = dv_known.iter().enumerate().find(|(_, x)| !x.is_finite()) {
            let name = self.table.get(knowns[i]).map_or("?", |v| v.name);
            return self.fail(
                f,
                Fmi2Status::Error,
                format!("dvKnown[{i}] = {x} (for \"{name}\") is not finite"),
            );
        }
        match self
            .model
            .directional_derivative(unknowns, knowns, dv_known)
        {
            Ok(v) if v.len() == unknowns.len() => {
                if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                    let name = self.table.get(unknowns[i]).map_or("?", |v| v.name);
                    return self.fail(
                        f,
                        Fmi2Status::Error,
                        format!("the derivative of \"{name}\" is not finite"),
                    );
                }
                dv_unknown.copy_from_slice(&v);
                Fmi2Status::Ok
            }
            Ok(v) => self.fail(
                f,
                Fmi2Status::Error,
                format!(
                    "model returned {} values for {} unknowns",
                    v.len(),
                    unknowns.len()
                ),
            ),
            Err(e) => {
                let s = e.status.max(Fmi2Status::Error);
                self.fail(f, s, e.message)
            }
        }
    }

    // -----------------------------------------------------------------------------------
    // Model Exchange
    // -----------------------------------------------------------------------------------

    /// Number of continuous states.
    pub fn n_states(&self) -> usize {
        self.me_states.0.len()
    }

    fn check_nx(&mut self, f: Func, n: usize, what: &str) -> Result<(), Fmi2Status> {
        if n == self.n_states() {
            Ok(())
        } else {
            let nx = self.n_states();
            Err(self.fail(
                f,
                Fmi2Status::Error,
                format!("{what} has {n} elements but the model has {nx} continuous states"),
            ))
        }
    }

    /// `fmi2SetTime`.
    pub fn set_time(&mut self, t: f64) -> Fmi2Status {
        let f = Func::SetTime;
        if !t.is_finite() {
            return self.fail(
                f,
                Fmi2Status::Error,
                format!("time must be finite, got {t}"),
            );
        }
        let now = self.shell.time;
        if t < now - TIME_TOLERANCE * now.abs().max(1.0) && self.shell.mode == Mode::EventMode {
            return self.fail(
                f,
                Fmi2Status::Error,
                format!("time {t:?} is before the current time {now:?} in event mode"),
            );
        }
        match self.model.set_time(t) {
            Ok(()) => {
                self.shell.time = t;
                Fmi2Status::Ok
            }
            Err(e) => {
                let s = e.status.max(Fmi2Status::Error);
                self.fail(f, s, e.message)
            }
        }
    }

    /// `fmi2SetContinuousStates`.
    pub fn set_continuous_states(&mut self, x: &[f64]) -> Fmi2Status {
        let f = Func::SetContinuousStates;
        if let Err(s) = self.check_nx(f, x.len(), "x") {
            return s;
        }
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            let name = self.table.get(self.me_states.0[i]).map_or("?", |v| v.name);
            return self.fail(
                f,
                Fmi2Status::Error,
                format!("x[{i}] = {} (state \"{name}\") is not finite", x[i]),
            );
        }
        let mut ctx = Ctx::new(&self.logger, f.name());
        let r = self.model.set_continuous_states(&mut ctx, x);
        let cs = ctx.status();
        self.conclude(f, cs, r)
    }

    fn fill(&mut self, f: Func, out: &mut [f64], derivatives: bool) -> Fmi2Status {
        if let Err(s) = self.check_nx(f, out.len(), "the output array") {
            return s;
        }
        let vrs = if derivatives {
            std::mem::take(&mut self.me_states.1)
        } else {
            std::mem::take(&mut self.me_states.0)
        };
        let r = if derivatives {
            self.model.get_derivatives(&vrs, out)
        } else {
            self.model.get_continuous_states(&vrs, out)
        };
        let bad = out.iter().position(|v| !v.is_finite());
        if derivatives {
            self.me_states.1 = vrs;
        } else {
            self.me_states.0 = vrs;
        }
        match r {
            Err(e) => {
                let s = e.status.max(Fmi2Status::Error);
                self.fail(f, s, e.message)
            }
            Ok(()) => match bad {
                None => Fmi2Status::Ok,
                Some(i) => {
                    let vr = if derivatives {
                        self.me_states.1[i]
                    } else {
                        self.me_states.0[i]
                    };
                    let name = self.table.get(vr).map_or("?", |v| v.name);
                    self.fail(
                        f,
                        Fmi2Status::Error,
                        format!("\"{name}\" is not finite ({})", out[i]),
                    )
                }
            },
        }
    }

    /// `fmi2GetDerivatives`.
    pub fn get_derivatives(&mut self, dx: &mut [f64]) -> Fmi2Status {
        self.fill(Func::GetDerivatives, dx, true)
    }

    /// `fmi2GetContinuousStates`.
    pub fn get_continuous_states(&mut self, x: &mut [f64]) -> Fmi2Status {
        self.fill(Func::GetContinuousStates, x, false)
    }

    /// `fmi2GetNominalsOfContinuousStates`: each state's `nominal` from the table (1 if none).
    pub fn get_nominals(&mut self, out: &mut [f64]) -> Fmi2Status {
        if let Err(s) = self.check_nx(Func::GetNominalsOfContinuousStates, out.len(), "x_nominal") {
            return s;
        }
        for (o, &vr) in out.iter_mut().zip(&self.me_states.0) {
            *o = self.table.get(vr).and_then(|v| v.nominal).unwrap_or(1.0);
        }
        Fmi2Status::Ok
    }

    /// `fmi2GetEventIndicators`: the shell's models have none.
    pub fn get_event_indicators(&mut self, n: usize) -> Fmi2Status {
        if n == 0 {
            Fmi2Status::Ok
        } else {
            self.fail(
                Func::GetEventIndicators,
                Fmi2Status::Error,
                format!(
                    "ni = {n} but the model has no event indicators (numberOfEventIndicators=0)"
                ),
            )
        }
    }

    /// `fmi2EnterEventMode` / `fmi2EnterContinuousTimeMode`: the mode change.
    pub fn enter_mode(&mut self, f: Func, mode: Mode) -> Fmi2Status {
        self.shell.mode = mode;
        self.debug(|| format!("{}: at t = {}", f.name(), self.shell.time));
        Fmi2Status::Ok
    }

    /// `fmi2CompletedIntegratorStep`: returns (status, enterEventMode).
    pub fn completed_integrator_step(&mut self) -> (Fmi2Status, bool) {
        let f = Func::CompletedIntegratorStep;
        let mut ctx = Ctx::new(&self.logger, f.name());
        let r = self.model.completed_integrator_step(&mut ctx);
        let cs = ctx.status();
        match r {
            Ok(ev) => (cs, ev),
            Err(e) => (self.conclude(f, cs, Err(e)), false),
        }
    }
}
