//! ODE (4) with the terms (1)-(3), its input-dependent coefficients and its Jacobians.
//!
//! ```text
//! dr1/dt = -K_b1 S_x (r1 - r1_min)^beta + E - K_d1 r1
//! dr2/dt = -K_b2 S_y (r2 - r2_min)^beta + E - K_d2 r2
//! E      =  K_tau (|omega|/omega_ref)^p s_B B (r1 r2)
//! ```
//!
//! Everything that depends only on the inputs (S_x, S_y, the expansion coefficient, the
//! confinement gains, the steady target) is gathered in [`InputTerms`], computed once per
//! input change: the integrator's hot path then only evaluates a few multiplications.
//!
//! With `Confinement::Scheduled` the gains are set so that the equilibrium of (4) is the
//! steady map (5) exactly:
//!
//! ```text
//! K_b,i = (E(r1*, r2*) - K_d,i r_i*) / (S_i (r_i* - r_i,min)^beta)
//! ```
//!
//! The map scales as S^-alpha while (4)'s confinement is linear in S, so constant gains
//! cannot do this (see `magswarm paper` for the best constant fit's error).

use crate::maptable::MapTable;
use crate::steady::{self, SteadyPoint};
use crate::Model;

/// Floor of a scheduled confinement gain; below it the ODE cannot reach the map with the
/// structure of (4) (expansion weaker than relaxation), and the point is flagged.
pub const KB_FLOOR: f64 = 1e-9;

/// Coefficients of (4) at fixed inputs.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct InputTerms {
    /// Inputs these terms were computed for (z_m \[m\], omega [rad/s]).
    pub z_m: f64,
    /// Field angular velocity [rad/s].
    pub omega: f64,
    /// The steady map at these inputs (with its Jacobian and validity flags).
    pub steady: SteadyPoint,
    /// Expansion coefficient e0 = K_tau w^p s_B B [1/(mm s)]: E = e0 r1 r2.
    pub e0: f64,
    /// Confinement gains K_b1, K_b2 in force.
    pub k_b: [f64; 2],
    /// d e0 / d(z_m, omega).
    de0: [f64; 2],
    /// d K_b,i / d(z_m, omega) (zero for constant gains).
    dk_b: [[f64; 2]; 2],
    /// The Jacobian parts (`steady.ds`, `steady.jac`, the field's z-derivatives but
    /// `db_dz`, `de0`, `dk_b`) were computed. Always true for terms made outside this
    /// crate; a [`crate::Plant`] keeps terms without them and computes them when asked
    /// ([`InputTerms::with_jacobian`]).
    jacobian: bool,
    /// Which computation these terms came from (see [`TermsId`]).
    id: TermsId,
}

/// A number no other [`InputTerms::new`] in this process returned: two terms with the same
/// id are the same computation, so the integrator can recognise a communication step it has
/// already taken without comparing every coefficient (`integrate`). Ignored by equality (it
/// names a computation, not a value).
#[derive(Debug, Clone, Copy, Default)]
pub struct TermsId(pub u64);

impl PartialEq for TermsId {
    fn eq(&self, _: &TermsId) -> bool {
        true
    }
}

impl TermsId {
    /// A fresh id. Each thread takes blocks of [`TermsId::BLOCK`] ids from a global counter
    /// and hands them out one by one, so an input change costs a thread-local increment
    /// rather than an atomic read-modify-write (a locked instruction that stalls the
    /// pipeline, about a seventh of [`InputTerms::new`]); ids stay unique process-wide.
    /// A [`crate::Plant`] hands out ids from a block of its own ([`TermsIds`]).
    #[inline]
    fn fresh() -> TermsId {
        use std::cell::Cell;
        thread_local! {
            /// (next id, end of this thread's block); (0, 0) before the first block.
            static RANGE: Cell<(u64, u64)> = const { Cell::new((0, 0)) };
        }
        RANGE.with(|r| {
            let mut ids = TermsIds {
                next: r.get().0,
                end: r.get().1,
            };
            let id = ids.take();
            r.set((ids.next, ids.end));
            id
        })
    }

    /// Block b holds ids b * BLOCK + 1 ..= (b + 1) * BLOCK (0 is never an id): (first, end).
    fn new_block() -> (u64, u64) {
        use std::sync::atomic::{AtomicU64, Ordering};
        static BLOCKS: AtomicU64 = AtomicU64::new(0);
        let b = BLOCKS.fetch_add(1, Ordering::Relaxed);
        let next = b * Self::BLOCK + 1;
        (next, next + Self::BLOCK)
    }

    /// Ids a thread (or a plant) takes from the global counter at a time.
    const BLOCK: u64 = 1 << 16;
}

/// A block of [`TermsId`]s of one owner (a thread, a plant), taken from the process's
/// counter: ids stay unique process-wide while an input change pays an increment, not a
/// thread-local lookup (in a shared library, a call into the dynamic loader). A clone
/// starts with no block (it takes its own at its first id), so two owners never hand out
/// the same id; equality ignores it.
#[derive(Debug, Default)]
pub(crate) struct TermsIds {
    next: u64,
    end: u64,
}

impl TermsIds {
    /// The next id of the block (a new block when it is used up).
    #[inline]
    pub(crate) fn take(&mut self) -> TermsId {
        if self.next == self.end {
            (self.next, self.end) = TermsId::new_block();
        }
        let id = TermsId(self.next);
        self.next += 1;
        id
    }
}

impl Clone for TermsIds {
    fn clone(&self) -> TermsIds {
        TermsIds::default()
    }
}

impl PartialEq for TermsIds {
    fn eq(&self, _: &TermsIds) -> bool {
        true
    }
}

impl InputTerms {
    /// Compute the coefficients of (4) for inputs (z_m \[m\], omega [rad/s]).
    pub fn new(model: &Model, z_m: f64, omega: f64) -> InputTerms {
        Self::with_map(model, z_m, omega, None)
    }

    /// As [`InputTerms::new`], with the steady map from `map` (a [`MapTable`] built for
    /// `model`: within its proven bound of the exact map) when given.
    pub fn with_map(model: &Model, z_m: f64, omega: f64, map: Option<&MapTable>) -> InputTerms {
        Self::build::<true>(model, z_m, omega, map)
    }

    /// [`InputTerms::with_map`] without the Jacobian parts, written into `out`: the same
    /// coefficients of (4), bit for bit (the same expressions), for about two thirds of the
    /// work (the map table's slopes, the field's z-derivatives, the chain rule through
    /// (5)-(7), the scheduled gains' derivatives: a dozen divisions among them), built where
    /// the plant keeps them (no copy). What stepping (4) needs; the Jacobian is computed
    /// when asked ([`InputTerms::with_jacobian`]). With an effect that acts on the map, the
    /// full terms (its rates read the Jacobian parts).
    pub(crate) fn values_into(
        out: &mut InputTerms,
        model: &Model,
        z_m: f64,
        omega: f64,
        map: Option<&MapTable>,
        id: TermsId,
    ) {
        if crate::maptable::tabulable(model) {
            Self::build_into::<false>(out, model, z_m, omega, map, id)
        } else {
            Self::build_into::<true>(out, model, z_m, omega, map, id)
        }
    }

    /// [`InputTerms::values_into`] for a model without effects (`model.effects` empty, so
    /// [`crate::maptable::tabulable`]): the same computation, without asking.
    #[inline]
    pub(crate) fn plain_values_into(
        out: &mut InputTerms,
        model: &Model,
        z_m: f64,
        omega: f64,
        map: Option<&MapTable>,
        id: TermsId,
    ) {
        debug_assert!(model.effects.is_empty());
        Self::build_into::<false>(out, model, z_m, omega, map, id)
    }

    /// [`InputTerms::values_into`] as a value.
    pub(crate) fn values_with_map(
        model: &Model,
        z_m: f64,
        omega: f64,
        map: Option<&MapTable>,
    ) -> InputTerms {
        let mut t = InputTerms::default();
        Self::values_into(&mut t, model, z_m, omega, map, TermsId::fresh());
        t
    }

    /// Whether the Jacobian parts are here (a plant computes them when asked, see
    /// [`crate::Plant::terms`]).
    pub fn has_jacobian(&self) -> bool {
        self.jacobian
    }

    /// These terms with their Jacobian parts: a copy if they have them, else the full
    /// computation at the same inputs with the same `map` (the one these terms were made
    /// with), whose values are these bit for bit and whose Jacobian is the one
    /// [`InputTerms::with_map`] gives. Keeps the id (the same coefficients of (4)).
    pub(crate) fn with_jacobian(&self, model: &Model, map: Option<&MapTable>) -> InputTerms {
        if self.jacobian {
            return *self;
        }
        let mut t = Self::with_map(model, self.z_m, self.omega, map);
        t.id = self.id;
        t
    }

    /// The terms, with the Jacobian parts only `WITH_JACOBIAN` (the values are the same
    /// expressions either way).
    fn build<const WITH_JACOBIAN: bool>(
        model: &Model,
        z_m: f64,
        omega: f64,
        map: Option<&MapTable>,
    ) -> InputTerms {
        let mut t = InputTerms::default();
        Self::build_into::<WITH_JACOBIAN>(&mut t, model, z_m, omega, map, TermsId::fresh());
        t
    }

    /// [`InputTerms::build`] into `t` (every field written).
    #[inline(always)]
    fn build_into<const WITH_JACOBIAN: bool>(
        t: &mut InputTerms,
        model: &Model,
        z_m: f64,
        omega: f64,
        map: Option<&MapTable>,
        id: TermsId,
    ) {
        let d = &model.dynamics;
        match map {
            Some(m) => m.evaluate_into::<WITH_JACOBIAN>(model, z_m, omega, &mut t.steady),
            None if WITH_JACOBIAN => t.steady = steady::evaluate(model, z_m, omega),
            None => t.steady = steady::evaluate_values(model, z_m, omega),
        }
        let sp = &t.steady;
        let (w, dw) = steady::norm_freq_with::<WITH_JACOBIAN>(model, omega);
        // The swarm's rotation rate (|omega| unless the phase_lag effect makes it step out).
        let (w, dw, dw_dz) = steady::swarm_rate(model, w, dw, &sp.field);
        let wp = if w > 0.0 {
            pow_int_or_real(w, d.p)
        } else {
            0.0
        };
        let e0 = d.K_tau * wp * d.s_B * sp.field.b;
        let mut de0 = [0.0; 2];
        if WITH_JACOBIAN {
            let dwp = if w > 0.0 { d.p * wp / w * dw } else { 0.0 };
            de0 = [
                d.K_tau * wp * d.s_B * sp.field.db_dz,
                d.K_tau * dwp * d.s_B * sp.field.b,
            ];
            if dw_dz != 0.0 && w > 0.0 {
                de0[0] += d.K_tau * d.p * wp / w * dw_dz * d.s_B * sp.field.b;
            }
        }
        t.z_m = z_m;
        t.omega = omega;
        t.e0 = e0;
        t.k_b = [d.K_b1, d.K_b2];
        t.de0 = de0;
        t.dk_b = [[0.0; 2]; 2];
        t.jacobian = WITH_JACOBIAN;
        t.id = id;
        if d.confinement == crate::params::Confinement::Scheduled {
            t.schedule::<WITH_JACOBIAN>(model);
        }
    }

    /// Set K_b,i so that (r1*, r2*) of the map is an equilibrium, with its derivatives
    /// (only `WITH_JACOBIAN`).
    fn schedule<const WITH_JACOBIAN: bool>(&mut self, model: &Model) {
        let d = &model.dynamics;
        let sp = self.steady;
        let rs = [sp.r1, sp.r2];
        let rmin = [d.r1_min, d.r2_min];
        let kd = [d.K_d1, d.K_d2];
        let s = [sp.s_x, sp.s_y];
        let prod = rs[0] * rs[1];
        for i in 0..2 {
            let gap = (rs[i] - rmin[i]).max(1e-12);
            let gap_b = pow_int_or_real(gap, d.beta);
            let den = s[i] * gap_b;
            let num = self.e0 * prod - kd[i] * rs[i];
            let kb = num / den;
            // Written so that a NaN gain (degenerate inputs) is clamped as well.
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            let too_small = !(kb > KB_FLOOR);
            if too_small {
                self.k_b[i] = KB_FLOOR;
                self.dk_b[i] = [0.0, 0.0];
                self.steady.validity.dynamics_clamped = true;
                continue;
            }
            self.k_b[i] = kb;
            if !WITH_JACOBIAN {
                continue;
            }
            // The derivatives only feed Jacobians: one division for both (the gain itself
            // stays an exact quotient, it drives the trajectory).
            let inv_den = 1.0 / den;
            let gap_b1 = d.beta * pow_int_or_real(gap, d.beta - 1.0);
            for j in 0..2 {
                let dprod = sp.jac[0][j] * rs[1] + rs[0] * sp.jac[1][j];
                let dnum = self.de0[j] * prod + self.e0 * dprod - kd[i] * sp.jac[i][j];
                let dden = sp.ds[i][j] * gap_b + s[i] * gap_b1 * sp.jac[i][j];
                self.dk_b[i][j] = (dnum - kb * dden) * inv_den;
            }
        }
    }

    /// The identity of this computation (see [`TermsId`]).
    #[inline]
    pub fn id(&self) -> u64 {
        self.id.0
    }

    /// Stiffness of each axis [S_x, S_y].
    #[inline]
    fn s(&self) -> [f64; 2] {
        [self.steady.s_x, self.steady.s_y]
    }

    /// Right-hand side of (4) [mm/s] at state r \[mm\] (inlined into the integrator's six
    /// stages).
    #[inline(always)]
    pub fn rhs(&self, model: &Model, r: [f64; 2]) -> [f64; 2] {
        let beta = model.dynamics.beta;
        if beta == 3.0 {
            // What the integrator evaluates (`integrate::Stepper::advance`), bit for bit.
            self.rhs_with(model, r, gain_times_cube)
        } else {
            self.rhs_with(model, r, |gap, c| c * pow_int_or_real(gap, beta))
        }
    }

    /// [`InputTerms::rhs`] with `c (r - r_min)^beta` for a positive gap given as
    /// `pow(gap, c)` (c = k_b S, the gain of that term; the integrator and [`InputTerms::rhs`]
    /// pass `(c gap) (gap gap)` when beta is 3, without choosing the power on every
    /// evaluation).
    #[inline(always)]
    pub(crate) fn rhs_with(
        &self,
        model: &Model,
        r: [f64; 2],
        pow: impl Fn(f64, f64) -> f64,
    ) -> [f64; 2] {
        let d = &model.dynamics;
        let s = self.s();
        // Ordered for a short dependency chain (the integrator's stages wait on each other):
        // the state-independent gain k_b s goes into the power (`pow(gap, c)` is
        // `c gap^beta`; the cube as `(c gap) (gap gap)`), and `e - K_d r` is summed beside
        // it, so r -> f is a subtraction, two multiplications and a subtraction. The same
        // terms as `-k_b s gap^beta + e - K_d r`, associated differently: an ulp-level
        // difference, far inside the integrator's tolerance (`integrate` tests).
        let e = self.e0 * r[0] * r[1];
        let c = [self.k_b[0] * s[0], self.k_b[1] * s[1]];
        let confine = |gap: f64, c: f64| if gap > 0.0 { pow(gap, c) } else { 0.0 };
        [
            (e - d.K_d1 * r[0]) - confine(r[0] - d.r1_min, c[0]),
            (e - d.K_d2 * r[1]) - confine(r[1] - d.r2_min, c[1]),
        ]
    }

    /// Every number [`InputTerms::rhs`] reads besides the state: two right-hand sides with
    /// equal keys are the same function (the tests compare terms by it; the integrator's
    /// memos name a right-hand side by [`InputTerms::id`] instead, see
    /// `integrate::RestMemo`); whoever adds a term to `rhs` adds what it reads here.
    #[inline]
    pub fn rhs_key(&self, model: &Model) -> [f64; 10] {
        let d = &model.dynamics;
        [
            self.e0,
            self.k_b[0],
            self.k_b[1],
            self.steady.s_x,
            self.steady.s_y,
            d.r1_min,
            d.r2_min,
            d.beta,
            d.K_d1,
            d.K_d2,
        ]
    }

    /// Jacobian of (4) with respect to the state, d f_i / d r_j [1/s].
    pub fn jac_state(&self, model: &Model, r: [f64; 2]) -> [[f64; 2]; 2] {
        let d = &model.dynamics;
        let s = self.s();
        [
            [
                -self.k_b[0] * s[0] * confine_d(r[0] - d.r1_min, d.beta) + self.e0 * r[1] - d.K_d1,
                self.e0 * r[0],
            ],
            [
                self.e0 * r[1],
                -self.k_b[1] * s[1] * confine_d(r[1] - d.r2_min, d.beta) + self.e0 * r[0] - d.K_d2,
            ],
        ]
    }

    /// Jacobian of (4) with respect to the inputs, d f_i / d(z_m \[m\], omega [rad/s]).
    pub fn jac_input(&self, model: &Model, r: [f64; 2]) -> [[f64; 2]; 2] {
        debug_assert!(self.jacobian, "jac_input of terms without their Jacobian");
        let d = &model.dynamics;
        let s = self.s();
        let gaps = [r[0] - d.r1_min, r[1] - d.r2_min];
        let mut out = [[0.0; 2]; 2];
        for i in 0..2 {
            let c = confine(gaps[i], d.beta);
            for j in 0..2 {
                out[i][j] = -(self.dk_b[i][j] * s[i] + self.k_b[i] * self.steady.ds[i][j]) * c
                    + self.de0[j] * r[0] * r[1];
            }
        }
        out
    }
}

/// `c gap^3` as `(c gap) (gap gap)`: the confinement term of (4) for the paper's beta = 3,
/// two multiplications deep. The one form both [`InputTerms::rhs`] and the integrator's
/// stages use, so that the two give the same bits.
#[inline(always)]
pub(crate) fn gain_times_cube(gap: f64, c: f64) -> f64 {
    (c * gap) * (gap * gap)
}

/// `x^e` by multiplication when `e` is 1, 2, 3 or 4 (the paper's beta is 3), by `sqrt` for
/// 0.5 (the paper's p), else [`crate::fastpow::pow`] (within its proven bound of `powf`).
///
/// The right-hand side of (4) is evaluated six times per integrator step; `powf` is a libm
/// call of about 20 ns, three multiplications are under 2 ns. The products differ from
/// `powf` by at most two units in the last place, far below the integrator's tolerance.
#[inline(always)]
pub fn pow_int_or_real(x: f64, e: f64) -> f64 {
    if e == 3.0 {
        x * x * x
    } else if e == 2.0 {
        x * x
    } else if e == 4.0 {
        let x2 = x * x;
        x2 * x2
    } else if e == 1.0 {
        x
    } else if e == 0.5 && x >= 0.0 {
        x.sqrt()
    } else {
        pow_general(x, e)
    }
}

/// The general case of [`pow_int_or_real`], out of line so that the integer cases stay small
/// enough to inline into the right-hand side.
#[inline(never)]
fn pow_general(x: f64, e: f64) -> f64 {
    crate::fastpow::pow(x, e)
}

/// (r - r_min)^beta, zero below the packing limit (the confinement cannot pull further).
#[inline(always)]
fn confine(gap: f64, beta: f64) -> f64 {
    if gap > 0.0 {
        pow_int_or_real(gap, beta)
    } else {
        0.0
    }
}

#[inline]
fn confine_d(gap: f64, beta: f64) -> f64 {
    if gap > 0.0 {
        beta * pow_int_or_real(gap, beta - 1.0)
    } else {
        0.0
    }
}

/// Equilibrium analysis at one operating point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Equilibrium {
    /// The equilibrium found \[mm\].
    pub r: [f64; 2],
    /// Eigenvalues of the state Jacobian there (real parts, imaginary part) [1/s].
    pub eig: [(f64, f64); 2],
    /// Number of distinct equilibria found in the search box.
    pub count: usize,
}

impl Equilibrium {
    /// Slowest time constant \[s\] (the formation time scale), infinite if not stable.
    pub fn time_constant(&self) -> f64 {
        let slow = self.eig[0].0.max(self.eig[1].0);
        if slow < 0.0 {
            -1.0 / slow
        } else {
            f64::INFINITY
        }
    }

    /// True when both eigenvalues have negative real part.
    pub fn stable(&self) -> bool {
        self.eig[0].0 < 0.0 && self.eig[1].0 < 0.0
    }
}

/// Eigenvalues of a real 2x2 matrix as (re, im) pairs.
pub fn eig2(a: [[f64; 2]; 2]) -> [(f64, f64); 2] {
    let tr = a[0][0] + a[1][1];
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    let disc = tr * tr / 4.0 - det;
    if disc >= 0.0 {
        let s = disc.sqrt();
        [(tr / 2.0 + s, 0.0), (tr / 2.0 - s, 0.0)]
    } else {
        let s = (-disc).sqrt();
        [(tr / 2.0, s), (tr / 2.0, -s)]
    }
}

/// Find every equilibrium of (4) at fixed inputs by Newton from a grid of starting points
/// spanning (r_min, 4 x steady radius) on each axis, and analyse the one closest to the map.
///
/// Used to show numerically that the equilibrium is unique and stable over the envelope.
pub fn equilibria(model: &Model, terms: &InputTerms) -> Equilibrium {
    let d = &model.dynamics;
    let target = terms.steady.radii();
    let lo = [d.r1_min, d.r2_min];
    let mut roots: Vec<[f64; 2]> = Vec::new();
    let n = 12;
    for a in 0..n {
        for b in 0..n {
            let mut r = [
                lo[0] + (4.0 * target[0] - lo[0]) * (a as f64 + 0.5) / n as f64,
                lo[1] + (4.0 * target[1] - lo[1]) * (b as f64 + 0.5) / n as f64,
            ];
            let mut ok = false;
            for _ in 0..100 {
                let f = terms.rhs(model, r);
                let j = terms.jac_state(model, r);
                let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
                if det.abs() < 1e-300 {
                    break;
                }
                let dx = [
                    (j[1][1] * f[0] - j[0][1] * f[1]) / det,
                    (-j[1][0] * f[0] + j[0][0] * f[1]) / det,
                ];
                // Damped step that stays above the packing limit.
                let mut t = 1.0;
                while t > 1e-4 && (r[0] - t * dx[0] <= lo[0] || r[1] - t * dx[1] <= lo[1]) {
                    t *= 0.5;
                }
                r = [r[0] - t * dx[0], r[1] - t * dx[1]];
                if (dx[0].abs() + dx[1].abs()) * t < 1e-11 * (r[0] + r[1]) {
                    let f = terms.rhs(model, r);
                    ok = f[0].abs() + f[1].abs() < 1e-8;
                    break;
                }
            }
            if ok
                && r.iter().all(|v| v.is_finite())
                && !roots
                    .iter()
                    .any(|q| (q[0] - r[0]).abs() + (q[1] - r[1]).abs() < 1e-6 * (r[0] + r[1]))
            {
                roots.push(r);
            }
        }
    }
    let best = roots
        .iter()
        .copied()
        .min_by(|p, q| {
            let dp = (p[0] - target[0]).abs() + (p[1] - target[1]).abs();
            let dq = (q[0] - target[0]).abs() + (q[1] - target[1]).abs();
            dp.total_cmp(&dq)
        })
        .unwrap_or([f64::NAN; 2]);
    Equilibrium {
        r: best,
        eig: eig2(terms.jac_state(model, best)),
        count: roots.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hz_to_rad_s as hz;

    #[test]
    fn rhs_matches_hand_computation() {
        let m = Model::paper();
        let t = InputTerms::new(&m, 0.0085, hz(4.0));
        let d = m.dynamics;
        let r = [7.0, 12.0];
        let w: f64 = 4.0 / m.steady.f_ref;
        let e = d.K_tau * w.powf(d.p) * d.s_B * t.steady.field.b * r[0] * r[1];
        let f1 = -t.k_b[0] * t.steady.s_x * (r[0] - d.r1_min).powf(d.beta) + e - d.K_d1 * r[0];
        let f2 = -t.k_b[1] * t.steady.s_y * (r[1] - d.r2_min).powf(d.beta) + e - d.K_d2 * r[1];
        let got = t.rhs(&m, r);
        assert!((got[0] - f1).abs() < 1e-12 && (got[1] - f2).abs() < 1e-12);
    }

    #[test]
    fn scheduled_equilibrium_is_the_map() {
        let m = Model::paper();
        let t = InputTerms::new(&m, 0.0135, hz(6.0));
        let f = t.rhs(&m, t.steady.radii());
        assert!(f[0].abs() < 1e-10 && f[1].abs() < 1e-10, "{f:?}");
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let m = Model::paper();
        for &(z, f) in &[(0.0035, 1.0), (0.0085, 4.0), (0.0235, 10.0), (0.0135, 6.5)] {
            let om = hz(f);
            let t = InputTerms::new(&m, z, om);
            let r = [t.steady.r1 * 1.1, t.steady.r2 * 0.93];
            let js = t.jac_state(&m, r);
            let ju = t.jac_input(&m, r);
            let h = 1e-6;
            for j in 0..2 {
                let mut rp = r;
                let mut rm = r;
                rp[j] += h;
                rm[j] -= h;
                let (fp, fm) = (t.rhs(&m, rp), t.rhs(&m, rm));
                for i in 0..2 {
                    let fd = (fp[i] - fm[i]) / (2.0 * h);
                    assert!(
                        (fd - js[i][j]).abs() <= 1e-6 * fd.abs().max(1e-3),
                        "state {i}{j}"
                    );
                }
            }
            let steps = [1e-8, 1e-5];
            for j in 0..2 {
                let (mut up, mut um) = ([z, om], [z, om]);
                up[j] += steps[j];
                um[j] -= steps[j];
                let tp = InputTerms::new(&m, up[0], up[1]);
                let tm = InputTerms::new(&m, um[0], um[1]);
                let (fp, fm) = (tp.rhs(&m, r), tm.rhs(&m, r));
                for i in 0..2 {
                    let fd = (fp[i] - fm[i]) / (2.0 * steps[j]);
                    assert!(
                        (fd - ju[i][j]).abs() <= 1e-5 * fd.abs().max(1e-3),
                        "z {z} f {f} input d f{i}/du{j}: analytic {} fd {fd}",
                        ju[i][j]
                    );
                }
            }
        }
    }

    #[test]
    fn eig2_of_known_matrices() {
        let e = eig2([[-1.0, 0.0], [0.0, -3.0]]);
        assert_eq!(e, [(-1.0, 0.0), (-3.0, 0.0)]);
        let e = eig2([[0.0, 1.0], [-1.0, 0.0]]);
        assert_eq!(e, [(0.0, 1.0), (0.0, -1.0)]);
    }
}
