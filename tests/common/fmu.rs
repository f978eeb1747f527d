//! Test helper: package MagSwarm.fmu with the `magswarm fmu` command of this build, so FMU
//! tests do not depend on `target/fmu/MagSwarm.fmu` being fresh or on test order.
//!
//! Use from an integration test with `#[path = "common/fmu.rs"] mod fmu_common;`.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The `magswarm` executable Cargo built for this test.
pub fn magswarm_exe() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_magswarm"))
}

/// Run `magswarm fmu [--model MODEL] --out OUT` (it builds the FMU's cdylib with cargo if
/// needed) and panic with its output if it fails.
pub fn package(out: &Path, model: Option<&Path>) -> PathBuf {
    package_version(out, model, 2)
}

/// Run `magswarm fmu [--model MODEL] --out OUT --fmi-version V`.
pub fn package_version(out: &Path, model: Option<&Path>, version: u32) -> PathBuf {
    let mut cmd = Command::new(magswarm_exe());
    cmd.arg("fmu").arg("--fmi-version").arg(version.to_string());
    if let Some(m) = model {
        cmd.arg("--model").arg(m);
    }
    cmd.arg("--out").arg(out);
    let o = cmd.output().expect("cannot run magswarm fmu");
    assert!(
        o.status.success(),
        "magswarm fmu failed ({}):\n{}\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(out.is_file(), "{} not written", out.display());
    out.to_path_buf()
}

/// A scratch directory for the whole test process, under Cargo's `target/tmp` (a static is
/// never dropped, so it is not removed at exit; `cargo clean` does).
pub fn scratch_dir() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        let base = Path::new(env!("CARGO_TARGET_TMPDIR"));
        std::fs::create_dir_all(base).expect("CARGO_TARGET_TMPDIR");
        tempfile::Builder::new()
            .prefix("magswarm-fmu-test")
            .tempdir_in(base)
            .expect("tempdir")
    })
    .path()
}

/// The default MagSwarm.fmu, packaged once per test process.
pub fn packaged() -> &'static Path {
    static FMU: OnceLock<PathBuf> = OnceLock::new();
    FMU.get_or_init(|| package(&scratch_dir().join("MagSwarm.fmu"), None))
}

/// The default MagSwarm.fmu in FMI 3.0, packaged once per test process.
pub fn packaged_fmi3() -> &'static Path {
    static FMU: OnceLock<PathBuf> = OnceLock::new();
    FMU.get_or_init(|| {
        let dir = scratch_dir().join("fmi3");
        std::fs::create_dir_all(&dir).expect("scratch dir");
        package_version(&dir.join("MagSwarm.fmu"), None, 3)
    })
}
