//! `magswarm fmu`: build and package `MagSwarm.fmu` (or, with `--pid`, `MagSwarmPID.fmu`) in
//! FMI 2.0 (the default) or FMI 3.0 (`--fmi-version 3`).
//!
//! This module only turns the command's arguments into inputs (model, controller
//! configuration, library path); the archives themselves are built by the workspace crate
//! `magswarm-packaging` (top-level `packaging/`, documented in `packaging/README.md`), which is
//! re-exported here so `magswarm::packaging::{plant, pid, archive, ...}` keep working.

use std::path::PathBuf;

use anyhow::{Context, Result};
use magswarm_control::PidConfig;
use magswarm_model::Model;

pub use crate::cli::FmuArgs;
pub use magswarm_packaging::*;

/// Where `magswarm fmu` writes the plant FMU unless told otherwise.
pub const DEFAULT_OUT: &str = plant::DEFAULT_OUT;

/// Run the command.
pub fn run(a: &FmuArgs) -> Result<()> {
    let version = FmiVersion::from_major(u32::from(a.fmi_version))
        .with_context(|| format!("--fmi-version {}: expected 2 or 3", a.fmi_version))?;
    if a.pid {
        return run_pid(a, version);
    }
    let model = load_model(a)?;
    if let Some(xml_path) = &a.xml {
        write_atomic(
            xml_path,
            plant::model_description(&model, version).as_bytes(),
        )?;
        println!("wrote {}", xml_path.display());
        return Ok(());
    }
    let lib = match &a.lib {
        Some(p) => p.clone(),
        None => locate_library(plant::CRATE, plant::LIB_FILE, plant::LIB_ENV, a.no_build)?,
    };
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(plant::default_out(version)));
    println!("{}", plant::package(&model, &lib, &out, version)?);
    Ok(())
}

/// `magswarm fmu --pid`: the controller FMU. `--model` is the plant model the controller
/// assumes, `--pid-config` its configuration, `--lib` the controller's library; `--xml` needs
/// the library too (the controller's XML comes only from its compiled `.so`).
fn run_pid(a: &FmuArgs, version: FmiVersion) -> Result<()> {
    let model = load_model(a)?;
    let cfg = match &a.pid_config {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("cannot read --pid-config {}", p.display()))?;
            PidConfig::from_json(&text).with_context(|| format!("--pid-config {}", p.display()))?
        }
        None => PidConfig::default(),
    };
    let lib = match &a.lib {
        Some(p) => p.clone(),
        None => locate_library(pid::CRATE, pid::LIB_FILE, pid::LIB_ENV, a.no_build)?,
    };
    if let Some(xml_path) = &a.xml {
        write_atomic(
            xml_path,
            pid::model_description(&lib, &cfg, version)?.as_bytes(),
        )?;
        println!("wrote {}", xml_path.display());
        return Ok(());
    }
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(pid::default_out(version)));
    println!("{}", pid::package(&model, &cfg, &lib, &out, version)?);
    Ok(())
}

/// `--model`, or the paper model.
fn load_model(a: &FmuArgs) -> Result<Model> {
    match &a.model {
        Some(p) => Model::load(p).with_context(|| format!("--model {}", p.display())),
        None => Ok(Model::paper()),
    }
}
