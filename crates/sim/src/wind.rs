//! Wind model of a scenario: steady wind, discrete gusts and Dryden
//! turbulence, produced as one [`WindSample`] per integration step (the
//! simulator interpolates between samples within a step).
//!
//! The file syntax (`[wind]`, `[[wind.gusts]]`, `[wind.turbulence]`) is in
//! docs/files.md. Steady wind: `speed` and `from_direction` (where it blows
//! FROM, clockwise from north) give the air mass's NED velocity
//! `−speed·(cos ψ, sin ψ, 0)`.
//!
//! **Discrete gusts** (`gust`): the 1−cosine gust of MIL-F-8785C §3.7.3,
//! added to the steady wind. **Dryden turbulence** (`dryden`): the forms of
//! MIL-F-8785C §3.7.2.2, discretised exactly, in body axes; the table
//! (`turbulence`) gives an intensity or explicit σ and L, and the altitude
//! rules (`intensity`) the rest, after MIL-F-8785C Figure 10 as tabulated by
//! Gage (AIAA 2003-5529).
//!
//! The parts, each importing only those listed before it: `check` (field
//! checks), `intensity`, `gust`, `turbulence`, `dryden`.

mod check;
mod dryden;
mod gust;
mod intensity;
mod turbulence;

#[cfg(test)]
mod dryden_tests;
#[cfg(test)]
mod tests;

pub use gust::GustSpec;
pub use turbulence::{FlightConditions, TurbulenceParameters, TurbulenceSpec};

use aeroid_core::error::FieldErrors;
use aeroid_core::random;
use aeroid_core::units::{Dimension, Quantity};
use check::quantity_value;
use dryden::Turbulence;
use gust::Gust;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// The `[wind]` table of a scenario file (every field optional, default calm).
#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct WindSpec {
    /// Steady wind speed (Speed).
    pub speed: Quantity,
    /// Direction the steady wind blows FROM, clockwise from north (Angle).
    pub from_direction: Quantity,
    /// Discrete 1−cosine gusts, `[[wind.gusts]]`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub gusts: Vec<GustSpec>,
    /// Dryden turbulence, `[wind.turbulence]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub turbulence: Option<TurbulenceSpec>,
}

/// Wind at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WindSample {
    /// Steady wind plus gusts: velocity of the air mass in NED, m/s.
    pub ned: Vector3<f64>,
    /// Turbulence u_g, v_g, w_g in body axes, m/s.
    pub body: Vector3<f64>,
}

impl WindSpec {
    /// Collects every problem into `problems` with field paths prefixed "wind.".
    pub fn validate(&self, problems: &mut FieldErrors) {
        let speed = quantity_value(problems, "wind.speed", &self.speed, Dimension::Speed);
        if speed.is_some_and(|speed| speed < 0.0) {
            problems.push(
                "wind.speed",
                "must not be negative (turn from_direction instead)",
            );
        }
        quantity_value(
            problems,
            "wind.from_direction",
            &self.from_direction,
            Dimension::Angle,
        );
        for (index, gust) in self.gusts.iter().enumerate() {
            gust.validate(&format!("wind.gusts[{index}]"), problems);
        }
        if let Some(turbulence) = &self.turbulence {
            turbulence.validate("wind.turbulence", problems);
        }
    }

    /// One sample per step at t_k = k·step, k = 0..count; bit-identical for a seed.
    /// Fails when `validate` finds a problem or the conditions or step are unusable.
    pub fn generate(
        &self,
        conditions: &FlightConditions,
        step: f64,
        count: usize,
        seed: u64,
    ) -> Result<Vec<WindSample>, crate::error::Error> {
        let mut problems = FieldErrors::default();
        self.validate(&mut problems);
        if !problems.is_empty() {
            return Err(crate::error::Error::WindProblems {
                problems: problems.0,
            });
        }
        if !(step.is_finite() && step > 0.0) {
            return Err(crate::error::Error::WindStep { step });
        }
        let steady = self.steady_velocity()?;
        let gusts = self
            .gusts
            .iter()
            .map(Gust::resolve)
            .collect::<Result<Vec<_>, _>>()?;
        let mut rng = random::stream(seed, random::streams::TURBULENCE);
        let mut turbulence = match &self.turbulence {
            Some(spec) => Some(Turbulence::start(spec, conditions, step, &mut rng)?),
            None => None,
        };
        let mut samples = Vec::with_capacity(count);
        for index in 0..count {
            let time = index as f64 * step;
            let gust_sum: Vector3<f64> = gusts.iter().map(|gust| gust.velocity(time)).sum();
            let body = turbulence
                .as_ref()
                .map_or_else(Vector3::zeros, Turbulence::velocity);
            samples.push(WindSample {
                ned: steady + gust_sum,
                body,
            });
            if let Some(turbulence) = turbulence.as_mut() {
                turbulence.advance(&mut rng);
            }
        }
        Ok(samples)
    }

    /// NED velocity of the steady air mass.
    fn steady_velocity(&self) -> aeroid_core::Result<Vector3<f64>> {
        let speed = self.speed.si(Dimension::Speed)?;
        let from = self.from_direction.si(Dimension::Angle)?;
        Ok(Vector3::new(-speed * from.cos(), -speed * from.sin(), 0.0))
    }
}
