//! Colours: the categorical palette for series and the two colour maps of the heatmaps
//! (sequential viridis, diverging blue-white-red), interpolated from one set of stops each.

use plotters::style::RGBColor;

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
pub(super) fn interpolate(stops: &[(f64, f64, f64)], t: f64, nan_t: f64) -> RGBColor {
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
