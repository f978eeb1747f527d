//! Reader of logs, in three stages: the header ([`parse_header`]: which columns, in which
//! order), each row's cells ([`parse_row`]: numbers, radii, the `valid` flag), and the rules
//! across rows ([`SessionClock`]: time never goes backwards within a session). [`Log`] ties
//! them together and collects every problem found.

use std::collections::{HashMap, HashSet};
use std::io::Read;
use std::path::Path;

use crate::column::{Column, Layout};
use crate::error::{LogError, LogProblem};
use crate::row::LogRow;
use crate::write::LogWriter;

/// A parsed log.
#[derive(Debug, Clone, PartialEq)]
pub struct Log {
    /// File name (or `"<string>"`) for messages.
    pub source: String,
    /// Column layout of the file.
    pub layout: Layout,
    /// Rows in file order.
    pub rows: Vec<LogRow>,
    /// Problems of rows left out in lenient mode (empty otherwise).
    pub skipped: Vec<LogProblem>,
}

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

/// The layout named by a header record: known columns, unknown ones kept in order, duplicate
/// or missing required columns and an unpaired radius column reported at `line`.
pub fn parse_header<'a>(
    names: impl IntoIterator<Item = &'a str>,
    line: usize,
) -> Result<Layout, Vec<LogProblem>> {
    let mut layout = Layout {
        columns: Vec::new(),
        extra_columns: Vec::new(),
    };
    let mut problems = Vec::new();
    let mut seen = HashSet::new();
    for name in names {
        let name = name.trim_start_matches('\u{feff}').trim();
        if !seen.insert(name.to_string()) {
            problems.push(LogProblem {
                line,
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
                line,
                column: Some(c.name(&[]).to_string()),
                message: "required column missing (a log needs t_s, z_m_mm, f_hz)".into(),
            });
        }
    }
    if layout.has(&Column::R1) != layout.has(&Column::R2) {
        let missing = if layout.has(&Column::R1) {
            "r2_mm"
        } else {
            "r1_mm"
        };
        problems.push(LogProblem {
            line,
            column: Some(missing.into()),
            message: "radius columns come in pairs: r1_mm and r2_mm".into(),
        });
    }
    if problems.is_empty() {
        Ok(layout)
    } else {
        Err(problems)
    }
}

/// What is wrong with one cell (a [`LogProblem`]'s message, with its line and column).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
enum CellError {
    #[error("expected 0 or 1, got {0:?}")]
    NotBool(String),
    #[error("must be finite, got {0}")]
    NotFinite(f64),
    #[error("not a number: {0:?}")]
    NotNumber(String),
    #[error("empty radius on a valid row (mark the row valid=0 if the measurement failed)")]
    EmptyRadius,
    #[error("negative radius {0}")]
    NegativeRadius(f64),
}

/// The `valid` cell: empty counts as 1.
fn parse_valid(cell: &str) -> Result<bool, CellError> {
    match cell.to_ascii_lowercase().as_str() {
        "" | "1" | "true" | "1.0" => Ok(true),
        "0" | "false" | "0.0" => Ok(false),
        other => Err(CellError::NotBool(other.to_string())),
    }
}

/// A required number (`t_s`, `z_m_mm`, `f_hz`): finite.
fn parse_required(cell: &str) -> Result<f64, CellError> {
    match parse_num(cell) {
        Some(v) if v.is_finite() => Ok(v),
        Some(v) => Err(CellError::NotFinite(v)),
        None => Err(CellError::NotNumber(cell.to_string())),
    }
}

/// A radius cell: finite and non-negative on a valid row; on a `valid` = 0 row it may be
/// empty or NaN (the camera lost the swarm), but not negative or text.
fn parse_radius(cell: &str, valid: bool) -> Result<Option<f64>, CellError> {
    if cell.is_empty() {
        return if valid {
            Err(CellError::EmptyRadius)
        } else {
            Ok(None)
        };
    }
    match parse_num(cell) {
        Some(v) if v.is_nan() && !valid => Ok(None),
        Some(v) if !v.is_finite() => Err(CellError::NotFinite(v)),
        Some(v) if v < 0.0 => Err(CellError::NegativeRadius(v)),
        Some(v) => Ok(Some(v)),
        None => Err(CellError::NotNumber(cell.to_string())),
    }
}

/// An optional number (setpoints): empty, or finite.
fn parse_optional(cell: &str) -> Result<Option<f64>, CellError> {
    if cell.is_empty() {
        return Ok(None);
    }
    parse_required(cell).map(Some)
}

/// One row's cells (already split, as many as the layout has columns) into a [`LogRow`],
/// with every problem of its cells. Rules across rows (time order) are [`SessionClock`]'s.
pub fn parse_row<'a>(
    layout: &Layout,
    cells: impl IntoIterator<Item = &'a str> + Clone,
    line: usize,
) -> (LogRow, Vec<LogProblem>) {
    let mut problems = Vec::new();
    let mut row = LogRow {
        line,
        valid: true,
        extra: vec![String::new(); layout.extra_columns.len()],
        ..LogRow::default()
    };
    // First pass: the valid flag, which decides how strict the radius cells are.
    for (c, cell) in layout.columns.iter().zip(cells.clone()) {
        if *c == Column::Valid {
            match parse_valid(cell) {
                Ok(v) => row.valid = v,
                Err(e) => problems.push(LogProblem {
                    line,
                    column: Some("valid".into()),
                    message: e.to_string(),
                }),
            }
        }
    }
    for (c, cell) in layout.columns.iter().zip(cells) {
        let parsed: Result<(), CellError> = match c {
            Column::T => parse_required(cell).map(|v| row.t_s = v),
            Column::Z => parse_required(cell).map(|v| row.z_m_mm = v),
            Column::F => parse_required(cell).map(|v| row.f_hz = v),
            Column::R1 => parse_radius(cell, row.valid).map(|v| row.r1_mm = v),
            Column::R2 => parse_radius(cell, row.valid).map(|v| row.r2_mm = v),
            Column::R1Ref => parse_optional(cell).map(|v| row.r1_ref_mm = v),
            Column::R2Ref => parse_optional(cell).map(|v| row.r2_ref_mm = v),
            Column::Session => {
                row.session = cell.to_string();
                Ok(())
            }
            Column::Valid => Ok(()),
            Column::Extra(i) => {
                row.extra[*i] = cell.to_string();
                Ok(())
            }
        };
        if let Err(e) = parsed {
            problems.push(LogProblem {
                line,
                column: Some(c.name(&layout.extra_columns).to_string()),
                message: e.to_string(),
            });
        }
    }
    (row, problems)
}

/// The rule across rows: `t_s` never decreases within a session.
#[derive(Debug, Default)]
pub struct SessionClock {
    /// Last (t_s, line) per session.
    last_t: HashMap<String, (f64, usize)>,
}

impl SessionClock {
    /// Check `row` against the previous row of its session and advance the session's clock.
    /// `t_ok`: false when the row's own `t_s` cell was bad (then the clock is left alone).
    /// `has_sessions`: the log has a `session` column (changes the advice in the message).
    pub fn check(&mut self, row: &LogRow, t_ok: bool, has_sessions: bool) -> Option<LogProblem> {
        if !t_ok {
            return None;
        }
        let mut problem = None;
        if let Some(&(prev, prev_line)) = self.last_t.get(&row.session) {
            if row.t_s < prev {
                problem = Some(LogProblem {
                    line: row.line,
                    column: Some("t_s".into()),
                    message: format!(
                        "time goes backwards: {} after {} (line {prev_line}){}",
                        row.t_s,
                        prev,
                        if has_sessions {
                            format!(" in session {:?}", row.session)
                        } else {
                            " (add a session column if t_s restarts)".into()
                        }
                    ),
                });
            }
        }
        // A row whose other cells are bad still fixes the session's clock.
        self.last_t.insert(row.session.clone(), (row.t_s, row.line));
        problem
    }
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
        let at_line = |line: usize, message: String| LogProblem {
            line,
            column: None,
            message,
        };
        let mut csv = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(rdr);
        let mut records = csv.records();
        let header = match records.next() {
            None => {
                return Err(fail(vec![at_line(
                    1,
                    "empty file: expected the header t_s,z_m_mm,f_hz,...".into(),
                )]))
            }
            Some(Err(e)) => return Err(fail(vec![at_line(1, format!("unreadable header: {e}"))])),
            Some(Ok(h)) => h,
        };
        let header_line = header.position().map(|p| p.line() as usize).unwrap_or(1);
        let layout = parse_header(header.iter(), header_line).map_err(fail)?;

        let ncol = layout.columns.len();
        let has_sessions = layout.has(&Column::Session);
        let mut problems = Vec::new();
        let mut rows = Vec::new();
        let mut skipped = Vec::new();
        let mut clock = SessionClock::default();
        for rec in records {
            let rec = match rec {
                Ok(r) => r,
                Err(e) => {
                    let line = e.position().map(|p| p.line() as usize).unwrap_or(0);
                    problems.push(at_line(line, format!("unreadable row: {e}")));
                    continue;
                }
            };
            let line = rec.position().map(|p| p.line() as usize).unwrap_or(0);
            let mut row_problems = Vec::new();
            let mut row = None;
            if rec.len() != ncol {
                row_problems.push(at_line(
                    line,
                    format!("{} fields, the header has {ncol}", rec.len()),
                ));
            } else {
                let (r, mut p) = parse_row(&layout, rec.iter(), line);
                let t_ok = !p.iter().any(|p| p.column.as_deref() == Some("t_s"));
                p.extend(clock.check(&r, t_ok, has_sessions));
                row_problems = p;
                row = Some(r);
            }
            match row {
                Some(r) if row_problems.is_empty() => rows.push(r),
                _ if opts.lenient => skipped.extend(row_problems),
                _ => problems.extend(row_problems),
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
