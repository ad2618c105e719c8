//! The aerodynamic coefficients as record channels: CX, CY, CZ (body
//! axes), CL, CD (wind axes), Cl, Cm, Cn computed from the measured
//! accelerations (`aeroid derive --coefficients`), so that a model whose
//! outputs are coefficients can be fitted to them — the way the quasi-steady
//! stall model is fitted to flight data (Verma & Peyada 2020, Eqs. 2–4:
//! CL, CD and Cm as outputs, the Kirchhoff separation point χ as the one
//! state; Jategaonkar, "Flight Vehicle System Identification", 2nd ed.,
//! AIAA 2015, the stall example of its chapter on unsteady aerodynamics).
//!
//! The equations are those of [`crate::reconstruction`] (reflex-wing UAV
//! paper, Eqs. 17–24):
//! - forces from the load factors carried from the accelerometers' stated
//!   position to the CG, a_cg = a − ω̇×r − ω×(ω×r), the thrust removed
//!   (the record's `thrust` channel, else the aircraft's engine model at
//!   the throttle channel): `C = (m·a_cg − T)/(q̄·S)`;
//! - CL = CX·sin α − CZ·cos α, CD = −CX·cos α − CZ·sin α (Eqs. 19, 20);
//! - moments from the Euler equations with ω̇ the record's `p_dot`,
//!   `q_dot`, `r_dot` or the rates differentiated by the smoothing local
//!   polynomial ([`aeroid_record::prep::differentiation::Differentiator`]),
//!   as [`crate::reconstruction::AngularAccelerations`] says, carried to the
//!   CG from the aircraft's moment reference point.
//!
//! Each coefficient is computed where the record has what it needs; the
//! others are listed with the channels they lack. A coefficient's channel
//! has the instants of the reconstruction's reference channel (the fastest
//! accelerometer or rate gyro), a dropout where a needed value is not
//! finite or q̄ ≤ 0.

use crate::error::{Error, Result};
use crate::reconstruction::{
    Reconstruction, ReconstructionOptions, Request, missing_channels, reconstruct,
};
use aeroid_record::{Channel, FlightRecord};
use aeroid_sim::aero::{Coefficient, ForceAxes};
use aeroid_sim::aircraft::Aircraft;

/// The coefficient channels' names, in the order they are returned.
pub const COEFFICIENT_CHANNELS: [&str; 8] = ["CX", "CY", "CZ", "CL", "CD", "Cl", "Cm", "Cn"];

/// What names the step in errors and refusals.
const STEP: &str = "coefficients from the accelerations";

/// The coefficients a record allows, and why the others are left out.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CoefficientChannels {
    /// One channel per coefficient computed, in the order of
    /// [`COEFFICIENT_CHANNELS`].
    pub channels: Vec<Channel>,
    /// Each coefficient left out, with the channels the record lacks for it.
    pub left_out: Vec<(&'static str, Vec<&'static str>)>,
    /// Where the accelerations, thrust, density and time base came from.
    pub notes: Vec<String>,
}

/// Every coefficient of [`COEFFICIENT_CHANNELS`] that `record` has the
/// channels for, with `aircraft`'s mass, inertia, geometry and engine.
pub fn coefficient_channels(
    record: &FlightRecord,
    aircraft: &Aircraft,
    options: &ReconstructionOptions,
) -> Result<CoefficientChannels> {
    let mut result = CoefficientChannels::default();
    // The aircraft's own axes give the moments (about its reference point)
    // and one pair of force coefficients; the other axes the other pair.
    let mut other = aircraft.clone();
    other.aero.force_axes = match aircraft.aero.force_axes {
        ForceAxes::Wind => ForceAxes::Body,
        ForceAxes::Body => ForceAxes::Wind,
    };
    let mut options = options.clone();
    let passes = [
        (aircraft, Coefficient::ALL.to_vec()),
        (&other, vec![Coefficient::Lift, Coefficient::Drag]),
    ];
    for (craft, wanted) in passes {
        let axes = craft.aero.force_axes;
        let mut available = Vec::new();
        for coefficient in wanted {
            let request = request(vec![coefficient]);
            let missing = missing_channels(record, craft, &request, &options);
            if missing.is_empty() {
                available.push(coefficient);
            } else {
                result.left_out.push((coefficient.name(axes), missing));
            }
        }
        if available.is_empty() {
            continue;
        }
        let reconstruction =
            reconstruct(record, craft, &request(available.clone()), &options, STEP)?;
        // Both passes on one time base.
        options
            .reference_channel
            .get_or_insert_with(|| reconstruction.reference_channel.clone());
        for coefficient in available {
            result
                .channels
                .push(channel(record, &reconstruction, coefficient, axes)?);
        }
        for note in reconstruction.notes {
            if !result.notes.contains(&note) {
                result.notes.push(note);
            }
        }
    }
    let order = |name: &str| COEFFICIENT_CHANNELS.iter().position(|n| *n == name);
    result.channels.sort_by_key(|c| order(&c.name));
    result.left_out.sort_by_key(|(name, _)| order(name));
    Ok(result)
}

impl CoefficientChannels {
    /// Adds the channels to `record`: a channel of the same name already
    /// there is kept and the computed one added as `NAME_derived`, unless
    /// `replace`. One line per channel says which.
    pub fn add_to(self, record: &mut FlightRecord, replace: bool) -> Vec<String> {
        let mut said = Vec::new();
        for mut channel in self.channels {
            let existing = record.channels.iter().position(|c| c.name == channel.name);
            match existing {
                Some(index) if replace => {
                    said.push(format!(
                        "{}: the recorded channel replaced by the computed one",
                        channel.name
                    ));
                    record.channels[index] = channel;
                }
                Some(_) => {
                    let name = format!("{}_derived", channel.name);
                    said.push(format!(
                        "{}: the recorded channel kept; the computed one added as {name} (--replace replaces it)",
                        channel.name
                    ));
                    record.channels.retain(|c| c.name != name);
                    channel.name = name;
                    record.channels.push(channel);
                }
                None => {
                    said.push(format!("{}: added", channel.name));
                    record.channels.push(channel);
                }
            }
        }
        said
    }
}

fn request(coefficients: Vec<Coefficient>) -> Request {
    Request {
        coefficients,
        regressors: Vec::new(),
    }
}

/// One coefficient's channel on the reference channel's instants over the
/// reconstructed span, a dropout where an instant was left out.
fn channel(
    record: &FlightRecord,
    reconstruction: &Reconstruction,
    coefficient: Coefficient,
    axes: ForceAxes,
) -> Result<Channel> {
    let name = coefficient.name(axes);
    let kept = &reconstruction.times;
    let (Some(&first), Some(&last)) = (kept.first(), kept.last()) else {
        return Err(Error::Data {
            reason: format!(
                "{name} cannot be computed at any instant of the record: a needed value is never finite, or q̄ is never positive"
            ),
        });
    };
    let reference = record.channel(&reconstruction.reference_channel)?;
    let computed = reconstruction.coefficient(coefficient);
    let mut times = Vec::with_capacity(kept.len());
    let mut values = Vec::with_capacity(kept.len());
    let mut next = 0;
    for &time in reference
        .times
        .iter()
        .filter(|t| (first..=last).contains(*t))
    {
        if kept.get(next) == Some(&time) {
            values.push(computed[next]);
            next += 1;
        } else {
            values.push(f64::NAN);
        }
        times.push(time);
    }
    let from = if coefficient.is_force() {
        "the load factors (carried to the CG), the thrust and q̄"
    } else {
        "the rates, the angular accelerations, the thrust and q̄ (the Euler equations)"
    };
    Ok(Channel {
        name: name.to_string(),
        unit: "-".to_string(),
        rate: reconstruction.rate,
        resolution: None,
        source: format!(
            "computed from {from} at the instants of {} (aeroid derive --coefficients)",
            reconstruction.reference_channel
        ),
        times,
        values,
    })
}
