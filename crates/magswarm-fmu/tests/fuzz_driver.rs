//! The fuzz driver (`fuzz/src/lib.rs`, run by `cargo fuzz` on nightly) replayed on stable:
//! the committed corpus and a few thousand pseudo-random inputs, so every build checks that
//! the call sequences it generates (Co-Simulation and Model Exchange) keep the invariants.
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
