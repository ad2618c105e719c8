//! Smoothing numerical differentiation of a recorded channel by local
//! polynomial least squares (Savitzky & Golay, "Smoothing and
//! differentiation of data by simplified least squares procedures", Anal.
//! Chem. 36, 1964; Klein & Morelli, "Aircraft System Identification", 2006,
//! §11.2 on smoothed numerical differentiation).
//!
//! At every sample t_k a polynomial of degree d is fitted by least squares to
//! the samples within ±m of k (m = half-width × nominal rate, rounded),
//! using the channel's ACTUAL sample instants (so jittered or skewed time
//! tags are handled, and dropouts are simply left out of the window); the
//! derivative is the fitted polynomial's slope at t_k. On a uniform grid this
//! is exactly the Savitzky–Golay derivative filter.
//!
//! Properties of the centred estimate (uniform grid):
//! - zero lag: the weights are antisymmetric, so the response is i·ω·G(ω)
//!   with a real gain G — no phase shift at any frequency;
//! - the gain is exact for polynomials up to degree d; for a sinusoid its
//!   error grows like (ω·T)^(d+1) (d odd) or (ω·T)^d (d even), T = m/rate the
//!   half-width. Degrees 2p−1 and 2p give the same centred derivative
//!   (the even term has no slope at the centre), so the default degree 4 is
//!   the quartic/cubic filter with an (ω·T)⁴ error;
//! - [`Differentiator::bandwidth`] gives, for a rate, the frequency up to
//!   which |G − 1| < 1 % and the frequency where G falls to ½ (the smoothing
//!   cut-off). Default (d = 4, T = 0.1 s): at 100 Hz (10 samples each
//!   side) the gain error is 2e-5 at 0.5 Hz and 4e-4 at 1 Hz, within 1 % up
//!   to ≈ 2.3 Hz, ½ at ≈ 7.3 Hz; at 25 Hz (3 each side, T = 0.12 s) within
//!   1 % up to ≈ 1.9 Hz, ½ at ≈ 5.8 Hz. Rigid-body motion of a transport
//!   aircraft lies below ~1 Hz, so the default passes it nearly unchanged
//!   (accuracy first: the ideal-data gate of 1e-3 relative needs it) and
//!   attenuates sensor noise only above a few Hz; for noisy data a wider
//!   window (e.g. T = 0.2 s: 1 % to ≈ 1.2 Hz, ½ at ≈ 3.6 Hz) or degree 2
//!   smooths more at the price of a gain error.
//!
//! The first and last m samples have no centred window and get no
//! derivative: the derivative channel is shorter than its source.

use crate::record::Channel;

/// Settings of the local polynomial differentiator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Differentiator {
    /// Half-width of the window (s); rounded to whole samples at the channel's rate.
    pub half_width: f64,
    /// Degree of the local polynomial (≥ 1).
    pub degree: usize,
}

impl Default for Differentiator {
    fn default() -> Self {
        Differentiator {
            half_width: 0.1,
            degree: 4,
        }
    }
}

/// Passband and cut-off of the centred derivative on a uniform grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bandwidth {
    /// Samples on each side of the centre.
    pub half_window: usize,
    /// Highest frequency (Hz) below which the gain is within 1 % of the ideal derivative's.
    pub accurate_to: f64,
    /// Frequency (Hz) where the gain has fallen to one half.
    pub half_gain: f64,
}

impl Differentiator {
    /// Samples on each side of the centre at `rate` (Hz): at least enough for the degree.
    pub fn half_window(&self, rate: f64) -> usize {
        let from_width = (self.half_width * rate).round() as usize;
        from_width.max(self.degree.div_ceil(2)).max(1)
    }

    /// The derivative of `channel` on its own time base (see the module
    /// documentation), as a channel named `{name}_dot` holding the interior
    /// samples; a window with too few valid samples gives a dropout (NaN).
    pub fn differentiate(&self, channel: &Channel) -> Channel {
        let m = self.half_window(channel.rate);
        let count = channel.times.len();
        let end = count.saturating_sub(m);
        let interior = m.min(end)..end;
        let values = interior
            .clone()
            .map(|k| self.slope_at(&channel.times, &channel.values, k, m))
            .collect();
        Channel {
            name: format!("{}_dot", channel.name),
            unit: format!("{}/s", channel.unit),
            rate: channel.rate,
            resolution: None,
            source: format!(
                "local polynomial derivative (degree {}, ±{m} samples) of {}",
                self.degree, channel.name
            ),
            times: channel.times[interior].to_vec(),
            values,
        }
    }

    /// Slope at sample k of the degree-d polynomial fitted to samples k−m..=k+m.
    fn slope_at(&self, times: &[f64], values: &[f64], k: usize, m: usize) -> f64 {
        let terms = self.degree + 1;
        let scale = (times[k + m] - times[k - m]) / 2.0;
        let mut normal = nalgebra::DMatrix::<f64>::zeros(terms, terms);
        let mut right = nalgebra::DVector::<f64>::zeros(terms);
        let mut used = 0;
        for j in k - m..=k + m {
            if !values[j].is_finite() {
                continue;
            }
            used += 1;
            let s = (times[j] - times[k]) / scale;
            let powers: Vec<f64> = (0..terms).map(|i| s.powi(i as i32)).collect();
            for (a, pa) in powers.iter().enumerate() {
                right[a] += pa * values[j];
                for (b, pb) in powers.iter().enumerate() {
                    normal[(a, b)] += pa * pb;
                }
            }
        }
        if used <= terms {
            return f64::NAN;
        }
        normal
            .cholesky()
            .map_or(f64::NAN, |c| c.solve(&right)[1] / scale)
    }

    /// The centred derivative's gain relative to the ideal derivative at
    /// `frequency` (Hz) on a uniform grid of `rate` (Hz).
    pub fn gain(&self, rate: f64, frequency: f64) -> f64 {
        let m = self.half_window(rate);
        let omega = std::f64::consts::TAU * frequency;
        let times: Vec<f64> = (0..=2 * m).map(|j| j as f64 / rate).collect();
        let values: Vec<f64> = times
            .iter()
            .map(|t| (omega * (t - times[m])).sin())
            .collect();
        self.slope_at(&times, &values, m, m) / omega
    }

    /// The accurate band and the cut-off at `rate` (Hz), by scanning the gain.
    pub fn bandwidth(&self, rate: f64) -> Bandwidth {
        let nyquist = rate / 2.0;
        let steps = 2000;
        let frequencies = (1..=steps).map(|i| nyquist * i as f64 / steps as f64);
        let mut accurate_to = nyquist;
        let mut half_gain = nyquist;
        let mut accurate_found = false;
        for frequency in frequencies {
            let gain = self.gain(rate, frequency);
            if !accurate_found && (gain - 1.0).abs() > 0.01 {
                accurate_to = frequency - nyquist / steps as f64;
                accurate_found = true;
            }
            if gain < 0.5 {
                half_gain = frequency;
                break;
            }
        }
        Bandwidth {
            half_window: self.half_window(rate),
            accurate_to,
            half_gain,
        }
    }

    /// One line for an estimate's notes.
    pub fn describe(&self, rate: f64) -> String {
        let band = self.bandwidth(rate);
        format!(
            "angular accelerations by local polynomial (Savitzky–Golay) differentiation: degree {}, ±{} samples at {} Hz (±{:.3} s), zero lag, gain within 1 % up to {:.2} Hz, one half at {:.2} Hz",
            self.degree,
            band.half_window,
            rate,
            band.half_window as f64 / rate,
            band.accurate_to,
            band.half_gain
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(times: Vec<f64>, values: Vec<f64>) -> Channel {
        Channel {
            name: "q".into(),
            unit: "rad/s".into(),
            rate: 100.0,
            resolution: None,
            source: String::new(),
            times,
            values,
        }
    }

    /// A quartic is differentiated exactly (to rounding, 1e-10) by the
    /// default degree-4 filter, also on jittered sample times with a dropout.
    #[test]
    fn quartic_is_differentiated_exactly() {
        let f = |t: f64| 0.3 - 1.2 * t + 0.7 * t * t - 0.25 * t.powi(3) + 0.05 * t.powi(4);
        let df = |t: f64| -1.2 + 1.4 * t - 0.75 * t * t + 0.2 * t.powi(3);
        let times: Vec<f64> = (0..300)
            .map(|k| k as f64 * 0.01 + 0.002 * ((k * 7919) % 13) as f64 / 13.0)
            .collect();
        let mut values: Vec<f64> = times.iter().map(|&t| f(t)).collect();
        values[150] = f64::NAN;
        let derivative = Differentiator::default().differentiate(&channel(times, values));
        assert_eq!(derivative.name, "q_dot");
        assert_eq!(derivative.times.len(), 300 - 20);
        for (t, d) in derivative.times.iter().zip(&derivative.values) {
            assert!((d - df(*t)).abs() < 1e-10, "t = {t}: {d} vs {}", df(*t));
        }
    }

    /// A channel shorter than the window gives an empty derivative, no panic.
    #[test]
    fn short_channel_has_no_derivative() {
        let derivative =
            Differentiator::default().differentiate(&channel(vec![0.0, 0.01, 0.02], vec![1.0; 3]));
        assert!(derivative.times.is_empty() && derivative.values.is_empty());
    }

    /// The documented bandwidths of the default filter (module doc), to 0.1 Hz,
    /// and its gain errors at 0.5 and 1 Hz at 100 Hz (what the ideal-data
    /// equation-error gate of 1e-3 relative needs: well below it).
    #[test]
    fn default_bandwidth_is_as_documented() {
        let d = Differentiator::default();
        let fast = d.bandwidth(100.0);
        assert_eq!(fast.half_window, 10);
        assert!((fast.accurate_to - 2.3).abs() < 0.1, "{fast:?}");
        assert!((fast.half_gain - 7.3).abs() < 0.1, "{fast:?}");
        let slow = d.bandwidth(25.0);
        assert_eq!(slow.half_window, 3);
        assert!((slow.accurate_to - 1.9).abs() < 0.1, "{slow:?}");
        assert!((slow.half_gain - 5.8).abs() < 0.1, "{slow:?}");
        assert!((d.gain(100.0, 0.5) - 1.0).abs() < 3e-5);
        assert!((d.gain(100.0, 1.0) - 1.0).abs() < 4e-4);
    }
}
