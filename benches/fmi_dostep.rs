//! Criterion benches of the FMI calls, MagSwarm.fmu beside the Euler2 yardstick (the C FMU of
//! `benches/fixture/euler2.c`, compiled at run time), both through the same importer and the
//! raw FMI function pointers. The one-table summary of every figure with ratios is
//! `cargo run --release --example perf_table`; this is the statistically careful view.
//!
//! Run: `cargo run --release -- fmu && cargo bench --bench fmi_dostep -- --warm-up-time 1 --measurement-time 3`

use std::f64::consts::TAU;
use std::path::Path;

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use magswarm::cosim::{Fmu, FmuSlave, SlaveOptions};

type DoStep = unsafe extern "C" fn(*mut std::ffi::c_void, f64, f64, i32) -> i32;
type SetReal = unsafe extern "C" fn(*mut std::ffi::c_void, *const u32, usize, *const f64) -> i32;
type GetReal = unsafe extern "C" fn(*mut std::ffi::c_void, *const u32, usize, *mut f64) -> i32;

struct Raw {
    slave: FmuSlave,
    do_step: DoStep,
    set_real: SetReal,
    get_real: GetReal,
    ins: [u32; 2],
    outs: [u32; 2],
    t: f64,
}

fn inputs(t: f64) -> [f64; 2] {
    let s = (TAU * 0.2 * t).sin();
    [8.5e-3 + 2.0e-3 * s, (4.0 + s) * TAU]
}

impl Raw {
    fn new(fmu: &Fmu, names: [&str; 4]) -> Raw {
        let mut slave = fmu.instantiate("bench", SlaveOptions::default()).unwrap();
        let ins = [
            fmu.real_vr(names[0]).unwrap(),
            fmu.real_vr(names[1]).unwrap(),
        ];
        let outs = [
            fmu.real_vr(names[2]).unwrap(),
            fmu.real_vr(names[3]).unwrap(),
        ];
        slave.setup_experiment(None, 0.0, None).unwrap();
        slave.enter_initialization_mode().unwrap();
        slave.set_real(&ins, &inputs(0.0)).unwrap();
        slave.exit_initialization_mode().unwrap();
        let b = slave.raw_binding();
        // SAFETY: the binding's function types are these C signatures (fmi2Functions.h).
        // (The source types are the bindings' generated ones, named by inference.)
        #[allow(clippy::missing_transmute_annotations)]
        let (do_step, set_real, get_real) = unsafe {
            (
                std::mem::transmute::<_, DoStep>(*b.fmi2DoStep.as_ref().unwrap()),
                std::mem::transmute::<_, SetReal>(*b.fmi2SetReal.as_ref().unwrap()),
                std::mem::transmute::<_, GetReal>(*b.fmi2GetReal.as_ref().unwrap()),
            )
        };
        Raw {
            slave,
            do_step,
            set_real,
            get_real,
            ins,
            outs,
            t: 0.0,
        }
    }

    fn step(&mut self, h: f64) {
        // SAFETY: a live, initialised instance.
        let s = unsafe { (self.do_step)(self.slave.component(), self.t, h, 1) };
        assert!(s <= 1);
        self.t += h;
    }

    fn set_step_get(&mut self, h: f64) -> [f64; 2] {
        let u = inputs(self.t);
        let c = self.slave.component();
        let mut y = [0.0; 2];
        // SAFETY: live instance, arrays of 2.
        unsafe {
            assert!((self.set_real)(c, self.ins.as_ptr(), 2, u.as_ptr()) <= 1);
        }
        self.step(h);
        // SAFETY: as above.
        unsafe {
            assert!((self.get_real)(c, self.outs.as_ptr(), 2, y.as_mut_ptr()) <= 1);
        }
        y
    }
}

fn bench(c: &mut Criterion) {
    let magswarm = Path::new("target/fmu/MagSwarm.fmu");
    if !magswarm.is_file() {
        eprintln!(
            "{} missing: `cargo run --release -- fmu` first",
            magswarm.display()
        );
        return;
    }
    let fixture = magswarm::perf::fixture::build(Path::new("target/perf")).expect("Euler2.fmu");
    let fmus = [
        (
            "MagSwarm",
            Fmu::load(magswarm).unwrap(),
            ["z_m", "omega_m", "r1", "r2"],
        ),
        (
            "Euler2",
            Fmu::load(&fixture).unwrap(),
            ["u1", "u2", "x1", "x2"],
        ),
    ];
    for (name, fmu, vars) in &fmus {
        for h in [0.01, 0.001] {
            let mut r = Raw::new(fmu, *vars);
            c.bench_function(&format!("{name}: doStep, constant inputs, h = {h}"), |b| {
                b.iter(|| r.step(black_box(h)))
            });
            let mut r = Raw::new(fmu, *vars);
            c.bench_function(
                &format!("{name}: set + doStep + get, input change, h = {h}"),
                |b| b.iter(|| black_box(r.set_step_get(black_box(h)))),
            );
        }
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
