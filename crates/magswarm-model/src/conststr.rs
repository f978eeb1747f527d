//! `&'static str` joined at compile time from constant parts.
//!
//! The registry's effect rows carry names such as `phase_lag.f_so_hz`, built from the
//! effect's name (which is written once, in the list of effects) and the field's. The FMU's
//! parameter table lives in a library that importers load and unload, so the rows must be
//! static data, not strings built and leaked at run time: [`concat_str!`] joins them while
//! compiling.

/// Total length of the parts.
pub(crate) const fn total_len(parts: &[&str]) -> usize {
    let mut n = 0;
    let mut i = 0;
    while i < parts.len() {
        n += parts[i].len();
        i += 1;
    }
    n
}

/// The parts' bytes one after the other (`N` is their total length).
pub(crate) const fn join<const N: usize>(parts: &[&str]) -> [u8; N] {
    let mut out = [0u8; N];
    let mut k = 0;
    let mut i = 0;
    while i < parts.len() {
        let b = parts[i].as_bytes();
        let mut j = 0;
        while j < b.len() {
            out[k] = b[j];
            k += 1;
            j += 1;
        }
        i += 1;
    }
    assert!(k == N, "concat_str!: length mismatch");
    out
}

/// Join constant string expressions into one `&'static str` at compile time.
macro_rules! concat_str {
    ($($part:expr),+ $(,)?) => {{
        const PARTS: &[&str] = &[$($part),+];
        const LEN: usize = $crate::conststr::total_len(PARTS);
        const BYTES: [u8; LEN] = $crate::conststr::join::<LEN>(PARTS);
        match ::core::str::from_utf8(&BYTES) {
            Ok(s) => s,
            // Every part is a str, so their concatenation is UTF-8.
            Err(_) => panic!("concat_str!: not UTF-8"),
        }
    }};
}
pub(crate) use concat_str;

#[cfg(test)]
mod tests {
    #[test]
    fn joins_at_compile_time() {
        const A: &str = "phase";
        const S: &str = concat_str!(A, "_lag", ".", "nu");
        assert_eq!(S, "phase_lag.nu");
    }
}
