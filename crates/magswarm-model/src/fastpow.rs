//! `x^e` for the model's non-integer exponents (gamma_i, rho, mu_P, q_P, q, alpha_i), faster
//! than libm's `pow` and within a proven relative error.
//!
//! Every input change evaluates eight such powers (stiffness (7), frequency terms (6), map
//! (5)); libm's correctly-rounded-ish `pow` costs about 120 instructions each, which made
//! them the largest part of an FMU step with a new input. Here a power is a table lookup
//! and a cubic:
//!
//! ```text
//! x = m 2^k,  m in [1, 2)   =>   x^e = m^e 2^(e k)
//! ```
//!
//! `2^(e k)` comes from a table over the binary exponent k (computed once with `powf`), and
//! `m^e` from a cubic Hermite interpolant on N = 512 uniform cells of [1, 2], built from the
//! exact values and slopes `m^e`, `e m^(e-1)` at the 513 nodes.
//!
//! # The error bound (a proof, not a measurement)
//!
//! On a cell [a, b] of width h the cubic Hermite interpolant p of a C^4 function f satisfies
//! `f(m) - p(m) = f''''(xi) (m - a)^2 (m - b)^2 / 4!` for some xi in the cell (the
//! interpolation remainder with double nodes), and `(m - a)^2 (m - b)^2 <= h^4 / 16`, so
//! `|f - p| <= h^4 / 384 max |f''''|`. For `f(m) = m^e`,
//! `f''''(m) = e (e-1) (e-2) (e-3) m^(e-4)`, whose magnitude is monotone in m (a power), so
//! its maximum on the cell is at an end: `max(a^(e-4), b^(e-4))`. Dividing by the smallest
//! value of f on the cell, `min(a^e, b^e)`, bounds the relative error of the interpolant on
//! that cell; [`PowTable::interp_bound`] is the largest over the 512 cells, computed when
//! the table is built. To it add the rounding of the evaluation (`eps = 2^-52`): the node
//! values are within an ulp of exact (`powf`); the cubic's coefficients are differences of
//! them, each off by a few ulps of `m^e`, and its Horner evaluation with the local
//! coordinate in [0, 1) adds three more, so the cubic is within 10 ulps of the interpolant;
//! the scale `2^(e k)` is `powf(2, e k)` of a rounded product `e k`, off by at most
//! `ln 2 |e k| eps / 2` plus an ulp, and the final product adds one:
//! [`PowTable::bound`] is the interpolation bound plus `(12 + 0.35 |e| 64) eps`.
//! For the paper's exponents (|e| < 1) the bound is below 1e-13 relative; the tests check it
//! against `powf` on a million points and at every cell's worst point.
//!
//! Inputs outside the table (non-positive, subnormal, infinite or NaN x, or `|k| > 64`, i.e.
//! x outside about [5e-20, 3e19]) fall back to `powf`, so the function is total.
//!
//! Tables live in a fixed set of static slots keyed by the exponent's bits (no allocation,
//! nothing left behind when an FMU's library is unloaded); an exponent that finds no free
//! slot (more than [`SLOTS`] distinct exponents in one process) uses `powf`.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

/// Cells of the mantissa table.
const N: usize = 512;
/// Binary exponents covered: k in [-K, K].
const K: i64 = 64;
/// Distinct exponents that get a table.
pub const SLOTS: usize = 32;

/// The table of one exponent.
#[derive(Debug)]
pub struct PowTable {
    e: f64,
    /// (m^e, h e m^(e-1)) at the nodes m = 1 + i / N.
    nodes: [[f64; 2]; N + 1],
    /// 2^(e k) for k = -K ..= K.
    scale: [f64; (2 * K + 1) as usize],
    interp_bound: f64,
}

impl PowTable {
    /// The table of `e`, with its proven interpolation bound.
    pub fn new(e: f64) -> PowTable {
        let h = 1.0 / N as f64;
        let mut nodes = [[0.0; 2]; N + 1];
        for (i, n) in nodes.iter_mut().enumerate() {
            let m = 1.0 + i as f64 * h;
            *n = [m.powf(e), h * e * m.powf(e - 1.0)];
        }
        let mut scale = [0.0; (2 * K + 1) as usize];
        for (j, s) in scale.iter_mut().enumerate() {
            *s = 2f64.powf(e * (j as i64 - K) as f64);
        }
        let c4 = (e * (e - 1.0) * (e - 2.0) * (e - 3.0)).abs();
        let mut worst: f64 = 0.0;
        for i in 0..N {
            let (a, b) = (1.0 + i as f64 * h, 1.0 + (i + 1) as f64 * h);
            let d4 = c4 * a.powf(e - 4.0).max(b.powf(e - 4.0));
            let fmin = a.powf(e).min(b.powf(e));
            worst = worst.max(h.powi(4) / 384.0 * d4 / fmin);
        }
        PowTable {
            e,
            nodes,
            scale,
            interp_bound: worst,
        }
    }

    /// The exponent.
    pub fn exponent(&self) -> f64 {
        self.e
    }

    /// The proven bound of the interpolation alone (relative).
    pub fn interp_bound(&self) -> f64 {
        self.interp_bound
    }

    /// The proven bound of [`PowTable::pow`] against the exact `x^e` (relative), rounding
    /// included, for every x the table covers.
    pub fn bound(&self) -> f64 {
        self.interp_bound * (1.0 + 1e-3) + (12.0 + 0.35 * self.e.abs() * K as f64) * f64::EPSILON
    }

    /// `x^e`.
    #[inline]
    pub fn pow(&self, x: f64) -> f64 {
        let bits = x.to_bits();
        let biased = (bits >> 52) as i64; // sign bit included: negative x is out of range
        let k = biased - 1023;
        if !(1..2047).contains(&biased) || !(-K..=K).contains(&k) {
            return x.powf(self.e);
        }
        const FRAC: u32 = 52 - 9; // 9 bits index the 512 cells
        let i = ((bits >> FRAC) & (N as u64 - 1)) as usize;
        let t = (bits & ((1u64 << FRAC) - 1)) as f64 * (1.0 / (1u64 << FRAC) as f64);
        let [f0, d0] = self.nodes[i];
        let [f1, d1] = self.nodes[i + 1];
        // Cubic Hermite on [0, 1] in the local coordinate t.
        let c2 = 3.0 * (f1 - f0) - 2.0 * d0 - d1;
        let c3 = 2.0 * (f0 - f1) + d0 + d1;
        let p = f0 + t * (d0 + t * (c2 + t * c3));
        p * self.scale[(k + K) as usize]
    }
}

struct Slot {
    /// The exponent's bits plus one (0: free).
    key: AtomicU64,
    table: OnceLock<PowTable>,
}

#[allow(clippy::declare_interior_mutable_const)]
const FREE: Slot = Slot {
    key: AtomicU64::new(0),
    table: OnceLock::new(),
};

static TABLES: [Slot; SLOTS] = [FREE; SLOTS];

/// The table of `e`, built on first use (`None` when every slot holds another exponent, or
/// for a NaN exponent).
///
/// Inline: the common case (the exponent's table built, in its first slot) is a hash, a
/// load and two comparisons; everything else is `table_search`, which returns the same
/// table.
#[inline]
pub fn table(e: f64) -> Option<&'static PowTable> {
    let key = e.to_bits().wrapping_add(1);
    if let Some(slot) = TABLES.get(first_slot(key)) {
        if !e.is_nan() && slot.key.load(Ordering::Acquire) == key {
            if let Some(t) = slot.table.get() {
                return Some(t);
            }
        }
    }
    table_search(e)
}

/// The slot an exponent's key (its bits plus one) is looked for first.
#[inline(always)]
fn first_slot(key: u64) -> usize {
    (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 59) as usize % SLOTS
}

/// [`table`]'s search: open addressing from the exponent's first slot, claiming a free
/// slot and building the table there if no slot holds it yet.
#[inline(never)]
fn table_search(e: f64) -> Option<&'static PowTable> {
    let key = e.to_bits().checked_add(1).filter(|_| !e.is_nan())?;
    // Open addressing from a hash of the key: the first probe is the exponent's slot unless
    // another exponent took it.
    let start = first_slot(key);
    for j in 0..SLOTS {
        let slot = &TABLES[(start + j) % SLOTS];
        let k = slot.key.load(Ordering::Acquire);
        if k == key {
            return Some(slot.table.get_or_init(|| PowTable::new(e)));
        }
        if k == 0
            && slot
                .key
                .compare_exchange(0, key, Ordering::AcqRel, Ordering::Acquire)
                .is_ok()
        {
            return Some(slot.table.get_or_init(|| PowTable::new(e)));
        }
        // Another thread took this free slot meanwhile: it may be ours; check again.
        if slot.key.load(Ordering::Acquire) == key {
            return Some(slot.table.get_or_init(|| PowTable::new(e)));
        }
    }
    None
}

/// `x^e` within [`PowTable::bound`] of the exact value (exactly `powf` where no table
/// applies).
#[inline]
pub fn pow(x: f64, e: f64) -> f64 {
    pow_by(table(e), x, e)
}

/// [`pow`] with the table of `e` looked up beforehand (`table(e)`, kept by a caller that
/// raises many numbers to the same exponent): the same value, without the lookup. A
/// lookup's answer never changes (a slot, once taken, keeps its exponent), so keeping it
/// is exact.
#[inline]
pub fn pow_by(table: Option<&PowTable>, x: f64, e: f64) -> f64 {
    match table {
        Some(t) => t.pow(x),
        None => x.powf(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's exponents and a few more (negative, above 1, small).
    const EXPONENTS: [f64; 9] = [0.21, 0.10, 0.33, 0.45, 0.24, -0.45, -1.3, 2.7, 1e-3];

    fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    #[test]
    fn the_bound_holds_on_a_million_points_and_at_every_cell_midpoint() {
        let mut s: u64 = 0x1234_5678_9abc_def1;
        for &e in &EXPONENTS {
            let t = table(e).expect("a slot");
            assert!(t.bound() < 1e-11, "e = {e}: bound {:e}", t.bound());
            let mut worst: f64 = 0.0;
            for _ in 0..120_000 {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                // x over 1e-6 .. 1e6, log-uniform.
                let x = 10f64.powf((s >> 11) as f64 / (1u64 << 53) as f64 * 12.0 - 6.0);
                worst = worst.max(rel(t.pow(x), x.powf(e)));
            }
            // Midpoints of the cells, where the interpolation error peaks.
            for i in 0..N {
                for k in [-3, 0, 5] {
                    let x = (1.0 + (i as f64 + 0.5) / N as f64) * 2f64.powi(k);
                    worst = worst.max(rel(t.pow(x), x.powf(e)));
                }
            }
            assert!(
                worst <= t.bound(),
                "e = {e}: error {worst:e} above the bound {:e}",
                t.bound()
            );
        }
    }

    #[test]
    fn out_of_range_inputs_fall_back_to_powf() {
        for x in [0.0, -1.0, 1e-300, 1e300, f64::INFINITY, f64::NAN, 5e-324] {
            let (a, b) = (pow(x, 0.21), x.powf(0.21));
            assert!(a == b || (a.is_nan() && b.is_nan()), "{x}: {a} vs {b}");
        }
        assert!(pow(2.0, f64::NAN).is_nan());
    }

    #[test]
    fn tables_are_shared_by_exponent() {
        let a = table(0.777).unwrap() as *const PowTable;
        let b = table(0.777).unwrap() as *const PowTable;
        assert_eq!(a, b);
        assert_eq!(table(0.777).unwrap().exponent(), 0.777);
    }
}
