//! A [`DrivenSimulation`] sampled from a flight record on its grid: each
//! control reconstructed between its samples as the `interpolation`
//! setting chooses (held or linear), the measured pseudo-controls and
//! quantities linear, a missing altitude replaced by the pressure altitude
//! or the ISA density altitude of the measured density
//! ([`ALTITUDE_SUBSTITUTES`]).

use super::measured::{ALTITUDE_SUBSTITUTES, Ambient, measured_alpha_dot, measured_ambient};
use super::memo::Frozen;
use super::simulation::DrivenSimulation;
use super::{FLIGHT_PATH_SIZE, FlightPathState};
use crate::error::{Error, Result};
use crate::input_timing::{self, Chosen, InputInterpolation};
use crate::structure::FLIGHT_PATH_STATES;
use aeroid_record::FlightRecord;
use aeroid_sim::atmosphere::Atmosphere;
use aeroid_sim::integrator::Interpolation;
use aeroid_sim::state::{CONTROL_COUNT, Control, Controls};

impl DrivenSimulation {
    /// Samples controls and pseudo-controls from the record on the grid
    /// start, start + step, …, end. Each control channel is reconstructed
    /// between its samples as `interpolation` chooses for it (a hold keeps
    /// a recorded step a step; noted); measured pseudo-controls,
    /// continuous signals, linearly.
    /// A missing control channel is held at 0 (noted); a missing
    /// pseudo-control that the model needs is an error. The record's
    /// `density` and `thrust` channels, when it has them, are sampled
    /// linearly too and replace the ISA's density and the throttle model
    /// ([`Ambient`]); a missing altitude is the pressure altitude, else the
    /// ISA density altitude of the measured density
    /// ([`ALTITUDE_SUBSTITUTES`]). With `alpha_dot` the derivative of the
    /// record's α is sampled too (`measured_alpha_dot`), for a stall
    /// model whose separation takes it. Each is noted.
    pub fn from_record(
        record: &FlightRecord,
        integrate: &[usize],
        interpolation: &InputInterpolation,
        step: f64,
        (start, end): (f64, f64),
        alpha_dot: bool,
    ) -> Result<DrivenSimulation> {
        let count = ((end - start) / step + 1e-9).floor() as usize + 1;
        let times: Vec<f64> = (0..count).map(|k| start + k as f64 * step).collect();
        let (mut ambient, mut measured_quantities) = measured_ambient(record, &times)?;
        if alpha_dot {
            measured_quantities.push(measured_alpha_dot(record, &times, &mut ambient)?);
        }
        let mut notes = measured_quantities.clone();
        let thrust_measured = ambient.first().is_some_and(|a| a.thrust.is_some());
        let (controls, holds, input_timing) =
            sampled_controls(record, interpolation, &times, thrust_measured, &mut notes)?;
        let mut mask = [false; FLIGHT_PATH_SIZE];
        integrate.iter().for_each(|&i| mask[i] = true);
        let (measured, altitude_note) = sampled_states(record, &mask, &times, &ambient)?;
        if let Some(note) = altitude_note {
            notes.push(note.into());
            measured_quantities.push(note.into());
        }
        debug_assert_eq!(CONTROL_COUNT, 5);
        if !input_timing.is_empty() {
            notes.push(input_timing::note(&input_timing));
        }
        Ok(DrivenSimulation {
            start,
            step,
            holds,
            input_timing,
            integrate: mask,
            controls,
            frozen: Frozen::new(&measured, &ambient),
            measured,
            ambient,
            notes,
            measured_quantities,
        })
    }

    /// The simulation over its first `points` grid points (at least two,
    /// at most all): what a linearisation at its start reads, without a
    /// copy of the whole record's inputs.
    pub fn head(&self, points: usize) -> DrivenSimulation {
        let n = points.max(2).min(self.len());
        let measured = self.measured[..n].to_vec();
        let ambient = self.ambient[..n].to_vec();
        DrivenSimulation {
            start: self.start,
            step: self.step,
            holds: self.holds,
            input_timing: self.input_timing.clone(),
            integrate: self.integrate,
            controls: self.controls[..n].to_vec(),
            frozen: Frozen::new(&measured, &ambient),
            measured,
            ambient,
            notes: Vec::new(),
            measured_quantities: Vec::new(),
        }
    }
}

/// The record's controls on the grid `times`, each reconstructed between
/// its samples as `interpolation` chooses for it, with how each is taken
/// inside a step and the choices; a missing control channel held at 0
/// (noted in `notes`), the throttle not read when the thrust is measured.
fn sampled_controls(
    record: &FlightRecord,
    interpolation: &InputInterpolation,
    times: &[f64],
    thrust_measured: bool,
    notes: &mut Vec<String>,
) -> Result<(Vec<Controls>, [Interpolation; CONTROL_COUNT], Vec<Chosen>)> {
    let mut controls = vec![Controls::zeros(); times.len()];
    let mut holds = [Interpolation::ZeroOrderHold; CONTROL_COUNT];
    let mut input_timing = Vec::new();
    for control in Control::ALL {
        match record.channel(control.name()) {
            Ok(channel) => {
                let chosen = interpolation.choose(control.name(), &channel.values);
                holds[control.index()] = chosen.interpolation;
                for (sample, value) in controls
                    .iter_mut()
                    .zip(channel.sampled_at(times, chosen.interpolation)?)
                {
                    sample[control.index()] = value;
                }
                input_timing.push(chosen);
            }
            // With the thrust measured the throttle is not read.
            Err(_) if control == Control::Throttle && thrust_measured => {}
            Err(_) => notes.push(format!("no '{}' channel: held at 0", control.name())),
        }
    }
    Ok((controls, holds, input_timing))
}

/// The measured flight-path states (those `integrate` leaves out) on the
/// grid `times`, linear between samples; a missing altitude the pressure
/// altitude, else the ISA density altitude of the measured density (with
/// the note saying so); ψ and χ 0 when absent.
fn sampled_states(
    record: &FlightRecord,
    integrate: &[bool; FLIGHT_PATH_SIZE],
    times: &[f64],
    ambient: &[Ambient],
) -> Result<(Vec<FlightPathState>, Option<&'static str>)> {
    let mut measured = vec![FlightPathState::zeros(); times.len()];
    let mut note = None;
    for (i, name) in FLIGHT_PATH_STATES
        .iter()
        .enumerate()
        .filter(|(i, _)| !integrate[*i])
    {
        match record.channel(name) {
            Ok(channel) => {
                for (sample, value) in measured.iter_mut().zip(channel.values_at(times)?) {
                    sample[i] = value;
                }
            }
            Err(_) if matches!(*name, "yaw" | "chi") => {}
            Err(_) if *name == "altitude" => {
                if let Ok(altitude) = record.channel(ALTITUDE_SUBSTITUTES[0]) {
                    for (sample, value) in measured.iter_mut().zip(altitude.values_at(times)?) {
                        sample[i] = value;
                    }
                } else if ambient.first().is_some_and(|a| a.density.is_some()) {
                    for (sample, ambient) in measured.iter_mut().zip(ambient) {
                        sample[i] =
                            Atmosphere::density_altitude(ambient.density.unwrap_or(f64::NAN));
                    }
                    note = Some(
                        "no altitude channel: the altitude is the ISA density altitude of the measured density (the air's temperature and speed of sound the ISA's there)",
                    );
                } else {
                    return Err(missing_altitude());
                }
            }
            Err(_) => return Err(missing(name)),
        }
    }
    Ok((measured, note))
}

fn missing_altitude() -> Error {
    Error::Data {
        reason: format!(
            "the model needs the measured channel 'altitude' (it is not integrated), or '{}', '{}' or '{}' instead, but the record has none",
            ALTITUDE_SUBSTITUTES[0], ALTITUDE_SUBSTITUTES[1], ALTITUDE_SUBSTITUTES[2]
        ),
    }
}

pub(super) fn missing(name: &str) -> Error {
    Error::Data {
        reason: format!(
            "the model needs the measured channel '{name}' (it is not integrated), but the record has none"
        ),
    }
}
