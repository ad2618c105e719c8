//! The command line's contracts: output locations are checked before the
//! work starts and write failures say "cannot write"; errors are said in the
//! user's words, each cause once; a filter that matches nothing is an error;
//! files named inside a record folder, a scenario or a study stay inside the
//! folder that names them.

use crate::common;
use std::path::{Path, PathBuf};
use std::process::Command;

fn aeroid() -> Command {
    Command::new(env!("CARGO_BIN_EXE_aeroid"))
}

/// Exit code, stdout and stderr of a command.
fn outcome(command: &mut Command) -> (Option<i32>, String, String) {
    let output = command.output().unwrap();
    (
        output.status.code(),
        String::from_utf8_lossy(&output.stdout).into_owned(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

/// The stderr of a command that must fail with exit 1 before printing anything.
fn refused_at_once(command: &mut Command) -> String {
    let (code, stdout, stderr) = outcome(command);
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    assert!(stdout.is_empty(), "work was done first: {stdout}{stderr}");
    stderr
}

/// A record of the ATTAS elevator 3211 with the ideal recorder, in `folder/rec`.
fn record_in(folder: &Path) -> PathBuf {
    let record = folder.join("rec");
    let (code, stdout, stderr) = outcome(
        aeroid()
            .args([
                "record",
                "attas-elevator-3211",
                "--profile",
                "ideal",
                "--out",
            ])
            .arg(&record),
    );
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    record
}

#[test]
fn gate_only_that_matches_no_case_is_an_error_listing_the_cases() {
    let stderr = refused_at_once(aeroid().args(["gate", "--only", "no-such-case"]));
    assert!(
        stderr.contains("--only 'no-such-case' matches no case of")
            && stderr.contains("cases: attas-longitudinal-ideal-oem, "),
        "{stderr}"
    );
}

/// `study --out` naming an existing file is refused before the study runs,
/// in the words of a write, not a read.
#[test]
fn study_out_to_an_existing_file_is_refused_at_once() {
    let folder = common::temp_folder("contracts-study-out");
    let file = common::write(&folder, "results", "not a folder");
    let stderr = refused_at_once(
        aeroid()
            .args(["study", "attas-lateral-acceptance", "--runs", "1", "--out"])
            .arg(&file),
    );
    let expected = format!(
        "error: cannot write {}: it is a file, not a folder\n",
        file.display()
    );
    assert_eq!(stderr, expected);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "not a folder");
}

/// Every command that writes checks its output location first; a path that
/// cannot be written says "cannot write" once, with one reason.
#[test]
fn every_output_location_is_checked_before_the_work() {
    let folder = common::temp_folder("contracts-outputs");
    let record = record_in(&folder);
    let file = common::write(&folder, "a-file", "x");
    let map = common::write(
        &folder,
        "map.toml",
        "[time]\ncolumn = \"t\"\n\n[[channels]]\nname = \"alpha\"\ncolumn = \"a\"\nunit = \"deg\"\n",
    );
    let data = common::write(&folder, "data.csv", "t,a\n0,1\n0.1,2\n0.2,3\n");
    let record = record.to_str().unwrap();
    let cases: Vec<Vec<&str>> = vec![
        vec!["run", "attas-elevator-3211"],
        vec!["record", "attas-elevator-3211"],
        vec![
            "import",
            data.to_str().unwrap(),
            "--map",
            map.to_str().unwrap(),
        ],
        vec!["reconstruct", record],
        vec![
            "estimate",
            record,
            "--model",
            "attas-longitudinal",
            "--method",
            "ee",
        ],
        vec!["study", "attas-lateral-acceptance", "--runs", "1"],
    ];
    for case in cases {
        let below = file.join("out");
        let stderr = refused_at_once(aeroid().args(&case).arg("--out").arg(&below));
        assert_eq!(
            stderr,
            format!(
                "error: cannot write {}: {} is a file, not a folder\n",
                below.display(),
                file.display()
            ),
            "{case:?}"
        );
    }
    let missing = folder.join("no-such-folder").join("trace.csv");
    let stderr = refused_at_once(
        aeroid()
            .args(["simulate", "attas-trim", "--out"])
            .arg(&missing),
    );
    assert_eq!(
        stderr,
        format!(
            "error: cannot write {}: the folder {} does not exist\n",
            missing.display(),
            folder.join("no-such-folder").display()
        )
    );
    let stderr = refused_at_once(
        aeroid()
            .args(["simulate", "attas-trim", "--out"])
            .arg(&folder),
    );
    assert!(stderr.contains("it is a folder; name a file"), "{stderr}");
}

/// An unwritable place: the reason the system gives is said once, as a
/// write failure.
#[test]
fn an_unwritable_output_says_cannot_write_once() {
    let stderr = refused_at_once(aeroid().args(["record", "attas-trim", "--out", "/proc/x/out"]));
    assert!(
        stderr.starts_with("error: cannot write /proc/x/out: "),
        "{stderr}"
    );
    assert!(!stderr.contains("cannot read"), "{stderr}");
    assert_eq!(stderr.matches("os error").count(), 1, "{stderr}");
}

/// A read failure names the file and gives the system's reason once.
#[test]
fn a_missing_record_is_reported_once() {
    let folder = common::temp_folder("contracts-missing-record");
    let missing = folder.join("nothing");
    let stderr = refused_at_once(aeroid().arg("inspect").arg(&missing));
    assert_eq!(
        stderr,
        format!(
            "error: cannot read {}: No such file or directory (os error 2)\n",
            missing.join("record.toml").display()
        )
    );
}

/// `estimate --check-on` a record that does not exist fails before the fit.
#[test]
fn estimate_check_on_a_missing_record_fails_before_the_fit() {
    let folder = common::temp_folder("contracts-check-on");
    let record = record_in(&folder);
    let missing = folder.join("missing");
    let stderr = refused_at_once(
        aeroid()
            .arg("estimate")
            .arg(&record)
            .args([
                "--model",
                "attas-longitudinal",
                "--method",
                "ee",
                "--check-on",
            ])
            .arg(&missing),
    );
    assert!(
        stderr.contains(&format!(
            "cannot read {}",
            missing.join("record.toml").display()
        )),
        "{stderr}"
    );
}

/// A boolean where a quantity belongs says what a quantity is.
#[test]
fn a_boolean_quantity_says_a_quantity_is_expected() {
    let folder = common::temp_folder("contracts-quantity");
    let scenario = common::write(
        &folder,
        "s.toml",
        "name = \"s\"\naircraft = \"attas\"\nduration = true\nstep = \"0.01 s\"\nseed = 1\n\n\
         [trim]\nairspeed = \"103 m/s\"\naltitude = \"4877 m\"\n",
    );
    let stderr = refused_at_once(aeroid().arg("check").arg(&scenario));
    assert!(
        stderr.contains("line 3")
            && stderr.contains("expected a quantity (a number or a string such as \"5 deg\")"),
        "{stderr}"
    );
    assert!(!stderr.contains("untagged enum"), "{stderr}");
}

/// A semicolon-separated file with decimal commas: the field-count error
/// says which delimiter the file seems to use.
#[test]
fn a_semicolon_separated_csv_gets_a_delimiter_hint() {
    let folder = common::temp_folder("contracts-semicolon");
    let map = common::write(
        &folder,
        "map.toml",
        "[time]\ncolumn = \"t\"\n\n[[channels]]\nname = \"alpha\"\ncolumn = \"a\"\nunit = \"deg\"\n",
    );
    let data = common::write(&folder, "data.csv", "t;a\n0,0;1,5\n0,1;1,6\n");
    let stderr = refused_at_once(
        aeroid()
            .arg("import")
            .arg(&data)
            .arg("--map")
            .arg(&map)
            .arg("--out")
            .arg(folder.join("rec")),
    );
    assert!(
        stderr.contains("line 2")
            && stderr.contains(
                "the file seems to use ';' as delimiter; aeroid reads comma-separated files"
            ),
        "{stderr}"
    );
}

/// The JSBSim commands exist in every build; without the feature they say
/// how to get it.
#[cfg(not(feature = "jsbsim"))]
#[test]
fn jsbsim_commands_say_which_feature_they_need() {
    for args in [
        vec!["export-jsbsim", "attas", "--out", "x"],
        vec!["crosscheck", "attas-elevator-3211"],
    ] {
        let stderr = refused_at_once(aeroid().args(&args));
        assert_eq!(
            stderr,
            "error: this command needs the jsbsim feature: build with `cargo build --release --features jsbsim`\n",
            "{args:?}"
        );
    }
}

/// A record folder whose record.toml names a file outside it, by `..`, by
/// an absolute path or through a symbolic link: refused, naming the file
/// and the field, and the outside file is not read.
#[test]
fn a_record_folder_crafted_to_escape_is_refused() {
    let folder = common::temp_folder("contracts-record-escape");
    let record = record_in(&folder);
    let text = std::fs::read_to_string(record.join("record.toml")).unwrap();
    let crafted = folder.join("crafted");
    std::fs::create_dir_all(&crafted).unwrap();
    let toml = crafted.join("record.toml");
    let cases = [
        ("../../../../etc/passwd", "leaves the folder with '..'"),
        ("/etc/passwd", "is an absolute path"),
        ("link.csv", "leads to"),
    ];
    #[cfg(unix)]
    std::os::unix::fs::symlink(record.join("rate_100hz.csv"), crafted.join("link.csv")).unwrap();
    for (reference, reason) in cases {
        if cfg!(not(unix)) && reference == "link.csv" {
            continue;
        }
        let first = text.replacen(
            "file = \"rate_100hz.csv\"",
            &format!("file = \"{reference}\""),
            1,
        );
        std::fs::write(&toml, first).unwrap();
        let stderr = refused_at_once(aeroid().arg("inspect").arg(&crafted));
        assert!(
            stderr.contains(&format!(
                "{}: channels[0].file: '{reference}' {reason}",
                toml.display()
            )),
            "{stderr}"
        );
    }
}

/// A scenario whose CSV input lies outside its folder is refused, naming
/// the scenario and the field; a CSV inside the folder is read.
#[test]
fn a_scenario_whose_csv_input_points_outside_is_refused() {
    let root = common::temp_folder("contracts-scenario-escape");
    let folder = root.join("scenario");
    std::fs::create_dir_all(&folder).unwrap();
    let csv = "t,elevator_deg\n0,0\n1,1\n2,0\n";
    common::write(&root, "outside.csv", csv);
    common::write(&folder, "inside.csv", csv);
    let scenario = |file: &str| {
        common::write(
            &folder,
            "replay.toml",
            &format!(
                "name = \"replay\"\naircraft = \"attas\"\nduration = \"3 s\"\nstep = \"0.01 s\"\nseed = 1\n\n\
                 [trim]\nairspeed = \"103 m/s\"\naltitude = \"4877 m\"\n\n\
                 [[inputs]]\nkind = \"csv\"\ncontrol = \"elevator\"\nfile = \"{file}\"\n\
                 time_column = \"t\"\ncolumn = \"elevator_deg\"\nunit = \"deg\"\n"
            ),
        )
    };
    let outside = root.join("outside.csv");
    for (reference, reason) in [
        ("../outside.csv", "leaves the scenario's folder"),
        (outside.to_str().unwrap(), "leaves the scenario's folder"),
    ] {
        let path = scenario(reference);
        let stderr = refused_at_once(aeroid().arg("check").arg(&path));
        assert!(
            stderr.contains(&path.display().to_string())
                && stderr.contains(&format!("inputs[0].file: '{reference}' {reason}")),
            "{stderr}"
        );
    }
    let path = scenario("inside.csv");
    let (code, stdout, stderr) = outcome(aeroid().arg("check").arg(&path));
    assert_eq!(code, Some(0), "{stdout}{stderr}");
}

/// A scenario's aircraft and a study's scenarios are found inside the folder
/// of the file naming them or in the data folder, never through `..`.
#[test]
fn scenario_and_study_references_stay_inside() {
    let root = common::temp_folder("contracts-reference-escape");
    let folder = root.join("inner");
    std::fs::create_dir_all(&folder).unwrap();
    common::write(&root, "plane.toml", &common::attas_with(|t| t));
    let scenario = common::write(
        &folder,
        "s.toml",
        "name = \"s\"\naircraft = \"../plane.toml\"\nduration = \"3 s\"\nstep = \"0.01 s\"\nseed = 1\n\n\
         [trim]\nairspeed = \"103 m/s\"\naltitude = \"4877 m\"\n",
    );
    let stderr = refused_at_once(aeroid().arg("check").arg(&scenario));
    assert!(
        stderr.contains(&format!(
            "{}: aircraft: '../plane.toml' leaves the folder with '..'",
            scenario.display()
        )),
        "{stderr}"
    );
    let study = common::write(
        &folder,
        "study.toml",
        "name = \"escape\"\nscenarios = [\"../../x.toml\"]\nprofile = \"ideal\"\n\
         models = [\"attas-lateral\"]\nmethods = [\"ee\"]\nruns = 1\nseed = 1\n",
    );
    let stderr = refused_at_once(aeroid().arg("check").arg(&study));
    assert!(
        stderr.contains("scenarios[0]: scenario '../../x.toml' leaves the folder with '..'"),
        "{stderr}"
    );
}

/// A gate file's cases name bundled files; an absolute path or `..` is
/// refused before any case runs.
#[test]
fn a_gate_case_naming_a_file_outside_is_refused() {
    let folder = common::temp_folder("contracts-gate-escape");
    let gates = common::write(
        &folder,
        "gates.toml",
        "[[case]]\nname = \"escape\"\nscenario = \"../../etc/x.toml\"\nprofile = \"/etc/passwd\"\n\
         model = \"attas-longitudinal\"\nmethod = \"ee\"\nrelative_tolerance = 0.1\n",
    );
    let stderr = refused_at_once(aeroid().arg("gate").arg("--file").arg(&gates));
    assert!(
        stderr.contains("case[0] (escape).scenario: '../../etc/x.toml' is an absolute path or leaves the folder with '..'")
            && stderr.contains("case[0] (escape).profile: '/etc/passwd'"),
        "{stderr}"
    );
}

/// A scenario's aircraft reached through a symbolic link that leads out of
/// the scenario's folder is refused.
#[cfg(unix)]
#[test]
fn a_scenario_aircraft_linked_from_outside_is_refused() {
    let root = common::temp_folder("contracts-linked-aircraft");
    let folder = root.join("inner");
    std::fs::create_dir_all(&folder).unwrap();
    let plane = common::write(&root, "plane.toml", &common::attas_with(|t| t));
    std::os::unix::fs::symlink(&plane, folder.join("plane.toml")).unwrap();
    let scenario = common::write(
        &folder,
        "s.toml",
        "name = \"s\"\naircraft = \"plane.toml\"\nduration = \"3 s\"\nstep = \"0.01 s\"\nseed = 1\n\n\
         [trim]\nairspeed = \"103 m/s\"\naltitude = \"4877 m\"\n",
    );
    let stderr = refused_at_once(aeroid().arg("check").arg(&scenario));
    assert!(
        stderr.contains(&format!(
            "{}: aircraft: 'plane.toml' leads to {}, outside {}",
            scenario.display(),
            plane.canonicalize().unwrap().display(),
            folder.display()
        )),
        "{stderr}"
    );
}

/// One path rule for every file that names another: a model structure's
/// aircraft and a study's scenario reached through a symbolic link that
/// leads out of the naming file's folder are refused as a scenario's
/// aircraft is, by `check` as by the command that would read them.
#[cfg(unix)]
#[test]
fn a_model_or_study_naming_a_linked_file_from_outside_is_refused() {
    let root = common::temp_folder("contracts-linked-model");
    let folder = root.join("inner");
    std::fs::create_dir_all(&folder).unwrap();
    let plane = common::write(&root, "plane.toml", &common::attas_with(|t| t));
    std::os::unix::fs::symlink(&plane, folder.join("plane.toml")).unwrap();
    let model_text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/attas-lateral.toml"),
    )
    .unwrap()
    .replacen("aircraft = \"attas\"", "aircraft = \"plane.toml\"", 1);
    assert!(
        model_text.contains("aircraft = \"plane.toml\""),
        "the bundled model changed"
    );
    let model = common::write(&folder, "m.toml", &model_text);
    let stderr = refused_at_once(aeroid().arg("check").arg(&model));
    assert!(
        stderr.contains("aircraft 'plane.toml' leads to")
            && stderr.contains("through a symbolic link, outside the folder"),
        "{stderr}"
    );
    let scenario = common::write(
        &root,
        "s.toml",
        "name = \"s\"\naircraft = \"attas\"\nduration = \"3 s\"\nstep = \"0.01 s\"\nseed = 1\n\n\
         [trim]\nairspeed = \"103 m/s\"\naltitude = \"4877 m\"\n",
    );
    std::os::unix::fs::symlink(&scenario, folder.join("s.toml")).unwrap();
    let study = common::write(
        &folder,
        "study.toml",
        "name = \"linked\"\nscenarios = [\"s.toml\"]\nprofile = \"ideal\"\nmodels = [\"attas-lateral\"]\nmethods = [\"ee\"]\nruns = 1\nseed = 1\n",
    );
    let stderr = refused_at_once(aeroid().arg("check").arg(&study));
    assert!(
        stderr.contains("scenario 's.toml' leads to")
            && stderr.contains("through a symbolic link, outside the folder"),
        "{stderr}"
    );
}
