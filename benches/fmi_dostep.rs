//! Criterion benches of the FMI calls, MagSwarm.fmu (FMI 2.0 and, when packaged, 3.0) beside
//! the Euler2 yardstick (the C FMU of `benches/fixture/euler2.c`, compiled at run time), all
//! through the same importer and the raw FMI function pointers ([`magswarm::perf::raw`]). The
//! one-table summary of every figure with ratios is `cargo run --release --example
//! perf_table`; this is the statistically careful view.
//!
//! Run: `cargo run --release -- fmu && cargo bench --bench fmi_dostep -- --warm-up-time 1 --measurement-time 3`

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use magswarm::cosim::Fmu;
use magswarm::perf::raw::{RawLoop, EULER2, MAGSWARM};

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
    let mut fmus = vec![
        ("MagSwarm", Fmu::load(magswarm).unwrap(), MAGSWARM),
        ("Euler2", Fmu::load(&fixture).unwrap(), EULER2),
    ];
    let fmi3 = Path::new("target/fmu/fmi3/MagSwarm.fmu");
    if fmi3.is_file() {
        fmus.push(("MagSwarm FMI 3.0", Fmu::load(fmi3).unwrap(), MAGSWARM));
    }
    for (name, fmu, vars) in &fmus {
        for h in [0.01, 0.001] {
            let mut r = RawLoop::new(fmu, *vars, h).unwrap();
            c.bench_function(&format!("{name}: doStep, constant inputs, h = {h}"), |b| {
                b.iter(|| r.step())
            });
            let mut r = RawLoop::new(fmu, *vars, h).unwrap();
            c.bench_function(
                &format!("{name}: set + doStep + get, input change, h = {h}"),
                |b| b.iter(|| r.set_step_get()),
            );
        }
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
