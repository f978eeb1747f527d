//! The command-line layer: the clap structs of every command and the dispatch to the library
//! module that runs it. `src/main.rs` only parses and calls [`main`].
//!
//! Each command's arguments live in a module of their own here; the modules that run a command
//! take its struct (re-exported at their old paths, e.g. `magswarm::identify::IdentifyArgs`).

mod control;
mod diagnose;
mod fmu;
pub mod identify;
mod lab;
pub mod paper;
pub mod predict;
mod progress;
pub mod sweep;

pub use control::{InverseArgs, LinearizeArgs};
pub use diagnose::DiagnoseArgs;
pub use fmu::FmuArgs;
pub use identify::IdentifyArgs;
pub use lab::LabArgs;
pub use paper::PaperArgs;
pub use predict::PredictArgs;
pub use sweep::SweepArgs;

use clap::{Parser, Subcommand};

/// The command line.
#[derive(Parser)]
#[command(
    name = "magswarm",
    version,
    about = "Reduced-order model of magnetic microparticle swarms: FMU, control, identification"
)]
pub struct Cli {
    #[command(subcommand)]
    pub cmd: Cmd,
}

/// The commands.
#[derive(Subcommand)]
pub enum Cmd {
    /// Print the seed's figures beside the model's, and optionally draw Fig. 4/5-style plots.
    Paper(PaperArgs),
    /// Build and package the FMI 2.0 FMU, Co-Simulation and Model Exchange in one (default
    /// target/fmu/MagSwarm.fmu).
    Fmu(FmuArgs),
    /// Replay the inputs of a log through a model (dynamics included).
    Predict(PredictArgs),
    /// Fit the model's parameters to measured logs.
    Identify(IdentifyArgs),
    /// The sim-to-real gap report: where the gap lies, which unmodelled effect causes it.
    Diagnose(DiagnoseArgs),
    /// Feedforward: the inputs (z_m, f) that give target radii (r1*, r2*).
    Inverse(InverseArgs),
    /// Linearise the plant at an operating point (A, B, C, D).
    Linearize(LinearizeArgs),
    /// Virtual lab: synthetic measurement logs from a truth model with chosen effects.
    Lab(LabArgs),
    /// Monte Carlo of the seed's closed-loop tracking scenario under parameter uncertainty.
    Sweep(SweepArgs),
}

/// Every output path of the command, checked (and missing folders created) before it runs.
pub fn prepare_outputs(cmd: &Cmd) -> anyhow::Result<()> {
    use crate::outputs::{prepare_dir, prepare_file};
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

/// An error and its causes on one line, "outer: inner", each cause once: a library error
/// whose own message already carries its source's text (so that it reads whole where it is
/// printed alone) is not followed by that text again.
pub fn error_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

/// Run the parsed command; the process exit code (0, or 2 after printing the error).
pub fn main(cli: &Cli) -> i32 {
    if let Err(e) = prepare_outputs(&cli.cmd) {
        eprintln!("magswarm: error: {}", error_line(&e));
        return 2;
    }
    let result = match &cli.cmd {
        Cmd::Paper(a) => paper::run(a),
        Cmd::Fmu(a) => fmu::run(a),
        Cmd::Predict(a) => predict::run(a),
        Cmd::Identify(a) => identify::run(a),
        Cmd::Diagnose(a) => diagnose::run(a),
        Cmd::Inverse(a) => control::run_inverse(a),
        Cmd::Linearize(a) => control::run_linearize(a),
        Cmd::Lab(a) => lab::run(a),
        Cmd::Sweep(a) => sweep::run(a),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("magswarm: error: {}", error_line(&e));
            2
        }
    }
}

#[cfg(test)]
mod tests {
    use super::error_line;

    #[derive(Debug)]
    struct Inner;
    impl std::fmt::Display for Inner {
        fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("inner: 3 pairs")
        }
    }
    impl std::error::Error for Inner {}

    /// An error whose message carries its source's text, and which also returns it.
    #[derive(Debug)]
    struct Outer(Inner);
    impl std::fmt::Display for Outer {
        fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            write!(f, "log.csv: {}", self.0)
        }
    }
    impl std::error::Error for Outer {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            Some(&self.0)
        }
    }

    #[test]
    fn a_cause_already_in_its_outer_message_is_not_repeated() {
        let e = anyhow::Error::new(Outer(Inner)).context("diagnose");
        assert_eq!(error_line(&e), "diagnose: log.csv: inner: 3 pairs");
        let plain = anyhow::anyhow!("alone");
        assert_eq!(error_line(&plain), "alone");
    }
}
