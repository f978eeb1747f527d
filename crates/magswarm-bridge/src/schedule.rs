//! PLAN (`t_s,z_m_mm,f_hz`) and TARGETS (`t_s,r1_ref_mm,r2_ref_mm`) files: schedules whose
//! rows apply from their `t_s` until the next row.

use std::path::{Path, PathBuf};

/// A schedule that cannot be read; each names the file (and line).
#[derive(Debug, thiserror::Error)]
pub enum ScheduleError {
    /// The file cannot be read.
    #[error("{path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// Not CSV (or a row of another length).
    #[error("{file}: {source}")]
    Csv {
        /// The file.
        file: String,
        /// The CSV reader's error.
        source: csv::Error,
    },
    /// A required column is missing.
    #[error("{file}: no column `{column}` (header: {header})")]
    NoColumn {
        /// The file.
        file: String,
        /// The column.
        column: String,
        /// The header found.
        header: String,
    },
    /// A bad row.
    #[error("{file}: line {line}: {problem}")]
    Row {
        /// The file.
        file: String,
        /// Line number.
        line: u64,
        /// What is wrong.
        problem: RowProblem,
    },
    /// No rows.
    #[error("{file}: no rows")]
    Empty {
        /// The file.
        file: String,
    },
}

/// What is wrong with a row.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RowProblem {
    /// Not a number.
    #[error("`{column}` = {text:?} is not a number")]
    NotANumber {
        /// The column.
        column: String,
        /// Its text.
        text: String,
    },
    /// NaN or infinite.
    #[error("`{column}` = {text} is not finite")]
    NotFinite {
        /// The column.
        column: String,
        /// Its text.
        text: String,
    },
    /// A negative time.
    #[error("t_s = {0} is negative")]
    Negative(f64),
    /// Time going backwards.
    #[error("t_s = {t} goes back in time (previous row {previous})")]
    Backwards {
        /// This row's time.
        t: f64,
        /// The previous row's.
        previous: f64,
    },
}

/// A schedule of two values.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    /// (t_s, a, b), t_s non-decreasing.
    pub rows: Vec<(f64, f64, f64)>,
    /// Column names of a and b.
    pub names: [String; 2],
}

impl Schedule {
    /// Read a CSV with columns `t_s`, `cols[0]`, `cols[1]` (others ignored).
    pub fn read(path: &Path, cols: [&str; 2]) -> Result<Schedule, ScheduleError> {
        let text = std::fs::read_to_string(path).map_err(|e| ScheduleError::Read {
            path: path.into(),
            source: e,
        })?;
        Schedule::parse(&text, cols, &path.display().to_string())
    }

    /// Parse CSV text (`source` names it in errors).
    pub fn parse(text: &str, cols: [&str; 2], source: &str) -> Result<Schedule, ScheduleError> {
        let file = || source.to_string();
        let csv_err = |e| ScheduleError::Csv {
            file: file(),
            source: e,
        };
        let mut rdr = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .from_reader(text.as_bytes());
        let header = rdr.headers().map_err(csv_err)?.clone();
        let idx = |name: &str| {
            header
                .iter()
                .position(|h| h == name)
                .ok_or_else(|| ScheduleError::NoColumn {
                    file: file(),
                    column: name.into(),
                    header: header.iter().collect::<Vec<_>>().join(","),
                })
        };
        let (it, ia, ib) = (idx("t_s")?, idx(cols[0])?, idx(cols[1])?);
        let mut rows: Vec<(f64, f64, f64)> = Vec::new();
        for (k, rec) in rdr.records().enumerate() {
            let rec = rec.map_err(csv_err)?;
            let line = rec.position().map(|p| p.line()).unwrap_or(k as u64 + 2);
            let bad = |problem| ScheduleError::Row {
                file: file(),
                line,
                problem,
            };
            let num = |i: usize, name: &str| -> Result<f64, ScheduleError> {
                let s = rec.get(i).unwrap_or("");
                let v: f64 = s.parse().map_err(|_| {
                    bad(RowProblem::NotANumber {
                        column: name.into(),
                        text: s.into(),
                    })
                })?;
                if !v.is_finite() {
                    return Err(bad(RowProblem::NotFinite {
                        column: name.into(),
                        text: s.into(),
                    }));
                }
                Ok(v)
            };
            let t = num(it, "t_s")?;
            let (a, b) = (num(ia, cols[0])?, num(ib, cols[1])?);
            if t < 0.0 {
                return Err(bad(RowProblem::Negative(t)));
            }
            if let Some(&(tp, _, _)) = rows.last() {
                if t < tp {
                    return Err(bad(RowProblem::Backwards { t, previous: tp }));
                }
            }
            rows.push((t, a, b));
        }
        if rows.is_empty() {
            return Err(ScheduleError::Empty { file: file() });
        }
        Ok(Schedule {
            rows,
            names: [cols[0].into(), cols[1].into()],
        })
    }

    /// The values in force at `t` (the first row's before it starts).
    pub fn at(&self, t: f64) -> (f64, f64) {
        let i = self.rows.partition_point(|r| r.0 <= t);
        let r = self.rows[i.saturating_sub(1)];
        (r.1, r.2)
    }

    /// Default duration: the last row lasts as long as the one before it (a single row: none).
    pub fn default_duration(&self) -> Option<f64> {
        let n = self.rows.len();
        if n < 2 {
            return None;
        }
        let (a, b) = (self.rows[n - 2].0, self.rows[n - 1].0);
        Some(b + (b - a))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_apply_until_the_next() {
        let s = Schedule::parse(
            "t_s,z_m_mm,f_hz\n0,8.5,4\n2,10,5\n5,12,6\n",
            ["z_m_mm", "f_hz"],
            "PLAN",
        )
        .unwrap();
        assert_eq!(s.at(0.0), (8.5, 4.0));
        assert_eq!(s.at(1.99), (8.5, 4.0));
        assert_eq!(s.at(2.0), (10.0, 5.0));
        assert_eq!(s.at(100.0), (12.0, 6.0));
        assert_eq!(s.default_duration(), Some(8.0));
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = Schedule::parse("t_s,z_m_mm,f_hz\n0,8.5,4\n1,x,5\n", ["z_m_mm", "f_hz"], "P")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("z_m_mm"), "{e}");
        let e = Schedule::parse("t_s,z_m_mm,f_hz\n2,8.5,4\n1,9,5\n", ["z_m_mm", "f_hz"], "P")
            .unwrap_err()
            .to_string();
        assert!(e.contains("back in time"), "{e}");
        let e = Schedule::parse("t_s,r1_ref_mm\n0,8\n", ["r1_ref_mm", "r2_ref_mm"], "T")
            .unwrap_err()
            .to_string();
        assert!(e.contains("r2_ref_mm"), "{e}");
    }
}
