//! Another lab: its rig (the seed's steady map with its own gains, exponents and geometry),
//! its noise, its own transient after an input change (first order, not ODE (4)), and the
//! logs it writes.

use crate::shape::{At, Shape};
use magswarm_model::{hz_to_rad_s, steady, Model};
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};

/// Another lab's rig and habits.
#[derive(Debug, Clone)]
pub(crate) struct Lab {
    pub model: Model,
    /// Visit noise SD per axis \[mm\]: the scatter of a visit's mean around the truth.
    pub visit_sd: [f64; 2],
    /// Row noise SD per axis \[mm\].
    pub row_sd: [f64; 2],
    /// Time constant of the approach after a change \[s\].
    pub tau: f64,
    /// Wait before the first row after a change \[s\].
    pub settle: f64,
    /// Time between rows \[s\].
    pub dt: f64,
    /// Size of the approach per axis (1: the step's whole size; the baseline's imitation may
    /// move it).
    pub own_gain: [f64; 2],
    /// Session time over which the drifts run their course \[s\] (the training session's
    /// length: a withheld session of the same rig drifts at the same pace; None: the plan's
    /// own length).
    pub drift_span: Option<f64>,
}

/// The operating points in visiting order and the rows per visit.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Plan {
    pub visits: Vec<(f64, f64)>,
    pub rows: usize,
}

/// One noise-free row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Row {
    pub t: f64,
    pub visit: usize,
    pub z: f64,
    pub f: f64,
    pub r: [f64; 2],
}

fn normal(rng: &mut rand::rngs::StdRng) -> f64 {
    StandardNormal.sample(rng)
}

impl Lab {
    /// A lab drawn from a seed.
    pub fn draw(seed: u64) -> Lab {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ 0x1AB);
        let mut u = |a: f64, b: f64| a + (b - a) * rng.random::<f64>();
        let mut m = Model::paper();
        let s = &mut m.steady;
        s.C_1 *= u(0.9, 1.1);
        s.C_2 *= u(0.9, 1.1);
        s.a_K1 *= u(0.8, 1.25);
        s.a_K2 *= u(0.8, 1.25);
        s.alpha_1 += u(-0.03, 0.03);
        s.alpha_2 += u(-0.04, 0.04);
        s.N += u(-0.05, 0.05);
        s.q += u(-0.04, 0.04);
        m.magnet.z_offset_m += u(-0.5e-3, 1.5e-3);
        m.magnet.remanence_t *= u(0.9, 1.05);
        Lab {
            model: m,
            visit_sd: [u(0.1, 0.2), u(0.2, 0.35)],
            row_sd: [u(0.15, 0.25), u(0.25, 0.4)],
            tau: u(1.0, 2.5),
            settle: u(2.0, 4.0),
            dt: u(0.8, 1.2),
            own_gain: [1.0; 2],
            drift_span: None,
        }
    }

    /// SD of one row around the truth per axis \[mm\]: the floor no model can beat.
    pub fn floor(&self) -> [f64; 2] {
        [0, 1].map(|i| (self.visit_sd[i].powi(2) + self.row_sd[i].powi(2)).sqrt())
    }

    /// The rig's steady map at (z \[mm\], f \[Hz\]) \[mm\].
    pub fn map(&self, z: f64, f: f64) -> [f64; 2] {
        steady::evaluate(&self.model, z * 1e-3, hz_to_rad_s(f)).radii()
    }

    /// The steady radii at (z, f) with the shapes over the inputs at their amplitudes.
    pub fn steady(&self, effects: &[(Shape, f64)], z: f64, f: f64) -> [f64; 2] {
        let base = self.map(z, f);
        let map = |z: f64, f: f64| self.map(z, f);
        let at = At {
            z,
            f,
            d: z + self.model.magnet.radius_m * 1e3 + self.model.magnet.z_offset_m * 1e3,
            base,
            sd: self.visit_sd,
            map: &map,
        };
        effects.iter().fold(base, |r, &(s, x)| s.steady(x, &at, r))
    }

    /// Length of a session of `plan` \[s\].
    pub fn duration(&self, plan: &Plan) -> f64 {
        (self.settle + plan.rows as f64 * self.dt) * plan.visits.len() as f64
    }

    /// Session time \[s\] of row `k` of visit `v`, and the time since that visit's change.
    fn times(&self, plan: &Plan, v: usize, k: usize) -> (f64, f64) {
        let per_visit = self.settle + plan.rows as f64 * self.dt;
        let since = self.settle + k as f64 * self.dt;
        (v as f64 * per_visit + since, since)
    }

    /// The noise-free rows of a plan with the shapes at their amplitudes.
    pub fn rows(&self, effects: &[(Shape, f64)], plan: &Plan) -> Vec<Row> {
        let total = self.drift_span.unwrap_or_else(|| self.duration(plan));
        let mut out = Vec::with_capacity(plan.visits.len() * plan.rows);
        let mut prev: Option<[f64; 2]> = None;
        for (v, &(z, f)) in plan.visits.iter().enumerate() {
            let target = self.steady(effects, z, f);
            let step = prev
                .map(|p| [target[0] - p[0], target[1] - p[1]])
                .unwrap_or([0.0; 2]);
            for k in 0..plan.rows {
                let (t, since) = self.times(plan, v, k);
                let own = (-since / self.tau).exp();
                let mut m = [self.own_gain[0] * own, self.own_gain[1] * own];
                for &(s, x) in effects {
                    if let Some(d) = s.missing(x, since, own, self.tau, step) {
                        m = [m[0] + d[0], m[1] + d[1]];
                    }
                }
                let mut r = [target[0] - m[0] * step[0], target[1] - m[1] * step[1]];
                for &(s, x) in effects {
                    if let Some(g) = s.over_time(t / total) {
                        for i in 0..2 {
                            r[i] += 2.0 * x * self.visit_sd[i] * g;
                        }
                    }
                }
                out.push(Row {
                    t,
                    visit: v,
                    z,
                    f,
                    r,
                });
            }
            prev = Some(target);
        }
        out
    }

    /// A log (CSV in the project's format) of a plan: the noise-free rows plus a visit
    /// offset and row noise.
    pub fn csv(&self, effects: &[(Shape, f64)], plan: &Plan, seed: u64) -> String {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let mut s = String::from("t_s,z_m_mm,f_hz,r1_mm,r2_mm\n");
        let mut off = [0.0; 2];
        let mut last = usize::MAX;
        for row in self.rows(effects, plan) {
            if row.visit != last {
                off = [0, 1].map(|i| self.visit_sd[i] * normal(&mut rng));
                last = row.visit;
            }
            let r: Vec<f64> = (0..2)
                .map(|i| (row.r[i] + off[i] + self.row_sd[i] * normal(&mut rng)).max(0.01))
                .collect();
            s.push_str(&format!(
                "{:.3},{},{},{:.4},{:.4}\n",
                row.t, row.z, row.f, r[0], r[1]
            ));
        }
        s
    }
}
