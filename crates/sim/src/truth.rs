//! The truth of a run, `truth.toml` beside a simulated record: the
//! aircraft's true aerodynamic parameters by name, the kind of truth, the
//! trim point, the scenario and its seed. Estimator scoring reads it back; a
//! record imported from real flight data has none.
//!
//! Kind `exact`: the parameters are the ones the simulator used, and
//! `local_derivatives` holds the truth model's local derivatives at trim for
//! postulates of another structure (DESIGN.md, "Truth when the structures
//! differ"). Kind `local_derivative`: a flight of one of JSBSim's own aircraft
//! (`aeroid_jsbsim::own`), whose truth is only JSBSim's local derivatives at
//! the trim point; `parameters` is then empty.
//!
//! A scenario that changes parameters during the flight
//! (`[[parameter_changes]]`) leaves `parameters` and `local_derivatives` at
//! their values at the start, so that a fit scored against them reads as
//! for any other flight, and lists the schedule in `parameter_changes`:
//! [`RunTruth::parameter_at`] gives a parameter's value at any time,
//! [`RunTruth::final_parameters`] the values after every change.

use crate::error::{Error, Result};
use crate::scenario::{ParameterChange, Scenario};
use crate::trim::Trim;
use aeroid_core::error::{parse_toml, read_text};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The truth file's name inside a record folder.
pub const TRUTH_FILE: &str = "truth.toml";

/// What kind of truth the parameter values are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TruthKind {
    /// The values the simulator itself used.
    Exact,
    /// Local derivatives of the truth model at the trim point.
    LocalDerivative,
}

/// The trim point the run started from, SI and radians.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrimPoint {
    pub airspeed: f64,
    pub altitude: f64,
    pub flight_path_angle: f64,
    pub heading: f64,
    pub alpha: f64,
    pub beta: f64,
    pub pitch: f64,
    /// Trim controls by name (`elevator`, …, `throttle`).
    pub controls: BTreeMap<String, f64>,
}

/// The truth of one simulated run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunTruth {
    pub kind: TruthKind,
    pub scenario: String,
    pub seed: u64,
    pub aircraft: String,
    pub trim: TrimPoint,
    /// The truth model's kind; a postulate of the same kind is scored
    /// against `parameters` (exact), any other against `local_derivatives`.
    #[serde(default)]
    pub model: crate::aero::ModelKind,
    /// True aerodynamic parameters by name (`CL_alpha`, `Cm_q`, …).
    pub parameters: BTreeMap<String, f64>,
    /// Local linear derivatives of the truth model at the trim point
    /// (`AeroModel::local_derivatives`), for postulates of another structure.
    #[serde(default)]
    pub local_derivatives: BTreeMap<String, f64>,
    /// Changes of `parameters` during the flight, in time order: from
    /// `time` on, `parameter` is `value`. Absent (empty) when none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub parameter_changes: Vec<ParameterChange>,
}

impl RunTruth {
    /// The exact truth of a scenario flown from `trim`.
    pub fn exact(scenario: &Scenario, trim: &Trim) -> RunTruth {
        let controls = crate::state::Control::ALL
            .iter()
            .map(|c| (c.name().to_string(), trim.controls[c.index()]))
            .collect();
        let parameters = scenario
            .aircraft
            .aero
            .parameters
            .iter()
            .map(|(name, value)| (name.to_string(), value))
            .collect();
        RunTruth {
            local_derivatives: trim_derivatives(scenario, trim),
            parameter_changes: scenario.parameter_changes.clone(),
            ..RunTruth::exact_parameters(
                scenario,
                (trim.alpha, trim.beta, trim.pitch, controls),
                scenario.aircraft.aero.kind,
                parameters,
            )
        }
    }

    /// The exact truth of a scenario whose model of kind `model` flew
    /// `parameters` from the scenario's trim condition with the attitude and
    /// controls (α, β, θ, controls) `trimmed`: no local derivatives, no
    /// parameter changes.
    pub fn exact_parameters(
        scenario: &Scenario,
        trimmed: (f64, f64, f64, BTreeMap<String, f64>),
        model: crate::aero::ModelKind,
        parameters: BTreeMap<String, f64>,
    ) -> RunTruth {
        let (alpha, beta, pitch, controls) = trimmed;
        RunTruth {
            kind: TruthKind::Exact,
            scenario: scenario.name.clone(),
            seed: scenario.seed,
            aircraft: scenario.aircraft.name.clone(),
            trim: TrimPoint {
                airspeed: scenario.trim.airspeed,
                altitude: scenario.trim.altitude,
                flight_path_angle: scenario.trim.flight_path_angle,
                heading: scenario.trim.heading,
                alpha,
                beta,
                pitch,
                controls,
            },
            model,
            parameters,
            local_derivatives: Default::default(),
            parameter_changes: Vec::new(),
        }
    }

    /// The value of parameter `name` at time `t` (s): the last change at or
    /// before `t`, else the value at the start; None for a name `parameters`
    /// does not hold.
    pub fn parameter_at(&self, name: &str, t: f64) -> Option<f64> {
        let start = *self.parameters.get(name)?;
        Some(
            self.parameter_changes
                .iter()
                .rev()
                .find(|c| c.parameter == name && c.time <= t)
                .map_or(start, |c| c.value),
        )
    }

    /// The parameters after every change: the values at the end of the flight.
    pub fn final_parameters(&self) -> BTreeMap<String, f64> {
        let mut parameters = self.parameters.clone();
        for change in &self.parameter_changes {
            if let Some(value) = parameters.get_mut(&change.parameter) {
                *value = change.value;
            }
        }
        parameters
    }

    /// The truth value of a parameter of a postulated model of `kind`, and what kind of truth it is.
    pub fn value_for(&self, name: &str, kind: crate::aero::ModelKind) -> Option<(f64, TruthKind)> {
        let exact = (kind == self.model)
            .then(|| self.parameters.get(name))
            .flatten();
        exact.map(|&v| (v, self.kind)).or_else(|| {
            self.local_derivatives
                .get(name)
                .map(|&v| (v, TruthKind::LocalDerivative))
        })
    }

    pub fn write(&self, path: &Path) -> Result<()> {
        let text = toml::to_string(self).map_err(|e| Error::Serialize {
            reason: e.to_string(),
        })?;
        Ok(aeroid_core::atomic::write_text(path, &text)?)
    }

    pub fn read(path: &Path) -> Result<RunTruth> {
        Ok(parse_toml(path, &read_text(path)?)?)
    }
}

/// Local derivatives of the scenario aircraft's aerodynamic model at the trim point.
fn trim_derivatives(scenario: &Scenario, trim: &Trim) -> BTreeMap<String, f64> {
    let aero = &scenario.aircraft.aero;
    let air = scenario.environment.atmosphere.at(scenario.trim.altitude);
    let at = crate::aero::AeroInput {
        alpha: trim.alpha,
        beta: trim.beta,
        airspeed: scenario.trim.airspeed,
        mach: scenario.trim.airspeed / air.speed_of_sound,
        controls: trim.controls,
        chi: aero.steady_separation(trim.alpha),
        ..Default::default()
    };
    aero.local_derivatives(&at).into_iter().collect()
}
