//! What an estimator returns: values with Cramér–Rao standard errors, the
//! covariance and correlation matrices, fit metrics per output (residual RMS,
//! R², Theil's inequality coefficient, Verma & Peyada 2020, Eq. 27, the
//! residuals' whiteness), the iteration and
//! cost history, wall time and a status. Serialises to JSON and CSV.
//!
//! The status says how the fit ended, and nothing else
//! ([`Estimate::assess`]): "converged" when its method stopped at an
//! optimum, every estimated parameter has a finite standard error (a
//! singular information matrix leaves the parameters of its null space
//! with infinite ones) and the covariance is finite. Otherwise it says what
//! it is: the iteration limit, no progress short of a minimum, a diverging
//! model, unidentified parameters by name, a degenerate covariance, a
//! recursive estimate still moving.
//!
//! Beside the status, an estimate carries its diagnoses ([`Diagnosis`]):
//! what its residuals, its model or its starts show, each with its
//! measure — an output reproduced worse than by its mean, residuals with a
//! structured part (coloured residuals, [`Estimate::assess_residuals`]),
//! process noise suspected, input timing suspected, an unstable model,
//! innovations inconsistent with their covariance. Process noise is told
//! from coloured sensor noise and from a model error by two signatures of
//! the structured residuals: they move together across outputs (the
//! cross-correlation against Bartlett's bound for independent first-order
//! processes: Box, Jenkins & Reinsel, "Time Series Analysis", Eq. 11.1.7),
//! and they are as large where the predicted motion is quiet as where it
//! is not ([`OutputFit::quiet_share`]). A fit at the optimum of
//! real flight data is converged with its diagnoses: a diagnosis never
//! takes a fit out of a study's statistics or a gate's check, and both
//! count every diagnosis, so that neither a label nor its absence hides a
//! bias.

use crate::error::{Error, Result};
use crate::estimation::solver::gauss_newton::Solution;
use nalgebra::DVector;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// How an estimation ended.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "status", content = "reason")]
pub enum Status {
    /// Stopped at an optimum, every parameter determined.
    Converged,
    /// The iteration limit came first.
    IterationLimit,
    /// The model could not be evaluated (a departing simulation, a NaN).
    Diverged(String),
    /// No step lowers the cost while the Gauss–Newton step still predicts
    /// a decrease beyond the convergence tolerance (from the start, or after
    /// some iterations: the fit stalled short of a minimum).
    NoProgress,
    /// These parameters have a non-finite standard error: the data do not
    /// determine them.
    Unidentified(Vec<String>),
    /// The covariance is missing or not finite though every standard error is.
    Degenerate(String),
    /// A recursive estimator's parameter estimates had not settled by the
    /// end of the record: the reason.
    Unsettled(String),
}

impl Status {
    /// Only a converged estimate counts as a success in scores, gates and studies.
    pub fn is_success(&self) -> bool {
        matches!(self, Status::Converged)
    }
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Status::Converged => f.write_str("converged"),
            Status::IterationLimit => f.write_str("iteration limit"),
            Status::Diverged(reason) => write!(f, "diverged: {reason}"),
            Status::NoProgress => {
                f.write_str("no progress: no step lowers the cost short of the minimum")
            }
            Status::Unidentified(names) => write!(f, "unidentified: {}", names.join(", ")),
            Status::Degenerate(reason) => write!(f, "degenerate: {reason}"),
            Status::Unsettled(reason) => write!(f, "not settled: {reason}"),
        }
    }
}

/// What a diagnosis is about. The names are those of a study's
/// `diagnoses` column and of a gate case's `diagnoses` list.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DiagnosisKind {
    /// Outputs reproduced worse than by their mean (R² < 0) or not at all;
    /// measure: R².
    PoorFit,
    /// Residuals with a structured part beyond [`STRUCTURED_LIMIT`] of the
    /// output's variation (a structure lacking a term, a wrong minimum,
    /// process noise, real flight data's small model errors); measure: the
    /// structured residual ([`OutputFit::structured`]).
    ColouredResiduals,
    /// Residuals with the signature of state noise: structured, yet
    /// unexplained by the model's own sensitivities; measure: the share of
    /// the structured residual they leave unexplained.
    ProcessNoise,
    /// The recorded inputs' timing between samples is suspected; measure:
    /// the share of an input's changes that are ramps.
    InputTiming,
    /// The fitted model is unstable; measure: the time to double (s) of
    /// its fastest growing mode.
    Unstable,
    /// A recursive filter's innovations disagree with their predicted
    /// covariance; measure: mean ν²/S per output.
    InconsistentInnovations,
    /// Estimates from several starts disagree beyond their bounds; measure:
    /// the largest difference in σ.
    StartsDisagree,
}

impl DiagnosisKind {
    /// The name used in files and tables.
    pub fn name(self) -> &'static str {
        match self {
            DiagnosisKind::PoorFit => "poor_fit",
            DiagnosisKind::ColouredResiduals => "coloured_residuals",
            DiagnosisKind::ProcessNoise => "process_noise",
            DiagnosisKind::InputTiming => "input_timing",
            DiagnosisKind::Unstable => "unstable",
            DiagnosisKind::InconsistentInnovations => "inconsistent_innovations",
            DiagnosisKind::StartsDisagree => "starts_disagree",
        }
    }
}

impl std::fmt::Display for DiagnosisKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// One thing an estimate's residuals, model or starts show, beside its
/// status: what it is about (outputs, parameters or modes), its measure
/// for each, and what it means for the user.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Diagnosis {
    pub kind: DiagnosisKind,
    /// The outputs, parameters or modes concerned.
    pub about: Vec<String>,
    /// The measure for each of `about` (its meaning: [`DiagnosisKind`]).
    pub measures: Vec<f64>,
    /// What it means and which method is built for it.
    pub advice: String,
}

impl std::fmt::Display for Diagnosis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let items: Vec<String> = self
            .about
            .iter()
            .zip(&self.measures)
            .map(|(name, measure)| format!("{name} {}", crate::record::significant(*measure, 3)))
            .collect();
        write!(f, "{}: {}", self.kind, items.join(", "))?;
        if !self.advice.is_empty() {
            write!(f, " ({})", self.advice)?;
        }
        Ok(())
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParameterEstimate {
    pub name: String,
    pub value: f64,
    /// Cramér–Rao standard error (corrected for coloured residuals where the method allows).
    pub standard_error: f64,
    pub start: f64,
}

/// Lags 1..=WHITENESS_LAGS of the residuals' normalised autocorrelation
/// enter [`OutputFit::outside_band`].
pub const WHITENESS_LAGS: usize = 20;

/// How well the fitted model reproduces one output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OutputFit {
    pub channel: String,
    pub samples: usize,
    pub rms: f64,
    pub r_squared: f64,
    /// Theil's inequality coefficient (Verma & Peyada 2020, Eq. 27): 0 perfect, 1 worst.
    pub theil: f64,
    /// Lag-1 autocorrelation of the residuals, Σ e_k·e_(k+1) / Σ e_k²
    /// (about the residuals' zero, so that an offset counts as correlated):
    /// within ±1.96/√N for white residuals, near 1 for a systematic error
    /// that varies slowly against the sample period. NaN below
    /// 2·[`WHITENESS_LAGS`] samples.
    #[serde(default = "not_computed")]
    pub lag_one: f64,
    /// Fraction of the residuals' normalised autocorrelation (mean
    /// removed) at lags 1..=[`WHITENESS_LAGS`] outside ±1.96/√N: about 0.05
    /// for white residuals, near 1 for structured ones. NaN below
    /// 2·[`WHITENESS_LAGS`] samples.
    #[serde(default = "not_computed")]
    pub outside_band: f64,
    /// The structured residual: √(max(ρ₁, 0)·Σe²/Σ(z − z̄)²), ρ₁ =
    /// [`Self::lag_one`]. The residual's part that is correlated from one
    /// sample to the next, as a fraction of the output's variation about its
    /// mean. White noise leaves ρ₁ ≈ 0, so sensor noise does not count,
    /// however large; a model error that varies slowly against the sample
    /// period counts in full. NaN where the output is constant or too
    /// short.
    #[serde(default = "not_computed")]
    pub structured: f64,
    /// The share of the residuals' energy in the quieter half of the
    /// output's predicted motion (the samples where the prediction lies
    /// nearest its median): about ½ when the residual does not grow with
    /// the motion the model predicts (sensor noise, or the response to
    /// process noise, which the inputs do not drive), well below ½ when
    /// it does (a model error, which is a function of the motion). NaN
    /// where the output is too short.
    #[serde(default = "not_computed")]
    pub quiet_share: f64,
    /// The residuals themselves, in sample order (dropouts left out), for
    /// the diagnoses that compare outputs; not written to files.
    #[serde(skip)]
    pub residuals: Vec<f64>,
}

fn not_computed() -> f64 {
    f64::NAN
}

/// √N·ρ₁ beyond which the residuals are taken to be correlated: white
/// residuals exceed it with probability 3e-5 (ρ₁ of N white samples is
/// about normal with standard deviation 1/√N).
pub const CORRELATED_LAG_ONE: f64 = 4.0;

/// The structured residual ([`OutputFit::structured`]) beyond which a
/// correlated output is poorly fitted. Measured on output error's fits
/// (flight-test-25hz, docs/findings.md, "Fit quality"): every matched fit
/// of the accuracy gates and of the stall variants stays at or below
/// 0.025 (CDRW's q and nz, correlated by the input steps' timing at
/// 25 Hz, reach 0.022); a linear model of the stall flight gives 0.47–0.95,
/// the stall model without hysteresis 0.25–0.37, without the one-sided
/// hysteresis 0.10–0.11, a fit in a wrong minimum 0.36–0.38, output error
/// in moderate turbulence 0.23–0.79.
pub const STRUCTURED_LIMIT: f64 = 0.05;

/// The [`OutputFit::quiet_share`] every structured output must reach for
/// its residual to be taken for the response to process noise rather than
/// a model error. Measured on output error's fits (flight-test-25hz): the
/// turbulence flights 0.28–0.75 on every output; the stall flight fitted
/// with a linear model 0.15 on α (its other outputs 0.36–0.73).
pub const PROCESS_NOISE_SHARE: f64 = 0.25;

impl OutputFit {
    /// Fit metrics of `predicted` against `measured` (dropouts skipped;
    /// the autocorrelations run over the remaining samples in order).
    pub fn new(channel: &str, measured: &[f64], predicted: &[f64]) -> OutputFit {
        let pairs: Vec<(f64, f64)> = measured
            .iter()
            .zip(predicted)
            .map(|(&z, &y)| (z, y))
            .filter(|(z, y)| z.is_finite() && y.is_finite())
            .collect();
        let n = pairs.len().max(1) as f64;
        let mean = pairs.iter().map(|(z, _)| z).sum::<f64>() / n;
        let residual_square: f64 = pairs.iter().map(|(z, y)| (z - y).powi(2)).sum();
        let total_square: f64 = pairs.iter().map(|(z, _)| (z - mean).powi(2)).sum();
        let rms = (residual_square / n).sqrt();
        let measured_rms = (pairs.iter().map(|(z, _)| z * z).sum::<f64>() / n).sqrt();
        let predicted_rms = (pairs.iter().map(|(_, y)| y * y).sum::<f64>() / n).sqrt();
        let residuals: Vec<f64> = pairs.iter().map(|(z, y)| z - y).collect();
        let (lag_one, outside_band) = whiteness(&residuals);
        let predicted: Vec<f64> = pairs.iter().map(|(_, y)| *y).collect();
        OutputFit {
            channel: channel.to_string(),
            samples: pairs.len(),
            rms,
            r_squared: if total_square > 0.0 {
                1.0 - residual_square / total_square
            } else {
                f64::NAN
            },
            theil: rms / (measured_rms + predicted_rms),
            lag_one,
            outside_band,
            structured: if total_square > 0.0 {
                (lag_one.max(0.0) * residual_square / total_square).sqrt()
            } else {
                f64::NAN
            },
            quiet_share: quiet_share(&residuals, &predicted),
            residuals,
        }
    }
}

/// The outputs whose structured residuals carry the signature of process
/// noise, with their quiet shares; empty when the signature is absent.
/// The signature (module documentation): at least two structured outputs;
/// every structured output's residual as large where its predicted motion
/// is quiet as where it is not ([`OutputFit::quiet_share`] at least
/// [`PROCESS_NOISE_SHARE`]: a model error is a function of the motion and
/// leaves at least one output below it); and each named output's residual
/// correlated with another structured output's at a lag within
/// ±[`COHERENCE_LAGS`] beyond what two independent coloured series give
/// ([`coherent`]): process noise drives every output through the
/// dynamics, while coloured sensor noise is independent from sensor to
/// sensor.
fn process_noise_signature(structured: &[&OutputFit]) -> Vec<(String, f64)> {
    let quiet = structured
        .iter()
        .all(|f| f.quiet_share >= PROCESS_NOISE_SHARE);
    if structured.len() < 2 || !quiet {
        return Vec::new();
    }
    (0..structured.len())
        .filter(|&i| {
            (0..structured.len()).any(|j| j != i && coherent(structured[i], structured[j]))
        })
        .map(|i| (structured[i].channel.clone(), structured[i].quiet_share))
        .collect()
}

/// Lags (samples, either way) over which two outputs' residuals are compared.
pub const COHERENCE_LAGS: usize = 50;

/// Standard deviations of the sample cross-correlation of two independent
/// series beyond which two outputs' residuals are taken to move together.
pub const COHERENT: f64 = 4.0;

/// Whether two outputs' residuals (sampled alike) are correlated beyond
/// chance: the largest |cross-correlation| over lags within
/// ±[`COHERENCE_LAGS`] against [`COHERENT`] times its standard deviation
/// for two independent first-order processes with the residuals' lag-1
/// autocorrelations ρ_a, ρ_b, √((1 + ρ_a·ρ_b) / (N·(1 − ρ_a·ρ_b)))
/// (Bartlett's formula: Box, Jenkins & Reinsel, "Time Series Analysis",
/// Eq. 11.1.7).
fn coherent(a: &OutputFit, b: &OutputFit) -> bool {
    let (x, y) = (&a.residuals, &b.residuals);
    if x.len() != y.len() || x.len() < 2 * WHITENESS_LAGS {
        return false;
    }
    let product = (a.lag_one * b.lag_one).clamp(0.0, 0.999);
    let sigma = ((1.0 + product) / (x.len() as f64 * (1.0 - product))).sqrt();
    largest_cross_correlation(x, y) > COHERENT * sigma
}

/// max over lags |k| ≤ [`COHERENCE_LAGS`] of |Σ a_t·b_(t+k)| / √(Σa²·Σb²).
fn largest_cross_correlation(a: &[f64], b: &[f64]) -> f64 {
    let norm = (a.iter().map(|x| x * x).sum::<f64>() * b.iter().map(|x| x * x).sum::<f64>()).sqrt();
    if norm == 0.0 {
        return 0.0;
    }
    let at = |lag: usize, first: &[f64], second: &[f64]| {
        first
            .iter()
            .zip(&second[lag.min(second.len())..])
            .map(|(x, y)| x * y)
            .sum::<f64>()
    };
    (0..=COHERENCE_LAGS)
        .flat_map(|lag| [at(lag, a, b), at(lag, b, a)])
        .map(|c| c.abs() / norm)
        .fold(0.0, f64::max)
}

/// [`OutputFit::quiet_share`]: the residuals' energy over the half of the
/// samples whose prediction lies nearest the prediction's median, as a
/// share of all their energy; NaN below 2·[`WHITENESS_LAGS`] samples or
/// for residuals that are all zero.
fn quiet_share(residuals: &[f64], predicted: &[f64]) -> f64 {
    let n = residuals.len();
    let energy: f64 = residuals.iter().map(|e| e * e).sum();
    if n < 2 * WHITENESS_LAGS || energy == 0.0 {
        return f64::NAN;
    }
    let mut sorted = predicted.to_vec();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[n / 2];
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| {
        (predicted[a] - median)
            .abs()
            .total_cmp(&(predicted[b] - median).abs())
    });
    order[..n / 2]
        .iter()
        .map(|&k| residuals[k] * residuals[k])
        .sum::<f64>()
        / energy
}

impl OutputFit {
    /// Whether the residuals are correlated from one sample to the next
    /// beyond what white residuals give (√N·ρ₁ > [`CORRELATED_LAG_ONE`]).
    pub fn correlated(&self) -> bool {
        (self.samples as f64).sqrt() * self.lag_one > CORRELATED_LAG_ONE
    }

    /// Whether the residuals hold a structured part the model does not
    /// reproduce: correlated, and structured beyond [`STRUCTURED_LIMIT`]
    /// of the output's variation.
    pub fn is_structured(&self) -> bool {
        self.correlated() && self.structured > STRUCTURED_LIMIT
    }

    /// The whiteness figures as text: ρ₁, the fraction outside the band,
    /// the structured residual.
    pub fn whiteness_text(&self) -> String {
        format!(
            "{}: ρ₁ {:.2}, {:.0} % of lags 1–{WHITENESS_LAGS} outside ±1.96/√N, structured {:.3}",
            self.channel,
            self.lag_one,
            100.0 * self.outside_band,
            self.structured
        )
    }
}

/// The residuals' lag-1 autocorrelation about zero and the fraction of
/// their normalised autocorrelation (mean removed) at lags
/// 1..=[`WHITENESS_LAGS`] outside ±1.96/√N; NaN for fewer than
/// 2·WHITENESS_LAGS residuals. Residuals that are all zero are white.
fn whiteness(residuals: &[f64]) -> (f64, f64) {
    let n = residuals.len();
    if n < 2 * WHITENESS_LAGS {
        return (f64::NAN, f64::NAN);
    }
    let power: f64 = residuals.iter().map(|e| e * e).sum();
    if power == 0.0 {
        return (0.0, 0.0);
    }
    let lag_one = residuals.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / power;
    let mean = residuals.iter().sum::<f64>() / n as f64;
    let centred: Vec<f64> = residuals.iter().map(|e| e - mean).collect();
    let variance: f64 = centred.iter().map(|e| e * e).sum();
    if variance == 0.0 {
        return (lag_one, 0.0);
    }
    let band = 1.96 / (n as f64).sqrt();
    let outside = (1..=WHITENESS_LAGS)
        .filter(|&lag| {
            let r = centred
                .iter()
                .zip(&centred[lag..])
                .map(|(a, b)| a * b)
                .sum::<f64>()
                / variance;
            r.abs() > band
        })
        .count();
    (lag_one, outside as f64 / WHITENESS_LAGS as f64)
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    pub method: String,
    pub model: String,
    pub record: String,
    pub status: Status,
    /// What the residuals, the model or the starts show, beside the status.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub diagnoses: Vec<Diagnosis>,
    pub parameters: Vec<ParameterEstimate>,
    /// Covariance of the estimates (rows/columns in `parameters` order).
    pub covariance: Vec<Vec<f64>>,
    pub fits: Vec<OutputFit>,
    pub iterations: usize,
    pub cost_history: Vec<f64>,
    pub wall_time: f64,
    /// Anything the user should know (a channel held constant, an unidentifiable parameter).
    pub notes: Vec<String>,
    /// The method's own report, as text (stepwise regression: each
    /// coefficient's search); empty when the method has none.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub details: String,
    /// The network a neural method trained: its size, seed, MSE and R².
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub network: Option<crate::estimation::neural::NetworkReport>,
    /// Per parameter, the distribution of its local values over the
    /// record, for methods that estimate a derivative at every sample
    /// (the Delta method); empty otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub distributions: Vec<ParameterDistribution>,
    /// Histories the method estimated along the record (the smoothed
    /// coefficients of estimation before modelling); empty otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub histories: Vec<History>,
}

/// A quantity a method estimated at every point of a grid along the
/// record: its values and, where the method gives them, their standard
/// deviations.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct History {
    pub name: String,
    /// Times (s) of the values.
    pub times: Vec<f64>,
    pub values: Vec<f64>,
    /// Standard deviation of each value; empty when the method gives none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sigma: Vec<f64>,
}

/// The spread of a parameter estimated at every sample of a record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParameterDistribution {
    pub name: String,
    pub samples: usize,
    pub mean: f64,
    pub standard_deviation: f64,
    /// The 5th, 50th and 95th percentiles.
    pub p05: f64,
    pub median: f64,
    pub p95: f64,
    /// The value at the trim point (the record's first sample or the
    /// method's stated reference condition).
    pub at_trim: f64,
}

/// The covariance of uncorrelated estimates with these standard errors:
/// diag(σ²), as the rows of [`Estimate::covariance`].
pub fn diagonal_covariance(standard_errors: &[f64]) -> Vec<Vec<f64>> {
    let n = standard_errors.len();
    (0..n)
        .map(|i| {
            let mut row = vec![0.0; n];
            row[i] = standard_errors[i].powi(2);
            row
        })
        .collect()
}

impl Estimate {
    /// The estimate of a Gauss–Newton solution: values with Cramér–Rao
    /// standard errors (√ of the covariance diagonal), the covariance, the
    /// iterations and cost history. Fits, wall time and notes are the caller's.
    pub fn from_solution(
        (method, model, record): (&str, String, String),
        names: &[String],
        start: &DVector<f64>,
        solution: &Solution,
    ) -> Estimate {
        let covariance = solution.covariance();
        Estimate {
            method: method.to_string(),
            model,
            record,
            diagnoses: Vec::new(),
            status: solution.status.clone(),
            parameters: (0..names.len())
                .map(|j| ParameterEstimate {
                    name: names[j].clone(),
                    value: solution.theta[j],
                    standard_error: covariance[(j, j)].sqrt(),
                    start: start[j],
                })
                .collect(),
            covariance: (0..covariance.nrows())
                .map(|i| covariance.row(i).iter().copied().collect())
                .collect(),
            fits: Vec::new(),
            iterations: solution.history.len(),
            cost_history: solution.history.iter().map(|i| i.cost).collect(),
            wall_time: 0.0,
            notes: Vec::new(),
            details: String::new(),
            network: None,
            distributions: Vec::new(),
            histories: Vec::new(),
        }
    }

    /// The estimate with its status judged honestly and its fits
    /// diagnosed (module documentation): a converged status becomes
    /// unidentified or degenerate where the bounds say so; an output
    /// reproduced worse than by its mean is a [`DiagnosisKind::PoorFit`],
    /// whatever the status.
    pub fn assess(mut self) -> Estimate {
        let poor: Vec<&OutputFit> = self
            .fits
            .iter()
            .filter(|fit| fit.r_squared.is_nan() || fit.r_squared < 0.0 || !fit.rms.is_finite())
            .collect();
        if !poor.is_empty() {
            let diagnosis = Diagnosis {
                kind: DiagnosisKind::PoorFit,
                about: poor.iter().map(|f| f.channel.clone()).collect(),
                measures: poor.iter().map(|f| f.r_squared).collect(),
                advice: "reproduced worse than by the output's mean (R² < 0): the model \
                         structure or the fit's minimum is wrong for these outputs"
                    .into(),
            };
            self.diagnose(diagnosis);
        }
        if self.status != Status::Converged {
            return self;
        }
        let unidentified: Vec<String> = self
            .parameters
            .iter()
            .filter(|p| !p.standard_error.is_finite())
            .map(|p| p.name.clone())
            .collect();
        self.status = if !unidentified.is_empty() {
            Status::Unidentified(unidentified)
        } else if let Some(reason) = self.degenerate() {
            Status::Degenerate(reason)
        } else {
            Status::Converged
        };
        if self.status != Status::Converged {
            self.notes.push(format!(
                "not converged: {} (model '{}')",
                self.status, self.model
            ));
        }
        self
    }

    /// [`Self::assess`], then the residuals diagnosed as a method whose
    /// residuals should be white diagnoses them (output error with sensor
    /// noise: the model reproduces everything but the noise). Outputs
    /// whose residuals are structured ([`OutputFit::is_structured`]) are
    /// [`DiagnosisKind::ColouredResiduals`], measured by their structured
    /// part; residuals correlated but structured below
    /// [`STRUCTURED_LIMIT`] get a note. The status is left as it is.
    pub fn assess_residuals(self) -> Estimate {
        let mut estimate = self.assess();
        let structured: Vec<&OutputFit> =
            estimate.fits.iter().filter(|f| f.is_structured()).collect();
        let correlated: Vec<&OutputFit> = estimate
            .fits
            .iter()
            .filter(|f| f.correlated() && !f.is_structured())
            .collect();
        if !correlated.is_empty() {
            let text = correlated
                .iter()
                .map(|f| f.whiteness_text())
                .collect::<Vec<_>>()
                .join("; ");
            estimate.notes.push(format!(
                "residuals correlated but their structured part below {STRUCTURED_LIMIT} of the output's variation (a small model error, input timing or coloured noise): {text}"
            ));
        }
        if !structured.is_empty() {
            let diagnosis = Diagnosis {
                kind: DiagnosisKind::ColouredResiduals,
                about: structured.iter().map(|f| f.channel.clone()).collect(),
                measures: structured.iter().map(|f| f.structured).collect(),
                advice: format!(
                    "structured residual beyond {STRUCTURED_LIMIT} of the output's variation: \
                     a structure lacking a term, a wrong minimum, process noise the method \
                     does not model, or the small model errors of real flight data; the \
                     bounds assume white residuals"
                ),
            };
            let noisy = process_noise_signature(&structured);
            estimate.diagnose(diagnosis);
            if !noisy.is_empty() {
                estimate.diagnose(Diagnosis {
                    kind: DiagnosisKind::ProcessNoise,
                    about: noisy.iter().map(|(c, _)| c.clone()).collect(),
                    measures: noisy.iter().map(|(_, share)| *share).collect(),
                    advice: "the structured residuals of these outputs move together, and are \
                             as large where the predicted motion is quiet as where it is not: \
                             the response to process noise (turbulence), which output error \
                             does not model; filter error (fem) and the augmented EKF are \
                             built for it (measure: the quiet share)"
                        .into(),
                });
            }
        }
        estimate
    }

    /// Adds a diagnosis (replacing one of the same kind).
    pub fn diagnose(&mut self, diagnosis: Diagnosis) {
        self.diagnoses.retain(|d| d.kind != diagnosis.kind);
        self.diagnoses.push(diagnosis);
    }

    /// The diagnosis of this kind, if the estimate carries one.
    pub fn diagnosis(&self, kind: DiagnosisKind) -> Option<&Diagnosis> {
        self.diagnoses.iter().find(|d| d.kind == kind)
    }

    /// Why the covariance cannot be used, if it cannot: missing, or
    /// holding non-finite entries although every standard error is finite.
    /// (A singular information matrix shows as infinite standard errors of
    /// the parameters in its null space: unidentified, above. A covariance
    /// corrected for coloured residuals need not be positive definite where
    /// the residuals are rounding noise, as on noise-free data, so
    /// definiteness is not asked of it.)
    fn degenerate(&self) -> Option<String> {
        if self.covariance.is_empty() {
            return (!self.parameters.is_empty()).then(|| "no covariance was computed".to_string());
        }
        let square = self
            .covariance
            .iter()
            .all(|row| row.len() == self.covariance.len());
        if !square || self.covariance.len() != self.parameters.len() {
            return Some("the covariance does not match the parameters".into());
        }
        self.covariance
            .iter()
            .flatten()
            .any(|v| !v.is_finite())
            .then(|| "the covariance holds non-finite entries".to_string())
    }

    pub fn parameter(&self, name: &str) -> Option<&ParameterEstimate> {
        self.parameters.iter().find(|p| p.name == name)
    }

    /// Correlation matrix from the covariance.
    pub fn correlation(&self) -> Vec<Vec<f64>> {
        let c = &self.covariance;
        (0..c.len())
            .map(|i| {
                (0..c.len())
                    .map(|j| c[i][j] / (c[i][i] * c[j][j]).sqrt())
                    .collect()
            })
            .collect()
    }

    /// The parameter most correlated with parameter `index` and
    /// |correlation|; None without a finite covariance.
    pub fn strongest_correlation(&self, index: usize) -> Option<(&str, f64)> {
        let correlation = self.correlation();
        let row = correlation.get(index)?;
        row.iter()
            .enumerate()
            .filter(|&(j, r)| j != index && r.is_finite())
            .map(|(j, r)| {
                (
                    self.parameters.get(j).map_or("", |p| p.name.as_str()),
                    r.abs(),
                )
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The condition number of the correlation matrix (the information
    /// matrix with every parameter scaled to unit variance): how close the
    /// parameters are to being inseparable, independent of their units.
    /// None without a finite covariance.
    pub fn correlation_condition(&self) -> Option<f64> {
        let correlation = self.correlation();
        let n = correlation.len();
        if n == 0 || correlation.iter().flatten().any(|r| !r.is_finite()) {
            return None;
        }
        let matrix = nalgebra::DMatrix::from_fn(n, n, |i, j| correlation[i][j]);
        let eigenvalues = matrix.symmetric_eigenvalues();
        let largest = eigenvalues.max();
        let smallest = eigenvalues.min();
        (smallest > 0.0)
            .then(|| largest / smallest)
            .or(Some(f64::INFINITY))
    }

    pub fn write_json(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| Error::Other(format!("{}: {e}", path.display())))?;
        std::fs::write(path, text).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })
    }

    pub fn read_json(path: &Path) -> Result<Estimate> {
        let text = crate::error::read_text(path)?;
        serde_json::from_str(&text).map_err(|e| Error::Other(format!("{}: {e}", path.display())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A converged two-parameter estimate with the given covariance and
    /// one output fit of R² `r_squared`.
    fn estimate(covariance: [[f64; 2]; 2], r_squared: f64) -> Estimate {
        Estimate {
            method: "test".into(),
            model: "m".into(),
            record: "r".into(),
            status: Status::Converged,
            diagnoses: Vec::new(),
            parameters: ["a", "b"]
                .iter()
                .enumerate()
                .map(|(i, name)| ParameterEstimate {
                    name: name.to_string(),
                    value: 1.0,
                    standard_error: covariance[i][i].sqrt(),
                    start: 0.0,
                })
                .collect(),
            covariance: covariance.iter().map(|row| row.to_vec()).collect(),
            fits: vec![OutputFit {
                channel: "nz".into(),
                samples: 100,
                rms: 0.1,
                r_squared,
                theil: 0.1,
                lag_one: 0.0,
                outside_band: 0.05,
                structured: 0.0,
                quiet_share: f64::NAN,
                residuals: Vec::new(),
            }],
            iterations: 3,
            cost_history: vec![3.0, 2.0, 1.0],
            wall_time: 0.0,
            notes: Vec::new(),
            details: String::new(),
            network: None,
            distributions: Vec::new(),
            histories: Vec::new(),
        }
    }

    /// Each way an estimate is not converged, built on purpose: an infinite
    /// σ names the parameter; finite σ with a NaN covariance entry is
    /// degenerate. R² < 0 and a NaN R² leave the status converged with a
    /// poor-fit diagnosis naming the output. A sound estimate stays
    /// converged without diagnoses, and a status that is already not
    /// converged is kept (its poor fit diagnosed all the same).
    #[test]
    fn assessment_says_what_an_estimate_is() {
        let sound = estimate([[1.0, 0.5], [0.5, 1.0]], 0.9);
        assert_eq!(sound.assess().status, Status::Converged);

        let infinite = estimate([[1.0, 0.0], [0.0, f64::INFINITY]], 0.9);
        let assessed = infinite.assess();
        assert_eq!(assessed.status, Status::Unidentified(vec!["b".into()]));
        assert!(assessed.notes.iter().any(|n| n.contains("unidentified: b")));

        let degenerate = estimate([[1.0, f64::NAN], [f64::NAN, 1.0]], 0.9);
        assert!(matches!(degenerate.assess().status, Status::Degenerate(_)));

        let sound = estimate([[1.0, 0.5], [0.5, 1.0]], 0.9).assess();
        assert!(sound.diagnoses.is_empty());

        for r_squared in [-0.3, f64::NAN] {
            let poor = estimate([[1.0, 0.0], [0.0, 1.0]], r_squared).assess();
            assert_eq!(poor.status, Status::Converged);
            let diagnosis = poor.diagnosis(DiagnosisKind::PoorFit).unwrap();
            assert_eq!(diagnosis.about, vec!["nz".to_string()]);
            assert_eq!(diagnosis.measures.len(), 1);
        }

        let mut limited = estimate([[1.0, 0.0], [0.0, f64::INFINITY]], -0.3);
        limited.status = Status::IterationLimit;
        let limited = limited.assess();
        assert_eq!(limited.status, Status::IterationLimit);
        assert!(limited.diagnosis(DiagnosisKind::PoorFit).is_some());
        assert!(!Status::IterationLimit.is_success());
    }
}
