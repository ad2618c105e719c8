//! Bringing real flight data in: a data file (headed CSV, headerless
//! whitespace- or comma-separated ASCII with columns known by number, or a
//! MATLAB level-5 MAT-file: a matrix's columns by number, vectors by name)
//! and a column-map file (TOML) that says which column is which channel, in which
//! unit, with which scale and offset, and how several columns form one
//! channel. Values are converted to SI with angles in radians on load:
//! `SI = (raw·scale + offset)·unit factor`, and a temperature in `degC` also
//! gets +273.15 K (records hold absolute temperatures). The result is a
//! [`FlightRecord`] like any simulated one. The format is documented for
//! users in `docs/import.md`.
//!
//! Nothing is silently dropped: a mapped column missing from the file, a
//! cell that is not a number, a time column that does not increase strictly
//! or a channel named twice is an error naming the file, line and column; an
//! empty cell becomes a dropout unless the map says `empty = "skip"` for that
//! channel; a cell that reads as NaN or an infinity is an error unless the
//! map says `non_finite = "dropout"`; a file without data rows is an error.
//! Columns the map does not mention, and channels that neither an estimator
//! nor the derive step reads, are
//! listed in the outcome.

mod source;

use crate::derived;
use crate::error::Result;
use crate::{Channel, FlightRecord, check_name};
use aeroid_core::csv_table::{Delimiter, first_disorder};
use aeroid_core::error::{FieldErrors, parse_toml, read_text};
use aeroid_core::units::{Dimension, Quantity, unit_factor};
use aeroid_sim::atmosphere::Atmosphere;
use serde::{Deserialize, Serialize};
use source::Source;
use std::fmt;
use std::path::Path;

/// Kelvin at 0 °C.
const CELSIUS_ZERO: f64 = 273.15;

/// A column-map file (TOML) as written: the layout of the data file, its
/// time column and one entry per channel (`docs/import.md`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ColumnMapFile {
    #[serde(default)]
    pub name: Option<String>,
    /// How the data file is laid out; a headed CSV when absent.
    #[serde(default)]
    pub file: FileLayout,
    pub time: ColumnSpec,
    pub channels: Vec<ChannelColumnSpec>,
}

/// The `[file]` table of a column map.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileLayout {
    /// Whether the first line that is not a comment names the columns.
    #[serde(default = "with_header")]
    pub header: bool,
    #[serde(default)]
    pub delimiter: Delimiter,
    /// In a MAT-file, the variable whose columns are numbered (needed when
    /// the file holds several matrices).
    #[serde(default)]
    pub matrix: Option<String>,
}

fn with_header() -> bool {
    true
}

impl Default for FileLayout {
    fn default() -> Self {
        FileLayout {
            header: true,
            delimiter: Delimiter::Auto,
            matrix: None,
        }
    }
}

/// A column of the data file: its header, or its number (1 is the first).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub(crate) enum ColumnRef {
    Number(i64),
    Name(String),
}

impl fmt::Display for ColumnRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ColumnRef::Number(n) => write!(f, "{n}"),
            ColumnRef::Name(name) => write!(f, "'{name}'"),
        }
    }
}

/// One column of the data file with its unit, scale and offset: the time
/// column of a column map.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ColumnSpec {
    pub column: ColumnRef,
    #[serde(default)]
    pub unit: Option<String>,
    #[serde(default)]
    pub scale: Option<f64>,
    #[serde(default)]
    pub offset: Option<f64>,
}

/// One `[[channels]]` entry of a column map: the channel it makes, from
/// which column or columns, and how its raw values become SI.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ChannelColumnSpec {
    pub name: String,
    /// The one column of the channel ...
    #[serde(default)]
    pub column: Option<ColumnRef>,
    /// ... or a constant, in `unit`, at every time of the time column
    /// (a density or Mach the flight did not record) ...
    #[serde(default)]
    pub value: Option<f64>,
    /// ... or several, combined as `combine` says.
    #[serde(default)]
    pub columns: Option<Vec<ColumnRef>>,
    #[serde(default)]
    pub combine: Option<Combine>,
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
    /// The altitude convention of the column (channel `altitude` only).
    #[serde(default)]
    pub convention: Option<AltitudeConvention>,
}

/// How several columns form one channel (each converted to SI first).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(crate) enum Combine {
    /// a + b + …: two engines' thrust.
    Sum,
    /// (a + b + …)/n: two vanes.
    Mean,
    /// (a − b)/2: left and right ailerons to the aileron.
    HalfDifference,
}

/// What an altitude column measures. Records hold geopotential altitude,
/// the altitude the ISA is evaluated at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(crate) enum AltitudeConvention {
    /// Kept as it is.
    #[default]
    Geopotential,
    /// z, converted to H = r0·z/(r0 + z), r0 = 6 356 766 m.
    Geometric,
    /// Pressure altitude Hp: the ISA altitude whose standard pressure is
    /// the measured static pressure, kept as it is (H = Hp).
    Pressure,
}

/// What a cell that reads as NaN or an infinity means.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(crate) enum NonFiniteCell {
    /// The import fails, naming the file, line and column.
    #[default]
    Error,
    /// The sample was lost: kept as NaN.
    Dropout,
}

/// What an empty cell of a channel column means.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(crate) enum EmptyCell {
    /// A sample was due but lost: kept as NaN.
    #[default]
    Dropout,
    /// The channel has no sample at this row (multi-rate exports).
    Skip,
}

/// A raw-to-SI conversion: `(raw·scale + offset)·factor + shift`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Conversion {
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
    columns: Vec<ColumnRef>,
    /// A constant in the map's unit, in place of columns.
    constant: Option<f64>,
    combine: Option<Combine>,
    unit: String,
    /// The unit as the map writes it.
    map_unit: String,
    conversion: Conversion,
    rate: Option<f64>,
    resolution: Option<f64>,
    empty: EmptyCell,
    non_finite: NonFiniteCell,
    convention: Option<AltitudeConvention>,
}

/// Something about an imported channel the user should know.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImportWarning {
    pub channel: String,
    pub message: String,
}

impl fmt::Display for ImportWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "channel '{}': {}", self.channel, self.message)
    }
}

/// The imported record, the data file's columns the map did not use,
/// warnings (channels nothing reads, the altitude convention's limits)
/// and notes (channels the map states as constants).
#[derive(Debug, Clone)]
pub struct ImportOutcome {
    pub record: FlightRecord,
    pub unmapped: Vec<String>,
    pub warnings: Vec<ImportWarning>,
    pub notes: Vec<String>,
}

/// Reads `data` with the column map at `map_path` into a flight record;
/// a mapped channel not among `read` (the channels the estimators read,
/// `aeroid_estimation::CHANNELS_READ` for aeroid's) is kept with a warning.
pub fn import(data: &Path, map_path: &Path, read: &[&str]) -> Result<ImportOutcome> {
    let file: ColumnMapFile = parse_toml(map_path, &read_text(map_path)?)?;
    let (time, channels) = validate_map(&file, map_path)?;
    let table = Source::read(data, &file.file)?;
    let headers = table.headers();
    let time_index = table.index(&file.time.column)?;
    let raw_times = table.times(time_index)?;
    let rows = raw_times.len();
    let times: Vec<f64> = raw_times.into_iter().map(|t| time.apply(t)).collect();
    check_converted_times(&times, &file.time.column, map_path)?;
    let mut used = vec![time_index];
    let mut record_channels = Vec::with_capacity(channels.len());
    for (i, mapped) in channels.iter().enumerate() {
        let mut columns = Vec::with_capacity(mapped.columns.len().max(1));
        if let Some(value) = mapped.constant {
            columns.push(vec![Some(value); rows]);
        }
        for column in &mapped.columns {
            let index = table.index(column)?;
            used.push(index);
            columns.push(table.cells(
                index,
                rows,
                mapped.non_finite == NonFiniteCell::Dropout,
                &format!(
                    "to record such cells as dropouts, set non_finite = \"dropout\" for channel '{}' in {}",
                    mapped.name,
                    map_path.display()
                ),
            )?);
        }
        let channel = build_channel(mapped, &times, &columns, &headers, data);
        check_physical(&channel)?;
        check_rate(&channel, i, map_path)?;
        record_channels.push(channel);
    }
    let unmapped = (0..headers.len())
        .filter(|i| !used.contains(i))
        .map(|i| headers[i].clone())
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
        bridge_gaps: false,
    };
    // What the record format relies on (a channel whose cells are all
    // skipped has no samples), said of the data file before anything is written.
    record.validate(data)?;
    let notes = channels
        .iter()
        .zip(&record.channels)
        .filter_map(|(mapped, channel)| {
            let value = mapped.constant?;
            let si = match mapped.map_unit == channel.unit || mapped.map_unit.is_empty() {
                true => String::new(),
                false => format!(
                    " ({}{})",
                    crate::significant(channel.values[0], 6),
                    unit_suffix(&channel.unit)
                ),
            };
            Some(format!(
                "channel '{}': the constant {value}{} stated by the map{si} at each of the {} times",
                mapped.name,
                unit_suffix(&mapped.map_unit),
                channel.times.len()
            ))
        })
        .collect();
    Ok(ImportOutcome {
        record,
        unmapped,
        warnings: warnings(&channels, read),
        notes,
    })
}

/// A unit after a number: ` kg/m3`, nothing for a dimensionless one.
fn unit_suffix(unit: &str) -> String {
    match unit {
        "" | "-" => String::new(),
        unit => format!(" {unit}"),
    }
}

/// Channels not among `read`, and altitudes whose density is the standard day's.
fn warnings(channels: &[MappedChannel], read: &[&str]) -> Vec<ImportWarning> {
    let mut warnings = Vec::new();
    for mapped in channels {
        if !read.contains(&mapped.name.as_str()) && !crate::prep::derive::reads(&mapped.name) {
            warnings.push(ImportWarning {
                channel: mapped.name.clone(),
                message: "no estimator of a 6-DOF model and no step of `aeroid derive` reads this \
                          channel (a linear model may name it as an input or output); it is kept \
                          in the record"
                    .into(),
            });
        }
        if mapped.convention == Some(AltitudeConvention::Pressure) {
            warnings.push(ImportWarning {
                channel: mapped.name.clone(),
                message: "pressure altitude is kept as the ISA altitude of the measured static \
                          pressure: density and temperature taken from the ISA at it are the \
                          standard day's"
                    .into(),
            });
        }
    }
    warnings
}

/// The Earth's mean radius (m): an altitude below −R is inside the Earth.
const EARTH_RADIUS: f64 = 6.371e6;

/// A channel whose values cannot be physical is refused, naming the first
/// such sample: a temperature (K) below absolute zero, an altitude below
/// the Earth's centre.
fn check_physical(channel: &Channel) -> Result<()> {
    let (limit, unit, what) = match channel.unit.as_str() {
        "K" => (0.0, "K", "below absolute zero"),
        "m" if channel.name.contains("altitude") => {
            (-EARTH_RADIUS, "m", "below the Earth's centre")
        }
        _ => return Ok(()),
    };
    let Some(k) = channel.values.iter().position(|v| *v < limit) else {
        return Ok(());
    };
    Err(crate::Error::Unphysical {
        channel: channel.name.clone(),
        origin: channel.source.clone(),
        time: channel.times[k],
        value: channel.values[k],
        unit,
        what,
    })
}

/// A channel from its columns' cells (`None`: empty), combined when
/// several, in SI and the record's altitude convention.
fn build_channel(
    mapped: &MappedChannel,
    times: &[f64],
    columns: &[Vec<Option<f64>>],
    headers: &[String],
    data: &Path,
) -> Channel {
    let value = |row: usize| -> Option<f64> {
        let values: Option<Vec<f64>> = columns
            .iter()
            .map(|column| column[row].map(|raw| mapped.conversion.apply(raw)))
            .collect();
        let values = values?;
        let combined = match mapped.combine {
            None => values[0],
            Some(Combine::Sum) => values.iter().sum(),
            Some(Combine::Mean) => values.iter().sum::<f64>() / values.len() as f64,
            Some(Combine::HalfDifference) => (values[0] - values[1]) / 2.0,
        };
        Some(match mapped.convention {
            Some(AltitudeConvention::Geometric) => Atmosphere::geopotential_altitude(combined),
            _ => combined,
        })
    };
    let (times, values): (Vec<f64>, Vec<f64>) = times
        .iter()
        .enumerate()
        .map(|(row, &t)| (t, value(row)))
        .filter(|(_, v)| v.is_some() || mapped.empty == EmptyCell::Dropout)
        .map(|(t, v)| (t, v.unwrap_or(f64::NAN)))
        .unzip();
    let described: Vec<String> = mapped
        .columns
        .iter()
        .map(|c| match c {
            ColumnRef::Name(name) => format!("'{name}'"),
            ColumnRef::Number(n) => usize::try_from(*n - 1)
                .ok()
                .and_then(|i| headers.get(i))
                .map_or_else(|| n.to_string(), |h| h.clone()),
        })
        .collect();
    let source = match (mapped.constant, mapped.combine) {
        (Some(value), _) => format!(
            "import: the constant {value}{} of the column map",
            unit_suffix(&mapped.map_unit)
        ),
        (None, None) => format!("import: column {} of {}", described[0], data.display()),
        (None, Some(combine)) => format!(
            "import: {} of columns {} of {}",
            serde_json::to_value(combine)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default(),
            described.join(", "),
            data.display()
        ),
    };
    Channel {
        name: mapped.name.clone(),
        unit: mapped.unit.clone(),
        rate: mapped.rate.unwrap_or_else(|| median_rate(&times)),
        resolution: mapped.resolution,
        source,
        times,
        values,
    }
}

/// The time column after its scale, offset and unit: still finite and
/// strictly increasing (a huge scale or offset can make times overflow or
/// collapse onto each other).
fn check_converted_times(times: &[f64], column: &ColumnRef, map_path: &Path) -> Result<()> {
    match first_disorder(times) {
        None => Ok(()),
        Some(k) => Err(aeroid_core::error::Error::Invalid {
            path: map_path.to_path_buf(),
            problems: vec![aeroid_core::error::FieldError {
                field: "time".into(),
                message: format!(
                    "column {column} converted to seconds is {} at data row {}{}: \
                     the time scale and offset must keep times finite and increasing",
                    times[k],
                    k + 1,
                    match k {
                        0 => String::new(),
                        _ => format!(", not after {}", times[k - 1]),
                    }
                ),
            }],
        }
        .into()),
    }
}

/// A channel's nominal rate, given or from the median sample interval, is
/// finite and positive (a time scale can make intervals so short that the
/// rate overflows).
fn check_rate(channel: &Channel, index: usize, map_path: &Path) -> Result<()> {
    if channel.rate.is_finite() && channel.rate > 0.0 {
        return Ok(());
    }
    Err(aeroid_core::error::Error::Invalid {
        path: map_path.to_path_buf(),
        problems: vec![aeroid_core::error::FieldError {
            field: format!("channels[{index}].rate"),
            message: format!(
                "channel '{}': its median sample interval gives a rate of {} Hz; \
                 check the time scale and unit, or give the rate",
                channel.name,
                crate::rate_text(channel.rate)
            ),
        }],
    }
    .into())
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
    let mut problems = FieldErrors::default();
    let (time, _) = conversion(
        "time",
        &format!("column {}", file.time.column),
        file.time.unit.as_deref(),
        file.time.scale,
        file.time.offset,
        Some(Dimension::Time),
        &mut problems,
    );
    check_column(
        &file.time.column,
        file.file.header,
        "time.column",
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
        let columns = channel_columns(spec, &field, &mut problems);
        for (k, column) in columns.iter().enumerate() {
            let at = match spec.columns {
                Some(_) => format!("{field}.columns[{k}]"),
                None => format!("{field}.column"),
            };
            check_column(column, file.file.header, &at, &mut problems);
        }
        channels.push(map_channel(spec, columns, &field, &mut problems));
    }
    Ok(problems.finish(path, (time, channels))?)
}

/// A column number is at least 1; a file without a header has only numbers.
fn check_column(column: &ColumnRef, header: bool, field: &str, problems: &mut FieldErrors) {
    match column {
        ColumnRef::Number(n) if *n < 1 => {
            problems.push(field, format!("column numbers start at 1, not {n}"))
        }
        ColumnRef::Name(name) if !header => problems.push(
            field,
            format!(
                "'{name}' is a column name, but the file has no header (file.header = false): \
                 give the column's number (1 is the first)"
            ),
        ),
        _ => {}
    }
}

/// The columns of a channel: `column`, or `columns` with `combine`.
fn channel_columns(
    spec: &ChannelColumnSpec,
    field: &str,
    problems: &mut FieldErrors,
) -> Vec<ColumnRef> {
    if spec.value.is_some() {
        if spec.column.is_some() || spec.columns.is_some() || spec.combine.is_some() {
            problems.push(
                field,
                "give `value` (a constant) or `column`/`columns`, not both",
            );
        }
        return Vec::new();
    }
    match (&spec.column, &spec.columns, spec.combine) {
        (Some(column), None, None) => vec![column.clone()],
        (Some(_), Some(_), _) => {
            problems.push(field, "give `column` or `columns`, not both");
            Vec::new()
        }
        (None, None, _) => {
            problems.push(
                field,
                "no column: give `column` (or `columns` with `combine`, or a constant `value`)",
            );
            Vec::new()
        }
        (Some(_), None, Some(_)) => {
            problems.push(
                format!("{field}.combine"),
                "combines several `columns`; this channel has one `column`",
            );
            Vec::new()
        }
        (None, Some(_), None) => {
            problems.push(
                format!("{field}.combine"),
                "several columns need `combine` (\"sum\", \"mean\" or \"half_difference\")",
            );
            Vec::new()
        }
        (None, Some(columns), Some(combine)) => {
            let count = columns.len();
            match combine {
                Combine::HalfDifference if count != 2 => problems.push(
                    format!("{field}.columns"),
                    format!("half_difference takes two columns (left, right), not {count}"),
                ),
                _ if count < 2 => problems.push(
                    format!("{field}.columns"),
                    format!("{combine:?} takes at least two columns, not {count}").to_lowercase(),
                ),
                _ => {}
            }
            for (i, column) in columns.iter().enumerate() {
                if columns[..i].contains(column) {
                    problems.push(
                        format!("{field}.columns"),
                        format!("column {column} is combined with itself"),
                    );
                }
            }
            columns.clone()
        }
    }
}

fn map_channel(
    spec: &ChannelColumnSpec,
    columns: Vec<ColumnRef>,
    field: &str,
    problems: &mut FieldErrors,
) -> MappedChannel {
    let known = derived::measurand(&spec.name).map(|m| m.dimension);
    let described: Vec<String> = columns.iter().map(ToString::to_string).collect();
    let (conversion, dimension) = conversion(
        field,
        &match spec.value {
            Some(value) => format!("channel '{}', constant value {value}", spec.name),
            None => format!(
                "channel '{}', column{} {}",
                spec.name,
                if described.len() > 1 { "s" } else { "" },
                described.join(", ")
            ),
        },
        spec.unit.as_deref(),
        spec.scale,
        spec.offset,
        known,
        problems,
    );
    check_constant(spec, field, problems);
    if spec
        .unit
        .as_deref()
        .is_some_and(|unit| unit.trim().is_empty())
    {
        problems.push(
            format!("{field}.unit"),
            format!(
                "is empty: leave `unit` out for the SI unit of channel '{}', or name its unit",
                spec.name
            ),
        );
    }
    if spec.convention.is_some() && spec.name != "altitude" {
        problems.push(
            format!("{field}.convention"),
            format!(
                "an altitude convention is for channel 'altitude', not '{}'",
                spec.name
            ),
        );
    }
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
        columns,
        constant: spec.value,
        combine: spec.combine,
        unit,
        map_unit: spec.unit.as_deref().unwrap_or("").trim().to_string(),
        conversion,
        rate: positive("rate", &spec.rate, Dimension::Frequency),
        resolution: positive("resolution", &spec.resolution, dimension),
        empty: spec.empty,
        non_finite: spec.non_finite,
        convention: spec.convention,
    }
}

/// A constant channel (`value`) must be finite and state none of a
/// column's keys (scale, offset, resolution, empty, non_finite).
fn check_constant(spec: &ChannelColumnSpec, field: &str, problems: &mut FieldErrors) {
    let Some(value) = spec.value else {
        return;
    };
    if !value.is_finite() {
        problems.push(
            format!("{field}.value"),
            format!("must be a finite number, is {value}"),
        );
    }
    for (key, given) in [
        ("scale", spec.scale.is_some()),
        ("offset", spec.offset.is_some()),
        ("resolution", spec.resolution.is_some()),
        ("empty", spec.empty != EmptyCell::default()),
        ("non_finite", spec.non_finite != NonFiniteCell::default()),
    ] {
        if given {
            problems.push(
                format!("{field}.{key}"),
                format!(
                    "is for a column; channel '{}' is the constant `value` (state it in its `unit`)",
                    spec.name
                ),
            );
        }
    }
}

/// The conversion of a column in `unit` with scale and offset; the dimension
/// is the known channel's, else the first one the unit belongs to.
fn conversion(
    field: &str,
    what: &str,
    unit: Option<&str>,
    scale: Option<f64>,
    offset: Option<f64>,
    known: Option<Dimension>,
    problems: &mut FieldErrors,
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
            problems.push(format!("{field}.unit"), format!("{what}: {message}"));
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
        (Dimension::TemperatureDifference, "degC" | "°C") => CELSIUS_ZERO,
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
