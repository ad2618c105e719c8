//! A stability augmentation: the flight-control computer of an aircraft
//! that cannot be flown open loop (Jategaonkar, "Flight Vehicle System
//! Identification", 2nd ed., ch. 9, "Unstable Aircraft Identification").
//! It moves one control by u = u_pilot + Σ_i K_i·(x_i − x_i,trim), the
//! flight variables x_i read at the start of each frame and the command
//! held over it, so the recorded control is the total deflection and the
//! record is what a flight test of an unstable aircraft gives: the inputs
//! correlated with the motion through the loop.
//!
//! A scenario names it as `[feedback]` for the 6-DOF simulator, with gains
//! on the flight variables `alpha`, `beta` (rad), `p`, `q`, `r` (rad/s),
//! `roll`, `pitch` (rad) and `airspeed` (m/s), or as `[linear.feedback]`
//! for a linear model, with gains on the model's states (docs/files.md).

use crate::dynamics::Evaluation;
use crate::state::{self, Control, StateVector};
use aeroid_core::error::FieldErrors;
use aeroid_core::units::{Dimension, Quantity};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// `[feedback]` or `[linear.feedback]` as written: the control moved, the
/// gain on each variable (control units per variable unit) and the frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeedbackSpec {
    /// The control (or the linear model's input) the augmentation moves.
    pub control: String,
    /// The gain on each named variable.
    pub gains: BTreeMap<String, f64>,
    /// The computer's frame: a multiple of the scenario's step (default the step).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame: Option<Quantity>,
}

/// A validated feedback table.
#[derive(Debug, Clone, PartialEq)]
pub struct Feedback {
    pub control: String,
    pub gains: BTreeMap<String, f64>,
    /// The frame in scenario steps (at least 1).
    pub frame_steps: usize,
}

impl Feedback {
    /// Checks a table (its problems named under `key`): finite gains and a
    /// frame that is a whole number of steps `step`.
    pub fn read(
        spec: &FeedbackSpec,
        step: f64,
        key: &str,
        problems: &mut FieldErrors,
    ) -> Option<Feedback> {
        let mut valid = true;
        for (variable, gain) in &spec.gains {
            if !gain.is_finite() {
                problems.push(format!("{key}.gains.{variable}"), "must be finite");
                valid = false;
            }
        }
        let frame_steps = match &spec.frame {
            None => 1,
            Some(frame) => match frame.si(Dimension::Time) {
                Ok(frame) => {
                    let steps = (frame / step).round();
                    if !(steps >= 1.0
                        && (frame - steps * step).abs() <= 1e-9 * frame.abs().max(1.0))
                    {
                        problems.push(
                            format!("{key}.frame"),
                            format!("must be a positive multiple of the step ({step} s)"),
                        );
                        valid = false;
                    }
                    steps.max(1.0) as usize
                }
                Err(message) => {
                    problems.push(format!("{key}.frame"), message);
                    valid = false;
                    1
                }
            },
        };
        valid.then(|| Feedback {
            control: spec.control.clone(),
            gains: spec.gains.clone(),
            frame_steps,
        })
    }

    /// The 6-DOF form: the control and the variables by name, checked
    /// (problems under `feedback`).
    pub fn for_six_dof(&self, problems: &mut FieldErrors) -> Option<Augmentation> {
        let control = Control::ALL.into_iter().find(|c| c.name() == self.control);
        if control.is_none() {
            problems.push(
                "feedback.control",
                format!(
                    "'{}' is not a control (elevator, aileron, rudder, flap, throttle)",
                    self.control
                ),
            );
        }
        let mut gains = Vec::new();
        for (name, &gain) in &self.gains {
            match FlightVariable::ALL.into_iter().find(|v| v.name() == name) {
                Some(variable) => gains.push((variable, gain)),
                None => problems.push(
                    format!("feedback.gains.{name}"),
                    format!(
                        "is not a flight variable the computer reads ({})",
                        FlightVariable::ALL.map(FlightVariable::name).join(", ")
                    ),
                ),
            }
        }
        (gains.len() == self.gains.len()).then_some(())?;
        Some(Augmentation {
            control: control?,
            gains,
            frame_steps: self.frame_steps,
        })
    }
}

/// A flight variable the 6-DOF flight-control computer reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlightVariable {
    Alpha,
    Beta,
    P,
    Q,
    R,
    Roll,
    Pitch,
    Airspeed,
}

impl FlightVariable {
    pub const ALL: [FlightVariable; 8] = [
        FlightVariable::Alpha,
        FlightVariable::Beta,
        FlightVariable::P,
        FlightVariable::Q,
        FlightVariable::R,
        FlightVariable::Roll,
        FlightVariable::Pitch,
        FlightVariable::Airspeed,
    ];

    pub fn name(self) -> &'static str {
        match self {
            FlightVariable::Alpha => "alpha",
            FlightVariable::Beta => "beta",
            FlightVariable::P => "p",
            FlightVariable::Q => "q",
            FlightVariable::R => "r",
            FlightVariable::Roll => "roll",
            FlightVariable::Pitch => "pitch",
            FlightVariable::Airspeed => "airspeed",
        }
    }

    /// Its value at state `x` with the evaluation there (air data).
    pub fn value(self, x: &StateVector, evaluation: &Evaluation) -> f64 {
        match self {
            FlightVariable::Alpha => evaluation.air_data.alpha,
            FlightVariable::Beta => evaluation.air_data.beta,
            FlightVariable::P => x[state::P],
            FlightVariable::Q => x[state::Q],
            FlightVariable::R => x[state::R],
            FlightVariable::Roll => state::euler(x).roll,
            FlightVariable::Pitch => state::euler(x).pitch,
            FlightVariable::Airspeed => evaluation.air_data.airspeed,
        }
    }
}

/// The 6-DOF stability augmentation, resolved.
#[derive(Debug, Clone, PartialEq)]
pub struct Augmentation {
    pub control: Control,
    pub gains: Vec<(FlightVariable, f64)>,
    pub frame_steps: usize,
}

impl Augmentation {
    /// The variables' values at state `x` (with its evaluation): at trim,
    /// the reference the command is taken from.
    pub fn values(&self, x: &StateVector, evaluation: &Evaluation) -> Vec<f64> {
        self.gains
            .iter()
            .map(|(v, _)| v.value(x, evaluation))
            .collect()
    }

    /// The command Σ K_i·(x_i − x_i,trim) at state `x` (with its
    /// evaluation), the trim values `reference` ([`Augmentation::values`]).
    pub fn command(&self, x: &StateVector, evaluation: &Evaluation, reference: &[f64]) -> f64 {
        self.gains
            .iter()
            .zip(reference)
            .map(|((v, gain), trim)| gain * (v.value(x, evaluation) - trim))
            .sum()
    }
}
