//! The synthetic collapse of Fig. 5: noisy repeats on the seed grid, scaled by the stiffness,
//! binned by frequency against Phi(f).

use magswarm_model::{hz_to_rad_s, steady, Model};

use super::figures::CollapseFigures;
use super::grid::median;
use super::seed;

/// Collapse variables y_i = r_i S_i^alpha_i / C_i of noisy synthetic repeats on the seed grid.
pub struct CollapseData {
    /// (f, y1, y2) per repeat and grid point.
    pub samples: Vec<(f64, f64, f64)>,
    /// (f, y1, y2) of the noise-free model per grid point.
    pub exact: Vec<(f64, f64, f64)>,
    /// The figures computed from them.
    pub figures: CollapseFigures,
}

/// The collapse data of Fig. 5 for a model (seeded synthetic repeats: the same every run).
pub fn collapse(model: &Model) -> CollapseData {
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
pub fn bins(samples: &[(f64, f64, f64)]) -> Vec<(f64, Vec<f64>, Vec<f64>)> {
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
