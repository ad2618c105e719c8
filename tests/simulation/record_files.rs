//! Flight-record files: lossless round trip, import of external CSV data with
//! a column map (unit conversion and every error naming row and column), the
//! `record` / `inspect` command line with its QAR snapshot, truth.toml, the
//! scenario's default profile, and `check` on a profile.

use crate::common;
use aeroid::record::recorder::{Profile, profile_for};
use aeroid::record::{Channel, FlightRecord};
use aeroid::sim::scenario::Scenario;
use aeroid::sim::truth::{RunTruth, TruthKind};
use aeroid::units::{DEG, FOOT, KNOT};
use std::path::Path;
use std::process::Command;

fn channel(name: &str, unit: &str, rate: f64, times: Vec<f64>, values: Vec<f64>) -> Channel {
    Channel {
        name: name.into(),
        unit: unit.into(),
        rate,
        resolution: None,
        source: format!("test {name}"),
        times,
        values,
    }
}

/// Bitwise comparison, so that NaN dropouts and −0.0 count.
fn assert_same(a: &FlightRecord, b: &FlightRecord) {
    assert_eq!(
        (&a.scenario, a.seed, &a.profile, &a.absent),
        (&b.scenario, b.seed, &b.profile, &b.absent)
    );
    assert_eq!(a.channels.len(), b.channels.len());
    for (x, y) in a.channels.iter().zip(&b.channels) {
        assert_eq!(
            (&x.name, &x.unit, x.rate, x.resolution, &x.source),
            (&y.name, &y.unit, y.rate, y.resolution, &y.source)
        );
        let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&x.times), bits(&y.times), "{}", x.name);
        assert_eq!(bits(&x.values), bits(&y.values), "{}", x.name);
    }
}

/// Awkward values, NaN dropouts and several time bases survive write + read bit for bit.
#[test]
fn record_round_trip_is_lossless() {
    let folder = common::temp_folder("round-trip");
    let fast: Vec<f64> = (0..50).map(|k| 0.1 + k as f64 * 0.04).collect();
    let awkward = |k: usize| match k % 5 {
        0 => 0.1 + 0.2,
        1 => -0.0,
        2 => 1e-300,
        3 => f64::NAN,
        _ => -123_456.789e10 / 3.0,
    };
    let record = FlightRecord {
        scenario: "round trip".into(),
        seed: Some(12_345),
        profile: "hand-made".into(),
        absent: vec!["p".into()],
        channels: vec![
            channel(
                "alpha",
                "rad",
                25.0,
                fast.clone(),
                (0..50).map(awkward).collect(),
            ),
            channel(
                "beta",
                "rad",
                25.0,
                fast.clone(),
                (0..50).map(|k| k as f64 / 7.0).collect(),
            ),
            channel(
                "gross_weight",
                "kg",
                1.0 / 64.0,
                vec![0.015625, 64.015625],
                vec![17631.0, f64::NAN],
            ),
            Channel {
                resolution: Some(0.1 * DEG),
                ..channel(
                    "pitch",
                    "rad",
                    1.0,
                    vec![0.171875, 1.171875],
                    vec![0.15707963267948966, 0.0],
                )
            },
        ],
        bridge_gaps: false,
    };
    record.write(&folder).unwrap();
    let mut files: Vec<String> = std::fs::read_dir(&folder)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(
        files,
        [
            "gross_weight.csv",
            "pitch.csv",
            "rate_25hz.csv",
            "record.toml"
        ]
    );
    let text = std::fs::read_to_string(folder.join("rate_25hz.csv")).unwrap();
    assert!(
        text.starts_with("time [s],alpha [rad],beta [rad]\n0.1,0.30000000000000004,0\n0.14,-0,")
    );
    assert!(text.contains(",,"), "a dropout is an empty cell");
    assert_same(&record, &FlightRecord::read(&folder).unwrap());
}

/// A simulated QAR record (35 channels, word-slot skew, faulty AoA) round-trips too.
#[test]
fn recorded_flight_round_trips() {
    let folder = common::temp_folder("qar-round-trip");
    let mut scenario = Scenario::load("attas-trim").unwrap();
    scenario.duration = 70.0;
    let profile = Profile::load("qar-seed000", None).unwrap();
    let (record, _) = aeroid::record::recorder::record_scenario(&scenario, &profile).unwrap();
    record.write(&folder).unwrap();
    assert_same(&record, &FlightRecord::read(&folder).unwrap());
}

const FLIGHT_CSV: &str = "\
Time,AOA,IAS,ALT,TAT,Flag,HDG
0.0,2.5,200,10000,-12.5,1,359
0.5,2.6,201,10010,-12.25,0,
1.0,2.7,,10020,-12.0,1,1
1.5,2.8,203,10030,-11.75,0,
";

const FLIGHT_MAP: &str = r#"
name = "test flight"
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
[[channels]]
name = "altitude"
column = "ALT"
unit = "ft"
scale = 1.0
offset = -10000.0
resolution = "1 ft"
[[channels]]
name = "total_air_temperature"
column = "TAT"
unit = "degC"
[[channels]]
name = "yaw"
column = "HDG"
unit = "deg"
empty = "skip"
"#;

/// Degrees, knots and feet (with an offset) and °C become rad, m/s, m and K;
/// an empty cell is a NaN dropout, or no sample where the map says `skip`;
/// unmapped columns are reported; the rate comes from the median interval.
#[test]
fn import_converts_units_to_si() {
    let outcome = common::import_case("import", FLIGHT_CSV, FLIGHT_MAP).unwrap();
    let record = &outcome.record;
    assert_eq!(record.scenario, "test flight");
    assert_eq!(outcome.unmapped, ["Flag"]);
    let alpha = record.channel("alpha").unwrap();
    assert_eq!(alpha.unit, "rad");
    assert_eq!(alpha.times, [0.0, 0.5, 1.0, 1.5]);
    assert!((alpha.values[1] - 2.6 * DEG).abs() < 1e-15);
    assert_eq!(alpha.rate, 2.0);
    let airspeed = record.channel("airspeed").unwrap();
    assert_eq!(airspeed.unit, "m/s");
    assert!((airspeed.values[0] - 200.0 * KNOT).abs() < 1e-12);
    assert!(airspeed.values[2].is_nan() && airspeed.dropouts() == 1);
    let altitude = record.channel("altitude").unwrap();
    assert!((altitude.values[3] - 30.0 * FOOT).abs() < 1e-12);
    assert_eq!(altitude.resolution, Some(FOOT));
    let temperature = record.channel("total_air_temperature").unwrap();
    assert_eq!(temperature.unit, "K");
    assert!((temperature.values[0] - 260.65).abs() < 1e-12);
    let heading = record.channel("yaw").unwrap();
    assert_eq!(heading.times, [0.0, 1.0]);
    assert!((heading.values[0] - 359.0 * DEG).abs() < 1e-12);
}

fn csv_error(
    result: aeroid::record::Result<aeroid::record::import::ImportOutcome>,
) -> (u64, String, String) {
    match result {
        Err(aeroid::record::Error::Core(aeroid_core::Error::Csv {
            line,
            column,
            message,
            ..
        })) => (line, column, message),
        other => panic!("expected a CSV error, got {other:?}"),
    }
}

/// A mapped column missing from the header: line 1 and the column's name.
#[test]
fn import_missing_column_is_named() {
    let map = FLIGHT_MAP.replace("column = \"IAS\"", "column = \"KIAS\"");
    let (line, column, message) = csv_error(common::import_case("missing", FLIGHT_CSV, &map));
    assert_eq!((line, column.as_str()), (1, "KIAS"));
    assert!(message.contains("no such column"), "{message}");
}

/// A cell that is not a number: its line and column.
#[test]
fn import_non_numeric_cell_is_named() {
    let csv = FLIGHT_CSV.replace("10020", "1002O");
    let (line, column, message) = csv_error(common::import_case("non-numeric", &csv, FLIGHT_MAP));
    assert_eq!((line, column.as_str()), (4, "ALT"));
    assert!(message.contains("'1002O' is not a number"), "{message}");
}

/// A time that does not increase: its line and the time column.
#[test]
fn import_non_monotonic_time_is_named() {
    let csv = FLIGHT_CSV.replace("1.5,2.8", "0.5,2.8");
    let (line, column, message) = csv_error(common::import_case("non-monotonic", &csv, FLIGHT_MAP));
    assert_eq!((line, column.as_str()), (5, "Time"));
    assert!(message.contains("not after the previous time"), "{message}");
}

/// A channel named twice in the map: the entry (row of the map) and its name field.
#[test]
fn import_duplicate_channel_is_named() {
    let map = FLIGHT_MAP.replace("name = \"yaw\"", "name = \"alpha\"");
    match common::import_case("duplicate", FLIGHT_CSV, &map) {
        Err(error) if error.field_errors().is_some() => {
            let problems = error.field_errors().unwrap_or_default();
            assert_eq!(problems.len(), 1, "{problems:?}");
            assert_eq!(problems[0].field, "channels[4].name");
            assert!(
                problems[0]
                    .message
                    .contains("duplicate channel name 'alpha' (also channels[0])")
            );
        }
        other => panic!("expected a map error, got {other:?}"),
    }
}

/// A column name repeated in the CSV header is an error too, not a silent pick.
#[test]
fn import_duplicate_header_is_named() {
    let csv = FLIGHT_CSV.replace("Flag", "AOA");
    let (line, column, _) = csv_error(common::import_case("duplicate-header", &csv, FLIGHT_MAP));
    assert_eq!((line, column.as_str()), (1, "AOA"));
}

/// A wrong unit for a known channel is a map problem naming the field.
#[test]
fn import_wrong_unit_is_named() {
    let map = FLIGHT_MAP.replace("unit = \"kt\"", "unit = \"deg\"");
    let error = common::import_case("wrong-unit", FLIGHT_CSV, &map)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("channels[1].unit")
            && error
                .contains("channel 'airspeed', column 'IAS': unit 'deg' is not a unit of speed"),
        "{error}"
    );
}

fn aeroid(args: &[&str]) -> String {
    let output = Command::new(env!("CARGO_BIN_EXE_aeroid"))
        .args(args)
        .env("AEROID_DATA", env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "aeroid {args:?} failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout).unwrap()
}

/// `aeroid record` with the QAR profile, then `aeroid inspect`: exactly the
/// channel set, rates and resolutions of Wang et al. 2012, Table 1 (values rounded to
/// four significant digits), plus the run's truth.toml.
#[test]
fn qar_record_inspect_snapshot() {
    let folder = common::temp_folder("qar-cli");
    let out = folder.join("record");
    let out = out.to_str().unwrap();
    aeroid(&[
        "record",
        "attas-trim",
        "--profile",
        "qar-seed000",
        "--out",
        out,
    ]);
    insta::assert_snapshot!("qar_seed000_inspect", aeroid(&["inspect", out]));
    let truth = RunTruth::read(&Path::new(out).join("truth.toml")).unwrap();
    assert_eq!(truth.kind, TruthKind::Exact);
    assert_eq!((truth.scenario.as_str(), truth.seed), ("attas-trim", 1));
    assert_eq!(truth.parameters.get("CL_alpha"), Some(&3.30));
    let aircraft = Scenario::load("attas-trim").unwrap().aircraft;
    let names: Vec<&String> = truth.parameters.keys().collect();
    let mut expected: Vec<&String> = aircraft.aero.parameters.names().iter().collect();
    expected.sort();
    assert_eq!(names, expected);
    assert!((truth.trim.airspeed - 103.0).abs() < 1e-12);
}

/// A scenario's `recorder` field picks the profile when none is given; `ideal` otherwise.
#[test]
fn scenario_names_its_default_profile() {
    let folder = common::temp_folder("default-profile");
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/attas-trim.toml"
    ))
    .unwrap()
    .replace("seed = 1", "seed = 1\nrecorder = \"flight-test-25hz\"");
    let path = common::write(&folder, "with-recorder.toml", &text);
    let scenario = Scenario::load(path.to_str().unwrap()).unwrap();
    assert_eq!(
        profile_for(&scenario, None).unwrap().name,
        "flight-test-25hz"
    );
    assert_eq!(
        profile_for(&scenario, Some("qar-seed000")).unwrap().name,
        "qar-seed000"
    );
    let plain = Scenario::load("attas-trim").unwrap();
    assert_eq!(profile_for(&plain, None).unwrap().name, "ideal");
}

/// `aeroid check` tells a profile by its [[channels]] and validates it.
#[test]
fn check_accepts_a_profile() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/recorders/qar-seed000.toml");
    let report = aeroid::check::check_file(crate::common::registry(), Path::new(path)).unwrap();
    assert_eq!(report.kind, "recorder profile");
    assert!(report.lines[0].contains("35 channels"));
    let folder = common::temp_folder("check-profile");
    let bad = common::write(
        &folder,
        "bad.toml",
        "name = \"x\"\n[[channels]]\nname = \"pitch\"\nrate = -1\n",
    );
    let error = aeroid::check::check_file(crate::common::registry(), &bad)
        .unwrap_err()
        .to_string();
    assert!(error.contains("channels.pitch.rate"), "{error}");
}

/// Load factors may come in g or m/s²: both are read as multiples of g0.
#[test]
fn import_load_factor_in_g_or_acceleration() {
    let csv = "t,NZ,AZ\n0,1.02,10.0\n1,0.98,9.0\n";
    let map = r#"
        [time]
        column = "t"
        [[channels]]
        name = "nz"
        column = "NZ"
        unit = "g"
        [[channels]]
        name = "ny"
        column = "AZ"
        unit = "m/s^2"
    "#;
    let record = common::import_case("load-factor", csv, map).unwrap().record;
    assert_eq!(record.channel("nz").unwrap().values, [1.02, 0.98]);
    let ny = &record.channel("ny").unwrap().values;
    assert!((ny[0] - 10.0 / aeroid::units::STANDARD_GRAVITY).abs() < 1e-15);
}

/// A non-finite offset in the map is a map problem naming the field, for
/// the time column and for a channel.
#[test]
fn import_non_finite_offset_is_named() {
    let map = FLIGHT_MAP.replace("column = \"Time\"", "column = \"Time\"\noffset = nan");
    let error = common::import_case("nan-time-offset", FLIGHT_CSV, &map)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("map.toml") && error.contains("time.offset: must be a finite number"),
        "{error}"
    );
    let map = FLIGHT_MAP.replace("offset = -10000.0", "offset = inf");
    let error = common::import_case("inf-channel-offset", FLIGHT_CSV, &map)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("channels[2].offset: must be a finite number"),
        "{error}"
    );
}

/// A time scale so large that converted times overflow is refused, naming
/// the time column, instead of importing a record with infinite times.
#[test]
fn import_time_overflowing_on_conversion_is_refused() {
    let map = FLIGHT_MAP.replace(
        "column = \"Time\"",
        "column = \"Time\"\nscale = 1e308\nunit = \"h\"",
    );
    let error = common::import_case("time-overflow", FLIGHT_CSV, &map)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("map.toml")
            && error.contains("time: column 'Time' converted to seconds is inf")
            && error.contains("keep times finite and increasing"),
        "{error}"
    );
}

/// A seed above i64::MAX cannot be stored in record.toml (TOML integers are
/// signed 64-bit): writing refuses it, naming the field, rather than writing
/// a record that does not read back. In memory the record is valid: a Monte
/// Carlo case's recorder seed may be any u64.
#[test]
fn record_seed_beyond_toml_integers_is_refused() {
    let folder = common::temp_folder("huge-seed");
    let record = FlightRecord {
        scenario: "huge seed".into(),
        seed: Some(15_161_483_648_911_747_848),
        profile: "test".into(),
        absent: Vec::new(),
        channels: vec![channel("q", "rad/s", 1.0, vec![0.0, 1.0], vec![0.1, 0.2])],
        bridge_gaps: false,
    };
    record.validate(&folder).unwrap();
    let error = record.write(&folder.join("rec")).unwrap_err().to_string();
    assert!(
        error.contains("seed: 15161483648911747848 is above 9223372036854775807"),
        "{error}"
    );
    let fits = FlightRecord {
        seed: Some(i64::MAX as u64),
        ..record
    };
    fits.write(&folder.join("fits")).unwrap();
    assert_same(&fits, &FlightRecord::read(&folder.join("fits")).unwrap());
}

/// Extreme nominal rates name their shared CSV file in a few characters
/// (a plain 1e300 would be a 300-digit file name the file system refuses).
#[test]
fn extreme_rates_give_short_file_names() {
    let folder = common::temp_folder("extreme-rates");
    let times = vec![0.0, 1.0];
    let record = FlightRecord {
        scenario: "extreme rates".into(),
        seed: None,
        profile: "test".into(),
        absent: Vec::new(),
        channels: vec![
            channel("q", "rad/s", 1e300, times.clone(), vec![0.1, 0.2]),
            channel("r", "rad/s", 1e300, times.clone(), vec![0.1, 0.2]),
            channel("p", "rad/s", 1e-300, vec![0.5, 2.0], vec![0.1, 0.2]),
            channel("nz", "-", 1e-300, vec![0.5, 2.0], vec![1.0, 1.0]),
        ],
        bridge_gaps: false,
    };
    let data = folder.join("rec");
    record.write(&data).unwrap();
    let mut files: Vec<String> = std::fs::read_dir(&data)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(
        files,
        [
            "rate_1p000e-300hz.csv",
            "rate_1p000e300hz.csv",
            "record.toml"
        ]
    );
    assert_same(&record, &FlightRecord::read(&data).unwrap());
}

/// A time scale that makes sample intervals so short that the rate from
/// the median interval overflows is refused, naming the channel's rate.
#[test]
fn import_rate_overflowing_from_the_time_scale_is_named() {
    let map = FLIGHT_MAP.replace("column = \"Time\"", "column = \"Time\"\nscale = 5e-324");
    let csv = "Time,AOA,IAS,ALT,TAT,Flag,HDG\n544,2.5,200,10000,-12.5,1,359\n545,2.6,201,10010,-12.25,0,1\n";
    let error = common::import_case("rate-overflow", csv, &map)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("map.toml")
            && error.contains("channels[0].rate: channel 'alpha': its median sample interval gives a rate of inf Hz"),
        "{error}"
    );
}

/// `qar-seed000-vanes` is `qar-seed000` with its angle of attack working
/// and a sideslip vane added, nothing else (its file copies the QAR's
/// channels, so this keeps the two from drifting apart): every other
/// channel the same in every field, the angle of attack without the fault
/// and with the attitude's resolution, one more channel, `beta`.
#[test]
fn the_vanes_profile_is_the_qar_with_working_vanes() {
    let qar = Profile::load("qar-seed000", None).unwrap();
    let vanes = Profile::load("qar-seed000-vanes", None).unwrap();
    assert_eq!(vanes.channels.len(), qar.channels.len() + 1);
    for (a, b) in qar.channels.iter().zip(&vanes.channels) {
        assert_eq!(a.measurand.name, b.measurand.name);
        if a.measurand.name == "alpha" {
            assert!(a.fault.is_some() && b.fault.is_none());
            assert_eq!(b.resolution, Some(0.1 * DEG));
            assert_eq!((a.rate, a.offset), (b.rate, b.offset));
        } else {
            assert_eq!(format!("{a:?}"), format!("{b:?}"));
        }
    }
    let beta = vanes.channels.last().unwrap();
    assert_eq!(beta.measurand.name, "beta");
    assert_eq!((beta.rate, beta.resolution), (1.0, Some(0.1 * DEG)));
    assert_eq!(qar.absent, ["p", "q", "r", "beta", "airspeed"]);
    assert_eq!(vanes.absent, ["p", "q", "r", "airspeed"]);
}
