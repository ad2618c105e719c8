//! Sizes and bounds: a file that would make aeroid allocate beyond its memory
//! budget, or that asks for a step, duration, rate, lag or number of runs
//! beyond its bound, gets a clean error naming the file, the field and the
//! bound — never a panic (exit 101) or an allocation abort (SIGABRT); and
//! nonsense a file can state (an impossible inertia, a recorder without
//! channels, infinite cells, an empty record) is refused, not flown.

use crate::common;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::Profile;
use aeroid::sim::Error;
use aeroid::sim::aircraft::Aircraft;
use aeroid::sim::scenario::Scenario;
use aeroid::units::DEG;
use std::path::PathBuf;
use std::process::Command;

const MANIFEST: &str = env!("CARGO_MANIFEST_DIR");

fn bundled(path: &str) -> String {
    std::fs::read_to_string(format!("{MANIFEST}/{path}")).unwrap()
}

/// The bundled `attas-trim` scenario with `edit` applied, written to a fresh folder.
fn scenario_with(test: &str, edit: impl Fn(String) -> String) -> PathBuf {
    let folder = common::temp_folder(test);
    common::write(
        &folder,
        "scenario.toml",
        &edit(bundled("scenarios/attas-trim.toml")),
    )
}

/// The bundled `attas-elevator-3211` scenario with `edit` applied.
fn input_scenario_with(test: &str, edit: impl Fn(String) -> String) -> PathBuf {
    let folder = common::temp_folder(test);
    common::write(
        &folder,
        "scenario.toml",
        &edit(bundled("scenarios/attas-elevator-3211.toml")),
    )
}

/// An error of a file that does not validate, from the simulator or the
/// recorder: its problems and its message.
trait Validation: std::fmt::Display {
    fn problem_list(&self) -> Option<&[aeroid::error::FieldError]>;
}

impl Validation for aeroid::sim::Error {
    fn problem_list(&self) -> Option<&[aeroid::error::FieldError]> {
        self.field_errors()
    }
}

impl Validation for aeroid::record::Error {
    fn problem_list(&self) -> Option<&[aeroid::error::FieldError]> {
        self.field_errors()
    }
}

/// The problems of a validation error as `field: message` lines.
fn problems(error: &impl Validation) -> Vec<String> {
    match error.problem_list() {
        Some(problems) => problems.iter().map(|p| p.to_string()).collect(),
        None => panic!("expected a validation error, got {error}"),
    }
}

/// The one problem of a validation error, which must name `path`.
fn only_problem(error: &impl Validation, path: &std::path::Path) -> String {
    let message = error.to_string();
    assert!(
        message.starts_with(&path.display().to_string()),
        "{message}"
    );
    let problems = problems(error);
    assert_eq!(problems.len(), 1, "{problems:?}");
    problems[0].clone()
}

fn aeroid(args: &[&str], budget: Option<&str>) -> std::process::Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_aeroid"));
    command.args(args).env("AEROID_DATA", MANIFEST);
    match budget {
        Some(budget) => command.env("AEROID_MEMORY_BUDGET", budget),
        None => command.env_remove("AEROID_MEMORY_BUDGET"),
    };
    command.output().unwrap()
}

/// Exit code 1 (not a panic's 101 or a signal) and the stderr.
fn failure(output: std::process::Output) -> String {
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

// --- Step, duration and the simulation's memory -----------------------------

/// A step of 1e-300 s (and 1e-20 s, 5e-324 s, the smallest double) made the
/// simulator index out of bounds; 1e-9 s asked for terabytes. Each is below
/// the smallest step, refused when the scenario is read.
#[test]
fn a_step_below_a_microsecond_is_refused() {
    for (step, shown) in [
        ("1e-300", "1e-300"),
        ("1e-20", "1e-20"),
        ("5e-324", "5e-324"),
        ("\"1e-9 s\"", "1e-9"),
    ] {
        let path = scenario_with("tiny-step", |t| {
            t.replace("step = \"0.01 s\"", &format!("step = {step}"))
        });
        let error = Scenario::load(path.to_str().unwrap()).unwrap_err();
        assert_eq!(
            only_problem(&error, &path),
            format!(
                "step: {shown} s is below the smallest step 1e-6 s (RK4 is exact to round-off there; a smaller step only adds round-off and samples)"
            )
        );
    }
}

/// `duration = "1e9 s"` asked for 4.8 TB of truth trace.
#[test]
fn a_duration_beyond_any_endurance_is_refused() {
    let path = scenario_with("long-duration", |t| {
        t.replace("duration = \"60 s\"", "duration = \"1e9 s\"")
    });
    let error = Scenario::load(path.to_str().unwrap()).unwrap_err();
    assert_eq!(
        only_problem(&error, &path),
        "duration: 1000000000 s is above the longest duration 100000 s (longer than any aircraft's endurance)"
    );
}

/// Within the bounds, a simulation that would not fit the memory budget is
/// refused with its samples, bytes and the budget (10¹¹ steps fit no machine).
#[test]
fn a_simulation_beyond_the_memory_budget_is_refused_with_the_numbers() {
    let path = scenario_with("huge-simulation", |t| {
        t.replace("duration = \"60 s\"", "duration = \"100000 s\"")
            .replace("step = \"0.01 s\"", "step = \"1e-6 s\"")
    });
    let error = Scenario::load(path.to_str().unwrap()).unwrap_err();
    let problem = only_problem(&error, &path);
    assert!(
        problem.starts_with(&format!(
            "duration: the simulation (duration / step + 1 samples) would need 100000000001 × {} bytes = ",
            aeroid::sim::scenario::BYTES_PER_STEP
        )) && problem.contains("TB, more than the memory budget of "),
        "{problem}"
    );

    // A scenario changed after loading is checked again before anything is allocated.
    let mut scenario = Scenario::load("attas-trim").unwrap();
    scenario.step = 1e-300;
    let error = aeroid::sim::Simulation::prepare(&scenario).unwrap_err();
    assert!(
        problems(&error)[0].starts_with("step: 1e-300 s is below the smallest step 1e-6 s"),
        "{error}"
    );
    let error = aeroid::sim::simulate(&scenario).unwrap_err();
    assert!(error.to_string().contains("1e-300 s"), "{error}");
}

/// The budget comes from `AEROID_MEMORY_BUDGET` when set: a 60 s flight at
/// 0.01 s does not fit 1 MB, and `check`, `simulate` say so with the numbers
/// and exit 1; a budget that is not a size is an error saying what it holds.
#[test]
fn cli_refuses_a_simulation_beyond_the_budget_variable() {
    let steps = 6001;
    let bytes = steps * aeroid::sim::scenario::BYTES_PER_STEP;
    let out = common::temp_folder("cli-budget").join("trace.csv");
    let out = out.to_str().unwrap();
    for command in [
        &["check", "scenarios/attas-trim.toml"][..],
        &["simulate", "scenarios/attas-trim.toml", "--out", out],
    ] {
        let stderr = failure(aeroid(command, Some("1MB")));
        for expected in [
            "scenarios/attas-trim.toml",
            &format!(
                "duration: the simulation (duration / step + 1 samples) would need {steps} × {} bytes = {:.1} MB, more than the memory budget of 1.0 MB (AEROID_MEMORY_BUDGET=1MB)",
                aeroid::sim::scenario::BYTES_PER_STEP,
                bytes as f64 / 1e6
            ),
        ] {
            assert!(
                stderr.contains(expected),
                "{command:?}: {expected}: {stderr}"
            );
        }
    }
    let stderr = failure(aeroid(
        &["check", "scenarios/attas-trim.toml"],
        Some("lots"),
    ));
    assert!(
        stderr.contains("AEROID_MEMORY_BUDGET='lots' is not a memory size"),
        "{stderr}"
    );
    let output = aeroid(&["check", "scenarios/attas-trim.toml"], Some("1GB"));
    assert!(output.status.success(), "{output:?}");
}

/// The CLI on a scenario with a step of 1e-300 s: exit 1 naming the file and
/// the field, not the simulator's index-out-of-bounds panic.
#[test]
fn cli_simulate_with_a_tiny_step_fails_cleanly() {
    let path = scenario_with("cli-tiny-step", |t| {
        t.replace("step = \"0.01 s\"", "step = 1e-300")
    });
    let out = path.with_file_name("trace.csv");
    let stderr = failure(aeroid(
        &[
            "simulate",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        None,
    ));
    assert!(
        stderr.contains(&path.display().to_string())
            && stderr.contains("step: 1e-300 s is below the smallest step 1e-6 s"),
        "{stderr}"
    );
}

// --- Recorder profiles -------------------------------------------------------

fn profile_with(
    test: &str,
    edit: impl Fn(String) -> String,
) -> (PathBuf, aeroid::record::Result<Profile>) {
    let folder = common::temp_folder(test);
    let path = common::write(
        &folder,
        "profile.toml",
        &edit(bundled("recorders/ideal.toml")),
    );
    let profile = Profile::load(path.to_str().unwrap(), None);
    (path, profile)
}

/// A channel at 1e9 Hz asked for gigabytes per channel; the rate is bounded.
#[test]
fn a_recorder_rate_beyond_any_flight_test_system_is_refused() {
    let (path, profile) = profile_with("fast-rate", |t| {
        t.replacen("rate = \"100 Hz\"", "rate = \"1e9 Hz\"", 1)
    });
    assert_eq!(
        only_problem(&profile.unwrap_err(), &path),
        "channels.airspeed.rate: 1000000000 Hz is above the highest rate 10000 Hz (far above any flight-test system's sampling of aircraft motion)"
    );
}

/// A profile changed after loading (a study's rate sweep) is checked against
/// the memory budget before the record is allocated.
#[test]
fn a_record_beyond_the_memory_budget_is_refused_with_the_numbers() {
    let scenario = Scenario::load("attas-trim").unwrap();
    let (trace, _) = aeroid::sim::fly(&scenario).unwrap();
    let profile = Profile::load("ideal", None).unwrap().with_rate(1e12);
    let error = profile.record(&trace, &scenario.aircraft, 1).unwrap_err();
    let problem = problems(&error).remove(0);
    assert!(
        problem.starts_with("channels.rate: the record of profile ideal@1000000000000Hz (channel rate × duration samples) would need ")
            && problem.contains(" × 16 bytes = ")
            && problem.contains("more than the memory budget of"),
        "{problem}"
    );
}

/// No channels, a NaN scale factor (every sample a dropout) and a lag of
/// 1e308 s were accepted.
#[test]
fn recorder_profiles_without_channels_or_with_nonsense_settings_are_refused() {
    let (path, profile) = profile_with("no-channels", |t| {
        t.split("[[channels]]").next().unwrap().to_string() + "channels = []\n"
    });
    assert_eq!(
        only_problem(&profile.unwrap_err(), &path),
        "channels: must list at least one channel (a [[channels]] table): a recorder without channels records nothing"
    );

    let (path, profile) = profile_with("nan-scale", |t| {
        t.replacen(
            "rate = \"100 Hz\"",
            "rate = \"100 Hz\"\nscale_factor = nan",
            1,
        )
    });
    assert_eq!(
        only_problem(&profile.unwrap_err(), &path),
        "channels.airspeed.scale_factor: must be a finite number, is NaN"
    );

    let (_, profile) = profile_with("huge-lag", |t| {
        t.replacen("rate = \"100 Hz\"", "rate = \"100 Hz\"\nlag = 1e308", 1)
            .replacen(
                "name = \"alpha\"\nrate = \"100 Hz\"",
                "name = \"alpha\"\nrate = \"100 Hz\"\ndelay = \"1000 s\"",
                1,
            )
    });
    assert_eq!(
        problems(&profile.unwrap_err()),
        [
            "channels.airspeed.lag: 1e308 s is above the longest 100 s (longer than the slowest aircraft mode's period: such a sensor records no motion)",
            "channels.alpha.delay: 1000 s is above the longest 100 s (longer than the slowest aircraft mode's period: such a sensor records no motion)",
        ]
    );
    let (_, profile) = profile_with("infinite-noise", |t| {
        t.replacen("rate = \"100 Hz\"", "rate = \"100 Hz\"\nnoise = inf", 1)
    });
    assert_eq!(
        problems(&profile.unwrap_err()),
        ["channels.airspeed.noise: inf is not a finite number"]
    );
}

/// `aeroid check` refuses the same profile: exit 1 naming the file and field.
#[test]
fn cli_check_refuses_a_fast_profile_and_a_huge_study() {
    let (path, _) = profile_with("cli-fast-rate", |t| {
        t.replacen("rate = \"100 Hz\"", "rate = \"1e9 Hz\"", 1)
    });
    let stderr = failure(aeroid(&["check", path.to_str().unwrap()], None));
    assert!(
        stderr.contains(&path.display().to_string())
            && stderr.contains(
                "channels.airspeed.rate: 1000000000 Hz is above the highest rate 10000 Hz"
            ),
        "{stderr}"
    );
    let folder = common::temp_folder("cli-study-runs");
    let path = common::write(
        &folder,
        "study.toml",
        &bundled("studies/attas-lateral-acceptance.toml")
            .replace("runs = 100", "runs = 4000000000"),
    );
    let stderr = failure(aeroid(&["check", path.to_str().unwrap()], None));
    assert!(
        stderr.contains(&path.display().to_string())
            && stderr.contains("runs: 4000000000 is above the most runs per sweep point, 1000000"),
        "{stderr}"
    );
}

// --- Studies -----------------------------------------------------------------

/// `runs = 4000000000` passed validation and aborted allocating the cases.
#[test]
fn a_study_with_billions_of_runs_is_refused() {
    let folder = common::temp_folder("study-runs");
    let path = common::write(
        &folder,
        "study.toml",
        &bundled("studies/attas-lateral-acceptance.toml")
            .replace("runs = 100", "runs = 4000000000"),
    );
    let error = aeroid::eval::study::Study::load(crate::common::registry(), path.to_str().unwrap())
        .unwrap_err();
    let message = error.to_string();
    assert!(
        message.starts_with(&path.display().to_string()),
        "{message}"
    );
    let problems_of_study: Vec<String> = error
        .field_errors()
        .expect("a validation error")
        .iter()
        .map(|p| p.to_string())
        .collect();
    assert_eq!(problems_of_study.len(), 1, "{problems_of_study:?}");
    assert_eq!(
        problems_of_study[0],
        "runs: 4000000000 is above the most runs per sweep point, 1000000 (statistics of a thousand runs are within a few percent; a million runs of a one-second fit take eleven days of one core)"
    );
    let mut study =
        aeroid::eval::study::Study::load(crate::common::registry(), "attas-lateral-acceptance")
            .unwrap();
    let error = study.set_runs(0, "--runs").unwrap_err();
    let problems_of_runs: Vec<String> = error
        .field_errors()
        .expect("a validation error")
        .iter()
        .map(|p| p.to_string())
        .collect();
    assert_eq!(problems_of_runs, ["--runs: must be at least 1"]);
    study.set_runs(3, "--runs").unwrap();
    assert_eq!(study.runs, 3);
}

/// `aeroid study NAME --runs 100000000000` aborted; now exit 1 naming the
/// study file and the option.
#[test]
fn cli_study_with_too_many_runs_fails_cleanly() {
    let stderr = failure(aeroid(
        &[
            "study",
            "attas-lateral-acceptance",
            "--runs",
            "100000000000",
        ],
        None,
    ));
    for expected in [
        "studies/attas-lateral-acceptance.toml",
        "--runs: 100000000000 is above the most runs per sweep point, 1000000",
    ] {
        assert!(stderr.contains(expected), "{expected}: {stderr}");
    }
    // Within the bound but beyond a small budget: the numbers.
    let stderr = failure(aeroid(
        &["study", "attas-lateral-acceptance", "--runs", "1000000"],
        Some("10MB"),
    ));
    assert!(
        stderr.contains("--runs: the study (1 sweep point(s) × 1000000 runs")
            && stderr
                .contains("more than the memory budget of 10.0 MB (AEROID_MEMORY_BUDGET=10MB)"),
        "{stderr}"
    );
}

// --- Aircraft inertia -------------------------------------------------------

fn aircraft_error(test: &str, edit: impl Fn(String) -> String) -> (PathBuf, Error) {
    let folder = common::temp_folder(test);
    let path = common::write(&folder, "plane.toml", &common::attas_with(edit));
    (path.clone(), Aircraft::load(&path).unwrap_err())
}

/// Ixx + Iyy < Izz (or any permutation): no rigid body has it, so `check`
/// and loading refuse it, naming the largest moment.
#[test]
fn an_inertia_that_violates_the_triangle_inequality_is_refused() {
    for (edit, field) in [
        (("izz = \"3.59593e5", "izz = \"5.0e5"), "mass.izz"),
        (("ixx = \"1.33367e5", "ixx = \"7.0e5"), "mass.ixx"),
        (("iyy = \"2.52687e5", "iyy = \"6.0e5"), "mass.iyy"),
    ] {
        let (path, error) = aircraft_error("triangle", |t| t.replace(edit.0, edit.1));
        let problem = only_problem(&error, &path);
        assert!(
            problem.starts_with(&format!(
                "{field}: no rigid body has these moments of inertia"
            )) && problem.contains(
                "violate the triangle inequality (each must be at most the sum of the other two"
            ) && problem.contains("give the reason in mass.impossible_inertia"),
            "{problem}"
        );
    }
    // Non-positive moments and an Ixz that breaks positive definiteness.
    let (_, error) = aircraft_error("negative-moment", |t| {
        t.replace("iyy = \"2.52687e5", "iyy = \"-2.52687e5")
    });
    assert!(
        problems(&error)[0].starts_with("mass: the inertia tensor is not positive definite"),
        "{error}"
    );

    let folder = common::temp_folder("triangle-cli");
    let path = common::write(
        &folder,
        "plane.toml",
        &common::attas_with(|t| t.replace("izz = \"3.59593e5", "izz = \"5.0e5")),
    );
    let stderr = failure(aeroid(&["check", path.to_str().unwrap()], None));
    assert!(
        stderr.contains("mass.izz: no rigid body has these moments of inertia"),
        "{stderr}"
    );
}

/// A paper's published moments that violate the inequality fly when the
/// file says why (`mass.impossible_inertia`), as the bundled CDRW does.
#[test]
fn published_impossible_inertia_flies_when_the_file_says_why() {
    let folder = common::temp_folder("triangle-accepted");
    let path = common::write(
        &folder,
        "plane.toml",
        &common::attas_with(|t| {
            t.replace(
                "izz = \"3.59593e5 kg*m2\"",
                "izz = \"5.0e5 kg*m2\"\nimpossible_inertia = \"as published\"",
            )
        }),
    );
    let aircraft = Aircraft::load(&path).unwrap();
    assert_eq!(aircraft.mass.inertia[(2, 2)], 5.0e5);
    Aircraft::load(&PathBuf::from(format!("{MANIFEST}/aircraft/cdrw.toml"))).unwrap();
    let (_, error) = aircraft_error("triangle-empty-reason", |t| {
        t.replace(
            "izz = \"3.59593e5 kg*m2\"",
            "izz = \"5.0e5 kg*m2\"\nimpossible_inertia = \" \"",
        )
    });
    assert!(problems(&error)[0].starts_with("mass.izz:"), "{error}");
}

// --- Inputs ------------------------------------------------------------------

/// A 3211 of 1e308 deg and an input starting at −5 s were flown.
#[test]
fn inputs_beyond_a_controls_range_or_before_the_flight_are_refused() {
    let path = input_scenario_with("huge-amplitude", |t| {
        t.replace("amplitude = \"-1.5 deg\"", "amplitude = \"1e308 deg\"")
    });
    let error = Scenario::load(path.to_str().unwrap()).unwrap_err();
    assert_eq!(
        only_problem(&error, &path),
        "inputs[0].amplitude: 1e308 deg is beyond the elevator input's largest magnitude 90 deg (no control surface deflects further)"
    );

    let path = input_scenario_with("negative-start", |t| {
        t.replace("start = \"3 s\"", "start = \"-5 s\"")
    });
    let error = Scenario::load(path.to_str().unwrap()).unwrap_err();
    assert_eq!(
        only_problem(&error, &path),
        "inputs[0].start: -5 s is before the flight begins at 0 s; an input starts at 0 s or later"
    );

    let path = input_scenario_with("doublet", |t| {
        let at = t.find("[[inputs]]").unwrap();
        let end = t[at..].find("amplitude").unwrap() + at;
        let end = end + t[end..].find('\n').unwrap();
        format!(
            "{}[[inputs]]\nkind = \"doublet\"\ncontrol = \"throttle\"\nstart = \"1 s\"\npulse_width = \"1 s\"\namplitude = 2.5\n{}",
            &t[..at],
            &t[end + 1..]
        )
    });
    let error = Scenario::load(path.to_str().unwrap()).unwrap_err();
    assert_eq!(
        only_problem(&error, &path),
        "inputs[0].amplitude: 2.5 is beyond the throttle input's largest magnitude 1, the whole range of thrust"
    );
    // Within range, a doublet still flies.
    let scenario = Scenario::load("attas-elevator-3211").unwrap();
    assert!(scenario.inputs.deviation(4.0)[0].abs() <= 1.5 * DEG + 1e-12);
}

// --- Import and records ------------------------------------------------------

const CSV: &str = "Time,AOA,IAS\n0.0,2.5,200\n0.5,2.6,201\n1.0,2.7,202\n";

const MAP: &str = r#"
[time]
column = "Time"
[[channels]]
name = "alpha"
column = "AOA"
unit = "deg"
[[channels]]
name = "airspeed"
column = "IAS"
unit = "kt"
"#;

/// `inf` and `1e400` cells were stored as infinities: each is an error
/// naming the file, line and column, and how to map them to dropouts.
#[test]
fn import_refuses_non_finite_cells_unless_mapped_to_dropouts() {
    for (cell, reads) in [
        ("inf", "inf"),
        ("1e400", "inf"),
        ("-inf", "-inf"),
        ("NaN", "NaN"),
    ] {
        let csv = CSV.replace("2.6", cell);
        let error = common::import_case("import-inf", &csv, MAP).unwrap_err();
        let message = error.to_string();
        assert!(
            message.ends_with(&format!(
                "flight.csv: line 3, column 'AOA': '{cell}' reads as {reads}, not a finite number; to record such cells as dropouts, set non_finite = \"dropout\" for channel 'alpha' in {}",
                std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
                    .join(format!("aeroid-import-inf-{}", std::process::id()))
                    .join("map.toml")
                    .display()
            )),
            "{message}"
        );
    }
    let map = MAP.replace("unit = \"deg\"", "unit = \"deg\"\nnon_finite = \"dropout\"");
    let outcome =
        common::import_case("import-inf-dropout", &CSV.replace("2.6", "1e400"), &map).unwrap();
    let alpha = outcome.record.channel("alpha").unwrap();
    assert_eq!(alpha.times, [0.0, 0.5, 1.0]);
    assert!(alpha.values[1].is_nan() && alpha.dropouts() == 1);
    assert!((alpha.values[2] - 2.7 * DEG).abs() < 1e-15);
}

/// A header-only CSV was "3 channels imported"; a map without channels is refused.
#[test]
fn import_refuses_a_csv_without_data_rows_and_a_map_without_channels() {
    let error = common::import_case("import-header-only", "Time,AOA,IAS\n", MAP).unwrap_err();
    let message = error.to_string();
    assert!(
        message.ends_with(
            "flight.csv: line 1, column '': the file has a header but no data rows; a record needs samples"
        ),
        "{message}"
    );
    let map = "channels = []\n".to_string() + MAP.split("[[channels]]").next().unwrap();
    let error = common::import_case("import-no-channels", CSV, &map).unwrap_err();
    assert_eq!(
        problems(&error),
        ["channels: must map at least one column to a channel ([[channels]] tables)"]
    );
    let map = MAP.replace("unit = \"kt\"", "unit = \"kt\"\noffset = inf");
    let error = common::import_case("import-infinite-offset", CSV, &map).unwrap_err();
    assert_eq!(
        problems(&error),
        ["channels[1].offset: must be a finite number"]
    );
}

/// A record folder with no channels, or a channel with no samples, is
/// refused where it is read (and before it is written).
#[test]
fn an_empty_record_is_refused_where_it_is_read() {
    let folder = common::temp_folder("empty-record");
    let record = common::import_case("empty-record-source", CSV, MAP)
        .unwrap()
        .record;
    record.write(&folder).unwrap();
    let text = std::fs::read_to_string(folder.join("record.toml")).unwrap();
    let header = text.split("[[channels]]").next().unwrap().to_string();
    std::fs::write(folder.join("record.toml"), header + "channels = []\n").unwrap();
    let error = FlightRecord::read(&folder).unwrap_err();
    assert_eq!(
        only_problem(&error, &folder.join("record.toml")),
        "channels: the record has no channels; a record needs at least one"
    );

    std::fs::write(folder.join("record.toml"), &text).unwrap();
    let csv = std::fs::read_dir(&folder)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "csv"))
        .unwrap();
    let samples = std::fs::read_to_string(&csv).unwrap();
    let header_line = samples.lines().next().unwrap().to_string();

    // A record's cells are numbers or empty (a dropout), never infinities.
    let second = samples.lines().nth(2).unwrap();
    let mut cells: Vec<&str> = second.split(',').collect();
    cells[1] = "1e400";
    std::fs::write(&csv, samples.replace(second, &cells.join(","))).unwrap();
    let message = FlightRecord::read(&folder).unwrap_err().to_string();
    assert!(
        message.contains(&format!("{}: line 3, column 'alpha [rad]': '1e400' reads as inf, not a finite number; a record stores a lost sample (dropout) as an empty cell", csv.display())),
        "{message}"
    );
    std::fs::write(&csv, header_line + "\n").unwrap();
    let error = FlightRecord::read(&folder).unwrap_err();
    assert_eq!(
        problems(&error),
        [
            "channels[0] (alpha): the channel has no samples",
            "channels[1] (airspeed): the channel has no samples",
        ]
    );

    let mut empty = record.clone();
    empty.channels.clear();
    let error = empty
        .write(&common::temp_folder("empty-record-write"))
        .unwrap_err();
    assert_eq!(
        problems(&error),
        ["channels: the record has no channels; a record needs at least one"]
    );
}

// --- Identifiability ---------------------------------------------------------

/// `--segment "0 s"` quietly analysed the whole flight.
#[test]
fn a_zero_identifiability_segment_is_an_error() {
    let stderr = failure(aeroid(
        &["identifiability", "attas-elevator-3211", "--segment", "0 s"],
        None,
    ));
    assert!(
        stderr.contains("--segment: \"0 s\" must be a positive length of time (e.g. \"20 s\")"),
        "{stderr}"
    );
    let scenario = Scenario::load("attas-elevator-3211").unwrap();
    let profile = Profile::load("ideal", None).unwrap();
    for segment in [0.0, -1.0, 1e-9, f64::NAN] {
        let options = aeroid::analysis::identifiability::IdentifiabilityOptions {
            segment: Some(segment),
            ..Default::default()
        };
        let error =
            aeroid::analysis::identifiability::analyse(&scenario, &profile, &options).unwrap_err();
        assert!(
            error.to_string().starts_with(&format!(
                "segment length {segment} s: a segment must be at least one integration step (0.01 s of "
            )),
            "{error}"
        );
    }
}

/// A finite cell times a finite but huge scale overflows to infinity: the
/// import is refused naming the channel and the sample, not stored as an
/// infinity (found by the property tests).
#[test]
fn import_refuses_values_that_overflow_in_conversion() {
    let map = MAP.replace(
        "name = \"airspeed\"\ncolumn = \"IAS\"\nunit = \"kt\"",
        "name = \"airspeed\"\ncolumn = \"IAS\"\nunit = \"kt\"\nscale = 1e308",
    );
    assert_ne!(map, MAP);
    let message = common::import_case("import-overflow", CSV, &map)
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("(airspeed)") && message.contains("is infinite"),
        "{message}"
    );
}

/// Recorder settings each within their bounds can overflow together (a
/// huge scale factor on a large value): recording is refused naming the
/// profile, the channel and the sample (found by the property tests).
#[test]
fn a_profile_whose_samples_overflow_is_refused() {
    let (path, profile) = profile_with("overflow", |t| {
        t.replacen(
            "rate = \"100 Hz\"",
            "rate = \"100 Hz\"\nscale_factor = 1e308",
            1,
        )
    });
    let profile = profile.unwrap();
    let scenario = Scenario::load("attas-trim").unwrap();
    let (trace, _) = aeroid::sim::fly(&scenario).unwrap();
    let error = profile.record(&trace, &scenario.aircraft, 1).unwrap_err();
    let message = error.to_string();
    assert!(
        message.contains(&path.display().to_string())
            && message.contains("(airspeed)")
            && message.contains("is infinite"),
        "{message}"
    );
}
