//! Problems found while reading a log, each with its line and column.

use std::fmt;

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
    /// File name or `"<string>"`.
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
