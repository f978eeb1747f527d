//! The best *constant*-gain ODE (4): how far the seed's constant confinement gains are from the map.
//!
//! ODE (4) as the seed writes it has constant confinement gains K_b1, K_b2. Its equilibrium
//! cannot follow the map (5) everywhere: the map scales as S^-alpha_i while the confinement of
//! (4) is linear in S. This module fits constant (K_b1, K_b2) — and, in a second fit, also the
//! expansion gain K_tau and exponent p — by Levenberg-Marquardt, minimising the sum of squared
//! relative equilibrium errors `(r_eq,i - r_map,i) / r_map,i` over a 21 x 16 sub-grid of the
//! fine envelope grid of [`super::fine_grid`] (41 x 46 points, both axes, where the errors are
//! then reported), from several starts, with every other parameter of the model
//! (beta, r_min, K_d, s_B) kept. The fitted gains are then put in the model with
//! `Confinement::Constant` and the reported errors come from the model crate's own
//! equilibrium search ([`magswarm_model::dynamics::equilibria`]), so the numbers are those a
//! user of `Confinement::Constant` would see.

use magswarm_fit::lm::{self, LevenbergMarquardt};
use magswarm_model::dynamics::{equilibria, InputTerms};
use magswarm_model::{hz_to_rad_s, Confinement, Model};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// One constant-gain fit and its errors over the envelope grid.
#[derive(Debug, Clone, Serialize)]
pub struct FitResult {
    /// Parameters that were free in this fit.
    pub free: Vec<String>,
    /// Constant confinement gains (K_b1, K_b2) [mm^(1-beta)/s].
    pub k_b: [f64; 2],
    /// Expansion gain K_tau [1/(mm s)] (fitted or the model's).
    pub k_tau: f64,
    /// Expansion exponent p [-] (fitted or the model's).
    pub p: f64,
    /// Largest relative equilibrium error over both axes and the grid.
    pub max_rel_error: f64,
    /// RMS of the relative equilibrium errors (both axes).
    pub rms_rel_error: f64,
    /// Where the largest error is: z_m \[mm\], f \[Hz\].
    pub worst_at: [f64; 2],
    /// True when K_tau ended within 1 % (in decades) of its bound (see [`KTAU_DECADES`]).
    pub k_tau_at_bound: bool,
    /// Grid points with no equilibrium near the map, or an unstable one.
    pub bad_points: usize,
    /// Optimiser starts (the best is kept).
    pub starts: usize,
    /// Residual evaluations used by the optimiser (all starts).
    pub evaluations: usize,
    /// Why the optimiser stopped.
    pub termination: String,
    /// Relative error [%] per grid point (rows: f, columns: z_m; larger of the two axes,
    /// NaN where no equilibrium was found). Not serialised.
    #[serde(skip)]
    pub error_map_pct: Vec<Vec<f64>>,
}

/// Both constant fits.
#[derive(Debug, Clone, Serialize)]
pub struct ConstantFit {
    /// Grid (z_m points, f points) the fits are evaluated on (the fine envelope grid).
    pub grid: [usize; 2],
    /// Sub-grid the fits were made on (every 2nd z_m, every 3rd f of `grid`).
    pub train_grid: [usize; 2],
    /// K_b1, K_b2 free; K_tau, p as in the model.
    pub kb_only: FitResult,
    /// K_b1, K_b2, K_tau, p free.
    pub full: FitResult,
}

/// What the residual needs at one grid point (everything that does not depend on the fit).
#[derive(Debug, Clone, Copy)]
struct Point {
    s: [f64; 2],
    /// e0 / K_tau without the frequency power: s_B B.
    sb_b: f64,
    /// |omega| / omega_ref.
    w: f64,
    r_map: [f64; 2],
}

/// Parameters of the constant ODE: (K_b1, K_b2, K_tau, p).
type Params = [f64; 4];

/// Equilibrium of (4) with constant gains near the map, by damped Newton from the map.
fn solve(m: &Model, pt: &Point, par: &Params) -> Option<[f64; 2]> {
    let d = &m.dynamics;
    let rmin = [d.r1_min, d.r2_min];
    let kd = [d.K_d1, d.K_d2];
    let e0 = par[2] * pt.w.powf(par[3]) * pt.sb_b;
    let f = |r: [f64; 2]| -> [f64; 2] {
        let e = e0 * r[0] * r[1];
        [0, 1]
            .map(|i| -par[i] * pt.s[i] * (r[i] - rmin[i]).max(0.0).powf(d.beta) + e - kd[i] * r[i])
    };
    let mut r = pt.r_map;
    for _ in 0..60 {
        let fv = f(r);
        let g = [0, 1].map(|i| {
            let gap = (r[i] - rmin[i]).max(0.0);
            -par[i] * pt.s[i] * d.beta * gap.powf(d.beta - 1.0) - kd[i]
        });
        let j = [[g[0] + e0 * r[1], e0 * r[0]], [e0 * r[1], g[1] + e0 * r[0]]];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        if !det.is_finite() || det.abs() < 1e-300 {
            return None;
        }
        let dx = [
            (j[1][1] * fv[0] - j[0][1] * fv[1]) / det,
            (-j[1][0] * fv[0] + j[0][0] * fv[1]) / det,
        ];
        let mut t = 1.0;
        while t > 1e-6 && (r[0] - t * dx[0] <= rmin[0] || r[1] - t * dx[1] <= rmin[1]) {
            t *= 0.5;
        }
        r = [r[0] - t * dx[0], r[1] - t * dx[1]];
        if !(r[0].is_finite() && r[1].is_finite()) || r[0] > 1e3 || r[1] > 1e3 {
            return None;
        }
        if (dx[0].abs() + dx[1].abs()) * t < 1e-12 * (r[0] + r[1]) {
            return Some(r);
        }
    }
    let fv = f(r);
    (fv[0].abs() + fv[1].abs() < 1e-8).then_some(r)
}

/// K_tau may move this many decades either side of the model's value. Without a bound the
/// fit runs off to infinite gains: the equilibrium depends only on K_b,i/K_tau and K_d,i/K_tau,
/// so growing every gain at fixed K_d is the limit K_d -> 0, with formation times -> 0.
pub const KTAU_DECADES: f64 = 2.0;
/// |p| is kept below this.
pub const P_BOUND: f64 = 3.0;

/// Penalty residual where no equilibrium is found (as if 100 % off).
const PENALTY: f64 = 1.0;

struct Problem<'a> {
    model: &'a Model,
    points: &'a [Point],
    /// Which of the 4 parameters are free (their indices); the rest come from `base`.
    free: &'a [usize],
    base: Params,
    /// Free parameters: log for K's (positive), p itself.
    x: DVector<f64>,
}

impl Problem<'_> {
    fn params_of(&self, x: &DVector<f64>) -> Params {
        let mut p = self.base;
        for (k, &i) in self.free.iter().enumerate() {
            p[i] = match i {
                0 | 1 => x[k].exp(),
                2 => self.base[2] * 10f64.powf(KTAU_DECADES * x[k].tanh()),
                _ => P_BOUND * x[k].tanh(),
            };
        }
        p
    }

    fn residuals_at(&self, x: &DVector<f64>) -> DVector<f64> {
        let par = self.params_of(x);
        let mut out = DVector::zeros(2 * self.points.len());
        for (n, pt) in self.points.iter().enumerate() {
            match solve(self.model, pt, &par) {
                Some(r) => {
                    out[2 * n] = (r[0] - pt.r_map[0]) / pt.r_map[0];
                    out[2 * n + 1] = (r[1] - pt.r_map[1]) / pt.r_map[1];
                }
                None => {
                    out[2 * n] = PENALTY;
                    out[2 * n + 1] = PENALTY;
                }
            }
        }
        out
    }
}

impl lm::Fit for Problem<'_> {
    fn set(&mut self, x: &[f64]) {
        self.x.copy_from_slice(x);
    }

    fn residuals(&self) -> DVector<f64> {
        self.residuals_at(&self.x)
    }

    fn jacobian(&self) -> DMatrix<f64> {
        let n = self.x.len();
        let m = 2 * self.points.len();
        let mut j = DMatrix::zeros(m, n);
        for k in 0..n {
            let h = 1e-6 * (1.0 + self.x[k].abs());
            let mut xp = self.x.clone();
            let mut xm = self.x.clone();
            xp[k] += h;
            xm[k] -= h;
            let d = (self.residuals_at(&xp) - self.residuals_at(&xm)) / (2.0 * h);
            j.set_column(k, &d);
        }
        j
    }
}

fn points(model: &Model, zs: &[f64], fs: &[f64]) -> Vec<(f64, f64, Point)> {
    let omega_ref = std::f64::consts::TAU * model.steady.f_ref;
    let mut v = Vec::with_capacity(zs.len() * fs.len());
    for &z in zs {
        for &f in fs {
            let t = InputTerms::new(model, z * 1e-3, hz_to_rad_s(f));
            let sp = t.steady;
            v.push((
                z,
                f,
                Point {
                    s: [sp.s_x, sp.s_y],
                    sb_b: model.dynamics.s_B * sp.field.b,
                    w: hz_to_rad_s(f).abs() / omega_ref,
                    r_map: sp.radii(),
                },
            ));
        }
    }
    v
}

/// The model with constant gains set to `par`.
pub fn constant_model(model: &Model, k_b: [f64; 2], k_tau: f64, p: f64) -> Model {
    let mut m = model.clone();
    m.dynamics.confinement = Confinement::Constant;
    m.dynamics.K_b1 = k_b[0];
    m.dynamics.K_b2 = k_b[1];
    m.dynamics.K_tau = k_tau;
    m.dynamics.p = p;
    m
}

/// Errors of the constant model with `par` over the grid, from the model crate's own
/// equilibrium search: (max, RMS, worst (z_m, f), bad points, error map [%] per [f][z]).
fn evaluate(
    model: &Model,
    zs: &[f64],
    fs: &[f64],
    par: Params,
) -> (f64, f64, [f64; 2], usize, Vec<Vec<f64>>) {
    let m = constant_model(model, [par[0], par[1]], par[2], par[3]);
    let (mut max, mut ss, mut n, mut worst, mut bad) = (0.0f64, 0.0, 0usize, [0.0; 2], 0usize);
    let mut map = vec![vec![f64::NAN; zs.len()]; fs.len()];
    for (i, &z) in zs.iter().enumerate() {
        for (j, &f) in fs.iter().enumerate() {
            let t = InputTerms::new(&m, z * 1e-3, hz_to_rad_s(f));
            let e = equilibria(&m, &t);
            let sp = t.steady;
            if e.count == 0 || !e.stable() {
                bad += 1;
            }
            let mut here = 0.0f64;
            for (r, rm) in e.r.iter().zip(sp.radii()) {
                let err = if r.is_finite() {
                    ((r - rm) / rm).abs()
                } else {
                    f64::INFINITY
                };
                ss += if err.is_finite() { err * err } else { PENALTY };
                n += 1;
                here = here.max(err);
                if err > max {
                    max = err;
                    worst = [z, f];
                }
            }
            map[j][i] = if here.is_finite() {
                100.0 * here
            } else {
                f64::NAN
            };
        }
    }
    (max, (ss / n as f64).sqrt(), worst, bad, map)
}

/// One Levenberg-Marquardt run from `start`; `base` holds the fixed parameters and the
/// reference of the K_tau bound. Returns the parameters, the objective and the report.
fn lm(
    model: &Model,
    pts: &[Point],
    free: &[usize],
    base: Params,
    start: Params,
) -> (Params, f64, usize, String) {
    let x0 = DVector::from_iterator(
        free.len(),
        free.iter().map(|&i| match i {
            0 | 1 => start[i].ln(),
            2 => ((start[2] / base[2]).log10() / KTAU_DECADES)
                .clamp(-0.99, 0.99)
                .atanh(),
            _ => (start[3] / P_BOUND).clamp(-0.99, 0.99).atanh(),
        }),
    );
    let problem = Problem {
        model,
        points: pts,
        free,
        base,
        x: x0.clone(),
    };
    let out = lm::minimize(problem, x0, LevenbergMarquardt::new().with_patience(200));
    let problem = out.fit;
    let par = problem.params_of(&problem.x);
    let obj = problem.residuals_at(&problem.x).norm_squared();
    (par, obj, out.evals, out.termination)
}

/// Best of several LM runs (`starts`), evaluated on the grid.
fn fit_one(
    model: &Model,
    grid: (&[f64], &[f64]),
    pts: &[Point],
    free: &[usize],
    base: Params,
    starts: &[Params],
) -> FitResult {
    let mut best: Option<(Params, f64, usize, String)> = None;
    let mut evals = 0;
    for &s in starts {
        let r = lm(model, pts, free, base, s);
        evals += r.2;
        if best.as_ref().is_none_or(|b| r.1 < b.1) {
            best = Some(r);
        }
    }
    let (par, _, _, termination) = best.expect("at least one start");
    let (max, rms, worst, bad, error_map_pct) = evaluate(model, grid.0, grid.1, par);
    let names = ["K_b1", "K_b2", "K_tau", "p"];
    FitResult {
        free: free.iter().map(|&i| names[i].to_string()).collect(),
        k_b: [par[0], par[1]],
        k_tau: par[2],
        p: par[3],
        max_rel_error: max,
        rms_rel_error: rms,
        worst_at: worst,
        k_tau_at_bound: free.contains(&2) && (par[2] / base[2]).log10().abs() > 0.99 * KTAU_DECADES,
        bad_points: bad,
        starts: starts.len(),
        evaluations: evals,
        termination,
        error_map_pct,
    }
}

/// Fit constant gains over the fine envelope grid (see the module doc).
pub fn fit(model: &Model) -> ConstantFit {
    let (zs, fs) = super::grid::fine_grid(model);
    // Start from the median scheduled gains (what the scheduled model uses mid-envelope).
    let mut sched = model.clone();
    sched.dynamics.confinement = Confinement::Scheduled;
    // Train on every 2nd z_m and every 3rd f of the grid (21 x 16, edges included);
    // evaluate on all of it.
    let tz: Vec<f64> = zs.iter().copied().step_by(2).collect();
    let tf: Vec<f64> = fs.iter().copied().step_by(3).collect();
    let all = points(&sched, &tz, &tf);
    let pts: Vec<Point> = all.iter().map(|p| p.2).collect();
    let (mut k1, mut k2) = (Vec::new(), Vec::new());
    for &(z, f, _) in &all {
        let t = InputTerms::new(&sched, z * 1e-3, hz_to_rad_s(f));
        k1.push(t.k_b[0]);
        k2.push(t.k_b[1]);
    }
    let d = &model.dynamics;
    let base = [
        super::grid::median(&k1),
        super::grid::median(&k2),
        d.K_tau,
        d.p,
    ];
    let grid = (&zs[..], &fs[..]);
    let kb_starts: Vec<Params> = [1.0, 0.3, 3.0]
        .iter()
        .map(|&c| [base[0] * c, base[1] * c, base[2], base[3]])
        .collect();
    let kb_only = fit_one(model, grid, &pts, &[0, 1], base, &kb_starts);
    // K_b and K_tau scaled together keep the balance of (4) at the start.
    let mut full_starts = Vec::new();
    for &c in &[1.0, 10.0, 0.1] {
        for &p in &[d.p, -0.5, 1.5] {
            full_starts.push([kb_only.k_b[0] * c, kb_only.k_b[1] * c, d.K_tau * c, p]);
        }
    }
    let full = fit_one(model, grid, &pts, &[0, 1, 2, 3], base, &full_starts);
    ConstantFit {
        grid: [zs.len(), fs.len()],
        train_grid: [tz.len(), tf.len()],
        kb_only,
        full,
    }
}
