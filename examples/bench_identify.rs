//! Bench: time to identify a 500-row seed-like log (issue 5's target: < 0.5 s).
//!
//! Generates the log with the tests' synthetic generator (50 operating points x 10 repeats,
//! noise 0.25 / 0.4 mm, perturbed paper parameters), then runs `identify` with the default
//! configuration (8 starts, 200 bootstrap replicates) several times and prints the figures.
//! No assertion: the machine is shared and noisy; read the median.
//!
//! `cargo run --release --example bench_identify`

#[path = "../tests/common/synth.rs"]
mod synth;

use magswarm::identify::{self, Config};
use magswarm::model::Model;

fn main() {
    let log = synth::log(&synth::Spec::seed_like(synth::perturbed_truth(), 77));
    println!("log: {} rows", log.rows.len());
    let run = |cfg: &Config, n: usize| {
        let mut times: Vec<f64> = (0..n)
            .map(|_| {
                let t0 = std::time::Instant::now();
                let id = identify::identify(std::slice::from_ref(&log), &Model::paper(), cfg)
                    .expect("identify");
                std::hint::black_box(&id);
                t0.elapsed().as_secs_f64()
            })
            .collect();
        times.sort_by(|a, b| a.total_cmp(b));
        (times[n / 2], times[0], times[n - 1])
    };
    let full = Config::default();
    let _ = run(&full, 1); // warm-up
    let (med, min, max) = run(&full, 7);
    println!("identify, 8 starts + 200 bootstrap: median {med:.3} s (min {min:.3}, max {max:.3})");
    let fit_only = Config {
        bootstrap: 0,
        ..Config::default()
    };
    let (med0, min0, max0) = run(&fit_only, 7);
    println!(
        "identify, 8 starts, no bootstrap:   median {med0:.3} s (min {min0:.3}, max {max0:.3})"
    );
    println!(
        "bootstrap share of the time: {:.0} %",
        100.0 * (1.0 - med0 / med)
    );
}
