//! `magswarm-bridge`: run, check, emulate, measure, fmu.

mod package_fmu;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use magswarm_bridge::config::RigConfig;
use magswarm_bridge::run::{self, RunOptions, Signals};
use magswarm_bridge::safety::FaultLatch;

#[derive(Parser)]
#[command(
    name = "magswarm-bridge",
    version,
    about = "The magswarm plant interface on the real rig (UR e-Series over RTDE, TMCL stepper, camera), and emulators of it"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Run a plan of inputs or the PID on setpoints on the rig; write the measurement log.
    Run {
        /// Rig configuration (TOML).
        #[arg(long)]
        config: PathBuf,
        /// Plan of inputs: CSV `t_s,z_m_mm,f_hz` (a row applies until the next).
        #[arg(long, conflicts_with = "targets")]
        plan: Option<PathBuf>,
        /// Setpoints for the PID: CSV `t_s,r1_ref_mm,r2_ref_mm`.
        #[arg(long)]
        targets: Option<PathBuf>,
        /// The measurement log to write (CSV).
        #[arg(long)]
        log: PathBuf,
        /// Run length [s] (default: the last row lasts as long as the one before it).
        #[arg(long)]
        duration: Option<f64>,
        /// Talk to no actuator (camera and models only).
        #[arg(long)]
        dry_run: bool,
    },
    /// Probe each device and print what it found (moves nothing).
    Check {
        /// Rig configuration (TOML).
        #[arg(long)]
        config: PathBuf,
    },
    /// Serve emulated devices as the config describes; prints where each listens.
    Emulate {
        /// Rig configuration (TOML).
        #[arg(long)]
        config: PathBuf,
        /// Stop after this many seconds (default: until SIGINT/SIGTERM).
        #[arg(long)]
        duration: Option<f64>,
        /// Write every TMCL instruction the emulated stepper receives to this CSV
        /// (`t_unix_s,instruction,type,value`, appended within 20 ms), for tests and demos.
        #[arg(long)]
        trace: Option<PathBuf>,
    },
    /// Build MagSwarmRig.fmu: the rig as an FMI 2.0 Co-Simulation FMU (MagSwarm.fmu's
    /// variables, doStep paced to the wall clock), with the config baked in.
    Fmu {
        /// Rig configuration (TOML) to bake into the FMU.
        #[arg(long)]
        config: PathBuf,
        /// The FMU to write.
        #[arg(long, default_value = "MagSwarmRig.fmu")]
        out: PathBuf,
        /// The compiled rig FMU library (default: build it with cargo in a source tree, or
        /// take libmagswarm_rig_fmu.so beside this executable; or $MAGSWARM_RIG_FMU_LIB).
        #[arg(long)]
        lib: Option<PathBuf>,
        /// Do not run cargo; package the library found beside this executable.
        #[arg(long)]
        no_build: bool,
        /// The stepper watchdog program to ship (default: beside this executable).
        #[arg(long)]
        watchdog: Option<PathBuf>,
    },
    /// Re-measure a recorded frame folder: one row per frame.
    Measure {
        /// Frame folder (PNG files and index.csv with t_s,file).
        #[arg(long)]
        frames: PathBuf,
        /// Pixel size in the swarm's plane [mm].
        #[arg(long)]
        mm_per_px: f64,
        /// Output CSV: t_s,file,r1_mm,r2_mm,angle_deg,cx_px,cy_px,valid.
        #[arg(long)]
        out: PathBuf,
        /// Optional rig config whose [vision] section (threshold, invert, roi) applies.
        #[arg(long)]
        config: Option<PathBuf>,
    },
}

fn load(path: &Path) -> Result<RigConfig, String> {
    let c = RigConfig::load(path).map_err(|e| e.to_string())?;
    for k in c.unknown_keys() {
        eprintln!(
            "magswarm-bridge: warning: {}: unknown key `{k}` (kept, not used)",
            path.display()
        );
    }
    Ok(c)
}

fn main() -> ExitCode {
    // The library reports through `log`; the program prints it on stderr (level from
    // $MAGSWARM_LOG: error, warn, info (default), debug, trace).
    env_logger::Builder::new()
        .filter_level(log::LevelFilter::Info)
        .parse_env(env_logger::Env::new().filter("MAGSWARM_LOG"))
        .format(|buf, r| {
            use std::io::Write;
            let level = match r.level() {
                log::Level::Warn => "warning".to_string(),
                l => l.as_str().to_ascii_lowercase(),
            };
            writeln!(buf, "magswarm-bridge: {level}: {}", r.args())
        })
        .init();
    let cli = Cli::parse();
    match cli.cmd {
        Cmd::Run {
            config,
            plan,
            targets,
            log,
            duration,
            dry_run,
        } => {
            let signals = match Signals::install() {
                Ok(s) => s,
                Err(e) => return fail(format!("installing signal handlers: {e}")),
            };
            let cfg = match load(&config) {
                Ok(c) => c,
                Err(e) => return fail(e),
            };
            let mode = match run::read_mode(plan.as_deref(), targets.as_deref()) {
                Ok(m) => m,
                Err(e) => return fail(format!("{e:#}")),
            };
            let latch = FaultLatch::new();
            let opts = RunOptions {
                mode,
                log: log.clone(),
                duration,
                dry_run,
            };
            match run::run(&cfg, &opts, &signals, &latch) {
                Ok(r) => {
                    let lat: Vec<f64> = r.latencies_s.iter().map(|s| s * 1e3).collect();
                    eprintln!(
                        "magswarm-bridge: {} rows to {} ({} invalid frames); frame -> command p50 {:.3} ms, p99 {:.3} ms",
                        r.rows,
                        log.display(),
                        r.invalid_frames,
                        run::percentile(&lat, 50.0),
                        run::percentile(&lat, 99.0)
                    );
                    match r.fault {
                        None => ExitCode::SUCCESS,
                        Some(f) => {
                            eprintln!(
                                "magswarm-bridge: FAULT {}: {f}; stepper stopped, robot held, log flushed; \
                                 the fault stays latched: check the rig, then start a new run",
                                f.name()
                            );
                            ExitCode::from(3)
                        }
                    }
                }
                Err(e) => fail(format!("{e:#}")),
            }
        }
        Cmd::Check { config } => {
            let cfg = match load(&config) {
                Ok(c) => c,
                Err(e) => return fail(e),
            };
            let probes = magswarm_bridge::check::check(&cfg);
            let mut ok = true;
            for p in &probes {
                println!(
                    "{:<16} {}  {}",
                    p.device,
                    if p.ok { "ok  " } else { "FAIL" },
                    p.detail
                );
                ok &= p.ok;
            }
            if ok {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            }
        }
        Cmd::Emulate {
            config,
            duration,
            trace,
        } => {
            let signals = match Signals::install() {
                Ok(s) => s,
                Err(e) => return fail(format!("installing signal handlers: {e}")),
            };
            let cfg = match load(&config) {
                Ok(c) => c,
                Err(e) => return fail(e),
            };
            let emu = match magswarm_bridge::emulate::start(&cfg, true) {
                Ok(e) => e,
                Err(e) => return fail(e.to_string()),
            };
            // Make the config's stepper device point at the pty (a symlink), unless it is a
            // real device.
            let dev = Path::new(&cfg.stepper.device);
            let mut linked = false;
            if !dev.exists() || dev.is_symlink() {
                let _ = std::fs::remove_file(dev);
                if std::os::unix::fs::symlink(&emu.stepper.path, dev).is_ok() {
                    linked = true;
                }
            }
            for l in emu.describe(&cfg) {
                println!("{l}");
            }
            if linked {
                println!("stepper-link {} -> {}", dev.display(), emu.stepper.path);
            }
            println!("ready");
            use std::io::Write;
            let _ = std::io::stdout().flush();
            let mut tracer = match trace.as_deref().map(StepperTrace::create).transpose() {
                Ok(t) => t,
                Err(e) => return fail(e),
            };
            let t0 = std::time::Instant::now();
            loop {
                if let Some(t) = tracer.as_mut() {
                    t.append(&emu.stepper.received());
                }
                if signals.int.load(std::sync::atomic::Ordering::SeqCst)
                    || signals.term.load(std::sync::atomic::Ordering::SeqCst)
                {
                    break;
                }
                if duration.is_some_and(|d| t0.elapsed().as_secs_f64() >= d) {
                    break;
                }
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
            if let Some(t) = tracer.as_mut() {
                t.append(&emu.stepper.received());
            }
            let rec = emu.robot.record();
            let (lo, hi) = rec
                .targets
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &z| {
                    (a.min(z), b.max(z))
                });
            eprintln!(
                "magswarm-bridge emulate: {} targets received (tool z {:.4}..{:.4} m), {} heartbeats, {} scripts, {} watchdog stops, {} stepper instructions",
                rec.targets.len(),
                lo,
                hi,
                rec.heartbeats,
                rec.scripts.len(),
                rec.watchdog_stops,
                emu.stepper.received().len()
            );
            if linked {
                let _ = std::fs::remove_file(dev);
            }
            ExitCode::SUCCESS
        }
        Cmd::Fmu {
            config,
            out,
            lib,
            no_build,
            watchdog,
        } => {
            if let Err(e) = load(&config) {
                return fail(e);
            }
            let req = package_fmu::Request {
                config: &config,
                out: &out,
                lib,
                no_build,
                watchdog,
            };
            match package_fmu::package(&req) {
                Ok(summary) => {
                    println!("{summary}");
                    ExitCode::SUCCESS
                }
                Err(e) => fail(format!("{e:#}")),
            }
        }
        Cmd::Measure {
            frames,
            mm_per_px,
            out,
            config,
        } => {
            let vision = match config.as_deref().map(load).transpose() {
                Ok(c) => c.and_then(|c| c.vision),
                Err(e) => return fail(e),
            };
            match magswarm_bridge::measure::measure_folder_to_csv(
                &frames,
                mm_per_px,
                vision.as_ref(),
                &out,
            ) {
                Ok((n, v)) => {
                    eprintln!(
                        "magswarm-bridge measure: {n} frames, {v} valid -> {}",
                        out.display()
                    );
                    ExitCode::SUCCESS
                }
                Err(e) => fail(format!("{e:#}")),
            }
        }
    }
}

/// `emulate --trace`: the emulated stepper's instructions with wall-clock times.
struct StepperTrace {
    out: std::io::BufWriter<std::fs::File>,
    written: usize,
}

impl StepperTrace {
    fn create(path: &Path) -> Result<StepperTrace, String> {
        use std::io::Write;
        let f =
            std::fs::File::create(path).map_err(|e| format!("--trace {}: {e}", path.display()))?;
        let mut out = std::io::BufWriter::new(f);
        let _ = writeln!(out, "t_unix_s,instruction,type,value").and_then(|_| out.flush());
        Ok(StepperTrace { out, written: 0 })
    }

    fn append(&mut self, received: &[magswarm_bridge::stepper_emu::Received]) {
        use std::io::Write;
        let (now_i, now_u) = (std::time::Instant::now(), std::time::SystemTime::now());
        let unix = now_u
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs_f64())
            .unwrap_or(0.0);
        for r in received.iter().skip(self.written) {
            let t = unix - now_i.duration_since(r.at).as_secs_f64();
            let _ = writeln!(self.out, "{t:.6},{},{},{}", r.instruction, r.typ, r.value);
        }
        self.written = received.len().max(self.written);
        let _ = self.out.flush();
    }
}

fn fail(msg: String) -> ExitCode {
    eprintln!("magswarm-bridge: error: {msg}");
    ExitCode::from(2)
}
