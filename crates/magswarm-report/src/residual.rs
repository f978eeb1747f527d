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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_merge_values_closer_than_a_micrometre() {
        let lv = levels([8.5, 3.5, 8.5 + 1e-9, 13.5, 3.5].into_iter());
        assert_eq!(lv, vec![3.5, 8.5, 13.5]);
    }

    #[test]
    fn draws_a_grid_and_refuses_what_spans_none() {
        let dir = tempfile::tempdir().unwrap();
        let pts = [
            (3.5, 1.0, 0.2),
            (8.5, 1.0, -0.4),
            (3.5, 5.0, 0.1),
            // (8.5, 5.0) missing: an empty cell, not a point moved to another cell.
        ];
        let path = dir.path().join("r.png");
        let map = ResidualMap {
            title: "Residual r1",
            points: &pts,
            marks: &[(8.5, 1.0)],
            marks_label: "withheld",
            half_range: None,
        };
        assert!(residual_map(&path, &map).unwrap());
        assert!(std::fs::metadata(&path).unwrap().len() > 1000);
        // One z_m level only: no grid, nothing drawn.
        let line = [(3.5, 1.0, 0.2), (3.5, 5.0, 0.1)];
        let path2 = dir.path().join("line.png");
        let map2 = ResidualMap {
            points: &line,
            ..map
        };
        assert!(!residual_map(&path2, &map2).unwrap());
        assert!(!path2.exists());
    }
}
