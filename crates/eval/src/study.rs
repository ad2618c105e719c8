//! Monte Carlo studies (`studies/*.toml`, `aeroid study`): many seeded runs
//! of the whole harness (simulate, record, estimate, score) over a grid of
//! sweep points, and per point, model, method and parameter the statistics
//! that say whether an estimator is unbiased and its Cramér–Rao bounds are
//! honest. The file's keys are in docs/files.md ([`StudyFile`]).
//!
//! ```toml
//! name = "attas-lateral-acceptance"
//! description = "..."
//! scenarios = ["attas-lateral-multistep"]   # manoeuvres (bundled names or paths relative to this file)
//! profile = "flight-test-25hz"              # recorder profile (or several: [sweep] profile)
//! models = ["attas-lateral"]                # model structures fitted to every record
//! methods = ["oem", "ee"]                   # ee, swr, oem (as `aeroid run`)
//! runs = 100                                # runs per sweep point
//! seed = 4                                  # study seed
//! [sweep]                                   # optional axes; each defaults to the files as they are
//! profile = ["ideal", "flight-test-25hz"]   # recorder profiles, instead of `profile` above
//! turbulence = ["none", "moderate"]         # Dryden turbulence replacing the scenarios'
//! input_scale = [0.5, 1.0]                  # every input's deviation from trim times this
//! sample_rate = ["10 Hz", "25 Hz"]          # every channel of the profile at this rate
//! noise_scale = [0.5, 1.0, 2.0]             # every channel's noise σ times this
//! resolution_scale = [1.0, 4.0]             # every quantized channel's LSB times this
//! missing = [[], ["alpha"]]                 # channels left out of the record
//! channel_rate = [{ alpha = "2 Hz" }]       # channels at their own rate (moot where `missing` leaves one out)
//! settings = [{}, { oem = { max_iterations = 3 } }]  # method settings variants
//! ```
//!
//! Sweep points are the product of the axes in [`Axis::PRODUCT`] order (the
//! last varies fastest). A case is one run at one point, seeded from the
//! study seed by [`Case::stream`]: its numbers depend on nothing but the
//! study seed, its point and its run index, so settings variants are
//! compared on the same flights and a resumed or sharded study gives the
//! same rows. Every case gives plain rows ([`Row`]: one per model, method
//! and parameter, or one per model and method when the fit failed); a
//! failed recording or estimate and a diverged fit are rows with their
//! status and reason, counted in the summary, never fatal. The
//! [`summarise`]d statistics use the converged fits only.

mod case;
mod check;
mod execute;
mod file;
mod load;
mod points;
mod result;
#[cfg(test)]
mod tests;

use self::check::runs_problem;
pub use self::execute::JournaledRun;
pub use self::file::{StudyFile, StudyMethods, SweepSpec};
pub use self::result::{StudyResult, assemble};
pub use crate::axis::{Axis, AxisValues};
use crate::axis::{channel_rates_text, settings_text};
use crate::error::{Error, Result};
pub use crate::row::{Row, RowStatus};
pub use crate::summary::{Ending, Summariser, SummaryRow, summarise};
use aeroid_core::limits;
use aeroid_estimation::estimator::MethodTables;
use aeroid_estimation::registry::Registry;
use aeroid_estimation::structure::Structure;
use aeroid_record::recorder::Profile;
use aeroid_sim::scenario::Scenario;
use std::path::PathBuf;

/// One point of the sweep grid: a scenario and the profile modified for it.
#[derive(Debug, Clone)]
pub struct SweepPoint {
    /// Index into [`Study::scenarios`].
    pub scenario: usize,
    /// The recorder profile's name as the study names it (before the sweep
    /// modifies its rates, noise or resolution).
    pub recorder: String,
    /// The turbulence intensity, or None for the scenario's own wind.
    pub turbulence: Option<String>,
    pub input_scale: f64,
    /// Every channel's rate (Hz), or None for the profile's own rates.
    pub sample_rate: Option<f64>,
    pub noise_scale: f64,
    pub resolution_scale: f64,
    /// Channels left out of the record.
    pub missing: Vec<String>,
    /// Channels sampled at their own rate (Hz), after `sample_rate`.
    pub channel_rates: Vec<(String, f64)>,
    /// Index into [`Study::setting_variants`].
    pub settings: usize,
    /// The recording this point fits: points that differ only in their
    /// settings share it (the same flight and noise draw), so settings
    /// are compared on the same data.
    pub recording: usize,
    pub profile: Profile,
}

impl SweepPoint {
    /// The point's value on `axis` as the study's fingerprint writes it
    /// (indices for the scenario and settings variant).
    pub fn identity(&self, axis: Axis) -> String {
        match axis {
            Axis::Scenario => self.scenario.to_string(),
            Axis::Profile => self.recorder.clone(),
            Axis::Missing => format!("{:?}", self.missing),
            Axis::ChannelRate => format!("{:?}", self.channel_rates),
            Axis::Turbulence => format!("{:?}", self.turbulence),
            Axis::InputScale => self.input_scale.to_string(),
            Axis::SampleRate => format!("{:?}", self.sample_rate),
            Axis::NoiseScale => self.noise_scale.to_string(),
            Axis::ResolutionScale => self.resolution_scale.to_string(),
            Axis::Settings => self.settings.to_string(),
        }
    }
}

/// A validated study, its files loaded.
#[derive(Debug, Clone)]
pub struct Study {
    pub name: String,
    pub description: String,
    pub path: PathBuf,
    pub scenarios: Vec<Scenario>,
    /// The recorder profiles: the study's `profile`, or its `[sweep] profile` list.
    pub profiles: Vec<Profile>,
    pub models: Vec<Structure>,
    pub methods: Vec<String>,
    /// The study's settings per method, overriding the models' and the scenarios'.
    pub settings: MethodTables,
    /// The settings axis: per variant, tables overriding `settings`
    /// (one empty variant when the study has no such axis).
    pub setting_variants: Vec<MethodTables>,
    /// Runs per sweep point.
    pub runs: usize,
    pub seed: u64,
    pub points: Vec<SweepPoint>,
    /// The derive step, on the records of the profiles it names.
    pub derive: Option<aeroid_record::prep::derive::DeriveTable>,
    /// The estimators the study runs its methods from.
    pub registry: Registry,
}

/// One run at one sweep point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Case {
    pub point: usize,
    pub run: usize,
}

impl Case {
    /// The case's stream of the study seed: `point·2³² + run`, with the
    /// point's recording index as `point` ([`SweepPoint::recording`]): the
    /// point without its settings variant, so that settings are compared on
    /// the same flights (without a settings axis it is the point). One
    /// ChaCha8 generator per case ([`aeroid_core::random::stream`]) draws
    /// two seeds: the turbulence seed (replacing the scenario's `seed`) and
    /// the recorder-noise seed. A case's numbers therefore depend on nothing
    /// but the study seed, its point and its run index: not on the thread
    /// count, the order the cases finish in, or the number of runs (raising
    /// `runs` from 100 to 200 keeps the first 100 rows), which is what a
    /// resumed or sharded study needs.
    pub fn stream(self) -> u64 {
        ((self.point as u64) << 32) | self.run as u64
    }
}

impl Study {
    /// Sets the runs per sweep point (`aeroid study --runs`), within
    /// [`limits::MAX_RUNS`] and the memory budget; `field` names where the
    /// number comes from in the refusal.
    pub fn set_runs(&mut self, runs: usize, field: &str) -> Result<()> {
        if let Some(message) = runs_problem(runs) {
            return Err(self.invalid(field, message));
        }
        self.runs = runs;
        self.check_size(field)
    }

    /// Checks that the cases and their rows fit the memory budget.
    fn check_size(&self, field: &str) -> Result<()> {
        let cases = self.points.len() as f64 * self.runs as f64;
        let parameters: usize = self
            .models
            .iter()
            .map(|m| m.free_names().len().max(1))
            .sum();
        let rows_per_case = (parameters.max(1) * self.methods.len().max(1)) as f64;
        limits::check_memory(
            &format!(
                "the study ({} sweep point(s) × {} runs, {rows_per_case} rows per case)",
                self.points.len(),
                self.runs
            ),
            cases,
            std::mem::size_of::<Case>() + rows_per_case as usize * std::mem::size_of::<Row>(),
        )
        .map_err(|message| self.invalid(field, message.to_string()))
    }

    fn invalid(&self, field: &str, message: String) -> Error {
        aeroid_core::Error::Invalid {
            path: self.path.clone(),
            problems: vec![aeroid_core::error::FieldError {
                field: field.into(),
                message,
            }],
        }
        .into()
    }

    /// Every case, point by point, run by run.
    pub fn cases(&self) -> Vec<Case> {
        (0..self.points.len())
            .flat_map(|point| (0..self.runs).map(move |run| Case { point, run }))
            .collect()
    }

    /// A sweep point's value on every axis, as its rows write them.
    pub fn point_axes(&self, point: usize) -> AxisValues {
        let p = &self.points[point];
        AxisValues {
            scenario: self.scenarios[p.scenario].name.clone(),
            profile: p.recorder.clone(),
            turbulence: p.turbulence.clone().unwrap_or_default(),
            input_scale: p.input_scale,
            sample_rate: p.sample_rate,
            noise_scale: p.noise_scale,
            resolution_scale: p.resolution_scale,
            missing: p.missing.join(","),
            channel_rates: channel_rates_text(&p.channel_rates),
            settings: settings_text(&self.setting_variants[p.settings]),
        }
    }

    /// A short label of a sweep point: scenario, profile (when the study
    /// has several), turbulence, input scale, rate, noise scale and
    /// resolution scale (the axes not at their defaults, and always the
    /// noise scale).
    pub fn point_label(&self, point: usize) -> String {
        let mut axes = self.point_axes(point);
        if self.profiles.len() <= 1 {
            axes.profile.clear();
        }
        axes.label()
    }

    /// The index of a case in the study's case order (point by point,
    /// run by run): what shards and journals key cases by.
    pub fn case_index(&self, case: Case) -> usize {
        case.point * self.runs + case.run
    }
}
