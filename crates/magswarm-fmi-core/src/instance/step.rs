//! Co-Simulation steps and the derivatives of outputs (directional and adjoint).

use super::{Instance, TIME_TOLERANCE};
use crate::log::Ctx;
use crate::mode::Mode;
use crate::model::FmuModel;
use crate::status::{ModelError, Status};
use crate::variable::VarType;

impl<M: FmuModel> Instance<M> {
    /// A Co-Simulation step from `current` by `step` (`fmi2DoStep`, `fmi3DoStep`). A model's
    /// Discard leaves the instance at `current` in [`Mode::StepFailed`].
    ///
    /// The arguments are checked in one test on the way in; only a refused step goes to
    /// `Instance::refuse_step` to find out which rule it broke and say so.
    #[inline(always)]
    pub fn do_step(&mut self, f: &'static str, current: f64, step: f64) -> Status {
        let t = self.shell.time;
        let next = current + step;
        let contiguous = (current - t).abs() <= TIME_TOLERANCE * t.abs().max(1.0);
        // Written as "not past the stop" so that it reads exactly as the refusal it replaces.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        let before_stop = match self.shell.stop_time {
            None => true,
            Some(stop) => !(next > stop + TIME_TOLERANCE * stop.abs().max(1.0)),
        };
        // `step > 0` and the finiteness of both are inside `contiguous` and this test: a NaN
        // fails every comparison, an infinite `current` is never within tolerance of `t`.
        if !(step.is_finite() && step > 0.0 && current.is_finite() && contiguous && before_stop) {
            return self.refuse_step(f, current, step);
        }
        let mut ctx = Ctx::new(&self.logger, f);
        let r = self.model.step(&mut ctx, current, step);
        let cs = ctx.status();
        match r {
            Ok(()) => {
                self.shell.time = next;
                cs
            }
            Err(e) => self.step_failed(f, cs, e, next),
        }
    }

    /// The model's step returned an error: log it; a Discard leaves the instance at the
    /// communication point in [`Mode::StepFailed`], a mere warning moves time on.
    #[cold]
    #[inline(never)]
    fn step_failed(&mut self, f: &'static str, cs: Status, e: ModelError, next: f64) -> Status {
        let discarded = e.status == Status::Discard;
        let s = self.conclude(f, cs, Err(e));
        if s <= Status::Warning {
            self.shell.time = next;
        } else if discarded {
            self.shell.mode = Mode::StepFailed;
        }
        s
    }

    /// Log which rule a refused step broke (in the order a reader would check them).
    #[cold]
    #[inline(never)]
    fn refuse_step(&mut self, f: &'static str, current: f64, step: f64) -> Status {
        if !(step.is_finite() && step > 0.0) {
            return self.fail(
                f,
                Status::Error,
                format!("communicationStepSize must be finite and > 0, got {step}"),
            );
        }
        if !current.is_finite() {
            return self.fail(
                f,
                Status::Error,
                format!("currentCommunicationPoint must be finite, got {current}"),
            );
        }
        let t = self.shell.time;
        let tol = TIME_TOLERANCE * t.abs().max(1.0);
        if (current - t).abs() > tol {
            return self.fail(
                f,
                Status::Error,
                format!(
                    "currentCommunicationPoint = {current:?} but the FMU is at t = {t:?} (difference {:e}); \
                     steps must be contiguous (restore an FMU state to go back)",
                    current - t
                ),
            );
        }
        let stop = self.shell.stop_time.unwrap_or(f64::INFINITY);
        self.fail(
            f,
            Status::Error,
            format!("step from {current:?} by {step:?} would pass the stopTime {stop:?} of the experiment"),
        )
    }

    /// The Jacobian of `unknowns` with respect to `knowns` (row-major), every reference
    /// checked to be a Real of the table and every entry checked finite.
    fn checked_jacobian(
        &mut self,
        f: &'static str,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        seed_name: &str,
        seed_refs: &[u32],
    ) -> Result<Vec<f64>, Status> {
        for &vr in unknowns.iter().chain(knowns) {
            if let Err(m) = self.table.typed(vr, VarType::Real) {
                return Err(self.fail(f, Status::Error, m));
            }
        }
        if let Some((i, x)) = seed.iter().enumerate().find(|(_, x)| !x.is_finite()) {
            let name = self.table.get(seed_refs[i]).map_or("?", |v| v.name);
            return Err(self.fail(
                f,
                Status::Error,
                format!("{seed_name}[{i}] = {x} (for \"{name}\") is not finite"),
            ));
        }
        let j = match self.model.jacobian(unknowns, knowns) {
            Ok(j) => j,
            Err(e) => {
                let s = e.status.max(Status::Error);
                return Err(self.fail(f, s, e.message));
            }
        };
        if j.len() != unknowns.len() * knowns.len() {
            return Err(self.fail(
                f,
                Status::Error,
                format!(
                    "the model returned {} Jacobian entries for {} unknowns x {} knowns",
                    j.len(),
                    unknowns.len(),
                    knowns.len()
                ),
            ));
        }
        if let Some(k) = j.iter().position(|x| !x.is_finite()) {
            let (u, v) = (unknowns[k / knowns.len()], knowns[k % knowns.len()]);
            let name = |vr| self.table.get(vr).map_or("?", |v| v.name);
            let msg = format!(
                "the derivative of \"{}\" with respect to \"{}\" is not finite",
                name(u),
                name(v)
            );
            return Err(self.fail(f, Status::Error, msg));
        }
        Ok(j)
    }

    /// Directional derivative `sensitivity = J seed` (`fmi2GetDirectionalDerivative`,
    /// `fmi3GetDirectionalDerivative`), `seed` over the knowns, `sensitivity` over the
    /// unknowns (the shell checked both lengths). `seed_name` names the seed argument in
    /// messages (`dvKnown`, `seed`).
    pub fn directional_derivative(
        &mut self,
        f: &'static str,
        (unknowns, knowns): (&[u32], &[u32]),
        seed: &[f64],
        seed_name: &str,
        sensitivity: &mut [f64],
    ) -> Status {
        match self.checked_jacobian(f, unknowns, knowns, seed, seed_name, knowns) {
            Ok(j) => {
                let n = knowns.len();
                for (i, out) in sensitivity.iter_mut().enumerate() {
                    *out = (0..n).map(|k| j[i * n + k] * seed[k]).sum();
                }
                Status::Ok
            }
            Err(s) => s,
        }
    }

    /// Adjoint derivative `sensitivity = seed^T J` (`fmi3GetAdjointDerivative`), `seed` over
    /// the unknowns, `sensitivity` over the knowns.
    pub fn adjoint_derivative(
        &mut self,
        f: &'static str,
        (unknowns, knowns): (&[u32], &[u32]),
        seed: &[f64],
        sensitivity: &mut [f64],
    ) -> Status {
        match self.checked_jacobian(f, unknowns, knowns, seed, "seed", unknowns) {
            Ok(j) => {
                let n = knowns.len();
                for (k, out) in sensitivity.iter_mut().enumerate() {
                    *out = (0..unknowns.len()).map(|i| seed[i] * j[i * n + k]).sum();
                }
                Status::Ok
            }
            Err(s) => s,
        }
    }
}
