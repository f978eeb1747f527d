//! Where the gap lies: contiguous boxes of input levels (and of session time, and of time
//! since the input change), tested by their mean visit residual with Benjamini-Hochberg control
//! over the boxes searched, and the measures of a region's residual that attribution uses.

use super::*;

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
    /// z_m range \[mm\].
    pub z: (f64, f64),
    /// f range \[Hz\].
    pub f: (f64, f64),
    /// Session-time range \[s\] (drift regions).
    pub t: Option<(f64, f64)>,
    /// Time since the input change \[s\] (formation regions).
    pub since: Option<(f64, f64)>,
    /// Mean residual (measured - model) \[mm\]; for formation regions the signed lag contrast.
    pub mean: f64,
    /// p-value corrected for the search.
    pub p: f64,
    /// Visits in the region.
    pub visits: Vec<usize>,
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
    // Structure over the inputs that no single box isolates: every visit, radius `a`.
    let pattern = |a: usize, p: f64| Region {
        kind: Kind::Pattern,
        axis: a,
        z: zfull,
        f: ffull,
        t: None,
        since: None,
        mean: pattern_rms(ds, res, a),
        p: p.min(1.0),
        visits: (0..nv).collect(),
    };
    if gt.families.contains(&"inputs") || gt.families.contains(&"lack_of_fit") {
        let zb = level_bins(&zs, 8);
        let fb = level_bins(&fs, 10);
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
            out.push(pattern(a, gt.space_p[a] * k));
        }
    }
    if gt.families.contains(&"drift") {
        let t: Vec<f64> = ds.visits.iter().map(|v| v.t_mid).collect();
        let tb = level_bins(&t, 6);
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
        // The drift family is significant but no stretch of the session stands out on its own
        // against the visit noise (a course that the smooth alternative follows across the
        // whole session, whose visit noise it inflates): the session as a whole is the
        // region, on the radius whose strongest stretch comes closest, so that the
        // candidates are still weighed rather than the gap left without a place.
        if !out.iter().any(|r| r.kind == Kind::Drift) {
            if let Some(c) = cands.iter().min_by(|x, y| x.4.total_cmp(&y.4)) {
                // The session's span: the first bin's start to the last bin's end.
                let (t0, t1) = (tb[0].0, tb[tb.len() - 1].1);
                out.push(Region {
                    kind: Kind::Drift,
                    axis: c.0,
                    z: zfull,
                    f: ffull,
                    t: Some((t0, t1)),
                    since: None,
                    mean: c.3,
                    p: gt.drift_p[c.0].min(1.0),
                    visits: (0..nv).collect(),
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
    // A significant gap always has a place: where no family's search isolates one, the
    // structure over the inputs on both radii (never a gap declared and then left unweighed).
    if out.is_empty() && gt.significant {
        out.extend((0..2).map(|a| pattern(a, gt.p_value)));
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
