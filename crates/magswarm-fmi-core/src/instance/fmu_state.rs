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
