//! An estimate is "converged" only when it is, and a problem that cannot
//! have an answer is refused, not "solved". Each case is built on purpose
//! from a real flight of the ATTAS lateral benchmark:
//! - an unexcited control: with the aileron never moved (its input removed,
//!   its channel recorded without noise), the aileron derivatives have no
//!   sensitivity, so output error must name them unidentified (infinite σ)
//!   and the score must not count an infinite σ as covering the truth;
//! - fewer data than unknowns (the first three samples: 15 data for 22
//!   unknowns) is refused with both numbers;
//! - a model with no outputs, or comparing a state it does not integrate
//!   (fed in from the record, compared with itself), is refused;
//! - an output name the model cannot produce fails when the model loads.
//!
//! The unchanged flight converges (the control case).

use aeroid::error::Error;
use aeroid::estimation::estimate::{Estimate, Status};
use aeroid::estimation::estimator::{Refusal, RefusalKind};
use aeroid::estimation::methods;
use aeroid::estimation::problem::EstimationProblem;
use aeroid::estimation::structure::ModelStructure;
use aeroid::eval::score;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;

fn oem(record: FlightRecord, structure: &ModelStructure) -> aeroid::Result<Estimate> {
    let problem = EstimationProblem::new("oem", vec![record], structure.clone(), &[])?;
    methods::estimate(&problem, None)
}

fn refusal(result: aeroid::Result<Estimate>) -> Refusal {
    match result {
        Err(Error::Refused(refusal)) => refusal,
        Err(other) => panic!("an error, not a refusal: {other}"),
        Ok(estimate) => panic!("an estimate, not a refusal: {}", estimate.status),
    }
}

/// A folder with a copy of a bundled scenario and the flight-test profile,
/// each edited by `edit`.
fn edited(name: &str, scenario_edit: impl Fn(&str) -> String) -> (Scenario, Profile) {
    let root = env!("CARGO_MANIFEST_DIR");
    let folder = std::env::temp_dir().join(format!("aeroid-honest-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&folder).unwrap();
    let scenario_text =
        std::fs::read_to_string(format!("{root}/scenarios/attas-lateral-multistep.toml")).unwrap();
    let scenario_path = folder.join("scenario.toml");
    std::fs::write(&scenario_path, scenario_edit(&scenario_text)).unwrap();
    // The aileron recorded without noise: exactly its trim value when unmoved.
    let profile_text =
        std::fs::read_to_string(format!("{root}/recorders/flight-test-25hz.toml")).unwrap();
    let profile_text = profile_text.replace(
        "name = \"aileron\"\nrate = \"25 Hz\"\nnoise = \"0.01 deg\"",
        "name = \"aileron\"\nrate = \"25 Hz\"",
    );
    assert!(!profile_text.contains("name = \"aileron\"\nrate = \"25 Hz\"\nnoise"));
    let profile_path = folder.join("profile.toml");
    std::fs::write(&profile_path, profile_text).unwrap();
    let scenario = Scenario::load(scenario_path.to_str().unwrap()).unwrap();
    let profile = Profile::load(profile_path.to_str().unwrap(), None).unwrap();
    std::fs::remove_dir_all(&folder).unwrap();
    (scenario, profile)
}

#[test]
fn an_unexcited_control_leaves_its_derivatives_unidentified() {
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let without_aileron = |text: &str| {
        let start = text
            .find("[[inputs]]\nkind = \"multistep\"\ncontrol = \"aileron\"")
            .unwrap();
        let end = start + text[start..].find("\n\n").unwrap();
        format!("{}{}", &text[..start], &text[end..])
    };
    let (scenario, profile) = edited("unexcited", without_aileron);
    let (record, truth) = record_scenario(&scenario, &profile).unwrap();
    let estimate = oem(record, &structure).unwrap();
    let Status::Unidentified(names) = &estimate.status else {
        panic!("no aileron input: {}", estimate.status);
    };
    for name in ["Cl_da", "Cn_da"] {
        assert!(names.iter().any(|n| n == name), "{names:?}");
    }
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

    // The control case: the same flight with the aileron moved converges.
    let (scenario, profile) = edited("excited", str::to_string);
    let (record, _) = record_scenario(&scenario, &profile).unwrap();
    assert_eq!(oem(record, &structure).unwrap().status, Status::Converged);
}

#[test]
fn degenerate_problems_are_refused() {
    let scenario = Scenario::load("attas-lateral-multistep").unwrap();
    let profile = aeroid::record::recorder::profile_for(&scenario, None).unwrap();
    let (record, _) = record_scenario(&scenario, &profile).unwrap();
    let structure = ModelStructure::load("attas-lateral").unwrap();

    let mut short = record.clone();
    for channel in &mut short.channels {
        channel.times.truncate(3);
        channel.values.truncate(3);
    }
    let too_few = refusal(oem(short, &structure));
    assert_eq!(too_few.kind(), RefusalKind::TooFewData);
    let text = too_few.to_string();
    assert!(text.contains("15 data for 22 unknowns"), "{text}");

    let rebuilt = |edit: &dyn Fn(&mut aeroid::estimation::structure::StructureFile)| {
        let mut file = structure.file.clone();
        edit(&mut file);
        ModelStructure::from_parts(&file, &structure.aircraft_file, &structure.path)
    };
    let no_outputs = rebuilt(&|file| file.outputs.clear()).unwrap();
    let refused = refusal(oem(record.clone(), &no_outputs));
    assert_eq!(refused.kind(), RefusalKind::UnsuitableModel, "{refused}");

    let nothing_integrated = rebuilt(&|file| file.integrate.clear()).unwrap();
    let refused = refusal(oem(record.clone(), &nothing_integrated));
    assert_eq!(refused.kind(), RefusalKind::UnsuitableModel);
    assert!(
        refused.to_string().contains("compared with itself"),
        "{refused}"
    );

    let error = rebuilt(&|file| file.outputs.push("airspeeed".into()))
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("outputs[5]") && error.contains("unknown output 'airspeeed'"),
        "{error}"
    );
}
