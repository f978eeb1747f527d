//! The grids and small statistics every figure shares: the seed's axes, the fine envelope
//! grid, the map at (z_m [mm], f [Hz]), medians. No figure type lives here, so every figure
//! module can use it without depending on another.

use magswarm_model::{hz_to_rad_s, steady, Model};

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

/// Smallest and largest value.
pub(super) fn range(v: impl Iterator<Item = f64>) -> [f64; 2] {
    v.fold([f64::INFINITY, f64::NEG_INFINITY], |a, x| {
        [a[0].min(x), a[1].max(x)]
    })
}

/// The fine envelope grid: z_m \[mm\] and f \[Hz\] values (41 x 46: 0.5 mm, 0.2 Hz).
pub fn fine_grid(model: &Model) -> (Vec<f64>, Vec<f64>) {
    let e = &model.envelope;
    let (z0, z1) = (e.z_min_m * 1e3, e.z_max_m * 1e3);
    let zs = (0..41).map(|i| z0 + (z1 - z0) * i as f64 / 40.0).collect();
    let fs = (0..46)
        .map(|j| e.f_min_hz + (e.f_max_hz - e.f_min_hz) * j as f64 / 45.0)
        .collect();
    (zs, fs)
}

/// Seed grid axes: z_m \[mm\], f \[Hz\].
pub fn seed_axes() -> (Vec<f64>, Vec<f64>) {
    let g = magswarm_model::seed_grid();
    let mut zs: Vec<f64> = g.iter().map(|p| p.0 * 1e3).collect();
    zs.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    let mut fs: Vec<f64> = g.iter().map(|p| p.1).collect();
    fs.sort_by(f64::total_cmp);
    fs.dedup();
    (zs, fs)
}

/// The steady map at z_m \[mm\] and f \[Hz\].
pub fn eval_mm(model: &Model, z_mm: f64, f: f64) -> steady::SteadyPoint {
    steady::evaluate(model, z_mm * 1e-3, hz_to_rad_s(f))
}
