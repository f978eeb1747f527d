//! `magswarm diagnose` on the seed's own protocol: the 50-point grid visited **once**, 10 rows
//! per visit, so that nothing is revisited and the gap must be told from noise by the
//! roughness of the residual surface. The logs are written here directly (not by the lab): the
//! paper model's steady map, a first-order approach after each input change, a visit offset
//! and row noise per axis (r2 noisier, as in the seed), and the structures an earlier version
//! missed on this protocol: a band of r2 over 5-6 Hz at every z_m, an underdamped transient
//! after input changes, a local anomaly at three visits. Null logs must stay quiet.
//!
//! And two designs off the seed's grid that another lab brings: operating points drawn at
//! random over the envelope (a Latin hypercube), which have no neighbour on a grid to estimate
//! the visit noise from, and streamed setpoint steps that return to points at other times,
//! where a loss of particles makes the returns differ.

use magswarm::diagnose::{self, Config, Diagnosis};
use magswarm::identify::fit::predict_point;
use magswarm::log::Log;
use magswarm::model::Model;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};

const ZS: [f64; 5] = [3.5, 8.5, 13.5, 18.5, 23.5];

/// What the truth adds to the steady radii, and to the transient after a change.
#[derive(Clone, Copy)]
enum Extra {
    None,
    /// +amp mm on r2 for 5 <= f <= 6 Hz at every z_m.
    Band(f64),
    /// +amp mm on r2 at 5 Hz only, at every z_m: a band between the grid's neighbours.
    NarrowBand(f64),
    /// Both radii shrink by the share amp from the middle of the session on (a sudden loss
    /// of particles).
    Loss(f64),
    /// After each change the radii ring: amp x step x exp(-t/tau) cos(2 pi t / period).
    Ringing(f64),
    /// +amp mm on both radii at three neighbouring operating points.
    Anomaly(f64),
}

fn normal(rng: &mut rand::rngs::StdRng) -> f64 {
    StandardNormal.sample(rng)
}

/// The operating points a log visits, in order.
#[derive(Clone, Copy)]
enum Design {
    /// The seed's 50-point grid, once each, in a random order.
    Grid,
    /// 45 points over the envelope, one per row and column of a 45 x 45 Latin square.
    Scattered,
    /// 40 setpoints drawn from the grid (returns to a point come at other times).
    Steps,
}

fn points(design: Design, rng: &mut rand::rngs::StdRng) -> Vec<(f64, f64)> {
    let mut pts: Vec<(f64, f64)> = Vec::new();
    match design {
        Design::Grid => {
            for z in ZS {
                for f in 1..=10 {
                    pts.push((z, f as f64));
                }
            }
        }
        Design::Scattered => {
            let n = 45;
            let mut fcol: Vec<usize> = (0..n).collect();
            for i in (1..n).rev() {
                fcol.swap(i, rng.random_range(0..=i));
            }
            for (i, &j) in fcol.iter().enumerate() {
                let u = (i as f64 + rng.random::<f64>()) / n as f64;
                let v = (j as f64 + rng.random::<f64>()) / n as f64;
                pts.push((3.5 + 20.0 * u, 1.0 + 9.0 * v));
            }
        }
        Design::Steps => {
            for _ in 0..40 {
                let z = ZS[rng.random_range(0..ZS.len())];
                pts.push((z, rng.random_range(1..=10) as f64));
            }
        }
    }
    // A random visiting order, as a lab would.
    for i in (1..pts.len()).rev() {
        let j = rng.random_range(0..=i);
        pts.swap(i, j);
    }
    pts
}

fn log_of(extra: Extra, seed: u64) -> Log {
    log_on(Design::Grid, extra, seed)
}

fn log_on(design: Design, extra: Extra, seed: u64) -> Log {
    let m = Model::paper();
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let pts = points(design, &mut rng);
    let n = pts.len();
    let mut s = String::from("t_s,z_m_mm,f_hz,r1_mm,r2_mm\n");
    let mut t = 0.0;
    let mut prev: Option<[f64; 2]> = None;
    for (visit, &(z, f)) in pts.iter().enumerate() {
        let mut ss = predict_point(&m, z, f);
        match extra {
            Extra::Band(a) if (5.0..=6.0).contains(&f) => ss[1] += a,
            Extra::NarrowBand(a) if f == 5.0 => ss[1] += a,
            Extra::Loss(a) if 2 * visit >= n => {
                ss[0] *= 1.0 - a;
                ss[1] *= 1.0 - a;
            }
            Extra::Anomaly(a) if z == 13.5 && (4.0..=6.0).contains(&f) => {
                ss[0] += a;
                ss[1] += a;
            }
            _ => {}
        }
        let step = prev
            .map(|p| [ss[0] - p[0], ss[1] - p[1]])
            .unwrap_or([0.0; 2]);
        let off: [f64; 2] = [0.15 * normal(&mut rng), 0.3 * normal(&mut rng)];
        for k in 0..10 {
            // Rows from 3 s after the change, 1 s apart; the ODE's approach (tau 1.5 s) is
            // nearly over, a ringing formation is not.
            let since = 3.0 + k as f64;
            let mut r = ss;
            for a in 0..2 {
                r[a] -= step[a] * (-since / 1.5f64).exp();
                if let Extra::Ringing(amp) = extra {
                    r[a] -= amp
                        * step[a]
                        * (-since / 8.0f64).exp()
                        * (2.0 * std::f64::consts::PI * since / 6.0).cos();
                }
                let sd = [0.2, 0.35][a];
                r[a] += off[a] + sd * normal(&mut rng);
            }
            s.push_str(&format!(
                "{:.3},{z},{f},{:.4},{:.4}\n",
                t + since,
                r[0],
                r[1]
            ));
        }
        t += 3.0 + 10.0;
        prev = Some(ss);
    }
    if let Ok(dir) = std::env::var("MAGSWARM_DUMP_LOGS") {
        let _ = std::fs::write(format!("{dir}/single_visit_{seed}.csv"), &s);
    }
    Log::from_str_named(&s, "single_visit.csv").expect("a valid log")
}

fn run(extra: Extra, seed: u64) -> Diagnosis {
    run_on(Design::Grid, extra, seed)
}

fn run_on(design: Design, extra: Extra, seed: u64) -> Diagnosis {
    diagnose::diagnose(
        &log_on(design, extra, seed),
        None,
        &Model::paper(),
        &Config::default(),
    )
    .expect("diagnose runs")
}

/// With each point visited once, session time and the operating points can be confounded by
/// the visiting order: on an unlucky order a time shape explains part of a band. The band must
/// be found on every log and named phase lag on most (2 of 3 here; the benchmark in
/// docs/diagnose.md measures the rate).
#[test]
fn a_band_over_f_at_every_z_is_found_and_named_phase_lag() {
    let mut named_right = Vec::new();
    for seed in [1, 2, 3] {
        let d = run(Extra::Band(1.0), seed);
        assert!(d.tests.significant, "seed {seed}: p = {}", d.tests.p_value);
        assert!(
            d.regions
                .iter()
                .any(|r| r.axis == 1 && r.f.0 <= 6.0 && r.f.1 >= 5.0),
            "seed {seed}: no r2 region over 5-6 Hz: {:?}",
            d.regions
        );
        if d.attr.accepted.first().map(String::as_str) == Some("phase_lag") {
            let ex = d.excess_removed()[2].expect("an excess");
            assert!(ex >= 0.5, "seed {seed}: {:.0} % removed", 100.0 * ex);
            named_right.push(seed);
        } else {
            eprintln!(
                "seed {seed}: named {:?} ({:?})",
                d.attr.accepted,
                d.attr
                    .evals
                    .iter()
                    .map(|e| (&e.name, e.round, e.gain, e.penalty, e.p))
                    .collect::<Vec<_>>()
            );
        }
    }
    assert!(
        named_right.len() >= 2,
        "phase_lag named first only on seeds {named_right:?}"
    );
}

#[test]
fn an_underdamped_transient_after_changes_is_named_formation_lag() {
    for seed in [3, 4] {
        let d = run(Extra::Ringing(0.6), seed);
        assert!(d.tests.significant, "seed {seed}: p = {}", d.tests.p_value);
        assert_eq!(
            d.attr.accepted.first().map(String::as_str),
            Some("formation_lag"),
            "seed {seed}: {:?}",
            d.attr.accepted
        );
        let ex = d.excess_removed()[2].expect("an excess");
        assert!(ex >= 0.5, "seed {seed}: {:.0} % removed", 100.0 * ex);
    }
}

#[test]
fn a_local_anomaly_at_three_visits_is_unexplained_where_it_lies() {
    for seed in [5, 6] {
        let d = run(Extra::Anomaly(1.5), seed);
        assert!(d.tests.significant, "seed {seed}: p = {}", d.tests.p_value);
        assert!(
            d.attr.accepted.is_empty(),
            "seed {seed}: named {:?}",
            d.attr.accepted
        );
        assert!(
            d.unexplained.iter().any(|u| u.region.z.0 <= 13.5
                && u.region.z.1 >= 13.5
                && u.region.f.0 <= 6.0
                && u.region.f.1 >= 4.0),
            "seed {seed}: {:?}",
            d.unexplained.iter().map(|u| &u.region).collect::<Vec<_>>()
        );
    }
}

/// The gap tests hold the level the user set: over 100 null logs of the grid visited once, a
/// gap at alpha = 0.01 on about 1. An earlier build declared one on 6 (the min-p over the
/// tests' 50 alternatives read the real log's p-values against an extrapolated tail that no
/// simulated log's could reach: `noise::replicate_ps`), and the report called it unexplained.
#[test]
fn null_logs_on_the_single_visit_grid_name_nothing() {
    let mut gaps = Vec::new();
    let mut named = Vec::new();
    for seed in 10..110 {
        let d = run(Extra::None, seed);
        if d.tests.significant {
            gaps.push((seed, d.tests.p_value));
        }
        if !d.attr.accepted.is_empty() {
            named.push((seed, d.attr.accepted.clone()));
        }
    }
    // 1 expected; 3 or fewer with probability 0.98.
    assert!(
        gaps.len() <= 3,
        "gaps declared on {} of 100: {gaps:?}",
        gaps.len()
    );
    assert!(named.len() <= 1, "{named:?}");
}

#[test]
fn the_same_seed_gives_the_same_report() {
    let log = log_of(Extra::Band(1.0), 7);
    let a = diagnose::diagnose(&log, None, &Model::paper(), &Config::default()).unwrap();
    let b = diagnose::diagnose(&log, None, &Model::paper(), &Config::default()).unwrap();
    assert_eq!(a.tests.p_value, b.tests.p_value);
    assert_eq!(a.attr.accepted, b.attr.accepted);
    assert_eq!(a.attr.augmented.cv, b.attr.augmented.cv);
}

/// A band that the grid sees at one frequency only (+1 mm of r2 at 5 Hz, every z_m): the
/// smooth shapes over f spread it over their neighbours, the strongest band over f at every
/// z_m does not.
#[test]
fn a_band_at_one_grid_frequency_is_found_and_named_phase_lag() {
    let mut named_right = Vec::new();
    for seed in [21, 22, 23] {
        let d = run(Extra::NarrowBand(1.0), seed);
        assert!(d.tests.significant, "seed {seed}: p = {}", d.tests.p_value);
        if d.attr.accepted.first().map(String::as_str) == Some("phase_lag") {
            named_right.push(seed);
        } else {
            eprintln!("seed {seed}: named {:?}", d.attr.accepted);
        }
    }
    assert!(
        named_right.len() >= 2,
        "phase_lag named first only on seeds {named_right:?}"
    );
}

/// Operating points off any grid: the visit noise comes from each visit's nearest neighbour
/// in the (z_m, f) plane. Such a log is diagnosed, not refused; a null one names nothing.
#[test]
fn scattered_operating_points_are_diagnosed_and_a_null_names_nothing() {
    let mut flagged = Vec::new();
    for seed in [31, 32, 33] {
        let d = run_on(Design::Scattered, Extra::None, seed);
        assert!(d.noise.pairs >= 12, "seed {seed}: {} pairs", d.noise.pairs);
        if !d.attr.accepted.is_empty() {
            flagged.push((seed, d.attr.accepted.clone()));
        }
    }
    assert!(flagged.is_empty(), "{flagged:?}");
}

/// A sudden loss of 6 % of the swarm halfway through a run of setpoint steps that returns to
/// points at other times: the returns differ, which inflates the visit noise of the baseline's
/// residual. Judged against the noise left once a course over session time is fitted, it is
/// found and named.
#[test]
fn a_sudden_loss_on_streamed_steps_is_named_particle_drift() {
    let mut named_right = Vec::new();
    for seed in [41, 42, 43] {
        let d = run_on(Design::Steps, Extra::Loss(0.06), seed);
        if d.attr.accepted.first().map(String::as_str) == Some("particle_drift") {
            named_right.push(seed);
        } else {
            eprintln!(
                "seed {seed}: p = {}, named {:?}",
                d.tests.p_value, d.attr.accepted
            );
        }
    }
    assert!(
        named_right.len() >= 2,
        "particle_drift named first only on seeds {named_right:?}"
    );
}
