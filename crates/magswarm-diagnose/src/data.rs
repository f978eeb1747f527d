//! The diagnosis data set: every valid row of the logs with its session, visit and operating
//! point, the baseline's fixed transient part, and the pure error of the repeats.
//!
//! Visits and the settled/transient split are identify's ([`magswarm_identify::data`]): a
//! visit is a maximal run of rows with the same commanded inputs within a session. The
//! *transient part* of the baseline at a row is its ODE (4) replay minus its steady map at the
//! row's inputs; it is computed once from the baseline and held fixed while candidates are
//! refitted (the steady map and the effects are refitted, the baseline's time scales are not).

use super::DiagnoseError;
use magswarm_identify::data::{self as idata, key, Session};
use magswarm_identify::fit::predict_point;
use magswarm_identify::predict::{replay, InputRow};
use magswarm_log::Log;
use magswarm_model::Model;
use std::collections::BTreeMap;

/// One valid row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DRow {
    /// Session index.
    pub sess: usize,
    /// Global visit index.
    pub visit: usize,
    /// Operating point index.
    pub point: usize,
    /// Session time \[s\].
    pub t: f64,
    /// Time since the visit's input change \[s\].
    pub since: f64,
    /// Time since the previous valid row of the session \[s\] (0 for the first).
    pub dt: f64,
    /// z_m \[mm\].
    pub z: f64,
    /// f \[Hz\].
    pub f: f64,
    /// Measured radii \[mm\].
    pub r: [f64; 2],
    /// Settled by identify's rule.
    pub settled: bool,
    /// Baseline replay minus baseline steady map \[mm\].
    pub trans: [f64; 2],
    /// The same transient as a fraction of the step the row's visit started with:
    /// (replay - map) / (state at the input change - map), per axis; NaN where the step is
    /// too small to scale (then `trans` is added as is). A model whose map differs from the
    /// baseline's starts each visit from another state and approaches another target; the
    /// fraction carries the baseline's ODE (4) time scale over to it.
    pub frac: [f64; 2],
    /// Line in the source file.
    pub line: usize,
}

/// One visit.
#[derive(Debug, Clone, PartialEq)]
pub struct Visit {
    /// Session index.
    pub sess: usize,
    /// Operating point.
    pub point: usize,
    /// Rows (indices into `Dataset::rows`).
    pub rows: Vec<usize>,
    /// Mid time of its rows \[s\].
    pub t_mid: f64,
    /// Previous visit in the same session (None for the first).
    pub prev: Option<usize>,
}

/// The rows of one or more logs, organised for the diagnosis.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// Valid rows, session by session in time order.
    pub rows: Vec<DRow>,
    /// Visits.
    pub visits: Vec<Visit>,
    /// Distinct operating points (z_m \[mm\], f \[Hz\]).
    pub points: Vec<(f64, f64)>,
    /// Session names.
    pub sessions: Vec<String>,
    /// Rows in the logs in all (valid or not).
    pub rows_total: usize,
}

impl Dataset {
    /// Build from identify's sessions (classified) and the baseline model (for the transient
    /// part). `points` may be pre-seeded (to share point indices with another data set).
    pub fn build(sessions: &[Session], baseline: &Model) -> Result<Dataset, DiagnoseError> {
        let mut ds = Dataset {
            rows: Vec::new(),
            visits: Vec::new(),
            points: Vec::new(),
            sessions: Vec::new(),
            rows_total: 0,
        };
        let mut pidx: BTreeMap<(i64, i64), usize> = BTreeMap::new();
        for (si, s) in sessions.iter().enumerate() {
            ds.sessions.push(s.name.clone());
            ds.rows_total += s.rows.len();
            let inputs: Vec<InputRow> = s.rows.iter().map(idata::Row::input).collect();
            let rep = replay(baseline, &inputs, 1e-6).map_err(|source| DiagnoseError::Replay {
                session: s.name.clone(),
                source,
            })?;
            // State at each visit's input change: the replay at the row before its first row
            // (the inputs change right after that row); a session starts formed at rest.
            let mut start: Vec<Option<[f64; 2]>> = vec![None; s.rows.len()];
            for i in 1..s.rows.len() {
                start[i] = if s.rows[i].visit != s.rows[i - 1].visit {
                    Some(rep[i - 1])
                } else {
                    start[i - 1]
                };
            }
            let mut vmap: BTreeMap<usize, usize> = BTreeMap::new();
            let mut last_t: Option<f64> = None;
            let mut prev_visit: Option<usize> = None;
            for (i, r) in s.rows.iter().enumerate() {
                let Some(meas) = r.r else { continue };
                let k = key(r.z_mm, r.f_hz);
                let np = pidx.len();
                let point = *pidx.entry(k).or_insert(np);
                if point == ds.points.len() {
                    ds.points.push((r.z_mm, r.f_hz));
                }
                let vi = match vmap.get(&r.visit) {
                    Some(&v) => v,
                    None => {
                        let v = ds.visits.len();
                        ds.visits.push(Visit {
                            sess: si,
                            point,
                            rows: Vec::new(),
                            t_mid: 0.0,
                            prev: prev_visit,
                        });
                        vmap.insert(r.visit, v);
                        prev_visit = Some(v);
                        v
                    }
                };
                let ss = predict_point(baseline, r.z_mm, r.f_hz);
                let mut frac = [f64::NAN; 2];
                if let Some(st) = start[i] {
                    for a in 0..2 {
                        let step = st[a] - ss[a];
                        if step.abs() > 0.05 {
                            frac[a] = (rep[i][a] - ss[a]) / step;
                        }
                    }
                }
                let row = DRow {
                    sess: si,
                    visit: vi,
                    point,
                    t: r.t,
                    since: r.since,
                    dt: last_t.map(|t| r.t - t).unwrap_or(0.0),
                    z: r.z_mm,
                    f: r.f_hz,
                    r: meas,
                    settled: r.settled,
                    trans: [rep[i][0] - ss[0], rep[i][1] - ss[1]],
                    frac,
                    line: r.line,
                };
                last_t = Some(r.t);
                ds.visits[vi].rows.push(ds.rows.len());
                ds.rows.push(row);
            }
        }
        for v in ds.visits.iter_mut() {
            let ts: Vec<f64> = v.rows.iter().map(|&i| ds.rows[i].t).collect();
            v.t_mid =
                (ts.first().copied().unwrap_or(0.0) + ts.last().copied().unwrap_or(0.0)) / 2.0;
        }
        Ok(ds)
    }

    /// Distinct sorted values of z_m and f over the points.
    pub fn levels(&self) -> (Vec<f64>, Vec<f64>) {
        let d = |it: &mut dyn Iterator<Item = f64>| {
            let mut v: Vec<f64> = it.collect();
            v.sort_by(|a, b| a.total_cmp(b));
            v.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
            v
        };
        (
            d(&mut self.points.iter().map(|p| p.0)),
            d(&mut self.points.iter().map(|p| p.1)),
        )
    }

    /// Row residuals, measured minus `pred` (per row, r1 and r2) \[mm\].
    pub fn residuals(&self, pred: &[[f64; 2]]) -> Vec<[f64; 2]> {
        self.rows
            .iter()
            .zip(pred)
            .map(|(r, p)| [r.r[0] - p[0], r.r[1] - p[1]])
            .collect()
    }

    /// Settled rows of a visit (empty when none is settled).
    pub fn settled_rows(&self, v: usize) -> Vec<usize> {
        self.visits[v]
            .rows
            .iter()
            .copied()
            .filter(|&i| self.rows[i].settled)
            .collect()
    }

    /// The rows a visit's mean is taken over: its settled rows, or all its rows when none is
    /// settled (a visit too short to settle still has a level).
    pub fn mean_rows(&self, v: usize) -> Vec<usize> {
        let s = self.settled_rows(v);
        if s.is_empty() {
            self.visits[v].rows.clone()
        } else {
            s
        }
    }
}

/// Pure error of the repeats.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PureError {
    /// Within-visit SD of settled rows per axis \[mm\].
    pub within_sd: [f64; 2],
    /// Degrees of freedom of `within_sd`.
    pub within_dof: usize,
    /// Visit-to-visit SD beyond the within-visit part per axis \[mm\] (0 when it cannot be
    /// estimated: no operating point visited twice).
    pub between_sd: [f64; 2],
    /// Degrees of freedom of the between-visit estimate (0: none).
    pub between_dof: usize,
    /// Points with two or more visits.
    pub repeat_points: usize,
}

impl PureError {
    /// SD of one row around the true value (within + between) \[mm\].
    pub fn row_sd(&self) -> [f64; 2] {
        [
            (self.within_sd[0].powi(2) + self.between_sd[0].powi(2)).sqrt(),
            (self.within_sd[1].powi(2) + self.between_sd[1].powi(2)).sqrt(),
        ]
    }
}

/// Pure error from the settled rows of each visit and from repeat visits of a point.
pub fn pure_error(ds: &Dataset) -> PureError {
    let vals: Vec<[f64; 2]> = ds.rows.iter().map(|r| r.r).collect();
    pure_error_of(ds, &vals)
}

/// Pure error of per-row values `vals` (the measurements, or a model's residuals: the scatter
/// of repeat visits around a model that includes a drift is not inflated by the drift).
pub fn pure_error_of(ds: &Dataset, vals: &[[f64; 2]]) -> PureError {
    let mut ss = [0.0; 2];
    let mut dof = 0usize;
    // Per visit: mean and count of settled rows.
    let mut vm: Vec<Option<([f64; 2], usize)>> = Vec::new();
    for v in 0..ds.visits.len() {
        let rows = ds.settled_rows(v);
        if rows.is_empty() {
            vm.push(None);
            continue;
        }
        let n = rows.len();
        let mut m = [0.0; 2];
        for &i in &rows {
            for a in 0..2 {
                m[a] += vals[i][a] / n as f64;
            }
        }
        for &i in &rows {
            for a in 0..2 {
                ss[a] += (vals[i][a] - m[a]).powi(2);
            }
        }
        dof += n - 1;
        vm.push(Some((m, n)));
    }
    let within = [
        (ss[0] / dof.max(1) as f64).sqrt(),
        (ss[1] / dof.max(1) as f64).sqrt(),
    ];
    // Between visits of one point: variance of visit means minus the within part.
    let mut by_point: BTreeMap<usize, Vec<([f64; 2], usize)>> = BTreeMap::new();
    for (v, m) in vm.iter().enumerate() {
        if let Some(m) = m {
            by_point.entry(ds.visits[v].point).or_default().push(*m);
        }
    }
    let (mut sb, mut bdof, mut expect, mut reps) = ([0.0; 2], 0usize, [0.0; 2], 0usize);
    for ms in by_point.values().filter(|m| m.len() >= 2) {
        reps += 1;
        let k = ms.len();
        for a in 0..2 {
            let mean = ms.iter().map(|m| m.0[a]).sum::<f64>() / k as f64;
            sb[a] += ms.iter().map(|m| (m.0[a] - mean).powi(2)).sum::<f64>();
            // Expected within contribution: sum over visits (1 - 1/k) within^2 / n_v.
            expect[a] += ms
                .iter()
                .map(|m| (1.0 - 1.0 / k as f64) * within[a].powi(2) / m.1 as f64)
                .sum::<f64>();
        }
        bdof += k - 1;
    }
    let mut between = [0.0; 2];
    if bdof > 0 {
        for a in 0..2 {
            between[a] = ((sb[a] - expect[a]) / bdof as f64).max(0.0).sqrt();
        }
    }
    PureError {
        within_sd: within,
        within_dof: dof,
        between_sd: between,
        between_dof: bdof,
        repeat_points: reps,
    }
}

/// Sessions of the logs classified by the settle rule of `model` (identify's split).
pub fn sessions(logs: &[Log], rule: idata::SettleRule, model: &Model) -> Vec<Session> {
    let mut s = idata::sessions(logs);
    idata::classify(&mut s, rule, model);
    s
}

/// Per-visit residual summary.
#[derive(Debug, Clone, PartialEq)]
pub struct VisitRes {
    /// Mean residual of the settled rows (all rows when none is settled) \[mm\].
    pub e: Vec<[f64; 2]>,
    /// Rows averaged.
    pub n: Vec<usize>,
}

/// Visit residuals from row residuals.
pub fn visit_residuals(ds: &Dataset, res: &[[f64; 2]]) -> VisitRes {
    let mut e = Vec::with_capacity(ds.visits.len());
    let mut n = Vec::with_capacity(ds.visits.len());
    for v in 0..ds.visits.len() {
        let rows = ds.mean_rows(v);
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

/// Up to `k` bins of sorted distinct values: (lo, hi) edges per bin.
pub fn level_bins(vals: &[f64], k: usize) -> Vec<(f64, f64)> {
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
