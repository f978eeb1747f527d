//! The inverse steady map (feedforward): the inputs (z_m, omega) whose steady radii are a
//! target (r1*, r2*), or, when no inputs in the envelope give the target, the reachable radii
//! nearest to it.
//!
//! The map (5)-(7) folds: over the seed's envelope its Jacobian is singular along a curve
//! from about (5 mm, 9.5 Hz) to (21 mm, 3 Hz) (r1 falls and then rises with frequency), so
//! the reachable set is a thin band of the (r1, r2) plane, a target may have two preimages,
//! and the nearest reachable point of an infeasible target may lie on the image of the fold
//! rather than of the envelope's edges. The solver therefore minimises the squared distance
//! `|r(z_m, omega) - r*|^2` over the input box by a projected (bound-constrained)
//! Levenberg-Marquardt on the analytic Jacobian, started from a grid over the box; a feasible
//! target is a zero of that distance (Newton's iteration is what LM reduces to there).
//! Among equally good solutions the one with the lowest frequency (then the smallest z_m) is
//! returned: that keeps the choice deterministic (the Rust and Python harnesses agree), keeps
//! the swarm away from the retrograde regime above f_off ~ 6 Hz where it can, and stays on the
//! fold's low-frequency sheet (det J > 0) so that consecutive setpoints do not jump sheets.
//!
//! Work is done in normalised inputs x in [0, 1]^2 (z_m and f scaled by the envelope's spans),
//! which makes the box, the damping and the tolerances dimensionless.

use magswarm_model::{steady, Envelope, Model};
use serde::{Deserialize, Serialize};

use crate::mat2::{self, M2};

/// Options of [`inverse_with`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InverseOptions {
    /// Input box (default: the model's envelope, z_m 3.5-23.5 mm, f 1-10 Hz).
    pub bounds: Option<Envelope>,
    /// Starting points per axis of the grid over the box (`grid * grid` starts).
    pub grid: usize,
    /// Iteration cap per start.
    pub max_iter: usize,
    /// A target is feasible when the distance of the best point to it is below this [mm].
    pub feasible_tol_mm: f64,
}

impl Default for InverseOptions {
    fn default() -> Self {
        InverseOptions {
            bounds: None,
            grid: 5,
            max_iter: 300,
            feasible_tol_mm: 1e-6,
        }
    }
}

/// What [`inverse`] found.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct InverseResult {
    /// Target radii (r1*, r2*) [mm].
    pub target: [f64; 2],
    /// Magnet-swarm distance [m].
    pub z_m: f64,
    /// Field angular velocity [rad/s].
    pub omega: f64,
    /// Steady radius r1 at (z_m, omega) [mm]: the target when feasible, else the nearest
    /// reachable r1.
    pub r1: f64,
    /// Steady radius r2 at (z_m, omega) [mm].
    pub r2: f64,
    /// True when the target is reachable within the box (distance below the tolerance).
    pub feasible: bool,
    /// Euclidean distance from the target to (r1, r2) in the (r1, r2) plane [mm].
    pub distance_mm: f64,
    /// Iterations of the start that gave the result.
    pub iterations: usize,
    /// Total iterations over all starts.
    pub total_iterations: usize,
    /// Which inputs sit on the box: [z_m at min, z_m at max, f at min, f at max].
    pub at_bound: [bool; 4],
    /// d(r1, r2)/d(z_m [m], omega [rad/s]) at the result [mm/m, mm s/rad].
    pub jac: [[f64; 2]; 2],
}

impl InverseResult {
    /// Field frequency [Hz].
    pub fn f_hz(&self) -> f64 {
        magswarm_model::rad_s_to_hz(self.omega)
    }

    /// Radii reached [mm].
    pub fn radii(&self) -> [f64; 2] {
        [self.r1, self.r2]
    }

    /// One line for people, e.g. "target infeasible, nearest reachable (7.80, 10.40) mm,
    /// distance 0.91 mm".
    pub fn describe(&self) -> String {
        if self.feasible {
            format!(
                "target ({:.3}, {:.3}) mm feasible: z_m {:.3} mm, f {:.3} Hz",
                self.target[0],
                self.target[1],
                self.z_m * 1e3,
                self.f_hz()
            )
        } else {
            format!(
                "target ({:.3}, {:.3}) mm infeasible, nearest reachable ({:.3}, {:.3}) mm, \
                 distance {:.3} mm, at z_m {:.3} mm, f {:.3} Hz",
                self.target[0],
                self.target[1],
                self.r1,
                self.r2,
                self.distance_mm,
                self.z_m * 1e3,
                self.f_hz()
            )
        }
    }
}

/// Affine map between physical inputs and the normalised box [0, 1]^2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Scale {
    pub z0: f64,
    pub dz: f64,
    pub w0: f64,
    pub dw: f64,
}

impl Scale {
    pub fn new(b: &Envelope) -> Scale {
        let tau = std::f64::consts::TAU;
        Scale {
            z0: b.z_min_m,
            dz: b.z_max_m - b.z_min_m,
            w0: b.f_min_hz * tau,
            dw: (b.f_max_hz - b.f_min_hz) * tau,
        }
    }

    /// (z_m, omega) from x.
    pub fn u_of(self, x: [f64; 2]) -> [f64; 2] {
        [self.z0 + self.dz * x[0], self.w0 + self.dw * x[1]]
    }

    /// x from (z_m, omega).
    pub fn x_of(self, u: [f64; 2]) -> [f64; 2] {
        [(u[0] - self.z0) / self.dz, (u[1] - self.w0) / self.dw]
    }

    /// Jacobian in normalised inputs [mm per span].
    pub fn jac_x(&self, jac: &M2) -> M2 {
        [
            [jac[0][0] * self.dz, jac[0][1] * self.dw],
            [jac[1][0] * self.dz, jac[1][1] * self.dw],
        ]
    }
}

/// Inverse of the steady map over the model's envelope with default options.
pub fn inverse(model: &Model, r1: f64, r2: f64) -> InverseResult {
    inverse_with(model, r1, r2, &InverseOptions::default())
}

struct Run {
    x: [f64; 2],
    r: [f64; 2],
    jac: M2,
    dist: f64,
    iters: usize,
}

/// Inverse of the steady map with explicit options.
pub fn inverse_with(model: &Model, r1: f64, r2: f64, opt: &InverseOptions) -> InverseResult {
    let bounds = opt.bounds.unwrap_or(model.envelope);
    let sc = Scale::new(&bounds);
    let target = [r1, r2];
    let n = opt.grid.max(1);
    let mut best: Option<Run> = None;
    let mut total = 0;
    for i in 0..n {
        for j in 0..n {
            let pos = |k: usize| {
                if n == 1 {
                    0.5
                } else {
                    k as f64 / (n - 1) as f64
                }
            };
            let run = solve_from(model, &sc, target, [pos(i), pos(j)], opt);
            total += run.iters;
            best = Some(match best {
                None => run,
                Some(b) => {
                    if better(&run, &b, opt.feasible_tol_mm) {
                        run
                    } else {
                        b
                    }
                }
            });
        }
    }
    let b = best.expect("at least one start");
    let u = sc.u_of(b.x);
    let e = 1e-9;
    InverseResult {
        target,
        z_m: u[0],
        omega: u[1],
        r1: b.r[0],
        r2: b.r[1],
        feasible: b.dist <= opt.feasible_tol_mm,
        distance_mm: b.dist,
        iterations: b.iters,
        total_iterations: total,
        at_bound: [
            b.x[0] <= e,
            b.x[0] >= 1.0 - e,
            b.x[1] <= e,
            b.x[1] >= 1.0 - e,
        ],
        jac: b.jac,
    }
}

/// Is `a` a better answer than `b`? Smaller distance, and among (numerically) equal ones the
/// lower frequency, then the smaller z_m.
fn better(a: &Run, b: &Run, tol: f64) -> bool {
    let tie = tol.max(1e-9 * (1.0 + b.dist));
    if a.dist < b.dist - tie {
        return true;
    }
    if a.dist > b.dist + tie {
        return false;
    }
    if (a.x[1] - b.x[1]).abs() > 1e-6 {
        return a.x[1] < b.x[1];
    }
    a.x[0] < b.x[0] - 1e-6
}

fn eval(model: &Model, sc: &Scale, x: [f64; 2]) -> ([f64; 2], M2, M2) {
    let u = sc.u_of(x);
    let sp = steady::evaluate(model, u[0], u[1]);
    (sp.radii(), sc.jac_x(&sp.jac), sp.jac)
}

/// Projected Levenberg-Marquardt from one start.
fn solve_from(model: &Model, sc: &Scale, t: [f64; 2], x0: [f64; 2], opt: &InverseOptions) -> Run {
    let clamp = |x: [f64; 2]| [x[0].clamp(0.0, 1.0), x[1].clamp(0.0, 1.0)];
    let mut x = clamp(x0);
    let (mut r, mut jx, mut jac) = eval(model, sc, x);
    let mut res = [r[0] - t[0], r[1] - t[1]];
    let mut cost = 0.5 * (res[0] * res[0] + res[1] * res[1]);
    let h0 = mat2::mul(&mat2::t(&jx), &jx);
    let mut mu = 1e-3 * h0[0][0].max(h0[1][1]).max(1e-12);
    let mut nu = 2.0;
    let mut iters = 0;
    while iters < opt.max_iter {
        iters += 1;
        if cost.sqrt() < 1e-13 {
            break;
        }
        let g = [
            jx[0][0] * res[0] + jx[1][0] * res[1],
            jx[0][1] * res[0] + jx[1][1] * res[1],
        ];
        let h = mat2::mul(&mat2::t(&jx), &jx);
        // Active bounds: on a face with the descent direction pointing out of the box.
        let free = [
            !((x[0] <= 0.0 && g[0] > 0.0) || (x[0] >= 1.0 && g[0] < 0.0)),
            !((x[1] <= 0.0 && g[1] > 0.0) || (x[1] >= 1.0 && g[1] < 0.0)),
        ];
        let pg = [
            if free[0] { g[0] } else { 0.0 },
            if free[1] { g[1] } else { 0.0 },
        ];
        if pg[0].abs() + pg[1].abs() < 1e-15 {
            break;
        }
        let step = match (free[0], free[1]) {
            (true, true) => {
                let a = [[h[0][0] + mu, h[0][1]], [h[1][0], h[1][1] + mu]];
                match mat2::inv(&a) {
                    Some(ai) => {
                        let s = mat2::mul_v(&ai, g);
                        [-s[0], -s[1]]
                    }
                    None => [0.0, 0.0],
                }
            }
            (true, false) => [-g[0] / (h[0][0] + mu), 0.0],
            (false, true) => [0.0, -g[1] / (h[1][1] + mu)],
            (false, false) => [0.0, 0.0],
        };
        let xn = clamp([x[0] + step[0], x[1] + step[1]]);
        let d = [xn[0] - x[0], xn[1] - x[1]];
        if d[0].abs() + d[1].abs() < 1e-15 {
            // The projected step vanished: converged to a (constrained) stationary point,
            // unless the damping is what stalls it.
            if mu > 1e12 {
                break;
            }
            mu *= nu;
            nu *= 2.0;
            continue;
        }
        let (rn, jxn, jacn) = eval(model, sc, xn);
        let resn = [rn[0] - t[0], rn[1] - t[1]];
        let costn = 0.5 * (resn[0] * resn[0] + resn[1] * resn[1]);
        // Predicted reduction of the (projected) step under the linear model.
        let jd = mat2::mul_v(&jx, d);
        let pred = -(g[0] * d[0] + g[1] * d[1]) - 0.5 * (jd[0] * jd[0] + jd[1] * jd[1]);
        if costn < cost {
            let rho = if pred > 0.0 {
                (cost - costn) / pred
            } else {
                1.0
            };
            mu *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
            nu = 2.0;
            let rel = cost - costn;
            x = xn;
            r = rn;
            jx = jxn;
            jac = jacn;
            res = resn;
            cost = costn;
            if rel < 1e-30 + 1e-16 * cost && d[0].abs() + d[1].abs() < 1e-13 {
                break;
            }
        } else {
            if mu > 1e12 {
                break;
            }
            mu *= nu;
            nu *= 2.0;
        }
    }
    Run {
        x,
        r,
        jac,
        dist: (2.0 * cost).sqrt(),
        iters,
    }
}

/// Is a point with normalised inputs `x` and radius residual `res` (= r - r*) a stationary
/// point of the distance over the box (first-order conditions, for tests)? Returns the
/// projected gradient's size relative to |J^T| |res|.
pub fn projected_gradient(model: &Model, res: &InverseResult, bounds: Option<Envelope>) -> f64 {
    let sc = Scale::new(&bounds.unwrap_or(model.envelope));
    let x = sc.x_of([res.z_m, res.omega]);
    let jx = sc.jac_x(&res.jac);
    let e = [res.r1 - res.target[0], res.r2 - res.target[1]];
    let g = [
        jx[0][0] * e[0] + jx[1][0] * e[1],
        jx[0][1] * e[0] + jx[1][1] * e[1],
    ];
    let mut pg = 0.0f64;
    for k in 0..2 {
        let blocked = (x[k] <= 1e-9 && g[k] > 0.0) || (x[k] >= 1.0 - 1e-9 && g[k] < 0.0);
        if !blocked {
            pg = pg.max(g[k].abs());
        }
    }
    let s = mat2::singular_values(&jx)[0] * (e[0].hypot(e[1])).max(1e-300);
    pg / s
}
