//! A small campaign generator for diagnose's tests, bench and worked example: a randomised
//! operating-point grid visited in a shuffled order, rows during the approach and settled
//! repeats, per-row and per-visit noise, occasional invalid frames, and *foreign* forms of the
//! six effects: deliberately not the forms diagnose fits ([`super::candidates`]), so that a
//! recovery shows that diagnose recognises an effect, not that it recovers its own generator.
//!
//! | truth | foreign form here | candidate form diagnose fits |
//! | --- | --- | --- |
//! | `phase_lag` | r_i x (1 + A_i (1 - exp(-(f - 5.5 Hz)_+ / 1.5 Hz))), no field dependence | logistic step at a field-scaled f_so |
//! | `cohesion_loss` | r_i x (1 + c_i ((z_m - 14 mm)_+ / 9.5 mm)^2) | logistic in z_m |
//! | `formation_lag` | two first-order stages in series (4 s each: aggregation, then compaction) between the plant and what is seen | one first-order lag |
//! | `particle_drift` | r_i x (0.88 + 0.12 exp(-t / 1200 s)) (particle loss) | linear in t |
//! | `centroid_offset` | r_i x (1 + k_i (6 mm / (z_m + 6 mm))^2) | the dipole field off axis |
//! | `camera_bias` | sqrt((1.03 r_i)^2 + (4 mm)^2) (edge blur and scale) | constant offset |

use crate::log::{Layout, LogRow, LogWriter};
use magswarm_model::{hz_to_rad_s, Model, Plant};
use rand::{seq::SliceRandom, RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};

/// A campaign to generate.
#[derive(Debug, Clone)]
pub struct Campaign {
    /// The true plant without effects.
    pub truth: Model,
    /// Effects acting in the truth (CONTRACTS names), each with a strength multiplier (1 =
    /// the documented size).
    pub effects: Vec<(String, f64)>,
    /// Operating points (z_m [mm], f [Hz]).
    pub points: Vec<(f64, f64)>,
    /// Visits per point.
    pub visits_per_point: usize,
    /// Rows during the approach after each change.
    pub transient_rows: usize,
    /// Their spacing [s].
    pub transient_dt: f64,
    /// Settled rows per visit.
    pub settled_rows: usize,
    /// From the change to the first settled row [s].
    pub wait_s: f64,
    /// Spacing of settled rows [s].
    pub dt: f64,
    /// Row noise SD per axis [mm].
    pub sigma_row: [f64; 2],
    /// Visit-to-visit noise SD per axis [mm].
    pub sigma_visit: [f64; 2],
    /// Share of rows marked invalid.
    pub invalid: f64,
    /// Seed.
    pub seed: u64,
}

/// The paper model with its default free steady parameters moved (the rig is not the paper's).
pub fn rig_truth() -> Model {
    let mut m = Model::paper();
    let s = &mut m.steady;
    s.C_1 *= 1.06;
    s.C_2 *= 0.95;
    s.a_K1 *= 1.2;
    s.a_K2 *= 0.9;
    s.alpha_1 += 0.02;
    s.alpha_2 -= 0.03;
    s.N -= 0.04;
    s.q += 0.03;
    m.name = "rig-truth".into();
    m
}

impl Campaign {
    /// The seed's grid (z_m 3.5..23.5 mm x f 1..10 Hz), one visit each in a random order,
    /// 2 approach rows and 8 settled rows: 500 rows.
    pub fn seed_grid_500(effects: &[(&str, f64)], seed: u64) -> Campaign {
        Campaign {
            visits_per_point: 1,
            settled_rows: 8,
            ..Campaign::seed_grid(effects, seed)
        }
    }

    /// The seed's grid (z_m 3.5..23.5 mm x f 1..10 Hz), each point visited twice in a random
    /// order (so that the visit-to-visit error is measured), 2 approach rows and 4 settled
    /// rows per visit: 600 rows.
    pub fn seed_grid(effects: &[(&str, f64)], seed: u64) -> Campaign {
        Campaign {
            truth: rig_truth(),
            effects: effects.iter().map(|(n, s)| (n.to_string(), *s)).collect(),
            points: magswarm_model::seed_grid()
                .into_iter()
                .map(|(z, f)| (z * 1e3, f))
                .collect(),
            visits_per_point: 2,
            transient_rows: 2,
            transient_dt: 2.0,
            settled_rows: 4,
            wait_s: 20.0,
            dt: 1.0,
            sigma_row: [0.2, 0.3],
            sigma_visit: [0.08, 0.12],
            invalid: 0.01,
            seed,
        }
    }

    fn strength(&self, name: &str) -> f64 {
        self.effects
            .iter()
            .find(|e| e.0 == name)
            .map(|e| e.1)
            .unwrap_or(0.0)
    }

    /// The steady-state multiplicative/measurement effects at (z, f, t) applied to radii r.
    fn apply(&self, r: [f64; 2], z: f64, f: f64, t: f64) -> [f64; 2] {
        let mut r = r;
        let s = self.strength("phase_lag");
        if s != 0.0 {
            let x = 1.0 - (-(f - 5.5).max(0.0) / 1.5).exp();
            r[0] *= 1.0 + s * 0.03 * x;
            r[1] *= 1.0 + s * 0.10 * x;
        }
        let s = self.strength("cohesion_loss");
        if s != 0.0 {
            let x = ((z - 14.0).max(0.0) / 9.5).powi(2);
            r[0] *= 1.0 + s * 0.08 * x;
            r[1] *= 1.0 + s * 0.15 * x;
        }
        let s = self.strength("centroid_offset");
        if s != 0.0 {
            let x = (6.0 / (z + 6.0)).powi(2);
            r[0] *= 1.0 + s * 0.20 * x;
            r[1] *= 1.0 + s * 0.12 * x;
        }
        let s = self.strength("particle_drift");
        if s != 0.0 {
            let k = 1.0 - s * 0.12 * (1.0 - (-t / 1200.0).exp());
            r[0] *= k;
            r[1] *= k;
        }
        let s = self.strength("camera_bias");
        if s != 0.0 {
            let b = 4.0 * s.sqrt();
            for v in r.iter_mut() {
                *v = ((1.0 + 0.03 * s) * *v).hypot(b);
            }
        }
        r
    }

    /// Generate the rows (one session "s").
    pub fn rows(&self) -> Vec<LogRow> {
        let mut rng = rand::rngs::StdRng::seed_from_u64(self.seed);
        let mut order: Vec<(f64, f64)> = Vec::new();
        for _ in 0..self.visits_per_point {
            order.extend(self.points.iter().copied());
        }
        order.shuffle(&mut rng);
        let n1 = Normal::new(0.0, self.sigma_row[0].max(1e-12)).expect("sd");
        let n2 = Normal::new(0.0, self.sigma_row[1].max(1e-12)).expect("sd");
        let v1 = Normal::new(0.0, self.sigma_visit[0].max(1e-12)).expect("sd");
        let v2 = Normal::new(0.0, self.sigma_visit[1].max(1e-12)).expect("sd");
        let t_form = 4.0 * self.strength("formation_lag");
        // Schedule: (t, z, f, visit).
        let mut sched = Vec::new();
        let mut t_change = 0.0;
        for (k, &(z, f)) in order.iter().enumerate() {
            for j in 1..=self.transient_rows {
                sched.push((t_change + j as f64 * self.transient_dt, z, f, k));
            }
            for j in 0..self.settled_rows {
                sched.push((t_change + self.wait_s + j as f64 * self.dt, z, f, k));
            }
            t_change = sched.last().map(|s| s.0).unwrap_or(t_change);
        }
        // Input changes: at the last row of the old inputs (the log's convention).
        let mut changes: Vec<(f64, f64, f64)> = Vec::new();
        for i in 0..sched.len() {
            if i == 0 || sched[i].3 != sched[i - 1].3 {
                let tc = if i == 0 { sched[0].0 } else { sched[i - 1].0 };
                changes.push((tc, sched[i].1, sched[i].2));
            }
        }
        let (t0, z0, f0, _) = sched[0];
        let mut plant = Plant::new(self.truth.clone(), z0 * 1e-3, hz_to_rad_s(f0));
        let mut t_now = t0;
        let mut ci = 1;
        let mut offset = [0.0; 2];
        let mut out = Vec::with_capacity(sched.len());
        // Two formation stages in series (exact for a state held over the row interval).
        let mut stage1 = plant.state();
        let mut stage2 = plant.state();
        let mut t_last = t0;
        for (i, &(t, z, f, k)) in sched.iter().enumerate() {
            if i == 0 || sched[i - 1].3 != k {
                offset = [v1.sample(&mut rng), v2.sample(&mut rng)];
            }
            while ci < changes.len() && changes[ci].0 <= t {
                let (tc, zc, fc) = changes[ci];
                if tc > t_now {
                    plant.step(tc - t_now).expect("truth integrates");
                    t_now = tc;
                }
                plant.set_inputs(zc * 1e-3, hz_to_rad_s(fc));
                ci += 1;
            }
            if t > t_now {
                plant.step(t - t_now).expect("truth integrates");
                t_now = t;
            }
            let mut st = plant.state();
            if t_form > 0.0 {
                let h = t - t_last;
                let e = (-h / t_form).exp();
                for a in 0..2 {
                    let x = st[a];
                    stage2[a] = x + (stage2[a] - x) * e + (stage1[a] - x) * (h / t_form) * e;
                    stage1[a] = x + (stage1[a] - x) * e;
                }
                st = stage2;
            }
            t_last = t;
            let r = self.apply(st, z, f, t);
            let meas = [
                r[0] + offset[0] + n1.sample(&mut rng),
                r[1] + offset[1] + n2.sample(&mut rng),
            ];
            let mut row = LogRow::new(t, z, f, Some(meas));
            row.session = "s".into();
            if self.invalid > 0.0 && rng.random::<f64>() < self.invalid {
                row.valid = false;
                row.r1_mm = None;
                row.r2_mm = None;
            }
            out.push(row);
        }
        out
    }

    /// The log as CSV text.
    pub fn csv(&self) -> String {
        let mut w = LogWriter::new(Vec::new(), Layout::standard(true, true, true, false))
            .expect("in-memory writer");
        for r in self.rows() {
            w.write_row(&r).expect("in-memory write");
        }
        String::from_utf8(w.into_inner().expect("in-memory writer")).expect("utf-8")
    }

    /// The log, parsed.
    pub fn log(&self, name: &str) -> crate::log::Log {
        crate::log::Log::from_str_named(&self.csv(), name).expect("generated log parses")
    }
}
