//! Learned effect terms (`effects.learned`): what each axis and mode does to the plant's
//! outputs, their neutrality, their Jacobian, the model file's checks and the plant state.

use magswarm_model::learned::{LearnedAxis, LearnedMode, LearnedSteps, LearnedTerm};
use magswarm_model::{hz_to_rad_s as hz, steady, Model, Plant};

fn term(
    axis: LearnedAxis,
    mode: LearnedMode,
    knots: &[f64],
    r1: &[f64],
    r2: &[f64],
) -> LearnedTerm {
    LearnedTerm {
        effect: match axis {
            LearnedAxis::FHz => "phase_lag",
            LearnedAxis::ZmMm => "cohesion_loss",
            LearnedAxis::TS => "particle_drift",
            LearnedAxis::SinceChangeS => "formation_lag",
        }
        .into(),
        axis,
        mode,
        knots: knots.to_vec(),
        r1: r1.to_vec(),
        r2: r2.to_vec(),
        sd_r1: None,
        sd_r2: None,
        field_exponent: 0.0,
        amplitude_exponent: 0.0,
        steps: Default::default(),
        step_size_mm: 0.0,
    }
}

fn with(terms: Vec<LearnedTerm>) -> Model {
    let mut m = Model::paper();
    m.effects.learned = terms;
    m
}

/// Run a plant through a schedule of (duration [s], z_m [mm], f [Hz]); outputs every 0.5 s.
fn run(m: &Model, sched: &[(f64, f64, f64)]) -> Vec<[f64; 2]> {
    let mut p = Plant::new(m.clone(), sched[0].1 * 1e-3, hz(sched[0].2));
    let mut out = Vec::new();
    for &(dur, z, f) in sched {
        p.try_set_inputs(z * 1e-3, hz(f)).unwrap();
        for _ in 0..(dur / 0.5) as usize {
            p.step(0.5).unwrap();
            let o = p.outputs();
            out.push([o.r1, o.r2]);
        }
    }
    out
}

const SCHED: [(f64, f64, f64); 3] = [(20.0, 8.5, 4.0), (30.0, 18.5, 4.0), (30.0, 18.5, 8.0)];

#[test]
fn zero_heights_change_nothing_bit_for_bit() {
    let zero = |axis, mode| term(axis, mode, &[1.0, 30.0], &[0.0, 0.0], &[0.0, 0.0]);
    let m = with(vec![
        zero(LearnedAxis::FHz, LearnedMode::AddMm),
        zero(LearnedAxis::FHz, LearnedMode::RateHz),
        zero(LearnedAxis::ZmMm, LearnedMode::Relative),
        zero(LearnedAxis::TS, LearnedMode::AddMm),
        zero(LearnedAxis::SinceChangeS, LearnedMode::StepFraction),
    ]);
    assert_eq!(run(&m, &SCHED), run(&Model::paper(), &SCHED));
}

#[test]
fn a_millimetre_over_z_moves_the_steady_map_and_the_ode_settles_there() {
    let m = with(vec![term(
        LearnedAxis::ZmMm,
        LearnedMode::AddMm,
        &[3.5, 23.5],
        &[1.0, 1.0],
        &[1.0, 1.0],
    )]);
    let base = steady::evaluate(&Model::paper(), 0.0135, hz(5.0));
    let sp = steady::evaluate(&m, 0.0135, hz(5.0));
    assert!((sp.r1 - base.r1 - 1.0).abs() < 1e-12 && (sp.r2 - base.r2 - 1.0).abs() < 1e-12);
    let a = run(&m, &[(120.0, 13.5, 5.0)]);
    let b = run(&Model::paper(), &[(120.0, 13.5, 5.0)]);
    let last = a.len() - 1;
    assert!(
        (a[last][0] - b[last][0] - 1.0).abs() < 1e-3,
        "{:?} {:?}",
        a[last],
        b[last]
    );
}

#[test]
fn a_rate_deficit_is_the_map_at_the_slower_rotation() {
    let m = with(vec![term(
        LearnedAxis::FHz,
        LearnedMode::RateHz,
        &[2.0, 8.0],
        &[0.5, 0.5],
        &[0.5, 0.5],
    )]);
    let sp = steady::evaluate(&m, 0.0085, hz(6.0));
    let slow = steady::evaluate(&Model::paper(), 0.0085, hz(5.5));
    assert!((sp.r1 - slow.r1).abs() < 1e-12 && (sp.r2 - slow.r2).abs() < 1e-12);
}

#[test]
fn the_steady_jacobian_matches_central_differences_with_every_steady_term() {
    let mut terms = vec![
        term(
            LearnedAxis::FHz,
            LearnedMode::RateHz,
            &[2.0, 5.0, 9.0],
            &[0.0, 0.4, 1.0],
            &[0.0, 0.4, 1.0],
        ),
        term(
            LearnedAxis::FHz,
            LearnedMode::AddMm,
            &[2.0, 5.0, 9.0],
            &[0.0, 0.3, 0.1],
            &[0.1, 0.6, 0.2],
        ),
        term(
            LearnedAxis::ZmMm,
            LearnedMode::Relative,
            &[5.0, 15.0, 25.0],
            &[0.0, 0.05, 0.2],
            &[0.0, 0.1, 0.3],
        ),
    ];
    terms[0].field_exponent = 0.7;
    terms[1].amplitude_exponent = 1.0;
    terms[1].field_exponent = 0.3;
    let m = with(terms);
    for (z, f) in [(0.0085, 4.3), (0.0162, 6.7), (0.021, 3.1)] {
        let sp = steady::evaluate(&m, z, hz(f));
        let (hz_, hw) = (1e-7, 1e-5);
        let dz = |s: f64| steady::evaluate(&m, z + s * hz_, hz(f));
        let dw = |s: f64| steady::evaluate(&m, z, hz(f) + s * hw);
        let fd = [
            [
                (dz(1.0).r1 - dz(-1.0).r1) / (2.0 * hz_),
                (dw(1.0).r1 - dw(-1.0).r1) / (2.0 * hw),
            ],
            [
                (dz(1.0).r2 - dz(-1.0).r2) / (2.0 * hz_),
                (dw(1.0).r2 - dw(-1.0).r2) / (2.0 * hw),
            ],
        ];
        for i in 0..2 {
            for j in 0..2 {
                let tol = 1e-4 * fd[i][j].abs().max(1.0);
                assert!(
                    (sp.jac[i][j] - fd[i][j]).abs() < tol,
                    "z {z} f {f}: jac[{i}][{j}] {} vs {}",
                    sp.jac[i][j],
                    fd[i][j]
                );
            }
        }
    }
}

#[test]
fn a_shape_over_session_time_acts_only_as_time_passes() {
    let m = with(vec![term(
        LearnedAxis::TS,
        LearnedMode::Relative,
        &[0.0, 60.0],
        &[0.0, -0.1],
        &[0.0, -0.1],
    )]);
    let a = run(&m, &SCHED);
    let b = run(&Model::paper(), &SCHED);
    assert!((a[0][0] - b[0][0]).abs() < 0.01 * b[0][0]);
    let last = a.len() - 1;
    assert!(
        (a[last][0] / b[last][0] - 0.9).abs() < 1e-9,
        "{:?} {:?}",
        a[last],
        b[last]
    );
}

#[test]
fn a_step_fraction_holds_the_response_back_after_each_change_then_lets_go() {
    let m = with(vec![term(
        LearnedAxis::SinceChangeS,
        LearnedMode::StepFraction,
        &[0.0, 10.0],
        &[-1.0, 0.0],
        &[-1.0, 0.0],
    )]);
    let a = run(&m, &SCHED);
    let b = run(&Model::paper(), &SCHED);
    // Before the first change: nothing.
    assert_eq!(a[10], b[10]);
    // 2 s after the z_m step (row 40 + 4) the measured radius lags the plant's by 80 % of the
    // step; 15 s after it, not at all.
    let step = b[99][1] - b[39][1];
    let lag = b[43][1] - a[43][1];
    assert!(
        (lag - 0.8 * step).abs() < 0.05 * step.abs(),
        "lag {lag} step {step}"
    );
    assert!((a[69][1] - b[69][1]).abs() < 1e-12);
}

/// A transient that follows only growing steps: after the z_m step (r2 grows) the measured
/// radius lags as with every step; after a change that shrinks the radii, nothing. The
/// shrinking-only term does the opposite, and the two together are the term for every step.
#[test]
fn a_one_sided_step_fraction_follows_only_its_own_direction() {
    let one = |steps| LearnedTerm {
        steps,
        ..term(
            LearnedAxis::SinceChangeS,
            LearnedMode::StepFraction,
            &[0.0, 10.0],
            &[-1.0, 0.0],
            &[-1.0, 0.0],
        )
    };
    // z_m 8.5 -> 18.5 mm (radii grow), then 18.5 -> 6 mm (radii shrink).
    let sched = [(20.0, 8.5, 4.0), (30.0, 18.5, 4.0), (30.0, 6.0, 4.0)];
    let plain = run(&Model::paper(), &sched);
    let all = run(&with(vec![one(LearnedSteps::All)]), &sched);
    let grow = run(&with(vec![one(LearnedSteps::Growing)]), &sched);
    let shrink = run(&with(vec![one(LearnedSteps::Shrinking)]), &sched);
    let both = run(
        &with(vec![
            one(LearnedSteps::Growing),
            one(LearnedSteps::Shrinking),
        ]),
        &sched,
    );
    assert!(plain[99][1] > plain[39][1] && plain[159][1] < plain[99][1]);
    // 2 s after the growing step (row 43) and after the shrinking one (row 103).
    for (row, lags, free) in [(43, &grow, &shrink), (103, &shrink, &grow)] {
        assert!(
            (lags[row][1] - plain[row][1]).abs() > 0.5,
            "row {row}: {:?} against {:?}",
            lags[row],
            plain[row]
        );
        assert_eq!(lags[row], all[row], "row {row}");
        assert_eq!(free[row], plain[row], "row {row}");
    }
    for row in [43, 103, 150] {
        for i in 0..2 {
            assert!((both[row][i] - all[row][i]).abs() < 1e-12, "row {row}");
        }
    }
}

#[test]
fn a_running_transient_survives_a_state_snapshot_bit_for_bit() {
    let m = with(vec![term(
        LearnedAxis::SinceChangeS,
        LearnedMode::StepFraction,
        &[0.0, 4.0, 10.0],
        &[-1.0, 0.3, 0.0],
        &[-0.8, 0.2, 0.0],
    )]);
    let mut p = Plant::new(m.clone(), 0.0085, hz(4.0));
    p.step(5.0).unwrap();
    p.try_set_inputs(0.0185, hz(7.0)).unwrap();
    p.step(1.5).unwrap();
    let s = p.snapshot();
    let json = serde_json::to_string(&s).unwrap();
    let mut q = Plant::from_snapshot(m, &serde_json::from_str(&json).unwrap());
    for _ in 0..8 {
        p.step(0.5).unwrap();
        q.step(0.5).unwrap();
        assert_eq!(p.outputs().r1.to_bits(), q.outputs().r1.to_bits());
        assert_eq!(p.outputs().r2.to_bits(), q.outputs().r2.to_bits());
    }
}

#[test]
fn model_files_with_bad_learned_terms_are_refused_naming_the_field() {
    let mut m = with(vec![
        term(
            LearnedAxis::ZmMm,
            LearnedMode::AddMm,
            &[5.0, 10.0],
            &[0.0, 1.0],
            &[0.0, 1.0],
        ),
        term(
            LearnedAxis::TS,
            LearnedMode::AddMm,
            &[0.0, 10.0, 10.0],
            &[0.0, 1.0, 1.0],
            &[0.0, 1.0, 1.0],
        ),
    ]);
    m.schema = magswarm_model::SCHEMA.into();
    let e = m.validate().unwrap_err();
    assert_eq!(e.path, "effects.learned[1].knots");
    assert!(e.message.contains("not strictly increasing"), "{e}");
    // A round trip through JSON keeps every term.
    m.effects.learned.pop();
    let s = serde_json::to_string(&m).unwrap();
    let back: Model = serde_json::from_str(&s).unwrap();
    assert_eq!(back, m);
}

/// A term scaled by the step's size (`step_size_mm`): after a change twice as large the
/// correction is four times as large (step x |step|), where a plain term's is twice; after
/// a change of exactly `step_size_mm` the two agree. A size set on a term that does not
/// follow the steps, or a size that is not a finite number >= 0, is refused by name.
#[test]
fn a_size_scaled_step_fraction_grows_as_the_step_times_its_size() {
    let shape = |size: f64| LearnedTerm {
        step_size_mm: size,
        ..term(
            LearnedAxis::SinceChangeS,
            LearnedMode::StepFraction,
            &[0.0, 10.0],
            &[-0.5, 0.0],
            &[-0.5, 0.0],
        )
    };
    // Two changes of depth at 5 Hz: 8.5 -> 13.5 mm, then 13.5 -> 23.5 mm.
    let sched = [(20.0, 8.5, 5.0), (30.0, 13.5, 5.0), (30.0, 23.5, 5.0)];
    let plain = run(&Model::paper(), &sched);
    let flat = run(&with(vec![shape(0.0)]), &sched);
    // The steady map's steps of r2 at the two changes.
    let r2 = |z: f64| steady::evaluate(&Model::paper(), z * 1e-3, hz(5.0)).r2;
    let (d1, d2) = (r2(13.5) - r2(8.5), r2(23.5) - r2(13.5));
    assert!(
        d1.abs() > 0.1 && d2.abs() > 1.5 * d1.abs(),
        "steps {d1}, {d2}"
    );
    let size = d1.abs();
    let scaled = run(&with(vec![shape(size)]), &sched);
    // 1 s after each change (rows 41 and 101): the plain term's correction, and the scaled
    // one's, relative to the run without terms.
    for (row, d) in [(41usize, d1), (101, d2)] {
        let c_flat = flat[row][1] - plain[row][1];
        let c_scaled = scaled[row][1] - plain[row][1];
        assert!(c_flat.abs() > 1e-3, "row {row}: {c_flat}");
        let want = c_flat * d.abs() / size;
        assert!(
            (c_scaled - want).abs() < 1e-9 + 1e-6 * want.abs(),
            "row {row}: {c_scaled} against {want}"
        );
    }
    // Refused: a size on a term over z_m, a negative size, a NaN.
    for (t, what) in [
        (
            LearnedTerm {
                step_size_mm: 1.0,
                ..term(
                    LearnedAxis::ZmMm,
                    LearnedMode::AddMm,
                    &[5.0, 10.0],
                    &[0.0, 1.0],
                    &[0.0, 1.0],
                )
            },
            "only a step_fraction term",
        ),
        (shape(-1.0), "not a finite size"),
        (shape(f64::NAN), "not a finite size"),
    ] {
        let mut m = with(vec![t]);
        m.schema = magswarm_model::SCHEMA.into();
        let e = m.validate().unwrap_err();
        assert_eq!(e.path, "effects.learned[0].step_size_mm");
        assert!(e.message.contains(what), "{e}");
    }
}
