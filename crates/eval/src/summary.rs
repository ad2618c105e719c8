//! A study's statistics, accumulated row by row in case order
//! ([`Summariser`]): memory grows with the number of sweep points, models,
//! methods and parameters, never with the number of cases. Per point,
//! model, method and parameter, over the converged fits: mean, bias,
//! sample standard deviation σ_MC (Welford's update: Welford, "Note on a
//! method for calculating corrected sums of squares and products",
//! Technometrics 4(3), 1962), mean Cramér–Rao bound, coverage; and how
//! every fit ended, each fit counted once whatever its number of
//! parameter rows.

use crate::axis::AxisValues;
use crate::row::{Row, RowStatus, float_text};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Statistics of one parameter at one sweep point for one model and method,
/// over the converged runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SummaryRow {
    pub point: usize,
    pub scenario: String,
    /// The recorder profile (before the sweep's rate, noise and resolution).
    #[serde(default)]
    pub profile: String,
    /// The turbulence intensity; empty for the scenario's own wind.
    pub turbulence: String,
    pub input_scale: f64,
    pub sample_rate: Option<f64>,
    pub noise_scale: f64,
    pub resolution_scale: f64,
    /// Channels left out of the record, comma-separated.
    #[serde(default)]
    pub missing: String,
    /// Channels at their own rate, `channel:rate Hz` comma-separated.
    #[serde(default)]
    pub channel_rates: String,
    /// The settings variant, `method.key=value` comma-separated.
    #[serde(default)]
    pub settings: String,
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
    /// a filter's parameters still moving (the status column of `runs.csv`
    /// says which).
    pub not_converged: usize,
    /// How many fits carried each diagnosis, whatever their status:
    /// `kind:count` space-separated (the diagnoses column of `runs.csv`
    /// says which fits); empty when none did. Converged fits enter the
    /// statistics below with their diagnoses.
    #[serde(default)]
    pub diagnosed: String,
    /// How many fits carried any diagnosis.
    #[serde(default)]
    pub diagnosed_fits: usize,
    pub refused: usize,
    pub failed: usize,
    #[serde(with = "float_text")]
    pub truth: f64,
    #[serde(with = "float_text")]
    pub mean: f64,
    /// mean − truth.
    #[serde(with = "float_text")]
    pub bias: f64,
    /// bias / |truth|.
    #[serde(with = "float_text")]
    pub relative_bias: f64,
    /// Sample standard deviation of the estimates (n − 1), σ_MC.
    #[serde(with = "float_text")]
    pub std: f64,
    /// bias / σ_MC.
    #[serde(with = "float_text")]
    pub bias_over_std: f64,
    /// Standard error of the mean, σ_MC/√n: the bias is significant when
    /// many times larger.
    #[serde(with = "float_text")]
    pub bias_standard_error: f64,
    /// Mean Cramér–Rao standard error of the runs.
    #[serde(with = "float_text")]
    pub mean_crb: f64,
    /// bias / mean CRB.
    #[serde(with = "float_text")]
    pub bias_over_crb: f64,
    /// σ_MC / mean CRB: 1 when the bounds are honest.
    #[serde(with = "float_text")]
    pub std_over_crb: f64,
    /// Share of runs whose 95 % interval (±1.96 CRB) holds the truth.
    #[serde(with = "float_text")]
    pub coverage: f64,
    /// √(mean (estimate − truth)²).
    #[serde(with = "float_text")]
    pub rmse: f64,
    /// Share of the runs whose fit did not converge (refusals aside).
    #[serde(with = "float_text")]
    pub failure_rate: f64,
    /// Share of the runs whose estimator refused the record.
    #[serde(with = "float_text")]
    pub refusal_rate: f64,
    /// Mean CRB / |truth|.
    #[serde(with = "float_text")]
    pub relative_crb: f64,
    /// Share of converged fits in which this parameter's correlation with
    /// another exceeds 0.9 in magnitude, and the other parameter (the
    /// first such fit's).
    #[serde(with = "float_text")]
    pub correlated_share: f64,
    pub correlated_with: String,
    /// Mean log₁₀ of the fits' correlation-matrix condition number.
    #[serde(with = "float_text")]
    pub condition_log10: f64,
    /// `identifiable`, `weak` or `not identifiable` ([`verdict`]).
    pub identifiability: String,
}

/// |correlation| above which two parameters are reported as entangled.
pub(crate) const CORRELATED: f64 = 0.9;

/// The identifiability of a parameter from its summary: `not identifiable`
/// when no fit converged or its Cramér–Rao bound exceeds its size
/// (relative CRB > 1); `weak` when the bound is over 20 % of its size or it
/// is correlated beyond 0.9 with another parameter in most fits; else
/// `identifiable`. A parameter whose truth is 0 is judged by its
/// correlations alone.
pub fn verdict(converged: usize, relative_crb: f64, correlated_share: f64) -> &'static str {
    if converged == 0 || relative_crb > 1.0 && relative_crb.is_finite() {
        "not identifiable"
    } else if relative_crb > 0.2 && relative_crb.is_finite() || correlated_share > 0.5 {
        "weak"
    } else {
        "identifiable"
    }
}

/// How many fits ended one way, with the first of them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Ending {
    pub status: RowStatus,
    pub count: usize,
    /// The first row of the first such fit.
    pub first: Row,
}

/// One (point, model, method, parameter) group.
#[derive(Debug, Clone)]
struct Group {
    first: Row,
    /// Converged estimates: count, sum, Welford's mean and M₂.
    n: usize,
    sum: f64,
    running_mean: f64,
    m2: f64,
    crb_sum: f64,
    inside: usize,
    squared_error: f64,
    correlated: usize,
    correlated_with: Option<String>,
    condition_log_sum: f64,
    conditions: usize,
}

type FitKey = (usize, String, String);

/// Rows in, statistics out (module header).
#[derive(Debug, Clone, Default)]
pub struct Summariser {
    order: Vec<(usize, String, String, String)>,
    groups: HashMap<(usize, String, String, String), Group>,
    /// Per (point, model, method): fits by status.
    fits: HashMap<FitKey, HashMap<RowStatus, usize>>,
    /// Per (point, model, method): fits by diagnosis, and fits with any.
    diagnosed: HashMap<FitKey, (std::collections::BTreeMap<String, usize>, usize)>,
    endings: Vec<Ending>,
    /// The fit the last row belonged to: (point, run, model, method).
    last_fit: Option<(usize, usize, String, String)>,
    rows: usize,
}

impl Summariser {
    /// Adds the rows of one case (cases in case order).
    pub fn add(&mut self, rows: &[Row]) {
        for row in rows {
            self.add_row(row);
        }
    }

    fn add_row(&mut self, row: &Row) {
        self.rows += 1;
        let fit = (row.point, row.run, row.model.clone(), row.method.clone());
        if self.last_fit.as_ref() != Some(&fit) {
            let key = (row.point, row.model.clone(), row.method.clone());
            let (kinds, any) = self.diagnosed.entry(key.clone()).or_default();
            for kind in row.diagnoses.split_whitespace() {
                *kinds.entry(kind.to_string()).or_default() += 1;
            }
            *any += usize::from(!row.diagnoses.is_empty());
            *self
                .fits
                .entry(key)
                .or_default()
                .entry(row.status)
                .or_default() += 1;
            match self.endings.iter_mut().find(|e| e.status == row.status) {
                Some(ending) => ending.count += 1,
                None => self.endings.push(Ending {
                    status: row.status,
                    count: 1,
                    first: row.clone(),
                }),
            }
            self.last_fit = Some(fit);
        }
        if row.truth.is_none() {
            return;
        }
        let key = (
            row.point,
            row.model.clone(),
            row.method.clone(),
            row.parameter.clone(),
        );
        let group = self.groups.entry(key.clone()).or_insert_with(|| {
            self.order.push(key);
            Group {
                first: row.clone(),
                n: 0,
                sum: 0.0,
                running_mean: 0.0,
                m2: 0.0,
                crb_sum: 0.0,
                inside: 0,
                squared_error: 0.0,
                correlated: 0,
                correlated_with: None,
                condition_log_sum: 0.0,
                conditions: 0,
            }
        });
        if row.status == RowStatus::Converged {
            group.n += 1;
            group.sum += row.estimate;
            let delta = row.estimate - group.running_mean;
            group.running_mean += delta / group.n as f64;
            group.m2 += delta * (row.estimate - group.running_mean);
            group.crb_sum += row.standard_error;
            group.inside += usize::from(row.inside_95 == Some(true));
            if let Some(truth) = row.truth {
                group.squared_error += (row.estimate - truth).powi(2);
            }
            if row.max_correlation.is_some_and(|r| r > CORRELATED) {
                group.correlated += 1;
                group
                    .correlated_with
                    .get_or_insert_with(|| row.correlated_with.clone());
            }
            if let Some(condition) = row.condition_number.filter(|c| c.is_finite()) {
                group.condition_log_sum += condition.log10();
                group.conditions += 1;
            }
        }
    }

    /// The number of rows added.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// How the fits ended, in the order each status first appeared.
    pub fn endings(&self) -> &[Ending] {
        &self.endings
    }

    /// The summary rows, groups in the order they first appeared.
    pub fn summary(&self) -> Vec<SummaryRow> {
        self.order.iter().map(|key| self.summary_row(key)).collect()
    }

    /// The fits of (point, model, method) by status.
    fn fit_counts(&self, key: &FitKey) -> HashMap<RowStatus, usize> {
        self.fits.get(key).cloned().unwrap_or_default()
    }

    /// How many fits of (point, model, method) carried each diagnosis
    /// (`kind:count` space-separated) and any.
    fn diagnosed_text(&self, key: &FitKey) -> (String, usize) {
        self.diagnosed
            .get(key)
            .map(|(counts, any)| {
                let text = counts
                    .iter()
                    .map(|(kind, n)| format!("{kind}:{n}"))
                    .collect::<Vec<_>>()
                    .join(" ");
                (text, *any)
            })
            .unwrap_or_default()
    }

    /// The statistics of one (point, model, method, parameter) group, its
    /// axis columns from the group's first row.
    fn summary_row(&self, key: &(usize, String, String, String)) -> SummaryRow {
        let group = &self.groups[key];
        let fit_key = (key.0, key.1.clone(), key.2.clone());
        let fits = self.fit_counts(&fit_key);
        let count = |status: RowStatus| fits.get(&status).copied().unwrap_or(0);
        let (diagnosed, diagnosed_fits) = self.diagnosed_text(&fit_key);
        let n = group.n as f64;
        let mean = group.sum / n;
        let std = (group.m2 / (n - 1.0)).sqrt();
        let mean_crb = group.crb_sum / n;
        let truth = group.first.truth.unwrap_or(f64::NAN);
        let bias = mean - truth;
        let runs: usize = fits.values().sum();
        let relative_crb = mean_crb / truth.abs();
        let correlated_share = group.correlated as f64 / n;
        let AxisValues {
            scenario,
            profile,
            turbulence,
            input_scale,
            sample_rate,
            noise_scale,
            resolution_scale,
            missing,
            channel_rates,
            settings,
        } = group.first.axes();
        SummaryRow {
            point: key.0,
            scenario,
            profile,
            turbulence,
            input_scale,
            sample_rate,
            noise_scale,
            resolution_scale,
            missing,
            channel_rates,
            settings,
            model: key.1.clone(),
            method: key.2.clone(),
            parameter: key.3.clone(),
            runs,
            converged: count(RowStatus::Converged),
            iteration_limit: count(RowStatus::IterationLimit),
            diverged: count(RowStatus::Diverged),
            not_converged: fits
                .iter()
                .filter(|(status, _)| status.is_not_converged())
                .map(|(_, n)| n)
                .sum(),
            diagnosed,
            diagnosed_fits,
            refused: count(RowStatus::Refused),
            failed: count(RowStatus::Failed),
            truth,
            mean,
            bias,
            relative_bias: bias / truth.abs(),
            std,
            bias_over_std: bias / std,
            bias_standard_error: std / n.sqrt(),
            mean_crb,
            bias_over_crb: bias / mean_crb,
            std_over_crb: std / mean_crb,
            coverage: group.inside as f64 / n,
            rmse: (group.squared_error / n).sqrt(),
            failure_rate: (runs - count(RowStatus::Converged) - count(RowStatus::Refused)) as f64
                / runs as f64,
            refusal_rate: count(RowStatus::Refused) as f64 / runs as f64,
            relative_crb,
            correlated_share,
            correlated_with: group.correlated_with.clone().unwrap_or_default(),
            condition_log10: group.condition_log_sum / group.conditions as f64,
            identifiability: verdict(group.n, relative_crb, correlated_share).into(),
        }
    }
}

impl SummaryRow {
    /// The row's sweep-point values.
    pub fn axes(&self) -> AxisValues {
        AxisValues {
            scenario: self.scenario.clone(),
            profile: self.profile.clone(),
            turbulence: self.turbulence.clone(),
            input_scale: self.input_scale,
            sample_rate: self.sample_rate,
            noise_scale: self.noise_scale,
            resolution_scale: self.resolution_scale,
            missing: self.missing.clone(),
            channel_rates: self.channel_rates.clone(),
            settings: self.settings.clone(),
        }
    }
}

/// The summary of `rows` (in case order).
pub fn summarise(rows: &[Row]) -> Vec<SummaryRow> {
    let mut summariser = Summariser::default();
    summariser.add(rows);
    summariser.summary()
}
