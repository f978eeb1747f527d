//! Attribution: which effect explains the gap, judged on withheld visits and calibrated by
//! simulation.
//!
//! Every candidate effect is a family of shapes along its physical axis ([`super::shapes`]:
//! step-out over f, possibly moving with the field; cohesion loss over z_m; drift over session
//! time; formation over the time since a change) or, for the effects without an axis, the
//! correction its parametric form makes (centroid offset at a few distances, camera offset).
//! Beside them stands one pseudo-candidate, the *local anomaly*: the strongest small box of
//! operating points, which no effect describes.
//!
//! A candidate's **gain** is the drop of the withheld sum of squares (grouped cross-validation
//! by visit, everything refitted per fold together with the model's free parameters), halved,
//! in units of the row noise, best over the candidate's variants (smoothness, field exponent).
//! Its **null distribution** is that of the same statistic on logs simulated from the current
//! model with the log's own design and noise structure ([`super::noise`]), each refitted
//! exactly as the real one, variants and box search included. A candidate *passes* when its
//! gain lies beyond its null (bootstrap p < alpha); the passing candidate with the largest gain
//! is named. If that is the local anomaly, nothing more is named: the gap there is reported
//! unexplained. Plausibility of the fitted parametric form and the share of each region's
//! residual removed are reported as reasons, never as vetoes over strong evidence.
//!
//! Forward selection: the named effect joins the design, the gap tests ([`super::detect`])
//! run again on what is left, and selection continues while a significant gap remains.
//!
//! Then each named effect's **form** is chosen: its library (parametric) form, fitted by the
//! nonlinear fitter, is used where it does as well on withheld visits as the learned shape (at
//! least 90 % of its gain); otherwise the learned shape goes into the model as a learned
//! effect term (heights at knots with their SDs).

use super::candidates::{self, Augmented, Ctx};
use super::data::Dataset;
use super::detect::{self, Setting};
use super::fitter::{self, FitResult};
use super::gap::{self, Region};
use super::linear::{self, Design, Solver};
use super::noise::{self, Noise};
use super::shapes::{self, Axis, Family, Mode, RowCtx, Shape};
use crate::identify::params::{self, Free};
use nalgebra::{DMatrix, DVector};
use rand::{seq::SliceRandom, SeedableRng};
use rayon::prelude::*;

/// Smallest withheld gain that names an effect, beyond its null: a log-likelihood ratio of
/// e^2 (about 7), "positive evidence" on Kass and Raftery's scale. A candidate with a narrow
/// null (one column) can lie beyond it with a gain no user would notice.
pub const MIN_GAIN: f64 = 2.0;

/// Ridge on the baseline's free-parameter directions (unit-norm columns).
const JAC_RIDGE: f64 = 1e-2;

/// Predicted radii (r1, r2) at every row \[mm\].
pub type Preds = Vec<[f64; 2]>;

/// Settings.
#[derive(Debug, Clone, Copy)]
pub struct Settings {
    /// Folds.
    pub folds: usize,
    /// Significance of a candidate's gain.
    pub alpha: f64,
    /// Most effects accepted.
    pub max_effects: usize,
    /// Seed of the fold assignment and the simulations.
    pub seed: u64,
    /// Bootstrap replicates.
    pub boot: usize,
}

/// A model fitted on all rows and cross-validated.
#[derive(Debug, Clone)]
pub struct Evaluated {
    /// Effects (names, in order of addition).
    pub names: Vec<String>,
    /// Fit on all rows.
    pub full: FitResult,
    /// Predictions of the full fit at every row.
    pub pred: Vec<[f64; 2]>,
    /// Withheld predictions (each row by the fit that did not see its visit).
    pub cv: Vec<[f64; 2]>,
}

/// How a named effect enters the model.
#[derive(Debug, Clone, PartialEq)]
pub enum Form {
    /// Its library (parametric) form.
    Parametric,
    /// A learned shape along its axis.
    Learned(Shape),
}

/// The evaluation of one candidate in one round.
#[derive(Debug, Clone)]
pub struct CandidateEval {
    /// Name.
    pub name: String,
    /// Round (1 = on top of the baseline).
    pub round: usize,
    /// The model with it (for a named effect: in the form chosen).
    pub model: Evaluated,
    /// Withheld gain over the model of the round [row-noise units].
    pub gain: f64,
    /// The null distribution's (1 - alpha) quantile of the gain.
    pub penalty: f64,
    /// Bootstrap p-value of the gain.
    pub p: f64,
    /// The variant that gave the gain.
    pub variant: String,
    /// Reasons for doubt about the fitted parametric form (reported, not a veto).
    pub implausible: Vec<String>,
    /// Largest share of a significant region's residual it removes, and that region's index.
    pub signature: (f64, Option<usize>),
    /// With it, the gap tests find no significant gap left.
    pub closes_gap: bool,
    /// Gain beyond its null.
    pub passed: bool,
    /// Named.
    pub accepted: bool,
    /// Candidates whose gain comes within 80 % of this one's (close alternatives).
    pub ambiguous_with: Vec<String>,
    /// The form it enters the model in (named effects; the library form otherwise).
    pub form: Form,
    /// Gains of the library form and of the learned shape when the form was chosen.
    pub form_gains: Option<(f64, f64)>,
    /// Predictions at every row of the baseline with the library form, and with the learned
    /// shape (named effects): what each adds to the baseline, for the report's figure.
    pub curves: Option<(Preds, Preds)>,
}

/// Everything attribution produced.
#[derive(Debug, Clone)]
pub struct Attribution {
    /// The baseline, evaluated the same way.
    pub baseline: Evaluated,
    /// The final model (baseline plus accepted effects).
    pub augmented: Evaluated,
    /// Accepted effects, most important first.
    pub accepted: Vec<String>,
    /// Latest evaluation of every candidate.
    pub evals: Vec<CandidateEval>,
    /// Pairs that came close (reported; the larger gain is named).
    pub ambiguous: Vec<(String, String)>,
    /// Fold of each visit.
    pub fold_of_visit: Vec<usize>,
    /// The gap tests after each accepted effect.
    pub rounds: Vec<detect::Detection>,
    /// The local anomaly beat every effect in the last round: the gap left is unexplained.
    pub anomaly_won: bool,
    /// The local anomaly's score in the last round: (gain, null quantile, p-value).
    pub anomaly: Option<(f64, f64, f64)>,
}

/// Fold of each visit: shuffled, then dealt round-robin.
pub fn folds(nv: usize, k: usize, seed: u64) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..nv).collect();
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ 0xF01D);
    idx.shuffle(&mut rng);
    let mut f = vec![0; nv];
    for (r, &v) in idx.iter().enumerate() {
        f[v] = r % k.max(1);
    }
    f
}

/// The linear world of one log: the linearisation point, the model's Jacobian, the noise.
pub struct Linear<'a> {
    /// Data.
    pub ds: &'a Dataset,
    /// Context.
    pub ctx: &'a Ctx,
    /// The baseline (the linearisation point).
    pub base: &'a Augmented,
    /// Its predictions.
    pub p0: Vec<[f64; 2]>,
    /// Its steady map at the points.
    pub map0: Vec<[f64; 2]>,
    /// Weighted residual of the baseline (stacked).
    pub y: DVector<f64>,
    /// The baseline's design (free parameters' Jacobian, weighted).
    pub jac: Design,
    /// Row context.
    pub rc: RowCtx,
    /// Noise.
    pub noise: Noise,
    /// Fold of each stacked row.
    pub fold_of_stacked: Vec<usize>,
    /// Folds.
    pub k: usize,
    /// Free parameters of the baseline.
    pub free: &'a [Free],
}

impl<'a> Linear<'a> {
    /// Set up from the baseline and its free parameters.
    pub fn new(
        ds: &'a Dataset,
        ctx: &'a Ctx,
        base: &'a Augmented,
        free: &'a [Free],
        noise: Noise,
        fold_of_visit: &[usize],
        k: usize,
    ) -> Linear<'a> {
        let p0 = candidates::predict(base, ds);
        let map0 = candidates::point_map(base, ds);
        let sd = noise.row();
        let w = [1.0 / sd[0].max(1e-6), 1.0 / sd[1].max(1e-6)];
        let n = ds.rows.len();
        let y = DVector::from_fn(2 * n, |s, _| {
            let (i, a) = (s / 2, s % 2);
            let v = w[a] * (ds.rows[i].r[a] - p0[i][a]);
            if v.is_finite() {
                v
            } else {
                0.0
            }
        });
        // Jacobian of the predictions in the free parameters, each column scaled to unit norm
        // (only the span matters).
        let mut a = DMatrix::zeros(2 * n, free.len());
        for (c, f) in free.iter().enumerate() {
            let th = params::get(&base.model, f.name());
            let h = 1e-4 * th.abs().max(1e-3);
            let mut b = base.clone();
            params::set(&mut b.model, f.name(), th + h);
            let p = candidates::predict(&b, ds);
            for i in 0..n {
                for ax in 0..2 {
                    let d = w[ax] * (p[i][ax] - p0[i][ax]) / h;
                    a[(2 * i + ax, c)] = if d.is_finite() { d } else { 0.0 };
                }
            }
            let nrm = a.column(c).norm();
            if nrm > 0.0 {
                a.column_mut(c).scale_mut(1.0 / nrm);
            }
        }
        // A small ridge on the unit-norm columns: a fold's refit must not run along the nearly
        // unidentified combinations of the steady parameters (exponents against gains), where
        // the linearisation means nothing; well-determined directions are barely shrunk.
        // The baseline's own transient after each change (its ODE (4) replay less its map)
        // may be off in size and in time scale on another rig: identify fitted those time
        // scales, so their directions belong to the baseline too (per axis: the transient
        // scaled, and stretched in time, `since d/dsince`). A formation effect must beat what
        // refitting the baseline's dynamics would do.
        // And a first-order approach of any size at time constants around the baseline's own
        // (half and equal): another rig's fast formation may follow another law than ODE
        // (4) without being a formation effect.
        let tau_b = {
            let mut t: Vec<f64> = ds
                .rows
                .iter()
                .flat_map(|r| r.frac.iter().map(move |&f| (f, r.since)))
                .filter(|(f, s)| f.is_finite() && *f > 0.05 && *f < 0.95 && *s > 0.0)
                .map(|(f, s)| -s / f.ln())
                .collect();
            t.sort_by(|a, b| a.total_cmp(b));
            t.get(t.len() / 2).copied().unwrap_or(2.0).clamp(0.3, 5.0)
        };
        let step = |i: usize| -> [f64; 2] {
            match ds.visits[ds.rows[i].visit].prev {
                Some(pv) => {
                    let (a, b) = (map0[ds.rows[i].point], map0[ds.visits[pv].point]);
                    [a[0] - b[0], a[1] - b[1]]
                }
                None => [0.0; 2],
            }
        };
        let mut extra = DMatrix::zeros(2 * n, 10);
        for i in 0..n {
            let st = step(i);
            for (k, c) in [0.5].into_iter().enumerate() {
                let e = (-ds.rows[i].since / (c * tau_b)).exp();
                for ax in 0..2 {
                    extra[(2 * i + ax, 4 + 2 * k + ax)] = w[ax] * st[ax] * e;
                }
            }
        }
        for v in &ds.visits {
            let rows = &v.rows;
            for (k, &i) in rows.iter().enumerate() {
                let (lo, hi) = (rows[k.saturating_sub(1)], rows[(k + 1).min(rows.len() - 1)]);
                let dt = ds.rows[hi].since - ds.rows[lo].since;
                for ax in 0..2 {
                    let tr = ds.rows[i].trans[ax];
                    extra[(2 * i + ax, ax)] = w[ax] * tr;
                    if dt > 0.0 {
                        let d = (ds.rows[hi].trans[ax] - ds.rows[lo].trans[ax]) / dt;
                        extra[(2 * i + ax, 2 + ax)] = w[ax] * ds.rows[i].since * d;
                    }
                }
            }
        }
        let mut keep: Vec<usize> = Vec::new();
        for c in 0..10 {
            let nrm = extra.column(c).norm();
            if nrm > 1e-9 && nrm.is_finite() {
                extra.column_mut(c).scale_mut(1.0 / nrm);
                keep.push(c);
            }
        }
        let extra = extra.select_columns(&keep);
        let p = free.len() + extra.ncols();
        let mut full = DMatrix::zeros(2 * n, p);
        full.columns_mut(0, free.len()).copy_from(&a);
        full.columns_mut(free.len(), extra.ncols())
            .copy_from(&extra);
        let jac = Design {
            a: full,
            pen: DMatrix::identity(p, p) * JAC_RIDGE,
        };
        let ln_b = ds
            .rows
            .iter()
            .map(|r| {
                (candidates::field_b(&base.model, r.z) / ctx.b_mid)
                    .max(1e-300)
                    .ln()
            })
            .collect();
        // Sensitivity of the steady map to the drive frequency (central differences).
        let dmap_df: Vec<[f64; 2]> = {
            let m = base.synced();
            ds.points
                .iter()
                .map(|&(z, f)| {
                    let h = 0.02 * f.abs().max(0.5);
                    let (a, b) = (
                        candidates::map_at(&m, z, f + h),
                        candidates::map_at(&m, z, f - h),
                    );
                    let d = |i: usize| {
                        let v = (a[i] - b[i]) / (2.0 * h);
                        if v.is_finite() {
                            v
                        } else {
                            0.0
                        }
                    };
                    [d(0), d(1)]
                })
                .collect()
        };
        let rc = RowCtx::new(ds, &p0, &map0, &dmap_df, ln_b, w);
        let fold_of_stacked = (0..2 * n)
            .map(|s| fold_of_visit[ds.rows[s / 2].visit])
            .collect();
        Linear {
            ds,
            ctx,
            base,
            p0,
            map0,
            y,
            jac,
            rc,
            noise,
            fold_of_stacked,
            k,
            free,
        }
    }

    /// Row predictions [mm] from weighted fitted values of the residual.
    fn pred_of(&self, fitted: &DVector<f64>) -> Vec<[f64; 2]> {
        (0..self.ds.rows.len())
            .map(|i| {
                [
                    self.p0[i][0] + fitted[2 * i] / self.rc.w[0],
                    self.p0[i][1] + fitted[2 * i + 1] / self.rc.w[1],
                ]
            })
            .collect()
    }

    /// In-sample and withheld predictions of a design.
    fn evaluate(&self, d: &Design) -> Option<(Preds, Preds)> {
        let s = Solver::new(d, &self.fold_of_stacked, self.k)?;
        let fit = &self.y - s.residual(&self.y);
        let cv = &self.y - s.cv_residual(&self.y);
        Some((self.pred_of(&fit), self.pred_of(&cv)))
    }
}

/// One variant of a candidate: its columns (and penalty), or a box found per log.
#[derive(Debug, Clone)]
enum Variant {
    Shape(Family),
    Column(&'static str, DMatrix<f64>),
    Columns(&'static str, DMatrix<f64>, DMatrix<f64>),
    Anomaly,
}

/// The candidates and their variants.
fn variants(lin: &Linear) -> Vec<(&'static str, Vec<Variant>)> {
    let ds = lin.ds;
    let (zs, fs) = ds.levels();
    let rc = &lin.rc;
    let smooths = [0.01, 0.1, 1.0];
    let mut out: Vec<(&'static str, Vec<Variant>)> = Vec::new();
    // Effects on the steady map act in mm or in proportion to the radius (a change of Phi
    // (6) or of the stiffness scales the radii): both modes are variants. A step-out is above
    // all a deficit of the swarm's rotation rate, acting through the map's own sensitivity to
    // the drive (one deficit for both radii).
    let mut v = Vec::new();
    // Every variant widens the candidate's null: the phase lag's many forms are searched at
    // two smoothings only.
    for nu in [0.0, 1.0] {
        let xs = rc.xs(Axis::F { nu });
        for (mode, amp) in [
            (Mode::Rate, 0.0),
            (Mode::Add, 0.0),
            (Mode::Relative, 0.0),
            (Mode::Add, 1.0),
        ] {
            for s in [0.1, 1.0] {
                v.push(Variant::Shape(Family {
                    axis: Axis::F { nu },
                    mode,
                    knots: shapes::knots_of(&xs, fs.len().clamp(2, 10)),
                    pin_last: false,
                    amp,
                    smooth: s,
                }));
            }
        }
    }
    out.push(("phase_lag", v));
    let mut v = Vec::new();
    for mode in [Mode::Add, Mode::Relative] {
        for s in smooths {
            v.push(Variant::Shape(Family {
                axis: Axis::Z,
                mode,
                knots: shapes::knots_of(&zs, 8),
                pin_last: false,
                amp: 0.0,
                smooth: s,
            }));
        }
    }
    out.push(("cohesion_loss", v));
    if let Some(f) = detect::since_family(rc, 0.1) {
        out.push((
            "formation_lag",
            smooths
                .iter()
                .map(|&s| {
                    Variant::Shape(Family {
                        smooth: s,
                        ..f.clone()
                    })
                })
                .collect(),
        ));
    }
    out.push((
        "particle_drift",
        smooths
            .iter()
            .map(|&s| {
                Variant::Shape(Family {
                    axis: Axis::T,
                    mode: Mode::Relative,
                    knots: shapes::knots_of(&rc.t, 8),
                    pin_last: false,
                    amp: 0.0,
                    smooth: s,
                })
            })
            .collect(),
    ));
    // Centroid offset: the correction its library form makes at a few distances (amplitude
    // free), each a column.
    let mut cv = Vec::new();
    for o in [3.0, 8.0, 16.0] {
        let mut a = lin.base.clone();
        a.effects.push(("centroid_offset".into(), vec![o]));
        let p = candidates::predict(&a, ds);
        let col = DMatrix::from_fn(2 * ds.rows.len(), 1, |s, _| {
            let (i, ax) = (s / 2, s % 2);
            let d = rc.w[ax] * (p[i][ax] - lin.p0[i][ax]);
            if d.is_finite() {
                d
            } else {
                0.0
            }
        });
        if col.norm() > 1e-9 {
            // The same correction with an amplitude that may vary over z_m (an axis that is
            // not parallel to the field's: the swarm further off it at some depths than at
            // others), in the library form's own ratio of r1 to r2.
            let kz = shapes::knots_of(&rc.z, 6);
            if kz.len() >= 2 {
                let k = kz.len();
                let mut a = DMatrix::zeros(2 * ds.rows.len(), k);
                for i in 0..ds.rows.len() {
                    for (j, wt) in shapes::hat(&kz, rc.z[i]) {
                        for ax in 0..2 {
                            a[(2 * i + ax, j)] = wt * col[(2 * i + ax, 0)];
                        }
                    }
                }
                let info = (0..k).map(|c| a.column(c).norm_squared()).sum::<f64>() / k as f64;
                let info = info.max(1e-12);
                let pen = crate::diagnose::linear::roughness(k, 1, 0.3 * info, 1e-3 * info);
                cv.push(Variant::Columns("offset, amplitude over z_m", a, pen));
            }
            cv.push(Variant::Column("offset", col));
        }
    }
    if !cv.is_empty() {
        out.push(("centroid_offset", cv));
    }
    out.push((
        "camera_bias",
        vec![Variant::Column(
            "offset",
            DMatrix::from_fn(2 * ds.rows.len(), 1, |s, _| rc.w[s % 2]),
        )],
    ));
    out.push(("local_anomaly", vec![Variant::Anomaly]));
    out.retain(|(_, v)| {
        v.iter()
            .all(|x| !matches!(x, Variant::Shape(f) if f.knots.len() < 2))
    });
    out
}

/// Columns and penalty of a fixed variant.
fn columns_of(v: &Variant, rc: &RowCtx) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    match v {
        Variant::Shape(f) => Some(shapes::columns(f, rc)),
        Variant::Column(_, c) => Some((c.clone(), DMatrix::identity(c.ncols(), c.ncols()) * 1e-8)),
        Variant::Columns(_, c, p) => Some((c.clone(), p.clone())),
        Variant::Anomaly => None,
    }
}

/// The indicator columns (one per axis) of the strongest small box of the in-sample
/// residual `e0` (weighted, stacked).
fn anomaly_columns(lin: &Linear, e0: &DVector<f64>) -> (DMatrix<f64>, DMatrix<f64>) {
    let ds = lin.ds;
    let r0 = detect::unweight(e0, lin.rc.w);
    let sd = noise::estimate(ds, &r0)
        .map(|n| n.visit)
        .unwrap_or(lin.noise.visit);
    let (_, _, zr, fr) = detect::box_scan(ds, &r0, sd, true);
    let (cell, _, _) = noise::cells(ds);
    let n = ds.rows.len();
    let mut a = DMatrix::zeros(2 * n, 2);
    for (i, r) in ds.rows.iter().enumerate() {
        let (zi, fi) = cell[r.visit];
        if zi >= zr.0 && zi <= zr.1 && fi >= fr.0 && fi <= fr.1 {
            for ax in 0..2 {
                a[(2 * i + ax, ax)] = lin.rc.w[ax];
            }
        }
    }
    (a, DMatrix::identity(2, 2) * 1e-8)
}

/// Withheld gain (halved drop of the withheld SSE, per axis studentised by `rho`) of `cand`
/// over `cur` on the weighted residual `y`.
fn gain(cur: &Solver, cand: &Solver, y: &DVector<f64>, rho: [f64; 2]) -> f64 {
    let s0 = linear::sse_axes(&cur.cv_residual(y));
    let s1 = linear::sse_axes(&cand.cv_residual(y));
    0.5 * ((s0[0] - s1[0]) / rho[0] + (s0[1] - s1[1]) / rho[1])
}

/// Quantile of a sample.
fn quantile(x: &[f64], q: f64) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    let mut v = x.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// One candidate's result in a round.
struct Scored {
    name: &'static str,
    gain: f64,
    null: Vec<f64>,
    p: f64,
    best: Option<Variant>,
    variant: String,
}

fn describe(v: &Variant) -> String {
    match v {
        Variant::Shape(f) => format!(
            "learned shape over {} ({} knots, smoothing {})",
            f.axis.label(),
            f.knots.len(),
            f.smooth
        ),
        Variant::Column(n, _) => format!("library form's {n} (amplitude free)"),
        Variant::Columns(n, ..) => format!("library form's {n}"),
        Variant::Anomaly => "strongest small box of operating points".into(),
    }
}

/// Score every candidate on top of design `cur` by its withheld gain and its bootstrap null.
fn score_round(
    lin: &Linear,
    cur: &Design,
    cands: &[(&'static str, Vec<Variant>)],
    st: &Settings,
    round: usize,
) -> Option<Vec<Scored>> {
    let ds = lin.ds;
    let cur_s = Solver::new(cur, &lin.fold_of_stacked, lin.k)?;
    let one = vec![0usize; lin.y.len()];
    let cur_in = Solver::new(cur, &one, 1)?;
    // Fixed variants factor once.
    let fixed: Vec<Vec<Option<Solver>>> = cands
        .iter()
        .map(|(_, vs)| {
            vs.iter()
                .map(|v| {
                    columns_of(v, &lin.rc).and_then(|(c, p)| {
                        Solver::new(&cur.extend(&c, &p), &lin.fold_of_stacked, lin.k)
                    })
                })
                .collect()
        })
        .collect();
    // Gains of every candidate (best variant) on one weighted residual.
    let gains_of = |y: &DVector<f64>, real_sd: Option<[f64; 2]>| -> Option<Vec<(f64, usize)>> {
        let e0 = cur_in.residual(y);
        let r0 = detect::unweight(&e0, lin.rc.w);
        let sd = noise::estimate(ds, &r0).ok()?.visit;
        let rho = match real_sd {
            Some(r) => [(sd[0] / r[0]).powi(2), (sd[1] / r[1]).powi(2)],
            None => [1.0, 1.0],
        };
        let mut out = Vec::with_capacity(cands.len());
        for (ci, (_, vs)) in cands.iter().enumerate() {
            let mut best = (f64::NEG_INFINITY, 0);
            for (vi, v) in vs.iter().enumerate() {
                let g = match v {
                    Variant::Anomaly => {
                        let (c, p) = anomaly_columns(lin, &e0);
                        match Solver::new(&cur.extend(&c, &p), &lin.fold_of_stacked, lin.k) {
                            Some(s) => gain(&cur_s, &s, y, rho),
                            None => f64::NEG_INFINITY,
                        }
                    }
                    _ => match &fixed[ci][vi] {
                        Some(s) => gain(&cur_s, s, y, rho),
                        None => f64::NEG_INFINITY,
                    },
                };
                if g > best.0 {
                    best = (g, vi);
                }
            }
            out.push(best);
        }
        Some(out)
    };
    let real_sd = noise::estimate(ds, &detect::unweight(&cur_in.residual(&lin.y), lin.rc.w))
        .ok()?
        .visit;
    let obs = gains_of(&lin.y, None)?;
    let seed = st.seed ^ (round as u64).wrapping_mul(0xA77_0001);
    let null: Vec<Vec<(f64, usize)>> = (0..st.boot)
        .into_par_iter()
        .filter_map(|b| {
            let y = noise::simulate(ds, &lin.noise, lin.rc.w, seed, b);
            gains_of(&y, Some(real_sd))
        })
        .collect();
    let one_fold_e0 = cur_in.residual(&lin.y);
    Some(
        cands
            .iter()
            .enumerate()
            .map(|(ci, (name, vs))| {
                let nl: Vec<f64> = null.iter().map(|v| v[ci].0).collect();
                let (g, vi) = obs[ci];
                let best = match &vs[vi] {
                    Variant::Anomaly => {
                        let (c, _) = anomaly_columns(lin, &one_fold_e0);
                        Some(Variant::Column("box", c))
                    }
                    v => Some(v.clone()),
                };
                Scored {
                    name,
                    gain: g,
                    p: noise::boot_p(g, &nl),
                    null: nl,
                    variant: describe(&vs[vi]),
                    best,
                }
            })
            .collect(),
    )
}

/// The detection setting on design `d`.
fn setting<'b>(lin: &'b Linear, d: &'b Design, st: &Settings) -> Setting<'b> {
    Setting {
        ds: lin.ds,
        rc: &lin.rc,
        y: &lin.y,
        base: d,
        noise: &lin.noise,
        boot: st.boot,
        seed: st.seed ^ 0xD7EC,
    }
}

/// A model from the linear fit of design `d` (the baseline's free parameters moved by their
/// coefficients) and the learned shapes of the named effects.
fn linear_model(lin: &Linear, d: &Design, learned: &[(String, Family)]) -> Option<Augmented> {
    let g = d.a.tr_mul(&d.a) + &d.pen;
    let c = nalgebra::Cholesky::new(g)?;
    let beta = c.solve(&d.a.tr_mul(&lin.y));
    let inv = c.inverse();
    let mut aug = lin.base.clone();
    // Free parameters: columns were scaled to unit norm; recover the step per column.
    let n = lin.ds.rows.len();
    for (col, f) in lin.free.iter().enumerate() {
        let th = params::get(&lin.base.model, f.name());
        let h = 1e-4 * th.abs().max(1e-3);
        let mut b = lin.base.clone();
        params::set(&mut b.model, f.name(), th + h);
        let p = candidates::predict(&b, lin.ds);
        let mut nrm = 0.0;
        for i in 0..n {
            for ax in 0..2 {
                let dd = lin.rc.w[ax] * (p[i][ax] - lin.p0[i][ax]) / h;
                if dd.is_finite() {
                    nrm += dd * dd;
                }
            }
        }
        let nrm = nrm.sqrt();
        if nrm > 0.0 {
            let v = (th + beta[col] / nrm).clamp(f.lo, f.hi);
            params::set(&mut aug.model, f.name(), v);
        }
    }
    let mut at = lin.jac.cols();
    for (name, fam) in learned {
        let (cols, _) = shapes::columns(fam, &lin.rc);
        let q = cols.ncols();
        let coef: Vec<f64> = (0..q).map(|j| beta[at + j]).collect();
        let sd: Vec<f64> = (0..q)
            .map(|j| inv[(at + j, at + j)].max(0.0).sqrt())
            .collect();
        aug.learned
            .push((name.clone(), shapes::shape_of(fam, &coef, &sd)));
        at += q;
    }
    Some(aug)
}

fn residuals(ds: &Dataset, pred: &[[f64; 2]]) -> Vec<[f64; 2]> {
    ds.rows
        .iter()
        .zip(pred)
        .map(|(r, p)| [r.r[0] - p[0], r.r[1] - p[1]])
        .collect()
}

/// Run the attribution.
#[allow(clippy::too_many_arguments)]
pub fn attribute(
    lin: &Linear,
    fold_of_visit: &[usize],
    regions: &[Region],
    base_map: &[[f64; 2]],
    st: Settings,
    progress: &indicatif::ProgressBar,
) -> Attribution {
    let (ds, ctx) = (lin.ds, lin.ctx);
    let eval_of = |d: &Design, names: Vec<String>, aug: Augmented| -> Evaluated {
        let (pred, cv) = lin
            .evaluate(d)
            .unwrap_or_else(|| (lin.p0.clone(), lin.p0.clone()));
        Evaluated {
            names,
            full: FitResult {
                aug,
                cost: 0.0,
                at_bound: Vec::new(),
            },
            pred,
            cv,
        }
    };
    let base_aug = linear_model(lin, &lin.jac, &[]).unwrap_or_else(|| lin.base.clone());
    let base = eval_of(&lin.jac, Vec::new(), base_aug);
    progress.inc(1);
    let mut out = Attribution {
        baseline: base.clone(),
        augmented: base.clone(),
        accepted: Vec::new(),
        evals: Vec::new(),
        ambiguous: Vec::new(),
        fold_of_visit: fold_of_visit.to_vec(),
        rounds: Vec::new(),
        anomaly_won: false,
        anomaly: None,
    };
    if regions.is_empty() {
        return out;
    }
    let cands = variants(lin);
    let mut cur = lin.jac.clone();
    // Named effects: (name, the variants that entered the design).
    let mut named: Vec<(String, Vec<Variant>)> = Vec::new();
    let mut rounds_run = 0;
    // Rounds that only refine a named effect do not count toward `max_effects`, but at most
    // two of them run.
    while out.accepted.len() < st.max_effects && rounds_run < st.max_effects + 2 {
        rounds_run += 1;
        let round = rounds_run;
        if round > 1 {
            let det = detect::detect(&setting(lin, &cur, &st), st.alpha);
            let go = det.as_ref().map(|d| d.significant).unwrap_or(false);
            if let Some(d) = det {
                out.rounds.push(d);
            }
            if !go {
                break;
            }
        }
        // Effects not named yet, and the named ones again: what a named effect's shape leaves
        // of its own structure is more of the same effect (a refinement), not a new one.
        let todo: Vec<(&'static str, Vec<Variant>)> = cands.clone();
        let Some(scored) = score_round(lin, &cur, &todo, &st, round) else {
            break;
        };
        progress.inc(1);
        let is_named = |n: &str| named.iter().any(|(a, _)| a == n);
        let mut order: Vec<usize> = (0..scored.len())
            .filter(|&i| scored[i].p < st.alpha && scored[i].gain >= MIN_GAIN)
            .collect();
        // The candidate furthest beyond its own null: its gain less the null's (1 - alpha)
        // quantile. A flexible candidate's null is wider, and the local anomaly's includes its
        // search over boxes: the excess is a calibrated penalty for flexibility.
        let excess = |s: &Scored| s.gain - quantile(&s.null, 1.0 - st.alpha);
        order.sort_by(|&a, &b| excess(&scored[b]).total_cmp(&excess(&scored[a])));
        // Candidates within 5 % of the top excess are tied: the one least likely under its own
        // null (smallest bootstrap p) goes first (a constrained form that fits as well as a
        // flexible one is the more specific description).
        if let Some(&top) = order.first() {
            let tied = order
                .iter()
                .take_while(|&&i| excess(&scored[i]) >= 0.95 * excess(&scored[top]))
                .count();
            order[..tied].sort_by(|&a, &b| scored[a].p.total_cmp(&scored[b].p));
        }
        let mut best = order.first().copied();
        // A local anomaly ahead of every effect: an effect that passed still names the gap if
        // its excess comes within 60 % of the anomaly's, or if it keeps a gain beyond its null
        // on top of the anomaly's box (the effect is there, the box took its strongest part);
        // otherwise the gap is a local one no effect describes.
        if let Some(b) = best.filter(|&b| scored[b].name == "local_anomaly") {
            let boxed = scored[b]
                .best
                .as_ref()
                .and_then(|v| columns_of(v, &lin.rc))
                .map(|(c, p)| cur.extend(&c, &p));
            let rescued = order.iter().copied().skip(1).find(|&e| {
                let (Some(d), Some((c, p))) = (
                    boxed.as_ref(),
                    scored[e].best.as_ref().and_then(|v| columns_of(v, &lin.rc)),
                ) else {
                    return false;
                };
                let (Some(s0), Some(s1)) = (
                    Solver::new(d, &lin.fold_of_stacked, lin.k),
                    Solver::new(&d.extend(&c, &p), &lin.fold_of_stacked, lin.k),
                ) else {
                    return false;
                };
                let g = gain(&s0, &s1, &lin.y, [1.0, 1.0]);
                g >= MIN_GAIN.max(quantile(&scored[e].null, 1.0 - st.alpha))
            });
            // A near tie goes to the effect: a physical description that explains the box
            // nearly as well is the better report (the leftover, if any, is tested next).
            let close = order.iter().copied().skip(1).find(|&e| {
                scored[e].name != "local_anomaly" && excess(&scored[e]) >= 0.6 * excess(&scored[b])
            });
            if let Some(e) = close.or(rescued) {
                best = Some(e);
            }
        }
        let winner = best.map(|b| scored[b].name);
        let new_name = winner.filter(|w| *w != "local_anomaly" && !is_named(w));
        for (i, s) in scored.iter().enumerate() {
            if s.name == "local_anomaly" {
                out.anomaly = Some((s.gain, quantile(&s.null, 1.0 - st.alpha), s.p));
            }
            if s.name == "local_anomaly" || is_named(s.name) {
                continue;
            }
            let accepted = Some(i) == best && new_name.is_some();
            let close: Vec<String> = match best {
                Some(b) if i == b => order
                    .iter()
                    .skip(1)
                    .filter(|&&j| {
                        scored[j].name != "local_anomaly"
                            && !is_named(scored[j].name)
                            && excess(&scored[j]) >= 0.8 * excess(&scored[b])
                    })
                    .map(|&j| scored[j].name.to_string())
                    .collect(),
                _ => Vec::new(),
            };
            let e = CandidateEval {
                name: s.name.to_string(),
                round,
                model: base.clone(),
                gain: s.gain,
                penalty: quantile(&s.null, 1.0 - st.alpha),
                p: s.p,
                variant: s.variant.clone(),
                implausible: Vec::new(),
                signature: (0.0, None),
                closes_gap: false,
                passed: s.p < st.alpha && s.gain >= MIN_GAIN,
                accepted,
                ambiguous_with: close,
                form: Form::Parametric,
                form_gains: None,
                curves: None,
            };
            if let Some(old) = out.evals.iter_mut().find(|x| x.name == e.name) {
                if !old.accepted {
                    *old = e;
                }
            } else {
                out.evals.push(e);
            }
        }
        let Some(b) = best else { break };
        if scored[b].name == "local_anomaly" {
            out.anomaly_won = true;
            break;
        }
        let v = scored[b].best.clone().expect("a variant");
        if let Some((c, p)) = columns_of(&v, &lin.rc) {
            cur = cur.extend(&c, &p);
        }
        if let Some(n) = named.iter_mut().find(|(a, _)| a == scored[b].name) {
            // A refinement: the named effect's shape gains a term.
            n.1.push(v);
            continue;
        }
        for a in out
            .evals
            .iter()
            .find(|e| e.name == scored[b].name)
            .map(|e| e.ambiguous_with.clone())
            .unwrap_or_default()
        {
            out.ambiguous.push((scored[b].name.to_string(), a));
        }
        named.push((scored[b].name.to_string(), vec![v]));
        out.accepted.push(scored[b].name.to_string());
    }
    if named.is_empty() {
        return out;
    }
    // The form of each named effect, and the final model.
    let (aug, design) = choose_forms(lin, &named, &mut out, st, progress);
    // Detection on what the final model leaves (the closing round).
    if out.rounds.len() < named.len() {
        if let Some(d) = detect::detect(&setting(lin, &design, &st), st.alpha) {
            out.rounds.push(d);
        }
    }
    let left_significant = out.rounds.last().map(|d| d.significant).unwrap_or(false);
    let names = out.accepted.clone();
    let mut ev = eval_of(&design, names, aug.clone());
    // In-sample predictions through the model itself (what `predict` and the FMU replay).
    ev.pred = candidates::predict(&aug, ds);
    // With a library form in the model, its withheld predictions come from nonlinear refits
    // per fold (learned heights held), so that its location is never fitted on the visits it
    // predicts.
    if !aug.effects.is_empty() {
        ev.cv = library_cv(lin, &aug);
    }
    out.augmented = ev;
    // Reasons, for the table: the library form's plausibility, regions' residual removed.
    let res_base = residuals(ds, &base.pred);
    let res_aug = residuals(ds, &out.augmented.pred);
    for e in out.evals.iter_mut().filter(|e| e.accepted) {
        e.model = out.augmented.clone();
        e.closes_gap = !left_significant;
        e.implausible = candidates::implausible(&e.name, &aug, ctx);
        for (ri, r) in regions.iter().enumerate() {
            let before = gap::region_mean(ds, &res_base, base_map, r);
            let after = gap::region_mean(ds, &res_aug, base_map, r);
            if before.abs() > 1e-12 {
                let share = 1.0 - after.abs() / before.abs();
                if share > e.signature.0 {
                    e.signature = (share, Some(ri));
                }
            }
        }
    }
    out
}

/// For each named effect, its library form against its learned shape; the final model and
/// its design.
fn choose_forms(
    lin: &Linear,
    named: &[(String, Vec<Variant>)],
    out: &mut Attribution,
    st: Settings,
    progress: &indicatif::ProgressBar,
) -> (Augmented, Design) {
    let ds = lin.ds;
    let mut design = lin.jac.clone();
    let mut learned: Vec<(String, Family)> = Vec::new();
    let mut parametric: Vec<String> = Vec::new();
    // The last library fit (free parameters and library forms fitted together).
    let mut last_lib: Option<Augmented> = None;
    let one = vec![0usize; lin.y.len()];
    for (name, vs) in named {
        let before = Solver::new(&design, &lin.fold_of_stacked, lin.k);
        let mut shape_design = Some(design.clone());
        for v in vs {
            shape_design = match (shape_design, columns_of(v, &lin.rc)) {
                (Some(d), Some((c, p))) => Some(d.extend(&c, &p)),
                _ => None,
            };
        }
        let is_shape = vs.iter().all(|v| matches!(v, Variant::Shape(_)));
        let g_learned = match (&before, &shape_design) {
            (Some(b), Some(d)) => Solver::new(d, &lin.fold_of_stacked, lin.k)
                .map(|s| gain(b, &s, &lin.y, [1.0, 1.0]))
                .unwrap_or(f64::NEG_INFINITY),
            _ => f64::NEG_INFINITY,
        };
        // The library form: fitted by the nonlinear fitter on top of the baseline and the
        // library forms named before it, its correction then one column of the design.
        let lin_start = linear_model(lin, &lin.jac_only_learned(&learned), &learned)
            .unwrap_or_else(|| lin.base.clone());
        let mut start = match &last_lib {
            Some(l) => Augmented {
                learned: lin_start.learned.clone(),
                ..l.clone()
            },
            None => lin_start,
        };
        start
            .effects
            .push((name.clone(), candidates::neutral(name, lin.ctx)));
        let starts = candidates::starts(name, lin.ctx, ds);
        let all: Vec<usize> = (0..ds.rows.len()).collect();
        let fr = fitter::fit(
            &start,
            lin.free,
            ds,
            lin.ctx,
            &all,
            lin.noise.row(),
            &starts,
        );
        progress.inc(1);
        let p_fit = candidates::predict(&fr.aug, ds);
        let col = DMatrix::from_fn(2 * ds.rows.len(), 1, |s, _| {
            let (i, ax) = (s / 2, s % 2);
            let d = lin.rc.w[ax] * (p_fit[i][ax] - lin.p0[i][ax]);
            if d.is_finite() {
                d
            } else {
                0.0
            }
        });
        // The library form's correction less what the free parameters already span.
        let col = match Solver::new(&lin.jac, &one, 1) {
            Some(s) => {
                let r = s.residual(&DVector::from_column_slice(col.as_slice()));
                DMatrix::from_column_slice(r.len(), 1, r.as_slice())
            }
            None => col,
        };
        let param_design = design.extend(&col, &(DMatrix::identity(1, 1) * 1e-8));
        // The library form's withheld gain: each fold refitted by the nonlinear fitter (its
        // location and shape included, from the full fit), against the current design's
        // withheld residual. (A column from the full fit with a free amplitude would know
        // the withheld visits through the fitted location.)
        let g_param = match &before {
            Some(b) if col.norm() > 1e-9 => {
                let e0 = linear::sse_axes(&b.cv_residual(&lin.y));
                let cv = library_cv(lin, &fr.aug);
                let e1 = linear::sse_axes(&DVector::from_fn(lin.y.len(), |s, _| {
                    let (i, a) = (s / 2, s % 2);
                    let v = lin.rc.w[a] * (ds.rows[i].r[a] - cv[i][a]);
                    if v.is_finite() {
                        v
                    } else {
                        1e3
                    }
                }));
                0.5 * (e0[0] - e1[0] + e0[1] - e1[1])
            }
            _ => f64::NEG_INFINITY,
        };
        let use_learned = is_shape && g_learned.is_finite() && g_param < 0.9 * g_learned;
        let learned_pred = shape_design
            .as_ref()
            .filter(|_| is_shape)
            .and_then(|d| lin.evaluate(d))
            .map(|x| x.0);
        let mut e = out.evals.iter_mut().find(|e| &e.name == name);
        if let Some(e) = e.as_deref_mut() {
            e.curves = Some((p_fit.clone(), learned_pred.unwrap_or_default()));
        }
        // Given the effects named before it (in whichever form they took), an effect that no
        // longer gains what names an effect is dropped: it was explaining their leftovers.
        if g_param.max(g_learned) < MIN_GAIN {
            if let Some(e) = e {
                e.form_gains = Some((g_param, g_learned));
                e.accepted = false;
                e.implausible.push(format!(
                    "dropped: with the effects named before it, its withheld gain is {:.2} < {MIN_GAIN}",
                    g_param.max(g_learned)
                ));
            }
            out.accepted.retain(|a| a != name);
            continue;
        }
        if use_learned {
            for v in vs {
                if let Variant::Shape(f) = v {
                    learned.push((name.clone(), f.clone()));
                }
            }
            design = shape_design.expect("shape design");
            if let Some(e) = e {
                e.form_gains = Some((g_param, g_learned));
            }
        } else {
            parametric.push(name.clone());
            // The fit refitted the earlier library forms and the free parameters with it.
            last_lib = Some(fr.aug.clone());
            design = param_design;
            if let Some(e) = e {
                e.form_gains = Some((g_param, g_learned));
            }
        }
        let _ = st;
    }
    // The final model: learned heights and the free parameters from the linear fit; the
    // library forms refitted by the nonlinear fitter with the learned shapes held.
    let mut aug = linear_model(lin, &lin.jac_only_learned(&learned), &learned)
        .unwrap_or_else(|| lin.base.clone());
    if let Some(mut lib) = last_lib {
        // From the last library fit, which fitted the free parameters and every library form
        // together (a joint refit from neutral values would stay where the effects vanish),
        // with the learned shapes' heights from the linear fit.
        lib.learned = aug.learned.clone();
        let all: Vec<usize> = (0..ds.rows.len()).collect();
        aug = fitter::fit(&lib, lin.free, ds, lin.ctx, &all, lin.noise.row(), &[]).aug;
    }
    aug.sync_model();
    for (name, sh) in &aug.learned {
        if let Some(e) = out.evals.iter_mut().find(|e| &e.name == name) {
            e.form = Form::Learned(sh.clone());
        }
    }
    (aug, design)
}

/// Withheld predictions of a fitted augmented model: each fold refitted on the other folds'
/// rows by the nonlinear fitter, from the full fit.
fn library_cv(lin: &Linear, full: &Augmented) -> Vec<[f64; 2]> {
    let ds = lin.ds;
    let mut cv = vec![[0.0; 2]; ds.rows.len()];
    let fold_of_row: Vec<usize> = (0..ds.rows.len())
        .map(|i| lin.fold_of_stacked[2 * i])
        .collect();
    for f in 0..lin.k {
        let train: Vec<usize> = (0..ds.rows.len())
            .filter(|&i| fold_of_row[i] != f)
            .collect();
        if train.len() == ds.rows.len() {
            continue;
        }
        let fr = fitter::fit(full, lin.free, ds, lin.ctx, &train, lin.noise.row(), &[]);
        let p = candidates::predict(&fr.aug, ds);
        for i in 0..ds.rows.len() {
            if fold_of_row[i] == f {
                cv[i] = p[i];
            }
        }
    }
    cv
}

impl Linear<'_> {
    /// The Jacobian design with the learned shapes' columns (in order).
    fn jac_only_learned(&self, learned: &[(String, Family)]) -> Design {
        let mut d = self.jac.clone();
        for (_, f) in learned {
            let (c, p) = shapes::columns(f, &self.rc);
            d = d.extend(&c, &p);
        }
        d
    }
}
