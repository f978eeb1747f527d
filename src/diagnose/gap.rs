//! Is there a gap, and where: lack of fit against the pure error of the repeats, residual
//! structure over the inputs and over time, and the regions where it lies.
//!
//! Residuals are *measured minus model* [mm]. The unit of every test is the visit (rows of one
//! visit share a visit-to-visit error and are not independent):
//!
//! - **lack of fit** (reported; in the decision only when the pure error comes from repeat
//!   visits): F = (SS_lof / (m - p)) / (SS_pe / dof_pe) per axis, SS_lof from the point means,
//!   SS_pe from the repeats. With one visit per point the pure error of the rows within a visit
//!   cannot see the visit-to-visit error, and F would call that error a gap;
//! - **structure over (z_m, f)**: a leave-one-out kernel smoother of the visit residuals over
//!   the normalised inputs; statistic = share of the residual variance it predicts, best of two
//!   bandwidths; p-value by permutation of the residuals over the visits (no assumption on the
//!   noise level);
//! - **structure over session time** (drift): |correlation| of the visit residuals with
//!   session time and its square, by the same permutations;
//! - **structure over time since the input change** (formation): within each visit, the mean
//!   residual of its first half minus its second half, signed against the direction of the
//!   model's change from the previous visit (a lag makes the early rows stay behind); a
//!   t test over visits (the visit's own offset cancels).
//!
//! The gap is significant when the smallest of these family p-values, Bonferroni-corrected
//! for the number of families, is below alpha. Regions are then searched only within the
//! families that are significant: contiguous boxes of input levels (and of session time),
//! each tested by its mean visit residual against a robust visit-level SD, with
//! Benjamini-Hochberg control over all boxes; the strongest non-overlapping boxes are kept,
//! trimmed of edge slices that carry no residual, and reported with a p-value corrected for
//! the number of boxes searched.

use super::data::{Dataset, PureError};
use super::stats;
use rand::{seq::SliceRandom, SeedableRng};

/// Per-visit residual summary.
#[derive(Debug, Clone, PartialEq)]
pub struct VisitRes {
    /// Mean residual of the settled rows (all rows when none is settled) [mm].
    pub e: Vec<[f64; 2]>,
    /// Rows averaged.
    pub n: Vec<usize>,
}

/// Visit residuals from row residuals.
pub fn visit_residuals(ds: &Dataset, res: &[[f64; 2]]) -> VisitRes {
    let mut e = Vec::with_capacity(ds.visits.len());
    let mut n = Vec::with_capacity(ds.visits.len());
    for v in 0..ds.visits.len() {
        let mut rows = ds.settled_rows(v);
        if rows.is_empty() {
            rows = ds.visits[v].rows.clone();
        }
        let k = rows.len().max(1) as f64;
        let mut m = [0.0; 2];
        for &i in &rows {
            m[0] += res[i][0] / k;
            m[1] += res[i][1] / k;
        }
        e.push(m);
        n.push(rows.len());
    }
    VisitRes { e, n }
}

/// Lack-of-fit test of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lof {
    /// F statistic.
    pub f: f64,
    /// Degrees of freedom (lack of fit, pure error).
    pub dof: (f64, f64),
    /// p-value.
    pub p: f64,
}

/// The family tests.
#[derive(Debug, Clone, PartialEq)]
pub struct GapTests {
    /// Lack of fit per axis.
    pub lof: [Lof; 2],
    /// The pure error is from repeat visits (then the lack of fit is in the decision).
    pub lof_from_visits: bool,
    /// Structure over (z_m, f): p per axis.
    pub space_p: [f64; 2],
    /// Drift over session time: p per axis.
    pub drift_p: [f64; 2],
    /// Formation after input changes: p per axis (1 when untestable).
    pub trans_p: [f64; 2],
    /// Visits that entered the formation test.
    pub trans_visits: usize,
    /// Combined p-value (Bonferroni over families and axes).
    pub p_value: f64,
    /// Significant at alpha.
    pub significant: bool,
    /// Families significant at alpha after correction: "lack_of_fit", "inputs", "drift",
    /// "formation".
    pub families: Vec<&'static str>,
    /// Robust SD of a visit residual around the smooth structure, per axis [mm].
    pub visit_sd: [f64; 2],
}

/// Normalised (z, f) coordinates of the visits.
pub fn coords(ds: &Dataset) -> Vec<[f64; 2]> {
    let (zs, fs) = ds.levels();
    let span = |v: &[f64]| (v.last().unwrap_or(&1.0) - v.first().unwrap_or(&0.0)).max(1e-9);
    let (z0, zspan, f0, fspan) = (
        zs.first().copied().unwrap_or(0.0),
        span(&zs),
        fs.first().copied().unwrap_or(0.0),
        span(&fs),
    );
    ds.visits
        .iter()
        .map(|v| {
            let (z, f) = ds.points[v.point];
            [(z - z0) / zspan, (f - f0) / fspan]
        })
        .collect()
}

/// Leave-one-out Nadaraya-Watson predictions of `y` at each `x` (Gaussian kernel, bandwidth h).
pub fn loo_smooth(x: &[[f64; 2]], y: &[f64], h: f64) -> Vec<f64> {
    let n = x.len();
    let mut out = vec![0.0; n];
    for i in 0..n {
        let (mut sw, mut swy) = (0.0, 0.0);
        for j in 0..n {
            if j == i {
                continue;
            }
            let d2 = (x[i][0] - x[j][0]).powi(2) + (x[i][1] - x[j][1]).powi(2);
            let w = (-d2 / (2.0 * h * h)).exp();
            sw += w;
            swy += w * y[j];
        }
        out[i] = if sw > 1e-12 { swy / sw } else { 0.0 };
    }
    out
}

const BANDWIDTHS: [f64; 2] = [0.12, 0.25];

/// Leave-one-out kernel weights (row-normalised, zero diagonal) for each bandwidth.
fn loo_weights(x: &[[f64; 2]]) -> Vec<Vec<f64>> {
    let n = x.len();
    BANDWIDTHS
        .iter()
        .map(|&h| {
            let mut w = vec![0.0; n * n];
            for i in 0..n {
                let mut s = 0.0;
                for j in 0..n {
                    if j != i {
                        let d2 = (x[i][0] - x[j][0]).powi(2) + (x[i][1] - x[j][1]).powi(2);
                        w[i * n + j] = (-d2 / (2.0 * h * h)).exp();
                        s += w[i * n + j];
                    }
                }
                if s > 1e-12 {
                    for j in 0..n {
                        w[i * n + j] /= s;
                    }
                }
            }
            w
        })
        .collect()
}

fn space_stat(w: &[Vec<f64>], y: &[f64]) -> f64 {
    let n = y.len();
    let m = stats::mean(y);
    let tot: f64 = y.iter().map(|v| (v - m).powi(2)).sum::<f64>().max(1e-300);
    w.iter()
        .map(|wk| {
            let mut sse = 0.0;
            for i in 0..n {
                let s: f64 = (0..n).map(|j| wk[i * n + j] * (y[j] - m)).sum();
                sse += (y[i] - m - s).powi(2);
            }
            1.0 - sse / tot
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Permutation p-value: the empirical (1 + #{perm >= obs}) / (1 + B); where no permutation
/// reaches the observed value, the tail of a normal fitted to the permutation distribution
/// (never above the empirical bound), so that a strong structure is not capped at 1 / (1 + B).
fn perm_p(obs: f64, perm: &[f64]) -> f64 {
    let b = perm.len();
    let ge = perm.iter().filter(|&&v| v >= obs).count();
    let emp = (1 + ge) as f64 / (1 + b) as f64;
    if ge > 0 || b < 20 {
        return emp;
    }
    let m = stats::mean(perm);
    let sd = (perm.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (b - 1) as f64).sqrt();
    if sd <= 0.0 {
        return emp;
    }
    (stats::z_two_sided((obs - m) / sd) / 2.0).min(emp)
}

fn drift_stat(t: &[f64], y: &[f64]) -> f64 {
    let tm = stats::mean(t);
    let t2: Vec<f64> = t.iter().map(|v| (v - tm).powi(2)).collect();
    stats::corr(t, y).abs().max(stats::corr(&t2, y).abs())
}

/// Run the family tests. `n_free` is the number of free steady parameters of the baseline.
pub fn tests(
    ds: &Dataset,
    res: &[[f64; 2]],
    pe: &PureError,
    base_map: &[[f64; 2]],
    n_free: usize,
    alpha: f64,
    perms: usize,
    seed: u64,
) -> GapTests {
    let vr = visit_residuals(ds, res);
    let nv = ds.visits.len();
    let x = coords(ds);
    let wts = loo_weights(&x);
    let t: Vec<f64> = ds.visits.iter().map(|v| v.t_mid).collect();
    let lof_from_visits = pe.between_dof >= 5 && pe.repeat_points >= 3;
    let p_ax = n_free.div_ceil(2) as f64;
    let mut lof = [Lof {
        f: f64::NAN,
        dof: (0.0, 0.0),
        p: 1.0,
    }; 2];
    let mut space_p = [1.0; 2];
    let mut drift_p = [1.0; 2];
    let mut trans_p = [1.0; 2];
    let mut visit_sd = [0.0; 2];
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut trans_visits = 0;
    for a in 0..2 {
        // Lack of fit.
        let m = ds.points.len() as f64;
        let (mut ss_lof, mut ss_pe, mut dof_pe) = (0.0, 0.0, 0.0);
        if lof_from_visits {
            for p in 0..ds.points.len() {
                let es: Vec<f64> = (0..nv)
                    .filter(|&v| ds.visits[v].point == p)
                    .map(|v| vr.e[v][a])
                    .collect();
                if es.is_empty() {
                    continue;
                }
                let mu = stats::mean(&es);
                ss_lof += es.len() as f64 * mu * mu;
                ss_pe += es.iter().map(|e| (e - mu).powi(2)).sum::<f64>();
                dof_pe += (es.len() - 1) as f64;
            }
        } else {
            for p in 0..ds.points.len() {
                let es: Vec<f64> = (0..nv)
                    .filter(|&v| ds.visits[v].point == p)
                    .flat_map(|v| {
                        let mut r = ds.settled_rows(v);
                        if r.is_empty() {
                            r = ds.visits[v].rows.clone();
                        }
                        r
                    })
                    .map(|i| res[i][a])
                    .collect();
                if es.is_empty() {
                    continue;
                }
                let mu = stats::mean(&es);
                ss_lof += es.len() as f64 * mu * mu;
                ss_pe += es.iter().map(|e| (e - mu).powi(2)).sum::<f64>();
                dof_pe += (es.len() - 1) as f64;
            }
        }
        let d1 = (m - p_ax).max(1.0);
        if dof_pe > 0.0 && ss_pe > 0.0 {
            let f = (ss_lof / d1) / (ss_pe / dof_pe);
            lof[a] = Lof {
                f,
                dof: (d1, dof_pe),
                p: stats::f_sf(f, d1, dof_pe),
            };
        }

        // Structure over inputs and time, by permutation.
        let y: Vec<f64> = vr.e.iter().map(|e| e[a]).collect();
        let s_obs = space_stat(&wts, &y);
        let d_obs = drift_stat(&t, &y);
        let (mut ps, mut pd) = (Vec::with_capacity(perms), Vec::with_capacity(perms));
        let mut yp = y.clone();
        for _ in 0..perms {
            yp.shuffle(&mut rng);
            ps.push(space_stat(&wts, &yp));
            pd.push(drift_stat(&t, &yp));
        }
        space_p[a] = perm_p(s_obs, &ps);
        drift_p[a] = perm_p(d_obs, &pd);
        let sm = loo_smooth(&x, &y, BANDWIDTHS[1]);
        let dev: Vec<f64> = y.iter().zip(&sm).map(|(a, b)| a - b).collect();
        let floor = (pe.within_sd[a].powi(2) / 5.0 + pe.between_sd[a].powi(2)).sqrt();
        visit_sd[a] = stats::robust_sd(&dev).max(floor).max(1e-6);

        // Formation: signed early-minus-late contrast within visits.
        let s = formation_contrasts(ds, res, base_map, a);
        trans_visits = trans_visits.max(s.len());
        trans_p[a] = stats::one_sample_t(&s).2;
    }
    let mut fam: Vec<(&'static str, f64)> = vec![
        ("inputs", 2.0 * space_p[0].min(space_p[1])),
        ("drift", 2.0 * drift_p[0].min(drift_p[1])),
        ("formation", 2.0 * trans_p[0].min(trans_p[1])),
    ];
    if lof_from_visits {
        fam.push(("lack_of_fit", 2.0 * lof[0].p.min(lof[1].p)));
    }
    let k = fam.len() as f64;
    let p_value = fam
        .iter()
        .map(|f| (f.1 * k).min(1.0))
        .fold(1.0f64, f64::min);
    let families: Vec<&'static str> = fam
        .iter()
        .filter(|f| f.1 * k < alpha)
        .map(|f| f.0)
        .collect();
    GapTests {
        lof,
        lof_from_visits,
        space_p,
        drift_p,
        trans_p,
        trans_visits,
        p_value,
        significant: p_value < alpha,
        families,
        visit_sd,
    }
}

/// Per visit (with a previous visit and at least 4 rows): -(sign of the model's change from
/// the previous visit) x (mean residual of the first half of the rows - of the second half).
/// Positive: the measurement stays behind the model after a change.
pub fn formation_contrasts(
    ds: &Dataset,
    res: &[[f64; 2]],
    base_map: &[[f64; 2]],
    a: usize,
) -> Vec<f64> {
    let mut out = Vec::new();
    for v in &ds.visits {
        let Some(pv) = v.prev else { continue };
        if v.rows.len() < 4 {
            continue;
        }
        let d = base_map[v.point][a] - base_map[ds.visits[pv].point][a];
        if d.abs() < 1e-9 {
            continue;
        }
        let h = v.rows.len() / 2;
        let first: Vec<f64> = v.rows[..h].iter().map(|&i| res[i][a]).collect();
        let second: Vec<f64> = v.rows[h..].iter().map(|&i| res[i][a]).collect();
        out.push(-d.signum() * (stats::mean(&first) - stats::mean(&second)));
    }
    out
}

/// What kind of region.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A box of (z_m, f).
    Inputs,
    /// A range of session time.
    Drift,
    /// The start of visits (time since the input change).
    Formation,
    /// Structure over the inputs that no box isolates (a pattern over the whole range); judged
    /// by the RMS of its smoothed visit residuals.
    Pattern,
}

/// A region where the gap lies.
#[derive(Debug, Clone, PartialEq)]
pub struct Region {
    /// Kind.
    pub kind: Kind,
    /// Axis (0: r1, 1: r2).
    pub axis: usize,
    /// z_m range [mm].
    pub z: (f64, f64),
    /// f range [Hz].
    pub f: (f64, f64),
    /// Session-time range [s] (drift regions).
    pub t: Option<(f64, f64)>,
    /// Time since the input change [s] (formation regions).
    pub since: Option<(f64, f64)>,
    /// Mean residual (measured - model) [mm]; for formation regions the signed lag contrast.
    pub mean: f64,
    /// p-value corrected for the search.
    pub p: f64,
    /// Visits in the region.
    pub visits: Vec<usize>,
}

/// Up to `k` bins of sorted distinct values: (lo, hi) edges per bin.
fn bins(vals: &[f64], k: usize) -> Vec<(f64, f64)> {
    let mut v = vals.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    v.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    if v.is_empty() {
        return Vec::new();
    }
    if v.len() <= k {
        return v.iter().map(|&x| (x, x)).collect();
    }
    let n = v.len();
    (0..k)
        .map(|b| {
            let i0 = b * n / k;
            let i1 = ((b + 1) * n / k).max(i0 + 1) - 1;
            (v[i0], v[i1])
        })
        .collect()
}

fn in_bin(x: f64, b: (f64, f64)) -> bool {
    x >= b.0 - 1e-9 && x <= b.1 + 1e-9
}

/// Mean and p-value of the visit residuals `vs` on axis `a` against the visit SD.
fn box_test(vr: &VisitRes, vs: &[usize], a: usize, sd: f64) -> (f64, f64) {
    let e: Vec<f64> = vs.iter().map(|&v| vr.e[v][a]).collect();
    let m = stats::mean(&e);
    let z = m / (sd / (vs.len() as f64).sqrt());
    (m, stats::z_two_sided(z))
}

/// Search the regions of the significant families.
pub fn localise(
    ds: &Dataset,
    res: &[[f64; 2]],
    base_map: &[[f64; 2]],
    gt: &GapTests,
) -> Vec<Region> {
    let vr = visit_residuals(ds, res);
    let nv = ds.visits.len();
    let (zs, fs) = ds.levels();
    let zfull = (zs[0], zs[zs.len() - 1]);
    let ffull = (fs[0], fs[fs.len() - 1]);
    let mut out = Vec::new();
    if gt.families.contains(&"inputs") || gt.families.contains(&"lack_of_fit") {
        let zb = bins(&zs, 8);
        let fb = bins(&fs, 10);
        // (axis, zi0, zi1, fi0, fi1, mean, p, visits)
        type Cand = (usize, usize, usize, usize, usize, f64, f64, Vec<usize>);
        let mut cands: Vec<Cand> = Vec::new();
        let vis_in = |z0: usize, z1: usize, f0: usize, f1: usize| -> Vec<usize> {
            (0..nv)
                .filter(|&v| {
                    let (z, f) = ds.points[ds.visits[v].point];
                    (z0..=z1).any(|i| in_bin(z, zb[i])) && (f0..=f1).any(|j| in_bin(f, fb[j]))
                })
                .collect()
        };
        for a in 0..2 {
            for z0 in 0..zb.len() {
                for z1 in z0..zb.len() {
                    for f0 in 0..fb.len() {
                        for f1 in f0..fb.len() {
                            let vs = vis_in(z0, z1, f0, f1);
                            if vs.len() < 2 {
                                continue;
                            }
                            let (m, p) = box_test(&vr, &vs, a, gt.visit_sd[a]);
                            cands.push((a, z0, z1, f0, f1, m, p, vs));
                        }
                    }
                }
            }
        }
        let ps: Vec<f64> = cands.iter().map(|c| c.6).collect();
        let q = stats::bh_adjust(&ps);
        let ntests = cands.len() as f64;
        let mut order: Vec<usize> = (0..cands.len()).filter(|&i| q[i] < 0.05).collect();
        order.sort_by(|&i, &j| cands[i].6.total_cmp(&cands[j].6));
        let mut picked: Vec<(usize, usize, usize, usize, usize)> = Vec::new();
        for i in order {
            let c = &cands[i];
            let overlaps = picked
                .iter()
                .any(|p| p.0 == c.0 && p.1 <= c.2 && c.1 <= p.2 && p.3 <= c.4 && c.3 <= p.4);
            if overlaps || picked.iter().filter(|p| p.0 == c.0).count() >= 3 {
                continue;
            }
            // Trim edge slices without residual of the box's sign.
            let (a, mut z0, mut z1, mut f0, mut f1) = (c.0, c.1, c.2, c.3, c.4);
            let sign = c.5.signum();
            let weak = |vs: Vec<usize>| -> bool {
                if vs.is_empty() {
                    return true;
                }
                let (m, _) = box_test(&vr, &vs, a, gt.visit_sd[a]);
                let z = m / (gt.visit_sd[a] / (vs.len() as f64).sqrt());
                z * sign < 1.0
            };
            loop {
                let mut changed = false;
                if z1 > z0 && weak(vis_in(z0, z0, f0, f1)) {
                    z0 += 1;
                    changed = true;
                }
                if z1 > z0 && weak(vis_in(z1, z1, f0, f1)) {
                    z1 -= 1;
                    changed = true;
                }
                if f1 > f0 && weak(vis_in(z0, z1, f0, f0)) {
                    f0 += 1;
                    changed = true;
                }
                if f1 > f0 && weak(vis_in(z0, z1, f1, f1)) {
                    f1 -= 1;
                    changed = true;
                }
                if !changed {
                    break;
                }
            }
            let vs = vis_in(z0, z1, f0, f1);
            if vs.is_empty() {
                continue;
            }
            let (m, p) = box_test(&vr, &vs, a, gt.visit_sd[a]);
            picked.push((a, z0, z1, f0, f1));
            if p * ntests >= 0.05 {
                // Trimmed to a box that no longer stands out after the search correction.
                continue;
            }
            out.push(Region {
                kind: Kind::Inputs,
                axis: a,
                z: (zb[z0].0, zb[z1].1),
                f: (fb[f0].0, fb[f1].1),
                t: None,
                since: None,
                mean: m,
                p: (p * ntests).min(1.0),
                visits: vs,
            });
        }
    }
    for a in 0..2 {
        let has = out.iter().any(|r| r.axis == a && r.kind == Kind::Inputs);
        let k = 2.0 * gt.families.len().max(1) as f64;
        if !has && gt.families.contains(&"inputs") && gt.space_p[a] * k < 0.05 {
            let vs: Vec<usize> = (0..nv).collect();
            out.push(Region {
                kind: Kind::Pattern,
                axis: a,
                z: zfull,
                f: ffull,
                t: None,
                since: None,
                mean: pattern_rms(ds, res, a),
                p: (gt.space_p[a] * k).min(1.0),
                visits: vs,
            });
        }
    }
    if gt.families.contains(&"drift") {
        let t: Vec<f64> = ds.visits.iter().map(|v| v.t_mid).collect();
        let tb = bins(&t, 6);
        let mut cands = Vec::new();
        for a in 0..2 {
            for b0 in 0..tb.len() {
                for b1 in b0..tb.len() {
                    if b0 == 0 && b1 == tb.len() - 1 {
                        continue;
                    }
                    let vs: Vec<usize> = (0..nv)
                        .filter(|&v| t[v] >= tb[b0].0 - 1e-9 && t[v] <= tb[b1].1 + 1e-9)
                        .collect();
                    if vs.len() < 2 {
                        continue;
                    }
                    let (m, p) = box_test(&vr, &vs, a, gt.visit_sd[a]);
                    cands.push((a, b0, b1, m, p, vs));
                }
            }
        }
        let ntests = cands.len() as f64;
        for a in 0..2 {
            if let Some(c) = cands
                .iter()
                .filter(|c| c.0 == a && c.4 * ntests < 0.05)
                .min_by(|x, y| x.4.total_cmp(&y.4))
            {
                out.push(Region {
                    kind: Kind::Drift,
                    axis: a,
                    z: zfull,
                    f: ffull,
                    t: Some((tb[c.1].0, tb[c.2].1)),
                    since: None,
                    mean: c.3,
                    p: (c.4 * ntests).min(1.0),
                    visits: c.5.clone(),
                });
            }
        }
    }
    if gt.families.contains(&"formation") {
        for a in 0..2 {
            if gt.trans_p[a] * 2.0 >= 0.05 {
                continue;
            }
            let s = formation_contrasts(ds, res, base_map, a);
            let vs: Vec<usize> = (0..nv)
                .filter(|&v| ds.visits[v].prev.is_some() && ds.visits[v].rows.len() >= 4)
                .collect();
            let mut split: Vec<f64> = vs
                .iter()
                .map(|&v| {
                    let r = &ds.visits[v].rows;
                    ds.rows[r[r.len() / 2]].since
                })
                .collect();
            split.sort_by(|a, b| a.total_cmp(b));
            let sp = split.get(split.len() / 2).copied().unwrap_or(0.0);
            out.push(Region {
                kind: Kind::Formation,
                axis: a,
                z: zfull,
                f: ffull,
                t: None,
                since: Some((0.0, sp)),
                mean: stats::mean(&s),
                p: (gt.trans_p[a] * 2.0).min(1.0),
                visits: vs,
            });
        }
    }
    out
}

/// The statistic a region is judged by under residuals `res`: its mean visit residual (inputs,
/// drift) or the mean formation contrast.
pub fn region_mean(ds: &Dataset, res: &[[f64; 2]], base_map: &[[f64; 2]], r: &Region) -> f64 {
    match r.kind {
        Kind::Formation => stats::mean(&formation_contrasts(ds, res, base_map, r.axis)),
        Kind::Pattern => pattern_rms(ds, res, r.axis),
        _ => {
            let vr = visit_residuals(ds, res);
            stats::mean(
                &r.visits
                    .iter()
                    .map(|&v| vr.e[v][r.axis])
                    .collect::<Vec<_>>(),
            )
        }
    }
}

/// RMS of the leave-one-out smoothed visit residuals over the inputs (the structured part).
pub fn pattern_rms(ds: &Dataset, res: &[[f64; 2]], a: usize) -> f64 {
    let vr = visit_residuals(ds, res);
    let y: Vec<f64> = vr.e.iter().map(|e| e[a]).collect();
    let s = loo_smooth(&coords(ds), &y, BANDWIDTHS[0]);
    (s.iter().map(|v| v * v).sum::<f64>() / s.len().max(1) as f64).sqrt()
}
