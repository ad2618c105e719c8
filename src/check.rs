//! `aeroid check`: validates an aircraft, model-structure, scenario, recorder-profile or study file,
//! reporting every problem at once; a valid scenario is also trimmed, so that
//! a flight condition with no trim is found before a long run.

use crate::error::{Result, parse_toml, read_text};
use aeroid_estimation::registry::Registry;
use aeroid_estimation::structure::ModelStructure;
use aeroid_eval::study::{Study, StudyFile};
use aeroid_record::recorder::{Profile, ProfileFile};
use aeroid_sim::Simulation;
use aeroid_sim::aircraft::Aircraft;
use aeroid_sim::scenario::{Scenario, ScenarioFile};
use std::path::Path;

/// What a valid file holds, in a few lines for the user.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckReport {
    pub kind: &'static str,
    pub lines: Vec<String>,
}

/// Validates the file at `path`, telling an aircraft, a scenario, a
/// recorder profile and a study apart by their tables (`[aero]`, `[trim]`,
/// `[[channels]]`, `runs` with `methods`).
pub fn check_file(registry: &Registry, path: &Path) -> Result<CheckReport> {
    let text = read_text(path)?;
    let table: toml::Table = parse_toml(path, &text)?;
    if table.contains_key("trim") {
        let file: ScenarioFile = parse_toml(path, &text)?;
        registry.validate_tables(&file.methods, path)?;
        check_scenario(&Scenario::from_file(&file, path)?)
    } else if table.contains_key("runs") && table.contains_key("methods") {
        let file: StudyFile = parse_toml(path, &text)?;
        Ok(describe_study(&Study::from_file(registry, &file, path)?))
    } else if table.get("kind").and_then(|k| k.as_str())
        == Some(aeroid_estimation::linear_structure::KIND)
    {
        let structure =
            aeroid_estimation::linear_structure::LinearStructure::load(&path.to_string_lossy())?;
        registry.validate_tables(&structure.methods, path)?;
        Ok(CheckReport {
            kind: "model structure",
            lines: vec![
                format!(
                    "{}: linear, states {}, inputs {}, outputs {}, {} of {} parameters free",
                    structure.name,
                    structure.states.join(", "),
                    structure.inputs.join(", "),
                    structure.outputs.join(", "),
                    structure.free.iter().filter(|f| **f).count(),
                    structure.free.len()
                ),
                format!("free: {}", structure.free_names().join(", ")),
            ],
        })
    } else if table.contains_key("aero") && table.contains_key("aircraft") {
        let structure = ModelStructure::load(&path.to_string_lossy())?;
        registry.validate_tables(&structure.methods, path)?;
        Ok(CheckReport {
            kind: "model structure",
            lines: vec![
                format!(
                    "{}: fits aircraft {} ({:?} model), {} of {} parameters free",
                    structure.name,
                    structure.aircraft.name,
                    structure.aircraft.aero.kind,
                    structure.free.iter().filter(|f| **f).count(),
                    structure.free.len()
                ),
                format!("free: {}", structure.free_names().join(", ")),
            ],
        })
    } else if table.contains_key("aero") {
        Ok(describe_aircraft(&Aircraft::load(path)?))
    } else if table.get("channels").is_some_and(|c| c.is_array()) && !table.contains_key("time") {
        let file: ProfileFile = parse_toml(path, &text)?;
        Ok(describe_profile(&Profile::from_file(&file, path)?))
    } else {
        Err(aeroid_core::Error::Invalid {
            path: path.to_path_buf(),
            problems: vec![aeroid_core::error::FieldError {
                field: "(file)".into(),
                message: "neither a scenario (no [trim] table), an aircraft or model structure (no [aero] table), \
                          a recorder profile (no [[channels]]) nor a study (no runs and methods)"
                    .into(),
            }],
        }
        .into())
    }
}

fn describe_aircraft(aircraft: &Aircraft) -> CheckReport {
    let names = aircraft.aero.parameters.names().join(", ");
    CheckReport {
        kind: "aircraft",
        lines: vec![
            format!(
                "{}: mass {:.1} kg, S {:.3} m², b {:.3} m, c̄ {:.3} m",
                aircraft.name,
                aircraft.mass.mass,
                aircraft.wing_area,
                aircraft.geometry.span,
                aircraft.geometry.chord
            ),
            format!(
                "{:?} aerodynamic model, {} parameters: {names}",
                aircraft.aero.kind,
                aircraft.aero.parameters.len()
            ),
        ],
    }
}

fn describe_study(study: &Study) -> CheckReport {
    let mut lines = vec![format!(
        "{}: {} sweep point(s) × {} runs = {} cases, seed {}; methods {}",
        study.name,
        study.points.len(),
        study.runs,
        study.cases().len(),
        study.seed,
        study.methods.join(", ")
    )];
    lines.extend((0..study.points.len()).map(|i| format!("point {i}: {}", study.point_label(i))));
    CheckReport {
        kind: "study",
        lines,
    }
}

fn describe_profile(profile: &Profile) -> CheckReport {
    let channels: Vec<String> = profile
        .channels
        .iter()
        .map(|c| {
            format!(
                "{} {} Hz",
                c.measurand.name,
                aeroid_record::rate_text(c.rate)
            )
        })
        .collect();
    let absent = match profile.absent.is_empty() {
        true => "none".to_string(),
        false => profile.absent.join(", "),
    };
    CheckReport {
        kind: "recorder profile",
        lines: vec![
            format!("{}: {} channels", profile.name, profile.channels.len()),
            channels.join(", "),
            format!("absent: {absent}"),
        ],
    }
}

fn check_scenario(scenario: &Scenario) -> Result<CheckReport> {
    if let aeroid_sim::FlightSource::Jsbsim(jsbsim) = scenario.source() {
        return check_jsbsim_scenario(scenario, jsbsim);
    }
    let simulation = Simulation::prepare(scenario)?;
    let trim = &simulation.trim;
    let c = &trim.controls;
    let mut lines = vec![
        format!(
            "{}: aircraft {} ({}), {} s at {} s steps, seed {}",
            scenario.name,
            scenario.aircraft.name,
            scenario.aircraft_path.display(),
            scenario.duration,
            scenario.step,
            scenario.seed
        ),
        format!(
            "trim: α {:.3}°, θ {:.3}°, elevator {:.3}°, aileron {:.3}°, rudder {:.3}°, throttle {:.4}; residual {:.1e} after {} iterations",
            trim.alpha.to_degrees(),
            trim.pitch.to_degrees(),
            c[0].to_degrees(),
            c[1].to_degrees(),
            c[2].to_degrees(),
            c[4],
            trim.residual,
            trim.iterations
        ),
    ];
    let parameters = &scenario.aircraft.aero.parameters;
    lines.extend(scenario.parameter_changes.iter().map(|change| {
        format!(
            "parameter change at {} s: {} = {} (aircraft file: {})",
            change.time,
            change.parameter,
            change.value,
            parameters.get(&change.parameter).unwrap_or(f64::NAN)
        )
    }));
    Ok(CheckReport {
        kind: "scenario",
        lines,
    })
}

/// A scenario of one of JSBSim's own aircraft: trimmed by JSBSim, and its
/// rigid-body file checked against JSBSim's mass, inertia and geometry.
fn check_jsbsim_scenario(
    scenario: &Scenario,
    jsbsim: &aeroid_sim::scenario::JsbsimAircraft,
) -> Result<CheckReport> {
    let mut lines = vec![format!(
        "{}: JSBSim aircraft {} (rigid body {}), {} s at {} s steps, seed {}",
        scenario.name,
        jsbsim.model,
        scenario.aircraft_path.display(),
        scenario.duration,
        scenario.step,
        scenario.seed
    )];
    lines.extend(jsbsim_trim_line(scenario)?);
    Ok(CheckReport {
        kind: "scenario",
        lines,
    })
}

/// JSBSim's trim of the scenario and the rigid-body check, as a report line.
#[cfg(feature = "jsbsim")]
fn jsbsim_trim_line(scenario: &Scenario) -> Result<Option<String>> {
    let trimmed = aeroid_jsbsim::own::trim(scenario)?;
    aeroid_jsbsim::own::check_rigid_body(scenario, &trimmed.exec)?;
    let [elevator, aileron, rudder] = trimmed.deflections()?;
    Ok(Some(format!(
        "JSBSim trim: α {:.3}°, θ {:.3}°, elevator {:.3}°, aileron {:.3}°, rudder {:.3}°, throttle command {:.4}, thrust {:.1} kN; rigid body matches JSBSim",
        trimmed.alpha.to_degrees(),
        trimmed.at.attitude[1].to_degrees(),
        elevator.to_degrees(),
        aileron.to_degrees(),
        rudder.to_degrees(),
        trimmed.throttle_command,
        trimmed.thrust()? / 1000.0
    )))
}

/// Without JSBSim a JSBSim scenario does not load, so there is no trim to report.
#[cfg(not(feature = "jsbsim"))]
fn jsbsim_trim_line(_scenario: &Scenario) -> Result<Option<String>> {
    Ok(None)
}
