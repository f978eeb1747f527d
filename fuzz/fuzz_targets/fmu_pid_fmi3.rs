//! Random FMI 3.0 call sequences against `magswarm_pid_fmu::MagSwarmPid` (see `magswarm_fuzz::drive3`).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    magswarm_fuzz::drive3::<magswarm_pid_fmu::MagSwarmPid>(data);
});
