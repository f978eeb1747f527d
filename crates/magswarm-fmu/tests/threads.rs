//! Eight threads, each driving its own instances through the C entry points at once (the
//! standard allows that), give results bit-identical to the same runs done serially.

use magswarm_fmi::fmi2::host::Host;
use magswarm_fmi::fmi2::Fmi2Status;
use magswarm_fmu::{vr, MagSwarm};

/// One run: an input schedule that depends on `seed`, 400 steps, the bits of r1 and r2.
fn run(seed: u64) -> Vec<(u64, u64)> {
    let h = Host::<MagSwarm>::instantiate(&format!("t{seed}"), None).unwrap();
    assert_eq!(h.init(0.0), Fmi2Status::Ok);
    let mut out = Vec::new();
    for k in 0..400u64 {
        let z = 0.006 + 0.012 * (((k * 7 + seed * 13) % 50) as f64 / 50.0);
        let f = 2.0 + 6.0 * (((k * 3 + seed * 5) % 40) as f64 / 40.0);
        assert!(h.set_real(vr::Z_M, z) <= Fmi2Status::Warning);
        assert!(h.set_real(vr::OMEGA_M, f * std::f64::consts::TAU) <= Fmi2Status::Warning);
        assert!(h.step(k as f64 * 0.02, 0.02) <= Fmi2Status::Warning);
        out.push((
            h.get_real(vr::R1).1.to_bits(),
            h.get_real(vr::R2).1.to_bits(),
        ));
    }
    out
}

#[test]
fn eight_threads_match_a_serial_run_bit_for_bit() {
    let serial: Vec<_> = (0..8).map(run).collect();
    let parallel: Vec<_> = std::thread::scope(|s| {
        let hs: Vec<_> = (0..8u64).map(|seed| s.spawn(move || run(seed))).collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert_eq!(serial, parallel);
    assert_ne!(serial[0], serial[1], "the runs differ from each other");
}
