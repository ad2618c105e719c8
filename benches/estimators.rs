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
//! The `attas_lateral_filter`
//! group times one pass of the extended and of the unscented Kalman filter
//! over the same record with the 4 kinematic states and the 18 parameters
//! as augmented states (no process noise, R at the profile's noise; the
//! EKF's keeping everything and keeping what the `ekf` method reads), and
//! the whole `ekf` and `ukf` methods (start, Fourier R, passes). Run:
//! `cargo bench --bench estimators`.

use aeroid::estimation::estimator::Settings;
use aeroid::estimation::methods::augmented_ekf::{self, FilterSettings, augmented_estimate};
use aeroid::estimation::methods::equation_error::equation_error;
use aeroid::estimation::methods::filter_error::{FilterErrorOptions, filter_error};
use aeroid::estimation::methods::output_error::{OutputErrorOptions, Start, output_error};
use aeroid::estimation::methods::smoothed_regression::{
    SmoothedRegressionSettings, smooth, smooth_and_regress,
};
use aeroid::estimation::methods::unscented;
use aeroid::estimation::model::augmented::Augmented;
use aeroid::estimation::model::observations::Observations;
use aeroid::estimation::model::state_space::{DrivenStateSpace, StateSpaceModel};
use aeroid::estimation::solver::extended_kalman::{self, Noise};
use aeroid::estimation::solver::unscented_kalman;
use aeroid::estimation::structure::ModelStructure;
use aeroid::numerics::kalman::Gaussian;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{DMatrix, DVector};
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

fn bench_filters(c: &mut Criterion) {
    let scenario = Scenario::load("attas-lateral-multistep").expect("bundled scenario");
    let profile = Profile::load("flight-test-25hz", None).expect("bundled profile");
    let (record, _) = record_scenario(&scenario, &profile).expect("record");
    let structure = ModelStructure::load("attas-lateral").expect("bundled model");
    let (view, x0) =
        DrivenStateSpace::for_record(&record, &structure, &Default::default(), None, None)
            .expect("view");
    let theta = view.parameters();
    let free: Vec<usize> = (0..theta.len()).filter(|&i| structure.free[i]).collect();
    let model = Augmented::new(&view, theta.as_slice(), free.clone()).expect("augmented");
    let n = model.state_count();
    let mut prior = DMatrix::from_diagonal_element(n, n, 1e-5);
    for j in 0..free.len() {
        let i = x0.len() + j;
        prior[(i, i)] = (0.3 * theta[free[j]].abs().max(0.1)).powi(2);
    }
    let initial = Gaussian {
        mean: model.state(x0.as_slice()),
        covariance: prior,
    };
    let deg = std::f64::consts::PI / 180.0;
    let noise = Noise {
        process: DMatrix::zeros(n, n),
        measurement: DVector::from_vec(
            [0.1 * deg, 0.002, 0.002, 0.1 * deg, 0.02 / 9.80665]
                .iter()
                .map(|s| s * s)
                .collect(),
        ),
    };
    let observations = Observations::from_record(
        &record,
        &structure.outputs,
        view.time(0),
        view.time(1) - view.time(0),
        view.len(),
    )
    .expect("observations");
    let sigma = unscented::read(&Settings::new()).expect("defaults").1;
    let mut group = c.benchmark_group("attas_lateral_filter");
    group.sample_size(10);
    group.bench_function("ekf_pass", |b| {
        b.iter(|| {
            extended_kalman::filter(&model, &[], initial.clone(), &noise, &observations).unwrap()
        })
    });
    let settings = FilterSettings::default();
    group.bench_function("ekf_pass_as_the_method_keeps", |b| {
        b.iter(|| {
            augmented_ekf::extended_pass(&settings, &model, initial.clone(), &noise, &observations)
                .unwrap()
        })
    });
    group.bench_function("ukf_pass", |b| {
        b.iter(|| {
            unscented_kalman::filter(&model, &[], initial.clone(), &noise, &observations, &sigma)
                .unwrap()
        })
    });
    group.bench_function("ekf_method", |b| {
        b.iter(|| {
            augmented_estimate(
                "ekf",
                &record,
                &structure,
                &settings,
                None,
                &|m, i, q, o| augmented_ekf::extended_pass(&settings, m, i, q, o),
            )
            .unwrap()
        })
    });
    group.bench_function("ukf_method", |b| {
        b.iter(|| {
            augmented_estimate(
                "ukf",
                &record,
                &structure,
                &settings,
                None,
                &|m, i, q, o| unscented_kalman::filter(m, &[], i, q, o, &sigma),
            )
            .unwrap()
        })
    });
    group.finish();
}

criterion_group!(benches, bench_fits, bench_filters);
criterion_main!(benches);
