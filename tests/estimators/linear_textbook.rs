//! Linear models as textbooks write them: a parameter in several entries
//! (the short period's Z_w and Z_δe in A and B and in a_z's row of C and
//! D), initial states from the model file or estimated, several records in
//! one output-error fit, and output biases beside the states' biases.
//!
//! The flights are a linear model's own (`aeroid_eval::linear_flight::fly`,
//! 100 Hz, the model's exact discretisation), recorded here channel by
//! channel so that the states, inputs and outputs may carry any names.

use aeroid::estimation::estimate::{Estimate, Status};
use aeroid::estimation::estimator::RefusalKind;
use aeroid::estimation::linear_structure::{LinearFile, LinearStructure};
use aeroid::record::{Channel, FlightRecord};
use aeroid::sim::scenario::{Scenario, ScenarioFile};
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;
use std::collections::BTreeMap;
use std::path::Path;

use crate::common;

/// The textbook short period in w and q (Jategaonkar ch. 9, McRuer):
/// ẇ = Z_w·w + U₀·q + Z_δe·δe, q̇ = M_w·w + M_q·q + M_δe·δe, and the
/// vertical acceleration a_z = ẇ − U₀·q = Z_w·w + Z_δe·δe: Z_w and Z_δe
/// are entries of A and B and of a_z's row of C and D. U₀ = 100 m/s;
/// stable (ω = 2.6 rad/s, ζ = 0.52). `STATES` is replaced by the
/// states' names, `EXTRA` by more keys.
const SHORT_PERIOD: &str = r#"
kind = "linear"
name = "textbook-short-period"
states = STATES
inputs = ["elevator"]
outputs = ["w", "q", "a_z"]
A = [["Zw", 100.0], ["Mw", "Mq"]]
B = [["Zde"], ["Mde"]]
C = [[1, 0], [0, 1], ["Zw", 0]]
D = [[0], [0], ["Zde"]]
EXTRA
[parameters.Zw]
start = -1.2
[parameters.Mw]
start = -0.05
[parameters.Mq]
start = -1.5
[parameters.Zde]
start = -10.0
[parameters.Mde]
start = -8.0
"#;

/// The short period with states named `states` and `extra` keys.
fn short_period(states: &str, extra: &str) -> String {
    SHORT_PERIOD
        .replace("STATES", states)
        .replace("EXTRA", extra)
}

/// `text` as a linear structure (written to `folder` as `name`), every
/// parameter's start value multiplied by `factor` (the file's values are
/// the flight's truth).
fn structure(folder: &Path, name: &str, text: &str, factor: f64) -> LinearStructure {
    let path = common::write(folder, name, text);
    let mut file: LinearFile = toml::from_str(text).unwrap();
    for parameter in file.parameters.values_mut() {
        parameter.start *= factor;
    }
    LinearStructure::from_file(&file, &path).unwrap()
}

/// A flight of the model file `model` (30 s at 100 Hz, no process noise)
/// driven by the elevator `inputs` (scenario `[[inputs]]` tables): the
/// bundled short-period scenario's settings.
fn scenario(model: &Path, inputs: &str) -> Scenario {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/linear-short-period-attas.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let head = text.split("[[inputs]]").next().unwrap().to_string();
    let name = model.file_name().unwrap().to_string_lossy();
    let edited = head
        .replace(
            "model = \"linear-short-period-attas\"",
            &format!("model = {name:?}"),
        )
        .replace("process_noise = { alpha = 0.004, q = 0.01 }", "")
        + inputs;
    let file: ScenarioFile = toml::from_str(&edited).unwrap();
    // Beside the model file, which it names by a relative path.
    Scenario::from_file(&file, &model.with_file_name("scenario.toml")).unwrap()
}

const THREE_TWO_ONE_ONE: &str = "[[inputs]]\nkind = \"3211\"\ncontrol = \"elevator\"\nstart = \"3 s\"\nunit_time = \"0.8 s\"\namplitude = \"-1.5 deg\"\n";
const DOUBLET: &str = "[[inputs]]\nkind = \"doublet\"\ncontrol = \"elevator\"\nstart = \"5 s\"\npulse_width = \"1 s\"\namplitude = \"2 deg\"\n";

/// The flight's channels `keep`, on its grid (an output's signal where a
/// state has its name); each with white noise of `noise` times its own
/// standard deviation (drawn from `seed`) when given.
fn record(scenario: &Scenario, keep: &[&str], noise: Option<(f64, u64)>) -> FlightRecord {
    let trace =
        aeroid::eval::linear_flight::fly(scenario, scenario.linear.as_ref().unwrap()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(noise.map_or(0, |(_, seed)| seed));
    let mut seen = Vec::new();
    // Outputs come after the states and inputs: the last signal of a name.
    let signals: Vec<&(String, Vec<f64>)> = trace
        .signals
        .iter()
        .rev()
        .filter(|(name, _)| {
            keep.contains(&name.as_str()) && !seen.contains(name) && {
                seen.push(name.clone());
                true
            }
        })
        .collect();
    let channels = signals
        .into_iter()
        .rev()
        .map(|(name, values)| {
            let mean = values.iter().sum::<f64>() / values.len() as f64;
            let spread = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>()
                / values.len() as f64)
                .sqrt();
            let sigma = noise.map_or(0.0, |(factor, _)| factor * spread);
            Channel {
                name: name.clone(),
                unit: "-".into(),
                rate: 1.0 / scenario.step,
                resolution: None,
                source: "test".into(),
                times: trace.times.clone(),
                values: values
                    .iter()
                    .map(|v| v + sigma * rng.sample::<f64, _>(StandardNormal))
                    .collect(),
            }
        })
        .collect();
    FlightRecord {
        scenario: scenario.name.clone(),
        profile: "test".into(),
        channels,
        ..FlightRecord::default()
    }
}

/// `method` on `records` with `structure` and `[methods.METHOD]` `settings`.
fn fit(
    method: &str,
    records: &[&FlightRecord],
    structure: &LinearStructure,
    settings: &str,
) -> aeroid::estimation::Result<Estimate> {
    let mut structure = structure.clone();
    if !settings.is_empty() {
        structure
            .methods
            .insert(method.to_string(), toml::from_str(settings).unwrap());
    }
    let problem = common::registry().problem(
        method,
        records.iter().map(|r| (*r).clone()).collect(),
        structure,
        &[],
    )?;
    common::registry().estimate(&problem, None)
}

/// The file's parameter values: a flight's truth.
fn truth(text: &str) -> BTreeMap<String, f64> {
    let file: LinearFile = toml::from_str(text).unwrap();
    file.parameters
        .iter()
        .map(|(name, p)| (name.clone(), p.start))
        .collect()
}

/// The largest error of the estimate's parameters named in `truth`,
/// relative to max(|truth|, 1).
fn worst_error(estimate: &Estimate, truth: &BTreeMap<String, f64>) -> f64 {
    truth
        .iter()
        .map(|(name, t)| {
            let p = estimate
                .parameter(name)
                .unwrap_or_else(|| panic!("{name} not estimated"));
            (p.value - t).abs() / t.abs().max(1.0)
        })
        .fold(0.0, f64::max)
}

const OUTPUTS: [&str; 4] = ["elevator", "w", "q", "a_z"];

/// Z_w in A and C and Z_δe in B and D: output error and filter error on a
/// noise-free flight of the model (recorded on the flight's own grid, so
/// the fit's exact discretisation is the flight's), started 20 % off
/// every value, recover the truth within 1e-6 of max(|truth|, 1): what is
/// left is the solver's stop, a step under a small fraction of σ, and σ
/// is at rounding level on noise-free data (measured: errors 6e-15 and
/// 8e-15, σ below 3e-12). Frequency-domain output error (`fdoe`) is held
/// to the same 1e-6 (measured 4.5e-8: the quadrature of its Fourier
/// transforms of the sampled signals).
#[test]
fn a_parameter_in_the_state_and_output_equations_is_recovered() {
    let folder = common::temp_folder("linear-textbook-shared");
    let text = short_period(r#"["w", "q"]"#, "");
    let path = common::write(&folder, "flown.toml", &text);
    let record = record(&scenario(&path, THREE_TWO_ONE_ONE), &OUTPUTS, None);
    let started = structure(&folder, "fitted.toml", &text, 1.2);
    assert_eq!(
        started.entries[started.names.iter().position(|n| n == "Zw").unwrap()].len(),
        2
    );
    let truth = truth(&text);
    for method in ["oem", "fem", "fdoe"] {
        let estimate = fit(method, &[&record], &started, "").unwrap();
        assert_eq!(
            estimate.status,
            Status::Converged,
            "{method}: {:?}",
            estimate.notes
        );
        let worst = worst_error(&estimate, &truth);
        assert!(worst < 1e-6, "{method}: worst error {worst:.3e}");
    }
}

/// Equation error and frequency-domain regression regress one equation at
/// a time: free parameters in two equations are refused, the refusal
/// naming each with its entries, and the methods that fit them.
#[test]
fn regressions_refuse_a_parameter_in_several_equations() {
    let folder = common::temp_folder("linear-textbook-refused");
    let text = short_period(r#"["w", "q"]"#, "");
    let path = common::write(&folder, "flown.toml", &text);
    let record = record(&scenario(&path, THREE_TWO_ONE_ONE), &OUTPUTS, None);
    let started = structure(&folder, "fitted.toml", &text, 1.2);
    for method in ["ee", "fdee"] {
        match fit(method, &[&record], &started, "") {
            Err(aeroid::estimation::Error::Refused(refusal)) => {
                assert_eq!(refusal.kind(), RefusalKind::UnsuitableModel, "{method}");
                let text = refusal.to_string();
                for part in ["'Zw' (A[0][0], C[2][0])", "'Zde' (B[0][0], D[2][0])", "oem"] {
                    assert!(text.contains(part), "{method}: {part} not in: {text}");
                }
            }
            other => panic!("{method}: {other:?}"),
        }
    }
}

/// States named like no channel (`s_w`, `s_q`), a flight started at
/// w = 3 m/s, q = 0.05 rad/s (the model file's `initial_state`), its
/// outputs and input recorded without error.
///
/// - With `initial_state` stated the fit starts there: exact (1e-6 of
///   max(|truth|, 1), as above).
/// - Without it the states start from 0 (no channel names them): the
///   transient the fit cannot follow biases the estimates (measured: worst
///   error 6e-3, against 7e-15 with `initial_state`), held to beyond 1e-3.
/// - With `estimate_initial_state = true` and a wrong `initial_state`
///   (0, 0) the fit recovers θ exactly and x₀ to 1e-6.
#[test]
fn initial_states_come_from_the_model_or_are_estimated() {
    let folder = common::temp_folder("linear-textbook-initial");
    let states = r#"["s_w", "s_q"]"#;
    let flown = short_period(states, "initial_state = [3.0, 0.05]");
    let path = common::write(&folder, "flown.toml", &flown);
    let record = record(&scenario(&path, THREE_TWO_ONE_ONE), &OUTPUTS, None);
    let truth = truth(&flown);
    let stated = structure(&folder, "stated.toml", &flown, 1.2);
    let exact = fit("oem", &[&record], &stated, "").unwrap();
    assert_eq!(exact.status, Status::Converged, "{:?}", exact.notes);
    assert!(
        worst_error(&exact, &truth) < 1e-6,
        "{}",
        worst_error(&exact, &truth)
    );

    let unstated = structure(&folder, "unstated.toml", &short_period(states, ""), 1.2);
    let biased = fit("oem", &[&record], &unstated, "").unwrap();
    let bias = worst_error(&biased, &truth);
    assert!(bias > 1e-3, "no bias from x0 = 0: {bias:.3e}");

    let wrong = structure(
        &folder,
        "wrong.toml",
        &short_period(states, "initial_state = [0.0, 0.0]"),
        1.2,
    );
    let estimated = fit("oem", &[&record], &wrong, "estimate_initial_state = true").unwrap();
    assert_eq!(estimated.status, Status::Converged, "{:?}", estimated.notes);
    assert!(
        worst_error(&estimated, &truth) < 1e-6,
        "{}",
        worst_error(&estimated, &truth)
    );
    for (name, value) in [("x0[0].s_w", 3.0), ("x0[0].s_q", 0.05)] {
        let p = estimated.parameter(name).unwrap();
        assert!((p.value - value).abs() < 1e-6, "{name} = {}", p.value);
    }
}

/// Two flights of one model with different inputs (a 3211, a doublet)
/// and initial states, fitted jointly by output error: θ shared, each
/// record its own estimated x₀. Noise-free: θ within 1e-6 of
/// max(|truth|, 1) and each x₀ within 1e-6 of its flight's.
#[test]
fn several_records_fit_jointly_each_from_its_own_initial_state() {
    let folder = common::temp_folder("linear-textbook-joint");
    let states = r#"["w", "q"]"#;
    let first = short_period(states, "initial_state = [2.0, 0.03]");
    let second = short_period(states, "initial_state = [-1.5, -0.02]");
    let first_path = common::write(&folder, "first.toml", &first);
    let second_path = common::write(&folder, "second.toml", &second);
    let one = record(&scenario(&first_path, THREE_TWO_ONE_ONE), &OUTPUTS, None);
    let mut two = record(&scenario(&second_path, DOUBLET), &OUTPUTS, None);
    two.scenario = "second".into();
    let started = structure(&folder, "fitted.toml", &short_period(states, ""), 1.2);
    let joint = fit("oem", &[&one, &two], &started, "").unwrap();
    assert_eq!(joint.status, Status::Converged, "{:?}", joint.notes);
    let truth = truth(&first);
    assert!(
        worst_error(&joint, &truth) < 1e-6,
        "{}",
        worst_error(&joint, &truth)
    );
    for (name, value) in [
        ("x0[0].w", 2.0),
        ("x0[0].q", 0.03),
        ("x0[1].w", -1.5),
        ("x0[1].q", -0.02),
    ] {
        let p = joint.parameter(name).unwrap();
        assert!((p.value - value).abs() < 1e-6, "{name} = {}", p.value);
    }
}

/// Two records of the same flight with independent noise (2 % of each
/// output's spread): the joint fit's standard errors are those of twice
/// the data, each about 1/√2 of either record's alone (alone: the same
/// model, its x₀ estimated too); measured ratios 1.40–1.43, held to
/// 1.2–1.65 (the two records' own R estimates differ by their scatter).
/// The joint estimates are within 4σ of the truth (measured within 2σ).
#[test]
fn a_joint_fit_has_the_bounds_of_its_data() {
    let folder = common::temp_folder("linear-textbook-joint-noise");
    let states = r#"["w", "q"]"#;
    let flown = short_period(states, "initial_state = [2.0, 0.03]");
    let path = common::write(&folder, "flown.toml", &flown);
    let flight = scenario(&path, THREE_TWO_ONE_ONE);
    let one = record(&flight, &OUTPUTS, Some((0.02, 1)));
    let mut two = record(&flight, &OUTPUTS, Some((0.02, 2)));
    two.scenario = "repeat".into();
    let started = structure(&folder, "fitted.toml", &short_period(states, ""), 1.2);
    let joint = fit("oem", &[&one, &two], &started, "").unwrap();
    assert_eq!(joint.status, Status::Converged, "{:?}", joint.notes);
    let alone: Vec<Estimate> = [&one, &two]
        .iter()
        .map(|r| fit("oem", &[r], &started, "estimate_initial_state = true").unwrap())
        .collect();
    for (name, t) in truth(&flown) {
        let p = joint.parameter(&name).unwrap();
        assert!(
            (p.value - t).abs() < 4.0 * p.standard_error,
            "{name}: {} against {t}",
            p.value
        );
        for single in &alone {
            let ratio = single.parameter(&name).unwrap().standard_error / p.standard_error;
            assert!((1.2..1.65).contains(&ratio), "{name}: σ ratio {ratio:.3}");
        }
    }
}

/// Output biases beside the states' (the book's BY beside BX): α is a
/// state and an output with its own bias, y_α = α + c_α, and q̇ has a
/// state bias b_q. Flown with c_α = 0.01 rad and b_q = 0.02 rad/s²
/// (noise-free), fitted from c_α = b_q = 0 and the other parameters 20 %
/// off, the states' x₀ estimated: both biases and every derivative within
/// 1e-6 of max(|truth|, 1) (measured 1e-14). The recorded α is α + c_α,
/// not the state's start (started from it, the fit converges 2.6e-2 off
/// the truth): output error estimates x₀ unasked, and says so.
#[test]
fn output_and_state_biases_are_recovered_together() {
    let folder = common::temp_folder("linear-textbook-biases");
    let text = |c: f64, b: f64| {
        format!(
            r#"
kind = "linear"
name = "biased-short-period"
states = ["alpha", "q"]
inputs = ["elevator"]
outputs = ["alpha", "q"]
A = [["Za", 1.0], ["Ma", "Mq"]]
B = [[0.0], ["Mde"]]
C = [[1, 0], [0, 1]]
state_bias = [0, "bq"]
output_bias = ["calpha", 0]
[parameters.Za]
start = -1.2
[parameters.Ma]
start = -6.0
[parameters.Mq]
start = -2.0
[parameters.Mde]
start = -9.0
[parameters.bq]
start = {b}
[parameters.calpha]
start = {c}
"#
        )
    };
    let flown = text(0.01, 0.02);
    let path = common::write(&folder, "flown.toml", &flown);
    let record = record(
        &scenario(&path, THREE_TWO_ONE_ONE),
        &["elevator", "alpha", "q"],
        None,
    );
    let started = structure(&folder, "fitted.toml", &text(0.0, 0.0), 1.2);
    let truth = truth(&flown);
    for settings in ["estimate_initial_state = true", ""] {
        let estimate = fit("oem", &[&record], &started, settings).unwrap();
        assert_eq!(estimate.status, Status::Converged, "{:?}", estimate.notes);
        let worst = worst_error(&estimate, &truth);
        assert!(worst < 1e-6, "{settings}: {worst:.3e}");
        assert!(estimate.parameter("x0[0].alpha").is_some(), "{settings}");
        let said = estimate
            .notes
            .iter()
            .any(|n| n.starts_with("the initial state is estimated: the recorded alpha"));
        assert_eq!(
            said,
            settings.is_empty(),
            "{settings}: {:?}",
            estimate.notes
        );
    }
}
