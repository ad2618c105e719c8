//! Steps per second of aeroid's simulator and of JSBSim on the same aircraft
//! (the ATTAS exported by `aeroid export-jsbsim`) and the same scenario
//! (`attas-elevator-3211`), in one run, single core. aeroid: one RK4 step (four
//! evaluations). JSBSim 1.3.3: one `Run` (one evaluation, third-order
//! Adams–Bashforth) plus the five control writes, through the FFI.
//! Run: `cargo bench --features jsbsim --bench jsbsim`.

use aeroid::jsbsim::crosscheck::{saturated_controls, start_exported};
use aeroid::sim::Simulation;
use aeroid::sim::scenario::Scenario;
use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;

const STEPS: usize = 1000;

fn bench_steps(c: &mut Criterion) {
    let scenario = Scenario::load("attas-elevator-3211").expect("bundled scenario");
    let simulation = Simulation::prepare(&scenario).expect("trim");
    let mut group = c.benchmark_group("steps_attas_elevator_3211");
    group.throughput(Throughput::Elements(STEPS as u64));
    group.bench_function("aeroid_rk4", |b| {
        b.iter(|| {
            let mut x = simulation.trim.state;
            for k in 0..STEPS {
                x = simulation.advance(black_box(&x), k);
            }
            x
        })
    });
    let controls: Vec<_> = (0..=STEPS)
        .map(|k| saturated_controls(&simulation, k))
        .collect();
    group.bench_function("jsbsim_ab3", |b| {
        b.iter_batched(
            || start_exported(&simulation, false, 1).expect("JSBSim loads the exported ATTAS"),
            |mut flight| {
                for k in 0..STEPS {
                    flight.advance(k, &controls[k + 1]).expect("JSBSim steps");
                }
                flight
            },
            BatchSize::PerIteration,
        )
    });
    group.finish();
}

criterion_group!(benches, bench_steps);
criterion_main!(benches);
