//! Streaming writer of logs.

use std::io::Write;
use std::path::Path;

use crate::column::{Column, Layout};
use crate::row::LogRow;

/// Format a float so that it reads back bit-identically (shortest round-trip form).
fn fmt_f(v: f64) -> String {
    format!("{v}")
}

/// Streams log rows to any writer (co-simulation examples, lab, bridge, predict).
///
/// The header is written on creation; each [`LogWriter::write_row`] writes one line. Rows are
/// written as given: the writer does not check the contract's rules (the reader does).
pub struct LogWriter<W: Write> {
    csv: csv::Writer<W>,
    layout: Layout,
}

impl LogWriter<std::io::BufWriter<std::fs::File>> {
    /// Create (truncate) a file and write the header.
    pub fn create(path: &Path, layout: Layout) -> std::io::Result<Self> {
        let f = std::fs::File::create(path)?;
        LogWriter::new(std::io::BufWriter::new(f), layout)
    }
}

impl<W: Write> LogWriter<W> {
    /// Wrap a writer and write the header.
    pub fn new(w: W, layout: Layout) -> std::io::Result<Self> {
        let mut csv = csv::WriterBuilder::new().has_headers(false).from_writer(w);
        csv.write_record(layout.header()).map_err(csv_io)?;
        Ok(LogWriter { csv, layout })
    }

    /// The layout being written.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Write one row in the layout's column order. Missing optional values are empty cells.
    /// A row with `valid` = false needs a `valid` column in the layout (an error otherwise,
    /// rather than silently writing it as valid).
    pub fn write_row(&mut self, r: &LogRow) -> std::io::Result<()> {
        if !r.valid && !self.layout.has(&Column::Valid) {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "row marked invalid but the log layout has no `valid` column",
            ));
        }
        let opt = |v: Option<f64>| v.map(fmt_f).unwrap_or_default();
        let cells: Vec<String> = self
            .layout
            .columns
            .iter()
            .map(|c| match c {
                Column::T => fmt_f(r.t_s),
                Column::Z => fmt_f(r.z_m_mm),
                Column::F => fmt_f(r.f_hz),
                Column::R1 => opt(r.r1_mm),
                Column::R2 => opt(r.r2_mm),
                Column::Session => r.session.clone(),
                Column::Valid => if r.valid { "1" } else { "0" }.to_string(),
                Column::R1Ref => opt(r.r1_ref_mm),
                Column::R2Ref => opt(r.r2_ref_mm),
                Column::Extra(i) => r.extra.get(*i).cloned().unwrap_or_default(),
            })
            .collect();
        self.csv.write_record(&cells).map_err(csv_io)
    }

    /// Convenience: write a valid row of inputs and radii (session from `session`).
    pub fn write_measurement(
        &mut self,
        t_s: f64,
        z_m_mm: f64,
        f_hz: f64,
        r_mm: [f64; 2],
        session: &str,
    ) -> std::io::Result<()> {
        let mut row = LogRow::new(t_s, z_m_mm, f_hz, Some(r_mm));
        row.session = session.to_string();
        self.write_row(&row)
    }

    /// Flush buffered rows (call periodically when streaming to a file others read).
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.csv.flush()
    }

    /// Flush and close.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.csv.flush()
    }

    /// Flush and return the inner writer.
    pub fn into_inner(self) -> std::io::Result<W> {
        self.csv
            .into_inner()
            .map_err(|e| std::io::Error::other(e.to_string()))
    }
}

fn csv_io(e: csv::Error) -> std::io::Error {
    std::io::Error::other(e.to_string())
}
