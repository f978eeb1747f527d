//! Model Exchange: time, continuous states, derivatives, nominals, the integrator's
//! completed steps and the mode changes of the event iteration.

use super::{Instance, TIME_TOLERANCE};
use crate::log::Ctx;
use crate::mode::Mode;
use crate::model::FmuModel;
use crate::status::Status;

impl<M: FmuModel> Instance<M> {
    /// Number of continuous states.
    pub fn n_states(&self) -> usize {
        self.me_states.0.len()
    }

    fn check_nx(&mut self, f: &'static str, n: usize, what: &str) -> Result<(), Status> {
        if n == self.n_states() {
            Ok(())
        } else {
            let nx = self.n_states();
            Err(self.fail(
                f,
                Status::Error,
                format!("{what} has {n} elements but the model has {nx} continuous states"),
            ))
        }
    }

    /// Set the integrator's time (`fmi2SetTime`, `fmi3SetTime`).
    pub fn set_time(&mut self, f: &'static str, t: f64) -> Status {
        if !t.is_finite() {
            return self.fail(f, Status::Error, format!("time must be finite, got {t}"));
        }
        let now = self.shell.time;
        if t < now - TIME_TOLERANCE * now.abs().max(1.0) && self.shell.mode == Mode::EventMode {
            return self.fail(
                f,
                Status::Error,
                format!("time {t:?} is before the current time {now:?} in event mode"),
            );
        }
        match self.model.set_time(t) {
            Ok(()) => {
                self.shell.time = t;
                Status::Ok
            }
            Err(e) => {
                let s = e.status.max(Status::Error);
                self.fail(f, s, e.message)
            }
        }
    }

    /// Set the continuous states.
    pub fn set_continuous_states(&mut self, f: &'static str, x: &[f64]) -> Status {
        if let Err(s) = self.check_nx(f, x.len(), "x") {
            return s;
        }
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            let name = self.table.get(self.me_states.0[i]).map_or("?", |v| v.name);
            return self.fail(
                f,
                Status::Error,
                format!("x[{i}] = {} (state \"{name}\") is not finite", x[i]),
            );
        }
        let mut ctx = Ctx::new(&self.logger, f);
        let r = self.model.set_continuous_states(&mut ctx, x);
        let cs = ctx.status();
        self.conclude(f, cs, r)
    }

    fn fill(&mut self, f: &'static str, out: &mut [f64], derivatives: bool) -> Status {
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
                let s = e.status.max(Status::Error);
                self.fail(f, s, e.message)
            }
            Ok(()) => match bad {
                None => Status::Ok,
                Some(i) => {
                    let vr = if derivatives {
                        self.me_states.1[i]
                    } else {
                        self.me_states.0[i]
                    };
                    let name = self.table.get(vr).map_or("?", |v| v.name);
                    self.fail(
                        f,
                        Status::Error,
                        format!("\"{name}\" is not finite ({})", out[i]),
                    )
                }
            },
        }
    }

    /// The derivatives of the continuous states (`fmi2GetDerivatives`,
    /// `fmi3GetContinuousStateDerivatives`).
    pub fn get_derivatives(&mut self, f: &'static str, dx: &mut [f64]) -> Status {
        self.fill(f, dx, true)
    }

    /// The continuous states.
    pub fn get_continuous_states(&mut self, f: &'static str, x: &mut [f64]) -> Status {
        self.fill(f, x, false)
    }

    /// The nominals of the continuous states: each state's `nominal` from the table (1 if none).
    pub fn get_nominals(&mut self, f: &'static str, out: &mut [f64]) -> Status {
        if let Err(s) = self.check_nx(f, out.len(), "x_nominal") {
            return s;
        }
        for (o, &vr) in out.iter_mut().zip(&self.me_states.0) {
            *o = self.table.get(vr).and_then(|v| v.nominal).unwrap_or(1.0);
        }
        Status::Ok
    }

    /// Event indicators: the shell's models have none, so only `n = 0` is accepted.
    pub fn get_event_indicators(&mut self, f: &'static str, n: usize) -> Status {
        if n == 0 {
            Status::Ok
        } else {
            self.fail(
                f,
                Status::Error,
                format!(
                    "ni = {n} but the model has no event indicators (numberOfEventIndicators=0)"
                ),
            )
        }
    }

    /// Entering event mode or continuous-time mode: the mode change.
    pub fn enter_mode(&mut self, f: &'static str, mode: Mode) -> Status {
        self.shell.mode = mode;
        self.debug(|| format!("{}: at t = {}", f, self.shell.time));
        Status::Ok
    }

    /// The integrator completed a step: returns (status, enterEventMode).
    pub fn completed_integrator_step(&mut self, f: &'static str) -> (Status, bool) {
        let mut ctx = Ctx::new(&self.logger, f);
        let r = self.model.completed_integrator_step(&mut ctx);
        let cs = ctx.status();
        match r {
            Ok(ev) => (cs, ev),
            Err(e) => (self.conclude(f, cs, Err(e)), false),
        }
    }
}
