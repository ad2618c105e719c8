//! One output-error fit and one equation-error fit of the ATTAS
//! lateral-directional case (scenario attas-lateral-multistep: 60 s of
//! aileron and rudder multisteps, recorded at 25 Hz by the flight-test
//! profile; model attas-lateral, 18 parameters and 4 initial states). The
//! output-error fit is the default one: it starts from equation error's
//! estimates (their cost included); `output_error_from_model_file` starts
//! from the model file's a-priori values instead. `ebm_smoother_pass` is
//! one EKF + modified Bryson–Frazier pass of estimation before modelling
//! over the same record (28 states, 1501 points), `ebm` that pass and the
//! regression. `filter_error` is the filter error method's default fit of
//! the same record (from equation error's estimates, their cost included).
//! Run:
//! `cargo bench --bench estimators`.

use aeroid::estimation::methods::equation_error::equation_error;
use aeroid::estimation::methods::filter_error::{FilterErrorOptions, filter_error};
use aeroid::estimation::methods::output_error::{OutputErrorOptions, Start, output_error};
use aeroid::estimation::methods::smoothed_regression::{
    SmoothedRegressionSettings, smooth, smooth_and_regress,
};
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

fn bench_fits(c: &mut Criterion) {
    let scenario = Scenario::load("attas-lateral-multistep").expect("bundled scenario");
    let profile = Profile::load("flight-test-25hz", None).expect("bundled profile");
    let (record, _) = record_scenario(&scenario, &profile).expect("record");
    let structure = ModelStructure::load("attas-lateral").expect("bundled model");
    let from_model = OutputErrorOptions::for_structure(&structure).expect("model settings");
    let mut group = c.benchmark_group("attas_lateral_fit");
    group.sample_size(10);
    group.bench_function("output_error", |b| {
        b.iter(|| output_error(&[black_box(&record)], &structure, &from_model).unwrap())
    });
    let from_file = OutputErrorOptions {
        start: Start::Model,
        ..from_model.clone()
    };
    group.bench_function("output_error_from_model_file", |b| {
        b.iter(|| output_error(&[black_box(&record)], &structure, &from_file).unwrap())
    });
    let filter = FilterErrorOptions::for_structure(&structure).expect("model settings");
    group.bench_function("filter_error", |b| {
        b.iter(|| filter_error(black_box(&record), &structure, &filter).unwrap())
    });
    group.bench_function("equation_error", |b| {
        b.iter(|| equation_error(black_box(&record), &structure, &Default::default()).unwrap())
    });
    let settings = SmoothedRegressionSettings::default();
    group.bench_function("ebm_smoother_pass", |b| {
        b.iter(|| smooth(black_box(&record), &structure, &settings).unwrap())
    });
    group.bench_function("ebm", |b| {
        b.iter(|| smooth_and_regress(black_box(&record), &structure, &settings).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench_fits);
criterion_main!(benches);
