//! The postulated model an estimator fits (`models/*.toml`): which terms
//! each coefficient has (the `[aero]` table, same schema as an aircraft
//! file, its values being start values), which parameters are fixed, their
//! bounds, and for simulating estimators which flight-path states are
//! integrated and which measured signals are fed in as pseudo-controls
//! (decoupled longitudinal or lateral models: the reflex-wing UAV paper (ML, LS and neural
//! Gauss–Newton), Eqs. 1–8), and which recorded channels are
//! compared. How a method fits it (integration step, differentiator, start
//! values, initial states and biases as unknowns) is the method's setting,
//! in a `[methods.NAME]` table (see `aeroid methods`).
//!
//! ```toml
//! name = "attas-lateral"
//! aircraft = "attas"              # mass, inertia, geometry, propulsion of the fitted model
//! integrate = ["beta", "p", "r", "roll"]   # the rest comes from measured channels
//! outputs = ["beta", "p", "r", "roll", "ny"]
//! zero_when_absent = ["q"]        # a record without a q channel: q held at 0 (noted)
//! [aero]
//! rate_normalization = "2V"
//! [aero.Cl]
//! beta = -0.05                    # start value of Cl_beta
//! p = -0.3
//! [parameters.Cl_0]
//! fixed = true
//! [parameters.Cn_beta]
//! lower = 0.0
//! upper = 1.0
//! [parameters.Cn_dr]
//! tie = { to = "Cl_dr", factor = -3.2 }   # θ = c·θ_master + d: no unknown, reported as tied
//! [methods.oem]
//! estimate_initial_state = true
//! output_biases = ["ny"]
//! ```

use crate::error::{Error, Result};
use crate::linear_structure::{self, LinearStructure};
use crate::settings::MethodTables;
use aeroid_core::catalog;
use aeroid_core::error::{FieldErrors, parse_toml, read_text};
use aeroid_core::refusal::Refusal;
use aeroid_record::{Channel, FlightRecord};
use aeroid_sim::aero::{AeroModel, AeroSpec};
use aeroid_sim::aircraft::{Aircraft, AircraftFile};
use aeroid_sim::trace::TruthTrace;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Flight-path states a simulating estimator can integrate, named as record channels.
pub(crate) const FLIGHT_PATH_STATES: [&str; 11] = [
    "airspeed", "alpha", "beta", "p", "q", "r", "roll", "pitch", "yaw", "altitude", "chi",
];

/// How a channel of zeros put in for `zero_when_absent` names its source.
pub(crate) const ZERO_SOURCE: &str = "zero_when_absent of";

/// The flight-path states a model may hold at 0 when a record lacks them
/// (`zero_when_absent`): the angles and rates of the other axis.
const ZERO_CAPABLE: [&str; 8] = ["alpha", "beta", "p", "q", "r", "roll", "pitch", "yaw"];

/// A model structure file (`models/*.toml`) as written (the schema is in
/// the module docs), before its aircraft is read and it is checked.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StructureFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub aircraft: String,
    #[serde(default)]
    pub integrate: Vec<String>,
    #[serde(default)]
    pub outputs: Vec<String>,
    /// Flight-path states the model does not integrate (angles and rates)
    /// that a record may lack: an absent one is a channel of zeros, said
    /// in the estimate's notes. Any other absent channel is refused.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub zero_when_absent: Vec<String>,
    pub aero: AeroSpec,
    #[serde(default)]
    pub parameters: BTreeMap<String, ParameterSpec>,
    /// Settings per method (`[methods.oem]`, `[methods.ee]`, …).
    #[serde(default)]
    pub methods: MethodTables,
}

/// A `[parameters.NAME]` table of a model structure file: whether the
/// parameter is fixed at its start value, its bounds, or its tie to another.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterSpec {
    #[serde(default)]
    pub fixed: bool,
    pub lower: Option<f64>,
    pub upper: Option<f64>,
    /// θ = factor·θ_to + offset: the parameter follows another, is no
    /// unknown, and is reported as tied.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tie: Option<TieSpec>,
}

/// `tie = { to = "Cm_de", factor = -0.268, offset = 0.0 }`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TieSpec {
    /// The master parameter.
    pub to: String,
    pub factor: f64,
    #[serde(default)]
    pub offset: f64,
}

/// A validated model structure.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelStructure {
    pub name: String,
    pub path: PathBuf,
    /// The file it was read from, and its aircraft's file: what an
    /// [`crate::problem::EstimationProblem`] carries to be
    /// rebuilt elsewhere.
    pub file: StructureFile,
    pub aircraft_file: AircraftFile,
    /// The aircraft whose mass, inertia, geometry and propulsion the model uses,
    /// with its aerodynamic model replaced by the postulated one.
    pub aircraft: Aircraft,
    /// Indices (into `FLIGHT_PATH_STATES`) of the integrated states.
    pub integrate: Vec<usize>,
    pub outputs: Vec<String>,
    /// Indices (into `FLIGHT_PATH_STATES`) of the pseudo-controls a
    /// record may lack (held at 0).
    pub zero_when_absent: Vec<usize>,
    /// Per aero parameter (same order as `aircraft.aero.parameters`): free?
    pub free: Vec<bool>,
    pub bounds: Vec<(f64, f64)>,
    /// The file's settings per method.
    pub methods: MethodTables,
}

impl ModelStructure {
    /// Loads a structure by bundled name (`models/NAME.toml`) or path.
    pub fn load(reference: &str) -> Result<ModelStructure> {
        let path = catalog::resolve(reference, catalog::MODEL_FOLDER, None)?;
        let text = read_text(&path)?;
        let file: StructureFile = parse_toml(&path, &text)?;
        ModelStructure::from_file(&file, &path)
    }

    /// Validates a parsed file, loading its aircraft relative to `path`.
    pub fn from_file(file: &StructureFile, path: &Path) -> Result<ModelStructure> {
        let base = path.parent().unwrap_or(Path::new("."));
        let aircraft_path = catalog::resolve(&file.aircraft, catalog::AIRCRAFT_FOLDER, Some(base))?;
        let aircraft_text = read_text(&aircraft_path)?;
        let aircraft_file: AircraftFile = parse_toml(&aircraft_path, &aircraft_text)?;
        ModelStructure::from_parts(file, &aircraft_file, path)
    }

    /// Validates a structure file with its aircraft file given (as an
    /// estimation problem carries them); `path` is named in errors.
    pub fn from_parts(
        file: &StructureFile,
        aircraft_file: &AircraftFile,
        path: &Path,
    ) -> Result<ModelStructure> {
        let mut aircraft = Aircraft::from_file(aircraft_file, path)?;
        let mut problems = FieldErrors::default();
        aircraft.aero = AeroModel::from_spec(&file.aero, aircraft.geometry, "aero", &mut problems);
        let integrate = state_indices(&file.integrate, "integrate", &mut problems);
        let zero_when_absent =
            state_indices(&file.zero_when_absent, "zero_when_absent", &mut problems);
        for (i, name) in file.zero_when_absent.iter().enumerate() {
            let index = FLIGHT_PATH_STATES.iter().position(|s| s == name);
            if index.is_some_and(|index| integrate.contains(&index)) {
                problems.push(
                    format!("zero_when_absent[{i}]"),
                    format!(
                        "'{name}' is integrated: only a state fed in from the record can be absent"
                    ),
                );
            } else if index.is_some() && !ZERO_CAPABLE.contains(&name.as_str()) {
                problems.push(
                    format!("zero_when_absent[{i}]"),
                    format!(
                        "'{name}' cannot be held at 0 (no flight has it zero); these can: {}",
                        ZERO_CAPABLE.join(", ")
                    ),
                );
            }
        }
        for (i, name) in file.outputs.iter().enumerate() {
            if Observable::parse(name).is_none() {
                problems.push(
                    format!("outputs[{i}]"),
                    format!(
                        "unknown output '{name}'; known: {}",
                        Observable::names().collect::<Vec<_>>().join(", ")
                    ),
                );
            }
        }
        tie_parameters(&mut aircraft.aero, &file.parameters, &mut problems);
        let (free, bounds) = parameter_settings(&aircraft.aero, &file.parameters, &mut problems);
        let structure = ModelStructure {
            name: file.name.clone(),
            path: path.to_path_buf(),
            file: file.clone(),
            aircraft_file: aircraft_file.clone(),
            aircraft,
            integrate,
            outputs: file.outputs.clone(),
            zero_when_absent,
            free,
            bounds,
            methods: file.methods.clone(),
        };
        Ok(problems.finish(path, structure)?)
    }

    /// Names of the free aerodynamic parameters.
    pub fn free_names(&self) -> Vec<String> {
        let names = self.aircraft.aero.parameters.names();
        (0..names.len())
            .filter(|&i| self.free[i])
            .map(|i| names[i].clone())
            .collect()
    }

    /// `records` with a channel of zeros for each of the model's
    /// `zero_when_absent` states a record lacks, on the times of the
    /// record's densest channel, its source `ZERO_SOURCE`.
    pub fn with_zero_channels(&self, mut records: Vec<FlightRecord>) -> Vec<FlightRecord> {
        for record in &mut records {
            let absent: Vec<&'static str> = self
                .zero_when_absent
                .iter()
                .map(|&i| FLIGHT_PATH_STATES[i])
                .filter(|name| record.channel(name).is_err())
                .collect();
            if absent.is_empty() {
                continue;
            }
            let Some(densest) = record.channels.iter().max_by_key(|c| c.times.len()) else {
                continue;
            };
            let (times, rate) = (densest.times.clone(), densest.rate);
            for name in absent {
                record.channels.push(Channel {
                    name: name.to_string(),
                    unit: TruthTrace::column(name).map_or("rad", |c| c.unit).into(),
                    rate,
                    resolution: None,
                    source: format!("{ZERO_SOURCE} model '{}'", self.name),
                    values: vec![0.0; times.len()],
                    times: times.clone(),
                });
            }
        }
        records
    }

    /// Names of the flight-path states that are not integrated: measured
    /// channels fed in as pseudo-controls by a simulating estimator.
    pub fn pseudo_controls(&self) -> Vec<&'static str> {
        (0..FLIGHT_PATH_STATES.len())
            .filter(|i| !self.integrate.contains(i))
            .map(|i| FLIGHT_PATH_STATES[i])
            .collect()
    }
}

/// A model structure of either kind a model file declares: the nonlinear
/// 6-DOF equations with non-dimensional coefficients (no `kind` key), or a
/// linear state-space model in dimensional derivatives (`kind = "linear"`,
/// [`LinearStructure`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Structure {
    SixDof(Box<ModelStructure>),
    Linear(Box<LinearStructure>),
}

impl From<ModelStructure> for Structure {
    fn from(structure: ModelStructure) -> Structure {
        Structure::SixDof(Box::new(structure))
    }
}

impl From<LinearStructure> for Structure {
    fn from(structure: LinearStructure) -> Structure {
        Structure::Linear(Box::new(structure))
    }
}

impl Structure {
    /// Loads a structure of either kind by bundled name or path.
    pub fn load(reference: &str) -> Result<Structure> {
        let path = catalog::resolve(reference, catalog::MODEL_FOLDER, None)?;
        let text = read_text(&path)?;
        let table: toml::Table = parse_toml(&path, &text)?;
        match table.get("kind").map(|kind| kind.as_str()) {
            None => ModelStructure::from_file(&parse_toml(&path, &text)?, &path)
                .map(|s| Structure::SixDof(Box::new(s))),
            Some(Some(linear_structure::KIND)) => {
                LinearStructure::from_file(&parse_toml(&path, &text)?, &path)
                    .map(|s| Structure::Linear(Box::new(s)))
            }
            Some(other) => Err(aeroid_core::Error::Invalid {
                path,
                problems: vec![aeroid_core::error::FieldError {
                    field: "kind".into(),
                    message: format!(
                        "is {}; a model file is \"{}\" or has no kind (the 6-DOF equations)",
                        other.map_or("not text".into(), |k| format!("'{k}'")),
                        linear_structure::KIND
                    ),
                }],
            }
            .into()),
        }
    }

    pub fn name(&self) -> &str {
        match self {
            Structure::SixDof(s) => &s.name,
            Structure::Linear(s) => &s.name,
        }
    }

    /// The file it was read from.
    pub fn path(&self) -> &std::path::Path {
        match self {
            Structure::SixDof(s) => &s.path,
            Structure::Linear(s) => &s.path,
        }
    }

    /// The file's `[methods.NAME]` tables (checked against the methods by
    /// [`crate::registry::Registry::validate_tables`] before a fit).
    pub fn methods(&self) -> &MethodTables {
        match self {
            Structure::SixDof(s) => &s.methods,
            Structure::Linear(s) => &s.methods,
        }
    }

    /// The compared outputs.
    pub fn outputs(&self) -> &[String] {
        match self {
            Structure::SixDof(s) => &s.outputs,
            Structure::Linear(s) => &s.outputs,
        }
    }

    /// Every parameter's name and start value.
    pub fn parameters(&self) -> (&[String], &[f64]) {
        match self {
            Structure::SixDof(s) => (
                s.aircraft.aero.parameters.names(),
                s.aircraft.aero.parameters.values(),
            ),
            Structure::Linear(s) => (&s.names, &s.starts),
        }
    }

    /// Every parameter's bounds (low, high), in the order of
    /// [`Structure::parameters`].
    pub fn bounds(&self) -> &[(f64, f64)] {
        match self {
            Structure::SixDof(s) => &s.bounds,
            Structure::Linear(s) => &s.bounds,
        }
    }

    /// The names of the free parameters.
    pub fn free_names(&self) -> Vec<String> {
        match self {
            Structure::SixDof(s) => s.free_names(),
            Structure::Linear(s) => s.free_names(),
        }
    }

    /// The model's source files as JSON (what identifies it).
    pub fn files_json(&self) -> std::result::Result<String, serde_json::Error> {
        match self {
            Structure::SixDof(s) => serde_json::to_string(&(&s.file, &s.aircraft_file)),
            Structure::Linear(s) => serde_json::to_string(&s.file),
        }
    }

    /// The kind's name in messages.
    pub fn kind_name(&self) -> &'static str {
        match self {
            Structure::SixDof(_) => "6-DOF",
            Structure::Linear(_) => linear_structure::KIND,
        }
    }

    /// The kind of truth model a fit of this structure is scored against
    /// exactly: a linear flight's truth is kept as a linear aero model's,
    /// under the parameters' own names.
    pub fn score_kind(&self) -> aeroid_sim::aero::ModelKind {
        match self {
            Structure::SixDof(s) => s.aircraft.aero.kind,
            Structure::Linear(_) => aeroid_sim::aero::ModelKind::Linear,
        }
    }

    /// The 6-DOF structure, or the refusal of `method`, which fits only
    /// that kind.
    pub fn six_dof(&self, method: &str) -> Result<&ModelStructure> {
        match self {
            Structure::SixDof(s) => Ok(s.as_ref()),
            Structure::Linear(s) => Err(Error::Refused(Refusal::StructureKind {
                method: method.to_string(),
                model: s.name.clone(),
                structure: linear_structure::KIND.into(),
                needs: "the 6-DOF equations with non-dimensional coefficients".into(),
            })),
        }
    }
}

fn state_indices(names: &[String], field: &str, problems: &mut FieldErrors) -> Vec<usize> {
    names
        .iter()
        .enumerate()
        .filter_map(|(i, name)| {
            let index = FLIGHT_PATH_STATES.iter().position(|s| s == name);
            if index.is_none() {
                problems.push(
                    format!("{field}[{i}]"),
                    format!(
                        "unknown state '{name}'; known: {}",
                        FLIGHT_PATH_STATES.join(", ")
                    ),
                );
            }
            index
        })
        .collect()
}

/// Applies the `tie` of each parameter setting to the model
/// ([`AeroModel::tie`]), naming the setting in each problem.
fn tie_parameters(
    aero: &mut AeroModel,
    settings: &BTreeMap<String, ParameterSpec>,
    problems: &mut FieldErrors,
) {
    for (name, spec) in settings {
        let (Some(tie), Some(tied)) = (&spec.tie, aero.parameters.index(name)) else {
            continue;
        };
        let field = format!("parameters.{name}.tie");
        let Some(master) = aero.parameters.index(&tie.to) else {
            problems.push(
                field,
                format!(
                    "unknown parameter '{}'; known: {}",
                    tie.to,
                    aero.parameters.names().join(", ")
                ),
            );
            continue;
        };
        let relation = aeroid_sim::aero::Tie {
            master,
            factor: tie.factor,
            offset: tie.offset,
        };
        if let Err(message) = aero.tie(tied, relation) {
            problems.push(field, message);
        }
    }
}

fn parameter_settings(
    aero: &AeroModel,
    settings: &BTreeMap<String, ParameterSpec>,
    problems: &mut FieldErrors,
) -> (Vec<bool>, Vec<(f64, f64)>) {
    let count = aero.parameters.len();
    let (mut free, mut bounds) = (
        vec![true; count],
        vec![(f64::NEG_INFINITY, f64::INFINITY); count],
    );
    for (name, spec) in settings {
        let Some(index) = aero.parameters.index(name) else {
            problems.push(
                format!("parameters.{name}"),
                format!(
                    "unknown parameter; known: {}",
                    aero.parameters.names().join(", ")
                ),
            );
            continue;
        };
        free[index] = !spec.fixed && spec.tie.is_none();
        if spec.tie.is_some() && (spec.fixed || spec.lower.is_some() || spec.upper.is_some()) {
            problems.push(
                format!("parameters.{name}.tie"),
                "a tied parameter follows its master: it is neither fixed nor bounded",
            );
        }
        bounds[index] = (
            spec.lower.unwrap_or(f64::NEG_INFINITY),
            spec.upper.unwrap_or(f64::INFINITY),
        );
        let value = aero.parameters.values()[index];
        if bounds[index].0 >= bounds[index].1 || value < bounds[index].0 || value > bounds[index].1
        {
            problems.push(
                format!("parameters.{name}"),
                "the bounds must be ordered and contain the start value",
            );
        }
    }
    (free, bounds)
}

/// A postulated stall model of the `attas-stall` aircraft for unit tests
/// (longitudinal, 0.04 s step, initial states and an nz bias estimated):
/// linear terms, the Oswald e, a CD_CL2 term, and the stall parameters with
/// τ1 as given (fixed when 0, which makes χ algebraic and the forces
/// depend on α̇).
/// A model output, resolved once from its record channel name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Observable {
    /// A flight-path state (index into x).
    State(usize),
    /// Load factors nx, ny, nz (specific force / g; nz positive up).
    LoadFactor(usize),
    /// ṗ, q̇, ṙ.
    AngularAcceleration(usize),
    Mach,
    DynamicPressure,
    /// CX, CY, CZ.
    Force(usize),
    Lift,
    Drag,
    /// Cl, Cm, Cn.
    Moment(usize),
}

impl Observable {
    /// The outputs other than the flight-path states, by record channel name.
    const NAMED: [(&'static str, Observable); 16] = [
        ("nx", Observable::LoadFactor(0)),
        ("ny", Observable::LoadFactor(1)),
        ("nz", Observable::LoadFactor(2)),
        ("p_dot", Observable::AngularAcceleration(0)),
        ("q_dot", Observable::AngularAcceleration(1)),
        ("r_dot", Observable::AngularAcceleration(2)),
        ("mach", Observable::Mach),
        ("dynamic_pressure", Observable::DynamicPressure),
        ("CX", Observable::Force(0)),
        ("CY", Observable::Force(1)),
        ("CZ", Observable::Force(2)),
        ("CL", Observable::Lift),
        ("CD", Observable::Drag),
        ("Cl", Observable::Moment(0)),
        ("Cm", Observable::Moment(1)),
        ("Cn", Observable::Moment(2)),
    ];

    /// The output a record channel name stands for; None when the model has no such output.
    pub fn parse(name: &str) -> Option<Observable> {
        if let Some(i) = FLIGHT_PATH_STATES.iter().position(|s| *s == name) {
            return Some(Observable::State(i));
        }
        Observable::NAMED
            .iter()
            .find(|(named, _)| *named == name)
            .map(|(_, observable)| *observable)
    }

    /// Every output name a model structure may compare.
    pub fn names() -> impl Iterator<Item = &'static str> {
        FLIGHT_PATH_STATES
            .iter()
            .copied()
            .chain(Observable::NAMED.iter().map(|(name, _)| *name))
    }
}

#[cfg(test)]
pub(crate) fn stall_test_structure(tau1: f64) -> ModelStructure {
    let text = format!(
        r#"
name = "stall-test"
aircraft = "attas-stall"
integrate = ["airspeed", "alpha", "q", "pitch"]
outputs = ["airspeed", "alpha", "q", "nz", "nx"]
[aero]
model = "stall"
rate_normalization = "V"
oswald_efficiency = 0.8
[aero.stall]
a1 = 20.0
alpha_star = 0.3
tau1 = {tau1:?}
tau2 = 0.5
[aero.CD]
0 = 0.04
CL2 = 0.02
chi = 0.07
[aero.CL]
0 = 0.15
alpha = 3.0
[aero.Cm]
0 = 0.05
alpha = -0.2
q = -6.0
de = -0.4
chi = -0.1
[parameters.tau1]
fixed = {fixed}
[methods.oem]
step = "0.04 s"
estimate_initial_state = true
output_biases = ["nz"]
"#,
        fixed = tau1 == 0.0
    );
    let file: StructureFile = toml::from_str(&text).unwrap();
    let path = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../models/stall-test.toml"
    ));
    ModelStructure::from_file(&file, path).unwrap()
}
