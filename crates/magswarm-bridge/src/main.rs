//! `magswarm-bridge`: run, check, emulate, measure.

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
        Cmd::Emulate { config, duration } => {
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
                Err(e) => return fail(e),
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
            let t0 = std::time::Instant::now();
            loop {
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

fn fail(msg: String) -> ExitCode {
    eprintln!("magswarm-bridge: error: {msg}");
    ExitCode::from(2)
}
