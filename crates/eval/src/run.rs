//! `aeroid run`: the whole harness on one scenario. It simulates, records
//! with the scenario's (or a given) recorder profile, runs every registered
//! estimator on every model structure the scenario names, and scores each
//! estimate against the run's truth. An estimator that cannot run on the
//! record refuses with a typed [`Refusal`]; one that fails (a diverged fit)
//! is reported in its row; the others carry on. A method that starts from
//! another's estimate (output error from equation error's) gets it when
//! that method ran on the same model before it.

use crate::error::{Error, Result};
use crate::score::{self, ParameterScore};
use aeroid_estimation::estimate::Estimate;
use aeroid_estimation::estimator::{MethodTables, Refusal};
use aeroid_estimation::registry::Registry;
use aeroid_estimation::structure::Structure;
use aeroid_record::FlightRecord;
use aeroid_record::recorder::Profile;
use aeroid_sim::scenario::Scenario;
use aeroid_sim::truth::RunTruth;

/// How one estimator fared on one model.
#[derive(Debug, Clone)]
pub enum Outcome {
    /// An estimate (whatever its status) and its scores against the truth.
    Estimated {
        estimate: Box<Estimate>,
        scores: Vec<ParameterScore>,
    },
    /// The estimator cannot run on this record or model, and says why.
    Refused(Refusal),
    /// Anything else that stopped it (a model file that does not load, a
    /// simulation that cannot start), as a message.
    Failed(String),
}

impl Outcome {
    fn of(result: Result<(Estimate, Vec<ParameterScore>)>) -> Outcome {
        match result {
            Ok((estimate, scores)) => Outcome::Estimated {
                estimate: Box::new(estimate),
                scores,
            },
            Err(error) => match error.refusal() {
                Some(refusal) => Outcome::Refused(refusal.clone()),
                None => Outcome::Failed(error.to_string()),
            },
        }
    }

    /// The estimate, when there is one.
    pub fn estimate(&self) -> Option<&Estimate> {
        match self {
            Outcome::Estimated { estimate, .. } => Some(estimate),
            _ => None,
        }
    }

    /// Why there is no estimate, when there is none.
    pub fn reason(&self) -> Option<String> {
        match self {
            Outcome::Estimated { .. } => None,
            Outcome::Refused(refusal) => Some(format!("refused: {refusal}")),
            Outcome::Failed(message) => Some(message.clone()),
        }
    }
}

/// One estimator on one model: its estimate and scores, or why it could not run.
#[derive(Debug, Clone)]
pub struct MethodRun {
    pub model: String,
    pub method: String,
    pub outcome: Outcome,
}

impl MethodRun {
    /// Share of scored parameters whose truth lies inside the 95 % interval, and the largest |error/σ|.
    pub fn coverage(&self) -> Option<(usize, usize, f64)> {
        let Outcome::Estimated { scores, .. } = &self.outcome else {
            return None;
        };
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
    /// The record the estimators read (after the derive step, if asked).
    pub record: FlightRecord,
    /// What the derive step did, when it ran (its record moved to
    /// `record`, so empty here).
    pub derived: Option<aeroid_record::prep::derive::Derived>,
    pub truth: RunTruth,
    pub runs: Vec<MethodRun>,
}

/// Simulates, records, runs the derive step when `derive` is given (the
/// record the estimators read is then the derived one) and estimates;
/// fails only when the flight itself cannot be made or derived.
pub fn run(
    registry: &Registry,
    scenario: &Scenario,
    profile: &Profile,
    derive: Option<&aeroid_record::prep::derive::Options>,
) -> Result<RunReport> {
    registry.validate_tables(&scenario.methods, &scenario.path)?;
    let (recorded, truth) = crate::linear_flight::record_flight(scenario, profile, scenario.seed)?;
    let mut derived = derive
        .map(|options| aeroid_record::prep::derive::derive(&recorded, options))
        .transpose()?;
    let record = match &mut derived {
        Some(derived) => std::mem::take(&mut derived.record),
        None => recorded,
    };
    let names = registry.names();
    let mut runs = Vec::new();
    for (index, reference) in scenario.models.iter().enumerate() {
        let field = format!("models[{index}]");
        let structure = aeroid_core::catalog::resolve_named(
            reference,
            aeroid_core::catalog::MODEL_FOLDER,
            &scenario.path,
            &field,
        )
        .map_err(aeroid_estimation::Error::from)
        .and_then(|path| Structure::load(&path.to_string_lossy()));
        let outcomes = match &structure {
            Ok(structure) => estimate_each(
                registry,
                &names,
                &record,
                &truth,
                structure,
                &[&scenario.methods],
            ),
            Err(error) => names
                .iter()
                .map(|name| (name.clone(), Outcome::Failed(error.to_string())))
                .collect(),
        };
        runs.extend(outcomes.into_iter().map(|(method, outcome)| MethodRun {
            model: reference.clone(),
            method,
            outcome,
        }));
    }
    Ok(RunReport {
        scenario: scenario.name.clone(),
        profile: profile.name.clone(),
        record,
        derived,
        truth,
        runs,
    })
}

/// Runs each of `methods` in turn on a record with one model and scores
/// every estimate; a method that starts from another's estimate
/// ([`aeroid_estimation::estimator::Capabilities::starts_from`]) gets it when
/// that method ran before it here.
pub fn estimate_each(
    registry: &Registry,
    methods: &[String],
    record: &FlightRecord,
    truth: &RunTruth,
    structure: &Structure,
    layers: &[&MethodTables],
) -> Vec<(String, Outcome)> {
    let mut outcomes: Vec<(String, Outcome)> = Vec::with_capacity(methods.len());
    for method in methods {
        let start = registry
            .find(method)
            .ok()
            .and_then(|estimator| estimator.capabilities().starts_from)
            .and_then(|from| outcomes.iter().find(|(name, _)| name == from))
            .and_then(|(_, outcome)| outcome.estimate());
        let outcome = estimate_scored(registry, method, record, truth, structure, layers, start);
        outcomes.push((method.clone(), outcome));
    }
    outcomes
}

/// Runs one registered method on a record and scores its estimate against
/// the run's truth; its settings are the model's `[methods.NAME]` table
/// overridden by `layers` (scenario, study or gate case).
pub fn estimate_scored(
    registry: &Registry,
    method: &str,
    record: &FlightRecord,
    truth: &RunTruth,
    structure: &Structure,
    layers: &[&MethodTables],
    start: Option<&Estimate>,
) -> Outcome {
    Outcome::of(
        registry
            .problem(method, vec![record.clone()], structure.clone(), layers)
            .and_then(|problem| registry.estimate(&problem, start))
            .map_err(Error::from)
            .map(|estimate| {
                let scores = score::score(&estimate, Some(truth), structure.score_kind());
                (estimate, scores)
            }),
    )
}
