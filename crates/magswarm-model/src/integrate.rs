//! Error-controlled Dormand-Prince 5(4) stepping of the two-state ODE (4).
//!
//! Built for the FMU's hot path: the state is a `[f64; 2]`, nothing is allocated, and the
//! integrator carries its last accepted step size from one communication step to the next
//! (so a controller calling doStep every millisecond pays for about one stage set per call).
//! The whole integrator state is `Copy`, which makes FMU state save/restore a memcpy.

use crate::dynamics::InputTerms;
use crate::Model;

/// Tolerances and limits of the integrator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerances {
    /// Relative tolerance per step.
    pub rtol: f64,
    /// Absolute tolerance per step \[mm\].
    pub atol: f64,
    /// Largest internal step \[s\].
    pub h_max: f64,
    /// Most internal steps per communication step before giving up.
    pub max_steps: u32,
}

impl Default for Tolerances {
    fn default() -> Self {
        Tolerances {
            rtol: 1e-8,
            atol: 1e-9,
            h_max: 0.5,
            max_steps: 100_000,
        }
    }
}

/// Integrator memory carried between communication steps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stepper {
    /// Next internal step size to try \[s\].
    pub h_next: f64,
    /// Internal steps taken in total (for diagnostics and benches).
    pub steps: u64,
    /// Rejected internal steps in total.
    pub rejected: u64,
    /// The last accepted step that left the state unchanged, the last communication step if
    /// it was nothing but those, and the last stage of the last step (caches, not state).
    pub rest: RestMemo,
}

impl Default for Stepper {
    fn default() -> Self {
        Stepper {
            h_next: 1e-3,
            steps: 0,
            rejected: 0,
            rest: RestMemo::default(),
        }
    }
}

/// A formed swarm at constant inputs sits on a fixed point of the Dormand-Prince map: the
/// step's increment rounds away and `y` comes out bit for bit as it went in. The step is a
/// deterministic function of (state, step size, right-hand side, tolerances), so once such a
/// step has been taken, the same step again is known without evaluating it: this memo holds
/// its inputs and its step-size factor, and `advance` replays it (same state, same step
/// counts, same next step size; only the arithmetic is skipped). The right-hand side is
/// named by the terms' id ([`InputTerms::id`], as the other two memos name it: the same id
/// is the same computation, so the same function), not by its coefficients: a memo made
/// under other terms is simply not used (the step is computed, to the same bits). It is a
/// cache: equality ignores it, snapshots do not carry it (a restored plant recomputes the
/// step once).
///
/// It also keeps the last stage of the last accepted step (`FirstStage`): the first stage
/// of the next communication step, when that starts where this one ended under the same
/// right-hand side.
///
/// And the products of the last step size with the method's coefficients (`Scaled`).
#[derive(Debug, Clone, Copy, Default)]
pub struct RestMemo(
    Option<Rest>,
    Option<CommStep>,
    Option<FirstStage>,
    Option<Scaled>,
);

/// The products `hs * a_ij` (stages 2 to 6) and `hs * b_i` (the fifth-order solution) of a
/// step size `hs`, each held twice (once per component, so that a stage multiplies both
/// components by one load). A step computes `y + (hs * a_ij) * k_j` as before; the products
/// are the same numbers whether made in the step or kept from the last step of the same
/// size (a master's communication step after an input change is one step of the same
/// size every time).
#[derive(Debug, Clone, Copy)]
struct Scaled {
    hs: u64,
    a: [[f64; 2]; 15],
    b: [[f64; 2]; 5],
}

const A: [f64; 15] = [
    A21, A31, A32, A41, A42, A43, A51, A52, A53, A54, A61, A62, A63, A64, A65,
];
const B: [f64; 5] = [B1, B3, B4, B5, B6];

impl Scaled {
    /// The products for `hs`, made here unless they are those of the last step.
    #[inline(always)]
    fn of(slot: &mut Option<Scaled>, hs: f64) -> &Scaled {
        if !matches!(slot, Some(c) if c.hs == hs.to_bits()) {
            *slot = Some(Scaled::new(hs));
        }
        match slot {
            Some(c) => c,
            None => unreachable!("set above"),
        }
    }

    #[cold]
    #[inline(never)]
    fn new(hs: f64) -> Scaled {
        Scaled {
            hs: hs.to_bits(),
            a: A.map(|a| [hs * a; 2]),
            b: B.map(|b| [hs * b; 2]),
        }
    }
}

/// f(y) at the state `y` (bits) a communication step ended in, under the right-hand side of
/// the terms `id` ([`InputTerms::id`]): Dormand-Prince's last stage of an accepted step is
/// the first stage of the next (first same as last), and a communication step that starts
/// where the last one ended, under the same terms, takes it from here instead of
/// evaluating f(y) again (the same function at the same point: the same bits). Keyed like
/// [`CommStep`], by the terms' id.
#[derive(Debug, Clone, Copy)]
struct FirstStage {
    id: u64,
    y: [u64; 2],
    k1: [f64; 2],
}

/// A whole communication step that was nothing but rest steps: from the state `y` and the
/// step size `h_in` it left both unchanged but for the counts and the next step size. The
/// same call again (same terms, by [`InputTerms::id`], same y, h_in, communication step and
/// tolerances) has the same outcome, applied in O(1).
#[derive(Debug, Clone, Copy)]
struct CommStep {
    id: u64,
    y: [f64; 2],
    h_in: f64,
    h_comm: f64,
    tol: [f64; 3],
    d_steps: u64,
    h_out: f64,
}

#[derive(Debug, Clone, Copy)]
struct Rest {
    /// The terms' id (never 0: default terms, made by no computation, are never remembered).
    id: u64,
    y: [f64; 2],
    hs: f64,
    tol: [f64; 3],
    factor: f64,
}

impl PartialEq for RestMemo {
    fn eq(&self, _: &RestMemo) -> bool {
        true
    }
}

impl RestMemo {
    /// True when a rest step is remembered.
    pub fn is_set(&self) -> bool {
        self.0.is_some()
    }

    #[inline]
    fn factor_for(&self, id: u64, y: &[f64; 2], hs: f64, tol: &[f64; 3]) -> Option<f64> {
        match &self.0 {
            Some(r) if r.id == id && r.hs == hs && r.y == *y && r.tol == *tol => Some(r.factor),
            _ => None,
        }
    }
}

/// Why a communication step could not be completed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepError {
    /// The step size fell below the resolution of time (a stiff or non-finite right-hand side).
    StepTooSmall { t: f64, h: f64 },
    /// More internal steps than `Tolerances::max_steps`.
    TooManySteps { t: f64 },
    /// The state became non-finite.
    NonFinite { t: f64 },
}

impl std::fmt::Display for StepError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StepError::StepTooSmall { t, h } => {
                write!(f, "integrator step size {h:e} s too small at t = {t} s")
            }
            StepError::TooManySteps { t } => write!(f, "too many internal steps at t = {t} s"),
            StepError::NonFinite { t } => write!(f, "state became non-finite at t = {t} s"),
        }
    }
}

impl std::error::Error for StepError {}

// Dormand-Prince coefficients.
const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const B1: f64 = 35.0 / 384.0;
const B3: f64 = 500.0 / 1113.0;
const B4: f64 = 125.0 / 192.0;
const B5: f64 = -2187.0 / 6784.0;
const B6: f64 = 11.0 / 84.0;
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;

/// `y + sum_j ha_j k_j`, with `ha_j = hs * a_j` from [`Scaled`] (the same products, in the
/// same order, as `y + hs * a_j * k_j`).
#[inline(always)]
fn axpy(y: [f64; 2], k: &[[f64; 2]], ha: &[[f64; 2]]) -> [f64; 2] {
    let mut o = y;
    for (ki, hai) in k.iter().zip(ha) {
        o[0] += hai[0] * ki[0];
        o[1] += hai[1] * ki[1];
    }
    o
}

impl Stepper {
    /// The communication step from `y` by `h_comm` under `terms`, if it is one remembered as
    /// nothing but rest steps (see `CommStep`): apply its outcome (step counts, next step
    /// size; `y` stays) and return true. Otherwise false, and nothing changed.
    #[inline]
    pub fn replay(
        &mut self,
        terms: &InputTerms,
        y: &[f64; 2],
        h_comm: f64,
        tol: &Tolerances,
    ) -> bool {
        match &self.rest.1 {
            Some(c)
                if c.id == terms.id()
                    && c.y == *y
                    && c.h_in == self.h_next
                    && c.h_comm == h_comm
                    && c.tol == [tol.rtol, tol.atol, tol.h_max] =>
            {
                self.steps += c.d_steps;
                self.h_next = c.h_out;
                true
            }
            _ => false,
        }
    }

    /// Advance `y` from `t` by `h_comm` seconds under constant inputs (`terms`).
    ///
    /// The right-hand side is autonomous between input changes (inputs are held over a
    /// communication step, as FMI co-simulation prescribes), so time only counts steps.
    #[inline]
    pub fn advance(
        &mut self,
        model: &Model,
        terms: &InputTerms,
        y: &mut [f64; 2],
        t: f64,
        h_comm: f64,
        tol: &Tolerances,
    ) -> Result<(), StepError> {
        if self.replay(terms, y, h_comm, tol) {
            return Ok(());
        }
        // The paper's confinement exponent (beta = 3) gets a right-hand side of its own, with
        // the cube written out instead of chosen per evaluation, times its gain as
        // `(c g) (g g)` (two multiplications deep instead of three; `InputTerms::rhs` takes
        // the same form for beta = 3, so both give the same bits), fewer branches in the
        // seven stages, which LLVM then keeps in registers.
        if model.dynamics.beta == 3.0 {
            let f = |r: [f64; 2]| terms.rhs_with(model, r, crate::dynamics::gain_times_cube);
            self.advance_with(f, terms, y, t, h_comm, tol)
        } else {
            let f = |r: [f64; 2]| terms.rhs(model, r);
            self.advance_with(f, terms, y, t, h_comm, tol)
        }
    }

    /// [`Stepper::advance`] with the right-hand side `f` (that of `terms`).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn advance_with(
        &mut self,
        f: impl Fn([f64; 2]) -> [f64; 2],
        terms: &InputTerms,
        y: &mut [f64; 2],
        t: f64,
        h_comm: f64,
        tol: &Tolerances,
    ) -> Result<(), StepError> {
        let tol_key = [tol.rtol, tol.atol, tol.h_max];
        let (y_in, h_in, steps_in, rejected_in) = (*y, self.h_next, self.steps, self.rejected);
        let mut all_rest = true;
        let mut done = 0.0;
        let mut h = self.h_next.min(tol.h_max).min(h_comm);
        let id = terms.id();
        // k1 = f(y), computed only when a step is actually evaluated (or kept from the last
        // step, see `FirstStage`).
        let mut k1_slot: Option<[f64; 2]> = match &self.rest.2 {
            Some(f) if f.id == terms.id() && f.y == y.map(f64::to_bits) => Some(f.k1),
            _ => None,
        };
        let mut n = 0u32;
        while done < h_comm {
            let remaining = h_comm - done;
            // Land exactly on the communication point; avoid a sliver step after it.
            let last = h >= remaining * (1.0 - 1e-12) || remaining - h < 1e-3 * h;
            let hs = if last { remaining } else { h };
            n += 1;
            if n > tol.max_steps {
                return Err(StepError::TooManySteps { t: t + done });
            }
            if let Some(factor) = self.rest.factor_for(id, y, hs, &tol_key) {
                // The same accepted step as remembered: y stays, k1 = f(y) stays.
                done = if last { h_comm } else { done + hs };
                self.steps += 1;
                if !last || hs >= h {
                    h = (hs * factor).min(tol.h_max);
                }
                self.h_next = h;
                continue;
            }
            all_rest = false;
            let k1 = *k1_slot.get_or_insert_with(|| f(*y));
            let c = Scaled::of(&mut self.rest.3, hs);
            let k2 = f(axpy(*y, &[k1], &c.a[0..1]));
            let k3 = f(axpy(*y, &[k1, k2], &c.a[1..3]));
            let k4 = f(axpy(*y, &[k1, k2, k3], &c.a[3..6]));
            let k5 = f(axpy(*y, &[k1, k2, k3, k4], &c.a[6..10]));
            let k6 = f(axpy(*y, &[k1, k2, k3, k4, k5], &c.a[10..15]));
            let y5 = axpy(*y, &[k1, k3, k4, k5, k6], &c.b);
            let k7 = f(y5);
            let _ = (C2, C3, C4, C5); // stage times: the right-hand side is autonomous
            let mut err = 0.0f64;
            for i in 0..2 {
                let e = hs
                    * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i]);
                // max(|y|, |y5|) without f64::max's NaN rule: a NaN y5 (or y, which makes
                // y5 NaN) takes the non-finite branch below whatever err is, so both give
                // the same step.
                let (a, b) = (y[i].abs(), y5[i].abs());
                let sc = tol.atol + tol.rtol * if a >= b { a } else { b };
                err = err.max((e / sc).abs());
            }
            if !err.is_finite() || !y5[0].is_finite() || !y5[1].is_finite() {
                // Shrink hard; a non-finite trial usually means the step was far too large.
                h = hs * 0.1;
                self.rejected += 1;
                if h < 1e-14 * (1.0 + t.abs()) {
                    return Err(StepError::NonFinite { t: t + done });
                }
                continue;
            }
            // 0.9 err^-1/5 clamped to [0.2, 5]; the clamp decides without the libm call
            // whenever err is below (0.9/5)^5 = 1.89e-4 (the usual case of a formed swarm)
            // or above (0.9/0.2)^5 = 1845 (thresholds kept inside those bounds, so the
            // result is the same as evaluating the power).
            let factor = if err < 1.8e-4 {
                5.0
            } else if err > 1900.0 {
                0.2
            } else {
                // Within 1e-14 of libm's power (crate::fastpow): the step size it sets moves
                // the solution by far less than the tolerance it controls.
                (0.9 * crate::fastpow::pow(err, -0.2)).clamp(0.2, 5.0)
            };
            if err <= 1.0 {
                if y5 == *y && id != 0 {
                    self.rest.0 = Some(Rest {
                        id,
                        y: y5,
                        hs,
                        tol: tol_key,
                        factor,
                    });
                } else if self.rest.0.is_some() {
                    self.rest.0 = None;
                }
                *y = y5;
                k1_slot = Some(k7);
                done = if last { h_comm } else { done + hs };
                self.steps += 1;
                // Remember the step the error asked for, not the truncated last one.
                if !last || hs >= h {
                    h = (hs * factor).min(tol.h_max);
                }
                self.h_next = h;
            } else {
                self.rejected += 1;
                h = hs * factor.min(1.0);
                if h < 1e-14 * (1.0 + t.abs()) {
                    return Err(StepError::StepTooSmall { t: t + done, h });
                }
            }
        }
        // Whatever k1 holds now is f at the state the step ended in (an accepted step's
        // last stage, or f(y) of a state that did not move).
        self.rest.2 = k1_slot.map(|k1| FirstStage {
            id,
            y: y.map(f64::to_bits),
            k1,
        });
        // A step of nothing but replayed rest steps is remembered whole (see `CommStep`).
        if all_rest && *y == y_in && self.rejected == rejected_in {
            self.rest.1 = Some(CommStep {
                id,
                y: y_in,
                h_in,
                h_comm,
                tol: tol_key,
                d_steps: self.steps - steps_in,
                h_out: self.h_next,
            });
        } else if self.rest.1.is_some() {
            self.rest.1 = None;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hz_to_rad_s as hz;

    #[test]
    fn converges_to_the_steady_map() {
        let m = Model::paper();
        let terms = InputTerms::new(&m, 0.0085, hz(4.0));
        let mut y = [3.0, 4.0];
        let mut st = Stepper::default();
        let tol = Tolerances::default();
        let mut t = 0.0;
        for _ in 0..600 {
            st.advance(&m, &terms, &mut y, t, 0.1, &tol).unwrap();
            t += 0.1;
        }
        assert!(
            (y[0] - terms.steady.r1).abs() < 1e-6,
            "{y:?} {:?}",
            terms.steady
        );
        assert!((y[1] - terms.steady.r2).abs() < 1e-6);
    }

    #[test]
    fn step_size_independent_results() {
        let m = Model::paper();
        let terms = InputTerms::new(&m, 0.0135, hz(7.0));
        let tol = Tolerances::default();
        let run = |h: f64, n: usize| {
            let mut y = [5.0, 6.0];
            let mut st = Stepper::default();
            for i in 0..n {
                st.advance(&m, &terms, &mut y, i as f64 * h, h, &tol)
                    .unwrap();
            }
            y
        };
        let a = run(0.001, 2000);
        let b = run(0.5, 4);
        assert!(
            (a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6,
            "{a:?} {b:?}"
        );
    }
}
