//! Neural Gauss–Newton (`ngn`) on the ATTAS lateral-directional case
//! (scenario attas-lateral-multistep: 60 s of aileron and rudder
//! multisteps recorded at 25 Hz by the flight-test profile; model
//! attas-lateral, 18 parameters): `training` and `training_20` time the
//! feed-forward network's Levenberg–Marquardt training alone on the
//! restricted model's training set (1 428 pairs of 7 inputs and 7
//! outputs, 10 and 20 tanh neurons, early stopping on every 5th pair);
//! `train_and_estimate` the whole method with the bundled settings
//! (training, with the hidden-layer size chosen from the data, and the
//! Gauss–Newton fit through the network), `train_and_estimate_20` the same
//! with `hidden = 20`. A second group times the training of 200 epochs on
//! a noise-free record's set, where early stopping does not end it
//! (`training_200_epochs_ideal`, 10 neurons). Run: `cargo bench --bench ngn`.

use aeroid::estimation::estimator::MethodTables;
use aeroid::estimation::neural::NetworkReport;
use aeroid::estimation::neural::feedforward::LevenbergMarquardt;
use aeroid::estimation::neural::restricted::{
    self, Network, RestrictedOptions, Trainer, TrainingSet,
};
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use std::sync::Mutex;

/// Inputs and targets, row by row.
type Pairs = (Vec<Vec<f64>>, Vec<Vec<f64>>);

/// A trainer that keeps a copy of the training set it is given.
struct Capture(Mutex<Option<Pairs>>);

impl Trainer for Capture {
    fn train(
        &self,
        set: &TrainingSet,
    ) -> aeroid::estimation::Result<(Box<dyn Network>, NetworkReport)> {
        if let Ok(mut kept) = self.0.lock() {
            *kept = Some((set.inputs.clone(), set.targets.clone()));
        }
        Trainer::train(&LevenbergMarquardt::default(), set)
    }
}

/// The restricted model's training pairs of the record (ngn's: the
/// coefficients at k+1 as outputs too), scaled as the method scales them.
fn training_set(profile: &str) -> Pairs {
    let scenario = Scenario::load("attas-lateral-multistep").expect("bundled scenario");
    let profile = Profile::load(profile, None).expect("bundled profile");
    let (record, _) = record_scenario(&scenario, &profile).expect("record");
    let structure = ModelStructure::load("attas-lateral").expect("bundled model");
    let problem = aeroid::estimation::registry::Registry::built_in()
        .problem("ngn", vec![record], structure, &[])
        .expect("problem");
    let capture = Capture(Mutex::new(None));
    let options = RestrictedOptions {
        coefficient_outputs: true,
        ..RestrictedOptions::default()
    };
    restricted::estimate("ngn", &problem, None, &capture, &options).expect("estimate");
    capture.0.into_inner().ok().flatten().expect("training set")
}

fn bench_ngn(c: &mut Criterion) {
    let scenario = Scenario::load("attas-lateral-multistep").expect("bundled scenario");
    let profile = Profile::load("flight-test-25hz", None).expect("bundled profile");
    let (record, _) = record_scenario(&scenario, &profile).expect("record");
    let structure = ModelStructure::load("attas-lateral").expect("bundled model");
    let problem = aeroid::estimation::registry::Registry::built_in()
        .problem("ngn", vec![record], structure, &[])
        .expect("problem");
    let mut tables = MethodTables::new();
    tables.insert(
        "ngn".into(),
        toml::from_str("hidden = 20").expect("settings"),
    );
    let fixed = aeroid::estimation::registry::Registry::built_in()
        .problem(
            "ngn",
            problem.records.clone(),
            ModelStructure::load("attas-lateral").expect("bundled model"),
            &[&tables],
        )
        .expect("problem");
    let (inputs, targets) = training_set("flight-test-25hz");
    let mut group = c.benchmark_group("attas_lateral_ngn");
    group.sample_size(20);
    for (name, hidden) in [("training", 10), ("training_20", 20)] {
        let trainer = LevenbergMarquardt {
            hidden,
            ..LevenbergMarquardt::default()
        };
        group.bench_function(name, |b| {
            b.iter(|| {
                trainer
                    .train(black_box(&inputs), &targets)
                    .expect("trained")
            })
        });
    }
    group.bench_function("train_and_estimate", |b| {
        b.iter(|| {
            aeroid::estimation::registry::Registry::built_in()
                .estimate(black_box(&problem), None)
                .expect("estimate")
        })
    });
    group.bench_function("train_and_estimate_20", |b| {
        b.iter(|| {
            aeroid::estimation::registry::Registry::built_in()
                .estimate(black_box(&fixed), None)
                .expect("estimate")
        })
    });
    group.finish();
    let (inputs, targets) = training_set("ideal");
    let mut group = c.benchmark_group("attas_lateral_ngn_ideal");
    group.sample_size(10);
    let trainer = LevenbergMarquardt {
        held_out_every: 0,
        ..LevenbergMarquardt::default()
    };
    group.bench_function("training_200_epochs_ideal", |b| {
        b.iter(|| {
            trainer
                .train(black_box(&inputs), &targets)
                .expect("trained")
        })
    });
    group.finish();
}

criterion_group!(benches, bench_ngn);
criterion_main!(benches);
