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
use magswarm::cosim::{Fmu, FmuSlave, SlaveOptions};
use magswarm::model::dynamics::InputTerms;
use magswarm::model::{Model, Plant};

const REPEATS: usize = 7;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Inputs at time t: z_m 8.5 +- 2 mm, f 4 +- 1 Hz at 0.2 Hz (a new value every call).
fn inputs(t: f64) -> [f64; 2] {
    let s = (TAU * 0.2 * t).sin();
    [8.5e-3 + 2.0e-3 * s, (4.0 + s) * TAU]
}

type DoStep = unsafe extern "C" fn(*mut std::ffi::c_void, f64, f64, i32) -> i32;
type SetReal = unsafe extern "C" fn(*mut std::ffi::c_void, *const u32, usize, *const f64) -> i32;
type GetReal = unsafe extern "C" fn(*mut std::ffi::c_void, *const u32, usize, *mut f64) -> i32;

/// One initialised instance and its raw FMI function pointers.
struct Raw {
    slave: FmuSlave,
    do_step: DoStep,
    set_real: SetReal,
    get_real: GetReal,
    ins: [u32; 2],
    outs: [u32; 2],
    t: f64,
    h: f64,
}

impl Raw {
    fn new(fmu: &Fmu, names: [&str; 4], h: f64) -> Result<Raw> {
        let mut slave = fmu.instantiate("bench", SlaveOptions::default())?;
        let ins = [fmu.real_vr(names[0])?, fmu.real_vr(names[1])?];
        let outs = [fmu.real_vr(names[2])?, fmu.real_vr(names[3])?];
        slave.setup_experiment(None, 0.0, None)?;
        slave.enter_initialization_mode()?;
        slave.set_real(&ins, &inputs(0.0))?;
        slave.exit_initialization_mode()?;
        let b = slave.raw_binding();
        let (Ok(d), Ok(s), Ok(g)) = (&b.fmi2DoStep, &b.fmi2SetReal, &b.fmi2GetReal) else {
            bail!(
                "{}: fmi2DoStep/SetReal/GetReal missing",
                fmu.path().display()
            );
        };
        // SAFETY: the binding's function types are these C signatures (fmi2Functions.h).
        // (The source types are the bindings' generated ones, named by inference.)
        #[allow(clippy::missing_transmute_annotations)]
        let (do_step, set_real, get_real) = unsafe {
            (
                std::mem::transmute::<_, DoStep>(*d),
                std::mem::transmute::<_, SetReal>(*s),
                std::mem::transmute::<_, GetReal>(*g),
            )
        };
        Ok(Raw {
            slave,
            do_step,
            set_real,
            get_real,
            ins,
            outs,
            t: 0.0,
            h,
        })
    }

    /// ns per call of `f`, median of REPEATS loops of `calls` calls after a warm-up.
    fn time(&mut self, calls: usize, f: fn(&mut Raw)) -> f64 {
        for _ in 0..calls / 10 {
            f(self);
        }
        median(
            (0..REPEATS)
                .map(|_| {
                    let t0 = Instant::now();
                    for _ in 0..calls {
                        f(self);
                    }
                    t0.elapsed().as_nanos() as f64 / calls as f64
                })
                .collect(),
        )
    }

    fn step(&mut self) {
        let c = self.slave.component();
        // SAFETY: a live, initialised instance of this library.
        let s = unsafe { (self.do_step)(c, self.t, self.h, 1) };
        assert!(s <= 1, "fmi2DoStep returned {s}");
        self.t += self.h;
    }

    fn set_step(&mut self) {
        let u = inputs(self.t);
        let c = self.slave.component();
        // SAFETY: live instance, arrays of 2.
        let s = unsafe { (self.set_real)(c, self.ins.as_ptr(), 2, u.as_ptr()) };
        assert!(s <= 1, "fmi2SetReal returned {s}");
        self.step();
    }

    fn set_step_get(&mut self) {
        self.set_step();
        let mut y = [0.0; 2];
        let c = self.slave.component();
        // SAFETY: live instance, arrays of 2.
        let s = unsafe { (self.get_real)(c, self.outs.as_ptr(), 2, y.as_mut_ptr()) };
        assert!(s <= 1, "fmi2GetReal returned {s}");
        black_box(y);
    }
}

const MAGSWARM: [&str; 4] = ["z_m", "omega_m", "r1", "r2"];
const EULER2: [&str; 4] = ["u1", "u2", "x1", "x2"];

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
/// derivatives): the work of one input change.
fn input_change_ns(calls: usize) -> f64 {
    let m = Model::paper();
    let mut k = 0usize;
    median(
        (0..REPEATS)
            .map(|_| {
                let t0 = Instant::now();
                for _ in 0..calls {
                    k += 1;
                    let u = inputs(k as f64 * 1e-3);
                    black_box(InputTerms::new(&m, black_box(u[0]), black_box(u[1])));
                }
                t0.elapsed().as_nanos() as f64 / calls as f64
            })
            .collect(),
    )
}

/// ns per in-process `Plant::step(h)` (no FMI shell): at constant inputs with the swarm
/// formed, and with `set_inputs` to a new value before every step.
fn plant_ns(calls: usize, h: f64) -> (f64, f64) {
    let mut p = Plant::new(Model::paper(), 8.5e-3, 4.0 * TAU);
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
/// stage: set time, set states, get derivatives), through the shell's entry points in process
/// (the exported C symbols forward to these same functions); at constant inputs and with
/// `fmi2SetReal` of a new z_m before every evaluation.
fn me_rhs_ns(calls: usize) -> (f64, f64) {
    use magswarm_fmi2::abi::FMI2_MODEL_EXCHANGE;
    use magswarm_fmi2::host::Host;
    let h = Host::<magswarm_fmu::MagSwarm>::instantiate_as("perf", None, FMI2_MODEL_EXCHANGE)
        .expect("ME instance");
    assert_eq!(h.init(0.0), magswarm_fmi2::Fmi2Status::Ok);
    h.new_discrete_states();
    h.enter_continuous_time_mode();
    let c = h.component();
    let time = |change: bool| {
        let mut k = 0usize;
        let mut x = [8.4e-3, 12.0e-3];
        let mut dx = [0.0; 2];
        median(
            (0..REPEATS)
                .map(|_| {
                    let t0 = Instant::now();
                    for _ in 0..calls {
                        k += 1;
                        let t = k as f64 * 1e-4;
                        // SAFETY: a live ME instance in continuous-time mode; arrays of 2.
                        unsafe {
                            if change {
                                let z = inputs(t)[0];
                                magswarm_fmi2::shell::fmi2_set_real::<magswarm_fmu::MagSwarm>(
                                    c,
                                    &magswarm_fmu::vr::Z_M,
                                    1,
                                    &z,
                                );
                            }
                            magswarm_fmi2::shell::fmi2_set_time::<magswarm_fmu::MagSwarm>(c, t);
                            magswarm_fmi2::shell::fmi2_set_continuous_states::<
                                magswarm_fmu::MagSwarm,
                            >(c, x.as_ptr(), 2);
                            magswarm_fmi2::shell::fmi2_get_derivatives::<magswarm_fmu::MagSwarm>(
                                c,
                                dx.as_mut_ptr(),
                                2,
                            );
                        }
                        x[0] += 1e-7 * black_box(dx[0]).signum();
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

/// Seconds for the seed's 180 s scenario at 1 kHz through the FMU harness
/// (examples/pid_tracking.rs) and in-process (magswarm_control::sim::closed_loop).
fn tracking(fmu: &Fmu) -> Result<(f64, f64, usize)> {
    let model = Model::paper();
    let cfg = PidConfig {
        sample_time_s: 0.001,
        ..PidConfig::default()
    };
    let segs = seed_scenario();
    let mut rows = 0;
    let mut via_fmu = Vec::new();
    for _ in 0..3 {
        let t0 = Instant::now();
        let run = pid_tracking::run(fmu, &model, &cfg, &segs, sim::SEED_START)?;
        via_fmu.push(t0.elapsed().as_secs_f64());
        rows = run.samples.len();
    }
    let mut in_process = Vec::new();
    for _ in 0..3 {
        let t0 = Instant::now();
        let mut plant = Plant::new(model.clone(), sim::SEED_START.0, sim::SEED_START.1);
        let mut ctrl = magswarm::control::Controller::new(model.clone(), cfg.clone())?;
        black_box(sim::closed_loop(&mut plant, &mut ctrl, &segs, false));
        in_process.push(t0.elapsed().as_secs_f64());
    }
    Ok((median(via_fmu), median(in_process), rows))
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
    let mut calls = 20_000usize;
    let mut with_fmpy = true;
    let mut with_identify = true;
    let mut python = PathBuf::from(".venv/bin/python");
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--fmu" => fmu_path = args.next().context("--fmu PATH")?.into(),
            "--calls" => calls = args.next().context("--calls N")?.parse()?,
            "--python" => python = args.next().context("--python PATH")?.into(),
            "--no-fmpy" => with_fmpy = false,
            "--no-identify" => with_identify = false,
            "-h" | "--help" => {
                println!(
                    "perf_table [--fmu PATH] [--calls N] [--python PATH] [--no-fmpy] [--no-identify]"
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
        let ms = Raw::new(&fmu, MAGSWARM, h)?.time(calls, Raw::step);
        let fx = Raw::new(&fixture, EULER2, h)?.time(calls, Raw::step);
        let err = global_error(&fmu, h)?;
        t.row(&[
            format!(
                "doStep, constant inputs, h = {} ms (global error {err:.1e} mm)",
                h * 1e3
            ),
            format!("{ms:.0} ns"),
            format!("{fx:.1} ns"),
            format!("{:.1}x", ms / fx),
            "<= 3x".into(),
            verdict(ms / fx <= 3.0),
        ]);
    }
    for h in [0.01, 0.001] {
        let (rest, change) = plant_ns(calls, h);
        t.row(&[
            format!(
                "in-process Plant::step (no FMI), h = {} ms: constant / input change",
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
        let ms = Raw::new(&fmu, MAGSWARM, h)?.time(calls, Raw::set_step_get);
        let fx = Raw::new(&fixture, EULER2, h)?.time(calls, Raw::set_step_get);
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
        let set_step = Raw::new(&fmu, MAGSWARM, h)?.time(calls, Raw::set_step);
        let step = Raw::new(&fmu, MAGSWARM, h)?.time(calls, Raw::step);
        change.push(set_step - step);
    }
    let (rhs_const, rhs_change) = me_rhs_ns(calls);
    t.row(&[
        "Model Exchange right-hand side (fmi2SetTime + fmi2SetContinuousStates + fmi2GetDerivatives, in process through the shell): constant inputs / input change every call".into(),
        format!("{rhs_const:.0} ns / {rhs_change:.0} ns"),
        "-".into(),
        "-".into(),
        "-".into(),
        "reported".into(),
    ]);
    let ic = input_change_ns(calls);
    t.row(&[
        "one input change: InputTerms::new (stiffness, map, scheduled gains)".into(),
        format!("{ic:.0} ns"),
        "-".into(),
        "-".into(),
        "reported".into(),
        format!(
            "through the FMU: setReal+doStep - doStep = {:.0} ns (10 ms), {:.0} ns (1 ms)",
            change[0], change[1]
        ),
    ]);

    if with_fmpy {
        match fmpy(&python, &fmu_path, &fixture_path, calls) {
            Ok(v) => {
                for (case, label) in [
                    ("const", "fmpy: doStep, constant inputs"),
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

    let (via_fmu, in_proc, rows) = tracking(&fmu)?;
    t.row(&[
        format!("seed tracking scenario, 180 s at 1 kHz ({rows} samples), FMU + Rust PID harness"),
        format!("{:.1} ms", via_fmu * 1e3),
        "-".into(),
        "-".into(),
        "< 20 ms".into(),
        verdict(via_fmu < 0.020),
    ]);
    t.row(&[
        "same, in-process plant (magswarm_control::sim::closed_loop)".into(),
        format!("{:.1} ms", in_proc * 1e3),
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
        "pending: `magswarm diagnose` is not in main yet".into(),
    ]);
    std::fs::write("target/perf/table.md", &t.0)?;
    println!("\n(table also in target/perf/table.md)");
    Ok(())
}
