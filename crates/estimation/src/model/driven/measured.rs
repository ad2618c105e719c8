//! What the record measures in place of part of the model ([`Ambient`]):
//! the air density ρ (the `density` channel, or 2·q̄/V² from the dynamic
//! pressure and the airspeed) instead of the ISA's at the altitude, the
//! Mach number (the `mach` channel) instead of V over the ISA's speed of
//! sound at the altitude, the
//! thrust (the `thrust` channel, along the thrust line) instead of
//! δT·Tmax·(ρ/ρ0)ⁿ, and α̇ of the separation equation from the measured α
//! (local polynomial differentiation, not across a control step); and
//! the air, thrust and α̇ one evaluation takes ([`Surroundings`]).

use crate::error::{Error, Result};
use crate::reconstruction::control_steps;
use aeroid_record::FlightRecord;
use aeroid_record::prep::differentiation::Differentiator;
use aeroid_sim::atmosphere::{Air, Atmosphere, SEA_LEVEL_DENSITY};

/// What the record measures that replaces part of the model at one
/// instant: the air density ρ (kg/m³, the `density` channel) instead of
/// the ISA's at the altitude, and the thrust (N, the `thrust` channel,
/// along the aircraft's thrust line) instead of the throttle and engine
/// model δT·Tmax·(ρ/ρ0)ⁿ, and the Mach number (the `mach` channel)
/// instead of V/a; None where the record has no such channel. And
/// the derivative of the measured α (rad/s) for a stall model whose
/// separation takes it (`measured_alpha_dot`), None for any other.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Ambient {
    pub density: Option<f64>,
    pub thrust: Option<f64>,
    pub mach: Option<f64>,
    pub alpha_dot: Option<f64>,
}

impl Ambient {
    /// The values a fraction θ into a step from `self` to `end`: linear,
    /// as the measured pseudo-controls ([`between`](super::memo::between)).
    pub(super) fn between(self, end: Ambient, theta: f64) -> Ambient {
        let mix = |a: Option<f64>, b: Option<f64>| a.zip(b).map(|(a, b)| a + (b - a) * theta);
        Ambient {
            density: mix(self.density, end.density),
            thrust: mix(self.thrust, end.thrust),
            mach: mix(self.mach, end.mach),
            alpha_dot: mix(self.alpha_dot, end.alpha_dot),
        }
    }

    /// The air at `altitude`: the atmosphere's, its density (and ln(ρ/ρ0),
    /// which the thrust lapse reads) the measured one when there is one,
    /// and the measured Mach number when there is one. Temperature,
    /// pressure and speed of sound stay the atmosphere's at the altitude.
    pub fn air(self, atmosphere: &Atmosphere, altitude: f64) -> Air {
        let mut air = atmosphere.at(altitude);
        air.mach = self.mach;
        if let Some(density) = self.density {
            air.density = density;
            air.log_density_ratio = (density / SEA_LEVEL_DENSITY).ln();
        }
        air
    }

    /// The air at `altitude` ([`Ambient::air`]), the measured thrust and α̇.
    pub(super) fn surroundings(self, atmosphere: &Atmosphere, altitude: f64) -> Surroundings {
        Surroundings {
            air: self.air(atmosphere, altitude),
            thrust: self.thrust,
            alpha_dot: self.alpha_dot,
        }
    }
}

/// The air, the measured thrust (None: the propulsion model's) and the
/// measured α̇ (None: the state's) an evaluation of the model takes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(super) struct Surroundings {
    pub(super) air: Air,
    pub(super) thrust: Option<f64>,
    pub(super) alpha_dot: Option<f64>,
}

impl From<Air> for Surroundings {
    fn from(air: Air) -> Surroundings {
        Surroundings {
            air,
            thrust: None,
            alpha_dot: None,
        }
    }
}

/// The record's measured quantities the model takes instead of its own
/// ([`Ambient`]).
pub const MEASURED_QUANTITIES: [&str; 3] = ["density", "thrust", "mach"];

/// The channels that stand in for a missing `altitude` pseudo-control, in
/// order: pressure altitude, else the density altitude of the measured
/// density, else of the density 2·q̄/V² from the dynamic pressure and the
/// airspeed ([`DrivenSimulation::from_record`](super::DrivenSimulation::from_record)).
pub const ALTITUDE_SUBSTITUTES: [&str; 3] = ["pressure_altitude", "density", "dynamic_pressure"];

/// The record's measured density, thrust and Mach on the grid (linear between
/// samples, as the measured pseudo-controls), and the notes saying so.
pub(super) fn measured_ambient(
    record: &FlightRecord,
    times: &[f64],
) -> Result<(Vec<Ambient>, Vec<String>)> {
    let mut ambient = vec![Ambient::default(); times.len()];
    let mut notes = Vec::new();
    let [density, thrust, mach] = MEASURED_QUANTITIES;
    if let Ok(channel) = record.channel(density) {
        for (into, value) in ambient.iter_mut().zip(channel.values_at(times)?) {
            into.density = Some(value);
        }
        notes.push(
            "air density: the record's 'density' channel, not the ISA at the altitude".into(),
        );
    } else if ["altitude", ALTITUDE_SUBSTITUTES[0]]
        .iter()
        .all(|name| record.channel(name).is_err())
        && let (Ok(pressure), Ok(airspeed)) = (
            record.channel(ALTITUDE_SUBSTITUTES[2]),
            record.channel("airspeed"),
        )
    {
        let speeds = airspeed.values_at(times)?;
        for ((into, q), v) in ambient
            .iter_mut()
            .zip(pressure.values_at(times)?)
            .zip(speeds)
        {
            into.density = Some(2.0 * q / (v * v));
        }
        notes.push(
            "air density: 2·q̄/V² from the record's 'dynamic_pressure' and 'airspeed' channels (it has no density or altitude channel)".into(),
        );
    }
    if let Ok(channel) = record.channel(thrust) {
        for (into, value) in ambient.iter_mut().zip(channel.values_at(times)?) {
            into.thrust = Some(value);
        }
        notes.push(
            "thrust: the record's 'thrust' channel, along the aircraft's thrust line, not the throttle and engine model"
                .into(),
        );
    }
    if let Ok(channel) = record.channel(mach) {
        for (into, value) in ambient.iter_mut().zip(channel.values_at(times)?) {
            into.mach = Some(value);
        }
        notes.push(
            "Mach: the record's 'mach' channel, not the airspeed over the ISA's speed of sound at the altitude"
                .into(),
        );
    }
    let bad = |value: Option<f64>, positive: bool| {
        value.is_some_and(|v| !v.is_finite() || (positive && v <= 0.0))
    };
    for (&t, a) in times.iter().zip(&ambient) {
        if bad(a.density, true) {
            return Err(Error::Data {
                reason: format!(
                    "the measured air density at t = {t:.3} s is {}: it must be finite and positive (channel '{density}', or 2·q̄/V² from 'dynamic_pressure' and 'airspeed')",
                    a.density.unwrap_or(f64::NAN)
                ),
            });
        }
        if bad(a.mach, false) || a.mach.is_some_and(|m| m < 0.0) {
            return Err(Error::Data {
                reason: format!(
                    "the record's '{mach}' channel is {} at t = {t:.3} s: it must be finite and not negative",
                    a.mach.unwrap_or(f64::NAN)
                ),
            });
        }
        if bad(a.thrust, false) {
            return Err(Error::Data {
                reason: format!(
                    "the record's '{thrust}' channel has no finite value at t = {t:.3} s"
                ),
            });
        }
    }
    Ok((ambient, notes))
}

/// The smoothed derivative of the record's α, written into `ambient` at
/// `times`, and the note saying so: the project's local polynomial
/// differentiator ([`Differentiator`], its default: degree 4, ±0.1 s) with
/// no window across a control step ([`control_steps`], as the regression
/// methods differentiate), linear between its samples and, where it has
/// none (the first and last half-window of the record, and beside a
/// step), bridged from its neighbours or held at the ends.
pub(super) fn measured_alpha_dot(
    record: &FlightRecord,
    times: &[f64],
    ambient: &mut [Ambient],
) -> Result<String> {
    let alpha = record.channel("alpha").map_err(|_| {
        Error::Data { reason: "the stall model takes α̇ from the measured α (`alpha_dot = \"measured\"`), but the record has no 'alpha' channel".into(), }
    })?;
    let differentiator = Differentiator::default();
    let steps = control_steps(record);
    let derivative = differentiator.differentiate_with_breaks(alpha, &steps);
    for (into, value) in ambient.iter_mut().zip(derivative.values_at(times)?) {
        into.alpha_dot = Some(value);
    }
    let m = differentiator.half_window(alpha.rate);
    Ok(format!(
        "α̇ of the separation equation: the derivative of the record's 'alpha' (local polynomial, degree {}, ±{m} samples at {} Hz, not across {} control steps; held over the first and last {:.2} s)",
        differentiator.degree,
        aeroid_record::rate_text(alpha.rate),
        steps.len(),
        m as f64 / alpha.rate
    ))
}
