//! The smoothed histories of estimation before modelling on the filter's
//! grid ([`Smoothed`]): the states x_{k|N} and their standard deviations
//! √diag P_{k|N}, the coefficients as an estimate's histories and as CSV,
//! CL = CX·sin α − CZ·cos α and CD = −CX·cos α − CZ·sin α for the wind axes.

use crate::error::Result;
use crate::estimate::History;
use crate::model::coefficient_states::{self, COEFFICIENT_NAMES, H, P, PHI, PSI, THETA, U};
use nalgebra::DVector;
use std::path::Path;

/// The smoothed histories on the filter's grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Smoothed {
    /// Grid times (s).
    pub times: Vec<f64>,
    /// Smoothed states x_{k|N} (the layout of
    /// [`crate::model::coefficient_states`]).
    pub states: Vec<DVector<f64>>,
    /// Their standard deviations √diag P_{k|N}.
    pub deviations: Vec<DVector<f64>>,
    /// The observations compared, in order.
    pub observations: Vec<String>,
    /// What the pass found (observations used and absent, how well each
    /// coefficient history is determined).
    pub notes: Vec<String>,
}

/// The history columns of [`Smoothed::write_csv`]: name, unit, value of a state.
type Column = (&'static str, &'static str, fn(&[f64]) -> f64);

const HISTORY_COLUMNS: &[Column] = &[
    ("CX", "-", |x| x[coefficient_states::coefficient(0)]),
    ("CY", "-", |x| x[coefficient_states::coefficient(1)]),
    ("CZ", "-", |x| x[coefficient_states::coefficient(2)]),
    ("Cl", "-", |x| x[coefficient_states::coefficient(3)]),
    ("Cm", "-", |x| x[coefficient_states::coefficient(4)]),
    ("Cn", "-", |x| x[coefficient_states::coefficient(5)]),
    ("CL", "-", |x| wind_axes(x).0),
    ("CD", "-", |x| wind_axes(x).1),
    ("airspeed", "m/s", |x| speed(x)),
    ("alpha", "rad", |x| x[U + 2].atan2(x[U])),
    ("beta", "rad", |x| {
        (x[U + 1] / speed(x)).clamp(-1.0, 1.0).asin()
    }),
    ("p", "rad/s", |x| x[P]),
    ("q", "rad/s", |x| x[P + 1]),
    ("r", "rad/s", |x| x[P + 2]),
    ("roll", "rad", |x| x[PHI]),
    ("pitch", "rad", |x| x[THETA]),
    ("yaw", "rad", |x| x[PSI]),
    ("altitude", "m", |x| x[H]),
];

pub(super) fn speed(x: &[f64]) -> f64 {
    (x[U] * x[U] + x[U + 1] * x[U + 1] + x[U + 2] * x[U + 2]).sqrt()
}

/// (CL, CD) of a state: CL = CX·sin α − CZ·cos α, CD = −CX·cos α − CZ·sin α.
pub(super) fn wind_axes(x: &[f64]) -> (f64, f64) {
    let (sin, cos) = x[U + 2].atan2(x[U]).sin_cos();
    let (cx, cz) = (
        x[coefficient_states::coefficient(0)],
        x[coefficient_states::coefficient(2)],
    );
    (cx * sin - cz * cos, -cx * cos - cz * sin)
}

impl Smoothed {
    /// The six smoothed body-axis coefficients (CX … Cn) with their
    /// standard deviations, as an estimate's histories.
    pub fn coefficient_histories(&self) -> Vec<History> {
        COEFFICIENT_NAMES
            .iter()
            .enumerate()
            .map(|(i, name)| {
                let state = coefficient_states::coefficient(i);
                History {
                    name: (*name).to_string(),
                    times: self.times.clone(),
                    values: self.states.iter().map(|x| x[state]).collect(),
                    sigma: self.deviations.iter().map(|d| d[state]).collect(),
                }
            })
            .collect()
    }

    /// Writes the histories as CSV: time, the six body-axis coefficients,
    /// CL, CD, the air data, rates, attitude and altitude, then the
    /// standard deviation of each coefficient (`sigma_CX` …), header
    /// `name [unit]` as the truth trace's, so that a plot can lay one over
    /// the other.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        let io_error = |source: std::io::Error| aeroid_core::error::write_error(path, source);
        let mut writer = csv::Writer::from_path(path).map_err(|e| io_error(e.into()))?;
        let mut header = vec!["time [s]".to_string()];
        header.extend(HISTORY_COLUMNS.iter().map(|(n, u, _)| format!("{n} [{u}]")));
        header.extend(COEFFICIENT_NAMES.iter().map(|n| format!("sigma_{n} [-]")));
        writer
            .write_record(&header)
            .map_err(|e| io_error(e.into()))?;
        for ((t, x), sigma) in self.times.iter().zip(&self.states).zip(&self.deviations) {
            let mut row = vec![t.to_string()];
            row.extend(
                HISTORY_COLUMNS
                    .iter()
                    .map(|(_, _, f)| f(x.as_slice()).to_string()),
            );
            row.extend((0..6).map(|i| sigma[coefficient_states::coefficient(i)].to_string()));
            writer.write_record(&row).map_err(|e| io_error(e.into()))?;
        }
        Ok(writer.flush().map_err(io_error)?)
    }

    /// The smoothed value of a body-axis coefficient (0 CX … 5 Cn) at each grid point.
    pub fn coefficient(&self, i: usize) -> Vec<f64> {
        self.states
            .iter()
            .map(|x| x[coefficient_states::coefficient(i)])
            .collect()
    }
}
