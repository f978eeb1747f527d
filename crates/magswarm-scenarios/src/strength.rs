//! What strength means: the part of a shape that the baseline cannot absorb.
//!
//! A shape that the rig's own free parameters can mimic is invisible after identification,
//! whatever its size: a camera's scale is a change of the gains C_i, a swarm a little off the
//! axis sees the field of a slightly larger distance, which the exponents alpha_i largely
//! follow. Naming the effect of such a shape "at strength 3" because its raw size is three
//! times the visit noise would score diagnose on what no method can see. So a scenario's
//! strength is the **largest deviation, over the rows of its training log, of the noise-free
//! log from the best least-squares imitation by the baseline, in units of the lab's visit
//! noise** (per axis). The baseline's parameters are those a lab identifies: the seed's axis
//! parameters C_i, a_K,i, alpha_i and its frequency law N, q (Table I), and the size (per axis)
//! and time constant of the rig's own approach after an input change; the imitation is a
//! nonlinear least-squares fit of them (Levenberg-Marquardt from the rig's values).
//!
//! The shape's amplitude is found so that this deviation equals the strength asked for (a
//! bisection on the linearised deviation, then secant steps on the nonlinear one); where the
//! physics bounds the amplitude (an offset of 20 mm, a full share) the strength reached is
//! recorded instead, and the benchmark scores the scenario at the strength it has.

use crate::lab::{Lab, Plan, Row};
use crate::shape::Shape;
use nalgebra::{DMatrix, DVector};

/// Parameters of the baseline's imitation, in a well-scaled form.
const NP: usize = 11;

fn get(l: &Lab) -> [f64; NP] {
    let s = &l.model.steady;
    [
        s.C_1.ln(),
        s.C_2.ln(),
        s.a_K1.ln(),
        s.a_K2.ln(),
        s.alpha_1,
        s.alpha_2,
        s.N,
        s.q,
        l.tau.ln(),
        l.own_gain[0],
        l.own_gain[1],
    ]
}

fn set(l: &mut Lab, p: &[f64]) {
    let s = &mut l.model.steady;
    s.C_1 = p[0].exp();
    s.C_2 = p[1].exp();
    s.a_K1 = p[2].exp();
    s.a_K2 = p[3].exp();
    s.alpha_1 = p[4];
    s.alpha_2 = p[5];
    s.N = p[6];
    s.q = p[7];
    l.tau = p[8].exp();
    l.own_gain = [p[9], p[10]];
}

/// The rig and a plan: what the baseline can imitate on that plan's rows.
pub(crate) struct Absorb<'a> {
    lab: &'a Lab,
    plan: &'a Plan,
    /// The noise-free rows without effects (stacked, in visit-SD units).
    base: DVector<f64>,
    /// Orthonormal basis of the parameters' directions at the rig's values.
    basis: DMatrix<f64>,
}

impl<'a> Absorb<'a> {
    /// The imitation's directions on `plan`.
    pub fn new(lab: &'a Lab, plan: &'a Plan) -> Absorb<'a> {
        let p0 = get(lab);
        let base = stack(lab, &lab.rows(&[], plan));
        let jac = jacobian(lab, plan, &p0, &base);
        let svd = jac.svd(true, false);
        let u = svd.u.expect("U");
        let smax = svd.singular_values.max();
        let keep: Vec<usize> = (0..svd.singular_values.len())
            .filter(|&i| svd.singular_values[i] > 1e-9 * smax)
            .collect();
        Absorb {
            lab,
            plan,
            base,
            basis: u.select_columns(&keep),
        }
    }

    fn deviation(&self, effects: &[(Shape, f64)]) -> DVector<f64> {
        stack(self.lab, &self.lab.rows(effects, self.plan)) - &self.base
    }

    /// The largest deviation \[visit SDs\] of the noise-free rows with `effects` from the
    /// baseline's imitation of them linearised at the rig's values.
    pub fn visible_linear(&self, effects: &[(Shape, f64)]) -> f64 {
        let d = self.deviation(effects);
        let r = &d - &self.basis * (self.basis.tr_mul(&d));
        r.amax()
    }

    /// The largest deviation \[visit SDs\] of the noise-free rows with `effects` from the
    /// baseline's best (nonlinear least-squares) imitation of them.
    pub fn visible(&self, effects: &[(Shape, f64)]) -> f64 {
        self.unabsorbed(effects)
            .amax()
            .min(self.visible_linear(effects))
    }

    /// The operating points of the plan where the unabsorbed deviation of `effects` (a visit's
    /// mean, either radius) reaches half its largest value: where a residual can show it.
    pub fn where_visible(&self, effects: &[(Shape, f64)]) -> Vec<(f64, f64)> {
        let d = self.unabsorbed(effects);
        let n = self.plan.rows;
        let means: Vec<f64> = (0..self.plan.visits.len())
            .map(|v| {
                (0..2)
                    .map(|a| ((0..n).map(|k| d[2 * (v * n + k) + a]).sum::<f64>() / n as f64).abs())
                    .fold(0.0, f64::max)
            })
            .collect();
        let top = means.iter().copied().fold(0.0, f64::max);
        let mut pts: Vec<(f64, f64)> = (0..means.len())
            .filter(|&v| top > 0.0 && means[v] >= 0.5 * top)
            .map(|v| self.plan.visits[v])
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        pts.dedup();
        pts
    }

    /// The noise-free rows' deviation with `effects` from the baseline's best imitation
    /// (stacked, in visit SDs).
    fn unabsorbed(&self, effects: &[(Shape, f64)]) -> DVector<f64> {
        let y = stack(self.lab, &self.lab.rows(effects, self.plan));
        let mut p = get(self.lab);
        let mut lab = self.lab.clone();
        let mut r = &y - &self.base;
        let mut cost = r.norm_squared();
        let mut mu = 1e-3;
        for _ in 0..12 {
            let cur = stack(&lab, &lab.rows(&[], self.plan));
            let j = jacobian(&lab, self.plan, &p, &cur);
            let jtj = j.tr_mul(&j);
            let g = j.tr_mul(&r);
            let mut improved = false;
            for _ in 0..6 {
                let mut a = jtj.clone();
                for i in 0..NP {
                    a[(i, i)] += mu * (jtj[(i, i)] + 1e-12);
                }
                let Some(step) = a.cholesky().map(|c| c.solve(&g)) else {
                    mu *= 10.0;
                    continue;
                };
                let trial: Vec<f64> = p.iter().zip(step.iter()).map(|(a, b)| a + b).collect();
                let mut l2 = lab.clone();
                set(&mut l2, &trial);
                let r2 = &y - stack(&l2, &l2.rows(&[], self.plan));
                let c2 = r2.norm_squared();
                if c2.is_finite() && c2 < cost {
                    p.copy_from_slice(&trial);
                    lab = l2;
                    r = r2;
                    let done = cost - c2 < 1e-10 * cost.max(1e-300);
                    cost = c2;
                    mu = (mu / 3.0).max(1e-9);
                    improved = !done;
                    break;
                }
                mu *= 10.0;
            }
            if !improved {
                break;
            }
        }
        r
    }

    /// The amplitude of `shape` at which its visible deviation is `strength`, and the
    /// strength reached (less than asked where the physics bounds the amplitude).
    pub fn calibrate(&self, shape: Shape, strength: f64) -> (f64, f64) {
        let hi = shape.max_amplitude();
        let lin = |x: f64| self.visible_linear(&[(shape, x)]);
        // The linearised deviation first (cheap): a bisection.
        let mut x = if lin(hi) <= strength {
            hi
        } else {
            let (mut lo, mut up) = (0.0, hi);
            for _ in 0..50 {
                let mid = 0.5 * (lo + up);
                if lin(mid) < strength {
                    lo = mid;
                } else {
                    up = mid;
                }
            }
            0.5 * (lo + up)
        };
        // Then the nonlinear one: secant steps on a deviation nearly proportional to x.
        let mut v = self.visible(&[(shape, x)]);
        for _ in 0..4 {
            if (v - strength).abs() < 0.02 * strength || v <= 0.0 {
                break;
            }
            let next = (x * strength / v).min(hi);
            if next == x {
                break;
            }
            x = next;
            v = self.visible(&[(shape, x)]);
        }
        (x, v)
    }
}

fn stack(lab: &Lab, rows: &[Row]) -> DVector<f64> {
    DVector::from_iterator(
        2 * rows.len(),
        rows.iter()
            .flat_map(|r| [r.r[0] / lab.visit_sd[0], r.r[1] / lab.visit_sd[1]]),
    )
}

/// Forward differences of the stacked rows in the imitation's parameters at `p`.
fn jacobian(lab: &Lab, plan: &Plan, p: &[f64; NP], at: &DVector<f64>) -> DMatrix<f64> {
    let mut j = DMatrix::zeros(at.len(), NP);
    for k in 0..NP {
        let h = 1e-5 * p[k].abs().max(1e-2);
        let mut q = *p;
        q[k] += h;
        let mut l = lab.clone();
        set(&mut l, &q);
        let d = (stack(&l, &l.rows(&[], plan)) - at) / h;
        j.set_column(k, &d);
    }
    j
}
