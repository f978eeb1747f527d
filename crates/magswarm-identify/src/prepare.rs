//! Step 1 of the pipeline, data preparation: classified sessions to fitted and withheld
//! operating points with weights and counts, and the refusal of data that cannot identify the
//! free parameters.

use super::data::{self, OpPoint, Weighting};
use super::params::Free;
use super::result::Counts;
use crate::IdentifyError;

/// Refuse with a message that says why the data cannot identify the free set.
macro_rules! bail {
    ($($t:tt)*) => {
        return Err(IdentifyError::NotIdentifiable(format!($($t)*)))
    };
}

/// Row counts of classified sessions.
pub(super) fn count(sessions: &[data::Session]) -> Counts {
    let mut c = Counts {
        sessions: sessions.len(),
        ..Counts::default()
    };
    for s in sessions {
        c.visits += s.rows.last().map(|r| r.visit + 1).unwrap_or(0);
        for r in &s.rows {
            c.rows += 1;
            match (r.r, r.settled) {
                (None, _) => c.invalid += 1,
                (Some(_), true) => c.settled += 1,
                (Some(_), false) => c.transient += 1,
            }
        }
    }
    c
}

/// The fitting data of one settle classification: fitted and withheld points, weights, counts.
#[derive(Debug, Clone)]
pub(super) struct Prepared {
    pub(super) points: Vec<OpPoint>,
    pub(super) withheld: Vec<OpPoint>,
    pub(super) weighting: Weighting,
    pub(super) counts: Counts,
}

/// Pool the classified sessions into points, withhold every K-th, weight the fitted ones
/// (withheld points are weighted like the fitted ones, pooled SD, for reporting only).
pub(super) fn prepare(sessions: &[data::Session], withhold_every: usize) -> Prepared {
    let all = data::op_points(sessions);
    let (mut points, mut withheld) = (Vec::new(), Vec::new());
    for (i, p) in all.into_iter().enumerate() {
        if withhold_every > 0 && (i + 1) % withhold_every == 0 {
            withheld.push(p);
        } else {
            points.push(p);
        }
    }
    let mut counts = count(sessions);
    counts.points = points.len() + withheld.len();
    let weighting = data::assign_weights(&mut points);
    for w in withheld.iter_mut() {
        w.se = [1.0; 2];
    }
    Prepared {
        points,
        withheld,
        weighting,
        counts,
    }
}

/// The distinct values of `v` (to 1e-6), sorted.
pub(super) fn distinct(v: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut x: Vec<f64> = v.collect();
    x.sort_by(|a, b| a.total_cmp(b));
    x.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    x
}

/// Refuse data that cannot identify the free parameters, saying what is missing.
pub(super) fn check_identifiable(
    points: &[OpPoint],
    free: &[Free],
    counts: &Counts,
) -> Result<(), IdentifyError> {
    if counts.settled == 0 {
        bail!(
            "no settled rows: all {} valid rows lie within the settle time of an input change \
             ({} transient). Record longer at each operating point, or pass --settle-s 0 if \
             the log holds only settled measurements",
            counts.transient,
            counts.transient
        );
    }
    let p = free.len();
    if p == 0 {
        bail!("no free steady parameters (check --free / --fix)");
    }
    let need = (p + 2).div_ceil(2);
    if points.len() < need {
        bail!(
            "too few operating points: {} settled point(s) (visits pooled by inputs) for {p} \
             free steady parameters; need at least {need} (2 radii per point, >= 2 residual \
             degrees of freedom). Add visits at more (z_m, f) pairs or fix parameters with --fix",
            points.len()
        );
    }
    let zs = distinct(points.iter().map(|p| p.z_mm));
    let fs = distinct(points.iter().map(|p| p.f_hz));
    let z_shape: Vec<&str> = free
        .iter()
        .map(|f| f.name())
        .filter(|n| !matches!(*n, "C_1" | "C_2" | "N" | "q" | "c_P" | "q_P"))
        .collect();
    if !z_shape.is_empty() && zs.len() < 3 {
        bail!(
            "{} distinct z_m value(s) ({} mm): the z_m-dependent parameters {} need at least \
             3 distinct z_m values to be told apart from C_1, C_2. Add visits at other \
             distances or fix them with --fix {}",
            zs.len(),
            zs.iter()
                .map(|z| format!("{z}"))
                .collect::<Vec<_>>()
                .join(", "),
            z_shape.join(", "),
            z_shape.join(",")
        );
    }
    let f_shape: Vec<&str> = free
        .iter()
        .map(|f| f.name())
        .filter(|n| matches!(*n, "N" | "q" | "c_P" | "q_P"))
        .collect();
    if !f_shape.is_empty() && fs.len() < 3 {
        bail!(
            "{} distinct frequency value(s) ({} Hz): the frequency parameters {} need at least \
             3 distinct f values. Add visits at other frequencies or fix them with --fix {}",
            fs.len(),
            fs.iter()
                .map(|f| format!("{f}"))
                .collect::<Vec<_>>()
                .join(", "),
            f_shape.join(", "),
            f_shape.join(",")
        );
    }
    Ok(())
}
