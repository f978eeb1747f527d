use super::*;

#[test]
fn the_sets_are_large_deterministic_and_cover_every_effect() {
    for (a, b) in [(scenarios(1), scenarios(1)), (heldout(1), heldout(1))] {
        assert!(a.len() >= 140, "{}", a.len());
        assert_eq!(a.len(), b.len());
        assert_eq!(a[17].logs(), b[17].logs());
        for e in EFFECTS {
            let shapes: std::collections::BTreeSet<String> = a
                .iter()
                .flat_map(|s| s.truths.iter())
                .filter(|t| t.shape.effect() == e)
                .map(|t| t.shape.label())
                .collect();
            assert!(
                shapes.len() >= 3,
                "{e}: at least 3 foreign shapes: {shapes:?}"
            );
        }
        assert!(a.iter().filter(|s| s.truths.is_empty()).count() >= 15);
    }
    // The held-out set shares no effect shape with the tuning set.
    let labels = |v: &[Scenario]| -> std::collections::BTreeSet<String> {
        v.iter()
            .flat_map(|s| s.truths.iter())
            .filter(|t| !["anomaly", "camera_bias"].contains(&t.shape.effect()))
            .map(|t| t.shape.label())
            .collect()
    };
    let (t, h) = (labels(&scenarios(1)), labels(&heldout(1)));
    assert!(
        t.is_disjoint(&h),
        "{:?}",
        t.intersection(&h).collect::<Vec<_>>()
    );
}

fn one(shape: Shape, strength: f64) -> Scenario {
    Scenario {
        id: 0,
        protocol: Protocol::GridOnce,
        truths: vec![Truth { shape, strength }],
        seed: 5,
        set: Set::Tuning,
    }
}

#[test]
fn strength_is_what_the_baseline_cannot_absorb() {
    let lab = Lab::draw(5);
    let plan = Protocol::GridOnce.plan(5);
    let ab = Absorb::new(&lab, &plan);
    // A camera's scale is a change of the gains: invisible however large.
    assert!(ab.visible(&[(Shape::CameraScale, 5.0)]) < 0.05);
    // A linear onset is mostly visible; its calibrated strength is the one asked for, and
    // doubling the strength doubles the amplitude (the shape is linear in it).
    let s = Shape::LinearOnset { z0: 13.5 };
    let (x2, s2) = ab.calibrate(s, 2.0);
    let (x4, s4) = ab.calibrate(s, 4.0);
    assert!(
        (s2 - 2.0).abs() < 0.05 && (s4 - 4.0).abs() < 0.1,
        "{s2} {s4}"
    );
    assert!((x4 / x2 - 2.0).abs() < 0.1, "{x2} {x4}");
    let r = one(s, 3.0).realise();
    assert!((r.strengths[0] - 3.0).abs() < 0.07, "{}", r.strengths[0]);
    assert!(r.floor[0] > 0.1 && r.floor[1] > r.floor[0]);
}

#[test]
fn a_bounded_shape_records_the_strength_it_reaches() {
    // An off-axis swarm is bounded by a 20 mm offset: asked for far more than it can show, it
    // reports what it reaches.
    let r = one(Shape::OffAxis { offset: 4.0 }, 500.0).realise();
    assert!(r.strengths[0] < 500.0);
    assert!((r.amplitudes[0] - 5.0).abs() < 1e-9);
}

#[test]
fn names_no_item_of_the_models_effect_terms() {
    for (file, src) in [
        ("lib.rs", include_str!("lib.rs")),
        ("shape.rs", include_str!("shape.rs")),
        ("lab.rs", include_str!("lab.rs")),
        ("sets.rs", include_str!("sets.rs")),
        ("protocol.rs", include_str!("protocol.rs")),
        ("strength.rs", include_str!("strength.rs")),
    ] {
        for forbidden in [
            "effects::",
            "PhaseLag",
            "CohesionLoss",
            "FormationLag",
            "ParticleDrift",
            "CentroidOffset",
            "CameraBias",
            "learned",
            "lateral_offset",
        ] {
            assert!(!src.contains(forbidden), "{file} names {forbidden}");
        }
    }
}
