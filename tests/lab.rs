//! The virtual lab: determinism, protocol shape, noise statistics, invalid frames, exact
//! agreement with `predict` without noise, and the direction of each foreign effect.

use magswarm::lab::{self, Foreign, Noise, Protocol, Scenario};
use magswarm::log::LogRow;
use magswarm::predict::{replay, InputRow};
use magswarm_model::effects::*;
use magswarm_model::Model;
use std::collections::BTreeMap;

fn gen(model: &Model, sc: &Scenario, seed: u64) -> Vec<LogRow> {
    lab::generate(model, sc, seed, |_, _| {}).unwrap()
}

fn grid(z: &[f64], f: &[f64], visits: usize, repeats: usize) -> Protocol {
    Protocol::Grid {
        z_mm: z.to_vec(),
        f_hz: f.to_vec(),
        visits,
        repeats,
        settle_s: 20.0,
        sample_s: 1.0,
        approach_s: Vec::new(),
    }
}

/// Rows grouped by visit (consecutive rows with the same inputs and session, without a
/// settle gap of more than 5 s between them).
fn visits(rows: &[LogRow]) -> Vec<Vec<&LogRow>> {
    let mut out: Vec<Vec<&LogRow>> = Vec::new();
    for r in rows {
        match out.last_mut() {
            Some(v)
                if v[0].z_m_mm == r.z_m_mm
                    && v[0].f_hz == r.f_hz
                    && v[0].session == r.session
                    && r.t_s - v.last().unwrap().t_s < 5.0 =>
            {
                v.push(r)
            }
            _ => out.push(vec![r]),
        }
    }
    out
}

#[test]
fn same_seed_same_log_other_seed_other_log() {
    let sc = Scenario::default();
    let m = Model::paper();
    let a = gen(&m, &sc, 11);
    let b = gen(&m, &sc, 11);
    let c = gen(&m, &sc, 12);
    assert_eq!(a, b);
    assert_ne!(a, c);
    // Same points, another order and other noise.
    let pts = |rows: &[LogRow]| {
        let mut v: Vec<(u64, u64)> = rows
            .iter()
            .map(|r| (r.z_m_mm.to_bits(), r.f_hz.to_bits()))
            .collect();
        v.sort();
        v
    };
    assert_eq!(pts(&a), pts(&c));
}

#[test]
fn grid_protocol_has_the_seeds_shape() {
    let rows = gen(&Model::paper(), &Scenario::default(), 3);
    assert_eq!(rows.len(), 500);
    let v = visits(&rows);
    assert_eq!(v.len(), 50, "every point visited once, 10 repeats each");
    let mut seen = BTreeMap::new();
    let mut t_last = 0.0;
    for (k, visit) in v.iter().enumerate() {
        assert_eq!(visit.len(), 10);
        *seen
            .entry((visit[0].z_m_mm.to_bits(), visit[0].f_hz.to_bits()))
            .or_insert(0) += 1;
        // Settle 20 s after the previous visit's last measurement, then 1 s apart.
        let start = if k == 0 { 0.0 } else { t_last };
        assert!((visit[0].t_s - start - 20.0).abs() < 1e-9);
        for w in visit.windows(2) {
            assert!((w[1].t_s - w[0].t_s - 1.0).abs() < 1e-9);
        }
        t_last = visit.last().unwrap().t_s;
    }
    assert_eq!(seen.len(), 50);
    // Randomised: the order is not the grid's z-major order.
    let z_major = v.windows(2).all(|w| w[0][0].z_m_mm <= w[1][0].z_m_mm);
    assert!(!z_major);
}

#[test]
fn long_runs_have_sessions_with_restarting_time() {
    let sc = Scenario {
        protocol: grid(&[8.5, 18.5], &[2.0, 6.0], 2, 3),
        sessions: 3,
        ..Scenario::default()
    };
    let rows = gen(&Model::paper(), &sc, 5);
    assert_eq!(rows.len(), 3 * 2 * 4 * 3);
    let mut by: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    for r in &rows {
        by.entry(r.session.as_str()).or_default().push(r.t_s);
    }
    assert_eq!(by.keys().copied().collect::<Vec<_>>(), ["s1", "s2", "s3"]);
    for ts in by.values() {
        assert_eq!(ts.len(), 24);
        assert!((ts[0] - 20.0).abs() < 1e-9, "time restarts per session");
        assert!(ts.windows(2).all(|w| w[1] > w[0]));
    }
}

#[test]
fn sweep_goes_up_then_down_at_each_distance() {
    let sc = Scenario {
        protocol: Protocol::default_of("sweep").unwrap(),
        noise: Noise::none(),
        ..Scenario::default()
    };
    let rows = gen(&Model::paper(), &sc, 0);
    let v = visits(&rows);
    let fs: Vec<f64> = v.iter().map(|v| v[0].f_hz).collect();
    let one: Vec<f64> = (1..=10).chain((1..=9).rev()).map(|f| f as f64).collect();
    assert_eq!(fs.len(), 2 * one.len());
    assert_eq!(&fs[..19], &one[..]);
    assert!(v.iter().all(|v| v.len() == 15));
}

#[test]
fn noise_statistics_match_the_noise_model() {
    let noise = Noise {
        sd_mm: [0.1, 0.2],
        rel: [0.02, 0.03],
        visit_sd_mm: [0.15, 0.3],
        p_invalid: 0.1,
    };
    let sc = Scenario {
        protocol: grid(&[8.5], &[4.0], 200, 20),
        noise: noise.clone(),
        ..Scenario::default()
    };
    let m = Model::paper();
    let rows = gen(&m, &sc, 9);
    let truth = magswarm_model::steady::evaluate(&m, 0.0085, magswarm_model::hz_to_rad_s(4.0));
    let sd = noise.sd_at([truth.r1, truth.r2]);
    // Invalid frames: about p_invalid, marked, and off the truth.
    let invalid = rows.iter().filter(|r| !r.valid).count() as f64 / rows.len() as f64;
    assert!((invalid - 0.1).abs() < 0.02, "invalid share {invalid}");
    for r in rows.iter().filter(|r| !r.valid) {
        assert!(r.r2_mm.unwrap() < 0.85 * truth.r2);
    }
    // Within-visit (pure error) and between-visit spread.
    let vs = visits(&rows);
    assert_eq!(vs.len(), 200);
    let (mut within, mut nw) = ([0.0; 2], 0.0);
    let mut means: Vec<[f64; 2]> = Vec::new();
    for v in &vs {
        let ok: Vec<[f64; 2]> = v
            .iter()
            .filter(|r| r.valid)
            .map(|r| r.radii().unwrap())
            .collect();
        let n = ok.len() as f64;
        let mean = [
            ok.iter().map(|r| r[0]).sum::<f64>() / n,
            ok.iter().map(|r| r[1]).sum::<f64>() / n,
        ];
        for r in &ok {
            for i in 0..2 {
                within[i] += (r[i] - mean[i]).powi(2);
            }
        }
        nw += n - 1.0;
        means.push(mean);
    }
    for i in 0..2 {
        let s = (within[i] / nw).sqrt();
        assert!(
            (s / sd[i] - 1.0).abs() < 0.05,
            "axis {i}: within sd {s} vs {}",
            sd[i]
        );
        let mm = means.iter().map(|m| m[i]).sum::<f64>() / means.len() as f64;
        let between = (means.iter().map(|m| (m[i] - mm).powi(2)).sum::<f64>()
            / (means.len() as f64 - 1.0))
            .sqrt();
        let expect = (noise.visit_sd_mm[i].powi(2) + sd[i].powi(2) / 18.0).sqrt();
        assert!(
            (between / expect - 1.0).abs() < 0.15,
            "axis {i}: between {between} vs {expect}"
        );
        let r_true = [truth.r1, truth.r2][i];
        assert!(
            (mm - r_true).abs() < 0.06,
            "axis {i}: mean {mm} vs truth {r_true}"
        );
    }
}

#[test]
fn noise_is_heteroscedastic() {
    let sc = Scenario {
        protocol: grid(&[3.5, 23.5], &[1.0], 40, 20),
        noise: Noise {
            sd_mm: [0.0, 0.0],
            rel: [0.05, 0.05],
            visit_sd_mm: [0.0, 0.0],
            p_invalid: 0.0,
        },
        ..Scenario::default()
    };
    let rows = gen(&Model::paper(), &sc, 4);
    let spread = |z: f64| {
        let v: Vec<f64> = rows
            .iter()
            .filter(|r| r.z_m_mm == z)
            .map(|r| r.r2_mm.unwrap())
            .collect();
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (
            (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt(),
            m,
        )
    };
    let (s_near, m_near) = spread(3.5);
    let (s_far, m_far) = spread(23.5);
    assert!(m_far > m_near);
    assert!((s_far / s_near / (m_far / m_near) - 1.0).abs() < 0.1);
}

fn all_effects() -> Model {
    let mut m = Model::paper();
    m.effects.phase_lag = Some(PhaseLag {
        f_so_hz: 6.0,
        nu: 1.0,
        spread: 0.0,
    });
    m.effects.cohesion_loss = Some(CohesionLoss {
        z_c_mm: 16.0,
        k_per_mm2: 0.01,
    });
    m.effects.formation_lag = Some(FormationLag {
        share: 0.4,
        tau_s: 6.0,
        zeta: 0.5,
    });
    m.effects.particle_drift = Some(ParticleDrift { rate_per_h: -0.3 });
    m.effects.centroid_offset = Some(CentroidOffset { offset_mm: 1.0 });
    m.effects.camera_bias = Some(CameraBias {
        scale: 1.02,
        offset_mm: 0.1,
        tilt_deg: 8.0,
    });
    m
}

#[test]
fn noise_free_lab_is_predict_of_its_inputs_with_every_effect() {
    let m = all_effects();
    for protocol in ["grid", "steps"] {
        let sc = Scenario {
            protocol: Protocol::default_of(protocol).unwrap(),
            noise: Noise::none(),
            ..Scenario::default()
        };
        let rows = gen(&m, &sc, 21);
        let inputs: Vec<InputRow> = rows
            .iter()
            .map(|r| InputRow {
                t: r.t_s,
                z_mm: r.z_m_mm,
                f_hz: r.f_hz,
            })
            .collect();
        let pred = replay(&m, &inputs, 1e-9).unwrap();
        let worst = rows
            .iter()
            .zip(&pred)
            .map(|(r, p)| {
                let q = r.radii().unwrap();
                (q[0] - p[0]).abs().max((q[1] - p[1]).abs())
            })
            .fold(0.0, f64::max);
        assert!(worst < 2e-4, "{protocol}: lab vs predict {worst} mm");
        // And the effects matter: the paper model is far from these data.
        let base = replay(&Model::paper(), &inputs, 1e-9).unwrap();
        let far = rows
            .iter()
            .zip(&base)
            .map(|(r, p)| (r.r2_mm.unwrap() - p[1]).abs())
            .fold(0.0, f64::max);
        assert!(
            far > 0.5,
            "{protocol}: effects change r2 by {far} mm at most"
        );
    }
}

/// Mean r2 per (z, f) of a noise-free run.
fn mean_r2(m: &Model, foreign: Vec<Foreign>, protocol: Protocol) -> BTreeMap<(i64, i64), f64> {
    let sc = Scenario {
        protocol,
        foreign,
        noise: Noise::none(),
        ..Scenario::default()
    };
    let rows = gen(m, &sc, 1);
    let mut acc: BTreeMap<(i64, i64), (f64, f64)> = BTreeMap::new();
    for r in &rows {
        let e = acc
            .entry(((r.z_m_mm * 10.0) as i64, (r.f_hz * 10.0) as i64))
            .or_default();
        e.0 += r.r2_mm.unwrap();
        e.1 += 1.0;
    }
    acc.into_iter().map(|(k, (s, n))| (k, s / n)).collect()
}

#[test]
fn foreign_effects_act_where_their_physics_says() {
    let m = Model::paper();
    let g = || grid(&[3.5, 13.5, 23.5], &[2.0, 9.0], 1, 3);
    let base = mean_r2(&m, vec![], g());
    let ratio = |other: &BTreeMap<(i64, i64), f64>, z: i64, f: i64| other[&(z, f)] / base[&(z, f)];

    let pl = mean_r2(
        &m,
        vec![Foreign::PhaseLagLogistic {
            f_c_hz: 6.0,
            width_hz: 0.5,
            depth: 0.7,
        }],
        g(),
    );
    assert!((ratio(&pl, 135, 20) - 1.0).abs() < 0.01);
    assert!(ratio(&pl, 135, 90) > 1.01, "{}", ratio(&pl, 135, 90));

    let co = mean_r2(
        &m,
        vec![Foreign::CohesionPoly {
            z0_mm: 15.0,
            gain: [0.0005, 0.001],
            power: 3.0,
            tau_s: 2.0,
        }],
        g(),
    );
    assert_eq!(ratio(&co, 35, 20), 1.0);
    assert!(ratio(&co, 235, 20) > 1.5, "{}", ratio(&co, 235, 20));

    let cam = mean_r2(
        &m,
        vec![Foreign::CameraProjection {
            tilt_deg: 30.0,
            axis_deg: 20.0,
            scale: 1.0,
            offset_mm: 0.0,
        }],
        g(),
    );
    assert!(ratio(&cam, 135, 20) < 0.99 && ratio(&cam, 135, 20) > 0.85);

    let tilt = mean_r2(
        &m,
        vec![Foreign::AxisTilt {
            offset_mm: 0.0,
            tilt_deg: 10.0,
            z_ref_mm: 3.5,
        }],
        g(),
    );
    assert!((ratio(&tilt, 35, 20) - 1.0).abs() < 1e-9);
    assert!((ratio(&tilt, 235, 20) - 1.0).abs() > 0.002);

    // Drift: the late half of a long session is smaller than the early half.
    let sc = Scenario {
        protocol: grid(&[13.5], &[5.0], 60, 10),
        foreign: vec![Foreign::DriftSqrt { c_per_sqrt_h: -0.2 }],
        noise: Noise::none(),
        ..Scenario::default()
    };
    let rows = gen(&m, &sc, 0);
    let (early, late) = rows.split_at(rows.len() / 2);
    let avg = |v: &[LogRow]| v.iter().map(|r| r.r2_mm.unwrap()).sum::<f64>() / v.len() as f64;
    assert!(avg(late) < avg(early) * 0.99);

    // Input lag: right after a step the swarm is further from its new state.
    let steps = Protocol::Steps {
        n_steps: 6,
        z_range_mm: [3.5, 23.5],
        f_range_hz: [1.0, 10.0],
        dwell_s: 30.0,
        sample_s: 0.5,
    };
    let run = |foreign: Vec<Foreign>| {
        let sc = Scenario {
            protocol: steps.clone(),
            foreign,
            noise: Noise::none(),
            ..Scenario::default()
        };
        gen(&m, &sc, 2)
    };
    let (a, b) = (
        run(vec![]),
        run(vec![Foreign::InputLag {
            tau_s: 5.0,
            delay_s: 1.0,
        }]),
    );
    let va = visits(&a);
    let vb = visits(&b);
    let mut lagging = 0;
    for (x, y) in va.iter().zip(&vb).skip(1) {
        let end = x.last().unwrap().r2_mm.unwrap();
        assert!(
            (y.last().unwrap().r2_mm.unwrap() - end).abs() < 0.05,
            "settles by the end"
        );
        let d = |r: &LogRow| (r.r2_mm.unwrap() - end).abs();
        if d(y[2]) > d(x[2]) + 0.05 {
            lagging += 1;
        }
    }
    assert!(lagging >= 4, "{lagging} of 5 steps lag");
}

#[test]
fn scenario_files_are_checked_and_name_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s.json");
    std::fs::write(&p, r#"{"protocol": {"kind": "grid", "repeat": 3}}"#).unwrap();
    let e = format!("{:#}", Scenario::load(&p).unwrap_err());
    assert!(e.contains("repeat") && e.contains("unknown field"), "{e}");
    std::fs::write(
        &p,
        r#"{"foreign": [{"kind": "drift_sqrt", "c_per_sqrt_h": 9}]}"#,
    )
    .unwrap();
    let e = format!("{:#}", Scenario::load(&p).unwrap_err());
    assert!(e.contains("c_per_sqrt_h"), "{e}");
    std::fs::write(&p, r#"{"noise": {"p_invalid": 0.9}}"#).unwrap();
    let e = format!("{:#}", Scenario::load(&p).unwrap_err());
    assert!(e.contains("p_invalid"), "{e}");
    // A relative truth path is relative to the scenario file.
    let mut m = Model::paper();
    m.effects.camera_bias = Some(CameraBias {
        scale: 1.1,
        offset_mm: 0.0,
        tilt_deg: 0.0,
    });
    m.save(&dir.path().join("truth.json")).unwrap();
    std::fs::write(&p, r#"{"truth": "truth.json", "sessions": 2}"#).unwrap();
    let sc = Scenario::load(&p).unwrap();
    assert_eq!(sc.truth_model().unwrap(), m);
}

#[test]
fn cli_writes_a_readable_log() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("lab.csv");
    let st = std::process::Command::new(env!("CARGO_BIN_EXE_magswarm"))
        .args([
            "lab",
            "--protocol",
            "long",
            "--repeats",
            "2",
            "--seed",
            "4",
            "--quiet",
            "--out",
        ])
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let log = magswarm::log::Log::read(&out).unwrap();
    assert_eq!(log.rows.len(), 3 * 2 * 50 * 2);
    assert!(log.rows.iter().any(|r| !r.valid));
    let bad = std::process::Command::new(env!("CARGO_BIN_EXE_magswarm"))
        .args(["lab", "--protocol", "sweep", "--repeats", "2", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--repeats applies to the grid"));
}
