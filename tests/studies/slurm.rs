//! The sharded study on a real Slurm cluster: a single-node cluster
//! (controller and node daemon on localhost, `scripts/slurm-local.sh`)
//! runs `scripts/slurm-study.sh` — a job array of shards, then the merge —
//! and the merged files are byte-identical to a one-machine run. Skipped,
//! with the reason printed, where Slurm is not installed or cannot be
//! started (not root); CI installs it (`.ci/run`).

use crate::common;
use std::path::Path;
use std::process::Command;

fn written(folder: &Path) -> Vec<Vec<u8>> {
    ["runs.csv", "summary.csv", "study.json"]
        .iter()
        .map(|name| std::fs::read(folder.join(name)).unwrap())
        .collect()
}

#[test]
fn a_slurm_job_array_merges_to_the_one_machine_result() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    if Command::new("sbatch").arg("--version").output().is_err() {
        println!("SKIPPED: Slurm is not installed (apt-get install slurm-wlm munge)");
        return;
    }
    let started = Command::new(root.join("scripts/slurm-local.sh"))
        .output()
        .unwrap();
    if !started.status.success() {
        println!(
            "SKIPPED: a local Slurm cluster could not be started: {}",
            String::from_utf8_lossy(&started.stderr).trim()
        );
        return;
    }
    let aeroid = env!("CARGO_BIN_EXE_aeroid");
    let folder = common::temp_folder("slurm_study");
    let output = Command::new(root.join("scripts/slurm-study.sh"))
        .env("AEROID", aeroid)
        .args([
            "attas-lateral-acceptance",
            folder.join("array").to_str().unwrap(),
            "3",
            "--runs",
            "5",
        ])
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "slurm-study.sh failed:\n{}\n{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    let one = folder.join("one");
    let status = Command::new(aeroid)
        .args(["study", "attas-lateral-acceptance", "--runs", "5", "--out"])
        .arg(&one)
        .output()
        .unwrap();
    assert!(status.status.success());
    assert_eq!(written(&folder.join("array/merged")), written(&one));
    // Each shard ran as its own array task.
    for k in 1..=3 {
        let log =
            std::fs::read_to_string(folder.join(format!("array/logs/shard-{k}.log"))).unwrap();
        assert!(log.contains(&format!("shard {k}/3")), "{log}");
    }
}
