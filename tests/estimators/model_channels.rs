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

/// A model that integrates no state (`integrate = []`), every motion
/// variable fed in from the record and only the load factors as outputs:
/// each registered method either fits it or refuses it with a message,
/// never a panic (an empty state matrix once reached nalgebra's
/// eigenvalue and LU routines, which panic on 0×0). Output error on the
/// noise-free record then has no dynamics to integrate: the load factors
/// are the force coefficients' regression, so it recovers the force
/// and drag parameters to the truth (1e-6 relative; the ideal record's
/// rounding is far below it), and leaves the moment derivatives, which nothing
/// it compares depends on, unidentified rather than "converged".
#[test]
fn a_model_without_integrated_states_fits_or_is_refused_never_panics() {
    let model = {
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/attas-longitudinal.toml"),
        )
        .unwrap()
        .replace(
            "integrate = [\"airspeed\", \"alpha\", \"q\", \"pitch\"]",
            "integrate = []",
        )
        .replace(
            "outputs = [\"airspeed\", \"alpha\", \"q\", \"pitch\", \"nx\", \"nz\"]",
            "outputs = [\"nx\", \"nz\"]",
        );
        assert!(text.contains("integrate = []"), "the bundled model changed");
        common::write(
            &common::temp_folder("no_integrated_state"),
            "model.toml",
            &text,
        )
    };
    let (full, _) = records();
    for method in common::registry().names() {
        let outcome = std::panic::catch_unwind(|| fit(&method, full.clone(), &model));
        match outcome {
            Err(_) => panic!("{method} panicked on a model without integrated states"),
            Ok(Err(error)) => assert!(
                !error.to_string().trim().is_empty(),
                "{method}: an error without a message"
            ),
            Ok(Ok(_)) => {}
        }
    }
    let oem = fit("oem", full, &model).unwrap();
    let truth = Scenario::load("attas-elevator-3211").unwrap();
    let rows = common::against_truth(&oem, &truth);
    eprintln!("{}\n{}", oem.status, common::truth_table(&rows));
    let status = oem.status.to_string();
    for name in ["Cm_alpha", "Cm_q", "Cm_de"] {
        assert!(
            status.contains(name),
            "{name} is not reported unidentified: {status}"
        );
    }
    let forces = rows
        .iter()
        .filter(|row| row.0.starts_with("CL") || row.0.starts_with("CD") || row.0 == "e");
    assert_eq!(
        forces.clone().count(),
        6,
        "CL_0, CL_alpha, CL_q, CL_de, CD_0, e"
    );
    for (name, value, _, truth) in forces {
        assert!(
            (value - truth).abs() <= 1e-6 * truth.abs().max(1.0),
            "{name}: {value} against the truth {truth}"
        );
    }
}

/// A model file whose start value makes a mode too fast for any grid a
/// fit takes (Cm_q = −1e30) is refused with the mode and the step named,
/// by every method that simulates the model, whatever its start (output
/// error's `start = "model"` here) — not a panic on a grid of 10³⁰ points.
#[test]
fn a_start_value_that_no_grid_integrates_is_refused_with_the_mode_named() {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/attas-longitudinal.toml"),
    )
    .unwrap()
    .replacen("q = -10.0", "q = -1e30", 1);
    assert!(text.contains("q = -1e30"), "the bundled model changed");
    let text = text.replacen("[methods.oem]", "[methods.oem]\nstart = \"model\"", 1);
    let model = common::write(&common::temp_folder("too_fast_start"), "model.toml", &text);
    let (full, _) = records();
    for method in ["oem", "fem", "ekf", "ukf", "fdoe"] {
        let outcome = std::panic::catch_unwind(|| fit(method, full.clone(), &model));
        let Ok(result) = outcome else {
            panic!("{method} panicked on a start value of 1e30");
        };
        let error = result.err().map(|e| e.to_string()).unwrap_or_default();
        assert!(
            error.contains("fastest mode") && error.contains("e28/s"),
            "{method}: {error}"
        );
    }
}
