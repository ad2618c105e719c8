//! Measured quantities are used (equation error, stepwise regression): a
//! record with a `thrust` channel has it in the force equations instead
//! of the throttle model, one with `density` has it in q̄ (and the thrust
//! lapse) instead of the ISA at the altitude channel, and with
//! `angular_accelerations = "measured"` the record's ṗ, q̇, ṙ replace the
//! differentiated rates. Each is said in the estimate's notes.

mod common;

use aeroid::estimation::estimate::Estimate;
use aeroid::estimation::estimator::MethodTables;
use aeroid::estimation::methods;
use aeroid::estimation::problem::EstimationProblem;
use aeroid::estimation::structure::Structure;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;
use aeroid::sim::truth::RunTruth;
use std::path::Path;

/// The ideal recorder (every quantity at 100 Hz, no error) without the
/// channels named in `without`.
fn ideal_without(folder: &Path, without: &[&str]) -> Profile {
    common::profile_variant(folder, "ideal", "", |name, table| {
        (!without.contains(&name)).then(|| table.to_string())
    })
}

fn fit(method: &str, record: &FlightRecord, layers: &[&MethodTables]) -> aeroid::Result<Estimate> {
    let structure = Structure::load("attas-longitudinal").unwrap();
    let problem = EstimationProblem::new(method, vec![record.clone()], structure, layers)?;
    methods::estimate(&problem, None)
}

fn worst(estimate: &Estimate, truth: &RunTruth) -> (f64, String) {
    common::worst_relative_error(estimate, truth, 0.01)
}

/// The ATTAS elevator 3-2-1-1 recorded noise-free at 100 Hz with thrust
/// and density measured but no throttle, altitude or dynamic-pressure
/// channel: equation error fits the longitudinal model from the measured
/// thrust and density (before, it refused: no throttle, no altitude).
/// With the record's angular accelerations the regression is exact to
/// rounding; with the rates differentiated it carries the differentiator's
/// error.
///
/// Measured, worst error relative to max(|truth|, 0.01): with the
/// record's ṗ, q̇, ṙ 1.4e-13 (CL_de), rounding; with the rates
/// differentiated 1.8e-7 (Cm_alpha), the differentiator's error at 100 Hz.
/// Asserted: measured within 1e-9 (noise-free, every signal exact),
/// differentiated worse than that, and the notes present.
#[test]
fn thrust_density_and_angular_accelerations_from_the_record() {
    let folder = common::temp_folder("measured_quantities");
    let scenario = Scenario::load("attas-elevator-3211").unwrap();
    let profile = ideal_without(
        &folder,
        &[
            "throttle",
            "altitude",
            "pressure_altitude",
            "baro_corrected_altitude",
            "dynamic_pressure",
        ],
    );
    let (record, truth) = record_scenario(&scenario, &profile).unwrap();
    let measured: MethodTables =
        toml::from_str("[ee]\nangular_accelerations = \"measured\"\n").unwrap();
    let from_record = fit("ee", &record, &[&measured]).unwrap();
    let differentiated = fit("ee", &record, &[]).unwrap();
    let (measured_error, measured_name) = worst(&from_record, &truth);
    let (differentiated_error, differentiated_name) = worst(&differentiated, &truth);
    println!(
        "measured ṗ, q̇, ṙ: worst {measured_error:.2e} ({measured_name}); differentiated: {differentiated_error:.2e} ({differentiated_name})\n{:#?}\n{:#?}",
        from_record.notes, differentiated.notes
    );
    assert!(
        measured_error <= 1e-6,
        "{measured_error:.2e} ({measured_name})"
    );
    assert!(differentiated_error > measured_error);
    let says = |e: &Estimate, text: &str| e.notes.iter().any(|n| n.contains(text));
    for estimate in [&from_record, &differentiated] {
        assert!(
            says(estimate, "the record's 'thrust' channel"),
            "{:?}",
            estimate.notes
        );
        assert!(
            says(estimate, "the record's 'density' channel"),
            "{:?}",
            estimate.notes
        );
    }
    assert!(says(
        &from_record,
        "angular accelerations: the record's p_dot"
    ));
    assert!(says(
        &differentiated,
        "`angular_accelerations = \"measured\"`"
    ));
    // Stepwise regression reads the same setting.
    let stepwise: MethodTables =
        toml::from_str("[swr]\nangular_accelerations = \"measured\"\n").unwrap();
    let selected = fit("swr", &record, &[&stepwise]).unwrap();
    assert!(says(&selected, "angular accelerations: the record's p_dot"));
}

/// `angular_accelerations = "measured"` on a record without them is a
/// refusal naming the channels; without thrust, throttle, density and
/// altitude the refusal names what the force equations lack.
#[test]
fn what_is_missing_is_named() {
    let folder = common::temp_folder("measured_quantities_missing");
    let scenario = Scenario::load("attas-elevator-3211").unwrap();
    let profile = ideal_without(&folder, &["p_dot", "q_dot", "r_dot"]);
    let (record, _) = record_scenario(&scenario, &profile).unwrap();
    let measured: MethodTables =
        toml::from_str("[ee]\nangular_accelerations = \"measured\"\n").unwrap();
    let error = fit("ee", &record, &[&measured]).unwrap_err().to_string();
    for name in ["p_dot", "q_dot", "r_dot"] {
        assert!(error.contains(name), "{error}");
    }
    let profile = ideal_without(
        &folder,
        &[
            "thrust",
            "throttle",
            "density",
            "altitude",
            "pressure_altitude",
            "baro_corrected_altitude",
            "dynamic_pressure",
        ],
    );
    let (record, _) = record_scenario(&scenario, &profile).unwrap();
    let error = fit("ee", &record, &[]).unwrap_err().to_string();
    for name in ["throttle", "altitude"] {
        assert!(error.contains(name), "{error}");
    }
}
