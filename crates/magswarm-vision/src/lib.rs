//! Camera sources and swarm measurement for the magswarm hardware bridge.
//!
//! - [`vision`]: threshold (Otsu or fixed), largest connected component by runs, central second
//!   moments -> principal radii r1 <= r2, orientation and centroid, with an invalid reason.
//! - [`camera`]: the [`Camera`] trait and its sources: [`replay`] (a recorded frame folder),
//!   [`emulated`] (renders a swarm from a model's radii) and, with the `aravis` feature,
//!   GenICam cameras through Aravis (`aravis_camera`).
//! - [`measure`]: re-measure a frame folder into rows
//!   `t_s,file,r1_mm,r2_mm,angle_deg,cx_px,cy_px,valid`.
//! - [`folder`]: the frame folder format (8-bit grayscale PNG files and `index.csv` with
//!   `t_s,file`) and a writer to record one.
//! - [`synth`]: synthetic ellipse frames with a known truth (tests, benches).
//!
//! Nothing here links glib or any system library unless the `aravis` feature is on.

#[cfg(feature = "aravis")]
pub mod aravis_camera;
pub mod camera;
pub mod emulated;
pub mod folder;
pub mod image;
pub mod measure;
pub mod replay;
pub mod synth;
pub mod vision;

pub use camera::{Camera, CameraError, Frame};
pub use emulated::{EmulatedCamera, EmulatorConfig, SharedSwarm, SwarmRenderer, SwarmState};
pub use folder::{FolderError, FrameFolderWriter};
pub use image::{GrayImage, GrayView};
pub use measure::{measure_folder, write_rows_csv, FrameRow, MeasureError};
pub use replay::ReplayCamera;
pub use vision::{measure_frame, Invalid, Measurement, Roi, Threshold, Vision, VisionConfig};
