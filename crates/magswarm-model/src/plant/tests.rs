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

/// The envelope flags a plant reports for its inputs are the envelope's classification of
/// them, with and without effects (one that slows the rotation the map sees included) and
/// with the map table.
#[test]
fn envelope_validity_is_the_classification_of_the_inputs() {
    use crate::learned::{LearnedAxis, LearnedMode, LearnedTerm};
    let paper = Model::paper();
    let mut slowed = paper.clone();
    slowed.effects.learned.push(LearnedTerm {
        effect: "phase_lag".into(),
        axis: LearnedAxis::FHz,
        mode: LearnedMode::RateHz,
        knots: vec![0.5, 6.0, 12.0],
        r1: vec![0.0, 3.0, 9.0],
        r2: vec![0.0, 3.0, 9.0],
        sd_r1: None,
        sd_r2: None,
        field_exponent: 0.0,
        amplitude_exponent: 0.0,
        steps: Default::default(),
        step_size_mm: 0.0,
    });
    for m in [paper, slowed] {
        for table in [false, true] {
            let mut p = Plant::new(m.clone(), 0.0085, hz(4.0));
            p.use_map_table(table);
            for z in [
                0.0006,
                0.0035,
                0.003499999,
                0.0135,
                0.0235,
                0.02350001,
                0.04,
            ] {
                for f in [0.3, 1.0, 0.9999999, 5.0, 10.0, 10.00001, 30.0] {
                    for w in [hz(f), -hz(f)] {
                        p.set_inputs(z, w);
                        assert_eq!(
                            p.envelope_validity(),
                            m.envelope.classify(z, w),
                            "{} at {z} m, {f} Hz",
                            m.name
                        );
                    }
                }
            }
        }
    }
}

/// The ids of input terms stay unique across plants, their clones and terms made outside a
/// plant (each owner hands out ids from a block of its own), and they change with every
/// input change (the memos keyed by them must never mistake one right-hand side for
/// another).
#[test]
fn input_terms_ids_are_unique_across_plants_and_clones() {
    let mut seen = std::collections::HashSet::new();
    let mut a = Plant::new(Model::paper(), 0.0085, hz(4.0));
    a.set_inputs(0.009, hz(4.5));
    let mut b = a.clone();
    assert_eq!(a.terms().id(), b.terms().id(), "a clone has the same terms");
    let mut c = Plant::new(Model::paper(), 0.0085, hz(4.0));
    assert!(seen.insert(a.terms().id()));
    assert!(seen.insert(c.terms().id()));
    for k in 0..300 {
        let z = 0.009 + 1e-5 * k as f64;
        for p in [&mut a, &mut b, &mut c] {
            p.set_inputs(z, hz(5.0));
            assert!(
                seen.insert(p.terms().id()),
                "id {} handed out twice",
                p.terms().id()
            );
        }
        let t = InputTerms::new(&Model::paper(), z, hz(5.0));
        assert!(seen.insert(t.id()));
    }
}
