//! The candidate effects diagnose tries, each a compact parametric extension of the plant that
//! nests the baseline at its neutral parameters.
//!
//! A candidate is: its name (the fixed CONTRACTS names), the parameters it frees (name, unit,
//! bounds, neutral value, starting values) and how it acts on the prediction. They act in a
//! fixed order: on the swarm's steady map (phase lag, cohesion loss, centroid offset), then on
//! the swarm over time (formation lag, particle drift), then on the measurement (camera bias).
//!
//! | name | parameters | form |
//! | --- | --- | --- |
//! | `phase_lag` | a_1, a_2 [-], f_so [Hz], nu [-] | r_i x (1 + a_i sigma((f - f_so (B/B_mid)^nu) / (0.1 f_so))): a change of the swarm past a step-out frequency that scales with the field |
//! | `cohesion_loss` | b_1, b_2 >= 0 [-], z_c [mm], w_z [mm] | r_i x (1 + b_i sigma((z_m - z_c) / w_z) / sigma((z_max - z_c) / w_z)): confinement fading past a distance z_c (b_i: the change at the data's largest z_m, z_max; z_c may lie past z_max, the onset of a fade toward z_off) |
//! | `centroid_offset` | c_1, c_2 [-], lambda [mm] | r_i x (1 + c_i exp(-(z_m - z_min) / lambda)): a swarm off the field axis feels it most where the magnet is close (the displacement is comparable to the depth), fading over a length lambda; c_i is the change at the data's smallest z_m |
//! | `formation_lag` | tau_f [s] | the measured swarm follows the model's trajectory through a first-order lag |
//! | `particle_drift` | k_1, k_2 [1/h] | r_i x (1 + k_i t), t session time |
//! | `camera_bias` | o_1, o_2 [mm] | r_i + o_i (a pure scale of the camera is absorbed by C_1, C_2) |
//!
//! sigma is the logistic function. The forms are deliberately generic within their physics
//! (free sign and per-axis amplitude) so that a rig's own form of the same effect is still
//! recognised; the acceptance rules (withheld gain, plausibility, residual signature) keep a
//! generic form from being accepted for a residual of another kind.

use super::data::Dataset;
use crate::identify::fit::predict_point;
use magswarm_model::{steady, Model};

/// The candidates, in report order.
pub const NAMES: [&str; 6] = [
    "phase_lag",
    "cohesion_loss",
    "formation_lag",
    "particle_drift",
    "centroid_offset",
    "camera_bias",
];

/// One parameter of a candidate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EffParam {
    /// Name.
    pub name: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// Fit bounds.
    pub lo: f64,
    /// Fit bounds.
    pub hi: f64,
    /// Log transform (strictly positive scale) rather than the double-bounded sine.
    pub log: bool,
    /// True for a location (step frequency, distance): it must lie inside the data's range
    /// to be a plausible description of the residual rather than of a trend.
    pub location: Option<Axis>,
    /// Which bounds mean "the data want more than the form allows" when reached: (lower,
    /// upper). A physical sign limit (an amplitude at 0: no effect on that axis) or a width
    /// at its lower bound (sharper than the grid resolves) is not such a bound.
    pub flag: (bool, bool),
}

/// Which input a location parameter refers to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// z_m.
    Z,
    /// f.
    F,
}

const fn p(name: &'static str, unit: &'static str, lo: f64, hi: f64) -> EffParam {
    EffParam {
        name,
        unit,
        lo,
        hi,
        log: false,
        location: None,
        flag: (true, true),
    }
}

/// Parameters of a candidate.
pub fn params(name: &str) -> Vec<EffParam> {
    match name {
        "phase_lag" => vec![
            p("a_1", "-", -0.6, 1.5),
            p("a_2", "-", -0.6, 1.5),
            EffParam {
                location: Some(Axis::F),
                ..p("f_so", "Hz", 0.3, 40.0)
            },
            p("nu", "-", -1.5, 1.5),
        ],
        "cohesion_loss" => vec![
            // Weakening cohesion enlarges the footprint: b_i >= 0.
            EffParam {
                flag: (false, true),
                ..p("b_1", "-", 0.0, 2.0)
            },
            EffParam {
                flag: (false, true),
                ..p("b_2", "-", 0.0, 2.0)
            },
            // Normalised at z_max, the form tends to exp((z - z_max) / w_z) as z_c grows:
            // an onset past the data is a fade toward a z_off beyond them, not a misfit.
            EffParam {
                location: Some(Axis::Z),
                flag: (true, false),
                ..p("z_c", "mm", -10.0, 80.0)
            },
            EffParam {
                log: true,
                flag: (false, true),
                ..p("w_z", "mm", 0.3, 10.0)
            },
        ],
        "centroid_offset" => vec![
            p("c_1", "-", -0.8, 2.0),
            p("c_2", "-", -0.8, 2.0),
            EffParam {
                log: true,
                flag: (false, true),
                ..p("lambda", "mm", 0.5, 30.0)
            },
        ],
        "formation_lag" => vec![EffParam {
            log: true,
            ..p("tau_f", "s", 0.02, 1000.0)
        }],
        "particle_drift" => vec![p("k_1", "1/h", -3.0, 3.0), p("k_2", "1/h", -3.0, 3.0)],
        "camera_bias" => vec![p("o_1", "mm", -5.0, 5.0), p("o_2", "mm", -5.0, 5.0)],
        _ => Vec::new(),
    }
}

/// Neutral values (the baseline exactly) of a candidate's parameters, given the baseline.
pub fn neutral(name: &str, _base: &Model) -> Vec<f64> {
    match name {
        "phase_lag" => vec![0.0, 0.0, 6.0, 0.0],
        "cohesion_loss" => vec![0.0, 0.0, 20.0, 2.0],
        "centroid_offset" => vec![0.0, 0.0, 4.0],
        "formation_lag" => vec![0.02],
        "particle_drift" => vec![0.0, 0.0],
        "camera_bias" => vec![0.0, 0.0],
        _ => Vec::new(),
    }
}

/// Starting values for the multi-start fit of a candidate (the data's ranges place the
/// location parameters).
pub fn starts(name: &str, _base: &Model, ds: &Dataset) -> Vec<Vec<f64>> {
    let (zs, fs) = ds.levels();
    let q = |v: &[f64], x: f64| {
        let lo = v.first().copied().unwrap_or(0.0);
        let hi = v.last().copied().unwrap_or(1.0);
        lo + (hi - lo) * x
    };
    let span_z = (q(&zs, 1.0) - q(&zs, 0.0)).max(1.0);
    match name {
        "phase_lag" => [0.35, 0.6, 0.85]
            .iter()
            .map(|&x| vec![0.05, 0.05, q(&fs, x), 0.0])
            .collect(),
        "cohesion_loss" => [0.45, 0.7, 0.9]
            .iter()
            .map(|&x| vec![0.05, 0.05, q(&zs, x), (0.15 * span_z).clamp(0.5, 8.0)])
            .collect(),
        "centroid_offset" => [0.1, 0.25]
            .iter()
            .map(|&x| vec![0.03, 0.03, (x * span_z).clamp(0.6, 25.0)])
            .collect(),
        "formation_lag" => {
            let mut durs: Vec<f64> = ds
                .visits
                .iter()
                .filter_map(|v| {
                    let a = ds.rows[*v.rows.first()?].since;
                    let b = ds.rows[*v.rows.last()?].since;
                    Some(b.max(a))
                })
                .collect();
            durs.sort_by(|a, b| a.total_cmp(b));
            let med = durs.get(durs.len() / 2).copied().unwrap_or(10.0).max(0.5);
            vec![
                vec![(med / 10.0).clamp(0.05, 500.0)],
                vec![(med / 2.0).clamp(0.05, 500.0)],
            ]
        }
        "particle_drift" => vec![vec![0.0, 0.0], vec![-0.2, -0.2], vec![0.2, 0.2]],
        "camera_bias" => vec![vec![0.0, 0.0], vec![-0.3, -0.3], vec![0.3, 0.3]],
        _ => vec![Vec::new()],
    }
}

fn logistic(x: f64) -> f64 {
    if x >= 0.0 {
        1.0 / (1.0 + (-x).exp())
    } else {
        let e = x.exp();
        e / (1.0 + e)
    }
}

/// An augmented model: the baseline's (refitted) parameters and the active effects.
#[derive(Debug, Clone, PartialEq)]
pub struct Augmented {
    /// The plant model (the centroid offset lives in it).
    pub model: Model,
    /// Active effects (name, parameter values).
    pub effects: Vec<(String, Vec<f64>)>,
}

impl Augmented {
    /// The baseline alone.
    pub fn baseline(model: &Model) -> Augmented {
        Augmented {
            model: model.clone(),
            effects: Vec::new(),
        }
    }

    fn eff(&self, name: &str) -> Option<&[f64]> {
        self.effects
            .iter()
            .find(|e| e.0 == name)
            .map(|e| e.1.as_slice())
    }

    /// Write a candidate's parameters into the model where the model holds them (none of the
    /// present forms lives in the model file of schema 1).
    pub fn sync_model(&mut self) {}
}

/// Context the effects need beyond the rows: the field magnitude at mid-range z_m and the
/// largest z_m of the training data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ctx {
    /// |B| at the middle of the z_m range of the training data [T].
    pub b_mid: f64,
    /// Largest z_m of the training data [mm].
    pub z_max: f64,
    /// Smallest z_m of the training data [mm].
    pub z_min: f64,
}

impl Ctx {
    /// From the data set.
    pub fn new(model: &Model, ds: &Dataset) -> Ctx {
        let (zs, _) = ds.levels();
        let zm = (zs.first().copied().unwrap_or(10.0) + zs.last().copied().unwrap_or(10.0)) / 2.0;
        Ctx {
            b_mid: model.magnet.at(zm * 1e-3).b.max(1e-12),
            z_max: zs.last().copied().unwrap_or(20.0),
            z_min: zs.first().copied().unwrap_or(3.5),
        }
    }
}

/// Steady map of the augmented model at every point of `ds` [mm].
pub fn point_map(aug: &Augmented, ds: &Dataset, ctx: &Ctx) -> Vec<[f64; 2]> {
    let m = &aug.model;
    let phase = aug.eff("phase_lag");
    let coh = aug.eff("cohesion_loss");
    let cen = aug.eff("centroid_offset");
    ds.points
        .iter()
        .map(|&(z, f)| {
            let mut r = predict_point(m, z, f);
            if let Some(pp) = phase {
                let b = m.magnet.at(z * 1e-3).b.max(1e-12);
                let fso = pp[2] * (b / ctx.b_mid).powf(pp[3]);
                let s = logistic((f - fso) / (0.1 * fso).max(0.05));
                r[0] *= 1.0 + pp[0] * s;
                r[1] *= 1.0 + pp[1] * s;
            }
            if let Some(c) = coh {
                let w = c[3].max(1e-3);
                let s = logistic((z - c[2]) / w) / logistic((ctx.z_max - c[2]) / w).max(1e-300);
                r[0] *= 1.0 + c[0] * s;
                r[1] *= 1.0 + c[1] * s;
            }
            if let Some(c) = cen {
                let s = (-(z - ctx.z_min) / c[2].max(1e-3)).exp();
                r[0] *= 1.0 + c[0] * s;
                r[1] *= 1.0 + c[1] * s;
            }
            r
        })
        .collect()
}

/// Predicted radii at every row of `ds` [mm].
pub fn predict(aug: &Augmented, ds: &Dataset, ctx: &Ctx) -> Vec<[f64; 2]> {
    let map = point_map(aug, ds, ctx);
    let mut out: Vec<[f64; 2]> = ds
        .rows
        .iter()
        .map(|r| {
            let m = map[r.point];
            [m[0] + r.trans[0], m[1] + r.trans[1]]
        })
        .collect();
    if let Some(tau) = aug.eff("formation_lag").map(|v| v[0]) {
        let mut y = [0.0; 2];
        for (i, r) in ds.rows.iter().enumerate() {
            let x = out[i];
            if i == 0 || ds.rows[i - 1].sess != r.sess {
                y = x;
            } else {
                let k = (-r.dt / tau.max(1e-9)).exp();
                for a in 0..2 {
                    y[a] = x[a] + (y[a] - x[a]) * k;
                }
            }
            out[i] = y;
        }
    }
    if let Some(k) = aug.eff("particle_drift") {
        for (o, r) in out.iter_mut().zip(&ds.rows) {
            let th = r.t / 3600.0;
            o[0] *= 1.0 + k[0] * th;
            o[1] *= 1.0 + k[1] * th;
        }
    }
    if let Some(o) = aug.eff("camera_bias") {
        for x in out.iter_mut() {
            x[0] += o[0];
            x[1] += o[1];
        }
    }
    out
}

/// Mid-range |B| helper for the report (field at a z_m [mm]).
pub fn field_b(model: &Model, z_mm: f64) -> f64 {
    steady::evaluate(model, z_mm * 1e-3, 1.0).field.b
}
