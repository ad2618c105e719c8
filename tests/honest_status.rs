//! An estimate is "converged" only when it is. Built on purpose from a real
//! flight: output error on the first three samples of the lateral record
//! has 15 data for 22 unknowns, so the information matrix is singular and
//! parameters have infinite σ: the estimate must say which are
//! unidentified, never "converged", and the score must not count an
//! infinite σ as covering the truth. The same fit on the whole record
//! converges (the control case).

use aeroid::estimation::estimate::Status;
use aeroid::estimation::methods;
use aeroid::estimation::problem::EstimationProblem;
use aeroid::estimation::structure::ModelStructure;
use aeroid::eval::score;
use aeroid::record::recorder::{profile_for, record_scenario};
use aeroid::sim::scenario::Scenario;

#[test]
fn too_few_data_is_unidentified_not_converged() {
    let scenario = Scenario::load("attas-lateral-multistep").unwrap();
    let profile = profile_for(&scenario, None).unwrap();
    let (record, truth) = record_scenario(&scenario, &profile).unwrap();
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let mut short = record.clone();
    for channel in &mut short.channels {
        channel.times.truncate(3);
        channel.values.truncate(3);
    }
    let fit = |record| {
        let problem = EstimationProblem::new("oem", vec![record], structure.clone(), &[]).unwrap();
        methods::estimate(&problem, None).unwrap()
    };
    let estimate = fit(short);
    let Status::Unidentified(names) = &estimate.status else {
        panic!("3 samples: {}", estimate.status);
    };
    assert!(!names.is_empty());
    let scores = score::score(&estimate, Some(&truth), structure.aircraft.aero.kind);
    for s in scores.iter().filter(|s| names.contains(&s.name)) {
        assert_ne!(
            s.inside_95,
            Some(true),
            "{} with σ = {}",
            s.name,
            s.standard_error
        );
    }
    assert_eq!(fit(record).status, Status::Converged);
}
