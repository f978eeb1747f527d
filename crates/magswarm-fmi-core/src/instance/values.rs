//! Getting and setting variables: every reference checked against the table (type,
//! causality, the mode) before any value is touched, non-finite Reals refused by name.
//!
//! The independent variable (time), if the table has one, is answered by the instance
//! itself (its current time), never by the model.

use std::ffi::CString;

use super::Instance;
use crate::log::Ctx;
use crate::mode::may_set;
use crate::model::FmuModel;
use crate::status::{ModelError, Status};
use crate::variable::{VarType, Variable};

impl<M: FmuModel> Instance<M> {
    /// Check every reference; `Ok(true)` when one of them is the independent variable.
    #[inline(always)]
    fn check_get(&mut self, f: &'static str, vrs: &[u32], ty: VarType) -> Result<bool, Status> {
        let mut time = false;
        for &vr in vrs {
            match self.table.is_typed(vr, ty) {
                Some(independent) => time |= independent,
                None => return Err(self.refuse_reference(f, vr, ty)),
            }
        }
        Ok(time)
    }

    /// `vr` is not a variable of type `ty`: say which it is, if any.
    #[cold]
    #[inline(never)]
    fn refuse_reference(&mut self, f: &'static str, vr: u32, ty: VarType) -> Status {
        match self.table.typed(vr, ty) {
            Err(m) => self.fail(f, Status::Error, m),
            Ok(_) => Status::Ok,
        }
    }

    #[cold]
    #[inline(never)]
    fn getter_error(&mut self, f: &'static str, var_vr: u32, e: ModelError) -> Status {
        let name = self.table.get(var_vr).map_or("?", |v| v.name);
        self.fail(
            f,
            e.status.max(Status::Error),
            format!("variable \"{name}\": {}", e.message),
        )
    }

    /// Get Reals (`fmi2GetReal`, `fmi3GetFloat64`). Inline in the shells' entry points (a
    /// master reads its outputs every step; one function instead of two saves a prologue).
    #[inline(always)]
    pub fn get_real(&mut self, f: &'static str, vrs: &[u32], out: &mut [f64]) -> Status {
        let time = match self.check_get(f, vrs, VarType::Real) {
            Ok(time) => time,
            Err(s) => return s,
        };
        if !time {
            // The common case (a master reading outputs): the model answers all at once.
            return match self.model.get_reals(vrs, out) {
                Ok(()) => Status::Ok,
                Err((vr, e)) => self.getter_error(f, vr, e),
            };
        }
        let time_vr = self.table.independent();
        for (&vr, o) in vrs.iter().zip(out.iter_mut()) {
            if Some(vr) == time_vr {
                *o = self.shell.time;
                continue;
            }
            match self.model.get_real(vr) {
                Ok(x) => *o = x,
                Err(e) => return self.getter_error(f, vr, e),
            }
        }
        Status::Ok
    }

    /// Get Integers (`fmi2GetInteger`, `fmi3GetInt32`).
    pub fn get_integer(&mut self, f: &'static str, vrs: &[u32], out: &mut [i32]) -> Status {
        if let Err(s) = self.check_get(f, vrs, VarType::Integer) {
            return s;
        }
        for (&vr, o) in vrs.iter().zip(out.iter_mut()) {
            match self.model.get_integer(vr) {
                Ok(x) => *o = x,
                Err(e) => return self.getter_error(f, vr, e),
            }
        }
        Status::Ok
    }

    /// Get Booleans, written as the shell's C type (`fmi2Boolean` is an int, `fmi3Boolean`
    /// a `bool`) from 1 or 0.
    pub fn get_boolean<B: From<bool>>(
        &mut self,
        f: &'static str,
        vrs: &[u32],
        out: &mut [B],
    ) -> Status {
        if let Err(s) = self.check_get(f, vrs, VarType::Boolean) {
            return s;
        }
        for (&vr, o) in vrs.iter().zip(out.iter_mut()) {
            match self.model.get_boolean(vr) {
                Ok(x) => *o = B::from(x),
                Err(e) => return self.getter_error(f, vr, e),
            }
        }
        Status::Ok
    }

    /// Get Strings: fills `out` with pointers into strings owned by the instance.
    pub fn get_string(
        &mut self,
        f: &'static str,
        vrs: &[u32],
        out: &mut [*const std::ffi::c_char],
    ) -> Status {
        if let Err(s) = self.check_get(f, vrs, VarType::String) {
            return s;
        }
        self.strings.clear();
        for &vr in vrs {
            match self.model.get_string(vr) {
                Ok(s) => match CString::new(s) {
                    Ok(c) => self.strings.push(c),
                    Err(_) => {
                        let e = ModelError::error("value contains a NUL character");
                        return self.getter_error(f, vr, e);
                    }
                },
                Err(e) => return self.getter_error(f, vr, e),
            }
        }
        for (o, c) in out.iter_mut().zip(&self.strings) {
            *o = c.as_ptr();
        }
        Status::Ok
    }

    /// Check every reference before setting anything, so a bad call leaves no variable
    /// half-set.
    #[inline(always)]
    fn check_set(&mut self, f: &'static str, vrs: &[u32], ty: VarType) -> Result<(), Status> {
        let mode = self.shell.mode;
        for &vr in vrs {
            if !self.table.is_settable(vr, ty, mode) {
                return Err(self.refuse_set(f, vr, ty));
            }
        }
        Ok(())
    }

    /// `vr` cannot be set now: not a variable of type `ty`, or not settable in this mode
    /// ([`may_set`] says why).
    #[cold]
    #[inline(never)]
    fn refuse_set(&mut self, f: &'static str, vr: u32, ty: VarType) -> Status {
        let var: &Variable = match self.table.typed(vr, ty) {
            Ok(v) => v,
            Err(m) => return self.fail(f, Status::Error, m),
        };
        match may_set(var, self.shell.mode) {
            Err(m) => self.fail(f, Status::Error, m),
            Ok(()) => Status::Ok,
        }
    }

    #[inline(always)]
    fn setter_result(
        &mut self,
        f: &'static str,
        vr: u32,
        r: Result<(), ModelError>,
        worst: &mut Status,
    ) -> bool {
        match r {
            Ok(()) => true,
            Err(e) => self.setter_failed(f, vr, e, worst),
        }
    }

    #[cold]
    #[inline(never)]
    fn setter_failed(
        &mut self,
        f: &'static str,
        vr: u32,
        mut e: ModelError,
        worst: &mut Status,
    ) -> bool {
        let name = self.table.get(vr).map_or("?", |v| v.name);
        e.message = format!("variable \"{name}\": {}", e.message);
        let s = self.conclude(f, Status::Ok, Err(e));
        *worst = (*worst).max(s);
        s <= Status::Warning
    }

    #[cold]
    #[inline(never)]
    fn non_finite(&mut self, f: &'static str, vr: u32, x: f64) -> Status {
        let name = self.table.get(vr).map_or("?", |v| v.name);
        let msg = format!(
            "value {x} for variable \"{name}\" (value reference {vr}) is not finite; rejected, the variable keeps its value"
        );
        self.fail(f, Status::Error, msg)
    }

    /// Set Reals (`fmi2SetReal`, `fmi3SetFloat64`): non-finite values are refused, naming the
    /// variable. Inline in the shells' entry points, as [`Instance::get_real`].
    #[inline(always)]
    pub fn set_real(&mut self, f: &'static str, vrs: &[u32], values: &[f64]) -> Status {
        if let Err(s) = self.check_set(f, vrs, VarType::Real) {
            return s;
        }
        for (&vr, &x) in vrs.iter().zip(values) {
            if !x.is_finite() {
                return self.non_finite(f, vr, x);
            }
        }
        let mut worst = Status::Ok;
        for (&vr, &x) in vrs.iter().zip(values) {
            let mut ctx = Ctx::new(&self.logger, f);
            let r = self.model.set_real(&mut ctx, vr, x);
            worst = worst.max(ctx.status());
            if !self.setter_result(f, vr, r, &mut worst) {
                break;
            }
        }
        worst
    }

    /// Set Integers.
    pub fn set_integer(&mut self, f: &'static str, vrs: &[u32], values: &[i32]) -> Status {
        if let Err(s) = self.check_set(f, vrs, VarType::Integer) {
            return s;
        }
        let mut worst = Status::Ok;
        for (&vr, &x) in vrs.iter().zip(values) {
            let mut ctx = Ctx::new(&self.logger, f);
            let r = self.model.set_integer(&mut ctx, vr, x);
            worst = worst.max(ctx.status());
            if !self.setter_result(f, vr, r, &mut worst) {
                break;
            }
        }
        worst
    }

    /// Set Booleans (the shell has turned its C type into `bool`: any non-zero value is true).
    pub fn set_boolean(&mut self, f: &'static str, vrs: &[u32], values: &[bool]) -> Status {
        if let Err(s) = self.check_set(f, vrs, VarType::Boolean) {
            return s;
        }
        let mut worst = Status::Ok;
        for (&vr, &x) in vrs.iter().zip(values) {
            let mut ctx = Ctx::new(&self.logger, f);
            let r = self.model.set_boolean(&mut ctx, vr, x);
            worst = worst.max(ctx.status());
            if !self.setter_result(f, vr, r, &mut worst) {
                break;
            }
        }
        worst
    }

    /// Set Strings, with the C strings already decoded (`None`: NULL or not UTF-8).
    pub fn set_string(&mut self, f: &'static str, vrs: &[u32], values: &[Option<&str>]) -> Status {
        if let Err(s) = self.check_set(f, vrs, VarType::String) {
            return s;
        }
        for (&vr, v) in vrs.iter().zip(values) {
            if v.is_none() {
                let name = self.table.get(vr).map_or("?", |v| v.name);
                let msg = format!("value for variable \"{name}\" is NULL or not valid UTF-8");
                return self.fail(f, Status::Error, msg);
            }
        }
        let mut worst = Status::Ok;
        for (&vr, v) in vrs.iter().zip(values) {
            let mut ctx = Ctx::new(&self.logger, f);
            let r = self.model.set_string(&mut ctx, vr, v.unwrap_or_default());
            worst = worst.max(ctx.status());
            if !self.setter_result(f, vr, r, &mut worst) {
                break;
            }
        }
        worst
    }
}
