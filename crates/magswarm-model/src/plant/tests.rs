use super::*;
use crate::hz_to_rad_s as hz;

#[test]
fn step_response_settles_on_the_new_map() {
    let mut p = Plant::new(Model::paper(), 0.0085, hz(4.0));
    let before = p.outputs();
    assert_eq!(before.r1, before.steady.r1);
    p.set_inputs(0.0185, hz(8.0));
    for _ in 0..300 {
        p.step(0.1).unwrap();
    }
    let o = p.outputs();
    assert!((o.r1 - o.steady.r1).abs() < 1e-5 && (o.r2 - o.steady.r2).abs() < 1e-5);
    assert!(o.r1 > before.r1, "larger z_m gives a larger swarm");
}

#[test]
fn inputs_inside_the_magnet_or_non_finite_are_refused() {
    let mut p = Plant::new(Model::paper(), 0.0085, hz(4.0));
    let floor = -p.model().magnet.z_offset_m;
    let e = p.try_set_inputs(floor, hz(4.0)).unwrap_err();
    assert!(e.to_string().contains("inside the magnet"), "{e}");
    assert!(e.to_string().starts_with("z_m = "), "{e}");
    assert!(p.try_set_inputs(f64::NAN, hz(4.0)).is_err());
    assert!(p.try_set_inputs(0.01, f64::INFINITY).is_err());
    assert_eq!(
        p.inputs(),
        (0.0085, hz(4.0)),
        "refused inputs change nothing"
    );
    // Below the envelope but outside the magnet is extrapolation, not an error.
    p.try_set_inputs(floor + 1e-4, hz(4.0)).unwrap();
}

#[test]
fn snapshot_replays_bit_identically() {
    let mut p = Plant::new(Model::paper(), 0.0085, hz(4.0));
    p.set_inputs(0.0135, hz(6.0));
    p.step(0.37).unwrap();
    let json = serde_json::to_string(&p.snapshot()).unwrap();
    p.step(0.5).unwrap();
    let snap: PlantSnapshot = serde_json::from_str(&json).unwrap();
    let mut q = Plant::from_snapshot(Model::paper(), &snap);
    q.step(0.5).unwrap();
    assert_eq!(p.state(), q.state());
    assert_eq!(p, q);
}

#[test]
fn clone_replays_bit_identically() {
    let mut p = Plant::new(Model::paper(), 0.0085, hz(4.0));
    p.set_inputs(0.0135, hz(6.0));
    p.step(0.37).unwrap();
    let snap = p.clone();
    p.step(0.5).unwrap();
    let a = p.state();
    let mut q = snap;
    q.step(0.5).unwrap();
    assert_eq!(a, q.state());
}
