//! What an estimate's residuals, model or starts show beside its status:
//! a [`Diagnosis`] of a [`DiagnosisKind`], naming what it is about with
//! its measure, and the diagnoses computed from the output fits alone.
//!
//! Process noise is told from coloured sensor noise and from a model
//! error by two signatures of the structured residuals
//! ([`OutputFit::is_structured`]):
//! - they move together across outputs: process noise drives every output
//!   through the dynamics, while sensor noise is independent from sensor to
//!   sensor. The largest cross-correlation over ±`COHERENCE_LAGS` lags is
//!   compared with `COHERENT` standard deviations of the cross-correlation
//!   of two independent first-order processes with the residuals' lag-1
//!   autocorrelations ρ_a, ρ_b, √((1 + ρ_a·ρ_b)/(N·(1 − ρ_a·ρ_b)))
//!   (Bartlett's formula: Box, Jenkins & Reinsel, "Time Series Analysis",
//!   Eq. 11.1.7);
//! - they are as large where the predicted motion is quiet as where it is
//!   not ([`OutputFit::quiet_share`] at least `PROCESS_NOISE_SHARE` on
//!   every structured output): a model error is a function of the motion.
//!
//! The methods built for process noise are filter error (Maine & Iliff
//! 1985; Jategaonkar, "Flight Vehicle System Identification", ch. 5) and
//! the augmented EKF (ch. 7); the diagnosis names them.

use crate::fit_quality::{OutputFit, WHITENESS_LAGS};
use serde::{Deserialize, Serialize};

/// What a diagnosis is about. The names are those of a study's
/// `diagnoses` column and of a gate case's `diagnoses` list.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DiagnosisKind {
    /// Outputs reproduced worse than by their mean (R² < 0) or not at all;
    /// measure: R².
    PoorFit,
    /// Residuals with a structured part beyond [`STRUCTURED_LIMIT`](crate::fit_quality::STRUCTURED_LIMIT) of the
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
    /// Parameters the data do not separate from another unknown (their
    /// estimates' correlation beyond 0.95); measure: the |correlation|.
    Inseparable,
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
            DiagnosisKind::Inseparable => "inseparable",
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
            .map(|(name, measure)| format!("{name} {}", aeroid_record::significant(*measure, 3)))
            .collect();
        write!(f, "{}: {}", self.kind, items.join(", "))?;
        if !self.advice.is_empty() {
            write!(f, " ({})", self.advice)?;
        }
        Ok(())
    }
}

/// The [`OutputFit::quiet_share`] every structured output must reach for
/// its residual to be taken for the response to process noise rather than
/// a model error. Measured on output error's fits (flight-test-25hz): the
/// turbulence flights 0.28–0.75 on every output; the stall flight fitted
/// with a linear model 0.15 on α (its other outputs 0.36–0.73).
pub(crate) const PROCESS_NOISE_SHARE: f64 = 0.25;

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
pub(crate) fn process_noise_signature(structured: &[&OutputFit]) -> Vec<(String, f64)> {
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
pub(crate) const COHERENCE_LAGS: usize = 50;

/// Standard deviations of the sample cross-correlation of two independent
/// series beyond which two outputs' residuals are taken to move together.
pub(crate) const COHERENT: f64 = 4.0;

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
