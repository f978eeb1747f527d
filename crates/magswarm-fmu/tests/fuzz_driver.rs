//! The fuzz driver (`fuzz/src/lib.rs`, run by `cargo fuzz` on nightly) replayed on stable:
//! the committed corpus and a few thousand pseudo-random inputs, so every build checks that
//! the call sequences it generates (FMI 2.0 and 3.0, Co-Simulation and Model Exchange) keep
//! the invariants.
//! Not a substitute for fuzzing (no coverage guidance), a floor under it.

#[path = "../../../fuzz/src/lib.rs"]
#[allow(dead_code)]
mod fuzz_driver;

use magswarm_fmu::MagSwarm;

#[test]
fn the_committed_corpus_keeps_the_invariants() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fuzz/corpus/fmu_plant");
    let mut n = 0;
    for e in std::fs::read_dir(dir).expect("corpus folder") {
        let bytes = std::fs::read(e.unwrap().path()).unwrap();
        fuzz_driver::drive::<MagSwarm>(&bytes);
        fuzz_driver::drive3::<MagSwarm>(&bytes);
        n += 1;
    }
    assert!(n > 0, "empty corpus");
}

#[test]
fn pseudo_random_call_sequences_keep_the_invariants_in_both_interfaces() {
    // xorshift: reproducible without a dependency.
    let mut s: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    for k in 0..3000 {
        let len = 16 + (next() % 400) as usize;
        let mut data: Vec<u8> = (0..len).map(|_| next() as u8).collect();
        // Half the runs as Model Exchange (bit 2 of the first byte), with an early init.
        data[0] = (data[0] & !4) | if k % 2 == 0 { 4 } else { 0 };
        fuzz_driver::drive::<MagSwarm>(&data);
    }
}

#[test]
fn pseudo_random_fmi3_call_sequences_keep_the_invariants_in_both_interfaces() {
    let mut s: u64 = 0x2545_f491_4f6c_dd1d;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    for k in 0..3000 {
        let len = 16 + (next() % 400) as usize;
        let mut data: Vec<u8> = (0..len).map(|_| next() as u8).collect();
        data[0] = (data[0] & !4) | if k % 2 == 0 { 4 } else { 0 };
        fuzz_driver::drive3::<MagSwarm>(&data);
    }
}

/// The FMI 3.0 driver can fail: a model that panics when stepped at u = 0.5 (the panic is
/// caught by the shell, and the driver's "no panic inside" invariant catches that).
#[test]
#[should_panic(expected = "a panic inside the FMU")]
fn the_fmi3_driver_finds_a_planted_bug() {
    // Co-Simulation; init(0); set u = 0.5; step by 0.01.
    let input = [0u8, 0, 0, 1, 0, 22, 3, 0, 19];
    fuzz_driver::drive3::<fuzz_driver::planted::Planted>(&input);
}
