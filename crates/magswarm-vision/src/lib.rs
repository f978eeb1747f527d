//! Camera sources and swarm measurement for the magswarm hardware bridge.
//!
//! - [`vision`]: threshold (Otsu or fixed), largest connected component by runs, central second
//!   moments -> principal radii r1 <= r2, orientation and centroid, with an invalid reason.
//! - [`camera`]: the [`camera::Camera`] trait and its sources: [`replay`] (a recorded frame
//!   folder), [`emulated`] (renders a swarm from a model's radii) and, with the `aravis` feature,
//!   GenICam cameras through Aravis.
//! - [`measure`]: re-measure a frame folder into rows `t_s,file,r1_mm,r2_mm,angle_deg,cx_px,cy_px,valid`.
//! - [`folder`]: the frame folder format (8-bit grayscale PNG files and `index.csv` with `t_s,file`).
//!
//! Nothing here links glib or any system library unless the `aravis` feature is on.

pub mod folder;
pub mod image;
pub mod synth;
pub mod vision;

pub use image::{GrayImage, GrayView};
pub use vision::{measure, Invalid, Measurement, Roi, Threshold, Vision, VisionConfig};
