//! Only what the model needs: a model declares which pseudo-controls a
//! record may lack (`zero_when_absent`), an estimator then fits a record
//! without them (held at 0, said in the notes), and without the
//! declaration the record is refused with the channels named.
//!
//! The flight: the bundled ATTAS elevator 3-2-1-1 (60 s, still air),
//! recorded by the ideal profile, flown by the ATTAS with its lateral
//! offsets CY_0, Cl_0 and Cn_0 at 0: a symmetric aircraft whose lateral
//! motion nothing excites, so β, p, r and φ are 0 throughout and a record
//! without them carries the same information: a fit on it must give the
//! full record's estimates.

use crate::common;
use aeroid::estimation::estimate::Estimate;
use aeroid::estimation::estimator::RefusalKind;
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;
use std::path::PathBuf;
use std::sync::OnceLock;

const LATERAL: [&str; 4] = ["beta", "p", "r", "roll"];

/// The ideal record of the 3-2-1-1, and the same without its lateral
/// channels (flown once for both tests).
fn records() -> (FlightRecord, FlightRecord) {
    static RECORDS: OnceLock<(FlightRecord, FlightRecord)> = OnceLock::new();
    RECORDS.get_or_init(fly).clone()
}

fn fly() -> (FlightRecord, FlightRecord) {
    let folder = common::temp_folder("model_channels_flight");
    common::write(
        &folder,
        "symmetric.toml",
        &common::attas_with(|t| {
            t.replace("0 = -0.0067 ", "0 = 0.0 ")
                .replace("0 = 6.0e-5 ", "0 = 0.0 ")
                .replace("0 = 0.0014 ", "0 = 0.0 ")
        }),
    );
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/attas-elevator-3211.toml"),
    )
    .unwrap()
    .replacen("aircraft = \"attas\"", "aircraft = \"symmetric.toml\"", 1);
    let path = common::write(&folder, "attas-elevator-3211.toml", &text);
    let scenario = Scenario::load(path.to_str().unwrap()).unwrap();
    let profile = Profile::load("ideal", None).unwrap();
    let (full, _) = record_scenario(&scenario, &profile).unwrap();
    for name in LATERAL {
        let channel = full.channel(name).unwrap();
        let largest = channel.values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(
            largest < 1e-9,
            "{name} reaches {largest}: not a longitudinal flight"
        );
    }
    let mut longitudinal = full.clone();
    longitudinal
        .channels
        .retain(|c| !LATERAL.contains(&c.name.as_str()));
    (full, longitudinal)
}

/// The bundled longitudinal model with `line` added, written to a
/// temporary folder (its aircraft is the bundled one, by name).
fn model_with(test: &str, line: &str) -> PathBuf {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/attas-longitudinal.toml"),
    )
    .unwrap()
    .replacen("outputs = [", &format!("{line}\noutputs = ["), 1);
    common::write(&common::temp_folder(test), "model.toml", &text)
}

fn fit(
    method: &str,
    record: FlightRecord,
    model: &std::path::Path,
) -> aeroid::estimation::Result<Estimate> {
    let structure = ModelStructure::load(model.to_str().unwrap()).unwrap();
    let problem = crate::common::registry().problem(method, vec![record], structure, &[])?;
    crate::common::registry().estimate(&problem, None)
}

/// Output error, equation error and the augmented EKF on the record
/// without lateral channels give the full record's estimates (to 1e-9
/// relative: the channels of zeros are exactly what the full record
/// holds), and each notes every state it held at 0.
#[test]
fn a_longitudinal_model_fits_a_record_without_lateral_channels() {
    let (full, longitudinal) = records();
    let model = model_with(
        "model_channels_fit",
        r#"zero_when_absent = ["beta", "p", "r", "roll"]"#,
    );
    for method in ["oem", "ee", "ekf"] {
        let reference = fit(method, full.clone(), &model).unwrap();
        let reduced = fit(method, longitudinal.clone(), &model).unwrap();
        // The EKF's innovations on noise-free data are far below their
        // predicted covariance: "not settled" with or without the channels.
        assert_eq!(reduced.status, reference.status, "{method}");
        assert!(
            method == "ekf" || reduced.status.is_success(),
            "{method}: {}",
            reduced.status
        );
        for (a, b) in reference.parameters.iter().zip(&reduced.parameters) {
            assert_eq!(a.name, b.name);
            assert!(
                (a.value - b.value).abs() <= 1e-9 * a.value.abs().max(1e-6),
                "{method} {}: {} with the lateral channels, {} without",
                a.name,
                a.value,
                b.value
            );
        }
        for name in LATERAL {
            let said = format!("no '{name}' channel in 'attas-elevator-3211': held at 0");
            assert!(
                reduced.notes.iter().any(|n| n.starts_with(&said)),
                "{method}: no note on {name}: {:?}",
                reduced.notes
            );
            assert!(
                !reference.notes.iter().any(|n| n.starts_with(&said)),
                "{method}: a note on {name} although the record has it"
            );
        }
    }
}

/// Without the declaration, the same record is refused, every missing
/// lateral channel named; a declaration of a state that cannot be 0 (the
/// altitude) or that the model integrates (α) is a problem of the model
/// file, named by its field.
#[test]
fn undeclared_or_impossible_zero_channels_are_refused() {
    let (_, longitudinal) = records();
    let plain = model_with("model_channels_plain", "");
    let error = fit("oem", longitudinal, &plain).unwrap_err();
    let text = error.to_string();
    assert!(
        matches!(&error, aeroid::estimation::Error::Refused(r) if r.kind() == RefusalKind::MissingChannels),
        "{text}"
    );
    for name in LATERAL {
        assert!(text.contains(&format!("'{name}'")), "{text}");
    }
    for (line, field, says) in [
        (
            r#"zero_when_absent = ["altitude"]"#,
            "zero_when_absent[0]",
            "cannot be held at 0",
        ),
        (
            r#"zero_when_absent = ["beta", "alpha"]"#,
            "zero_when_absent[1]",
            "is integrated",
        ),
        (
            r#"zero_when_absent = ["sideslip"]"#,
            "zero_when_absent[0]",
            "unknown state",
        ),
    ] {
        let model = model_with("model_channels_bad", line);
        let text = ModelStructure::load(model.to_str().unwrap())
            .unwrap_err()
            .to_string();
        assert!(
            text.contains(field) && text.contains(says),
            "{line}: {text}"
        );
    }
}
