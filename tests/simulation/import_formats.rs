//! Importing real flight data in the forms analysts have: a headerless,
//! whitespace-separated ASCII file in mixed units (ft, kt, deg, two engines'
//! thrust in lbf, density in slug/ft³, angular accelerations in deg/s², a
//! split aileron) with comment lines, CRLF line ends and a byte-order mark
//! imports into the same record as its headed-CSV twin in SI, and equation
//! error gives the same estimate on both; the altitude conventions; and bad
//! input named by file, line and column.
//!
//! The flight: the bundled ATTAS elevator 3-2-1-1 recorded by the ideal
//! profile (every channel at 100 Hz, no error), so that the two files differ
//! only by their units and layout.

use crate::common;
use aeroid::estimation::methods::equation_error::{EquationErrorOptions, equation_error};
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::FlightRecord;
use aeroid::record::import::{ImportOutcome, import};
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::atmosphere::Atmosphere;
use aeroid::sim::scenario::Scenario;
use aeroid::units::{DEG, FOOT, KNOT, POUND_FORCE, SLUG};
use std::sync::OnceLock;

/// The ideal record of the ATTAS 3-2-1-1 (module documentation).
fn flight() -> &'static FlightRecord {
    static FLIGHT: OnceLock<FlightRecord> = OnceLock::new();
    FLIGHT.get_or_init(|| {
        let scenario = Scenario::load("attas-elevator-3211").unwrap();
        let profile = Profile::load("ideal", None).unwrap();
        record_scenario(&scenario, &profile).unwrap().0
    })
}

/// A channel of the file: its record channel, its factor from SI to the
/// file's unit and the unit as the map writes it.
struct Column {
    channel: &'static str,
    unit: &'static str,
    /// File value = SI value / factor.
    factor: f64,
}

const fn column(channel: &'static str, unit: &'static str, factor: f64) -> Column {
    Column {
        channel,
        unit,
        factor,
    }
}

/// The channels of both files; the thrust and the aileron are written as
/// two columns each in the ASCII file.
fn columns() -> Vec<Column> {
    let slug_per_cubic_foot = SLUG / (FOOT * FOOT * FOOT);
    vec![
        column("airspeed", "kt", KNOT),
        column("alpha", "deg", DEG),
        column("beta", "deg", DEG),
        column("p", "deg/s", DEG),
        column("q", "deg/s", DEG),
        column("r", "deg/s", DEG),
        column("roll", "deg", DEG),
        column("pitch", "deg", DEG),
        column("nx", "", 1.0),
        column("ny", "", 1.0),
        column("nz", "", 1.0),
        column("altitude", "ft", FOOT),
        column("dynamic_pressure", "psf", POUND_FORCE / (FOOT * FOOT)),
        column("mach", "", 1.0),
        column("elevator", "deg", DEG),
        column("rudder", "deg", DEG),
        column("flap", "deg", DEG),
        column("throttle", "%", 0.01),
        column("density", "slug/ft3", slug_per_cubic_foot),
        column("p_dot", "deg/s2", DEG),
        column("q_dot", "deg/s2", DEG),
        column("r_dot", "deg/s2", DEG),
        column("temperature", "degC", 1.0),
    ]
}

/// The SI value of a channel at sample k.
fn value(record: &FlightRecord, name: &str, k: usize) -> f64 {
    record.channel(name).unwrap().values[k]
}

/// The headed CSV in SI and its map.
fn headed_twin(record: &FlightRecord) -> (String, String) {
    let names: Vec<&str> = columns()
        .iter()
        .map(|c| c.channel)
        .chain(["aileron", "thrust"])
        .collect();
    let times = &record.channel("airspeed").unwrap().times;
    let mut csv = format!("time,{}\n", names.join(","));
    for (k, t) in times.iter().enumerate() {
        let row: Vec<String> = names
            .iter()
            .map(|n| value(record, n, k).to_string())
            .collect();
        csv += &format!("{t},{}\n", row.join(","));
    }
    let mut map = "name = \"twin\"\n[time]\ncolumn = \"time\"\n".to_string();
    for name in names {
        map += &format!("[[channels]]\nname = \"{name}\"\ncolumn = \"{name}\"\n");
    }
    (csv, map)
}

/// The headerless ASCII file in mixed units (with a BOM, comments and
/// CRLF) and its map: time in column 1, then the channels of [`columns`],
/// then the left and right aileron, then the two engines' thrust.
fn ascii_twin(record: &FlightRecord) -> (String, String) {
    let columns = columns();
    let times = &record.channel("airspeed").unwrap().times;
    let mut text =
        "\u{feff}% ATTAS flight test, elevator 3-2-1-1\r\n# units: see the map\r\n".to_string();
    for (k, t) in times.iter().enumerate() {
        let mut cells = vec![t.to_string()];
        for c in &columns {
            let si = value(record, c.channel, k);
            let raw = match c.unit {
                "degC" => si - 273.15,
                _ => si / c.factor,
            };
            cells.push(raw.to_string());
        }
        let aileron = value(record, "aileron", k) / DEG;
        cells.push(aileron.to_string());
        cells.push((-aileron).to_string());
        let engine = value(record, "thrust", k) / 2.0 / POUND_FORCE;
        cells.push(engine.to_string());
        cells.push(engine.to_string());
        text += &cells.join("   ");
        text += "\r\n";
        if k == 10 {
            text += "% a comment between data lines\r\n\r\n";
        }
    }
    let mut map = "name = \"twin\"\n[file]\nheader = false\n[time]\ncolumn = 1\n".to_string();
    for (i, c) in columns.iter().enumerate() {
        // A dimensionless channel's unit is left out (an empty one is refused).
        let unit = match c.unit {
            "" => String::new(),
            unit => format!("unit = \"{unit}\"\n"),
        };
        map += &format!(
            "[[channels]]\nname = \"{}\"\ncolumn = {}\n{unit}",
            c.channel,
            i + 2,
        );
    }
    let n = columns.len() + 2;
    map += &format!(
        "[[channels]]\nname = \"aileron\"\ncolumns = [{n}, {}]\ncombine = \"half_difference\"\nunit = \"deg\"\n",
        n + 1
    );
    map += &format!(
        "[[channels]]\nname = \"thrust\"\ncolumns = [{}, {}]\ncombine = \"sum\"\nunit = \"lbf\"\n",
        n + 2,
        n + 3
    );
    (text, map)
}

fn import_files(test: &str, data: &str, map: &str, extension: &str) -> ImportOutcome {
    let folder = common::temp_folder(test);
    let data = common::write(&folder, &format!("flight.{extension}"), data);
    let map = common::write(&folder, "map.toml", map);
    import(&data, &map, aeroid::estimation::CHANNELS_READ).unwrap()
}

/// The two files give the same record: the same channels, units and
/// times, values within 1e-12 relative (the unit factors' rounding), and
/// the ASCII file's comment lines, CRLF and BOM change nothing.
#[test]
fn headerless_ascii_in_mixed_units_imports_like_its_headed_si_twin() {
    let record = flight();
    let (csv, csv_map) = headed_twin(record);
    let (ascii, ascii_map) = ascii_twin(record);
    let headed = import_files("twin-csv", &csv, &csv_map, "csv");
    let headerless = import_files("twin-asc", &ascii, &ascii_map, "asc");
    assert!(headed.unmapped.is_empty() && headerless.unmapped.is_empty());
    let (a, b) = (&headed.record, &headerless.record);
    assert_eq!(a.channels.len(), b.channels.len());
    for channel in &a.channels {
        let other = b.channel(&channel.name).unwrap();
        assert_eq!(channel.unit, other.unit, "{}", channel.name);
        assert_eq!(channel.times, other.times, "{}", channel.name);
        assert_eq!(channel.values.len(), other.values.len());
        let scale = channel
            .values
            .iter()
            .fold(0.0_f64, |m, v| m.max(v.abs()))
            .max(1e-300);
        for (x, y) in channel.values.iter().zip(&other.values) {
            assert!(
                (x - y).abs() <= 1e-12 * scale,
                "{}: {x} vs {y}",
                channel.name
            );
        }
        // The values are the recorded SI values.
        let original = record.channel(&channel.name).unwrap();
        assert_eq!(channel.values, original.values, "{}", channel.name);
    }
    assert_eq!(b.channel("thrust").unwrap().unit, "N");
    assert_eq!(b.channel("density").unwrap().unit, "kg/m3");
    assert_eq!(b.channel("q_dot").unwrap().unit, "rad/s2");
    // Channels no estimator reads are named in warnings, the same in both.
    let warned: Vec<&str> = headerless
        .warnings
        .iter()
        .map(|w| w.channel.as_str())
        .collect();
    assert_eq!(
        warned,
        headed
            .warnings
            .iter()
            .map(|w| w.channel.as_str())
            .collect::<Vec<_>>()
    );
    // Equation error reads the angular accelerations, the derive step
    // the temperature: neither is "read by nothing".
    for name in ["p_dot", "q_dot", "r_dot", "temperature"] {
        assert!(!warned.contains(&name), "{name}: {warned:?}");
    }
    // Measured thrust and density are read (equation error, output error
    // and the filters).
    for name in ["thrust", "density"] {
        assert!(!warned.contains(&name), "{name}: {warned:?}");
    }
    assert!(!warned.contains(&"alpha"));
    // The record written and read back is the same record.
    let folder = common::temp_folder("twin-round-trip");
    b.write(&folder.join("rec")).unwrap();
    let back = FlightRecord::read(&folder.join("rec")).unwrap();
    assert_eq!(back.channels, b.channels);
}

/// Equation error on the two imported records gives the same estimate:
/// every parameter within 1e-9 relative; the standard errors, which on
/// ideal data are rounding noise (1e-15), within 1e-12.
#[test]
fn equation_error_gives_the_same_estimate_on_both_twins() {
    let record = flight();
    let (csv, csv_map) = headed_twin(record);
    let (ascii, ascii_map) = ascii_twin(record);
    let headed = import_files("twin-ee-csv", &csv, &csv_map, "csv").record;
    let headerless = import_files("twin-ee-asc", &ascii, &ascii_map, "asc").record;
    let structure = ModelStructure::load("attas-longitudinal").unwrap();
    let options = EquationErrorOptions::default();
    let a = equation_error(&headed, &structure, &options).unwrap();
    let b = equation_error(&headerless, &structure, &options).unwrap();
    assert!(!a.parameters.is_empty());
    // The rate from the median sample interval is not exactly 100 Hz in
    // binary; it prints as people write it.
    let rate = headerless.channel("alpha").unwrap().rate;
    assert!((rate - 100.0).abs() < 1e-6 && rate != 100.0, "{rate}");
    let notes = b.notes.join("\n");
    assert!(
        notes.contains("at 100 Hz") && notes.contains("(100 Hz)") && !notes.contains("99.99"),
        "{notes}"
    );
    for (x, y) in a.parameters.iter().zip(&b.parameters) {
        assert_eq!(x.name, y.name);
        assert!(
            (x.value - y.value).abs() <= 1e-9 * x.value.abs().max(1e-6),
            "{}: {} vs {}",
            x.name,
            x.value,
            y.value
        );
        assert!(
            (x.standard_error - y.standard_error).abs() <= 1e-6 * x.standard_error + 1e-12,
            "{}: σ {} vs {}",
            x.name,
            x.standard_error,
            y.standard_error
        );
    }
}

/// An altitude given as geometric is converted to geopotential,
/// H = r0·z/(r0 + z); one given as geopotential (the default) or as
/// pressure altitude is kept, the latter with a warning; a temperature in
/// °C gets +273.15 K; FL is 100 ft.
#[test]
fn altitude_conventions_and_offset_units_convert() {
    let data = "0 10000 15 100\n1 10000 15 100\n";
    let map = |convention: &str| {
        format!(
            "[file]\nheader = false\n[time]\ncolumn = 1\n\
             [[channels]]\nname = \"altitude\"\ncolumn = 2\nunit = \"m\"\n{convention}\
             [[channels]]\nname = \"temperature\"\ncolumn = 3\nunit = \"°C\"\n\
             [[channels]]\nname = \"pressure_altitude\"\ncolumn = 4\nunit = \"FL\"\n"
        )
    };
    let geometric = import_files(
        "convention-geometric",
        data,
        &map("convention = \"geometric\"\n"),
        "asc",
    );
    let altitude = geometric.record.channel("altitude").unwrap().values[0];
    assert!((altitude - 9_984.3).abs() < 0.05, "{altitude}");
    assert_eq!(altitude, Atmosphere::geopotential_altitude(10_000.0));
    let temperature = geometric.record.channel("temperature").unwrap().values[0];
    assert!((temperature - 288.15).abs() < 1e-12);
    let flight_level = geometric
        .record
        .channel("pressure_altitude")
        .unwrap()
        .values[0];
    assert!((flight_level - 3048.0).abs() < 1e-9);
    let plain = import_files("convention-default", data, &map(""), "asc");
    assert_eq!(
        plain.record.channel("altitude").unwrap().values[0],
        10_000.0
    );
    let pressure = import_files(
        "convention-pressure",
        data,
        &map("convention = \"pressure\"\n"),
        "asc",
    );
    assert_eq!(
        pressure.record.channel("altitude").unwrap().values[0],
        10_000.0
    );
    assert!(
        pressure
            .warnings
            .iter()
            .any(|w| w.channel == "altitude" && w.message.contains("standard day")),
        "{:?}",
        pressure.warnings
    );
    let error = common::import_case(
        "convention-wrong-channel",
        "t,a\n0,1\n1,2\n",
        "[time]\ncolumn = \"t\"\n[[channels]]\nname = \"alpha\"\ncolumn = \"a\"\nconvention = \"geometric\"\n",
    )
    .unwrap_err()
    .to_string();
    assert!(error.contains("channels[0].convention"), "{error}");
}

/// Combined channels: the sum of two thrusts, the mean of two vanes, the
/// half-difference of left and right ailerons; comma-separated headerless
/// lines work too.
#[test]
fn several_columns_form_one_channel() {
    let data = "# t, left, right, vane1, vane2\n0, 1000, 1200, 2, 4\n1, 1100, 1300, 3, 5\n";
    let map = "[file]\nheader = false\n[time]\ncolumn = 1\n\
               [[channels]]\nname = \"thrust\"\ncolumns = [2, 3]\ncombine = \"sum\"\nunit = \"kN\"\n\
               [[channels]]\nname = \"alpha\"\ncolumns = [4, 5]\ncombine = \"mean\"\nunit = \"deg\"\n\
               [[channels]]\nname = \"aileron\"\ncolumns = [4, 5]\ncombine = \"half_difference\"\nunit = \"rad\"\n";
    let outcome = import_files("combine", data, map, "asc");
    let record = &outcome.record;
    assert_eq!(record.channel("thrust").unwrap().values, [2.2e6, 2.4e6]);
    let alpha = &record.channel("alpha").unwrap().values;
    assert!((alpha[0] - 3.0 * DEG).abs() < 1e-15 && (alpha[1] - 4.0 * DEG).abs() < 1e-15);
    assert_eq!(record.channel("aileron").unwrap().values, [-1.0, -1.0]);
    assert!(
        record
            .channel("thrust")
            .unwrap()
            .source
            .contains("sum of columns 2, 3")
    );
}

fn import_error(test: &str, data: &str, map: &str) -> String {
    let folder = common::temp_folder(test);
    let data = common::write(&folder, "flight.asc", data);
    let map = common::write(&folder, "map.toml", map);
    import(&data, &map, aeroid::estimation::CHANNELS_READ)
        .unwrap_err()
        .to_string()
}

const BAD_MAP_HEAD: &str = "[file]\nheader = false\n[time]\ncolumn = 1\n";

/// Bad input is named: an unknown unit and a unit of another dimension by
/// the map file, field, channel and column; a column number beyond the
/// row, a cell that is not a number and a short line by the data file,
/// line and column.
#[test]
fn bad_headerless_input_names_file_line_and_column() {
    let data = "% header comment\n0 1.5 2\n0.1 1.6 2\n0.2 x 2\n";
    let unknown = import_error(
        "bad-unknown-unit",
        data,
        &format!(
            "{BAD_MAP_HEAD}[[channels]]\nname = \"density\"\ncolumn = 2\nunit = \"slugs/furlong3\"\n"
        ),
    );
    assert!(
        unknown.contains("map.toml")
            && unknown.contains("channels[0].unit")
            && unknown.contains("channel 'density', column 2: unit 'slugs/furlong3' is not a unit of density; accepted: kg/m3"),
        "{unknown}"
    );
    let wrong = import_error(
        "bad-wrong-dimension",
        data,
        &format!("{BAD_MAP_HEAD}[[channels]]\nname = \"q_dot\"\ncolumn = 2\nunit = \"deg/s\"\n"),
    );
    assert!(
        wrong.contains("channel 'q_dot', column 2: unit 'deg/s' is not a unit of angular acceleration; accepted: rad/s2"),
        "{wrong}"
    );
    let beyond = import_error(
        "bad-beyond",
        data,
        &format!("{BAD_MAP_HEAD}[[channels]]\nname = \"alpha\"\ncolumn = 7\n"),
    );
    assert!(
        beyond.contains(
            "flight.asc: line 2, column '7': column number 7 is beyond the row, which has 3 columns"
        ),
        "{beyond}"
    );
    let cell = import_error(
        "bad-cell",
        data,
        &format!("{BAD_MAP_HEAD}[[channels]]\nname = \"alpha\"\ncolumn = 2\n"),
    );
    assert!(
        cell.contains("flight.asc: line 4, column '2': 'x' is not a number"),
        "{cell}"
    );
    let short = import_error(
        "bad-short-line",
        "0 1 2\n0.1 1\n",
        &format!("{BAD_MAP_HEAD}[[channels]]\nname = \"alpha\"\ncolumn = 2\n"),
    );
    assert!(
        short.contains("flight.asc: line 2")
            && short.contains("the line has 2 cells, line 1 has 3"),
        "{short}"
    );
    let name_without_header = import_error(
        "bad-name-without-header",
        data,
        &format!("{BAD_MAP_HEAD}[[channels]]\nname = \"alpha\"\ncolumn = \"AOA\"\n"),
    );
    assert!(
        name_without_header.contains("channels[0].column")
            && name_without_header.contains("the file has no header"),
        "{name_without_header}"
    );
    let zero = import_error(
        "bad-zero-column",
        data,
        &format!("{BAD_MAP_HEAD}[[channels]]\nname = \"alpha\"\ncolumn = 0\n"),
    );
    assert!(zero.contains("column numbers start at 1"), "{zero}");
    let no_combine = import_error(
        "bad-no-combine",
        data,
        &format!("{BAD_MAP_HEAD}[[channels]]\nname = \"alpha\"\ncolumns = [2, 3]\n"),
    );
    assert!(no_combine.contains("channels[0].combine"), "{no_combine}");
    let comments_only = import_error(
        "bad-comments-only",
        "# nothing\n% at all\n",
        &format!("{BAD_MAP_HEAD}[[channels]]\nname = \"alpha\"\ncolumn = 2\n"),
    );
    assert!(comments_only.contains("no data rows"), "{comments_only}");
}

/// A headed CSV may carry comment lines, CRLF and a BOM, and its columns
/// may be named by number too.
#[test]
fn headed_csv_with_comments_crlf_bom_and_numbered_columns() {
    let data = "\u{feff}# exported by a tool\r\nTime,AOA\r\n% units: s, deg\r\n0,1\r\n0.1,2\r\n";
    let map =
        "[time]\ncolumn = \"Time\"\n[[channels]]\nname = \"alpha\"\ncolumn = 2\nunit = \"deg\"\n";
    let outcome = import_files("headed-comments", data, map, "csv");
    let alpha = outcome.record.channel("alpha").unwrap();
    assert_eq!(alpha.times, [0.0, 0.1]);
    assert!((alpha.values[1] - 2.0 * DEG).abs() < 1e-15);
    assert!(alpha.source.contains("column AOA"), "{}", alpha.source);
    let cell = common::import_case(
        "headed-comments-bad-cell",
        "# c\nTime,AOA\n0,1\n0.1,y\n",
        map,
    )
    .unwrap_err()
    .to_string();
    assert!(cell.contains("line 4, column 'AOA'"), "{cell}");
}

/// A flight without density or altitude (the HFB-320 file) takes ρ from a
/// constant the map states in its unit: the density channel holds its SI
/// value at every time of the data file, its source and the import's notes
/// say it is the map's constant; a Mach stated without a unit is kept as
/// it is. A constant that is not finite, in a unit of another dimension,
/// given beside a column or with a column's scale is refused, naming the
/// map's field.
#[test]
fn a_map_states_constant_channels() {
    let data = "0 80 2.5\n0.1 81 2.6\n0.2 82 2.4\n";
    let head = "[file]\nheader = false\n[time]\ncolumn = 1\n[[channels]]\nname = \"airspeed\"\ncolumn = 2\n[[channels]]\nname = \"alpha\"\ncolumn = 3\nunit = \"deg\"\n";
    let map = format!(
        "{head}[[channels]]\nname = \"density\"\nvalue = 0.0015\nunit = \"slug/ft3\"\n[[channels]]\nname = \"mach\"\nvalue = 0.792\n"
    );
    let outcome = import_files("constant-density", data, &map, "asc");
    let density = outcome.record.channel("density").unwrap();
    let si = 0.0015 * SLUG / (FOOT * FOOT * FOOT);
    assert_eq!(density.values, [si; 3]);
    assert_eq!(density.times, [0.0, 0.1, 0.2]);
    assert_eq!(density.unit, "kg/m3");
    assert!(
        density.source.contains("constant 0.0015 slug/ft3"),
        "{}",
        density.source
    );
    assert_eq!(outcome.record.channel("mach").unwrap().values, [0.792; 3]);
    let notes = outcome.notes.join("\n");
    assert!(
        notes.contains("channel 'density': the constant 0.0015 slug/ft3 stated by the map (0.773")
            && notes.contains("channel 'mach': the constant 0.792 stated by the map"),
        "{notes}"
    );
    for (test, channel, expected) in [
        (
            "constant-nan",
            "name = \"density\"\nvalue = nan\nunit = \"kg/m3\"",
            "channels[2].value: must be a finite number, is NaN",
        ),
        (
            "constant-unit",
            "name = \"density\"\nvalue = 1.2\nunit = \"m/s\"",
            "channel 'density', constant value 1.2: unit 'm/s' is not a unit of density",
        ),
        (
            "constant-and-column",
            "name = \"density\"\nvalue = 1.2\ncolumn = 2",
            "give `value` (a constant) or `column`/`columns`, not both",
        ),
        (
            "constant-scale",
            "name = \"density\"\nvalue = 1.2\nscale = 2.0",
            "channels[2].scale: is for a column; channel 'density' is the constant `value`",
        ),
    ] {
        let error = import_error(test, data, &format!("{head}[[channels]]\n{channel}\n"));
        assert!(
            error.contains("map.toml") && error.contains(expected),
            "{test}: {error}"
        );
    }
}

/// The import warns of a channel only when nothing reads it: not the
/// angular accelerations (equation error's `angular_accelerations`), the
/// coefficients (a model's outputs), the derive step's inputs (ground
/// speed, split surfaces, a fuel flow per engine, total air temperature);
/// an engine's exhaust gas temperature, which nothing reads, is named with
/// what could still read it.
#[test]
fn only_channels_nothing_reads_are_warned_of() {
    let names = [
        "q_dot",
        "CL",
        "ground_speed",
        "aileron_left",
        "fuel_flow_left",
        "total_air_temperature",
        "egt_left",
    ];
    let mut map = "[file]\nheader = false\n[time]\ncolumn = 1\n".to_string();
    for (i, name) in names.iter().enumerate() {
        map += &format!(
            "[[channels]]\nname = \"{name}\"\ncolumn = {}\nunit = \"-\"\n",
            i + 2
        );
    }
    let data = "0 1 2 3 4 5 6 7\n0.1 1 2 3 4 5 6 7\n0.2 1 2 3 4 5 6 7\n";
    let map = map
        .replace(
            "name = \"q_dot\"\ncolumn = 2\nunit = \"-\"",
            "name = \"q_dot\"\ncolumn = 2\nunit = \"rad/s2\"",
        )
        .replace("column = 4\nunit = \"-\"", "column = 4\nunit = \"m/s\"")
        .replace("column = 5\nunit = \"-\"", "column = 5\nunit = \"rad\"")
        .replace("column = 6\nunit = \"-\"", "column = 6\nunit = \"kg/s\"")
        .replace("column = 7\nunit = \"-\"", "column = 7\nunit = \"K\"")
        .replace("column = 8\nunit = \"-\"", "column = 8\nunit = \"K\"");
    let outcome = import_files("warned-channels", data, &map, "asc");
    let warned: Vec<(&str, &str)> = outcome
        .warnings
        .iter()
        .map(|w| (w.channel.as_str(), w.message.as_str()))
        .collect();
    assert_eq!(warned.len(), 1, "{warned:?}");
    assert_eq!(warned[0].0, "egt_left");
    assert!(
        warned[0].1.contains("a linear model may name it"),
        "{}",
        warned[0].1
    );
}

/// Physical sanity at import: a temperature below absolute zero (a
/// column in °C mapped as K), an altitude below the Earth's centre (a
/// scale off by thousands), a column combined with itself and an empty
/// unit are refused, each naming the channel, the column or the map's key,
/// and the value where there is one.
#[test]
fn unphysical_channels_and_degenerate_maps_are_refused() {
    let data = "0 80 -300 10\n0.1 81 -280 11\n0.2 82 -290 12\n";
    let head = "[file]\nheader = false\n[time]\ncolumn = 1\n[[channels]]\nname = \"airspeed\"\ncolumn = 2\n";
    for (case, channel, says) in [
        (
            "below-zero-kelvin",
            "name = \"temperature\"\ncolumn = 3\nunit = \"K\"",
            &[
                "channel 'temperature' (import: column 3",
                "reads -300 K at t = 0 s, below absolute zero",
            ][..],
        ),
        (
            "inside-the-earth",
            "name = \"altitude\"\ncolumn = 3\nunit = \"km\"\nscale = 30",
            &[
                "channel 'altitude'",
                "reads -9000000 m",
                "below the Earth's centre",
            ],
        ),
        (
            "combined-with-itself",
            "name = \"thrust\"\ncolumns = [4, 4]\ncombine = \"sum\"",
            &["channels[1].columns: column 4 is combined with itself"],
        ),
        (
            "empty-unit",
            "name = \"elevator\"\ncolumn = 4\nunit = \"\"",
            &["channels[1].unit: is empty", "channel 'elevator'"],
        ),
    ] {
        let map = format!("{head}[[channels]]\n{channel}\n");
        let error = common::import_case(case, data, &map)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        for text in says {
            assert!(error.contains(text), "{case}: expected '{text}' in {error}");
        }
    }
    // In °C the same column is a plausible temperature.
    let map = format!("{head}[[channels]]\nname = \"temperature\"\ncolumn = 4\nunit = \"degC\"\n");
    common::import_case("celsius", data, &map).unwrap();
}
