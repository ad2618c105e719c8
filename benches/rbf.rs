//! The RBF network + Delta method (`rbf-delta`, Wang et al. 2012) on the
//! ATTAS lateral-directional case (scenario attas-lateral-multistep: 60 s
//! of aileron and rudder multisteps recorded at 25 Hz by the flight-test
//! profile; model attas-lateral, 18 parameters): coefficient
//! reconstruction, clustering, width search, least-squares weights of the
//! three networks and the Delta method at every sample. Target (issue
//! 21): ≤ 100 ms. Run: `cargo bench --bench rbf`.

use aeroid::estimation::methods::rbf_delta::{RbfDeltaSettings, rbf_delta};
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

fn bench_rbf_delta(c: &mut Criterion) {
    let scenario = Scenario::load("attas-lateral-multistep").expect("bundled scenario");
    let profile = Profile::load("flight-test-25hz", None).expect("bundled profile");
    let (record, _) = record_scenario(&scenario, &profile).expect("record");
    let structure = ModelStructure::load("attas-lateral").expect("bundled model");
    let settings = RbfDeltaSettings::default();
    let mut group = c.benchmark_group("attas_lateral_rbf_delta");
    group.sample_size(10);
    group.bench_function("rbf_delta", |b| {
        b.iter(|| rbf_delta(black_box(&record), &structure, &settings).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench_rbf_delta);
criterion_main!(benches);
