//! A channel's signal chain (the parent module's header gives the order):
//! the sensor's dynamics on the simulator's grid, sampling, and the
//! measurement errors of each sample.

use super::{ChannelModel, Fault};
use crate::Channel;
use crate::derived::Context;
use crate::error::{Error, Result};
use aeroid_sim::trace::TruthTrace;
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use rand_distr::StandardNormal;
use std::f64::consts::TAU;

impl ChannelModel {
    /// Sample instants within the trace: `t0 + offset + k/rate`.
    pub fn sample_times(&self, start: f64, end: f64) -> Vec<f64> {
        let first = start + self.offset;
        (0..)
            .map(|k| first + k as f64 / self.rate)
            .take_while(|&t| t <= end)
            .collect()
    }

    pub(super) fn record(
        &self,
        trace: &TruthTrace,
        context: &Context,
        profile: &str,
        rng: &mut ChaCha8Rng,
    ) -> Result<Channel> {
        let context = Context {
            sensor_position: self.position,
            ..*context
        };
        let grid: Vec<f64> = trace.samples.iter().map(|s| s.time).collect();
        let signal: Vec<f64> = trace
            .samples
            .iter()
            .map(|s| (self.measurand.value)(s, &context))
            .collect();
        self.record_signal(&grid, signal, trace.step, profile, rng)
    }

    /// Records the true quantity `signal` given on `grid` (of step `step`):
    /// the sensor's own dynamics, sampling and measurement errors.
    pub(super) fn record_signal(
        &self,
        grid: &[f64],
        signal: Vec<f64>,
        step: f64,
        profile: &str,
        rng: &mut ChaCha8Rng,
    ) -> Result<Channel> {
        let signal = self.sensed_signal(signal, grid, step)?;
        let times = self.sample_times(grid[0], grid[grid.len() - 1]);
        let mut values = Vec::with_capacity(times.len());
        let mut last_good = f64::NAN;
        // The previous sample's normalised noise, for coloured noise.
        let mut noise = None;
        for &time in &times {
            let truth = interpolate(grid, &signal, time - self.delay);
            let value = self.measure(truth, time, (&mut last_good, &mut noise), rng);
            values.push(value);
        }
        Ok(Channel {
            name: self.measurand.name.to_string(),
            unit: self.measurand.unit.to_string(),
            rate: self.rate,
            resolution: self.resolution,
            source: self.source(profile),
            times,
            values,
        })
    }

    fn source(&self, profile: &str) -> String {
        match self.label.is_empty() {
            true => format!("recorder {profile}"),
            false => format!("recorder {profile}: {}", self.label),
        }
    }

    /// The true quantity on the simulator's grid after the sensor's own dynamics.
    fn sensed_signal(&self, mut signal: Vec<f64>, grid: &[f64], step: f64) -> Result<Vec<f64>> {
        if self.measurand.wraps {
            crate::unwrap_angles(&mut signal);
        }
        if self.lag > 0.0 {
            first_order_lag(grid, &mut signal, self.lag);
        }
        if let Some(cutoff) = self.anti_alias {
            butterworth(&mut signal, cutoff, step, self.measurand.name)?;
        }
        Ok(signal)
    }

    /// One recorded sample from the sensed truth at its instant; `noise`
    /// carries the previous sample's normalised noise (coloured noise).
    fn measure(
        &self,
        truth: f64,
        time: f64,
        (last_good, noise): (&mut f64, &mut Option<f64>),
        rng: &mut ChaCha8Rng,
    ) -> f64 {
        let mut value = self.scale_factor * truth + self.bias;
        if self.noise > 0.0 {
            let draw = rng.sample::<f64, _>(StandardNormal);
            let normalised = match (*noise, self.noise_time > 0.0) {
                (Some(previous), true) => {
                    let a = (-1.0 / (self.rate * self.noise_time)).exp();
                    a * previous + (1.0 - a * a).sqrt() * draw
                }
                _ => draw,
            };
            *noise = Some(normalised);
            value += self.noise * normalised;
        }
        if let Some((low, high)) = self.saturation {
            value = value.clamp(low, high);
        }
        value = match (self.measurand.wraps, self.resolution) {
            (true, lsb) => wrap_and_quantize(value, lsb),
            (false, Some(lsb)) => quantize(value, lsb),
            (false, None) => value,
        };
        value = match &self.fault {
            Some(Fault::Levels(levels)) => levels[rng.random_range(0..levels.len())],
            Some(Fault::Stuck { from, value: stuck }) if time >= *from => {
                stuck.unwrap_or(*last_good)
            }
            _ => {
                *last_good = value;
                value
            }
        };
        if self.dropout > 0.0 && rng.random::<f64>() < self.dropout {
            f64::NAN
        } else {
            value
        }
    }
}

/// Rounds to the nearest multiple of the least significant bit.
pub fn quantize(value: f64, lsb: f64) -> f64 {
    (value / lsb).round() * lsb
}

/// Wraps an angle to [0, 2π) and quantizes it so that the result stays in
/// [0, 2π): a value that rounds up to a full turn reads 0 (when 2π is a whole
/// number of LSBs, as for 0.3°, 0.5° and 1° headings).
pub fn wrap_and_quantize(angle: f64, lsb: Option<f64>) -> f64 {
    let wrapped = angle.rem_euclid(TAU);
    let Some(lsb) = lsb else {
        return wrapped;
    };
    let steps = (wrapped / lsb).round();
    let full_turn = (TAU / lsb).round();
    if steps >= full_turn && (TAU / lsb - full_turn).abs() < 1e-6 {
        (steps - full_turn) * lsb
    } else {
        steps * lsb
    }
}

/// Linear interpolation of `values` on strictly increasing `grid`, holding the ends.
pub fn interpolate(grid: &[f64], values: &[f64], time: f64) -> f64 {
    let after = grid.partition_point(|&t| t <= time);
    if after == 0 {
        return values[0];
    }
    if after == grid.len() {
        return values[grid.len() - 1];
    }
    let k = after - 1;
    let fraction = (time - grid[k]) / (grid[k + 1] - grid[k]);
    values[k] + (values[k + 1] - values[k]) * fraction
}

/// First-order lag `τ·ẏ + y = u`, exact for an input linear between grid points,
/// starting in equilibrium.
fn first_order_lag(grid: &[f64], signal: &mut [f64], time_constant: f64) {
    let mut output = signal[0];
    let mut previous_input = signal[0];
    for k in 1..signal.len() {
        let step = grid[k] - grid[k - 1];
        let decay = (-step / time_constant).exp();
        let input = signal[k];
        output = decay * output
            + (1.0 - decay) * previous_input
            + (input - previous_input) * (1.0 - time_constant * (1.0 - decay) / step);
        previous_input = input;
        signal[k] = output;
    }
}

/// Second-order Butterworth low-pass (bilinear transform with pre-warping) on
/// a uniform grid of `step`, starting in equilibrium.
fn butterworth(signal: &mut [f64], cutoff: f64, step: f64, channel: &str) -> Result<()> {
    if cutoff >= 0.5 / step {
        return Err(Error::AntiAlias {
            channel: channel.into(),
            cutoff,
            nyquist: 0.5 / step,
        });
    }
    let k = (std::f64::consts::PI * cutoff * step).tan();
    let root2 = std::f64::consts::SQRT_2;
    let norm = 1.0 / (1.0 + root2 * k + k * k);
    let b0 = k * k * norm;
    let (b1, b2) = (2.0 * b0, b0);
    let a1 = 2.0 * (k * k - 1.0) * norm;
    let a2 = (1.0 - root2 * k + k * k) * norm;
    let (mut x1, mut x2, mut y1, mut y2) = (signal[0], signal[0], signal[0], signal[0]);
    for value in signal.iter_mut() {
        let x0 = *value;
        let y0 = b0 * x0 + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2;
        (x2, x1, y2, y1) = (x1, x0, y1, y0);
        *value = y0;
    }
    Ok(())
}
