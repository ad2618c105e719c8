//! Bad input gets a clear error naming the file, field, line or time — never
//! a panic — and a departing simulation keeps the trace computed so far.

use crate::common;
use aeroid::sim::Error;
use aeroid::sim::aircraft::Aircraft;
use aeroid::sim::scenario::Scenario;
use std::path::Path;

fn load_aircraft_text(test: &str, text: &str) -> (std::path::PathBuf, Error) {
    let folder = common::temp_folder(test);
    let path = common::write(&folder, "plane.toml", text);
    let error = Aircraft::load(&path).unwrap_err();
    (path, error)
}

fn problem_fields(error: &Error) -> Vec<String> {
    match error.field_errors() {
        Some(problems) => problems.iter().map(|p| p.field.clone()).collect(),
        None => panic!("expected a validation error, got {error}"),
    }
}

#[test]
fn malformed_toml_names_file_and_line() {
    let text = common::attas_with(|t| t.replace("span = \"21.5 m\"", "span = = 21.5"));
    let line = 1 + text
        .lines()
        .position(|l| l.starts_with("span = ="))
        .unwrap();
    let (path, error) = load_aircraft_text("malformed", &text);
    let message = error.to_string();
    assert!(
        matches!(error, Error::Core(aeroid_core::Error::Toml { .. })),
        "{message}"
    );
    assert!(
        message.contains(&path.display().to_string())
            && message.contains(&format!("line {line}, column 8")),
        "{message}"
    );
}

#[test]
fn unknown_aircraft_lists_the_known_ones() {
    let folder = common::temp_folder("unknown-aircraft");
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/attas-trim.toml"
    ))
    .unwrap();
    let path = common::write(
        &folder,
        "s.toml",
        &text.replace("aircraft = \"attas\"", "aircraft = \"concorde\""),
    );
    let error = Scenario::load(path.to_str().unwrap()).unwrap_err();
    let message = error.to_string();
    assert!(
        message.contains("unknown aircraft 'concorde'") && message.contains("attas"),
        "{message}"
    );
}

/// Without the `jsbsim` feature, a scenario that names one of JSBSim's own
/// aircraft says so, naming the file and how to build (the default build has
/// no C++ JSBSim); the bundled 737 scenario is one.
#[cfg(not(feature = "jsbsim"))]
#[test]
fn a_jsbsim_aircraft_without_the_feature_says_how_to_build() {
    let error = Scenario::load("b737-elevator-3211").unwrap_err();
    let message = error.to_string();
    assert_eq!(problem_fields(&error), ["aircraft"]);
    for expected in [
        "scenarios/b737-elevator-3211.toml",
        "'jsbsim:737' is one of JSBSim's own aircraft",
        "--features jsbsim",
    ] {
        assert!(message.contains(expected), "{expected}: {message}");
    }
}

#[test]
fn negative_mass_nan_and_bad_unit_are_all_reported_at_once() {
    let text = common::attas_with(|t| {
        t.replace("mass = \"17631 kg\"", "mass = \"-17631 kg\"")
            .replace("span = \"21.5 m\"", "span = nan")
            .replace("chord = \"3.159 m\"", "chord = \"3.159 parsec\"")
    });
    let (path, error) = load_aircraft_text("negative-mass", &text);
    assert_eq!(
        problem_fields(&error),
        ["geometry.span", "geometry.chord", "mass.mass"]
    );
    let message = error.to_string();
    assert!(
        message.starts_with(&path.display().to_string()),
        "{message}"
    );
    assert!(
        message.contains("not a finite number")
            && message.contains("'parsec'")
            && message.contains("must be positive"),
        "{message}"
    );
}

/// A mass of 1e308 kg or an inertia of 1e300 kg·m² (a unit slip or a
/// typo) is refused with the key, the value as a number and the range,
/// not accepted and printed as a 309-digit number.
#[test]
fn a_mass_or_inertia_beyond_any_aircraft_is_refused_with_its_range() {
    let text = common::attas_with(|t| {
        t.replace("mass = \"17631 kg\"", "mass = \"1e308 kg\"")
            .replace("1.14420e4 kg*m2", "1e300 kg*m2")
    });
    let (_, error) = load_aircraft_text("heavy", &text);
    let fields = problem_fields(&error);
    assert!(fields.contains(&"mass.mass".to_string()), "{fields:?}");
    let message = error.to_string();
    assert!(
        message.contains("mass.mass: must be positive and at most 1e7 kg, is 1e308 kg")
            && message.contains("at most 1e10 kg·m² in magnitude, is 1e300 kg·m²"),
        "{message}"
    );
}

#[test]
fn inertia_must_be_positive_definite() {
    let (_, error) = load_aircraft_text(
        "inertia",
        &common::attas_with(|t| t.replace("1.14420e4 kg*m2", "3.0e5 kg*m2")),
    );
    assert_eq!(problem_fields(&error), ["mass"]);
    assert!(
        error.to_string().contains("not positive definite"),
        "{error}"
    );
}

#[test]
fn unknown_parameter_names_are_rejected() {
    let (_, error) = load_aircraft_text(
        "unknown-term",
        &common::attas_with(|t| t.replace("[aero.Cm]", "[aero.Cm]\nalpha_squared = 0.3")),
    );
    assert_eq!(problem_fields(&error), ["aero.Cm.alpha_squared"]);
    assert!(error.to_string().contains("unknown term 'alpha_squared'"));

    let mut aircraft = Aircraft::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/aircraft/attas.toml"
    )))
    .unwrap();
    let error = aircraft
        .aero
        .parameters
        .set("Cm_alpha_squared", 1.0)
        .unwrap_err();
    assert!(
        error
            .to_string()
            .contains("unknown parameter 'Cm_alpha_squared'")
            && error.to_string().contains("Cm_alpha")
    );
    aircraft.aero.parameters.set("Cm_alpha", -0.5).unwrap();
    assert_eq!(aircraft.aero.parameters.get("Cm_alpha"), Some(-0.5));
}

#[test]
fn impossible_trim_is_reported_with_what_it_would_need() {
    let mut scenario = Scenario::load("attas-trim").unwrap();
    scenario.trim.airspeed = 400.0;
    let error = aeroid::sim::Simulation::prepare(&scenario).unwrap_err();
    let message = error.to_string();
    assert!(
        message.starts_with("no trim") && message.contains("throttle"),
        "{message}"
    );
}

/// A statically unstable aircraft (Cmα > 0) trims, then diverges in pitch.
/// Flown with `fly`, the departure comes beside the trace up to it (the
/// error type holds no trace); flown with `run`, it is an error with the time.
#[test]
fn departing_simulation_reports_time_and_keeps_the_trace() {
    let mut scenario = Scenario::load("attas-trim").unwrap();
    scenario
        .aircraft
        .aero
        .parameters
        .set("Cm_alpha", 0.05)
        .unwrap();
    scenario.aircraft.aero.parameters.set("Cm_q", 0.0).unwrap();
    let simulation = aeroid::sim::Simulation::prepare(&scenario).unwrap();
    let mut simulation = simulation;
    simulation.exogenous[0][0] += 0.01;
    let (partial, departure) = simulation.fly();
    let Some(departure) = departure else {
        panic!("expected a departure");
    };
    let time = departure.time;
    assert!(time > 0.0 && time < 60.0, "{time}");
    assert!(!partial.samples.is_empty());
    let last = partial.samples.last().unwrap().time;
    assert!(
        (time - last - scenario.step).abs() < 1e-9,
        "trace ends one step before departure"
    );
    assert!(
        departure.reason.contains('α') || departure.reason.contains("airspeed"),
        "{}",
        departure.reason
    );
    match simulation.run() {
        Err(Error::Departed {
            time: run_time,
            reason,
        }) => {
            assert_eq!(run_time, time);
            assert_eq!(reason, departure.reason);
        }
        other => panic!("expected a departure, got {other:?}"),
    }
}

/// The CLI explains every problem and exits non-zero; a departure still writes the partial trace.
#[test]
fn cli_check_explains_problems_and_fails() {
    let text = common::attas_with(|t| {
        t.replace("mass = \"17631 kg\"", "mass = 0")
            .replace("[aero.CL]", "[aero.CL]\nbogus = 1")
    });
    let folder = common::temp_folder("cli-check");
    let path = common::write(&folder, "plane.toml", &text);
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_aeroid"))
        .arg("check")
        .arg(&path)
        .output()
        .unwrap();
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("2 problem(s)")
            && stderr.contains("mass.mass")
            && stderr.contains("aero.CL.bogus"),
        "{stderr}"
    );
}

/// A multisine period so long that its band's harmonic numbers do not fit
/// is a problem naming the input's period, not an integer overflow.
#[test]
fn multisine_period_beyond_harmonic_numbers_is_named() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/attas-multisine.toml"
    ))
    .unwrap()
    .replace(
        "period = \"20 s\"",
        "period = \"123456789012345678901234567890 s\"",
    );
    let folder = common::temp_folder("multisine-period");
    let path = common::write(&folder, "s.toml", &text);
    let error = Scenario::load(path.to_str().unwrap()).unwrap_err();
    let fields = problem_fields(&error);
    let message = error.to_string();
    assert_eq!(fields, ["inputs[0].period"], "{message}");
    assert!(
        message.contains("puts the harmonic numbers beyond 4294967295"),
        "{message}"
    );
}

/// A gate whose tolerance is infinite would pass whatever the estimate: the
/// gate file is refused, naming the case.
#[test]
fn an_infinite_gate_tolerance_is_refused() {
    let folder = common::temp_folder("infinite-tolerance");
    let path = common::write(
        &folder,
        "gates.toml",
        r#"[[case]]
name = "never-fails"
scenario = "attas-lateral-multistep"
profile = "ideal"
model = "attas-lateral"
method = "oem"
sigma_tolerance = inf
"#,
    );
    let error = aeroid::eval::gate::load(crate::common::registry(), &path)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("never-fails") && error.contains("positive finite"),
        "{error}"
    );
    std::fs::remove_dir_all(&folder).unwrap();
}

/// A bad `interpolation` setting is refused before any fit, the error
/// naming the method's table and the key: an unknown word, a table naming
/// a channel that is not an input, and a number.
#[test]
fn a_bad_interpolation_names_the_key() {
    use aeroid::estimation::estimator::MethodTables;

    use aeroid::estimation::structure::Structure;
    use aeroid::record::recorder::{Profile, record_scenario};
    let mut scenario = Scenario::load("attas-elevator-3211").unwrap();
    scenario.duration = 2.0;
    let profile = Profile::load("ideal", None).unwrap();
    let record = record_scenario(&scenario, &profile).unwrap().0;
    for (method, value, expected) in [
        ("oem", "\"cubic\"", "\"cubic\" is not"),
        ("fem", "{ ailerons = \"zoh\" }", "no input named ailerons"),
        ("ekf", "3", "expected interpolation"),
    ] {
        let tables: MethodTables =
            toml::from_str(&format!("[{method}]\ninterpolation = {value}")).unwrap();
        let structure = Structure::load("attas-longitudinal").unwrap();
        let error = crate::common::registry()
            .problem(method, vec![record.clone()], structure, &[&tables])
            .err()
            .unwrap_or_else(|| panic!("{method}: interpolation = {value} accepted"))
            .to_string();
        assert!(
            error.contains(&format!("[methods.{method}]"))
                && error.contains("interpolation")
                && error.contains(expected),
            "{error}"
        );
    }
}
