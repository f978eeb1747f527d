//! Bench: nanoseconds per `fmi2DoStep` of the packaged MagSwarm.fmu through the C ABI.
//!
//! ```text
//! cargo run --release --bin magswarm -- fmu          # target/fmu/MagSwarm.fmu
//! cargo run --release --example bench_dostep [-- --fmu PATH --calls N]
//! ```
//!
//! The FMU is imported like any importer does (`magswarm::cosim::Fmu`: unzip, XML, dlopen).
//! Each figure is the median over 7 repeats of `calls` calls (after a warm-up) at a
//! communication step of 10 ms and 1 ms:
//!
//! - `doStep, steady inputs`: inputs fixed, the swarm formed (the integrator takes its
//!   largest steps);
//! - `doStep, input change every call`: `fmi2SetReal(z_m, omega_m)` + `fmi2DoStep` with a
//!   new, slowly varying input every call (z_m 8.5 +- 2 mm and f 4 +- 1 Hz at 0.2 Hz), i.e.
//!   the closed-loop situation;
//! - `set + doStep + get`: the full communication step of a master: set both inputs, step,
//!   get r1 and r2.
//!
//! "raw" calls the function pointer from the FMU's function table directly; "FmuSlave" goes
//! through the safe wrapper (status check and log bookkeeping), to show its overhead.

use std::f64::consts::TAU;
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

use magswarm::cosim::{Fmu, FmuSlave, SlaveOptions};

const REPEATS: usize = 7;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn inputs(t: f64) -> [f64; 2] {
    let s = (TAU * 0.2 * t).sin();
    [8.5e-3 + 2.0e-3 * s, (4.0 + 1.0 * s) * TAU]
}

struct Bench {
    slave: FmuSlave,
    t: f64,
    h: f64,
    ins: [u32; 2],
    outs: [u32; 2],
}

impl Bench {
    fn new(fmu: &Fmu, h: f64) -> Bench {
        let mut slave = fmu
            .instantiate("bench", SlaveOptions::default())
            .expect("instantiate");
        let ins = [fmu.real_vr("z_m").unwrap(), fmu.real_vr("omega_m").unwrap()];
        let outs = [fmu.real_vr("r1").unwrap(), fmu.real_vr("r2").unwrap()];
        slave.setup_experiment(None, 0.0, None).unwrap();
        slave.enter_initialization_mode().unwrap();
        slave.set_real(&ins, &inputs(0.0)).unwrap();
        slave.exit_initialization_mode().unwrap();
        Bench {
            slave,
            t: 0.0,
            h,
            ins,
            outs,
        }
    }

    /// ns per call of `f` over `calls` calls, median of REPEATS.
    fn time(&mut self, calls: usize, mut f: impl FnMut(&mut Bench)) -> f64 {
        for _ in 0..calls / 10 {
            f(self);
        }
        let mut v = Vec::new();
        for _ in 0..REPEATS {
            let t0 = Instant::now();
            for _ in 0..calls {
                f(self);
            }
            v.push(t0.elapsed().as_nanos() as f64 / calls as f64);
        }
        median(v)
    }
}

fn main() {
    let mut fmu_path = PathBuf::from("target/fmu/MagSwarm.fmu");
    let mut calls = 20_000usize;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--fmu" => fmu_path = args.next().expect("--fmu PATH").into(),
            "--calls" => calls = args.next().expect("--calls N").parse().expect("N"),
            "-h" | "--help" => {
                println!("bench_dostep [--fmu PATH] [--calls N]");
                return;
            }
            // `cargo bench` passes --bench; ignore what we do not know
            _ => {}
        }
    }
    if !fmu_path.is_file() {
        eprintln!(
            "{} not found: build it with `cargo run --release -- fmu`",
            fmu_path.display()
        );
        std::process::exit(2);
    }
    let fmu = Fmu::load(&fmu_path).expect("load FMU");
    println!(
        "MagSwarm.fmu doStep bench: {} ({}), {calls} calls x {REPEATS} repeats, median ns/call",
        fmu_path.display(),
        fmu.guid()
    );
    println!("{:<48} {:>12} {:>12}", "case", "h = 10 ms", "h = 1 ms");

    let mut rows: Vec<(String, [f64; 2])> = Vec::new();
    let mut add = |name: &str, f: &dyn Fn(&Fmu, f64) -> f64| {
        let v = [f(&fmu, 0.01), f(&fmu, 0.001)];
        println!("{name:<48} {:>12.0} {:>12.0}", v[0], v[1]);
        rows.push((name.to_string(), v));
    };

    // doStep only, steady inputs (formed swarm), raw function pointer
    add("doStep, steady inputs (raw)", &|fmu, h| {
        let mut b = Bench::new(fmu, h);
        let do_step = *b.slave.raw_binding().fmi2DoStep.as_ref().unwrap();
        let c = b.slave.component();
        b.time(calls, |b| {
            // SAFETY: a live, initialised component of this library.
            let s = unsafe { do_step(c, b.t, b.h, 1) };
            assert_eq!(s, 0);
            b.t += b.h;
        })
    });
    add("doStep, steady inputs (FmuSlave)", &|fmu, h| {
        let mut b = Bench::new(fmu, h);
        b.time(calls, |b| {
            let (t, h) = (b.t, b.h);
            b.slave.do_step(t, h).unwrap();
            b.t += h;
        })
    });
    // input change every call: setReal + doStep
    add(
        "setReal + doStep, input change every call (raw)",
        &|fmu, h| {
            let mut b = Bench::new(fmu, h);
            let do_step = *b.slave.raw_binding().fmi2DoStep.as_ref().unwrap();
            let set_real = *b.slave.raw_binding().fmi2SetReal.as_ref().unwrap();
            let c = b.slave.component();
            b.time(calls, |b| {
                let u = inputs(b.t);
                // SAFETY: live component, arrays of 2.
                unsafe {
                    assert_eq!(set_real(c, b.ins.as_ptr(), 2, u.as_ptr()), 0);
                    assert_eq!(do_step(c, b.t, b.h, 1), 0);
                }
                b.t += b.h;
            })
        },
    );
    add("set + doStep + get, input change (raw)", &|fmu, h| {
        let mut b = Bench::new(fmu, h);
        let bind = b.slave.raw_binding();
        let do_step = *bind.fmi2DoStep.as_ref().unwrap();
        let set_real = *bind.fmi2SetReal.as_ref().unwrap();
        let get_real = *bind.fmi2GetReal.as_ref().unwrap();
        let c = b.slave.component();
        let mut y = [0.0; 2];
        b.time(calls, |b| {
            let u = inputs(b.t);
            // SAFETY: live component, arrays of 2.
            unsafe {
                assert_eq!(set_real(c, b.ins.as_ptr(), 2, u.as_ptr()), 0);
                assert_eq!(do_step(c, b.t, b.h, 1), 0);
                assert_eq!(get_real(c, b.outs.as_ptr(), 2, y.as_mut_ptr()), 0);
            }
            black_box(&y);
            b.t += b.h;
        })
    });
    add("set + doStep + get, input change (FmuSlave)", &|fmu, h| {
        let mut b = Bench::new(fmu, h);
        let mut y = [0.0; 2];
        b.time(calls, |b| {
            let u = inputs(b.t);
            let (t, h, ins, outs) = (b.t, b.h, b.ins, b.outs);
            b.slave.set_real(&ins, &u).unwrap();
            b.slave.do_step(t, h).unwrap();
            b.slave.get_real(&outs, &mut y).unwrap();
            black_box(&y);
            b.t += h;
        })
    });

    let base = rows[0].1;
    println!("\nratios to `doStep, steady inputs (raw)` of the same h (same run):");
    for (name, v) in &rows {
        println!(
            "{name:<48} {:>12.2} {:>12.2}",
            v[0] / base[0],
            v[1] / base[1]
        );
    }
    println!(
        "\nper simulated second: steady {:.1} us (h = 10 ms), {:.1} us (h = 1 ms); \
         closed-loop set+doStep+get {:.1} us, {:.1} us",
        base[0] * 100.0 / 1e3,
        base[1] * 1000.0 / 1e3,
        rows[3].1[0] * 100.0 / 1e3,
        rows[3].1[1] * 1000.0 / 1e3
    );
}
