//! Accuracy gates (`golden/gates.toml`, `aeroid gate`): each case flies a
//! scenario, records it with a profile, runs one estimator on one model and
//! checks every estimated parameter against the truth within a tolerance,
//! relative (|estimate − truth| ≤ tol·|truth|) or, for parameters whose truth
//! is near zero, absolute. A regression of any estimator's accuracy fails the
//! gate with a table of what moved. Tolerances are set from the accuracy
//! measured when a case was added, with the reason in the file.

use crate::error::{Error, Problems, Result, parse_toml, read_text};
use crate::estimation::estimate::Estimate;
use crate::estimation::structure::ModelStructure;
use crate::pipeline;
use crate::recorder::{Profile, record_scenario};
use crate::scenario::Scenario;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The gate file bundled with aeroid.
pub const GATE_FILE: &str = "golden/gates.toml";

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GateFile {
    #[serde(rename = "case")]
    pub cases: Vec<GateCase>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GateCase {
    pub name: String,
    pub scenario: String,
    pub profile: String,
    pub model: String,
    pub method: String,
    /// Default relative tolerance for every parameter with a truth.
    pub relative_tolerance: f64,
    /// Absolute tolerance used instead when |truth| is below it (near-zero truths).
    #[serde(default)]
    pub absolute_floor: f64,
    /// Per-parameter relative tolerances overriding the default.
    #[serde(default)]
    pub tolerance: BTreeMap<String, f64>,
}

/// One parameter's check.
#[derive(Debug, Clone, PartialEq)]
pub struct GateRow {
    pub parameter: String,
    pub estimate: f64,
    pub truth: f64,
    pub error: f64,
    pub allowed: f64,
}

impl GateRow {
    pub fn passed(&self) -> bool {
        self.error.abs() <= self.allowed
    }
}

/// The outcome of one case.
#[derive(Debug, Clone)]
pub struct GateResult {
    pub case: GateCase,
    pub estimate: Estimate,
    pub rows: Vec<GateRow>,
}

impl GateResult {
    pub fn passed(&self) -> bool {
        self.rows.iter().all(GateRow::passed)
    }

    /// The rows that failed, as a readable table.
    pub fn failures(&self) -> String {
        let mut text = format!(
            "{:<14} {:>13} {:>13} {:>11} {:>11}\n",
            "parameter", "estimate", "truth", "error", "allowed"
        );
        for row in self.rows.iter().filter(|r| !r.passed()) {
            text += &format!(
                "{:<14} {:>13.6} {:>13.6} {:>11.3e} {:>11.3e}\n",
                row.parameter, row.estimate, row.truth, row.error, row.allowed
            );
        }
        text
    }

    /// The estimates rounded to 4 significant digits, one per line, for snapshots.
    pub fn snapshot(&self) -> String {
        let mut text = format!(
            "{} / {} / {} / {}: {:?}\n",
            self.case.scenario,
            self.case.profile,
            self.case.model,
            self.case.method,
            self.estimate.status
        );
        for p in &self.estimate.parameters {
            text += &format!("{} = {}\n", p.name, crate::record::rounded(p.value));
        }
        text
    }
}

/// Loads and validates a gate file.
pub fn load(path: &Path) -> Result<GateFile> {
    let file: GateFile = parse_toml(path, &read_text(path)?)?;
    let mut problems = Problems::default();
    for (i, case) in file.cases.iter().enumerate() {
        if !pipeline::METHODS.contains(&case.method.as_str()) {
            problems.push(
                format!("case[{i}].method"),
                format!(
                    "unknown method '{}'; known: {}",
                    case.method,
                    pipeline::METHODS.join(", ")
                ),
            );
        }
        if [case.relative_tolerance]
            .iter()
            .chain(case.tolerance.values())
            .any(|t| t.is_nan() || *t <= 0.0)
        {
            problems.push(format!("case[{i}]"), "tolerances must be positive");
        }
    }
    problems.finish(path, file)
}

/// Runs one case.
pub fn run_case(case: &GateCase) -> Result<GateResult> {
    let scenario = Scenario::load(&case.scenario)?;
    let profile = Profile::load(&case.profile, None)?;
    let structure = ModelStructure::load(&case.model)?;
    let (record, truth) = record_scenario(&scenario, &profile)?;
    let estimate = pipeline::estimate(&case.method, &record, &structure)?;
    let rows = estimate
        .parameters
        .iter()
        .filter_map(|p| {
            let (truth, _) = truth.value_for(&p.name, structure.aircraft.aero.kind)?;
            let relative = case
                .tolerance
                .get(&p.name)
                .copied()
                .unwrap_or(case.relative_tolerance);
            Some(GateRow {
                parameter: p.name.clone(),
                estimate: p.value,
                truth,
                error: p.value - truth,
                allowed: (relative * truth.abs()).max(case.absolute_floor),
            })
        })
        .collect::<Vec<_>>();
    if rows.is_empty() {
        return Err(Error::Other(format!(
            "gate '{}': no estimated parameter has a truth",
            case.name
        )));
    }
    Ok(GateResult {
        case: case.clone(),
        estimate,
        rows,
    })
}
