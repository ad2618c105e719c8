//! The aerodynamic coefficients reconstructed from measured accelerations and
//! angular accelerations, and the regressors of a postulated model, on one
//! common time base — the data of the regression estimators (equation error,
//! stepwise regression).
//!
//! Forces (reflex-wing UAV paper, Eqs. 17, 18 and 22, with the thrust vector of the
//! aircraft's propulsion model; the load factors are specific force over g0
//! with nz positive UP, so a_z = −g0·nz):
//! - `CX = (m·g0·nx − T_x)/(q̄·S)`                                   (Eq. 17)
//! - `CZ = (−m·g0·nz − T_z)/(q̄·S)`                                  (Eq. 18)
//! - `CY = (m·g0·ny − T_y)/(q̄·S)`                                   (Eq. 22)
//! - `CL = CX·sin α − CZ·cos α`, `CD = −CX·cos α − CZ·sin α`          (Eqs. 19, 20)
//!
//! Accelerometers at r from the CG (body axes) read the specific force
//! there, a = a_cg + ω̇×r + ω×(ω×r); with an accelerometer position stated
//! the load factors are carried back to the CG before Eqs. 17–22 (ω̇ as
//! for the moments below).
//!
//! with T along the thrust line: the record's `thrust` channel (N) when it
//! has one, else `T = δT·Tmax·(ρ/ρ0)^n` from the throttle channel, ρ the
//! record's `density` channel when it has one, else the ISA at the
//! altitude channel. The scan of the reflex-wing UAV paper writes
//! Eq. 18 without thrust; a thrust line inclined to the body x axis has a z
//! component, so it is subtracted here as in Eq. 17.
//!
//! Moments, from the Euler equations `I·ω̇ + ω×(I·ω) = M_aero + r_T×F_T`
//! with `I = [[Ix, 0, −Ixz], [0, Iy, 0], [−Ixz, 0, Iz]]` (as in
//! `dynamics.rs`), written out:
//! - `Cl = (Ix·ṗ − Ixz·(ṙ + p·q) + (Iz − Iy)·q·r − L_T)/(q̄·S·b)`       (Eq. 23)
//! - `Cm = (Iy·q̇ + (Ix − Iz)·p·r + Ixz·(p² − r²) − M_T)/(q̄·S·c̄)`      (Eq. 21)
//! - `Cn = (Iz·ṙ − Ixz·(ṗ − q·r) + (Iy − Ix)·p·q − N_T)/(q̄·S·b)`       (Eq. 24)
//!
//! The scanned Eqs. 21, 23 and 24 of the reflex-wing UAV paper are damaged: they carry Iyz and
//! Ixy products (zero for a symmetric aircraft), drop the Ixz·ṙ and Ixz·ṗ
//! couplings and flip the sign of the Ixz·(p² − r²) term (a sign convention
//! for Ixz); the standard form above, consistent with the simulator, is used.
//!
//! q̄ is the `dynamic_pressure` channel when the record has it, else
//! ½·ρ·V² from the airspeed channel and ρ as above. ṗ, q̇, ṙ are the
//! record's `p_dot`, `q_dot`, `r_dot` channels when asked, each where a
//! requested equation reads it (q̇ for Cm, ṗ and ṙ for Cl and Cn)
//! ([`AngularAccelerations`]; by default the rates are differentiated and
//! the notes say when the record has them); otherwise they (and α̇
//! for `alpha_dot` terms) come from [`Differentiator`] applied to each channel on
//! its own time base, with no window across a step in any control channel
//! ([`control_steps`]: the accelerations jump there). Every channel is then read at the sample instants of
//! one reference channel with [`Channel::values_at`] (linear interpolation;
//! dropouts bridged), inside the span where every channel and derivative
//! exists. Samples where anything needed is not finite, or q̄ ≤ 0, are left out.

use crate::error::{Error, Result};
use aeroid_core::refusal::{MissingChannel, Refusal};
use aeroid_core::units::STANDARD_GRAVITY;
use aeroid_record::prep::differentiation::{Differentiator, corner_times, step_times};
use aeroid_record::{Channel, FlightRecord};
use aeroid_sim::aero::{AeroInput, Coefficient, ForceAxes, REGRESSOR_COUNT, RateSpeed, Regressor};
use aeroid_sim::aircraft::Aircraft;
use aeroid_sim::atmosphere::Atmosphere;
use aeroid_sim::state::Control;
use nalgebra::Vector3;
use std::collections::BTreeMap;

/// How the record is brought to one time base.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReconstructionOptions {
    /// The differentiator; None: the default one (equation error and
    /// stepwise regression put the one of their settings here).
    pub differentiator: Option<Differentiator>,
    /// The channel whose sample instants are the common time base; default:
    /// the fastest of the accelerometer and rate-gyro channels used.
    pub reference_channel: Option<String>,
    /// Only samples within [start, end] (s) are used.
    pub time_range: Option<(f64, f64)>,
    /// The moments leave out I·ω̇ (no rate is differentiated): the
    /// frequency-domain estimators add it from the rates' transforms.
    pub omit_angular_accelerations: bool,
    /// Where ṗ, q̇, ṙ come from.
    pub angular_accelerations: AngularAccelerations,
    /// Where the differentiator breaks at a control step.
    pub step_breaks: StepBreaks,
    /// The accelerometers' position relative to the centre of gravity,
    /// body axes (m): the load factors are carried to the CG,
    /// a_cg = a − ω̇×r − ω×(ω×r), with ω̇ as for the moments. Zero: they
    /// were measured at the CG.
    pub accelerometer_position: Vector3<f64>,
}

/// Where the differentiator breaks at a control transition of one sample
/// interval (a ramp through several samples breaks at both corners either
/// way).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StepBreaks {
    /// At both samples around it ([`control_corners`]): a step at the later
    /// sample or a ramp spanning the interval, whose first corner a window
    /// must not cross either.
    #[default]
    Corners,
    /// At the first sample with the new value only ([`control_steps`]):
    /// one sample more per step for the neural restricted model's training
    /// set, whose fits the gates pin with these breaks (with the corners
    /// the CDRW longitudinal fit of the neural Gauss–Newton method ends at
    /// its iteration limit).
    NewValue,
}

/// Where the angular accelerations of the moment equations come from (the
/// `angular_accelerations` setting of the regression methods).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AngularAccelerations {
    /// The record's `p_dot`, `q_dot`, `r_dot` (those the requested
    /// equations read) when it has them, else
    /// the differentiated rates.
    Auto,
    /// The record's `p_dot`, `q_dot`, `r_dot` (a record without them is
    /// refused, naming them).
    Measured,
    /// The rates differentiated, whatever the record has (the default:
    /// the estimate's notes say when the record has them).
    #[default]
    Differentiated,
}

/// The channels of measured angular accelerations.
const ANGULAR_ACCELERATION_CHANNELS: [&str; 3] = ["p_dot", "q_dot", "r_dot"];

/// The measured angular accelerations a request reads: q̇ for Cm (the
/// pitch equation has no ṗ or ṙ), ṗ and ṙ for Cl and Cn (coupled by
/// Ixz), all three for load factors carried from the accelerometers'
/// position (ω̇×r).
fn wanted_accelerations(request: &Request, options: &ReconstructionOptions) -> Vec<&'static str> {
    let all = transfers_load_factors(request, options);
    let pitch = all || request.coefficients.contains(&Coefficient::Pitch);
    let lateral = all
        || request
            .coefficients
            .iter()
            .any(|c| matches!(c, Coefficient::Roll | Coefficient::Yaw));
    let [p, q, r] = ANGULAR_ACCELERATION_CHANNELS;
    let mut wanted = Vec::new();
    if lateral {
        wanted.push(p);
    }
    if pitch {
        wanted.push(q);
    }
    if lateral {
        wanted.push(r);
    }
    wanted
}

/// Whether the record has every channel of `names`.
fn has_all(record: &FlightRecord, names: &[&str]) -> bool {
    names.iter().all(|name| record.channel(name).is_ok())
}

impl AngularAccelerations {
    /// Whether `record`'s measured angular accelerations (those `wanted`)
    /// are used.
    fn measured(self, record: &FlightRecord, wanted: &[&str]) -> bool {
        match self {
            AngularAccelerations::Auto => !wanted.is_empty() && has_all(record, wanted),
            AngularAccelerations::Measured => true,
            AngularAccelerations::Differentiated => false,
        }
    }
}

/// What to reconstruct: which coefficients (as measured values) and which regressors.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Request {
    pub coefficients: Vec<Coefficient>,
    pub regressors: Vec<Regressor>,
}

/// The measured coefficients and regressors at the kept instants.
#[derive(Debug, Clone, PartialEq)]
pub struct Reconstruction {
    pub times: Vec<f64>,
    /// Measured coefficient series by `Coefficient as usize` (None when not requested).
    pub coefficients: [Option<Vec<f64>>; 6],
    /// Every regressor at each instant (`Regressor as usize`); unrequested ones may be NaN.
    pub regressors: Vec<[f64; REGRESSOR_COUNT]>,
    pub reference_channel: String,
    /// q̄ (Pa) at each kept instant; empty when the data did not come from
    /// a record's reconstruction.
    pub dynamic_pressure: Vec<f64>,
    /// Rate (Hz) of the reference channel.
    pub rate: f64,
    pub notes: Vec<String>,
}

impl Reconstruction {
    /// The measured series of one coefficient.
    pub fn coefficient(&self, coefficient: Coefficient) -> &[f64] {
        self.coefficients[coefficient as usize]
            .as_deref()
            .unwrap_or(&[])
    }

    /// One regressor's series.
    pub fn regressor(&self, regressor: Regressor) -> Vec<f64> {
        self.regressors
            .iter()
            .map(|r| r[regressor as usize])
            .collect()
    }
}

/// Measured channels used, each with why (for the error naming a missing one).
type Needs = BTreeMap<&'static str, String>;

fn need(needs: &mut Needs, channel: &'static str, why: &str) {
    needs
        .entry(channel)
        .and_modify(|reasons| {
            if !reasons.contains(why) {
                *reasons += ", ";
                *reasons += why;
            }
        })
        .or_insert_with(|| why.to_string());
}

/// The channels a request needs.
fn needed_channels(
    record: &FlightRecord,
    aircraft: &Aircraft,
    request: &Request,
    options: &ReconstructionOptions,
) -> Needs {
    let mut needs = Needs::new();
    let wanted = wanted_accelerations(request, options);
    let measured_accelerations = !options.omit_angular_accelerations
        && options.angular_accelerations.measured(record, &wanted);
    let mut wants_dynamic_pressure = false;
    let mut wants_thrust = false;
    for &coefficient in &request.coefficients {
        wants_dynamic_pressure = true;
        wants_thrust |=
            coefficient_needs(aircraft, coefficient, measured_accelerations, &mut needs);
    }
    if transfers_load_factors(request, options) {
        for channel in ["p", "q", "r"] {
            need(&mut needs, channel, "accelerometer position");
        }
        if measured_accelerations {
            for channel in ANGULAR_ACCELERATION_CHANNELS {
                need(&mut needs, channel, "accelerometer position");
            }
        }
    }
    for &regressor in &request.regressors {
        regressor_needs(aircraft, regressor, &mut needs);
    }
    let density = if record.channel("density").is_ok() {
        "density"
    } else {
        "altitude"
    };
    if wants_thrust && record.channel("thrust").is_ok() {
        need(&mut needs, "thrust", "thrust");
    } else if wants_thrust && aircraft.propulsion.max_thrust > 0.0 {
        need(&mut needs, "throttle", "thrust");
        if aircraft.propulsion.density_exponent != 0.0 {
            need(&mut needs, density, "thrust lapse with density");
        }
    }
    if wants_dynamic_pressure && record.channel("dynamic_pressure").is_err() {
        need(&mut needs, "airspeed", "dynamic pressure");
        need(&mut needs, density, "dynamic pressure");
    } else if wants_dynamic_pressure {
        need(&mut needs, "dynamic_pressure", "dynamic pressure");
    }
    needs
}

/// The channels coefficient `coefficient` needs, pushed to `needs`
/// (the angular accelerations where they are `measured_accelerations`);
/// whether it wants the thrust.
fn coefficient_needs(
    aircraft: &Aircraft,
    coefficient: Coefficient,
    measured_accelerations: bool,
    needs: &mut Needs,
) -> bool {
    let axes = aircraft.aero.force_axes;
    let name = coefficient.name(axes);
    let mut wants_thrust = false;
    // Thrust enters a coefficient only through its component along that
    // axis: a thrust line in the symmetry plane makes no side force, and
    // its moment about the centre of gravity is a pitching moment only.
    let direction = aircraft.propulsion.direction;
    let moment = aircraft.propulsion.position.cross(&direction);
    match coefficient {
        Coefficient::Lift | Coefficient::Drag => {
            wants_thrust |= match (axes, coefficient) {
                (ForceAxes::Body, Coefficient::Lift) => direction.z != 0.0,
                (ForceAxes::Body, _) => direction.x != 0.0,
                _ => direction.x != 0.0 || direction.z != 0.0,
            };
            if axes == ForceAxes::Wind {
                for channel in ["nx", "nz", "alpha"] {
                    need(needs, channel, name);
                }
            } else if coefficient == Coefficient::Lift {
                need(needs, "nz", name);
            } else {
                need(needs, "nx", name);
            }
        }
        Coefficient::Side => {
            wants_thrust |= direction.y != 0.0;
            need(needs, "ny", name);
        }
        Coefficient::Roll | Coefficient::Pitch | Coefficient::Yaw => {
            let axis = match coefficient {
                Coefficient::Roll => 0,
                Coefficient::Pitch => 1,
                _ => 2,
            };
            wants_thrust |= moment[axis] != 0.0;
            for channel in ["p", "q", "r"] {
                need(needs, channel, name);
            }
            if measured_accelerations {
                let [p, q, r] = ANGULAR_ACCELERATION_CHANNELS;
                let channels = if axis == 1 { vec![q] } else { vec![p, r] };
                for channel in channels {
                    need(needs, channel, name);
                }
            }
            // A moment taken about a point other than the CG: the
            // measured forces carry it there.
            let transfer = aircraft.aero.transfer_uses(coefficient);
            for (axis, channel) in ["nx", "ny", "nz"].into_iter().enumerate() {
                if transfer[axis] {
                    wants_thrust |= direction[axis] != 0.0;
                    need(needs, channel, "moment reference point");
                }
            }
        }
    }
    wants_thrust
}

fn regressor_needs(aircraft: &Aircraft, regressor: Regressor, needs: &mut Needs) {
    let why = format!("regressor '{}'", regressor.key());
    let rate_speed = aircraft.aero.rate_speed == RateSpeed::Airspeed;
    match regressor {
        Regressor::Constant | Regressor::Separation | Regressor::LiftSquared => {}
        Regressor::Alpha => need(needs, "alpha", &why),
        Regressor::Beta => need(needs, "beta", &why),
        Regressor::RollRate | Regressor::PitchRate | Regressor::YawRate | Regressor::AlphaDot => {
            let channel = match regressor {
                Regressor::RollRate => "p",
                Regressor::PitchRate => "q",
                Regressor::YawRate => "r",
                _ => "alpha",
            };
            need(needs, channel, &why);
            if rate_speed {
                need(needs, "airspeed", &why);
            }
        }
        Regressor::Elevator => need(needs, "elevator", &why),
        Regressor::Aileron => need(needs, "aileron", &why),
        Regressor::Rudder => need(needs, "rudder", &why),
        Regressor::Flap => need(needs, "flap", &why),
        Regressor::SpeedRatio => need(needs, "airspeed", &why),
        Regressor::Mach => need(needs, "mach", &why),
    }
}

/// Where any control channel of the record steps (sorted, each instant
/// once): the instants where angular accelerations and α̇ may jump
/// ([`step_times`]).
pub fn control_steps(record: &FlightRecord) -> Vec<f64> {
    control_instants(record, step_times)
}

/// The corners of every control channel's steps and ramps (sorted, each
/// instant once; [`corner_times`]): where equation error's differentiator
/// breaks.
pub fn control_corners(record: &FlightRecord) -> Vec<f64> {
    control_instants(record, corner_times)
}

fn control_instants(record: &FlightRecord, each: fn(&Channel) -> Vec<f64>) -> Vec<f64> {
    let mut instants: Vec<f64> = Control::ALL
        .iter()
        .filter_map(|control| record.channel(control.name()).ok())
        .flat_map(each)
        .collect();
    instants.sort_by(f64::total_cmp);
    instants.dedup();
    instants
}

/// Whether the load factors are read away from the CG: an accelerometer
/// position is stated and something reads them (a force coefficient, or
/// a moment taken about a point other than the CG).
fn transfers_load_factors(request: &Request, options: &ReconstructionOptions) -> bool {
    options.accelerometer_position != Vector3::zeros() && !request.coefficients.is_empty()
}

/// The channels that are differentiated: the rates for moments and for
/// the accelerometers' transfer to the CG (unless the record's angular
/// accelerations are used), α for α̇ terms.
fn differentiated_channels(
    request: &Request,
    options: &ReconstructionOptions,
    measured_accelerations: bool,
) -> Vec<&'static str> {
    let moments = !options.omit_angular_accelerations
        && !measured_accelerations
        && (request.coefficients.iter().any(|c| !c.is_force())
            || transfers_load_factors(request, options));
    let mut names = Vec::new();
    if moments {
        names.extend(["p", "q", "r"]);
    }
    if request.regressors.contains(&Regressor::AlphaDot) {
        names.push("alpha");
    }
    names
}

/// The channels a request needs that the record does not have.
pub fn missing_channels(
    record: &FlightRecord,
    aircraft: &Aircraft,
    request: &Request,
    options: &ReconstructionOptions,
) -> Vec<&'static str> {
    needed_channels(record, aircraft, request, options)
        .into_keys()
        .filter(|name| record.channel(name).is_err())
        .collect()
}

/// Checks that the record has every channel `request` needs; the error
/// names all missing ones and what each is for.
pub(crate) fn check_channels(
    record: &FlightRecord,
    aircraft: &Aircraft,
    request: &Request,
    method: &str,
) -> Result<()> {
    check_present(
        record,
        &needed_channels(record, aircraft, request, &ReconstructionOptions::default()),
        method,
    )
}

/// Checks that every needed channel is present: a refusal naming all
/// missing ones and what each is for.
fn check_present(record: &FlightRecord, needs: &Needs, method: &str) -> Result<()> {
    let missing: Vec<MissingChannel> = needs
        .iter()
        .filter(|(name, _)| record.channel(name).is_err())
        .map(|(name, why)| MissingChannel {
            name: name.to_string(),
            purpose: why.to_string(),
        })
        .collect();
    let present = record.channels.iter().map(|c| c.name.clone()).collect();
    match Refusal::missing(method, missing, present) {
        Some(refusal) => Err(Error::Refused(refusal)),
        None => Ok(()),
    }
}

/// Reconstructs the requested coefficients and regressors from a record;
/// `method` names the estimator in errors.
pub fn reconstruct(
    record: &FlightRecord,
    aircraft: &Aircraft,
    request: &Request,
    options: &ReconstructionOptions,
    method: &str,
) -> Result<Reconstruction> {
    let needs = needed_channels(record, aircraft, request, options);
    check_present(record, &needs, method)?;
    let measured_accelerations = ANGULAR_ACCELERATION_CHANNELS
        .iter()
        .any(|name| needs.contains_key(name));
    let differentiated = differentiated_channels(request, options, measured_accelerations);
    let derivatives = derivatives(record, differentiated, options)?;
    let reference = reference_channel(record, &needs, options)?;
    let times = common_times(record, &needs, &derivatives, reference, options)?;
    let mut sampled: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    for name in needs.keys() {
        sampled.insert(name, record.channel(name)?.values_at(&times)?);
    }
    let mut rates: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    for (name, derivative) in &derivatives {
        // Not bridged: a derivative's dropouts are where it does not exist.
        rates.insert(name, derivative.values_at_unbridged(&times));
    }
    let signals = Signals::new(&sampled, &rates);
    let mut reconstruction = Reconstruction {
        times: Vec::with_capacity(times.len()),
        coefficients: Default::default(),
        regressors: Vec::with_capacity(times.len()),
        reference_channel: reference.name.clone(),
        dynamic_pressure: Vec::with_capacity(times.len()),
        rate: reference.rate,
        notes: Vec::new(),
    };
    for &coefficient in &request.coefficients {
        reconstruction.coefficients[coefficient as usize] = Some(Vec::new());
    }
    let mut dropped = 0;
    for (k, &time) in times.iter().enumerate() {
        match sample(
            aircraft,
            request,
            &signals,
            k,
            &options.accelerometer_position,
        ) {
            Some((coefficients, regressors)) => {
                reconstruction.times.push(time);
                reconstruction
                    .dynamic_pressure
                    .push(dynamic_pressure(&signals, k));
                reconstruction.regressors.push(regressors);
                for (series, value) in reconstruction.coefficients.iter_mut().zip(coefficients) {
                    if let Some(series) = series {
                        series.push(value);
                    }
                }
            }
            None => dropped += 1,
        }
    }
    let sources = Sources {
        needs: &needs,
        derivatives: &derivatives,
        measured_accelerations,
        wanted_accelerations: wanted_accelerations(request, options),
        reference,
    };
    reconstruction
        .notes
        .extend(sources.notes(record, options, &times, dropped));
    Ok(reconstruction)
}

/// What a reconstruction took from the record: the channels it needed,
/// those it differentiated, whether the angular accelerations were
/// measured, and the channel whose instants are the time base.
struct Sources<'a> {
    needs: &'a Needs,
    derivatives: &'a BTreeMap<&'a str, Channel>,
    measured_accelerations: bool,
    /// The measured angular accelerations the request reads, if measured.
    wanted_accelerations: Vec<&'static str>,
    reference: &'a Channel,
}

impl Sources<'_> {
    /// The reconstruction's notes: where the angular accelerations, thrust
    /// and density came from, the differentiator, and the time base
    /// (`times`, of which `dropped` instants were left out).
    fn notes(
        &self,
        record: &FlightRecord,
        options: &ReconstructionOptions,
        times: &[f64],
        dropped: usize,
    ) -> Vec<String> {
        let mut notes = Vec::new();
        let wanted = self.wanted_accelerations.join(", ");
        if self.measured_accelerations {
            notes.push(format!(
                "angular accelerations: the record's {wanted} (`angular_accelerations = \"differentiated\"` differentiates the rates instead)"
            ));
        }
        if !self.measured_accelerations
            && self.derivatives.contains_key("p")
            && !self.wanted_accelerations.is_empty()
            && has_all(record, &self.wanted_accelerations)
        {
            notes.push(format!(
                "the record has {wanted}: `angular_accelerations = \"measured\"` (or \"auto\") uses them instead of differentiating the rates"
            ));
        }
        let arm = options.accelerometer_position;
        if arm != Vector3::zeros() {
            notes.push(format!(
                "load factors carried to the CG from the accelerometers at ({}, {}, {}) m, body axes: a_cg = a − ω̇×r − ω×(ω×r)",
                arm.x, arm.y, arm.z
            ));
        }
        if self.needs.contains_key("thrust") {
            notes.push(
                "thrust: the record's 'thrust' channel, along the aircraft's thrust line".into(),
            );
        }
        if self.needs.contains_key("density") {
            notes.push(
                "air density: the record's 'density' channel, not the ISA at the altitude channel"
                    .into(),
            );
        }
        if !self.derivatives.is_empty() {
            notes.push(
                options
                    .differentiator
                    .unwrap_or_default()
                    .describe(self.reference.rate),
            );
        }
        notes.push(format!(
            "common time base: the {} instants of channel '{}' ({} Hz) from {:.3} s to {:.3} s{}",
            times.len() - dropped,
            self.reference.name,
            aeroid_record::rate_text(self.reference.rate),
            times.first().copied().unwrap_or(f64::NAN),
            times.last().copied().unwrap_or(f64::NAN),
            if dropped > 0 {
                format!("; {dropped} instants left out (a value not finite, or q̄ ≤ 0)")
            } else {
                String::new()
            }
        ));
        notes
    }
}

/// The derivatives of the channels `differentiated`, the differentiator's
/// windows stopping at the corners of the control steps and ramps (only
/// looked for when something is differentiated).
fn derivatives<'a>(
    record: &FlightRecord,
    differentiated: Vec<&'a str>,
    options: &ReconstructionOptions,
) -> Result<BTreeMap<&'a str, Channel>> {
    let breaks = if differentiated.is_empty() {
        Vec::new()
    } else {
        match options.step_breaks {
            StepBreaks::Corners => control_corners(record),
            StepBreaks::NewValue => control_steps(record),
        }
    };
    differentiated
        .into_iter()
        .map(|name| {
            let channel = record.channel(name)?;
            let derivative = options
                .differentiator
                .unwrap_or_default()
                .differentiate_with_breaks(channel, &breaks);
            Ok((name, derivative))
        })
        .collect()
}

/// The reference channel: the option, else the fastest accelerometer or rate
/// gyro used, else the fastest channel used.
fn reference_channel<'a>(
    record: &'a FlightRecord,
    needs: &Needs,
    options: &ReconstructionOptions,
) -> Result<&'a Channel> {
    if let Some(name) = &options.reference_channel {
        return Ok(record.channel(name)?);
    }
    let primary = ["nx", "ny", "nz", "p", "q", "r"];
    let fastest = |names: Vec<&str>| -> Option<&'a Channel> {
        names
            .into_iter()
            .filter_map(|n| record.channel(n).ok())
            .fold(None, |best: Option<&Channel>, c| match best {
                Some(b) if b.rate >= c.rate => Some(b),
                _ => Some(c),
            })
    };
    let used_primary: Vec<&str> = primary
        .into_iter()
        .filter(|n| needs.contains_key(n))
        .collect();
    fastest(used_primary)
        .or_else(|| fastest(needs.keys().copied().collect()))
        .ok_or_else(|| Error::Data {
            reason: "nothing to reconstruct: no channel is needed".into(),
        })
}

/// The reference instants inside the span covered by every channel and derivative.
fn common_times(
    record: &FlightRecord,
    needs: &Needs,
    derivatives: &BTreeMap<&str, Channel>,
    reference: &Channel,
    options: &ReconstructionOptions,
) -> Result<Vec<f64>> {
    let (mut start, mut end) = options
        .time_range
        .unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
    let spans = needs
        .keys()
        .map(|name| record.channel(name))
        .collect::<aeroid_record::Result<Vec<_>>>()?;
    for channel in spans {
        let (first, last) = valid_span(channel).ok_or_else(|| Error::Data {
            reason: format!("channel '{}' has no valid sample", channel.name),
        })?;
        start = start.max(first);
        end = end.min(last);
    }
    for (name, derivative) in derivatives {
        let (first, last) = valid_span(derivative).ok_or_else(|| {
            Error::Data { reason: format!(
                "channel '{name}' cannot be differentiated: it is shorter than the differentiator's window or has too many dropouts"
            ) }
        })?;
        start = start.max(first);
        end = end.min(last);
    }
    Ok(reference
        .times
        .iter()
        .copied()
        .filter(|t| (start..=end).contains(t))
        .collect())
}

/// First and last instants with a valid value.
fn valid_span(channel: &Channel) -> Option<(f64, f64)> {
    let first = channel.values.iter().position(|v| v.is_finite())?;
    let last = channel.values.iter().rposition(|v| v.is_finite())?;
    Some((channel.times[first], channel.times[last]))
}

/// The channels [`sample`] reads, sampled on the common time base (looked
/// up by name once, not at every instant), and the derivatives of the
/// differentiated ones; None when not needed.
struct Signals<'a> {
    airspeed: Option<&'a [f64]>,
    alpha: Option<&'a [f64]>,
    altitude: Option<&'a [f64]>,
    beta: Option<&'a [f64]>,
    density: Option<&'a [f64]>,
    dynamic_pressure: Option<&'a [f64]>,
    mach: Option<&'a [f64]>,
    thrust: Option<&'a [f64]>,
    throttle: Option<&'a [f64]>,
    /// nx, ny, nz.
    load_factors: [Option<&'a [f64]>; 3],
    /// p, q, r.
    rates: [Option<&'a [f64]>; 3],
    /// ṗ, q̇, ṙ.
    rate_derivatives: [Option<&'a [f64]>; 3],
    alpha_dot: Option<&'a [f64]>,
    /// By [`Control::index`].
    controls: [Option<&'a [f64]>; aeroid_sim::state::CONTROL_COUNT],
}

/// A series' value at instant k; NaN when there is no series.
fn at(series: Option<&[f64]>, k: usize) -> f64 {
    series.map_or(f64::NAN, |v| v[k])
}

impl<'a> Signals<'a> {
    fn new(
        sampled: &'a BTreeMap<&str, Vec<f64>>,
        derivatives: &'a BTreeMap<&str, Vec<f64>>,
    ) -> Signals<'a> {
        let get = |name: &str| sampled.get(name).map(Vec::as_slice);
        let rate = |name: &str| derivatives.get(name).map(Vec::as_slice);
        let mut controls = [None; aeroid_sim::state::CONTROL_COUNT];
        for control in Control::ALL {
            controls[control.index()] = get(control.name());
        }
        Signals {
            airspeed: get("airspeed"),
            alpha: get("alpha"),
            altitude: get("altitude"),
            beta: get("beta"),
            density: get("density"),
            dynamic_pressure: get("dynamic_pressure"),
            mach: get("mach"),
            thrust: get("thrust"),
            throttle: get("throttle"),
            load_factors: ["nx", "ny", "nz"].map(get),
            rates: ["p", "q", "r"].map(get),
            // Each axis's measured ṗ, q̇ or ṙ where the request reads it,
            // else the differentiated rate.
            rate_derivatives: std::array::from_fn(|i| {
                get(ANGULAR_ACCELERATION_CHANNELS[i]).or_else(|| rate(["p", "q", "r"][i]))
            }),
            alpha_dot: rate("alpha"),
            controls,
        }
    }

    fn rates(&self, k: usize) -> Vector3<f64> {
        Vector3::from_fn(|i, _| at(self.rates[i], k))
    }
}

/// The coefficients (all six, unrequested ones NaN) and regressors at
/// instant k, the load factors read at `accelerometer` (body axes, m, from
/// the CG); None when a requested value is not finite or q̄ ≤ 0.
fn sample(
    aircraft: &Aircraft,
    request: &Request,
    signals: &Signals,
    k: usize,
    accelerometer: &Vector3<f64>,
) -> Option<([f64; 6], [f64; REGRESSOR_COUNT])> {
    let dynamic_pressure = dynamic_pressure(signals, k);
    if dynamic_pressure.is_nan() || dynamic_pressure <= 0.0 {
        return None;
    }
    let thrust = thrust_force(aircraft, signals, k);
    let force = force_coefficients(
        aircraft,
        signals,
        k,
        dynamic_pressure,
        &thrust,
        accelerometer,
    );
    let moment = moment_coefficients(aircraft, signals, k, dynamic_pressure, &thrust)
        - moment_transfer(aircraft, request, &force);
    let alpha = at(signals.alpha, k);
    let (lift, drag) = match aircraft.aero.force_axes {
        ForceAxes::Wind => (
            force.x * alpha.sin() - force.z * alpha.cos(),
            -force.x * alpha.cos() - force.z * alpha.sin(),
        ),
        ForceAxes::Body => (force.z, force.x),
    };
    let all = [lift, force.y, drag, moment.x, moment.y, moment.z];
    let mut regressors = regressors(aircraft, signals, k);
    regressors[Regressor::LiftSquared as usize] = lift * lift;
    let finite = request
        .coefficients
        .iter()
        .all(|&c| all[c as usize].is_finite())
        && request
            .regressors
            .iter()
            .all(|&r| regressors[r as usize].is_finite());
    finite.then_some((all, regressors))
}

/// What the transfer of the requested moments from the model's reference
/// point to the CG adds ([`aeroid_sim::aero::AeroModel::moment_transfer`]),
/// from the measured body-axis force coefficients (only the components it
/// uses, the others not having been read); zero about the CG.
fn moment_transfer(aircraft: &Aircraft, request: &Request, force: &Vector3<f64>) -> Vector3<f64> {
    let aero = &aircraft.aero;
    let used = (request.coefficients.iter()).fold([false; 3], |used, &c| {
        let uses = aero.transfer_uses(c);
        [0, 1, 2].map(|i| used[i] || uses[i])
    });
    if used == [false; 3] {
        return Vector3::zeros();
    }
    aero.moment_transfer(&Vector3::from_fn(
        |i, _| {
            if used[i] { force[i] } else { 0.0 }
        },
    ))
}

/// ρ: the density channel, else the ISA at the altitude channel.
fn density(signals: &Signals, k: usize) -> f64 {
    match signals.density {
        Some(measured) => measured[k],
        None => Atmosphere::default().at(at(signals.altitude, k)).density,
    }
}

fn dynamic_pressure(signals: &Signals, k: usize) -> f64 {
    if let Some(measured) = signals.dynamic_pressure {
        measured[k]
    } else {
        let airspeed = at(signals.airspeed, k);
        0.5 * density(signals, k) * airspeed * airspeed
    }
}

/// Thrust force in body axes (N): zero without propulsion.
fn thrust_force(aircraft: &Aircraft, signals: &Signals, k: usize) -> Vector3<f64> {
    let propulsion = &aircraft.propulsion;
    if let Some(thrust) = signals.thrust {
        return propulsion.direction * thrust[k];
    }
    let Some(throttle) = signals.throttle.filter(|_| propulsion.max_thrust != 0.0) else {
        return Vector3::zeros();
    };
    // Without a thrust lapse the altitude channel is not needed (nor read).
    let log_density_ratio = if propulsion.density_exponent == 0.0 {
        0.0
    } else if signals.density.is_some() {
        (density(signals, k) / aeroid_sim::atmosphere::SEA_LEVEL_DENSITY).ln()
    } else {
        Atmosphere::default()
            .at(at(signals.altitude, k))
            .log_density_ratio
    };
    propulsion.direction * propulsion.thrust(throttle[k], log_density_ratio)
}

/// CX, CY, CZ (Eqs. 17, 22, 18) from the load factors measured at
/// `accelerometer` (body axes, m, from the CG), carried to the CG:
/// a_cg = a − ω̇×r − ω×(ω×r). Components whose channel was not needed are NaN.
fn force_coefficients(
    aircraft: &Aircraft,
    signals: &Signals,
    k: usize,
    dynamic_pressure: f64,
    thrust: &Vector3<f64>,
    accelerometer: &Vector3<f64>,
) -> Vector3<f64> {
    let weight = aircraft.mass.mass * STANDARD_GRAVITY;
    let [nx, ny, nz] = signals.load_factors.map(|n| at(n, k));
    let mut measured = Vector3::new(weight * nx, weight * ny, -weight * nz);
    if *accelerometer != Vector3::zeros() {
        let omega = signals.rates(k);
        let omega_dot = Vector3::from_fn(|i, _| signals.rate_derivatives[i].map_or(0.0, |v| v[k]));
        measured -= (omega_dot.cross(accelerometer) + omega.cross(&omega.cross(accelerometer)))
            * aircraft.mass.mass;
    }
    let aerodynamic = measured - thrust;
    aerodynamic / (dynamic_pressure * aircraft.wing_area)
}

/// Cl, Cm, Cn from the Euler equations (Eqs. 21, 23, 24, standard form).
fn moment_coefficients(
    aircraft: &Aircraft,
    signals: &Signals,
    k: usize,
    dynamic_pressure: f64,
    thrust: &Vector3<f64>,
) -> Vector3<f64> {
    let omega = signals.rates(k);
    // Without derivatives (omit_angular_accelerations) I·ω̇ is left out.
    let omega_dot = Vector3::from_fn(|i, _| signals.rate_derivatives[i].map_or(0.0, |v| v[k]));
    let inertia = &aircraft.mass.inertia;
    let thrust_moment = aircraft.propulsion.position.cross(thrust);
    let aerodynamic = inertia * omega_dot + omega.cross(&(inertia * omega)) - thrust_moment;
    let scale = dynamic_pressure * aircraft.wing_area;
    let geometry = &aircraft.geometry;
    Vector3::new(
        aerodynamic.x / (scale * geometry.span),
        aerodynamic.y / (scale * geometry.chord),
        aerodynamic.z / (scale * geometry.span),
    )
}

/// Every regressor of the postulated model from the measured channels
/// (NaN where a channel was not needed); `chi` is taken as 1 (not measured).
fn regressors(aircraft: &Aircraft, signals: &Signals, k: usize) -> [f64; REGRESSOR_COUNT] {
    let controls = aeroid_sim::state::Controls::from_fn(|i, _| at(signals.controls[i], k));
    let input = AeroInput {
        alpha: at(signals.alpha, k),
        beta: at(signals.beta, k),
        airspeed: at(signals.airspeed, k),
        mach: at(signals.mach, k),
        rates: signals.rates(k),
        alpha_dot: at(signals.alpha_dot, k),
        measured_alpha_dot: None,
        controls,
        chi: 1.0,
    };
    aircraft.aero.regressors(&input, 1.0)
}

#[cfg(test)]
mod tests;
