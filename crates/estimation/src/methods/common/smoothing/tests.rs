//! Tests of the smoother's algebra, the inputs and the Gauss–Markov bounds.

use super::inputs::unwrapped_yaw;
use super::regression::regress_smoothed;
use super::smoother::{process_noise, smooth_with};
use super::{GaussMarkov, METHOD, Smoothed, SmoothedRegressionSettings};
use crate::methods::common::regression;
use crate::model::coefficient_states::{
    self, COEFFICIENT_NAMES, H, P, PHI, PSI, STATE_COUNT, THETA, U,
};
use crate::solver::extended_kalman::Keep;
use crate::structure::ModelStructure;
use aeroid_record::Channel;
use aeroid_record::FlightRecord;
use nalgebra::{DMatrix, DVector};
use std::f64::consts::PI;

/// The scalar updates and their smoother give the vector updates'
/// results to rounding (`smoother`'s header, steps 2–3: equal in exact
/// arithmetic), on the record the `ebm_smoother_pass` bench runs on
/// (ATTAS lateral multistep, flight-test-25hz, 1501 points, 28 states,
/// 13 outputs): each smoothed state within 1e-9 of its largest value
/// over the record, each standard deviation within 1e-9 of its largest
/// (rounding carried through 1501 filter and smoother steps, the
/// covariance shrinking by orders of magnitude, is about 1e-12 and
/// below; an error in the sequence's algebra moves them by its own
/// size), the regressed estimates within 1e-6 of their standard errors
/// and those within 1e-8 relative.
#[test]
fn scalar_and_vector_updates_smooth_alike() {
    use aeroid_record::recorder::{Profile, record_scenario};
    use aeroid_sim::scenario::Scenario;
    let scenario = Scenario::load("attas-lateral-multistep").unwrap();
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    let (record, _) = record_scenario(&scenario, &profile).unwrap();
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let settings = SmoothedRegressionSettings::default();
    let run = |keep: Keep| {
        let plans = regression::plans(&structure, METHOD).unwrap();
        let smoothed = smooth_with(&record, &structure, &settings, &plans, keep).unwrap();
        let estimate = regress_smoothed(&record, &structure, &settings, plans, &smoothed).unwrap();
        (smoothed, estimate)
    };
    let (scalar, scalar_estimate) = run(Keep::SEQUENTIAL_SMOOTHER);
    let (vector, vector_estimate) = run(Keep::SMOOTHER);
    assert_eq!(scalar.states.len(), vector.states.len());
    let worst = |of: fn(&Smoothed) -> &Vec<DVector<f64>>| {
        let (a, b) = (of(&scalar), of(&vector));
        (0..STATE_COUNT)
            .map(|i| {
                let largest = b.iter().map(|x| x[i].abs()).fold(0.0, f64::max);
                let difference = a
                    .iter()
                    .zip(b)
                    .map(|(x, y)| (x[i] - y[i]).abs())
                    .fold(0.0, f64::max);
                difference / largest.max(f64::MIN_POSITIVE)
            })
            .fold(0.0, f64::max)
    };
    let (states, deviations) = (worst(|s| &s.states), worst(|s| &s.deviations));
    let (mut estimates, mut errors) = (0.0_f64, 0.0_f64);
    for (a, b) in scalar_estimate
        .parameters
        .iter()
        .zip(&vector_estimate.parameters)
    {
        assert_eq!(a.name, b.name);
        estimates = estimates.max((a.value - b.value).abs() / b.standard_error);
        errors = errors.max((a.standard_error - b.standard_error).abs() / b.standard_error);
    }
    println!(
        "scalar against vector updates: states {states:.1e}, deviations {deviations:.1e} of their largest; estimates {estimates:.1e} of their standard errors, those {errors:.1e} relative"
    );
    assert!(
        states < 1e-9 && deviations < 1e-9,
        "{states:e} {deviations:e}"
    );
    assert!(
        estimates < 1e-6 && errors < 1e-8,
        "{estimates:e} {errors:e}"
    );
}

/// A heading through ±180° becomes continuous; dropouts stay dropouts
/// and do not break the unwrapping.
#[test]
fn yaw_is_unwrapped_across_the_branch_cut() {
    let values = vec![3.0, 3.1, f64::NAN, -3.1, -3.0, 3.05];
    let record = FlightRecord {
        channels: vec![Channel {
            name: "yaw".into(),
            unit: "rad".into(),
            rate: 1.0,
            resolution: None,
            source: "test".into(),
            times: (0..values.len()).map(|k| k as f64).collect(),
            values,
        }],
        ..FlightRecord::default()
    };
    let unwrapped = unwrapped_yaw(&record).channels[0].values.clone();
    let expected = [3.0, 3.1, f64::NAN, 2.0 * PI - 3.1, 2.0 * PI - 3.0, 3.05];
    for (u, e) in unwrapped.iter().zip(expected) {
        assert!(
            u.is_nan() && e.is_nan() || (u - e).abs() < 1e-12,
            "{unwrapped:?}"
        );
    }
}

/// The change bound: for a transport at q̄ = 10 kPa (accelerations per
/// unit coefficient 36 m/s² for the forces, 103, 8 and 38 rad/s² for
/// Cl, Cm, Cn) the default chains are left alone at 25 Hz; at 1 Hz each
/// is lowered so that its spread over one sample period, the (0, 0)
/// entry of the exact (Van Loan) discrete noise of the chain, times the
/// gain is the bound, its initial derivative deviations to σ_C/T and
/// 2·σ_C/T², and its axis takes white noise of bound²·T.
#[test]
fn change_bounds_hold_the_spread_over_one_sample_period() {
    use crate::solver::extended_kalman::Discretisation;
    let settings = SmoothedRegressionSettings::default();
    let gains = [36.0, 36.0, 36.0, 103.0, 8.0, 38.0];
    let fast = GaussMarkov::for_period(&settings, &gains, 0.04);
    assert!(fast.bounded.is_empty(), "{:?}", fast.bounded);
    assert_eq!(fast.white, [0.0; 6]);
    assert_eq!(fast.density[3], settings.moment_noise);
    let period = 1.0;
    let slow = GaussMarkov::for_period(&settings, &gains, period);
    assert_eq!(slow.bounded, COEFFICIENT_NAMES.to_vec());
    let chain = DMatrix::from_row_slice(3, 3, &[0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
    for (i, gain) in gains.iter().enumerate() {
        let bound = if i < 3 {
            settings.force_change_bound
        } else {
            settings.moment_change_bound
        };
        let mut density = DMatrix::zeros(3, 3);
        density[(2, 2)] = slow.density[i];
        let (_, noise) = Discretisation::Exact.transition_and_noise(&chain, &density, period);
        let spread = noise[(0, 0)].sqrt() * gain;
        assert!(
            (spread / bound - 1.0).abs() < 1e-9,
            "{i}: {spread} against {bound}"
        );
        let sigma = bound / gain;
        let initial = slow.initial[i];
        assert!(
            initial[1] <= sigma / period * (1.0 + 1e-12),
            "{i}: {initial:?}"
        );
        assert!(initial[2] <= 2.0 * sigma / (period * period) * (1.0 + 1e-12));
        assert_eq!(slow.white[i], bound * bound * period);
    }
    let q = process_noise(&settings, &slow);
    assert_eq!(q[(U, U)], settings.force_change_bound.powi(2) * period);
    assert_eq!(
        q[(P + 1, P + 1)],
        settings.moment_change_bound.powi(2) * period
    );
}

/// The process noise puts each setting on its states: the third
/// derivatives of the coefficients, the velocities and the rates, and
/// nothing on the kinematic angles, height or lower derivatives.
#[test]
fn process_noise_sits_on_the_third_derivatives_and_velocities() {
    let settings = SmoothedRegressionSettings::default();
    let markov = GaussMarkov::for_period(&settings, &[1.0; 6], 0.04);
    let q = process_noise(&settings, &markov);
    for i in 0..3 {
        let force = coefficient_states::coefficient(i);
        let moment = coefficient_states::coefficient(3 + i);
        assert_eq!(q[(force + 2, force + 2)], settings.force_noise);
        assert_eq!(q[(moment + 2, moment + 2)], settings.moment_noise);
        assert_eq!(q[(force, force)] + q[(force + 1, force + 1)], 0.0);
        assert_eq!(q[(U + i, U + i)], settings.velocity_noise);
        assert_eq!(q[(P + i, P + i)], settings.rate_noise);
    }
    for state in [PHI, THETA, PSI, H] {
        assert_eq!(q[(state, state)], 0.0);
    }
    assert_eq!(q.nrows(), STATE_COUNT);
    assert_eq!((&q - DMatrix::from_diagonal(&q.diagonal())).amax(), 0.0);
}
