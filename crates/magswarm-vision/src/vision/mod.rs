//! Swarm measurement on one 8-bit grayscale frame.
//!
//! 1. Threshold: Otsu's method on the histogram of the region of interest (one pass), or a fixed
//!    level. The swarm is the dark class (`v <= T`), or the light class (`v > T`) with `invert`.
//! 2. Connected components by runs: one pass over the rows turns the binary image into runs of
//!    swarm pixels (64 pixels per SIMD step, background stretches are skipped a word at a time);
//!    runs of neighbouring rows that touch (8-connectivity) are joined with a union-find.
//! 3. The largest component is the swarm (debris and specks do not count). Its moments are summed
//!    per run in closed form (exact integer sums), giving area, centroid and the central second
//!    moments; each pixel is a unit square, so its own second moment 1/12 is added.
//! 4. r_i = 2 sqrt(lambda_i) for the eigenvalues lambda_1 <= lambda_2 of the covariance: exact
//!    for a filled ellipse with semi-axes r_1 <= r_2. The angle is that of the r_2 (major) axis.
//!
//! A frame is invalid (with the reason) when the threshold finds no contrast, no component is at
//! least `min_area_px` large, or the swarm touches the edge of the region of interest (it is cut,
//! so its moments are wrong).

//!
//! Files: `components.rs` (runs, union-find, moments of the largest component: [`Vision`]),
//! `threshold.rs` ([`histogram`] and Otsu's level, [`otsu`]); the configuration and the result
//! types are here.

mod components;
mod threshold;

use serde::{Deserialize, Serialize};
use std::fmt;

pub use components::{measure_frame, Vision};
pub use threshold::{histogram, otsu, Otsu};

/// How the swarm/background level is chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Threshold {
    /// Otsu's method on the histogram of the region of interest.
    #[default]
    Otsu,
    /// A fixed level: the swarm is `v <= level` (dark swarm) or `v > level` (with `invert`).
    Fixed(u8),
}

impl Serialize for Threshold {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Threshold::Otsu => s.serialize_str("otsu"),
            Threshold::Fixed(v) => s.serialize_u8(*v),
        }
    }
}

impl<'de> Deserialize<'de> for Threshold {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Num(i64),
            Text(String),
        }
        match Raw::deserialize(d)? {
            Raw::Num(v) if (0..=255).contains(&v) => Ok(Threshold::Fixed(v as u8)),
            Raw::Num(v) => Err(serde::de::Error::custom(format!(
                "threshold {v} is outside 0..=255 (8-bit gray level) "
            ))),
            Raw::Text(t) if t.eq_ignore_ascii_case("otsu") => Ok(Threshold::Otsu),
            Raw::Text(t) => Err(serde::de::Error::custom(format!(
                "threshold \"{t}\": expected \"otsu\" or a gray level 0..=255"
            ))),
        }
    }
}

/// Region of interest in frame pixels: columns `x..x+w`, rows `y..y+h`. TOML: `roi = [x, y, w, h]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(from = "[usize; 4]", into = "[usize; 4]")]
pub struct Roi {
    pub x: usize,
    pub y: usize,
    pub w: usize,
    pub h: usize,
}

impl From<[usize; 4]> for Roi {
    fn from(a: [usize; 4]) -> Self {
        Roi {
            x: a[0],
            y: a[1],
            w: a[2],
            h: a[3],
        }
    }
}
impl From<Roi> for [usize; 4] {
    fn from(r: Roi) -> Self {
        [r.x, r.y, r.w, r.h]
    }
}

/// The `[vision]` section of the bridge config.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VisionConfig {
    /// `"otsu"` (default) or a fixed gray level 0..=255.
    pub threshold: Threshold,
    /// `false` (default): dark swarm on a light background; `true`: light swarm on dark.
    pub invert: bool,
    /// `[x, y, w, h]` in pixels; the whole frame when absent.
    pub roi: Option<Roi>,
    /// The largest component must have at least this many pixels to count as the swarm
    /// (default 200: a disc of 8 px radius; specks of debris are smaller).
    pub min_area_px: u64,
    /// Otsu only: the two classes' mean gray levels must differ by at least this much, else the
    /// frame has no swarm (an empty frame's noise split in two).
    pub min_contrast: u8,
}

impl Default for VisionConfig {
    fn default() -> Self {
        VisionConfig {
            threshold: Threshold::Otsu,
            invert: false,
            roi: None,
            min_area_px: 200,
            min_contrast: 24,
        }
    }
}

/// Which edges of the region of interest a component touches.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Edges {
    pub left: bool,
    pub right: bool,
    pub top: bool,
    pub bottom: bool,
}

impl Edges {
    pub fn any(&self) -> bool {
        self.left || self.right || self.top || self.bottom
    }
}

impl fmt::Display for Edges {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<&str> = [
            (self.left, "left"),
            (self.right, "right"),
            (self.top, "top"),
            (self.bottom, "bottom"),
        ]
        .iter()
        .filter(|(b, _)| *b)
        .map(|(_, n)| *n)
        .collect();
        write!(f, "{}", names.join(", "))
    }
}

/// Why a frame has no valid measurement.
#[derive(Clone, Debug, PartialEq)]
pub enum Invalid {
    /// The region of interest lies (partly) outside the frame or is empty.
    BadRoi {
        roi: Roi,
        width: usize,
        height: usize,
    },
    /// Otsu: the two gray-level classes are closer than `min_contrast` (or one is empty).
    NoContrast {
        dark_mean: f64,
        light_mean: f64,
        min_contrast: u8,
    },
    /// No component of at least `min_area_px` pixels.
    NoSwarm { largest_px: u64, min_area_px: u64 },
    /// The swarm touches the edge of the region of interest: it is cut off.
    TouchesEdge {
        edges: Edges,
        area_px: u64,
        roi_px: u64,
    },
}

impl fmt::Display for Invalid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Invalid::BadRoi { roi, width, height } => write!(
                f,
                "region of interest [x={}, y={}, w={}, h={}] is empty or not inside the {}x{} frame",
                roi.x, roi.y, roi.w, roi.h, width, height
            ),
            Invalid::NoContrast {
                dark_mean,
                light_mean,
                min_contrast,
            } => write!(
                f,
                "no swarm: no contrast (Otsu classes at gray {dark_mean:.1} and {light_mean:.1}, \
                 less than min_contrast = {min_contrast} apart)"
            ),
            Invalid::NoSwarm {
                largest_px,
                min_area_px,
            } => write!(
                f,
                "no swarm: largest component has {largest_px} px, fewer than min_area_px = {min_area_px}"
            ),
            Invalid::TouchesEdge {
                edges,
                area_px,
                roi_px,
            } => {
                write!(
                    f,
                    "swarm touches the {edges} edge of the frame/region of interest ({area_px} px)"
                )?;
                if *area_px * 2 > *roi_px {
                    write!(
                        f,
                        "; it covers most of the image: is the polarity right \
                         (dark swarm on light background unless [vision] invert = true)?"
                    )?;
                }
                Ok(())
            }
        }
    }
}

/// The result for one frame. Pixel coordinates are those of the full frame, pixel centres at
/// integer coordinates (x to the right, y down). When `invalid` is set the geometry is that of the
/// largest component found (NaN when there is none) and must not be used as a measurement.
#[derive(Clone, Debug, PartialEq)]
pub struct Measurement {
    /// The gray level used (Otsu's or the fixed one).
    pub threshold: u8,
    /// Pixels of the swarm component.
    pub area_px: u64,
    /// Semi-axes, r1 <= r2, in pixels.
    pub r1_px: f64,
    pub r2_px: f64,
    /// Angle of the r2 (major) axis from +x towards +y (down), degrees in (-90, 90].
    pub angle_deg: f64,
    pub cx_px: f64,
    pub cy_px: f64,
    /// Components found (all sizes).
    pub components: usize,
    pub invalid: Option<Invalid>,
}

impl Measurement {
    pub fn valid(&self) -> bool {
        self.invalid.is_none()
    }

    fn invalid(threshold: u8, why: Invalid) -> Self {
        Measurement {
            threshold,
            area_px: 0,
            r1_px: f64::NAN,
            r2_px: f64::NAN,
            angle_deg: f64::NAN,
            cx_px: f64::NAN,
            cy_px: f64::NAN,
            components: 0,
            invalid: Some(why),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_parses_from_toml_like_values() {
        let c: VisionConfig =
            serde_json::from_str(r#"{"threshold": 90, "invert": true, "roi": [1,2,3,4]}"#).unwrap();
        assert_eq!(c.threshold, Threshold::Fixed(90));
        assert!(c.invert);
        assert_eq!(
            c.roi,
            Some(Roi {
                x: 1,
                y: 2,
                w: 3,
                h: 4
            })
        );
        let c: VisionConfig = serde_json::from_str(r#"{"threshold": "Otsu"}"#).unwrap();
        assert_eq!(c.threshold, Threshold::Otsu);
        assert!(serde_json::from_str::<VisionConfig>(r#"{"threshold": 300}"#).is_err());
        assert!(serde_json::from_str::<VisionConfig>(r#"{"treshold": 3}"#).is_err());
    }
}
