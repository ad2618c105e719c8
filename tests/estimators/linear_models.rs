//! Linear state-space model structures (`kind = "linear"`): the
//! linearisation `aeroid linearise` writes against the nonlinear
//! simulator, output error on a noise-free linear flight, and filter error
//! against output error on flights with process noise.

use aeroid::analysis::linear_model::{Axes, linearise_scenario};
use aeroid::analysis::linearize::{self, ModeKind};
use aeroid::estimation::estimator::RefusalKind;
use aeroid::estimation::linear_structure::LinearStructure;
use aeroid::estimation::model::state_space::StateSpaceModel;
use aeroid::estimation::structure::Structure;
use aeroid::eval::linear_flight::record_flight;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::{Scenario, ScenarioFile};
use nalgebra::Complex;
use std::path::Path;

use crate::common;
/// A bundled scenario with its text edited.
fn scenario_with(name: &str, edit: impl Fn(String) -> String) -> Scenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenarios/{name}.toml"));
    let text = edit(std::fs::read_to_string(&path).unwrap());
    let file: ScenarioFile = toml::from_str(&text).unwrap();
    Scenario::from_file(&file, &path).unwrap()
}

fn estimate(
    method: &str,
    record: &aeroid::record::FlightRecord,
    model: &str,
) -> aeroid::estimation::Result<aeroid::estimation::estimate::Estimate> {
    let structure = Structure::load(model)?;
    let problem =
        crate::common::registry().problem(method, vec![record.clone()], structure, &[])?;
    crate::common::registry().estimate(&problem, None)
}

/// Output error on a noise-free flight of each bundled linear model
/// (recorded without error at 100 Hz, the flight's own step, so the fit's
/// exact discretisation is the flight's) recovers every parameter within
/// 1e-6 of max(|truth|, 1): what is left is the solver's stop (a step
/// under 0.014σ, and σ is at rounding level on noise-free data).
#[test]
fn output_error_recovers_a_noise_free_linear_flight() {
    let profile = Profile::load("ideal", None).unwrap();
    for name in ["linear-lateral-attas", "linear-short-period-attas"] {
        let scenario = scenario_with(name, |t| t.replace("process_noise", "# process_noise"));
        let (record, truth) = record_flight(&scenario, &profile, scenario.seed).unwrap();
        let estimate = estimate("oem", &record, name).unwrap();
        assert_eq!(estimate.parameters.len(), truth.parameters.len());
        for p in &estimate.parameters {
            let true_value = truth.parameters[&p.name];
            let error = (p.value - true_value).abs();
            assert!(
                error <= 1e-6 * true_value.abs().max(1.0),
                "{name}: {} = {} against {true_value}: error {error:.3e}",
                p.name,
                p.value
            );
        }
    }
}

/// The linear lateral flight with every change of its multisteps a 0.1 s
/// ramp, recorded without error (ideal profile, 100 Hz): its truth is the
/// model's own derivatives, flown with the ramps linear between the
/// simulator's steps (the model file's default `interpolation = "auto"`).
/// Every method that fits a linear model, with its default settings, finds
/// the ramps and is not `converged` while beyond 3σ and 1e-3 of the truth
/// (oem, fem, fdoe, ee and fdee converge, exact to rounding; the
/// augmented filters end unsettled, no noise to weigh)
/// (relative, with a floor of 1e-6: σ is at rounding level here). With the
/// model file's `interpolation = "zoh"` the same fit holds each ramp half a
/// sample late, and output error misses beyond both.
#[test]
fn linear_fits_follow_ramped_inputs_by_default() {
    use aeroid::estimation::input_timing::InputInterpolation;
    use aeroid::sim::integrator::Interpolation;
    let name = "linear-lateral-attas";
    let scenario = scenario_with(name, |text| {
        text.replace("process_noise", "# process_noise").replace(
            "\n[[inputs]]\nkind = \"multistep\"",
            "\n[[inputs]]\ntransition = \"0.1 s\"\nkind = \"multistep\"",
        )
    });
    let profile = Profile::load("ideal", None).unwrap();
    let (record, truth) = record_flight(&scenario, &profile, scenario.seed).unwrap();
    let misses = |estimate: &aeroid::estimation::estimate::Estimate| -> Vec<String> {
        estimate
            .parameters
            .iter()
            .filter_map(|p| {
                let t = truth.parameters.get(&p.name)?;
                let error = (p.value - t).abs();
                (error > 3.0 * p.standard_error && error > 1e-3 * t.abs().max(1e-3))
                    .then(|| format!("{} {:.6} against {t:.6}", p.name, p.value))
            })
            .collect()
    };
    for method in ["oem", "fem", "ekf", "ukf", "fdoe", "ee", "fdee"] {
        let estimate = estimate(method, &record, name).unwrap_or_else(|e| panic!("{method}: {e}"));
        assert!(
            estimate
                .parameters
                .iter()
                .any(|p| truth.parameters.contains_key(&p.name)),
            "{method}"
        );
        // Noise-free, the augmented filters end unsettled (their
        // innovations far below any noise they could weigh), and filter
        // error, on its exact sensitivities, lowers the likelihood from the
        // truth by 3.5 % (the noise it estimates goes to zero) until no step
        // lowers it: "no progress", at the truth all the same.
        use aeroid::estimation::estimate::Status;
        let converged = estimate.status == Status::Converged;
        let stalled = method == "fem" && estimate.status == Status::NoProgress;
        assert!(
            converged || stalled || ["ekf", "ukf"].contains(&method),
            "{method}: {}",
            estimate.status
        );
        if converged || stalled {
            let missed = misses(&estimate);
            assert!(missed.is_empty(), "{method}: {missed:#?}");
        }
        if ["oem", "fem", "ekf", "ukf"].contains(&method) {
            assert!(
                estimate
                    .notes
                    .iter()
                    .any(|n| n.contains("aileron linear (ramps")
                        && n.contains("rudder linear (ramps")),
                "{method}: {:?}",
                estimate.notes
            );
        }
    }
    let Structure::Linear(mut held) = Structure::load(name).unwrap() else {
        panic!("{name} is a linear model")
    };
    held.interpolation = InputInterpolation::from(Interpolation::ZeroOrderHold);
    let problem = crate::common::registry()
        .problem("oem", vec![record.clone()], *held, &[])
        .unwrap();
    let estimate = crate::common::registry().estimate(&problem, None).unwrap();
    assert!(!misses(&estimate).is_empty(), "held ramps");
}

/// The methods tied to the 6-DOF equations refuse a linear structure with
/// a typed refusal.
#[test]
fn six_dof_methods_refuse_a_linear_structure() {
    let scenario = Scenario::load("linear-short-period-attas").unwrap();
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    let (record, _) = record_flight(&scenario, &profile, 1).unwrap();
    for method in ["swr", "ebm"] {
        match estimate(method, &record, "linear-short-period-attas") {
            Err(aeroid::estimation::Error::Refused(refusal)) => {
                assert_eq!(
                    refusal.kind(),
                    RefusalKind::StructureKind,
                    "{method}: {refusal}"
                )
            }
            other => panic!("{method}: {other:?}"),
        }
    }
}

/// Per output: its name, the recorded channel, and the predicted (time,
/// value) pairs.
type Responses = Vec<(String, aeroid::record::Channel, Vec<(f64, f64)>)>;

/// The nonlinear simulator's recorded response to a doublet of `control`
/// (`amplitude` in degrees, ideal recorder, 100 Hz) and the response of
/// the linear model `aeroid linearise` writes for `axes`, driven by the
/// same recorded inputs: per output of the linear model, the recorded
/// channel and the predicted values on the model's grid.
fn doublet_responses(name: &str, axes: Axes, control: &str, amplitude: f64) -> Responses {
    let profile = Profile::load("ideal", None).unwrap();
    let doublet = format!(
        "[[inputs]]\nkind = \"doublet\"\ncontrol = \"{control}\"\nstart = \"1 s\"\npulse_width = \"1 s\"\namplitude = \"{amplitude} deg\"\n"
    );
    let scenario = scenario_with(name, |text| {
        let head = text.split("[[inputs]]").next().unwrap().to_string();
        head.replace("duration = \"60 s\"", "duration = \"12 s\"") + &doublet
    });
    let (record, _) = record_scenario(&scenario, &profile).unwrap();
    let file = linearise_scenario(&scenario, axes).unwrap();
    let structure = LinearStructure::from_file(&file, Path::new("linearised.toml")).unwrap();
    let (model, mut x) = structure.for_record(&record, None, None).unwrap();
    let theta = structure.parameter_values();
    let mut predicted = vec![Vec::new(); structure.outputs.len()];
    for k in 0..model.len() {
        if k > 0 {
            x = model.step(k - 1, x.as_slice(), theta.as_slice()).unwrap();
        }
        let y = model
            .outputs(model.time(k), x.as_slice(), theta.as_slice())
            .unwrap();
        for (o, column) in predicted.iter_mut().enumerate() {
            column.push((model.time(k), y[o]));
        }
    }
    structure
        .outputs
        .iter()
        .zip(predicted)
        .map(|(output, predicted)| {
            (
                output.clone(),
                record.channel(output).unwrap().clone(),
                predicted,
            )
        })
        .collect()
}

/// The response of the linear model `aeroid linearise` writes, driven by
/// the recorded inputs of a 1° doublet flown by the nonlinear simulator,
/// against the simulator's recorded response: within 1 % of each output's
/// largest excursion from its first value.
///
/// One output misses that by a hair, and the cause is the simulator's
/// second-order terms, not the linearisation: an elevator doublet moves
/// the airspeed by only 0.12 m/s, and the simulator's second-order terms
/// make 1.02 % of that at 1°, 0.51 % at 0.5° and 2.06 % at 2° — the error
/// grows with the amplitude, as a second-order term's share does. The odd part of
/// the response, (y(+1°) − y(−1°))/2, cancels every even-order term: the
/// linear model reproduces it within 0.05 % for every output, airspeed
/// included (measured: at most 0.02 % laterally, 0.003 % longitudinally,
/// airspeed 0.0025 %), which is what "the linearisation is right" means.
/// Asserted: the direct comparison within 1 % for every output but the
/// elevator-driven airspeed, that one within 1.1 % (the second-order share
/// measured above), and the odd part within 0.05 %.
#[test]
fn linearisation_reproduces_a_small_doublet() {
    let cases = [
        ("attas-lateral-multistep", Axes::Lateral, "aileron"),
        ("attas-lateral-multistep", Axes::Lateral, "rudder"),
        ("attas-elevator-3211", Axes::ShortPeriod, "elevator"),
        ("attas-elevator-3211", Axes::Longitudinal, "elevator"),
    ];
    for (name, axes, control) in cases {
        let positive = doublet_responses(name, axes, control, 1.0);
        let negative = doublet_responses(name, axes, control, -1.0);
        // The short-period approximation holds V and θ: it is compared over
        // the first 6 s only, before the phugoid moves them.
        let horizon = if axes == Axes::ShortPeriod { 6.0 } else { 12.0 };
        for ((output, channel, predicted), (_, mirrored, _)) in positive.iter().zip(&negative) {
            let (mut excursion, mut error, mut odd_error) = (0.0_f64, 0.0_f64, 0.0_f64);
            let first = predicted[0].1;
            for &(t, value) in predicted.iter().take_while(|(t, _)| *t <= horizon) {
                let measured = channel.value_at(t).unwrap();
                let odd = 0.5 * (measured - mirrored.value_at(t).unwrap());
                excursion = excursion.max((measured - channel.values[0]).abs());
                error = error.max((value - measured).abs());
                odd_error = odd_error.max((value - first - odd).abs());
            }
            // The short-period approximation (V and θ held) is good to a
            // few %: measured 0.7 % on α, 2.2 % on q; its odd part too.
            let (limit, odd_limit) = match (axes, output.as_str()) {
                (Axes::ShortPeriod, _) => (0.05, 0.05),
                (_, "airspeed") => (0.011, 0.0005),
                _ => (0.01, 0.0005),
            };
            println!(
                "{name} {} {control} {output}: error {:.3} %, odd part {:.4} % of the excursion {excursion:.4e}",
                axes.name(),
                100.0 * error / excursion,
                100.0 * odd_error / excursion
            );
            assert!(
                error <= limit * excursion,
                "{name} {} {control}: {output} off by {error:.3e}, excursion {excursion:.3e}",
                axes.name()
            );
            assert!(
                odd_error <= odd_limit * excursion,
                "{name} {} {control}: {output}'s odd part off by {odd_error:.3e}, excursion {excursion:.3e}",
                axes.name()
            );
        }
    }
}

/// The eigenvalues of the written lateral and longitudinal models are the
/// simulator's modes (tests/simulation/linear_modes.rs checks those against simulated
/// responses): the change of variables to V, α, β is a similarity and the
/// axes decouple at a symmetric trim, so they agree to 2e-6 rad/s (entries
/// below 1e-12 written as exact zeros; the lateral-longitudinal coupling
/// terms of the full model, ~1e-9, left out).
#[test]
fn linearisation_eigenvalues_are_the_simulators_modes() {
    let lateral = Scenario::load("attas-lateral-multistep").unwrap();
    let longitudinal = Scenario::load("attas-elevator-3211").unwrap();
    let simulation = aeroid::sim::Simulation::prepare(&lateral).unwrap();
    let modes =
        linearize::linearize(&simulation.model, &simulation.trim, &simulation.winds[0]).modes();
    let eigenvalues = |scenario: &Scenario, axes: Axes| -> Vec<Complex<f64>> {
        let file = linearise_scenario(scenario, axes).unwrap();
        let structure = LinearStructure::from_file(&file, Path::new("linearised.toml")).unwrap();
        structure
            .matrices
            .a
            .complex_eigenvalues()
            .iter()
            .copied()
            .collect()
    };
    let nearest = |values: &[Complex<f64>], target: Complex<f64>| {
        values
            .iter()
            .map(|v| (v - target).norm())
            .fold(f64::INFINITY, f64::min)
    };
    let lateral_values = eigenvalues(&lateral, Axes::Lateral);
    let longitudinal_values = eigenvalues(&longitudinal, Axes::Longitudinal);
    for (kind, values, tolerance) in [
        (ModeKind::DutchRoll, &lateral_values, 2e-6),
        (ModeKind::Roll, &lateral_values, 2e-6),
        (ModeKind::Spiral, &lateral_values, 2e-6),
        (ModeKind::ShortPeriod, &longitudinal_values, 2e-6),
        (ModeKind::Phugoid, &longitudinal_values, 2e-6),
    ] {
        let mode = linearize::find(&modes, kind).unwrap();
        let distance = nearest(values, mode.eigenvalue);
        println!(
            "{}: λ = {:.5}, distance {distance:.2e} rad/s",
            kind.name(),
            mode.eigenvalue
        );
        assert!(distance <= tolerance, "{}: {distance:.3e}", kind.name());
    }
}

/// Output error and filter error with the short-period model.
const SHORT_PERIOD: &[(&str, &str)] = &[
    ("oem", "linear-short-period-attas"),
    ("fem", "linear-short-period-attas"),
];

/// The `fits` (method, model) on the short-period flights `scenario(seed)`
/// for seeds 1..=`seeds` (flight-test-25hz), each fit converged; output
/// error's carry a coloured-residuals diagnosis (the process noise leaves
/// the noise-driven motion in its residuals, structured: methods.md, "Fit
/// quality") and are scored all the same, to show their bias: per method
/// and parameter, the sum of the errors in σ units, how many lie inside
/// the 95 % interval, and how many there are.
fn errors_in_sigma(
    seeds: u64,
    scenario: impl Fn(u64) -> Scenario,
    fits: &[(&'static str, &str)],
) -> std::collections::BTreeMap<(&'static str, String), (f64, usize, usize)> {
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    let mut sums: std::collections::BTreeMap<(&str, String), (f64, usize, usize)> =
        Default::default();
    for seed in 1..=seeds {
        let (record, truth) = record_flight(&scenario(seed), &profile, seed).unwrap();
        for &(method, model) in fits {
            let estimate = estimate(method, &record, model).unwrap();
            let coloured = !common::coloured_outputs(&estimate).is_empty();
            assert!(
                estimate.status == aeroid::estimation::estimate::Status::Converged
                    && coloured == (method == "oem"),
                "{method} on {model}, seed {seed}: {} {:?}",
                estimate.status,
                estimate.diagnoses
            );
            for p in &estimate.parameters {
                let error = (p.value - truth.parameters[&p.name]) / p.standard_error;
                let entry = sums.entry((method, p.name.clone())).or_default();
                entry.0 += error;
                entry.1 += usize::from(error.abs() <= 1.96);
                entry.2 += 1;
            }
        }
    }
    sums
}

/// The textbook result (Jategaonkar ch. 5): on flights with process noise
/// (the short-period model in white noise on α and q, 25 Hz flight-test
/// recorder), the filter error method's estimates scatter about the truth
/// within their Cramér–Rao bounds, while output error, which takes the
/// noise-driven motion for a response to the inputs, is biased. Over 20
/// process-noise seeds: the mean of each parameter's error in σ units
/// (mean over seeds of error/σ, whose own scatter is 1/√20 ≈ 0.22 for an
/// unbiased estimator with honest bounds). Measured: filter error's means
/// −0.10σ to −0.47σ, 114 of 120 estimates inside their 95 % interval;
/// output error's means 3.5σ to 5.9σ in size, 20 of 120 inside. The
/// assertions: every filter-error mean below 1σ and 85 % coverage; some
/// output-error mean beyond 3σ.
#[test]
fn filter_error_is_within_its_bounds_where_output_error_is_biased() {
    let sums = errors_in_sigma(
        20,
        |seed| {
            scenario_with("linear-short-period-attas", |t| {
                t.replace("seed = 4", &format!("seed = {seed}"))
            })
        },
        SHORT_PERIOD,
    );
    for ((method, name), (sum, inside, count)) in &sums {
        println!(
            "{method} {name}: mean error {:+.2}σ, {inside}/{count} inside 95 %",
            sum / *count as f64
        );
    }
    let (mut fem_inside, mut fem_count, mut oem_worst) = (0, 0, 0.0_f64);
    for ((method, _), (sum, inside, count)) in &sums {
        let mean = sum / *count as f64;
        match *method {
            "fem" => {
                fem_inside += inside;
                fem_count += count;
                assert!(mean.abs() < 1.0, "fem mean error {mean:.2}σ");
            }
            _ => oem_worst = oem_worst.max(mean.abs()),
        }
    }
    assert!(
        fem_inside as f64 >= 0.85 * fem_count as f64,
        "fem: {fem_inside}/{fem_count} inside"
    );
    assert!(
        oem_worst > 3.0,
        "output error is not shown biased: worst mean {oem_worst:.2}σ"
    );
}

/// A linear structure with every parameter's start value scaled by
/// `factor` (a linear model's start values are its flight's truth).
fn started_off(name: &str, factor: f64) -> LinearStructure {
    let structure = LinearStructure::load(name).unwrap();
    let mut file = structure.file.clone();
    for parameter in file.parameters.values_mut() {
        parameter.start *= factor;
    }
    LinearStructure::from_file(&file, &structure.path).unwrap()
}

/// The augmented-state EKF and UKF on the linear lateral model (16 free
/// derivatives as augmented states, the model's exact discretisation as
/// the state's step), the model file's values 20 % off every truth.
///
/// Noise-free (ideal recorder, 100 Hz, the flight's own grid), started
/// from those values (`start = "model"`: equation error is within 1e-4
/// of the truth here, so starting there would test little): the filter's
/// model is the truth's exactly, so the estimates reach the truth to
/// 1e-6 of max(|truth|, 1). The fit is converged (settled, identified),
/// and its innovations are diagnosed inconsistent with their covariance:
/// they are rounding, far below the floor R is held at (10⁻⁴ of each
/// channel's spread), not white noise of variance R (measured: 3.5e-14).
/// The UKF (square-root form) is held to the same 1e-6 and status:
/// measured 8.4e-8, 0.03σ. It is not the EKF's rounding
/// floor because the augmented model is bilinear (θ·x): the unscented
/// mean of a step carries the second-order term the EKF drops (for
/// E[θ·x] it is the cross-covariance P_θx), so on a noise-free record
/// the UKF's predictions at the truth differ from the record by a term of
/// the order of its covariance, and its estimates settle within a small
/// fraction of their σ of the truth, not at it.
///
/// Noisy (flight-test-25hz: 0.1° on β and φ, 0.002 rad/s on the rates,
/// 0.01° on the surfaces), equation error's start: converged (settled,
/// identified, innovations consistent) and every estimate within 4σ of
/// the truth (16 parameters at 4σ: a chance of 1e-3 that an honest
/// filter fails here).
#[test]
fn augmented_filters_serve_a_linear_structure() {
    let name = "linear-lateral-attas";
    let scenario = Scenario::load(name).unwrap();
    let structure = started_off(name, 1.2);
    let from_model: aeroid::estimation::estimator::MethodTables =
        toml::from_str("[ekf]\nstart = \"model\"\n[ukf]\nstart = \"model\"\n").unwrap();
    for (profile, noisy) in [("ideal", false), ("flight-test-25hz", true)] {
        let profile = Profile::load(profile, None).unwrap();
        let (record, truth) = record_flight(&scenario, &profile, scenario.seed).unwrap();
        for method in ["ekf", "ukf"] {
            let layers: Vec<&aeroid::estimation::estimator::MethodTables> =
                if noisy { vec![] } else { vec![&from_model] };
            let problem = crate::common::registry()
                .problem(method, vec![record.clone()], structure.clone(), &layers)
                .unwrap();
            let estimate = crate::common::registry().estimate(&problem, None).unwrap();
            assert_eq!(estimate.parameters.len(), 16);
            let (mut worst_error, mut worst_sigma) = (0.0_f64, 0.0_f64);
            for p in &estimate.parameters {
                let true_value = truth.parameters[&p.name];
                let error = (p.value - true_value).abs();
                worst_error = worst_error.max(error / true_value.abs().max(1.0));
                worst_sigma = worst_sigma.max(error / p.standard_error);
            }
            println!(
                "{method} on {}: {}; worst error {worst_error:.2e} of max(|truth|, 1), worst {worst_sigma:.2}σ\n{}",
                profile.name, estimate.status, estimate.details
            );
            if noisy {
                assert_eq!(
                    estimate.status,
                    aeroid::estimation::estimate::Status::Converged,
                    "{method}"
                );
                assert!(worst_sigma < 4.0, "{method}: {worst_sigma:.2}σ");
            } else {
                assert!(worst_error < 1e-6, "{method}: {worst_error:.3e}");
                assert_eq!(
                    estimate.status,
                    aeroid::estimation::estimate::Status::Converged,
                    "{method}"
                );
                let inconsistent =
                    aeroid::estimation::estimate::DiagnosisKind::InconsistentInnovations;
                assert!(
                    estimate.diagnosis(inconsistent).is_some(),
                    "{method}: {:?}",
                    estimate.diagnoses
                );
            }
        }
    }
}

/// Equation error on a linear structure, noise-free (ideal recorder,
/// 100 Hz): every state measured, ẋ by the differentiator with its
/// windows kept off the multisteps' control steps, or, for a model whose
/// rate outputs p_dot and r_dot are recorded, those. With ẋ recorded the
/// regressions are exact: the p and r equations within 1e-9 of
/// max(|truth|, 1) (rounding). With ẋ differentiated (every equation of
/// the plain model, β's of the other), the quartic differentiator's gain
/// error at the lateral modes (≤ 0.3 Hz: 2e-5 at 0.5 Hz) is what is
/// left: within 1e-3 of max(|truth|, 1) (measured 1.5e-6).
#[test]
fn equation_error_recovers_a_noise_free_linear_flight() {
    let name = "linear-lateral-attas";
    let scenario = Scenario::load(name).unwrap();
    let profile = Profile::load("ideal", None).unwrap();
    let plain = LinearStructure::load(name).unwrap();
    let mut file = plain.file.clone();
    file.rate_outputs = [("p_dot", "p"), ("r_dot", "r")]
        .into_iter()
        .map(|(o, s)| (o.to_string(), s.to_string()))
        .collect();
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("aeroid-linear-ee-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let rated_path = dir.join("linear-lateral-rates.toml");
    std::fs::write(&rated_path, toml::to_string(&file).unwrap()).unwrap();
    let rated = LinearStructure::from_file(&file, &rated_path).unwrap();
    // A scenario file beside the model names it by a relative path.
    let bundled = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenarios/{name}.toml"));
    let text = std::fs::read_to_string(&bundled).unwrap().replace(
        "[linear]\nmodel = \"linear-lateral-attas\"",
        "[linear]\nmodel = \"linear-lateral-rates.toml\"",
    );
    let scenario_path = dir.join("linear-lateral-rates-flight.toml");
    let rated_scenario =
        Scenario::from_file(&toml::from_str(&text).unwrap(), &scenario_path).unwrap();
    for (structure, scenario, recorded) in [(plain, scenario, 1e-3), (rated, rated_scenario, 1e-9)]
    {
        let (record, truth) = record_flight(&scenario, &profile, scenario.seed).unwrap();
        let problem = crate::common::registry()
            .problem("ee", vec![record], structure.clone(), &[])
            .unwrap();
        let estimate = crate::common::registry().estimate(&problem, None).unwrap();
        assert_eq!(
            estimate.status,
            aeroid::estimation::estimate::Status::Converged
        );
        assert_eq!(estimate.parameters.len(), 16);
        let mut worst = 0.0_f64;
        for p in &estimate.parameters {
            let true_value = truth.parameters[&p.name];
            let error = (p.value - true_value).abs() / true_value.abs().max(1.0);
            worst = worst.max(error);
            let differentiated = !(p.name.starts_with("A_p_")
                || p.name.starts_with("A_r_")
                || p.name.starts_with("B_p_")
                || p.name.starts_with("B_r_"));
            let tolerance = if differentiated { 1e-3 } else { recorded };
            assert!(
                error <= tolerance,
                "{}: {} = {} against {true_value}",
                structure.outputs.len(),
                p.name,
                p.value
            );
        }
        println!(
            "ee, {} outputs: worst error {worst:.2e} of max(|truth|, 1)",
            structure.outputs.len()
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Equation error on the noisy linear lateral flight (flight-test-25hz):
/// the measured states are its regressors, and their noise biases the
/// estimates (errors in variables), a bias the Cramér–Rao bound does not
/// hold. Predicted attenuation of a state's derivative by its noise:
/// σ_n²/(σ_x² + σ_n²), with 0.1° noise on β and φ against excursions of
/// some degrees, a few tenths of a per cent; the differentiated noise in
/// ẋ makes the scatter (the coloured-residual σ) much larger than that.
/// Measured on the flight's seed: every estimate within 1.5σ (worst
/// A_beta_roll −1.43σ), relative errors up to 9 % on the weakly excited
/// entries (B_beta_aileron, truth 0.0014, is +0.75σ and 10 times its
/// truth). Asserted: every estimate within 3σ (16 parameters).
#[test]
fn equation_error_on_a_noisy_linear_flight_shows_errors_in_variables() {
    let name = "linear-lateral-attas";
    let scenario = Scenario::load(name).unwrap();
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    let (record, truth) = record_flight(&scenario, &profile, scenario.seed).unwrap();
    let estimate = estimate("ee", &record, name).unwrap();
    for p in &estimate.parameters {
        let true_value = truth.parameters[&p.name];
        println!(
            "{}: {:.5} ± {:.2e} (truth {true_value:.5}, {:+.2} %, {:+.2} σ)",
            p.name,
            p.value,
            p.standard_error,
            100.0 * (p.value - true_value) / true_value,
            (p.value - true_value) / p.standard_error
        );
        assert!(
            (p.value - true_value).abs() <= 3.0 * p.standard_error,
            "{}",
            p.name
        );
    }
}

/// The short-period flight in moderate Dryden turbulence instead of white
/// process noise: the vertical gust w_g enters as an angle of attack
/// w_g/V, G = (A_αα, A_qα)ᵀ/V in the w_g column (V = 103 m/s).
fn gusty_short_period(seed: u64, duration: &str) -> Scenario {
    scenario_with("linear-short-period-attas", |t| {
        t.replace("seed = 4", &format!("seed = {seed}"))
            .replace("duration = \"30 s\"", &format!("duration = \"{duration}\""))
            .replace(
                "process_noise = { alpha = 0.004, q = 0.01 }",
                "gusts = { matrix = [[0.0, 0.0, -0.004559], [0.0, 0.0, -0.005410]], intensity = \"moderate\" }",
            )
    })
}

/// The gusts entering a linear flight have the Dryden shape: over 10
/// seeds of 600 s (100 Hz), w_g's variance is σ_w² and its
/// autocorrelation at the lag L_w/V is the Dryden form's
/// σ_w²·(1 − ½)·e⁻¹ = 0.184·σ_w² (MIL-F-8785C: R(τ) = σ²(1 − τV/2L)e^{−τV/L}),
/// each within 4 standard errors of the seeds' mean (the Monte Carlo
/// scatter of the per-seed estimates: correlation time L/V ≈ 5 s, about 60
/// independent stretches a flight).
#[test]
fn linear_flight_gusts_have_the_dryden_shape() {
    let seeds = 10;
    let (mut variances, mut correlations) = (Vec::new(), Vec::new());
    let mut expected = None;
    for seed in 1..=seeds {
        let scenario = gusty_short_period(seed, "600 s");
        let linear = scenario.linear.as_ref().unwrap();
        let spec = &linear.gusts.as_ref().unwrap().turbulence;
        let parameters = spec.parameters(scenario.trim.altitude).unwrap();
        let (sigma, length) = (parameters.sigma[2], parameters.length[2]);
        let lag = (length / scenario.trim.airspeed / scenario.step).round() as usize;
        expected = Some((sigma, lag));
        let trace = aeroid::eval::linear_flight::fly(&scenario, linear).unwrap();
        let w: Vec<f64> = trace.gusts.iter().map(|g| g[2]).collect();
        let n = w.len();
        variances.push(w.iter().map(|v| v * v).sum::<f64>() / n as f64 / (sigma * sigma));
        correlations.push(
            (0..n - lag).map(|k| w[k] * w[k + lag]).sum::<f64>()
                / (n - lag) as f64
                / (sigma * sigma),
        );
    }
    let (sigma, lag) = expected.unwrap();
    let mean_and_error = |values: &[f64]| {
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let spread = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>()
            / (values.len() - 1) as f64)
            .sqrt();
        (mean, spread / (values.len() as f64).sqrt())
    };
    let (variance, variance_error) = mean_and_error(&variances);
    let (correlation, correlation_error) = mean_and_error(&correlations);
    let dryden = 0.5 * (-1.0_f64).exp();
    println!(
        "σ_w {sigma:.3} m/s, lag {lag} steps: variance/σ² {variance:.3} ± {variance_error:.3}, R(L/V)/σ² {correlation:.3} ± {correlation_error:.3} (Dryden {dryden:.3})"
    );
    assert!((variance - 1.0).abs() <= 4.0 * variance_error, "{variance}");
    assert!(
        (correlation - dryden).abs() <= 4.0 * correlation_error,
        "{correlation}"
    );
}

/// Filter error against output error on the gusty short-period flight
/// (moderate Dryden turbulence, σ_w 2.4 m/s, α moved by about 1.3°;
/// flight-test-25hz, 10 seeds): the mean over seeds of each parameter's
/// error in σ units (its scatter 1/√10 ≈ 0.32 for an unbiased estimator
/// with honest bounds) and the share inside the 95 % interval.
///
/// Measured: output error is biased, means +2.1σ to +10.3σ in size
/// (B_alpha_elevator −1.7σ), 5 of 60 inside. Filter error is better but
/// NOT within its bounds: means +2.1σ to +4.2σ, 21 of 60 inside. Its
/// model's process noise is white, while the Dryden gust is coloured
/// (correlation time L_w/V ≈ 5 s, longer than the short period's ≈ 1.9 s
/// time constant): the innovations of its steady-state filter are
/// correlated and its likelihood is not the data's. (With white process
/// noise it is within its bounds:
/// `filter_error_is_within_its_bounds_where_output_error_is_biased`.)
/// Asserted, the finding: output error's worst mean bias at least twice
/// filter error's, and filter error's coverage below 85 %.
#[test]
fn filter_error_on_a_gusty_linear_flight() {
    let sums = errors_in_sigma(10, |seed| gusty_short_period(seed, "30 s"), SHORT_PERIOD);
    let (mut worst, mut covered) = (
        std::collections::BTreeMap::<&str, f64>::new(),
        std::collections::BTreeMap::<&str, (usize, usize)>::new(),
    );
    for ((method, name), (sum, inside, count)) in &sums {
        let mean = sum / *count as f64;
        println!("{method} {name}: mean error {mean:+.2}σ, {inside}/{count} inside 95 %");
        let entry = worst.entry(method).or_default();
        *entry = entry.max(mean.abs());
        let coverage = covered.entry(method).or_default();
        coverage.0 += inside;
        coverage.1 += count;
    }
    assert!(
        worst["oem"] >= 2.0 * worst["fem"],
        "output error {:.2}σ, filter error {:.2}σ",
        worst["oem"],
        worst["fem"]
    );
    let (inside, count) = covered["fem"];
    assert!(
        (inside as f64) < 0.85 * count as f64,
        "filter error inside its bounds on the gusts: {inside}/{count}"
    );
}

/// Filter error on the same gusty flights with the gust's forming filter
/// in the model (`linear-short-period-attas-dryden`: the Dryden w filter
/// as two states driven by white noise, F on the second estimated, the
/// gust entering α and q through the flight's matrix): the process noise
/// the filter assumes is now the one that drives the flight, so its
/// likelihood is the data's. Over 20 seeds the mean error of each
/// parameter in σ units scatters by 1/√20 ≈ 0.22 for an unbiased
/// estimator with honest bounds, and 95 % of the 120 estimates should lie
/// inside their 95 % interval (binomial: 114 ± 2.4).
///
/// Measured with the full R (the default): means −0.37σ to +0.24σ, 109 of
/// 120 inside; with a diagonal R −0.39σ to +0.25σ, 106 of 120 (over 60
/// seeds: −0.05σ… +0.33σ, 324 of 360). Unbiased, but with the diagonal R
/// the bounds of the two parameters of A's α column are optimistic: the RMS of error/σ over 40
/// seeds is 1.72 for A_alpha_alpha and A_q_alpha (0.94–1.05 for the
/// others), 1.39 on 300-s flights, and F comes out at 1.70–1.81 ± 0.18
/// against the gust's 2·√λ·σ_w = 2.11. The steady-state filter starts the
/// unmeasured gust states at zero while the flight's gust starts from its
/// stationary spread (σ_w, 1.3° of α), a transient the likelihood does not
/// model; that it shrinks with the record's length fits this (the
/// time-varying gain takes most of it away:
/// `time_varying_filter_error_starts_the_gust_states_unknown`).
/// Asserted: every mean within 3/√20 ≈ 0.67σ and at least 85 % inside,
/// the bounds of `filter_error_is_within_its_bounds_where_output_error_is_biased`.
#[test]
fn filter_error_with_the_gust_filter_is_within_its_bounds() {
    let sums = errors_in_sigma(
        20,
        |seed| gusty_short_period(seed, "30 s"),
        &[("fem", "linear-short-period-attas-dryden")],
    );
    let (mut inside_all, mut count_all) = (0, 0);
    for ((method, name), (sum, inside, count)) in &sums {
        let mean = sum / *count as f64;
        println!("{method} {name}: mean error {mean:+.2}σ, {inside}/{count} inside 95 %");
        assert!(mean.abs() <= 3.0 / 20f64.sqrt(), "{name}: mean {mean:+.2}σ");
        inside_all += inside;
        count_all += count;
    }
    assert_eq!(count_all, 120);
    assert!(
        inside_all as f64 >= 0.85 * count_all as f64,
        "{inside_all}/{count_all} inside"
    );
}

/// The time-varying filter error (`gain = "time_varying"`) on the gusty
/// flights of `filter_error_with_the_gust_filter_is_within_its_bounds`
/// (20 seeds, 30 s), with the Dryden filter's states started unknown: P0
/// of z1 and z2 their stationary covariance σ_w²·I (the forming filter
/// z' = λ·[[0, 1], [−1, −2]]·z + (0, 2·√λ·σ_w)ᵀ·n has the Lyapunov
/// solution σ_w²·I in these coordinates), σ_w the moderate intensity at
/// the flight's altitude. The steady-state filter starts the gust states
/// at zero, a transient its likelihood does not model, and the bounds of
/// the α column of A are optimistic. Per parameter the RMS over seeds of
/// error/σ, 1 for honest bounds (its scatter about 1/√40 ≈ 0.16 when the
/// errors are Gaussian), for both gains on the same flights.
///
/// Measured (20 seeds): A_alpha_alpha and A_q_alpha 1.78 steady, 1.29
/// time-varying; the other four 0.97–1.03 and 0.91–0.94; F on z2 (its
/// truth 2·√λ·σ_w = 2.11) 1.89 steady, 2.00 time-varying on average.
/// Over 40 seeds 1.72 → 1.28; on 300-s flights (20 seeds) 1.39 → 1.21.
/// The time-varying filter takes the larger part of the excess away; the
/// rest does not shrink with the record's length, so it is not the
/// start's transient (nor the covariance term of the information matrix:
/// without it the bounds are the same to 0.01).
/// Asserted: every fit converged; for both α-column entries the
/// time-varying RMS at most 1.45 and at least 0.3 below the steady one;
/// the other entries' RMS within 0.7–1.3 with either gain; every
/// time-varying mean error within 3/√20 ≈ 0.67σ.
#[test]
fn time_varying_filter_error_starts_the_gust_states_unknown() {
    let seeds = 20;
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    let scenario = gusty_short_period(1, "30 s");
    let linear = scenario.linear.as_ref().unwrap();
    let spec = &linear.gusts.as_ref().unwrap().turbulence;
    let sigma_w = spec.parameters(scenario.trim.altitude).unwrap().sigma[2];
    let variance = sigma_w * sigma_w;
    let time_varying: toml::Table = toml::from_str(&format!(
        "gain = \"time_varying\"\ninitial_variance = {{ z1 = {variance}, z2 = {variance} }}"
    ))
    .unwrap();
    let layers: aeroid::estimation::estimator::MethodTables =
        [("fem".to_string(), time_varying)].into_iter().collect();
    let model = "linear-short-period-attas-dryden";
    let mut squares: std::collections::BTreeMap<(bool, String), (f64, f64, usize)> =
        Default::default();
    for seed in 1..=seeds {
        let (record, truth) =
            record_flight(&gusty_short_period(seed, "30 s"), &profile, seed).unwrap();
        for varying in [false, true] {
            let structure = Structure::load(model).unwrap();
            let chosen: Vec<&aeroid::estimation::estimator::MethodTables> =
                if varying { vec![&layers] } else { vec![] };
            let problem = crate::common::registry()
                .problem("fem", vec![record.clone()], structure, &chosen)
                .unwrap();
            let estimate = crate::common::registry().estimate(&problem, None).unwrap();
            assert_eq!(
                estimate.status,
                aeroid::estimation::estimate::Status::Converged,
                "time-varying {varying}, seed {seed}: {:?}",
                estimate.notes
            );
            let f: f64 = estimate
                .details
                .lines()
                .find_map(|line| line.trim().strip_prefix("F.z2 = "))
                .and_then(|rest| rest.split(' ').next())
                .and_then(|value| value.parse().ok())
                .unwrap();
            let entry = squares.entry((varying, "F.z2".to_string())).or_default();
            entry.1 += f;
            entry.2 += 1;
            for p in &estimate.parameters {
                let error = (p.value - truth.parameters[&p.name]) / p.standard_error;
                let entry = squares.entry((varying, p.name.clone())).or_default();
                entry.0 += error * error;
                entry.1 += error;
                entry.2 += 1;
            }
        }
    }
    let rms = |varying: bool, name: &str| {
        let (square, _, count) = squares[&(varying, name.to_string())];
        (square / count as f64).sqrt()
    };
    for ((varying, name), (square, sum, count)) in &squares {
        let gain = if *varying { "time-varying" } else { "steady" };
        let mean = sum / *count as f64;
        if name.starts_with("F.") {
            println!("{gain} {name}: mean {mean:.3}");
        } else {
            let rms = (square / *count as f64).sqrt();
            println!("{gain} {name}: RMS error/σ {rms:.2}, mean error {mean:+.2}σ");
        }
    }
    for ((varying, name), (_, sum, count)) in &squares {
        if name.starts_with("F.") {
            continue;
        }
        if ["A_alpha_alpha", "A_q_alpha"].contains(&name.as_str()) {
            if *varying {
                let (steady, varying) = (rms(false, name), rms(true, name));
                assert!(
                    varying <= 1.45 && varying <= steady - 0.3,
                    "{name}: RMS error/σ {varying:.2} time-varying, {steady:.2} steady"
                );
            }
        } else {
            let value = rms(*varying, name);
            assert!(
                (0.7..=1.3).contains(&value),
                "{name}: RMS error/σ {value:.2}"
            );
        }
        if *varying {
            let mean = sum / *count as f64;
            assert!(mean.abs() <= 3.0 / 20f64.sqrt(), "{name}: mean {mean:+.2}σ");
        }
    }
}

/// A gust matrix that does not fit the model's states, a row of the wrong
/// length and a misspelt key are errors naming the key.
#[test]
fn bad_gust_tables_name_the_key() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/linear-short-period-attas.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let with = |gusts: &str| {
        text.replace(
            "process_noise = { alpha = 0.004, q = 0.01 }",
            &format!("gusts = {gusts}"),
        )
    };
    let rows = with("{ matrix = [[0.0, 0.0, 1.0]], intensity = \"moderate\" }");
    let scenario = Scenario::from_file(&toml::from_str(&rows).unwrap(), &path).unwrap();
    let error = aeroid::eval::linear_flight::fly(&scenario, scenario.linear.as_ref().unwrap())
        .unwrap_err()
        .to_string();
    assert!(error.contains("linear.gusts.matrix"), "{error}");
    let short = with("{ matrix = [[0.0, 1.0], [0.0, 0.0, 1.0]], intensity = \"moderate\" }");
    let error = Scenario::from_file(&toml::from_str(&short).unwrap(), &path)
        .unwrap_err()
        .to_string();
    assert!(error.contains("linear.gusts.matrix[0]"), "{error}");
    let misspelt = with("{ matrix = [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]], intensty = \"moderate\" }");
    let parsed = toml::from_str::<ScenarioFile>(&misspelt)
        .map_err(|e| e.to_string())
        .and_then(|file| Scenario::from_file(&file, &path).map_err(|e| e.to_string()));
    let error = parsed.unwrap_err();
    assert!(error.contains("intensty"), "{error}");
}

/// The augmented EKF's noise tuning on the short-period flights with known
/// white process noise (F = diag(0.004, 0.01) on α and q: intensities
/// 1.6e-5 and 1e-4 per s), flight-test-25hz, seeds 1–10, default passes
/// (4): the process-noise intensity the passes end with, by zero-lag
/// covariance matching (`correlation_lags = 0`) and by Mehra's method
/// with lags 1 … 5 (`correlation_lags = 5`; the default is lags 1 … n, n
/// the integrated states).
///
/// Measured: Mehra's mean over the seeds 1.77e-5 on α (+10 %) and 8.5e-5
/// on q (−15 %), single seeds 6.8e-6 … 6.8e-5 and 6.3e-5 … 1.2e-4; the
/// zero-lag matching ends at 1.9e-8 and 1.1e-8, three to four orders of
/// magnitude low (the innovations' excess over their predicted variance
/// at lag 0 is small where the gain already follows the data). With the
/// tuned Q the filter leans less on the model: A_q_q and B_alpha_elevator
/// end unidentified (σ not below σ₀/√2) on most seeds.
/// Asserted: Mehra's means within 25 % of the truth; zero lag's below 1 %
/// of it.
#[test]
fn ekf_residual_correlation_tunes_the_process_noise() {
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    let truth = [0.004_f64.powi(2), 0.01_f64.powi(2)];
    let mut sums = [[0.0; 2]; 2];
    let mut report = String::new();
    let seeds = 10;
    for seed in 1..=seeds {
        let scenario = scenario_with("linear-short-period-attas", |t| {
            t.replace("seed = 4", &format!("seed = {seed}"))
        });
        let (record, _) = record_flight(&scenario, &profile, seed).unwrap();
        for (variant, lags) in [0, 5].into_iter().enumerate() {
            let layer: aeroid::estimation::estimator::MethodTables =
                toml::from_str(&format!("[ekf]\ncorrelation_lags = {lags}\n")).unwrap();
            let structure = Structure::load("linear-short-period-attas").unwrap();
            let problem = crate::common::registry()
                .problem("ekf", vec![record.clone()], structure, &[&layer])
                .unwrap();
            let estimate = crate::common::registry().estimate(&problem, None).unwrap();
            let note = estimate
                .notes
                .iter()
                .find(|n| n.starts_with("final noise"))
                .unwrap();
            let values: Vec<f64> = note
                .rsplit("alpha, q ")
                .next()
                .unwrap()
                .split(", ")
                .map(|v| v.parse().unwrap())
                .collect();
            report.push_str(&format!(
                "seed {seed} lags {lags}: {values:?} {}\n",
                estimate.status
            ));
            for i in 0..2 {
                sums[variant][i] += values[i] / seeds as f64;
            }
        }
    }
    println!(
        "{report}truth {truth:?}\nzero lag mean {:?}\nMehra mean {:?}",
        sums[0], sums[1]
    );
    for i in 0..2 {
        assert!(
            (sums[1][i] - truth[i]).abs() <= 0.25 * truth[i],
            "Mehra {i}: {} against {}",
            sums[1][i],
            truth[i]
        );
        assert!(sums[0][i] < 0.01 * truth[i], "zero lag {i}: {}", sums[0][i]);
    }
}

/// Settings a linear structure does not take are refused naming the key,
/// never silently unused: output error's 6-DOF settings (several starts,
/// the start, the inputs' interpolation, coloured-residual and input-noise
/// bounds), filter error's `start` and `interpolation`, and the augmented
/// filters' `interpolation` (a linear model states it in its file).
#[test]
fn linear_models_refuse_the_settings_they_do_not_take() {
    let name = "linear-short-period-attas";
    let scenario = scenario_with(name, |t| t);
    let profile = Profile::load("ideal", None).unwrap();
    let (record, _) = record_flight(&scenario, &profile, scenario.seed).unwrap();
    for (method, table, key) in [
        ("oem", "starts = 3", "starts"),
        ("oem", "start = \"ee\"", "start"),
        ("oem", "interpolation = \"linear\"", "interpolation"),
        (
            "oem",
            "input_noise = { elevator = \"0.01 deg\" }",
            "input_noise",
        ),
        ("oem", "correlation_lag = \"1 s\"", "correlation_lag"),
        ("fem", "start = \"ee\"", "start"),
        ("fem", "interpolation = \"linear\"", "interpolation"),
        ("ekf", "interpolation = \"linear\"", "interpolation"),
        ("ukf", "interpolation = \"linear\"", "interpolation"),
    ] {
        let layer: aeroid::estimation::estimator::MethodTables =
            toml::from_str(&format!("[{method}]\n{table}\n")).unwrap();
        let error = crate::common::registry()
            .problem(
                method,
                vec![record.clone()],
                Structure::load(name).unwrap(),
                &[&layer],
            )
            .and_then(|problem| crate::common::registry().estimate(&problem, None))
            .unwrap_err()
            .to_string();
        assert!(
            error.contains(&format!("not for the linear model '{name}': {key} (")),
            "{method} {table}: {error}"
        );
    }
}

/// The unstable short period (`linear-short-period-unstable`: M_α > 0,
/// a divergence λ = +0.500/s, flown closed loop by a pitch augmentation)
/// recorded by `profile` with the recorder's seed `seed`.
fn unstable_flight(
    profile: &str,
    seed: u64,
) -> (aeroid::record::FlightRecord, aeroid::sim::truth::RunTruth) {
    let scenario = Scenario::load("linear-short-period-unstable").unwrap();
    let profile = Profile::load(profile, None).unwrap();
    record_flight(&scenario, &profile, seed).unwrap()
}

/// The truth model's time to double, ln 2 / Re λ of its divergence.
fn truth_doubling() -> f64 {
    let structure = LinearStructure::load("linear-short-period-unstable").unwrap();
    let lambda = structure
        .matrices
        .a
        .complex_eigenvalues()
        .iter()
        .map(|l| l.re)
        .fold(f64::NEG_INFINITY, f64::max);
    std::f64::consts::LN_2 / lambda
}

fn oem_with(
    record: &aeroid::record::FlightRecord,
    table: &str,
) -> aeroid::estimation::estimate::Estimate {
    let layer: aeroid::estimation::estimator::MethodTables =
        toml::from_str(&format!("[oem]\n{table}\n")).unwrap();
    let problem = crate::common::registry()
        .problem(
            "oem",
            vec![record.clone()],
            Structure::load("linear-short-period-unstable").unwrap(),
            &[&layer],
        )
        .unwrap();
    crate::common::registry().estimate(&problem, None).unwrap()
}

/// The flight is closed loop: on the ideal record the elevator at each
/// 40 ms frame's start is the pilot's 3211 and doublet plus 2.5·α + 1.0·q
/// of that instant (to rounding), and the motion stays bounded (|α| under
/// 5°) though the open loop doubles in 1.39 s.
#[test]
fn the_unstable_short_period_is_flown_closed_loop() {
    let (record, _) = unstable_flight("ideal", 1);
    let scenario = Scenario::load("linear-short-period-unstable").unwrap();
    let channel = |name: &str| record.channel(name).unwrap();
    let (alpha, q, elevator) = (channel("alpha"), channel("q"), channel("elevator"));
    let mut checked = 0;
    for (k, &t) in elevator.times.iter().enumerate() {
        let frame = (t / 0.04).round();
        if (t - frame * 0.04).abs() > 1e-9 {
            continue;
        }
        let pilot = scenario.inputs.deviation(t)[0];
        let command = pilot + 2.5 * alpha.values[k] + 1.0 * q.values[k];
        assert!(
            (elevator.values[k] - command).abs() < 1e-12,
            "t = {t}: elevator {} against {command}",
            elevator.values[k]
        );
        checked += 1;
    }
    assert_eq!(checked, 501);
    let largest = alpha.values.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    assert!(
        largest < 5f64.to_radians() && largest > 0.2f64.to_radians(),
        "{largest}"
    );
    assert!(
        (truth_doubling() - 1.386).abs() < 1e-3,
        "{}",
        truth_doubling()
    );
}

/// Plain output error on the unstable short period (flight-test-25hz,
/// recorder seed 1) simulates the open-loop model over the whole 20-s
/// record from its first samples: its divergence (time to double 1.39 s)
/// takes any error of the initial state or inputs through 2^14 and the
/// fit fails: measured on seed 1, the iteration limit with A_alpha_alpha
/// at +3.49 for −0.47 (24.6σ). The fitted model's modes name the
/// instability: `unstable`, about the short period's divergence, its time
/// to double 1.427 s, within 10 % of the truth model's 1.386 s, advising
/// `segment`. (Over recorder seeds 1–8 the plain fit ends at the iteration
/// limit on seven, up to 26σ off, and converges 2.3σ off on one; its time
/// to double, a wrong model's, lies between 1.11 and 1.61 s; every one is
/// diagnosed `unstable`.)
#[test]
fn plain_output_error_on_an_unstable_aircraft_is_diagnosed_unstable() {
    let (record, truth) = unstable_flight("flight-test-25hz", 1);
    let plain = oem_with(&record, "");
    let worst = plain
        .parameters
        .iter()
        .map(|p| ((p.value - truth.parameters[&p.name]) / p.standard_error).abs())
        .fold(0.0, f64::max);
    assert!(
        plain.status != aeroid::estimation::estimate::Status::Converged || worst > 4.0,
        "plain output error did not fail: {} {worst:.2}σ",
        plain.status
    );
    let unstable = plain
        .diagnosis(aeroid::estimation::estimate::DiagnosisKind::Unstable)
        .unwrap_or_else(|| panic!("no instability named: {:?}", plain.diagnoses));
    assert!(
        unstable.about[0].starts_with("short period λ = +"),
        "{unstable}"
    );
    let doubling = unstable.measures[0];
    assert!(
        (doubling / truth_doubling() - 1.0).abs() < 0.1,
        "time to double {doubling} against {}",
        truth_doubling()
    );
    assert!(unstable.advice.contains("segment = \""), "{unstable}");
}

/// Stabilised output error (multiple shooting, `segment = "1 s"`: 20
/// pieces, each from its own estimated initial state, each shorter than
/// the time to double) on the same flight: every parameter within 2σ of
/// the truth (flight-test-25hz, recorder seed 1: measured within 1.08σ,
/// and within 1.98σ on each of seeds 1–8), within 1e-4 relative on the
/// ideal record (measured 4e-15), converged, and no instability diagnosed
/// (the divergence doubles in 1.39 s, longer than a piece; with
/// `segment = "2 s"` the fits are as good and diagnosed `unstable`).
#[test]
fn stabilised_output_error_recovers_an_unstable_aircraft() {
    for (profile, seed) in [("ideal", 1), ("flight-test-25hz", 1)] {
        let (record, truth) = unstable_flight(profile, seed);
        let shot = oem_with(&record, "segment = \"1 s\"");
        assert_eq!(
            shot.status,
            aeroid::estimation::estimate::Status::Converged,
            "{profile}: {:?}",
            shot.notes
        );
        assert!(
            shot.notes
                .iter()
                .any(|n| n.starts_with("multiple shooting: 20 pieces of about 1 s")),
            "{:?}",
            shot.notes
        );
        assert!(
            shot.diagnosis(aeroid::estimation::estimate::DiagnosisKind::Unstable)
                .is_none(),
            "{:?}",
            shot.diagnoses
        );
        for (name, &true_value) in &truth.parameters {
            let p = shot.parameter(name).unwrap();
            let error = p.value - true_value;
            if profile == "ideal" {
                assert!((error / true_value).abs() < 1e-4, "{name}: {}", p.value);
            } else {
                assert!(error.abs() < 2.0 * p.standard_error, "{name}: {}", p.value);
            }
        }
    }
}

/// A feedback table whose control is not a model input, whose gain names
/// no state, or whose frame is not a multiple of the step is an error
/// naming the key.
#[test]
fn bad_feedback_tables_name_the_key() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/linear-short-period-unstable.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let load = |from: &str, to: &str| {
        let edited = text.replace(from, to);
        assert_ne!(edited, text);
        Scenario::from_file(&toml::from_str(&edited).unwrap(), &path)
    };
    let fly = |scenario: Scenario| {
        aeroid::eval::linear_flight::fly(&scenario, scenario.linear.as_ref().unwrap())
            .unwrap_err()
            .to_string()
    };
    let error = fly(load("control = \"elevator\"", "control = \"aileron\"").unwrap());
    assert!(error.contains("linear.feedback.control"), "{error}");
    let error = fly(load("alpha = 2.5", "beta = 2.5").unwrap());
    assert!(error.contains("linear.feedback.gains.beta"), "{error}");
    let error = load("frame = \"0.04 s\"", "frame = \"0.015 s\"")
        .unwrap_err()
        .to_string();
    assert!(error.contains("linear.feedback.frame"), "{error}");
}
