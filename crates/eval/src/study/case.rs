//! One case: its seeds drawn from its stream of the study seed, the
//! scenario flown with the point's turbulence and input scale and recorded
//! by the point's profile (and derived), every model fitted with every
//! method, and the fits as rows. A failure is a row, never an error.

use super::{Case, Row, RowStatus, Study, SweepPoint};
use crate::error::Result;
use crate::histories::CaseHistories;
use crate::run::{self, Outcome};
use crate::score::ParameterScore;
use aeroid_core::random;
use aeroid_estimation::estimate::Estimate;
use aeroid_estimation::structure::Structure;
use aeroid_record::FlightRecord;
use aeroid_sim::scenario::Scenario;
use aeroid_sim::trace::TruthTrace;
use aeroid_sim::truth::RunTruth;
use aeroid_sim::wind::TurbulenceSpec;
use rand::RngExt;

/// A case's flight as recorded: the record, the truth and the trace, or
/// why there is none.
type Recorded = Result<(FlightRecord, RunTruth, Option<TruthTrace>)>;

impl Study {
    /// Runs one case: draws its seeds, flies and records the scenario, and
    /// fits every model with every method. Never fails: a failure is a row.
    pub fn run_case(&self, case: Case) -> Vec<Row> {
        self.run_case_with_histories(case, false).0
    }

    /// [`Study::run_case`], and when `keep` the case's time histories
    /// (measured, proof of match, estimated and true coefficient histories).
    pub fn run_case_with_histories(
        &self,
        case: Case,
        keep: bool,
    ) -> (Vec<Row>, Option<CaseHistories>) {
        let point = &self.points[case.point];
        let recording = Case {
            point: point.recording,
            run: case.run,
        };
        let mut rng = random::stream(self.seed, recording.stream());
        let turbulence_seed: u64 = rng.random();
        let recorder_seed: u64 = rng.random();
        let scenario = self.flown_scenario(point, turbulence_seed);
        let recorded =
            crate::linear_flight::record_flight_traced(&scenario, &point.profile, recorder_seed)
                .and_then(|(record, truth, trace)| match &self.derive {
                    Some(derive) if derive.applies_to(&point.recorder) => {
                        aeroid_record::prep::derive::derive(&record, &derive.options())
                            .map(|derived| (derived.record, truth, trace))
                            .map_err(Into::into)
                    }
                    _ => Ok((record, truth, trace)),
                });
        let mut histories = match (&recorded, keep) {
            (Ok((record, _, _)), true) => Some(CaseHistories::new(
                case.point,
                case.run,
                self.point_label(case.point),
                record,
                &self.models,
            )),
            _ => None,
        };
        let template = Row::template(
            case.point,
            self.point_axes(case.point),
            case.run,
            turbulence_seed,
            recorder_seed,
        );
        let mut rows = Vec::new();
        for model in &self.models {
            let outcomes = self.fit_model(model, point, &scenario, &recorded);
            if let (Some(histories), Ok((record, _, trace))) = (&mut histories, &recorded) {
                for (_, outcome) in &outcomes {
                    if let Some(estimate) = outcome.estimate() {
                        histories.add(model, estimate, record, trace.as_ref());
                    }
                }
            }
            for (method, outcome) in outcomes {
                let fit = Row {
                    model: model.name().to_string(),
                    method,
                    ..template.clone()
                };
                fit_rows(fit, outcome, &mut rows);
            }
        }
        (rows, histories)
    }

    /// The point's scenario with the case's turbulence seed, its
    /// turbulence intensity and its inputs scaled.
    fn flown_scenario(&self, point: &SweepPoint, turbulence_seed: u64) -> Scenario {
        let mut scenario = self.scenarios[point.scenario].clone();
        scenario.seed = turbulence_seed;
        match point.turbulence.as_deref() {
            None => {}
            Some("none") => scenario.wind.turbulence = None,
            Some(intensity) => {
                scenario.wind.turbulence = Some(TurbulenceSpec {
                    intensity: Some(intensity.to_string()),
                    ..TurbulenceSpec::default()
                })
            }
        }
        if point.input_scale != 1.0 {
            scenario.inputs = scenario.inputs.scaled(point.input_scale);
        }
        scenario
    }

    /// Every method's outcome on `model`, or every method failed with the
    /// recording's error.
    fn fit_model(
        &self,
        model: &Structure,
        point: &SweepPoint,
        scenario: &Scenario,
        recorded: &Recorded,
    ) -> Vec<(String, Outcome)> {
        match recorded {
            Ok((record, truth, _)) => run::estimate_each(
                &self.registry,
                &self.methods,
                record,
                truth,
                model,
                &[
                    &scenario.methods,
                    &self.settings,
                    &self.setting_variants[point.settings],
                ],
            ),
            Err(error) => self
                .methods
                .iter()
                .map(|method| (method.clone(), Outcome::Failed(error.to_string())))
                .collect(),
        }
    }
}

/// The rows of one fit (`fit`: its model and method set) from its outcome:
/// one per parameter when estimated, else one with the reason.
fn fit_rows(fit: Row, outcome: Outcome, rows: &mut Vec<Row>) {
    match outcome {
        Outcome::Estimated { estimate, scores } => {
            let (status, reason) = RowStatus::of(&estimate.status);
            let fit = Row {
                condition_number: estimate.correlation_condition(),
                diagnoses: diagnoses_text(&estimate),
                ..fit
            };
            rows.extend(scores.iter().map(|s| {
                let index = estimate.parameters.iter().position(|p| p.name == s.name);
                let strongest = index.and_then(|i| estimate.strongest_correlation(i));
                Row {
                    correlated_with: strongest.map_or(String::new(), |(name, _)| name.to_string()),
                    max_correlation: strongest.map(|(_, r)| r),
                    ..parameter_row(&fit, status, &reason, s)
                }
            }));
        }
        Outcome::Refused(refusal) => rows.push(Row {
            status: RowStatus::Refused,
            reason: refusal.to_string(),
            ..fit
        }),
        Outcome::Failed(reason) => rows.push(Row { reason, ..fit }),
    }
}

/// An estimate's diagnoses as a row's `diagnoses` column.
fn diagnoses_text(estimate: &Estimate) -> String {
    estimate
        .diagnoses
        .iter()
        .map(|d| d.kind.name())
        .collect::<Vec<_>>()
        .join(" ")
}

fn parameter_row(fit: &Row, status: RowStatus, reason: &str, score: &ParameterScore) -> Row {
    Row {
        status,
        reason: reason.to_string(),
        parameter: score.name.clone(),
        estimate: score.estimate,
        standard_error: score.standard_error,
        truth: score.truth,
        error: score.error,
        inside_95: score.inside_95,
        ..fit.clone()
    }
}
