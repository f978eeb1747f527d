//! The seed's tracking experiment (Sec. III-D, Fig. 6) in closed loop: the packaged
//! `MagSwarm.fmu` loaded as any importer would (`magswarm::cosim`: unzip, modelDescription,
//! `dlopen` of the binary, FMI 2.0 calls), and the decoupled PID of `magswarm-control` in this
//! process as the control-design code.
//!
//! ```text
//! cargo run --release --example pid_tracking -- --fmu target/fmu/MagSwarm.fmu \
//!     --out target/demo/pid_tracking.csv [--config cfg.json] [--model M.json] \
//!     [--segments 60:7:11,60:8:11,60:9:11] [--plot target/demo/pid_tracking.png]
//! ```
//!
//! Loop (one communication step = one controller sample, 0.05 s by default): read the plant's
//! `r1`, `r2` at `t_k`; the controller maps them and the setpoint to `(z_m, omega_m)`; one log
//! row; set the plant's inputs; `fmi2DoStep(t_k, Ts)`. The first sample resets the controller
//! bumplessly at the plant's initial inputs (8.5 mm, 4 Hz) and the first measurement. This is
//! the order `examples/pid_tracking.py` uses with `MagSwarmPID.fmu`, so the two logs agree.
//!
//! The log is the measurement log of docs/log-format.md with `r1_ref_mm`, `r2_ref_mm`, plus the
//! extra columns `r1_goal_mm`, `r2_goal_mm` (the nearest reachable radii the loop settles on)
//! and `target_feasible` (0/1).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Parser;
use magswarm::control::driver::NoLog;
use magswarm::control::{seed_scenario, sim, summarize, Controller, PidConfig, Sample, Segment};
use magswarm::cosim::{CoSimConfig, CoSimulation, Fmu};
use magswarm::log::{Layout, LogWriter};
use magswarm::model::Model;

/// Command line.
#[derive(Debug, Parser)]
#[command(about = "Closed-loop PID tracking against MagSwarm.fmu (the seed's Fig. 6 experiment)")]
pub struct Args {
    /// The plant FMU.
    #[arg(long, default_value = "target/fmu/MagSwarm.fmu")]
    pub fmu: PathBuf,
    /// Measurement log to write (CSV, docs/log-format.md).
    #[arg(long, default_value = "target/demo/pid_tracking.csv")]
    pub out: PathBuf,
    /// Controller configuration (magswarm-pid/1 JSON; default the library's).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Model the controller assumes (magswarm-model/1 JSON; default the paper model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Setpoint segments "seconds:r1_mm:r2_mm,..." (default the seed's 60:7:11,60:8:11,60:9:11).
    #[arg(long)]
    pub segments: Option<String>,
    /// Also draw a Fig. 6-like PNG (radii against setpoints, inputs against time).
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// One closed-loop run: the samples (one per log row) and whether each sample's setpoint was
/// feasible.
#[derive(Debug, Clone)]
pub struct Run {
    /// The samples, as `magswarm_control::sim::tracking` records them.
    pub samples: Vec<Sample>,
    /// `!target_infeasible()` at each sample.
    pub feasible: Vec<bool>,
    /// fmi2Warning statuses from the plant during the run.
    pub warnings: u64,
}

/// Parse "seconds:r1:r2,..." into segments.
pub fn parse_segments(text: &str) -> Result<Vec<Segment>> {
    text.split(',')
        .map(|s| {
            let v: Vec<f64> = s
                .split(':')
                .map(|x| x.trim().parse::<f64>())
                .collect::<std::result::Result<_, _>>()
                .with_context(|| format!("segment {s:?}: expected seconds:r1_mm:r2_mm"))?;
            match v[..] {
                [d, r1, r2] if d > 0.0 && r1 > 0.0 && r2 > 0.0 => Ok(Segment {
                    duration_s: d,
                    r1,
                    r2,
                }),
                _ => bail!("segment {s:?}: expected seconds:r1_mm:r2_mm, all positive"),
            }
        })
        .collect()
}

/// Run `segments` with the controller (`model`, `cfg`) against the plant FMU `fmu`, which
/// starts formed at `start` (z_m [m], omega [rad/s]).
pub fn run(
    fmu: &Fmu,
    model: &Model,
    cfg: &PidConfig,
    segments: &[Segment],
    start: (f64, f64),
) -> Result<Run> {
    let ts = cfg.sample_time_s;
    let mut sim = CoSimulation::new(
        fmu,
        &CoSimConfig {
            step_s: ts,
            initial_inputs: [start.0, start.1],
            instance_name: "swarm".into(),
            ..CoSimConfig::default()
        },
    )?;
    let mut ctrl = Controller::new(model.clone(), cfg.clone())?;
    // The one closed-loop driver, with the FMU importer as the plant.
    let w0 = sim.warnings();
    let run = sim::tracking(&mut sim, &mut ctrl, segments, false, &mut NoLog)?;
    Ok(Run {
        samples: run.samples,
        feasible: run.feasible,
        warnings: sim.warnings() - w0,
    })
}

/// Write the measurement log (docs/log-format.md columns, setpoints, goal and feasibility extras).
pub fn write_log(path: &Path, run: &Run) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let mut layout = Layout::standard(true, false, false, true);
    for name in ["r1_goal_mm", "r2_goal_mm", "target_feasible"] {
        layout.add_extra(name);
    }
    let mut w = LogWriter::create(path, layout)
        .with_context(|| format!("cannot write {}", path.display()))?;
    for (s, ok) in run.samples.iter().zip(&run.feasible) {
        let mut row = s.log_row();
        row.extra = vec![
            format!("{}", s.r1_goal_mm),
            format!("{}", s.r2_goal_mm),
            (if *ok { "1" } else { "0" }).to_string(),
        ];
        w.write_row(&row)?;
    }
    w.finish()?;
    Ok(())
}

/// Fig. 6-like plot: radii against setpoints and reachable goals, then z_m and f.
pub fn plot(path: &Path, run: &Run) -> Result<()> {
    use magswarm::plot::{time_panels, Panel, Series};
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let s = &run.samples;
    let col = |f: fn(&Sample) -> f64| s.iter().map(|x| (x.t_s, f(x))).collect::<Vec<_>>();
    time_panels(
        path,
        "MagSwarm.fmu under the decoupled PID (seed Fig. 6 scenario)",
        "t [s]",
        &[
            Panel {
                y_label: "r1 [mm]".into(),
                series: vec![
                    Series::line("r1 (FMU)", col(|x| x.r1_mm)),
                    Series::dashed("r1* setpoint", col(|x| x.r1_ref_mm)),
                    Series::dashed("nearest reachable", col(|x| x.r1_goal_mm)),
                ],
            },
            Panel {
                y_label: "r2 [mm]".into(),
                series: vec![
                    Series::line("r2 (FMU)", col(|x| x.r2_mm)),
                    Series::dashed("r2* setpoint", col(|x| x.r2_ref_mm)),
                    Series::dashed("nearest reachable", col(|x| x.r2_goal_mm)),
                ],
            },
            Panel {
                y_label: "z_m [mm]".into(),
                series: vec![Series::line("z_m", col(|x| x.z_m_mm))],
            },
            Panel {
                y_label: "f [Hz]".into(),
                series: vec![Series::line("f_m", col(|x| x.f_hz))],
            },
        ],
    )?;
    Ok(())
}

/// The per-segment table (markdown), with the seed's model radii beside ours for the seed's
/// scenario.
pub fn report(run: &Run, segments: &[Segment]) -> String {
    let seed = [(7.61, 10.43), (8.14, 11.23), (8.50, 11.70)];
    let is_seed = segments == seed_scenario().as_slice();
    let mut out = String::from(
        "| segment | r1*, r2* [mm] | final r1, r2 [mm] | nearest reachable r1, r2 [mm] | distance [mm] | feasible | final z_m [mm], f [Hz] | settling to 0.1 mm [s] |",
    );
    if is_seed {
        out.push_str(" seed model r1, r2 [mm] |");
    }
    out.push_str("\n|---|---|---|---|---|---|---|---|");
    if is_seed {
        out.push_str("---|");
    }
    out.push('\n');
    for (k, s) in summarize(&run.samples, 0.1).iter().enumerate() {
        let last = run
            .samples
            .iter()
            .rposition(|x| x.segment == k)
            .expect("segment has samples");
        let feasible = run.feasible[last];
        let dist =
            ((s.setpoint[0] - s.goal[0]).powi(2) + (s.setpoint[1] - s.goal[1]).powi(2)).sqrt();
        out.push_str(&format!(
            "| {} | {:.2}, {:.2} | {:.3}, {:.3} | {:.3}, {:.3} | {:.3} | {} | {:.2}, {:.2} | {} |",
            k + 1,
            s.setpoint[0],
            s.setpoint[1],
            s.final_radii[0],
            s.final_radii[1],
            s.goal[0],
            s.goal[1],
            dist,
            if feasible { "yes" } else { "no (infeasible)" },
            s.final_inputs[0],
            s.final_inputs[1],
            s.settling_time_s
                .map_or("not settled".to_string(), |t| format!("{t:.2}")),
        ));
        if is_seed {
            out.push_str(&format!(" {:.2}, {:.2} |", seed[k].0, seed[k].1));
        }
        out.push('\n');
    }
    out
}

/// Load the configuration and model named by `args`.
pub fn load_inputs(args: &Args) -> Result<(PidConfig, Model, Vec<Segment>)> {
    let cfg = match &args.config {
        Some(p) => PidConfig::from_json(
            &std::fs::read_to_string(p).with_context(|| format!("cannot read {}", p.display()))?,
        )?,
        None => PidConfig::default(),
    };
    let model = match &args.model {
        Some(p) => Model::load(p)?,
        None => Model::paper(),
    };
    let segments = match &args.segments {
        Some(s) => parse_segments(s)?,
        None => seed_scenario(),
    };
    Ok((cfg, model, segments))
}

#[allow(dead_code)] // the tests include this file for its functions
fn main() -> Result<()> {
    let args = Args::parse();
    let (cfg, model, segments) = load_inputs(&args)?;
    let fmu = Fmu::load(&args.fmu).with_context(|| format!("--fmu {}", args.fmu.display()))?;
    let t = std::time::Instant::now();
    let run = run(&fmu, &model, &cfg, &segments, sim::SEED_START)?;
    let elapsed = t.elapsed().as_secs_f64();
    write_log(&args.out, &run)?;
    println!(
        "closed loop: {} samples of {} s against {} ({} plant warnings) in {:.2} s; log {}",
        run.samples.len(),
        cfg.sample_time_s,
        args.fmu.display(),
        run.warnings,
        elapsed,
        args.out.display()
    );
    print!("{}", report(&run, &segments));
    if let Some(p) = &args.plot {
        plot(p, &run)?;
        println!("plot {}", p.display());
    }
    Ok(())
}
