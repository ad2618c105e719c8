//! How well a fitted model reproduces one output ([`OutputFit`]): the
//! residual RMS, R², Theil's inequality coefficient (Verma & Peyada 2020,
//! Eq. 27), the residuals' whiteness (lag-1 autocorrelation and the share
//! of lags outside the ±1.96/√N band), their structured part and their
//! quiet share. Output error's residual judgement
//! ([`crate::estimate::Estimate::assess_residuals`]) and the
//! diagnoses ([`crate::diagnosis`]) read them.

use serde::{Deserialize, Serialize};

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
