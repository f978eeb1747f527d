//! A small synthetic-log generator for the identify/predict tests (the virtual lab's stand-in):
//! visits to operating points in sequence within one session; after each input change the
//! true plant (dynamics included) is simulated, `transient_rows` rows are sampled during the
//! approach, then `repeats` rows from `wait_s` on, with iid Gaussian noise on each radius.
#![allow(dead_code)]

use magswarm::log::{Layout, LogRow, LogWriter};
use magswarm::model::{hz_to_rad_s, Model, Plant};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

/// What to generate.
#[derive(Clone)]
pub struct Spec {
    /// The true model.
    pub truth: Model,
    /// Operating points (z_m [mm], f [Hz]) in visiting order.
    pub points: Vec<(f64, f64)>,
    /// Settled repeats per point.
    pub repeats: usize,
    /// Noise SD per axis [mm].
    pub sigma: [f64; 2],
    /// Seed.
    pub seed: u64,
    /// Time from the input change to the first settled repeat [s].
    pub wait_s: f64,
    /// Time between repeats [s].
    pub dt_s: f64,
    /// Rows sampled during the approach.
    pub transient_rows: usize,
    /// Interval of the approach rows [s].
    pub transient_dt_s: f64,
}

impl Spec {
    /// The seed's design: 50 points, 10 repeats, sigma 0.25 / 0.4 mm, settled only.
    pub fn seed_like(truth: Model, seed: u64) -> Spec {
        Spec {
            truth,
            points: magswarm::model::seed_grid()
                .into_iter()
                .map(|(z, f)| (z * 1e3, f))
                .collect(),
            repeats: 10,
            sigma: [0.25, 0.4],
            seed,
            wait_s: 30.0,
            dt_s: 1.0,
            transient_rows: 0,
            transient_dt_s: 0.5,
        }
    }
}

/// The (t, z_m [mm], f [Hz]) schedule: after each input change, `transient_rows` rows every
/// `transient_dt_s`, then `repeats` rows every `dt_s` starting `wait_s` after the change. A
/// row's inputs are in force since the previous row (the `predict` convention).
pub fn schedule(spec: &Spec) -> Vec<(f64, f64, f64)> {
    let mut out = Vec::new();
    let mut t_change = 0.0;
    for &(z, f) in &spec.points {
        for k in 1..=spec.transient_rows {
            out.push((t_change + k as f64 * spec.transient_dt_s, z, f));
        }
        for k in 0..spec.repeats {
            out.push((t_change + spec.wait_s + k as f64 * spec.dt_s, z, f));
        }
        t_change = out.last().unwrap().0;
    }
    out
}

/// Generate the log rows (one session "s"): the true plant is stepped between rows under the
/// later row's inputs and the noisy state is recorded.
pub fn rows(spec: &Spec) -> Vec<LogRow> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(spec.seed);
    let n1 = Normal::new(0.0, spec.sigma[0]).unwrap();
    let n2 = Normal::new(0.0, spec.sigma[1]).unwrap();
    let sched = schedule(spec);
    let (t0, z0, f0) = sched[0];
    let mut plant = Plant::new(spec.truth.clone(), z0 * 1e-3, hz_to_rad_s(f0));
    let mut t_last = t0;
    let mut out = Vec::new();
    for (t, z, f) in sched {
        plant.set_inputs(z * 1e-3, hz_to_rad_s(f));
        if t > t_last {
            plant.step(t - t_last).unwrap();
        }
        t_last = t;
        let r = plant.state();
        let mut row = LogRow::new(
            t,
            z,
            f,
            Some([r[0] + n1.sample(&mut rng), r[1] + n2.sample(&mut rng)]),
        );
        row.session = "s".into();
        out.push(row);
    }
    out
}

/// Generate the log as CSV text.
pub fn csv(spec: &Spec) -> String {
    let mut w = LogWriter::new(Vec::new(), Layout::standard(true, true, false, false)).unwrap();
    for r in rows(spec) {
        w.write_row(&r).unwrap();
    }
    String::from_utf8(w.into_inner().unwrap()).unwrap()
}

/// Parse generated text.
pub fn log(spec: &Spec) -> magswarm::log::Log {
    magswarm::log::Log::from_str_named(&csv(spec), "synthetic.csv").unwrap()
}

/// The paper model with the default free steady parameters perturbed.
pub fn perturbed_truth() -> Model {
    let mut m = Model::paper();
    let s = &mut m.steady;
    s.C_1 *= 1.08;
    s.C_2 *= 0.93;
    s.a_K1 *= 1.25;
    s.a_K2 *= 0.85;
    s.alpha_1 += 0.03;
    s.alpha_2 -= 0.04;
    s.N -= 0.05;
    s.q += 0.04;
    m.name = "truth".into();
    m
}
