//! From log rows to fitting data: sessions, input segments (visits), the settled/transient
//! split, and the per-operating-point statistics (mean, repeat SD, MAD).
//!
//! **Visits.** Within a session (one log file x one `session` value), a visit is a maximal run
//! of consecutive rows with the same commanded inputs (z_m_mm, f_hz). A row's inputs are the
//! ones that were in force while its measurement formed: held over the interval since the
//! previous row (docs/log-format.md; the convention `predict` replays with and every magswarm
//! log is written in), so a change is dated at the time of the last row with the old inputs.
//! In a log streamed at a fixed rate this is exact for magswarm's own logs; in a log that only
//! records measurements (inputs changed, wait, measure) it correctly counts the unrecorded
//! waiting time. The first visit of a session starts at the session's first row: the state
//! before it is unknown.
//!
//! **Settled rows.** A row is settled when the time since its visit started is at least the
//! settle time: `--settle-s S` if given, else `settle_factor x tau(z_m, f)` with tau the
//! slowest time constant of ODE (4) linearised at the steady point of the current model
//! (default factor 5: a first-order transient has decayed to e^-5 = 0.7 % by then).
//! Settled rows feed the steady-map fit; the others are transients and feed the ODE fit.
//! Rows with `valid` = 0 (or without radii) still mark input changes but are never fitted.
//!
//! **Operating points.** Settled rows with the same inputs (to 1e-6 mm / 1e-6 Hz) are pooled
//! over all visits and files into one operating point: mean, repeat standard deviation, MAD
//! (median absolute deviation, unscaled as the seed reports it) and the number of visits.

use magswarm_log::Log;
use magswarm_model::dynamics::{eig2, InputTerms};
use magswarm_model::{hz_to_rad_s, Model};
use std::collections::BTreeMap;

/// One fit-relevant row of a session.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Time within the session \[s\].
    pub t: f64,
    /// Commanded z_m \[mm\].
    pub z_mm: f64,
    /// Commanded frequency \[Hz\].
    pub f_hz: f64,
    /// Measured radii \[mm\] (None: invalid row or no radii).
    pub r: Option<[f64; 2]>,
    /// Index of the visit within the session (0: the session's first).
    pub visit: usize,
    /// Time since the visit started \[s\].
    pub since: f64,
    /// Settled by the rule above (only meaningful when `r` is Some).
    pub settled: bool,
    /// Line in the source file.
    pub line: usize,
}

impl Row {
    /// The row's inputs, as [`crate::predict::replay`] takes them.
    pub fn input(&self) -> crate::predict::InputRow {
        crate::predict::InputRow {
            t: self.t,
            z_mm: self.z_mm,
            f_hz: self.f_hz,
        }
    }
}

/// The rows of one session, in time order.
#[derive(Debug, Clone, PartialEq)]
pub struct Session {
    /// "file" or "file \[session\]".
    pub name: String,
    /// Rows.
    pub rows: Vec<Row>,
}

/// One operating point: statistics of its settled rows.
#[derive(Debug, Clone, PartialEq)]
pub struct OpPoint {
    /// z_m \[mm\].
    pub z_mm: f64,
    /// f \[Hz\].
    pub f_hz: f64,
    /// Number of settled rows.
    pub n: usize,
    /// Number of visits contributing.
    pub visits: usize,
    /// Mean radii \[mm\].
    pub mean: [f64; 2],
    /// Repeat standard deviation \[mm\] (0 when n = 1).
    pub sd: [f64; 2],
    /// Median absolute deviation from the median \[mm\].
    pub mad: [f64; 2],
    /// Standard error of the mean used as the fit's weight \[mm\] (set by [`assign_weights`]).
    pub se: [f64; 2],
    /// The settled samples \[mm\].
    pub samples: Vec<[f64; 2]>,
    /// Session time \[s\] of each sample (same order; empty when not known, e.g. a point built
    /// by [`point_stats`] alone): drift effects make the observed radii depend on it.
    pub t_s: Vec<f64>,
}

/// Same inputs to 1e-6 mm / 1e-6 Hz.
pub fn key(z_mm: f64, f_hz: f64) -> (i64, i64) {
    ((z_mm * 1e6).round() as i64, (f_hz * 1e6).round() as i64)
}

/// Slowest time constant \[s\] of ODE (4) linearised at the steady point (infinite when the
/// linearisation is not stable).
pub fn time_constant(model: &Model, z_mm: f64, f_hz: f64) -> f64 {
    let t = InputTerms::new(model, z_mm * 1e-3, hz_to_rad_s(f_hz));
    let e = eig2(t.jac_state(model, t.steady.radii()));
    let slow = e[0].0.max(e[1].0);
    if slow < 0.0 {
        -1.0 / slow
    } else {
        f64::INFINITY
    }
}

/// The settle rule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SettleRule {
    /// Fixed settle time \[s\].
    Fixed(f64),
    /// factor x slowest time constant of the model at the visit's inputs.
    TimeConstants(f64),
}

impl SettleRule {
    /// Human-readable description for the report.
    pub fn describe(&self) -> String {
        match self {
            SettleRule::Fixed(s) => format!("settled = at least {s} s after the input change"),
            SettleRule::TimeConstants(k) => format!(
                "settled = at least {k} x tau(z_m, f) after the input change, tau the slowest \
                 time constant of ODE (4) linearised at the steady point"
            ),
        }
    }
}

/// Split the logs into sessions and visits (no settle classification yet).
pub fn sessions(logs: &[Log]) -> Vec<Session> {
    let mut out = Vec::new();
    for log in logs {
        // Sessions in order of first appearance.
        let mut order: Vec<String> = Vec::new();
        let mut by: BTreeMap<String, Vec<Row>> = BTreeMap::new();
        for r in &log.rows {
            if !by.contains_key(&r.session) {
                order.push(r.session.clone());
            }
            by.entry(r.session.clone()).or_default().push(Row {
                t: r.t_s,
                z_mm: r.z_m_mm,
                f_hz: r.f_hz,
                r: if r.valid { r.radii() } else { None },
                visit: 0,
                since: 0.0,
                settled: false,
                line: r.line,
            });
        }
        for s in order {
            let mut rows = by.remove(&s).unwrap_or_default();
            let mut visit = 0;
            let mut start = rows.first().map(|r| r.t).unwrap_or(0.0);
            let mut prev: Option<((i64, i64), f64)> = None;
            for r in rows.iter_mut() {
                let k = key(r.z_mm, r.f_hz);
                if let Some((pk, pt)) = prev {
                    if pk != k {
                        visit += 1;
                        start = pt;
                    }
                }
                prev = Some((k, r.t));
                r.visit = visit;
                r.since = r.t - start;
            }
            let name = if s.is_empty() {
                log.source.clone()
            } else {
                format!("{} [{}]", log.source, s)
            };
            out.push(Session { name, rows });
        }
    }
    out
}

/// Mark settled rows by the rule; tau is evaluated once per distinct operating point.
pub fn classify(sessions: &mut [Session], rule: SettleRule, model: &Model) {
    let mut cache: BTreeMap<(i64, i64), f64> = BTreeMap::new();
    for s in sessions.iter_mut() {
        for r in s.rows.iter_mut() {
            let need = match rule {
                SettleRule::Fixed(x) => x,
                SettleRule::TimeConstants(k) => {
                    k * *cache
                        .entry(key(r.z_mm, r.f_hz))
                        .or_insert_with(|| time_constant(model, r.z_mm, r.f_hz))
                }
            };
            r.settled = r.since >= need;
        }
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

/// Median and MAD of a sample.
pub fn median_mad(x: &[f64]) -> (f64, f64) {
    let mut v = x.to_vec();
    let m = median(&mut v);
    let mut dev: Vec<f64> = x.iter().map(|a| (a - m).abs()).collect();
    (m, median(&mut dev))
}

/// Pool the settled rows into operating points (sorted by z, then f).
pub fn op_points(sessions: &[Session]) -> Vec<OpPoint> {
    /// z, f, samples, (session, visit) pairs seen, session times of the samples.
    type Acc = (f64, f64, Vec<[f64; 2]>, Vec<(usize, usize)>, Vec<f64>);
    let mut acc: BTreeMap<(i64, i64), Acc> = BTreeMap::new();
    for (si, s) in sessions.iter().enumerate() {
        for r in &s.rows {
            if let (Some(v), true) = (r.r, r.settled) {
                let e = acc
                    .entry(key(r.z_mm, r.f_hz))
                    .or_insert_with(|| (r.z_mm, r.f_hz, Vec::new(), Vec::new(), Vec::new()));
                e.2.push(v);
                e.4.push(r.t);
                if !e.3.contains(&(si, r.visit)) {
                    e.3.push((si, r.visit));
                }
            }
        }
    }
    acc.into_values()
        .map(|(z, f, samples, visits, t_s)| OpPoint {
            t_s,
            ..point_stats(z, f, samples, visits.len())
        })
        .collect()
}

/// Statistics of one point's samples.
pub fn point_stats(z_mm: f64, f_hz: f64, samples: Vec<[f64; 2]>, visits: usize) -> OpPoint {
    let n = samples.len();
    let mut mean = [0.0; 2];
    let mut sd = [0.0; 2];
    let mut mad = [0.0; 2];
    for a in 0..2 {
        let x: Vec<f64> = samples.iter().map(|s| s[a]).collect();
        mean[a] = x.iter().sum::<f64>() / n as f64;
        if n > 1 {
            sd[a] = (x.iter().map(|v| (v - mean[a]).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
        }
        mad[a] = median_mad(&x).1;
    }
    OpPoint {
        z_mm,
        f_hz,
        n,
        visits,
        mean,
        sd,
        mad,
        se: [f64::NAN; 2],
        samples,
        t_s: Vec::new(),
    }
}

/// Prior degrees of freedom of the pooled variance in the shrunk per-point variance.
pub const SHRINK_DOF: f64 = 10.0;

/// How the weights were set (for the report).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weighting {
    /// Pooled repeat SD per axis \[mm\] (NaN without repeats).
    pub pooled_sd: [f64; 2],
    /// False when no point has repeats: then every SE is 1 mm (unit weights).
    pub from_repeats: bool,
}

/// Set `se` of every point from its repeat variance, shrunk toward the pooled variance of the
/// axis: `var_i = ((n_i - 1) s_i^2 + nu0 s_pool^2) / (n_i - 1 + nu0)`, `se_i = sqrt(var_i /
/// n_i)`, nu0 = [`SHRINK_DOF`]. A raw 10-repeat variance is too noisy (chi^2 with 9 degrees
/// of freedom) to weight by alone; the shrinkage keeps real differences between points (the
/// seed's r2 varies more at intermediate inputs) without letting a lucky small SD dominate.
pub fn assign_weights(points: &mut [OpPoint]) -> Weighting {
    let mut pooled = [f64::NAN; 2];
    let dof: f64 = points.iter().map(|p| p.n.saturating_sub(1) as f64).sum();
    let from_repeats = dof > 0.0;
    for (a, pa) in pooled.iter_mut().enumerate() {
        if from_repeats {
            let ss: f64 = points
                .iter()
                .map(|p| p.n.saturating_sub(1) as f64 * p.sd[a] * p.sd[a])
                .sum();
            *pa = (ss / dof).sqrt();
        }
    }
    for p in points.iter_mut() {
        #[allow(clippy::needless_range_loop)]
        for a in 0..2 {
            p.se[a] = if from_repeats {
                let k = p.n.saturating_sub(1) as f64;
                let var =
                    (k * p.sd[a] * p.sd[a] + SHRINK_DOF * pooled[a] * pooled[a]) / (k + SHRINK_DOF);
                // A floor keeps noise-free synthetic data finite.
                (var / p.n as f64).sqrt().max(1e-6)
            } else {
                1.0
            };
        }
    }
    Weighting {
        pooled_sd: pooled,
        from_repeats,
    }
}
