//! Studies that are interrupted, resumed, split into shards and merged
//! write the same bytes as one uninterrupted run on one machine: every
//! case's numbers depend only on the study seed and the case's index, and
//! the result is assembled in case order from the journal.

use crate::common;
use aeroid::eval::journal::{self, JOURNAL_FILE, Shard};
use aeroid::eval::study::{self, Study};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A small study: the bundled acceptance study with 6 runs per point,
/// equation error only (cheap; the journal does not care which method).
fn study() -> Study {
    let mut study = Study::load(crate::common::registry(), "attas-lateral-acceptance").unwrap();
    study.methods = vec!["ee".into()];
    study.set_runs(6, "runs").unwrap();
    study
}

/// The bytes of the result files a study writes, and of the histories of
/// its one sweep point's first run.
fn written(folder: &Path) -> Vec<Vec<u8>> {
    [
        "runs.csv",
        "summary.csv",
        "study.json",
        "histories/point-00000.json",
    ]
    .iter()
    .map(|name| std::fs::read(folder.join(name)).unwrap())
    .collect()
}

/// One thread, one journal: the reference bytes. The summary of the
/// unjournaled run is the same.
fn reference(study: &Study, folder: &Path) -> Vec<Vec<u8>> {
    study
        .run_journaled(folder, Shard::default(), false, 1, &|_| {})
        .unwrap();
    let result = study::assemble(&[folder.to_path_buf()], folder).unwrap();
    let unjournaled = study.run(2, &|_| {}).unwrap();
    assert_eq!(
        serde_json::to_string(&unjournaled).unwrap(),
        serde_json::to_string(&result).unwrap()
    );
    written(folder)
}

#[test]
fn shards_and_thread_counts_merge_to_the_one_machine_bytes() {
    let root = common::temp_folder("study_journal_shards");
    let study = study();
    let expected = reference(&study, &root.join("one"));
    // Two threads, one journaled shard.
    let whole = root.join("whole");
    study
        .run_journaled(&whole, Shard::default(), false, 2, &|_| {})
        .unwrap();
    study::assemble(std::slice::from_ref(&whole), &whole).unwrap();
    assert_eq!(written(&whole), expected, "two threads, journaled");
    // Four shards of a study with 6 cases: 2, 2, 1, 1 cases.
    let folders: Vec<PathBuf> = (1..=4)
        .map(|index| {
            let folder = root.join(format!("shard{index}"));
            let shard = Shard { index, count: 4 };
            let run = study
                .run_journaled(&folder, shard, false, 2, &|_| {})
                .unwrap();
            assert_eq!(run.ran, if index <= 2 { 2 } else { 1 });
            folder
        })
        .collect();
    let out = root.join("merged");
    study::assemble(&folders, &out).unwrap();
    assert_eq!(written(&out), expected, "four shards merged");
    // A missing shard or a shard given twice is refused.
    let error = study::assemble(&folders[..3], &out)
        .unwrap_err()
        .to_string();
    assert!(error.contains("missing"), "{error}");
    let twice = [folders[0].clone(), folders[0].clone()];
    let error = study::assemble(&twice, &out).unwrap_err().to_string();
    assert!(error.contains("both in"), "{error}");
}

#[test]
fn an_interrupted_study_resumes_without_losing_or_repeating_a_case() {
    let root = common::temp_folder("study_journal_resume");
    let study = study();
    let expected = reference(&study, &root.join("one"));
    let folder = root.join("interrupted");
    study
        .run_journaled(&folder, Shard::default(), false, 2, &|_| {})
        .unwrap();
    // Interrupt: keep the header and two cases, and half of the third line.
    let path = folder.join(JOURNAL_FILE);
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let torn = format!(
        "{}\n{}\n{}\n{}",
        lines[0],
        lines[1],
        lines[2],
        &lines[3][..lines[3].len() / 2]
    );
    std::fs::write(&path, torn).unwrap();
    let (_, finished) = journal::read(&folder).unwrap();
    assert_eq!(finished.len(), 2, "the torn line is dropped");
    // Starting afresh over a journal is refused; resuming runs the other 4.
    let error = study
        .run_journaled(&folder, Shard::default(), false, 2, &|_| {})
        .unwrap_err();
    assert!(error.to_string().contains("--resume"), "{error}");
    let run = study
        .run_journaled(&folder, Shard::default(), true, 2, &|_| {})
        .unwrap();
    assert_eq!((run.resumed, run.ran), (2, 4));
    study::assemble(std::slice::from_ref(&folder), &folder).unwrap();
    assert_eq!(written(&folder), expected);
    // The journal now holds each case once.
    let (_, finished) = journal::read(&folder).unwrap();
    assert_eq!(finished.len(), 6);
    // A journal of another study (other runs) is not resumed.
    let mut other = study.clone();
    other.set_runs(7, "runs").unwrap();
    let error = other
        .run_journaled(&folder, Shard::default(), true, 2, &|_| {})
        .unwrap_err();
    assert!(error.to_string().contains("another study"), "{error}");
}

#[test]
fn a_damaged_journal_names_its_file_and_line() {
    let root = common::temp_folder("study_journal_damaged");
    let study = study();
    let folder = root.join("damaged");
    study
        .run_journaled(&folder, Shard::default(), false, 2, &|_| {})
        .unwrap();
    let path = folder.join(JOURNAL_FILE);
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    lines[2] = "{\"case\": \"x\"}".into();
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    let error = journal::read(&folder).unwrap_err().to_string();
    assert!(error.contains("cases.jsonl:3"), "{error}");
}

#[test]
fn shard_option_parses_and_rejects_nonsense() {
    assert_eq!(Shard::parse("2/8").unwrap(), Shard { index: 2, count: 8 });
    for bad in ["0/4", "5/4", "1", "a/b", "1/0"] {
        assert!(Shard::parse(bad).is_err(), "{bad}");
    }
}

#[test]
fn cli_shards_merge_to_the_one_machine_files() {
    let root = common::temp_folder("study_journal_cli");
    let aeroid = || Command::new(env!("CARGO_BIN_EXE_aeroid"));
    let study = |extra: &[&str]| {
        let output = aeroid()
            .args([
                "study",
                "attas-lateral-acceptance",
                "--runs",
                "3",
                "--threads",
                "2",
            ])
            .args(extra)
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        // Not a terminal: progress comes as lines, the last one at the end.
        let progress = String::from_utf8_lossy(&output.stderr);
        assert!(
            progress.contains("cases/s") && progress.contains("eta"),
            "{progress}"
        );
        String::from_utf8_lossy(&output.stdout).to_string()
    };
    let one = root.join("one");
    let text = study(&["--out", one.to_str().unwrap(), "--report"]);
    assert!(
        text.contains("report.html") && one.join("report.html").is_file(),
        "{text}"
    );
    let mut shards = Vec::new();
    for k in 1..=2 {
        let folder = root.join(format!("s{k}"));
        let text = study(&[
            "--out",
            folder.to_str().unwrap(),
            "--shard",
            &format!("{k}/2"),
        ]);
        assert!(text.contains("aeroid study merge"), "{text}");
        shards.push(folder.to_str().unwrap().to_string());
    }
    let merged = root.join("merged");
    let output = aeroid()
        .args([
            "study",
            "merge",
            "--report",
            "--out",
            merged.to_str().unwrap(),
        ])
        .args(&shards)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert_eq!(written(&merged), written(&one));
    // The merged report draws the histories its shards kept.
    let page = std::fs::read_to_string(merged.join("report.html")).unwrap();
    assert!(page.contains("proof of match"));
    // Merging one shard of two fails with a reason, exit code non-zero.
    let output = aeroid()
        .args([
            "study",
            "merge",
            "--out",
            root.join("bad").to_str().unwrap(),
        ])
        .arg(&shards[0])
        .output()
        .unwrap();
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains("missing"));
}

/// The fingerprint that shards and resumes must share covers what a
/// scenario reads, not only its file: a pilot-input CSV edited between
/// two shards changes it, so the shards are not merged across the edit.
#[test]
fn the_fingerprint_covers_a_pilot_input_csv() {
    let folder = common::temp_folder("fingerprint_csv");
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/attas-elevator-3211.toml"
    ))
    .unwrap();
    let text = format!(
        "{text}\n[[inputs]]\nkind = \"csv\"\ncontrol = \"rudder\"\nfile = \"pilot.csv\"\ncolumn = \"rudder\"\nunit = \"deg\"\n"
    );
    let scenario = common::write(&folder, "replayed.toml", &text);
    let fingerprint = |csv: &str| {
        common::write(&folder, "pilot.csv", csv);
        let mut study = study();
        study.scenarios =
            vec![aeroid::sim::scenario::Scenario::load(scenario.to_str().unwrap()).unwrap()];
        study.fingerprint().unwrap()
    };
    let first = fingerprint("time,rudder\n0,0\n10,1\n20,0\n");
    assert_eq!(first, fingerprint("time,rudder\n0,0\n10,1\n20,0\n"));
    assert_ne!(first, fingerprint("time,rudder\n0,0\n10,2\n20,0\n"));
    std::fs::remove_dir_all(&folder).unwrap();
}
