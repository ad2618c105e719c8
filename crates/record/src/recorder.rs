//! Recorder (sensor) profiles and the recorder model that turns a truth trace
//! into a [`FlightRecord`]: what a real flight-test system or Quick Access
//! Recorder would have stored, and nothing more.
//!
//! Profiles are TOML files in `recorders/` (bundled: `qar-seed000`, Wang et al. 2012
//! Table 1 exactly; `flight-test-25hz`; `ideal`, every channel without error).
//! Top level: `name`, `description`, `frame` (recorder frame length, default
//! 1 s), `words_per_frame` (optional), `origin = { latitude, longitude }`
//! (where the flat earth lies on the globe, default 0, 0), `absent` (the
//! quantities the recorder lacks, recorded in the record's metadata), and one
//! `[[channels]]` table per channel:
//!
//! | key | meaning (units as in any aeroid file: plain number SI, or `"0.1 deg"`) |
//! |---|---|
//! | `name` | a quantity of [`crate::derived::MEASURANDS`] (`pitch`, `nz`, `calibrated_airspeed`, …) |
//! | `label` | the recorder's own parameter title, kept as the channel's source |
//! | `rate` | samples per second: `"25 Hz"`, `"1/64 Hz"`, `0.5`; at most [`aeroid_core::limits::MAX_RATE`] |
//! | `phase` | time of the first sample within the rate's period (default 0) |
//! | `slot` / `word` | position within the frame: a fraction in [0, 1), or a word index of `words_per_frame` |
//! | `resolution` | LSB; values are rounded to the nearest multiple |
//! | `saturation` | `[min, max]` the value is clamped to |
//! | `noise` | standard deviation of Gaussian noise, white unless `noise_time` is given |
//! | `noise_time` | correlation time of the noise: first-order Gauss–Markov noise, n_k = a·n_(k−1) + √(1 − a²)·σ·w_k, a = exp(−Δt/τ) over the sample interval Δt (coloured sensor noise: vane buffet, a gyro's drift); 0 (default): white |
//! | `bias`, `scale_factor` | `measured = scale_factor·x + bias` (default 0 and 1; finite) |
//! | `delay` | pure time delay, at most [`aeroid_core::limits::MAX_SENSOR_TIME`] |
//! | `lag` | time constant of a first-order sensor lag, at most [`aeroid_core::limits::MAX_SENSOR_TIME`] |
//! | `anti_alias` | cut-off of a 2nd-order Butterworth filter applied before sampling |
//! | `dropout` | probability that a sample is lost (recorded as NaN) |
//! | `fault` | `{ kind = "stuck", from = "20 s", value = … }` (holds `value`, or the last good sample) or `{ kind = "levels", values = [...] }` (every sample reads one of the values at random, as Wang et al. 2012's AoA) |
//! | `position` | accelerometer position relative to the CG, body axes (load factors only) |
//!
//! Sample instants: `t_k = t_0 + phase + slot·frame + k/rate` for every
//! `t_k` within the trace, so that channels of "the same second" are taken
//! at their word's instant in the frame. The signal chain of a channel, in
//! order: the true quantity on the simulator's step (angles that wrap are
//! unwrapped), first-order lag, anti-alias filter, sampling at `t_k − delay`
//! by linear interpolation of the truth (the first value is held before the
//! trace starts), scale factor and bias, noise, saturation, wrapping to
//! [0, 2π) for headings and directions, quantization, fault, dropout.
//!
//! Random draws: one ChaCha stream, `random::stream(seed, RECORDER)`,
//! consumed channel by channel in profile order and, within a channel,
//! sample by sample in the order noise, fault level, dropout (only the draws
//! a channel's configuration needs), so that a seed gives the same record bit
//! for bit.

use crate::derived::{Context, GeographicOrigin, Measurand};
use crate::error::{Error, Result};
use crate::{Channel, FlightRecord};
use aeroid_core::catalog;
use aeroid_core::error::{FieldErrors, parse_toml, read_text};
use aeroid_core::limits;
use aeroid_core::random::{self, streams};
use aeroid_core::units::{Dimension, Quantity};
use aeroid_sim::aircraft::Aircraft;
use aeroid_sim::scenario::Scenario;
use aeroid_sim::trace::TruthTrace;
use aeroid_sim::truth::RunTruth;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

mod chain;
mod reading;

pub use chain::{interpolate, quantize, wrap_and_quantize};
use reading::{FrameLayout, check_absent, positive, read_channel, read_origin};
pub use reading::{parse_rate, rate_limit_message};

/// The profile used when neither the command line nor the scenario names one.
pub(crate) const DEFAULT_PROFILE: &str = "ideal";

/// A recorder profile file (`recorders/*.toml`) as written (the keys are in
/// the module docs), before it is checked ([`Profile::from_file`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProfileFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// Recorder frame length (default 1 s); a channel's slot is a fraction of it.
    #[serde(default)]
    pub frame: Option<Quantity>,
    /// Words per frame, so that channels may give a `word` index instead of a `slot`.
    #[serde(default)]
    pub words_per_frame: Option<u32>,
    #[serde(default)]
    pub origin: Option<OriginSpec>,
    /// Quantities this recorder does not have.
    #[serde(default)]
    pub absent: Vec<String>,
    pub channels: Vec<ChannelSpec>,
}

/// Where a profile's flat earth lies on the globe (`origin = { latitude,
/// longitude }`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OriginSpec {
    pub latitude: Quantity,
    pub longitude: Quantity,
}

/// One `[[channels]]` table of a recorder profile: the quantity it records
/// and its sampling and error chain (the keys are in the module docs).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelSpec {
    pub name: String,
    #[serde(default)]
    pub label: String,
    pub rate: Quantity,
    #[serde(default)]
    pub phase: Quantity,
    #[serde(default)]
    pub slot: Option<f64>,
    #[serde(default)]
    pub word: Option<u32>,
    #[serde(default)]
    pub resolution: Option<Quantity>,
    #[serde(default)]
    pub saturation: Option<[Quantity; 2]>,
    #[serde(default)]
    pub noise: Quantity,
    #[serde(default)]
    pub noise_time: Quantity,
    #[serde(default)]
    pub bias: Quantity,
    #[serde(default)]
    pub scale_factor: Option<f64>,
    #[serde(default)]
    pub delay: Quantity,
    #[serde(default)]
    pub lag: Quantity,
    #[serde(default)]
    pub anti_alias: Option<Quantity>,
    #[serde(default)]
    pub dropout: f64,
    #[serde(default)]
    pub fault: Option<FaultSpec>,
    #[serde(default)]
    pub position: Option<[Quantity; 3]>,
}

/// A channel's `fault`: what a broken sensor reads in place of the signal.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum FaultSpec {
    /// From `from` on the channel reads `value`, or holds its last sample before `from`.
    Stuck {
        from: Quantity,
        #[serde(default)]
        value: Option<Quantity>,
    },
    /// Every sample reads one of `values`, drawn at random (Wang et al. 2012's AoA read 109.70 or 108.30).
    Levels { values: Vec<Quantity> },
}

/// A validated fault, values in SI.
#[derive(Debug, Clone, PartialEq)]
pub enum Fault {
    Stuck { from: f64, value: Option<f64> },
    Levels(Vec<f64>),
}

/// One validated channel of a profile, quantities in SI.
#[derive(Debug, Clone)]
pub struct ChannelModel {
    pub measurand: &'static Measurand,
    pub label: String,
    pub rate: f64,
    /// `phase + slot·frame`: the first sample's time after the trace start.
    pub offset: f64,
    pub resolution: Option<f64>,
    pub saturation: Option<(f64, f64)>,
    pub noise: f64,
    /// Correlation time of the noise (0: white).
    pub noise_time: f64,
    pub bias: f64,
    pub scale_factor: f64,
    pub delay: f64,
    pub lag: f64,
    pub anti_alias: Option<f64>,
    pub dropout: f64,
    pub fault: Option<Fault>,
    pub position: Vector3<f64>,
}

/// A validated recorder profile.
///
/// # Example
///
/// Record a flight with the bundled flight-test profile (every channel at
/// 25 Hz with white noise) and keep the record as a folder:
///
/// ```
/// use aeroid_record::{FlightRecord, recorder::Profile};
/// use aeroid_sim::scenario::Scenario;
///
/// let scenario = Scenario::load("attas-elevator-3211")?;
/// let (trace, _truth) = aeroid_sim::fly(&scenario)?;
/// let profile = Profile::load("flight-test-25hz", None)?;
/// let record = profile.record(&trace, &scenario.aircraft, scenario.seed)?;
///
/// // The pitch attitude at 25 Hz over 60 s, every 4th simulator step, off
/// // the truth by the profile's 0.1° of noise.
/// let pitch = record.channel("pitch")?;
/// assert_eq!((pitch.rate, pitch.times.len()), (25.0, 1501));
/// let truth = trace.values("pitch")?;
/// let errors = pitch.values.iter().enumerate().map(|(k, v)| v - truth[4 * k]);
/// let rms = (errors.map(|e| e * e).sum::<f64>() / 1501.0).sqrt().to_degrees();
/// assert!((rms - 0.1).abs() < 0.01, "{rms}°");
///
/// // A record folder reads back bit for bit.
/// let folder = std::env::temp_dir().join(format!("aeroid-record-doc-{}", std::process::id()));
/// record.write(&folder)?;
/// assert_eq!(FlightRecord::read(&folder)?, record);
/// # std::fs::remove_dir_all(&folder).unwrap();
/// # Ok::<(), aeroid_record::error::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Profile {
    pub name: String,
    pub description: String,
    pub path: PathBuf,
    pub origin: GeographicOrigin,
    pub absent: Vec<String>,
    pub channels: Vec<ChannelModel>,
}

impl Profile {
    /// Loads a profile by bundled name (`recorders/NAME.toml`) or path.
    pub fn load(reference: &str, base: Option<&Path>) -> Result<Profile> {
        let path = catalog::resolve(reference, catalog::RECORDER_FOLDER, base)?;
        let file: ProfileFile = parse_toml(&path, &read_text(&path)?)?;
        Profile::from_file(&file, &path)
    }

    /// Validates a parsed profile, reporting every problem at once.
    pub fn from_file(file: &ProfileFile, path: &Path) -> Result<Profile> {
        let mut problems = FieldErrors::default();
        if file.name.trim().is_empty() {
            problems.push("name", "must not be empty");
        }
        let frame = file.frame.as_ref().map_or(1.0, |q| {
            positive(q.si(Dimension::Time), "frame", &mut problems)
        });
        if file.words_per_frame == Some(0) {
            problems.push("words_per_frame", "must be at least 1");
        }
        let origin = read_origin(file.origin.as_ref(), &mut problems);
        let layout = FrameLayout {
            frame,
            words: file.words_per_frame.filter(|&w| w > 0),
        };
        let mut seen = BTreeSet::new();
        let channels = file
            .channels
            .iter()
            .filter_map(|spec| {
                if !seen.insert(spec.name.as_str()) {
                    problems.push(
                        format!("channels.{}", spec.name),
                        "the channel appears twice",
                    );
                }
                read_channel(spec, &layout, &mut problems)
            })
            .collect();
        if file.channels.is_empty() {
            problems.push(
                "channels",
                "must list at least one channel (a [[channels]] table): a recorder without channels records nothing",
            );
        }
        check_absent(&file.absent, &seen, &mut problems);
        let profile = Profile {
            name: file.name.clone(),
            description: file.description.clone(),
            path: path.to_path_buf(),
            origin,
            absent: file.absent.clone(),
            channels,
        };
        Ok(problems.finish(path, profile)?)
    }

    /// The same profile without its random and discontinuous errors (noise,
    /// quantization, dropouts, faults): what it records is a smooth function
    /// of the flight, for sensitivities. Rates, skew, delay, lag, filters,
    /// bias, scale factor and saturation stay.
    pub fn without_random_errors(&self) -> Profile {
        let mut clean = self.clone();
        for channel in &mut clean.channels {
            channel.noise = 0.0;
            channel.resolution = None;
            channel.dropout = 0.0;
            channel.fault = None;
        }
        clean
    }

    /// The profile without its random errors but with its resolution: the
    /// record a noise-free recorder of this resolution writes
    /// (quantization is deterministic given the flight).
    pub fn without_noise(&self) -> Profile {
        let mut quantized = self.without_random_errors();
        for (channel, original) in quantized.channels.iter_mut().zip(&self.channels) {
            channel.resolution = original.resolution;
        }
        quantized
    }

    /// Records a truth trace of `aircraft` with this profile; random draws come from `seed`.
    pub fn record(
        &self,
        trace: &TruthTrace,
        aircraft: &Aircraft,
        seed: u64,
    ) -> Result<FlightRecord> {
        if trace.samples.len() < 2 {
            return Err(Error::Recording {
                reason: "a truth trace needs at least two samples to be recorded",
            });
        }
        let context = Context {
            mass: aircraft.mass.mass,
            propulsion: aircraft.propulsion,
            origin: self.origin,
            sensor_position: Vector3::zeros(),
        };
        let start = trace.samples[0].time;
        let span = trace.samples[trace.samples.len() - 1].time - start;
        let samples: f64 = self
            .channels
            .iter()
            .map(|c| (span * c.rate).max(0.0) + 1.0)
            .sum();
        limits::check_memory(
            &format!(
                "the record of profile {} (channel rate × duration samples)",
                self.name
            ),
            samples,
            2 * std::mem::size_of::<f64>(),
        )
        .map_err(|message| aeroid_core::Error::Invalid {
            path: self.path.clone(),
            problems: vec![aeroid_core::error::FieldError {
                field: "channels.rate".into(),
                message: message.to_string(),
            }],
        })?;
        let mut rng = random::stream(seed, streams::RECORDER);
        let channels = self
            .channels
            .iter()
            .map(|model| model.record(trace, &context, &self.name, &mut rng))
            .collect::<Result<_>>()?;
        self.record_of(&trace.scenario, seed, channels)
    }

    /// The record of `scenario` this profile made with `seed`, checked.
    fn record_of(&self, scenario: &str, seed: u64, channels: Vec<Channel>) -> Result<FlightRecord> {
        let record = FlightRecord {
            scenario: scenario.to_string(),
            seed: Some(seed),
            profile: self.name.clone(),
            absent: self.absent.clone(),
            channels,
            bridge_gaps: false,
        };
        // Settings within their bounds can still overflow together (a huge
        // scale factor on a huge bias): the profile is named, with the
        // channel and the sample.
        record.validate(&self.path)?;
        Ok(record)
    }
}

impl Profile {
    /// Records named true signals on `grid` (a step of `step`), such as a
    /// linear model's states, inputs and outputs: each channel of the
    /// profile whose quantity is one of `signals` is recorded from it as
    /// from a truth trace; the profile's other channels are left out.
    /// Random draws come from `seed`, channel by channel in profile order.
    pub fn record_signals(
        &self,
        scenario: &str,
        grid: &[f64],
        step: f64,
        signals: &[(String, Vec<f64>)],
        seed: u64,
    ) -> Result<FlightRecord> {
        if grid.len() < 2 || signals.iter().any(|(_, s)| s.len() != grid.len()) {
            return Err(Error::Recording {
                reason: "signals to record need at least two samples, one per grid point",
            });
        }
        let mut rng = random::stream(seed, streams::RECORDER);
        let mut channels = Vec::new();
        for model in &self.channels {
            if let Some((_, signal)) = signals.iter().find(|(n, _)| n == model.measurand.name) {
                channels.push(model.record_signal(
                    grid,
                    signal.clone(),
                    step,
                    &self.name,
                    &mut rng,
                )?);
            }
        }
        self.record_of(scenario, seed, channels)
    }

    /// The same profile with every channel's white-noise standard deviation
    /// multiplied by `factor` (bias, quantization, faults unchanged), named
    /// `NAME×noiseFACTOR`. Monte Carlo studies sweep noise with it.
    pub fn with_noise_scaled(&self, factor: f64) -> Profile {
        let mut profile = self.clone();
        profile.name = format!("{}×noise{factor}", self.name);
        for channel in &mut profile.channels {
            channel.noise *= factor;
        }
        profile
    }

    /// The same profile with every quantized channel's resolution (LSB)
    /// times `factor` (0: unquantized), named `NAME×lsbFACTOR`. Monte Carlo
    /// studies sweep resolution with it.
    pub fn with_resolution_scaled(&self, factor: f64) -> Profile {
        let mut profile = self.clone();
        profile.name = format!("{}×lsb{factor}", self.name);
        for channel in &mut profile.channels {
            channel.resolution = channel.resolution.map(|r| r * factor).filter(|&r| r > 0.0);
        }
        profile
    }

    /// The same profile with every channel sampled at `rate` (Hz), each
    /// keeping its place in the frame, named `NAME@RATEHz`. Monte Carlo
    /// studies sweep sample rate with it.
    pub fn with_rate(&self, rate: f64) -> Profile {
        let mut profile = self.clone();
        profile.name = format!("{}@{rate}Hz", self.name);
        for channel in &mut profile.channels {
            channel.rate = rate;
        }
        profile
    }

    /// The same profile with the channels in `rates` sampled at their
    /// given rate (Hz), named `NAME@CHANNEL:RATEHz,…`; an error names a
    /// channel the profile does not record.
    pub fn with_channel_rates(
        &self,
        rates: &[(String, f64)],
    ) -> std::result::Result<Profile, crate::error::Error> {
        let mut profile = self.clone();
        for (name, rate) in rates {
            let channel = profile
                .channels
                .iter_mut()
                .find(|c| c.measurand.name == name)
                .ok_or_else(|| crate::error::Error::NoChannel {
                    profile: self.name.clone(),
                    channel: name.clone(),
                })?;
            channel.rate = *rate;
            profile.name += &format!("@{name}:{rate}Hz");
        }
        Ok(profile)
    }

    /// The same profile without the channels `missing`, which the record
    /// then states as absent, named `NAME−CHANNEL,…`; an error names a
    /// channel the profile does not record.
    pub fn without(&self, missing: &[String]) -> std::result::Result<Profile, crate::error::Error> {
        let mut profile = self.clone();
        for name in missing {
            let before = profile.channels.len();
            profile.channels.retain(|c| c.measurand.name != name);
            if profile.channels.len() == before {
                return Err(crate::error::Error::NoChannel {
                    profile: self.name.clone(),
                    channel: name.clone(),
                });
            }
            profile.absent.push(name.clone());
        }
        if !missing.is_empty() {
            profile.name = format!("{}−{}", self.name, missing.join(","));
        }
        Ok(profile)
    }
}

/// The profile to record a scenario with: `reference` if given, else the
/// scenario's `recorder`, else `DEFAULT_PROFILE`.
pub fn profile_for(scenario: &Scenario, reference: Option<&str>) -> Result<Profile> {
    match (reference, &scenario.recorder) {
        (Some(reference), _) => Profile::load(reference, None),
        (None, Some(reference)) => {
            let path = catalog::resolve_named(
                reference,
                catalog::RECORDER_FOLDER,
                &scenario.path,
                "recorder",
            )?;
            Profile::load(&path.to_string_lossy(), None)
        }
        (None, None) => Profile::load(DEFAULT_PROFILE, None),
    }
}

/// Simulates a scenario and records it: the flight record and the truth of the
/// run. The scenario's seed drives both the turbulence and the recorder.
pub fn record_scenario(scenario: &Scenario, profile: &Profile) -> Result<(FlightRecord, RunTruth)> {
    record_scenario_seeded(scenario, profile, scenario.seed)
}

/// [`record_scenario`] with the recorder's random draws from `recorder_seed`
/// (the turbulence still from `scenario.seed`), so that a Monte Carlo case
/// can draw the two independently.
pub fn record_scenario_seeded(
    scenario: &Scenario,
    profile: &Profile,
    recorder_seed: u64,
) -> Result<(FlightRecord, RunTruth)> {
    let (trace, truth) = aeroid_sim::fly(scenario)?;
    let record = profile.record(&trace, &scenario.aircraft, recorder_seed)?;
    Ok((record, truth))
}
