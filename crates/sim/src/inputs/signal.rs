//! The pre-computed signals an [`InputSchedule`](super::InputSchedule)
//! sums: piecewise-constant steps (each change a step or a linear ramp over
//! a transition), piecewise-linear polylines (ramps, CSV replays) and
//! multisines Σ A·cos(ω·τ + φ), each evaluated at a time without allocating.

use crate::state::{Control, Controls};

#[derive(Debug, Clone)]
pub(super) enum Signal {
    Steps(Steps),
    Polyline(Polyline),
    Multisine(Multisine),
}

impl Signal {
    pub(super) fn add_to(&self, time: f64, deviation: &mut Controls) {
        match self {
            Signal::Steps(steps) => deviation[steps.control] += steps.value(time),
            Signal::Polyline(line) => deviation[line.control] += line.value(time),
            Signal::Multisine(sine) => sine.add_to(time, deviation),
        }
    }
}

/// Tolerance (s) of a step input's switch times against rounding.
const SWITCH_TOLERANCE: f64 = 1e-10;

/// Piecewise constant: 0 before `times[0]`, `levels[i]` on
/// [`times[i]`, `times[i+1]`), `after` from the last time on; each change
/// a linear ramp over `transition` from its switch time (0: a step).
#[derive(Debug, Clone)]
pub(super) struct Steps {
    control: usize,
    times: Vec<f64>,
    levels: Vec<f64>,
    after: f64,
    transition: f64,
}

impl Steps {
    /// Levels starting at `start`, each held `duration`, then `after`.
    pub(super) fn new(
        control: Control,
        start: f64,
        duration: f64,
        levels: Vec<f64>,
        after: f64,
    ) -> Steps {
        let times = (0..=levels.len())
            .map(|i| start + i as f64 * duration)
            .collect();
        Steps {
            control: control.index(),
            times,
            levels,
            after,
            transition: 0.0,
        }
    }

    /// The same levels, each change a ramp over `transition`.
    pub(super) fn ramped(self, transition: f64) -> Steps {
        Steps { transition, ..self }
    }

    /// A switch within [`SWITCH_TOLERANCE`] (0.1 ns) after `time` counts as reached:
    /// switch times are sums such as 3 + 3·1.6 = 7.800000000000001, and a
    /// switch meant to fall on a sample instant must not slip a whole step.
    fn value(&self, time: f64) -> f64 {
        let time = time + SWITCH_TOLERANCE;
        if time.is_nan() || time < self.times[0] {
            return 0.0;
        }
        let passed = self.times.partition_point(|&t| t <= time);
        let level = self.levels.get(passed - 1).copied().unwrap_or(self.after);
        let since = time - self.times[passed - 1];
        if since >= self.transition {
            return level;
        }
        let previous = match passed {
            1 => 0.0,
            _ => self.levels[passed - 2],
        };
        previous + (level - previous) * since / self.transition
    }
}

/// Piecewise linear through (`times`, `values`): 0 before the first point,
/// `after` after the last.
#[derive(Debug, Clone)]
pub(super) struct Polyline {
    pub(super) control: usize,
    pub(super) times: Vec<f64>,
    pub(super) values: Vec<f64>,
    pub(super) after: f64,
}

impl Polyline {
    fn value(&self, time: f64) -> f64 {
        let last = self.times.len() - 1;
        if time.is_nan() || time < self.times[0] {
            return 0.0;
        }
        if time >= self.times[last] {
            return if time == self.times[last] {
                self.values[last]
            } else {
                self.after
            };
        }
        let next = self.times.partition_point(|&t| t <= time);
        let (t0, t1) = (self.times[next - 1], self.times[next]);
        let (v0, v1) = (self.values[next - 1], self.values[next]);
        v0 + (v1 - v0) * (time - t0) / (t1 - t0)
    }
}

/// One sinusoid `amplitude · cos(frequency · τ + phase)` of a multisine, τ
/// the time since the multisine's start.
#[derive(Debug, Clone, Copy)]
pub(super) struct Harmonic {
    pub(super) control: usize,
    pub(super) amplitude: f64,
    /// Angular frequency (rad/s).
    pub(super) frequency: f64,
    pub(super) phase: f64,
}

#[derive(Debug, Clone)]
pub(super) struct Multisine {
    pub(super) start: f64,
    pub(super) end: f64,
    pub(super) harmonics: Vec<Harmonic>,
}

impl Multisine {
    fn add_to(&self, time: f64, deviation: &mut Controls) {
        if time >= self.start && time < self.end {
            let elapsed = time - self.start;
            for harmonic in &self.harmonics {
                deviation[harmonic.control] +=
                    harmonic.amplitude * (harmonic.frequency * elapsed + harmonic.phase).cos();
            }
        }
    }
}
