//! The fuzz driver (`fuzz/src/lib.rs`, targets `fmu_pid` and `fmu_pid_fmi3` under `cargo
//! fuzz` on nightly) replayed on stable for the controller FMU: the committed corpus and
//! pseudo-random call sequences through the FMI 2.0 and 3.0 shells keep the invariants.
//! Not a substitute for fuzzing (no coverage guidance), a floor under it.

#[path = "../../../fuzz/src/lib.rs"]
#[allow(dead_code)]
mod fuzz_driver;

use magswarm_pid_fmu::MagSwarmPid;

#[test]
fn the_committed_corpus_keeps_the_invariants_in_both_versions() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fuzz/corpus/fmu_pid");
    let mut n = 0;
    for e in std::fs::read_dir(dir).expect("corpus folder") {
        let bytes = std::fs::read(e.unwrap().path()).unwrap();
        fuzz_driver::drive::<MagSwarmPid>(&bytes);
        fuzz_driver::drive3::<MagSwarmPid>(&bytes);
        n += 1;
    }
    assert!(n > 0, "empty corpus");
}

#[test]
fn pseudo_random_call_sequences_keep_the_invariants_in_both_versions() {
    // xorshift: reproducible without a dependency.
    let mut s: u64 = 0x6a09_e667_f3bc_c908;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    for _ in 0..1500 {
        let len = 16 + (next() % 400) as usize;
        let data: Vec<u8> = (0..len).map(|_| next() as u8).collect();
        fuzz_driver::drive::<MagSwarmPid>(&data);
        fuzz_driver::drive3::<MagSwarmPid>(&data);
    }
}
