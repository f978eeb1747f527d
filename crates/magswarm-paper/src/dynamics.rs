//! ODE (4) against the steady map over the fine envelope grid: equilibria, stability, the
//! formation time constants and the scheduled confinement gains.

use magswarm_model::dynamics::{equilibria, InputTerms};
use magswarm_model::{hz_to_rad_s, Model};

use super::figures::DynamicsFigures;
use super::grid::{fine_grid, range};

/// Per-point results of the dynamics sweep.
pub(super) struct DynSweep {
    /// Time constants [s], tau[f index][z index].
    pub(super) tau: Vec<Vec<f64>>,
    pub(super) figures: DynamicsFigures,
}

pub(super) fn dynamics_sweep(model: &Model) -> DynSweep {
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
