//! The magswarm measurement log (docs/log-format.md): reader and streaming writer.
//!
//! One format for everything that produces or consumes radii over time: the co-simulation
//! harnesses, `magswarm predict`, `identify`, `diagnose`, the virtual lab and the hardware
//! bridge. This crate depends only on `csv` and `thiserror` (no clap, no plotters), so any of
//! them can use it.
//!
//! ```text
//! t_s,z_m_mm,f_hz,r1_mm,r2_mm[,session][,valid][,r1_ref_mm][,r2_ref_mm][,anything else]
//! ```
//!
//! Modules: [`column`](mod@column) (which columns, in which order), [`row`] (one measurement),
//! [`read`] (header, row and cross-row parsing), [`write`](mod@write) (streaming writer), [`error`].
//!
//! # Rules of the reader
//!
//! Every rule names the line and the column of the row that breaks it.
//!
//! - `t_s`, `z_m_mm`, `f_hz` are required columns; every row needs finite numbers there.
//! - `r1_mm`, `r2_mm` may be absent as columns (a `predict` input). Where present, a row with
//!   `valid` = 1 (or no `valid` column) needs a finite, non-negative number in both. A row
//!   with `valid` = 0 may leave them empty or `NaN` (the camera lost the swarm): the row is
//!   kept and ignored by fitting, as docs/log-format.md says; a negative or non-numeric text is
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
//!
//! # When do a row's inputs act? (the row-time convention)
//!
//! A log samples a continuous experiment, so the file cannot say exactly when between two rows
//! an input changed. The rule, used by `predict` to replay and by `identify` to date input
//! changes (docs/log-format.md explains it at length):
//!
//! > The inputs of a row are held over the interval since the previous row of its session;
//! > the radii of a row are the state at its time.
//!
//! - A log of settled measurements (change the inputs, wait, measure) thereby counts the
//!   unrecorded waiting time: the first measurement of a new operating point comes
//!   `t - t_previous` after the change.
//! - A log streamed by a controller (the closed-loop driver writes the command issued at `t`
//!   on the row of the measurement taken at `t`) is replayed one sample period early at an
//!   input change; once settled the replay is exact.
//! - A command schedule for `predict` should list a row just before each change
//!   (`0,8.5,4` `9.99,8.5,4` `10,13.5,6` switches at 10 s).
//!
//! Writers of logs (the closed-loop driver, the lab, the bridge) follow the same rule: a row
//! carries the measurement taken at `t_s` and the inputs in force at that moment.

pub mod column;
pub mod error;
pub mod read;
pub mod row;
pub mod write;

pub use column::{Column, Layout, KNOWN_COLUMNS};
pub use error::{LogError, LogProblem};
pub use read::{Log, ReadOptions};
pub use row::LogRow;
pub use write::LogWriter;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::read::ReadOptions;

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
