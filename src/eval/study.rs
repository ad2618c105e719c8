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
//! profile = "flight-test-25hz"              # recorder profile
//! models = ["attas-lateral"]                # model structures fitted to every record
//! methods = ["oem", "ee"]                   # ee, swr, oem (as `aeroid run`)
//! runs = 100                                # runs per sweep point
//! seed = 4                                  # study seed
//! [sweep]                                   # optional axes; each defaults to the profile as it is
//! sample_rate = ["10 Hz", "25 Hz"]          # every channel of the profile at this rate
//! noise_scale = [0.5, 1.0, 2.0]             # every channel's noise σ times this
//! ```
//!
//! Sweep points are the product scenario × sample rate × noise scale, in
//! that order (the last varies fastest). A case is one run at one point; it
//! is keyed by the stream `point·2³² + run` of the study seed (one
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

use crate::catalog;
use crate::error::{Error, Problems, Result, parse_toml, read_text};
use crate::estimation::estimate::Status;
use crate::estimation::estimator::{MethodTables, check_method_tables, validate_method_tables};
use crate::estimation::methods;
use crate::estimation::structure::ModelStructure;
use crate::eval::run::{self, Outcome};
use crate::eval::score::ParameterScore;
use crate::limits;
use crate::random;
use crate::record::recorder::{Profile, parse_rate, record_scenario_seeded};
use crate::sim::scenario::Scenario;
use crate::units::Quantity;
use rand::RngExt;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Status of a row whose fit converged; only these enter the statistics.
pub const CONVERGED: &str = "converged";
/// Status of a row whose recording or estimate could not be made at all.
pub const FAILED: &str = "failed";
/// Status of a row whose estimator refused the record (a missing channel, …).
pub const REFUSED: &str = "refused";

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub scenarios: Vec<String>,
    pub profile: String,
    pub models: Vec<String>,
    pub methods: StudyMethods,
    pub runs: usize,
    pub seed: u64,
    #[serde(default)]
    pub sweep: SweepSpec,
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
    /// The method names, in the order they run.
    pub fn names(&self) -> Vec<String> {
        match self {
            StudyMethods::Names(names) => names.clone(),
            StudyMethods::Tables(tables) => methods::names()
                .into_iter()
                .filter(|name| tables.contains_key(name))
                .chain(
                    tables
                        .keys()
                        .filter(|name| methods::find(name).is_err())
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
    #[serde(default)]
    pub sample_rate: Vec<Quantity>,
    #[serde(default)]
    pub noise_scale: Vec<f64>,
}

/// One point of the sweep grid: a scenario and the profile modified for it.
#[derive(Debug, Clone)]
pub struct SweepPoint {
    /// Index into [`Study::scenarios`].
    pub scenario: usize,
    /// Every channel's rate (Hz), or None for the profile's own rates.
    pub sample_rate: Option<f64>,
    pub noise_scale: f64,
    pub profile: Profile,
}

/// A validated study, its files loaded.
#[derive(Debug, Clone)]
pub struct Study {
    pub name: String,
    pub description: String,
    pub path: PathBuf,
    pub scenarios: Vec<Scenario>,
    pub profile: Profile,
    pub models: Vec<ModelStructure>,
    pub methods: Vec<String>,
    /// The study's settings per method, overriding the models' and the scenarios'.
    pub settings: MethodTables,
    /// Runs per sweep point.
    pub runs: usize,
    pub seed: u64,
    pub points: Vec<SweepPoint>,
}

/// One run at one sweep point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Case {
    pub point: usize,
    pub run: usize,
}

impl Case {
    /// The case's stream of the study seed: `point·2³² + run`.
    pub fn stream(self) -> u64 {
        ((self.point as u64) << 32) | self.run as u64
    }
}

/// One parameter of one fit of one case (or the fit's failure): a plain row.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    pub point: usize,
    pub scenario: String,
    /// Every channel's rate (Hz); empty for the profile's own.
    pub sample_rate: Option<f64>,
    pub noise_scale: f64,
    pub run: usize,
    pub turbulence_seed: u64,
    pub recorder_seed: u64,
    pub model: String,
    pub method: String,
    /// `converged`, `iteration_limit`, `diverged`, `no_progress`,
    /// `unidentified`, `degenerate`, `poor_fit`, `refused` or `failed`.
    pub status: String,
    pub reason: String,
    /// Empty when the fit failed.
    pub parameter: String,
    pub estimate: f64,
    /// Cramér–Rao standard error of the estimate.
    pub standard_error: f64,
    /// None for unknowns without a truth (initial states, output biases).
    pub truth: Option<f64>,
    pub error: Option<f64>,
    pub inside_95: Option<bool>,
}

/// Statistics of one parameter at one sweep point for one model and method,
/// over the converged runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SummaryRow {
    pub point: usize,
    pub scenario: String,
    pub sample_rate: Option<f64>,
    pub noise_scale: f64,
    pub model: String,
    pub method: String,
    pub parameter: String,
    /// Cases run at this point, and how each fit ended.
    pub runs: usize,
    pub converged: usize,
    pub iteration_limit: usize,
    pub diverged: usize,
    /// Estimates that are not converged for another reason: no progress
    /// from the start, unidentified parameters, a degenerate covariance or
    /// a poor fit (the status column of `runs.csv` says which).
    pub not_converged: usize,
    pub refused: usize,
    pub failed: usize,
    pub truth: f64,
    pub mean: f64,
    /// mean − truth.
    pub bias: f64,
    /// bias / |truth|.
    pub relative_bias: f64,
    /// Sample standard deviation of the estimates (n − 1), σ_MC.
    pub std: f64,
    /// bias / σ_MC.
    pub bias_over_std: f64,
    /// Standard error of the mean, σ_MC/√n: the bias is significant when
    /// many times larger.
    pub bias_standard_error: f64,
    /// Mean Cramér–Rao standard error of the runs.
    pub mean_crb: f64,
    /// bias / mean CRB.
    pub bias_over_crb: f64,
    /// σ_MC / mean CRB: 1 when the bounds are honest.
    pub std_over_crb: f64,
    /// Share of runs whose 95 % interval (±1.96 CRB) holds the truth.
    pub coverage: f64,
}

/// What a study produced.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StudyResult {
    pub study: String,
    pub seed: u64,
    pub runs: usize,
    pub summary: Vec<SummaryRow>,
    pub rows: Vec<Row>,
}

impl Study {
    /// Loads a study by bundled name (`studies/NAME.toml`) or path.
    pub fn load(reference: &str) -> Result<Study> {
        let path = catalog::resolve(reference, catalog::STUDY_FOLDER, None)?;
        let file: StudyFile = parse_toml(&path, &read_text(&path)?)?;
        Study::from_file(&file, &path)
    }

    /// Validates a parsed study and loads the files it names, reporting every
    /// problem at once under its field.
    pub fn from_file(file: &StudyFile, path: &Path) -> Result<Study> {
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
            validate_method_tables(&scenario.methods, &scenario.path)?;
            Ok(scenario)
        });
        let models = load_each("models", &file.models, &mut problems, |r| {
            ModelStructure::load(&resolved(r, catalog::MODEL_FOLDER)?)
        });
        let profile = Profile::load(&file.profile, Some(base))
            .map_err(|error| problems.push("profile", error.to_string()))
            .ok();
        check_methods(&file.methods, &mut problems);
        check_method_tables(&file.methods.tables(), &mut problems);
        if let Err(message) = check_runs(file.runs) {
            problems.push("runs", message);
        }
        let rates = sample_rates(&file.sweep.sample_rate, &mut problems);
        let scales = noise_scales(&file.sweep.noise_scale, &mut problems);
        let (Some(profile), true) = (profile, problems.is_empty()) else {
            return Err(Error::Invalid {
                path: path.to_path_buf(),
                problems: problems.0,
            });
        };
        let mut points = Vec::new();
        for scenario in 0..scenarios.len() {
            for &sample_rate in &rates {
                let rated = sample_rate.map_or_else(|| profile.clone(), |r| profile.with_rate(r));
                for &noise_scale in &scales {
                    points.push(SweepPoint {
                        scenario,
                        sample_rate,
                        noise_scale,
                        profile: if noise_scale == 1.0 {
                            rated.clone()
                        } else {
                            rated.with_noise_scaled(noise_scale)
                        },
                    });
                }
            }
        }
        let study = Study {
            name: file.name.clone(),
            description: file.description.clone(),
            path: path.to_path_buf(),
            scenarios,
            profile,
            models,
            methods: file.methods.names(),
            settings: file.methods.tables(),
            runs: file.runs,
            seed: file.seed,
            points,
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
            problems: vec![crate::error::Problem {
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

    /// A short label of a sweep point: scenario, rate and noise scale.
    pub fn point_label(&self, point: usize) -> String {
        let p = &self.points[point];
        label(
            &self.scenarios[p.scenario].name,
            p.sample_rate,
            p.noise_scale,
        )
    }

    /// Runs one case: draws its seeds, flies and records the scenario, and
    /// fits every model with every method. Never fails: a failure is a row.
    pub fn run_case(&self, case: Case) -> Vec<Row> {
        let point = &self.points[case.point];
        let mut rng = random::stream(self.seed, case.stream());
        let turbulence_seed: u64 = rng.random();
        let recorder_seed: u64 = rng.random();
        let mut scenario = self.scenarios[point.scenario].clone();
        scenario.seed = turbulence_seed;
        let recorded = record_scenario_seeded(&scenario, &point.profile, recorder_seed);
        let template = Row {
            point: case.point,
            scenario: scenario.name.clone(),
            sample_rate: point.sample_rate,
            noise_scale: point.noise_scale,
            run: case.run,
            turbulence_seed,
            recorder_seed,
            model: String::new(),
            method: String::new(),
            status: FAILED.into(),
            reason: String::new(),
            parameter: String::new(),
            estimate: f64::NAN,
            standard_error: f64::NAN,
            truth: None,
            error: None,
            inside_95: None,
        };
        let mut rows = Vec::new();
        for model in &self.models {
            let outcomes = match &recorded {
                Ok((record, truth)) => run::estimate_each(
                    &self.methods,
                    record,
                    truth,
                    model,
                    &[&scenario.methods, &self.settings],
                ),
                Err(error) => self
                    .methods
                    .iter()
                    .map(|method| (method.clone(), Outcome::Failed(error.to_string())))
                    .collect(),
            };
            for (method, outcome) in outcomes {
                let fit = Row {
                    model: model.name.clone(),
                    method,
                    ..template.clone()
                };
                match outcome {
                    Outcome::Estimated { estimate, scores } => {
                        let (status, reason) = status_text(&estimate.status);
                        rows.extend(
                            scores
                                .iter()
                                .map(|s| parameter_row(&fit, status, &reason, s)),
                        );
                    }
                    Outcome::Refused(refusal) => rows.push(Row {
                        status: REFUSED.into(),
                        reason: refusal.to_string(),
                        ..fit
                    }),
                    Outcome::Failed(reason) => rows.push(Row { reason, ..fit }),
                }
            }
        }
        rows
    }

    /// Runs every case on `threads` threads (0: one per core), calling
    /// `progress` after each case, and summarises. The rows are in case
    /// order and bit-identical for any thread count.
    pub fn run(&self, threads: usize, progress: &(dyn Fn() + Sync)) -> Result<StudyResult> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| Error::Other(format!("cannot start {threads} threads: {e}")))?;
        let cases = self.cases();
        let rows: Vec<Row> = pool.install(|| {
            cases
                .par_iter()
                .flat_map_iter(|&case| {
                    let rows = self.run_case(case);
                    progress();
                    rows
                })
                .collect()
        });
        Ok(StudyResult {
            study: self.name.clone(),
            seed: self.seed,
            runs: self.runs,
            summary: summarise(&rows),
            rows,
        })
    }
}

fn label(scenario: &str, sample_rate: Option<f64>, noise_scale: f64) -> String {
    let rate = sample_rate.map_or(String::new(), |r| format!(" @{r} Hz"));
    format!("{scenario}{rate} noise×{noise_scale}")
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

fn check_methods(methods: &StudyMethods, problems: &mut Problems) {
    let names = methods.names();
    if names.is_empty() {
        problems.push("methods", "must name at least one");
    }
    if let StudyMethods::Names(names) = methods {
        for (i, method) in names.iter().enumerate() {
            if let Err(error) = methods::find(method) {
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
            Ok(rate) if rate > crate::limits::MAX_RATE => {
                problems.push(
                    format!("sweep.sample_rate[{i}]"),
                    crate::record::recorder::rate_limit_message(rate),
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

/// The noise-scale axis; `[1]` when empty.
fn noise_scales(spec: &[f64], problems: &mut Problems) -> Vec<f64> {
    if spec.is_empty() {
        return vec![1.0];
    }
    for (i, &scale) in spec.iter().enumerate() {
        if !(scale.is_finite() && scale >= 0.0) {
            problems.push(
                format!("sweep.noise_scale[{i}]"),
                format!("must be a finite number ≥ 0, is {scale}"),
            );
        }
    }
    spec.to_vec()
}

fn status_text(status: &Status) -> (&'static str, String) {
    match status {
        Status::Converged => (CONVERGED, String::new()),
        Status::IterationLimit => ("iteration_limit", String::new()),
        Status::Diverged(reason) => ("diverged", reason.clone()),
        Status::NoProgress => ("no_progress", String::new()),
        Status::Unidentified(names) => ("unidentified", names.join(" ")),
        Status::Degenerate(reason) => ("degenerate", reason.clone()),
        Status::PoorFit(outputs) => ("poor_fit", outputs.join(" ")),
        Status::Unsettled(reason) => ("unsettled", reason.clone()),
    }
}

fn parameter_row(fit: &Row, status: &str, reason: &str, score: &ParameterScore) -> Row {
    Row {
        status: status.to_string(),
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

/// Per sweep point, model, method and parameter with a truth: the
/// statistics of the converged fits, in the order the rows first name them.
/// Shards' rows concatenated summarise like one study's.
pub fn summarise(rows: &[Row]) -> Vec<SummaryRow> {
    // How each (point, model, method) fit ended, once per run.
    let mut endings: HashMap<(usize, &str, &str), HashMap<usize, &str>> = HashMap::new();
    let mut order: Vec<(usize, &str, &str, &str)> = Vec::new();
    let mut groups: HashMap<(usize, &str, &str, &str), Vec<&Row>> = HashMap::new();
    for row in rows {
        endings
            .entry((row.point, &row.model, &row.method))
            .or_default()
            .insert(row.run, &row.status);
        if row.truth.is_none() {
            continue;
        }
        let key = (row.point, &*row.model, &*row.method, &*row.parameter);
        groups
            .entry(key)
            .or_insert_with(|| {
                order.push(key);
                Vec::new()
            })
            .push(row);
    }
    order
        .iter()
        .map(|key| {
            let group = &groups[key];
            let ending = &endings[&(key.0, key.1, key.2)];
            let count = |status: &str| ending.values().filter(|&&s| s == status).count();
            statistics(
                group,
                SummaryRow {
                    point: key.0,
                    scenario: group[0].scenario.clone(),
                    sample_rate: group[0].sample_rate,
                    noise_scale: group[0].noise_scale,
                    model: key.1.to_string(),
                    method: key.2.to_string(),
                    parameter: key.3.to_string(),
                    runs: ending.len(),
                    converged: count(CONVERGED),
                    iteration_limit: count("iteration_limit"),
                    diverged: count("diverged"),
                    not_converged: ["no_progress", "unidentified", "degenerate", "poor_fit"]
                        .iter()
                        .map(|status| count(status))
                        .sum(),
                    refused: count(REFUSED),
                    failed: count(FAILED),
                    truth: group[0].truth.unwrap_or(f64::NAN),
                    mean: f64::NAN,
                    bias: f64::NAN,
                    relative_bias: f64::NAN,
                    std: f64::NAN,
                    bias_over_std: f64::NAN,
                    bias_standard_error: f64::NAN,
                    mean_crb: f64::NAN,
                    bias_over_crb: f64::NAN,
                    std_over_crb: f64::NAN,
                    coverage: f64::NAN,
                },
            )
        })
        .collect()
}

/// Fills the statistics of `summary` from the converged rows of `group`.
fn statistics(group: &[&Row], summary: SummaryRow) -> SummaryRow {
    let used: Vec<&Row> = group
        .iter()
        .copied()
        .filter(|r| r.status == CONVERGED)
        .collect();
    let n = used.len() as f64;
    let mean_of = |f: &dyn Fn(&Row) -> f64| used.iter().map(|r| f(r)).sum::<f64>() / n;
    let mean = mean_of(&|r| r.estimate);
    let variance = used
        .iter()
        .map(|r| (r.estimate - mean).powi(2))
        .sum::<f64>()
        / (n - 1.0);
    let std = variance.sqrt();
    let mean_crb = mean_of(&|r| r.standard_error);
    let truth = summary.truth;
    let bias = mean - truth;
    SummaryRow {
        mean,
        bias,
        relative_bias: bias / truth.abs(),
        std,
        bias_over_std: bias / std,
        bias_standard_error: std / n.sqrt(),
        mean_crb,
        bias_over_crb: bias / mean_crb,
        std_over_crb: std / mean_crb,
        coverage: mean_of(&|r| f64::from(u8::from(r.inside_95 == Some(true)))),
        ..summary
    }
}

impl StudyResult {
    /// How the fits ended: per status, the number of fits (one per case,
    /// model and method) and the first such fit's row, in status order of
    /// first appearance.
    pub fn endings(&self) -> Vec<(String, usize, &Row)> {
        let mut seen = std::collections::HashSet::new();
        let mut endings: Vec<(String, usize, &Row)> = Vec::new();
        for row in &self.rows {
            if !seen.insert((row.point, row.run, &row.model, &row.method)) {
                continue;
            }
            match endings
                .iter_mut()
                .find(|(status, _, _)| *status == row.status)
            {
                Some((_, count, _)) => *count += 1,
                None => endings.push((row.status.clone(), 1, row)),
            }
        }
        endings
    }

    /// Writes `runs.csv` (every row), `summary.csv` and `study.json` (the
    /// summary and rows; a NaN is null there) into `folder`, creating it.
    pub fn write(&self, folder: &Path) -> Result<()> {
        let io = |path: &Path, e: std::io::Error| crate::error::write_error(path, e);
        std::fs::create_dir_all(folder).map_err(|e| io(folder, e))?;
        write_csv(&folder.join("runs.csv"), &self.rows)?;
        write_csv(&folder.join("summary.csv"), &self.summary)?;
        let path = folder.join("study.json");
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| Error::Other(format!("{}: {e}", path.display())))?;
        std::fs::write(&path, text).map_err(|e| io(&path, e))
    }

    /// The summary as a fixed-width table for the terminal.
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
                    label(&s.scenario, s.sample_rate, s.noise_scale)
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
    let io_error = |e: csv::Error| crate::error::write_error(path, e);
    let mut writer = csv::Writer::from_path(path).map_err(io_error)?;
    for row in rows {
        writer.serialize(row).map_err(io_error)?;
    }
    writer
        .flush()
        .map_err(|e| crate::error::write_error(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(run: usize, status: &str, estimate: f64, standard_error: f64) -> Row {
        Row {
            point: 0,
            scenario: "s".into(),
            sample_rate: None,
            noise_scale: 1.0,
            run,
            turbulence_seed: 0,
            recorder_seed: 0,
            model: "m".into(),
            method: "oem".into(),
            status: status.into(),
            reason: String::new(),
            parameter: "Cl_p".into(),
            estimate,
            standard_error,
            truth: Some(-0.4),
            error: Some(estimate + 0.4),
            inside_95: Some((estimate + 0.4).abs() <= 1.96 * standard_error),
        }
    }

    /// Fits are counted once each, whatever their parameter rows: two
    /// converged fits of two parameters each, one unidentified fit and one
    /// refused (a single row) give 2, 1 and 1, each with its first row.
    #[test]
    fn endings_count_fits_by_status() {
        let mut rows = Vec::new();
        for run in 0..2 {
            rows.push(row(run, CONVERGED, -0.4, 0.01));
            rows.push(Row {
                parameter: "Cl_r".into(),
                ..row(run, CONVERGED, 0.1, 0.01)
            });
        }
        rows.push(Row {
            reason: "Cl_r".into(),
            ..row(2, "unidentified", -0.4, f64::INFINITY)
        });
        rows.push(Row {
            reason: "oem needs channels 'p'".into(),
            parameter: String::new(),
            ..row(3, REFUSED, f64::NAN, f64::NAN)
        });
        let result = StudyResult {
            study: "s".into(),
            seed: 1,
            runs: 4,
            summary: summarise(&rows),
            rows,
        };
        let endings: Vec<(String, usize, usize)> = result
            .endings()
            .into_iter()
            .map(|(status, count, first)| (status, count, first.run))
            .collect();
        assert_eq!(
            endings,
            [
                (CONVERGED.to_string(), 2, 0),
                ("unidentified".to_string(), 1, 2),
                (REFUSED.to_string(), 1, 3)
            ]
        );
    }

    /// Three converged estimates −0.41, −0.40, −0.36 (mean −0.39, bias
    /// +0.01, sample std √(0.0014/2) = 0.0264575), CRBs 0.01, 0.02, 0.03 (mean 0.02, so the
    /// first run's interval misses the truth: coverage 2/3); a diverged fit
    /// (wild value, left out of the statistics) and a failed one (no
    /// parameter row) are counted.
    #[test]
    fn summary_statistics_use_converged_fits_and_count_the_rest() {
        let mut rows = vec![
            row(0, CONVERGED, -0.41, 0.001),
            row(1, CONVERGED, -0.40, 0.02),
            row(2, CONVERGED, -0.36, 0.03),
            row(3, "diverged", 99.0, 1.0),
        ];
        rows[0].standard_error = 0.01;
        rows[0].inside_95 = Some(false);
        let mut failed = row(4, FAILED, f64::NAN, f64::NAN);
        (failed.parameter, failed.truth) = (String::new(), None);
        rows.push(failed);
        let summary = summarise(&rows);
        assert_eq!(summary.len(), 1);
        let s = &summary[0];
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
    }

    /// A model name longer than the header (as a path to a model file is)
    /// widens its column instead of pushing the numbers out of line: the
    /// header and every row have the same width.
    #[test]
    fn table_columns_fit_long_model_names() {
        let mut long = row(0, CONVERGED, -0.41, 0.01);
        long.model = "models/attas-lateral-with-long-name.toml".into();
        let rows = vec![long, row(0, CONVERGED, -0.40, 0.01)];
        let result = StudyResult {
            study: "s".into(),
            seed: 0,
            runs: 1,
            summary: summarise(&rows),
            rows,
        };
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
