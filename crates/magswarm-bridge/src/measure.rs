//! `magswarm-bridge measure`: re-measure a recorded frame folder.

use std::io::Write;
use std::path::Path;

use magswarm_vision::folder;

use crate::camera::Measurer;

/// Measure every frame of `dir` (in index order) and write
/// `t_s,file,r1_mm,r2_mm,angle_deg,cx_px,cy_px,valid` to `out`. Returns (frames, valid).
pub fn measure_folder_to_csv(
    dir: &Path,
    mm_per_px: f64,
    vision: Option<&toml::Table>,
    out: &Path,
) -> anyhow::Result<(usize, usize)> {
    if !(mm_per_px.is_finite() && mm_per_px > 0.0) {
        anyhow::bail!("--mm-per-px {mm_per_px} must be a positive number");
    }
    let entries = folder::read_index(dir).map_err(|e| anyhow::anyhow!("{}: {e}", dir.display()))?;
    let mut m = Measurer::new(vision, mm_per_px).map_err(|e| anyhow::anyhow!(e))?;
    let f = std::fs::File::create(out).map_err(|e| anyhow::anyhow!("{}: {e}", out.display()))?;
    let mut w = csv::Writer::from_writer(std::io::BufWriter::new(f));
    w.write_record([
        "t_s",
        "file",
        "r1_mm",
        "r2_mm",
        "angle_deg",
        "cx_px",
        "cy_px",
        "valid",
    ])?;
    let mut valid = 0;
    for e in &entries {
        let path = dir.join(&e.file);
        let img =
            folder::read_png(&path).map_err(|err| anyhow::anyhow!("{}: {err}", path.display()))?;
        let r = m.measure(&img);
        let ok = r.invalid.is_none();
        valid += ok as usize;
        let num = |v: f64| {
            if ok && v.is_finite() {
                format!("{v}")
            } else {
                String::new()
            }
        };
        w.write_record([
            format!("{}", e.t_s),
            e.file.clone(),
            num(r.r1_mm),
            num(r.r2_mm),
            num(r.angle_deg),
            num(r.cx_px),
            num(r.cy_px),
            (ok as u8).to_string(),
        ])?;
        if let Some(why) = &r.invalid {
            eprintln!(
                "magswarm-bridge measure: {} (t_s {}): invalid: {why}",
                e.file, e.t_s
            );
        }
    }
    w.flush()?;
    w.into_inner()
        .map_err(|e| anyhow::anyhow!("{e}"))?
        .flush()?;
    Ok((entries.len(), valid))
}
