//! The GUID: a hash of the variable table and metadata.
//!
//! FMI 2.0 uses the GUID to make sure a binary is paired with the modelDescription.xml it
//! was made for. Both sides compute it with [`guid`] from the same [`ModelInfo`], so they
//! cannot drift: change a variable, a unit or the version, and both change together.
//!
//! Start values are deliberately *not* hashed: packaging may bake different defaults
//! (e.g. a fitted model file in `resources/`) into the XML's start values without
//! rebuilding the binary, and that must not break instantiation.

use std::fmt::Write as _;

use crate::info::ModelInfo;
use crate::model::FmuModel;

const FNV128_OFFSET: u128 = 0x6c62272e07bb014262b821756295c58d;
const FNV128_PRIME: u128 = 0x0000000001000000000000000000013B;

/// 128-bit FNV-1a: deterministic across platforms and Rust versions (unlike `DefaultHasher`).
pub fn fnv1a_128(bytes: &[u8]) -> u128 {
    let mut h = FNV128_OFFSET;
    for &b in bytes {
        h ^= b as u128;
        h = h.wrapping_mul(FNV128_PRIME);
    }
    h
}

/// 64-bit FNV-1a (checksums of serialized states).
pub fn fnv1a_64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf29ce484222325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x100000001b3);
    }
    h
}

/// The text that is hashed: every structural field of the description, one per line.
pub fn canonical_text(info: &ModelInfo) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "fmi2-cs-shell/1");
    let _ = writeln!(
        s,
        "id={:?} name={:?} version={:?} descr={:?} author={:?} tool={:?} naming={:?}",
        info.model_identifier,
        info.model_name,
        info.version,
        info.description,
        info.author,
        info.generation_tool,
        info.naming_convention
    );
    for u in info.units {
        let _ = writeln!(s, "unit {:?} {:?}", u.name, u.base);
        for d in u.display_units {
            let _ = writeln!(s, "  display {:?} {:?} {:?}", d.name, d.factor, d.offset);
        }
    }
    for c in info.log_categories {
        let _ = writeln!(s, "category {:?}", c.name);
    }
    for v in info.variables {
        let _ = writeln!(
            s,
            "var {:?} vr={} {:?} {:?} {:?} init={:?} unit={:?} disp={:?} min={:?} max={:?} nom={:?} deps={:?} ideps={:?} der={:?} descr={:?}",
            v.name,
            v.vr,
            v.ty,
            v.causality,
            v.variability,
            v.effective_initial(),
            v.unit,
            v.display_unit,
            v.min,
            v.max,
            v.nominal,
            v.dependencies,
            v.initial_dependencies,
            v.derivative_of,
            v.description
        );
    }
    s
}

/// The GUID as a 128-bit number.
pub fn guid_u128(info: &ModelInfo) -> u128 {
    fnv1a_128(canonical_text(info).as_bytes())
}

/// Format 128 bits as `{xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx}`.
pub fn format_guid(h: u128) -> String {
    let x = format!("{h:032x}");
    format!(
        "{{{}-{}-{}-{}-{}}}",
        &x[0..8],
        &x[8..12],
        &x[12..16],
        &x[16..20],
        &x[20..32]
    )
}

/// The GUID of a model description.
pub fn guid_of(info: &ModelInfo) -> String {
    format_guid(guid_u128(info))
}

/// The GUID of model `M`: what `modelDescription.xml` says and what `fmi2Instantiate` expects.
pub fn guid<M: FmuModel>() -> String {
    guid_of(M::model_info())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv_known_values() {
        // Published FNV-1a test vectors.
        assert_eq!(fnv1a_64(b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a_64(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(fnv1a_128(b""), FNV128_OFFSET);
        assert_eq!(fnv1a_128(b"a"), 0xd228cb696f1a8caf78912b704e4a8964);
    }

    #[test]
    fn guid_shape() {
        let g = format_guid(0x0123456789abcdef0011223344556677);
        assert_eq!(g, "{01234567-89ab-cdef-0011-223344556677}");
    }
}
