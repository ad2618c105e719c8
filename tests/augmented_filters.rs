//! The augmented-state filters (`ekf`, `ukf`) on simulated records where
//! the answer is known.

use aeroid::estimation::estimate::{Estimate, Status};
use aeroid::estimation::estimator::Settings;
use aeroid::estimation::methods::augmented_ekf::{self, FilterSettings, History};
use aeroid::estimation::solver::extended_kalman;
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::{Profile, record_scenario, record_scenario_seeded};
use aeroid::sim::scenario::Scenario;
use aeroid::sim::state::Control;

/// The flight-test profile with the noise line of every channel for which
/// `noise` says so removed.
fn flight_test_variant(test: &str, strip: impl Fn(&str) -> bool) -> Profile {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/recorders/flight-test-25hz.toml"
    ))
    .unwrap();
    let mut channel = String::new();
    let mut out = String::new();
    for line in text.lines() {
        if let Some(name) = line.strip_prefix("name = \"") {
            channel = name.trim_end_matches('"').to_string();
        }
        if !(line.starts_with("noise") && strip(&channel)) {
            out += line;
            out += "\n";
        }
    }
    let path = std::env::temp_dir().join(format!("aeroid-{test}-{}.toml", std::process::id()));
    std::fs::write(&path, out).unwrap();
    Profile::load(path.to_str().unwrap(), None).unwrap()
}

fn is_control(channel: &str) -> bool {
    Control::ALL.iter().any(|c| c.name() == channel)
}

fn ekf(
    record: &FlightRecord,
    structure: &ModelStructure,
    settings: &FilterSettings,
) -> (Estimate, History) {
    augmented_ekf::augmented_estimate(
        "ekf",
        record,
        structure,
        settings,
        None,
        &|model, initial, noise, observations| {
            extended_kalman::filter(model, &[], initial, noise, observations)
        },
    )
    .unwrap()
}

fn report(estimate: &Estimate, scenario: &Scenario) -> (f64, f64, String) {
    let mut text = String::new();
    let (mut worst_relative, mut worst_sigma): (f64, f64) = (0.0, 0.0);
    for p in &estimate.parameters {
        let truth = scenario.aircraft.aero.parameters.get(&p.name).unwrap();
        let relative = ((p.value - truth) / truth).abs();
        let sigmas = (p.value - truth) / p.standard_error;
        worst_relative = worst_relative.max(relative);
        worst_sigma = worst_sigma.max(sigmas.abs());
        text += &format!(
            "{}: {:.6} ± {:.2e} (truth {truth:.6}, rel {relative:.2e}, {sigmas:+.2} σ)\n",
            p.name, p.value, p.standard_error
        );
    }
    (worst_relative, worst_sigma, text)
}

#[test]
fn explore() {
    let scenario = Scenario::load("attas-lateral-multistep").unwrap();
    let structure = ModelStructure::load("attas-lateral").unwrap();
    for (name, profile) in [
        ("noise-free", flight_test_variant("ekf-free", |_| true)),
        ("sensor-noise", flight_test_variant("ekf-sensor", is_control)),
    ] {
        let (record, _) = record_scenario(&scenario, &profile).unwrap();
        let t = std::time::Instant::now();
        let (estimate, _) = ekf(&record, &structure, &FilterSettings::default());
        let (rel, sig, text) = report(&estimate, &scenario);
        println!(
            "{name}: {:?} in {:?}: worst rel {rel:.2e}, worst {sig:.2} σ\n{text}{}\n{}",
            estimate.status,
            t.elapsed(),
            estimate.notes.join("\n"),
            estimate.details
        );
    }
}
