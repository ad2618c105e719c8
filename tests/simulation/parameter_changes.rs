//! Scheduled parameter changes (`[[parameter_changes]]` of a scenario): the
//! flight changes exactly at the step of the change and not before, the
//! run's truth records the schedule and reads back, and bad tables are
//! reported with the file and key.

use crate::common;
use aeroid::sim::Error;
use aeroid::sim::scenario::{ParameterChange, Scenario};
use aeroid::sim::truth::RunTruth;
use aeroid::sim::{Simulation, fly};

const SCENARIO: &str = "attas-cm-alpha-step";

fn problems_of(error: &Error) -> Vec<(String, String)> {
    match error.field_errors() {
        Some(problems) => problems
            .iter()
            .map(|p| (p.field.clone(), p.message.clone()))
            .collect(),
        None => panic!("expected a validation error, got {error}"),
    }
}

/// The elevator 3211 scenario with `tables` appended, written to a fresh folder.
fn scenario_with(test: &str, tables: &str) -> (std::path::PathBuf, aeroid::sim::Result<Scenario>) {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/attas-elevator-3211.toml"
    ))
    .unwrap();
    let folder = common::temp_folder(test);
    let path = common::write(&folder, "changes.toml", &format!("{text}\n{tables}"));
    let scenario = Scenario::load(path.to_str().unwrap());
    (path, scenario)
}

/// The bundled Cm_alpha step: the samples before 30 s and the state at 30 s
/// are bit for bit those of the same flight without the change; the pitching
/// moment at 30 s and the states after it are not.
#[test]
fn a_parameter_step_changes_the_flight_from_its_step_on() {
    let scenario = Scenario::load(SCENARIO).unwrap();
    assert_eq!(
        scenario.parameter_changes,
        [ParameterChange {
            time: 30.0,
            parameter: "Cm_alpha".into(),
            value: 0.8 * -0.176,
        }]
    );
    let mut unchanged = scenario.clone();
    unchanged.parameter_changes.clear();
    let changed = Simulation::prepare(&scenario).unwrap().run().unwrap();
    let reference = Simulation::prepare(&unchanged).unwrap().run().unwrap();
    let at = (30.0 / scenario.step).round() as usize;
    assert_eq!(changed.samples[..at], reference.samples[..at]);
    assert_eq!(changed.samples[at].state, reference.samples[at].state);
    let pitching_moment = |trace: &aeroid::sim::trace::TruthTrace, k: usize| {
        trace.samples[k].evaluation.coefficients.moment.y
    };
    assert_ne!(
        pitching_moment(&changed, at),
        pitching_moment(&reference, at)
    );
    assert!(
        changed.samples[at + 1..]
            .iter()
            .zip(&reference.samples[at + 1..])
            .all(|(a, b)| a.state != b.state)
    );
}

/// The truth holds the values at the start in `parameters`, the schedule in
/// `parameter_changes`, and reads back from truth.toml unchanged; a truth
/// without changes writes no `parameter_changes` key, as before.
#[test]
fn the_truth_records_the_schedule_and_reads_back() {
    let scenario = Scenario::load(SCENARIO).unwrap();
    let mut short = scenario.clone();
    short.duration = 31.0;
    let (_, truth) = fly(&short).unwrap();
    assert_eq!(truth.parameters["Cm_alpha"], -0.176);
    assert_eq!(truth.parameter_changes, scenario.parameter_changes);
    assert_eq!(truth.parameter_at("Cm_alpha", 29.99), Some(-0.176));
    assert_eq!(truth.parameter_at("Cm_alpha", 30.0), Some(0.8 * -0.176));
    assert_eq!(truth.parameter_at("Cm_q", 45.0), Some(-12.3));
    assert_eq!(truth.parameter_at("Cm_bogus", 45.0), None);
    let last = truth.final_parameters();
    assert_eq!(last["Cm_alpha"], 0.8 * -0.176);
    assert_eq!(last["Cm_q"], truth.parameters["Cm_q"]);

    let folder = common::temp_folder("truth-schedule");
    let path = folder.join("truth.toml");
    truth.write(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("[[parameter_changes]]"), "{text}");
    assert_eq!(RunTruth::read(&path).unwrap(), truth);

    let mut calm = short;
    calm.parameter_changes.clear();
    let (_, truth) = fly(&calm).unwrap();
    truth.write(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(!text.contains("parameter_changes"), "{text}");
    let read = RunTruth::read(&path).unwrap();
    assert!(read.parameter_changes.is_empty());
    assert_eq!(read.final_parameters(), read.parameters);
}

/// Every bad table is reported at once, under `parameter_changes[i].KEY`,
/// with the scenario file named.
#[test]
fn bad_changes_name_the_file_and_the_key() {
    let (path, scenario) = scenario_with(
        "bad-parameter-changes",
        r#"
[[parameter_changes]]
time = "10 s"
parameter = "Cm_bogus"
value = 1.0

[[parameter_changes]]
time = "-1 s"
parameter = "Cm_alpha"
value = -0.1

[[parameter_changes]]
time = "61 s"
parameter = "Cm_alpha"
scale = 0.8

[[parameter_changes]]
time = "20 s"
parameter = "Cm_q"
value = -10.0
scale = 0.8

[[parameter_changes]]
time = "20.005 s"
parameter = "Cm_q"
scale = 0.9

[[parameter_changes]]
time = "25 s"
parameter = "e"
value = 0.0

[[parameter_changes]]
time = "25 s"
parameter = "CL_alpha"
"#,
    );
    let error = scenario.unwrap_err();
    let message = error.to_string();
    assert!(message.contains(&path.display().to_string()), "{message}");
    let problems = problems_of(&error);
    let fields: Vec<&str> = problems.iter().map(|(f, _)| f.as_str()).collect();
    assert_eq!(
        fields,
        [
            "parameter_changes[0].parameter",
            "parameter_changes[1].time",
            "parameter_changes[2].time",
            "parameter_changes[3].scale",
            "parameter_changes[4].time",
            "parameter_changes[5].value",
            "parameter_changes[6].value",
        ],
        "{message}"
    );
    for expected in [
        "'Cm_bogus' is not a parameter of aircraft ATTAS; known: ",
        "-1 s is outside the run",
        "61 s is outside the run",
        "not both",
        "not a multiple of the step 0.01 s",
        "Oswald factor e must be positive",
        "give the new `value` or a `scale`",
    ] {
        assert!(message.contains(expected), "{expected}: {message}");
    }
}

/// The same parameter cannot be changed twice at one instant, and a stall
/// model's τ1 cannot turn χ from an algebraic variable into a state.
#[test]
fn ambiguous_and_structural_changes_are_refused() {
    let (_, scenario) = scenario_with(
        "twice-at-once",
        r#"
[[parameter_changes]]
time = "20 s"
parameter = "Cm_q"
scale = 0.9
[[parameter_changes]]
time = "20 s"
parameter = "Cm_q"
scale = 0.8
"#,
    );
    let problems = problems_of(&scenario.unwrap_err());
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert_eq!(problems[0].0, "parameter_changes[1].time");
    assert!(problems[0].1.contains("Cm_q is changed twice at 20 s"));

    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/attas-stall.toml"
    ))
    .unwrap();
    let folder = common::temp_folder("tau1-from-zero");
    let path = common::write(
        &folder,
        "stall.toml",
        &format!(
            "{text}\n[[parameter_changes]]\ntime = \"20 s\"\nparameter = \"tau1\"\nvalue = 0.5\n"
        ),
    );
    let problems = problems_of(&Scenario::load(path.to_str().unwrap()).unwrap_err());
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert_eq!(problems[0].0, "parameter_changes[0].value");
    assert!(problems[0].1.contains("tau1 must stay 0"), "{problems:?}");
}

/// Changes at one instant act together, and later changes build on earlier
/// ones: the simulator's model at each step carries every change up to it.
#[test]
fn the_simulator_flies_each_model_from_its_step() {
    let (_, scenario) = scenario_with(
        "several-changes",
        r#"
[[parameter_changes]]
time = "40 s"
parameter = "Cm_q"
value = -10.0
[[parameter_changes]]
time = "20 s"
parameter = "Cm_alpha"
value = -0.2
[[parameter_changes]]
time = "20 s"
parameter = "CL_alpha"
scale = 1.1
"#,
    );
    let scenario = scenario.unwrap();
    let times: Vec<f64> = scenario.parameter_changes.iter().map(|c| c.time).collect();
    assert_eq!(times, [20.0, 20.0, 40.0]);
    let simulation = Simulation::prepare(&scenario).unwrap();
    let value = |k: usize, name: &str| {
        simulation
            .model_at(k)
            .aircraft
            .aero
            .parameters
            .get(name)
            .unwrap()
    };
    assert_eq!(simulation.changed_models.len(), 2);
    assert_eq!(value(1999, "Cm_alpha"), -0.176);
    assert_eq!(value(2000, "Cm_alpha"), -0.2);
    assert_eq!(value(2000, "CL_alpha"), 1.1 * 3.30);
    assert_eq!(value(3999, "Cm_q"), -12.3);
    assert_eq!(value(4000, "Cm_q"), -10.0);
    assert_eq!(value(4000, "Cm_alpha"), -0.2);
}

/// A flight of one of JSBSim's own aircraft refuses parameter changes, with
/// the reason, whether or not this build has JSBSim.
#[test]
fn a_jsbsim_aircraft_refuses_parameter_changes() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/b737-elevator-3211.toml"
    ))
    .unwrap();
    let folder = common::temp_folder("jsbsim-parameter-changes");
    let path = common::write(
        &folder,
        "b737.toml",
        &format!(
            "{text}\n[[parameter_changes]]\ntime = \"10 s\"\nparameter = \"Cm_alpha\"\nscale = 0.8\n"
        ),
    );
    let error = Scenario::load(path.to_str().unwrap()).unwrap_err();
    let problems = problems_of(&error);
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert_eq!(problems[0].0, "parameter_changes");
    assert!(
        problems[0].1.contains("JSBSim's own aerodynamic tables"),
        "{problems:?}"
    );
    assert!(error.to_string().contains(&path.display().to_string()));
}

/// `aeroid check` reports a bad change with the file and key, and lists a
/// valid scenario's changes.
#[test]
fn check_reports_parameter_changes() {
    let (path, _) = scenario_with(
        "check-parameter-changes",
        "[[parameter_changes]]\ntime = \"10 s\"\nparameter = \"Cm_bogus\"\nvalue = 1.0\n",
    );
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_aeroid"))
        .args(["check", path.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        stderr.contains(&path.display().to_string())
            && stderr.contains("parameter_changes[0].parameter: 'Cm_bogus'"),
        "{stderr}"
    );
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_aeroid"))
        .arg("check")
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/scenarios/attas-cm-alpha-step.toml"
        ))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        stdout.contains("parameter change at 30 s: Cm_alpha = -0.1408"),
        "{stdout}"
    );
}
