//! The plug-in protocol's overhead: one round trip of a plug-in that does
//! nothing (write the problem and the record folder, start `sh`, read its
//! estimate back) on the ATTAS lateral record (60 s at 25 Hz), and its two
//! writes alone.

use aeroid::estimation::estimator::Estimator;
use aeroid::estimation::plugin::Plugin;
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;
use criterion::{Criterion, criterion_group, criterion_main};

fn round_trip(c: &mut Criterion) {
    let folder = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("aeroid-bench-plugin-{}", std::process::id()));
    std::fs::create_dir_all(&folder).unwrap();
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let parameters: Vec<String> = structure
        .free_names()
        .iter()
        .map(|name| format!("{{\"name\": \"{name}\", \"value\": 0.1, \"standard_error\": 0.01}}"))
        .collect();
    std::fs::write(
        folder.join("estimate.json"),
        format!(
            "{{\"format\": \"aeroid-plugin-estimate-1\", \"status\": \"converged\", \"parameters\": [{}]}}",
            parameters.join(", ")
        ),
    )
    .unwrap();
    std::fs::write(folder.join("noop.sh"), "cp estimate.json \"$1/\"\n").unwrap();
    std::fs::write(
        folder.join("noop.toml"),
        "command = [\"sh\", \"noop.sh\"]\n",
    )
    .unwrap();
    std::fs::write(
        folder.join("noop-json.toml"),
        "command = [\"sh\", \"noop.sh\"]\nrecord_folders = false\n",
    )
    .unwrap();
    let plugin = Plugin::load(&folder.join("noop.toml")).unwrap();
    let json_only = Plugin::load(&folder.join("noop-json.toml")).unwrap();
    let scenario = Scenario::load("attas-lateral-multistep").unwrap();
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    let (record, _) = record_scenario(&scenario, &profile).unwrap();
    let problem = aeroid::estimation::registry::Registry::built_in()
        .problem("ee", vec![record], structure, &[])
        .unwrap();
    c.bench_function("plugin round trip (no-op, ATTAS lateral record)", |b| {
        b.iter(|| plugin.estimate(&problem, None).unwrap())
    });
    c.bench_function("plugin round trip (no-op, problem.json only)", |b| {
        b.iter(|| json_only.estimate(&problem, None).unwrap())
    });
    // The two writes of the round trip alone, each into a new file as in a
    // work folder (rewriting a file in place costs a flush on ext4).
    let problem_path = folder.join("problem.json");
    c.bench_function("plugin problem.json written (ATTAS lateral record)", |b| {
        b.iter(|| {
            let _ = std::fs::remove_file(&problem_path);
            problem.write_json(&problem_path).unwrap()
        })
    });
    let record_folder = folder.join("record-0");
    c.bench_function("plugin record folder written (ATTAS lateral record)", |b| {
        b.iter(|| {
            let _ = std::fs::remove_dir_all(&record_folder);
            problem.records[0].write(&record_folder).unwrap()
        })
    });
    let _ = std::fs::remove_dir_all(&folder);
}

criterion_group!(benches, round_trip);
criterion_main!(benches);
