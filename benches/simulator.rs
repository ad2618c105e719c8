//! Steps per second of the 6-DOF (one RK4 step = four evaluations of the
//! equations of motion), single core, with the linear and the stall model.
//! Run: `cargo bench --bench simulator`.

use aeroid::sim::Simulation;
use aeroid::sim::scenario::Scenario;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;

const STEPS: usize = 1000;

fn prepared(reference: &str) -> Simulation {
    let scenario = Scenario::load(reference).expect("bundled scenario");
    Simulation::prepare(&scenario).expect("trim")
}

fn bench_steps(c: &mut Criterion) {
    let mut group = c.benchmark_group("rk4_steps");
    group.throughput(Throughput::Elements(STEPS as u64));
    for (label, reference) in [
        ("linear_attas", "attas-elevator-3211"),
        ("stall_attas", "attas-stall"),
    ] {
        let simulation = prepared(reference);
        group.bench_function(label, |b| {
            b.iter(|| {
                let mut x = simulation.trim.state;
                for k in 0..STEPS {
                    x = simulation.advance(black_box(&x), k);
                }
                x
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_steps);
criterion_main!(benches);
