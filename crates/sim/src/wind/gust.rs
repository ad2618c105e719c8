//! Discrete gusts (`[[wind.gusts]]`): the 1−cosine gust of MIL-F-8785C
//! §3.7.3, written in time:
//! `u(t) = A/2·(1 − cos(2π(t − start)/duration))` for
//! `start ≤ t ≤ start + duration`, zero outside. `direction` names where the
//! gust air moves TOWARDS ("up" is an updraft: a negative NED-down component).
//! Gusts add to the steady wind in [`WindSample::ned`](super::WindSample::ned).

use super::check::{FieldCheck, is_not_negative, is_positive, require};
use aeroid_core::error::FieldErrors;
use aeroid_core::units::{Dimension, Quantity};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// One `[[wind.gusts]]` entry: a 1−cosine gust.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GustSpec {
    /// Time the gust begins (Time, default 0).
    #[serde(default)]
    pub start: Quantity,
    /// Length of the gust in time (Time, > 0).
    pub duration: Quantity,
    /// Peak gust speed (Speed, ≥ 0).
    pub amplitude: Quantity,
    /// Where the gust air moves towards: up, down, north, east, south or west.
    pub direction: String,
}

/// Names of the gust directions, for messages.
const GUST_DIRECTIONS: &str = "up, down, north, east, south, west";

/// Unit NED vector of a gust direction (where the gust air moves towards).
fn gust_direction(name: &str) -> Option<Vector3<f64>> {
    let vector = match name.trim().to_ascii_lowercase().as_str() {
        "up" => Vector3::new(0.0, 0.0, -1.0),
        "down" => Vector3::new(0.0, 0.0, 1.0),
        "north" => Vector3::new(1.0, 0.0, 0.0),
        "south" => Vector3::new(-1.0, 0.0, 0.0),
        "east" => Vector3::new(0.0, 1.0, 0.0),
        "west" => Vector3::new(0.0, -1.0, 0.0),
        _ => return None,
    };
    Some(vector)
}

impl GustSpec {
    /// Records the problems of this gust under `path` (e.g. "wind.gusts[1]").
    pub(super) fn validate(&self, path: &str, problems: &mut FieldErrors) {
        let field = |name: &str| format!("{path}.{name}");
        let checks: [FieldCheck; 3] = [
            (
                "start",
                &self.start,
                Dimension::Time,
                is_not_negative,
                "must not be negative",
            ),
            (
                "duration",
                &self.duration,
                Dimension::Time,
                is_positive,
                "must be positive",
            ),
            (
                "amplitude",
                &self.amplitude,
                Dimension::Speed,
                is_not_negative,
                "must not be negative (choose the opposite direction instead)",
            ),
        ];
        for (name, quantity, dimension, condition, rule) in checks {
            require(problems, &field(name), quantity, dimension, condition, rule);
        }
        if gust_direction(&self.direction).is_none() {
            let message = format!(
                "unknown direction '{}'; known: {GUST_DIRECTIONS}",
                self.direction
            );
            problems.push(field("direction"), message);
        }
    }
}

/// A gust in SI units.
pub(super) struct Gust {
    start: f64,
    duration: f64,
    amplitude: f64,
    direction: Vector3<f64>,
}

impl Gust {
    pub(super) fn resolve(spec: &GustSpec) -> Result<Gust, crate::error::Error> {
        Ok(Gust {
            start: spec.start.si(Dimension::Time)?,
            duration: spec.duration.si(Dimension::Time)?,
            amplitude: spec.amplitude.si(Dimension::Speed)?,
            direction: gust_direction(&spec.direction).ok_or_else(|| {
                crate::error::Error::WindName {
                    kind: "gust direction",
                    name: spec.direction.clone(),
                }
            })?,
        })
    }

    /// NED velocity of the gust at `time`: A/2·(1 − cos(2π(t − start)/duration)) inside the window.
    pub(super) fn velocity(&self, time: f64) -> Vector3<f64> {
        let elapsed = time - self.start;
        if !(0.0..=self.duration).contains(&elapsed) {
            return Vector3::zeros();
        }
        let phase = std::f64::consts::TAU * elapsed / self.duration;
        self.direction * (0.5 * self.amplitude * (1.0 - phase.cos()))
    }
}
