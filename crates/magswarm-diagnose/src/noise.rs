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
    /// Lag-1 correlation of successive rows of a visit (AR(1) by row): a camera's filter,
    /// the swarm's own slow wobble. Rows that follow each other are not independent draws,
    /// and a shape within a visit fitted to such noise finds structure that iid noise would
    /// not give it.
    pub ar: [f64; 2],
    /// How well the log fixes `ar`, per axis.
    pub ar_evidence: [RowEvidence; 2],
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
    // Row noise: successive differences of settled rows within a visit (a visit's offset and
    // a slow transient cancel); their correlation from the likelihood of the differences
    // within each visit (`row_correlation`).
    let mut within = [0.0; 2];
    let mut ar = [0.0; 2];
    let mut ar_evidence = [RowEvidence::default(); 2];
    let mut settled_n = 0usize;
    for a in 0..2 {
        let mut d1 = Vec::new();
        let mut runs = Vec::with_capacity(ds.visits.len());
        for v in 0..ds.visits.len() {
            let rows = ds.settled_rows(v);
            if a == 0 {
                settled_n += rows.len().max(1);
            }
            let e: Vec<f64> = rows.iter().map(|&i| res[i][a]).collect();
            for w in e.windows(2) {
                d1.push(w[1] - w[0]);
            }
            runs.push(e);
        }
        if d1.len() < 10 {
            continue;
        }
        (ar[a], ar_evidence[a]) = row_correlation(&runs);
        within[a] = mad0(&d1) / (2.0 * (1.0 - ar[a])).sqrt();
    }
    let rows_per_visit = settled_n as f64 / ds.visits.len().max(1) as f64;
    let rough = Roughness::new(ds);
    let visit = rough.visit_sd(res)?;
    let mut between = [0.0; 2];
    for a in 0..2 {
        let part = within[a].powi(2) * mean_factor(ar[a], rows_per_visit) / rows_per_visit.max(1.0);
        between[a] = (visit[a].powi(2) - part).max(0.1 * visit[a].powi(2)).sqrt();
    }
    Ok(Noise {
        within,
        ar,
        ar_evidence,
        visit,
        between,
        rows_per_visit,
        pairs: rough.pairs(),
        repeat_pairs: rough.repeat_pairs(),
    })
}

/// Differences needed to estimate the rows' correlation (below it: independent rows).
const MIN_DIFFS: usize = 20;

/// Largest row correlation believed: beyond it a visit's rows are one slow course, which is
/// structure for the tests to find, not noise to calibrate them against.
const MAX_AR: f64 = 0.9;

/// Longest run of a visit's rows one block of the likelihood covers (a streamed visit of a
/// hundred rows is cut into blocks: the few correlations across a cut are all it loses).
const AR_BLOCK: usize = 40;

/// Rows a block needs for its slope to be taken out (second differences); shorter blocks
/// keep it (first differences, the slope a random effect).
const AR_DETREND: usize = 16;

/// A difference this many robust SDs out (of differences of its kind) marks its block as
/// holding a wild row (an unflagged tracker glitch), and the block is left out.
const AR_WILD: f64 = 4.0;

/// Likelihood-ratio statistic (twice the log-likelihood gain over independent rows) a
/// correlation must reach to be kept: the 5 % point of the one-sided test at the boundary.
pub const AR_KEEP: f64 = 2.71;

/// A correlation the log cannot exclude while reading 0 that makes the report say the rows'
/// correlation is poorly determined. (Simulated, 0.3 is kept on 11 of 40 logs of 25 five-row
/// visits, 31 of 40 with 100 such visits, 40 of 40 with 100 ten-row visits.)
pub const AR_UNSURE: f64 = 0.3;

/// How well a log fixes the rows' correlation along one axis.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RowEvidence {
    /// Differences within visits the correlation was read from.
    pub diffs: usize,
    /// Likelihood-ratio statistic of the best correlation against independent rows (kept
    /// from [`AR_KEEP`]).
    pub lr: f64,
    /// Largest correlation the log cannot tell from its best one (one-sided 95 %, the same
    /// likelihood ratio): where the kept correlation is 0 and this is [`AR_UNSURE`] or more,
    /// the log cannot tell independent rows from correlated ones.
    pub upper: f64,
}

/// Lag-1 correlation of a visit's successive rows (AR(1) by row), from each visit's settled
/// residuals in time order (`runs`), by restricted maximum likelihood of their differences
/// within a visit, in which the visit's offset cancels.
///
/// Why the whole likelihood rather than a ratio of two variances: on designs with a handful
/// of settled rows per visit (a grid visited once or twice, a spread grid, a Latin
/// hypercube) the rows' correlation is spread over every pair of differences of a visit. A
/// ratio of second differences at lags 2 and 1, which needs five rows per term, read 0 there
/// on rows correlated 0.3-0.6 (and 0.9 on others); the simulated logs then carried
/// independent rows, and the within-visit tests read the real ones' correlation as
/// structure.
///
/// A swarm still settling through a visit must not read as correlated rows (the project's
/// own lab, whose rows are independent, read up to 0.9 from first differences alone). In a
/// long block (at least [`AR_DETREND`] rows, a streamed step) second differences cancel the
/// slope and enough of them remain to fix the correlation. In a short block, removing each
/// visit's slope leaves two or three contrasts whose mutual correlations hardly move with the
/// rows' correlation (-0.67 to -0.51 between 0 and 0.8 for five rows); there the first
/// differences are kept and each visit's slope is a random effect (a shift shared by all of
/// the visit's differences, its variance profiled out beside the row variance), so that
/// slopes are told from correlation by the shape of the differences' covariance rather than
/// by removing them.
///
/// Kept only where it beats independent rows by a likelihood-ratio test at 5 %
/// ([`AR_KEEP`]): independent rows read a little above 0 by chance, and a null that carried
/// that chance correlation would blunt every test within a visit for nothing. Blocks with a
/// wild difference ([`AR_WILD`] robust SDs), or a residual that is not a number, are left
/// out.
/// Returns the correlation kept (0 where the test does not keep it) and its evidence.
fn row_correlation(runs: &[Vec<f64>]) -> (f64, RowEvidence) {
    // (second differences?, differences) per block.
    let mut blocks: Vec<(bool, Vec<f64>)> = runs
        .iter()
        .flat_map(|e| e.chunks(AR_BLOCK))
        .filter(|c| c.len() >= 3 && c.iter().all(|v| v.is_finite()))
        .map(|c| {
            if c.len() >= AR_DETREND {
                (
                    true,
                    c.windows(3).map(|w| w[2] - 2.0 * w[1] + w[0]).collect(),
                )
            } else {
                (false, c.windows(2).map(|w| w[1] - w[0]).collect())
            }
        })
        .collect();
    for kind in [false, true] {
        let all: Vec<f64> = blocks
            .iter()
            .filter(|b| b.0 == kind)
            .flat_map(|b| b.1.iter().copied())
            .collect();
        let s = biweight_scale(&all);
        if all.len() >= 3 && s > 0.0 {
            blocks.retain(|b| b.0 != kind || b.1.iter().all(|v| v.abs() <= AR_WILD * s));
        }
    }
    let n: usize = blocks.iter().map(|b| b.1.len()).sum();
    let none = (
        0.0,
        RowEvidence {
            diffs: n,
            ..RowEvidence::default()
        },
    );
    if n < MIN_DIFFS {
        return none;
    }
    // Restricted log-likelihood at correlation `phi` and slope variance `lam`, the row
    // variance profiled out.
    let loglik = |phi: f64, lam: f64| -> Option<f64> {
        // Covariances of differences k apart, per unit row variance: first, second.
        let r = |k: i64| phi.powi(k.unsigned_abs() as i32);
        let cov = |second: bool, k: i64| {
            if second {
                6.0 * r(k) - 4.0 * (r(k + 1) + r(k - 1)) + r(k + 2) + r(k - 2)
            } else {
                2.0 * r(k) - r(k + 1) - r(k - 1)
            }
        };
        let mut chol: std::collections::BTreeMap<(bool, usize), (nalgebra::DMatrix<f64>, f64)> =
            Default::default();
        let (mut q, mut logdet) = (0.0, 0.0);
        for (second, b) in &blocks {
            let key = (*second, b.len());
            if let std::collections::btree_map::Entry::Vacant(slot) = chol.entry(key) {
                let m = b.len();
                let l = nalgebra::DMatrix::from_fn(m, m, |i, j| {
                    cov(*second, i.abs_diff(j) as i64) + if *second { 0.0 } else { lam }
                })
                .cholesky()?
                .unpack();
                let ld = 2.0 * l.diagonal().iter().map(|d| d.ln()).sum::<f64>();
                slot.insert((l, ld));
            }
            let (l, ld) = &chol[&key];
            let z = l.solve_lower_triangular(&DVector::from_column_slice(b))?;
            q += z.norm_squared();
            logdet += ld;
        }
        (q > 0.0).then(|| -0.5 * (n as f64 * (q / n as f64).ln() + logdet))
    };
    // The variance of a short visit's slope (per row, relative to the row variance): none,
    // or 1e-3 to 10 on a log grid, the best one for each correlation (none to choose where
    // every block is long).
    let lams: Vec<f64> = if blocks.iter().any(|b| !b.0) {
        std::iter::once(0.0)
            .chain((0..16).map(|k| 10f64.powf(-3.0 + 4.0 * k as f64 / 15.0)))
            .collect()
    } else {
        vec![0.0]
    };
    let profile = |phi: f64| -> Option<f64> {
        lams.iter()
            .filter_map(|&lam| loglik(phi, lam))
            .max_by(f64::total_cmp)
    };
    let Some(at0) = profile(0.0) else { return none };
    let grid: Vec<(f64, f64)> = std::iter::once((0.0, at0))
        .chain((1..=45).filter_map(|k| {
            let phi = MAX_AR * k as f64 / 45.0;
            profile(phi).map(|l| (phi, l))
        }))
        .collect();
    let best = grid
        .iter()
        .copied()
        .fold((0.0, at0), |b, x| if x.1 > b.1 { x } else { b });
    let upper = grid
        .iter()
        .filter(|x| 2.0 * (best.1 - x.1) < AR_KEEP)
        .map(|x| x.0)
        .fold(0.0, f64::max);
    let lr = 2.0 * (best.1 - at0);
    log::debug!(
        "row correlation {:.2} from {n} differences in {} blocks (likelihood ratio {lr:.1})",
        best.0,
        blocks.len(),
    );
    (
        if lr >= AR_KEEP { best.0 } else { 0.0 },
        RowEvidence {
            diffs: n,
            lr,
            upper,
        },
    )
}

/// Variance of the mean of `n` AR(1) rows with correlation `phi` relative to `n`
/// independent ones: 1 + 2 sum_k (1 - k/n) phi^k.
fn mean_factor(phi: f64, n: f64) -> f64 {
    let n = n.max(1.0);
    let m = n.floor() as usize;
    1.0 + 2.0
        * (1..m)
            .map(|k| (1.0 - k as f64 / n) * phi.powi(k as i32))
            .sum::<f64>()
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
                let med = stats::median(&d[start..]);
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

/// Tukey's biweight scale of values centred on 0 (the square root of the biweight
/// midvariance, tuning constant 9 median absolute values): a normal SD for normal values,
/// about 85 % efficient where the median absolute value is 37 % efficient, and as robust
/// (values beyond 9 median absolute values, about 6 SD, carry no weight).
fn biweight_scale(x: &[f64]) -> f64 {
    let mad = stats::median(&x.iter().map(|v| v.abs()).collect::<Vec<_>>());
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
    1.4826 * stats::median(&a)
}

/// A simulated log of pure noise with the data's structure: weighted stacked rows
/// (`w[a] x (visit offset + row noise)`, the row noise AR(1) along each visit's rows with the
/// log's correlation), replicate `rep` of the stream `seed`.
pub fn simulate(ds: &Dataset, nz: &Noise, w: [f64; 2], seed: u64, rep: usize) -> DVector<f64> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(
        seed ^ 0x5EED_B007 ^ (rep as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
    );
    let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
    let off: Vec<[f64; 2]> = (0..ds.visits.len())
        .map(|_| [g() * nz.between[0], g() * nz.between[1]])
        .collect();
    let innov = nz.ar.map(|p| (1.0 - p * p).sqrt());
    // The previous row's noise of each visit (rows of a visit come in time order).
    let mut prev: Vec<Option<[f64; 2]>> = vec![None; ds.visits.len()];
    let mut y = DVector::zeros(2 * ds.rows.len());
    for (i, r) in ds.rows.iter().enumerate() {
        let mut e = [0.0; 2];
        for a in 0..2 {
            let z = g() * nz.within[a];
            e[a] = match prev[r.visit] {
                Some(p) => nz.ar[a] * p[a] + innov[a] * z,
                None => z,
            };
            y[2 * i + a] = w[a] * (off[r.visit][a] + e[a]);
        }
        prev[r.visit] = Some(e);
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
    // Never exactly 0 (the tail underflows far out): a p-value of 0 reads as certainty.
    stats::gamma_q(k, (obs - lo) / theta)
        .min(emp)
        .max(f64::MIN_POSITIVE)
}

/// The p-value of every replicate, read exactly as the observed statistic's is read by
/// [`boot_p`]: against the other draws of the exchangeable set (the other replicates and the
/// observed one), with the same extrapolated tail where a replicate lies beyond all of them.
///
/// Why: a min-p over several alternatives (Westfall and Young) compares the observed smallest
/// p with each replicate's smallest p. Read against the whole null including itself, a
/// replicate's p never falls below 1 / (1 + B), while the observed one, extrapolated beyond
/// every replicate, does: then an observed statistic beyond every replicate of any one of K
/// alternatives (a chance of about K / (1 + B) under the null) gave the smallest p of all.
/// With 30 to 50 alternatives that was a gap declared on 5 % of null logs at alpha = 0.01.
pub fn replicate_ps(obs: f64, null: &[f64]) -> Vec<f64> {
    let b = null.len();
    let key = |v: f64| if v.is_nan() { f64::NEG_INFINITY } else { v };
    let mut sorted: Vec<f64> = null.iter().map(|&v| key(v)).collect();
    sorted.sort_by(f64::total_cmp);
    let obs = key(obs);
    null.iter()
        .enumerate()
        .map(|(r, &x)| {
            if x.is_nan() {
                return 1.0;
            }
            // Replicates at or above x, less x itself, and the observed one if it is.
            let ge = b - sorted.partition_point(|&v| v < x) - 1 + usize::from(obs >= x);
            if ge > 0 || b < 20 {
                return (1 + ge) as f64 / (1 + b) as f64;
            }
            let others: Vec<f64> = null
                .iter()
                .enumerate()
                .filter(|&(q, _)| q != r)
                .map(|(_, &v)| key(v))
                .chain(std::iter::once(obs))
                .filter(|v| v.is_finite())
                .collect();
            boot_p(x, &others)
        })
        .collect()
}

/// Min-p over alternatives (Westfall and Young): the share of the exchangeable draws (the
/// observed one and its replicates) whose smallest p over the alternatives, each read by
/// [`boot_p`] against the other draws ([`replicate_ps`]), is as small as the observed one's.
/// `obs_p[j]` is the observed p of alternative j, `rep_p[j][r]` replicate r's. Beyond every
/// replicate, the observed smallest p times the alternatives (Bonferroni), never above
/// 1 / (1 + B). Returns the calibrated p and each replicate's smallest p.
pub fn min_p<C: AsRef<[f64]>>(obs_p: &[f64], rep_p: &[C]) -> (f64, Vec<f64>) {
    let b = rep_p.first().map_or(0, |c| c.as_ref().len());
    let best = obs_p.iter().copied().fold(1.0f64, f64::min);
    let rep_min: Vec<f64> = (0..b)
        .map(|r| {
            rep_p
                .iter()
                .map(|col| col.as_ref()[r])
                .fold(1.0f64, f64::min)
        })
        .collect();
    (adjusted(best, &rep_min, obs_p.len() as f64), rep_min)
}

/// Values of the replicates that could be evaluated (`by_rep[b]` is Some), in order, put back
/// at their replicate numbers (NaN for the others): so that two calibrations run on the same
/// simulated logs (the gap tests and a round's candidates) can be paired replicate by
/// replicate.
pub fn by_replicate_number<T>(by_rep: &[Option<T>], vals: &[f64]) -> Vec<f64> {
    let mut vals = vals.iter();
    by_rep
        .iter()
        .map(|r| match r {
            Some(_) => vals.next().copied().unwrap_or(f64::NAN),
            None => f64::NAN,
        })
        .collect()
}

/// The min-p adjusted p-value (Westfall and Young, single step) of a raw p-value `q` in a
/// family of `k` statistics whose replicates' smallest p-values are `rep_min`: the share of
/// the exchangeable draws whose smallest p is as small; beyond every replicate, `q k`
/// (Bonferroni; with weights, `k` is the sum over the statistics of the ratio of each one's
/// weight to the one judged), never above 1 / (1 + B). Any statistic of the family adjusted this way
/// rejects at `alpha` with probability at most `alpha` under the null, however the one
/// judged is chosen.
pub fn adjusted(q: f64, rep_min: &[f64], k: f64) -> f64 {
    let b = rep_min.len();
    let le = rep_min.iter().filter(|&&m| m <= q).count();
    let emp = (1 + le) as f64 / (1 + b) as f64;
    if le == 0 {
        (q * k.max(1.0)).min(emp)
    } else {
        emp
    }
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

    /// A `side` x `side` grid visited once, `n` rows a visit, every row settled.
    fn grid(side: usize, n: usize) -> Dataset {
        use crate::data::{DRow, Visit};
        let (mut rows, mut visits, mut points) = (Vec::new(), Vec::new(), Vec::new());
        for iz in 0..side {
            for jf in 0..side {
                let (v, z, f) = (visits.len(), 3.5 + 4.0 * iz as f64, 1.0 + 1.8 * jf as f64);
                points.push((z, f));
                let first = rows.len();
                for k in 0..n {
                    rows.push(DRow {
                        sess: 0,
                        visit: v,
                        point: v,
                        t: 30.0 * v as f64 + k as f64,
                        since: 20.0 + k as f64,
                        dt: 1.0,
                        z,
                        f,
                        r: [0.0; 2],
                        settled: true,
                        trans: [0.0; 2],
                        frac: [f64::NAN; 2],
                        line: rows.len() + 2,
                    });
                }
                visits.push(Visit {
                    sess: 0,
                    point: v,
                    rows: (first..rows.len()).collect(),
                    t_mid: 30.0 * v as f64 + 10.0,
                    prev: v.checked_sub(1),
                });
            }
        }
        Dataset {
            rows_total: rows.len(),
            rows,
            visits,
            points,
            sessions: vec!["s".into()],
        }
    }

    /// A camera whose rows follow each other (AR(1), 0.6) is read as such, with the row SD
    /// it has, and the simulated logs carry the same correlation; independent rows read 0,
    /// also where the swarm is still settling through the visit (a slope of one row SD per
    /// row, which cancels in second differences and, on short visits, goes to the slope's
    /// random effect). On a grid of five-row visits (a grid visited twice, a spread grid) a
    /// correlation of 0.4 is read too, where a ratio of lag-2 to lag-1 second differences
    /// read 0.
    #[test]
    fn correlated_rows_are_estimated_and_simulated_as_correlated() {
        let truth = |ar: f64, n: usize| Noise {
            within: [0.1, 0.2],
            ar: [ar, ar],
            ar_evidence: Default::default(),
            visit: [0.15, 0.25],
            between: [0.1, 0.2],
            rows_per_visit: n as f64,
            pairs: 0,
            repeat_pairs: 0,
        };
        for (n, ar, slope, lo, hi) in [
            (20, 0.6, 0.0, 0.5, 0.7),
            (20, 0.0, 0.0, 0.0, 0.08),
            (20, 0.0, 0.1, 0.0, 0.08),
            (5, 0.4, 0.0, 0.3, 0.5),
            (5, 0.0, 0.0, 0.0, 0.08),
            (5, 0.0, 0.1, 0.0, 0.08),
        ] {
            // Long visits on a 6 x 6 grid; five-row ones on 100 operating points (the
            // seed's 50 visited twice has as many visits).
            let ds = if n >= 20 { grid(6, n) } else { grid(10, n) };
            let mut got = Vec::new();
            for rep in 0..8 {
                let y = simulate(&ds, &truth(ar, n), [1.0, 1.0], 3, rep);
                let res: Vec<[f64; 2]> = (0..ds.rows.len())
                    .map(|i| {
                        let k = (i % n) as f64;
                        [y[2 * i] + slope * k, y[2 * i + 1] + 2.0 * slope * k]
                    })
                    .collect();
                got.push(estimate(&ds, &res).expect("enough pairs"));
            }
            for a in 0..2 {
                // The typical log (the median of 8): on five-row visits an odd one does not
                // clear the likelihood-ratio test and reads 0.
                let phi = stats::median(&got.iter().map(|n| n.ar[a]).collect::<Vec<_>>());
                let sd = got.iter().map(|n| n.within[a]).sum::<f64>() / 8.0;
                assert!((lo..=hi).contains(&phi), "{n} rows, ar {ar}: read {phi}");
                let want = truth(ar, n).within[a];
                // (A slope adds to every successive difference: the row SD is read on
                // settled rows, as it always was.)
                assert!(
                    slope > 0.0 || (sd / want - 1.0).abs() < 0.12,
                    "{n} rows, ar {ar}: row SD {sd} for {want}"
                );
            }
        }
    }

    /// Rows a camera quantises (radii to 0.1 mm), rows that never change, a residual that
    /// is not a number, no rows at all: the correlation is read or is 0, never a failure,
    /// and a run that is not a number costs only its own block.
    #[test]
    fn degenerate_rows_give_a_correlation_and_no_failure() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
        let ar = |g: &mut dyn FnMut() -> f64, n: usize, phi: f64| -> Vec<f64> {
            let mut x = g();
            (0..n)
                .map(|_| {
                    x = phi * x + (1.0 - phi * phi).sqrt() * g();
                    x
                })
                .collect()
        };
        assert_eq!(row_correlation(&[]).0, 0.0);
        assert_eq!(row_correlation(&vec![vec![1.0; 8]; 50]).0, 0.0);
        let runs: Vec<Vec<f64>> = (0..100).map(|_| ar(&mut g, 8, 0.5)).collect();
        let clean = row_correlation(&runs);
        assert!((0.35..=0.65).contains(&clean.0), "{clean:?}");
        let quantised: Vec<Vec<f64>> = runs
            .iter()
            .map(|r| r.iter().map(|v| (v * 1.5).round() / 1.5).collect())
            .collect();
        let q = row_correlation(&quantised);
        assert!((0.3..=0.7).contains(&q.0), "{q:?}");
        let mut broken = runs.clone();
        broken[3][2] = f64::NAN;
        let b = row_correlation(&broken);
        assert_eq!(b.1.diffs + 7, clean.1.diffs, "{b:?}");
        assert!((b.0 - clean.0).abs() <= 0.1, "{b:?}");
    }

    #[test]
    fn bootstrap_p_is_empirical_inside_and_extrapolated_beyond() {
        let null: Vec<f64> = (0..99).map(|i| i as f64 / 10.0).collect();
        assert!((boot_p(5.0, &null) - 50.0 / 100.0).abs() < 1e-12);
        let far = boot_p(100.0, &null);
        assert!(far < 1e-6 && far > 0.0);
    }

    /// Twenty alternatives of pure noise: a fresh draw of all twenty (the observed log under
    /// the null) is beyond every replicate of some alternative about 20 / 500 of the time.
    /// Read with the replicates' p-values capped at 1 / 500 while the observed one is
    /// extrapolated, each such draw rejected (about 4 % at alpha = 0.01); read alike, the
    /// min-p rejects at the level set.
    #[test]
    fn min_p_over_many_alternatives_has_the_level_the_user_set() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
        let k = 20;
        let null: Vec<Vec<f64>> = (0..k).map(|_| (0..499).map(|_| g()).collect()).collect();
        let trials = 1000;
        let rejected = (0..trials)
            .filter(|_| {
                let obs: Vec<f64> = (0..k).map(|_| g()).collect();
                let obs_p: Vec<f64> = (0..k).map(|j| boot_p(obs[j], &null[j])).collect();
                let rep_p: Vec<Vec<f64>> = (0..k).map(|j| replicate_ps(obs[j], &null[j])).collect();
                rejects(min_p(&obs_p, &rep_p).0, 0.01)
            })
            .count();
        // 10 expected; binomial SD 3.
        assert!(
            (2..=20).contains(&rejected),
            "{rejected} of {trials} at 0.01"
        );
        // A draw far beyond every replicate of one alternative is still strong evidence.
        let mut obs = vec![0.0; k];
        obs[3] = 8.0;
        let obs_p: Vec<f64> = (0..k).map(|j| boot_p(obs[j], &null[j])).collect();
        let rep_p: Vec<Vec<f64>> = (0..k).map(|j| replicate_ps(obs[j], &null[j])).collect();
        let (p, rep_min) = min_p(&obs_p, &rep_p);
        assert!(p < 1e-3, "{p}");
        assert_eq!(rep_min.len(), 499);
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
