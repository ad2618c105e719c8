//! Bringing real flight data in: a CSV file with one time column and a
//! column-map file (TOML) that says which column is which channel, in which
//! unit, with which scale and offset. Values are converted to SI with angles
//! in radians on load: `SI = (raw·scale + offset)·unit factor`, and a
//! temperature in `degC` also gets +273.15 K (files hold absolute
//! temperatures). The result is a [`FlightRecord`] like any simulated one.
//!
//! ```toml
//! name = "flight 1234"          # optional; default: the CSV file's name
//! [time]
//! column = "Time"
//! unit = "s"                    # optional, default s; scale and offset as for channels
//! [[channels]]
//! name = "airspeed"             # the channel name estimators use
//! column = "IAS"
//! unit = "kt"                   # optional, default SI
//! scale = 1.0                   # optional
//! offset = 0.0                  # optional, in the file's unit after scaling
//! rate = "8 Hz"                 # optional nominal rate; default from the median sample interval
//! resolution = "0.25 kt"        # optional
//! empty = "dropout"             # an empty cell: "dropout" (NaN sample, the default) or "skip" (no sample)
//! non_finite = "error"          # a cell reading NaN or an infinity (`nan`, `inf`, `1e400`): "error" (the default) or "dropout"
//! ```
//!
//! Nothing is silently dropped: a mapped column missing from the header, a
//! cell that is not a number, a time column that does not increase strictly
//! or a channel named twice is an error naming the row and column; an empty
//! cell becomes a dropout unless the map says `empty = "skip"` for that
//! channel; a cell that reads as NaN or an infinity is an error unless the
//! map says `non_finite = "dropout"`; a CSV without data rows is an error. Columns the map does not mention are listed in the outcome.

use crate::csv_table::{CsvTable, first_disorder};
use crate::error::{Problems, Result, parse_toml, read_text};
use crate::record::derived;
use crate::record::{Channel, FlightRecord, check_name};
use crate::units::{Dimension, Quantity, unit_factor};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Kelvin at 0 °C.
const CELSIUS_ZERO: f64 = 273.15;

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColumnMapFile {
    #[serde(default)]
    pub name: Option<String>,
    pub time: ColumnSpec,
    pub channels: Vec<ChannelColumnSpec>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColumnSpec {
    pub column: String,
    #[serde(default)]
    pub unit: Option<String>,
    #[serde(default)]
    pub scale: Option<f64>,
    #[serde(default)]
    pub offset: Option<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelColumnSpec {
    pub name: String,
    pub column: String,
    #[serde(default)]
    pub unit: Option<String>,
    #[serde(default)]
    pub scale: Option<f64>,
    #[serde(default)]
    pub offset: Option<f64>,
    #[serde(default)]
    pub rate: Option<Quantity>,
    #[serde(default)]
    pub resolution: Option<Quantity>,
    #[serde(default)]
    pub empty: EmptyCell,
    #[serde(default)]
    pub non_finite: NonFiniteCell,
}

/// What a cell that reads as NaN or an infinity means.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NonFiniteCell {
    /// The import fails, naming the file, line and column.
    #[default]
    Error,
    /// The sample was lost: kept as NaN.
    Dropout,
}

/// What an empty cell of a channel column means.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EmptyCell {
    /// A sample was due but lost: kept as NaN.
    #[default]
    Dropout,
    /// The channel has no sample at this row (multi-rate exports).
    Skip,
}

/// A raw-to-SI conversion: `(raw·scale + offset)·factor + shift`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Conversion {
    pub scale: f64,
    pub offset: f64,
    pub factor: f64,
    pub shift: f64,
}

impl Conversion {
    pub fn apply(&self, raw: f64) -> f64 {
        (raw * self.scale + self.offset) * self.factor + self.shift
    }
}

/// One validated channel mapping.
#[derive(Debug, Clone)]
struct MappedChannel {
    name: String,
    column: String,
    unit: String,
    conversion: Conversion,
    rate: Option<f64>,
    resolution: Option<f64>,
    empty: EmptyCell,
    non_finite: NonFiniteCell,
}

/// The imported record and the CSV columns the map did not use.
#[derive(Debug, Clone)]
pub struct ImportOutcome {
    pub record: FlightRecord,
    pub unmapped: Vec<String>,
}

/// Reads `data` (CSV) with the column map at `map_path` into a flight record.
pub fn import(data: &Path, map_path: &Path) -> Result<ImportOutcome> {
    let file: ColumnMapFile = parse_toml(map_path, &read_text(map_path)?)?;
    let (time, channels) = validate_map(&file, map_path)?;
    let table = CsvTable::read(data)?;
    table.require_rows()?;
    let time_index = table.column_index(&file.time.column)?;
    let times: Vec<f64> = table
        .time_column(time_index)?
        .into_iter()
        .map(|t| time.apply(t))
        .collect();
    check_converted_times(&times, &file.time.column, map_path)?;
    let mut used = vec![file.time.column.clone()];
    let mut record_channels = Vec::with_capacity(channels.len());
    for (i, mapped) in channels.iter().enumerate() {
        let index = table.column_index(&mapped.column)?;
        used.push(mapped.column.clone());
        let raw = table.measurements(
            index,
            mapped.non_finite == NonFiniteCell::Dropout,
            &format!(
                "to record such cells as dropouts, set non_finite = \"dropout\" for channel '{}' in {}",
                mapped.name,
                map_path.display()
            ),
        )?;
        let channel = build_channel(mapped, &times, &raw, data);
        check_rate(&channel, i, map_path)?;
        record_channels.push(channel);
    }
    let unmapped = table
        .headers
        .iter()
        .filter(|h| !used.contains(h))
        .cloned()
        .collect();
    let stem = data
        .file_stem()
        .map_or(String::new(), |s| s.to_string_lossy().into_owned());
    let record = FlightRecord {
        scenario: file.name.clone().unwrap_or(stem),
        seed: None,
        profile: format!("import:{}", map_path.display()),
        absent: Vec::new(),
        channels: record_channels,
    };
    // What the record format relies on (a channel whose cells are all
    // skipped has no samples), said of the data file before anything is written.
    record.validate(data)?;
    Ok(ImportOutcome { record, unmapped })
}

/// A channel from its column's cells (`None`: empty).
fn build_channel(
    mapped: &MappedChannel,
    times: &[f64],
    raw: &[Option<f64>],
    data: &Path,
) -> Channel {
    let (times, values): (Vec<f64>, Vec<f64>) = times
        .iter()
        .zip(raw)
        .filter(|(_, v)| v.is_some() || mapped.empty == EmptyCell::Dropout)
        .map(|(&t, &v)| (t, v.map_or(f64::NAN, |v| mapped.conversion.apply(v))))
        .unzip();
    Channel {
        name: mapped.name.clone(),
        unit: mapped.unit.clone(),
        rate: mapped.rate.unwrap_or_else(|| median_rate(&times)),
        resolution: mapped.resolution,
        source: format!("import: column '{}' of {}", mapped.column, data.display()),
        times,
        values,
    }
}

/// The time column after its scale, offset and unit: still finite and
/// strictly increasing (a huge scale or offset can make times overflow or
/// collapse onto each other).
fn check_converted_times(times: &[f64], column: &str, map_path: &Path) -> Result<()> {
    match first_disorder(times) {
        None => Ok(()),
        Some(k) => Err(crate::error::Error::Invalid {
            path: map_path.to_path_buf(),
            problems: vec![crate::error::Problem {
                field: "time".into(),
                message: format!(
                    "column '{column}' converted to seconds is {} at data row {}{}: \
                     the time scale and offset must keep times finite and increasing",
                    times[k],
                    k + 1,
                    match k {
                        0 => String::new(),
                        _ => format!(", not after {}", times[k - 1]),
                    }
                ),
            }],
        }),
    }
}

/// A channel's nominal rate, given or from the median sample interval, is
/// finite and positive (a time scale can make intervals so short that the
/// rate overflows).
fn check_rate(channel: &Channel, index: usize, map_path: &Path) -> Result<()> {
    if channel.rate.is_finite() && channel.rate > 0.0 {
        return Ok(());
    }
    Err(crate::error::Error::Invalid {
        path: map_path.to_path_buf(),
        problems: vec![crate::error::Problem {
            field: format!("channels[{index}].rate"),
            message: format!(
                "channel '{}': its median sample interval gives a rate of {} Hz; \
                 check the time scale and unit, or give the rate",
                channel.name, channel.rate
            ),
        }],
    })
}

/// The rate implied by the median sample interval (1 Hz with fewer than two samples).
fn median_rate(times: &[f64]) -> f64 {
    let mut intervals: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    if intervals.is_empty() {
        return 1.0;
    }
    intervals.sort_by(f64::total_cmp);
    1.0 / intervals[intervals.len() / 2]
}

/// Validates the whole map, reporting every problem at once.
fn validate_map(file: &ColumnMapFile, path: &Path) -> Result<(Conversion, Vec<MappedChannel>)> {
    let mut problems = Problems::default();
    let (time, _) = conversion(
        "time",
        file.time.unit.as_deref(),
        file.time.scale,
        file.time.offset,
        Some(Dimension::Time),
        &mut problems,
    );
    if time.scale <= 0.0 {
        problems.push(
            "time.scale",
            "must be positive so that time keeps increasing",
        );
    }
    if file.channels.is_empty() {
        problems.push(
            "channels",
            "must map at least one column to a channel ([[channels]] tables)",
        );
    }
    let mut channels: Vec<MappedChannel> = Vec::with_capacity(file.channels.len());
    for (i, spec) in file.channels.iter().enumerate() {
        let field = format!("channels[{i}]");
        if let Some(first) = channels.iter().position(|c| c.name == spec.name) {
            problems.push(
                format!("{field}.name"),
                format!(
                    "duplicate channel name '{}' (also channels[{first}])",
                    spec.name
                ),
            );
        }
        if let Err(message) = check_name(&spec.name) {
            problems.push(format!("{field}.name"), message);
        }
        channels.push(map_channel(spec, &field, &mut problems));
    }
    problems.finish(path, (time, channels))
}

fn map_channel(spec: &ChannelColumnSpec, field: &str, problems: &mut Problems) -> MappedChannel {
    let known = derived::measurand(&spec.name).map(|m| m.dimension);
    let (conversion, dimension) = conversion(
        field,
        spec.unit.as_deref(),
        spec.scale,
        spec.offset,
        known,
        problems,
    );
    let unit = derived::measurand(&spec.name).map_or_else(
        || match dimension.si_unit() {
            "" => "-".to_string(),
            unit => unit.to_string(),
        },
        |m| m.unit.to_string(),
    );
    let mut positive = |name: &str, q: &Option<Quantity>, dimension: Dimension| {
        q.as_ref().and_then(|q| match q.si(dimension) {
            Ok(v) if v > 0.0 => Some(v),
            Ok(v) => {
                problems.push(
                    format!("{field}.{name}"),
                    format!("must be positive, is {v}"),
                );
                None
            }
            Err(message) => {
                problems.push(format!("{field}.{name}"), message);
                None
            }
        })
    };
    MappedChannel {
        name: spec.name.clone(),
        column: spec.column.clone(),
        unit,
        conversion,
        rate: positive("rate", &spec.rate, Dimension::Frequency),
        resolution: positive("resolution", &spec.resolution, dimension),
        empty: spec.empty,
        non_finite: spec.non_finite,
    }
}

/// The conversion of a column in `unit` with scale and offset; the dimension
/// is the known channel's, else the first one the unit belongs to.
fn conversion(
    field: &str,
    unit: Option<&str>,
    scale: Option<f64>,
    offset: Option<f64>,
    known: Option<Dimension>,
    problems: &mut Problems,
) -> (Conversion, Dimension) {
    let unit = unit.unwrap_or("").trim();
    let dimension = known.unwrap_or_else(|| {
        Dimension::ALL
            .into_iter()
            .find(|d| unit_factor(unit, *d).is_ok())
            .unwrap_or(Dimension::Dimensionless)
    });
    let factor = match (unit, known) {
        ("", Some(_)) => 1.0,
        _ => unit_factor(unit, dimension).unwrap_or_else(|message| {
            problems.push(format!("{field}.unit"), message);
            f64::NAN
        }),
    };
    let scale = scale.unwrap_or(1.0);
    if !scale.is_finite() || scale == 0.0 {
        problems.push(format!("{field}.scale"), "must be a non-zero number");
    }
    if offset.is_some_and(|offset| !offset.is_finite()) {
        problems.push(format!("{field}.offset"), "must be a finite number");
    }
    let shift = match (dimension, unit) {
        (Dimension::TemperatureDifference, "degC") => CELSIUS_ZERO,
        _ => 0.0,
    };
    let conversion = Conversion {
        scale,
        offset: offset.unwrap_or(0.0),
        factor,
        shift,
    };
    (conversion, dimension)
}
