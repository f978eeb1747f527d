//! FMU states: in-memory snapshots (`fmi2GetFMUstate`, `fmi3GetFMUState`) and their byte
//! form (`fmi2SerializeFMUstate`, `fmi3SerializeFMUState`).
//!
//! A snapshot is a clone of the model plus the shell's own state (mode, time, experiment
//! setup), so restoring it puts the instance back exactly, including which calls are
//! allowed. The logger, instance name and resource location are *not* part of it: they
//! belong to the instance, not to the simulation state.
//!
//! # Serialized form
//!
//! Two layers. The *payload* is the CBOR encoding (RFC 8949, through `ciborium`) of
//! `{shell, model}`: the shell's state and the model's [`FmuModel::State`], which the model
//! declares as a serde type and never encodes itself. CBOR is self-describing (the models'
//! serde attributes, such as skipped `None` fields, work) and keeps every `f64` bit for bit
//! (NaN payloads included), so a restored state replays bit-identically. The *frame* around it
//! says what the bytes are and proves them intact (all integers little-endian):
//!
//! | bytes | content |
//! | --- | --- |
//! | 8 | magic `FMI2STAT` |
//! | 4 | frame layout version ([`SERIAL_VERSION`]) |
//! | 16 | GUID of the model (as 128 bits) |
//! | 4 | version of the model's state type ([`FmuModel::STATE_VERSION`]) |
//! | 8 | payload length n |
//! | 4 | CRC-32 (IEEE) of the 40 header bytes before it and of the payload |
//! | n | payload |
//!
//! [`deserialize`] checks, in this order and each with its own message: length of the
//! header, magic, layout version, payload length, checksum, GUID, state version, the CBOR
//! decoding, the shell state's plausibility, and finally the model's own validation
//! ([`FmuModel::restore_state`]). So truncated, foreign, corrupted or forged bytes give
//! an error naming the check that failed, never a crash or a half-restored instance.

use serde::{Deserialize, Serialize};

use crate::mode::Mode;
use crate::model::FmuModel;
use crate::status::ModelError;

/// First word of a live snapshot ("FMI2SNAP"), to recognise our pointers.
pub const SNAPSHOT_MAGIC: u64 = u64::from_le_bytes(*b"FMI2SNAP");
/// Magic bytes at the start of a serialized state.
pub const SERIAL_MAGIC: &[u8; 8] = b"FMI2STAT";
/// Version of the frame layout (1 was a hand-written payload with an FNV-1a checksum).
pub const SERIAL_VERSION: u32 = 2;
/// Bytes of the frame before the payload.
pub const HEADER_LEN: usize = 44;
/// Offset of the CRC-32 in the header (it covers the bytes before it and the payload).
const CRC_AT: usize = 40;

/// What the shell itself keeps besides the model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShellState {
    /// State-machine state.
    pub mode: Mode,
    /// Current communication point.
    pub time: f64,
    /// From the experiment.
    pub start_time: f64,
    /// From the experiment (`None`: not defined).
    pub stop_time: Option<f64>,
    /// From the experiment (`None`: not defined).
    pub tolerance: Option<f64>,
}

impl ShellState {
    /// The state right after instantiation or reset.
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

/// A saved FMU state, handed to the importer as its opaque `FMUstate` handle.
#[repr(C)]
pub struct Snapshot<M> {
    /// [`SNAPSHOT_MAGIC`] while alive (first field: checked through a `*const u64`).
    pub(crate) magic: u64,
    /// GUID of the model type, so states of another FMU are refused.
    pub(crate) guid: u128,
    pub(crate) shell: ShellState,
    pub(crate) model: M,
    /// Serialized form, computed once by the size query and reused.
    pub(crate) cached: Option<Vec<u8>>,
}

/// The shell's part of the payload (the mode as its stable byte, see [`Mode::to_byte`]).
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SavedShell {
    mode: u8,
    time: f64,
    start_time: f64,
    stop_time: Option<f64>,
    tolerance: Option<f64>,
}

#[derive(Serialize)]
struct PayloadOut<'a, S> {
    shell: SavedShell,
    model: &'a S,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PayloadIn<S> {
    shell: SavedShell,
    model: S,
}

fn crc(header: &[u8], payload: &[u8]) -> u32 {
    let mut h = crc32fast::Hasher::new();
    h.update(header);
    h.update(payload);
    h.finalize()
}

/// Wrap a payload in the frame described above.
pub fn frame(guid: u128, state_version: u32, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_LEN + payload.len());
    out.extend_from_slice(SERIAL_MAGIC);
    out.extend_from_slice(&SERIAL_VERSION.to_le_bytes());
    out.extend_from_slice(&guid.to_le_bytes());
    out.extend_from_slice(&state_version.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    let sum = crc(&out, payload);
    out.extend_from_slice(&sum.to_le_bytes());
    out.extend_from_slice(payload);
    out
}

fn le<const N: usize>(b: &[u8], at: usize) -> [u8; N] {
    let mut a = [0u8; N];
    a.copy_from_slice(&b[at..at + N]);
    a
}

/// Check the frame of `bytes` (every check named in the module documentation up to the
/// state version) and return its payload.
pub fn unframe(guid: u128, state_version: u32, bytes: &[u8]) -> Result<&[u8], ModelError> {
    let bad = |m: String| Err(ModelError::error(format!("serialized FMU state {m}")));
    if bytes.len() < HEADER_LEN {
        if bytes.len() >= SERIAL_MAGIC.len() && &bytes[..8] != SERIAL_MAGIC {
            return bad("rejected: bad magic bytes (not an FMU state of this FMU)".into());
        }
        return bad(format!(
            "is truncated: {} bytes, but the header alone has {HEADER_LEN}",
            bytes.len()
        ));
    }
    if &bytes[..8] != SERIAL_MAGIC {
        return bad("rejected: bad magic bytes (not an FMU state of this FMU)".into());
    }
    let version = u32::from_le_bytes(le(bytes, 8));
    if version != SERIAL_VERSION {
        return bad(format!(
            "rejected: frame layout version {version}, this FMU reads version {SERIAL_VERSION}"
        ));
    }
    let n = u64::from_le_bytes(le(bytes, 32));
    let present = (bytes.len() - HEADER_LEN) as u64;
    if n > present {
        return bad(format!(
            "is truncated: the header announces {n} payload bytes but only {present} follow"
        ));
    }
    if n < present {
        return bad(format!(
            "rejected: {} unexpected bytes after the {n} payload bytes the header announces",
            present - n
        ));
    }
    let payload = &bytes[HEADER_LEN..];
    let stored = u32::from_le_bytes(le(bytes, CRC_AT));
    let computed = crc(&bytes[..CRC_AT], payload);
    if stored != computed {
        return bad(format!(
            "is corrupted: CRC-32 checksum mismatch (stored {stored:#010x}, computed {computed:#010x})"
        ));
    }
    let g = u128::from_le_bytes(le(bytes, 12));
    if g != guid {
        return bad(format!(
            "was made by a different FMU: GUID {} instead of {}",
            crate::guid::format_guid(g),
            crate::guid::format_guid(guid)
        ));
    }
    let sv = u32::from_le_bytes(le(bytes, 28));
    if sv != state_version {
        return bad(format!(
            "rejected: the model's state has version {sv}, this build of the FMU reads version \
             {state_version} (saved by another version of the FMU)"
        ));
    }
    Ok(payload)
}

/// Serialize shell state and model (through [`FmuModel::save_state`]) into the form above.
pub fn serialize<M: FmuModel>(
    guid: u128,
    shell: &ShellState,
    model: &M,
) -> Result<Vec<u8>, ModelError> {
    let state = model.save_state()?;
    let payload = PayloadOut {
        shell: SavedShell {
            mode: shell.mode.to_byte(),
            time: shell.time,
            start_time: shell.start_time,
            stop_time: shell.stop_time,
            tolerance: shell.tolerance,
        },
        model: &state,
    };
    let mut bytes = Vec::new();
    ciborium::into_writer(&payload, &mut bytes)
        .map_err(|e| ModelError::error(format!("the model's state cannot be encoded: {e}")))?;
    Ok(frame(guid, M::STATE_VERSION, &bytes))
}

/// A deserialized shell state must be one the shell could have saved: the checksum only
/// proves the bytes were not damaged, not that whoever wrote them was honest.
fn validate_shell(
    mode: Mode,
    time: f64,
    start_time: f64,
    stop_time: Option<f64>,
    tolerance: Option<f64>,
) -> Result<(), ModelError> {
    let bad = |m: String| Err(ModelError::error(format!("serialized FMU state: {m}")));
    if mode == Mode::Fatal {
        // Getting an FMU state is refused in Fatal, so no genuine state is in it.
        return bad("mode Fatal cannot have been saved".into());
    }
    if !time.is_finite() || !start_time.is_finite() {
        return bad(format!("non-finite time {time} or start time {start_time}"));
    }
    let slack = crate::TIME_TOLERANCE * start_time.abs().max(time.abs()).max(1.0);
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
/// given the decoded state by [`FmuModel::restore_state`] (which validates it).
pub fn deserialize<M: FmuModel>(
    guid: u128,
    bytes: &[u8],
    mut template: M,
) -> Result<(ShellState, M), ModelError> {
    let mut payload = unframe(guid, M::STATE_VERSION, bytes)?;
    let decoded: PayloadIn<M::State> = ciborium::from_reader(&mut payload).map_err(|e| {
        ModelError::error(format!(
            "serialized FMU state: the payload does not decode as this FMU's state: {e}"
        ))
    })?;
    if !payload.is_empty() {
        return Err(ModelError::error(format!(
            "serialized FMU state: {} bytes left over after the decoded state",
            payload.len()
        )));
    }
    let s = decoded.shell;
    let mode = Mode::from_byte(s.mode).ok_or_else(|| {
        ModelError::error(format!(
            "serialized FMU state has an invalid mode byte {}",
            s.mode
        ))
    })?;
    validate_shell(mode, s.time, s.start_time, s.stop_time, s.tolerance)?;
    template
        .restore_state(decoded.model)
        .map_err(|e| ModelError {
            message: format!("serialized FMU state: the model refused it: {}", e.message),
            ..e
        })?;
    Ok((
        ShellState {
            mode,
            time: s.time,
            start_time: s.start_time,
            stop_time: s.stop_time,
            tolerance: s.tolerance,
        },
        template,
    ))
}
