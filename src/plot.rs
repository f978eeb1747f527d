//! Plots: a small, generic layer over `plotters` (bitmap backend, PNG files, bundled font).
//!
//! Every function writes one PNG and returns `anyhow::Result<()>` with the file's path in the
//! error context. Nothing here knows about swarms: callers pass numbers and labels (put the
//! units in the labels, e.g. `"z_m [mm]"`).
//!
//! - [`lines`]: line/point series with a legend;
//! - [`time_panels`]: stacked panels sharing one time axis;
//! - [`scatter_with_errorbars`]: points with vertical error bars, optionally with curves;
//! - [`pred_vs_meas`]: predicted against measured, with the identity line;
//! - [`heatmap`]: a filled colour map over a rectilinear grid, with colour bar, value range and
//!   optional marked points.
//!
//! The font (DejaVu Sans, `assets/fonts/DejaVuSans.ttf`) is compiled into the binary and
//! registered once as the `sans-serif` family, so plots look the same on every machine and no
//! system font is needed.

use anyhow::{anyhow, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::Once;

pub use plotters::style::RGBColor;

/// Default image size [px] of single-panel plots.
pub const SIZE: (u32, u32) = (1000, 700);

/// The bundled font.
static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
static FONT_ONCE: Once = Once::new();

/// Register the bundled font as `sans-serif` (idempotent; every plot function calls it).
pub fn ensure_font() {
    FONT_ONCE.call_once(|| {
        // The font is a compile-time constant known to parse; a failure would show in tests.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// A categorical palette (colour-blind friendly, Okabe-Ito order) used for series without an
/// explicit colour.
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
    RGBColor(240, 228, 66),
];

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Style {
    /// Solid line.
    #[default]
    Line,
    /// Dashed line.
    Dashed,
    /// Markers only (filled circles).
    Points,
    /// Solid line with markers.
    LinePoints,
}

/// One named series of (x, y) points.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend entry (empty: not in the legend).
    pub name: String,
    /// The points, in drawing order.
    pub points: Vec<(f64, f64)>,
    /// How to draw them.
    pub style: Style,
    /// Colour; `None` picks the next colour of [`PALETTE`].
    pub color: Option<RGBColor>,
}

impl Series {
    /// A series with the given style and an automatic colour.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>, style: Style) -> Series {
        Series {
            name: name.into(),
            points,
            style,
            color: None,
        }
    }
    /// A solid line.
    pub fn line(name: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series::new(name, points, Style::Line)
    }
    /// A dashed line.
    pub fn dashed(name: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series::new(name, points, Style::Dashed)
    }
    /// Markers only.
    pub fn points(name: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series::new(name, points, Style::Points)
    }
    /// Set the colour.
    pub fn with_color(mut self, c: RGBColor) -> Series {
        self.color = Some(c);
        self
    }
}

/// Title and axis labels of a plot (include units, e.g. `"t [s]"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Labels<'a> {
    /// Caption above the plot.
    pub title: &'a str,
    /// Label of the x axis.
    pub x: &'a str,
    /// Label of the y axis.
    pub y: &'a str,
}

/// One panel of [`time_panels`]: a y label and its series.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// Label of this panel's y axis (with unit).
    pub y_label: String,
    /// Series drawn in this panel.
    pub series: Vec<Series>,
}

/// A point with a vertical error bar from `lo` to `hi`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorBar {
    /// Abscissa.
    pub x: f64,
    /// Central value (drawn as a marker).
    pub y: f64,
    /// Lower end of the bar.
    pub lo: f64,
    /// Upper end of the bar.
    pub hi: f64,
}

/// A named set of points with error bars.
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorSeries {
    /// Legend entry.
    pub name: String,
    /// The points.
    pub points: Vec<ErrorBar>,
    /// Colour; `None` picks the next colour of [`PALETTE`].
    pub color: Option<RGBColor>,
}

/// A scalar field on a rectilinear grid, for [`heatmap`].
///
/// `values[j][i]` is the value at `(xs[i], ys[j])`; `xs` and `ys` are cell centres in
/// increasing order (unequal spacing is fine: each cell spans half-way to its neighbours).
/// Non-finite values are drawn grey.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Heatmap<'a> {
    /// Cell centres along x.
    pub xs: &'a [f64],
    /// Cell centres along y.
    pub ys: &'a [f64],
    /// Values, one row per y.
    pub values: &'a [Vec<f64>],
    /// Label of the colour bar (quantity and unit).
    pub colorbar_label: &'a str,
    /// Points to mark with open circles (e.g. measurement grid), in data coordinates.
    pub marks: &'a [(f64, f64)],
    /// Legend entry of the marks, shown under the colour bar (empty: no legend).
    pub marks_label: &'a str,
    /// Colour range; `None` uses the finite min..max of the values.
    pub range: Option<(f64, f64)>,
}

fn font(size: u32) -> TextStyle<'static> {
    ("sans-serif", size).into_font().color(&BLACK)
}

fn color_of(c: Option<RGBColor>, i: usize) -> RGBColor {
    c.unwrap_or(PALETTE[i % PALETTE.len()])
}

/// A padded range covering all finite values (a degenerate range is widened).
fn padded(it: impl Iterator<Item = f64>, pad: f64) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in it.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        // No finite value (lo stays +inf, hi -inf).
        return None;
    }
    let span = hi - lo;
    let p = if span > 0.0 {
        span * pad
    } else {
        lo.abs().max(1.0) * 0.05
    };
    Some((lo - p, hi + p))
}

fn no_data(path: &Path) -> anyhow::Error {
    anyhow!("{}: nothing to plot (no finite points)", path.display())
}

fn backend(path: &Path, size: (u32, u32)) -> Result<DrawingArea<BitMapBackend<'_>, Shift>> {
    ensure_font();
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    Ok(root)
}

/// Map plotters' drawing errors (not `Send`/`Sync`) into anyhow with the path.
fn ctx<T, E: std::fmt::Display>(r: std::result::Result<T, E>, path: &Path) -> Result<T> {
    r.map_err(|e| anyhow!("drawing {}: {e}", path.display()))
}

type Chart<'a, 'b> = ChartContext<
    'a,
    BitMapBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// Draw series into a chart, with legend entries for named ones.
fn draw_series<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    series: &[Series],
    path: &Path,
) -> Result<bool> {
    let mut any_named = false;
    for (i, s) in series.iter().enumerate() {
        let c = color_of(s.color, i);
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        let line_style = c.stroke_width(2);
        let anno = match s.style {
            Style::Line => ctx(chart.draw_series(LineSeries::new(pts, line_style)), path)?,
            Style::Dashed => ctx(
                chart.draw_series(DashedLineSeries::new(pts, 8, 5, line_style)),
                path,
            )?,
            Style::Points => ctx(
                chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled()))),
                path,
            )?,
            Style::LinePoints => {
                ctx(
                    chart.draw_series(LineSeries::new(pts.clone(), line_style)),
                    path,
                )?;
                ctx(
                    chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled()))),
                    path,
                )?
            }
        };
        if !s.name.is_empty() {
            any_named = true;
            let style = s.style;
            // One element type for every style: two segments and a marker, some invisible.
            type Seg = Vec<(i32, i32)>;
            let (seg1, seg2): (Seg, Seg) = match style {
                Style::Points => (vec![], vec![]),
                Style::Dashed => (vec![(0, 0), (7, 0)], vec![(12, 0), (20, 0)]),
                _ => (vec![(0, 0), (20, 0)], vec![]),
            };
            let marker = if matches!(style, Style::Points | Style::LinePoints) {
                c.filled()
            } else {
                c.mix(0.0).filled()
            };
            anno.label(s.name.clone()).legend(move |(x, y)| {
                EmptyElement::at((x, y))
                    + PathElement::new(seg1.clone(), c.stroke_width(2))
                    + PathElement::new(seg2.clone(), c.stroke_width(2))
                    + Circle::new((10, 0), 4, marker)
            });
        }
    }
    Ok(any_named)
}

fn draw_legend<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    path: &Path,
    pos: SeriesLabelPosition,
) -> Result<()> {
    ctx(
        chart
            .configure_series_labels()
            .position(pos)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.4))
            .label_font(font(16))
            .draw(),
        path,
    )
}

fn draw_mesh<'a, 'b: 'a>(chart: &mut Chart<'a, 'b>, x: &str, y: &str, path: &Path) -> Result<()> {
    ctx(
        chart
            .configure_mesh()
            .x_desc(x)
            .y_desc(y)
            .axis_desc_style(font(18))
            .label_style(font(15))
            .light_line_style(BLACK.mix(0.05))
            .bold_line_style(BLACK.mix(0.15))
            .draw(),
        path,
    )
}

/// Line and point series with a legend (upper right).
///
/// Axis ranges cover every finite point with 5 % padding.
pub fn lines(path: &Path, labels: &Labels, series: &[Series]) -> Result<()> {
    lines_sized(path, labels, series, SIZE)
}

/// [`lines`] with an explicit image size [px].
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

/// Viridis colour map, `t` in [0, 1].
pub fn viridis(t: f64) -> RGBColor {
    const V: [(f64, f64, f64); 9] = [
        (68.0, 1.0, 84.0),
        (71.0, 44.0, 122.0),
        (59.0, 81.0, 139.0),
        (44.0, 113.0, 142.0),
        (33.0, 144.0, 141.0),
        (39.0, 173.0, 129.0),
        (92.0, 200.0, 99.0),
        (170.0, 220.0, 50.0),
        (253.0, 231.0, 37.0),
    ];
    interpolate(&V, t, 0.0)
}

/// Cell edges from cell centres: half-way between neighbours, mirrored at the ends.
fn edges(c: &[f64]) -> Vec<f64> {
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

/// Diverging colour map (blue - white - red, ColorBrewer RdBu reversed), `t` in [0, 1] with
/// white at 0.5.
pub fn diverging(t: f64) -> RGBColor {
    const V: [(f64, f64, f64); 7] = [
        (33.0, 102.0, 172.0),
        (103.0, 169.0, 207.0),
        (209.0, 229.0, 240.0),
        (247.0, 247.0, 247.0),
        (253.0, 219.0, 199.0),
        (239.0, 138.0, 98.0),
        (178.0, 24.0, 43.0),
    ];
    interpolate(&V, t, 0.5)
}

/// Linear interpolation between equally spaced colour stops, `t` in [0, 1] (clamped); a
/// non-finite `t` takes the colour at `nan_t` (the low end for viridis, white for diverging).
fn interpolate(stops: &[(f64, f64, f64)], t: f64, nan_t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        nan_t
    };
    let s = t * (stops.len() - 1) as f64;
    let i = (s.floor() as usize).min(stops.len() - 2);
    let u = s - i as f64;
    let l = |a: f64, b: f64| (a + (b - a) * u).round() as u8;
    RGBColor(
        l(stops[i].0, stops[i + 1].0),
        l(stops[i].1, stops[i + 1].1),
        l(stops[i].2, stops[i + 1].2),
    )
}

/// The filled colour map behind [`heatmap`] and [`heatmap_diverging`].
fn heatmap_cmap(
    path: &Path,
    labels: &Labels,
    map: &Heatmap,
    cmap: fn(f64) -> RGBColor,
) -> Result<()> {
    let (nx, ny) = (map.xs.len(), map.ys.len());
    if nx == 0 || ny == 0 || map.values.len() != ny || map.values.iter().any(|r| r.len() != nx) {
        return Err(anyhow!(
            "{}: heatmap needs values[{ny}][{nx}] for {nx} x and {ny} y cells",
            path.display()
        ));
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

/// Short number formatting for labels (4 significant digits).
pub fn fmt_g(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let mag = v.abs().log10().floor() as i32;
    if (-3..5).contains(&mag) {
        let dec = (3 - mag).max(0) as usize;
        format!("{v:.dec$}")
    } else {
        format!("{v:.3e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png_ok(p: &Path) {
        let b = std::fs::read(p).unwrap();
        assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n", "{}", p.display());
        assert!(b.len() > 5_000, "{} is only {} bytes", p.display(), b.len());
    }

    #[test]
    fn every_plot_kind_writes_a_png() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let l = Labels {
            title: "t",
            x: "x [m]",
            y: "y [m]",
        };
        let sine: Vec<(f64, f64)> = (0..50)
            .map(|i| (i as f64 * 0.1, (i as f64 * 0.1).sin()))
            .collect();
        lines(
            &d.join("l.png"),
            &l,
            &[
                Series::line("sin", sine.clone()),
                Series::points("p", sine.clone()),
            ],
        )
        .unwrap();
        time_panels(
            &d.join("t.png"),
            "panels",
            "t [s]",
            &[
                Panel {
                    y_label: "a".into(),
                    series: vec![Series::line("a", sine.clone())],
                },
                Panel {
                    y_label: "b".into(),
                    series: vec![Series::dashed("b", sine.clone())],
                },
            ],
        )
        .unwrap();
        let e = ErrorSeries {
            name: "m".into(),
            points: vec![
                ErrorBar {
                    x: 1.0,
                    y: 1.0,
                    lo: 0.8,
                    hi: 1.2,
                },
                ErrorBar {
                    x: 2.0,
                    y: 1.5,
                    lo: 1.4,
                    hi: 1.7,
                },
            ],
            color: None,
        };
        scatter_with_errorbars(
            &d.join("e.png"),
            &l,
            &[e],
            &[Series::line("c", sine.clone())],
        )
        .unwrap();
        pred_vs_meas(
            &d.join("p.png"),
            &l,
            &[Series::points("r1", vec![(1.0, 1.1), (2.0, 1.9)])],
        )
        .unwrap();
        let xs = [1.0, 2.0, 3.0];
        let ys = [10.0, 20.0];
        let v = vec![vec![1.0, 2.0, 3.0], vec![4.0, f64::NAN, 6.0]];
        let h = Heatmap {
            xs: &xs,
            ys: &ys,
            values: &v,
            colorbar_label: "v [1]",
            marks: &[(2.0, 10.0)],
            marks_label: "grid",
            range: None,
        };
        heatmap(&d.join("sub/h.png"), &l, &h).unwrap();
        for f in ["l.png", "t.png", "e.png", "p.png", "sub/h.png"] {
            png_ok(&d.join(f));
        }
    }

    #[test]
    fn bad_input_is_an_error_naming_the_file() {
        let l = Labels {
            title: "t",
            x: "x",
            y: "y",
        };
        let err = lines(Path::new("/nonexistent-dir-xyz/a.png"), &l, &[]).unwrap_err();
        assert!(format!("{err:#}").contains("a.png"));
        let h = Heatmap {
            xs: &[1.0],
            ys: &[1.0, 2.0],
            values: &[vec![1.0]],
            colorbar_label: "",
            marks: &[],
            marks_label: "",
            range: None,
        };
        assert!(
            format!("{:#}", heatmap(Path::new("x.png"), &l, &h).unwrap_err()).contains("x.png")
        );
    }

    #[test]
    fn viridis_ends_and_edges() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(edges(&[1.0, 2.0, 4.0]), vec![0.5, 1.5, 3.0, 5.0]);
        assert_eq!(fmt_g(7.6123), "7.612");
    }
}
