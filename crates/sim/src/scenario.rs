//! Scenario files (`scenarios/*.toml`): the aircraft, the trim point, the
//! inputs superposed on trim, the wind, the environment, the duration,
//! integration step and input interpolation, the seed, and the limits beyond
//! which a simulation is declared to have departed.
//!
//! The aircraft is an aeroid aircraft file, or one of JSBSim's own aircraft
//! named `"jsbsim:NAME"` (`aircraft/NAME/NAME.xml` under JSBSim's root), which
//! `aeroid record` and `aeroid run` fly in JSBSim (feature `jsbsim`,
//! registered as [`crate::source::ForeignSimulator`], its aircraft checked
//! against [`crate::foreign::AircraftCatalog`]). Such a scenario also has a `[jsbsim]` table:
//!
//! ```toml
//! aircraft = "jsbsim:737"
//! [jsbsim]
//! rigid_body = "b737-jsbsim"   # aeroid aircraft file: JSBSim's mass, inertia, geometry, thrust line
//! properties = { "fcs/flap-cmd-norm" = 0.0 }   # optional: JSBSim properties set before the trim
//! ```
//!
//! Everything else (inputs, duration, step, seed, recorder, models) means
//! what it means for an aeroid aircraft; wind, flap inputs and parameter
//! changes are refused.
//!
//! A scenario may change one of the aircraft's aerodynamic parameters during
//! the flight (a failure, icing, a model that must be tracked):
//!
//! ```toml
//! [[parameter_changes]]
//! time = "30 s"           # on the step grid, inside the run: 0 < time < duration
//! parameter = "Cm_alpha"  # a parameter of the aircraft's aero model, named as in model files
//! scale = 0.8             # × the aircraft file's value; or `value = -0.14`, not both
//! ```
//!
//! The new value holds from that instant on: the sample at `time` and every
//! step after it are computed with it (see [`crate::Simulation`]). A
//! `time` off the integration step grid is refused rather than moved, so
//! that the change happens exactly when the file says. The run's truth
//! records the schedule ([`crate::truth::RunTruth::parameter_changes`]).

use crate::aircraft::Aircraft;
use crate::dynamics::Environment;
use crate::error::Result;
use crate::feedback::{Augmentation, Feedback, FeedbackSpec};
use crate::inputs::{InputSchedule, InputSpec};
use crate::integrator::Interpolation;
use crate::trim::TrimCondition;
use crate::wind::WindSpec;
use aeroid_core::catalog;
use aeroid_core::error::{FieldErrors, parse_toml, read_text};
use aeroid_core::limits;
use aeroid_core::units::{DEG, Dimension, Quantity};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// How a scenario names one of JSBSim's own aircraft: `"jsbsim:737"`.
pub const JSBSIM_PREFIX: &str = "jsbsim:";

/// A scenario file (`scenarios/*.toml`) as written, before its aircraft is
/// read and it is checked ([`Scenario::from_file`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// A bundled aircraft name or a path relative to this file, or
    /// `"jsbsim:NAME"` for one of JSBSim's own aircraft.
    pub aircraft: String,
    pub duration: Quantity,
    /// Integration step; the truth trace is written at this step.
    pub step: Quantity,
    #[serde(default)]
    pub seed: u64,
    #[serde(default)]
    pub interpolation: Interpolation,
    pub trim: TrimSpec,
    #[serde(default)]
    pub environment: EnvironmentSpec,
    #[serde(default)]
    pub inputs: Vec<InputSpec>,
    #[serde(default)]
    pub wind: WindSpec,
    #[serde(default)]
    pub departure: DepartureSpec,
    /// The recorder profile `aeroid record` uses when no `--profile` is given
    /// (a bundled name in `recorders/` or a path relative to this file).
    #[serde(default)]
    pub recorder: Option<String>,
    /// Model structures (`models/` names or paths) that `aeroid run` fits to this scenario's record.
    #[serde(default)]
    pub models: Vec<String>,
    /// Settings per estimation method (`[methods.oem]`, …), overriding the
    /// model files' tables; checked against the methods by `aeroid check`.
    #[serde(default)]
    pub methods: std::collections::BTreeMap<String, toml::Table>,
    /// For a JSBSim aircraft: its rigid body and the properties set before trim.
    #[serde(default)]
    pub jsbsim: Option<JsbsimSpec>,
    /// Aerodynamic parameters changed during the flight.
    #[serde(default)]
    pub parameter_changes: Vec<ParameterChangeSpec>,
    /// Fly a linear model file instead of the aircraft's 6-DOF equations.
    #[serde(default)]
    pub linear: Option<LinearFlightSpec>,
    /// A stability augmentation of the 6-DOF flight ([`crate::feedback`]).
    #[serde(default)]
    pub feedback: Option<FeedbackSpec>,
}

/// The `[linear]` table of a scenario: the flight is that of a linear
/// model (`kind = "linear"` model file), its inputs the scenario's
/// `[[inputs]]` on the model inputs named like controls, its truth the
/// model's parameter values. `aircraft` and `trim` then only name the
/// condition the model stands for.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearFlightSpec {
    /// A bundled model name or a path relative to this file.
    pub model: String,
    /// White process noise per state: the entry of the diagonal F of
    /// ẋ = A·x + B·u + b + F·w, w of unit intensity (state units per √s).
    #[serde(default)]
    pub process_noise: BTreeMap<String, f64>,
    /// Dryden turbulence entering the states: ẋ = … + G·(u_g, v_g, w_g):
    /// `matrix` and the keys of a `[wind.turbulence]` table ([`LinearGusts`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gusts: Option<toml::Table>,
    /// A stability augmentation moving one model input with the states
    /// ([`crate::feedback`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feedback: Option<FeedbackSpec>,
}

/// `[linear] gusts`: the Dryden turbulence of `[wind.turbulence]` (an
/// `intensity` or `sigma_*`, optional `length_*`, at the trim airspeed and
/// altitude) entering the state equations through `matrix`, G, one row per
/// state of the model and one column per gust component u_g, v_g, w_g
/// (body axes, m/s): ẋ = A·x + B·u + b + G·(u_g, v_g, w_g).
#[derive(Debug, Clone, PartialEq)]
pub struct LinearGusts {
    pub matrix: Vec<Vec<f64>>,
    pub turbulence: crate::wind::TurbulenceSpec,
}

impl LinearGusts {
    /// Reads a `gusts` table, its problems named under `linear.gusts`.
    fn read(table: &toml::Table, problems: &mut FieldErrors) -> Option<LinearGusts> {
        let mut rest = table.clone();
        let matrix = match rest.remove("matrix").map(|m| m.try_into::<Vec<Vec<f64>>>()) {
            Some(Ok(matrix)) => matrix,
            Some(Err(error)) => {
                problems.push("linear.gusts.matrix", error.to_string());
                return None;
            }
            None => {
                problems.push(
                    "linear.gusts.matrix",
                    "missing: G, one row per state, columns u_g, v_g, w_g",
                );
                return None;
            }
        };
        for (i, row) in matrix.iter().enumerate() {
            if row.len() != 3 || !row.iter().all(|v| v.is_finite()) {
                problems.push(
                    format!("linear.gusts.matrix[{i}]"),
                    "must hold 3 finite numbers (the factors of u_g, v_g, w_g)",
                );
            }
        }
        match toml::Value::Table(rest).try_into::<crate::wind::TurbulenceSpec>() {
            Ok(turbulence) => {
                turbulence.validate("linear.gusts", problems);
                Some(LinearGusts { matrix, turbulence })
            }
            Err(error) => {
                problems.push("linear.gusts", error.to_string());
                None
            }
        }
    }
}

/// A validated `[linear]` table.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearFlight {
    pub model_path: PathBuf,
    pub process_noise: BTreeMap<String, f64>,
    pub gusts: Option<LinearGusts>,
    pub feedback: Option<Feedback>,
}

/// One `[[parameter_changes]]` table of a scenario file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterChangeSpec {
    /// When the new value starts to hold: a multiple of the step, 0 < time < duration.
    pub time: Quantity,
    /// An aerodynamic parameter of the aircraft (`Cm_alpha`, `e`, `tau1`, …).
    pub parameter: String,
    /// The new value (the parameter's own units, as in the aircraft file).
    #[serde(default)]
    pub value: Option<f64>,
    /// The new value as a multiple of the aircraft file's value.
    #[serde(default)]
    pub scale: Option<f64>,
}

/// A validated parameter change: from `time` (s) on, `parameter` is `value`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterChange {
    pub time: f64,
    pub parameter: String,
    pub value: f64,
}

/// The `[jsbsim]` table of a scenario whose aircraft is `"jsbsim:NAME"`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JsbsimSpec {
    /// An aeroid aircraft file (bundled name or path) holding the JSBSim
    /// aircraft's mass, inertia, geometry and thrust line: the rigid body of
    /// the estimators' model structures, and what the recorder reads the mass
    /// and thrust from. Checked against JSBSim at the trim point when flown.
    pub rigid_body: String,
    /// JSBSim properties set before trimming (flaps, fuel, switches).
    #[serde(default)]
    pub properties: BTreeMap<String, f64>,
}

/// One of JSBSim's own aircraft, flown instead of an aeroid one.
#[derive(Debug, Clone, PartialEq)]
pub struct JsbsimAircraft {
    /// JSBSim's model name (`737` for `aircraft/737/737.xml`).
    pub model: String,
    /// Properties set before trimming.
    pub properties: BTreeMap<String, f64>,
}

/// The `[trim]` table of a scenario: the flight condition the aircraft is
/// trimmed at (airspeed, altitude, flight-path angle, heading, flap).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrimSpec {
    pub airspeed: Quantity,
    pub altitude: Quantity,
    #[serde(default)]
    pub flight_path_angle: Quantity,
    #[serde(default)]
    pub heading: Quantity,
    #[serde(default)]
    pub flap: Quantity,
}

/// The `[environment]` table of a scenario: the ISA temperature offset and
/// gravity.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentSpec {
    #[serde(default)]
    pub temperature_offset: Quantity,
    /// Default: standard gravity; 0 switches gravity off.
    #[serde(default)]
    pub gravity: Option<Quantity>,
}

/// Limits beyond which the simulation has departed (all optional).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DepartureSpec {
    /// Default 60°.
    pub max_alpha: Option<Quantity>,
    /// Default 45°.
    pub max_beta: Option<Quantity>,
    /// Default 0.3 × trim airspeed.
    pub min_airspeed: Option<Quantity>,
    /// Default 3 × trim airspeed.
    pub max_airspeed: Option<Quantity>,
    /// Default 0 m (the ground of the flat earth).
    pub min_altitude: Option<Quantity>,
}

/// Departure limits in SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepartureLimits {
    pub max_alpha: f64,
    pub max_beta: f64,
    pub min_airspeed: f64,
    pub max_airspeed: f64,
    pub min_altitude: f64,
}

/// A validated scenario, ready to simulate.
#[derive(Debug, Clone)]
pub struct Scenario {
    pub name: String,
    pub description: String,
    pub path: PathBuf,
    pub aircraft_path: PathBuf,
    pub aircraft: Aircraft,
    pub trim: TrimCondition,
    pub environment: Environment,
    pub duration: f64,
    pub step: f64,
    pub seed: u64,
    pub interpolation: Interpolation,
    pub inputs: InputSchedule,
    pub wind: WindSpec,
    pub departure: DepartureLimits,
    /// The default recorder profile reference, if the file names one.
    pub recorder: Option<String>,
    pub models: Vec<String>,
    /// The file's `[methods.NAME]` settings tables.
    pub methods: std::collections::BTreeMap<String, toml::Table>,
    /// Set when the scenario flies one of JSBSim's own aircraft; `aircraft` is
    /// then its rigid body (`[jsbsim] rigid_body`), whose aerodynamic model is
    /// not the truth.
    pub jsbsim: Option<JsbsimAircraft>,
    /// Aerodynamic parameters changed during the flight, in time order
    /// (changes at the same instant in file order).
    pub parameter_changes: Vec<ParameterChange>,
    /// Set when the flight is a linear model's (`[linear]`).
    pub linear: Option<LinearFlight>,
    /// The 6-DOF flight's stability augmentation (`[feedback]`).
    pub feedback: Option<Augmentation>,
}

impl Scenario {
    /// Loads a scenario by bundled name or path, with its aircraft.
    pub fn load(reference: &str) -> Result<Scenario> {
        let path = catalog::resolve(reference, catalog::SCENARIO_FOLDER, None)?;
        let text = read_text(&path)?;
        let file: ScenarioFile = parse_toml(&path, &text)?;
        Scenario::from_file(&file, &path)
    }

    /// Validates a parsed file, reporting every problem of the scenario at once
    /// (the aircraft file reports its own).
    pub fn from_file(file: &ScenarioFile, path: &Path) -> Result<Scenario> {
        let base = path.parent().unwrap_or(Path::new("."));
        let jsbsim = jsbsim_aircraft(file, path)?;
        let (aircraft_reference, field) = match (&jsbsim, &file.jsbsim) {
            (Some(_), Some(spec)) => (&spec.rigid_body, "jsbsim.rigid_body"),
            _ => (&file.aircraft, "aircraft"),
        };
        let aircraft_path =
            catalog::resolve_named(aircraft_reference, catalog::AIRCRAFT_FOLDER, path, field)?;
        let aircraft = Aircraft::load(&aircraft_path)?;
        let mut problems = FieldErrors::default();
        let mut read = |field: &str, q: &Quantity, dimension: Dimension| {
            q.si(dimension).unwrap_or_else(|message| {
                problems.push(field, message);
                f64::NAN
            })
        };
        let trim = read_trim(&file.trim, &mut read);
        let duration = read("duration", &file.duration, Dimension::Time);
        let step = read("step", &file.step, Dimension::Time);
        let environment = read_environment(&file.environment, &mut read);
        let departure = read_departure(&file.departure, trim.airspeed, &mut read);
        check_ranges(&trim, duration, step, &mut problems);
        let parameter_changes = read_parameter_changes(
            &file.parameter_changes,
            &aircraft,
            duration,
            step,
            &mut problems,
        );
        file.wind.validate(&mut problems);
        let linear = file
            .linear
            .as_ref()
            .and_then(|spec| read_linear(spec, step, path, &mut problems));
        let feedback = file.feedback.as_ref().and_then(|spec| {
            if file.linear.is_some() || jsbsim.is_some() {
                problems.push(
                    "feedback",
                    "is for aeroid's 6-DOF simulator: a linear flight takes [linear.feedback], and JSBSim's aircraft fly their own flight-control system",
                );
                return None;
            }
            Feedback::read(spec, step, "feedback", &mut problems)?.for_six_dof(&mut problems)
        });
        let inputs = read_inputs(file, base, path, &mut problems)?;
        let scenario = Scenario {
            name: file.name.clone(),
            description: file.description.clone(),
            path: path.to_path_buf(),
            aircraft_path,
            aircraft,
            trim,
            environment,
            duration,
            step,
            seed: file.seed,
            interpolation: file.interpolation,
            inputs,
            wind: file.wind.clone(),
            departure,
            recorder: file.recorder.clone(),
            models: file.models.clone(),
            methods: file.methods.clone(),
            jsbsim,
            parameter_changes,
            linear,
            feedback,
        };
        Ok(problems.finish(path, scenario)?)
    }

    /// Number of integration steps.
    pub fn step_count(&self) -> usize {
        (self.duration / self.step).round() as usize
    }

    /// The bounds of duration and step and the memory budget, for a scenario
    /// changed after loading: an [`aeroid_core::Error::Invalid`] naming the field.
    pub fn check_size(&self) -> Result<()> {
        let mut problems = FieldErrors::default();
        check_ranges(&self.trim, self.duration, self.step, &mut problems);
        problems
            .0
            .retain(|p| p.field == "duration" || p.field == "step");
        Ok(problems.finish(&self.path, ())?)
    }
}

/// The JSBSim aircraft a scenario names, checked: the `[jsbsim]` table is
/// there exactly when the aircraft is `"jsbsim:NAME"`, the build has the
/// `jsbsim` feature, JSBSim has the aircraft, and the flight is in still air
/// with no parameter changes.
fn jsbsim_aircraft(file: &ScenarioFile, path: &Path) -> Result<Option<JsbsimAircraft>> {
    let invalid = |field: &str, message: String| aeroid_core::Error::Invalid {
        path: path.to_path_buf(),
        problems: vec![aeroid_core::error::FieldError {
            field: field.into(),
            message,
        }],
    };
    let Some(model) = file.aircraft.strip_prefix(JSBSIM_PREFIX) else {
        return match file.jsbsim {
            Some(_) => Err(invalid(
                "jsbsim",
                format!(
                    "only a scenario whose aircraft is \"{JSBSIM_PREFIX}NAME\" has a [jsbsim] table"
                ),
            )
            .into()),
            None => Ok(None),
        };
    };
    if !file.parameter_changes.is_empty() {
        return Err(invalid(
            "parameter_changes",
            "a JSBSim aircraft flies JSBSim's own aerodynamic tables: aeroid cannot change its parameters during the flight".into(),
        ).into());
    }
    let Some(simulator) = crate::foreign::jsbsim() else {
        return Err(invalid(
            "aircraft",
            format!(
                "'{}' is one of JSBSim's own aircraft, and this aeroid has no JSBSim: build it with `--features jsbsim` (cargo run --release --features jsbsim -- ...); a library user also calls aeroid::jsbsim::register()",
                file.aircraft
            ),
        ).into());
    };
    let Some(spec) = &file.jsbsim else {
        return Err(invalid(
            "jsbsim",
            format!(
                "a JSBSim aircraft needs a [jsbsim] table with `rigid_body`, the aeroid aircraft file of {model}'s mass, inertia, geometry and thrust line (e.g. aircraft/b737-jsbsim.toml)"
            ),
        ).into());
    };
    simulator
        .check_model(model)
        .map_err(|error| invalid("aircraft", error.to_string()))?;
    let calm = file.wind.gusts.is_empty()
        && file.wind.turbulence.is_none()
        && file.wind.speed.si(Dimension::Speed).ok() == Some(0.0);
    if !calm {
        return Err(invalid(
            "wind",
            "a JSBSim aircraft flies in still air here: aeroid does not feed wind, gusts or turbulence to JSBSim".into(),
        ).into());
    }
    Ok(Some(JsbsimAircraft {
        model: model.to_owned(),
        properties: spec.properties.clone(),
    }))
}

/// The value a parameter change sets: `value`, or `scale` times the
/// aircraft's `original`, checked as a replacement; None (the problem
/// recorded under `parameter_changes[index]`) when neither or both are
/// given or the model refuses it.
fn new_value(
    spec: &ParameterChangeSpec,
    original: f64,
    aircraft: &Aircraft,
    index: usize,
    problems: &mut FieldErrors,
) -> Option<f64> {
    let field = |key: &str| format!("parameter_changes[{index}].{key}");
    let value = match (spec.value, spec.scale) {
        (Some(value), None) => Some(("value", value)),
        (None, Some(scale)) => Some(("scale", scale * original)),
        (Some(_), Some(_)) => {
            problems.push(field("scale"), "give either `value` or `scale`, not both");
            None
        }
        (None, None) => {
            problems.push(
                field("value"),
                "missing: give the new `value` or a `scale` of the aircraft's value",
            );
            None
        }
    };
    value.and_then(|(key, value)| {
        aircraft
            .aero
            .check_replacement(&spec.parameter, value)
            .map(|()| value)
            .map_err(|message| problems.push(field(key), message))
            .ok()
    })
}

/// The `[[parameter_changes]]` tables, checked against the aircraft, the
/// duration and the step (each problem under `parameter_changes[i].KEY`),
/// sorted by time.
fn read_parameter_changes(
    specs: &[ParameterChangeSpec],
    aircraft: &Aircraft,
    duration: f64,
    step: f64,
    problems: &mut FieldErrors,
) -> Vec<ParameterChange> {
    let mut changes: Vec<ParameterChange> = Vec::with_capacity(specs.len());
    for (index, spec) in specs.iter().enumerate() {
        let field = |key: &str| format!("parameter_changes[{index}].{key}");
        let time = match spec.time.si(Dimension::Time) {
            Ok(time) => check_change_time(time, duration, step)
                .map_err(|message| problems.push(field("time"), message))
                .ok(),
            Err(message) => {
                problems.push(field("time"), message);
                None
            }
        };
        let parameters = &aircraft.aero.parameters;
        let Some(original) = parameters.get(&spec.parameter) else {
            problems.push(
                field("parameter"),
                format!(
                    "'{}' is not a parameter of aircraft {}; known: {}",
                    spec.parameter,
                    aircraft.name,
                    parameters.names().join(", ")
                ),
            );
            continue;
        };
        let value = new_value(spec, original, aircraft, index, problems);
        let (Some(time), Some(value)) = (time, value) else {
            continue;
        };
        if changes
            .iter()
            .any(|c| c.parameter == spec.parameter && same_step(c.time, time, step))
        {
            problems.push(
                field("time"),
                format!(
                    "{} is changed twice at {} s",
                    spec.parameter,
                    limits::number(time)
                ),
            );
            continue;
        }
        changes.push(ParameterChange {
            time,
            parameter: spec.parameter.clone(),
            value,
        });
    }
    changes.sort_by(|a, b| a.time.total_cmp(&b.time));
    changes
}

/// Whether two change times fall on the same integration step.
fn same_step(a: f64, b: f64, step: f64) -> bool {
    (a / step).round() == (b / step).round()
}

/// A change time inside the run (0 < time < duration) on the step grid (a
/// duration or step that is itself invalid is reported on its own).
fn check_change_time(
    time: f64,
    duration: f64,
    step: f64,
) -> std::result::Result<f64, crate::error::Error> {
    if !(time > 0.0 && time.is_finite()) || time >= duration {
        return Err(crate::error::Error::ChangeOutsideRun { time, duration });
    }
    let steps = time / step;
    if step > 0.0 && step.is_finite() && (steps - steps.round()).abs() > 1e-6 {
        return Err(crate::error::Error::ChangeOffStep { time, step });
    }
    Ok(time)
}

/// The `[linear]` table: a linear flight of the model it names, with its
/// process noise, gusts and feedback; None (the problems recorded) when
/// the model cannot be found.
fn read_linear(
    spec: &LinearFlightSpec,
    step: f64,
    path: &Path,
    problems: &mut FieldErrors,
) -> Option<LinearFlight> {
    for (state, value) in &spec.process_noise {
        if !(value.is_finite() && *value >= 0.0) {
            problems.push(
                format!("linear.process_noise.{state}"),
                "must be finite and not negative",
            );
        }
    }
    let gusts = spec
        .gusts
        .as_ref()
        .and_then(|table| LinearGusts::read(table, problems));
    let feedback = spec
        .feedback
        .as_ref()
        .and_then(|spec| Feedback::read(spec, step, "linear.feedback", problems));
    match catalog::resolve_named(&spec.model, catalog::MODEL_FOLDER, path, "linear.model") {
        Ok(model_path) => Some(LinearFlight {
            model_path,
            process_noise: spec.process_noise.clone(),
            gusts,
            feedback,
        }),
        Err(error) => {
            problems.push("linear.model", error.to_string());
            None
        }
    }
}

/// The input schedule of `inputs` (files relative to `base`); its problems
/// joined to those found before, or its error when there were none.
fn read_inputs(
    file: &ScenarioFile,
    base: &Path,
    path: &Path,
    problems: &mut FieldErrors,
) -> Result<InputSchedule> {
    let inputs = InputSchedule::build(&file.inputs, base, path);
    Ok(match (problems.is_empty(), inputs) {
        (_, Ok(inputs)) => inputs,
        (true, Err(error)) => return Err((error).into()),
        (false, Err(aeroid_core::Error::Invalid { problems: more, .. })) => {
            problems.0.extend(more);
            InputSchedule::default()
        }
        (false, Err(other)) => {
            problems.push("inputs", other.to_string());
            InputSchedule::default()
        }
    })
}

/// The trim condition in SI.
fn read_trim(
    spec: &TrimSpec,
    read: &mut impl FnMut(&str, &Quantity, Dimension) -> f64,
) -> TrimCondition {
    TrimCondition {
        airspeed: read("trim.airspeed", &spec.airspeed, Dimension::Speed),
        altitude: read("trim.altitude", &spec.altitude, Dimension::Length),
        flight_path_angle: read(
            "trim.flight_path_angle",
            &spec.flight_path_angle,
            Dimension::Angle,
        ),
        heading: read("trim.heading", &spec.heading, Dimension::Angle),
        flap: read("trim.flap", &spec.flap, Dimension::Angle),
    }
}

/// The environment in SI: the atmosphere's temperature offset, gravity
/// (standard by default).
fn read_environment(
    spec: &EnvironmentSpec,
    read: &mut impl FnMut(&str, &Quantity, Dimension) -> f64,
) -> Environment {
    Environment {
        atmosphere: crate::atmosphere::Atmosphere::new(read(
            "environment.temperature_offset",
            &spec.temperature_offset,
            Dimension::TemperatureDifference,
        )),
        gravity: spec
            .gravity
            .as_ref()
            .map_or(aeroid_core::units::STANDARD_GRAVITY, |g| {
                read("environment.gravity", g, Dimension::Acceleration)
            }),
    }
}

fn read_departure(
    spec: &DepartureSpec,
    trim_airspeed: f64,
    read: &mut impl FnMut(&str, &Quantity, Dimension) -> f64,
) -> DepartureLimits {
    let mut optional = |field: &str, q: &Option<Quantity>, dimension: Dimension, default: f64| {
        q.as_ref().map_or(default, |q| read(field, q, dimension))
    };
    DepartureLimits {
        max_alpha: optional(
            "departure.max_alpha",
            &spec.max_alpha,
            Dimension::Angle,
            60.0 * DEG,
        ),
        max_beta: optional(
            "departure.max_beta",
            &spec.max_beta,
            Dimension::Angle,
            45.0 * DEG,
        ),
        min_airspeed: optional(
            "departure.min_airspeed",
            &spec.min_airspeed,
            Dimension::Speed,
            0.3 * trim_airspeed,
        ),
        max_airspeed: optional(
            "departure.max_airspeed",
            &spec.max_airspeed,
            Dimension::Speed,
            3.0 * trim_airspeed,
        ),
        min_altitude: optional(
            "departure.min_altitude",
            &spec.min_altitude,
            Dimension::Length,
            0.0,
        ),
    }
}

fn check_ranges(trim: &TrimCondition, duration: f64, step: f64, problems: &mut FieldErrors) {
    if trim.airspeed <= 0.0 {
        problems.push("trim.airspeed", "must be positive");
    }
    if !(0.0..=20_000.0).contains(&trim.altitude) {
        problems.push(
            "trim.altitude",
            "must be within the modelled atmosphere, 0–20 000 m",
        );
    }
    if trim.flight_path_angle.abs() >= 90.0 * DEG {
        problems.push("trim.flight_path_angle", "must be within ±90°");
    }
    if duration <= 0.0 {
        problems.push("duration", "must be positive");
    } else if duration > limits::MAX_DURATION {
        problems.push(
            "duration",
            format!(
                "{} s is above the longest duration {} s (longer than any aircraft's endurance)",
                limits::number(duration),
                limits::number(limits::MAX_DURATION)
            ),
        );
    }
    if step <= 0.0 || step > 0.1 {
        problems.push(
            "step",
            "must be positive and at most 0.1 s (RK4 accuracy for aircraft modes)",
        );
    } else if step < limits::MIN_STEP {
        problems.push(
            "step",
            format!(
                "{} s is below the smallest step {} s (RK4 is exact to round-off there; a smaller step only adds round-off and samples)",
                limits::number(step),
                limits::number(limits::MIN_STEP)
            ),
        );
    } else if duration > 0.0 && (duration / step - (duration / step).round()).abs() > 1e-6 {
        problems.push(
            "step",
            "must divide the duration into a whole number of steps",
        );
    } else if duration > 0.0
        && duration <= limits::MAX_DURATION
        && let Err(message) = check_simulation_size(duration / step)
    {
        problems.push("duration", message);
    }
}

/// Memory one integration step of a simulation holds: the exogenous
/// signals, the wind and the truth sample.
pub const BYTES_PER_STEP: usize = std::mem::size_of::<crate::dynamics::ExogenousVector>()
    + std::mem::size_of::<crate::wind::WindSample>()
    + std::mem::size_of::<crate::trace::TruthSample>();

/// Checks that a simulation of `steps` steps fits the memory budget.
pub(crate) fn check_simulation_size(steps: f64) -> Result<()> {
    Ok(limits::check_memory(
        "the simulation (duration / step + 1 samples)",
        steps.round() + 1.0,
        BYTES_PER_STEP,
    )?)
}
