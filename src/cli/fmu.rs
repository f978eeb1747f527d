//! Arguments of `magswarm fmu` (run by [`crate::packaging::run`]; the archives are built by
//! the workspace crate `magswarm-packaging`).

use std::path::PathBuf;

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
