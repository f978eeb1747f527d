//! Plots: a small, generic layer over `plotters` (bitmap backend, PNG files, bundled font).
//!
//! Every function writes one PNG and returns a [`crate::Result`] whose error names the
//! file. Nothing here knows about swarms: callers pass numbers and labels (put the
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
//!
//! Modules: `colour` (palette and colour maps), `frame` (backend, axes, legend: what every
//! plot shares), `xy` (line, panel, error-bar and predicted-vs-measured plots), `heatmap`.

mod colour;
mod frame;
mod heatmap;
mod xy;

pub use colour::{diverging, viridis, PALETTE};
pub use heatmap::{heatmap, heatmap_diverging};
pub use plotters::style::RGBColor;
pub use xy::{lines, lines_sized, pred_vs_meas, scatter_with_errorbars, time_panels};

use plotters::style::FontStyle;
use std::sync::Once;

/// Default image size \[px\] of single-panel plots.
pub const SIZE: (u32, u32) = (1000, 700);

/// The bundled font.
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

static FONT_ONCE: Once = Once::new();

/// Register the bundled font as `sans-serif` (idempotent; every plot function calls it).
pub fn ensure_font() {
    FONT_ONCE.call_once(|| {
        // The font is a compile-time constant known to parse; a failure would show in tests.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

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
    use super::heatmap::edges;
    use super::*;
    use std::path::Path;

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
