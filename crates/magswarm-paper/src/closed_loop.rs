//! The closed-loop operating points of Sec. III-D: the inputs that reach the seed's three
//! PID targets on the model's map, found on a fine grid and refined off it.

use magswarm_model::Model;

use super::figures::ClosedLoopPoint;
use super::grid::eval_mm;
use super::seed;
use magswarm_fit::optim::nelder_mead;

pub(super) fn closed_loop(model: &Model) -> Vec<ClosedLoopPoint> {
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
