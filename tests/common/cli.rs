//! Test helper: run the `magswarm` program of this build as a user does.
//!
//! Use from an integration test with `#[path = "common/cli.rs"] mod cli;`.
#![allow(dead_code)]

use std::process::Command;

/// `magswarm` with no arguments yet.
pub fn magswarm() -> Command {
    Command::new(env!("CARGO_BIN_EXE_magswarm"))
}

/// Run `c`; its error message (stderr) when it fails.
pub fn run(mut c: Command) -> Result<(), String> {
    let o = c
        .output()
        .map_err(|e| format!("cannot run magswarm: {e}"))?;
    if o.status.success() {
        Ok(())
    } else {
        Err(String::from_utf8_lossy(&o.stderr).into_owned())
    }
}
