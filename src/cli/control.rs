//! `magswarm inverse` and `magswarm linearize`: their arguments and the runs.

use std::path::PathBuf;

use anyhow::Context;

use magswarm::control::{inverse, linearize};
use magswarm::model::Model;

/// `--model`, or the paper model.
fn load_model(path: &Option<PathBuf>) -> anyhow::Result<Model> {
    Model::load_or_paper(path.as_deref()).context("--model")
}

/// Arguments of `magswarm inverse`.
#[derive(Debug, clap::Args)]
pub struct InverseArgs {
    /// Target r1 \[mm\].
    #[arg(long)]
    pub r1: f64,
    /// Target r2 \[mm\].
    #[arg(long)]
    pub r2: f64,
    /// Model JSON (default: the built-in paper model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Output format of `magswarm linearize`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum LinFormat {
    /// JSON with the matrices, operating point, names and units.
    #[default]
    Json,
    /// A MATLAB script (`A = [..]; ... sys = ss(A,B,C,D);`).
    Matlab,
    /// A python-control script (`sys = control.ss(A, B, C, D)`).
    Python,
}

/// Arguments of `magswarm linearize`.
#[derive(Debug, clap::Args)]
pub struct LinearizeArgs {
    /// Operating point z_m \[mm\].
    #[arg(long)]
    pub z: f64,
    /// Operating point f \[Hz\].
    #[arg(long)]
    pub f: f64,
    /// Model JSON (default: the built-in paper model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = LinFormat::Json)]
    pub format: LinFormat,
}

/// Run `magswarm inverse`.
pub fn run_inverse(a: &InverseArgs) -> anyhow::Result<()> {
    if !(a.r1.is_finite() && a.r2.is_finite() && a.r1 > 0.0 && a.r2 > 0.0) {
        anyhow::bail!("target radii must be positive numbers (mm)");
    }
    let model = load_model(&a.model)?;
    let r = inverse(&model, a.r1, a.r2);
    if a.json {
        let v = serde_json::json!({
            "target_mm": {"r1": a.r1, "r2": a.r2},
            "inputs": {"z_m_mm": r.z_m * 1e3, "f_hz": r.f_hz(), "z_m": r.z_m, "omega_m": r.omega},
            "achieved_mm": {"r1": r.r1, "r2": r.r2},
            "feasible": r.feasible,
            "distance_mm": r.distance_mm,
            "iterations": r.iterations,
            "at_bound": {
                "z_min": r.at_bound[0], "z_max": r.at_bound[1],
                "f_min": r.at_bound[2], "f_max": r.at_bound[3],
            },
            "jacobian_mm_per_m_and_mm_s_per_rad": r.jac,
            "envelope": model.envelope,
            "message": r.describe(),
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!("target     r1* = {:.4} mm, r2* = {:.4} mm", a.r1, a.r2);
        println!(
            "inputs     z_m = {:.4} mm, f = {:.4} Hz (omega_m = {:.4} rad/s)",
            r.z_m * 1e3,
            r.f_hz(),
            r.omega
        );
        println!("achieved   r1 = {:.4} mm, r2 = {:.4} mm", r.r1, r.r2);
        if r.feasible {
            println!("feasible   yes");
        } else {
            let mut edges = Vec::new();
            for (on, name) in r
                .at_bound
                .iter()
                .zip(["z_m min", "z_m max", "f min", "f max"])
            {
                if *on {
                    edges.push(name);
                }
            }
            println!(
                "feasible   no: nearest reachable point, distance {:.4} mm ({})",
                r.distance_mm,
                if edges.is_empty() {
                    "on the fold of the map, inside the input envelope".to_string()
                } else {
                    format!("on the envelope's edge: {}", edges.join(", "))
                }
            );
        }
    }
    Ok(())
}

/// Run `magswarm linearize`.
pub fn run_linearize(a: &LinearizeArgs) -> anyhow::Result<()> {
    if !(a.z.is_finite() && a.f.is_finite() && a.z > 0.0 && a.f > 0.0) {
        anyhow::bail!("--z (mm) and --f (Hz) must be positive numbers");
    }
    let model = load_model(&a.model)?;
    let v = model
        .envelope
        .classify(a.z * 1e-3, magswarm_model::hz_to_rad_s(a.f));
    if v.extrapolating() {
        eprintln!("magswarm: warning: {}", v.describe());
    }
    let lin = linearize(&model, a.z * 1e-3, magswarm_model::hz_to_rad_s(a.f));
    match a.format {
        LinFormat::Json => println!("{}", lin.to_json()),
        LinFormat::Matlab => print!("{}", lin.to_matlab()),
        LinFormat::Python => print!("{}", lin.to_python()),
    }
    Ok(())
}
