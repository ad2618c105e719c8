//! Neural Gauss–Newton (`ngn`) on simulated records whose truth is known.

mod common;

use aeroid::estimation::estimate::Estimate;
use aeroid::estimation::estimator::MethodTables;
use aeroid::estimation::problem::EstimationProblem;
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::Profile;
use aeroid::sim::scenario::Scenario;

/// The scenario flown and recorded with `profile`.
fn fly(scenario: &str, profile: &str) -> (FlightRecord, Scenario) {
    let scenario = Scenario::load(scenario).unwrap();
    let profile = Profile::load(profile, None).unwrap();
    let (record, _) = common::fly_and_record(&scenario, &profile);
    (record, scenario)
}

/// `method` on the record with the model and `[methods.METHOD]` settings.
fn run(method: &str, record: &FlightRecord, model: &str, settings: &str) -> Estimate {
    let structure = ModelStructure::load(model).unwrap();
    let mut tables = MethodTables::new();
    tables.insert(method.to_string(), toml::from_str(settings).unwrap());
    let problem = EstimationProblem::new(method, vec![record.clone()], structure, &[&tables]).unwrap();
    aeroid::estimation::methods::estimate(&problem, None).unwrap()
}

/// Each estimated parameter: (name, estimate, σ, truth).
fn against_truth(estimate: &Estimate, scenario: &Scenario) -> Vec<(String, f64, f64, f64)> {
    estimate
        .parameters
        .iter()
        .map(|p| {
            let truth = scenario.aircraft.aero.parameters.get(&p.name).unwrap_or(f64::NAN);
            (p.name.clone(), p.value, p.standard_error, truth)
        })
        .collect()
}

fn table(rows: &[(String, f64, f64, f64)]) -> String {
    rows.iter()
        .map(|(name, value, sigma, truth)| {
            format!(
                "{name}: {value:.5} ± {sigma:.5} (truth {truth:.5}, {:+.2} %, {:+.2} σ)\n",
                100.0 * (value - truth) / truth,
                (value - truth) / sigma
            )
        })
        .collect()
}

#[test]
fn explore() {
    let cases = std::env::var("NGN_CASES").unwrap_or_default();
    let settings = std::env::var("NGN_SETTINGS").unwrap_or_default();
    for case in cases.split(';').filter(|c| !c.is_empty()) {
        let parts: Vec<&str> = case.split(',').collect();
        let (record, scenario) = fly(parts[0], parts[1]);
        for method in parts[3..].iter() {
          for s in settings.split('|') {
            let s = if *method == "ngn" { s.replace('/', "\n") } else { String::new() };
            let s = s.as_str();
            let started = std::time::Instant::now();
            let estimate = run(method, &record, parts[2], s);
            eprintln!(
                "== {case} {method} {s}: {:?} {:.3} s iterations {}\n{}{:?}\n{:#?}",
                estimate.status,
                started.elapsed().as_secs_f64(),
                estimate.iterations,
                table(&against_truth(&estimate, &scenario)),
                estimate.network,
                estimate.notes
            );
          }
        }
    }
}
