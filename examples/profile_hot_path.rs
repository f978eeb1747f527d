//! A fixed amount of one hot-path workload, for `valgrind --tool=callgrind` (instruction
//! counts are repeatable on a loaded machine where timings are not; docs/performance.md).
//!
//! ```text
//! cargo build --release --example profile_hot_path && cargo run --release -- fmu
//! valgrind --tool=callgrind --callgrind-out-file=target/perf/cg.out \
//!     target/release/examples/profile_hot_path fmu-change 20000
//! callgrind_annotate target/perf/cg.out | head -40
//! ```
//!
//! Workloads (each `N` calls after a short warm-up, printed with a checksum of the outputs):
//! - `fmu-const`, `fmu-change`: MagSwarm.fmu (FMI 2.0, 3.0 with `--fmu3`, or `--fmu=PATH`,
//!   e.g. one packaged from a library built with line tables for `callgrind_annotate`) through the C
//!   ABI ([`magswarm::perf::raw::RawLoop`]): doStep at constant inputs / set + doStep + get
//!   with a new input every call, h = 1 ms;
//! - `plant-const`, `plant-change`: the in-process `Plant::step(1 ms)`, without / with
//!   `set_inputs` before every step (`--table`: with the map table in force, as in the FMU);
//! - `terms`: `InputTerms::new` alone (the work of one input change);
//! - `tracking`: the seed's tracking scenario through the FMU and the Rust PID harness
//!   (`--runs=K`: K runs, each on a new instance of the one loaded FMU, so the runs after
//!   the first find the map-table cells the first built; the difference of K = 2 and K = 1
//!   is the cost of a run with the cells built); each run prints its wall time;
//! - `replay`: the FMU and importer alone, replaying the commands of one PID run (no
//!   controller), `--runs=K`;
//! - `closed-loop`: the same scenario in process (controller and `Plant`, no FMI), `--runs=K`.
//!
//! The controller is `Fidelity::Lean` (the default); `--full` runs `Fidelity::Full`, the
//! controller before round perf18, in the same binary.

use std::hint::black_box;
use std::path::Path;

use anyhow::{bail, Context, Result};
use magswarm::control::{seed_scenario, sim, Controller, Fidelity, PidConfig};
use magswarm::control::{Inputs, SwarmPlant};
use magswarm::cosim::{CoSimConfig, CoSimulation, Fmu, NoLog};
use magswarm::model::dynamics::InputTerms;
use magswarm::model::{hz_to_rad_s, Model, Plant};
use magswarm::perf::raw::{inputs, RawLoop, MAGSWARM};

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let what = args.first().map(String::as_str).unwrap_or("fmu-change");
    let n: usize = args
        .get(1)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(20_000);
    let fmu_path = match args.iter().find_map(|a| a.strip_prefix("--fmu=")) {
        Some(p) => p,
        None if args.iter().any(|a| a == "--fmu3") => "target/fmu/fmi3/MagSwarm.fmu",
        None => "target/fmu/MagSwarm.fmu",
    };
    let h = 1e-3;
    let load = || Fmu::load(Path::new(fmu_path)).with_context(|| format!("load {fmu_path}"));
    // The tracking workloads: the seed's scenario at 1 kHz, `--runs=K` runs, each timed.
    let runs: usize = match args.iter().find_map(|a| a.strip_prefix("--runs=")) {
        Some(k) => k.parse().context("--runs=K")?,
        None => 1,
    };
    let cfg = PidConfig {
        sample_time_s: h,
        ..PidConfig::default()
    };
    let fidelity = if args.iter().any(|a| a == "--full") {
        Fidelity::Full
    } else {
        Fidelity::Lean
    };
    let new_ctrl = |cfg: PidConfig| Controller::with_fidelity(Model::paper(), cfg, fidelity);
    let co_cfg = CoSimConfig {
        step_s: h,
        initial_inputs: [sim::SEED_START.0, sim::SEED_START.1],
        ..CoSimConfig::default()
    };
    let report = |samples: usize, t0: std::time::Instant, check: f64| {
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        println!("{samples} samples, {ms:.1} ms ({check})");
    };
    match what {
        "fmu-const" | "fmu-change" => {
            let fmu = load()?;
            let mut r = RawLoop::new(&fmu, MAGSWARM, h)?;
            let f = if what == "fmu-const" {
                RawLoop::step
            } else {
                RawLoop::set_step_get
            };
            for _ in 0..n {
                f(&mut r);
            }
        }
        "plant-const" | "plant-change" => {
            let mut p = Plant::new(Model::paper(), 8.5e-3, 4.0 * std::f64::consts::TAU);
            p.use_map_table(args.iter().any(|a| a == "--table"));
            let mut t = 0.0;
            for _ in 0..n {
                if what == "plant-change" {
                    let u = inputs(t);
                    p.set_inputs(u[0], u[1]);
                }
                p.step(h)?;
                t += h;
            }
            println!("{:?}", p.state());
        }
        "terms" => {
            let m = Model::paper();
            for k in 0..n {
                let u = inputs(k as f64 * h);
                black_box(InputTerms::new(&m, black_box(u[0]), black_box(u[1])));
            }
        }
        "tracking" => {
            let fmu = load()?;
            for _ in 0..runs {
                let mut co = CoSimulation::new(&fmu, &co_cfg)?;
                let mut ctrl = new_ctrl(cfg.clone())?;
                let t0 = std::time::Instant::now();
                let run = sim::tracking(&mut co, &mut ctrl, &seed_scenario(), false, &mut NoLog)?;
                report(run.samples.len(), t0, run.summary.last.r_mm[0]);
            }
        }
        "replay" => {
            // The FMU and the importer alone: the commands of one PID run replayed through
            // `SwarmPlant::step` (set + doStep + get), with no controller; what the tracking
            // scenario costs at the least with this FMU and importer.
            let fmu = load()?;
            let mut co = CoSimulation::new(&fmu, &co_cfg)?;
            let mut ctrl = new_ctrl(cfg.clone())?;
            let run = sim::tracking(&mut co, &mut ctrl, &seed_scenario(), false, &mut NoLog)?;
            let cmds: Vec<Inputs> = run
                .samples
                .iter()
                .map(|s| Inputs::new(s.z_m_mm * 1e-3, hz_to_rad_s(s.f_hz)))
                .collect();
            for _ in 0..runs {
                let mut co = CoSimulation::new(&fmu, &co_cfg)?;
                let t0 = std::time::Instant::now();
                let mut sum = SwarmPlant::measure(&mut co)?.r_mm[0];
                for &u in &cmds {
                    sum += SwarmPlant::step(&mut co, u, h)?.r_mm[0];
                }
                report(cmds.len(), t0, sum);
            }
        }
        "controller" => {
            // The controller alone: the measurements and setpoints of one in-process run
            // fed to a fresh controller (no plant, no importer), `--runs=K`.
            let mut plant = Plant::new(Model::paper(), sim::SEED_START.0, sim::SEED_START.1);
            let mut ctrl = new_ctrl(cfg.clone())?;
            let s = sim::closed_loop(&mut plant, &mut ctrl, &seed_scenario(), false);
            for _ in 0..runs {
                let mut ctrl = new_ctrl(cfg.clone())?;
                let first = &s[0];
                ctrl.reset(sim::SEED_START.0, sim::SEED_START.1, [first.r1_mm, first.r2_mm]);
                let t0 = std::time::Instant::now();
                let mut sum = 0.0;
                for x in &s {
                    sum += ctrl.step([x.r1_mm, x.r2_mm], [x.r1_ref_mm, x.r2_ref_mm]).0;
                }
                report(s.len(), t0, sum);
            }
        }
        "closed-loop" => {
            // The same scenario in process: the controller and the plant without FMI.
            for _ in 0..runs {
                let mut plant = Plant::new(Model::paper(), sim::SEED_START.0, sim::SEED_START.1);
                let mut ctrl = new_ctrl(cfg.clone())?;
                let t0 = std::time::Instant::now();
                let s = sim::closed_loop(&mut plant, &mut ctrl, &seed_scenario(), false);
                report(s.len(), t0, s.last().map_or(f64::NAN, |x| x.r1_mm));
            }
        }
        other => bail!(
            "unknown workload {other}: fmu-const, fmu-change, plant-const, plant-change, terms, tracking, replay, controller, closed-loop"
        ),
    }
    Ok(())
}
