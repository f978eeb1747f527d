//! The unmodelled effects as model terms: neutral values give the seed's model bit-exactly,
//! each effect changes the plant where its physics says, Jacobians stay exact, and the
//! model file reads v1 and checks effect parameters.

use magswarm_model::dynamics::InputTerms;
use magswarm_model::effects::{self, *};
use magswarm_model::{hz_to_rad_s as hz, steady, Model, Plant, PlantSnapshot};

fn all_neutral() -> Model {
    let mut m = Model::paper();
    for k in EffectKind::ALL {
        m.effects.switch_on(k);
    }
    m
}

fn with(f: impl FnOnce(&mut Effects)) -> Model {
    let mut m = Model::paper();
    f(&mut m.effects);
    m
}

/// A run with input changes and irregular steps; every output as bits.
fn trace(m: &Model) -> Vec<u64> {
    let mut p = Plant::new(m.clone(), 0.0085, hz(4.0));
    let mut out = Vec::new();
    let plan = [(0.0185, 8.0, 3.7), (0.0035, 1.0, 0.9), (0.0235, 10.0, 12.0)];
    for (z, f, dur) in plan {
        p.set_inputs(z, hz(f));
        for k in 0..7 {
            p.step(dur / 7.0 + 0.01 * k as f64).unwrap();
            let o = p.outputs();
            for v in [
                o.r1,
                o.r2,
                o.steady.r1,
                o.steady.r2,
                o.steady.s_x,
                o.steady.s_y,
            ] {
                out.push(v.to_bits());
            }
            for row in o.steady.jac.iter().chain(p.jac_input().iter()) {
                out.extend(row.iter().map(|v| v.to_bits()));
            }
        }
    }
    out
}

#[test]
fn neutral_effects_are_the_seed_model_bit_exactly() {
    let base = Model::paper();
    let neutral = all_neutral();
    assert_eq!(neutral.effects.enabled().len(), 6);
    assert_eq!(trace(&base), trace(&neutral));
    for &(z, f) in &magswarm_model::seed_grid() {
        for sign in [1.0, -1.0] {
            let a = steady::evaluate(&base, z, sign * hz(f));
            let b = steady::evaluate(&neutral, z, sign * hz(f));
            assert_eq!(a, b, "z {z} f {f}");
            let c = effects::observed_steady(&neutral, z, sign * hz(f), 1234.5);
            assert_eq!(a, c);
        }
    }
    // Each effect alone at neutral as well (no cross-cancellation hides a difference).
    for n in EffectKind::ALL {
        let mut m = Model::paper();
        m.effects.switch_on(n);
        assert_eq!(trace(&base), trace(&m), "{n}");
    }
}

#[test]
fn phase_lag_raises_radii_only_above_step_out() {
    let m = with(|e| {
        e.phase_lag = Some(PhaseLag {
            f_so_hz: 6.0,
            nu: 1.0,
            spread: 0.0,
        })
    });
    let base = Model::paper();
    let z = 0.0085;
    let b = base.magnet.at(z).b / base.steady.B_ref;
    let f_so = 6.0 * b;
    for f in [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0] {
        let a = steady::evaluate(&base, z, hz(f));
        let x = steady::evaluate(&m, z, hz(f));
        if f < f_so {
            assert_eq!(a.r2, x.r2, "f {f} below step-out {f_so}");
        } else {
            // Phi falls with the rotation rate (N < 0): a slower swarm is larger.
            assert!(x.r2 > a.r2 && x.r1 > a.r1, "f {f}: {} vs {}", x.r2, a.r2);
        }
    }
    // Step-out frequency scales with the field: farther away it steps out earlier.
    let near =
        steady::evaluate(&m, 0.0035, hz(7.0)).r2 / steady::evaluate(&base, 0.0035, hz(7.0)).r2;
    let far =
        steady::evaluate(&m, 0.0235, hz(7.0)).r2 / steady::evaluate(&base, 0.0235, hz(7.0)).r2;
    assert!(far > near, "far {far} near {near}");
}

#[test]
fn cohesion_loss_grows_radii_past_onset_only() {
    let m = with(|e| {
        e.cohesion_loss = Some(CohesionLoss {
            z_c_mm: 15.0,
            k_per_mm2: 0.02,
        })
    });
    let base = Model::paper();
    for z_mm in [3.5, 8.5, 13.5, 18.5, 23.5] {
        let a = steady::evaluate(&base, z_mm * 1e-3, hz(5.0));
        let x = steady::evaluate(&m, z_mm * 1e-3, hz(5.0));
        if z_mm < 15.0 {
            assert_eq!(a, x);
        } else {
            assert!(x.r2 > a.r2 && x.s_y < a.s_y, "z {z_mm}");
        }
    }
    let g = |z: f64| steady::evaluate(&m, z, hz(5.0)).r2 / steady::evaluate(&base, z, hz(5.0)).r2;
    assert!(g(0.0235) > g(0.0185) && g(0.0235) > 1.1, "{}", g(0.0235));
}

#[test]
fn centroid_offset_changes_the_field_at_the_swarm() {
    let m = with(|e| e.centroid_offset = Some(CentroidOffset { offset_mm: 4.0 }));
    let base = Model::paper();
    let a = steady::evaluate(&base, 0.0085, hz(5.0));
    let x = steady::evaluate(&m, 0.0085, hz(5.0));
    let mut moved = base.magnet;
    moved.lateral_offset_m += 4e-3;
    let fx = moved.at(0.0085);
    assert_eq!(x.field, fx);
    assert!(x.field.b < a.field.b, "off the axis the field is weaker");
    assert!(x.r1 != a.r1 && x.r2 != a.r2);
}

#[test]
fn steady_and_input_jacobians_with_effects_match_finite_differences() {
    let mut m = Model::paper();
    m.effects.phase_lag = Some(PhaseLag {
        f_so_hz: 5.0,
        nu: 1.3,
        spread: 0.35,
    });
    m.effects.cohesion_loss = Some(CohesionLoss {
        z_c_mm: 12.0,
        k_per_mm2: 0.01,
    });
    m.effects.centroid_offset = Some(CentroidOffset { offset_mm: 1.5 });
    m.effects.camera_bias = Some(CameraBias {
        scale: 1.05,
        offset_mm: 0.2,
        tilt_deg: 12.0,
    });
    m.effects.particle_drift = Some(ParticleDrift { rate_per_h: -0.3 });
    for &z in &[0.0045, 0.0135, 0.0215] {
        for &f in &[2.0, 6.5, 9.5] {
            let om = hz(f);
            let t = 900.0;
            let sp = observed_steady(&m, z, om, t);
            let (hz_, ho) = (1e-7, 1e-5);
            let e = |z: f64, o: f64| observed_steady(&m, z, o, t);
            let (zp, zm, op, omn) = (e(z + hz_, om), e(z - hz_, om), e(z, om + ho), e(z, om - ho));
            let fd = [
                [(zp.r1 - zm.r1) / (2.0 * hz_), (op.r1 - omn.r1) / (2.0 * ho)],
                [(zp.r2 - zm.r2) / (2.0 * hz_), (op.r2 - omn.r2) / (2.0 * ho)],
            ];
            for i in 0..2 {
                for j in 0..2 {
                    let (a, b) = (sp.jac[i][j], fd[i][j]);
                    assert!(
                        (a - b).abs() <= 1e-4 * b.abs().max(1e-2),
                        "z {z} f {f} J[{i}][{j}] analytic {a} fd {b}"
                    );
                }
            }
            // d(dr/dt)/du of ODE (4) with the effects in its coefficients.
            let terms = InputTerms::new(&m, z, om);
            let r = [terms.steady.r1 * 1.05, terms.steady.r2 * 0.95];
            let ju = terms.jac_input(&m, r);
            let steps = [1e-8, 1e-5];
            for j in 0..2 {
                let (mut up, mut um) = ([z, om], [z, om]);
                up[j] += steps[j];
                um[j] -= steps[j];
                let fp = InputTerms::new(&m, up[0], up[1]).rhs(&m, r);
                let fm = InputTerms::new(&m, um[0], um[1]).rhs(&m, r);
                for i in 0..2 {
                    let fd = (fp[i] - fm[i]) / (2.0 * steps[j]);
                    assert!(
                        (fd - ju[i][j]).abs() <= 1e-4 * fd.abs().max(1e-2),
                        "z {z} f {f} d f{i}/du{j}: analytic {} fd {fd}",
                        ju[i][j]
                    );
                }
            }
        }
    }
}

#[test]
fn scheduled_equilibrium_is_the_map_with_effects() {
    let mut m = Model::paper();
    m.effects.phase_lag = Some(PhaseLag {
        f_so_hz: 5.0,
        nu: 1.0,
        spread: 0.0,
    });
    m.effects.cohesion_loss = Some(CohesionLoss {
        z_c_mm: 15.0,
        k_per_mm2: 0.005,
    });
    let t = InputTerms::new(&m, 0.0215, hz(9.0));
    let f = t.rhs(&m, t.steady.radii());
    assert!(f[0].abs() < 1e-10 && f[1].abs() < 1e-10, "{f:?}");
    let mut p = Plant::new(m, 0.0085, hz(3.0));
    p.set_inputs(0.0215, hz(9.0));
    for _ in 0..400 {
        p.step(1.0).unwrap();
    }
    let o = p.outputs();
    assert!(
        (o.r2 - o.steady.r2).abs() < 1e-6,
        "{} {}",
        o.r2,
        o.steady.r2
    );
}

#[test]
fn formation_lag_slows_and_oscillates_but_ends_on_the_map() {
    let base = Model::paper();
    let m = with(|e| {
        e.formation_lag = Some(FormationLag {
            share: 0.6,
            tau_s: 8.0,
            zeta: 0.4,
        })
    });
    let run = |m: &Model| {
        let mut p = Plant::new(m.clone(), 0.0085, hz(4.0));
        p.set_inputs(0.0185, hz(8.0));
        (0..1200)
            .map(|_| {
                p.step(0.25).unwrap();
                let o = p.outputs();
                (o.r2, o.steady.r2)
            })
            .collect::<Vec<_>>()
    };
    let (a, x) = (run(&base), run(&m));
    let target = a.last().unwrap().1;
    assert_eq!(target, x.last().unwrap().1, "same steady map");
    // After 5 s the baseline is further along than the lagged plant.
    let start = Plant::new(base.clone(), 0.0085, hz(4.0)).outputs().r2;
    let prog = |v: f64| (v - start) / (target - start);
    assert!(
        prog(x[19].0) < prog(a[19].0) - 0.2,
        "{} {}",
        prog(x[19].0),
        prog(a[19].0)
    );
    // Underdamped slow mode: overshoot, then it settles.
    let peak = x.iter().map(|v| prog(v.0)).fold(f64::MIN, f64::max);
    assert!(peak > 1.05, "peak {peak}");
    assert!((x.last().unwrap().0 - target).abs() < 1e-4);
}

#[test]
fn particle_drift_follows_session_time_and_camera_bias_maps_the_outputs() {
    let m = with(|e| e.particle_drift = Some(ParticleDrift { rate_per_h: -0.2 }));
    let mut p = Plant::new(m, 0.0135, hz(5.0));
    let r0 = p.outputs().r1;
    for _ in 0..36 {
        p.step(100.0).unwrap();
    }
    let r1h = p.outputs().r1;
    assert!((r1h / r0 - (-0.2f64).exp()).abs() < 1e-9, "{}", r1h / r0);
    assert!((p.outputs().steady.r1 / r0 - (-0.2f64).exp()).abs() < 1e-9);

    let m = with(|e| {
        e.camera_bias = Some(CameraBias {
            scale: 1.1,
            offset_mm: 0.3,
            tilt_deg: 60.0,
        })
    });
    let p = Plant::new(m, 0.0135, hz(5.0));
    let q = Plant::new(Model::paper(), 0.0135, hz(5.0));
    let (o, b) = (p.outputs(), q.outputs());
    assert!((o.r1 - (1.1 * b.r1 + 0.3)).abs() < 1e-12);
    assert!((o.r2 - (1.1 * 0.5 * b.r2 + 0.3)).abs() < 1e-12);
    // The ODE state stays the physical footprint.
    assert_eq!(p.state(), q.state());
}

#[test]
fn snapshot_carries_the_formation_mode() {
    let m = with(|e| {
        e.formation_lag = Some(FormationLag {
            share: 0.5,
            tau_s: 4.0,
            zeta: 0.5,
        })
    });
    let mut p = Plant::new(m.clone(), 0.0085, hz(4.0));
    p.set_inputs(0.0135, hz(6.0));
    p.step(1.3).unwrap();
    let json = serde_json::to_string(&p.snapshot()).unwrap();
    p.step(2.0).unwrap();
    let snap: PlantSnapshot = serde_json::from_str(&json).unwrap();
    let mut q = Plant::from_snapshot(m, &snap);
    q.step(2.0).unwrap();
    assert_eq!(p, q);
    assert_eq!(p.outputs(), q.outputs());
}

#[test]
fn model_file_v2_round_trips_effects_and_reads_v1() {
    let mut m = Model::paper();
    m.effects.phase_lag = Some(PhaseLag {
        f_so_hz: 6.1,
        nu: 0.9,
        spread: 0.0,
    });
    m.effects.camera_bias = Some(CameraBias::NEUTRAL);
    let text = m.to_json().unwrap();
    assert!(text.contains("\"magswarm-model/2\"") && text.contains("\"f_so_hz\": 6.1"));
    assert!(
        !text.contains("cohesion_loss"),
        "effects that are off are not written"
    );
    assert_eq!(Model::from_json_str(&text, "t").unwrap(), m);

    // A v1 file (empty effects) loads and is upgraded.
    let mut v: serde_json::Value = serde_json::to_value(Model::paper()).unwrap();
    v["schema"] = "magswarm-model/1".into();
    let back = Model::from_json_str(&v.to_string(), "v1.json").unwrap();
    assert_eq!(back, Model::paper());
    // v1 with effects is an error that says why.
    v["effects"] = serde_json::json!({"phase_lag": {"f_so_hz": 6.0, "nu": 1.0}});
    let e = Model::from_json_str(&v.to_string(), "v1.json").unwrap_err();
    assert_eq!(e.path, "effects", "{e}");
    assert!(e.message.contains("magswarm-model/2"), "{e}");
}

#[test]
fn effect_parameters_are_checked_and_named() {
    let mut v: serde_json::Value = serde_json::to_value(Model::paper()).unwrap();
    v["effects"] =
        serde_json::json!({"camera_bias": {"scale": -1.0, "offset_mm": 0.0, "tilt_deg": 0.0}});
    let e = Model::from_json_str(&v.to_string(), "m.json").unwrap_err();
    assert_eq!(e.path, "effects.camera_bias.scale", "{e}");
    v["effects"] = serde_json::json!({"camera_bias": {"scale": 1.0, "offset_mm": 0.0}});
    let e = Model::from_json_str(&v.to_string(), "m.json").unwrap_err();
    assert!(e.message.contains("tilt_deg"), "{e}");
    // A phase lag written before its `spread` existed reads as one sharp step-out.
    v["effects"] = serde_json::json!({"phase_lag": {"f_so_hz": 6.0, "nu": 1.0}});
    let m = Model::from_json_str(&v.to_string(), "m.json").unwrap();
    assert_eq!(m.effects.phase_lag.unwrap().spread, 0.0);
    v["effects"] = serde_json::json!({"phase_lags": {}});
    let e = Model::from_json_str(&v.to_string(), "m.json").unwrap_err();
    assert!(e.message.contains("unknown field"), "{e}");
}
