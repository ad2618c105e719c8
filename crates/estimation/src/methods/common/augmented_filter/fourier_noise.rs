//! R from the measurements by Fourier decomposition (Klein & Morelli 2006, §11.2, optimal Fourier smoothing; the module documentation's "Noise", 1).

use super::*;

/// The measurement-noise variance of a channel's samples by Fourier
/// decomposition (module header, Noise 1): the mean power of the spectrum
/// above `bandwidth` (Hz), at least the upper quarter of the band. Dropouts
/// are bridged linearly. NaN for fewer than 16 samples.
pub(crate) fn fourier_noise_variance(values: &[f64], rate: f64, bandwidth: f64) -> f64 {
    let x = bridged(values);
    let n = x.len();
    if n < 16 {
        return f64::NAN;
    }
    // Detrend by the line through the end points.
    let (first, last) = (x[0], x[n - 1]);
    let x: Vec<f64> = (0..n)
        .map(|i| x[i] - first - (last - first) * i as f64 / (n - 1) as f64)
        .collect();
    let total: f64 = n as f64 * x.iter().map(|v| v * v).sum::<f64>();
    let half = n / 2;
    let highest = (bandwidth * n as f64 / rate).floor() as usize;
    let motion = highest.min(3 * half / 4);
    // |X_0|² + 2·Σ_{k=1..K} |X_k|²: the bins at ±f_k below the bandwidth.
    let mut low = 0.0;
    for k in 0..=motion {
        let angle = -2.0 * std::f64::consts::PI * k as f64 / n as f64;
        let (sin, cos) = angle.sin_cos();
        let (mut re, mut im) = (0.0, 0.0);
        let (mut wr, mut wi) = (1.0, 0.0);
        for &v in &x {
            re += v * wr;
            im += v * wi;
            (wr, wi) = (wr * cos - wi * sin, wr * sin + wi * cos);
        }
        low += if k == 0 { 1.0 } else { 2.0 } * (re * re + im * im);
    }
    let bins = n - (2 * motion + 1);
    ((total - low) / (n as f64 * bins as f64)).max(0.0)
}

/// The values with NaN (dropouts) replaced by linear interpolation between
/// the finite neighbours (the nearest one at the ends); leading and
/// trailing NaN are dropped.
pub(super) fn bridged(values: &[f64]) -> Vec<f64> {
    let finite: Vec<usize> = (0..values.len())
        .filter(|&i| values[i].is_finite())
        .collect();
    let (Some(&first), Some(&last)) = (finite.first(), finite.last()) else {
        return Vec::new();
    };
    let mut out = values[first..=last].to_vec();
    for pair in finite.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        for i in a + 1..b {
            let w = (i - a) as f64 / (b - a) as f64;
            out[i - first] = values[a] * (1.0 - w) + values[b] * w;
        }
    }
    out
}

/// A channel's measurement-noise variance: the Fourier estimate over the
/// window, at least LSB²/12 of a quantised channel and (10⁻⁶·its standard
/// deviation)². Returns (variance, the Fourier estimate, the floor).
pub(super) fn channel_noise(
    channel: &Channel,
    window: (f64, f64),
    bandwidth: f64,
) -> (f64, f64, f64) {
    let values: Vec<f64> = channel
        .times
        .iter()
        .zip(&channel.values)
        .filter(|(t, _)| **t >= window.0 - 1e-9 && **t <= window.1 + 1e-9)
        .map(|(_, v)| *v)
        .collect();
    let fourier = fourier_noise_variance(&values, channel.rate, bandwidth);
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    let mean = finite.iter().sum::<f64>() / finite.len().max(1) as f64;
    let spread = (finite.iter().map(|v| (v - mean).powi(2)).sum::<f64>()
        / finite.len().max(1) as f64)
        .sqrt();
    let quantisation = channel.resolution.map_or(0.0, |lsb| lsb * lsb / 12.0);
    let floor = quantisation
        .max((NOISE_FLOOR * spread).powi(2))
        .max(f64::MIN_POSITIVE);
    let variance = if fourier.is_finite() {
        fourier.max(floor)
    } else {
        floor
    };
    (variance, fourier, floor)
}
