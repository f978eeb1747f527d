//! `magswarm paper`: the seed's figures beside the model's.
//!
//! [`paper_figures`] computes every figure the seed reports (Table I, Sec. III-C, Sec. III-D)
//! from a [`Model`] on the seed's 50-point grid, the consistency of ODE (4) with the map over a
//! fine envelope grid, and the best *constant*-gain fit of (4) (issue 2 item 4). The result is a
//! plain serialisable struct ([`PaperFigures`]) so the CLI, the FMU tests and the docs all quote
//! the same numbers; [`render_table`] turns it into the printed table and [`write_plots`] draws
//! the Fig. 4/5-style PNGs.
//!
//! Units: z_m in mm and f in Hz in everything printed (the model itself is SI at its inputs),
//! radii in mm, field quantities in SI.

pub mod constant_fit;

use anyhow::{Context, Result};
use magswarm_model::dynamics::{equilibria, InputTerms};
use magswarm_model::{hz_to_rad_s, steady, Model};
use serde::Serialize;
use std::path::{Path, PathBuf};

use crate::plot::{self, ErrorBar, ErrorSeries, Heatmap, Labels, Series, Style};

/// The seed's reported figures, in one place. Section references are to the seed paper
/// ("Physics-Based Reduced-Order Modeling of Magnetic Microparticle Swarms for Biomedical
/// Control", `../shared/seed/000_150bc7726678dff6.txt`).
pub mod seed {
    /// Median of the fitted S_x over the experimental conditions (Table I, "Median Stiffness").
    pub const MEDIAN_S_X: f64 = 0.393;
    /// Median of the fitted S_y over the experimental conditions (Table I, "Median Stiffness").
    pub const MEDIAN_S_Y: f64 = 2.455;
    /// Stiffness anisotropy S_x/S_y (Abstract; Sec. III-C d; Sec. IV a). Read here as the ratio
    /// of the two medians (0.393/2.455 = 0.160).
    pub const S_RATIO: f64 = 0.16;
    /// Near-isotropy of the squared-field curvature, k_xx/k_yy (Sec. III-C d).
    pub const K_RATIO: f64 = 1.04;
    /// Range (max - min) of r1 over the data [mm] (Sec. III-C d, "range 2.02 mm").
    pub const R1_RANGE_MM: f64 = 2.02;
    /// Range (max - min) of r2 over the data [mm] (Sec. III-C d, "range 5.66 mm").
    pub const R2_RANGE_MM: f64 = 5.66;
    /// Closed-loop model predictions (r1, r2) [mm] at the three PID operating points
    /// (Sec. III-D a): "r1 = 7.61, 8.14, 8.50 mm and r2 = 10.43, 11.23, 11.70 mm".
    pub const CLOSED_LOOP_MM: [(f64, f64); 3] = [(7.61, 10.43), (8.14, 11.23), (8.50, 11.70)];
    /// Collapse of the medians onto Phi: "within 5-10 % across most bins" (Sec. III-C c);
    /// the upper end, as a fraction.
    pub const COLLAPSE_TOL: f64 = 0.10;
    /// Validation RMSE of r1 [mm] (Table I), used as the noise of the synthetic collapse.
    pub const RMSE_R1_MM: f64 = 0.248;
    /// Validation RMSE of r2 [mm] (Table I), used as the noise of the synthetic collapse.
    pub const RMSE_R2_MM: f64 = 0.415;
    /// Repeated measurements per operating point (Sec. III-C).
    pub const REPEATS: usize = 10;
}

/// Arguments of `magswarm paper`.
#[derive(Debug, clap::Args)]
pub struct PaperArgs {
    /// Model JSON (default: the built-in paper model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Write Fig. 4/5-style PNG plots into this directory.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Print the figures as JSON (machine-readable) instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Magnet and dipole constants of the model.
#[derive(Debug, Clone, Serialize)]
pub struct MagnetFigures {
    /// Sphere radius [mm].
    pub radius_mm: f64,
    /// Remanence B_r [T].
    pub remanence_t: f64,
    /// Dipole moment |m| [A m^2].
    pub dipole_moment_a_m2: f64,
    /// mu_0 m / (4 pi) [T m^3].
    pub mu0_m_over_4pi_t_m3: f64,
    /// Offset added to z_m to reach the swarm plane from the magnet surface [mm].
    pub z_offset_mm: f64,
    /// Lateral offset of the swarm from the rotation axis [mm].
    pub lateral_offset_mm: f64,
    /// Depth of the swarm plane below the magnet centre at the envelope's ends [mm].
    pub depth_range_mm: [f64; 2],
}

/// Where a radius is smallest along frequency, at one z_m.
#[derive(Debug, Clone, Serialize)]
pub struct FreqShape {
    /// z_m [mm].
    pub z_m_mm: f64,
    /// Frequency of the smallest r1 on the seed grid [Hz].
    pub r1_argmin_f_hz: f64,
    /// True when that minimum is not at 1 or 10 Hz (falling then rising).
    pub r1_interior: bool,
    /// Frequency of the smallest r2 on the seed grid [Hz].
    pub r2_argmin_f_hz: f64,
    /// True when that minimum is interior.
    pub r2_interior: bool,
}

/// Figures on the seed's 50-point grid (z_m 3.5..23.5 mm step 5 x f 1..10 Hz).
#[derive(Debug, Clone, Serialize)]
pub struct GridFigures {
    /// Median S_x [-].
    pub median_s_x: f64,
    /// Median S_y [-].
    pub median_s_y: f64,
    /// median S_x / median S_y [-].
    pub s_ratio: f64,
    /// Median of S_x/S_y point by point [-] (for comparison with the ratio of medians).
    pub median_pointwise_s_ratio: f64,
    /// Median k_xx/k_yy over the grid [-].
    pub median_k_ratio: f64,
    /// Smallest and largest r1 [mm].
    pub r1_min_max_mm: [f64; 2],
    /// Smallest and largest r2 [mm].
    pub r2_min_max_mm: [f64; 2],
    /// r1 range max - min [mm].
    pub r1_range_mm: f64,
    /// r2 range max - min [mm].
    pub r2_range_mm: f64,
    /// r2 > r1 at every grid point.
    pub r2_gt_r1_everywhere: bool,
    /// Smallest r2 - r1 [mm].
    pub worst_r2_minus_r1_mm: f64,
    /// Where the smallest margin is (z_m [mm], f [Hz]).
    pub worst_margin_at: [f64; 2],
    /// Both radii strictly increase with z_m at every grid frequency.
    pub radii_grow_with_z: bool,
    /// Smallest increase of either radius between neighbouring z_m [mm].
    pub min_z_increment_mm: f64,
    /// Frequency shape per z_m.
    pub frequency_shape: Vec<FreqShape>,
    /// Every argmin (both radii, every z_m) is interior: falling then rising.
    pub falling_then_rising_everywhere: bool,
}

/// Nearest reachable point of the map to one of the seed's closed-loop model points.
#[derive(Debug, Clone, Serialize)]
pub struct ClosedLoopPoint {
    /// Seed's (r1, r2) [mm].
    pub seed_mm: [f64; 2],
    /// Nearest (r1, r2) on the map inside the envelope [mm].
    pub nearest_mm: [f64; 2],
    /// Inputs there: z_m [mm].
    pub z_m_mm: f64,
    /// Inputs there: f [Hz].
    pub f_hz: f64,
    /// Euclidean distance in (r1, r2) [mm].
    pub distance_mm: f64,
}

/// Consistency of ODE (4) with the map over a fine envelope grid.
#[derive(Debug, Clone, Serialize)]
pub struct DynamicsFigures {
    /// Grid size (z_m points, f points).
    pub grid: [usize; 2],
    /// Largest |r_eq - r_map| / r_map over both axes.
    pub max_rel_error: f64,
    /// Smallest and largest number of equilibria found per point.
    pub equilibria_count_min_max: [usize; 2],
    /// Exactly one equilibrium at every point.
    pub unique_everywhere: bool,
    /// Both eigenvalues negative at every point.
    pub stable_everywhere: bool,
    /// Points where the scheduled gain had to be clamped.
    pub clamped_points: usize,
    /// Formation time constant range [s].
    pub time_constant_s: [f64; 2],
    /// Scheduled K_b1 range.
    pub k_b1_range: [f64; 2],
    /// Scheduled K_b2 range.
    pub k_b2_range: [f64; 2],
    /// B range [T].
    pub b_t: [f64; 2],
    /// g_z range [T/m].
    pub g_z_t_per_m: [f64; 2],
    /// k_xx range [T^2/m^2].
    pub k_xx_t2_per_m2: [f64; 2],
    /// k_yy range [T^2/m^2].
    pub k_yy_t2_per_m2: [f64; 2],
    /// r2 > r1 at every fine-grid point.
    pub r2_gt_r1_fine: bool,
    /// Both radii increase with z_m at every fine-grid frequency.
    pub grow_with_z_fine: bool,
    /// Points of the fine grid that the model flags (floors, clamps).
    pub flagged_points: usize,
}

/// The synthetic-noise collapse of Fig. 5: model + Gaussian noise (seed RMSEs), median per
/// frequency bin, compared with Phi.
#[derive(Debug, Clone, Serialize)]
pub struct CollapseFigures {
    /// Noise standard deviations (r1, r2) [mm].
    pub sigma_mm: [f64; 2],
    /// Repeats per seed-grid point.
    pub repeats: usize,
    /// RNG seed.
    pub rng_seed: u64,
    /// Largest |median(y_i)/Phi - 1| over bins, per axis.
    pub max_median_dev: [f64; 2],
    /// Largest |y_i/Phi - 1| of the noise-free model over the grid (0 up to rounding).
    pub exact_max_dev: f64,
}

/// One printed row: figure, seed value, model value, deviation.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// Section heading the row belongs to.
    pub section: String,
    /// What is compared.
    pub figure: String,
    /// The seed's value (text).
    pub seed: String,
    /// The model's value (text).
    pub model: String,
    /// Relative deviation or other comparison (text).
    pub deviation: String,
}

/// Everything `magswarm paper` reports.
#[derive(Debug, Clone, Serialize)]
pub struct PaperFigures {
    /// Model name.
    pub model_name: String,
    /// Magnet constants.
    pub magnet: MagnetFigures,
    /// Seed-grid figures.
    pub grid: GridFigures,
    /// Closed-loop points of Sec. III-D.
    pub closed_loop: Vec<ClosedLoopPoint>,
    /// ODE (4) versus map.
    pub dynamics: DynamicsFigures,
    /// Formation time constants [s] on the fine grid ([`fine_grid`]), tau_map[f][z_m].
    /// Not serialised.
    #[serde(skip)]
    pub tau_map: Vec<Vec<f64>>,
    /// Best constant-gain fit of (4).
    pub constant_fit: constant_fit::ConstantFit,
    /// Synthetic collapse (Fig. 5).
    pub collapse: CollapseFigures,
    /// The table as printed.
    pub table: Vec<Row>,
}

/// Median of a slice (NaNs excluded); NaN when empty.
pub fn median(v: &[f64]) -> f64 {
    let mut s: Vec<f64> = v.iter().copied().filter(|x| !x.is_nan()).collect();
    if s.is_empty() {
        return f64::NAN;
    }
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// Median absolute deviation (unscaled).
pub fn mad(v: &[f64]) -> f64 {
    let m = median(v);
    let d: Vec<f64> = v.iter().map(|x| (x - m).abs()).collect();
    median(&d)
}

fn range(v: impl Iterator<Item = f64>) -> [f64; 2] {
    v.fold([f64::INFINITY, f64::NEG_INFINITY], |a, x| {
        [a[0].min(x), a[1].max(x)]
    })
}

/// The fine envelope grid: z_m [mm] and f [Hz] values (41 x 46: 0.5 mm, 0.2 Hz).
pub fn fine_grid(model: &Model) -> (Vec<f64>, Vec<f64>) {
    let e = &model.envelope;
    let (z0, z1) = (e.z_min_m * 1e3, e.z_max_m * 1e3);
    let zs = (0..41).map(|i| z0 + (z1 - z0) * i as f64 / 40.0).collect();
    let fs = (0..46)
        .map(|j| e.f_min_hz + (e.f_max_hz - e.f_min_hz) * j as f64 / 45.0)
        .collect();
    (zs, fs)
}

/// Seed grid axes: z_m [mm], f [Hz].
fn seed_axes() -> (Vec<f64>, Vec<f64>) {
    let g = magswarm_model::seed_grid();
    let mut zs: Vec<f64> = g.iter().map(|p| p.0 * 1e3).collect();
    zs.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    let mut fs: Vec<f64> = g.iter().map(|p| p.1).collect();
    fs.sort_by(f64::total_cmp);
    fs.dedup();
    (zs, fs)
}

fn eval_mm(model: &Model, z_mm: f64, f: f64) -> steady::SteadyPoint {
    steady::evaluate(model, z_mm * 1e-3, hz_to_rad_s(f))
}

fn grid_figures(model: &Model) -> GridFigures {
    let (zs, fs) = seed_axes();
    // pts[i][j]: z index i, f index j.
    let pts: Vec<Vec<steady::SteadyPoint>> = zs
        .iter()
        .map(|&z| fs.iter().map(|&f| eval_mm(model, z, f)).collect())
        .collect();
    let all = || pts.iter().flatten();
    let sx: Vec<f64> = all().map(|p| p.s_x).collect();
    let sy: Vec<f64> = all().map(|p| p.s_y).collect();
    let ratio: Vec<f64> = all().map(|p| p.s_x / p.s_y).collect();
    let kr: Vec<f64> = all().map(|p| p.field.k_xx / p.field.k_yy).collect();
    let r1 = range(all().map(|p| p.r1));
    let r2 = range(all().map(|p| p.r2));
    let mut worst = (f64::INFINITY, [0.0, 0.0]);
    for (i, row) in pts.iter().enumerate() {
        for (j, p) in row.iter().enumerate() {
            if p.r2 - p.r1 < worst.0 {
                worst = (p.r2 - p.r1, [zs[i], fs[j]]);
            }
        }
    }
    let mut min_inc = f64::INFINITY;
    for w in pts.windows(2) {
        for (lo, hi) in w[0].iter().zip(&w[1]) {
            min_inc = min_inc.min(hi.r1 - lo.r1).min(hi.r2 - lo.r2);
        }
    }
    let argmin = |row: &[steady::SteadyPoint], g: fn(&steady::SteadyPoint) -> f64| {
        let mut best = 0;
        for (j, p) in row.iter().enumerate() {
            if g(p) < g(&row[best]) {
                best = j;
            }
        }
        best
    };
    let shape: Vec<FreqShape> = zs
        .iter()
        .zip(&pts)
        .map(|(&z, row)| {
            let a1 = argmin(row, |p| p.r1);
            let a2 = argmin(row, |p| p.r2);
            let n = fs.len() - 1;
            FreqShape {
                z_m_mm: z,
                r1_argmin_f_hz: fs[a1],
                r1_interior: a1 > 0 && a1 < n,
                r2_argmin_f_hz: fs[a2],
                r2_interior: a2 > 0 && a2 < n,
            }
        })
        .collect();
    let (msx, msy) = (median(&sx), median(&sy));
    GridFigures {
        median_s_x: msx,
        median_s_y: msy,
        s_ratio: msx / msy,
        median_pointwise_s_ratio: median(&ratio),
        median_k_ratio: median(&kr),
        r1_min_max_mm: r1,
        r2_min_max_mm: r2,
        r1_range_mm: r1[1] - r1[0],
        r2_range_mm: r2[1] - r2[0],
        r2_gt_r1_everywhere: worst.0 > 0.0,
        worst_r2_minus_r1_mm: worst.0,
        worst_margin_at: worst.1,
        radii_grow_with_z: min_inc > 0.0,
        min_z_increment_mm: min_inc,
        falling_then_rising_everywhere: shape.iter().all(|s| s.r1_interior && s.r2_interior),
        frequency_shape: shape,
    }
}

/// Minimise `f` over a box by Nelder-Mead (trial points are clamped into the box).
pub(crate) fn nelder_mead(
    f: &dyn Fn(&[f64]) -> f64,
    x0: &[f64],
    step: &[f64],
    bounds: (&[f64], &[f64]),
    iters: usize,
) -> (Vec<f64>, f64) {
    let n = x0.len();
    let (lo, hi) = bounds;
    let clamp = |x: &mut Vec<f64>| {
        for k in 0..n {
            x[k] = x[k].clamp(lo[k], hi[k]);
        }
    };
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    let mut p0 = x0.to_vec();
    clamp(&mut p0);
    simplex.push((p0.clone(), f(&p0)));
    for k in 0..n {
        let mut p = p0.clone();
        p[k] += step[k];
        if p[k] > hi[k] {
            p[k] = p0[k] - step[k];
        }
        clamp(&mut p);
        let v = f(&p);
        simplex.push((p, v));
    }
    for _ in 0..iters {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let spread = simplex[n].1 - simplex[0].1;
        if spread.abs() <= 1e-15 * (1.0 + simplex[0].1.abs()) {
            break;
        }
        let mut c = vec![0.0; n];
        for (p, _) in &simplex[..n] {
            for k in 0..n {
                c[k] += p[k] / n as f64;
            }
        }
        let at = |t: f64| {
            let mut p: Vec<f64> = (0..n)
                .map(|k| c[k] + t * (simplex[n].0[k] - c[k]))
                .collect();
            clamp(&mut p);
            let v = f(&p);
            (p, v)
        };
        let r = at(-1.0);
        if r.1 < simplex[0].1 {
            let e = at(-2.0);
            simplex[n] = if e.1 < r.1 { e } else { r };
        } else if r.1 < simplex[n - 1].1 {
            simplex[n] = r;
        } else {
            let cpt = if r.1 < simplex[n].1 {
                at(-0.5)
            } else {
                at(0.5)
            };
            if cpt.1 < simplex[n].1.min(r.1) {
                simplex[n] = cpt;
            } else {
                let best = simplex[0].0.clone();
                for s in simplex.iter_mut().skip(1) {
                    let mut p: Vec<f64> =
                        (0..n).map(|k| best[k] + 0.5 * (s.0[k] - best[k])).collect();
                    clamp(&mut p);
                    s.1 = f(&p);
                    s.0 = p;
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex.swap_remove(0)
}

fn closed_loop(model: &Model) -> Vec<ClosedLoopPoint> {
    let e = &model.envelope;
    let (z0, z1) = (e.z_min_m * 1e3, e.z_max_m * 1e3);
    let (f0, f1) = (e.f_min_hz, e.f_max_hz);
    // Fine grid: 0.1 mm x 0.05 Hz, then Nelder-Mead off the grid.
    let nz = ((z1 - z0) / 0.1).round().max(1.0) as usize;
    let nf = ((f1 - f0) / 0.05).round().max(1.0) as usize;
    let mut map = Vec::with_capacity((nz + 1) * (nf + 1));
    for i in 0..=nz {
        let z = z0 + (z1 - z0) * i as f64 / nz as f64;
        for j in 0..=nf {
            let f = f0 + (f1 - f0) * j as f64 / nf as f64;
            let p = eval_mm(model, z, f);
            map.push((z, f, p.r1, p.r2));
        }
    }
    seed::CLOSED_LOOP_MM
        .iter()
        .map(|&(a, b)| {
            let d = |r1: f64, r2: f64| ((r1 - a).powi(2) + (r2 - b).powi(2)).sqrt();
            let best = map
                .iter()
                .min_by(|p, q| d(p.2, p.3).total_cmp(&d(q.2, q.3)))
                .copied()
                .unwrap_or((z0, f0, f64::NAN, f64::NAN));
            let obj = |x: &[f64]| {
                let p = eval_mm(model, x[0], x[1]);
                d(p.r1, p.r2)
            };
            let (x, _) = nelder_mead(
                &obj,
                &[best.0, best.1],
                &[0.05, 0.025],
                (&[z0, f0], &[z1, f1]),
                400,
            );
            let p = eval_mm(model, x[0], x[1]);
            ClosedLoopPoint {
                seed_mm: [a, b],
                nearest_mm: [p.r1, p.r2],
                z_m_mm: x[0],
                f_hz: x[1],
                distance_mm: d(p.r1, p.r2),
            }
        })
        .collect()
}

/// Per-point results of the dynamics sweep.
struct DynSweep {
    /// Time constants [s], tau[f index][z index].
    tau: Vec<Vec<f64>>,
    figures: DynamicsFigures,
}

fn dynamics_sweep(model: &Model) -> DynSweep {
    let (zs, fs) = fine_grid(model);
    let mut tau = vec![vec![f64::NAN; zs.len()]; fs.len()];
    let mut max_err = 0.0f64;
    let (mut cmin, mut cmax) = (usize::MAX, 0usize);
    let mut stable = true;
    let mut clamped = 0;
    let mut flagged = 0;
    let mut kb1 = [f64::INFINITY, f64::NEG_INFINITY];
    let mut kb2 = kb1;
    let mut r2gt = true;
    let mut grow = true;
    let mut prev: Vec<Option<(f64, f64)>> = vec![None; fs.len()];
    for (i, &z) in zs.iter().enumerate() {
        for (j, &f) in fs.iter().enumerate() {
            let t = InputTerms::new(model, z * 1e-3, hz_to_rad_s(f));
            let eq = equilibria(model, &t);
            let sp = t.steady;
            let err = ((eq.r[0] - sp.r1) / sp.r1)
                .abs()
                .max(((eq.r[1] - sp.r2) / sp.r2).abs());
            max_err = if err.is_nan() {
                f64::INFINITY
            } else {
                max_err.max(err)
            };
            cmin = cmin.min(eq.count);
            cmax = cmax.max(eq.count);
            stable &= eq.stable();
            if sp.validity.dynamics_clamped {
                clamped += 1;
            }
            if sp.validity.any() {
                flagged += 1;
            }
            tau[j][i] = eq.time_constant();
            kb1 = [kb1[0].min(t.k_b[0]), kb1[1].max(t.k_b[0])];
            kb2 = [kb2[0].min(t.k_b[1]), kb2[1].max(t.k_b[1])];
            r2gt &= sp.r2 > sp.r1;
            if let Some((a, b)) = prev[j] {
                grow &= sp.r1 > a && sp.r2 > b;
            }
            prev[j] = Some((sp.r1, sp.r2));
        }
    }
    let fields: Vec<_> = zs.iter().map(|&z| model.magnet.at(z * 1e-3)).collect();
    let figures = DynamicsFigures {
        grid: [zs.len(), fs.len()],
        max_rel_error: max_err,
        equilibria_count_min_max: [cmin, cmax],
        unique_everywhere: cmin == 1 && cmax == 1,
        stable_everywhere: stable,
        clamped_points: clamped,
        time_constant_s: range(tau.iter().flatten().copied()),
        k_b1_range: kb1,
        k_b2_range: kb2,
        b_t: range(fields.iter().map(|f| f.b)),
        g_z_t_per_m: range(fields.iter().map(|f| f.g_z)),
        k_xx_t2_per_m2: range(fields.iter().map(|f| f.k_xx)),
        k_yy_t2_per_m2: range(fields.iter().map(|f| f.k_yy)),
        r2_gt_r1_fine: r2gt,
        grow_with_z_fine: grow,
        flagged_points: flagged,
    };
    DynSweep { tau, figures }
}

/// Collapse variables y_i = r_i S_i^alpha_i / C_i of noisy synthetic repeats on the seed grid.
struct CollapseData {
    /// (f, y1, y2) per repeat and grid point.
    samples: Vec<(f64, f64, f64)>,
    /// (f, y1, y2) of the noise-free model per grid point.
    exact: Vec<(f64, f64, f64)>,
    figures: CollapseFigures,
}

fn collapse(model: &Model) -> CollapseData {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let rng_seed = 20_251_122;
    let sigma = [seed::RMSE_R1_MM, seed::RMSE_R2_MM];
    let mut rng = rand::rngs::StdRng::seed_from_u64(rng_seed);
    let n1 = Normal::new(0.0, sigma[0]).expect("positive sigma");
    let n2 = Normal::new(0.0, sigma[1]).expect("positive sigma");
    let p = &model.steady;
    let mut samples = Vec::new();
    let mut exact = Vec::new();
    let mut exact_dev = 0.0f64;
    for (z, f) in magswarm_model::seed_grid() {
        let sp = steady::evaluate(model, z, hz_to_rad_s(f));
        let k1 = sp.s_x.powf(p.alpha_1) / p.C_1;
        let k2 = sp.s_y.powf(p.alpha_2) / p.C_2;
        exact.push((f, sp.r1 * k1, sp.r2 * k2));
        exact_dev = exact_dev
            .max((sp.r1 * k1 / sp.phi - 1.0).abs())
            .max((sp.r2 * k2 / sp.phi - 1.0).abs());
        for _ in 0..seed::REPEATS {
            let r1 = sp.r1 + n1.sample(&mut rng);
            let r2 = sp.r2 + n2.sample(&mut rng);
            samples.push((f, r1 * k1, r2 * k2));
        }
    }
    let mut dev = [0.0f64; 2];
    for (f, y1, y2) in bins(&samples) {
        let ph = steady::phi(model, hz_to_rad_s(f));
        dev[0] = dev[0].max((median(&y1) / ph - 1.0).abs());
        dev[1] = dev[1].max((median(&y2) / ph - 1.0).abs());
    }
    CollapseData {
        samples,
        exact,
        figures: CollapseFigures {
            sigma_mm: sigma,
            repeats: seed::REPEATS,
            rng_seed,
            max_median_dev: dev,
            exact_max_dev: exact_dev,
        },
    }
}

/// Group collapse samples by frequency: (f, y1s, y2s), in increasing f.
fn bins(samples: &[(f64, f64, f64)]) -> Vec<(f64, Vec<f64>, Vec<f64>)> {
    let mut out: Vec<(f64, Vec<f64>, Vec<f64>)> = Vec::new();
    for &(f, a, b) in samples {
        match out.iter_mut().find(|o| (o.0 - f).abs() < 1e-9) {
            Some(o) => {
                o.1.push(a);
                o.2.push(b);
            }
            None => out.push((f, vec![a], vec![b])),
        }
    }
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

fn magnet_figures(model: &Model) -> MagnetFigures {
    let m = &model.magnet;
    let e = &model.envelope;
    MagnetFigures {
        radius_mm: m.radius_m * 1e3,
        remanence_t: m.remanence_t,
        dipole_moment_a_m2: m.dipole_moment(),
        mu0_m_over_4pi_t_m3: m.dipole_k(),
        z_offset_mm: m.z_offset_m * 1e3,
        lateral_offset_mm: m.lateral_offset_m * 1e3,
        depth_range_mm: [m.depth(e.z_min_m) * 1e3, m.depth(e.z_max_m) * 1e3],
    }
}

/// Compute every figure `magswarm paper` reports for `model`.
pub fn paper_figures(model: &Model) -> PaperFigures {
    let sweep = dynamics_sweep(model);
    let mut pf = PaperFigures {
        model_name: model.name.clone(),
        magnet: magnet_figures(model),
        grid: grid_figures(model),
        closed_loop: closed_loop(model),
        dynamics: sweep.figures,
        tau_map: sweep.tau,
        constant_fit: constant_fit::fit(model),
        collapse: collapse(model).figures,
        table: Vec::new(),
    };
    pf.table = rows(&pf);
    pf
}

fn pct(model: f64, seed: f64) -> String {
    format!("{:+.1} %", (model / seed - 1.0) * 100.0)
}

fn yes_no(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}

/// Collects table rows under the current section.
struct Table {
    section: String,
    rows: Vec<Row>,
}

impl Table {
    fn section(&mut self, s: &str) {
        self.section = s.to_string();
    }
    fn row(
        &mut self,
        figure: &str,
        seed: impl Into<String>,
        model: impl Into<String>,
        dev: impl Into<String>,
    ) {
        self.rows.push(Row {
            section: self.section.clone(),
            figure: figure.into(),
            seed: seed.into(),
            model: model.into(),
            deviation: dev.into(),
        });
    }
}

fn rows(p: &PaperFigures) -> Vec<Row> {
    let mut t = Table {
        section: String::new(),
        rows: Vec::new(),
    };
    let g = &p.grid;
    t.section("seed grid (z_m 3.5..23.5 mm step 5 x f 1..10 Hz, 50 points)");
    t.row(
        "median S_x [-] (Table I)",
        format!("{}", seed::MEDIAN_S_X),
        format!("{:.3}", g.median_s_x),
        pct(g.median_s_x, seed::MEDIAN_S_X),
    );
    t.row(
        "median S_y [-] (Table I)",
        format!("{}", seed::MEDIAN_S_Y),
        format!("{:.3}", g.median_s_y),
        pct(g.median_s_y, seed::MEDIAN_S_Y),
    );
    t.row(
        "S_x/S_y, ratio of medians [-] (III-C d)",
        format!("~{}", seed::S_RATIO),
        format!("{:.3}", g.s_ratio),
        format!(
            "{} (pointwise median {:.3})",
            pct(g.s_ratio, seed::S_RATIO),
            g.median_pointwise_s_ratio
        ),
    );
    t.row(
        "median k_xx/k_yy [-] (III-C d)",
        format!("~{}", seed::K_RATIO),
        format!("{:.3}", g.median_k_ratio),
        pct(g.median_k_ratio, seed::K_RATIO),
    );
    t.row(
        "r1 range max-min [mm] (III-C d)",
        format!("{}", seed::R1_RANGE_MM),
        format!("{:.2}", g.r1_range_mm),
        format!(
            "{} (r1 {:.2}..{:.2} mm)",
            pct(g.r1_range_mm, seed::R1_RANGE_MM),
            g.r1_min_max_mm[0],
            g.r1_min_max_mm[1]
        ),
    );
    t.row(
        "r2 range max-min [mm] (III-C d)",
        format!("{}", seed::R2_RANGE_MM),
        format!("{:.2}", g.r2_range_mm),
        format!(
            "{} (r2 {:.2}..{:.2} mm)",
            pct(g.r2_range_mm, seed::R2_RANGE_MM),
            g.r2_min_max_mm[0],
            g.r2_min_max_mm[1]
        ),
    );
    t.row(
        "r2 > r1 everywhere (III-C a)",
        "yes",
        yes_no(g.r2_gt_r1_everywhere),
        format!(
            "worst margin {:.2} mm at z_m {} mm, f {} Hz",
            g.worst_r2_minus_r1_mm, g.worst_margin_at[0], g.worst_margin_at[1]
        ),
    );
    t.row(
        "radii grow with z_m at every f (III-C a-i)",
        "yes",
        yes_no(g.radii_grow_with_z),
        format!("smallest step {:.3} mm per 5 mm", g.min_z_increment_mm),
    );
    t.row(
        "radii fall then rise with f (III-C a-ii,iii)",
        "yes",
        yes_no(g.falling_then_rising_everywhere),
        "argmin over f per z_m below",
    );
    for fs in &g.frequency_shape {
        let where_ = |b: bool| if b { "interior" } else { "at edge" };
        t.row(
            &format!("  z_m {:>4.1} mm: argmin f of r1, r2 [Hz]", fs.z_m_mm),
            "interior",
            format!("{}, {}", fs.r1_argmin_f_hz, fs.r2_argmin_f_hz),
            format!(
                "r1 {}, r2 {}",
                where_(fs.r1_interior),
                where_(fs.r2_interior)
            ),
        );
    }
    let c = &p.collapse;
    t.row(
        "Fig. 5: max |median y_i/Phi - 1| per f bin (III-C c)",
        format!("5-{:.0} %", seed::COLLAPSE_TOL * 100.0),
        format!(
            "r1 {:.1} %, r2 {:.1} %",
            c.max_median_dev[0] * 100.0,
            c.max_median_dev[1] * 100.0
        ),
        format!(
            "synthetic: model + N(0, {}/{} mm), {} repeats",
            c.sigma_mm[0], c.sigma_mm[1], c.repeats
        ),
    );
    t.section("closed-loop model points (III-D a): nearest reachable (r1, r2) in the envelope");
    for cl in &p.closed_loop {
        t.row(
            "(r1, r2) [mm]",
            format!("({:.2}, {:.2})", cl.seed_mm[0], cl.seed_mm[1]),
            format!("({:.2}, {:.2})", cl.nearest_mm[0], cl.nearest_mm[1]),
            format!(
                "distance {:.3} mm at z_m {:.2} mm, f {:.2} Hz",
                cl.distance_mm, cl.z_m_mm, cl.f_hz
            ),
        );
    }
    let d = &p.dynamics;
    t.section(&format!(
        "dynamics: ODE (4) equilibrium vs map (5), {}x{} envelope grid",
        d.grid[0], d.grid[1]
    ));
    t.row(
        "scheduled K_b: max |r_eq - r_map|/r_map",
        "-",
        format!("{:.1e} %", d.max_rel_error * 100.0),
        "consistent by construction",
    );
    let cf = &p.constant_fit;
    for (name, fit) in [
        ("best constant K_b1, K_b2", &cf.kb_only),
        ("best constant K_b1, K_b2, K_tau, p", &cf.full),
    ] {
        t.row(
            &format!("{name}: max / RMS rel. error"),
            "-",
            format!(
                "{:.1} % / {:.1} %",
                fit.max_rel_error * 100.0,
                fit.rms_rel_error * 100.0
            ),
            format!(
                "K_b ({:.3e}, {:.3e}), K_tau {:.3e}, p {:.3}; worst at z_m {:.1} mm, f {:.1} Hz; {} bad points",
                fit.k_b[0], fit.k_b[1], fit.k_tau, fit.p, fit.worst_at[0], fit.worst_at[1], fit.bad_points
            ),
        );
    }
    t.row(
        "equilibria per point (min..max)",
        "-",
        format!(
            "{}..{}",
            d.equilibria_count_min_max[0], d.equilibria_count_min_max[1]
        ),
        format!("unique everywhere: {}", yes_no(d.unique_everywhere)),
    );
    t.row(
        "stable everywhere",
        "-",
        yes_no(d.stable_everywhere),
        format!("{} clamped gains", d.clamped_points),
    );
    t.row(
        "formation time constant [s]",
        "-",
        format!("{:.2}..{:.2}", d.time_constant_s[0], d.time_constant_s[1]),
        "slowest eigenvalue at the equilibrium",
    );
    t.row(
        "scheduled K_b1, K_b2 [mm^(1-beta)/s]",
        "-",
        format!(
            "{:.3e}..{:.3e}, {:.3e}..{:.3e}",
            d.k_b1_range[0], d.k_b1_range[1], d.k_b2_range[0], d.k_b2_range[1]
        ),
        "",
    );
    t.row(
        "r2 > r1 / radii grow with z_m (fine grid)",
        "yes / yes",
        format!(
            "{} / {}",
            yes_no(d.r2_gt_r1_fine),
            yes_no(d.grow_with_z_fine)
        ),
        format!("{} flagged points", d.flagged_points),
    );
    t.section("field at the swarm over the envelope (SI)");
    t.row(
        "B [T]",
        "-",
        format!("{:.4}..{:.4}", d.b_t[0], d.b_t[1]),
        "",
    );
    t.row(
        "g_z [T/m]",
        "-",
        format!("{:.3}..{:.3}", d.g_z_t_per_m[0], d.g_z_t_per_m[1]),
        "",
    );
    t.row(
        "k_xx [T^2/m^2]",
        "-",
        format!("{:.1}..{:.1}", d.k_xx_t2_per_m2[0], d.k_xx_t2_per_m2[1]),
        "",
    );
    t.row(
        "k_yy [T^2/m^2]",
        "-",
        format!("{:.1}..{:.1}", d.k_yy_t2_per_m2[0], d.k_yy_t2_per_m2[1]),
        "",
    );
    let m = &p.magnet;
    t.section("magnet (NdFeB sphere as a point dipole)");
    t.row("radius [mm] (III-A)", "20", format!("{}", m.radius_mm), "");
    t.row(
        "remanence B_r [T]",
        "not given",
        format!("{}", m.remanence_t),
        "reconstruction (N42)",
    );
    t.row(
        "dipole moment |m| [A m^2]",
        "fitted, not given",
        format!("{:.2}", m.dipole_moment_a_m2),
        format!("mu0 m/(4 pi) = {:.4e} T m^3", m.mu0_m_over_4pi_t_m3),
    );
    t.row(
        "z offset, lateral offset [mm]",
        "not given",
        format!("{:.3}, {:.3}", m.z_offset_mm, m.lateral_offset_mm),
        format!(
            "swarm {:.2}..{:.2} mm below the magnet centre",
            m.depth_range_mm[0], m.depth_range_mm[1]
        ),
    );
    t.rows
}

/// The printed table.
pub fn render_table(p: &PaperFigures) -> String {
    let w0 = p.table.iter().map(|r| r.figure.len()).max().unwrap_or(0);
    let w1 = p
        .table
        .iter()
        .map(|r| r.seed.len())
        .max()
        .unwrap_or(0)
        .max(4);
    let w2 = p
        .table
        .iter()
        .map(|r| r.model.len())
        .max()
        .unwrap_or(0)
        .max(5);
    let mut out = format!("magswarm paper: seed figures vs model '{}'\n", p.model_name);
    let mut section = "";
    for r in &p.table {
        if r.section != section {
            section = &r.section;
            out.push_str(&format!("\n## {section}\n"));
            out.push_str(&format!(
                "{:<w0$}  {:<w1$}  {:<w2$}  {}\n",
                "figure", "seed", "model", "deviation"
            ));
        }
        out.push_str(&format!(
            "{:<w0$}  {:<w1$}  {:<w2$}  {}\n",
            r.figure, r.seed, r.model, r.deviation
        ));
    }
    out
}

/// Write the Fig. 4/5-style PNGs into `dir` for `model`, whose figures ([`paper_figures`])
/// are `figures`; returns the files written.
pub fn write_plots(model: &Model, figures: &PaperFigures, dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut written = Vec::new();
    let (zs, fs) = fine_grid(model);
    // pts[j][i]: f index j, z index i (heatmap layout).
    let pts: Vec<Vec<steady::SteadyPoint>> = fs
        .iter()
        .map(|&f| zs.iter().map(|&z| eval_mm(model, z, f)).collect())
        .collect();
    let marks: Vec<(f64, f64)> = magswarm_model::seed_grid()
        .iter()
        .map(|&(z, f)| (z * 1e3, f))
        .collect();
    let (xl, yl) = ("z_m [mm]", "f [Hz]");
    type Getter = fn(&steady::SteadyPoint) -> f64;
    let maps: [(&str, &str, &str, Getter); 4] = [
        (
            "fig4a_r1.png",
            "Fig. 4a: steady radius r1 (5) over (z_m, f)",
            "r1 [mm]",
            |p| p.r1,
        ),
        (
            "fig4b_r2.png",
            "Fig. 4b: steady radius r2 (5) over (z_m, f)",
            "r2 [mm]",
            |p| p.r2,
        ),
        (
            "stiffness_s_x.png",
            "Stiffness S_x (7) over (z_m, f)",
            "S_x [-]",
            |p| p.s_x,
        ),
        (
            "stiffness_s_y.png",
            "Stiffness S_y (7) over (z_m, f)",
            "S_y [-]",
            |p| p.s_y,
        ),
    ];
    for (name, title, cb, g) in maps {
        let path = dir.join(name);
        let values: Vec<Vec<f64>> = pts.iter().map(|row| row.iter().map(g).collect()).collect();
        plot::heatmap(
            &path,
            &Labels {
                title,
                x: xl,
                y: yl,
            },
            &Heatmap {
                xs: &zs,
                ys: &fs,
                values: &values,
                colorbar_label: cb,
                marks: &marks,
                marks_label: "seed grid (50 points)",
                range: None,
            },
        )?;
        written.push(path);
    }

    // Radii against frequency at the seed's z_m (the non-monotonic frequency dependence).
    let (sz, _) = seed_axes();
    let fine_f: Vec<f64> = (0..=90).map(|j| 1.0 + 0.1 * j as f64).collect();
    let mut series = Vec::new();
    for (k, &z) in sz.iter().enumerate() {
        let c = plot::PALETTE[k % plot::PALETTE.len()];
        let r2: Vec<(f64, f64)> = fine_f
            .iter()
            .map(|&f| (f, eval_mm(model, z, f).r2))
            .collect();
        let r1: Vec<(f64, f64)> = fine_f
            .iter()
            .map(|&f| (f, eval_mm(model, z, f).r1))
            .collect();
        series.push(Series::line(format!("r2, z_m {z} mm"), r2).with_color(c));
        series.push(Series::new(format!("r1, z_m {z} mm"), r1, Style::Dashed).with_color(c));
    }
    let path = dir.join("radii_vs_f.png");
    plot::lines_sized(
        &path,
        &Labels {
            title: "Steady radii (5) against f at the seed's z_m (r2 solid, r1 dashed)",
            x: "f [Hz]",
            y: "radius [mm]",
        },
        &series,
        (1100, 760),
    )?;
    written.push(path);

    // Fig. 5: collapse.
    let col = collapse(model);
    let phi: Vec<(f64, f64)> = fine_f
        .iter()
        .map(|&f| (f, steady::phi(model, hz_to_rad_s(f))))
        .collect();
    let (mut y1, mut y2) = (Vec::new(), Vec::new());
    for (f, a, b) in bins(&col.samples) {
        let (m1, m2) = (median(&a), median(&b));
        let (d1, d2) = (mad(&a), mad(&b));
        y1.push(ErrorBar {
            x: f - 0.1,
            y: m1,
            lo: m1 - d1,
            hi: m1 + d1,
        });
        y2.push(ErrorBar {
            x: f + 0.1,
            y: m2,
            lo: m2 - d2,
            hi: m2 + d2,
        });
    }
    let exact1: Vec<(f64, f64)> = col.exact.iter().map(|e| (e.0, e.1)).collect();
    let exact2: Vec<(f64, f64)> = col.exact.iter().map(|e| (e.0, e.2)).collect();
    let path = dir.join("fig5_collapse.png");
    plot::scatter_with_errorbars(
        &path,
        &Labels {
            title: "Fig. 5: collapse y_i = r_i S_i^alpha_i / C_i against f",
            x: "f [Hz]",
            y: "y_i [-]",
        },
        &[
            ErrorSeries {
                name: format!(
                    "r1 + N(0, {} mm), {} repeats: median ± MAD (shifted -0.1 Hz)",
                    col.figures.sigma_mm[0], col.figures.repeats
                ),
                points: y1,
                color: Some(plot::PALETTE[0]),
            },
            ErrorSeries {
                name: format!(
                    "r2 + N(0, {} mm), {} repeats: median ± MAD (shifted +0.1 Hz)",
                    col.figures.sigma_mm[1], col.figures.repeats
                ),
                points: y2,
                color: Some(plot::PALETTE[1]),
            },
        ],
        &[
            Series::line("Phi(omega) (6)", phi).with_color(plot::RGBColor(0, 0, 0)),
            Series::points(
                "model y1, y2 without noise (on Phi)",
                [exact1, exact2].concat(),
            )
            .with_color(plot::PALETTE[2]),
        ],
    )?;
    written.push(path);

    // Formation time constant map.
    let path = dir.join("formation_time_constant.png");
    plot::heatmap(
        &path,
        &Labels {
            title: "Formation time constant of ODE (4) (slowest eigenvalue)",
            x: xl,
            y: yl,
        },
        &Heatmap {
            xs: &zs,
            ys: &fs,
            values: &figures.tau_map,
            colorbar_label: "tau [s]",
            marks: &marks,
            marks_label: "seed grid",
            range: None,
        },
    )?;
    written.push(path);

    // Where constant gains fail.
    let path = dir.join("constant_kb_error.png");
    plot::heatmap(
        &path,
        &Labels {
            title: "ODE (4) with the best constant K_b, K_tau, p: equilibrium error vs map",
            x: xl,
            y: yl,
        },
        &Heatmap {
            xs: &zs,
            ys: &fs,
            values: &figures.constant_fit.full.error_map_pct,
            colorbar_label: "max rel. error [%]",
            marks: &[],
            marks_label: "",
            range: None,
        },
    )?;
    written.push(path);
    Ok(written)
}

/// Run the command.
pub fn run(a: &PaperArgs) -> Result<()> {
    let model = match &a.model {
        Some(p) => Model::load(p).with_context(|| format!("loading model {}", p.display()))?,
        None => Model::paper(),
    };
    let figures = paper_figures(&model);
    if a.json {
        println!("{}", serde_json::to_string_pretty(&figures)?);
    } else {
        print!("{}", render_table(&figures));
    }
    if let Some(dir) = &a.plots {
        let files = write_plots(&model, &figures, dir)?;
        if !a.json {
            println!("\nplots:");
            for f in files {
                println!("  {}", f.display());
            }
        }
    }
    Ok(())
}
