//! The estimator interface from a newcomer's side: a toy estimator added
//! through the registry alone (this file's type and one `Registry::add` call)
//! is found by `estimate` (the problem's method), `run`, `gate` and
//! `study`, with its settings table read from a gate file, checked and
//! refused when wrong; and the estimation problem's JSON reads back
//! identically for every bundled model on every bundled scenario.

use aeroid::estimation::Result;
use aeroid::estimation::estimate::{Estimate, ParameterEstimate, Status};
use aeroid::estimation::estimator::{Capabilities, Description, Method};
use aeroid::estimation::problem::EstimationProblem;
use aeroid::estimation::registry::Registry;
use aeroid::estimation::structure::ModelStructure;
use aeroid::eval::{gate, run, study};
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;
use std::sync::Arc;

/// The toy: every free parameter at the model file's start value times
/// `scale`, with standard error `sigma`. Not an estimator anyone should
/// use; it exercises the interface.
struct StartValues;

#[derive(serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
struct StartSettings {
    scale: f64,
    sigma: f64,
}

impl Default for StartSettings {
    fn default() -> Self {
        StartSettings {
            scale: 1.0,
            sigma: 1.0,
        }
    }
}

impl Method for StartValues {
    const NAME: &'static str = "toy-start";
    type Settings = StartSettings;

    fn describe() -> Description {
        Description {
            title: "the model file's start values",
            paper: "none",
            equations: "θ = scale·θ₀",
            needs: "nothing",
            settings: vec![("scale", "factor on the start values"), ("sigma", "σ")],
        }
    }

    /// A 6-DOF structure, one record.
    fn capabilities() -> Capabilities {
        Capabilities::default()
    }

    fn fit(
        &self,
        problem: &EstimationProblem,
        settings: &StartSettings,
        _start: Option<&Estimate>,
    ) -> Result<Estimate> {
        let structure = problem.structure.six_dof("toy-start")?;
        let parameters = &structure.aircraft.aero.parameters;
        let free: Vec<ParameterEstimate> = parameters
            .names()
            .iter()
            .zip(parameters.values())
            .enumerate()
            .filter(|(i, _)| structure.free[*i])
            .map(|(_, (name, &start))| ParameterEstimate {
                name: name.clone(),
                value: settings.scale * start,
                standard_error: settings.sigma,
                start,
            })
            .collect();
        let n = free.len();
        Ok(Estimate {
            method: "toy-start".into(),
            model: structure.name.clone(),
            record: problem.record().scenario.clone(),
            status: Status::Converged,
            diagnoses: Vec::new(),
            covariance: (0..n)
                .map(|i| {
                    (0..n)
                        .map(|j| if i == j { settings.sigma.powi(2) } else { 0.0 })
                        .collect()
                })
                .collect(),
            parameters: free,
            fits: Vec::new(),
            iterations: 0,
            cost_history: Vec::new(),
            wall_time: 0.0,
            notes: Vec::new(),
            details: String::new(),
            network: None,
            distributions: Vec::new(),
            histories: Vec::new(),
        })
    }
}

/// `[methods.NAME]` tables written as TOML (`[NAME]` tables).
fn tables(text: &str) -> aeroid::estimation::estimator::MethodTables {
    let parsed: toml::Table = toml::from_str(text).unwrap();
    parsed
        .into_iter()
        .map(|(name, table)| (name, table.as_table().unwrap().clone()))
        .collect()
}

/// The built-in estimators and the toy, added as a program adds its own.
fn toy_registry() -> &'static Registry {
    static REGISTRY: std::sync::OnceLock<Registry> = std::sync::OnceLock::new();
    REGISTRY.get_or_init(|| {
        let mut registry = Registry::built_in();
        registry.add(Arc::new(StartValues)).unwrap();
        registry
    })
}

#[test]
fn a_registered_estimator_runs_everywhere() {
    assert!(toy_registry().names().contains(&"toy-start".to_string()));
    assert!(
        toy_registry().clone().add(Arc::new(StartValues)).is_err(),
        "a name twice"
    );

    // estimate: the problem names the method; the model's table is merged
    // with the caller's.
    let scenario = Scenario::load("attas-lateral-multistep").unwrap();
    let profile = aeroid::record::recorder::profile_for(&scenario, None).unwrap();
    let (record, truth) = record_scenario(&scenario, &profile).unwrap();
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let overrides = tables("[toy-start]\nscale = 2.0");
    let problem = toy_registry()
        .problem(
            "toy-start",
            vec![record.clone()],
            structure.clone(),
            &[&overrides],
        )
        .unwrap();
    let estimate = toy_registry().estimate(&problem, None).unwrap();
    let first = &estimate.parameters[0];
    assert_eq!(first.value, 2.0 * first.start);
    assert_eq!(estimate.status, Status::Converged);

    // A setting it does not know is refused before it runs.
    let wrong = tables("[toy-start]\nscael = 2.0");
    let error = toy_registry()
        .problem(
            "toy-start",
            vec![record.clone()],
            structure.clone(),
            &[&wrong],
        )
        .unwrap_err()
        .to_string();
    assert!(error.contains("scael"), "{error}");

    // run: every registered method, the toy among them, scored.
    let report = run::run(toy_registry(), &scenario, &profile, None).unwrap();
    let toy = report
        .runs
        .iter()
        .find(|r| r.method == "toy-start")
        .expect("run lists the toy");
    assert!(toy.coverage().is_some());
    let _ = truth;

    // gate: a gate file naming the toy, with its settings table.
    let folder = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("aeroid-registry-{}", std::process::id()));
    std::fs::create_dir_all(&folder).unwrap();
    let gate_file = folder.join("gates.toml");
    std::fs::write(
        &gate_file,
        r#"[[case]]
name = "toy"
scenario = "attas-lateral-multistep"
profile = "ideal"
model = "attas-lateral"
method = "toy-start"
relative_tolerance = 0.4
absolute_floor = 1e-6
[case.methods.toy-start]
sigma = 0.5
"#,
    )
    .unwrap();
    let gates = gate::load(toy_registry(), &gate_file).unwrap();
    let result = gate::run_case(toy_registry(), &gates.cases[0]).unwrap();
    let estimate = result.estimate.as_ref().unwrap();
    assert!(estimate.parameters.iter().all(|p| p.standard_error == 0.5));
    // The toy returns the model file's start values: the gate judges each
    // one against the truth (18 rows), whatever it concludes.
    assert_eq!(result.rows.len(), 18, "{}", result.table(false));

    // study: a study file with the toy as its method.
    let study_file = folder.join("study.toml");
    std::fs::write(
        &study_file,
        r#"name = "toy"
scenarios = ["attas-lateral-multistep"]
profile = "ideal"
models = ["attas-lateral"]
runs = 2
seed = 1
[methods.toy-start]
scale = 1.0
"#,
    )
    .unwrap();
    let study = study::Study::load(toy_registry(), study_file.to_str().unwrap()).unwrap();
    assert_eq!(study.methods, ["toy-start"]);
    let rows = study.run_case(study.cases()[0]);
    assert!(rows.iter().all(|r| r.method == "toy-start"));
    assert!(
        rows.iter()
            .any(|r| r.status == aeroid::eval::row::RowStatus::Converged)
    );
    std::fs::remove_dir_all(&folder).unwrap();
}

/// The problem's JSON reads back identically: for every bundled model on
/// every bundled scenario (5 s of it), the problem read back equals the
/// one written (records compared bit for bit through the JSON text, whose
/// numbers are shortest round-trip decimals), for every method.
#[test]
fn estimation_problem_json_round_trip_is_exact() {
    let models = aeroid::catalog::bundled(aeroid::catalog::MODEL_FOLDER);
    let mut flown = 0;
    let mut problems = 0;
    for name in aeroid::catalog::bundled(aeroid::catalog::SCENARIO_FOLDER) {
        // JSBSim's own aircraft fly only in a build with the `jsbsim` feature.
        let Ok(mut scenario) = Scenario::load(&name) else {
            continue;
        };
        flown += 1;
        scenario.duration = scenario.duration.min(5.0);
        let profile = Profile::load("flight-test-25hz", None).unwrap();
        let (record, _) = record_scenario(&scenario, &profile).unwrap();
        for model in &models {
            let structure = aeroid::estimation::structure::Structure::load(model).unwrap();
            for method in ["ee", "swr", "oem"] {
                let problem = toy_registry()
                    .problem(
                        method,
                        vec![record.clone()],
                        structure.clone(),
                        &[&scenario.methods],
                    )
                    .unwrap();
                let text = problem.to_json().unwrap();
                let back =
                    EstimationProblem::from_json(&text, std::path::Path::new("problem.json"))
                        .unwrap();
                let again = back.to_json().unwrap();
                let first_difference = again
                    .lines()
                    .zip(text.lines())
                    .enumerate()
                    .find(|(_, (a, b))| a != b);
                assert_eq!(
                    first_difference, None,
                    "{name} {model} {method}: the JSON read back and written again differs"
                );
                assert_eq!(again.len(), text.len(), "{name} {model} {method}");
                // Field by field, every float in its shortest round-trip
                // form (NaN, an unset reference speed, is not == itself).
                assert_eq!(
                    format!("{:?}", back.structure),
                    format!("{:?}", problem.structure),
                    "{name} {model}"
                );
                assert_eq!(back.settings, problem.settings, "{name} {model}");
                for (a, b) in back.records[0]
                    .channels
                    .iter()
                    .zip(&problem.records[0].channels)
                {
                    assert!(
                        a.values
                            .iter()
                            .zip(&b.values)
                            .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan())),
                        "{name}: channel {}",
                        a.name
                    );
                }
                problems += 1;
            }
        }
    }
    assert!(flown >= 9, "{flown} scenarios flown");
    assert_eq!(problems, flown * models.len() * 3);
}

/// A problem file that is not one, or whose record breaks the record
/// format (times that do not increase), is refused naming the file.
#[test]
fn a_broken_problem_file_is_refused() {
    let scenario = Scenario::load("attas-lateral-multistep").unwrap();
    let profile = Profile::load("ideal", None).unwrap();
    let (record, _) = record_scenario(&scenario, &profile).unwrap();
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let problem = toy_registry()
        .problem("oem", vec![record], structure, &[])
        .unwrap();
    let origin = std::path::Path::new("broken.json");
    let error = EstimationProblem::from_json("{\"format\": 1}", origin)
        .unwrap_err()
        .to_string();
    assert!(
        error.starts_with("broken.json: not an estimation problem"),
        "{error}"
    );
    let mut reversed = problem.clone();
    reversed.records[0].channels[0].times.reverse();
    let error = EstimationProblem::from_json(&reversed.to_json().unwrap(), origin)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("broken.json") && error.contains("not after"),
        "{error}"
    );
}

/// Settings without an upper bound once asked for more memory or time
/// than any machine has (a differentiator's window of 1e9 s, a degree of
/// 1e11, a step of 1e-9 s, 1e8 starts or noise draws, a spread of 1e308):
/// each is refused by the method's settings check, naming the key and
/// the range, before anything is allocated.
#[test]
fn unbounded_settings_are_refused_with_their_range() {
    let refused = |method: &str, key: &str, value: serde_json::Value, range: &str| {
        let mut settings = aeroid::estimation::estimator::Settings::new();
        settings.insert(key.to_string(), value);
        if key == "input_noise_draws" {
            settings.insert(
                "input_noise".into(),
                serde_json::json!({ "elevator": "0.01 deg" }),
            );
        }
        let error = crate::common::registry()
            .find(method)
            .unwrap()
            .check_settings(&settings)
            .unwrap_err()
            .to_string();
        assert!(
            error.contains(key) && error.contains(range),
            "{method} {key}: {error}"
        );
    };
    for method in ["ee", "swr"] {
        refused(
            method,
            "differentiator",
            serde_json::json!({ "half_width": "1e9 s", "degree": 4 }),
            "at most 10 s",
        );
        refused(
            method,
            "differentiator",
            serde_json::json!({ "half_width": "0.1 s", "degree": 100_000_000_000u64 }),
            "from 1 to 10",
        );
    }
    for method in ["oem", "fem", "ekf", "ukf"] {
        refused(method, "step", "1e-9 s".into(), "at least 0.00001 s");
    }
    refused("oem", "starts", 100_000_000.into(), "from 1 to 1000");
    refused("oem", "start_spread", 1e308.into(), "at most 10");
    refused(
        "oem",
        "input_noise_draws",
        100_000_000.into(),
        "from 2 to 100000",
    );
}
