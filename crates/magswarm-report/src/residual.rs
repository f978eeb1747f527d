//! The residual map over the operating points (z_m, f): one figure that identify's and
//! diagnose's reports share, on a diverging colour map centred on zero.

use crate::plot::{self, Heatmap, Labels};
use crate::Result;
use std::path::Path;

/// Residuals at operating points, to be drawn over the (z_m, f) grid they span.
#[derive(Debug, Clone, Copy)]
pub struct ResidualMap<'a> {
    /// Figure title (say which residual: model - measured, or measured - model).
    pub title: &'a str,
    /// (z_m \[mm\], f \[Hz\], residual \[mm\]) per operating point.
    pub points: &'a [(f64, f64, f64)],
    /// Points to circle (withheld points, points in a significant region).
    pub marks: &'a [(f64, f64)],
    /// Legend entry of the marks ("" for none).
    pub marks_label: &'a str,
    /// Half-width of the colour range \[mm\] (None: the largest |residual|), so that several
    /// maps can share one scale.
    pub half_range: Option<f64>,
}

/// The distinct values of one input, ascending (values within 1e-6 are one level).
pub fn levels(values: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = values.collect();
    v.sort_by(|a, b| a.total_cmp(b));
    v.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    v
}

/// Draw the map into `path`. Points fill the cells of their (z_m, f) levels; cells without a
/// point stay empty. Returns false (and draws nothing) where the points do not span a grid:
/// fewer than two levels of either input, or more than 40 000 cells.
pub fn residual_map(path: &Path, map: &ResidualMap) -> Result<bool> {
    let zs = levels(map.points.iter().map(|p| p.0));
    let fs = levels(map.points.iter().map(|p| p.1));
    if zs.len() < 2 || fs.len() < 2 || zs.len() * fs.len() > 40_000 {
        return Ok(false);
    }
    let level = |lv: &[f64], x: f64| lv.iter().position(|v| (v - x).abs() < 1e-6);
    let mut vals = vec![vec![f64::NAN; zs.len()]; fs.len()];
    let mut vmax: f64 = 0.0;
    for &(z, f, r) in map.points {
        // Every point's levels are in the grid (the grid is made of them).
        if let (Some(i), Some(j)) = (level(&zs, z), level(&fs, f)) {
            vals[j][i] = r;
            vmax = vmax.max(r.abs());
        }
    }
    let h = map.half_range.unwrap_or(vmax).max(1e-9);
    plot::heatmap_diverging(
        path,
        &Labels {
            title: map.title,
            x: "z_m [mm]",
            y: "f [Hz]",
        },
        &Heatmap {
            xs: &zs,
            ys: &fs,
            values: &vals,
            colorbar_label: "residual [mm]",
            marks: map.marks,
            marks_label: map.marks_label,
            range: Some((-h, h)),
        },
    )?;
    Ok(true)
}
