//! The steady map (5)-(7) from two one-dimensional tables with a proven error bound, for
//! callers that evaluate it on every input change (the FMU, the controller's model).
//!
//! The map separates into a part that depends on z_m only and a part that depends on the
//! frequency only:
//!
//! ```text
//! S_x = G_x(d) + P(d) L(w),   S_y = G_y(d) + P(d) L(w),   r_i = C_i Phi(w) / S_i^alpha_i
//! G_x = s_0 + a_G (g_z/g_u)^rho + a_K1 (|k_xx|/k_u)^gamma_1,   G_y likewise with k_yy
//! P   = a_P (B/B_ref)^mu_P,   L = 1 + log(1 + c_P w^q_P),   Phi = exp(N (w^q - 1))
//! ```
//!
//! with d the depth of the swarm plane below the magnet centre and w = |omega| / omega_ref.
//! [`MapTable`] holds G_x, G_y, P over d and L, Phi over w as cubic Hermite interpolants
//! (values and slopes at the nodes, computed from the same formulas); the rest (the field
//! outputs, S, the two powers alpha_i, the Jacobian) is computed as in
//! [`crate::steady::evaluate`]. Eight of the ten powers, the logarithm and the exponential
//! of an input change become two table lookups.
//!
//! # The error bound (a proof, not a measurement)
//!
//! Cells are uniform in the binary representation of the variable (the index is the top
//! bits of the float, as in [`crate::fastpow`]): 2^10 cells per binade in depth, 2^8 in
//! frequency, so a cell is never wider than 1/1024 (1/256) of its left end, and the local
//! coordinate `t = (x - a) / h` is exact (h is a power of two). On a cell [a, b] of width h
//! the cubic Hermite interpolant p of f satisfies `|f - p| <= h^4 / 384 max |f''''|` and
//! `|f' - p'| <= sqrt(3) / 216 h^3 max |f''''|` (the remainder with double nodes and its
//! derivative). `max |f''''|` over the cell is bounded by evaluating the formula in
//! **interval arithmetic on Taylor polynomials of degree 5** ([`Jet`] over [`Iv`], rounded
//! outwards after every operation): first the fourth coefficient enclosed over the cell
//! directly (`|f''''| <= 24 |c4|`), which is tight where the formula does not cancel (the
//! frequency part); where that bound is not well inside the acceptance threshold, the
//! fourth coefficient at the cell's midpoint and the fifth coefficient's enclosure over the
//! cell: `|f''''| <= 24 |c4(mid)| + 60 h |c5|` on the cell (Taylor about the midpoint: a
//! centred form, far tighter than the direct enclosure where the cancellations of the
//! field's closed forms blow it up). To the interpolation bound add the rounding of the
//! node values and of the evaluation (`64 eps max|f|` for a value, `64 eps (max|f| / h +
//! max|f'|)` for a slope, generous for a dozen operations). A cell whose bound exceeds
//! `1e-11 max(1, max|f|)` for a value, or `1e-6` of `max|f'| + max|f| / a` for a slope, or
//! that the interval evaluation cannot enclose (|k_yy| or the logarithm's argument near
//! zero, the log floor),
//! is marked and evaluated exactly. So every value the table returns is within the cell's
//! stored bound of the exact formula; [`MapTable::bound`] propagates them to r1, r2 at an
//! operating point, and the tests check both the bound (below 1e-9 mm over the validated
//! envelope) and the table against the exact code over the envelope.
//!
//! Outside the tabulated range (the envelope widened by half its span in z_m, f from
//! f_min / 2 to 2 f_max), near the stiffness floor, or for a model with an effect that
//! acts on the map (centroid offset, phase lag, cohesion loss, learned terms on the map),
//! [`MapTable::evaluate`] is [`crate::steady::evaluate`] itself.

use crate::steady::{self, SteadyPoint};
use crate::Model;
use std::sync::{Arc, Mutex, OnceLock, PoisonError};

/// The tables shared by the plants of this process, most recently used last (see
/// [`MapTable::shared`]).
static SHARED: Mutex<Vec<Arc<MapTable>>> = Mutex::new(Vec::new());
/// How many models' tables the process keeps (a fully built table is about half a MB).
const SHARED_MODELS: usize = 8;

/// Cells per binade of the depth: 2^10 (its fourth derivatives reach 1e10 /m^4).
const DEPTH_BITS: u32 = 10;
/// Cells per binade of the frequency: 2^8.
const FREQ_BITS: u32 = 8;
/// Fraction of the acceptance threshold a cell's bound from the direct enclosure of
/// |f''''| must stay below to be used without the centred form (see `Axis::build`).
const DIRECT_MARGIN: f64 = 0.125;
/// Most cells per axis (a range of about 16 binades).
const MAX_CELLS: u64 = 8192;

mod interval;
pub use interval::{Iv, Jet, Num, ORDER};

// ---------------------------------------------------------------------------------------
// The two parts of the map, written once over `Num`.

/// G_x, G_y, P as functions of the depth d \[m\] (the closed forms of [`crate::field`] and the
/// powers of [`crate::steady`]).
pub fn depth_part<T: Num>(model: &Model, d: Jet<T>) -> Option<[Jet<T>; 3]> {
    depth_part_n(model, d)
}

/// [`depth_part`] over jets of N coefficients (see [`Jet`]: the first coefficients are
/// the same for any N).
pub fn depth_part_n<T: Num, const N: usize>(model: &Model, d: Jet<T, N>) -> Option<[Jet<T, N>; 3]> {
    let p = &model.steady;
    let c = &model.conventions;
    let k = model.magnet.dipole_k();
    let k2 = k * k;
    let u = model.magnet.lateral_offset_m * model.magnet.lateral_offset_m;
    let d2 = d.mul(d);
    let w = d2.addc(u);
    let n = d2.addc(2.5 * u);
    let w2 = w.mul(w);
    let w4 = w2.mul(w2);
    let w5 = w4.mul(w);
    let w6 = w5.mul(w);
    let one = Jet::cst(1.0);
    let iw4 = one.div(w4)?;
    let iw5 = one.div(w5)?;
    let iw6 = one.div(w6)?;
    // G = <B^2>/K^2 and the partial derivatives the field needs.
    let g = n.mul(iw4);
    let g_d = d.mul(iw4).scale(2.0).sub(d.mul(n).mul(iw5).scale(8.0));
    let g_u = iw4.scale(2.5).sub(n.mul(iw5).scale(4.0));
    let g_uu = iw5.scale(-20.0).add(n.mul(iw6).scale(20.0));
    let sg = g.powf(0.5)?;
    let b = sg.scale(k);
    // g_z = -d|B|/dd = -k g_d / (2 sqrt G)
    let g_z = g_d.scale(-k).div(sg.scale(2.0))?;
    let k_xx = g_u.scale(2.0 * k2);
    let k_yy = g_u.scale(2.0).add(g_uu.scale(4.0 * u)).scale(k2);
    let kx = k_xx.abs()?.scale(1.0 / c.k_unit_t2_per_m2);
    let ky = k_yy.abs()?.scale(1.0 / c.k_unit_t2_per_m2);
    let gq = g_z.scale(1.0 / c.g_unit_t_per_m);
    let bn = b.scale(1.0 / p.B_ref);
    let grad = gq.powf(p.rho)?.scale(p.a_G).addc(p.s_0);
    let gx = grad.add(kx.powf(p.gamma_1)?.scale(p.a_K1));
    let gy = grad.add(ky.powf(p.gamma_2)?.scale(p.a_K2));
    let part = bn.powf(p.mu_P)?.scale(p.a_P);
    Some([gx, gy, part])
}

/// L and Phi as functions of w = |omega| / omega_ref. `None` where the logarithm's argument
/// reaches the floor of the conventions (the exact code clamps there).
pub fn frequency_part<T: Num>(model: &Model, w: Jet<T>) -> Option<[Jet<T>; 2]> {
    frequency_part_n(model, w)
}

/// [`frequency_part`] over jets of N coefficients.
pub fn frequency_part_n<T: Num, const N: usize>(
    model: &Model,
    w: Jet<T, N>,
) -> Option<[Jet<T, N>; 2]> {
    let p = &model.steady;
    let c = &model.conventions;
    let arg = w.powf(p.q_P)?.scale(p.c_P).addc(1.0);
    if !arg.0[0].above(c.log_arg_floor) {
        return None;
    }
    let ln = arg.ln()?;
    let log = match c.log_base {
        crate::params::LogBase::E => ln,
        crate::params::LogBase::Ten => ln.div(Jet::cst(std::f64::consts::LN_10))?,
    };
    let l = log.addc(1.0);
    let phi = w.powf(p.q)?.addc(-1.0).scale(p.N).exp();
    Some([l, phi])
}

// ---------------------------------------------------------------------------------------
// One axis: cells indexed by the top bits of the variable.

/// The K functions of an axis, evaluated three ways for building a cell, each with as many
/// Taylor coefficients as it uses (the coefficients it uses are those of the full jet, bit
/// for bit: [`Jet`]): at a node over f64 (value and slope), over the cell over intervals
/// (up to the fifth coefficient), at the cell's midpoint over intervals (up to the fourth).
struct Parts<'a, const K: usize> {
    node: &'a dyn Fn(Jet<f64, 2>) -> Option<[Jet<f64, 2>; K]>,
    range: &'a dyn Fn(Jet<Iv>) -> Option<[Jet<Iv>; K]>,
    mid: &'a dyn Fn(Jet<Iv, 5>) -> Option<[Jet<Iv, 5>; K]>,
}

/// One cell: the cubic of each function in the local coordinate t in [0, 1).
#[derive(Debug, Clone, Copy)]
struct Cell<const K: usize> {
    /// Left end of the cell.
    lo: f64,
    /// 1 / width (a power of two).
    inv_h: f64,
    /// Interpolated (false: evaluate exactly).
    ok: bool,
    /// [f(a), h f'(a), c2, c3] per function: p(t) = f0 + t (s0 + t (c2 + t c3)).
    coef: [[f64; 4]; K],
}

/// The proven bounds of one cell (absolute, per function): value, slope.
#[derive(Debug, Clone, Copy)]
struct CellBound<const K: usize> {
    value: [f64; K],
    slope: [f64; K],
}

/// K functions of one positive variable over a range of cells, each cell built (nodes,
/// coefficients, bound) the first time it is needed: a sweep pays for the cells it visits
/// (about 5 us each in a release build), not for the whole range, and once per process
/// when its plants share the table ([`MapTable::shared`]).
#[derive(Debug, Clone)]
struct Axis<const K: usize> {
    /// `x.to_bits() >> shift` of the first cell.
    base: u64,
    /// 52 - log2(cells per binade).
    shift: u32,
    cells: Vec<OnceLock<(Cell<K>, CellBound<K>)>>,
}

impl<const K: usize> Axis<K> {
    /// The cells of [x_lo, x_hi] (both positive, finite), none built yet.
    fn new(bits: u32, x_lo: f64, x_hi: f64) -> Option<Axis<K>> {
        if !(x_lo > 0.0 && x_hi > x_lo && x_hi.is_finite() && x_lo.is_normal()) {
            return None;
        }
        let shift = 52 - bits;
        let base = x_lo.to_bits() >> shift;
        let end = (x_hi.to_bits() >> shift) + 1;
        if end - base > MAX_CELLS {
            return None;
        }
        Some(Axis {
            base,
            shift,
            cells: (base..end).map(|_| OnceLock::new()).collect(),
        })
    }

    /// The left end of cell i (and the right end of cell i - 1).
    fn edge(&self, i: usize) -> f64 {
        f64::from_bits((self.base + i as u64) << self.shift)
    }

    /// Build cell `i` of `f` (written over f64 for the nodes, over intervals for the bound).
    #[cold]
    #[inline(never)]
    fn build(&self, i: usize, f: &Parts<'_, K>) -> (Cell<K>, CellBound<K>) {
        let (a, b) = (self.edge(i), self.edge(i + 1));
        let h = b - a;
        let node = |x: f64| (f.node)(Jet::var(x)).map(|js| js.map(|j| [j.0[0], j.0[1]]));
        let mid = 0.5 * (a + b);
        let mut cell = Cell {
            lo: a,
            inv_h: 1.0 / h,
            ok: false,
            coef: [[0.0; 4]; K],
        };
        let mut bound = CellBound {
            value: [f64::INFINITY; K],
            slope: [f64::INFINITY; K],
        };
        let (Some(na), Some(nb), Some(enc)) =
            (node(a), node(b), (f.range)(Jet::var(Iv::new(a, b))))
        else {
            return (cell, bound);
        };
        for k in 0..K {
            let (f0, f1) = (na[k][0], nb[k][0]);
            let (s0, s1) = (h * na[k][1], h * nb[k][1]);
            cell.coef[k] = [
                f0,
                s0,
                3.0 * (f1 - f0) - 2.0 * s0 - s1,
                2.0 * (f0 - f1) + s0 + s1,
            ];
        }
        // The bounds of the cell from a bound m4 on |f''''| over it, and whether they pass
        // the acceptance test with `margin` to spare.
        let judge = |m4: [f64; K], margin: f64| {
            let mut b = CellBound {
                value: [f64::INFINITY; K],
                slope: [f64::INFINITY; K],
            };
            let mut ok = true;
            for k in 0..K {
                let m0 = enc[k].0[0].mag();
                let m1 = enc[k].0[1].mag();
                let eps = f64::EPSILON;
                let v = h.powi(4) / 384.0 * m4[k] + 64.0 * eps * m0;
                let sl = 3f64.sqrt() / 216.0 * h.powi(3) * m4[k] + 64.0 * eps * (m0 / h + m1);
                b.value[k] = v;
                b.slope[k] = sl;
                ok &= v.is_finite()
                    && sl.is_finite()
                    && v <= margin * 1e-11 * m0.max(1.0)
                    && sl <= margin * 1e-6 * (m1 + m0 / a);
            }
            (b, ok)
        };
        // First |f''''| enclosed over the cell directly (the enclosure is at hand): where
        // that passes with DIRECT_MARGIN to spare, it is the bound. Where the closed forms
        // cancel (the field's, in depth) the direct enclosure is loose and the centred form
        // decides: on the cell |x - mid| <= h/2, so |f''''(x)| <= |f''''(mid)| +
        // h/2 max|f'''''| = 24 |c4(mid)| + 60 h |c5| (Taylor about mid). Both are proven
        // bounds; the direct try saves the midpoint's interval evaluation (a third of a
        // cell's cost), and with the margin a cell it passes would pass the centred form
        // too (unless the fifth-order term alone took 7/8 of the threshold), so the cells
        // interpolated are the same.
        let (b, ok) = judge(enc.each_ref().map(|j| 24.0 * j.0[4].mag()), DIRECT_MARGIN);
        if ok {
            cell.ok = true;
            return (cell, b);
        }
        if let Some(at) = (f.mid)(Jet::var(Iv::new(mid, mid))) {
            let m4 =
                std::array::from_fn(|k| 24.0 * at[k].0[4].mag() + 60.0 * h * enc[k].0[5].mag());
            let (b, ok) = judge(m4, 1.0);
            cell.ok = ok;
            bound = b;
        }
        (cell, bound)
    }

    /// The cell holding x (built now if it was not), if tabulated and interpolated.
    #[inline]
    /// `build` builds cell i ([`Axis::build`] with the functions; only called for a cell
    /// not built yet, so the hot path never assembles them).
    fn cell(
        &self,
        x: f64,
        build: impl FnOnce(usize) -> (Cell<K>, CellBound<K>),
    ) -> Option<(usize, &(Cell<K>, CellBound<K>))> {
        // Negative x, NaN and infinities index far past the end.
        let i = (x.to_bits() >> self.shift).wrapping_sub(self.base) as usize;
        let slot = self.cells.get(i)?;
        let c = match slot.get() {
            Some(c) => c,
            None => slot.get_or_init(|| build(i)),
        };
        c.0.ok.then_some((i, c))
    }

    /// Build every cell; (cells, interpolated).
    fn build_all(&self, f: &Parts<'_, K>) -> [usize; 2] {
        let ok = (0..self.cells.len())
            .filter(|&i| self.cells[i].get_or_init(|| self.build(i, f)).0.ok)
            .count();
        [self.cells.len(), ok]
    }
}

impl<const K: usize> Cell<K> {
    /// Values and derivatives (d/dx) of the K functions at x in this cell (the derivatives
    /// only `WITH_JACOBIAN`, else 0; the values are the same expressions either way).
    #[inline]
    fn eval<const WITH_JACOBIAN: bool>(&self, x: f64) -> [(f64, f64); K] {
        let t = (x - self.lo) * self.inv_h;
        self.coef.map(|[f0, s0, c2, c3]| {
            let v = f0 + t * (s0 + t * (c2 + t * c3));
            let d = if WITH_JACOBIAN {
                (s0 + t * (2.0 * c2 + 3.0 * c3 * t)) * self.inv_h
            } else {
                0.0
            };
            (v, d)
        })
    }
}

// ---------------------------------------------------------------------------------------
// The map.

/// The parameters a table was built from (it answers for these only).
#[derive(Debug, Clone, PartialEq)]
struct Key {
    steady: crate::params::SteadyParams,
    conventions: crate::params::Conventions,
    magnet: crate::field::MagnetConfig,
    envelope: crate::envelope::Envelope,
}

impl Key {
    fn of(model: &Model) -> Key {
        Key {
            steady: model.steady,
            conventions: model.conventions,
            magnet: model.magnet,
            envelope: model.envelope,
        }
    }
}

/// The steady map of one model from tables (see the module documentation).
#[derive(Debug, Clone)]
pub struct MapTable {
    key: Key,
    /// The model the cells are built from (its map's parameters).
    model: Model,
    depth: Axis<3>,
    freq: Axis<2>,
    /// `fastpow::table` of alpha_1 and alpha_2, looked up once (see [`crate::fastpow::pow_by`]).
    alpha_pow: [Option<&'static crate::fastpow::PowTable>; 2],
}

/// Whether the map of `model` is the plain (5)-(7) that the tables hold: no effect acts on it
/// ([`steady::plain_map`]).
pub fn tabulable(model: &Model) -> bool {
    steady::plain_map(model)
}

impl MapTable {
    /// The tables of `model`'s map over its envelope widened by half its span in z_m and from
    /// f_min / 2 to 2 f_max; `None` when an effect acts on the map ([`tabulable`]) or the
    /// range is degenerate. Cells are built on first use (about 5 us each in a release
    /// build), so this is quick and a sweep pays for the cells it visits. A table of its
    /// own: plants take the process's shared one ([`MapTable::shared`]).
    pub fn new(model: &Model) -> Option<MapTable> {
        if !tabulable(model) {
            return None;
        }
        let e = &model.envelope;
        let span = e.z_max_m - e.z_min_m;
        let floor = -model.magnet.z_offset_m;
        let z_lo = (e.z_min_m - 0.5 * span).max(floor + 0.1 * model.magnet.radius_m);
        let z_hi = e.z_max_m + 0.5 * span;
        let (d_lo, d_hi) = (model.magnet.depth(z_lo), model.magnet.depth(z_hi));
        let depth = Axis::new(DEPTH_BITS, d_lo, d_hi)?;
        let f_ref = model.steady.f_ref;
        let (w_lo, w_hi) = (0.5 * e.f_min_hz.max(0.05) / f_ref, 2.0 * e.f_max_hz / f_ref);
        let freq = Axis::new(FREQ_BITS, w_lo, w_hi)?;
        let p = &model.steady;
        Some(MapTable {
            key: Key::of(model),
            model: model.clone(),
            depth,
            freq,
            alpha_pow: [
                crate::fastpow::table(p.alpha_1),
                crate::fastpow::table(p.alpha_2),
            ],
        })
    }

    /// The process's table for `model`'s map, shared by every plant of the same map
    /// parameters ([`MapTable::answers_for`]): a cell built by one instance (of an FMU, a
    /// sweep, a lab) is built for all. Sound because a cell is a pure function of those
    /// parameters and its index, built once behind its `OnceLock` (threads that want it at
    /// the same time wait for the one building it): who built it changes no value, so
    /// results and saved states replay bit for bit. The last eight models'
    /// tables are kept for the life of the process. `None` as for [`MapTable::new`].
    pub fn shared(model: &Model) -> Option<Arc<MapTable>> {
        if !tabulable(model) {
            return None;
        }
        let key = Key::of(model);
        // Only vector operations run under the lock (no panic can poison it in practice;
        // if one did, the list is still consistent).
        let mut tables = SHARED.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(i) = tables.iter().position(|t| t.key == key) {
            let t = tables.remove(i);
            tables.push(t.clone());
            return Some(t);
        }
        let t = Arc::new(MapTable::new(model)?);
        if tables.len() >= SHARED_MODELS {
            tables.remove(0);
        }
        tables.push(t.clone());
        Some(t)
    }

    /// The depth cell holding d (built if needed), if interpolated.
    #[inline]
    fn depth_cell(&self, d: f64) -> Option<&(Cell<3>, CellBound<3>)> {
        let m = &self.model;
        let build = |i| {
            self.depth.build(
                i,
                &Parts {
                    node: &|j| depth_part_n(m, j),
                    range: &|j| depth_part_n(m, j),
                    mid: &|j| depth_part_n(m, j),
                },
            )
        };
        self.depth.cell(d, build).map(|(_, c)| c)
    }

    /// The frequency cell holding w (built if needed), if interpolated.
    #[inline]
    fn freq_cell(&self, w: f64) -> Option<&(Cell<2>, CellBound<2>)> {
        let m = &self.model;
        let build = |i| {
            self.freq.build(
                i,
                &Parts {
                    node: &|j| frequency_part_n(m, j),
                    range: &|j| frequency_part_n(m, j),
                    mid: &|j| frequency_part_n(m, j),
                },
            )
        };
        self.freq.cell(w, build).map(|(_, c)| c)
    }

    /// Whether this table was built for `model`'s map.
    pub fn answers_for(&self, model: &Model) -> bool {
        tabulable(model) && self.key == Key::of(model)
    }

    /// The steady map at (z_m \[m\], omega [rad/s]): from the tables where they hold, else
    /// [`steady::evaluate`]. `model` must be the one the table was built for
    /// ([`MapTable::answers_for`]).
    #[inline]
    pub fn evaluate(&self, model: &Model, z_m: f64, omega: f64) -> SteadyPoint {
        self.interpolate(model, z_m, omega)
            .unwrap_or_else(|| steady::evaluate(model, z_m, omega))
    }

    /// [`MapTable::evaluate`] into `out`, with the Jacobian (`ds`, `jac` and the field's
    /// z-derivatives but `db_dz`) only `WITH_JACOBIAN`, else left at 0: the same values bit
    /// for bit (the same expressions; where the table does not answer,
    /// [`steady::evaluate_values`]). Written in place: an input change builds the point where
    /// the plant keeps it, without copying it.
    #[inline]
    pub(crate) fn evaluate_into<const WITH_JACOBIAN: bool>(
        &self,
        model: &Model,
        z_m: f64,
        omega: f64,
        out: &mut SteadyPoint,
    ) {
        if !self.interpolate_into::<WITH_JACOBIAN>(model, z_m, omega, out) {
            *out = if WITH_JACOBIAN {
                steady::evaluate(model, z_m, omega)
            } else {
                steady::evaluate_values(model, z_m, omega)
            };
        }
    }

    /// The map from the tables, with its Jacobian (`None` where they do not answer).
    fn interpolate(&self, model: &Model, z_m: f64, omega: f64) -> Option<SteadyPoint> {
        let mut sp = SteadyPoint::default();
        self.interpolate_into::<true>(model, z_m, omega, &mut sp)
            .then_some(sp)
    }

    /// The map from the tables into `out`, with the Jacobian only `WITH_JACOBIAN` (the
    /// values are the same expressions either way); false (and `out` untouched) where the
    /// tables do not answer.
    #[inline(always)]
    fn interpolate_into<const WITH_JACOBIAN: bool>(
        &self,
        model: &Model,
        z_m: f64,
        omega: f64,
        out: &mut SteadyPoint,
    ) -> bool {
        let p = &model.steady;
        let c = &model.conventions;
        let d = model.magnet.depth(z_m);
        let (w, dw) = steady::norm_freq_with::<WITH_JACOBIAN>(model, omega);
        let Some((zc, _)) = self.depth_cell(d) else {
            return false;
        };
        let Some((wc, _)) = self.freq_cell(w) else {
            return false;
        };
        let [(gx, dgx), (gy, dgy), (part, dpart)] = zc.eval::<WITH_JACOBIAN>(d);
        let [(l, dl), (phi, dphi)] = wc.eval::<WITH_JACOBIAN>(w);
        let pl = part * l;
        let (s_x, s_y) = (gx + pl, gy + pl);
        // Near the floor the exact code decides (it flags the point).
        let near = c.s_floor * (1.0 + 1e-6);
        if !(s_x > near && s_y > near) {
            return false;
        }
        let (ds, dlnphi_dw) = if WITH_JACOBIAN {
            let dpl_dz = dpart * l;
            let dpl_dw = part * dl * dw;
            (
                [[dgx + dpl_dz, dpl_dw], [dgy + dpl_dz, dpl_dw]],
                dphi / phi * dw,
            )
        } else {
            ([[0.0; 2]; 2], 0.0)
        };
        let s_alpha = [
            crate::fastpow::pow_by(self.alpha_pow[0], s_x, p.alpha_1),
            crate::fastpow::pow_by(self.alpha_pow[1], s_y, p.alpha_2),
        ];
        let ([r1, r2], jac) =
            steady::radii::<WITH_JACOBIAN>(p, s_alpha, [s_x, s_y], &ds, phi, dlnphi_dw);
        *out = SteadyPoint {
            field: model.magnet.at_with::<WITH_JACOBIAN>(z_m),
            s_x,
            s_y,
            phi,
            r1,
            r2,
            ds,
            jac,
            validity: model.envelope.classify(z_m, omega),
        };
        true
    }

    /// A proven bound on |r_i(table) - r_i(exact formula)| \[mm\] at an operating point, from
    /// the bounds of the two cells (`None` where the table does not answer): the errors of
    /// G_i, P, L and Phi propagated through `r = C Phi S^-alpha` to first order, doubled
    /// for the second-order terms, plus 1e-13 relative for the final arithmetic.
    pub fn bound(&self, model: &Model, z_m: f64, omega: f64) -> Option<[f64; 2]> {
        let mut sp = SteadyPoint::default();
        if !self.interpolate_into::<false>(model, z_m, omega, &mut sp) {
            return None;
        }
        let d = model.magnet.depth(z_m);
        let (w, _) = steady::norm_freq(model, omega);
        let (zc, zb) = self.depth_cell(d)?;
        let (wc, wb) = self.freq_cell(w)?;
        let [_, _, (part, _)] = zc.eval::<false>(d);
        let [(l, _), (phi, _)] = wc.eval::<false>(w);
        let (bz, bw) = (zb.value, wb.value);
        let ds_common = bz[2] * l.abs() + (part.abs() + bz[2]) * bw[0];
        let p = &model.steady;
        let one = |r: f64, s: f64, dg: f64, alpha: f64| {
            let rel = bw[1] / phi + alpha * (dg + ds_common) / s;
            r * (2.0 * rel + 1e-13)
        };
        Some([
            one(sp.r1, sp.s_x, bz[0], p.alpha_1),
            one(sp.r2, sp.s_y, bz[1], p.alpha_2),
        ])
    }

    /// Cells (depth, frequency) and how many of them are interpolated (the rest are
    /// evaluated exactly), for reports: builds every cell (tens of milliseconds).
    pub fn coverage(&self) -> ([usize; 2], [usize; 2]) {
        let m = &self.model;
        (
            self.depth.build_all(&Parts {
                node: &|j| depth_part_n(m, j),
                range: &|j| depth_part_n(m, j),
                mid: &|j| depth_part_n(m, j),
            }),
            self.freq.build_all(&Parts {
                node: &|j| frequency_part_n(m, j),
                range: &|j| frequency_part_n(m, j),
                mid: &|j| frequency_part_n(m, j),
            }),
        )
    }
}

#[cfg(test)]
mod tests;
