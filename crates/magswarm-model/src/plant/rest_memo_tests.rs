use super::*;
use crate::hz_to_rad_s as hz;
use crate::integrate::RestMemo;

/// Replaying remembered rest steps gives bit for bit what evaluating them gives: state,
/// next step size and step counts, through formation, rest and an input change.
#[test]
fn rest_steps_replay_bit_identically() {
    let mut a = Plant::new(Model::paper(), 0.0085, hz(4.0));
    a.set_state([6.0, 9.0]);
    let mut b = a.clone();
    let mut replayed = 0;
    for k in 0..40_000 {
        if k == 25_000 {
            a.set_inputs(0.0135, hz(6.0));
            b.set_inputs(0.0135, hz(6.0));
        }
        let h = if k % 3 == 0 { 0.01 } else { 0.001 };
        if a.stepper().rest.is_set() {
            replayed += 1;
        }
        a.step(h).unwrap();
        // b never uses the memo.
        b.set_stepper(Stepper {
            rest: RestMemo::default(),
            ..b.stepper()
        });
        b.step(h).unwrap();
        assert_eq!(a.state(), b.state(), "step {k}");
        assert_eq!(a.stepper().h_next.to_bits(), b.stepper().h_next.to_bits());
        assert_eq!(a.step_counts(), b.step_counts());
    }
    assert!(replayed > 1000, "the swarm never came to rest ({replayed})");
}
