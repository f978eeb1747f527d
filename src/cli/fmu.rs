//! `magswarm fmu`: its arguments and the run, which turns them into inputs (model,
//! controller configuration, library path) for the workspace crate `magswarm-packaging`
//! (top-level `packaging/`, documented in `packaging/README.md`: the archives themselves),
//! in FMI 2.0 (the default) or FMI 3.0 (`--fmi-version 3`).

use std::path::PathBuf;

use anyhow::{Context, Result};

use magswarm::control::PidConfig;
use magswarm::model::Model;
use magswarm::packaging::{locate_library, pid, plant, write_atomic, FmiVersion};

/// Arguments of `magswarm fmu`.
#[derive(Debug, clap::Args)]
pub struct FmuArgs {
    /// Model JSON to bake into resources/ as the FMU's default model (default: paper model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Output path of the FMU [default: target/fmu/MagSwarm.fmu, with --pid
    /// target/fmu/MagSwarmPID.fmu; with --fmi-version 3 the same names under target/fmu/fmi3/].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// The compiled shared library to package (default: build it with cargo, or take
    /// libmagswarm_fmu.so beside this executable).
    #[arg(long)]
    pub lib: Option<PathBuf>,
    /// Do not run cargo; package the library found beside this executable.
    #[arg(long)]
    pub no_build: bool,
    /// Only write modelDescription.xml to this path (no build, no zip).
    #[arg(long, value_name = "PATH")]
    pub xml: Option<PathBuf>,
    /// Package the controller FMU MagSwarmPID.fmu instead (crate magswarm-pid-fmu; default
    /// --out target/fmu/MagSwarmPID.fmu; --model is the plant model the controller assumes,
    /// --lib the controller's libmagswarm_pid_fmu.so).
    #[arg(long)]
    pub pid: bool,
    /// FMI version of the FMU: 2 or 3. The plant carries Co-Simulation and Model Exchange in
    /// one FMU in both versions (same variable names, units and value references; FMI 3.0
    /// adds the independent variable `time`); the controller (--pid) is Co-Simulation.
    #[arg(long, value_name = "2|3", default_value_t = 2, value_parser = clap::value_parser!(u8).range(2..=3))]
    pub fmi_version: u8,
    /// With --pid: controller configuration JSON (magswarm-pid/1) baked into resources/pid.json.
    #[arg(long, value_name = "CFG.json", requires = "pid")]
    pub pid_config: Option<PathBuf>,
}

/// Run `magswarm fmu`.
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
    Model::load_or_paper(a.model.as_deref()).context("--model")
}
