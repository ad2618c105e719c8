//! Several manoeuvres in one fit: output error fits repeats of a manoeuvre
//! jointly (shared aerodynamic parameters, each repeat its own initial
//! state), and methods that fit one record at a time refuse several,
//! from the library and from the command line.
//!
//! The manoeuvre: the bundled ATTAS elevator 3-2-1-1 (60 s, no turbulence)
//! recorded twice by the 25 Hz flight-test profile with two recorder seeds:
//! the same flight, two independent draws of sensor noise.

use crate::common;
use aeroid::estimation::estimate::Estimate;
use aeroid::estimation::estimator::{Refusal, RefusalKind};
use aeroid::estimation::registry::Registry;
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::{Profile, record_scenario_seeded};
use aeroid::sim::scenario::Scenario;
use std::sync::OnceLock;

/// The two repeats (module documentation).
fn repeats() -> &'static [FlightRecord; 2] {
    static REPEATS: OnceLock<[FlightRecord; 2]> = OnceLock::new();
    REPEATS.get_or_init(|| {
        let scenario = Scenario::load("attas-elevator-3211").unwrap();
        let profile = Profile::load("flight-test-25hz", None).unwrap();
        let record = |seed| record_scenario_seeded(&scenario, &profile, seed).unwrap().0;
        [record(11), record(12)]
    })
}

fn fit(method: &str, records: Vec<FlightRecord>) -> aeroid::estimation::Result<Estimate> {
    let structure = ModelStructure::load("attas-longitudinal").unwrap();
    let problem = crate::common::registry().problem(method, records, structure, &[])?;
    crate::common::registry().estimate(&problem, None)
}

/// Two repeats fitted jointly: every aerodynamic parameter's Cramér–Rao σ
/// is 1/√2 of one repeat's, within 5 %. Why 1/√2: the two repeats fly the
/// same trajectory, so their output sensitivities, and with them their
/// information matrices, are equal, and the joint information is twice
/// one repeat's. Why not exactly: the noise covariance R is estimated from
/// each fit's residuals, whose scatter over 1 500 samples per output is
/// about √(2/1500) ≈ 4 % in R, 2 % in σ; the initial states added per
/// repeat take a few data each. Measured: ratios 0.7065 to 0.7131 (within
/// 0.9 % of 1/√2).
#[test]
fn two_repeats_fitted_jointly_halve_the_variance() {
    let [first, second] = repeats().clone();
    let one = fit("oem", vec![first.clone()]).unwrap();
    let joint = fit("oem", vec![first, second]).unwrap();
    let structure = ModelStructure::load("attas-longitudinal").unwrap();
    let aerodynamic: Vec<String> = structure.aircraft.aero.parameters.names().to_vec();
    let mut compared = 0;
    for parameter in &one.parameters {
        let Some(both) = joint.parameter(&parameter.name) else {
            continue;
        };
        // Initial states (`x0[k].alpha`) and output biases belong to one
        // repeat each: only the shared aerodynamic parameters are compared.
        if !aerodynamic.contains(&parameter.name) {
            continue;
        }
        let ratio = both.standard_error / parameter.standard_error;
        assert!(
            (ratio * 2f64.sqrt() - 1.0).abs() < 0.05,
            "{}: σ joint {} / σ one {} = {ratio}, expected about {}",
            parameter.name,
            both.standard_error,
            parameter.standard_error,
            1.0 / 2f64.sqrt()
        );
        compared += 1;
    }
    assert!(compared >= 5, "{compared} parameters compared");
}

/// Every method but output error fits one record at a time (equation
/// error, stepwise regression, filter error, the EKF and UKF, estimation
/// before modelling, the frequency-domain methods, the neural methods,
/// the RBF + Delta method): given two, each refuses with a typed refusal rather
/// than use the first.
#[test]
fn one_record_methods_refuse_several() {
    let registry = Registry::built_in();
    let one_record: Vec<&str> = registry
        .all()
        .iter()
        .filter(|estimator| !estimator.capabilities().several_records)
        .map(|estimator| estimator.name())
        .collect();
    assert!(
        one_record.contains(&"ee") && !one_record.contains(&"oem"),
        "{one_record:?}"
    );
    for method in one_record {
        let error = fit(method, repeats().to_vec()).unwrap_err();
        let aeroid::estimation::Error::Refused(refusal) = &error else {
            panic!("{method}: not a refusal: {error}");
        };
        assert_eq!(refusal.kind(), RefusalKind::OneRecordOnly, "{refusal}");
        assert_eq!(
            refusal,
            &Refusal::OneRecordOnly {
                method: method.to_string(),
                records: 2,
                gaps: None,
            }
        );
        assert!(
            error
                .to_string()
                .contains("fits one record at a time, and was given 2"),
            "{error}"
        );
    }
}

/// From the command line: `aeroid estimate REC1 REC2 --method ee` refuses
/// and says why.
#[test]
fn the_command_line_takes_several_records() {
    let folder = common::temp_folder("joint-cli");
    let [first, second] = repeats();
    first.write(&folder.join("rec1")).unwrap();
    second.write(&folder.join("rec2")).unwrap();
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_aeroid"))
        .arg("estimate")
        .arg(folder.join("rec1"))
        .arg(folder.join("rec2"))
        .args(["--model", "attas-longitudinal", "--method", "ee"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        stderr.contains("ee fits one record at a time, and was given 2"),
        "{stderr}"
    );
}
