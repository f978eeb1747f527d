//! The harness must find the planted bug of `magswarm_fuzz::planted::Planted` (a panic when
//! stepping with u = 0.5): a run of this target that does *not* crash means the harness is
//! blind. See fuzz/README.md.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    magswarm_fuzz::drive::<magswarm_fuzz::planted::Planted>(data);
});
