//! The measurement log through files: reading, errors, streaming writer.
use magswarm::log::{Layout, Log, LogRow, LogWriter, ReadOptions};

#[test]
fn file_round_trip_keeps_unknown_columns_and_invalid_rows() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.csv");
    let text = "t_s,z_m_mm,f_hz,r1_mm,r2_mm,session,valid,r1_ref_mm,r2_ref_mm,cam_fps\n\
                0,8.5,4,8.31,11.92,s1,1,8,11,30\n\
                0.1,8.5,4,,,s1,0,8,11,30\n\
                0.2,8.5,4,8.3,11.9,s1,1,,,29.97\n";
    std::fs::write(&p, text).unwrap();
    let l = Log::read(&p).unwrap();
    let q = dir.path().join("b.csv");
    l.write(&q).unwrap();
    assert_eq!(std::fs::read_to_string(&q).unwrap(), text);
}

#[test]
fn streaming_writer_output_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s.csv");
    let mut layout = Layout::standard(true, false, true, true);
    let k = layout.add_extra("note");
    let mut w = LogWriter::create(&p, layout).unwrap();
    for i in 0..100 {
        let mut r = LogRow::new(
            i as f64 * 0.01,
            8.5,
            4.0,
            Some([8.0 + i as f64 * 1e-3, 12.0]),
        );
        r.r1_ref_mm = Some(8.0);
        r.extra = vec![String::new(); k + 1];
        r.extra[k] = format!("step {i}");
        r.valid = i % 10 != 0;
        w.write_row(&r).unwrap();
        if i % 25 == 0 {
            w.flush().unwrap();
        }
    }
    w.finish().unwrap();
    let l = Log::read(&p).unwrap();
    assert_eq!(l.rows.len(), 100);
    assert_eq!(l.rows[99].extra[0], "step 99");
    assert_eq!(l.rows.iter().filter(|r| !r.valid).count(), 10);
    assert_eq!(l.rows[5].r1_mm, Some(8.0 + 5.0 * 1e-3));
    assert_eq!(l.rows[5].r2_ref_mm, None);
}

#[test]
fn invalid_row_without_valid_column_is_refused_by_the_writer() {
    let mut w = LogWriter::new(Vec::new(), Layout::standard(true, false, false, false)).unwrap();
    let mut r = LogRow::new(0.0, 8.5, 4.0, Some([8.0, 12.0]));
    r.valid = false;
    assert!(w.write_row(&r).is_err());
}

#[test]
fn every_bad_row_is_reported_from_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.csv");
    let mut text = String::from("t_s,z_m_mm,f_hz,r1_mm,r2_mm\n");
    for i in 0..40 {
        if i % 4 == 3 {
            text += &format!("{i},8.5,4,bad,12\n");
        } else {
            text += &format!("{i},8.5,4,8,12\n");
        }
    }
    std::fs::write(&p, &text).unwrap();
    let e = Log::read(&p).unwrap_err();
    assert_eq!(e.problems.len(), 10);
    let lines: Vec<usize> = e.problems.iter().map(|p| p.line).collect();
    assert_eq!(lines, vec![5, 9, 13, 17, 21, 25, 29, 33, 37, 41]);
    let msg = e.to_string();
    assert!(
        msg.starts_with(&format!("{}: 10 problems", p.display())),
        "{msg}"
    );
    let l = Log::read_with(&p, ReadOptions { lenient: true }).unwrap();
    assert_eq!(l.rows.len(), 30);
    assert_eq!(l.skipped.len(), 10);
    assert!(Log::read(&dir.path().join("missing.csv"))
        .unwrap_err()
        .to_string()
        .contains("cannot open"));
}
