//! One row of a log: a measurement (or a command) at one time.

/// One measurement.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LogRow {
    /// 1-based line number in the source file (0 for rows built in memory).
    pub line: usize,
    /// Seconds since the start of the session.
    pub t_s: f64,
    /// Commanded magnet-swarm distance \[mm\].
    pub z_m_mm: f64,
    /// Commanded field frequency \[Hz\].
    pub f_hz: f64,
    /// Measured r1 \[mm\] (None: column absent, or empty on a `valid` = 0 row).
    pub r1_mm: Option<f64>,
    /// Measured r2 \[mm\].
    pub r2_mm: Option<f64>,
    /// Session name ("" when the log has no session column).
    pub session: String,
    /// False for `valid` = 0 rows (kept, ignored by fitting).
    pub valid: bool,
    /// Controller setpoint for r1 \[mm\].
    pub r1_ref_mm: Option<f64>,
    /// Controller setpoint for r2 \[mm\].
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
