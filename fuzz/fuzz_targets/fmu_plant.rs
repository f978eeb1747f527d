//! Random FMI 2.0 call sequences against `magswarm_fmu::MagSwarm` (see `magswarm_fuzz::drive`).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    magswarm_fuzz::drive::<magswarm_fmu::MagSwarm>(data);
});
