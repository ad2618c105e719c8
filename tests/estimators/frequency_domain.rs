//! The frequency-domain estimators: Fourier-transform regression (`fdee`)
//! and frequency-domain output error (`fdoe`).
//!
//! - Ideal data, matching structure: `fdee` on the ATTAS multisine and on
//!   the 3211-type lateral multistep (its moments need the piecewise
//!   transform across the control steps) recovers every parameter of the
//!   6-DOF structure, which is linear in its parameters, within 1e-3
//!   (measured: 1e-6); `fdoe` fitted to a simulated flight of a linear
//!   lateral model recovers its dimensional derivatives within 1e-3
//!   (measured: ~1e-7).
//! - The recursive form's estimate at the end of the record equals the
//!   batch estimate to 1e-9.
//! - `fdoe` on the nonlinear simulator's flight: the linearisation about
//!   the first sample is the method's own error, measured against the
//!   amplitude (docs/findings.md).
//! - The noisy Monte Carlo study beside equation and output error is
//!   `tests/studies/frequency_domain_study.rs`.

use aeroid::estimation::estimate::{Estimate, Status};
use aeroid::estimation::linear_structure::LinearStructure;
use aeroid::estimation::methods::frequency_output_error::linear_frequency_output_error;
use aeroid::estimation::methods::frequency_output_error::{
    FrequencyData, FrequencyOutputErrorOptions, fit_transfer, frequency_output_error,
};
use aeroid::estimation::methods::frequency_regression::{
    FrequencyRegressionOptions, frequency_regression, linear_frequency_regression,
};
use aeroid::estimation::model::linear::{Entry, LinearStateSpace, Matrix};
use aeroid::estimation::structure::ModelStructure;
use aeroid::eval::linear_flight::record_flight;
use aeroid::numerics::fourier::FourierTransform;
use aeroid::numerics::gauss_newton::Options;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::integrator::rk4_step;
use aeroid::sim::scenario::Scenario;
use aeroid::sim::truth::RunTruth;
use nalgebra::{DMatrix, DVector, SVector};

fn recorded(scenario: &str, profile: &str, input_scale: f64) -> (FlightRecord, RunTruth) {
    let mut scenario = Scenario::load(scenario).unwrap();
    if input_scale != 1.0 {
        scenario.inputs = scenario.inputs.scaled(input_scale);
    }
    let profile = Profile::load(profile, None).unwrap();
    record_scenario(&scenario, &profile).unwrap()
}

/// The largest |estimate − truth| / max(|truth|, floor) over the estimate.
fn worst_error(estimate: &Estimate, truth: &RunTruth, floor: f64) -> (String, f64) {
    estimate
        .parameters
        .iter()
        .map(|p| {
            let truth = truth.parameter_at(&p.name, 0.0).unwrap();
            (
                p.name.clone(),
                (p.value - truth).abs() / truth.abs().max(floor),
            )
        })
        .fold((String::new(), 0.0), |a, b| if b.1 > a.1 { b } else { a })
}

/// Noise-free data and the matching structure: every parameter within 1e-3
/// of its magnitude (bias terms near zero: of 1e-3, the size of the
/// smallest coefficients). The remaining error is the quadrature's O(h⁴)
/// and the rates' kinks at the steps: 1e-6 measured.
#[test]
fn fourier_regression_recovers_ideal_data() {
    for (scenario, profile, models) in [
        (
            "attas-multisine",
            "ideal",
            ["attas-lateral", "attas-longitudinal"],
        ),
        (
            "attas-lateral-multistep",
            "ideal",
            ["attas-lateral", "attas-lateral"],
        ),
    ] {
        let (record, truth) = recorded(scenario, profile, 1.0);
        for model in models {
            let structure = ModelStructure::load(model).unwrap();
            let estimate =
                frequency_regression(&record, &structure, &FrequencyRegressionOptions::default())
                    .unwrap();
            assert_eq!(estimate.status, Status::Converged, "{:?}", estimate.notes);
            let (name, error) = worst_error(&estimate, &truth, 1e-3);
            assert!(
                error < 1e-3,
                "{scenario}, {model}: {name} off by {error:.2e}\n{:?}",
                estimate.notes
            );
        }
    }
}

/// Without the breaks at the control steps the moment derivatives of the
/// multistep are off by per cents: the transform of a held control smeared
/// over a sample interval (measured 5 % on Cl_p at 25 Hz). With a band
/// given, the automatic band's transform is not involved.
#[test]
fn the_recursive_form_ends_on_the_batch_estimate() {
    let (record, _) = recorded("attas-lateral-multistep", "flight-test-25hz", 1.0);
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let batch =
        frequency_regression(&record, &structure, &FrequencyRegressionOptions::default()).unwrap();
    let options = FrequencyRegressionOptions {
        recursive: true,
        ..Default::default()
    };
    let recursive = frequency_regression(&record, &structure, &options).unwrap();
    assert_eq!(batch.parameters.len(), recursive.parameters.len());
    for (b, r) in batch.parameters.iter().zip(&recursive.parameters) {
        assert_eq!(b.name, r.name);
        assert!(
            (b.value - r.value).abs() <= 1e-9 * b.value.abs().max(1e-6),
            "{}: {} against {}",
            b.name,
            b.value,
            r.value
        );
        assert!(
            (b.standard_error - r.standard_error).abs() <= 1e-9 * b.standard_error,
            "{}",
            b.name
        );
    }
}

/// A lateral model in dimensional derivatives (ATTAS-like magnitudes at
/// 103 m/s): x = (β, p, r, φ), u = (δa, δr), y = x.
fn lateral_model() -> (LinearStateSpace, DVector<f64>) {
    #[rustfmt::skip]
    let a = DMatrix::from_row_slice(4, 4, &[
        -0.16, 0.03, -0.99, 0.095,
        -5.5, -1.6, 0.55, 0.0,
        2.4, -0.06, -0.25, 0.0,
        0.0, 1.0, 0.05, 0.0,
    ]);
    #[rustfmt::skip]
    let b = DMatrix::from_row_slice(4, 2, &[
        0.0, 0.028,
        -2.3, 0.55,
        -0.12, -1.3,
        0.0, 0.0,
    ]);
    let entry = |matrix, row, column| Entry {
        matrix,
        row,
        column,
    };
    let mut parameters = Vec::new();
    for (row, columns) in [(0, vec![0, 2]), (1, vec![0, 1, 2]), (2, vec![0, 1, 2])] {
        for column in columns {
            parameters.push(vec![entry(Matrix::A, row, column)]);
        }
    }
    for (row, column) in [(0, 1), (1, 0), (1, 1), (2, 0), (2, 1)] {
        parameters.push(vec![entry(Matrix::B, row, column)]);
    }
    let model = LinearStateSpace::new(
        [a, b, DMatrix::identity(4, 4), DMatrix::zeros(4, 2)],
        parameters,
        0.0,
        0.02,
        vec![DVector::zeros(2); 2],
    )
    .unwrap();
    let truth = model.parameter_values();
    (model, truth)
}

/// Multisine inputs (rad): aileron and rudder, harmonics of 1/20 Hz.
fn inputs(t: f64) -> SVector<f64, 2> {
    let tau = std::f64::consts::TAU;
    let sines = |harmonics: &[f64], amplitude: f64| -> f64 {
        harmonics
            .iter()
            .enumerate()
            .map(|(i, h)| amplitude * (tau * h * 0.05 * t + 1.3 * i as f64).sin())
            .sum()
    };
    SVector::from([
        sines(&[2.0, 5.0, 9.0, 14.0, 20.0], 0.012),
        sines(&[3.0, 7.0, 11.0, 17.0, 24.0], 0.010),
    ])
}

/// Output error in the frequency domain on a flight of the linear model
/// itself (RK4 at 2 ms, continuous inputs; sampled at 50 Hz over 40 s),
/// from a start 30 % off: every parameter within 1e-3 (relative), what is
/// left being the quadrature's O(h⁴) and the integration's error.
#[test]
fn frequency_output_error_recovers_a_linear_model() {
    let (model, truth) = lateral_model();
    let [a, b, ..] = [model.a.clone(), model.b.clone()];
    let (fine, every, count) = (0.002, 10, 2001);
    let mut x = SVector::<f64, 4>::zeros();
    let mut states = Vec::with_capacity(count);
    let mut controls = Vec::with_capacity(count);
    for k in 0..(count - 1) * every + 1 {
        let t = k as f64 * fine;
        if k % every == 0 {
            states.push(x);
            controls.push(inputs(t));
        }
        let derivative = |x: &SVector<f64, 4>, fraction: f64| -> SVector<f64, 4> {
            let u = inputs(t + fraction * fine);
            let ax = &a * DVector::from_column_slice(x.as_slice());
            let bu = &b * DVector::from_column_slice(u.as_slice());
            SVector::from_fn(|i, _| ax[i] + bu[i])
        };
        x = rk4_step(&x, fine, derivative);
    }
    let step = fine * every as f64;
    let duration = (count - 1) as f64 * step;
    let frequencies: Vec<f64> = (1..=60)
        .map(|m| std::f64::consts::TAU * m as f64 / duration)
        .collect();
    let transform = FourierTransform::new(&frequencies, 0.0, step, count).unwrap();
    let u = DMatrix::from_fn(count, 2, |k, i| controls[k][i]);
    let y = DMatrix::from_fn(count, 4, |k, i| states[k][i]);
    let last: Vec<f64> = states[count - 1].iter().copied().collect();
    let data = FrequencyData::new(&transform, &u, &y, (&[0.0; 4], &last)).unwrap();
    let start = truth.map(|v| 1.3 * v);
    let free: Vec<usize> = (0..truth.len()).collect();
    let mut options = Options::new(free.len());
    options.max_iterations = 40;
    let fit = fit_transfer(&model, &data, &start, &free, &options).unwrap();
    assert_eq!(fit.solution.status, Status::Converged);
    for i in 0..truth.len() {
        let error = (fit.theta[i] - truth[i]).abs() / truth[i].abs();
        assert!(
            error < 1e-3,
            "parameter {i}: {} against {} ({error:.1e})",
            fit.theta[i],
            truth[i]
        );
    }
}

/// `fdoe` on the nonlinear simulator's lateral multistep (noise free): the
/// linear model about the first sample is its only error, and it grows
/// with the amplitude. Measured, worst relative error over the fifteen
/// derivatives (always CY_da, the smallest, 0.0103): inputs × 0.25: 5 %
/// (the rolling and yawing moment derivatives within 0.7 %); full
/// amplitude (±4° aileron and rudder multisteps): 80 % (Cn_p 12 %, Cl_p 1.4 %).
/// Pinned at 1.5× those so that a change is seen.
#[test]
fn frequency_output_error_on_the_simulator_is_limited_by_the_linearisation() {
    const SMALL: f64 = 0.05;
    const FULL: f64 = 0.80;
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let mut worst = Vec::new();
    for scale in [0.25, 1.0] {
        let (record, truth) = recorded("attas-lateral-multistep", "ideal", scale);
        let estimate =
            frequency_output_error(&record, &structure, &FrequencyOutputErrorOptions::default())
                .unwrap();
        assert_eq!(estimate.status, Status::Converged, "{:?}", estimate.notes);
        assert!(
            estimate.parameter("Cl_0").is_none(),
            "bias terms are not estimated"
        );
        let (name, error) = worst_error(&estimate, &truth, 1e-3);
        println!("inputs × {scale}: worst {name} {error:.3}");
        worst.push(error);
    }
    assert!(worst[0] < 1.5 * SMALL, "× 0.25: {:.3}", worst[0]);
    assert!(worst[1] < 1.5 * FULL, "× 1: {:.3}", worst[1]);
    assert!(
        worst[0] < worst[1],
        "a smaller manoeuvre is closer to linear"
    );
}

/// Both methods on a flight of a bundled linear structure
/// (`linear-lateral-attas`, the ATTAS lateral linearisation, flown by the
/// linear model itself, ideal profile): every dimensional derivative within
/// 1e-5 of max(|truth|, 0.01) (measured worst: `fdee` 2.2e-8 absolute on
/// B_beta_aileron = 0.0014, the smallest entry; `fdoe` 5e-9).
#[test]
fn both_methods_recover_a_linear_structure() {
    let scenario = Scenario::load("linear-lateral-attas").unwrap();
    let profile = Profile::load("ideal", None).unwrap();
    let (record, truth) = record_flight(&scenario, &profile, scenario.seed).unwrap();
    let structure = LinearStructure::load("linear-lateral-attas").unwrap();
    let estimates = [
        linear_frequency_regression(&record, &structure, &Default::default()).unwrap(),
        linear_frequency_output_error(&record, &structure, &Default::default()).unwrap(),
    ];
    for estimate in &estimates {
        assert_eq!(estimate.status, Status::Converged, "{:?}", estimate.notes);
        assert_eq!(estimate.parameters.len(), 16);
        let (name, error) = worst_error(estimate, &truth, 1e-2);
        assert!(
            error < 1e-5,
            "{}: {name} off by {error:.1e}",
            estimate.method
        );
    }
}

/// Settings out of range are errors naming the method's table and the key.
#[test]
fn bad_settings_are_refused_with_the_key() {
    use aeroid::estimation::methods::frequency_output_error::FrequencyOutputErrorSettings;
    use aeroid::estimation::methods::frequency_regression::FrequencyRegressionSettings;
    let settings = |text: &str| -> aeroid::estimation::estimator::Settings {
        let table: toml::Table = toml::from_str(text).unwrap();
        serde_json::to_value(table)
            .unwrap()
            .as_object()
            .unwrap()
            .clone()
    };
    for (text, key) in [
        (r#"band = ["2 Hz", "1 Hz"]"#, "band"),
        (r#"band = ["0.1 Hz", "1 m"]"#, "band"),
        (r#"resolution = "-0.1 Hz""#, "resolution"),
        ("input_threshold = 1.5", "input_threshold"),
        ("bandwidth = 3", "bandwidth"),
    ] {
        let message = FrequencyRegressionSettings::read(&settings(text))
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("[methods.fdee]") && message.contains(key),
            "{text}: {message}"
        );
    }
    let message = FrequencyOutputErrorSettings::read(&settings("max_iterations = 0"))
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("[methods.fdoe]") && message.contains("max_iterations"),
        "{message}"
    );
}
