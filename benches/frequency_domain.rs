//! The frequency-domain estimators on the ATTAS lateral-directional case
//! (scenario attas-lateral-multistep: 60 s of aileron and rudder multisteps
//! recorded at 25 Hz by the flight-test profile, 1501 samples; model
//! attas-lateral, 18 parameters): one Fourier-transform regression with
//! the band from the inputs' spectra (`fdee`), with the band given as
//! [0.05, 1.5] Hz (`fdee_band_given`), its recursive form (`fdee_recursive`),
//! and one frequency-domain output-error fit from the model file's values
//! (`fdoe`). Equation error on the same record is in the `estimators`
//! bench (`attas_lateral_fit/equation_error`). The `fourier_transform`
//! group times the transform alone on the same grid: building the weights
//! of 143 frequencies (1/T to 2.37 Hz, 11 breaks) and transforming 12
//! signals with them. Run:
//! `cargo bench --bench frequency_domain`.

use aeroid::estimation::methods::frequency_output_error::frequency_output_error;
use aeroid::estimation::methods::frequency_regression::{
    BandOptions, FrequencyRegressionOptions, frequency_regression,
};
use aeroid::estimation::structure::ModelStructure;
use aeroid::numerics::fourier::FourierTransform;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::DMatrix;
use std::hint::black_box;

fn bench_frequency_domain(c: &mut Criterion) {
    let scenario = Scenario::load("attas-lateral-multistep").expect("bundled scenario");
    let profile = Profile::load("flight-test-25hz", None).expect("bundled profile");
    let (record, _) = record_scenario(&scenario, &profile).expect("record");
    let structure = ModelStructure::load("attas-lateral").expect("bundled model");
    let mut group = c.benchmark_group("attas_lateral_frequency_domain");
    group.sample_size(30);
    let automatic = FrequencyRegressionOptions::default();
    group.bench_function("fdee", |b| {
        b.iter(|| frequency_regression(black_box(&record), &structure, &automatic).unwrap())
    });
    let given = FrequencyRegressionOptions {
        band: BandOptions {
            band: Some((0.05, 1.5)),
            ..Default::default()
        },
        ..Default::default()
    };
    group.bench_function("fdee_band_given", |b| {
        b.iter(|| frequency_regression(black_box(&record), &structure, &given).unwrap())
    });
    let recursive = FrequencyRegressionOptions {
        recursive: true,
        ..given.clone()
    };
    group.bench_function("fdee_recursive", |b| {
        b.iter(|| frequency_regression(black_box(&record), &structure, &recursive).unwrap())
    });
    group.bench_function("fdoe", |b| {
        b.iter(|| {
            frequency_output_error(black_box(&record), &structure, &Default::default()).unwrap()
        })
    });
    group.finish();
}

fn bench_transform(c: &mut Criterion) {
    let (count, step) = (1501, 0.04);
    let duration = (count - 1) as f64 * step;
    let frequencies: Vec<f64> = (1..=143)
        .map(|m| std::f64::consts::TAU * m as f64 / duration)
        .collect();
    let breaks = [50, 75, 100, 150, 200, 225, 775, 805, 835, 895, 955];
    let signals = DMatrix::from_fn(count, 12, |k, i| ((k * (i + 1)) as f64 * 0.01).sin());
    let mut group = c.benchmark_group("fourier_transform");
    group.sample_size(30);
    group.bench_function("weights", |b| {
        b.iter(|| {
            FourierTransform::with_breaks(black_box(&frequencies), 0.0, step, count, &breaks)
                .unwrap()
        })
    });
    let transform = FourierTransform::with_breaks(&frequencies, 0.0, step, count, &breaks).unwrap();
    group.bench_function("transform_12_signals", |b| {
        b.iter(|| transform.transform_columns(black_box(&signals)).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench_frequency_domain, bench_transform);
criterion_main!(benches);
