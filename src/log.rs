//! Measurement log (CONTRACTS.md CSV format): reader and streaming writer.
//!
//! ```text
//! t_s,z_m_mm,f_hz,r1_mm,r2_mm[,session][,valid][,r1_ref_mm][,r2_ref_mm][,anything else]
//! ```
//!
//! Rules of the reader (every rule names the line and the column of the row that breaks it):
//!
//! - `t_s`, `z_m_mm`, `f_hz` are required columns; every row needs finite numbers there.
//! - `r1_mm`, `r2_mm` may be absent as columns (a `predict` input). Where present, a row with
//!   `valid` = 1 (or no `valid` column) needs a finite, non-negative number in both. A row
//!   with `valid` = 0 may leave them empty or `NaN` (the camera lost the swarm): the row is
//!   kept and ignored by fitting, as CONTRACTS.md says; a negative or non-numeric text is
//!   still an error there.
//! - `valid` accepts `0`/`1` (also `true`/`false`); an empty cell counts as 1.
//! - `session` is free text; `t_s` restarts per session and must never decrease within one.
//!   Rows of a session need not be contiguous.
//! - `r1_ref_mm`, `r2_ref_mm` may be empty; where filled they must be finite.
//! - Unknown columns are kept verbatim (and written back by [`Log::write`] in their original
//!   position) and otherwise ignored.
//! - Blank lines are skipped; a row with the wrong number of fields is an error.
//!
//! All problems of a file are collected and reported together in one [`LogError`]: nothing is
//! silently dropped. [`ReadOptions::lenient`] turns per-row problems into warnings instead:
//! the offending rows are left out of the returned log and listed in [`Log::skipped`], so the
//! caller can print them (the `--lenient` flag of `identify` does so).

use std::collections::HashMap;
use std::fmt;
use std::io::{Read, Write};
use std::path::Path;

/// The columns the contract knows, in canonical order.
pub const KNOWN_COLUMNS: [&str; 9] = [
    "t_s",
    "z_m_mm",
    "f_hz",
    "r1_mm",
    "r2_mm",
    "session",
    "valid",
    "r1_ref_mm",
    "r2_ref_mm",
];

/// One column of a log file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Column {
    /// `t_s`
    T,
    /// `z_m_mm`
    Z,
    /// `f_hz`
    F,
    /// `r1_mm`
    R1,
    /// `r2_mm`
    R2,
    /// `session`
    Session,
    /// `valid`
    Valid,
    /// `r1_ref_mm`
    R1Ref,
    /// `r2_ref_mm`
    R2Ref,
    /// Unknown column: index into [`Log::extra_columns`] / [`LogRow::extra`].
    Extra(usize),
}

impl Column {
    fn known(name: &str) -> Option<Column> {
        Some(match name {
            "t_s" => Column::T,
            "z_m_mm" => Column::Z,
            "f_hz" => Column::F,
            "r1_mm" => Column::R1,
            "r2_mm" => Column::R2,
            "session" => Column::Session,
            "valid" => Column::Valid,
            "r1_ref_mm" => Column::R1Ref,
            "r2_ref_mm" => Column::R2Ref,
            _ => return None,
        })
    }

    fn name<'a>(&self, extra: &'a [String]) -> &'a str {
        match self {
            Column::T => "t_s",
            Column::Z => "z_m_mm",
            Column::F => "f_hz",
            Column::R1 => "r1_mm",
            Column::R2 => "r2_mm",
            Column::Session => "session",
            Column::Valid => "valid",
            Column::R1Ref => "r1_ref_mm",
            Column::R2Ref => "r2_ref_mm",
            Column::Extra(i) => &extra[*i],
        }
    }
}

/// The layout of a log: which columns, in which order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    /// Columns in file order.
    pub columns: Vec<Column>,
    /// Names of the unknown columns (indexed by `Column::Extra`).
    pub extra_columns: Vec<String>,
}

impl Layout {
    /// `t_s,z_m_mm,f_hz,r1_mm,r2_mm`, plus the optional columns asked for, in canonical order.
    pub fn standard(radii: bool, session: bool, valid: bool, refs: bool) -> Layout {
        let mut columns = vec![Column::T, Column::Z, Column::F];
        if radii {
            columns.extend([Column::R1, Column::R2]);
        }
        if session {
            columns.push(Column::Session);
        }
        if valid {
            columns.push(Column::Valid);
        }
        if refs {
            columns.extend([Column::R1Ref, Column::R2Ref]);
        }
        Layout {
            columns,
            extra_columns: Vec::new(),
        }
    }

    /// True when the layout holds this column.
    pub fn has(&self, c: &Column) -> bool {
        self.columns.contains(c)
    }

    /// Add a column at the end if it is not there yet.
    pub fn ensure(&mut self, c: Column) {
        if !self.has(&c) {
            self.columns.push(c);
        }
    }

    /// Add an unknown (extra) column at the end; returns its index for `LogRow::extra`.
    pub fn add_extra(&mut self, name: &str) -> usize {
        if let Some(i) = self.extra_columns.iter().position(|n| n == name) {
            return i;
        }
        self.extra_columns.push(name.to_string());
        let i = self.extra_columns.len() - 1;
        self.columns.push(Column::Extra(i));
        i
    }

    /// Header names in file order.
    pub fn header(&self) -> Vec<&str> {
        self.columns
            .iter()
            .map(|c| c.name(&self.extra_columns))
            .collect()
    }
}

/// One measurement.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LogRow {
    /// 1-based line number in the source file (0 for rows built in memory).
    pub line: usize,
    /// Seconds since the start of the session.
    pub t_s: f64,
    /// Commanded magnet-swarm distance [mm].
    pub z_m_mm: f64,
    /// Commanded field frequency [Hz].
    pub f_hz: f64,
    /// Measured r1 [mm] (None: column absent, or empty on a `valid` = 0 row).
    pub r1_mm: Option<f64>,
    /// Measured r2 [mm].
    pub r2_mm: Option<f64>,
    /// Session name ("" when the log has no session column).
    pub session: String,
    /// False for `valid` = 0 rows (kept, ignored by fitting).
    pub valid: bool,
    /// Controller setpoint for r1 [mm].
    pub r1_ref_mm: Option<f64>,
    /// Controller setpoint for r2 [mm].
    pub r2_ref_mm: Option<f64>,
    /// Values of the unknown columns, verbatim (same order as `Layout::extra_columns`).
    pub extra: Vec<String>,
}

impl LogRow {
    /// A valid row with inputs and (optionally) radii.
    pub fn new(t_s: f64, z_m_mm: f64, f_hz: f64, r: Option<[f64; 2]>) -> LogRow {
        LogRow {
            t_s,
            z_m_mm,
            f_hz,
            r1_mm: r.map(|r| r[0]),
            r2_mm: r.map(|r| r[1]),
            valid: true,
            ..LogRow::default()
        }
    }

    /// Both radii, when the row has them.
    pub fn radii(&self) -> Option<[f64; 2]> {
        Some([self.r1_mm?, self.r2_mm?])
    }
}

/// A parsed log.
#[derive(Debug, Clone, PartialEq)]
pub struct Log {
    /// File name (or "<string>") for messages.
    pub source: String,
    /// Column layout of the file.
    pub layout: Layout,
    /// Rows in file order.
    pub rows: Vec<LogRow>,
    /// Problems of rows left out in lenient mode (empty otherwise).
    pub skipped: Vec<LogProblem>,
}

/// One problem found in a log.
#[derive(Debug, Clone, PartialEq)]
pub struct LogProblem {
    /// 1-based line number (1 is the header).
    pub line: usize,
    /// Column at fault, if one.
    pub column: Option<String>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for LogProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.column {
            Some(c) => write!(f, "line {}, column {}: {}", self.line, c, self.message),
            None => write!(f, "line {}: {}", self.line, self.message),
        }
    }
}

/// A log that cannot be read, with every problem found.
#[derive(Debug, Clone, PartialEq)]
pub struct LogError {
    /// File name or "<string>".
    pub source: String,
    /// All problems, in line order.
    pub problems: Vec<LogProblem>,
}

/// How many problems [`LogError`]'s message lists before summarising the rest.
const SHOWN_PROBLEMS: usize = 25;

impl fmt::Display for LogError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.problems.len();
        write!(
            f,
            "{}: {} problem{}",
            self.source,
            n,
            if n == 1 { "" } else { "s" }
        )?;
        for p in self.problems.iter().take(SHOWN_PROBLEMS) {
            write!(f, "\n  {p}")?;
        }
        if n > SHOWN_PROBLEMS {
            write!(f, "\n  ... and {} more", n - SHOWN_PROBLEMS)?;
        }
        Ok(())
    }
}

impl std::error::Error for LogError {}

/// Options of the reader.
#[derive(Debug, Clone, Copy, Default)]
pub struct ReadOptions {
    /// Leave out rows with problems (listed in [`Log::skipped`]) instead of failing. Problems
    /// of the header (missing or duplicate columns) are always errors.
    pub lenient: bool,
}

fn parse_num(s: &str) -> Option<f64> {
    s.trim().parse::<f64>().ok()
}

impl Log {
    /// Read a log file (strict).
    pub fn read(path: &Path) -> Result<Log, LogError> {
        Log::read_with(path, ReadOptions::default())
    }

    /// Read a log file with options.
    pub fn read_with(path: &Path, opts: ReadOptions) -> Result<Log, LogError> {
        let name = path.display().to_string();
        let file = std::fs::File::open(path).map_err(|e| LogError {
            source: name.clone(),
            problems: vec![LogProblem {
                line: 0,
                column: None,
                message: format!("cannot open: {e}"),
            }],
        })?;
        Log::from_reader(std::io::BufReader::new(file), &name, opts)
    }

    /// Parse a log from text (strict); `source` appears in errors.
    pub fn from_str_named(text: &str, source: &str) -> Result<Log, LogError> {
        Log::from_reader(text.as_bytes(), source, ReadOptions::default())
    }

    /// Parse a log from any reader.
    pub fn from_reader<R: Read>(rdr: R, source: &str, opts: ReadOptions) -> Result<Log, LogError> {
        let fail = |problems: Vec<LogProblem>| LogError {
            source: source.to_string(),
            problems,
        };
        let mut csv = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(rdr);
        let mut records = csv.records();
        let header = match records.next() {
            None => {
                return Err(fail(vec![LogProblem {
                    line: 1,
                    column: None,
                    message: "empty file: expected the header t_s,z_m_mm,f_hz,...".into(),
                }]))
            }
            Some(Err(e)) => {
                return Err(fail(vec![LogProblem {
                    line: 1,
                    column: None,
                    message: format!("unreadable header: {e}"),
                }]))
            }
            Some(Ok(h)) => h,
        };
        let header_line = header.position().map(|p| p.line() as usize).unwrap_or(1);
        let mut layout = Layout {
            columns: Vec::new(),
            extra_columns: Vec::new(),
        };
        let mut problems = Vec::new();
        let mut seen = std::collections::HashSet::new();
        for name in header.iter() {
            let name = name.trim_start_matches('\u{feff}').trim();
            if !seen.insert(name.to_string()) {
                problems.push(LogProblem {
                    line: header_line,
                    column: Some(name.to_string()),
                    message: "duplicate column".into(),
                });
                continue;
            }
            match Column::known(name) {
                Some(c) => layout.columns.push(c),
                None => {
                    layout.extra_columns.push(name.to_string());
                    layout
                        .columns
                        .push(Column::Extra(layout.extra_columns.len() - 1));
                }
            }
        }
        for c in [Column::T, Column::Z, Column::F] {
            if !layout.has(&c) {
                problems.push(LogProblem {
                    line: header_line,
                    column: Some(c.name(&[]).to_string()),
                    message: "required column missing (a log needs t_s, z_m_mm, f_hz)".into(),
                });
            }
        }
        if layout.has(&Column::R1) != layout.has(&Column::R2) {
            problems.push(LogProblem {
                line: header_line,
                column: Some(
                    if layout.has(&Column::R1) {
                        "r2_mm"
                    } else {
                        "r1_mm"
                    }
                    .into(),
                ),
                message: "radius columns come in pairs: r1_mm and r2_mm".into(),
            });
        }
        if !problems.is_empty() {
            return Err(fail(problems));
        }

        let ncol = layout.columns.len();
        let mut rows = Vec::new();
        let mut skipped = Vec::new();
        // Last (t_s, line) per session, for the monotonic-time rule.
        let mut last_t: HashMap<String, (f64, usize)> = HashMap::new();
        for rec in records {
            let rec = match rec {
                Ok(r) => r,
                Err(e) => {
                    let line = e.position().map(|p| p.line() as usize).unwrap_or(0);
                    problems.push(LogProblem {
                        line,
                        column: None,
                        message: format!("unreadable row: {e}"),
                    });
                    continue;
                }
            };
            let line = rec.position().map(|p| p.line() as usize).unwrap_or(0);
            let mut row_problems = Vec::new();
            if rec.len() != ncol {
                row_problems.push(LogProblem {
                    line,
                    column: None,
                    message: format!("{} fields, the header has {ncol}", rec.len()),
                });
                if opts.lenient {
                    skipped.extend(row_problems);
                } else {
                    problems.extend(row_problems);
                }
                continue;
            }
            let mut row = LogRow {
                line,
                valid: true,
                extra: vec![String::new(); layout.extra_columns.len()],
                ..LogRow::default()
            };
            // First pass: the valid flag, which decides how strict the radius cells are.
            for (c, cell) in layout.columns.iter().zip(rec.iter()) {
                if *c == Column::Valid {
                    match cell.to_ascii_lowercase().as_str() {
                        "" | "1" | "true" | "1.0" => row.valid = true,
                        "0" | "false" | "0.0" => row.valid = false,
                        other => row_problems.push(LogProblem {
                            line,
                            column: Some("valid".into()),
                            message: format!("expected 0 or 1, got {other:?}"),
                        }),
                    }
                }
            }
            for (c, cell) in layout.columns.iter().zip(rec.iter()) {
                let name = c.name(&layout.extra_columns).to_string();
                let mut bad = |msg: String| {
                    row_problems.push(LogProblem {
                        line,
                        column: Some(name.clone()),
                        message: msg,
                    })
                };
                match c {
                    Column::T | Column::Z | Column::F => match parse_num(cell) {
                        Some(v) if v.is_finite() => match c {
                            Column::T => row.t_s = v,
                            Column::Z => row.z_m_mm = v,
                            _ => row.f_hz = v,
                        },
                        Some(v) => bad(format!("must be finite, got {v}")),
                        None => bad(format!("not a number: {cell:?}")),
                    },
                    Column::R1 | Column::R2 => {
                        let v = if cell.is_empty() {
                            if row.valid {
                                bad("empty radius on a valid row (mark the row valid=0 if the \
                                     measurement failed)"
                                    .into());
                            }
                            None
                        } else {
                            match parse_num(cell) {
                                Some(v) if v.is_nan() && !row.valid => None,
                                Some(v) if !v.is_finite() => {
                                    bad(format!("must be finite, got {v}"));
                                    None
                                }
                                Some(v) if v < 0.0 => {
                                    bad(format!("negative radius {v}"));
                                    None
                                }
                                Some(v) => Some(v),
                                None => {
                                    bad(format!("not a number: {cell:?}"));
                                    None
                                }
                            }
                        };
                        if *c == Column::R1 {
                            row.r1_mm = v;
                        } else {
                            row.r2_mm = v;
                        }
                    }
                    Column::R1Ref | Column::R2Ref => {
                        let v = if cell.is_empty() {
                            None
                        } else {
                            match parse_num(cell) {
                                Some(v) if v.is_finite() => Some(v),
                                Some(v) => {
                                    bad(format!("must be finite, got {v}"));
                                    None
                                }
                                None => {
                                    bad(format!("not a number: {cell:?}"));
                                    None
                                }
                            }
                        };
                        if *c == Column::R1Ref {
                            row.r1_ref_mm = v;
                        } else {
                            row.r2_ref_mm = v;
                        }
                    }
                    Column::Session => row.session = cell.to_string(),
                    Column::Valid => {}
                    Column::Extra(i) => row.extra[*i] = cell.to_string(),
                }
            }
            let t_ok = !row_problems
                .iter()
                .any(|p| p.column.as_deref() == Some("t_s"));
            if t_ok {
                if let Some(&(prev, prev_line)) = last_t.get(&row.session) {
                    if row.t_s < prev {
                        row_problems.push(LogProblem {
                            line,
                            column: Some("t_s".into()),
                            message: format!(
                                "time goes backwards: {} after {} (line {prev_line}){}",
                                row.t_s,
                                prev,
                                if layout.has(&Column::Session) {
                                    format!(" in session {:?}", row.session)
                                } else {
                                    " (add a session column if t_s restarts)".into()
                                }
                            ),
                        });
                    }
                }
                // A row whose other cells are bad still fixes the session's clock.
                last_t.insert(row.session.clone(), (row.t_s, line));
            }
            if row_problems.is_empty() {
                rows.push(row);
            } else if opts.lenient {
                skipped.extend(row_problems);
            } else {
                problems.extend(row_problems);
            }
        }
        if !problems.is_empty() {
            return Err(fail(problems));
        }
        Ok(Log {
            source: source.to_string(),
            layout,
            rows,
            skipped,
        })
    }

    /// True when the log has radius columns.
    pub fn has_radii(&self) -> bool {
        self.layout.has(&Column::R1)
    }

    /// The layout to write this log with: its own, plus a `valid` column when a row is invalid
    /// and the layout has none (so that `valid` = 0 is never lost).
    pub fn write_layout(&self) -> Layout {
        let mut l = self.layout.clone();
        if self.rows.iter().any(|r| !r.valid) {
            l.ensure(Column::Valid);
        }
        l
    }

    /// Write the log (same layout, unknown columns included) to a file.
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let mut w = LogWriter::create(path, self.write_layout())?;
        for r in &self.rows {
            w.write_row(r)?;
        }
        w.finish()
    }

    /// The log as CSV text.
    pub fn to_csv_string(&self) -> String {
        let mut w = LogWriter::new(Vec::new(), self.write_layout()).expect("in-memory write");
        for r in &self.rows {
            w.write_row(r).expect("in-memory write");
        }
        String::from_utf8(w.into_inner().expect("in-memory write")).expect("utf-8")
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Log, LogError> {
        Log::from_str_named(text, "t.csv")
    }

    #[test]
    fn minimal_log_parses() {
        let l =
            parse("t_s,z_m_mm,f_hz,r1_mm,r2_mm\n0.0,8.5,4,8.31,11.92\n1,8.5,4,8.2,12\n").unwrap();
        assert_eq!(l.rows.len(), 2);
        assert_eq!(l.rows[0].line, 2);
        assert_eq!(l.rows[0].radii(), Some([8.31, 11.92]));
        assert!(l.rows[1].valid && l.has_radii());
    }

    #[test]
    fn radius_columns_may_be_absent() {
        let l = parse("t_s,z_m_mm,f_hz\n0,8.5,4\n").unwrap();
        assert!(!l.has_radii());
        assert_eq!(l.rows[0].radii(), None);
    }

    #[test]
    fn unknown_columns_round_trip_in_place() {
        let text = "temp_c,t_s,z_m_mm,f_hz,r1_mm,r2_mm,session,valid,r1_ref_mm,r2_ref_mm,note\n\
                    21.5,0,8.5,4,8.31,11.92,a,1,8,11,\"x, y\"\n\
                    21.6,0.5,8.5,4,,,a,0,,,\n";
        let l = parse(text).unwrap();
        assert_eq!(l.layout.extra_columns, vec!["temp_c", "note"]);
        assert_eq!(l.rows[0].extra, vec!["21.5", "x, y"]);
        assert!(!l.rows[1].valid && l.rows[1].r1_mm.is_none());
        let out = l.to_csv_string();
        assert_eq!(out.lines().next().unwrap(), text.lines().next().unwrap());
        let back = parse(&out).unwrap();
        assert_eq!(back.rows, l.rows);
    }

    #[test]
    fn all_problems_are_reported_with_lines_and_columns() {
        let text = "t_s,z_m_mm,f_hz,r1_mm,r2_mm\n\
                    0,8.5,4,8.3,11.9\n\
                    1,abc,4,8.3,11.9\n\
                    2,8.5,4,NaN,11.9\n\
                    3,8.5,4,-1,11.9\n\
                    2.5,8.5,4,8.3,11.9\n\
                    4,8.5,4,8.3\n\
                    5,8.5,inf,8.3,11.9\n";
        let e = parse(text).unwrap_err();
        let msg = e.to_string();
        assert_eq!(e.problems.len(), 6, "{msg}");
        assert!(msg.contains("line 3, column z_m_mm: not a number"), "{msg}");
        assert!(
            msg.contains("line 4, column r1_mm: must be finite"),
            "{msg}"
        );
        assert!(
            msg.contains("line 5, column r1_mm: negative radius"),
            "{msg}"
        );
        assert!(
            msg.contains("line 6, column t_s: time goes backwards"),
            "{msg}"
        );
        assert!(msg.contains("line 7: 4 fields"), "{msg}");
        assert!(msg.contains("line 8, column f_hz: must be finite"), "{msg}");
    }

    #[test]
    fn sessions_restart_time() {
        let text = "t_s,z_m_mm,f_hz,r1_mm,r2_mm,session\n\
                    0,8.5,4,8.3,11.9,a\n5,8.5,4,8.3,11.9,a\n0,8.5,4,8.3,11.9,b\n6,8.5,4,8,11,a\n";
        let l = parse(text).unwrap();
        assert_eq!(l.rows.len(), 4);
        let text = "t_s,z_m_mm,f_hz,r1_mm,r2_mm\n5,8.5,4,8.3,11.9\n0,8.5,4,8.3,11.9\n";
        let e = parse(text).unwrap_err();
        assert!(e.to_string().contains("add a session column"), "{e}");
    }

    #[test]
    fn header_problems() {
        let e = parse("t_s,f_hz,r1_mm\n").unwrap_err();
        let m = e.to_string();
        assert!(m.contains("column z_m_mm: required column missing"), "{m}");
        assert!(
            m.contains("column r2_mm: radius columns come in pairs"),
            "{m}"
        );
        let e = parse("t_s,z_m_mm,f_hz,t_s\n").unwrap_err();
        assert!(e.to_string().contains("duplicate column"));
        assert!(parse("").is_err());
    }

    #[test]
    fn empty_radius_on_valid_row_is_an_error_and_lenient_skips() {
        let text =
            "t_s,z_m_mm,f_hz,r1_mm,r2_mm,valid\n0,8.5,4,,11.9,1\n1,8.5,4,8,11,1\n2,8.5,4,x,11,0\n";
        let e = parse(text).unwrap_err();
        assert_eq!(e.problems.len(), 2, "{e}");
        assert_eq!(e.problems[0].line, 2);
        assert_eq!(e.problems[1].line, 4);
        let l = Log::from_reader(text.as_bytes(), "t", ReadOptions { lenient: true }).unwrap();
        assert_eq!(l.rows.len(), 1);
        assert_eq!(l.skipped.len(), 2);
    }

    #[test]
    fn writer_streams_rows() {
        let mut w = LogWriter::new(Vec::new(), Layout::standard(true, true, false, false)).unwrap();
        w.write_measurement(0.0, 8.5, 4.0, [8.31, 11.92], "s1")
            .unwrap();
        w.write_measurement(0.1, 8.5, 4.0, [1.0 / 3.0, 11.92], "s1")
            .unwrap();
        let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        assert!(text.starts_with("t_s,z_m_mm,f_hz,r1_mm,r2_mm,session\n0,8.5,4,8.31,11.92,s1\n"));
        let l = parse(&text).unwrap();
        assert_eq!(l.rows[1].r1_mm, Some(1.0 / 3.0));
    }
}
