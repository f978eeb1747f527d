//! The drawing frame every plot shares: the PNG backend, fonts, padded axis ranges, the mesh
//! with its labels, series and legend drawing, and errors that name the file.

use crate::{ReportError, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

use super::colour::PALETTE;
use super::{ensure_font, Series, Style};

pub(super) fn font(size: u32) -> TextStyle<'static> {
    ("sans-serif", size).into_font().color(&BLACK)
}

pub(super) fn color_of(c: Option<RGBColor>, i: usize) -> RGBColor {
    c.unwrap_or(PALETTE[i % PALETTE.len()])
}

/// A padded range covering all finite values (a degenerate range is widened).
pub(super) fn padded(it: impl Iterator<Item = f64>, pad: f64) -> Option<(f64, f64)> {
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

pub(super) fn no_data(path: &Path) -> ReportError {
    ReportError::NoData(path.to_path_buf())
}

pub(super) fn backend(
    path: &Path,
    size: (u32, u32),
) -> Result<DrawingArea<BitMapBackend<'_>, Shift>> {
    ensure_font();
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|err| ReportError::Io {
            what: "creating",
            path: dir.to_path_buf(),
            err,
        })?;
    }
    let root = BitMapBackend::new(path, size).into_drawing_area();
    ctx(root.fill(&WHITE), path)?;
    Ok(root)
}

/// Map plotters' drawing errors (not `Send`/`Sync`) into a [`ReportError`] with the path.
pub(super) fn ctx<T, E: std::fmt::Display>(r: std::result::Result<T, E>, path: &Path) -> Result<T> {
    r.map_err(|e| ReportError::Draw {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

pub(super) type Chart<'a, 'b> = ChartContext<
    'a,
    BitMapBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// Draw series into a chart, with legend entries for named ones.
pub(super) fn draw_series<'a, 'b: 'a>(
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

pub(super) fn draw_legend<'a, 'b: 'a>(
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

pub(super) fn draw_mesh<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    x: &str,
    y: &str,
    path: &Path,
) -> Result<()> {
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
