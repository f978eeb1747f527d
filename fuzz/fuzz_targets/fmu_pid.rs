//! Random FMI 2.0 call sequences against `magswarm_pid_fmu::MagSwarmPid` (see `magswarm_fuzz::drive`).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    magswarm_fuzz::drive::<magswarm_pid_fmu::MagSwarmPid>(data);
});
