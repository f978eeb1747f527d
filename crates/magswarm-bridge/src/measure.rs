//! `magswarm-bridge measure`: re-measure a recorded frame folder with `magswarm_vision`.

use std::path::Path;

/// Measure every frame of `dir` (in index order) and write
/// `t_s,file,r1_mm,r2_mm,angle_deg,cx_px,cy_px,valid` to `out`. Returns (frames, valid).
pub fn measure_folder_to_csv(
    dir: &Path,
    mm_per_px: f64,
    vision: Option<&toml::Table>,
    out: &Path,
) -> anyhow::Result<(usize, usize)> {
    let cfg = crate::camera::vision_config(vision).map_err(|e| anyhow::anyhow!(e))?;
    let rows = magswarm_vision::measure::measure_folder(dir, mm_per_px, &cfg)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    magswarm_vision::measure::write_rows_csv(out, &rows)
        .map_err(|e| anyhow::anyhow!("{}: {e}", out.display()))?;
    Ok((rows.len(), rows.iter().filter(|r| r.valid).count()))
}
