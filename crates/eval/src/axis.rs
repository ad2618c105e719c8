//! The sweep axes of a Monte Carlo study, as one concept: [`Axis`] names
//! each axis, in the order the sweep's cartesian product nests them
//! ([`Axis::PRODUCT`], the last varying fastest) and in the order rows
//! write them ([`Axis::COLUMNS`], the column names of `runs.csv` and
//! `summary.csv`); [`AxisValues`] is one point's value on every axis as a
//! row holds it, from which a row's and a summary row's axis columns and
//! the point's label are built.
//!
//! Adding an axis: a variant here (both orders, its column name, its label
//! part), its field in [`AxisValues`], `Row` and `SummaryRow` (their flat
//! CSV columns, filled from [`AxisValues`] in one function each), and its
//! values in the study's grid (`study::points`).

use aeroid_estimation::estimator::MethodTables;

/// A sweep axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Axis {
    Scenario,
    Profile,
    Missing,
    ChannelRate,
    Turbulence,
    InputScale,
    SampleRate,
    NoiseScale,
    ResolutionScale,
    Settings,
}

impl Axis {
    /// The sweep's nesting order: points are the product scenario ×
    /// profile × missing × channel rates × turbulence × input scale ×
    /// sample rate × noise scale × resolution scale × settings, the last
    /// varying fastest. Cases' seeds follow from it.
    pub const PRODUCT: [Axis; 10] = [
        Axis::Scenario,
        Axis::Profile,
        Axis::Missing,
        Axis::ChannelRate,
        Axis::Turbulence,
        Axis::InputScale,
        Axis::SampleRate,
        Axis::NoiseScale,
        Axis::ResolutionScale,
        Axis::Settings,
    ];

    /// The order of the axis columns in `runs.csv` and `summary.csv`
    /// (after `point`) and of a point's label.
    pub const COLUMNS: [Axis; 10] = [
        Axis::Scenario,
        Axis::Profile,
        Axis::Turbulence,
        Axis::InputScale,
        Axis::SampleRate,
        Axis::NoiseScale,
        Axis::ResolutionScale,
        Axis::Missing,
        Axis::ChannelRate,
        Axis::Settings,
    ];

    /// The axis' column name in `runs.csv` and `summary.csv`.
    pub fn column(self) -> &'static str {
        match self {
            Axis::Scenario => "scenario",
            Axis::Profile => "profile",
            Axis::Missing => "missing",
            Axis::ChannelRate => "channel_rates",
            Axis::Turbulence => "turbulence",
            Axis::InputScale => "input_scale",
            Axis::SampleRate => "sample_rate",
            Axis::NoiseScale => "noise_scale",
            Axis::ResolutionScale => "resolution_scale",
            Axis::Settings => "settings",
        }
    }

    /// The axis' place in [`Axis::PRODUCT`].
    pub fn index(self) -> usize {
        self as usize
    }
}

/// One sweep point's value on every axis, as a row writes it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AxisValues {
    pub scenario: String,
    /// The recorder profile (before the sweep's rate, noise and resolution).
    pub profile: String,
    /// The turbulence intensity; empty for the scenario's own wind.
    pub turbulence: String,
    pub input_scale: f64,
    /// Every channel's rate (Hz); None for the profile's own.
    pub sample_rate: Option<f64>,
    pub noise_scale: f64,
    pub resolution_scale: f64,
    /// Channels left out of the record, comma-separated.
    pub missing: String,
    /// Channels at their own rate, `channel:rate Hz` comma-separated.
    pub channel_rates: String,
    /// The settings variant, `method.key=value` comma-separated.
    pub settings: String,
}

impl AxisValues {
    /// A short label of the point: the axes not at their defaults (the
    /// profile when not empty), and always the scenario and noise scale.
    pub fn label(&self) -> String {
        Axis::COLUMNS
            .iter()
            .map(|&axis| self.label_part(axis))
            .collect()
    }

    /// One axis' part of [`AxisValues::label`] (empty at its default).
    fn label_part(&self, axis: Axis) -> String {
        let unless_empty = |prefix: &str, text: &str| {
            if text.is_empty() {
                String::new()
            } else {
                format!(" {prefix} {text}")
            }
        };
        match axis {
            Axis::Scenario => self.scenario.clone(),
            Axis::Profile => unless_empty("recorded by", &self.profile),
            Axis::Turbulence => unless_empty("turbulence", &self.turbulence),
            Axis::InputScale if self.input_scale != 1.0 => {
                format!(" inputs×{}", self.input_scale)
            }
            Axis::InputScale => String::new(),
            Axis::SampleRate => self.sample_rate.map_or(String::new(), |rate| {
                format!(" @{} Hz", aeroid_record::rate_text(rate))
            }),
            Axis::NoiseScale => format!(" noise×{}", self.noise_scale),
            Axis::ResolutionScale if self.resolution_scale != 1.0 => {
                format!(" lsb×{}", self.resolution_scale)
            }
            Axis::ResolutionScale => String::new(),
            Axis::Missing => unless_empty("without", &self.missing),
            Axis::ChannelRate => unless_empty("rates", &self.channel_rates),
            Axis::Settings => unless_empty("settings", &self.settings),
        }
    }
}

/// A point's channel rates as `channel:rate Hz` comma-separated.
pub(crate) fn channel_rates_text(rates: &[(String, f64)]) -> String {
    rates
        .iter()
        .map(|(channel, rate)| format!("{channel}:{} Hz", aeroid_record::rate_text(*rate)))
        .collect::<Vec<_>>()
        .join(",")
}

/// A settings variant as `method.key=value` comma-separated.
pub(crate) fn settings_text(tables: &MethodTables) -> String {
    tables
        .iter()
        .flat_map(|(method, table)| {
            table
                .iter()
                .map(move |(key, value)| format!("{method}.{key}={value}"))
        })
        .collect::<Vec<_>>()
        .join(",")
}
