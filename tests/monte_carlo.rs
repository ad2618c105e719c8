//! Monte Carlo studies (`aeroid study`): reproducibility whatever the thread
//! count, bad study files, and the issue-4 acceptance over 100 seeded runs.

mod common;

use aeroid::Error;
use aeroid::study::{Row, Study, StudyResult};
use std::path::PathBuf;

/// A cheap study (equation error only: ~10 ms a fit) with two sweep points.
const SMALL: &str = r#"
name = "small"
scenarios = ["attas-lateral-multistep"]
profile = "flight-test-25hz"
models = ["attas-lateral"]
methods = ["ee"]
runs = 4
seed = 11
[sweep]
noise_scale = [0.5, 2.0]
"#;

fn study_file(test: &str, text: &str) -> PathBuf {
    common::write(&common::temp_folder(test), "study.toml", text)
}

fn run(study: &Study, threads: usize) -> StudyResult {
    study.run(threads, &|| {}).unwrap()
}

/// Rows as CSV text: f64 are written in their shortest round-trip form, so
/// equal text is equal bits.
fn csv_text(rows: &[Row]) -> String {
    let mut writer = csv::Writer::from_writer(Vec::new());
    rows.iter().for_each(|r| writer.serialize(r).unwrap());
    String::from_utf8(writer.into_inner().unwrap()).unwrap()
}

/// A seed in, the same numbers out: 1 and 2 threads give bit-identical rows
/// (and so summaries); fewer runs give the first runs' rows unchanged, so a
/// study can be extended or resumed; another study seed gives other numbers
/// (the comparison can fail). Every case draws other seeds.
#[test]
fn same_rows_whatever_the_thread_count_and_run_count() {
    let path = study_file("mc-threads", SMALL);
    let mut study = Study::load(path.to_str().unwrap()).unwrap();
    let (one, two) = (run(&study, 1), run(&study, 2));
    assert_eq!(one.rows.len(), 2 * 4 * 18);
    assert_eq!(csv_text(&one.rows), csv_text(&two.rows));
    assert_eq!(format!("{:?}", one.summary), format!("{:?}", two.summary));
    let mut seeds: Vec<u64> = one.rows.iter().map(|r| r.recorder_seed).collect();
    seeds.dedup();
    assert_eq!(seeds.len(), 8, "one recorder seed per case");

    study.runs = 2;
    let fewer = run(&study, 2);
    let first_two: Vec<Row> = one.rows.iter().filter(|r| r.run < 2).cloned().collect();
    assert_eq!(csv_text(&fewer.rows), csv_text(&first_two));

    study.seed += 1;
    let other = run(&study, 2);
    assert_ne!(other.rows[0].estimate, fewer.rows[0].estimate);
}

/// The sweep grid is scenario × sample rate × noise scale, and each point's
/// profile is the bundled one modified (rates and noise of every channel).
#[test]
fn sweep_points_modify_the_profile() {
    let text = SMALL.replace(
        "noise_scale = [0.5, 2.0]",
        "noise_scale = [0.5, 2.0]\nsample_rate = [\"10 Hz\", 50]",
    );
    let study = Study::load(study_file("mc-sweep", &text).to_str().unwrap()).unwrap();
    let grid: Vec<(Option<f64>, f64)> = study
        .points
        .iter()
        .map(|p| (p.sample_rate, p.noise_scale))
        .collect();
    assert_eq!(
        grid,
        [
            (Some(10.0), 0.5),
            (Some(10.0), 2.0),
            (Some(50.0), 0.5),
            (Some(50.0), 2.0)
        ]
    );
    let alpha = |point: usize| {
        let channel = study.points[point]
            .profile
            .channels
            .iter()
            .find(|c| c.measurand.name == "alpha")
            .unwrap();
        (channel.rate, channel.noise)
    };
    let base = 0.1_f64.to_radians();
    assert_eq!(alpha(0).0, 10.0);
    assert!((alpha(3).1 - 2.0 * base).abs() < 1e-15 && alpha(3).0 == 50.0);
    assert_eq!(study.cases().len(), 16);
}

/// Every problem of a study file at once, each under its field, the file named.
#[test]
fn bad_study_names_file_and_every_field() {
    let text = r#"
name = "bad"
scenarios = ["attas-lateral-multistep", "nowhere"]
profile = "no-such-profile"
models = ["attas-lateral", "zzz"]
methods = ["oem", "magic"]
runs = 0
seed = 1
[sweep]
noise_scale = [1.0, -2.0]
sample_rate = ["fast", "0 Hz"]
"#;
    let path = study_file("mc-bad", text);
    let error = Study::load(path.to_str().unwrap()).unwrap_err();
    let message = error.to_string();
    let Error::Invalid {
        path: named,
        problems,
    } = &error
    else {
        panic!("expected a validation error, got {message}");
    };
    assert_eq!(named, &path);
    let fields: Vec<&str> = problems.iter().map(|p| p.field.as_str()).collect();
    for field in [
        "scenarios[1]",
        "models[1]",
        "profile",
        "methods[1]",
        "runs",
        "sweep.sample_rate[0]",
        "sweep.sample_rate[1]",
        "sweep.noise_scale[1]",
    ] {
        assert!(fields.contains(&field), "{field} missing in {message}");
    }
    assert_eq!(fields.len(), 8, "{message}");
    assert!(message.contains("unknown scenario 'nowhere'"), "{message}");
    assert!(message.contains("unknown recorder profile 'no-such-profile'"));
    assert!(
        message.contains("unknown model structure 'zzz'"),
        "{message}"
    );
    assert!(message.contains("unknown method 'magic'; known: ee, swr, oem"));

    let typo = study_file("mc-typo", &SMALL.replace("runs = 4", "runs = 4\nrun = 5"));
    let message = Study::load(typo.to_str().unwrap()).unwrap_err().to_string();
    assert!(
        message.contains("study.toml") && message.contains("unknown field `run`"),
        "{message}"
    );
    let unknown = Study::load("no-such-study").unwrap_err().to_string();
    assert!(
        unknown.contains("unknown study 'no-such-study'")
            && unknown.contains("attas-lateral-acceptance"),
        "{unknown}"
    );
}
