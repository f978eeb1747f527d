//! The x-y plots: line/point series, stacked time panels, points with error bars, and
//! predicted against measured.

use crate::Result;
use plotters::prelude::*;
use std::path::Path;

use super::frame::*;
use super::*;

/// Line and point series with a legend (upper right).
///
/// Axis ranges cover every finite point with 5 % padding.
pub fn lines(path: &Path, labels: &Labels, series: &[Series]) -> Result<()> {
    lines_sized(path, labels, series, SIZE)
}

/// [`lines`] with an explicit image size \[px\].
pub fn lines_sized(
    path: &Path,
    labels: &Labels,
    series: &[Series],
    size: (u32, u32),
) -> Result<()> {
    let pts = || series.iter().flat_map(|s| s.points.iter().copied());
    let xr = padded(pts().map(|p| p.0), 0.02).ok_or_else(|| no_data(path))?;
    let yr = padded(pts().map(|p| p.1), 0.05).ok_or_else(|| no_data(path))?;
    let root = backend(path, size)?;
    let mut chart = ctx(
        ChartBuilder::on(&root)
            .caption(labels.title, font(24))
            .margin(15)
            .x_label_area_size(55)
            .y_label_area_size(75)
            .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1),
        path,
    )?;
    draw_mesh(&mut chart, labels.x, labels.y, path)?;
    if draw_series(&mut chart, series, path)? {
        draw_legend(&mut chart, path, SeriesLabelPosition::UpperRight)?;
    }
    ctx(root.present(), path)
}

/// Stacked panels sharing one x (time) axis, with `title` above and `x_label` under the
/// bottom panel. Each panel has its own y range and legend. Image height grows with the
/// number of panels (260 px each, 1000 px wide).
pub fn time_panels(path: &Path, title: &str, x_label: &str, panels: &[Panel]) -> Result<()> {
    if panels.is_empty() {
        return Err(no_data(path));
    }
    let all = || {
        panels
            .iter()
            .flat_map(|p| p.series.iter().flat_map(|s| s.points.iter().copied()))
    };
    let xr = padded(all().map(|p| p.0), 0.0).ok_or_else(|| no_data(path))?;
    let n = panels.len() as u32;
    let root = backend(path, (1000, 60 + 260 * n))?;
    let root = ctx(root.titled(title, font(24)), path)?;
    let areas = root.split_evenly((panels.len(), 1));
    for (k, (panel, area)) in panels.iter().zip(areas.iter()).enumerate() {
        let last = k + 1 == panels.len();
        let ys = panel
            .series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.1));
        let yr = padded(ys, 0.08).unwrap_or((0.0, 1.0));
        let mut chart = ctx(
            ChartBuilder::on(area)
                .margin(8)
                .x_label_area_size(if last { 50 } else { 22 })
                .y_label_area_size(75)
                .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1),
            path,
        )?;
        draw_mesh(
            &mut chart,
            if last { x_label } else { "" },
            &panel.y_label,
            path,
        )?;
        if draw_series(&mut chart, &panel.series, path)? {
            draw_legend(&mut chart, path, SeriesLabelPosition::UpperRight)?;
        }
    }
    ctx(root.present(), path)
}

/// Points with vertical error bars (one colour per [`ErrorSeries`]), plus optional curves
/// (e.g. the model) drawn underneath. Legend in the upper right.
pub fn scatter_with_errorbars(
    path: &Path,
    labels: &Labels,
    series: &[ErrorSeries],
    curves: &[Series],
) -> Result<()> {
    let xs = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.x))
        .chain(curves.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
    let ys = series
        .iter()
        .flat_map(|s| s.points.iter().flat_map(|p| [p.lo, p.hi, p.y]))
        .chain(curves.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
    let xr = padded(xs, 0.04).ok_or_else(|| no_data(path))?;
    let yr = padded(ys, 0.08).ok_or_else(|| no_data(path))?;
    let root = backend(path, SIZE)?;
    let mut chart = ctx(
        ChartBuilder::on(&root)
            .caption(labels.title, font(24))
            .margin(15)
            .x_label_area_size(55)
            .y_label_area_size(75)
            .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1),
        path,
    )?;
    draw_mesh(&mut chart, labels.x, labels.y, path)?;
    let mut named = draw_series(&mut chart, curves, path)?;
    for (i, s) in series.iter().enumerate() {
        let c = color_of(s.color, i + curves.len());
        let pts: Vec<ErrorBar> = s
            .points
            .iter()
            .copied()
            .filter(|p| p.x.is_finite() && p.y.is_finite() && p.lo.is_finite() && p.hi.is_finite())
            .collect();
        // Vertical bar with 10 px caps: the cap width is constant in pixels, so draw each bar
        // as a path anchored at its data point with pixel offsets.
        ctx(
            chart.draw_series(
                pts.iter()
                    .map(|p| PathElement::new(vec![(p.x, p.lo), (p.x, p.hi)], c.stroke_width(2))),
            ),
            path,
        )?;
        for end in [0, 1] {
            ctx(
                chart.draw_series(pts.iter().map(|p| {
                    let y = if end == 0 { p.lo } else { p.hi };
                    EmptyElement::at((p.x, y))
                        + PathElement::new(vec![(-5, 0), (5, 0)], c.stroke_width(2))
                })),
                path,
            )?;
        }
        let anno = ctx(
            chart.draw_series(pts.iter().map(|p| Circle::new((p.x, p.y), 5, c.filled()))),
            path,
        )?;
        if !s.name.is_empty() {
            named = true;
            anno.label(s.name.clone())
                .legend(move |(x, y)| Circle::new((x + 10, y), 5, c.filled()));
        }
    }
    if named {
        draw_legend(&mut chart, path, SeriesLabelPosition::UpperRight)?;
    }
    ctx(root.present(), path)
}

/// Predicted (y) against measured (x) scatter with the dashed identity line y = x, on equal
/// square ranges. `series` are usually [`Style::Points`]; legend in the upper left.
pub fn pred_vs_meas(path: &Path, labels: &Labels, series: &[Series]) -> Result<()> {
    let all = series
        .iter()
        .flat_map(|s| s.points.iter().flat_map(|p| [p.0, p.1]));
    let r = padded(all, 0.05).ok_or_else(|| no_data(path))?;
    let root = backend(path, (850, 800))?;
    let mut chart = ctx(
        ChartBuilder::on(&root)
            .caption(labels.title, font(24))
            .margin(15)
            .x_label_area_size(55)
            .y_label_area_size(75)
            .build_cartesian_2d(r.0..r.1, r.0..r.1),
        path,
    )?;
    draw_mesh(&mut chart, labels.x, labels.y, path)?;
    let ident = Series::dashed("identity y = x", vec![(r.0, r.0), (r.1, r.1)])
        .with_color(RGBColor(110, 110, 110));
    let mut all_series = vec![ident];
    all_series.extend(series.iter().enumerate().map(|(i, s)| {
        let mut s = s.clone();
        s.color = Some(color_of(s.color, i));
        s
    }));
    draw_series(&mut chart, &all_series, path)?;
    draw_legend(&mut chart, path, SeriesLabelPosition::UpperLeft)?;
    ctx(root.present(), path)
}
