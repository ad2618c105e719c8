//! The record's channels estimation before modelling takes: the
//! observations (Wang et al. 2012, Eq. 8), needed and optional, a refusal
//! naming every missing one; the controls the terms read; the thrust
//! (the `thrust` channel, else the throttle); the altitude (else the
//! pressure altitude); the heading unwrapped.

use super::METHOD;
use super::settings::SmoothedRegressionSettings;
use crate::error::{Error, Result};
use crate::estimator::{MissingChannel, Refusal};
use crate::methods::common::regression::Plan;
use crate::model::coefficient_states::Output;
use crate::model::driven::ALTITUDE_SUBSTITUTES;
use crate::structure::ModelStructure;
use aeroid_record::FlightRecord;
use aeroid_sim::aero::Regressor;
use aeroid_sim::state::Control;

/// What a record and structure need of channels: (name, purpose).
fn needed_inputs(structure: &ModelStructure, plans: &[Plan]) -> Vec<(&'static str, String)> {
    let mut needs: Vec<(&'static str, String)> = Vec::new();
    for plan in plans {
        for regressor in plan.terms.iter().flat_map(|(term, _)| term.factors()) {
            let control = match regressor {
                Regressor::Elevator => Some(Control::Elevator),
                Regressor::Aileron => Some(Control::Aileron),
                Regressor::Rudder => Some(Control::Rudder),
                Regressor::Flap => Some(Control::Flap),
                _ => None,
            };
            if let Some(control) = control
                && !needs.iter().any(|(n, _)| *n == control.name())
            {
                needs.push((control.name(), format!("regressor '{}'", regressor.key())));
            }
        }
    }
    if structure.aircraft.propulsion.max_thrust > 0.0 {
        needs.push(("throttle", "thrust".into()));
    }
    needs
}

/// The thrust input on the grid `times`: the record's `thrust` channel (N)
/// when it has one, else the throttle when the aircraft has propulsion
/// (zeros without), and whether it is the measured thrust.
pub(super) fn thrust_input(
    record: &FlightRecord,
    structure: &ModelStructure,
    times: &[f64],
) -> Result<(Vec<f64>, bool)> {
    let finite = |values: Vec<f64>| -> Vec<f64> {
        values
            .into_iter()
            .map(|v| if v.is_finite() { v } else { 0.0 })
            .collect()
    };
    if let Ok(thrust) = record.channel("thrust") {
        return Ok((finite(thrust.values_at(times)?), true));
    }
    Ok(match record.channel("throttle") {
        Ok(channel) if structure.aircraft.propulsion.max_thrust > 0.0 => {
            (finite(channel.values_at(times)?), false)
        }
        _ => (vec![0.0; times.len()], false),
    })
}

/// The record with an `altitude` channel: its own, else the pressure
/// altitude (the ISA altitude of the static pressure, which on a standard
/// day is the altitude the model's ISA density is read at), with a note.
pub(super) fn with_altitude(
    record: &FlightRecord,
) -> (std::borrow::Cow<'_, FlightRecord>, Option<String>) {
    if record.channel("altitude").is_ok() {
        return (std::borrow::Cow::Borrowed(record), None);
    }
    let Ok(pressure) = record.channel(ALTITUDE_SUBSTITUTES[0]) else {
        return (std::borrow::Cow::Borrowed(record), None);
    };
    let mut altitude = pressure.clone();
    altitude.name = "altitude".into();
    altitude.source = format!("the record's pressure_altitude ({})", pressure.source);
    let mut with = record.clone();
    with.channels.push(altitude);
    (
        std::borrow::Cow::Owned(with),
        Some("no altitude channel: the pressure altitude observes h (the ISA of a standard day; a temperature offset would scale ḣ by T/T_ISA)".into()),
    )
}

/// The filter's observations: the needed ones, then the optional ones the
/// record has; a refusal naming every needed channel that is missing (and
/// every missing input).
pub(super) fn observations_and_inputs(
    record: &FlightRecord,
    structure: &ModelStructure,
    settings: &SmoothedRegressionSettings,
    plans: &[Plan],
) -> Result<(Vec<Output>, Vec<String>)> {
    let mut missing: Vec<MissingChannel> = Vec::new();
    let mut outputs: Vec<Output> = Vec::new();
    let has = |name: &str| {
        record.channel(name).is_ok()
            || (name == "altitude" && record.channel(ALTITUDE_SUBSTITUTES[0]).is_ok())
    };
    for name in &settings.observations {
        if !has(name) {
            missing.push(MissingChannel {
                name: name.clone(),
                purpose: "observation (Wang et al. 2012, Eq. 8)".into(),
            });
        } else if let Some(output) = Output::parse(name).filter(|o| !outputs.contains(o)) {
            outputs.push(output);
        }
    }
    for (name, purpose) in needed_inputs(structure, plans) {
        let measured_thrust = name == "throttle" && record.channel("thrust").is_ok();
        if record.channel(name).is_err() && !measured_thrust {
            missing.push(MissingChannel {
                name: name.to_string(),
                purpose,
            });
        }
    }
    let present = record.channels.iter().map(|c| c.name.clone()).collect();
    if let Some(refusal) = Refusal::missing(METHOD, missing, present) {
        return Err(Error::Refused(refusal));
    }
    let mut absent = Vec::new();
    for name in &settings.optional_observations {
        match Output::parse(name) {
            Some(output) if record.channel(name).is_ok() => {
                if !outputs.contains(&output) {
                    outputs.push(output);
                }
            }
            _ => absent.push(name.clone()),
        }
    }
    Ok((outputs, absent))
}

/// The record with its yaw channel unwrapped (no jump of 2π between
/// samples), so that the filter compares a continuous heading (an
/// estimation problem's records are already; `smooth` may be given others).
pub(super) fn unwrapped_yaw(record: &FlightRecord) -> FlightRecord {
    let mut record = record.clone();
    if let Some(channel) = record.channels.iter_mut().find(|c| c.name == "yaw") {
        aeroid_record::unwrap_angles(&mut channel.values);
    }
    record
}

/// A channel's value at t, or `default` when the record lacks it.
pub(super) fn value_or(record: &FlightRecord, name: &str, t: f64, default: f64) -> f64 {
    record
        .channel(name)
        .ok()
        .and_then(|c| c.value_at(t))
        .filter(|v| v.is_finite())
        .unwrap_or(default)
}
