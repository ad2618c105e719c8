//! MATLAB level-5 MAT-files in and out: a record exported to `.mat` imports
//! back through the same column map as its whitespace-ASCII twin, bit for
//! bit; named vectors of singles and integers import with their scale;
//! the export of a multi-rate record keeps each time base; and the formats
//! aeroid does not read (v7.3, level 4, binary junk) are refused with the
//! format and the file named. Files are made in the tests.

use crate::common;
use aeroid::record::export::{ExportFormat, export};
use aeroid::record::import::import;
use aeroid::record::mat::MatTable;
use aeroid::record::mat::write::{Values, Variable, write};
use aeroid::record::{Channel, FlightRecord};
use aeroid::units::DEG;
use std::path::Path;

fn channel(name: &str, unit: &str, times: &[f64], value: impl Fn(f64) -> f64) -> Channel {
    Channel {
        name: name.into(),
        unit: unit.into(),
        rate: 1.0 / (times[1] - times[0]),
        resolution: None,
        source: "test".into(),
        times: times.to_vec(),
        values: times.iter().map(|&t| value(t)).collect(),
    }
}

/// Four channels at 20 Hz over 3 s (values that are not short decimals),
/// `q` with one dropout.
fn record() -> FlightRecord {
    let times: Vec<f64> = (0..60).map(|k| 0.05 * k as f64 + 0.013).collect();
    let mut q = channel("q", "rad/s", &times, |t| 0.1 * (2.1 * t).sin() / 3.0);
    q.values[17] = f64::NAN;
    FlightRecord {
        scenario: "mat".into(),
        seed: None,
        profile: "test".into(),
        absent: Vec::new(),
        channels: vec![
            channel("alpha", "rad", &times, |t| 0.05 + 0.02 * (1.3 * t).cos()),
            q,
            channel(
                "elevator",
                "rad",
                &times,
                |t| {
                    if t > 1.0 { -0.03 } else { 0.0 }
                },
            ),
            channel("airspeed", "m/s", &times, |t| 100.0 + t / 7.0),
        ],
        bridge_gaps: false,
    }
}

/// The map by column numbers: time in 1, then the channels in order.
const NUMBERED_MAP: &str = r#"
[file]
header = false
[time]
column = 1
[[channels]]
name = "alpha"
column = 2
[[channels]]
name = "q"
column = 3
non_finite = "dropout"
[[channels]]
name = "elevator"
column = 4
[[channels]]
name = "airspeed"
column = 5
"#;

fn bits(values: &[f64]) -> Vec<u64> {
    values
        .iter()
        .map(|v| if v.is_nan() { u64::MAX } else { v.to_bits() })
        .collect()
}

fn import_error(data: &Path, map: &Path) -> String {
    import(data, map, aeroid::estimation::CHANNELS_READ)
        .expect_err("the import must fail")
        .to_string()
}

/// The export writes `data` (time, then a column per channel), `names` and
/// `units`; imported with the numbered map it gives the record back with
/// every time and value bit for bit (doubles carry them exactly), the
/// dropout a dropout; the same map on the record written as whitespace
/// ASCII (in a `.mat` file, as `save -ascii` writes it) gives the same record.
#[test]
fn a_record_exported_to_mat_imports_back_bit_for_bit() {
    let folder = common::temp_folder("mat-round-trip");
    let original = record();
    let mat = folder.join("flight.mat");
    let holds = export(&original, ExportFormat::Mat, &mat).unwrap();
    assert_eq!(
        holds,
        ["data: 60 × 5 double", "names: 5 names", "units: 5 names"]
    );
    let table = MatTable::read(&mat, None).unwrap();
    assert_eq!(
        table.headers(),
        [
            "data(:,1)",
            "data(:,2)",
            "data(:,3)",
            "data(:,4)",
            "data(:,5)"
        ]
    );
    assert_eq!(table.len(0), 60);

    let map = common::write(&folder, "map.toml", NUMBERED_MAP);
    let from_mat = import(&mat, &map, aeroid::estimation::CHANNELS_READ).unwrap();
    let mut ascii = String::new();
    for k in 0..60 {
        let cells: Vec<String> = std::iter::once(original.channels[0].times[k])
            .chain(original.channels.iter().map(|c| c.values[k]))
            .map(|v| v.to_string())
            .collect();
        ascii += &cells.join("  ");
        ascii += "\n";
    }
    // Named as MATLAB's `save -ascii` may name it: text all the same.
    let text = common::write(&folder, "ascii.mat", &ascii);
    let from_text = import(&text, &map, aeroid::estimation::CHANNELS_READ).unwrap();
    for imported in [&from_mat.record, &from_text.record] {
        for (got, want) in imported.channels.iter().zip(&original.channels) {
            assert_eq!((&got.name, &got.unit), (&want.name, &want.unit));
            assert_eq!(bits(&got.times), bits(&want.times), "{}", got.name);
            assert_eq!(bits(&got.values), bits(&want.values), "{}", got.name);
        }
    }
    assert!(from_mat.unmapped.is_empty(), "{:?}", from_mat.unmapped);
    let source = &from_mat.record.channel("q").unwrap().source;
    assert!(source.contains("data(:,3)"), "{source}");
}

/// Named vectors import by name whatever their class: a single in degrees
/// to the f32 value in radians, int16 counts with their scale, a double
/// time; the file's matrix and its character matrix are left alone (the
/// matrix's columns listed as not imported).
#[test]
fn named_vectors_of_singles_and_integers_import_with_their_scale() {
    let folder = common::temp_folder("mat-vectors");
    let alpha: Vec<f32> = vec![1.5, 2.25, -0.125, 3.0];
    let counts: Vec<i16> = vec![0, -120, 250, 32767];
    let data = folder.join("vectors.mat");
    let vector = |name: &str, values: Values| Variable::Numeric {
        name: name.into(),
        rows: 4,
        cols: 1,
        values,
    };
    write(
        &data,
        &[
            Variable::Numeric {
                name: "other".into(),
                rows: 2,
                cols: 2,
                values: Values::Double(vec![1.0, 2.0, 3.0, 4.0]),
            },
            Variable::Text {
                name: "label".into(),
                lines: vec!["flight 7".into()],
            },
            vector("t", Values::Double(vec![0.0, 0.04, 0.08, 0.12])),
            vector("AOA", Values::Single(alpha.clone())),
            vector("DE", Values::Int16(counts.clone())),
        ],
        "test",
    )
    .unwrap();
    let map = common::write(
        &folder,
        "map.toml",
        r#"
[time]
column = "t"
[[channels]]
name = "alpha"
column = "AOA"
unit = "deg"
[[channels]]
name = "elevator"
column = "DE"
unit = "deg"
scale = 0.01
"#,
    );
    let outcome = import(&data, &map, aeroid::estimation::CHANNELS_READ).unwrap();
    let record = &outcome.record;
    let alpha_si: Vec<f64> = alpha.iter().map(|&a| f64::from(a) * DEG).collect();
    assert_eq!(record.channel("alpha").unwrap().values, alpha_si);
    let elevator: Vec<f64> = counts.iter().map(|&c| f64::from(c) * 0.01 * DEG).collect();
    assert_eq!(record.channel("elevator").unwrap().values, elevator);
    assert_eq!(
        record.channel("alpha").unwrap().times,
        [0.0, 0.04, 0.08, 0.12]
    );
    assert_eq!(outcome.unmapped, ["other(:,1)", "other(:,2)"]);
}

/// Channels on several time bases export as one matrix per base, named
/// after the base (`data_rate_20hz`, `data_mach`), each with its names.
#[test]
fn a_multi_rate_record_exports_a_matrix_per_time_base() {
    let folder = common::temp_folder("mat-multi-rate");
    let mut rec = record();
    let slow: Vec<f64> = (0..4).map(|k| k as f64).collect();
    rec.channels
        .push(channel("mach", "-", &slow, |t| 0.3 + 0.001 * t));
    let mat = folder.join("rec.mat");
    let holds = export(&rec, ExportFormat::Mat, &mat).unwrap();
    assert_eq!(
        holds,
        [
            "data_rate_20hz: 60 × 5 double",
            "names_rate_20hz: 5 names",
            "units_rate_20hz: 5 names",
            "data_mach: 4 × 2 double",
            "names_mach: 2 names",
            "units_mach: 2 names",
        ]
    );
    let table = MatTable::read(&mat, Some("data_mach")).unwrap();
    assert_eq!(table.values(0, 4).unwrap(), slow.as_slice());
    assert_eq!(
        table.values(1, 4).unwrap(),
        rec.channel("mach").unwrap().values.as_slice()
    );
}

/// A file with two matrices needs `matrix = "NAME"` for numbered columns:
/// without it the error lists both; with it the named one's columns are read.
#[test]
fn numbered_columns_of_one_of_several_matrices() {
    let folder = common::temp_folder("mat-two-matrices");
    let matrix = |name: &str, offset: f64| Variable::Numeric {
        name: name.into(),
        rows: 3,
        cols: 2,
        values: Values::Double(vec![0.0, 1.0, 2.0, offset, offset + 1.0, offset + 2.0]),
    };
    let data = folder.join("two.mat");
    write(&data, &[matrix("a", 10.0), matrix("b", 20.0)], "test").unwrap();
    let map_text = |choice: &str| {
        format!(
            "[file]\nheader = false\n{choice}\n[time]\ncolumn = 1\n[[channels]]\nname = \"mach\"\ncolumn = 2\n"
        )
    };
    let map = common::write(&folder, "map.toml", &map_text(""));
    let error = import_error(&data, &map);
    assert!(
        error.contains("two.mat") && error.contains("several matrices (a, b)"),
        "{error}"
    );
    let map = common::write(&folder, "map.toml", &map_text("matrix = \"b\""));
    let record = import(&data, &map, aeroid::estimation::CHANNELS_READ)
        .unwrap()
        .record;
    assert_eq!(record.channel("mach").unwrap().values, [20.0, 21.0, 22.0]);
}

/// What aeroid does not read is named, with the file: a v7.3 (HDF5) file
/// by its header text or by the HDF5 signature, a level-4 file, binary
/// junk named `.mat`, and binary junk under another name (which used to
/// give only "stream did not contain valid UTF-8").
#[test]
fn other_formats_are_refused_with_the_format_named() {
    let folder = common::temp_folder("mat-refusals");
    let map = common::write(&folder, "map.toml", NUMBERED_MAP);
    let mut v73 =
        b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Dec  7 2026 HDF5 schema 1.00 ."
            .to_vec();
    v73.resize(512, b' ');
    v73.extend_from_slice(b"\x89HDF\r\n\x1a\n");
    v73.resize(2048, 0);
    let mut hdf5 = b"\x89HDF\r\n\x1a\n".to_vec();
    hdf5.resize(1024, 0);
    // A level-4 double matrix 'x' of 1 × 1 (type 0000: little-endian, double).
    let mut v4: Vec<u8> = [0i32, 1, 1, 0, 2]
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .collect();
    v4.extend_from_slice(b"x\0");
    v4.extend_from_slice(&1.5f64.to_le_bytes());
    let junk: Vec<u8> = (0..700u32)
        .map(|k| (k.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    for (name, bytes, expected) in [
        ("new.mat", &v73, "a MATLAB v7.3 MAT-file (HDF5-based)"),
        ("plain.h5", &hdf5, "a MATLAB v7.3 MAT-file (HDF5-based)"),
        (
            "old.mat",
            &v4,
            "not a MATLAB level-5 file: it looks like a level-4",
        ),
        ("junk.mat", &junk, "not a MATLAB level-5 file"),
        ("junk.dat", &junk, "not a MATLAB level-5 file, nor text"),
    ] {
        let path = folder.join(name);
        std::fs::write(&path, bytes).unwrap();
        let error = import_error(&path, &map);
        assert!(
            error.contains(&path.display().to_string()) && error.contains(expected),
            "{name}: {error}"
        );
        assert!(!error.contains("stream did not contain"), "{name}: {error}");
    }
}
