//! The noise a log carries, estimated without trusting the model, and logs of pure noise
//! with the same structure for the parametric bootstrap.
//!
//! Two levels, per axis: the *row* noise within a visit (successive differences of settled
//! rows: a visit's offset and any slow transient cancel) and the *visit* noise, the scatter
//! of a visit's mean around the truth (swarm re-formation, re-seeding: what the seed's 10
//! repeated measurements per point do not see). With repeat visits the visit noise is their
//! scatter; with each point visited once it is the roughness of the residual surface:
//! differences of neighbouring visits on the grid (same f at adjacent z_m, same z_m at adjacent
//! f), in which any structure that is smooth along at least one input cancels. A robust scale
//! (MAD) of the pooled differences keeps a band or a local bump, which spoils a minority of
//! the differences, from inflating it.

use super::data::Dataset;
use super::stats;
use nalgebra::DVector;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// Noise levels per axis \[mm\].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Noise {
    /// SD of one row around its visit's mean.
    pub within: [f64; 2],
    /// SD of a visit's mean of settled rows around the truth.
    pub visit: [f64; 2],
    /// SD of the visit-to-visit offset (visit noise less the within part of a mean).
    pub between: [f64; 2],
    /// Mean settled rows per visit.
    pub rows_per_visit: f64,
    /// Differences the visit noise was estimated from.
    pub pairs: usize,
    /// Repeat visits among them.
    pub repeat_pairs: usize,
}

impl Noise {
    /// SD of one row around the truth.
    pub fn row(&self) -> [f64; 2] {
        [
            (self.within[0].powi(2) + self.between[0].powi(2)).sqrt(),
            (self.within[1].powi(2) + self.between[1].powi(2)).sqrt(),
        ]
    }
}

/// Too little data to tell noise from structure.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "too few visits to estimate the visit-to-visit noise: {pairs} neighbouring or repeated \
     visit pair(s) on the grid of operating points, at least {need} needed (revisit points, or \
     measure a grid with at least 3 levels of z_m and of f)"
)]
pub struct TooFew {
    /// Pairs found.
    pub pairs: usize,
    /// Pairs needed.
    pub need: usize,
}

/// Fewest differences the visit noise is estimated from.
pub const MIN_PAIRS: usize = 12;

/// Cell (z bin, f bin) of every visit on the binned grid of operating points.
pub fn cells(ds: &Dataset) -> (Vec<(usize, usize)>, usize, usize) {
    let (zs, fs) = ds.levels();
    let zb = super::data::level_bins(&zs, 8);
    let fb = super::data::level_bins(&fs, 10);
    let find = |b: &[(f64, f64)], x: f64| {
        b.iter()
            .position(|&(lo, hi)| x >= lo - 1e-9 && x <= hi + 1e-9)
            .unwrap_or(0)
    };
    let c = ds
        .visits
        .iter()
        .map(|v| {
            let (z, f) = ds.points[v.point];
            (find(&zb, z), find(&fb, f))
        })
        .collect();
    (c, zb.len(), fb.len())
}

/// Estimate the noise from a model's row residuals \[mm\] (`res`; its structure mostly cancels).
pub fn estimate(ds: &Dataset, res: &[[f64; 2]]) -> Result<Noise, TooFew> {
    // Row noise: successive differences of settled rows within a visit.
    let mut within = [0.0; 2];
    let mut settled_n = 0usize;
    for a in 0..2 {
        let mut d = Vec::new();
        for v in 0..ds.visits.len() {
            let rows = ds.settled_rows(v);
            if a == 0 {
                settled_n += rows.len().max(1);
            }
            for w in rows.windows(2) {
                d.push(res[w[1]][a] - res[w[0]][a]);
            }
        }
        within[a] = if d.len() >= 10 {
            mad0(&d) / std::f64::consts::SQRT_2
        } else {
            0.0
        };
    }
    let rows_per_visit = settled_n as f64 / ds.visits.len().max(1) as f64;
    // Visit noise: differences of neighbouring or repeated visits.
    let vr = super::data::visit_residuals(ds, res);
    let (cell, nz, nf) = cells(ds);
    let mut first: Vec<Option<usize>> = vec![None; nz * nf];
    for (v, &(zi, fi)) in cell.iter().enumerate() {
        if first[zi * nf + fi].is_none() {
            first[zi * nf + fi] = Some(v);
        }
    }
    let mut by_point: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for (v, vi) in ds.visits.iter().enumerate() {
        by_point.entry(vi.point).or_default().push(v);
    }
    let mut groups: [Vec<(usize, usize)>; 3] = Default::default();
    for vs in by_point.values() {
        for w in vs.windows(2) {
            groups[0].push((w[0], w[1]));
        }
    }
    for (v, &(zi, fi)) in cell.iter().enumerate() {
        if zi + 1 < nz {
            if let Some(u) = first[(zi + 1) * nf + fi] {
                groups[1].push((v, u));
            }
        }
        if fi + 1 < nf {
            if let Some(u) = first[zi * nf + fi + 1] {
                groups[2].push((v, u));
            }
        }
    }
    let pairs: usize = groups.iter().map(|g| g.len()).sum();
    if pairs < MIN_PAIRS {
        return Err(TooFew {
            pairs,
            need: MIN_PAIRS,
        });
    }
    let mut visit = [0.0; 2];
    for a in 0..2 {
        // Each kind of neighbour centred on its own median (a trend along an input shifts the
        // differences of that kind alike), then one robust scale for all.
        let mut d = Vec::with_capacity(pairs);
        for g in &groups {
            let dg: Vec<f64> = g.iter().map(|&(u, v)| vr.e[v][a] - vr.e[u][a]).collect();
            let med = median(&dg);
            d.extend(dg.iter().map(|x| x - med));
        }
        visit[a] = (mad0(&d) / std::f64::consts::SQRT_2).max(1e-6);
    }
    let mut between = [0.0; 2];
    for a in 0..2 {
        let part = within[a].powi(2) / rows_per_visit.max(1.0);
        between[a] = (visit[a].powi(2) - part).max(0.1 * visit[a].powi(2)).sqrt();
    }
    Ok(Noise {
        within,
        visit,
        between,
        rows_per_visit,
        pairs,
        repeat_pairs: groups[0].len(),
    })
}

fn median(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let mut v = x.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// 1.4826 x the median absolute value (a normal SD for values centred on 0).
fn mad0(x: &[f64]) -> f64 {
    let a: Vec<f64> = x.iter().map(|v| v.abs()).collect();
    1.4826 * median(&a)
}

/// A simulated log of pure noise with the data's structure: weighted stacked rows
/// (`w[a] x (visit offset + row noise)`), replicate `rep` of the stream `seed`.
pub fn simulate(ds: &Dataset, nz: &Noise, w: [f64; 2], seed: u64, rep: usize) -> DVector<f64> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(
        seed ^ 0x5EED_B007 ^ (rep as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
    );
    let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
    let off: Vec<[f64; 2]> = (0..ds.visits.len())
        .map(|_| [g() * nz.between[0], g() * nz.between[1]])
        .collect();
    let mut y = DVector::zeros(2 * ds.rows.len());
    for (i, r) in ds.rows.iter().enumerate() {
        for a in 0..2 {
            y[2 * i + a] = w[a] * (off[r.visit][a] + g() * nz.within[a]);
        }
    }
    y
}

/// Bootstrap p-value of `obs` against null replicates: the empirical (1 + #{null >= obs}) /
/// (1 + B); where no replicate reaches `obs`, the tail of a gamma distribution fitted to the
/// replicates by moments (never above the empirical bound), so that strong evidence is not
/// capped at 1 / (1 + B).
pub fn boot_p(obs: f64, null: &[f64]) -> f64 {
    let b = null.len();
    let ge = null.iter().filter(|&&v| v >= obs).count();
    let emp = (1 + ge) as f64 / (1 + b) as f64;
    if ge > 0 || b < 20 {
        return emp;
    }
    let lo = null.iter().copied().fold(f64::INFINITY, f64::min).min(0.0);
    let m = stats::mean(null) - lo;
    let v = null.iter().map(|x| (x - lo - m).powi(2)).sum::<f64>() / (b - 1) as f64;
    if m <= 0.0 || v <= 0.0 {
        return emp;
    }
    let (k, theta) = (m * m / v, v / m);
    stats::gamma_q(k, (obs - lo) / theta).min(emp)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bootstrap_p_is_empirical_inside_and_extrapolated_beyond() {
        let null: Vec<f64> = (0..99).map(|i| i as f64 / 10.0).collect();
        assert!((boot_p(5.0, &null) - 50.0 / 100.0).abs() < 1e-12);
        let far = boot_p(100.0, &null);
        assert!(far < 1e-6 && far > 0.0);
    }
}
