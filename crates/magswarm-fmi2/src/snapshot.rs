//! FMU states: in-memory snapshots (`fmi2GetFMUstate`) and their byte form
//! (`fmi2SerializeFMUstate`).
//!
//! A snapshot is a clone of the model plus the shell's own state (mode, time, experiment
//! setup), so restoring it puts the instance back exactly, including which calls are
//! allowed. The logger, instance name and resource location are *not* part of it: they
//! belong to the instance, not to the simulation state.
//!
//! Serialized layout (little-endian):
//!
//! | bytes | content |
//! | --- | --- |
//! | 8 | magic `FMI2STAT` |
//! | 4 | format version (1) |
//! | 16 | GUID of the model (as 128 bits) |
//! | 1 + 8 + 8 + 1 + 8 + 1 + 8 | mode, time, start time, stop time (flag + value), tolerance (flag + value) |
//! | 8 + n | model payload length and bytes ([`crate::FmuModel::serialize_state`]) |
//! | 8 | FNV-1a 64 checksum of everything before it |
//!
//! Every field is validated on the way in, so truncated, foreign or corrupted bytes give
//! `fmi2Error` with a reason, never a crash or a half-restored instance.

use crate::bytes::{ByteReader, PutBytes};
use crate::guid::fnv1a_64;
use crate::model::{Fmi2Err, FmuModel};
use crate::state::Mode;

/// First word of a live snapshot ("FMI2SNAP"), to recognise our pointers.
pub(crate) const SNAPSHOT_MAGIC: u64 = u64::from_le_bytes(*b"FMI2SNAP");
/// Magic bytes at the start of a serialized state.
pub const SERIAL_MAGIC: &[u8; 8] = b"FMI2STAT";
/// Version of the serialized layout.
pub const SERIAL_VERSION: u32 = 1;

/// What the shell itself keeps besides the model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShellState {
    /// State-machine state.
    pub mode: Mode,
    /// Current communication point.
    pub time: f64,
    /// From `fmi2SetupExperiment`.
    pub start_time: f64,
    /// From `fmi2SetupExperiment` (`None`: not defined).
    pub stop_time: Option<f64>,
    /// From `fmi2SetupExperiment` (`None`: not defined).
    pub tolerance: Option<f64>,
}

impl ShellState {
    /// The state right after `fmi2Instantiate` / `fmi2Reset`.
    pub fn fresh() -> Self {
        ShellState {
            mode: Mode::Instantiated,
            time: 0.0,
            start_time: 0.0,
            stop_time: None,
            tolerance: None,
        }
    }
}

/// A saved FMU state, handed to the importer as `fmi2FMUstate`.
#[repr(C)]
pub struct Snapshot<M> {
    /// [`SNAPSHOT_MAGIC`] while alive (first field: checked through a `*const u64`).
    pub(crate) magic: u64,
    /// GUID of the model type, so states of another FMU are refused.
    pub(crate) guid: u128,
    pub(crate) shell: ShellState,
    pub(crate) model: M,
    /// Serialized form, computed once by `fmi2SerializedFMUstateSize` and reused.
    pub(crate) cached: Option<Vec<u8>>,
}

/// Serialize shell state and model into the layout above.
pub fn serialize<M: FmuModel>(
    guid: u128,
    shell: &ShellState,
    model: &M,
) -> Result<Vec<u8>, Fmi2Err> {
    let mut payload = Vec::new();
    model.serialize_state(&mut payload)?;
    let mut out = Vec::with_capacity(payload.len() + 96);
    out.extend_from_slice(SERIAL_MAGIC);
    out.put_u32(SERIAL_VERSION);
    out.extend_from_slice(&guid.to_le_bytes());
    out.put_u8(shell.mode.to_byte());
    out.put_f64(shell.time);
    out.put_f64(shell.start_time);
    put_opt(&mut out, shell.stop_time);
    put_opt(&mut out, shell.tolerance);
    out.put_bytes(&payload);
    let sum = fnv1a_64(&out);
    out.put_u64(sum);
    Ok(out)
}

fn put_opt(out: &mut Vec<u8>, x: Option<f64>) {
    out.put_bool(x.is_some());
    out.put_f64(x.unwrap_or(0.0));
}

fn get_opt(r: &mut ByteReader<'_>) -> Result<Option<f64>, Fmi2Err> {
    let some = r.bool()?;
    let x = r.f64()?;
    Ok(some.then_some(x))
}

/// A deserialized shell state must be one the shell could have saved: the checksum only
/// proves the bytes were not damaged, not that whoever wrote them was honest.
fn validate_shell(
    mode: Mode,
    time: f64,
    start_time: f64,
    stop_time: Option<f64>,
    tolerance: Option<f64>,
) -> Result<(), Fmi2Err> {
    let bad = |m: String| Err(Fmi2Err::error(format!("serialized FMU state: {m}")));
    if mode == Mode::Fatal {
        // fmi2GetFMUstate is refused in Fatal, so no genuine state is in it.
        return bad("mode Fatal cannot have been saved".into());
    }
    if !time.is_finite() || !start_time.is_finite() {
        return bad(format!("non-finite time {time} or start time {start_time}"));
    }
    let slack = crate::instance::TIME_TOLERANCE * start_time.abs().max(time.abs()).max(1.0);
    if time < start_time - slack {
        return bad(format!("time {time} is before the start time {start_time}"));
    }
    if let Some(stop) = stop_time {
        if !(stop.is_finite() && stop >= start_time && time <= stop + slack) {
            return bad(format!(
                "stop time {stop} is inconsistent with start time {start_time} and time {time}"
            ));
        }
    }
    if let Some(tol) = tolerance {
        if !(tol.is_finite() && tol > 0.0) {
            return bad(format!("tolerance {tol} must be finite and > 0"));
        }
    }
    Ok(())
}

/// Validate and decode bytes from [`serialize`]. `template` is a clone of the live model,
/// overwritten by [`FmuModel::deserialize_state`].
pub fn deserialize<M: FmuModel>(
    guid: u128,
    bytes: &[u8],
    mut template: M,
) -> Result<(ShellState, M), Fmi2Err> {
    if bytes.len() < SERIAL_MAGIC.len() || &bytes[..8] != SERIAL_MAGIC {
        return Err(Fmi2Err::error(
            "not a serialized FMU state of this FMU (bad magic bytes)",
        ));
    }
    if bytes.len() < 8 + 8 {
        return Err(Fmi2Err::error("serialized FMU state is truncated"));
    }
    let (body, sum) = bytes.split_at(bytes.len() - 8);
    let expected = u64::from_le_bytes(sum.try_into().expect("8 bytes"));
    if fnv1a_64(body) != expected {
        return Err(Fmi2Err::error(
            "serialized FMU state is corrupted (checksum mismatch)",
        ));
    }
    let mut r = ByteReader::new(body);
    r.take(8)?;
    let version = r.u32()?;
    if version != SERIAL_VERSION {
        return Err(Fmi2Err::error(format!(
            "serialized FMU state has layout version {version}, this FMU reads version {SERIAL_VERSION}"
        )));
    }
    let g = u128::from_le_bytes(r.take(16)?.try_into().expect("16 bytes"));
    if g != guid {
        return Err(Fmi2Err::error(
            "serialized FMU state was made by a different FMU (GUID mismatch)".to_string(),
        ));
    }
    let mode_byte = r.u8()?;
    let mode = Mode::from_byte(mode_byte).ok_or_else(|| {
        Fmi2Err::error(format!(
            "serialized FMU state has an invalid mode byte {mode_byte}"
        ))
    })?;
    let time = r.f64()?;
    let start_time = r.f64()?;
    let stop_time = get_opt(&mut r)?;
    let tolerance = get_opt(&mut r)?;
    let payload = r.bytes()?;
    r.finish()?;
    validate_shell(mode, time, start_time, stop_time, tolerance)?;
    template.deserialize_state(payload)?;
    Ok((
        ShellState {
            mode,
            time,
            start_time,
            stop_time,
            tolerance,
        },
        template,
    ))
}
