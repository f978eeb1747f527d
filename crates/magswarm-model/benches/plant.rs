//! Hot-path costs of the plant: one steady-map evaluation (5)-(7) with its Jacobian, one
//! computation of the input-dependent terms of (4), and one communication step of the plant
//! (error-controlled Dormand-Prince) of 10 ms and 1 ms.
//!
//! Run: `cargo bench -p magswarm-model --bench plant -- --warm-up-time 1 --measurement-time 2`

use criterion::{black_box, criterion_group, criterion_main, BatchSize, Criterion};
use magswarm_model::dynamics::InputTerms;
use magswarm_model::{hz_to_rad_s, steady, Model, Plant};

fn bench(c: &mut Criterion) {
    let model = Model::paper();
    let (z, om) = (0.0085, hz_to_rad_s(4.0));

    c.bench_function("steady::evaluate", |b| {
        b.iter(|| steady::evaluate(black_box(&model), black_box(z), black_box(om)))
    });
    c.bench_function("InputTerms::new", |b| {
        b.iter(|| InputTerms::new(black_box(&model), black_box(z), black_box(om)))
    });

    // A plant 0.5 s into the transient after an input step (8.5 mm, 4 Hz -> 18.5 mm, 8 Hz),
    // so each measured step integrates a real transient with the step size the integrator has
    // adapted to; cloned per iteration so every step starts from the same state.
    let mut transient = Plant::new(model.clone(), z, om);
    transient.set_inputs(0.0185, hz_to_rad_s(8.0));
    transient.step(0.5).expect("step");
    for h in [0.01, 0.001] {
        c.bench_function(&format!("Plant::step({h}) in a transient"), |b| {
            b.iter_batched(
                || transient.clone(),
                |mut p| {
                    p.step(black_box(h)).expect("step");
                    p
                },
                BatchSize::SmallInput,
            )
        });
    }
    // At rest on the map (the common case between input changes).
    let mut rest = Plant::new(model.clone(), z, om);
    rest.step(1.0).expect("step");
    c.bench_function("Plant::step(0.001) at rest", |b| {
        b.iter_batched(
            || rest.clone(),
            |mut p| {
                p.step(black_box(0.001)).expect("step");
                p
            },
            BatchSize::SmallInput,
        )
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
