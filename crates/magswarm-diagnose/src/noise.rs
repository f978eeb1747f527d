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
    let rough = Roughness::new(ds);
    let visit = rough.visit_sd(res)?;
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
        pairs: rough.pairs(),
        repeat_pairs: rough.repeat_pairs(),
    })
}

/// The pairs of visits whose differences measure the visit noise (repeat visits of a point;
/// neighbouring cells of the grid of operating points, same f at adjacent z_m and same z_m at
/// adjacent f) and the rows each visit's mean is taken over. Both are fixed by the design, so
/// they are found once per data set and serve every residual, the real one and the simulated
/// ones, under every alternative of the tests: a structure that inflates the visit noise of
/// the baseline's residual (a drift makes repeat visits at other times differ, a band spoils
/// neighbouring differences) is judged against the noise left once it is fitted.
#[derive(Debug, Clone)]
pub struct Roughness {
    mean_rows: Vec<Vec<usize>>,
    /// Repeat pairs, neighbours along z_m, neighbours along f, nearest neighbours in the
    /// (z_m, f) plane (a design off any grid).
    groups: [Vec<(usize, usize)>; 4],
    /// The scale of the differences: Tukey's biweight rather than the MAD.
    efficient: bool,
}

impl Roughness {
    /// The pairs and mean rows of a data set.
    pub fn new(ds: &Dataset) -> Roughness {
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
        let mut groups: [Vec<(usize, usize)>; 4] = Default::default();
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
        // Operating points off any grid (a Latin hypercube, setpoints drawn at random): few
        // visits have a neighbour in the next cell along an input. Each visit is then paired
        // with the visit at the nearest other operating point, in the (z_m, f) plane scaled
        // by the data's spans, where a smooth structure differs least.
        let nv = ds.visits.len();
        if groups[1].len() + groups[2].len() < nv / 2 {
            let (zs, fs) = ds.levels();
            let span = |v: &[f64]| {
                (v.last().copied().unwrap_or(0.0) - v.first().copied().unwrap_or(0.0)).max(1e-9)
            };
            let (sz, sf) = (span(&zs), span(&fs));
            let xy: Vec<(f64, f64)> = ds
                .visits
                .iter()
                .map(|v| {
                    let (z, f) = ds.points[v.point];
                    (z / sz, f / sf)
                })
                .collect();
            let mut seen = std::collections::BTreeSet::new();
            for v in 0..nv {
                let near = (0..nv)
                    .filter(|&u| ds.visits[u].point != ds.visits[v].point)
                    .min_by(|&a, &b| {
                        let d =
                            |u: usize| (xy[u].0 - xy[v].0).powi(2) + (xy[u].1 - xy[v].1).powi(2);
                        d(a).total_cmp(&d(b))
                    });
                if let Some(u) = near {
                    if seen.insert((u.min(v), u.max(v))) {
                        groups[3].push((u.min(v), u.max(v)));
                    }
                }
            }
        }
        Roughness {
            mean_rows: (0..nv).map(|v| ds.mean_rows(v)).collect(),
            groups,
            efficient: false,
        }
    }

    /// The same pairs, their scale taken as Tukey's biweight scale instead of the MAD: as
    /// robust, more than twice as efficient. For the gap tests, where the visit noise
    /// studentises every statistic in the real log and in each simulated one, so the
    /// estimate's scatter is scatter of the null distribution, that is lost power. The
    /// attribution and the noise model keep the MAD: there the estimate weighs candidates
    /// against one another rather than against a null, and the MAD's indifference to the
    /// shoulders of the differences keeps a lab's own smooth offsets from looking like an
    /// effect's.
    pub fn efficient(mut self) -> Roughness {
        self.efficient = true;
        self
    }

    /// Differences the visit noise is estimated from.
    pub fn pairs(&self) -> usize {
        self.groups.iter().map(|g| g.len()).sum()
    }

    /// Repeat visits among them.
    pub fn repeat_pairs(&self) -> usize {
        self.groups[0].len()
    }

    /// Visit noise per axis \[mm\] of row residuals `res` (one row per data row).
    pub fn visit_sd(&self, res: &[[f64; 2]]) -> Result<[f64; 2], TooFew> {
        self.sd_of(|i, a| res[i][a])
    }

    /// Visit noise per axis \[mm\] of stacked residuals weighted by `w` (row `2 i + a`).
    pub fn visit_sd_stacked(&self, e: &DVector<f64>, w: [f64; 2]) -> Result<[f64; 2], TooFew> {
        self.sd_of(|i, a| e[2 * i + a] / w[a])
    }

    fn sd_of(&self, res: impl Fn(usize, usize) -> f64) -> Result<[f64; 2], TooFew> {
        let pairs = self.pairs();
        if pairs < MIN_PAIRS {
            return Err(TooFew {
                pairs,
                need: MIN_PAIRS,
            });
        }
        let means: Vec<[f64; 2]> = self
            .mean_rows
            .iter()
            .map(|rows| {
                let k = rows.len().max(1) as f64;
                let mut m = [0.0; 2];
                for &i in rows {
                    m[0] += res(i, 0) / k;
                    m[1] += res(i, 1) / k;
                }
                m
            })
            .collect();
        let mut visit = [0.0; 2];
        let mut d = Vec::with_capacity(pairs);
        for (a, out) in visit.iter_mut().enumerate() {
            // Each kind of neighbour centred on its own median (a trend along an input shifts
            // the differences of that kind alike), then one robust scale for all.
            d.clear();
            for g in &self.groups {
                let start = d.len();
                d.extend(g.iter().map(|&(u, v)| means[v][a] - means[u][a]));
                let med = median(&d[start..]);
                for x in &mut d[start..] {
                    *x -= med;
                }
            }
            let scale = if self.efficient {
                biweight_scale(&d)
            } else {
                mad0(&d)
            };
            *out = (scale / std::f64::consts::SQRT_2).max(1e-6);
        }
        Ok(visit)
    }
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

/// Tukey's biweight scale of values centred on 0 (the square root of the biweight
/// midvariance, tuning constant 9 median absolute values): a normal SD for normal values,
/// about 85 % efficient where the median absolute value is 37 % efficient, and as robust
/// (values beyond 9 median absolute values, about 6 SD, carry no weight).
fn biweight_scale(x: &[f64]) -> f64 {
    let mad = median(&x.iter().map(|v| v.abs()).collect::<Vec<_>>());
    if mad <= 0.0 {
        return 1.4826 * mad;
    }
    let (mut num, mut den) = (0.0, 0.0);
    for &v in x {
        let u = v / (9.0 * mad);
        if u.abs() < 1.0 {
            let u2 = u * u;
            num += v * v * (1.0 - u2).powi(4);
            den += (1.0 - u2) * (1.0 - 5.0 * u2);
        }
    }
    if den <= 0.0 {
        return 1.4826 * mad;
    }
    (x.len() as f64 * num).sqrt() / den
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

/// Whether a bootstrap p-value rejects at level `alpha`: p <= alpha. With the empirical
/// p = (1 + #{null >= obs}) / (1 + B) this is the exact Monte Carlo test (Besag and Clifford;
/// Davison and Hinkley, sec. 4.2.5): under the null the observed statistic is one of B + 1
/// exchangeable draws, so P(p <= alpha) = floor(alpha (B + 1)) / (B + 1), which is alpha
/// itself when alpha (B + 1) is a whole number (0.01 with 499 replicates). A strict
/// `p < alpha` would test at 4 / 500 = 0.008 there, not at the level the user set.
pub fn rejects(p: f64, alpha: f64) -> bool {
    p <= alpha
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
    fn the_biweight_scale_is_the_sd_of_normal_values_and_ignores_a_few_wild_ones() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let mut x: Vec<f64> = (0..4000)
            .map(|_| {
                let g: f64 = StandardNormal.sample(&mut rng);
                0.3 * g
            })
            .collect();
        let sd = biweight_scale(&x);
        assert!((sd / 0.3 - 1.0).abs() < 0.04, "{sd}");
        // Scatter over repeated small samples: the biweight's is well below the MAD's.
        let spread = |f: fn(&[f64]) -> f64| {
            let v: Vec<f64> = x.chunks(40).map(|c| f(c).ln()).collect();
            let m = v.iter().sum::<f64>() / v.len() as f64;
            (v.iter().map(|a| (a - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
        };
        assert!(spread(biweight_scale) < 0.8 * spread(mad0));
        // 5 % of the values 30 SDs out (a band spoiling a few neighbour differences).
        for v in x.iter_mut().step_by(20) {
            *v = 9.0;
        }
        let sd = biweight_scale(&x);
        assert!((sd / 0.3 - 1.0).abs() < 0.1, "{sd}");
    }

    #[test]
    fn bootstrap_p_is_empirical_inside_and_extrapolated_beyond() {
        let null: Vec<f64> = (0..99).map(|i| i as f64 / 10.0).collect();
        assert!((boot_p(5.0, &null) - 50.0 / 100.0).abs() < 1e-12);
        let far = boot_p(100.0, &null);
        assert!(far < 1e-6 && far > 0.0);
    }

    #[test]
    fn the_monte_carlo_test_has_the_level_the_user_set() {
        // Under the null the observed statistic is one more exchangeable draw: over every
        // rank it can take among 499 replicates, the share rejected is alpha = 0.01 exactly.
        let null: Vec<f64> = (0..499).map(|i| i as f64 + 0.5).collect();
        let rejected = (0..500)
            .filter(|&r| rejects(boot_p(r as f64, &null), 0.01))
            .count();
        assert_eq!(rejected, 5);
    }
}
