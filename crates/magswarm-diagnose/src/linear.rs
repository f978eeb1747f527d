//! Penalised linear models on top of the fitted model, refitted fold by fold: the engine of
//! the gap tests ([`super::detect`]) and of the selection of effects ([`super::attribute`]).
//!
//! Near the fitted model every question diagnose asks is linear: the baseline's free steady
//! parameters enter through their Jacobian J (finite differences of the model's predictions),
//! and a learned effect shape is a set of hat functions along the effect's axis whose heights
//! are unknowns ([`super::shapes`]). A *design* is J plus such columns and a penalty on them
//! (second differences of neighbouring knot heights: a smooth shape unless the data insist).
//!
//! Why linear: the acceptance of an effect and the gap tests are calibrated by a parametric
//! bootstrap (hundreds of logs simulated with the log's own design and noise structure, each
//! refitted exactly as the real one). Refitting nonlinear candidates hundreds of times does
//! not fit in seconds; a linear design's normal equations are factored once per fold, and a
//! refit on a simulated log is then a few matrix-vector products. The same code runs on the
//! real residuals and on the simulated ones, so the null distribution is that of the very
//! statistic reported.
//!
//! Rows are *stacked*: row `2 i + a` is axis `a` (r1, r2) of data row `i`, weighted by
//! `1 / sd_a` (so sums of squares are in units of the row noise).
//!
//! A block of coefficients may be **monotone** (the heights of a shape whose physics says it
//! only grows, or only runs one way: a drift, a cohesion loss past its onset). The fit is then
//! the penalised least-squares one with that block's heights projected onto monotone
//! sequences (pool-adjacent-violators, weighted by each height's information) and the other
//! coefficients refitted given them: one projection and one small solve, the same on the real
//! and on every simulated log, so the null distributions stay those of the statistic used.

use nalgebra::{DMatrix, DVector};

/// Simulated logs fitted together by the bootstrap ([`Solver::fits_batch`],
/// [`Solver::residual_batch`]): the products with the tall design are matrix products over
/// this many logs, which read the design once for all of them (a long log's diagnosis spends
/// most of its time in these products).
pub const BATCH: usize = 16;

/// Which way a monotone block's coefficients may run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Monotone {
    /// Non-decreasing.
    Up,
    /// Non-increasing.
    Down,
    /// Either, whichever fits better.
    Either,
}

/// A block of consecutive coefficients constrained to be monotone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MonoBlock {
    /// First coefficient.
    pub start: usize,
    /// Coefficients in the block.
    pub len: usize,
    /// Direction.
    pub dir: Monotone,
}

/// A design: weighted columns over the stacked rows, the penalty on its coefficients, and
/// the blocks of coefficients that must be monotone.
#[derive(Debug, Clone)]
pub struct Design {
    /// Columns, already weighted (stacked rows x coefficients).
    pub a: DMatrix<f64>,
    /// Penalty (coefficients x coefficients), added to the normal equations.
    pub pen: DMatrix<f64>,
    /// Monotone blocks.
    pub mono: Vec<MonoBlock>,
}

impl Design {
    /// A design without monotone blocks.
    pub fn new(a: DMatrix<f64>, pen: DMatrix<f64>) -> Design {
        Design {
            a,
            pen,
            mono: Vec::new(),
        }
    }

    /// Coefficients.
    pub fn cols(&self) -> usize {
        self.a.ncols()
    }

    /// This design with more columns (and their penalty block).
    pub fn extend(&self, more: &DMatrix<f64>, pen: &DMatrix<f64>) -> Design {
        self.append(&Design::new(more.clone(), pen.clone()))
    }

    /// This design with the columns, penalty and monotone blocks of `more`.
    pub fn append(&self, more: &Design) -> Design {
        let (n, p, q) = (self.a.nrows(), self.a.ncols(), more.a.ncols());
        let mut a = DMatrix::zeros(n, p + q);
        a.columns_mut(0, p).copy_from(&self.a);
        a.columns_mut(p, q).copy_from(&more.a);
        let mut pn = DMatrix::zeros(p + q, p + q);
        pn.view_mut((0, 0), (p, p)).copy_from(&self.pen);
        pn.view_mut((p, p), (q, q)).copy_from(&more.pen);
        let mut mono = self.mono.clone();
        mono.extend(more.mono.iter().map(|m| MonoBlock {
            start: m.start + p,
            ..*m
        }));
        Design { a, pen: pn, mono }
    }
}

/// Weighted least-squares projection of `h` onto non-decreasing sequences
/// (pool-adjacent-violators).
fn pava_up(h: &[f64], w: &[f64]) -> Vec<f64> {
    // Blocks of (mean, weight, count).
    let mut blocks: Vec<(f64, f64, usize)> = Vec::with_capacity(h.len());
    for (&x, &wi) in h.iter().zip(w) {
        let wi = wi.max(1e-12);
        blocks.push((x, wi, 1));
        while blocks.len() >= 2 && blocks[blocks.len() - 2].0 > blocks[blocks.len() - 1].0 {
            let b = blocks.pop().expect("two blocks");
            let a = blocks.last_mut().expect("one block");
            let wt = a.1 + b.1;
            *a = ((a.0 * a.1 + b.0 * b.1) / wt, wt, a.2 + b.2);
        }
    }
    blocks
        .iter()
        .flat_map(|&(m, _, c)| std::iter::repeat_n(m, c))
        .collect()
}

/// Weighted least-squares projection of `h` onto monotone sequences of direction `dir`.
pub fn project_monotone(h: &[f64], w: &[f64], dir: Monotone) -> Vec<f64> {
    let up = || pava_up(h, w);
    let down = || {
        let neg: Vec<f64> = h.iter().map(|x| -x).collect();
        pava_up(&neg, w).iter().map(|x| -x).collect::<Vec<f64>>()
    };
    match dir {
        Monotone::Up => up(),
        Monotone::Down => down(),
        Monotone::Either => {
            let (u, d) = (up(), down());
            let dist = |p: &[f64]| -> f64 {
                p.iter()
                    .zip(h)
                    .zip(w)
                    .map(|((a, b), wi)| wi * (a - b) * (a - b))
                    .sum()
            };
            if dist(&u) <= dist(&d) {
                u
            } else {
                d
            }
        }
    }
}

/// The solution of `g beta = b` (factored as `chol`) with the monotone blocks projected and
/// the other coefficients refitted given them.
fn solve_mono(
    fac: &nalgebra::Cholesky<f64, nalgebra::Dyn>,
    g: &DMatrix<f64>,
    b: &DVector<f64>,
    mono: &[MonoBlock],
) -> DVector<f64> {
    let mut beta = fac.solve(b);
    if mono.is_empty() {
        return beta;
    }
    let mut changed = false;
    let mut in_block = vec![false; beta.len()];
    for m in mono {
        let idx = m.start..m.start + m.len;
        let h: Vec<f64> = idx.clone().map(|j| beta[j]).collect();
        let w: Vec<f64> = idx.clone().map(|j| g[(j, j)]).collect();
        let p = project_monotone(&h, &w, m.dir);
        for (k, j) in idx.enumerate() {
            in_block[j] = true;
            if (p[k] - beta[j]).abs() > 1e-15 * (1.0 + beta[j].abs()) {
                changed = true;
            }
            beta[j] = p[k];
        }
    }
    if !changed {
        return beta;
    }
    let others: Vec<usize> = (0..beta.len()).filter(|&j| !in_block[j]).collect();
    if others.is_empty() {
        return beta;
    }
    let fixed: Vec<usize> = (0..beta.len()).filter(|&j| in_block[j]).collect();
    let g_oo = g.select_rows(&others).select_columns(&others);
    let g_of = g.select_rows(&others).select_columns(&fixed);
    let h = DVector::from_iterator(fixed.len(), fixed.iter().map(|&j| beta[j]));
    let rhs = DVector::from_iterator(others.len(), others.iter().map(|&j| b[j])) - g_of * h;
    if let Some(c) = chol(g_oo) {
        let bo = c.solve(&rhs);
        for (k, &j) in others.iter().enumerate() {
            beta[j] = bo[k];
        }
    }
    beta
}

/// Second-difference roughness penalty for `k` knot heights per axis (axis blocks of k
/// columns, r1's then r2's), scaled by `lambda`, plus a small ridge.
pub fn roughness(k: usize, blocks: usize, lambda: f64, ridge: f64) -> DMatrix<f64> {
    let p = k * blocks;
    let mut pen = DMatrix::identity(p, p) * ridge;
    for b in 0..blocks {
        for j in 1..k.saturating_sub(1) {
            let idx = [b * k + j - 1, b * k + j, b * k + j + 1];
            let c = [1.0, -2.0, 1.0];
            for (x, cx) in idx.iter().zip(c) {
                for (y, cy) in idx.iter().zip(c) {
                    pen[(*x, *y)] += lambda * cx * cy;
                }
            }
        }
    }
    pen
}

/// The normal equations of a design factored once for the full data and for each fold's
/// training rows.
pub struct Solver {
    a: DMatrix<f64>,
    /// Stacked rows of each fold.
    fold_rows: Vec<Vec<usize>>,
    /// Rows of each fold as a dense block.
    fold_a: Vec<DMatrix<f64>>,
    /// The whole design transposed, for [`Solver::residual_batch`] (`A^T Y` as a plain
    /// matrix product, which runs blocked and vectorised where a transposed product does
    /// not). Built on the first batch: a solver made for one log never needs it.
    at: std::sync::OnceLock<DMatrix<f64>>,
    full: nalgebra::Cholesky<f64, nalgebra::Dyn>,
    train: Vec<Option<nalgebra::Cholesky<f64, nalgebra::Dyn>>>,
    /// Monotone blocks, and (where there are any) the normal matrices of the full data and
    /// of each fold's training rows.
    mono: Vec<MonoBlock>,
    g_full: DMatrix<f64>,
    g_train: Vec<DMatrix<f64>>,
}

fn chol(m: DMatrix<f64>) -> Option<nalgebra::Cholesky<f64, nalgebra::Dyn>> {
    let scale = (0..m.nrows()).map(|i| m[(i, i)].abs()).fold(0.0, f64::max);
    let mut m = m;
    for i in 0..m.nrows() {
        m[(i, i)] += 1e-10 * scale.max(1e-300);
    }
    nalgebra::Cholesky::new(m)
}

impl Solver {
    /// Factor `d` for the full data and the folds (`fold_of_stacked[s]` < `k`). None when the
    /// full system is singular.
    pub fn new(d: &Design, fold_of_stacked: &[usize], k: usize) -> Option<Solver> {
        Solver::build(d, fold_of_stacked, k, |a| a.tr_mul(a))
    }

    /// [`Solver::new`] for a design found on a simulated log (a box, a band), whose fits
    /// only make a null distribution: `A_f^T A_f` as a plain product with the transposed
    /// block, blocked and vectorised, several times faster than the transposed product's
    /// dot products and the same to rounding (which moves no p-value). The real log's
    /// solvers keep the exact summation order of earlier releases, so that their reports
    /// are reproduced digit for digit: the library forms' nonlinear refits amplify
    /// rounding.
    pub fn for_simulated(d: &Design, fold_of_stacked: &[usize], k: usize) -> Option<Solver> {
        Solver::build(d, fold_of_stacked, k, |a| a.transpose() * a)
    }

    fn build(
        d: &Design,
        fold_of_stacked: &[usize],
        k: usize,
        gram: impl Fn(&DMatrix<f64>) -> DMatrix<f64>,
    ) -> Option<Solver> {
        let mut fold_rows = vec![Vec::new(); k];
        for (s, &f) in fold_of_stacked.iter().enumerate() {
            fold_rows[f].push(s);
        }
        let fold_a: Vec<DMatrix<f64>> = fold_rows.iter().map(|r| d.a.select_rows(r)).collect();
        let grams: Vec<DMatrix<f64>> = fold_a.iter().map(gram).collect();
        let mut g = d.pen.clone();
        for gf in &grams {
            g += gf;
        }
        let full = chol(g.clone())?;
        let train = grams.iter().map(|gf| chol(&g - gf)).collect();
        let mono = d.mono.clone();
        let g_train = if mono.is_empty() {
            Vec::new()
        } else {
            grams.iter().map(|gf| &g - gf).collect()
        };
        Some(Solver {
            a: d.a.clone(),
            fold_rows,
            fold_a,
            at: std::sync::OnceLock::new(),
            full,
            train,
            g_full: if mono.is_empty() {
                DMatrix::zeros(0, 0)
            } else {
                g
            },
            g_train,
            mono,
        })
    }

    /// Coefficients of the full-data fit of the weighted data `y`.
    pub fn coef(&self, y: &DVector<f64>) -> DVector<f64> {
        solve_mono(&self.full, &self.g_full, &self.a.tr_mul(y), &self.mono)
    }

    /// Weighted residual of the full-data fit.
    pub fn residual(&self, y: &DVector<f64>) -> DVector<f64> {
        y - &self.a * self.coef(y)
    }

    /// Withheld residual of every stacked row: each fold predicted by the fit on the others.
    pub fn cv_residual(&self, y: &DVector<f64>) -> DVector<f64> {
        let (ys, bs, b) = self.fold_products(y);
        self.cv_from(y, &ys, &bs, &b)
    }

    /// The full-data residual and the withheld one ([`Solver::residual`] and
    /// [`Solver::cv_residual`]) from one pass over the design: the bootstrap asks for both on
    /// every simulated log and variant, and the products with the tall design dominate a
    /// long log's diagnosis.
    pub fn fits(&self, y: &DVector<f64>) -> (DVector<f64>, DVector<f64>) {
        let (ys, bs, b) = self.fold_products(y);
        let beta = solve_mono(&self.full, &self.g_full, &b, &self.mono);
        (y - &self.a * beta, self.cv_from(y, &ys, &bs, &b))
    }

    /// [`Solver::fits`] for many weighted data at once (one per column of `y`): the products
    /// with the tall design become matrix products, which read the design once for all the
    /// columns instead of once per column. Column `j` of each result is what
    /// [`Solver::fits`] gives for column `j` of `y` (to rounding).
    pub fn fits_batch(&self, y: &DMatrix<f64>) -> (DMatrix<f64>, DMatrix<f64>) {
        let (ys, bs, b) = self.fold_products_batch(y);
        let beta = self.solve_batch(&self.full, &self.g_full, &b);
        (y - &self.a * beta, self.cv_batch_from(y, &ys, &bs, &b))
    }

    /// [`Solver::cv_residual`] for many weighted data at once, as matrix products.
    pub fn cv_batch(&self, y: &DMatrix<f64>) -> DMatrix<f64> {
        let (ys, bs, b) = self.fold_products_batch(y);
        self.cv_batch_from(y, &ys, &bs, &b)
    }

    /// [`Solver::fold_products`] for many weighted data at once.
    #[allow(clippy::type_complexity)]
    fn fold_products_batch(
        &self,
        y: &DMatrix<f64>,
    ) -> (Vec<DMatrix<f64>>, Vec<DMatrix<f64>>, DMatrix<f64>) {
        let ys: Vec<DMatrix<f64>> = self.fold_rows.iter().map(|r| y.select_rows(r)).collect();
        let bs: Vec<DMatrix<f64>> = self
            .fold_a
            .iter()
            .zip(&ys)
            .map(|(a, yf)| a.transpose() * yf)
            .collect();
        let mut b = DMatrix::zeros(self.a.ncols(), y.ncols());
        for bf in &bs {
            b += bf;
        }
        (ys, bs, b)
    }

    /// [`Solver::cv_from`] for many weighted data at once.
    fn cv_batch_from(
        &self,
        y: &DMatrix<f64>,
        ys: &[DMatrix<f64>],
        bs: &[DMatrix<f64>],
        b: &DMatrix<f64>,
    ) -> DMatrix<f64> {
        let mut cv = y.clone();
        let empty = DMatrix::zeros(0, 0);
        for f in 0..self.fold_rows.len() {
            if self.fold_rows[f].is_empty() {
                continue;
            }
            let Some(c) = &self.train[f] else { continue };
            let g = self.g_train.get(f).unwrap_or(&empty);
            let beta = self.solve_batch(c, g, &(b - &bs[f]));
            let e = &ys[f] - &self.fold_a[f] * beta;
            for (j, &s) in self.fold_rows[f].iter().enumerate() {
                cv.row_mut(s).copy_from(&e.row(j));
            }
        }
        cv
    }

    /// [`Solver::residual`] for many weighted data at once (one per column of `y`), as
    /// matrix products.
    pub fn residual_batch(&self, y: &DMatrix<f64>) -> DMatrix<f64> {
        let at = self.at.get_or_init(|| self.a.transpose());
        let beta = self.solve_batch(&self.full, &self.g_full, &(at * y));
        y - &self.a * beta
    }

    /// The normal equations factored as `c` (normal matrix `g`) solved for every column of
    /// `rhs`, the monotone blocks projected column by column.
    fn solve_batch(
        &self,
        c: &nalgebra::Cholesky<f64, nalgebra::Dyn>,
        g: &DMatrix<f64>,
        rhs: &DMatrix<f64>,
    ) -> DMatrix<f64> {
        if self.mono.is_empty() {
            c.solve(rhs)
        } else {
            let cols: Vec<DVector<f64>> = (0..rhs.ncols())
                .map(|j| solve_mono(c, g, &rhs.column(j).into_owned(), &self.mono))
                .collect();
            DMatrix::from_columns(&cols)
        }
    }

    /// Each fold's rows of `y`, each fold's `A_f^T y_f`, and their sum `A^T y`.
    #[allow(clippy::type_complexity)]
    fn fold_products(
        &self,
        y: &DVector<f64>,
    ) -> (Vec<DVector<f64>>, Vec<DVector<f64>>, DVector<f64>) {
        let ys: Vec<DVector<f64>> = self.fold_rows.iter().map(|r| y.select_rows(r)).collect();
        let bs: Vec<DVector<f64>> = self
            .fold_a
            .iter()
            .zip(&ys)
            .map(|(a, yf)| a.tr_mul(yf))
            .collect();
        let mut b = DVector::zeros(self.a.ncols());
        for bf in &bs {
            b += bf;
        }
        (ys, bs, b)
    }

    /// The withheld residual from the folds' products.
    fn cv_from(
        &self,
        y: &DVector<f64>,
        ys: &[DVector<f64>],
        bs: &[DVector<f64>],
        b: &DVector<f64>,
    ) -> DVector<f64> {
        let mut out = y.clone();
        for f in 0..self.fold_rows.len() {
            if self.fold_rows[f].is_empty() {
                continue;
            }
            let Some(c) = &self.train[f] else { continue };
            let bf = b - &bs[f];
            let beta = if self.mono.is_empty() {
                c.solve(&bf)
            } else {
                solve_mono(c, &self.g_train[f], &bf, &self.mono)
            };
            let e = &ys[f] - &self.fold_a[f] * beta;
            for (j, &s) in self.fold_rows[f].iter().enumerate() {
                out[s] = e[j];
            }
        }
        out
    }
}

/// Sum of squares of stacked residuals per axis.
pub fn sse_axes(e: &DVector<f64>) -> [f64; 2] {
    sse_axes_of(e.iter())
}

/// [`sse_axes`] of stacked residuals given in order (a column of a batch).
pub fn sse_axes_of<'a>(e: impl Iterator<Item = &'a f64>) -> [f64; 2] {
    let mut s = [0.0; 2];
    for (i, v) in e.enumerate() {
        s[i % 2] += v * v;
    }
    s
}

/// Sum of squares of stacked residuals per visit (both axes).
pub fn sse_visits(e: &DVector<f64>, visit_of_row: &[usize], nv: usize) -> Vec<f64> {
    let mut s = vec![0.0; nv];
    for (i, v) in e.iter().enumerate() {
        s[visit_of_row[i / 2]] += v * v;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn design(n: usize) -> (Design, Vec<usize>) {
        // Intercept and slope over 0..1, both unpenalised.
        let a = DMatrix::from_fn(2 * n, 2, |s, c| {
            let x = (s / 2) as f64 / n as f64;
            if c == 0 {
                1.0
            } else {
                x
            }
        });
        let folds = (0..2 * n).map(|s| (s / 2) % 4).collect();
        (Design::new(a, DMatrix::zeros(2, 2)), folds)
    }

    /// The bootstrap fits its simulated logs a batch at a time: each column of a batch must
    /// come out as that log fitted alone, in and out of sample, with and without a monotone
    /// block (whose projection is done column by column); so must a simulated log's solver.
    #[test]
    fn a_batch_of_logs_is_fitted_as_each_log_alone() {
        let (d, folds) = design(30);
        // Four hat columns over the rows beside the line (a shape whose heights may be held
        // monotone).
        let hats = DMatrix::from_fn(60, 4, |s, c| {
            let x = 3.0 * (s / 2) as f64 / 30.0;
            (1.0 - (x - c as f64).abs()).max(0.0)
        });
        let ys: Vec<DVector<f64>> = (0..5)
            .map(|k| {
                DVector::from_fn(60, |i, _| {
                    let x = (i / 2) as f64;
                    (0.7 * x + k as f64).sin() + 0.1 * k as f64 * x / 30.0
                })
            })
            .collect();
        let ym = DMatrix::from_columns(&ys);
        for mono in [false, true] {
            let mut more = Design::new(hats.clone(), DMatrix::identity(4, 4) * 1e-3);
            if mono {
                more.mono = vec![MonoBlock {
                    start: 0,
                    len: 4,
                    dir: Monotone::Either,
                }];
            }
            let s = Solver::new(&d.append(&more), &folds, 4).unwrap();
            // A simulated log's solver (the Gram matrices by a blocked product) fits the
            // same, to rounding.
            let fast = Solver::for_simulated(&d.append(&more), &folds, 4).unwrap();
            let (r, cv) = s.fits_batch(&ym);
            let rb = s.residual_batch(&ym);
            let cvb = s.cv_batch(&ym);
            for (j, y) in ys.iter().enumerate() {
                let (r1, cv1) = s.fits(y);
                assert!((r.column(j) - &r1).norm() < 1e-10, "mono {mono}, log {j}");
                assert!((cv.column(j) - &cv1).norm() < 1e-10, "mono {mono}, log {j}");
                assert!((&r1 - s.residual(y)).norm() < 1e-10);
                assert!((rb.column(j) - &r1).norm() < 1e-10);
                assert!((cvb.column(j) - &cv1).norm() < 1e-10);
                let (r2, cv2) = fast.fits(y);
                assert!((&r2 - &r1).norm() < 1e-10 && (&cv2 - &cv1).norm() < 1e-10);
                assert!((&cv1 - s.cv_residual(y)).norm() < 1e-10);
            }
        }
    }

    #[test]
    fn exact_line_is_fitted_in_and_out_of_sample() {
        let (d, folds) = design(40);
        let s = Solver::new(&d, &folds, 4).unwrap();
        let y = DVector::from_fn(80, |i, _| 2.0 + 3.0 * (i / 2) as f64 / 40.0);
        assert!(s.residual(&y).norm() < 1e-8);
        assert!(s.cv_residual(&y).norm() < 1e-8);
        let b = s.coef(&y);
        assert!((b[0] - 2.0).abs() < 1e-8 && (b[1] - 3.0).abs() < 1e-8);
    }

    #[test]
    fn withheld_error_exceeds_in_sample_error_on_noise() {
        let (d, folds) = design(40);
        let s = Solver::new(&d, &folds, 4).unwrap();
        // A deterministic zig-zag standing in for noise.
        let y = DVector::from_fn(80, |i, _| if (i / 2) % 3 == 0 { 1.0 } else { -0.5 });
        let ins = sse_axes(&s.residual(&y));
        let cv = sse_axes(&s.cv_residual(&y));
        assert!(cv[0] > ins[0] && cv[1] > ins[1]);
    }

    #[test]
    fn monotone_projection_pools_violators_and_picks_the_closer_direction() {
        let w = [1.0; 4];
        assert_eq!(pava_up(&[1.0, 3.0, 2.0, 4.0], &w), vec![1.0, 2.5, 2.5, 4.0]);
        let d = project_monotone(&[4.0, 1.0, 2.0, 0.0], &w, Monotone::Either);
        assert!(d.windows(2).all(|p| p[0] >= p[1]), "{d:?}");
        let u = project_monotone(&[4.0, 1.0, 2.0, 0.0], &w, Monotone::Up);
        assert!(u.windows(2).all(|p| p[0] <= p[1]), "{u:?}");
        // A monotone block of a line fit stays as it is.
        let (d, folds) = design(40);
        let mut d = d;
        d.mono = vec![MonoBlock {
            start: 0,
            len: 2,
            dir: Monotone::Up,
        }];
        let s = Solver::new(&d, &folds, 4).unwrap();
        let y = DVector::from_fn(80, |i, _| 2.0 + 3.0 * (i / 2) as f64 / 40.0);
        let b = s.coef(&y);
        assert!((b[0] - 2.0).abs() < 1e-8 && (b[1] - 3.0).abs() < 1e-8);
    }

    #[test]
    fn roughness_leaves_lines_free() {
        let pen = roughness(5, 2, 10.0, 0.0);
        let line = DVector::from_fn(10, |i, _| {
            (i % 5) as f64 * 0.7 + if i < 5 { 1.0 } else { -2.0 }
        });
        assert!((line.transpose() * &pen * &line)[(0, 0)].abs() < 1e-9);
        let kink = DVector::from_fn(10, |i, _| if i == 2 { 1.0 } else { 0.0 });
        assert!((kink.transpose() * &pen * &kink)[(0, 0)] > 1.0);
    }
}
