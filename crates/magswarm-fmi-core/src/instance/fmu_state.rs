//! FMU states behind the importer's opaque handles: get, set, free, serialize, deserialize.
//!
//! A handle is a `*mut Snapshot<M>` that this instance handed out; it is compared with the
//! instance's list before it is read, so a handle of another instance, a freed handle or
//! garbage is refused without touching its memory. The shells only read and write the
//! importer's `FMUstate` variables; everything else is here.

use std::ffi::c_void;

use super::{Instance, Interface};
use crate::mode::Mode;
use crate::model::FmuModel;
use crate::snapshot::{self, Snapshot, SNAPSHOT_MAGIC};
use crate::status::Status;

impl<M: FmuModel> Instance<M> {
    /// The snapshot behind `s`, if this instance handed it out and it was not freed.
    fn snapshot_of(&mut self, f: &'static str, s: *mut c_void) -> Result<*mut Snapshot<M>, Status> {
        if s.is_null() {
            return Err(self.fail(f, Status::Error, "argument FMUstate must not be NULL"));
        }
        let snap = s as *mut Snapshot<M>;
        if !self.states.contains(&snap) {
            return Err(self.fail(
                f,
                Status::Error,
                "FMUstate is not an FMU state of this instance (freed already, made by another \
                 instance, or not an FMU state)",
            ));
        }
        Ok(snap)
    }

    fn hand_out(&mut self, snap: Snapshot<M>) -> *mut c_void {
        let p = Box::into_raw(Box::new(snap));
        self.states.push(p);
        p as *mut c_void
    }

    /// Get the FMU state: a new snapshot if `current` is NULL (returned as the new handle),
    /// else overwrite the snapshot `current` names (which the standards say was returned
    /// earlier and not freed).
    pub fn get_fmu_state(
        &mut self,
        f: &'static str,
        current: *mut c_void,
    ) -> Result<*mut c_void, Status> {
        if current.is_null() {
            let snap = Snapshot {
                magic: SNAPSHOT_MAGIC,
                guid: self.guid,
                shell: self.shell,
                model: self.model.clone(),
                cached: None,
            };
            return Ok(self.hand_out(snap));
        }
        let snap = self.snapshot_of(f, current)?;
        // SAFETY: the snapshot is a live box of this instance (`snapshot_of` found it in
        // `self.states`), and nothing else references it during this call.
        let snap = unsafe { &mut *snap };
        snap.shell = self.shell;
        snap.model = self.model.clone();
        snap.cached = None;
        Ok(current)
    }

    /// Set the FMU state: the instance becomes what it was, mode included.
    pub fn set_fmu_state(&mut self, f: &'static str, state: *mut c_void) -> Status {
        let snap = match self.snapshot_of(f, state) {
            Ok(s) => s,
            Err(st) => return st,
        };
        // SAFETY: as in `get_fmu_state`.
        let snap = unsafe { &*snap };
        // A state saved by an instance of the other interface (serialized bytes carry the
        // mode) would leave this one in a mode it has no way out of.
        let me = self.interface == Interface::ModelExchange;
        let foreign = match snap.shell.mode {
            Mode::StepComplete | Mode::StepFailed => me,
            Mode::EventMode | Mode::ContinuousTimeMode => !me,
            _ => false,
        };
        if foreign {
            let kind = if me {
                "Model Exchange"
            } else {
                "Co-Simulation"
            };
            return self.fail(
                f,
                Status::Error,
                format!(
                    "the FMU state was saved in mode {} by an instance of the other interface; \
                     this instance was instantiated for {kind}",
                    snap.shell.mode.name()
                ),
            );
        }
        self.model = snap.model.clone();
        self.shell = snap.shell;
        Status::Ok
    }

    /// Free the FMU state `state` (NULL is a no-op). On success the shell sets the
    /// importer's variable to NULL.
    pub fn free_fmu_state(&mut self, f: &'static str, state: *mut c_void) -> Status {
        if state.is_null() {
            return Status::Ok;
        }
        let snap = match self.snapshot_of(f, state) {
            Ok(s) => s,
            Err(st) => return st,
        };
        self.states.retain(|&p| p != snap);
        // SAFETY: the snapshot is a live box of this instance (found in `self.states`), just
        // removed from the list, so it is dropped exactly once and nothing else refers to it.
        unsafe {
            (*snap).magic = 0;
            drop(Box::from_raw(snap));
        }
        Status::Ok
    }

    /// The serialized form of the FMU state `state`, computed once and cached in it; the
    /// closure gets the bytes.
    pub fn with_serialized<R>(
        &mut self,
        f: &'static str,
        state: *mut c_void,
        use_bytes: impl FnOnce(&mut Self, &[u8]) -> R,
    ) -> Result<R, Status> {
        let snap = self.snapshot_of(f, state)?;
        // SAFETY: as in `get_fmu_state`; the reference ends before this function returns.
        let s = unsafe { &mut *snap };
        if s.cached.is_none() {
            match snapshot::serialize(self.guid, &s.shell, &s.model) {
                Ok(b) => s.cached = Some(b),
                Err(e) => {
                    let st = e.status.max(Status::Error);
                    return Err(self.fail(f, st, format!("could not serialize: {}", e.message)));
                }
            }
        }
        let bytes = s.cached.take().unwrap_or_default();
        let r = use_bytes(self, &bytes);
        // SAFETY: as above; `use_bytes` cannot free the snapshot (it has no handle to it).
        unsafe { (*snap).cached = Some(bytes) };
        Ok(r)
    }

    /// Deserialize `bytes` into a new FMU state (every check of [`snapshot::deserialize`]),
    /// returned as its handle.
    pub fn deserialize_fmu_state(
        &mut self,
        f: &'static str,
        bytes: &[u8],
    ) -> Result<*mut c_void, Status> {
        match snapshot::deserialize(self.guid, bytes, self.model.clone()) {
            Ok((shell, model)) => Ok(self.hand_out(Snapshot {
                magic: SNAPSHOT_MAGIC,
                guid: self.guid,
                shell,
                model,
                cached: None,
            })),
            Err(e) => {
                let s = e.status.max(Status::Error);
                Err(self.fail(f, s, format!("invalid serialized state: {}", e.message)))
            }
        }
    }
}

/// The importer's side of the FMU-state functions, the same in FMI 2.0 and 3.0: read and
/// write its `FMUstate` variables and byte buffers (NULL refused, naming the argument as the
/// shell's version spells it). The shells only convert their C types.
impl<M: FmuModel> Instance<M> {
    /// `argument {arg} must not be NULL`.
    pub fn null_arg(&mut self, f: &'static str, arg: &str) -> Status {
        self.fail(f, Status::Error, format!("argument {arg} must not be NULL"))
    }

    /// `GetFMUState(state)`: a new snapshot if `*state` is NULL, else overwrite it; the handle
    /// is written to `*state`.
    ///
    /// # Safety
    /// `state` is NULL or points to the importer's readable and writable state variable.
    pub unsafe fn get_fmu_state_at(
        &mut self,
        f: &'static str,
        state: *mut *mut c_void,
        arg: &str,
    ) -> Status {
        if state.is_null() {
            return self.null_arg(f, arg);
        }
        // SAFETY: non-NULL and the importer's variable (caller's contract).
        let current = unsafe { *state };
        match self.get_fmu_state(f, current) {
            Ok(p) => {
                // SAFETY: as above.
                unsafe { *state = p };
                Status::Ok
            }
            Err(s) => s,
        }
    }

    /// `FreeFMUState(state)`: free `*state` and set it to NULL (NULL `*state` is a no-op).
    ///
    /// # Safety
    /// As [`Instance::get_fmu_state_at`].
    pub unsafe fn free_fmu_state_at(
        &mut self,
        f: &'static str,
        state: *mut *mut c_void,
        arg: &str,
    ) -> Status {
        if state.is_null() {
            return self.null_arg(f, arg);
        }
        // SAFETY: non-NULL and the importer's variable (caller's contract).
        let s = self.free_fmu_state(f, unsafe { *state });
        if s == Status::Ok {
            // SAFETY: as above.
            unsafe { *state = std::ptr::null_mut() };
        }
        s
    }

    /// `SerializedFMUStateSize(state, size)`.
    ///
    /// # Safety
    /// `size` is NULL or points to the importer's writable variable.
    pub unsafe fn serialized_size_at(
        &mut self,
        f: &'static str,
        state: *mut c_void,
        size: *mut usize,
    ) -> Status {
        if size.is_null() {
            return self.null_arg(f, "size");
        }
        match self.with_serialized(f, state, |_, b| b.len()) {
            Ok(n) => {
                // SAFETY: non-NULL (checked above), the importer's variable.
                unsafe { *size = n };
                Status::Ok
            }
            Err(s) => s,
        }
    }

    /// `SerializeFMUState(state, buffer, size)`: `size` must be what `size_fn` (the version's
    /// `SerializedFMUStateSize`) returned.
    ///
    /// # Safety
    /// `buffer` is NULL or the importer's writable buffer of `size` bytes.
    pub unsafe fn serialize_into(
        &mut self,
        f: &'static str,
        state: *mut c_void,
        buffer: *mut u8,
        size: usize,
        size_fn: &str,
    ) -> Status {
        let copy = |i: &mut Self, bytes: &[u8]| {
            if size != bytes.len() {
                let msg = format!(
                    "size = {size} but the serialized state has {} bytes (see {size_fn})",
                    bytes.len()
                );
                return i.fail(f, Status::Error, msg);
            }
            // SAFETY: the importer's buffer of `size` bytes (caller's contract), which is not
            // the snapshot's cache it is copied from.
            let Some(out) = (unsafe { crate::ffi::slice_mut(buffer, size) }) else {
                return i.null_arg(f, "serializedState");
            };
            out.copy_from_slice(bytes);
            Status::Ok
        };
        self.with_serialized(f, state, copy).unwrap_or_else(|s| s)
    }

    /// `DeserializeFMUState(bytes, size, state)`: always a new FMU state, written to `*state`
    /// (the incoming value is not read: importers often pass it uninitialised).
    ///
    /// # Safety
    /// `bytes` is NULL or the importer's buffer of `size` bytes; `state` as in
    /// [`Instance::get_fmu_state_at`].
    pub unsafe fn deserialize_at(
        &mut self,
        f: &'static str,
        bytes: *const u8,
        size: usize,
        state: *mut *mut c_void,
        arg: &str,
    ) -> Status {
        if state.is_null() {
            return self.null_arg(f, arg);
        }
        // SAFETY: the importer's buffer of `size` bytes (caller's contract).
        let Some(b) = (unsafe { crate::ffi::slice(bytes, size) }) else {
            return self.null_arg(f, "serializedState");
        };
        match self.deserialize_fmu_state(f, b) {
            Ok(p) => {
                // SAFETY: non-NULL (checked above), the importer's variable.
                unsafe { *state = p };
                Status::Ok
            }
            Err(s) => s,
        }
    }
}
