//! The flight record: what estimators see, whether it came from the recorder
//! model or from real flight data. A record is a set of named channels, each
//! with its own sample times, SI unit (angles in rad) and metadata (nominal
//! rate, resolution, source). Nothing assumes a common time base: estimators
//! read each channel at its own instants.
//!
//! On disk a record is a folder:
//! - `record.toml`: `format`, `scenario`, `seed`, `profile`, `absent` (the
//!   quantities the recorder does not have) and one `[[channels]]` entry per
//!   channel with `name`, `unit`, `rate` (Hz), `resolution` (omitted when
//!   none), `source`, `file` and `column`;
//! - one CSV per distinct time base, which a spreadsheet opens directly:
//!   first column `time [s]`, then one column per channel headed
//!   `name [unit]`. A file holding a single channel is named after it
//!   (`pitch.csv`); a shared one after its rate (`rate_25hz.csv`,
//!   `rate_64s.csv` for one sample every 64 s).
//!
//! Values are written in Rust's shortest round-trip form, so writing and
//! reading back gives the same bits. A dropout is a sample whose value is
//! NaN; it is written as an EMPTY cell and read back as NaN (samples are
//! never omitted, so a channel's time base shows where a sample was due).

pub mod derived;
pub mod error;
pub mod export;
pub mod gaps;
pub mod import;
pub mod mat;
pub mod prep;
pub mod quality;
pub mod recorder;

use aeroid_core::csv_table::CsvTable;
use aeroid_core::csv_table::first_disorder;
use aeroid_core::error::{FieldErrors, parse_toml, read_text};
use aeroid_core::paths;
pub use error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::path::Path;

/// The metadata file of a record folder.
pub(crate) const RECORD_FILE: &str = "record.toml";
/// The format tag written into `record.toml`.
pub const FORMAT: &str = "aeroid-record-1";
/// The header of the time column of every record CSV.
pub(crate) const TIME_HEADER: &str = "time [s]";

/// One recorded channel. In JSON (an estimation problem) a dropout is `null`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Channel {
    pub name: String,
    /// SI unit (`rad`, `m/s`, `-`, …).
    pub unit: String,
    /// Nominal sample rate (Hz).
    pub rate: f64,
    /// Least significant bit, in `unit`, if the channel is quantized.
    pub resolution: Option<f64>,
    /// Where the channel came from (recorder profile and parameter, or imported file and column).
    pub source: String,
    /// Sample instants (s), strictly increasing.
    pub times: Vec<f64>,
    /// Sample values; NaN marks a dropout.
    #[serde(with = "nan_as_null")]
    pub values: Vec<f64>,
}

/// Serde for sample values: NaN (a dropout) as `null`, which JSON can hold.
mod nan_as_null {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(values: &[f64], serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(values.iter().map(|v| (!v.is_nan()).then_some(*v)))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(deserializer: D) -> Result<Vec<f64>, D::Error> {
        let values = Vec::<Option<f64>>::deserialize(deserializer)?;
        Ok(values.into_iter().map(|v| v.unwrap_or(f64::NAN)).collect())
    }
}

impl Channel {
    /// A test channel of `values` at `rate` (Hz) from t = 0, unit `rad`.
    #[cfg(test)]
    pub(crate) fn uniform(name: &str, rate: f64, values: Vec<f64>) -> Channel {
        Channel {
            name: name.into(),
            unit: "rad".into(),
            rate,
            resolution: None,
            source: String::new(),
            times: (0..values.len()).map(|k| k as f64 / rate).collect(),
            values,
        }
    }

    /// The CSV column header, `name [unit]`.
    pub fn header(&self) -> String {
        format!("{} [{}]", self.name, self.unit)
    }

    /// Number of samples whose value is missing.
    pub fn dropouts(&self) -> usize {
        self.values.iter().filter(|v| v.is_nan()).count()
    }

    /// Number of intervals between samples longer than 1.5 nominal periods.
    pub fn gaps(&self) -> usize {
        let limit = 1.5 / self.rate;
        self.times
            .windows(2)
            .filter(|w| w[1] - w[0] > limit)
            .count()
    }

    /// The value at time `t` by linear interpolation between the nearest
    /// valid samples (dropouts are skipped); held constant outside the record.
    /// None when the channel has no valid sample.
    pub fn value_at(&self, t: f64) -> Option<f64> {
        self.value_after(t, self.times.partition_point(|&time| time < t))
    }

    /// [`Channel::value_at`] given `after`, the index of the first sample at
    /// or after t.
    fn value_after(&self, t: f64, after: usize) -> Option<f64> {
        let previous = self.times[..after.min(self.times.len())]
            .iter()
            .zip(&self.values)
            .rposition(|(_, v)| !v.is_nan());
        let next = (after..self.times.len()).find(|&k| !self.values[k].is_nan());
        match (previous, next) {
            (Some(i), Some(j)) if self.times[j] > self.times[i] => {
                let weight = (t - self.times[i]) / (self.times[j] - self.times[i]);
                Some(self.values[i] + weight * (self.values[j] - self.values[i]))
            }
            (Some(i), _) => Some(self.values[i]),
            (None, Some(j)) => Some(self.values[j]),
            (None, None) => None,
        }
    }

    /// The value of the last valid sample at or before `t` (a zero-order
    /// hold; times within 1e-9 s count as equal), the first valid one before
    /// the record starts.
    pub fn value_held_at(&self, t: f64) -> Option<f64> {
        let after = self.times.partition_point(|&time| time <= t + 1e-9);
        let valid = |k: &usize| !self.values[*k].is_nan();
        (0..after)
            .rev()
            .find(valid)
            .or_else(|| (after..self.times.len()).find(valid))
            .map(|k| self.values[k])
    }

    /// Values at many instants, held or linearly interpolated between samples.
    pub fn sampled_at(
        &self,
        times: &[f64],
        interpolation: aeroid_sim::integrator::Interpolation,
    ) -> Result<Vec<f64>> {
        match interpolation {
            aeroid_sim::integrator::Interpolation::Linear => self.values_at(times),
            aeroid_sim::integrator::Interpolation::ZeroOrderHold => times
                .iter()
                .map(|&t| self.value_held_at(t))
                .collect::<Option<Vec<f64>>>()
                .ok_or_else(|| Error::NoValidSample {
                    channel: self.name.clone(),
                }),
        }
    }

    /// Values at many instants (see [`Channel::value_at`]); an error names the
    /// channel when it holds no valid sample.
    pub fn values_at(&self, times: &[f64]) -> Result<Vec<f64>> {
        // Increasing instants (a grid) walk a cursor forward instead of a
        // binary search each (restarted if an instant goes back).
        let mut after = 0;
        let mut last = f64::NEG_INFINITY;
        times
            .iter()
            .map(|&t| {
                if t < last {
                    after = 0;
                }
                last = t;
                while after < self.times.len() && self.times[after] < t {
                    after += 1;
                }
                self.value_after(t, after)
            })
            .collect::<Option<Vec<f64>>>()
            .ok_or_else(|| Error::NoValidSample {
                channel: self.name.clone(),
            })
    }

    /// Values at many instants by linear interpolation between the two
    /// samples around each instant, without bridging: NaN where either of
    /// them (the one at the instant, when there is one) is a dropout; held
    /// outside the record. For derived channels whose dropouts mark where no
    /// valid value exists (a derivative next to a control step).
    pub fn values_at_unbridged(&self, times: &[f64]) -> Vec<f64> {
        let last = self.times.len().saturating_sub(1);
        times
            .iter()
            .map(|&t| {
                let after = self.times.partition_point(|&time| time < t);
                if after > last {
                    return self.values.last().copied().unwrap_or(f64::NAN);
                }
                if after == 0 || self.times[after] == t {
                    return self.values[after];
                }
                let (i, j) = (after - 1, after);
                let weight = (t - self.times[i]) / (self.times[j] - self.times[i]);
                self.values[i] + weight * (self.values[j] - self.values[i])
            })
            .collect()
    }

    /// Smallest and largest value present, if any.
    pub fn range(&self) -> Option<(f64, f64)> {
        self.values
            .iter()
            .filter(|v| !v.is_nan())
            .fold(None, |range, &v| match range {
                None => Some((v, v)),
                Some((low, high)) => Some((f64::min(low, v), f64::max(high, v))),
            })
    }
}

/// A flight record: named channels with their own time bases.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlightRecord {
    /// Scenario name (or the imported file's name).
    pub scenario: String,
    /// The scenario seed the recorder's random stream came from, if simulated.
    pub seed: Option<u64>,
    /// The recorder profile (or `import:` and the column-map file).
    pub profile: String,
    /// Quantities the recorder does not have, by design (QAR: no angular rates).
    pub absent: Vec<String>,
    pub channels: Vec<Channel>,
    /// Whether estimators interpolate across the record's gaps instead of
    /// fitting the pieces between them as separate manoeuvres
    /// ([`gaps`], `aeroid import --bridge-gaps`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub bridge_gaps: bool,
}

fn is_false(value: &bool) -> bool {
    !value
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RecordFile {
    format: String,
    #[serde(default)]
    scenario: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    seed: Option<u64>,
    #[serde(default)]
    profile: String,
    #[serde(default)]
    absent: Vec<String>,
    #[serde(default)]
    channels: Vec<ChannelEntry>,
    #[serde(default, skip_serializing_if = "is_false")]
    bridge_gaps: bool,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ChannelEntry {
    name: String,
    unit: String,
    rate: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    resolution: Option<f64>,
    #[serde(default)]
    source: String,
    file: String,
    column: String,
}

/// Channels sharing one time base, written to one CSV.
pub(crate) struct TimeBase {
    pub(crate) file: String,
    pub(crate) channels: Vec<usize>,
}

impl FlightRecord {
    /// The record's name in messages and reports: its scenario, or for an
    /// imported record without one its profile.
    pub fn name(&self) -> &str {
        if self.scenario.is_empty() {
            &self.profile
        } else {
            &self.scenario
        }
    }

    /// The channel with this name, or an error listing the channels present.
    pub fn channel(&self, name: &str) -> Result<&Channel> {
        Ok(self
            .channels
            .iter()
            .find(|c| c.name == name)
            .ok_or_else(|| aeroid_core::Error::Unknown {
                kind: "channel",
                name: name.to_string(),
                known: self.channels.iter().map(|c| c.name.clone()).collect(),
            })?)
    }

    /// Checks what the file format relies on: at least one channel, each
    /// with samples, unique, file-safe names, matching lengths, finite
    /// strictly increasing times, positive rates, finite values (NaN is a
    /// dropout).
    pub fn validate(&self, path: &Path) -> Result<()> {
        let mut problems = FieldErrors::default();
        if self.channels.is_empty() {
            problems.push(
                "channels",
                "the record has no channels; a record needs at least one",
            );
        }
        let mut seen = BTreeSet::new();
        for (i, channel) in self.channels.iter().enumerate() {
            let field = format!("channels[{i}] ({})", channel.name);
            if let Err(message) = check_name(&channel.name) {
                problems.push(&field, message);
            }
            if !seen.insert(channel.name.as_str()) {
                problems.push(&field, "duplicate channel name");
            }
            if channel.times.len() != channel.values.len() {
                problems.push(&field, "times and values differ in length");
            } else if channel.times.is_empty() {
                problems.push(&field, "the channel has no samples");
            }
            if !(channel.rate.is_finite() && channel.rate > 0.0) {
                problems.push(&field, "the nominal rate must be positive");
            }
            if let Some(k) = first_disorder(&channel.times) {
                problems.push(
                    &field,
                    format!(
                        "time {} at sample {k} is not after the one before",
                        channel.times[k]
                    ),
                );
            }
            if let Some(k) = channel.values.iter().position(|v| v.is_infinite()) {
                problems.push(
                    &field,
                    format!(
                        "the value at sample {k} (t = {} s) is infinite; a sample is a finite number or a dropout",
                        channel.times[k]
                    ),
                );
            }
        }
        Ok(problems.finish(path, ())?)
    }

    /// Writes the record into `folder` (created if needed): `record.toml` and one CSV per time base.
    pub fn write(&self, folder: &Path) -> Result<()> {
        self.validate(folder)?;
        if let Some(seed) = self.seed
            && i64::try_from(seed).is_err()
        {
            return Err(aeroid_core::Error::Invalid {
                path: folder.join(RECORD_FILE),
                problems: vec![aeroid_core::error::FieldError {
                    field: "seed".into(),
                    message: format!(
                        "{seed} is above {}, the largest integer record.toml can hold",
                        i64::MAX
                    ),
                }],
            }
            .into());
        }
        std::fs::create_dir_all(folder).map_err(|e| aeroid_core::error::write_error(folder, e))?;
        let bases = self.time_bases();
        let mut entries = Vec::with_capacity(self.channels.len());
        for base in &bases {
            self.write_time_base(&folder.join(&base.file), &base.channels)?;
            for &i in &base.channels {
                entries.push((i, self.entry(i, &base.file)));
            }
        }
        entries.sort_by_key(|(i, _)| *i);
        let file = RecordFile {
            format: FORMAT.to_string(),
            scenario: self.scenario.clone(),
            seed: self.seed,
            profile: self.profile.clone(),
            absent: self.absent.clone(),
            channels: entries.into_iter().map(|(_, e)| e).collect(),
            bridge_gaps: self.bridge_gaps,
        };
        let path = folder.join(RECORD_FILE);
        let text = toml::to_string(&file).map_err(|e| Error::Serialize {
            reason: e.to_string(),
        })?;
        Ok(aeroid_core::atomic::write_text(&path, &text)?)
    }

    /// Reads a record folder written by [`FlightRecord::write`] (or by hand in the same layout).
    pub fn read(folder: &Path) -> Result<FlightRecord> {
        let path = folder.join(RECORD_FILE);
        let file: RecordFile = parse_toml(&path, &read_text(&path)?)?;
        if file.format != FORMAT {
            return Err(aeroid_core::Error::Invalid {
                path,
                problems: vec![aeroid_core::error::FieldError {
                    field: "format".into(),
                    message: format!("'{}' is not '{FORMAT}'", file.format),
                }],
            }
            .into());
        }
        let mut tables: Vec<(String, CsvTable, Vec<f64>)> = Vec::new();
        let mut channels = Vec::with_capacity(file.channels.len());
        for (index, entry) in file.channels.into_iter().enumerate() {
            if !tables.iter().any(|(name, _, _)| *name == entry.file) {
                let field = format!("channels[{index}].file");
                let table = CsvTable::read(&paths::inside(folder, &entry.file, &path, &field)?)?;
                let times = table.time_column(0)?;
                tables.push((entry.file.clone(), table, times));
            }
            let (_, table, times) = tables.iter().find(|(n, _, _)| *n == entry.file).unwrap();
            let column = table.column_index(&entry.column)?;
            channels.push(Channel {
                values: table
                    .measurements(
                        column,
                        false,
                        "a record stores a lost sample (dropout) as an empty cell",
                    )?
                    .into_iter()
                    .map(|v| v.unwrap_or(f64::NAN))
                    .collect(),
                times: times.clone(),
                name: entry.name,
                unit: entry.unit,
                rate: entry.rate,
                resolution: entry.resolution,
                source: entry.source,
            });
        }
        let record = FlightRecord {
            scenario: file.scenario,
            seed: file.seed,
            profile: file.profile,
            absent: file.absent,
            channels,
            bridge_gaps: file.bridge_gaps,
        };
        record.validate(&path)?;
        Ok(record)
    }

    fn entry(&self, i: usize, file: &str) -> ChannelEntry {
        let channel = &self.channels[i];
        ChannelEntry {
            name: channel.name.clone(),
            unit: channel.unit.clone(),
            rate: channel.rate,
            resolution: channel.resolution,
            source: channel.source.clone(),
            file: file.to_string(),
            column: channel.header(),
        }
    }

    /// Groups channels with identical sample times and names each group's file.
    pub(crate) fn time_bases(&self) -> Vec<TimeBase> {
        let mut bases: Vec<TimeBase> = Vec::new();
        for (i, channel) in self.channels.iter().enumerate() {
            match bases
                .iter_mut()
                .find(|b| self.channels[b.channels[0]].times == channel.times)
            {
                Some(base) => base.channels.push(i),
                None => bases.push(TimeBase {
                    file: String::new(),
                    channels: vec![i],
                }),
            }
        }
        let mut used = BTreeSet::new();
        for base in &mut bases {
            let first = &self.channels[base.channels[0]];
            let stem = match base.channels.len() {
                1 => first.name.clone(),
                _ => format!("rate_{}", rate_label(first.rate)),
            };
            let mut file = format!("{stem}.csv");
            let mut k = 2;
            while !used.insert(file.clone()) {
                file = format!("{stem}_{k}.csv");
                k += 1;
            }
            base.file = file;
        }
        bases
    }

    fn write_time_base(&self, path: &Path, members: &[usize]) -> Result<()> {
        // The header through the csv crate (quoting), the rows by hand:
        // a row is numbers and empty cells, which need no quoting.
        let mut header = csv::Writer::from_writer(Vec::new());
        header
            .write_record(
                std::iter::once(TIME_HEADER.to_string())
                    .chain(members.iter().map(|&i| self.channels[i].header())),
            )
            .map_err(|e| aeroid_core::error::write_error(path, e))?;
        let mut text = header
            .into_inner()
            .map_err(|e| aeroid_core::error::write_error(path, e.into_error()))?;
        let times = &self.channels[members[0]].times;
        text.reserve(times.len() * (members.len() + 1) * 20);
        let mut digits = zmij::Buffer::new();
        for (k, &time) in times.iter().enumerate() {
            text.extend_from_slice(shortest(&mut digits, time).as_bytes());
            for &i in members {
                text.push(b',');
                let value = self.channels[i].values[k];
                if !value.is_nan() {
                    text.extend_from_slice(shortest(&mut digits, value).as_bytes());
                }
            }
            text.push(b'\n');
        }
        Ok(std::fs::write(path, text).map_err(|e| aeroid_core::error::write_error(path, e))?)
    }

    /// The `aeroid inspect` table: every channel with its unit, rate,
    /// resolution, sample count, time span, value range, dropouts and gaps,
    /// numbers rounded to four significant digits.
    pub fn describe(&self) -> String {
        let seed = self.seed.map_or("-".to_string(), |s| s.to_string());
        let mut text = format!(
            "scenario: {}\nseed: {seed}\nprofile: {}\nabsent: {}\nchannels: {}\n",
            self.scenario,
            self.profile,
            if self.absent.is_empty() {
                "-".to_string()
            } else {
                self.absent.join(", ")
            },
            self.channels.len()
        );
        text += &format!(
            "{:<30} {:<6} {:>8} {:>10} {:>7} {:>9} {:>9} {:>11} {:>11} {:>8} {:>4}\n",
            "channel",
            "unit",
            "rate[Hz]",
            "resolution",
            "samples",
            "first[s]",
            "last[s]",
            "min",
            "max",
            "dropouts",
            "gaps"
        );
        for channel in &self.channels {
            text += &describe_channel(channel);
        }
        text
    }
}

fn describe_channel(channel: &Channel) -> String {
    let (low, high) = channel
        .range()
        .map_or(("-".into(), "-".into()), |(l, h)| (rounded(l), rounded(h)));
    let time = |t: Option<&f64>| t.map_or("-".to_string(), |t| rounded(*t));
    format!(
        "{:<30} {:<6} {:>8} {:>10} {:>7} {:>9} {:>9} {:>11} {:>11} {:>8} {:>4}\n",
        channel.name,
        channel.unit,
        rate_text(channel.rate),
        channel.resolution.map_or("-".to_string(), rounded),
        channel.times.len(),
        time(channel.times.first()),
        time(channel.times.last()),
        low,
        high,
        channel.dropouts(),
        channel.gaps()
    )
}

/// Rates and periods from here on are written in scientific notation.
const PLAIN_LIMIT: f64 = 1e6;

/// A rate as a user reads it: `25`, `0.5`, or `1/64` for one sample every 64 s;
/// `1.000e300` rather than 301 digits.
pub fn rate_text(rate: f64) -> String {
    let period = 1.0 / rate;
    if rate < 1.0 && period < PLAIN_LIMIT && (period - period.round()).abs() < 1e-9 {
        format!("1/{}", period.round())
    } else if (1.0..PLAIN_LIMIT).contains(&rate) && (rate - rate.round()).abs() < 1e-9 {
        format!("{}", rate.round())
    } else {
        rounded(rate)
    }
}

/// A rate for a file name: `25hz`, `12p5hz`, `64s` (one sample every 64 s);
/// short for any rate (`1p000e-300hz`), as file names have a length limit.
fn rate_label(rate: f64) -> String {
    let period = 1.0 / rate;
    if rate < 1.0 && period < PLAIN_LIMIT && (period - period.round()).abs() < 1e-9 {
        format!("{}s", period.round())
    } else {
        format!("{}hz", rate_text(rate).replace('.', "p"))
    }
}

/// Four significant digits, plain notation within 1e-3..1e6, else scientific.
pub fn rounded(value: f64) -> String {
    significant(value, 4)
}

/// `digits` significant digits (at least 1), plain notation within
/// 1e-3..1e6, else scientific; never "-0".
pub fn significant(value: f64, digits: usize) -> String {
    if value == 0.0 {
        return "0".to_string();
    }
    if !value.is_finite() {
        return format!("{value}");
    }
    let digits = digits.max(1) as i32;
    let magnitude = value.abs().log10().floor() as i32;
    let text = if (-3..6).contains(&magnitude) {
        format!("{:.*}", (digits - 1 - magnitude).max(0) as usize, value)
    } else {
        format!("{value:.*e}", (digits - 1) as usize)
    };
    if text.starts_with("-") && text.trim_start_matches(['-', '0', '.']).is_empty() {
        text[1..].to_string()
    } else {
        text
    }
}

/// Puts a derived channel into a record: it replaces the record's channel of
/// the same name, or is added, and its name leaves the `absent` list.
pub(crate) fn put_channel(record: &mut FlightRecord, channel: Channel) {
    record.absent.retain(|a| *a != channel.name);
    match record.channels.iter_mut().find(|c| c.name == channel.name) {
        Some(existing) => *existing = channel,
        None => record.channels.push(channel),
    }
}

/// The sample instants of `channels[reference]` inside the span that every
/// one of `channels` covers (from the latest first sample to the earliest
/// last one); empty when they share none or a channel has no sample.
pub(crate) fn shared_instants(channels: &[&Channel], reference: usize) -> Vec<f64> {
    if channels.iter().any(|c| c.times.is_empty()) {
        return Vec::new();
    }
    let start = channels.iter().map(|c| c.times[0]).fold(f64::MIN, f64::max);
    let end = channels
        .iter()
        .map(|c| c.times[c.times.len() - 1])
        .fold(f64::MAX, f64::min);
    channels[reference]
        .times
        .iter()
        .copied()
        .filter(|t| (start..=end).contains(t))
        .collect()
}

/// Removes 2π jumps so that an angle varies continuously: each value is
/// shifted by the whole turns that bring it within π of the valid value
/// before it. Dropouts (NaN) are skipped.
pub fn unwrap_angles(angles: &mut [f64]) {
    let mut previous: Option<f64> = None;
    let mut shift = 0.0;
    for value in angles.iter_mut().filter(|v| !v.is_nan()) {
        if let Some(last) = previous {
            shift -=
                std::f64::consts::TAU * ((*value + shift - last) / std::f64::consts::TAU).round();
        }
        *value += shift;
        previous = Some(*value);
    }
}

/// One CSV field of a sample: the shortest text that reads back as the
/// same number, empty for NaN (a missing sample); `text` is a reused buffer.
/// The shortest text that reads back as `value` exactly (Schubfach, the
/// zmij crate), with integral values written without ".0" ("0", "-0",
/// "4877"); large and small magnitudes in exponent form ("8.9e-5").
pub(crate) fn shortest(digits: &mut zmij::Buffer, value: f64) -> &str {
    let text = digits.format(value);
    text.strip_suffix(".0").unwrap_or(text)
}

/// A channel name must be usable as a CSV header and file name.
pub(crate) fn check_name(name: &str) -> std::result::Result<(), error::Error> {
    let allowed = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.');
    if name.is_empty() || !name.chars().all(allowed) {
        Err(error::Error::ChannelName { name: name.into() })
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values at instants in any order (the cursor restarts when an instant
    /// goes back) equal `value_at` at each: across a dropout, on a sample,
    /// and outside the record.
    #[test]
    fn values_at_matches_value_at_in_any_order() {
        let channel = Channel {
            name: "p".into(),
            unit: "rad/s".into(),
            rate: 10.0,
            resolution: None,
            source: String::new(),
            times: (0..20).map(|k| k as f64 * 0.1).collect(),
            values: (0..20)
                .map(|k| {
                    if k == 7 || k == 8 {
                        f64::NAN
                    } else {
                        (k as f64 * 0.3).sin()
                    }
                })
                .collect(),
        };
        let instants = [-0.5, 0.0, 0.05, 0.7, 0.75, 0.9, 1.95, 2.5, 0.31, 0.3, 1.0];
        let values = channel.values_at(&instants).unwrap();
        for (t, value) in instants.iter().zip(values) {
            assert_eq!(Some(value), channel.value_at(*t), "t = {t}");
        }
    }
}
