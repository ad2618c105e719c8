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
//!   half-width. Degrees 2p−1 and 2p give the same centred derivative, so
//!   the default degree 4 is the quartic/cubic filter with an (ω·T)⁴ error;
//! - [`Differentiator::bandwidth`] gives, for a rate, the frequency up to
//!   which |G − 1| < 1 % and the frequency where G falls to ½ (the
//!   smoothing cut-off); the default's figures are on [`Differentiator`].
//!
//! The first and last m samples have no centred window and get no
//! derivative: the derivative channel is shorter than its source.
//!
//! Steps. A step in a control surface makes the angular accelerations jump,
//! and a window across the jump smears it into the neighbouring samples.
//! Given the instants where the derivative may jump
//! ([`Differentiator::differentiate_with_breaks`]; [`step_times`] finds
//! them in a control channel), a sample whose window would reach across one
//! gets no derivative (a dropout, which the estimators leave out).

use crate::Channel;
use crate::quality::{FEW_LSB, quantum};

/// Settings of the local polynomial differentiator (a settings table
/// writes them as `differentiator = { half_width = "0.1 s", degree = 4 }`).
///
/// The default (d = 4, T = 0.1 s): at 100 Hz (10 samples each side) the
/// gain error is 2e-5 at 0.5 Hz and 4e-4 at 1 Hz, within 1 % up to
/// ≈ 2.3 Hz, ½ at ≈ 7.3 Hz; at 25 Hz (3 each side, T = 0.12 s) within 1 %
/// up to ≈ 1.9 Hz, ½ at ≈ 5.8 Hz. Rigid-body motion of a transport
/// aircraft lies below ~1 Hz, so the default passes it nearly unchanged
/// (accuracy first: the ideal-data gate of 1e-3 relative needs it) and
/// attenuates sensor noise only above a few Hz; for noisy data a wider
/// window (e.g. T = 0.2 s: 1 % to ≈ 1.2 Hz, ½ at ≈ 3.6 Hz) or degree 2
/// smooths more at the price of a gain error.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Differentiator {
    /// Half-width of the window (s); rounded to whole samples at the channel's rate.
    #[serde(deserialize_with = "aeroid_core::units::seconds")]
    pub half_width: f64,
    /// Degree of the local polynomial (≥ 1).
    pub degree: usize,
}

impl Differentiator {
    /// What is wrong with a differentiator read from a settings table or
    /// the command line, if anything: a half-width that is not positive or
    /// beyond `MAX_HALF_WIDTH`, a degree of 0 or beyond [`MAX_DEGREE`].
    pub fn check(&self) -> Option<String> {
        if !(self.half_width > 0.0 && self.half_width <= MAX_HALF_WIDTH) {
            Some(format!(
                "differentiator.half_width must be positive and at most {MAX_HALF_WIDTH} s, is {} s",
                self.half_width
            ))
        } else if !(1..=MAX_DEGREE).contains(&self.degree) {
            Some(format!(
                "differentiator.degree must be from 1 to {MAX_DEGREE}, is {}",
                self.degree
            ))
        } else {
            None
        }
    }
}

/// The widest half-window a differentiator takes, in seconds: a local
/// polynomial over more than 20 s smooths away every manoeuvre, and a
/// window of 1e9 s would ask for more memory than any machine has.
pub(crate) const MAX_HALF_WIDTH: f64 = 10.0;

/// The highest degree of a differentiator's local polynomial: beyond it the
/// least-squares fit on equidistant samples is ill-conditioned (Runge) and
/// its noise gain grows without bound.
pub const MAX_DEGREE: usize = 10;

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
    /// Samples on each side of the centre at `rate` (Hz): at least enough
    /// for a least-squares fit of the degree (2m + 1 ≥ degree + 2 samples).
    pub fn half_window(&self, rate: f64) -> usize {
        let from_width = (self.half_width * rate).round() as usize;
        from_width.max((self.degree + 1).div_ceil(2)).max(1)
    }

    /// The derivative of `channel` on its own time base (see the module
    /// documentation), as a channel named `{name}_dot` holding the interior
    /// samples; a window with too few valid samples gives a dropout (NaN).
    pub fn differentiate(&self, channel: &Channel) -> Channel {
        self.differentiate_with_breaks(channel, &[])
    }

    /// As [`Differentiator::differentiate`], with no window crossing any of
    /// `breaks` (sorted instants, s, where the derivative may jump).
    ///
    /// A window may end at a break but not pass it (the continuous signal's
    /// sample at a break ends the piece before it and starts the next); a
    /// sample whose window would cross one gets no derivative (a dropout).
    /// Without the breaks a step input's jump in the angular accelerations
    /// gives 1–7 % errors in the moment derivatives on noise-free data, and
    /// on the 25 Hz flight-test profile a bias towards zero (Cl_p −9.5 %,
    /// 22 σ over 100 runs) easily taken for the errors in variables the
    /// reflex-wing UAV paper reports. The dropouts cost 2m − 1 samples per
    /// step. Windows shifted off-centre to stay inside a piece would keep
    /// those samples but multiply their noise (an end-point slope of a
    /// 7-sample quartic fit) right where the control regressors have their
    /// leverage: over the same 100 runs that tripled the spread of Cl_p and
    /// left the Cramér–Rao bounds 1.5–2.8× optimistic, while the dropouts
    /// give σ_MC/CRB 0.76–1.19.
    pub fn differentiate_with_breaks(&self, channel: &Channel, breaks: &[f64]) -> Channel {
        let m = self.half_window(channel.rate);
        let count = channel.times.len();
        let end = count.saturating_sub(m);
        let interior = m.min(end)..end;
        let times = &channel.times;
        let uniform = UniformWindow::new(self, m, channel.rate);
        let values = interior
            .clone()
            .map(|k| {
                // The centred window must lie in the piece around k: from
                // the last break at or before t_k to the first break after
                // it, both ends included.
                let after = breaks.partition_point(|&b| b <= times[k]);
                let starts_after = after
                    .checked_sub(1)
                    .is_some_and(|i| times[k - m] < breaks[i]);
                let ends_after = breaks.get(after).is_some_and(|&b| times[k + m] > b);
                if starts_after || ends_after {
                    return f64::NAN;
                }
                uniform
                    .slope_at(times, &channel.values, k)
                    .unwrap_or_else(|| self.slope_at(times, &channel.values, k, k - m..=k + m))
            })
            .collect();
        Channel {
            name: format!("{}_dot", channel.name),
            unit: format!("{}/s", channel.unit),
            rate: channel.rate,
            resolution: None,
            source: format!(
                "local polynomial derivative (degree {}, ±{m} samples{}) of {}",
                self.degree,
                if breaks.is_empty() {
                    String::new()
                } else {
                    format!(", not across {} control steps", breaks.len())
                },
                channel.name
            ),
            times: channel.times[interior].to_vec(),
            values,
        }
    }

    /// Slope at sample k of the degree-d polynomial fitted to the samples in `window`.
    fn slope_at(
        &self,
        times: &[f64],
        values: &[f64],
        k: usize,
        window: std::ops::RangeInclusive<usize>,
    ) -> f64 {
        let terms = self.degree + 1;
        let scale = (times[*window.end()] - times[*window.start()]) / 2.0;
        if scale <= 0.0 {
            return f64::NAN;
        }
        let mut normal = nalgebra::DMatrix::<f64>::zeros(terms, terms);
        let mut right = nalgebra::DVector::<f64>::zeros(terms);
        let mut used = 0;
        for j in window {
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
        UniformWindow::new(self, self.half_window(rate), rate).gain(frequency)
    }

    /// The standard deviation of the centred derivative per unit standard
    /// deviation of white errors in the samples, on a uniform grid of
    /// `rate` (Hz): the norm √Σ w_j² of the filter's weights (1/s).
    pub fn noise_gain(&self, rate: f64) -> f64 {
        UniformWindow::new(self, self.half_window(rate), rate)
            .weights
            .iter()
            .map(|w| w * w)
            .sum::<f64>()
            .sqrt()
    }

    /// The accurate band and the cut-off at `rate` (Hz), by scanning the gain.
    pub fn bandwidth(&self, rate: f64) -> Bandwidth {
        let nyquist = rate / 2.0;
        let steps = 2000;
        let frequencies = (1..=steps).map(|i| nyquist * i as f64 / steps as f64);
        let mut accurate_to = nyquist;
        let mut half_gain = nyquist;
        let mut accurate_found = false;
        let window = UniformWindow::new(self, self.half_window(rate), rate);
        for frequency in frequencies {
            let gain = window.gain(frequency);
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
            crate::rate_text(rate),
            band.half_window as f64 / rate,
            band.accurate_to,
            band.half_gain
        )
    }
}

/// Instants where `channel` steps or turns a fast ramp's corner
/// ([`transitions`], with the channel's declared resolution): a transition of one change is a step, its instant
/// the first sample with the new value; a longer one is a surface moving
/// through an actuator's ramp, its instants the last sample before the
/// motion and the first after it. A slow ramp, whose changes stay below
/// the threshold, has none. Where the record's spectra are integrated in
/// pieces (the frequency-domain methods), these are the pieces' ends.
pub fn step_times(channel: &Channel) -> Vec<f64> {
    let finite = finite_samples(channel);
    let values: Vec<f64> = finite.iter().map(|(_, v)| *v).collect();
    transitions(&values, channel.resolution)
        .into_iter()
        .flat_map(|run| {
            let before = (run.len() > 1).then(|| finite[run.start].0);
            before.into_iter().chain([finite[run.end].0])
        })
        .collect()
}

/// Instants where the derivatives `channel` drives may jump or kink, the
/// differentiator's breaks: both ends of every transition ([`transitions`]),
/// the last sample before the change and the first after it. A ramp has
/// two corners, and a window across either smears the angular
/// accelerations' turn; none fits inside a fast ramp. A transition of one
/// change is a step at the later sample or a ramp spanning that one
/// sample interval, which the samples cannot tell apart: breaking at both
/// of its samples costs one window more at a step and keeps the ramp's
/// first corner out of every window.
pub fn corner_times(channel: &Channel) -> Vec<f64> {
    let finite = finite_samples(channel);
    let values: Vec<f64> = finite.iter().map(|(_, v)| *v).collect();
    transitions(&values, channel.resolution)
        .into_iter()
        .flat_map(|run| [finite[run.start].0, finite[run.end].0])
        .collect()
}

/// The (time, value) pairs of `channel` with a finite value.
fn finite_samples(channel: &Channel) -> Vec<(f64, f64)> {
    channel
        .times
        .iter()
        .zip(&channel.values)
        .filter(|(_, v)| v.is_finite())
        .map(|(t, v)| (*t, *v))
        .collect()
}

/// The fast transitions of a sampled signal (finite values, in order), as
/// ranges of changes (change j from sample j to j + 1).
///
/// A change is *large* when it exceeds both 10 robust standard deviations
/// of the sample-to-sample changes (1.4826 × their median absolute value:
/// sensor noise never reaches it, while a smooth input such as a multisine
/// changes by comparable amounts at every sample and never does) and 5 % of
/// the signal's range (quantization steps stay below it). A *transition*
/// is a run of consecutive changes above half that threshold holding at
/// least one large change: one change, a step sampled (or a ramp within
/// one sample interval); more, a ramp through samples. A channel whose
/// whole range is at most `FEW_LSB` least significant bits (`quantum`:
/// `resolution` when declared, else inferred from the values) is a
/// near-constant quantised channel, whose changes are quantisation: it has
/// no transitions (an unused flap at a level's edge that flips by one LSB).
pub fn transitions(values: &[f64], resolution: Option<f64>) -> Vec<std::ops::Range<usize>> {
    if values.len() < 3 {
        return Vec::new();
    }
    let changes: Vec<f64> = values.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    let mut ranked = changes.clone();
    let middle = ranked.len() / 2;
    let (_, median, _) = ranked.select_nth_unstable_by(middle, f64::total_cmp);
    let noise = 1.4826 * *median;
    let (low, high) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        });
    let threshold = (10.0 * noise).max(0.05 * (high - low));
    if threshold <= 0.0 {
        return Vec::new();
    }
    let mut runs = Vec::new();
    let mut i = 0;
    while i < changes.len() {
        if changes[i] <= 0.5 * threshold {
            i += 1;
            continue;
        }
        let first = i;
        while i < changes.len() && changes[i] > 0.5 * threshold {
            i += 1;
        }
        if changes[first..i].iter().any(|&c| c > threshold) {
            runs.push(first..i);
        }
    }
    let near_constant = !runs.is_empty()
        && quantum(values, resolution)
            .is_some_and(|lsb| high - low <= FEW_LSB * lsb * (1.0 + 1e-9));
    if near_constant {
        runs.clear();
    }
    runs
}

/// The slope of the centred window on a uniform grid as fixed weights
/// (the local polynomial fit is linear in the samples: a Savitzky–Golay
/// derivative filter), computed once per channel from
/// [`Differentiator::slope_at`] of unit samples; used where the window's
/// samples are all valid and evenly spaced (to 10⁻⁹ of the spacing),
/// which gives the fit's slope to rounding at a fraction of its cost.
struct UniformWindow {
    half: usize,
    spacing: f64,
    weights: Vec<f64>,
}

impl UniformWindow {
    fn new(differentiator: &Differentiator, half: usize, rate: f64) -> UniformWindow {
        let spacing = 1.0 / rate;
        let width = 2 * half + 1;
        let times: Vec<f64> = (0..width).map(|j| j as f64 * spacing).collect();
        let weights = (0..width)
            .map(|i| {
                let mut unit = vec![0.0; width];
                unit[i] = 1.0;
                differentiator.slope_at(&times, &unit, half, 0..=2 * half)
            })
            .collect();
        UniformWindow {
            half,
            spacing,
            weights,
        }
    }

    /// The gain relative to the ideal derivative at `frequency` (Hz): the
    /// weights applied to sin(ω·t) centred on the window, over ω.
    fn gain(&self, frequency: f64) -> f64 {
        let omega = std::f64::consts::TAU * frequency;
        let slope: f64 = self
            .weights
            .iter()
            .enumerate()
            .map(|(j, w)| w * (omega * (j as f64 - self.half as f64) * self.spacing).sin())
            .sum();
        slope / omega
    }

    /// The slope at sample k, or None where the window is not uniform and
    /// complete (or the weights are not finite).
    fn slope_at(&self, times: &[f64], values: &[f64], k: usize) -> Option<f64> {
        let start = k.checked_sub(self.half)?;
        let (times, values) = (
            times.get(start..=k + self.half)?,
            values.get(start..=k + self.half)?,
        );
        let tolerance = 1e-9 * self.spacing;
        let centre = times[self.half];
        let even = times.iter().enumerate().all(|(j, t)| {
            (t - centre - (j as f64 - self.half as f64) * self.spacing).abs() <= tolerance
        });
        if !even || !values.iter().all(|v| v.is_finite()) {
            return None;
        }
        let slope: f64 = self.weights.iter().zip(values).map(|(w, v)| w * v).sum();
        slope.is_finite().then_some(slope)
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

    /// The noise gain of the 7-point quartic (cubic) derivative is the
    /// norm of the Savitzky–Golay weights (22, −67, −58, 0, 58, 67,
    /// −22)/(252·Δt): √16674/252/Δt = 0.5124/Δt (to 1e-9 relative).
    #[test]
    fn noise_gain_is_the_norm_of_the_weights() {
        let d = Differentiator::default();
        let expected = 16674f64.sqrt() / 252.0 * 25.0;
        assert_eq!(d.half_window(25.0), 3);
        assert!((d.noise_gain(25.0) / expected - 1.0).abs() < 1e-9);
    }

    /// On evenly spaced samples the fixed weights give the local fit's
    /// slope to rounding (1e-12 relative on a noisy sine), and a window with
    /// a dropout or an uneven instant falls back to the fit itself.
    #[test]
    fn uniform_weights_match_the_local_fit() {
        let d = Differentiator::default();
        let times: Vec<f64> = (0..200).map(|k| k as f64 / 100.0).collect();
        let mut values: Vec<f64> = times
            .iter()
            .enumerate()
            .map(|(k, t)| (3.0 * t).sin() + 1e-3 * ((k * 7919) % 17) as f64)
            .collect();
        values[120] = f64::NAN;
        let mut uneven = times.clone();
        uneven[60] += 1e-4;
        let m = d.half_window(100.0);
        let window = UniformWindow::new(&d, m, 100.0);
        for k in m..200 - m {
            let fit = d.slope_at(&times, &values, k, k - m..=k + m);
            match window.slope_at(&times, &values, k) {
                Some(fast) => assert!((fast - fit).abs() <= 1e-12 * fit.abs().max(1.0), "{k}"),
                None => assert!((110..=130).contains(&k), "{k} fell back"),
            }
            let near_uneven = (50..=70).contains(&k);
            assert_eq!(
                window.slope_at(&uneven, &values, k).is_none(),
                near_uneven || (110..=130).contains(&k),
                "{k}"
            );
        }
    }

    /// A channel shorter than the window gives an empty derivative, no panic.
    #[test]
    fn short_channel_has_no_derivative() {
        let derivative =
            Differentiator::default().differentiate(&channel(vec![0.0, 0.01, 0.02], vec![1.0; 3]));
        assert!(derivative.times.is_empty() && derivative.values.is_empty());
    }

    /// The documented bandwidths of the default filter ([`Differentiator`]), to 0.1 Hz,
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

    /// p(t) continuous with a jump in ṗ at t = 1 s (ṗ = 0.5 before, −1.2 +
    /// t after, as a step input makes it): with the break, every derivative
    /// whose window stays on one side is exact (1e-10), each sample whose
    /// window would cross the break is a dropout (2m of them), and the
    /// samples at the break use the piece they start. Without the break the
    /// window smears the jump (error ≥ 0.1 next to it).
    #[test]
    fn breaks_keep_windows_off_a_jump() {
        let p = |t: f64| {
            if t <= 1.0 {
                0.5 * t
            } else {
                0.5 - 1.2 * (t - 1.0) + 0.5 * (t * t - 1.0)
            }
        };
        let dp = |t: f64| if t < 1.0 { 0.5 } else { -1.2 + t };
        let times: Vec<f64> = (0..200).map(|k| k as f64 * 0.01).collect();
        let values = times.iter().map(|&t| p(t)).collect();
        let source = channel(times, values);
        let d = Differentiator::default();
        let derivative = d.differentiate_with_breaks(&source, &[1.0]);
        let m = d.half_window(100.0) as f64;
        let mut dropouts = 0;
        for (t, v) in derivative.times.iter().zip(&derivative.values) {
            let crosses = (t - 1.0).abs() < m * 0.01 - 1e-9;
            if crosses {
                dropouts += 1;
                assert!(v.is_nan(), "t = {t}: the window crosses the break");
            } else {
                assert!((v - dp(*t)).abs() < 1e-10, "t = {t}: {v} vs {}", dp(*t));
            }
        }
        assert_eq!(dropouts, 2 * m as usize - 1, "dropouts");
        let smeared = d.differentiate(&source);
        let worst = smeared
            .times
            .iter()
            .zip(&smeared.values)
            .map(|(t, v)| (v - dp(*t)).abs())
            .fold(0.0, f64::max);
        assert!(worst > 0.1, "without the break: worst error {worst}");
    }

    /// Steps are found in a noisy step input (isolated jumps of 2° against
    /// 0.01° noise), at the first sample with the new value, and their
    /// corners at it and at the last sample with the old value (the
    /// corners of a ramp within that interval); a fast ramp gives its two
    /// corners; a multisine, a slow ramp and quantization
    /// steps give none.
    #[test]
    fn step_times_finds_steps_not_smooth_inputs() {
        let times: Vec<f64> = (0..500).map(|k| k as f64 * 0.04).collect();
        let noise = |k: usize| 1.7e-4 * (((k * 7919) % 23) as f64 / 11.0 - 1.0);
        let steps: Vec<f64> = (0..500)
            .map(|k| match k {
                0..100 => 0.0,
                100..140 => 0.035,
                140..200 => -0.035,
                _ => 0.0,
            } + noise(k))
            .collect();
        let rounded = |mut found: Vec<f64>| {
            found
                .iter_mut()
                .for_each(|t| *t = (*t * 100.0).round() / 100.0);
            found
        };
        let steps = channel(times.clone(), steps);
        assert_eq!(rounded(step_times(&steps)), vec![4.0, 5.6, 8.0]);
        assert_eq!(
            rounded(corner_times(&steps)),
            vec![3.96, 4.0, 5.56, 5.6, 7.96, 8.0]
        );
        let multisine: Vec<f64> = times
            .iter()
            .map(|t| {
                (0..6)
                    .map(f64::from)
                    .map(|i| (1.3 * t * (1.0 + i) + i).sin())
                    .sum::<f64>()
            })
            .collect();
        assert!(step_times(&channel(times.clone(), multisine)).is_empty());
        // A ramp through four samples has two corners: the last sample
        // before it (t = 4.0 s) and the first after (4.16 s); a slow ramp
        // (0.1 % of its range per sample) has none the differentiator
        // cannot follow.
        let ramp: Vec<f64> = (0..500)
            .map(|k| (k as f64 - 100.0).clamp(0.0, 4.0) * 0.01)
            .collect();
        let mut corners = step_times(&channel(times.clone(), ramp));
        corners
            .iter_mut()
            .for_each(|t| *t = (*t * 100.0).round() / 100.0);
        assert_eq!(corners, vec![4.0, 4.16]);
        let slow: Vec<f64> = (0..500)
            .map(|k| (k as f64 - 100.0).clamp(0.0, 1000.0) * 0.01)
            .collect();
        assert!(step_times(&channel(times.clone(), slow)).is_empty());
        let quantized: Vec<f64> = times
            .iter()
            .map(|t| ((t * 0.3).sin() * 20.0).round() / 20.0)
            .collect();
        assert!(step_times(&channel(times, quantized)).is_empty());
    }

    /// A near-constant quantised channel (an unused flap at a level's edge,
    /// LSB 0.01°) that flips by one LSB 300 times, at random, and by two
    /// now and then, has no steps and no corners, its LSB inferred from the
    /// values or declared. A 2° step on the same channel is still found,
    /// once (the flips stay below 5 % of its range), and a clean step input
    /// of two levels (which changes level only twice: no quantisation)
    /// keeps its steps.
    #[test]
    fn quantisation_flips_are_not_steps() {
        let lsb = 0.01 * std::f64::consts::PI / 180.0;
        let times: Vec<f64> = (0..3000).map(|k| k as f64 * 0.02).collect();
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut flips = 0;
        let dither: Vec<f64> = (0..3000)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                match state % 10 {
                    0 => {
                        flips += 1;
                        lsb
                    }
                    1 => 2.0 * lsb,
                    _ => 0.0,
                }
            })
            .collect();
        assert!(flips > 250, "{flips} flips");
        let mut flap = channel(times.clone(), dither.clone());
        assert!(
            step_times(&flap).is_empty(),
            "{:?}",
            &step_times(&flap)[..5]
        );
        assert!(corner_times(&flap).is_empty());
        flap.resolution = Some(lsb);
        assert!(step_times(&flap).is_empty());
        let deployed: Vec<f64> = dither
            .iter()
            .enumerate()
            .map(|(k, v)| v + if k >= 1500 { 2.0 * 100.0 * lsb } else { 0.0 })
            .collect();
        let deployed = channel(times.clone(), deployed);
        assert_eq!(step_times(&deployed), vec![times[1500]]);
        let two_levels: Vec<f64> = (0..3000)
            .map(|k| if (1000..2000).contains(&k) { lsb } else { 0.0 })
            .collect();
        assert_eq!(
            step_times(&channel(times.clone(), two_levels)),
            vec![times[1000], times[2000]]
        );
    }
}
