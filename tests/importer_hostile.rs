//! The importer (`magswarm::cosim`) leaves nothing behind and refuses hostile archives; the
//! packaged FMU refuses a resource location that lacks the model it was packaged with.
//!
//! Temp-folder counts run in child processes with their own `TMPDIR`, so other tests running
//! in parallel cannot disturb the count.

#[path = "common/fmu.rs"]
mod fmu_common;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use magswarm::cosim::{CosimError, Fmu, SlaveOptions};

fn unpacked_dirs(tmp: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(tmp)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| {
                    p.file_name()
                        .is_some_and(|n| n.to_string_lossy().starts_with("fmi-rs"))
                })
                .collect()
        })
        .unwrap_or_default()
}

/// Run this test binary's `child` test with `mode`, `TMPDIR` = `tmp`.
fn spawn_child(mode: &str, tmp: &Path) -> Command {
    let mut c = Command::new(std::env::current_exe().unwrap());
    c.args([
        "--exact",
        "child",
        "--include-ignored",
        "--nocapture",
        "--test-threads=1",
    ])
    .env("MAGSWARM_LITTER_CHILD", mode)
    .env("MAGSWARM_FMU", fmu_common::packaged())
    .env("TMPDIR", tmp);
    c
}

/// What the child process does (ignored unless run by the tests below).
#[test]
#[ignore = "run in a child process by the tests below"]
fn child() {
    let Ok(mode) = std::env::var("MAGSWARM_LITTER_CHILD") else {
        return;
    };
    let fmu_path = PathBuf::from(std::env::var_os("MAGSWARM_FMU").unwrap());
    match mode.as_str() {
        // Dropped normally, and one kept in a static (never dropped) until exit.
        "drop-and-static" => {
            for _ in 0..3 {
                let fmu = Fmu::load(&fmu_path).unwrap();
                let mut s = fmu.instantiate("a", SlaveOptions::default()).unwrap();
                s.setup_experiment(None, 0.0, None).unwrap();
                s.enter_initialization_mode().unwrap();
                s.exit_initialization_mode().unwrap();
                s.do_step(0.0, 0.01).unwrap();
            }
            static KEPT: OnceLock<Fmu> = OnceLock::new();
            KEPT.get_or_init(|| Fmu::load(&fmu_path).unwrap());
            assert_eq!(magswarm::cosim::extract::live_count(), 1);
        }
        // Interrupted while holding an FMU.
        "sigint" => {
            let fmu = Fmu::load(&fmu_path).unwrap();
            std::fs::write(std::env::temp_dir().join("loaded"), b"").unwrap();
            std::thread::sleep(Duration::from_secs(30));
            drop(fmu);
        }
        other => panic!("unknown mode {other}"),
    }
}

#[test]
fn no_unpacked_fmu_is_left_after_drop_exit_or_ctrl_c() {
    let tmp = tempfile::tempdir().unwrap();
    let before = unpacked_dirs(tmp.path()).len();
    let out = spawn_child("drop-and-static", tmp.path()).output().unwrap();
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("1 passed"));
    assert_eq!(
        unpacked_dirs(tmp.path()).len(),
        before,
        "left behind after a normal exit: {:?}",
        unpacked_dirs(tmp.path())
    );

    let mut c = spawn_child("sigint", tmp.path())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while !tmp.path().join("loaded").exists() {
        assert!(t0.elapsed() < Duration::from_secs(60), "child never loaded");
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(unpacked_dirs(tmp.path()).len(), 1, "unpacked while running");
    let st = Command::new("kill")
        .args(["-INT", &c.id().to_string()])
        .status()
        .unwrap();
    assert!(st.success());
    let status = c.wait().unwrap();
    assert!(!status.success(), "interrupted");
    assert_eq!(
        unpacked_dirs(tmp.path()).len(),
        0,
        "left behind after Ctrl-C: {:?}",
        unpacked_dirs(tmp.path())
    );
}

/// A zip with the given (name, bytes) entries.
fn zip_with(path: &Path, entries: &[(&str, &[u8])]) {
    let f = std::fs::File::create(path).unwrap();
    let mut z = zip::ZipWriter::new(f);
    let opt = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    for (name, bytes) in entries {
        z.start_file(*name, opt).unwrap();
        z.write_all(bytes).unwrap();
    }
    z.finish().unwrap();
}

#[test]
fn hostile_archives_are_refused_naming_the_entry_and_leave_nothing() {
    let dir = tempfile::tempdir().unwrap();
    // A real modelDescription.xml, so only the hostile part differs.
    let real = Fmu::load(fmu_common::packaged()).unwrap();
    let xml = std::fs::read(real.extracted_dir().join("modelDescription.xml")).unwrap();
    drop(real);
    let zeros = vec![0u8; 64 << 20];
    // (case, archive entries (name, bytes), what the refusal must name)
    type Case<'a> = (&'a str, Vec<(&'a str, &'a [u8])>, &'a str);
    let cases: Vec<Case> = vec![
        (
            "zip-slip",
            vec![
                ("modelDescription.xml", &xml[..]),
                ("../../escaped.txt", b"x"),
            ],
            "outside the unpacked folder",
        ),
        (
            "missing XML",
            vec![("resources/model.json", b"{}")],
            "no modelDescription.xml",
        ),
        (
            "zip bomb",
            vec![
                ("modelDescription.xml", &xml[..]),
                ("a", &zeros[..]),
                ("b", &zeros[..]),
                ("c", &zeros[..]),
                ("d", &zeros[..]),
                ("e", &zeros[..]),
                ("f", &zeros[..]),
                ("g", &zeros[..]),
                ("h", &zeros[..]),
                ("i", &zeros[..]),
                ("j", &zeros[..]),
                ("k", &zeros[..]),
                ("l", &zeros[..]),
                ("m", &zeros[..]),
                ("n", &zeros[..]),
                ("o", &zeros[..]),
                ("p", &zeros[..]),
                ("q", &zeros[..]),
            ],
            "more than",
        ),
        (
            "bad XML",
            vec![("modelDescription.xml", b"<fmiModelDescription")],
            "cannot import",
        ),
    ];
    let before = magswarm::cosim::extract::live_count();
    for (what, entries, needle) in cases {
        let p = dir.path().join(format!("{}.fmu", what.replace(' ', "_")));
        zip_with(&p, &entries);
        let e = Fmu::load(&p).expect_err(what);
        let msg = e.to_string();
        assert!(msg.contains(needle), "{what}: {msg}");
        assert!(
            msg.contains(&p.display().to_string()),
            "{what} names the file: {msg}"
        );
        assert!(!Path::new("/tmp/abs.txt").exists());
        assert!(!dir.path().join("escaped.txt").exists());
    }
    let not_zip = dir.path().join("not-a-zip.fmu");
    std::fs::write(&not_zip, b"hello").unwrap();
    assert!(matches!(
        Fmu::load(&not_zip),
        Err(CosimError::BadArchive { .. })
    ));
    assert!(magswarm::cosim::extract::live_count() <= before);
}

#[test]
fn a_resource_location_without_the_packaged_model_is_refused() {
    let fmu = Fmu::load(fmu_common::packaged()).unwrap();
    assert!(
        fmu.extracted_dir().join("resources/model.json").is_file(),
        "the default FMU bakes its model"
    );
    for uri in ["file:///nonexistent/resources", "file:///tmp"] {
        let e = fmu
            .instantiate(
                "wrong-resources",
                SlaveOptions {
                    resource_uri_override: Some(uri.into()),
                    ..Default::default()
                },
            )
            .expect_err(uri);
        let msg = e.to_string();
        assert!(msg.contains("packaged with"), "{uri}: {msg}");
    }
    // The right location works.
    fmu.instantiate("right", SlaveOptions::default()).unwrap();
}
