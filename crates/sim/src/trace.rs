//! The truth trace: the simulator's output at every integration step — states,
//! Euler angles, air data, controls, wind, the aerodynamic coefficients the
//! model actually used, the separation point χ, specific forces and angular
//! accelerations. Written to CSV with a header naming every column and its
//! unit (`alpha [rad]`).

use crate::dynamics::Evaluation;
use crate::error::Result;
use crate::state::{self, EulerAngles, StateVector};
use crate::wind::WindSample;
use std::path::Path;

/// One row of the truth trace.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthSample {
    pub time: f64,
    pub state: StateVector,
    pub euler: EulerAngles,
    pub evaluation: Evaluation,
    pub wind: WindSample,
}

impl TruthSample {
    pub fn new(time: f64, state: StateVector, evaluation: Evaluation, wind: WindSample) -> Self {
        TruthSample {
            time,
            state,
            euler: state::euler(&state),
            evaluation,
            wind,
        }
    }
}

/// A named column: name, unit and how to read it from a sample.
pub struct Column {
    pub name: &'static str,
    pub unit: &'static str,
    pub value: fn(&TruthSample) -> f64,
}

macro_rules! column {
    ($name:literal, $unit:literal, |$s:ident| $body:expr) => {
        Column {
            name: $name,
            unit: $unit,
            value: |$s: &TruthSample| $body,
        }
    };
}

/// Every column of the truth trace, in CSV order.
pub const COLUMNS: &[Column] = &[
    column!("time", "s", |s| s.time),
    column!("u", "m/s", |s| s.state[state::U]),
    column!("v", "m/s", |s| s.state[state::V]),
    column!("w", "m/s", |s| s.state[state::W]),
    column!("p", "rad/s", |s| s.state[state::P]),
    column!("q", "rad/s", |s| s.state[state::Q]),
    column!("r", "rad/s", |s| s.state[state::R]),
    column!("q0", "-", |s| s.state[state::Q0]),
    column!("q1", "-", |s| s.state[state::Q0 + 1]),
    column!("q2", "-", |s| s.state[state::Q0 + 2]),
    column!("q3", "-", |s| s.state[state::Q0 + 3]),
    column!("roll", "rad", |s| s.euler.roll),
    column!("pitch", "rad", |s| s.euler.pitch),
    column!("yaw", "rad", |s| s.euler.yaw),
    column!("north", "m", |s| s.state[state::NORTH]),
    column!("east", "m", |s| s.state[state::EAST]),
    column!("altitude", "m", |s| -s.state[state::DOWN]),
    column!("north_rate", "m/s", |s| s.evaluation.derivative
        [state::NORTH]),
    column!("east_rate", "m/s", |s| s.evaluation.derivative[state::EAST]),
    column!("climb_rate", "m/s", |s| -s.evaluation.derivative
        [state::DOWN]),
    column!("airspeed", "m/s", |s| s.evaluation.air_data.airspeed),
    column!("alpha", "rad", |s| s.evaluation.air_data.alpha),
    column!("beta", "rad", |s| s.evaluation.air_data.beta),
    column!("alpha_dot", "rad/s", |s| s.evaluation.alpha_dot),
    column!("beta_dot", "rad/s", |s| s.evaluation.beta_dot),
    column!("mach", "-", |s| s.evaluation.air_data.mach),
    column!("dynamic_pressure", "Pa", |s| s
        .evaluation
        .air_data
        .dynamic_pressure),
    column!("temperature", "K", |s| s.evaluation.air.temperature),
    column!("pressure", "Pa", |s| s.evaluation.air.pressure),
    column!("density", "kg/m^3", |s| s.evaluation.air.density),
    column!("elevator", "rad", |s| s.evaluation.controls[0]),
    column!("aileron", "rad", |s| s.evaluation.controls[1]),
    column!("rudder", "rad", |s| s.evaluation.controls[2]),
    column!("flap", "rad", |s| s.evaluation.controls[3]),
    column!("throttle", "-", |s| s.evaluation.controls[4]),
    column!("thrust", "N", |s| s.evaluation.thrust),
    column!("wind_north", "m/s", |s| s.wind.ned.x),
    column!("wind_east", "m/s", |s| s.wind.ned.y),
    column!("wind_down", "m/s", |s| s.wind.ned.z),
    column!("turbulence_u", "m/s", |s| s.wind.body.x),
    column!("turbulence_v", "m/s", |s| s.wind.body.y),
    column!("turbulence_w", "m/s", |s| s.wind.body.z),
    column!("chi", "-", |s| s.evaluation.chi),
    column!("CX", "-", |s| s.evaluation.coefficients.force.x),
    column!("CY", "-", |s| s.evaluation.coefficients.force.y),
    column!("CZ", "-", |s| s.evaluation.coefficients.force.z),
    column!("CL", "-", |s| s.evaluation.coefficients.lift),
    column!("CD", "-", |s| s.evaluation.coefficients.drag),
    column!("Cl", "-", |s| s.evaluation.coefficients.moment.x),
    column!("Cm", "-", |s| s.evaluation.coefficients.moment.y),
    column!("Cn", "-", |s| s.evaluation.coefficients.moment.z),
    column!("specific_force_x", "m/s^2", |s| s
        .evaluation
        .specific_force
        .x),
    column!("specific_force_y", "m/s^2", |s| s
        .evaluation
        .specific_force
        .y),
    column!("specific_force_z", "m/s^2", |s| s
        .evaluation
        .specific_force
        .z),
    column!("p_dot", "rad/s^2", |s| s.evaluation.angular_acceleration.x),
    column!("q_dot", "rad/s^2", |s| s.evaluation.angular_acceleration.y),
    column!("r_dot", "rad/s^2", |s| s.evaluation.angular_acceleration.z),
];

/// The simulator's output, one sample per integration step.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TruthTrace {
    pub scenario: String,
    pub step: f64,
    pub samples: Vec<TruthSample>,
}

impl TruthTrace {
    /// The column with this name, or an error listing the known names.
    pub fn column(name: &str) -> Result<&'static Column> {
        Ok(COLUMNS
            .iter()
            .find(|c| c.name == name)
            .ok_or_else(|| aeroid_core::Error::Unknown {
                kind: "truth column",
                name: name.to_string(),
                known: COLUMNS.iter().map(|c| c.name.to_string()).collect(),
            })?)
    }

    /// All values of a named column.
    pub fn values(&self, name: &str) -> Result<Vec<f64>> {
        let column = Self::column(name)?;
        Ok(self.samples.iter().map(column.value).collect())
    }

    pub fn duration(&self) -> f64 {
        self.samples.last().map_or(0.0, |s| s.time)
    }

    /// Writes the trace as CSV, header `name [unit]`, values in shortest round-trip form.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        let io_error = |source: std::io::Error| aeroid_core::error::write_error(path, source);
        let mut writer = csv::Writer::from_path(path).map_err(|e| io_error(e.into()))?;
        writer
            .write_record(COLUMNS.iter().map(|c| format!("{} [{}]", c.name, c.unit)))
            .map_err(|e| io_error(e.into()))?;
        for sample in &self.samples {
            writer
                .write_record(COLUMNS.iter().map(|c| (c.value)(sample).to_string()))
                .map_err(|e| io_error(e.into()))?;
        }
        Ok(writer.flush().map_err(io_error)?)
    }
}
