//! The derive step (`aeroid derive`): the channels a recorder lacks,
//! computed from those it has. In order: combined control surfaces from
//! split ones ([`crate::prep::surfaces`]), the air density from pressure
//! altitude and temperature ([`crate::prep::air_data`]), on request the
//! thrust from the fuel flow by the user's engine model
//! ([`crate::prep::thrust`]), the geometric
//! angle of attack and sideslip ([`crate::prep::flow_angles`]) and the body
//! rates from the attitude kinematics ([`crate::prep::angular_rates`]). Each derived
//! channel names its method and inputs in its `source`.

use crate::FlightRecord;
use crate::error::Result;
use crate::prep::air_data::with_air_density;
use crate::prep::angular_rates::{KinematicRates, with_kinematic_rates};
use crate::prep::differentiation::Differentiator;
use crate::prep::flow_angles::{GeometricFlowAngles, Wind, with_geometric_flow_angles};
use crate::prep::surfaces::with_combined_surfaces;
use crate::prep::thrust::{FuelFlowThrust, with_thrust_from_fuel_flow};

/// When the body rates are derived.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RatesChoice {
    /// When the record lacks any of p, q, r.
    WhenAbsent,
    /// Always (beside recorded rates as `p_kinematic`…, unless replacing).
    Always,
    Never,
}

/// What the derive step does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// The geometric flow angles with or without wind correction, or none.
    pub flow_angles: Option<Wind>,
    pub rates: RatesChoice,
    /// The differentiator of the attitude angles.
    pub differentiator: Differentiator,
    /// Replace usable recorded channels too (flow angles, rates).
    pub replace: bool,
    /// Add a `thrust` channel from the fuel flow with this engine model.
    pub thrust: Option<FuelFlowThrust>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            flow_angles: Some(Wind::Corrected),
            rates: RatesChoice::WhenAbsent,
            differentiator: crate::prep::angular_rates::DEFAULT_DIFFERENTIATOR,
            replace: false,
            thrust: None,
        }
    }
}

/// Whether some step of `aeroid derive` reads channel `name`: the flow
/// angles' inputs, the split surfaces, the air data (pressure altitude,
/// temperatures, calibrated airspeed, Mach), the fuel flow of each engine.
pub fn reads(name: &str) -> bool {
    const AIR_DATA: [&str; 5] = [
        "pressure_altitude",
        "temperature",
        "total_air_temperature",
        "calibrated_airspeed",
        "mach",
    ];
    crate::prep::flow_angles::INPUT_CHANNELS.contains(&name)
        || AIR_DATA.contains(&name)
        || crate::prep::surfaces::SPLIT_SURFACES
            .iter()
            .any(|s| s.left == name || s.right == name)
        || name == "fuel_flow"
        || name.starts_with("fuel_flow_")
}

/// Whether a channel's source says the derive step computed it from other
/// channels: the geometric flow angles and airspeed ("geometric (Wang et
/// al. …"), the kinematic rates ("kinematic (p = …"). A measured channel,
/// or one a compatibility check corrected, is not.
pub fn is_derived(source: &str) -> bool {
    source.starts_with("geometric") || source.starts_with("kinematic (")
}

/// The derive step as a gate case or a study states it: `aeroid derive`
/// with its defaults, and the thrust from the fuel flow when
/// `thrust_from_fuel_flow` is given.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeriveTable {
    /// `--thrust-from-fuel-flow`: thrust-specific fuel consumption, kg/(N·s).
    #[serde(default)]
    pub thrust_from_fuel_flow: Option<f64>,
    /// `--idle-fuel-flow`: kg/s per engine.
    #[serde(default)]
    pub idle_fuel_flow: f64,
    /// In a study: the recorder profiles whose records are derived (every
    /// record when empty). Not used by a gate case, which has one profile.
    #[serde(default)]
    pub profiles: Vec<String>,
}

impl DeriveTable {
    /// The derive step's options.
    pub fn options(&self) -> Options {
        Options {
            thrust: self
                .thrust_from_fuel_flow
                .map(|specific_fuel_consumption| FuelFlowThrust {
                    specific_fuel_consumption,
                    idle_fuel_flow: self.idle_fuel_flow,
                }),
            ..Default::default()
        }
    }

    /// Whether a record of the profile `name` is derived.
    pub fn applies_to(&self, profile: &str) -> bool {
        self.profiles.is_empty() || self.profiles.iter().any(|p| p == profile)
    }
}

/// A derived record and what was done.
#[derive(Debug, Clone)]
pub struct Derived {
    pub record: FlightRecord,
    pub angles: Option<GeometricFlowAngles>,
    pub rates: Option<KinematicRates>,
    /// One line per derived channel.
    pub notes: Vec<String>,
}

/// Runs the derive step on a record (see the module documentation).
pub fn derive(record: &FlightRecord, options: &Options) -> Result<Derived> {
    let (derived, mut notes) = with_combined_surfaces(record)?;
    let (mut derived, density_notes) = with_air_density(&derived)?;
    notes.extend(density_notes);
    if let Some(model) = &options.thrust {
        let (with_thrust, thrust_notes) = with_thrust_from_fuel_flow(&derived, model)?;
        derived = with_thrust;
        notes.extend(thrust_notes);
    }
    let mut angles = None;
    if let Some(wind) = options.flow_angles {
        let derivation = with_geometric_flow_angles(&derived, wind, options.replace)?;
        derived = derivation.record;
        notes.extend(derivation.notes);
        angles = Some(derivation.angles);
    }
    let lacks_rates = ["p", "q", "r"]
        .iter()
        .any(|name| record.channel(name).is_err());
    let mut rates = None;
    if options.rates == RatesChoice::Always
        || (options.rates == RatesChoice::WhenAbsent && lacks_rates)
    {
        let (with_rates, kinematic, rate_notes) =
            with_kinematic_rates(&derived, &options.differentiator, options.replace)?;
        derived = with_rates;
        notes.extend(rate_notes);
        rates = Some(kinematic);
    }
    Ok(Derived {
        record: derived,
        angles,
        rates,
        notes,
    })
}
