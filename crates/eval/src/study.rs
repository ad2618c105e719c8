//! Monte Carlo studies (`studies/*.toml`, `aeroid study`): many seeded runs
//! of the whole harness (simulate, record, estimate, score) over a grid of
//! sweep points, and per point, model, method and parameter the statistics
//! that say whether an estimator is unbiased and its Cramér–Rao bounds are
//! honest.
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
//! Sweep points are the product scenario × profile × missing channels ×
//! channel rates × turbulence × input scale × sample rate × noise scale ×
//! resolution scale × settings, in that order (the last varies fastest).
//! A case is one run at one point; it is keyed by the stream
//! `recording·2³² + run` of the study seed, the recording being the point
//! without its settings variant, so that settings are compared on the
//! same flights (without a settings axis it is the point) (one
//! ChaCha8 generator per case, [`random::stream`]), from which it draws two
//! seeds: the turbulence seed (replacing the scenario's `seed`) and the
//! recorder-noise seed. A case's numbers therefore depend on nothing but the
//! study seed, its point and its run index: not on the thread count, the
//! order the cases finish in, or the number of runs (raising `runs` from 100
//! to 200 keeps the first 100 rows), which is what a resumed or sharded
//! study needs.
//!
//! Every case gives plain rows ([`Row`]: one per model, method and
//! parameter, or one per model and method when the fit failed). A failed
//! recording or estimate and a diverged fit are rows with their status and
//! reason, counted in the summary, never fatal. The [`summarise`]d
//! statistics use the converged fits only.

use crate::histories::CaseHistories;
use crate::journal::{self, Finished, Header, Journal, Shard};
pub use crate::row::{Row, RowStatus};
use crate::run::{self, Outcome};
use crate::score::ParameterScore;
pub use crate::summary::{Ending, Summariser, SummaryRow, summarise};
use aeroid_core::catalog;
use aeroid_core::error::{Error, Problems, Result, parse_toml, read_text};
use aeroid_core::limits;
use aeroid_core::random;
use aeroid_core::units::Quantity;
use aeroid_estimation::estimate::Estimate;
use aeroid_estimation::estimator::MethodTables;
use aeroid_estimation::registry::Registry;
use aeroid_estimation::structure::Structure;
use aeroid_record::recorder::{Profile, parse_rate};
use aeroid_sim::scenario::Scenario;
use aeroid_sim::wind::TurbulenceSpec;
use rand::RngExt;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub scenarios: Vec<String>,
    /// The recorder profile; absent when `[sweep] profile` lists several.
    #[serde(default)]
    pub profile: Option<String>,
    pub models: Vec<String>,
    pub methods: StudyMethods,
    pub runs: usize,
    pub seed: u64,
    #[serde(default)]
    pub sweep: SweepSpec,
    /// The derive step on the records of the named profiles (all when none
    /// is named) before the estimators: for recorders that lack channels
    /// the estimators need (the QAR).
    #[serde(default)]
    pub derive: Option<aeroid_record::prep::derive::DeriveTable>,
}

/// A study's methods: a list of names (`methods = ["ee", "oem"]`), or one
/// settings table per method (`[methods.oem]`), run in registry order.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum StudyMethods {
    Names(Vec<String>),
    Tables(MethodTables),
}

impl<'de> Deserialize<'de> for StudyMethods {
    fn deserialize<D: serde::Deserializer<'de>>(
        deserializer: D,
    ) -> std::result::Result<Self, D::Error> {
        let expected = "a list of method names (methods = [\"ee\", \"oem\"]) or one [methods.NAME] settings table per method";
        match toml::Value::deserialize(deserializer)? {
            toml::Value::Array(names) => names
                .into_iter()
                .map(|name| match name {
                    toml::Value::String(name) => Ok(name),
                    other => Err(serde::de::Error::custom(format!(
                        "{other} is not a method name; expected {expected}"
                    ))),
                })
                .collect::<std::result::Result<_, _>>()
                .map(StudyMethods::Names),
            toml::Value::Table(tables) => tables
                .into_iter()
                .map(|(name, table)| match table {
                    toml::Value::Table(table) => Ok((name, table)),
                    other => Err(serde::de::Error::custom(format!(
                        "methods.{name} = {other}: expected {expected}"
                    ))),
                })
                .collect::<std::result::Result<_, _>>()
                .map(StudyMethods::Tables),
            other => Err(serde::de::Error::custom(format!(
                "{other}: expected {expected}"
            ))),
        }
    }
}

impl StudyMethods {
    /// The method names, in the order they run (for tables, the
    /// registry's order, then the names it does not know).
    pub fn names(&self, registry: &Registry) -> Vec<String> {
        match self {
            StudyMethods::Names(names) => names.clone(),
            StudyMethods::Tables(tables) => registry
                .names()
                .into_iter()
                .filter(|name| tables.contains_key(name))
                .chain(
                    tables
                        .keys()
                        .filter(|name| registry.find(name).is_err())
                        .cloned(),
                )
                .collect(),
        }
    }

    /// The settings tables (none for a list).
    pub fn tables(&self) -> MethodTables {
        match self {
            StudyMethods::Names(_) => MethodTables::new(),
            StudyMethods::Tables(tables) => tables.clone(),
        }
    }
}

/// The sweep axes; an empty axis leaves the profile as it is.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// Recorder profiles (bundled names or paths), in place of the study's `profile`.
    #[serde(default)]
    pub profile: Vec<String>,
    /// Dryden turbulence: `none`, `light`, `moderate`, `severe`.
    #[serde(default)]
    pub turbulence: Vec<String>,
    /// Every input's deviation from trim times this.
    #[serde(default)]
    pub input_scale: Vec<f64>,
    #[serde(default)]
    pub sample_rate: Vec<Quantity>,
    #[serde(default)]
    pub noise_scale: Vec<f64>,
    /// Every quantized channel's resolution (LSB) times this.
    #[serde(default)]
    pub resolution_scale: Vec<f64>,
    /// Channels left out of the record: each entry a list of channel names.
    #[serde(default)]
    pub missing: Vec<Vec<String>>,
    /// Per-channel sample rates: each entry a table channel → frequency.
    #[serde(default)]
    pub channel_rate: Vec<BTreeMap<String, Quantity>>,
    /// Method settings: each entry `{ NAME = { key = value } }`, over the
    /// study's `[methods.NAME]` tables.
    #[serde(default)]
    pub settings: Vec<MethodTables>,
}

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
    /// point's recording index as `point` ([`SweepPoint::recording`]).
    pub fn stream(self) -> u64 {
        ((self.point as u64) << 32) | self.run as u64
    }
}

/// What a study produced: its summary and how its fits ended.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StudyResult {
    pub study: String,
    pub seed: u64,
    pub runs: usize,
    /// Cases and rows (`runs.csv`'s) the summary is of.
    pub cases: usize,
    pub rows: usize,
    pub summary: Vec<SummaryRow>,
    /// How the fits ended, each status with its count and first fit.
    pub endings: Vec<Ending>,
}

impl Study {
    /// Loads a study by bundled name (`studies/NAME.toml`) or path.
    pub fn load(registry: &Registry, reference: &str) -> Result<Study> {
        let path = catalog::resolve(reference, catalog::STUDY_FOLDER, None)?;
        let file: StudyFile = parse_toml(&path, &read_text(&path)?)?;
        Study::from_file(registry, &file, &path)
    }

    /// Validates a parsed study and loads the files it names, reporting every
    /// problem at once under its field.
    pub fn from_file(registry: &Registry, file: &StudyFile, path: &Path) -> Result<Study> {
        let base = path.parent().unwrap_or(Path::new("."));
        let mut problems = Problems::default();
        if file.name.trim().is_empty() {
            problems.push("name", "must not be empty");
        }
        let resolved = |reference: &str, folder: &str| {
            catalog::resolve(reference, folder, Some(base))
                .map(|path| path.to_string_lossy().into_owned())
        };
        let scenarios = load_each("scenarios", &file.scenarios, &mut problems, |r| {
            let scenario = Scenario::load(&resolved(r, catalog::SCENARIO_FOLDER)?)?;
            registry.validate_tables(&scenario.methods, &scenario.path)?;
            Ok(scenario)
        });
        let models = load_each("models", &file.models, &mut problems, |r| {
            Structure::load(&resolved(r, catalog::MODEL_FOLDER)?)
        });
        let profiles = study_profiles(file, base, &mut problems);
        check_methods(&file.methods, registry, &mut problems);
        registry.check_tables(&file.methods.tables(), &mut problems);
        if let Err(message) = check_runs(file.runs) {
            problems.push("runs", message);
        }
        let rates = sample_rates(&file.sweep.sample_rate, &mut problems);
        let sweep = &file.sweep;
        let scales = scale_axis("noise_scale", &sweep.noise_scale, false, &mut problems);
        let resolutions = scale_axis(
            "resolution_scale",
            &sweep.resolution_scale,
            false,
            &mut problems,
        );
        let input_scales = scale_axis("input_scale", &sweep.input_scale, true, &mut problems);
        let turbulence = turbulence_axis(&sweep.turbulence, &mut problems);
        let Some(profiles) = profiles else {
            return Err(Error::Invalid {
                path: path.to_path_buf(),
                problems: problems.0,
            });
        };
        for name in file.derive.iter().flat_map(|d| &d.profiles) {
            if !profiles.iter().any(|p| &p.name == name) {
                problems.push(
                    "derive.profiles",
                    format!(
                        "'{name}' is not one of the study's profiles ({})",
                        profiles
                            .iter()
                            .map(|p| p.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                );
            }
        }
        let missing = missing_axis(&sweep.missing, &profiles, &mut problems);
        let channel_rates = channel_rate_axis(&sweep.channel_rate, &profiles, &mut problems);
        let variants = settings_axis(&sweep.settings, registry, &mut problems);
        if !problems.is_empty() {
            return Err(Error::Invalid {
                path: path.to_path_buf(),
                problems: problems.0,
            });
        }
        let mut points = Vec::new();
        let mut recordings = 0;
        for scenario in 0..scenarios.len() {
            for profile in &profiles {
                for missing in &missing {
                    let kept = profile.without(missing).map_err(Error::Other)?;
                    for rates_given in &channel_rates {
                        // A rate for a channel this point leaves out is moot.
                        let channel_rates: Vec<(String, f64)> = rates_given
                            .iter()
                            .filter(|(name, _)| !missing.contains(name))
                            .cloned()
                            .collect();
                        for turbulence in &turbulence {
                            for &input_scale in &input_scales {
                                for &sample_rate in &rates {
                                    let rated = sample_rate
                                        .map_or_else(|| kept.clone(), |r| kept.with_rate(r))
                                        .with_channel_rates(&channel_rates)
                                        .map_err(Error::Other)?;
                                    for &noise_scale in &scales {
                                        let noisy = if noise_scale == 1.0 {
                                            rated.clone()
                                        } else {
                                            rated.with_noise_scaled(noise_scale)
                                        };
                                        for &resolution_scale in &resolutions {
                                            let recorder = if resolution_scale == 1.0 {
                                                noisy.clone()
                                            } else {
                                                noisy.with_resolution_scaled(resolution_scale)
                                            };
                                            for settings in 0..variants.len() {
                                                points.push(SweepPoint {
                                                    scenario,
                                                    recorder: profile.name.clone(),
                                                    missing: missing.clone(),
                                                    channel_rates: channel_rates.clone(),
                                                    turbulence: turbulence.clone(),
                                                    input_scale,
                                                    sample_rate,
                                                    noise_scale,
                                                    resolution_scale,
                                                    settings,
                                                    recording: recordings,
                                                    profile: recorder.clone(),
                                                });
                                            }
                                            recordings += 1;
                                        }
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        let study = Study {
            name: file.name.clone(),
            description: file.description.clone(),
            path: path.to_path_buf(),
            scenarios,
            profiles,
            models,
            methods: file.methods.names(registry),
            settings: file.methods.tables(),
            setting_variants: variants,
            runs: file.runs,
            seed: file.seed,
            points,
            derive: file.derive.clone(),
            registry: registry.clone(),
        };
        study.check_size("runs")?;
        Ok(study)
    }

    /// Sets the runs per sweep point (`aeroid study --runs`), within
    /// [`limits::MAX_RUNS`] and the memory budget; `field` names where the
    /// number comes from in the refusal.
    pub fn set_runs(&mut self, runs: usize, field: &str) -> Result<()> {
        check_runs(runs).map_err(|message| self.invalid(field, message))?;
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
        .map_err(|message| self.invalid(field, message))
    }

    fn invalid(&self, field: &str, message: String) -> Error {
        Error::Invalid {
            path: self.path.clone(),
            problems: vec![aeroid_core::error::Problem {
                field: field.into(),
                message,
            }],
        }
    }

    /// Every case, point by point, run by run.
    pub fn cases(&self) -> Vec<Case> {
        (0..self.points.len())
            .flat_map(|point| (0..self.runs).map(move |run| Case { point, run }))
            .collect()
    }

    /// A short label of a sweep point: scenario, profile (when the study
    /// has several), turbulence, input scale, rate, noise scale and
    /// resolution scale (the axes not at their defaults, and always the
    /// noise scale).
    pub fn point_label(&self, point: usize) -> String {
        let p = &self.points[point];
        let missing = p.missing.join(",");
        let channel_rates = channel_rates_text(&p.channel_rates);
        let settings = settings_text(&self.setting_variants[p.settings]);
        label(&Axes {
            scenario: &self.scenarios[p.scenario].name,
            profile: if self.profiles.len() > 1 {
                &p.recorder
            } else {
                ""
            },
            turbulence: p.turbulence.as_deref().unwrap_or(""),
            input_scale: p.input_scale,
            sample_rate: p.sample_rate,
            noise_scale: p.noise_scale,
            resolution_scale: p.resolution_scale,
            missing: &missing,
            channel_rates: &channel_rates,
            settings: &settings,
        })
    }

    /// Runs one case: draws its seeds, flies and records the scenario, and
    /// fits every model with every method. Never fails: a failure is a row.
    pub fn run_case(&self, case: Case) -> Vec<Row> {
        self.run_case_with_histories(case, false).0
    }

    /// [`Study::run_case`], and when `keep` the case's time histories
    /// (measured, proof of match, estimated and true coefficient histories).
    pub fn run_case_with_histories(
        &self,
        case: Case,
        keep: bool,
    ) -> (Vec<Row>, Option<CaseHistories>) {
        let point = &self.points[case.point];
        let recording = Case {
            point: point.recording,
            run: case.run,
        };
        let mut rng = random::stream(self.seed, recording.stream());
        let turbulence_seed: u64 = rng.random();
        let recorder_seed: u64 = rng.random();
        let mut scenario = self.scenarios[point.scenario].clone();
        scenario.seed = turbulence_seed;
        match point.turbulence.as_deref() {
            None => {}
            Some("none") => scenario.wind.turbulence = None,
            Some(intensity) => {
                scenario.wind.turbulence = Some(TurbulenceSpec {
                    intensity: Some(intensity.to_string()),
                    ..TurbulenceSpec::default()
                })
            }
        }
        if point.input_scale != 1.0 {
            scenario.inputs = scenario.inputs.scaled(point.input_scale);
        }
        let recorded =
            crate::linear_flight::record_flight_traced(&scenario, &point.profile, recorder_seed)
                .and_then(|(record, truth, trace)| match &self.derive {
                    Some(derive) if derive.applies_to(&point.recorder) => {
                        aeroid_record::prep::derive::derive(&record, &derive.options())
                            .map(|derived| (derived.record, truth, trace))
                    }
                    _ => Ok((record, truth, trace)),
                });
        let mut histories = match (&recorded, keep) {
            (Ok((record, _, _)), true) => Some(CaseHistories::new(
                case.point,
                case.run,
                self.point_label(case.point),
                record,
                &self.models,
            )),
            _ => None,
        };
        let template = Row {
            point: case.point,
            scenario: scenario.name.clone(),
            profile: point.recorder.clone(),
            turbulence: point.turbulence.clone().unwrap_or_default(),
            input_scale: point.input_scale,
            sample_rate: point.sample_rate,
            noise_scale: point.noise_scale,
            resolution_scale: point.resolution_scale,
            missing: point.missing.join(","),
            channel_rates: channel_rates_text(&point.channel_rates),
            settings: settings_text(&self.setting_variants[point.settings]),
            run: case.run,
            turbulence_seed,
            recorder_seed,
            model: String::new(),
            method: String::new(),
            status: RowStatus::Failed,
            reason: String::new(),
            diagnoses: String::new(),
            parameter: String::new(),
            estimate: f64::NAN,
            standard_error: f64::NAN,
            truth: None,
            error: None,
            inside_95: None,
            correlated_with: String::new(),
            max_correlation: None,
            condition_number: None,
        };
        let mut rows = Vec::new();
        for model in &self.models {
            let outcomes = match &recorded {
                Ok((record, truth, _)) => run::estimate_each(
                    &self.registry,
                    &self.methods,
                    record,
                    truth,
                    model,
                    &[
                        &scenario.methods,
                        &self.settings,
                        &self.setting_variants[point.settings],
                    ],
                ),
                Err(error) => self
                    .methods
                    .iter()
                    .map(|method| (method.clone(), Outcome::Failed(error.to_string())))
                    .collect(),
            };
            if let (Some(histories), Ok((record, _, trace))) = (&mut histories, &recorded) {
                for (_, outcome) in &outcomes {
                    if let Some(estimate) = outcome.estimate() {
                        histories.add(model, estimate, record, trace.as_ref());
                    }
                }
            }
            for (method, outcome) in outcomes {
                let fit = Row {
                    model: model.name().to_string(),
                    method,
                    ..template.clone()
                };
                match outcome {
                    Outcome::Estimated { estimate, scores } => {
                        let (status, reason) = RowStatus::of(&estimate.status);
                        let fit = Row {
                            condition_number: estimate.correlation_condition(),
                            diagnoses: diagnoses_text(&estimate),
                            ..fit
                        };
                        rows.extend(scores.iter().map(|s| {
                            let index = estimate.parameters.iter().position(|p| p.name == s.name);
                            let strongest = index.and_then(|i| estimate.strongest_correlation(i));
                            Row {
                                correlated_with: strongest
                                    .map_or(String::new(), |(name, _)| name.to_string()),
                                max_correlation: strongest.map(|(_, r)| r),
                                ..parameter_row(&fit, status, &reason, s)
                            }
                        }));
                    }
                    Outcome::Refused(refusal) => rows.push(Row {
                        status: RowStatus::Refused,
                        reason: refusal.to_string(),
                        ..fit
                    }),
                    Outcome::Failed(reason) => rows.push(Row { reason, ..fit }),
                }
            }
        }
        (rows, histories)
    }

    /// The index of a case in the study's case order (point by point,
    /// run by run): what shards and journals key cases by.
    pub fn case_index(&self, case: Case) -> usize {
        case.point * self.runs + case.run
    }

    /// Runs every case on `threads` threads (0: one per core), calling
    /// `progress` with each case's rows as it finishes, and summarises
    /// them in case order: the same numbers for any thread count. Nothing
    /// is written; [`Study::run_journaled`] keeps every row.
    pub fn run(&self, threads: usize, progress: &(dyn Fn(&[Row]) + Sync)) -> Result<StudyResult> {
        let cases = self.cases();
        let ordered = std::sync::Mutex::new((0usize, BTreeMap::new(), Summariser::default()));
        self.run_cases(&cases, threads, false, &|position, rows, _| {
            progress(&rows);
            let mut guard = ordered
                .lock()
                .map_err(|_| Error::Other("a study thread panicked".into()))?;
            let (next, pending, summariser) = &mut *guard;
            pending.insert(position, rows);
            while let Some(rows) = pending.remove(next) {
                summariser.add(&rows);
                *next += 1;
            }
            Ok(())
        })?;
        let (_, _, summariser) = ordered
            .into_inner()
            .map_err(|_| Error::Other("a study thread panicked".into()))?;
        Ok(StudyResult::of(
            &self.name,
            self.seed,
            self.runs,
            cases.len(),
            &summariser,
        ))
    }

    /// Runs `cases` on `threads` threads (0: one per core), each thread
    /// taking the next case in order, and hands each case's position in
    /// `cases`, its rows and, when `histories` and the case is a point's
    /// first run, its histories to `finish` as it finishes. The first error
    /// `finish` returns stops the run (cases already running complete).
    pub fn run_cases(
        &self,
        cases: &[Case],
        threads: usize,
        histories: bool,
        finish: &(dyn Fn(usize, Vec<Row>, Option<CaseHistories>) -> Result<()> + Sync),
    ) -> Result<()> {
        use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
        let threads = match threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            n => n,
        }
        .min(cases.len().max(1));
        let next = AtomicUsize::new(0);
        let stop = AtomicBool::new(false);
        let failure = std::sync::Mutex::new(None);
        std::thread::scope(|scope| {
            for _ in 0..threads {
                scope.spawn(|| {
                    while !stop.load(Ordering::Relaxed) {
                        let position = next.fetch_add(1, Ordering::Relaxed);
                        let Some(&case) = cases.get(position) else {
                            break;
                        };
                        let (rows, kept) =
                            self.run_case_with_histories(case, histories && case.run == 0);
                        if let Err(error) = finish(position, rows, kept) {
                            stop.store(true, Ordering::Relaxed);
                            if let Ok(mut first) = failure.lock() {
                                first.get_or_insert(error);
                            }
                        }
                    }
                });
            }
        });
        match failure.into_inner() {
            Ok(None) => Ok(()),
            Ok(Some(error)) => Err(error),
            Err(_) => Err(Error::Other("a study thread panicked".into())),
        }
    }

    /// The cases of `shard` not yet in `finished`.
    pub fn remaining(&self, shard: Shard, finished: &Finished) -> Vec<Case> {
        self.cases()
            .into_iter()
            .filter(|&case| {
                let index = self.case_index(case);
                shard.holds(index) && !finished.contains(&index)
            })
            .collect()
    }

    /// The journal header of this study's `shard`.
    pub fn journal_header(&self, shard: Shard) -> Result<Header> {
        Ok(Header {
            format: journal::FORMAT.into(),
            study: self.name.clone(),
            seed: self.seed,
            runs: self.runs,
            fingerprint: self.fingerprint()?,
            cases: self.cases().len(),
            shard,
        })
    }

    /// A hash (FNV-1a, 64 bits) of everything that decides the study's
    /// numbers: seed, runs, methods and settings, every sweep point's
    /// values on every axis, and the text of every file the study reads (its
    /// scenarios and their aircraft, the profile, the models and their
    /// aircraft) — the same on every machine that has the same files,
    /// wherever they are.
    pub fn fingerprint(&self) -> Result<String> {
        let mut identity = format!(
            "{:?}|{}|{}|{:?}|{:?}",
            self.name, self.seed, self.runs, self.methods, self.settings
        );
        identity += &format!("|{:?}", self.setting_variants);
        for p in &self.points {
            identity += &format!(
                "|{}|{}|{:?}|{:?}|{:?}|{}|{:?}|{}|{}|{}",
                p.scenario,
                p.recorder,
                p.missing,
                p.channel_rates,
                p.turbulence,
                p.input_scale,
                p.sample_rate,
                p.noise_scale,
                p.resolution_scale,
                p.settings
            );
        }
        for scenario in &self.scenarios {
            identity += &read_text(&scenario.path)?;
            identity += &read_text(&scenario.aircraft_path)?;
            if let Some(linear) = &scenario.linear {
                identity += &read_text(&linear.model_path)?;
            }
        }
        for profile in &self.profiles {
            identity += &read_text(&profile.path)?;
        }
        for model in &self.models {
            identity += &model
                .files_json()
                .map_err(|e| Error::Other(format!("model '{}': {e}", model.name())))?;
        }
        let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
        for byte in identity.bytes() {
            hash ^= u64::from(byte);
            hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
        }
        Ok(format!("{hash:016x}"))
    }

    /// Runs the cases of `shard` still missing from the journal in
    /// `folder` (started there, or continued when `resume`), appending
    /// each to it as it finishes.
    pub fn run_journaled(
        &self,
        folder: &Path,
        shard: Shard,
        resume: bool,
        threads: usize,
        progress: &(dyn Fn(&[Row]) + Sync),
    ) -> Result<JournaledRun> {
        let header = self.journal_header(shard)?;
        let (journal, finished) = if resume {
            Journal::resume(folder, &header)?
        } else {
            (Journal::create(folder, &header)?, Finished::new())
        };
        let remaining = self.remaining(shard, &finished);
        self.run_cases(&remaining, threads, true, &|position, rows, histories| {
            if let Some(histories) = histories {
                histories.write(folder)?;
            }
            journal.append(self.case_index(remaining[position]), &rows)?;
            progress(&rows);
            Ok(())
        })?;
        Ok(JournaledRun {
            resumed: finished.len(),
            ran: remaining.len(),
        })
    }
}

/// What a journaled run did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct JournaledRun {
    /// Cases found in the journal when it resumed.
    pub resumed: usize,
    /// Cases run now.
    pub ran: usize,
}

/// The result of a study from the journals in `folders` (one whole
/// study's, or every shard's): `runs.csv` written to `out` case by case in
/// case order, then `summary.csv` and `study.json`. The same bytes
/// whether the cases ran on one machine, in shards, resumed, or on any
/// number of threads; memory independent of the number of cases.
pub fn assemble(folders: &[PathBuf], out: &Path) -> Result<StudyResult> {
    let mut cases = journal::open(folders)?;
    let header = cases.header().clone();
    std::fs::create_dir_all(out).map_err(|e| aeroid_core::error::write_error(out, e))?;
    crate::histories::copy_all(folders, out)?;
    let path = out.join("runs.csv");
    let io_error = |e: csv::Error| aeroid_core::error::write_error(&path, e);
    let mut writer = csv::Writer::from_path(&path).map_err(io_error)?;
    let mut summariser = Summariser::default();
    cases.for_each(|_, rows| {
        for row in &rows {
            writer.serialize(row).map_err(io_error)?;
        }
        summariser.add(&rows);
        Ok(())
    })?;
    writer
        .flush()
        .map_err(|e| aeroid_core::error::write_error(&path, e))?;
    let result = StudyResult::of(
        &header.study,
        header.seed,
        header.runs,
        header.cases,
        &summariser,
    );
    result.write(out)?;
    Ok(result)
}

/// A sweep point's values.
struct Axes<'a> {
    scenario: &'a str,
    /// Empty unless the study sweeps profiles.
    profile: &'a str,
    turbulence: &'a str,
    input_scale: f64,
    sample_rate: Option<f64>,
    noise_scale: f64,
    resolution_scale: f64,
    missing: &'a str,
    channel_rates: &'a str,
    settings: &'a str,
}

fn label(axes: &Axes) -> String {
    let mut text = axes.scenario.to_string();
    if !axes.profile.is_empty() {
        text += &format!(" recorded by {}", axes.profile);
    }
    if !axes.turbulence.is_empty() {
        text += &format!(" turbulence {}", axes.turbulence);
    }
    if axes.input_scale != 1.0 {
        text += &format!(" inputs×{}", axes.input_scale);
    }
    if let Some(rate) = axes.sample_rate {
        text += &format!(" @{} Hz", aeroid_record::rate_text(rate));
    }
    text += &format!(" noise×{}", axes.noise_scale);
    if axes.resolution_scale != 1.0 {
        text += &format!(" lsb×{}", axes.resolution_scale);
    }
    if !axes.missing.is_empty() {
        text += &format!(" without {}", axes.missing);
    }
    if !axes.channel_rates.is_empty() {
        text += &format!(" rates {}", axes.channel_rates);
    }
    if !axes.settings.is_empty() {
        text += &format!(" settings {}", axes.settings);
    }
    text
}

/// A point's channel rates as `channel:rate Hz` comma-separated.
fn channel_rates_text(rates: &[(String, f64)]) -> String {
    rates
        .iter()
        .map(|(channel, rate)| format!("{channel}:{} Hz", aeroid_record::rate_text(*rate)))
        .collect::<Vec<_>>()
        .join(",")
}

/// A settings variant as `method.key=value` comma-separated.
fn settings_text(tables: &MethodTables) -> String {
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

/// The missing-channels axis: `[[]]` (every channel kept) when empty; each
/// entry's channels must be recorded by every profile of the study.
fn missing_axis(
    spec: &[Vec<String>],
    profiles: &[Profile],
    problems: &mut Problems,
) -> Vec<Vec<String>> {
    if spec.is_empty() {
        return vec![Vec::new()];
    }
    for (i, missing) in spec.iter().enumerate() {
        for profile in profiles {
            if let Err(message) = profile.without(missing) {
                problems.push(format!("sweep.missing[{i}]"), message);
            }
        }
    }
    spec.to_vec()
}

/// The per-channel rate axis: `[[]]` when empty; each entry a table of
/// channel → frequency, every channel recorded by every profile.
fn channel_rate_axis(
    spec: &[BTreeMap<String, Quantity>],
    profiles: &[Profile],
    problems: &mut Problems,
) -> Vec<Vec<(String, f64)>> {
    if spec.is_empty() {
        return vec![Vec::new()];
    }
    spec.iter()
        .enumerate()
        .map(|(i, table)| {
            let rates: Vec<(String, f64)> = table
                .iter()
                .filter_map(|(channel, quantity)| {
                    let field = format!("sweep.channel_rate[{i}].{channel}");
                    match parse_rate(quantity) {
                        Ok(rate) if rate > aeroid_core::limits::MAX_RATE => {
                            problems.push(field, aeroid_record::recorder::rate_limit_message(rate))
                        }
                        Ok(rate) if rate > 0.0 && rate.is_finite() => {
                            return Some((channel.clone(), rate));
                        }
                        Ok(rate) => problems.push(field, format!("must be positive, is {rate}")),
                        Err(message) => problems.push(field, message),
                    }
                    None
                })
                .collect();
            for profile in profiles {
                if let Err(message) = profile.with_channel_rates(&rates) {
                    problems.push(format!("sweep.channel_rate[{i}]"), message);
                }
            }
            rates
        })
        .collect()
}

/// The settings axis: `[{}]` when empty; each variant's tables checked as
/// the study's `[methods.NAME]` tables are, problems named
/// `sweep.settings[i].methods.NAME`.
fn settings_axis(
    spec: &[MethodTables],
    registry: &Registry,
    problems: &mut Problems,
) -> Vec<MethodTables> {
    if spec.is_empty() {
        return vec![MethodTables::new()];
    }
    for (i, variant) in spec.iter().enumerate() {
        let mut found = Problems::default();
        registry.check_tables(variant, &mut found);
        for problem in found.0 {
            problems.push(
                format!("sweep.settings[{i}].{}", problem.field),
                problem.message,
            );
        }
    }
    spec.to_vec()
}

/// The study's recorder profiles: its `profile`, or every one of `[sweep]
/// profile` — one of the two, each failure recorded under its field.
fn study_profiles(file: &StudyFile, base: &Path, problems: &mut Problems) -> Option<Vec<Profile>> {
    let load = |reference: &str| Profile::load(reference, Some(base));
    match (&file.profile, file.sweep.profile.is_empty()) {
        (Some(reference), true) => load(reference)
            .map_err(|error| problems.push("profile", error.to_string()))
            .ok()
            .map(|profile| vec![profile]),
        (None, false) => {
            let profiles = load_each("sweep.profile", &file.sweep.profile, problems, load);
            (profiles.len() == file.sweep.profile.len()).then_some(profiles)
        }
        (Some(_), false) => {
            problems.push(
                "sweep.profile",
                "the study names a `profile` too: give one profile, or list several here, not both",
            );
            None
        }
        (None, true) => {
            problems.push(
                "profile",
                "missing: name a recorder profile, or list several under [sweep] profile",
            );
            None
        }
    }
}

/// Loads every reference of a list field, recording each failure under `field[i]`.
fn load_each<T>(
    field: &str,
    references: &[String],
    problems: &mut Problems,
    load: impl Fn(&str) -> Result<T>,
) -> Vec<T> {
    if references.is_empty() {
        problems.push(field, "must name at least one");
    }
    references
        .iter()
        .enumerate()
        .filter_map(|(i, reference)| {
            load(reference)
                .map_err(|error| problems.push(format!("{field}[{i}]"), error.to_string()))
                .ok()
        })
        .collect()
}

fn check_methods(methods: &StudyMethods, registry: &Registry, problems: &mut Problems) {
    let names = methods.names(registry);
    if names.is_empty() {
        problems.push("methods", "must name at least one");
    }
    if let StudyMethods::Names(names) = methods {
        for (i, method) in names.iter().enumerate() {
            if let Err(error) = registry.find(method) {
                problems.push(format!("methods[{i}]"), error.to_string());
            }
        }
    }
}

/// Runs per sweep point within 1..=[`limits::MAX_RUNS`].
fn check_runs(runs: usize) -> Result<(), String> {
    if runs == 0 {
        Err("must be at least 1".into())
    } else if runs > limits::MAX_RUNS {
        Err(format!(
            "{runs} is above the most runs per sweep point, {} (statistics of a thousand runs are within a few percent; a million runs of a one-second fit take eleven days of one core)",
            limits::MAX_RUNS
        ))
    } else {
        Ok(())
    }
}

/// The sample-rate axis in Hz; `[None]` (the profile's rates) when empty.
fn sample_rates(spec: &[Quantity], problems: &mut Problems) -> Vec<Option<f64>> {
    if spec.is_empty() {
        return vec![None];
    }
    spec.iter()
        .enumerate()
        .map(|(i, q)| match parse_rate(q) {
            Ok(rate) if rate > aeroid_core::limits::MAX_RATE => {
                problems.push(
                    format!("sweep.sample_rate[{i}]"),
                    aeroid_record::recorder::rate_limit_message(rate),
                );
                None
            }
            Ok(rate) if rate > 0.0 && rate.is_finite() => Some(rate),
            Ok(rate) => {
                problems.push(
                    format!("sweep.sample_rate[{i}]"),
                    format!("must be positive, is {rate}"),
                );
                None
            }
            Err(message) => {
                problems.push(format!("sweep.sample_rate[{i}]"), message);
                None
            }
        })
        .collect()
}

/// A scale axis `sweep.NAME`; `[1]` when empty. Each value finite and
/// ≥ 0 (> 0 when `positive`).
fn scale_axis(name: &str, spec: &[f64], positive: bool, problems: &mut Problems) -> Vec<f64> {
    if spec.is_empty() {
        return vec![1.0];
    }
    for (i, &scale) in spec.iter().enumerate() {
        let valid = scale.is_finite() && if positive { scale > 0.0 } else { scale >= 0.0 };
        if !valid {
            problems.push(
                format!("sweep.{name}[{i}]"),
                format!(
                    "must be a finite number {} 0, is {scale}",
                    if positive { ">" } else { "≥" }
                ),
            );
        }
    }
    spec.to_vec()
}

/// The turbulence axis; `[None]` (the scenarios' own wind) when empty.
fn turbulence_axis(spec: &[String], problems: &mut Problems) -> Vec<Option<String>> {
    if spec.is_empty() {
        return vec![None];
    }
    for (i, name) in spec.iter().enumerate() {
        if !TURBULENCE.contains(&name.as_str()) {
            problems.push(
                format!("sweep.turbulence[{i}]"),
                format!(
                    "unknown intensity '{name}'; known: {}",
                    TURBULENCE.join(", ")
                ),
            );
        }
    }
    spec.iter().cloned().map(Some).collect()
}

/// The turbulence axis' values.
const TURBULENCE: [&str; 4] = ["none", "light", "moderate", "severe"];

/// An estimate's diagnoses as a row's `diagnoses` column.
fn diagnoses_text(estimate: &Estimate) -> String {
    estimate
        .diagnoses
        .iter()
        .map(|d| d.kind.name())
        .collect::<Vec<_>>()
        .join(" ")
}

fn parameter_row(fit: &Row, status: RowStatus, reason: &str, score: &ParameterScore) -> Row {
    Row {
        status,
        reason: reason.to_string(),
        parameter: score.name.clone(),
        estimate: score.estimate,
        standard_error: score.standard_error,
        truth: score.truth,
        error: score.error,
        inside_95: score.inside_95,
        ..fit.clone()
    }
}

impl StudyResult {
    /// The result of `cases` cases summarised by `summariser`.
    pub fn of(
        study: &str,
        seed: u64,
        runs: usize,
        cases: usize,
        summariser: &Summariser,
    ) -> StudyResult {
        StudyResult {
            study: study.to_string(),
            seed,
            runs,
            cases,
            rows: summariser.rows(),
            summary: summariser.summary(),
            endings: summariser.endings().to_vec(),
        }
    }

    /// Writes `summary.csv` and `study.json` (the result; a non-finite
    /// number is the string "NaN", "inf" or "-inf" there) into `folder`,
    /// creating it.
    pub fn write(&self, folder: &Path) -> Result<()> {
        let io = |path: &Path, e: std::io::Error| aeroid_core::error::write_error(path, e);
        std::fs::create_dir_all(folder).map_err(|e| io(folder, e))?;
        write_csv(&folder.join("summary.csv"), &self.summary)?;
        let path = folder.join("study.json");
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| Error::Other(format!("{}: {e}", path.display())))?;
        std::fs::write(&path, text).map_err(|e| io(&path, e))
    }

    /// The summary as a fixed-width table for the terminal.
    /// Per sweep point, model and method whose fits carried diagnoses, one
    /// line each: how many fits carried which (`kind:count`).
    pub fn diagnosed(&self) -> Vec<String> {
        let mut seen = std::collections::BTreeSet::new();
        self.summary
            .iter()
            .filter(|s| !s.diagnosed.is_empty())
            .filter(|s| seen.insert((s.point, s.model.clone(), s.method.clone())))
            .map(|s| {
                format!(
                    "point {} {} {}: {} of {} fits diagnosed: {}",
                    s.point, s.model, s.method, s.diagnosed_fits, s.runs, s.diagnosed
                )
            })
            .collect()
    }

    pub fn table(&self) -> String {
        // The text columns are as wide as their longest entry, so that long
        // model names keep the numbers in line.
        let width = |header: &str, field: fn(&SummaryRow) -> &str| {
            self.summary
                .iter()
                .map(|s| field(s).chars().count())
                .chain([header.chars().count()])
                .max()
                .unwrap_or(0)
        };
        let model = width("model", |s| &s.model);
        let method = width("meth", |s| &s.method);
        let parameter = width("parameter", |s| &s.parameter);
        let mut text = format!(
            "{:<model$} {:<method$} {:<parameter$} {:>11} {:>11} {:>8} {:>7} {:>7} {:>7} {:>6} {:>9}\n",
            "model",
            "meth",
            "parameter",
            "truth",
            "mean",
            "bias %",
            "bias/σ",
            "b/CRB",
            "σ/CRB",
            "cov95",
            "conv/runs"
        );
        let mut point = usize::MAX;
        for s in &self.summary {
            if s.point != point {
                point = s.point;
                text += &format!(
                    "point {point}: {}\n",
                    label(&Axes {
                        scenario: &s.scenario,
                        profile: &s.profile,
                        turbulence: &s.turbulence,
                        input_scale: s.input_scale,
                        sample_rate: s.sample_rate,
                        noise_scale: s.noise_scale,
                        resolution_scale: s.resolution_scale,
                        missing: &s.missing,
                        channel_rates: &s.channel_rates,
                        settings: &s.settings,
                    })
                );
            }
            text += &format!(
                "{:<model$} {:<method$} {:<parameter$} {:>11.5} {:>11.5} {:>8.2} {:>7.2} {:>7.2} {:>7.2} {:>5.0}% {:>9}\n",
                s.model,
                s.method,
                s.parameter,
                s.truth,
                s.mean,
                100.0 * s.relative_bias,
                s.bias_over_std,
                s.bias_over_crb,
                s.std_over_crb,
                100.0 * s.coverage,
                format!("{}/{}", s.converged, s.runs)
            );
        }
        text
    }
}

fn write_csv<T: Serialize>(path: &Path, rows: &[T]) -> Result<()> {
    let io_error = |e: csv::Error| aeroid_core::error::write_error(path, e);
    let mut writer = csv::Writer::from_path(path).map_err(io_error)?;
    for row in rows {
        writer.serialize(row).map_err(io_error)?;
    }
    writer
        .flush()
        .map_err(|e| aeroid_core::error::write_error(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(run: usize, status: RowStatus, estimate: f64, standard_error: f64) -> Row {
        Row {
            point: 0,
            scenario: "s".into(),
            profile: "p".into(),
            turbulence: String::new(),
            input_scale: 1.0,
            sample_rate: None,
            noise_scale: 1.0,
            resolution_scale: 1.0,
            missing: String::new(),
            channel_rates: String::new(),
            settings: String::new(),
            run,
            turbulence_seed: 0,
            recorder_seed: 0,
            model: "m".into(),
            method: "oem".into(),
            status,
            reason: String::new(),
            diagnoses: String::new(),
            parameter: "Cl_p".into(),
            estimate,
            standard_error,
            truth: Some(-0.4),
            error: Some(estimate + 0.4),
            inside_95: Some((estimate + 0.4).abs() <= 1.96 * standard_error),
            correlated_with: String::new(),
            max_correlation: None,
            condition_number: None,
        }
    }

    /// Fits are counted once each, whatever their parameter rows: two
    /// converged fits of two parameters each, one unidentified fit and one
    /// refused (a single row) give 2, 1 and 1, each with its first row.
    #[test]
    fn endings_count_fits_by_status() {
        let mut rows = Vec::new();
        for run in 0..2 {
            rows.push(row(run, RowStatus::Converged, -0.4, 0.01));
            rows.push(Row {
                parameter: "Cl_r".into(),
                ..row(run, RowStatus::Converged, 0.1, 0.01)
            });
        }
        rows.push(Row {
            reason: "Cl_r".into(),
            ..row(2, RowStatus::Unidentified, -0.4, f64::INFINITY)
        });
        rows.push(Row {
            reason: "oem needs channels 'p'".into(),
            parameter: String::new(),
            ..row(3, RowStatus::Refused, f64::NAN, f64::NAN)
        });
        let mut summariser = Summariser::default();
        summariser.add(&rows);
        let result = StudyResult::of("s", 1, 4, 4, &summariser);
        assert_eq!(result.rows, rows.len());
        let endings: Vec<(RowStatus, usize, usize)> = result
            .endings
            .iter()
            .map(|e| (e.status, e.count, e.first.run))
            .collect();
        assert_eq!(
            endings,
            [
                (RowStatus::Converged, 2, 0),
                (RowStatus::Unidentified, 1, 2),
                (RowStatus::Refused, 1, 3)
            ]
        );
    }

    /// Three converged estimates −0.41, −0.40, −0.36 (mean −0.39, bias
    /// +0.01, sample std √(0.0014/2) = 0.0264575), CRBs 0.01, 0.02, 0.03 (mean 0.02, so the
    /// first run's interval misses the truth: coverage 2/3), two of them
    /// diagnosed and counted all the same; a diverged fit (wild value, left
    /// out of the statistics) and a failed one (no parameter row) are
    /// counted, the diverged one's diagnosis too.
    #[test]
    fn summary_statistics_use_converged_fits_and_count_the_rest() {
        let mut rows = vec![
            row(0, RowStatus::Converged, -0.41, 0.001),
            row(1, RowStatus::Converged, -0.40, 0.02),
            row(2, RowStatus::Converged, -0.36, 0.03),
            row(3, RowStatus::Diverged, 99.0, 1.0),
        ];
        rows[1].diagnoses = "coloured_residuals process_noise".into();
        rows[2].diagnoses = "coloured_residuals".into();
        rows[3].diagnoses = "poor_fit".into();
        rows[0].standard_error = 0.01;
        rows[0].inside_95 = Some(false);
        let mut failed = row(4, RowStatus::Failed, f64::NAN, f64::NAN);
        (failed.parameter, failed.truth) = (String::new(), None);
        rows.push(failed);
        let summary = summarise(&rows);
        assert_eq!(summary.len(), 1);
        let s = &summary[0];
        assert_eq!(
            (s.diagnosed.as_str(), s.diagnosed_fits),
            ("coloured_residuals:2 poor_fit:1 process_noise:1", 3)
        );
        assert_eq!(
            (s.runs, s.converged, s.diverged, s.failed, s.iteration_limit),
            (5, 3, 1, 1, 0)
        );
        let std = 0.0007_f64.sqrt();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(s.mean, -0.39) && close(s.bias, 0.01), "{s:?}");
        assert!(close(s.std, std) && close(s.bias_over_std, 0.01 / std));
        assert!(close(s.mean_crb, 0.02) && close(s.std_over_crb, std / 0.02));
        assert!(close(s.bias_over_crb, 0.5) && close(s.relative_bias, 0.025));
        assert!(close(s.bias_standard_error, std / 3f64.sqrt()));
        assert!(close(s.coverage, 2.0 / 3.0));
        // Errors −0.01, 0, +0.04; two of five runs failed to converge.
        assert!(close(s.rmse, (0.0017_f64 / 3.0).sqrt()), "{}", s.rmse);
        assert!(close(s.failure_rate, 0.4) && close(s.refusal_rate, 0.0));
        assert!(close(s.relative_crb, 0.05));
        assert_eq!(s.identifiability, "identifiable");
    }

    /// The verdict: a CRB above the parameter's size, none converged, a
    /// CRB over 20 % or mostly entangled with another parameter.
    #[test]
    fn identifiability_verdicts() {
        use crate::summary::verdict;
        assert_eq!(verdict(10, 0.05, 0.0), "identifiable");
        assert_eq!(verdict(10, 0.3, 0.0), "weak");
        assert_eq!(verdict(10, 0.05, 0.8), "weak");
        assert_eq!(verdict(10, 1.5, 0.0), "not identifiable");
        assert_eq!(verdict(0, f64::NAN, f64::NAN), "not identifiable");
        // Truth 0: the relative CRB is infinite; correlations decide.
        assert_eq!(verdict(10, f64::INFINITY, 0.0), "identifiable");
    }

    /// A model name longer than the header (as a path to a model file is)
    /// widens its column instead of pushing the numbers out of line: the
    /// header and every row have the same width.
    #[test]
    fn table_columns_fit_long_model_names() {
        let mut long = row(0, RowStatus::Converged, -0.41, 0.01);
        long.model = "models/attas-lateral-with-long-name.toml".into();
        let rows = vec![long, row(0, RowStatus::Converged, -0.40, 0.01)];
        let mut summariser = Summariser::default();
        summariser.add(&rows);
        let result = StudyResult::of("s", 0, 1, 1, &summariser);
        let table = result.table();
        let widths: Vec<usize> = table
            .lines()
            .filter(|line| !line.starts_with("point "))
            .map(|line| line.chars().count())
            .collect();
        assert_eq!(widths.len(), 3, "{table}");
        assert!(widths.iter().all(|w| *w == widths[0]), "{table}");
    }

    #[test]
    fn case_streams_are_distinct_per_point_and_run() {
        let stream = |point, run| Case { point, run }.stream();
        assert_eq!(stream(0, 7), 7);
        assert_eq!(stream(1, 0), 1 << 32);
        assert_ne!(stream(1, 0), stream(0, 1));
    }
}
