//! Every performance figure of `docs/performance.md` in one run, each beside the yardstick
//! it is judged against, measured in the same run (so the ratios hold on a loaded machine).
//!
//! ```text
//! cargo run --release -- fmu                              # target/fmu/MagSwarm.fmu
//! cargo run --release --example perf_table [-- --calls 20000 --no-fmpy --no-identify]
//! ```
//!
//! The yardstick is `Euler2.fmu` (`benches/fixture/euler2.c`: one forward-Euler step of a
//! two-state ODE per `fmi2DoStep`, no checks), compiled here with the system C compiler and
//! loaded through the same importer as MagSwarm.fmu (`magswarm::cosim`: unzip, XML, dlopen);
//! the loops call the FMI function pointers directly, as a C master does. Figures are medians
//! over repeats. Printed as a markdown table (also written to `target/perf/table.md`).

#[path = "pid_tracking.rs"]
#[allow(dead_code)]
mod pid_tracking;
#[path = "../tests/common/synth.rs"]
mod synth;

use std::f64::consts::TAU;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use magswarm::control::{seed_scenario, sim, PidConfig};
use magswarm::cosim::{Fmu, SlaveOptions};
use magswarm::model::dynamics::InputTerms;
use magswarm::model::maptable::MapTable;
use magswarm::model::{Model, Plant};
use magswarm::perf::raw::{inputs, median, RawLoop, EULER2, MAGSWARM, REPEATS};

/// Largest |r_FMU - r_reference| [mm] over 5 s of formation at constant inputs (8.5 mm, 4 Hz)
/// from r = (3, 4) mm, sampled at every communication point of step h; the reference is the
/// in-process plant at rtol 1e-13, atol 1e-15.
fn global_error(fmu: &Fmu, h: f64) -> Result<f64> {
    let (z, w) = (8.5e-3, 4.0 * TAU);
    let r0 = [3.0, 4.0];
    let mut s = fmu.instantiate("accuracy", SlaveOptions::default())?;
    s.setup_experiment(None, 0.0, None)?;
    s.enter_initialization_mode()?;
    s.set_boolean_by_name("settle_at_start", false)?;
    s.set_real_by_name("r1_start", r0[0] * 1e-3)?;
    s.set_real_by_name("r2_start", r0[1] * 1e-3)?;
    s.set_real_by_name("z_m", z)?;
    s.set_real_by_name("omega_m", w)?;
    s.exit_initialization_mode()?;
    let mut reference = Plant::new(Model::paper(), z, w);
    reference.set_state(r0);
    {
        let tol = reference.tolerances_mut();
        tol.rtol = 1e-13;
        tol.atol = 1e-15;
    }
    let n = (5.0 / h).round() as usize;
    let mut worst: f64 = 0.0;
    let mut t = 0.0;
    for _ in 0..n {
        s.do_step(t, h)?;
        t += h;
        reference.step(h).context("reference plant")?;
        let y = s.get_reals_by_name(&["r1", "r2"])?;
        let r = reference.state();
        worst = worst
            .max((y[0] * 1e3 - r[0]).abs())
            .max((y[1] * 1e3 - r[1]).abs());
    }
    Ok(worst)
}

/// ns per `InputTerms::new` (stiffness (7), map (5)-(6), scheduled gains and their
/// derivatives): the work of one input change; with `map`, the map from its tables.
fn input_change_ns(calls: usize, map: Option<&MapTable>) -> f64 {
    let m = Model::paper();
    let mut k = 0usize;
    median(
        (0..REPEATS)
            .map(|_| {
                let t0 = Instant::now();
                for _ in 0..calls {
                    k += 1;
                    let u = inputs(k as f64 * 1e-3);
                    black_box(InputTerms::with_map(
                        &m,
                        black_box(u[0]),
                        black_box(u[1]),
                        map,
                    ));
                }
                t0.elapsed().as_nanos() as f64 / calls as f64
            })
            .collect(),
    )
}

/// ns per in-process `Plant::step(h)` (no FMI shell): at constant inputs with the swarm
/// formed, and with `set_inputs` to a new value before every step (the map from its table,
/// as in the FMU).
fn plant_ns(calls: usize, h: f64) -> (f64, f64) {
    let mut p = Plant::new(Model::paper(), 8.5e-3, 4.0 * TAU);
    p.use_map_table(true);
    let time = |p: &mut Plant, change: bool| {
        let mut t = 0.0;
        median(
            (0..REPEATS)
                .map(|_| {
                    let t0 = Instant::now();
                    for _ in 0..calls {
                        if change {
                            let u = inputs(t);
                            p.set_inputs(u[0], u[1]);
                        }
                        p.step(h).expect("plant step");
                        t += h;
                    }
                    t0.elapsed().as_nanos() as f64 / calls as f64
                })
                .collect(),
        )
    };
    let rest = time(&mut p, false);
    let change = time(&mut p, true);
    (rest, change)
}

/// ns per Model Exchange right-hand side evaluation (what an importer's integrator calls per
/// stage: set time, set all six states, get their derivatives), through the shell's entry
/// points in process (the exported C symbols forward to these same functions); at constant
/// inputs and with `fmi2SetReal` of a new z_m before every evaluation.
fn me_rhs_ns(calls: usize) -> (f64, f64) {
    use magswarm_fmi2::abi::FMI2_MODEL_EXCHANGE;
    use magswarm_fmi2::host::Host;
    use magswarm_fmi2::shell;
    type M = magswarm_fmu::MagSwarm;
    const N: usize = magswarm_fmu::vr::STATES.len();
    let h = Host::<M>::instantiate_as("perf", None, FMI2_MODEL_EXCHANGE).expect("ME instance");
    assert_eq!(h.init(0.0), magswarm_fmi2::Fmi2Status::Ok);
    h.new_discrete_states();
    h.enter_continuous_time_mode();
    let (st, x0) = h.get_states(N);
    assert_eq!(st, magswarm_fmi2::Fmi2Status::Ok);
    let c = h.component();
    let time = |change: bool| {
        let mut k = 0usize;
        let mut x: [f64; N] = x0.clone().try_into().expect("six states");
        let mut dx = [0.0; N];
        median(
            (0..REPEATS)
                .map(|_| {
                    let t0 = Instant::now();
                    for _ in 0..calls {
                        k += 1;
                        let t = k as f64 * 1e-4;
                        // SAFETY: a live ME instance in continuous-time mode; arrays of N.
                        unsafe {
                            if change {
                                let z = inputs(t)[0];
                                shell::fmi2_set_real::<M>(c, &magswarm_fmu::vr::Z_M, 1, &z);
                            }
                            shell::fmi2_set_time::<M>(c, t);
                            shell::fmi2_set_continuous_states::<M>(c, x.as_ptr(), N);
                            let s = shell::fmi2_get_derivatives::<M>(c, dx.as_mut_ptr(), N);
                            assert_eq!(s, magswarm_fmi2::Fmi2Status::Ok);
                        }
                        x[0] += 1e-9 * black_box(dx[0]).signum();
                    }
                    t0.elapsed().as_nanos() as f64 / calls as f64
                })
                .collect(),
        )
    };
    let constant = time(false);
    let change = time(true);
    (constant, change)
}

/// The figures of [`tracking`]: seconds through the FMU (instances of an FMU already used in
/// this process, whose map-table cells its earlier instances built), through a freshly
/// loaded copy of the FMU (its first run builds the cells it visits, as a user's first run
/// does), in process; and the samples of a run.
struct Tracking {
    via_fmu: f64,
    first_run: f64,
    in_process: f64,
    rows: usize,
}

/// Seconds for the seed's 180 s scenario at 1 kHz through the FMU harness
/// (examples/pid_tracking.rs) and in-process (magswarm_control::sim::closed_loop): the median
/// of three runs, each with a fresh FMU instance and a fresh controller, after one untimed
/// run of each (the process's warm-up: right after the fmpy rows' subprocess the first runs
/// read 40-57 ms where later ones read 30 ms). The instances of one loaded FMU share their
/// map-table cells (`MapTable::shared`), so these runs find built the cells the earlier
/// ones visited; `first_run` is the median of three first runs, each on a copy of the FMU
/// loaded anew (`path`: a new library with no cells built; the loading is not timed).
fn tracking(fmu: &Fmu, path: &Path) -> Result<Tracking> {
    let model = Model::paper();
    let cfg = PidConfig {
        sample_time_s: 0.001,
        ..PidConfig::default()
    };
    let segs = seed_scenario();
    black_box(pid_tracking::run(
        fmu,
        &model,
        &cfg,
        &segs,
        sim::SEED_START,
    )?);
    {
        let mut plant = Plant::new(model.clone(), sim::SEED_START.0, sim::SEED_START.1);
        let mut ctrl = magswarm::control::Controller::new(model.clone(), cfg.clone())?;
        black_box(sim::closed_loop(&mut plant, &mut ctrl, &segs, false));
    }
    let mut rows = 0;
    let mut via_fmu = Vec::new();
    for _ in 0..3 {
        let t0 = Instant::now();
        let run = pid_tracking::run(fmu, &model, &cfg, &segs, sim::SEED_START)?;
        via_fmu.push(t0.elapsed().as_secs_f64());
        rows = run.samples.len();
    }
    let mut first_run = Vec::new();
    for _ in 0..3 {
        let fresh = Fmu::load(path).with_context(|| format!("load {}", path.display()))?;
        let t0 = Instant::now();
        black_box(pid_tracking::run(
            &fresh,
            &model,
            &cfg,
            &segs,
            sim::SEED_START,
        )?);
        first_run.push(t0.elapsed().as_secs_f64());
    }
    let mut in_process = Vec::new();
    for _ in 0..3 {
        let t0 = Instant::now();
        let mut plant = Plant::new(model.clone(), sim::SEED_START.0, sim::SEED_START.1);
        let mut ctrl = magswarm::control::Controller::new(model.clone(), cfg.clone())?;
        black_box(sim::closed_loop(&mut plant, &mut ctrl, &segs, false));
        in_process.push(t0.elapsed().as_secs_f64());
    }
    Ok(Tracking {
        via_fmu: median(via_fmu),
        first_run: median(first_run),
        in_process: median(in_process),
        rows,
    })
}

/// The largest proven bound of the map table on r1, r2 over the validated envelope and the
/// largest difference from the exact map, on a 401 x 361 grid of points between nodes.
fn map_table_bound(t: &MapTable) -> (f64, f64) {
    let m = Model::paper();
    let e = m.envelope;
    let (mut bound, mut seen) = (0.0f64, 0.0f64);
    for i in 0..401 {
        for j in 0..361 {
            let z = e.z_min_m + (e.z_max_m - e.z_min_m) * (i as f64 + 0.29) / 401.0;
            let f = e.f_min_hz + (e.f_max_hz - e.f_min_hz) * (j as f64 + 0.61) / 361.0;
            let w = f * TAU;
            let Some(b) = t.bound(&m, z, w) else {
                return (f64::INFINITY, f64::NAN);
            };
            let (a, x) = (
                t.evaluate(&m, z, w),
                magswarm::model::steady::evaluate(&m, z, w),
            );
            bound = bound.max(b[0]).max(b[1]);
            seen = seen.max((a.r1 - x.r1).abs()).max((a.r2 - x.r2).abs());
        }
    }
    (bound, seen)
}

fn identify_s() -> Result<(f64, usize)> {
    let log = synth::log(&synth::Spec::seed_like(synth::perturbed_truth(), 77));
    let cfg = magswarm::identify::Config::default();
    let mut v = Vec::new();
    for _ in 0..4 {
        let t0 = Instant::now();
        black_box(magswarm::identify::identify(
            std::slice::from_ref(&log),
            &Model::paper(),
            &cfg,
        )?);
        v.push(t0.elapsed().as_secs_f64());
    }
    v.remove(0); // warm-up
    Ok((median(v), log.rows.len()))
}

/// The fmpy loops (examples/bench_fmpy.py), as name/case/h -> ns.
fn fmpy(python: &Path, fmu: &Path, fixture: &Path, calls: usize) -> Result<serde_json::Value> {
    let out = Command::new(python)
        .arg("examples/bench_fmpy.py")
        .arg("--fmu")
        .arg(fmu)
        .arg("--fixture")
        .arg(fixture)
        .args(["--calls", &calls.to_string(), "--json"])
        .output()
        .with_context(|| format!("cannot run {}", python.display()))?;
    if !out.status.success() {
        bail!(
            "examples/bench_fmpy.py failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    Ok(serde_json::from_slice(&out.stdout)?)
}

struct Table(String);

impl Table {
    fn row(&mut self, cells: &[String]) {
        let line = format!("| {} |\n", cells.join(" | "));
        print!("{line}");
        self.0.push_str(&line);
    }
}

fn verdict(ok: bool) -> String {
    if ok { "met" } else { "NOT met" }.to_string()
}

fn main() -> Result<()> {
    let mut fmu_path = PathBuf::from("target/fmu/MagSwarm.fmu");
    let mut fmu3_path = PathBuf::from("target/fmu/fmi3/MagSwarm.fmu");
    let mut calls = 20_000usize;
    let mut with_fmpy = true;
    let mut with_identify = true;
    let mut python = PathBuf::from(".venv/bin/python");
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--fmu" => fmu_path = args.next().context("--fmu PATH")?.into(),
            "--fmu3" => fmu3_path = args.next().context("--fmu3 PATH")?.into(),
            "--calls" => calls = args.next().context("--calls N")?.parse()?,
            "--python" => python = args.next().context("--python PATH")?.into(),
            "--no-fmpy" => with_fmpy = false,
            "--no-identify" => with_identify = false,
            "-h" | "--help" => {
                println!(
                    "perf_table [--fmu PATH] [--fmu3 PATH] [--calls N] [--python PATH] [--no-fmpy] [--no-identify]"
                );
                return Ok(());
            }
            _ => {} // `cargo bench` passes --bench
        }
    }
    if !fmu_path.is_file() {
        bail!(
            "{} not found: build it with `cargo run --release -- fmu`",
            fmu_path.display()
        );
    }
    let fixture_path = magswarm::perf::fixture::build(Path::new("target/perf"))?;
    let fmu = Fmu::load(&fmu_path).context("load MagSwarm.fmu")?;
    let fixture = Fmu::load(&fixture_path).context("load Euler2.fmu")?;
    // The FMI 3.0 plant, when packaged (`magswarm fmu --fmi-version 3`).
    let fmu3 = if fmu3_path.is_file() {
        Some(Fmu::load(&fmu3_path).context("load the FMI 3.0 MagSwarm.fmu")?)
    } else {
        eprintln!(
            "{} not found: FMI 3.0 rows skipped (`cargo run --release -- fmu --fmi-version 3`)",
            fmu3_path.display()
        );
        None
    };

    let mut t = Table(String::new());
    println!(
        "MagSwarm.fmu ({}) against Euler2.fmu ({}), {calls} calls x {REPEATS} repeats, median\n",
        fmu_path.display(),
        fixture_path.display()
    );
    t.row(&[
        "figure".into(),
        "MagSwarm".into(),
        "Euler2 yardstick".into(),
        "ratio".into(),
        "target".into(),
        "status".into(),
    ]);
    t.row(&vec!["---".to_string(); 6]);

    // Interleave MagSwarm and the yardstick per figure so that load changes hit both.
    for h in [0.01, 0.001] {
        let ms = RawLoop::new(&fmu, MAGSWARM, h)?.time(calls, RawLoop::step);
        let fx = RawLoop::new(&fixture, EULER2, h)?.time(calls, RawLoop::step);
        let err = global_error(&fmu, h)?;
        t.row(&[
            format!(
                "doStep, constant inputs, swarm formed (at rest: the FMU replays its last step), h = {} ms (global error {err:.1e} mm)",
                h * 1e3
            ),
            format!("{ms:.0} ns"),
            format!("{fx:.1} ns"),
            format!("{:.1}x", ms / fx),
            "<= 3x".into(),
            verdict(ms / fx <= 3.0),
        ]);
    }
    // The rows above run a formed swarm at constant inputs: after the first steps the state
    // sits on a bitwise fixed point of the integrator and the FMU replays its last
    // communication step (a memo). A doStep during a transient pays real integration steps:
    // the same inputs, from r = (3, 4) mm, timed over the first 2 s of formation.
    for h in [0.01, 0.001] {
        let n = (2.0 / h) as usize;
        let start = [("r1_start", 3.0e-3), ("r2_start", 4.0e-3)];
        let ms = RawLoop::time_fresh(
            n,
            || RawLoop::with_start(&fmu, MAGSWARM, h, &start, &[("settle_at_start", false)]),
            RawLoop::step,
        )?;
        let fx = RawLoop::time_fresh(n, || RawLoop::new(&fixture, EULER2, h), RawLoop::step)?;
        t.row(&[
            format!(
                "doStep, constant inputs, during a transient (first 2 s of formation from r = (3, 4) mm, no memo hits), h = {} ms",
                h * 1e3
            ),
            format!("{ms:.0} ns"),
            format!("{fx:.1} ns"),
            format!("{:.1}x", ms / fx),
            "-".into(),
            "reported".into(),
        ]);
    }
    for h in [0.01, 0.001] {
        let (rest, change) = plant_ns(calls, h);
        t.row(&[
            format!(
                "in-process Plant::step (no FMI, map table), h = {} ms: constant inputs at rest (memo) / input change",
                h * 1e3
            ),
            format!("{rest:.0} ns / {change:.0} ns"),
            "-".into(),
            "-".into(),
            "-".into(),
            "reported".into(),
        ]);
    }
    let mut change = Vec::new();
    for h in [0.01, 0.001] {
        let ms = RawLoop::new(&fmu, MAGSWARM, h)?.time(calls, RawLoop::set_step_get);
        let fx = RawLoop::new(&fixture, EULER2, h)?.time(calls, RawLoop::set_step_get);
        t.row(&[
            format!(
                "set + doStep + get, input change every call, h = {} ms",
                h * 1e3
            ),
            format!("{ms:.0} ns"),
            format!("{fx:.1} ns"),
            format!("{:.1}x", ms / fx),
            "<= 10x".into(),
            verdict(ms / fx <= 10.0),
        ]);
        let set_step = RawLoop::new(&fmu, MAGSWARM, h)?.time(calls, RawLoop::set_step);
        let step = RawLoop::new(&fmu, MAGSWARM, h)?.time(calls, RawLoop::step);
        change.push(set_step - step);
    }
    if let Some(fmu3) = &fmu3 {
        for h in [0.01, 0.001] {
            let c3 = RawLoop::new(fmu3, MAGSWARM, h)?.time(calls, RawLoop::step);
            let cfx = RawLoop::new(&fixture, EULER2, h)?.time(calls, RawLoop::step);
            let m3 = RawLoop::new(fmu3, MAGSWARM, h)?.time(calls, RawLoop::set_step_get);
            let mfx = RawLoop::new(&fixture, EULER2, h)?.time(calls, RawLoop::set_step_get);
            t.row(&[
                format!(
                    "FMI 3.0: doStep constant / set + doStep + get input change, h = {} ms",
                    h * 1e3
                ),
                format!("{c3:.0} ns / {m3:.0} ns"),
                format!("{cfx:.1} ns / {mfx:.1} ns"),
                format!("{:.1}x / {:.1}x", c3 / cfx, m3 / mfx),
                "<= 3x / <= 10x".into(),
                verdict(c3 / cfx <= 3.0 && m3 / mfx <= 10.0),
            ]);
        }
    }
    let (rhs_const, rhs_change) = me_rhs_ns(calls);
    t.row(&[
        "Model Exchange right-hand side, 6 states (fmi2SetTime + fmi2SetContinuousStates + fmi2GetDerivatives, in process through the shell; the states move every call, no memo): constant inputs / input change every call".into(),
        format!("{rhs_const:.0} ns / {rhs_change:.0} ns"),
        "-".into(),
        "-".into(),
        "-".into(),
        "reported".into(),
    ]);
    let ic = input_change_ns(calls, None);
    let table = MapTable::new(&Model::paper()).context("the paper model's map is tabulable")?;
    let ict = input_change_ns(calls, Some(&table));
    // Every cell (a loop visits only its own): the time to prove the whole table.
    let t0 = Instant::now();
    let (zc, wc) = MapTable::new(&Model::paper())
        .context("the paper model's map is tabulable")?
        .coverage();
    let build = t0.elapsed().as_secs_f64();
    t.row(&[
        "one input change: InputTerms::new (stiffness, map, scheduled gains): exact map / map table (what the FMU uses after 16 384 input changes)".into(),
        format!("{ic:.0} ns / {ict:.0} ns"),
        "-".into(),
        "-".into(),
        "reported".into(),
        format!(
            "through the FMU: setReal+doStep - doStep = {:.0} ns (10 ms), {:.0} ns (1 ms)",
            change[0], change[1]
        ),
    ]);

    let (bound, observed) = map_table_bound(&table);
    t.row(&[
        "map table of the paper model: every cell built and proven; cells interpolated (depth, frequency); proven bound on r1, r2 over the envelope / largest difference from the exact map (401 x 361 points)".into(),
        format!(
            "{:.1} ms; {}/{}, {}/{}; {bound:.1e} mm / {observed:.1e} mm",
            build * 1e3,
            zc[1],
            zc[0],
            wc[1],
            wc[0]
        ),
        "-".into(),
        "-".into(),
        "<= 1e-9 mm".into(),
        if bound <= 1e-9 { "met" } else { "NOT met" }.into(),
    ]);

    if with_fmpy {
        match fmpy(&python, &fmu_path, &fixture_path, calls) {
            Ok(v) => {
                for (case, label) in [
                    (
                        "const",
                        "fmpy: doStep, constant inputs, swarm at rest (memo)",
                    ),
                    ("closed", "fmpy: setReal + doStep + getReal, input change"),
                ] {
                    for h in ["0.01", "0.001"] {
                        let m = v[format!("MagSwarm/{case}/{h}")]
                            .as_f64()
                            .unwrap_or(f64::NAN);
                        let e = v[format!("Euler2/{case}/{h}")].as_f64().unwrap_or(f64::NAN);
                        let hms = h.parse::<f64>()? * 1e3;
                        t.row(&[
                            format!("{label}, h = {hms} ms"),
                            format!("{m:.0} ns"),
                            format!("{e:.0} ns"),
                            format!("{:.3}x", m / e),
                            "<= 1.05x".into(),
                            verdict(m / e <= 1.05),
                        ]);
                    }
                }
            }
            Err(e) => t.row(&[
                "fmpy loops".into(),
                "-".into(),
                "-".into(),
                "-".into(),
                "<= 1.05x".into(),
                {
                    eprintln!("fmpy loops not measured: {e:#}");
                    "not measured (see stderr)".into()
                },
            ]),
        }
    }

    let tr = tracking(&fmu, &fmu_path)?;
    t.row(&[
        format!(
            "seed tracking scenario, 180 s at 1 kHz ({} samples), FMU + Rust PID harness: a new instance of an FMU already used in the process (map-table cells shared) / first run after loading the FMU",
            tr.rows
        ),
        format!("{:.1} ms / {:.1} ms", tr.via_fmu * 1e3, tr.first_run * 1e3),
        "-".into(),
        "-".into(),
        "<= 20 ms".into(),
        format!(
            "{} / {}",
            verdict(tr.via_fmu <= 0.020),
            verdict(tr.first_run <= 0.020)
        ),
    ]);
    if let Some(fmu3) = &fmu3 {
        let tr3 = tracking(fmu3, &fmu3_path)?;
        t.row(&[
            "same, FMI 3.0 FMU".into(),
            format!(
                "{:.1} ms / {:.1} ms",
                tr3.via_fmu * 1e3,
                tr3.first_run * 1e3
            ),
            "-".into(),
            "-".into(),
            "<= 20 ms".into(),
            format!(
                "{} / {}",
                verdict(tr3.via_fmu <= 0.020),
                verdict(tr3.first_run <= 0.020)
            ),
        ]);
    }
    t.row(&[
        "same, in-process plant (magswarm_control::sim::closed_loop)".into(),
        format!("{:.1} ms", tr.in_process * 1e3),
        "-".into(),
        "-".into(),
        "-".into(),
        "reported".into(),
    ]);
    if with_identify {
        let (s, n) = identify_s()?;
        t.row(&[
            format!("identify, {n} rows (8 starts + 200 bootstrap)"),
            format!("{s:.3} s"),
            "-".into(),
            "-".into(),
            "< 0.5 s".into(),
            verdict(s < 0.5),
        ]);
    }
    t.row(&[
        "diagnose, 500 rows, every candidate".into(),
        "-".into(),
        "-".into(),
        "-".into(),
        "< 5 s".into(),
        "not here: `cargo run --release --example bench_diagnose`".into(),
    ]);
    std::fs::write("target/perf/table.md", &t.0)?;
    println!("\n(table also in target/perf/table.md)");
    Ok(())
}
