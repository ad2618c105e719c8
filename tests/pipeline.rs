//! `aeroid run`: simulate → record → every classical estimator → score, as
//! a user runs it.

use aeroid::eval::run;
use aeroid::record::recorder::Profile;
use aeroid::sim::scenario::Scenario;

/// The bundled lateral scenario: all three estimators run on the model it
/// names and converge; every estimated term that the truth model has is
/// scored against exact truth (postulate and truth are both linear), and
/// equation error and output error estimate every term of the model.
#[test]
fn run_scores_every_method_on_the_lateral_scenario() {
    let scenario = Scenario::load("attas-lateral-multistep").unwrap();
    let profile = aeroid::record::recorder::profile_for(&scenario, None).unwrap();
    let report = run::run(&scenario, &profile).unwrap();
    let methods: Vec<&str> = report.runs.iter().map(|r| r.method).collect();
    assert_eq!(methods, run::METHODS);
    for run in &report.runs {
        let (estimate, scores) = run
            .outcome
            .as_ref()
            .unwrap_or_else(|e| panic!("{} failed: {e}", run.method));
        assert!(
            matches!(
                estimate.status,
                aeroid::estimation::solver::gauss_newton::Status::Converged
            ),
            "{}",
            run.method
        );
        for score in scores
            .iter()
            .filter(|s| report.truth.parameters.contains_key(&s.name))
        {
            assert_eq!(
                score.truth_kind,
                Some(aeroid::sim::truth::TruthKind::Exact),
                "{} {}",
                run.method,
                score.name
            );
        }
        if run.method != "swr" {
            assert!(
                scores.iter().filter(|s| s.truth.is_some()).count() == 18,
                "{}",
                run.method
            );
        }
    }
}

/// The QAR of Wang et al. 2012 records no angular rates, no airspeed, no throttle:
/// no estimator crashes on it; each reports what it lacks.
#[test]
fn qar_record_is_reported_not_crashed() {
    let mut scenario = Scenario::load("transport-approach").unwrap();
    scenario.duration = 20.0;
    let profile = Profile::load("qar-seed000", None).unwrap();
    let report = run::run(&scenario, &profile).unwrap();
    assert_eq!(report.runs.len(), 2 * run::METHODS.len());
    for run in &report.runs {
        let reason = run
            .outcome
            .as_ref()
            .expect_err("QAR lacks the channels these models need");
        assert!(
            reason.contains("channel"),
            "{}/{}: {reason}",
            run.model,
            run.method
        );
    }
}
