//! The multisine input (E. A. Morelli, "Multiple input design for
//! real-time parameter estimation in the frequency domain", 13th IFAC
//! Symposium on System Identification, 2003): harmonics k/T of one
//! fundamental interleaved over the inputs (harmonic j, ascending, to
//! control j mod n) so that their spectra are disjoint, Schroeder phases
//! φ_k = φ_1 − π k²/M for a low peak factor, each input shifted in time to
//! start at a zero crossing and scaled to peak at its amplitude. Morelli's
//! further optimisation of the phases (relative peak factor ≈ 1.0–1.1) is
//! not done: plain Schroeder phases give about 1.25–1.4.

use super::checker::{Checker, transpose};
use super::signal::{Harmonic, Multisine, Signal};
use super::spec::MultisineSpec;
use crate::state::Control;
use aeroid_core::units::{Dimension, Quantity};
use std::f64::consts::{PI, TAU};

/// A multisine's validated numbers, before the harmonics are laid out.
struct MultisinePlan {
    controls: Vec<Control>,
    amplitudes: Vec<f64>,
    start: f64,
    period: f64,
    harmonic_numbers: Vec<u32>,
    cycles: u32,
}

/// Most harmonics one multisine may use: beyond this, the band or the period is a typo.
const MAXIMUM_HARMONICS: usize = 10_000;

impl MultisineSpec {
    pub(super) fn resolve(&self, checker: &mut Checker) -> Option<Signal> {
        let plan = self.plan(checker)?;
        let control_count = plan.controls.len();
        let mut harmonics = Vec::with_capacity(plan.harmonic_numbers.len());
        let mut valid = true;
        for (slot, (&control, &amplitude)) in plan.controls.iter().zip(&plan.amplitudes).enumerate()
        {
            let numbers: Vec<u32> = (plan.harmonic_numbers.iter().copied())
                .skip(slot)
                .step_by(control_count)
                .collect();
            if numbers.len() < 2 {
                let message = format!(
                    "control '{}' gets {} harmonic(s) but needs at least 2: widen the band, lengthen the period or list more harmonics",
                    control.name(),
                    numbers.len()
                );
                checker.push("harmonics", message);
                valid = false;
                continue;
            }
            harmonics.extend(control_harmonics(control, amplitude, plan.period, &numbers));
        }
        valid.then_some(())?;
        Some(Signal::Multisine(Multisine {
            start: plan.start,
            end: plan.start + f64::from(plan.cycles) * plan.period,
            harmonics,
        }))
    }

    fn plan(&self, checker: &mut Checker) -> Option<MultisinePlan> {
        let controls_valid = check_multisine_controls(checker, &self.controls);
        let amplitudes = multisine_amplitudes(checker, &self.controls, &self.amplitudes);
        let start = checker.time("start", &self.start);
        let period = checker.positive("period", &self.period, Dimension::Time);
        if self.cycles == 0 {
            checker.push("cycles", "must be at least 1");
        }
        let band = frequency_band(
            checker,
            self.frequency_min.as_ref(),
            self.frequency_max.as_ref(),
        );
        let harmonic_numbers = harmonic_numbers(checker, self.harmonics.as_deref(), band?, period?);
        (controls_valid && self.cycles > 0).then_some(())?;
        Some(MultisinePlan {
            controls: self.controls.clone(),
            amplitudes: amplitudes?,
            start: start?,
            period: period?,
            harmonic_numbers: harmonic_numbers?,
            cycles: self.cycles,
        })
    }
}

/// At least one control, none twice.
fn check_multisine_controls(checker: &mut Checker, controls: &[Control]) -> bool {
    if controls.is_empty() {
        checker.push("controls", "must list at least one control");
        return false;
    }
    let mut valid = true;
    for (i, control) in controls.iter().enumerate() {
        if controls[..i].contains(control) {
            let message = format!(
                "'{}' appears twice; each control needs its own harmonics",
                control.name()
            );
            checker.push("controls", message);
            valid = false;
        }
    }
    valid
}

/// One positive amplitude per control, in that control's dimension.
fn multisine_amplitudes(
    checker: &mut Checker,
    controls: &[Control],
    amplitudes: &[Quantity],
) -> Option<Vec<f64>> {
    if amplitudes.len() != controls.len() {
        let message = format!(
            "{} controls but {} amplitudes",
            controls.len(),
            amplitudes.len()
        );
        checker.push("amplitudes", message);
        return None;
    }
    let values: Vec<Option<f64>> = controls
        .iter()
        .zip(amplitudes)
        .enumerate()
        .map(|(i, (&control, amplitude))| {
            let field = format!("amplitudes[{i}]");
            let value = checker.positive(&field, amplitude, control.dimension())?;
            checker.within_range(&field, amplitude, value, control)
        })
        .collect();
    values.into_iter().collect()
}

/// The optional band [frequency_min, frequency_max] in Hz; `None` when invalid.
fn frequency_band(
    checker: &mut Checker,
    minimum: Option<&Quantity>,
    maximum: Option<&Quantity>,
) -> Option<(Option<f64>, Option<f64>)> {
    let low = minimum.map(|q| checker.non_negative("frequency_min", q, Dimension::Frequency));
    let high = maximum.map(|q| checker.positive("frequency_max", q, Dimension::Frequency));
    let (low, high) = (transpose(low)?, transpose(high)?);
    if let (Some(low), Some(high)) = (low, high)
        && low >= high
    {
        checker.push(
            "frequency_min",
            format!("must be below frequency_max ({low} Hz ≥ {high} Hz)"),
        );
        return None;
    }
    Some((low, high))
}

/// The sorted harmonic numbers k (frequency k/period): the listed ones, which
/// must lie inside the band if one is given, or every one inside the band.
fn harmonic_numbers(
    checker: &mut Checker,
    listed: Option<&[u32]>,
    band: (Option<f64>, Option<f64>),
    period: f64,
) -> Option<Vec<u32>> {
    let numbers = match (listed, band) {
        (Some(listed), _) => check_listed_harmonics(checker, listed, band, period)?,
        (None, (Some(_), Some(high)))
            if (high * period).is_nan() || high * period >= u32::MAX as f64 =>
        {
            let message = format!(
                "{period} s at frequency_max {high} Hz puts the harmonic numbers beyond {}: check the band and period",
                u32::MAX
            );
            checker.push("period", message);
            return None;
        }
        (None, (Some(low), Some(high))) => harmonics_in_band(low, high, period),
        (None, _) => {
            let message = "frequency_min and frequency_max are required unless harmonics is given";
            checker.push("harmonics", message);
            return None;
        }
    };
    if numbers.len() > MAXIMUM_HARMONICS {
        let message = format!(
            "{} harmonics (more than {MAXIMUM_HARMONICS}): check the band and period",
            numbers.len()
        );
        checker.push("harmonics", message);
        return None;
    }
    Some(numbers)
}

/// Tolerance when comparing a harmonic's frequency with the band edges, so
/// that e.g. 0.1 Hz · 10 s counts as harmonic 1 despite rounding.
const BAND_TOLERANCE: f64 = 1e-9;

fn harmonics_in_band(low: f64, high: f64, period: f64) -> Vec<u32> {
    let first = (low * period - BAND_TOLERANCE).ceil().max(1.0);
    let last = (high * period + BAND_TOLERANCE).floor();
    let count = (last - first + 1.0).clamp(0.0, (MAXIMUM_HARMONICS + 1) as f64) as u32;
    (0..count).map(|i| first as u32 + i).collect()
}

fn check_listed_harmonics(
    checker: &mut Checker,
    listed: &[u32],
    band: (Option<f64>, Option<f64>),
    period: f64,
) -> Option<Vec<u32>> {
    let mut numbers = listed.to_vec();
    numbers.sort_unstable();
    let length = numbers.len();
    numbers.dedup();
    let mut valid = true;
    if numbers.len() != length {
        checker.push("harmonics", "lists a harmonic twice");
        valid = false;
    }
    if numbers.first() == Some(&0) {
        checker.push(
            "harmonics",
            "harmonic 0 is a constant, not a sinusoid; harmonics start at 1",
        );
        valid = false;
    }
    let low = band.0.unwrap_or(0.0) * period - BAND_TOLERANCE;
    let high = band
        .1
        .map_or(f64::INFINITY, |high| high * period + BAND_TOLERANCE);
    if let Some(outside) = numbers
        .iter()
        .find(|&&k| f64::from(k) < low || f64::from(k) > high)
    {
        let message = format!(
            "harmonic {outside} ({} Hz) lies outside the frequency band",
            f64::from(*outside) / period
        );
        checker.push("harmonics", message);
        valid = false;
    }
    valid.then_some(numbers)
}

/// One control's harmonics: equal amplitudes, Schroeder phases
/// φ_k = φ_1 − π k²/M (k = 1..M over this control's own harmonics, φ_1 = 0),
/// shifted in time to start at a zero crossing, scaled to peak `amplitude`.
fn control_harmonics(
    control: Control,
    amplitude: f64,
    period: f64,
    numbers: &[u32],
) -> Vec<Harmonic> {
    let count = numbers.len() as f64;
    let mut harmonics: Vec<Harmonic> = numbers
        .iter()
        .enumerate()
        .map(|(i, &number)| Harmonic {
            control: control.index(),
            amplitude: 1.0,
            frequency: TAU * f64::from(number) / period,
            phase: -PI * ((i + 1) as f64).powi(2) / count,
        })
        .collect();
    let shift = zero_crossing_nearest_origin(&harmonics, period);
    for harmonic in &mut harmonics {
        harmonic.phase = (harmonic.phase + harmonic.frequency * shift).rem_euclid(TAU);
    }
    let peak = peak_magnitude(&harmonics, period);
    for harmonic in &mut harmonics {
        harmonic.amplitude = amplitude / peak;
    }
    harmonics
}

fn sum_of(harmonics: &[Harmonic], time: f64) -> f64 {
    harmonics
        .iter()
        .map(|h| h.amplitude * (h.frequency * time + h.phase).cos())
        .sum()
}

fn slope_of(harmonics: &[Harmonic], time: f64) -> f64 {
    harmonics
        .iter()
        .map(|h| -h.amplitude * h.frequency * (h.frequency * time + h.phase).sin())
        .sum()
}

/// Grid spacing for searches: 64 points per cycle of the highest harmonic.
fn search_step(harmonics: &[Harmonic]) -> f64 {
    let highest = harmonics.iter().map(|h| h.frequency).fold(0.0, f64::max);
    TAU / highest / 64.0
}

/// The zero of the sum nearest t = 0: a grid search outwards from 0 in both
/// directions, then bisection of the first bracket found.
fn zero_crossing_nearest_origin(harmonics: &[Harmonic], period: f64) -> f64 {
    let step = search_step(harmonics);
    let value = |time: f64| sum_of(harmonics, time);
    let steps = (0.5 * period / step).ceil() as usize;
    for i in 0..steps {
        let near = i as f64 * step;
        for (a, b) in [(near, near + step), (-near, -near - step)] {
            if value(a) == 0.0 {
                return a;
            }
            if value(a) * value(b) < 0.0 {
                return bisect(value, a, b);
            }
        }
    }
    0.0 // unreachable for a zero-mean sum: it crosses zero within every period
}

/// A root of `function` in [a, b] where it changes sign, to machine precision.
fn bisect(function: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    let positive_at_a = function(a) > 0.0;
    for _ in 0..200 {
        let middle = 0.5 * (a + b);
        if middle == a || middle == b {
            break;
        }
        if (function(middle) > 0.0) == positive_at_a {
            a = middle;
        } else {
            b = middle;
        }
    }
    0.5 * (a + b)
}

/// max |sum| over one period: the grid's local maxima near the top, each
/// refined by bisecting the slope between its neighbours.
fn peak_magnitude(harmonics: &[Harmonic], period: f64) -> f64 {
    let count = (period / search_step(harmonics)).ceil() as usize;
    let step = period / count as f64;
    let samples: Vec<f64> = (0..count)
        .map(|i| sum_of(harmonics, i as f64 * step).abs())
        .collect();
    let grid_peak = samples.iter().copied().fold(0.0, f64::max);
    let mut peak = grid_peak;
    for i in 0..count {
        let (before, after) = (samples[(i + count - 1) % count], samples[(i + 1) % count]);
        if samples[i] >= 0.8 * grid_peak && samples[i] >= before && samples[i] >= after {
            let centre = i as f64 * step;
            let sign = sum_of(harmonics, centre).signum();
            let outward_slope = |time: f64| sign * slope_of(harmonics, time);
            let top = bisect(outward_slope, centre - step, centre + step);
            peak = peak.max(sum_of(harmonics, top).abs());
        }
    }
    peak
}
