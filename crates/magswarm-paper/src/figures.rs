//! The figures `magswarm paper` reports, as one serialisable struct ([`PaperFigures`]), and
//! their computation on the seed's 50-point grid ([`paper_figures`]); the dynamics, closed-loop
//! and collapse figures come from their own modules.

use magswarm_model::{steady, Model};
use serde::Serialize;

use super::constant_fit;
use super::grid::{eval_mm, median, range, seed_axes};

/// Magnet and dipole constants of the model.
#[derive(Debug, Clone, Serialize)]
pub struct MagnetFigures {
    /// Sphere radius \[mm\].
    pub radius_mm: f64,
    /// Remanence B_r \[T\].
    pub remanence_t: f64,
    /// Dipole moment |m| [A m^2].
    pub dipole_moment_a_m2: f64,
    /// mu_0 m / (4 pi) [T m^3].
    pub mu0_m_over_4pi_t_m3: f64,
    /// Offset added to z_m to reach the swarm plane from the magnet surface \[mm\].
    pub z_offset_mm: f64,
    /// Lateral offset of the swarm from the rotation axis \[mm\].
    pub lateral_offset_mm: f64,
    /// Depth of the swarm plane below the magnet centre at the envelope's ends \[mm\].
    pub depth_range_mm: [f64; 2],
}

/// Where a radius is smallest along frequency, at one z_m.
#[derive(Debug, Clone, Serialize)]
pub struct FreqShape {
    /// z_m \[mm\].
    pub z_m_mm: f64,
    /// Frequency of the smallest r1 on the seed grid \[Hz\].
    pub r1_argmin_f_hz: f64,
    /// True when that minimum is not at 1 or 10 Hz (falling then rising).
    pub r1_interior: bool,
    /// Frequency of the smallest r2 on the seed grid \[Hz\].
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
    /// Smallest and largest r1 \[mm\].
    pub r1_min_max_mm: [f64; 2],
    /// Smallest and largest r2 \[mm\].
    pub r2_min_max_mm: [f64; 2],
    /// r1 range max - min \[mm\].
    pub r1_range_mm: f64,
    /// r2 range max - min \[mm\].
    pub r2_range_mm: f64,
    /// r2 > r1 at every grid point.
    pub r2_gt_r1_everywhere: bool,
    /// Smallest r2 - r1 \[mm\].
    pub worst_r2_minus_r1_mm: f64,
    /// Where the smallest margin is (z_m \[mm\], f \[Hz\]).
    pub worst_margin_at: [f64; 2],
    /// Both radii strictly increase with z_m at every grid frequency.
    pub radii_grow_with_z: bool,
    /// Smallest increase of either radius between neighbouring z_m \[mm\].
    pub min_z_increment_mm: f64,
    /// Frequency shape per z_m.
    pub frequency_shape: Vec<FreqShape>,
    /// Every argmin (both radii, every z_m) is interior: falling then rising.
    pub falling_then_rising_everywhere: bool,
}

/// Nearest reachable point of the map to one of the seed's closed-loop model points.
#[derive(Debug, Clone, Serialize)]
pub struct ClosedLoopPoint {
    /// Seed's (r1, r2) \[mm\].
    pub seed_mm: [f64; 2],
    /// Nearest (r1, r2) on the map inside the envelope \[mm\].
    pub nearest_mm: [f64; 2],
    /// Inputs there: z_m \[mm\].
    pub z_m_mm: f64,
    /// Inputs there: f \[Hz\].
    pub f_hz: f64,
    /// Euclidean distance in (r1, r2) \[mm\].
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
    /// Formation time constant range \[s\].
    pub time_constant_s: [f64; 2],
    /// Scheduled K_b1 range.
    pub k_b1_range: [f64; 2],
    /// Scheduled K_b2 range.
    pub k_b2_range: [f64; 2],
    /// B range \[T\].
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
    /// Noise standard deviations (r1, r2) \[mm\].
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
    /// Formation time constants \[s\] on the fine grid ([`fine_grid`](crate::fine_grid)), `tau_map[f][z_m]`.
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

pub(super) fn grid_figures(model: &Model) -> GridFigures {
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

pub(super) fn magnet_figures(model: &Model) -> MagnetFigures {
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
