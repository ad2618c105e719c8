//! `aeroid run`: the whole harness on one scenario. It simulates, records
//! with the scenario's (or a given) recorder profile, runs every classical
//! estimator (equation error, stepwise regression, output error) on every
//! model structure the scenario names, and scores each estimate against the
//! run's truth. One estimator failing (a missing channel on a QAR record, a
//! diverged fit) is reported in its row and the others carry on.

use crate::error::Result;
use crate::estimation::estimate::Estimate;
use crate::estimation::methods::{equation_error, output_error, stepwise};
use crate::estimation::structure::ModelStructure;
use crate::eval::score::{self, ParameterScore};
use crate::record::FlightRecord;
use crate::record::recorder::{Profile, record_scenario};
use crate::sim::scenario::Scenario;
use crate::sim::truth::RunTruth;

/// The classical estimators, in the order `aeroid run` runs them.
pub const METHODS: [&str; 3] = ["ee", "swr", "oem"];

/// One estimator on one model: its estimate and scores, or why it could not run.
#[derive(Debug, Clone)]
pub struct MethodRun {
    pub model: String,
    pub method: &'static str,
    pub outcome: std::result::Result<(Estimate, Vec<ParameterScore>), String>,
}

impl MethodRun {
    /// Share of scored parameters whose truth lies inside the 95 % interval, and the largest |error/σ|.
    pub fn coverage(&self) -> Option<(usize, usize, f64)> {
        let (_, scores) = self.outcome.as_ref().ok()?;
        let scored: Vec<&ParameterScore> = scores.iter().filter(|s| s.truth.is_some()).collect();
        let inside = scored.iter().filter(|s| s.inside_95 == Some(true)).count();
        let worst = scored
            .iter()
            .filter_map(|s| s.error_sigma)
            .map(f64::abs)
            .fold(0.0, f64::max);
        Some((inside, scored.len(), worst))
    }
}

/// Everything one run produced.
#[derive(Debug, Clone)]
pub struct RunReport {
    pub scenario: String,
    pub profile: String,
    pub record: FlightRecord,
    pub truth: RunTruth,
    pub runs: Vec<MethodRun>,
}

/// Simulates, records and estimates; fails only when the flight itself cannot be made.
pub fn run(scenario: &Scenario, profile: &Profile) -> Result<RunReport> {
    let (record, truth) = record_scenario(scenario, profile)?;
    let mut runs = Vec::new();
    for reference in &scenario.models {
        let structure = ModelStructure::load(reference);
        for method in METHODS {
            let outcome = match &structure {
                Ok(structure) => {
                    estimate_scored(method, &record, &truth, structure).map_err(|e| e.to_string())
                }
                Err(error) => Err(error.to_string()),
            };
            runs.push(MethodRun {
                model: reference.clone(),
                method,
                outcome,
            });
        }
    }
    Ok(RunReport {
        scenario: scenario.name.clone(),
        profile: profile.name.clone(),
        record,
        truth,
        runs,
    })
}

/// Runs one named estimator and scores its estimate against the run's truth.
pub fn estimate_scored(
    method: &str,
    record: &FlightRecord,
    truth: &RunTruth,
    structure: &ModelStructure,
) -> Result<(Estimate, Vec<ParameterScore>)> {
    let estimate = estimate(method, record, structure)?;
    let scores = score::score(&estimate, Some(truth), structure.aircraft.aero.kind);
    Ok((estimate, scores))
}

/// Runs one named estimator with its default options.
pub fn estimate(
    method: &str,
    record: &FlightRecord,
    structure: &ModelStructure,
) -> Result<Estimate> {
    match method {
        "ee" => equation_error::equation_error(record, structure, &Default::default()),
        "swr" => stepwise::stepwise_all(record, structure).map(|(_, estimate)| estimate),
        "oem" => output_error::output_error(&[record], structure, &Default::default()),
        other => Err(crate::Error::Unknown {
            kind: "method",
            name: other.to_string(),
            known: METHODS.map(String::from).to_vec(),
        }),
    }
}
