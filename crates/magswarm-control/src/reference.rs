//! The controller's reference model: ODE (4) driven by the feedforward, stepped with a
//! fixed-step classical Runge-Kutta method instead of the plant's error-controlled
//! Dormand-Prince integrator.
//!
//! # Why not the plant itself
//!
//! The reference only has to be far more accurate than anything the PID acts on (the model's
//! own error, disturbances, the command's resolution, see `pid`); the plant's integrator holds
//! every step to rtol 1e-8 with an error estimate, a step-size controller and memos, about
//! 470 instructions a step, and the reference steps on every sample of a transient (27 % of
//! the seed's 1 kHz tracking run). Four stages of the same right-hand side (the same
//! [`InputTerms`], the same expression) per step do the same job for less than half of that.
//!
//! # Accuracy
//!
//! The step is split into `n` equal substeps so that `h * rho <= THETA`, with `rho` the
//! infinity norm of the ODE's Jacobian at the state the sample starts from (a bound on the
//! modulus of its eigenvalues; it moves little over one sample). The classical method's
//! error on a linear mode `lambda` over the whole decay of a deviation `d` is at most about
//! `e^-1 (h lambda)^4 / 120 |d|` (the amplification error per step `(h lambda)^5 / 120`,
//! summed over the decay): below `2e-8 |d|` at `THETA = 0.05`, `2e-11 |d|` at 1 kHz in the
//! seed's scenario (`h rho <= 0.0096`, one step a sample). Over the seed's scenario the
//! reference stays within 5e-12 mm of ODE (4) at 1 kHz and 8.4e-10 mm at the default
//! 20 Hz (the plant model at rtol 1e-13, steps of at most 0.25 ms; the plant model at its
//! own rtol 1e-8, the reference before, is 5e-12 and 2.5e-8 mm from it):
//! `lean_reference_follows_the_full_model` in this crate's `tests/closed_loop.rs`.
//!
//! At rest the state sits on a fixed point of the step (the increment rounds away), and the
//! step is then skipped until the inputs change: the same result, for nothing.

use magswarm_model::dynamics::{pow_int_or_real, InputTerms};
use magswarm_model::{Model, Plant, PlantSnapshot};

/// Largest `h * rho` of a substep (see the module's docs).
const THETA: f64 = 0.05;

/// ODE (4) under held inputs, stepped by the classical fourth-order Runge-Kutta method.
#[derive(Debug, Clone)]
pub(crate) struct Reference {
    /// The inputs in force (z_m \[m\], omega [rad/s]).
    u: [f64; 2],
    /// The coefficients of (4) at them.
    c: Coefficients,
    /// The steady map's radii at them \[mm\] (where a non-finite step puts the state).
    steady: [f64; 2],
    /// The steady map's Jacobian there, d(r1, r2)/d(z_m, omega) (the controller's
    /// decoupler takes it when the command is this close to the feedforward).
    jac: [[f64; 2]; 2],
    /// Radii (r1, r2) \[mm\].
    r: [f64; 2],
    /// The last step left `r` bit for bit unchanged under `c`: the next is skipped.
    rest: bool,
}

/// The numbers the right-hand side of (4) reads, gathered from the input terms and the
/// model once per input change (the stages then read six numbers from one place).
#[derive(Debug, Clone, Copy)]
struct Coefficients {
    /// Expansion coefficient e0 [1/(mm s)].
    e0: f64,
    /// Confinement gains times stiffness, k_b,i S_i.
    c: [f64; 2],
    /// Relaxation rates K_d,i [1/s].
    kd: [f64; 2],
    /// Packing limits r_i,min \[mm\].
    rmin: [f64; 2],
    /// The confinement exponent beta (the paper's 3 is written out as a cube).
    beta: f64,
}

impl Coefficients {
    fn of(t: &InputTerms, model: &Model) -> Coefficients {
        let d = &model.dynamics;
        Coefficients {
            e0: t.e0,
            c: [t.k_b[0] * t.steady.s_x, t.k_b[1] * t.steady.s_y],
            kd: [d.K_d1, d.K_d2],
            rmin: [d.r1_min, d.r2_min],
            beta: d.beta,
        }
    }

    /// The right-hand side of (4) at `r` [mm/s] in the form [`InputTerms::rhs`] takes,
    /// `(e - K_d r) - conf(g, c)` with g = r - r_min and `conf(g, c)` = `c g^beta` (no
    /// confinement for g <= 0).
    #[inline(always)]
    fn rhs_with(&self, r: [f64; 2], conf: impl Fn(f64, f64) -> f64) -> [f64; 2] {
        let e = self.e0 * r[0] * r[1];
        let (g0, g1) = (r[0] - self.rmin[0], r[1] - self.rmin[1]);
        let c0 = if g0 > 0.0 { conf(g0, self.c[0]) } else { 0.0 };
        let c1 = if g1 > 0.0 { conf(g1, self.c[1]) } else { 0.0 };
        [(e - self.kd[0] * r[0]) - c0, (e - self.kd[1] * r[1]) - c1]
    }

    /// The infinity norm of d f / d r at `r` (a bound on the modulus of the eigenvalues),
    /// `dconf(g, c)` = `beta c g^(beta - 1)`.
    #[inline(always)]
    fn jacobian_norm_with(&self, r: [f64; 2], dconf: impl Fn(f64, f64) -> f64) -> f64 {
        let row = |i: usize| {
            let g = r[i] - self.rmin[i];
            let d = if g > 0.0 { dconf(g, self.c[i]) } else { 0.0 };
            (self.e0 * r[1 - i] - self.kd[i] - d).abs() + (self.e0 * r[i]).abs()
        };
        row(0).max(row(1))
    }

    /// [`Coefficients::rhs_with`] for any beta (the paper's 3 as `(c g) (g g)`, the form
    /// of the plant's integrator).
    #[cfg(test)]
    fn rhs(&self, r: [f64; 2]) -> [f64; 2] {
        if self.beta == 3.0 {
            self.rhs_with(r, cube)
        } else {
            self.rhs_with(r, |g, c| c * pow_int_or_real(g, self.beta))
        }
    }
}

/// `c g^3` as the plant's integrator evaluates it.
#[inline(always)]
fn cube(g: f64, c: f64) -> f64 {
    (c * g) * (g * g)
}

impl Reference {
    /// At state `r` \[mm\] under inputs `u` (z_m \[m\], omega [rad/s]).
    pub(crate) fn new(model: &Model, u: [f64; 2], r: [f64; 2]) -> Reference {
        // With the Jacobian: the same coefficients bit for bit as the plant's lean terms
        // after an input change, and the decoupler's Jacobian at the feedforward for a
        // little more.
        let t = InputTerms::new(model, u[0], u[1]);
        Reference {
            u,
            c: Coefficients::of(&t, model),
            steady: t.steady.radii(),
            jac: t.steady.jac,
            r,
            rest: false,
        }
    }

    /// From a plant's snapshot (its inputs and state; its integrator's memory does not
    /// apply).
    pub(crate) fn from_snapshot(model: &Model, s: &PlantSnapshot) -> Reference {
        Reference::new(model, s.inputs, s.r)
    }

    /// As a plant's snapshot (a plant at these inputs and this state), so that controller
    /// states keep one format whichever reference wrote them.
    pub(crate) fn snapshot(&self, model: &Model) -> PlantSnapshot {
        let mut p = Plant::new(model.clone(), self.u[0], self.u[1]);
        p.set_state(self.r);
        p.snapshot()
    }

    /// Radii \[mm\].
    #[inline]
    pub(crate) fn state(&self) -> [f64; 2] {
        self.r
    }

    /// The inputs in force (z_m \[m\], omega [rad/s]).
    #[inline]
    pub(crate) fn inputs(&self) -> [f64; 2] {
        self.u
    }

    /// The steady map's Jacobian at [`Reference::inputs`], d(r1, r2)/d(z_m \[m\],
    /// omega [rad/s]) [mm/m, mm s/rad]: that of `steady::evaluate` there.
    #[inline]
    pub(crate) fn map_jacobian(&self) -> [[f64; 2]; 2] {
        self.jac
    }

    /// Hold inputs `u` from now on (the terms are recomputed only when they change); whether
    /// they changed.
    #[inline]
    pub(crate) fn set_inputs(&mut self, model: &Model, u: [f64; 2]) -> bool {
        if u[0].to_bits() != self.u[0].to_bits() || u[1].to_bits() != self.u[1].to_bits() {
            self.change_inputs(model, u);
            return true;
        }
        false
    }

    #[inline(never)]
    fn change_inputs(&mut self, model: &Model, u: [f64; 2]) {
        *self = Reference::new(model, u, self.r);
    }

    /// Advance by `ts` seconds. A non-finite result (never expected inside the envelope)
    /// puts the state on the steady map, as the plant-based reference did on a failed step.
    /// Whether the state moved.
    #[inline]
    pub(crate) fn advance(&mut self, ts: f64) -> bool {
        if self.rest {
            return false;
        }
        self.integrate(ts);
        !self.rest
    }

    #[inline(never)]
    fn integrate(&mut self, ts: f64) {
        let c = self.c;
        // The paper's beta written out (a stage is then a dozen floating-point operations).
        if c.beta == 3.0 {
            self.integrate_with(
                ts,
                |r| c.rhs_with(r, cube),
                |r| c.jacobian_norm_with(r, |g, c| 3.0 * c * (g * g)),
            );
        } else {
            let b = c.beta;
            self.integrate_with(
                ts,
                |r| c.rhs_with(r, |g, c| c * pow_int_or_real(g, b)),
                |r| c.jacobian_norm_with(r, |g, c| b * c * pow_int_or_real(g, b - 1.0)),
            );
        }
    }

    /// [`Reference::integrate`] with the right-hand side `f` and the norm of its
    /// Jacobian `rho`.
    #[inline(always)]
    fn integrate_with(
        &mut self,
        ts: f64,
        f: impl Fn([f64; 2]) -> [f64; 2],
        rho: impl Fn([f64; 2]) -> f64,
    ) {
        let n = substeps(ts * rho(self.r));
        let mut y = self.r;
        if n == 1 {
            y = rk4(&f, y, ts);
        } else {
            let h = ts / n as f64;
            for _ in 0..n {
                y = rk4(&f, y, h);
            }
        }
        if !(y[0].is_finite() && y[1].is_finite()) {
            y = self.steady;
        }
        self.rest = y.map(f64::to_bits) == self.r.map(f64::to_bits);
        self.r = y;
    }
}

/// Substeps for a step of `h rho` = `x` (at least one; `x` NaN or huge: one, the result is
/// then caught as non-finite or is what it is).
#[inline(always)]
fn substeps(x: f64) -> u32 {
    if x <= THETA || x.is_nan() {
        return 1;
    }
    let n = (x / THETA).ceil();
    if n < 1e6 {
        n as u32
    } else {
        1
    }
}

/// One classical Runge-Kutta step of `f` from `y` over `h`.
#[inline(always)]
fn rk4(f: &impl Fn([f64; 2]) -> [f64; 2], y: [f64; 2], h: f64) -> [f64; 2] {
    let h2 = 0.5 * h;
    let at = |k: [f64; 2], s: f64| [y[0] + s * k[0], y[1] + s * k[1]];
    let k1 = f(y);
    let k2 = f(at(k1, h2));
    let k3 = f(at(k2, h2));
    let k4 = f(at(k3, h));
    let h6 = h / 6.0;
    [
        y[0] + h6 * ((k1[0] + k4[0]) + 2.0 * (k2[0] + k3[0])),
        y[1] + h6 * ((k1[1] + k4[1]) + 2.0 * (k2[1] + k3[1])),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The step's order: on ODE (4) from a deviation of a millimetre, halving the step
    /// divides the error after 1 s by about 16 (against the plant at a tight tolerance).
    #[test]
    fn the_step_is_fourth_order_on_ode_4() {
        let m = Model::paper();
        let u = [6.0e-3, 9.0 * std::f64::consts::TAU];
        let r0 = {
            let t = InputTerms::new(&m, u[0], u[1]);
            let r = t.steady.radii();
            [r[0] + 1.0, r[1] - 1.0]
        };
        let mut exact = Plant::new(m.clone(), u[0], u[1]);
        exact.tolerances_mut().rtol = 1e-13;
        exact.tolerances_mut().atol = 1e-15;
        exact.set_state(r0);
        exact.step(1.0).unwrap();
        let err = |h: f64| {
            let t = InputTerms::new(&m, u[0], u[1]);
            let c = Coefficients::of(&t, &m);
            // The same right-hand side as the plant's.
            assert_eq!(c.rhs(r0), t.rhs(&m, r0));
            let f = |r: [f64; 2]| c.rhs(r);
            let mut y = r0;
            for _ in 0..(1.0 / h).round() as usize {
                y = rk4(&f, y, h);
            }
            (y[0] - exact.state()[0])
                .abs()
                .max((y[1] - exact.state()[1]).abs())
        };
        let (coarse, fine) = (err(0.04), err(0.02));
        let ratio = coarse / fine;
        assert!((12.0..20.0).contains(&ratio), "{coarse} / {fine} = {ratio}");
        // The bound of the module's docs at h rho = THETA: a millimetre's transient within 2e-8 mm.
        let t = InputTerms::new(&m, u[0], u[1]);
        let j = t.jac_state(&m, r0);
        let rho = (j[0][0].abs() + j[0][1].abs()).max(j[1][0].abs() + j[1][1].abs());
        let c = Coefficients::of(&t, &m);
        let ours = c.jacobian_norm_with(r0, |g, c| 3.0 * c * (g * g));
        assert!((ours - rho).abs() <= 1e-12 * rho, "{ours} vs {rho}");
        let h = THETA / rho;
        assert!(err(1.0 / (1.0 / h).ceil()) < 2e-8, "{}", err(h));
    }

    #[test]
    fn substeps_keep_h_rho_at_most_theta() {
        assert_eq!(substeps(0.0), 1);
        assert_eq!(substeps(0.01), 1);
        assert_eq!(substeps(THETA), 1);
        assert_eq!(substeps(THETA * 1.5), 2);
        assert_eq!(substeps(0.48), 10);
        assert_eq!(substeps(f64::NAN), 1);
        assert_eq!(substeps(f64::INFINITY), 1);
    }

    /// At rest the step is skipped, and skipping it is what stepping would give.
    #[test]
    fn rest_is_a_fixed_point_of_the_step() {
        let m = Model::paper();
        let u = [8.5e-3, 4.0 * std::f64::consts::TAU];
        let mut r = Reference::new(&m, u, [8.0, 11.0]);
        let mut n = 0;
        while !r.rest {
            r.advance(1e-3);
            n += 1;
            assert!(n < 200_000, "no fixed point");
        }
        let at = r.state();
        let mut fresh = Reference::new(&m, u, at);
        fresh.advance(1e-3);
        assert_eq!(fresh.state(), at);
        assert!(fresh.rest);
        // A new input leaves rest.
        r.set_inputs(&m, [8.6e-3, u[1]]);
        r.advance(1e-3);
        assert_ne!(r.state(), at);
    }
}
