//! The command line as a user meets it: what it prints, where it finds its
//! files and how it ends. Each test runs the built `aeroid` binary.

use crate::common;
use std::io::Read;
use std::process::{Command, Stdio};

pub(crate) fn aeroid() -> Command {
    Command::new(env!("CARGO_BIN_EXE_aeroid"))
}

/// The output of a command that must succeed.
pub(crate) fn stdout_of(command: &mut Command) -> String {
    let output = command.output().unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout).unwrap()
}

/// A reader that goes away (`aeroid list | head -1`) ends the program
/// quietly: exit 0 and nothing on stderr, not a panic about a broken pipe
/// (exit 101). The read end of the pipe is closed before aeroid writes.
#[test]
fn a_closed_pipe_ends_the_program_quietly() {
    let mut child = aeroid()
        .arg("list")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let mut stderr = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut stderr)
        .unwrap();
    let status = child.wait().unwrap();
    assert!(stderr.is_empty(), "{stderr}");
    assert_eq!(status.code(), Some(0), "{stderr}");
}

/// `estimate --model` takes a model structure by name, so `aeroid list`
/// shows the bundled model structures beside the aircraft and scenarios.
#[test]
fn list_shows_the_model_structures() {
    let text = stdout_of(aeroid().arg("list"));
    for expected in [
        "aircraft:",
        "scenarios:",
        "recorders:",
        "models:\n",
        "  attas-lateral\n",
        "studies:",
    ] {
        assert!(text.contains(expected), "{expected}: {text}");
    }
}

/// `check` validates model-structure files too, and its help says so; the
/// top-level help names the data folder's environment variable.
#[test]
fn help_names_model_structures_and_the_data_folder_variable() {
    let check = stdout_of(aeroid().args(["check", "--help"]));
    assert!(check.contains("model-structure"), "{check}");
    let top = stdout_of(aeroid().arg("--help"));
    assert!(top.contains("AEROID_DATA"), "{top}");
}

/// `aeroid --help` lists each subcommand in one line; its paragraph stays
/// in `aeroid help CMD` (and `CMD --help`).
#[test]
fn top_level_help_gives_each_subcommand_one_line() {
    let top = stdout_of(aeroid().arg("--help"));
    let commands: Vec<&str> = top
        .split("Commands:")
        .nth(1)
        .and_then(|rest| rest.split("\n\n").next())
        .unwrap_or_else(|| panic!("{top}"))
        .lines()
        .filter(|line| !line.is_empty())
        .collect();
    assert!(commands.len() >= 19, "{top}");
    for line in &commands {
        assert!(
            line.starts_with("  ") && line.split_whitespace().count() > 1,
            "a subcommand's help runs over one line: {line:?}\n{top}"
        );
        assert!(line.chars().count() <= 100, "{line}");
    }
    let study = stdout_of(aeroid().args(["help", "study"]));
    assert!(
        study.contains("--resume continues an interrupted study"),
        "{study}"
    );
}

/// The gate file is found through the data folder, like scenarios: from a
/// folder that is not the repository (the data folder is then the source
/// tree), and from the folder `AEROID_DATA` names (there a file without
/// cases, refused naming that file: an empty gate file gates nothing and
/// never passes).
#[test]
fn gate_finds_its_file_through_the_data_folder() {
    let elsewhere = common::temp_folder("cli-gate-elsewhere");
    let output = aeroid()
        .args(["gate", "--only", "no case has this name"])
        .current_dir(&elsewhere)
        .env_remove("AEROID_DATA")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success() && stderr.contains("cases: attas-longitudinal-ideal-oem"),
        "{stderr}"
    );

    let data = common::temp_folder("cli-gate-data");
    std::fs::create_dir_all(data.join("golden")).unwrap();
    common::write(&data.join("golden"), "gates.toml", "case = []\n");
    let output = aeroid()
        .arg("gate")
        .current_dir(&elsewhere)
        .env("AEROID_DATA", &data)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    let path = data.join("golden").join("gates.toml");
    assert!(
        !output.status.success()
            && stderr.contains(&path.display().to_string())
            && stderr.contains("no [[case]]"),
        "{stderr}"
    );
}

/// A scenario that names no model structures has nothing to estimate: `run`
/// says so and prints no (empty) table header.
#[test]
fn run_without_models_prints_no_table_header() {
    let text = stdout_of(aeroid().args(["run", "attas-trim"]));
    assert!(text.contains("nothing to estimate"), "{text}");
    assert!(!text.contains("inside 95 %"), "{text}");
}

/// `run --derive` on the QAR: the raw record has no rates, true airspeed or
/// combined surfaces, so without the derive step every estimator refuses;
/// with it the estimators run, the derive step's notes are printed and
/// Fourier-transform regression converges (as its gate
/// transport-qar-derived-fdee asserts). The derive flags without
/// `--derive` are an error, not silently ignored.
#[test]
fn run_derives_the_qar_record_when_asked() {
    let raw = stdout_of(aeroid().args(["run", "transport-approach", "--profile", "qar-seed000"]));
    let rows = |text: &str, prefix: &str| {
        text.lines()
            .filter(|line| line.starts_with(prefix))
            .map(String::from)
            .collect::<Vec<_>>()
    };
    let raw_rows = rows(&raw, "transport-longitudinal");
    assert!(!raw_rows.is_empty(), "{raw}");
    assert!(raw_rows.iter().all(|row| row.contains("refused")), "{raw}");
    let derived = stdout_of(aeroid().args([
        "run",
        "transport-approach",
        "--profile",
        "qar-seed000",
        "--derive",
        "--thrust-from-fuel-flow",
        "2.0e-5",
        "--idle-fuel-flow",
        "0.02",
    ]));
    assert!(derived.contains("after the derive step"), "{derived}");
    assert!(
        derived.contains("thrust: added from fuel_flow_left + fuel_flow_right"),
        "{derived}"
    );
    let fdee = rows(&derived, "transport-longitudinal fdee");
    assert!(
        fdee.len() == 1 && fdee[0].contains("converged"),
        "{derived}"
    );
    assert!(
        rows(&derived, "transport-longitudinal")
            .iter()
            .all(|row| !row.contains("refused")),
        "{derived}"
    );
    let output = aeroid()
        .args([
            "run",
            "transport-approach",
            "--profile",
            "qar-seed000",
            "--thrust-from-fuel-flow",
            "2.0e-5",
        ])
        .output()
        .unwrap();
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("need --derive"), "{stderr}");
}

/// A departing flight: `simulate` writes the trace up to the departure,
/// says where it is and fails.
#[test]
fn simulate_writes_the_partial_trace_of_a_departing_flight() {
    let folder = common::temp_folder("cli-departure");
    let aircraft = common::attas_with(|t| {
        t.replace("alpha = -0.176", "alpha = 0.05")
            .replace("q = -12.3", "q = 0.0")
    });
    common::write(&folder, "unstable.toml", &aircraft);
    let scenario = common::write(
        &folder,
        "departs.toml",
        "name = \"departs\"\naircraft = \"unstable.toml\"\nduration = \"60 s\"\nstep = \"0.01 s\"\nseed = 1\n\n\
         [trim]\nairspeed = \"103 m/s\"\naltitude = \"4877 m\"\n\n\
         [[inputs]]\nkind = \"step\"\ncontrol = \"elevator\"\nstart = \"1 s\"\namplitude = \"-0.5 deg\"\n",
    );
    let out = folder.join("trace.csv");
    let output = aeroid()
        .arg("simulate")
        .arg(&scenario)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "{stderr}");
    assert!(
        stderr.contains("departed at t = ") && stderr.contains("samples before departure"),
        "{stderr}"
    );
    let lines = std::fs::read_to_string(&out).unwrap().lines().count();
    assert!(lines > 100, "the partial trace has {lines} lines");
}

/// A `truth.toml` that aeroid did not write (another tool's, with fields
/// aeroid does not know) does not stop `estimate`: the estimate is made and
/// reported unscored, with a warning naming the file.
#[test]
fn a_foreign_truth_file_is_ignored_with_a_warning() {
    let folder = common::temp_folder("foreign-truth");
    let record = folder.join("rec");
    stdout_of(
        aeroid()
            .args([
                "record",
                "attas-elevator-3211",
                "--profile",
                "flight-test-25hz",
                "--out",
            ])
            .arg(&record),
    );
    std::fs::write(record.join("truth.toml"), "conventions = \"other\"\n").unwrap();
    let output = aeroid()
        .args(["estimate"])
        .arg(&record)
        .args(["--model", "attas-longitudinal", "--method", "ee"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning:")
            && stderr.contains("truth.toml")
            && stderr.contains("not scored"),
        "{stderr}"
    );
    assert!(String::from_utf8_lossy(&output.stdout).contains("converged"));
    std::fs::remove_dir_all(&folder).unwrap();
}

/// `estimate --method ebm --write-smoothed FILE` writes the smoothed
/// coefficient histories where the user named, with the truth trace's
/// column names; with another method the option is refused, naming `ebm`,
/// and nothing is written.
#[test]
fn estimate_writes_the_smoothed_histories_where_asked() {
    let folder = common::temp_folder("write-smoothed");
    let record = folder.join("rec");
    stdout_of(
        aeroid()
            .args([
                "record",
                "attas-elevator-3211",
                "--profile",
                "flight-test-25hz",
                "--out",
            ])
            .arg(&record),
    );
    let csv = folder.join("smoothed.csv");
    let printed = stdout_of(
        aeroid()
            .arg("estimate")
            .arg(&record)
            .args(["--model", "attas-longitudinal", "--method", "ebm"])
            .arg("--write-smoothed")
            .arg(&csv),
    );
    assert!(printed.contains("Cm_q"), "{printed}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let header = text.lines().next().unwrap();
    assert!(
        header.starts_with("time [s],CX [-],CY [-],CZ [-],Cl [-],Cm [-],Cn [-]"),
        "{header}"
    );
    assert_eq!(text.lines().count(), 1 + 1501);
    let other = folder.join("other.csv");
    let output = aeroid()
        .arg("estimate")
        .arg(&record)
        .args(["--model", "attas-longitudinal", "--method", "ee"])
        .arg("--write-smoothed")
        .arg(&other)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success() && stderr.contains("ebm"),
        "{stderr}"
    );
    assert!(!other.exists());
    std::fs::remove_dir_all(&folder).unwrap();
}

/// The QAR record of the transport approach: `inspect --quality` flags its
/// angle of attack as stuck, and `derive` leaves that channel out for the
/// geometric one and says so, adds the sideslip the QAR lacks (no longer
/// absent), and the written channels say where they came from.
#[test]
fn derive_replaces_the_stuck_angle_of_attack_and_says_so() {
    let folder = common::temp_folder("derive-qar");
    let (recorded, derived) = (folder.join("qar"), folder.join("derived"));
    stdout_of(
        aeroid()
            .args(["record", "transport-approach", "--out"])
            .arg(&recorded),
    );
    let quality = stdout_of(aeroid().args(["inspect", "--quality"]).arg(&recorded));
    assert!(
        quality.contains("stuck: reads only 1.890, 1.915 rad"),
        "{quality}"
    );
    assert!(quality.ends_with("flagged: alpha\n"), "{quality}");
    let text = stdout_of(
        aeroid()
            .arg("derive")
            .arg(&recorded)
            .arg("--out")
            .arg(&derived),
    );
    assert!(
        text.contains("alpha: the recorded channel is left out (stuck: reads only 1.890, 1.915 rad); replaced by the geometric one"),
        "{text}"
    );
    assert!(text.contains("beta: added (geometric)"), "{text}");
    let record = aeroid::record::FlightRecord::read(&derived).unwrap();
    for name in ["alpha", "beta"] {
        let channel = record.channel(name).unwrap();
        assert!(
            channel
                .source
                .starts_with("geometric (Wang et al. 2012, Eqs. 1-6) from pitch, roll, yaw"),
            "{}",
            channel.source
        );
        assert_eq!(channel.rate, 1.0);
    }
    assert!(!record.absent.contains(&"beta".to_string()));
    // The QAR has no rate gyros and split surfaces: derive adds p, q, r from
    // the attitude kinematics and the combined surfaces, with provenance.
    for (name, source) in [
        ("p", "kinematic (p = roll_dot - yaw_dot sin(pitch)"),
        ("q", "kinematic ("),
        ("r", "kinematic ("),
        ("aileron", "combined: (aileron_left - aileron_right)/2"),
        ("elevator", "combined: (elevator_left + elevator_right)/2"),
        ("flap", "combined: (flap_left + flap_right)/2"),
    ] {
        assert!(
            text.contains(&format!("{name}: added")),
            "{name} not added: {text}"
        );
        let channel = record.channel(name).unwrap();
        assert!(channel.source.starts_with(source), "{}", channel.source);
        assert!(!record.absent.contains(&name.to_string()));
    }
    assert!(text.contains("airspeed: added (geometric"), "{text}");
}

/// A record without the flight-path channels (the 25 Hz flight-test
/// profile) is refused with the record and every missing channel named;
/// without the wind correction the wind channels are not asked for.
#[test]
fn derive_names_the_missing_channels() {
    let folder = common::temp_folder("derive-missing");
    let recorded = folder.join("flight-test");
    stdout_of(
        aeroid()
            .args([
                "record",
                "attas-lateral-multistep",
                "--profile",
                "flight-test-25hz",
                "--out",
            ])
            .arg(&recorded),
    );
    for (flag, expected) in [
        (
            None,
            "need the channel(s) flight_path_angle, track, ground_speed, wind_speed, wind_direction, which the record lacks",
        ),
        (
            Some("--no-wind-correction"),
            "need the channel(s) flight_path_angle, track, ground_speed, which the record lacks",
        ),
    ] {
        let mut command = aeroid();
        command
            .arg("derive")
            .arg(&recorded)
            .arg("--out")
            .arg(folder.join("out"));
        command.args(flag);
        let output = command.output().unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains(&recorded.display().to_string()), "{stderr}");
        assert!(stderr.contains(expected), "{stderr}");
        assert!(!folder.join("out").exists());
    }
}

/// No command overwrites what it reads: `--write-problem` naming the model
/// file or a record's own `record.toml`, and `report --out` naming the
/// study's `runs.csv`, are refused before any work, naming the file, and
/// the input is left byte for byte as it was.
#[test]
fn an_output_that_names_an_input_is_refused_and_the_input_kept() {
    let folder = common::temp_folder("output-names-input");
    let record = folder.join("rec");
    stdout_of(
        aeroid()
            .args(["record", "attas-elevator-3211", "--out"])
            .arg(&record),
    );
    let model = folder.join("model.toml");
    std::fs::copy(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/attas-longitudinal.toml"),
        &model,
    )
    .unwrap();
    let record_toml = record.join("record.toml");
    for target in [&model, &record_toml] {
        let before = std::fs::read(target).unwrap();
        let output = aeroid()
            .arg("estimate")
            .arg(&record)
            .arg("--model")
            .arg(&model)
            .args(["--method", "ee", "--write-problem"])
            .arg(target)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        let name = target.file_name().unwrap().to_str().unwrap();
        assert!(
            !output.status.success() && stderr.contains(name) && stderr.contains("reads"),
            "{stderr}"
        );
        assert_eq!(std::fs::read(target).unwrap(), before, "{name} changed");
    }
    let study = folder.join("study");
    std::fs::create_dir_all(&study).unwrap();
    let runs = common::write(&study, "runs.csv", "point,run\n");
    common::write(&study, "study.json", "{}");
    let output = aeroid()
        .arg("report")
        .arg(&study)
        .arg("--out")
        .arg(&runs)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success() && stderr.contains("runs.csv") && stderr.contains("reads"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&runs).unwrap(), "point,run\n");
    std::fs::remove_dir_all(&folder).unwrap();
}

/// A plug-in file that does not load, or whose name another plug-in file
/// also has, is named with its reason when its method is asked for, not
/// only as an unknown method.
#[test]
fn a_plugin_that_did_not_load_is_explained_where_it_is_asked_for() {
    let folder = common::temp_folder("plugin-not-loaded");
    let plugins = folder.join("estimators");
    std::fs::create_dir_all(&plugins).unwrap();
    common::write(&plugins, "broken.toml", "command = []\n");
    let record = folder.join("rec");
    stdout_of(
        aeroid()
            .args(["record", "attas-lateral-multistep", "--out"])
            .arg(&record),
    );
    let output = aeroid()
        .env("AEROID_ESTIMATORS", &plugins)
        .arg("estimate")
        .arg(&record)
        .args(["--model", "attas-lateral", "--method", "broken"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success()
            && stderr.contains("broken.toml")
            && stderr.contains("did not load")
            && stderr.contains("command"),
        "{stderr}"
    );
    // Two plug-in files of one name in two folders: neither is run.
    let other = folder.join("more");
    std::fs::create_dir_all(&other).unwrap();
    for place in [&plugins, &other] {
        common::write(place, "twin.toml", "command = [\"sh\", \"twin.sh\"]\n");
    }
    let output = aeroid()
        .env(
            "AEROID_ESTIMATORS",
            format!("{}:{}", plugins.display(), other.display()),
        )
        .arg("estimate")
        .arg(&record)
        .args(["--model", "attas-lateral", "--method", "twin"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success() && stderr.contains("both are left out"),
        "{stderr}"
    );
    std::fs::remove_dir_all(&folder).unwrap();
}

/// `aeroid export` writes a record as one MAT-file or CSV: the format from
/// `--format` or the extension; the CSV holds every channel on the union
/// of their instants (empty where a channel has no sample, NaN for a
/// dropout). It refuses a file inside the record folder (the record is
/// only read, and is left as it was) and a name without a format.
#[test]
fn export_writes_one_file_outside_the_record() {
    use aeroid::record::{Channel, FlightRecord};
    let folder = common::temp_folder("cli-export");
    let channel = |name: &str, times: Vec<f64>, values: Vec<f64>| Channel {
        name: name.into(),
        unit: "rad".into(),
        rate: 1.0 / (times[1] - times[0]),
        resolution: None,
        source: "test".into(),
        times,
        values,
    };
    let record = FlightRecord {
        scenario: "export".into(),
        seed: None,
        profile: "test".into(),
        absent: Vec::new(),
        channels: vec![
            channel("alpha", vec![0.0, 0.5, 1.0], vec![0.1, f64::NAN, 0.3]),
            channel("pitch", vec![0.0, 1.0], vec![0.05, 0.06]),
        ],
        bridge_gaps: false,
    };
    let rec = folder.join("rec");
    record.write(&rec).unwrap();
    let before: Vec<(std::path::PathBuf, Vec<u8>)> = std::fs::read_dir(&rec)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| (p.clone(), std::fs::read(&p).unwrap()))
        .collect();
    let csv = folder.join("out.csv");
    let text = stdout_of(aeroid().arg("export").arg(&rec).arg("--out").arg(&csv));
    assert!(text.contains("2 channels exported"), "{text}");
    assert_eq!(
        std::fs::read_to_string(&csv).unwrap(),
        "time [s],alpha [rad],pitch [rad]\n0,0.1,0.05\n0.5,NaN,\n1,0.3,0.06\n"
    );
    let mat = folder.join("out.data");
    let text = stdout_of(
        aeroid()
            .arg("export")
            .arg(&rec)
            .args(["--format", "mat", "--out"])
            .arg(&mat),
    );
    assert!(
        text.contains("data_alpha: 3 × 2 double") && text.contains("data_pitch: 2 × 2 double"),
        "{text}"
    );
    assert!(
        std::fs::read(&mat)
            .unwrap()
            .starts_with(b"MATLAB 5.0 MAT-file")
    );
    for (out, expected) in [
        (rec.join("alpha.csv"), "inside the record folder"),
        (rec.join("copy.mat"), "inside the record folder"),
        (folder.join("out.txt"), "say the format with --format mat"),
    ] {
        let output = aeroid()
            .arg("export")
            .arg(&rec)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(
            !output.status.success() && stderr.contains(expected),
            "{stderr}"
        );
    }
    assert!(!rec.join("copy.mat").exists() && !folder.join("out.txt").exists());
    for (path, bytes) in before {
        assert_eq!(std::fs::read(&path).unwrap(), bytes, "{}", path.display());
    }
}

/// `derive --coefficients`: the stall record by the flight-test profile
/// gets the eight coefficient channels (each said on its own line, with
/// the accelerometers' transfer and the differentiator in the notes); the
/// written record holds them; a position that is not three distances and
/// an unknown source of the angular accelerations are errors naming the
/// flag, and nothing is written.
#[test]
fn derive_adds_the_coefficients_from_the_accelerations() {
    let folder = common::temp_folder("cli_derive_coefficients");
    let record = folder.join("rec");
    stdout_of(
        aeroid()
            .args([
                "record",
                "attas-stall",
                "--profile",
                "flight-test-25hz",
                "--out",
            ])
            .arg(&record),
    );
    let out = folder.join("coefficients");
    let printed = stdout_of(
        aeroid()
            .arg("derive")
            .arg(&record)
            .arg("--out")
            .arg(&out)
            .args([
                "--no-flow-angles",
                "--no-rates",
                "--coefficients",
                "attas-stall",
            ])
            .args(["--accelerometer-position", "6,1.5,-0.8"]),
    );
    assert!(
        printed.contains("carried to the CG from the accelerometers at (6, 1.5, -0.8) m"),
        "{printed}"
    );
    assert!(
        printed.contains("angular accelerations by local polynomial"),
        "{printed}"
    );
    let written = aeroid::record::FlightRecord::read(&out).unwrap();
    for name in ["CX", "CY", "CZ", "CL", "CD", "Cl", "Cm", "Cn"] {
        assert!(
            printed.contains(&format!("  {name}: added")),
            "{name}: {printed}"
        );
        let channel = written.channel(name).unwrap();
        assert!(
            channel.values.iter().filter(|v| v.is_finite()).count() > 1000,
            "{name}"
        );
    }
    for (flags, says) in [
        (
            ["--accelerometer-position", "6,1.5"],
            "--accelerometer-position \"6,1.5\"",
        ),
        (
            ["--angular-accelerations", "guessed"],
            "--angular-accelerations \"guessed\"",
        ),
    ] {
        let bad = folder.join("bad");
        let output = aeroid()
            .arg("derive")
            .arg(&record)
            .arg("--out")
            .arg(&bad)
            .args(["--coefficients", "attas-stall"])
            .args(flags)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(
            !output.status.success() && stderr.contains(says),
            "{stderr}"
        );
        assert!(!bad.exists(), "nothing is written on an error");
    }
}
