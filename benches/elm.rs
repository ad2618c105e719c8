//! ELM + Gauss–Newton on the ATTAS lateral-directional case (scenario
//! attas-lateral-multistep: 60 s of aileron and rudder multisteps recorded
//! at 25 Hz by the flight-test profile; model attas-lateral, 18
//! parameters): one `elm-gn` estimate from the record, training included —
//! the coefficient reconstruction, equation error's start, the hidden-size
//! search (six candidate sizes on four fifths of the pairs), the final
//! training and the Gauss–Newton fit (`elm_gn`); the training alone on the
//! same record's pairs is not separable through the method's interface, so
//! `elm_training` times the ELM trainer on a training set of the same
//! shape (1428 pairs, 7 inputs, 4 outputs). `relm_gn_stall` is one
//! `relm-gn` estimate on the ATTAS stall flight (model attas-stall, 13
//! parameters). Run: `cargo bench --bench elm`.

use aeroid::estimation::neural::elm::ElmTrainer;
use aeroid::estimation::neural::restricted::{Trainer, TrainingSet};
use aeroid::estimation::problem::EstimationProblem;
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

fn problem(method: &str, scenario: &str, model: &str) -> EstimationProblem {
    let scenario = Scenario::load(scenario).expect("bundled scenario");
    let profile = Profile::load("flight-test-25hz", None).expect("bundled profile");
    let (record, _) = record_scenario(&scenario, &profile).expect("record");
    let structure = ModelStructure::load(model).expect("bundled model");
    aeroid::estimation::registry::Registry::built_in()
        .problem(method, vec![record], structure, &[])
        .expect("problem")
}

/// A training set of the lateral case's shape: smooth functions of the inputs.
fn training_set() -> TrainingSet {
    let inputs: Vec<Vec<f64>> = (0..1428)
        .map(|i| {
            (0..7)
                .map(|j| ((i as f64) * 0.013 * (j + 1) as f64).sin())
                .collect()
        })
        .collect();
    let targets = inputs
        .iter()
        .map(|x| (0..4).map(|k| (x[k] + 0.3 * x[k + 3]).tanh()).collect())
        .collect();
    TrainingSet {
        inputs,
        targets,
        input_names: (0..7).map(|j| format!("x{j}")).collect(),
        output_names: (0..4).map(|k| format!("z{k}")).collect(),
    }
}

fn bench_elm(c: &mut Criterion) {
    let lateral = problem("elm-gn", "attas-lateral-multistep", "attas-lateral");
    let stall = problem("relm-gn", "attas-stall", "attas-stall");
    let set = training_set();
    let trainer = ElmTrainer::default();
    let mut group = c.benchmark_group("attas_elm");
    group.sample_size(20);
    group.bench_function("elm_gn", |b| {
        b.iter(|| {
            aeroid::estimation::registry::Registry::built_in()
                .estimate(black_box(&lateral), None)
                .unwrap()
        })
    });
    group.bench_function("elm_training", |b| {
        b.iter(|| trainer.train(black_box(&set)).unwrap())
    });
    group.bench_function("relm_gn_stall", |b| {
        b.iter(|| {
            aeroid::estimation::registry::Registry::built_in()
                .estimate(black_box(&stall), None)
                .unwrap()
        })
    });
    group.finish();
}

criterion_group!(benches, bench_elm);
criterion_main!(benches);
