//! `magswarm`: the command-line face of the library. Each subcommand lives in its own
//! library module; this file only parses arguments and reports errors.

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "magswarm",
    version,
    about = "Reduced-order model of magnetic microparticle swarms: FMU, control, identification"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Print the seed's figures beside the model's, and optionally draw Fig. 4/5-style plots.
    Paper(magswarm::paper::PaperArgs),
    /// Build and package the FMI 2.0 Co-Simulation FMU (default target/fmu/MagSwarm.fmu).
    Fmu(magswarm::packaging::FmuArgs),
    /// Replay the inputs of a log through a model (dynamics included).
    Predict(magswarm::predict::PredictArgs),
    /// Fit the model's parameters to measured logs.
    Identify(magswarm::identify::IdentifyArgs),
    /// The sim-to-real gap report: where the gap lies, which unmodelled effect causes it.
    Diagnose(magswarm::diagnose::DiagnoseArgs),
    /// Feedforward: the inputs (z_m, f) that give target radii (r1*, r2*).
    Inverse(magswarm::control_cli::InverseArgs),
    /// Linearise the plant at an operating point (A, B, C, D).
    Linearize(magswarm::control_cli::LinearizeArgs),
    /// Virtual lab: synthetic measurement logs from a truth model with chosen effects.
    Lab(magswarm::lab::LabArgs),
    /// Monte Carlo of the seed's closed-loop tracking scenario under parameter uncertainty.
    Sweep(magswarm::sweep::SweepArgs),
}

/// Every output path of the command, checked (and missing folders created) before it runs.
fn prepare_outputs(cmd: &Cmd) -> anyhow::Result<()> {
    use magswarm::outputs::{prepare_dir, prepare_file};
    match cmd {
        Cmd::Paper(a) => {
            if let Some(d) = &a.plots {
                prepare_dir("--plots", d)?;
            }
        }
        Cmd::Fmu(a) => {
            if let Some(p) = &a.out {
                prepare_file("--out", p)?;
            }
            if let Some(p) = &a.xml {
                prepare_file("--xml", p)?;
            }
        }
        Cmd::Predict(a) => prepare_file("--out", &a.out)?,
        Cmd::Identify(a) => {
            prepare_file("--out", &a.out)?;
            if let Some(d) = &a.report {
                prepare_dir("--report", d)?;
            }
        }
        Cmd::Diagnose(a) => prepare_dir("--out", &a.out)?,
        Cmd::Lab(a) => {
            if !a.print_scenario {
                prepare_file("--out", &a.out)?;
            }
        }
        Cmd::Sweep(a) => prepare_file("--out", &a.out)?,
        Cmd::Inverse(_) | Cmd::Linearize(_) => {}
    }
    Ok(())
}

fn main() {
    let cli = Cli::parse();
    if let Err(e) = prepare_outputs(&cli.cmd) {
        eprintln!("magswarm: error: {e:#}");
        std::process::exit(2);
    }
    let result = match &cli.cmd {
        Cmd::Paper(a) => magswarm::paper::run(a),
        Cmd::Fmu(a) => magswarm::packaging::run(a),
        Cmd::Predict(a) => magswarm::predict::run(a),
        Cmd::Identify(a) => magswarm::identify::run(a),
        Cmd::Diagnose(a) => magswarm::diagnose::run(a),
        Cmd::Inverse(a) => magswarm::control_cli::run_inverse(a),
        Cmd::Linearize(a) => magswarm::control_cli::run_linearize(a),
        Cmd::Lab(a) => magswarm::lab::run(a),
        Cmd::Sweep(a) => magswarm::sweep::run(a.clone()),
    };
    if let Err(e) = result {
        eprintln!("magswarm: error: {e:#}");
        std::process::exit(2);
    }
}
