//! The estimation problem: everything an estimator reads, resolved — the
//! record or records (every channel in SI at its own sample instants, NaN a
//! dropout), the model structure (its file and its aircraft's file, its
//! free and fixed parameters with start values and bounds, the integrated
//! states, the pseudo-controls and the compared outputs) and the method's
//! settings (its `[methods.NAME]` tables merged: model file, then scenario,
//! then study or gate case).
//!
//! It serialises to JSON and reads back identically: the contract for
//! estimators written in other languages. The JSON holds the source files
//! of the model (so aeroid rebuilds the same structure from it) beside the
//! resolved view a foreign program reads directly (`parameters`,
//! `integrate`, `pseudo_controls`, `outputs`). A dropout is `null`, an
//! unbounded side of a parameter's range is `null`.
//!
//! ```json
//! { "format": "aeroid-estimation-problem-1", "method": "oem",
//!   "settings": { "estimate_initial_state": true },
//!   "parameters": [ { "name": "Cl_beta", "start": -0.05, "free": true,
//!                     "lower": null, "upper": null } ],
//!   "integrate": ["beta", "p", "r", "roll"], "pseudo_controls": ["airspeed", …],
//!   "outputs": ["beta", "p", "r", "roll", "ny"],
//!   "model": { "structure": { … model file … }, "aircraft": { … aircraft file … } },
//!   "records": [ { "scenario": "…", "channels": [ { "name": "p", "unit": "rad/s",
//!                  "rate": 25.0, "times": [ … ], "values": [ … ] } ] } ] }
//! ```

use crate::error::{Error, Result};
use crate::estimation::estimator::{MethodTables, Settings, merge_settings};
use crate::estimation::linear_structure::{LinearFile, LinearStructure};
use crate::estimation::methods;
use crate::estimation::structure::{ModelStructure, Structure, StructureFile, ZERO_SOURCE};
use crate::record::FlightRecord;
use crate::sim::aircraft::AircraftFile;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The format tag of a problem's JSON.
pub const FORMAT: &str = "aeroid-estimation-problem-1";

/// One estimator's problem.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimationProblem {
    /// The registered method that solves it.
    pub method: String,
    /// One record, or several manoeuvres fitted together.
    pub records: Vec<FlightRecord>,
    /// The model structure, of either kind.
    pub structure: Structure,
    /// The method's settings: the merged `[methods.NAME]` tables.
    pub settings: Settings,
}

impl EstimationProblem {
    /// The problem of `method` on `records`, its settings the structure's
    /// `[methods.NAME]` table overridden key by key by each of `layers`
    /// (scenario, then study or gate case). Fails on an unknown method or
    /// settings it does not accept.
    pub fn new(
        method: &str,
        records: Vec<FlightRecord>,
        structure: impl Into<Structure>,
        layers: &[&MethodTables],
    ) -> Result<EstimationProblem> {
        let structure = structure.into();
        let estimator = methods::find(method)?;
        let mut all = vec![structure.methods()];
        all.extend_from_slice(layers);
        let settings = merge_settings(method, &all);
        estimator.check_settings(&settings)?;
        if records.is_empty() {
            return Err(Error::Other(format!(
                "{method} on model '{}': no record given",
                structure.name()
            )));
        }
        let records = match &structure {
            Structure::SixDof(six_dof) => six_dof.with_zero_channels(records),
            Structure::Linear(_) => records,
        };
        Ok(EstimationProblem {
            method: method.to_string(),
            records,
            structure,
            settings,
        })
    }

    /// What the problem holds at 0 for the estimator: a note per channel
    /// of zeros the model's `zero_when_absent` put in a record.
    pub fn notes(&self) -> Vec<String> {
        self.records
            .iter()
            .flat_map(|record| {
                record
                    .channels
                    .iter()
                    .filter(|c| c.source.starts_with(ZERO_SOURCE))
                    .map(|c| {
                        format!(
                            "no '{}' channel in '{}': held at 0 (the model's zero_when_absent)",
                            c.name, record.scenario
                        )
                    })
            })
            .collect()
    }

    /// The first (or only) record.
    pub fn record(&self) -> &FlightRecord {
        &self.records[0]
    }

    /// The problem as JSON (see the module documentation).
    pub fn to_json(&self) -> Result<String> {
        let document = Document::of(self);
        serde_json::to_string_pretty(&document)
            .map_err(|e| Error::Other(format!("estimation problem as JSON: {e}")))
    }

    /// Reads a problem written by [`EstimationProblem::to_json`]; `origin`
    /// names the file in errors. The structure is rebuilt from the files
    /// the JSON carries and must agree with its resolved view.
    pub fn from_json(text: &str, origin: &Path) -> Result<EstimationProblem> {
        let document: Document = serde_json::from_str(text).map_err(|e| {
            Error::Other(format!(
                "{}: not an estimation problem: line {}, column {}: {e}",
                origin.display(),
                e.line(),
                e.column()
            ))
        })?;
        if document.format != FORMAT {
            return Err(Error::Other(format!(
                "{}: format '{}' is not '{FORMAT}'",
                origin.display(),
                document.format
            )));
        }
        let path = PathBuf::from(&document.model.path);
        let structure = document.model.structure(&path)?;
        let resolved = Document::parameters(&structure);
        let aircraft_agrees = match &structure {
            Structure::SixDof(six_dof) => document
                .aircraft
                .as_ref()
                .is_none_or(|view| *view == AircraftView::of(six_dof)),
            Structure::Linear(_) => document.aircraft.is_none(),
        };
        if resolved != document.parameters || !aircraft_agrees {
            return Err(Error::Other(format!(
                "{}: the parameters or the aircraft do not agree with the model files they came with",
                origin.display()
            )));
        }
        methods::find(&document.method)?.check_settings(&document.settings)?;
        if document.records.is_empty() {
            return Err(Error::Other(format!("{}: no record", origin.display())));
        }
        for record in &document.records {
            record.validate(origin)?;
        }
        Ok(EstimationProblem {
            method: document.method,
            records: document.records,
            structure,
            settings: document.settings,
        })
    }

    pub fn write_json(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_json()?).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })
    }

    pub fn read_json(path: &Path) -> Result<EstimationProblem> {
        EstimationProblem::from_json(&crate::error::read_text(path)?, path)
    }
}

/// One parameter of the model as the problem states it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProblemParameter {
    pub name: String,
    pub start: f64,
    pub free: bool,
    /// None: unbounded below.
    pub lower: Option<f64>,
    /// None: unbounded above.
    pub upper: Option<f64>,
}

/// The model's source files: a 6-DOF structure with its aircraft, or a
/// linear model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelDocument {
    /// Where the model file was read from (named in errors).
    path: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    structure: Option<StructureFile>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    aircraft: Option<AircraftFile>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    linear: Option<LinearFile>,
}

impl ModelDocument {
    fn of(structure: &Structure) -> ModelDocument {
        match structure {
            Structure::SixDof(s) => ModelDocument {
                path: s.path.display().to_string(),
                structure: Some(s.file.clone()),
                aircraft: Some(s.aircraft_file.clone()),
                linear: None,
            },
            Structure::Linear(s) => ModelDocument {
                path: s.path.display().to_string(),
                structure: None,
                aircraft: None,
                linear: Some(s.file.clone()),
            },
        }
    }

    /// The structure rebuilt from the files.
    fn structure(&self, path: &Path) -> Result<Structure> {
        match (&self.structure, &self.aircraft, &self.linear) {
            (Some(structure), Some(aircraft), None) => {
                ModelStructure::from_parts(structure, aircraft, path)
                    .map(|s| Structure::SixDof(Box::new(s)))
            }
            (None, None, Some(linear)) => {
                LinearStructure::from_file(linear, path).map(|s| Structure::Linear(Box::new(s)))
            }
            _ => Err(Error::Other(format!(
                "{}: the model holds either `structure` and `aircraft` (6-DOF) or `linear`",
                path.display()
            ))),
        }
    }
}

/// The JSON form.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Document {
    format: String,
    method: String,
    settings: Settings,
    parameters: Vec<ProblemParameter>,
    integrate: Vec<String>,
    pseudo_controls: Vec<String>,
    outputs: Vec<String>,
    /// The aircraft in SI, as the model uses it (read for programs; on
    /// reading it must agree with the files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    aircraft: Option<AircraftView>,
    model: ModelDocument,
    records: Vec<FlightRecord>,
}

/// The aircraft and the model's conventions in SI, for programs that read
/// the problem: mass (kg), wing area (m²), span and chord (m), the inertia
/// tensor's Ixx, Iyy, Izz, Ixz (kg·m²), the rate normalisation (`2V`: p̂ =
/// p·b/(2V)) and the speed it uses (`airspeed` or `reference`, then
/// `reference_airspeed`, m/s, null when the model sets none).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AircraftView {
    pub mass: f64,
    pub wing_area: f64,
    pub span: f64,
    pub chord: f64,
    pub ixx: f64,
    pub iyy: f64,
    pub izz: f64,
    pub ixz: f64,
    pub rate_normalization: String,
    pub rate_speed: String,
    /// None (null) when the model sets none.
    pub reference_airspeed: Option<f64>,
}

impl AircraftView {
    fn of(structure: &ModelStructure) -> AircraftView {
        let aircraft = &structure.aircraft;
        let inertia = &aircraft.mass.inertia;
        let aero = &structure.file.aero;
        AircraftView {
            mass: aircraft.mass.mass,
            wing_area: aircraft.wing_area,
            span: aircraft.geometry.span,
            chord: aircraft.geometry.chord,
            ixx: inertia[(0, 0)],
            iyy: inertia[(1, 1)],
            izz: inertia[(2, 2)],
            ixz: -inertia[(0, 2)],
            rate_normalization: value_text(&aero.rate_normalization),
            rate_speed: value_text(&aero.rate_speed),
            reference_airspeed: Some(aircraft.aero.reference_airspeed).filter(|v| v.is_finite()),
        }
    }
}

/// A setting's text as the files write it.
fn value_text<T: Serialize>(value: &T) -> String {
    serde_json::to_value(value)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_default()
}

impl Document {
    fn of(problem: &EstimationProblem) -> Document {
        let structure = &problem.structure;
        let (integrate, pseudo_controls, aircraft) = match structure {
            Structure::SixDof(s) => (
                s.file.integrate.clone(),
                s.pseudo_controls().into_iter().map(String::from).collect(),
                Some(AircraftView::of(s)),
            ),
            Structure::Linear(s) => (s.states.clone(), s.inputs.clone(), None),
        };
        Document {
            format: FORMAT.to_string(),
            method: problem.method.clone(),
            settings: problem.settings.clone(),
            parameters: Document::parameters(structure),
            integrate,
            pseudo_controls,
            outputs: structure.outputs().to_vec(),
            aircraft,
            model: ModelDocument::of(structure),
            records: problem.records.clone(),
        }
    }

    fn parameters(structure: &Structure) -> Vec<ProblemParameter> {
        let (names, starts, free, bounds) = match structure {
            Structure::SixDof(s) => {
                let parameters = &s.aircraft.aero.parameters;
                (parameters.names(), parameters.values(), &s.free, &s.bounds)
            }
            Structure::Linear(s) => (&s.names[..], &s.starts[..], &s.free, &s.bounds),
        };
        let finite = |v: f64| v.is_finite().then_some(v);
        names
            .iter()
            .zip(starts)
            .enumerate()
            .map(|(i, (name, &start))| ProblemParameter {
                name: name.clone(),
                start,
                free: free[i],
                lower: finite(bounds[i].0),
                upper: finite(bounds[i].1),
            })
            .collect()
    }
}
