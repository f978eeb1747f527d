//! The frame folder: 8-bit grayscale PNG files and an `index.csv` with columns `t_s,file`
//! (seconds from the first frame; file names relative to the folder).

use crate::image::GrayImage;
use std::fs::File;
use std::io::{BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

/// Errors reading or writing frames and index files; each names the file (and line).
#[derive(Debug, thiserror::Error)]
pub enum FolderError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(
        "{path}: frame index not found (a frame folder needs index.csv with columns t_s,file)"
    )]
    NoIndex { path: PathBuf },
    #[error("{path}:{line}: {msg}")]
    BadIndex {
        path: PathBuf,
        line: u64,
        msg: String,
    },
    #[error("{path}: cannot decode PNG: {source}")]
    Decode {
        path: PathBuf,
        #[source]
        source: PngError,
    },
    #[error("{path}: cannot encode PNG: {source}")]
    Encode {
        path: PathBuf,
        #[source]
        source: PngError,
    },
}

/// A PNG frame that cannot be decoded or encoded.
#[derive(Debug, thiserror::Error)]
pub enum PngError {
    /// The decoder's error (not a PNG, truncated, bad checksum).
    #[error(transparent)]
    Decoding(#[from] png::DecodingError),
    /// The encoder's error.
    #[error(transparent)]
    Encoding(#[from] png::EncodingError),
    /// Samples that are not 8-bit after expansion.
    #[error("{0:?}-bit samples after expansion")]
    BitDepth(png::BitDepth),
    /// A palette image the decoder did not expand.
    #[error("palette PNG was not expanded")]
    Palette,
    /// Header and data disagree.
    #[error("PNG size does not match its data")]
    Size,
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> FolderError + '_ {
    move |source| FolderError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// One row of `index.csv`.
#[derive(Clone, Debug, PartialEq)]
pub struct IndexEntry {
    pub t_s: f64,
    pub file: String,
    /// Line number in index.csv (1 = header).
    pub line: u64,
}

/// Reads `dir/index.csv`. Errors name the file and line: missing file, missing columns, a `t_s`
/// that is not a finite non-negative number or goes backwards, an empty file name, no rows.
/// Extra columns are ignored.
pub fn read_index(dir: &Path) -> Result<Vec<IndexEntry>, FolderError> {
    let path = dir.join("index.csv");
    let f = match File::open(&path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(FolderError::NoIndex { path })
        }
        Err(e) => return Err(io_err(&path)(e)),
    };
    let bad = |line: u64, msg: String| FolderError::BadIndex {
        path: path.clone(),
        line,
        msg,
    };
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(false)
        .trim(csv::Trim::All)
        .from_reader(BufReader::new(f));
    let headers = rdr
        .headers()
        .map_err(|e| bad(1, format!("cannot read the header: {e}")))?
        .clone();
    let col = |name: &str| {
        headers
            .iter()
            .position(|h| h.trim_start_matches('\u{feff}') == name)
    };
    let (it, ifile) = match (col("t_s"), col("file")) {
        (Some(a), Some(b)) => (a, b),
        _ => {
            return Err(bad(
                1,
                format!(
                    "header must have columns t_s and file, found: {}",
                    headers.iter().collect::<Vec<_>>().join(",")
                ),
            ))
        }
    };
    let mut out: Vec<IndexEntry> = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| {
            let line = e.position().map(|p| p.line()).unwrap_or(0);
            bad(line, format!("malformed row: {e}"))
        })?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        let ts = rec.get(it).unwrap_or("");
        let t_s: f64 = ts
            .parse()
            .map_err(|_| bad(line, format!("t_s {ts:?} is not a number")))?;
        if !t_s.is_finite() || t_s < 0.0 {
            return Err(bad(line, format!("t_s {ts} must be finite and >= 0")));
        }
        if let Some(prev) = out.last() {
            if t_s < prev.t_s {
                return Err(bad(
                    line,
                    format!("t_s {t_s} goes backwards (previous row: {})", prev.t_s),
                ));
            }
        }
        let file = rec.get(ifile).unwrap_or("").to_string();
        if file.is_empty() {
            return Err(bad(line, "empty file name".into()));
        }
        out.push(IndexEntry { t_s, file, line });
    }
    if out.is_empty() {
        return Err(bad(1, "no frames listed (header only)".into()));
    }
    Ok(out)
}

/// Decodes a PNG frame from memory into 8-bit grayscale. The frame folder format is 8-bit
/// grayscale; other PNGs a recording tool may have written are converted rather than refused:
/// 1/2/4-bit gray is expanded, 16-bit keeps its high byte, an alpha channel is dropped, palette and
/// colour images become their luma (ITU-R BT.601 weights).
pub fn decode_png(bytes: &[u8]) -> Result<GrayImage, PngError> {
    let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
    dec.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = dec.read_info()?;
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf)?;
    let (w, h) = (info.width as usize, info.height as usize);
    if info.bit_depth != png::BitDepth::Eight {
        return Err(PngError::BitDepth(info.bit_depth));
    }
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => return Err(PngError::Palette),
    };
    let stride = info.line_size;
    if stride < w * channels || buf.len() < stride * h.saturating_sub(1) + w * channels {
        return Err(PngError::Size);
    }
    let mut data = Vec::with_capacity(w * h);
    for y in 0..h {
        let row = &buf[y * stride..y * stride + w * channels];
        match channels {
            1 => data.extend_from_slice(row),
            2 => data.extend(row.chunks_exact(2).map(|p| p[0])),
            _ => data.extend(row.chunks_exact(channels).map(|p| {
                ((299 * p[0] as u32 + 587 * p[1] as u32 + 114 * p[2] as u32 + 500) / 1000) as u8
            })),
        }
    }
    GrayImage::from_vec(w, h, data).ok_or(PngError::Size)
}

/// Reads and decodes one PNG frame.
pub fn read_png(path: &Path) -> Result<GrayImage, FolderError> {
    let bytes = std::fs::read(path).map_err(io_err(path))?;
    decode_png(&bytes).map_err(|source| FolderError::Decode {
        path: path.to_path_buf(),
        source,
    })
}

/// Encodes an 8-bit grayscale PNG (fast compression: recording must keep up with a camera).
pub fn encode_png(img: &GrayImage) -> Result<Vec<u8>, PngError> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, img.width() as u32, img.height() as u32);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Fast);
        let mut w = enc.write_header()?;
        w.write_image_data(img.data())?;
    }
    Ok(out)
}

/// Writes one PNG frame.
pub fn write_png(path: &Path, img: &GrayImage) -> Result<(), FolderError> {
    let bytes = encode_png(img).map_err(|source| FolderError::Encode {
        path: path.to_path_buf(),
        source,
    })?;
    std::fs::write(path, bytes).map_err(io_err(path))
}

/// Records a frame folder: `push` writes `frame_000000.png`, ... and appends to `index.csv`
/// (flushed per frame, so a recording cut short stays readable).
pub struct FrameFolderWriter {
    dir: PathBuf,
    index: BufWriter<File>,
    index_path: PathBuf,
    count: u64,
    last_t: f64,
}

impl FrameFolderWriter {
    /// Creates `dir` (and parents) and a fresh `index.csv` in it.
    pub fn create(dir: &Path) -> Result<Self, FolderError> {
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        let index_path = dir.join("index.csv");
        let f = File::create(&index_path).map_err(io_err(&index_path))?;
        let mut index = BufWriter::new(f);
        writeln!(index, "t_s,file").map_err(io_err(&index_path))?;
        index.flush().map_err(io_err(&index_path))?;
        Ok(FrameFolderWriter {
            dir: dir.to_path_buf(),
            index,
            index_path,
            count: 0,
            last_t: f64::NEG_INFINITY,
        })
    }

    /// Appends a frame taken at `t_s` (seconds from the first frame; must not go backwards).
    /// Returns the file name written.
    pub fn push(&mut self, t_s: f64, img: &GrayImage) -> Result<String, FolderError> {
        if !t_s.is_finite() || t_s < 0.0 || t_s < self.last_t {
            return Err(FolderError::BadIndex {
                path: self.index_path.clone(),
                line: self.count + 2,
                msg: format!(
                    "t_s {t_s} must be finite, >= 0 and not before the previous frame ({})",
                    self.last_t
                ),
            });
        }
        let name = format!("frame_{:06}.png", self.count);
        write_png(&self.dir.join(&name), img)?;
        writeln!(self.index, "{t_s},{name}").map_err(io_err(&self.index_path))?;
        self.index.flush().map_err(io_err(&self.index_path))?;
        self.count += 1;
        self.last_t = t_s;
        Ok(name)
    }

    pub fn frames(&self) -> u64 {
        self.count
    }
    pub fn dir(&self) -> &Path {
        &self.dir
    }
}

/// Writes a whole frame folder at once.
pub fn write_frame_folder(dir: &Path, frames: &[(f64, GrayImage)]) -> Result<(), FolderError> {
    let mut w = FrameFolderWriter::create(dir)?;
    for (t, img) in frames {
        w.push(*t, img)?;
    }
    Ok(())
}
