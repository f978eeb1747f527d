//! Re-measuring a recorded frame folder: one row per frame,
//! `t_s,file,r1_mm,r2_mm,angle_deg,cx_px,cy_px,valid`.

use crate::folder::{read_index, read_png, FolderError, IndexEntry};
use crate::vision::{Measurement, Vision, VisionConfig};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The columns of the measure output, in order.
pub const COLUMNS: [&str; 8] = [
    "t_s",
    "file",
    "r1_mm",
    "r2_mm",
    "angle_deg",
    "cx_px",
    "cy_px",
    "valid",
];

/// One measured frame. For an invalid frame the geometry is what was found (NaN when nothing
/// was) and `reason` says why it is invalid.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameRow {
    pub t_s: f64,
    pub file: String,
    pub r1_mm: f64,
    pub r2_mm: f64,
    pub angle_deg: f64,
    pub cx_px: f64,
    pub cy_px: f64,
    pub valid: bool,
    pub reason: Option<String>,
}

impl FrameRow {
    /// The row for a measurement (pixel radii scaled by `mm_per_px`).
    pub fn from_measurement(t_s: f64, file: &str, m: &Measurement, mm_per_px: f64) -> Self {
        FrameRow {
            t_s,
            file: file.to_string(),
            r1_mm: m.r1_px * mm_per_px,
            r2_mm: m.r2_px * mm_per_px,
            angle_deg: m.angle_deg,
            cx_px: m.cx_px,
            cy_px: m.cy_px,
            valid: m.valid(),
            reason: m.invalid.as_ref().map(|i| i.to_string()),
        }
    }

    /// The row for a frame that could not be read.
    pub fn lost(t_s: f64, file: &str, reason: String) -> Self {
        FrameRow {
            t_s,
            file: file.to_string(),
            r1_mm: f64::NAN,
            r2_mm: f64::NAN,
            angle_deg: f64::NAN,
            cx_px: f64::NAN,
            cy_px: f64::NAN,
            valid: false,
            reason: Some(reason),
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum MeasureError {
    #[error("--mm-per-px must be a positive finite number of millimetres per pixel, got {0}")]
    BadScale(f64),
    #[error(transparent)]
    Folder(#[from] FolderError),
    #[error("{path}: {source}")]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Measures every frame listed in `dir/index.csv`, in index order. A frame that is missing or
/// cannot be decoded gives a `valid = 0` row with its reason (also printed on stderr), not an
/// error; a missing or malformed index is an error naming the file and line. Frames are decoded
/// and measured on up to four threads.
pub fn measure_folder(
    dir: &Path,
    mm_per_px: f64,
    cfg: &VisionConfig,
) -> Result<Vec<FrameRow>, MeasureError> {
    if !(mm_per_px.is_finite() && mm_per_px > 0.0) {
        return Err(MeasureError::BadScale(mm_per_px));
    }
    let entries = read_index(dir)?;
    let threads = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .clamp(1, 4)
        .min(entries.len());
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut rows: Vec<Option<FrameRow>> = vec![None; entries.len()];
    let results = std::sync::Mutex::new(&mut rows);
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| {
                let mut vision = Vision::new();
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(e) = entries.get(i) else { break };
                    let row = measure_entry(dir, e, mm_per_px, cfg, &mut vision);
                    results.lock().unwrap_or_else(|p| p.into_inner())[i] = Some(row);
                }
            });
        }
    });
    let rows: Vec<FrameRow> = rows
        .into_iter()
        .map(|r| r.expect("every frame measured"))
        .collect();
    for (r, e) in rows.iter().zip(&entries) {
        if let Some(why) = &r.reason {
            log::warn!(
                "{} (index.csv line {}, t_s = {}): valid=0: {why}",
                dir.join(&e.file).display(),
                e.line,
                e.t_s
            );
        }
    }
    Ok(rows)
}

fn measure_entry(
    dir: &Path,
    e: &IndexEntry,
    mm_per_px: f64,
    cfg: &VisionConfig,
    vision: &mut Vision,
) -> FrameRow {
    match read_png(&dir.join(&e.file)) {
        Ok(img) => {
            let m = vision.measure(img.view(), cfg);
            FrameRow::from_measurement(e.t_s, &e.file, &m, mm_per_px)
        }
        Err(err) => FrameRow::lost(e.t_s, &e.file, frame_error_reason(&err)),
    }
}

fn frame_error_reason(e: &FolderError) -> String {
    match e {
        FolderError::Io { source, .. } => format!("cannot read the frame: {source}"),
        FolderError::Decode { source, .. } => format!("cannot decode the frame: {source}"),
        other => other.to_string(),
    }
}

fn num(v: f64, decimals: usize) -> String {
    if v.is_finite() {
        format!("{v:.decimals$}")
    } else {
        "nan".into()
    }
}

/// Writes the rows as CSV with the header [`COLUMNS`].
pub fn write_rows<W: Write>(out: W, rows: &[FrameRow]) -> std::io::Result<()> {
    let mut w = csv::Writer::from_writer(out);
    w.write_record(COLUMNS)?;
    for r in rows {
        w.write_record([
            format!("{}", r.t_s),
            r.file.clone(),
            num(r.r1_mm, 6),
            num(r.r2_mm, 6),
            num(r.angle_deg, 4),
            num(r.cx_px, 3),
            num(r.cy_px, 3),
            if r.valid { "1".into() } else { "0".into() },
        ])?;
    }
    w.flush()
}

/// Writes the rows to `path` (created or replaced).
pub fn write_rows_csv(path: &Path, rows: &[FrameRow]) -> Result<(), MeasureError> {
    let werr = |source| MeasureError::Write {
        path: path.to_path_buf(),
        source,
    };
    let f = std::fs::File::create(path).map_err(werr)?;
    write_rows(std::io::BufWriter::new(f), rows).map_err(werr)
}
