//! Equation error (least squares, as in the ELM + Gauss–Newton and reflex-wing UAV papers) and stepwise regression
//! on simulated ATTAS flights: exact recovery on ideal data, the
//! errors-in-variables bias on the noisy 25 Hz flight-test profile, model
//! structure determination, and named errors for bad input.
//!
//! The manoeuvre: ATTAS trimmed at 103 m/s, 4877 m; a Schroeder-phased
//! multisine on elevator (1.5°), aileron (3°) and rudder (2°) from 1 s,
//! harmonics of 0.05 Hz between 0.1 and 0.8 Hz interleaved over the three
//! controls, two 20 s periods; 60 s at a 0.01 s step with LINEAR input
//! interpolation. Why linear: with zero-order-hold inputs the recorded
//! control at t_k is the value held over [t_k, t_k+1), half a step ahead of
//! the mean control the differentiated rate reflects: 1–5 % errors even for
//! the multisine, a property of the simulated data, not of the method. Step
//! inputs (a 3211, doublets) are covered by the golden gates: the simulator
//! has no actuator dynamics, so the angular accelerations jump at a step,
//! and the differentiator leaves out the samples whose window would cross
//! one (crates/estimation/src/differentiation.rs); without that the jumps were
//! smeared into 1–7 % errors.

use aeroid::estimation::estimate::Estimate;
use aeroid::estimation::estimate::Status;
use aeroid::estimation::methods::equation_error::{EquationErrorOptions, equation_error};
use aeroid::estimation::methods::stepwise::{Action, StepwiseOptions, stepwise};
use aeroid::estimation::reconstruction::{ReconstructionOptions, Request, StepBreaks, reconstruct};
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::Simulation;
use aeroid::sim::aero::{Coefficient, Regressor};
use aeroid::sim::aircraft::Aircraft;
use aeroid::sim::scenario::{Scenario, ScenarioFile};
use nalgebra::{DMatrix, DVector};
use std::path::Path;

const MULTISINE: &str = r#"
[[inputs]]
kind = "multisine"
controls = ["elevator", "aileron", "rudder"]
amplitudes = ["1.5 deg", "3 deg", "2 deg"]
start = "1 s"
period = "20 s"
frequency_min = "0.1 Hz"
frequency_max = "0.8 Hz"
cycles = 2
"#;

/// The test manoeuvre (module documentation) with the given inputs.
fn manoeuvre(inputs: &str) -> Scenario {
    let text = format!(
        r#"name = "attas-multisine"
aircraft = "attas"
duration = "60 s"
step = "0.01 s"
seed = 1
interpolation = "linear"
[trim]
airspeed = "103 m/s"
altitude = "4877 m"
{inputs}"#
    );
    let file: ScenarioFile = toml::from_str(&text).unwrap();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/attas-multisine.toml");
    Scenario::from_file(&file, &path).unwrap()
}

fn truth() -> Aircraft {
    Aircraft::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("aircraft/attas.toml")).unwrap()
}

fn ideal_record() -> FlightRecord {
    let profile = Profile::load("ideal", None).unwrap();
    record_scenario(&manoeuvre(MULTISINE), &profile).unwrap().0
}

fn relative_error(estimate: &Estimate, truth: &Aircraft, name: &str) -> f64 {
    let value = estimate.parameter(name).unwrap().value;
    let true_value = truth.aero.parameters.get(name).unwrap();
    (value - true_value) / true_value
}

/// Ideal profile (100 Hz, no error of any kind), structure attas-full equal
/// to the truth model, every one of its 28 parameters free (the multisine
/// excites all of them). Truth: aircraft/attas.toml.
/// - Forces (CL, CD with the Oswald factor, CY) need no differentiation: the
///   coefficients are reconstructed exactly, so every force parameter is
///   recovered to 1e-9 relative (measured: ≤ 3e-13).
/// - Moments need ṗ, q̇, ṙ: the issue's gate is 1e-3 relative (the
///   differentiation error). Measured with the default differentiator
///   (degree 4, ±0.1 s): worst 3.3e-4 (Cn_r), Cl_0 3.0e-4, Cm_q 1.8e-4.
///   The error budget: the differentiator's gain error (2e-5 at 0.5 Hz, 4e-4
///   at 1 Hz) and the simulator's piecewise-linear input between 0.01 s
///   steps, whose mean offset −ü·Δ²/12 makes a relative error ≈ (ωΔ)²/12
///   (checked: halving the step quarters it). A degree-2 (linear-fit)
///   differentiator of the same width misses the gate by 5×.
#[test]
fn ideal_data_recovers_every_parameter() {
    let record = ideal_record();
    let structure = ModelStructure::load("attas-full").unwrap();
    let estimate = equation_error(&record, &structure, &EquationErrorOptions::default()).unwrap();
    let truth = truth();
    assert_eq!(estimate.status, Status::Converged, "{:?}", estimate.notes);
    assert_eq!(estimate.method, "ee");
    assert_eq!(estimate.parameters.len(), 28);
    for parameter in &estimate.parameters {
        let error = relative_error(&estimate, &truth, &parameter.name).abs();
        let moment = ["Cl_", "Cm_", "Cn_"]
            .iter()
            .any(|p| parameter.name.starts_with(p));
        let tolerance = if moment { 1e-3 } else { 1e-9 };
        assert!(
            error < tolerance,
            "{}: {} vs truth, relative error {error:e} (tolerance {tolerance:e})",
            parameter.name,
            parameter.value
        );
        assert!(parameter.standard_error.is_finite() && parameter.standard_error >= 0.0);
    }
    for fit in &estimate.fits {
        assert!(fit.r_squared > 0.9999, "{fit:?}");
    }
    assert_eq!(estimate.covariance.len(), 28);
    assert!(
        estimate
            .notes
            .iter()
            .any(|n| n.contains("Savitzky–Golay") && n.contains("100 Hz"))
    );
    assert!(estimate.notes.iter().any(|n| n.contains("Morelli & Klein")));
}

/// The errors-in-variables prediction of the least-squares limit of the
/// regression of one coefficient on the terms `parameters` (all of its
/// terms, e.g. ["Cm_0", "Cm_alpha", "Cm_q", "Cm_de"]):
/// θ∞ = (M_xx + M_nn)⁻¹·M_xx·θ with M_xx the second moments of the true
/// regressors (from the ideal record) and M_nn the diagonal of the
/// recorder's white-noise variances in regressor units (rates scaled by
/// c̄/(2V) or b/(2V) at the mean airspeed). Returns θ∞ in the same order.
fn errors_in_variables_limit(
    ideal: &FlightRecord,
    noisy: &Profile,
    parameters: &[&str],
) -> Vec<f64> {
    let structure = ModelStructure::load("attas-full").unwrap();
    let truth = truth();
    let regressors: Vec<Regressor> = parameters
        .iter()
        .map(|name| Regressor::from_key(name.split_once('_').unwrap().1).unwrap())
        .collect();
    let request = Request {
        coefficients: vec![Coefficient::Pitch],
        regressors: regressors.clone(),
    };
    let data = reconstruct(
        ideal,
        &structure.aircraft,
        &request,
        &ReconstructionOptions::default(),
        "test",
    )
    .unwrap();
    let count = data.times.len();
    let x = DMatrix::from_fn(count, regressors.len(), |k, j| {
        data.regressors[k][regressors[j] as usize]
    });
    let moments = x.transpose() * &x / count as f64;
    let noise = |name: &str| {
        noisy
            .channels
            .iter()
            .find(|c| c.measurand.name == name)
            .unwrap()
            .noise
    };
    let speeds = &ideal.channel("airspeed").unwrap().values;
    let twice_speed = 2.0 * speeds.iter().sum::<f64>() / speeds.len() as f64;
    let geometry = structure.aircraft.geometry;
    let noise_deviation = |regressor: Regressor| match regressor {
        Regressor::Constant => 0.0,
        Regressor::Alpha => noise("alpha"),
        Regressor::Beta => noise("beta"),
        Regressor::RollRate => noise("p") * geometry.span / twice_speed,
        Regressor::PitchRate => noise("q") * geometry.chord / twice_speed,
        Regressor::YawRate => noise("r") * geometry.span / twice_speed,
        Regressor::Elevator => noise("elevator"),
        Regressor::Aileron => noise("aileron"),
        Regressor::Rudder => noise("rudder"),
        other => panic!("no noise model for {other:?}"),
    };
    let noise_moments = DMatrix::from_diagonal(&DVector::from_iterator(
        regressors.len(),
        regressors.iter().map(|r| noise_deviation(*r).powi(2)),
    ));
    let theta = DVector::from_iterator(
        parameters.len(),
        parameters
            .iter()
            .map(|name| truth.aero.parameters.get(name).unwrap()),
    );
    let limit = (&moments + noise_moments).try_inverse().unwrap() * &moments * theta;
    limit.iter().copied().collect()
}

/// Noisy flight-test profile (25 Hz; α, β, angles and controls 0.1°, rates
/// 0.002 rad/s, accelerations 0.02 m/s²): 40 recordings of the same flight
/// with different recorder seeds (the simulation is flown once), attas-full
/// all free. Least squares assumes noise-free regressors; with noisy ones
/// the estimates are attenuated towards zero (the reflex-wing UAV paper's finding: its LS
/// Clp, Clβ, Clδa were 25–35 % smaller than ML). Measured mean errors
/// (Monte Carlo standard error in brackets, truth from aircraft/attas.toml):
/// - CL_alpha 3.30: −0.183 [0.003], −5.6 %, z ≈ −57;
/// - Cm_q −12.3: +1.55 [0.07], −12.6 % in magnitude, z ≈ +22;
/// - Cl_p −0.389: +0.0058 [0.0003], −1.5 % in magnitude, z ≈ +17.
///
/// Asserted: each bias is more than 5 Monte Carlo standard errors from zero
/// and towards zero; for CL_alpha and Cm_q it agrees with the
/// errors-in-variables prediction (see `attenuated_longitudinal`) within 4
/// Monte Carlo standard errors plus 15 % of the prediction (the prediction
/// ignores the α error in the CL rotation, −CD·δα, and the 100 Hz vs 25 Hz
/// sampling of the moments); and the reported (coloured-residual corrected)
/// standard error is within a factor 0.7–2.5 of the Monte Carlo scatter.
#[test]
fn noisy_regressors_bias_estimates_towards_zero() {
    let scenario = manoeuvre(MULTISINE);
    let trace = Simulation::prepare(&scenario).unwrap().run().unwrap();
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    let structure = ModelStructure::load("attas-full").unwrap();
    let truth = truth();
    let names = ["CL_alpha", "Cm_q", "Cl_p"];
    let runs = 40;
    let mut errors = vec![Vec::new(); names.len()];
    let mut standard_errors = vec![Vec::new(); names.len()];
    for seed in 0..runs {
        let record = profile
            .record(&trace, &scenario.aircraft, 1000 + seed)
            .unwrap();
        let estimate =
            equation_error(&record, &structure, &EquationErrorOptions::default()).unwrap();
        assert_eq!(estimate.status, Status::Converged);
        for (i, name) in names.iter().enumerate() {
            let parameter = estimate.parameter(name).unwrap();
            errors[i].push(parameter.value - truth.aero.parameters.get(name).unwrap());
            standard_errors[i].push(parameter.standard_error);
        }
    }
    let ideal = ideal_record();
    let value = |name: &str| truth.aero.parameters.get(name).unwrap();
    let lift = errors_in_variables_limit(&ideal, &profile, &["CL_0", "CL_alpha", "CL_q", "CL_de"]);
    let pitch = errors_in_variables_limit(&ideal, &profile, &["Cm_0", "Cm_alpha", "Cm_q", "Cm_de"]);
    let roll = errors_in_variables_limit(
        &ideal,
        &profile,
        &["Cl_0", "Cl_beta", "Cl_p", "Cl_r", "Cl_da", "Cl_dr"],
    );
    let predicted_bias = [
        lift[1] - value("CL_alpha"),
        pitch[2] - value("Cm_q"),
        roll[2] - value("Cl_p"),
    ];
    for (i, name) in names.iter().enumerate() {
        let n = runs as f64;
        let mean = errors[i].iter().sum::<f64>() / n;
        let scatter =
            (errors[i].iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let monte_carlo_error = scatter / n.sqrt();
        let true_value = value(name);
        let reported = standard_errors[i].iter().sum::<f64>() / n;
        println!(
            "{name}: truth {true_value}, mean error {mean:.4e} ({:.2} %), Monte Carlo standard error {monte_carlo_error:.2e}, scatter {scatter:.2e}, mean reported σ {reported:.2e}, predicted bias {:.4e}",
            100.0 * mean / true_value,
            predicted_bias[i]
        );
        assert!(
            mean.abs() > 5.0 * monte_carlo_error,
            "{name}: bias not significant"
        );
        assert!(
            mean * true_value < 0.0 && mean.abs() < true_value.abs(),
            "{name}: not towards zero"
        );
        let predicted = predicted_bias[i];
        assert!(
            (mean - predicted).abs() < 4.0 * monte_carlo_error + 0.15 * predicted.abs(),
            "{name}: measured bias {mean:e}, errors-in-variables prediction {predicted:e}"
        );
        assert!(
            (0.7..2.5).contains(&(reported / scatter)),
            "{name}: reported σ {reported:e} vs scatter {scatter:e}"
        );
    }
}

/// A record without the pitch-rate channel: an error that names 'q' and
/// what it is needed for (Cm, and the rate regressors), never a panic.
#[test]
fn missing_pitch_rate_is_named() {
    let mut record = ideal_record();
    record.channels.retain(|c| c.name != "q");
    let structure = ModelStructure::load("attas-longitudinal").unwrap();
    let message = equation_error(&record, &structure, &EquationErrorOptions::default())
        .unwrap_err()
        .to_string();
    assert!(message.contains("'q'"), "{message}");
    assert!(message.contains("Cm"), "{message}");
    let message = stepwise(
        &record,
        &structure,
        Coefficient::Pitch,
        &StepwiseOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(message.contains("'q'"), "{message}");
}

/// Elevator-only multisine, full structure: aileron and rudder never move,
/// so the Cl, Cn and CY regressor matrices have zero columns. The estimate
/// is Diverged with a reason naming the coefficient and the parameters (no
/// panic), those parameters get infinite standard errors, and the
/// longitudinal ones are still recovered (1e-3).
#[test]
fn unexcited_terms_are_reported_as_unidentifiable() {
    let elevator_only = MULTISINE
        .replace(r#"["elevator", "aileron", "rudder"]"#, r#"["elevator"]"#)
        .replace(r#"["1.5 deg", "3 deg", "2 deg"]"#, r#"["1.5 deg"]"#);
    let profile = Profile::load("ideal", None).unwrap();
    let record = record_scenario(&manoeuvre(&elevator_only), &profile)
        .unwrap()
        .0;
    let structure = ModelStructure::load("attas-full").unwrap();
    let estimate = equation_error(&record, &structure, &EquationErrorOptions::default()).unwrap();
    let Status::Diverged(reason) = &estimate.status else {
        panic!("expected Diverged, got {:?}", estimate.status);
    };
    assert!(
        reason.contains("Cl:") && reason.contains("Cl_da"),
        "{reason}"
    );
    assert!(
        estimate
            .parameter("Cn_dr")
            .unwrap()
            .standard_error
            .is_infinite()
    );
    let truth = truth();
    for name in ["CL_alpha", "Cm_alpha", "Cm_q", "Cm_de"] {
        assert!(
            relative_error(&estimate, &truth, name).abs() < 1e-3,
            "{name}"
        );
    }
}

/// Stepwise regression on the ideal record, every coefficient, from the
/// default pool (every regressor key the record supplies: α, β, p̂, q̂, r̂,
/// α̇, δe, δa, δr, δf, plus CL² for drag, plus the centred products α², αβ,
/// β², α·δe). The truth (aircraft/attas.toml) has, besides the constant:
/// CL {α, q, δe}, CD {CL² (induced drag)}, CY, Cl, Cn {β, p, r, δa, δr},
/// Cm {α, q, δe}; no α̇, no flap, no squares or products. The procedure must
/// select exactly the true terms, report R² and PRESS at every step (R²
/// rising, PRESS falling with each entry), end with R² > 99.99 %, and give
/// Cm_alpha within 1e-3 of the truth in its estimate ("swr").
#[test]
fn stepwise_selects_the_true_terms() {
    let record = ideal_record();
    let structure = ModelStructure::load("attas-full").unwrap();
    let truth = truth();
    let lateral = ["beta", "p", "r", "da", "dr"];
    let expected: [(Coefficient, &[&str]); 6] = [
        (Coefficient::Lift, &["alpha", "q", "de"]),
        (Coefficient::Drag, &["CL2"]),
        (Coefficient::Side, &lateral),
        (Coefficient::Roll, &lateral),
        (Coefficient::Pitch, &["alpha", "q", "de"]),
        (Coefficient::Yaw, &lateral),
    ];
    for (coefficient, terms) in expected {
        let report = stepwise(
            &record,
            &structure,
            coefficient,
            &StepwiseOptions::default(),
        )
        .unwrap();
        let mut selected = report.steps.last().unwrap().terms.clone();
        selected.sort();
        let mut wanted: Vec<String> = terms.iter().map(|t| t.to_string()).collect();
        wanted.sort();
        assert_eq!(selected, wanted, "{report}");
        assert!(report.excluded.iter().any(|(name, _)| name == "alpha^2"));
        for pair in report.steps.windows(2) {
            if pair[1].action == Action::Enter {
                assert!(pair[1].r_squared > pair[0].r_squared, "{report}");
                assert!(pair[1].press < pair[0].press, "{report}");
            }
        }
        assert!(report.steps.last().unwrap().r_squared > 0.9999, "{report}");
        let table = report.to_string();
        assert!(
            table.contains("PRESS") && table.contains("R² [%]"),
            "{table}"
        );
        if coefficient == Coefficient::Pitch {
            let estimate = report.estimate();
            assert_eq!(estimate.method, "swr");
            assert!(relative_error(&estimate, &truth, "Cm_alpha").abs() < 1e-3);
        }
    }
}

/// The ATTAS lateral multistep with every change a ramp over one sample
/// interval (0.01 s at the ideal profile's 100 Hz): the angular
/// accelerations turn at both of its corners, the last sample before the
/// change and the first after it, and the samples cannot tell that ramp
/// from a step. The differentiator breaks at both, so every window lies
/// on one side of each corner, and equation error recovers every
/// parameter within 1e-4 of its truth (relative; 1e-7 absolute for the
/// near-zero constant terms Cl_0 and Cn_0), as on the gates' ramps
/// through several samples (golden/gates.toml). Breaking only at the
/// first sample with the new value (`StepBreaks::NewValue`, what the
/// neural restricted model keeps), a window ending there reaches across
/// the ramp's first corner and some term misses 1e-4.
#[test]
fn ramps_over_one_sample_interval_break_at_both_corners() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/attas-lateral-multistep-ramped.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("transition = \"0.1 s\"", "transition = \"0.01 s\"");
    assert_eq!(text.matches("transition = \"0.01 s\"").count(), 2);
    let file: ScenarioFile = toml::from_str(&text).unwrap();
    let scenario = Scenario::from_file(&file, &path).unwrap();
    let profile = Profile::load("ideal", None).unwrap();
    let record = record_scenario(&scenario, &profile).unwrap().0;
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let truth = &scenario.aircraft;
    let misses = |options: &EquationErrorOptions| -> Vec<String> {
        let estimate = equation_error(&record, &structure, options).unwrap();
        assert_eq!(estimate.status, Status::Converged, "{:?}", estimate.notes);
        assert_eq!(estimate.parameters.len(), 18);
        estimate
            .parameters
            .iter()
            .filter_map(|parameter| {
                let true_value = truth.aero.parameters.get(&parameter.name).unwrap();
                let error = (parameter.value - true_value).abs();
                (error > (1e-4 * true_value.abs()).max(1e-7)).then(|| {
                    format!(
                        "{}: {} against {true_value}, relative error {:e}",
                        parameter.name,
                        parameter.value,
                        error / true_value.abs()
                    )
                })
            })
            .collect()
    };
    let missed = misses(&EquationErrorOptions::default());
    assert!(missed.is_empty(), "{missed:#?}");
    let mut one_break = EquationErrorOptions::default();
    one_break.reconstruction.step_breaks = StepBreaks::NewValue;
    assert!(!misses(&one_break).is_empty(), "one break per ramp");
}
