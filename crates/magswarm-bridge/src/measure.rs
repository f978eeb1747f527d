//! `magswarm-bridge measure`: re-measure a recorded frame folder with `magswarm_vision`.

use std::path::Path;

use crate::camera::CameraSetupError;

/// Why a folder could not be measured.
#[derive(Debug, thiserror::Error)]
pub enum MeasureFolderError {
    /// The `[vision]` settings.
    #[error(transparent)]
    Vision(#[from] CameraSetupError),
    /// The folder, a frame, or the output (each names its file).
    #[error(transparent)]
    Measure(#[from] magswarm_vision::MeasureError),
}

/// Measure every frame of `dir` (in index order) and write
/// `t_s,file,r1_mm,r2_mm,angle_deg,cx_px,cy_px,valid` to `out`. Returns (frames, valid).
pub fn measure_folder_to_csv(
    dir: &Path,
    mm_per_px: f64,
    vision: Option<&toml::Table>,
    out: &Path,
) -> Result<(usize, usize), MeasureFolderError> {
    let cfg = crate::camera::vision_config(vision)?;
    let rows = magswarm_vision::measure::measure_folder(dir, mm_per_px, &cfg)?;
    magswarm_vision::measure::write_rows_csv(out, &rows)?;
    Ok((rows.len(), rows.iter().filter(|r| r.valid).count()))
}
