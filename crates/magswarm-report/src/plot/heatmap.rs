//! Heatmaps: a filled colour map over a rectilinear grid, with colour bar, value range and
//! optional marked points.

use crate::{ReportError, Result};
use plotters::prelude::*;
use std::path::Path;

use super::colour::{diverging, viridis};
use super::frame::*;
use super::*;

/// Cell edges from cell centres: half-way between neighbours, mirrored at the ends.
pub(super) fn edges(c: &[f64]) -> Vec<f64> {
    let n = c.len();
    if n == 1 {
        return vec![c[0] - 0.5, c[0] + 0.5];
    }
    let mut e = Vec::with_capacity(n + 1);
    e.push(c[0] - (c[1] - c[0]) / 2.0);
    for i in 0..n - 1 {
        e.push((c[i] + c[i + 1]) / 2.0);
    }
    e.push(c[n - 1] + (c[n - 1] - c[n - 2]) / 2.0);
    e
}

/// A filled colour map (viridis) of `map` with a colour bar on the right; under the bar its
/// label, the value range and the legend of `map.marks` (drawn as open circles on the map).
pub fn heatmap(path: &Path, labels: &Labels, map: &Heatmap) -> Result<()> {
    heatmap_cmap(path, labels, map, viridis)
}

/// As [`heatmap`] with a diverging blue-white-red colour map for signed quantities
/// (residuals): the range is made symmetric about zero so that white is zero.
pub fn heatmap_diverging(path: &Path, labels: &Labels, map: &Heatmap) -> Result<()> {
    let m = match map.range {
        Some((a, b)) => a.abs().max(b.abs()),
        None => map
            .values
            .iter()
            .flatten()
            .filter(|v| v.is_finite())
            .fold(0.0f64, |m, v| m.max(v.abs())),
    }
    .max(1e-12);
    let sym = Heatmap {
        range: Some((-m, m)),
        ..*map
    };
    heatmap_cmap(path, labels, &sym, diverging)
}

/// The filled colour map behind [`heatmap`] and [`heatmap_diverging`].
pub(super) fn heatmap_cmap(
    path: &Path,
    labels: &Labels,
    map: &Heatmap,
    cmap: fn(f64) -> RGBColor,
) -> Result<()> {
    let (nx, ny) = (map.xs.len(), map.ys.len());
    if nx == 0 || ny == 0 || map.values.len() != ny || map.values.iter().any(|r| r.len() != nx) {
        return Err(ReportError::Shape {
            path: path.to_path_buf(),
            message: format!("heatmap needs values[{ny}][{nx}] for {nx} x and {ny} y cells"),
        });
    }
    let (vmin, vmax) = match map.range {
        Some(r) => r,
        None => padded(map.values.iter().flatten().copied(), 0.0).ok_or_else(|| no_data(path))?,
    };
    let span = if vmax > vmin { vmax - vmin } else { 1.0 };
    let (ex, ey) = (edges(map.xs), edges(map.ys));
    let root = backend(path, (1050, 720))?;
    let root = ctx(root.titled(labels.title, font(24)), path)?;
    let (main, bar) = root.split_horizontally(870);
    let mut chart = ctx(
        ChartBuilder::on(&main)
            .margin(15)
            .x_label_area_size(55)
            .y_label_area_size(75)
            .build_cartesian_2d(ex[0]..ex[nx], ey[0]..ey[ny]),
        path,
    )?;
    ctx(
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(labels.x)
            .y_desc(labels.y)
            .axis_desc_style(font(18))
            .label_style(font(15))
            .draw(),
        path,
    )?;
    let mut cells = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            let v = map.values[j][i];
            let c = if v.is_finite() {
                cmap((v - vmin) / span)
            } else {
                RGBColor(160, 160, 160)
            };
            cells.push(Rectangle::new(
                [(ex[i], ey[j]), (ex[i + 1], ey[j + 1])],
                c.filled(),
            ));
        }
    }
    ctx(chart.draw_series(cells), path)?;
    if !map.marks.is_empty() {
        ctx(
            chart.draw_series(
                map.marks
                    .iter()
                    .map(|&p| Circle::new(p, 6, BLACK.stroke_width(1))),
            ),
            path,
        )?;
        ctx(
            chart.draw_series(
                map.marks
                    .iter()
                    .map(|&p| Circle::new(p, 5, WHITE.stroke_width(2))),
            ),
            path,
        )?;
    }
    // Colour bar: 100 bands, ticks on the right, label and range as caption.
    let mut cb = ctx(
        ChartBuilder::on(&bar)
            .margin_top(15)
            .margin_bottom(105)
            .margin_left(5)
            .margin_right(5)
            .right_y_label_area_size(70)
            .build_cartesian_2d(0.0..1.0, vmin..vmin + span),
        path,
    )?;
    ctx(
        cb.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_labels(8)
            .label_style(font(14))
            .draw(),
        path,
    )?;
    let bands = 100;
    ctx(
        cb.draw_series((0..bands).map(|k| {
            let a = vmin + span * k as f64 / bands as f64;
            let b = vmin + span * (k + 1) as f64 / bands as f64;
            Rectangle::new(
                [(0.0, a), (1.0, b)],
                cmap((k as f64 + 0.5) / bands as f64).filled(),
            )
        })),
        path,
    )?;
    // Under the bar: its label, the value range, and the legend of the marks (kept off the
    // map so it hides nothing).
    let bh = bar.dim_in_pixel().1 as i32;
    let text = |s: String, y: i32, size: u32| bar.draw(&Text::new(s, (8, bh - y), font(size)));
    ctx(text(map.colorbar_label.to_string(), 92, 16), path)?;
    ctx(
        text(format!("range {} .. {}", fmt_g(vmin), fmt_g(vmax)), 68, 14),
        path,
    )?;
    if !map.marks.is_empty() && !map.marks_label.is_empty() {
        ctx(
            bar.draw(&Circle::new((14, bh - 31), 5, BLACK.stroke_width(2))),
            path,
        )?;
        ctx(
            bar.draw(&Text::new(
                map.marks_label.to_string(),
                (26, bh - 38),
                font(13),
            )),
            path,
        )?;
    }
    ctx(root.present(), path)
}
