//! The quantities a recorder can store, computed from one truth sample: the
//! states and air data the simulator has directly, and the derived channels a
//! real recorder stores (load factors at the accelerometer, calibrated
//! airspeed, ground speed, track, flight-path angle, pressure altitude, total
//! air temperature, wind, left/right surface positions, engine readings,
//! latitude and longitude, total thrust, air density, static pressure,
//! body angular accelerations). Names follow `trace::COLUMNS` where the quantity
//! is the same; every value is SI with angles in radians.
//!
//! Conventions (pinned here, tested in `tests/simulation/recorder.rs`):
//! - load factors are specific force at the sensor over standard gravity,
//!   `n = (f + ω̇×r + ω×(ω×r))/g0`, with nz positive UP (1 in level flight):
//!   `nx = a_x/g0`, `ny = a_y/g0`, `nz = −a_z/g0`;
//! - calibrated airspeed from the impact pressure of the subsonic
//!   isentropic pitot relation, referred to ISA sea level;
//! - total air temperature with recovery factor 1: `T·(1 + 0.2·M²)`;
//! - pressure altitude from static pressure (ISA). The atmosphere keeps the
//!   standard sea-level pressure, so the baro-corrected altitude (QNH set to
//!   the local sea-level pressure) equals the pressure altitude here;
//! - heading (`yaw`), `track` and `wind_direction` are recorded in [0, 2π);
//!   the wind direction is where the wind blows FROM (meteorological);
//! - split surfaces: `elevator_left = elevator_right = elevator`,
//!   `flap_left = flap_right = flap`, `aileron_left = aileron`,
//!   `aileron_right = −aileron` (so that aileron = (left − right)/2);
//! - latitude and longitude: the flat-earth north/east position placed on a
//!   sphere of radius 6 371 km around the profile's origin (small-area
//!   projection);
//! - engine channels come from the ASSUMED map of [`aeroid_sim::engine`].

use aeroid_core::units::{Dimension, STANDARD_GRAVITY};
use aeroid_sim::aircraft::Propulsion;
use aeroid_sim::atmosphere::{
    Atmosphere, GAS_CONSTANT, HEAT_CAPACITY_RATIO, SEA_LEVEL_PRESSURE, SEA_LEVEL_TEMPERATURE,
};
use aeroid_sim::engine::{self, EngineReading};
use aeroid_sim::state::{self, DOWN, EAST, NORTH};
use aeroid_sim::trace::TruthSample;
use nalgebra::Vector3;

/// Mean earth radius (m) for latitude and longitude.
pub(crate) const EARTH_RADIUS: f64 = 6_371_000.0;

/// Where the flat earth's origin lies on the globe.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GeographicOrigin {
    pub latitude: f64,
    pub longitude: f64,
}

/// What a derived quantity needs besides the truth sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Context {
    pub mass: f64,
    pub propulsion: Propulsion,
    pub origin: GeographicOrigin,
    /// Accelerometer position relative to the centre of gravity, body axes (m).
    pub sensor_position: Vector3<f64>,
}

/// A quantity a recorder channel can measure.
#[derive(Debug)]
pub struct Measurand {
    pub name: &'static str,
    /// Its SI unit as written in record headers.
    pub unit: &'static str,
    /// The dimension of its resolution, noise, bias and limits in a profile.
    pub dimension: Dimension,
    /// An angle recorded in [0, 2π) that is unwrapped before filtering and interpolation.
    pub wraps: bool,
    pub value: fn(&TruthSample, &Context) -> f64,
}

macro_rules! measurand {
    ($name:literal, $unit:literal, $dimension:ident, |$s:ident, $c:ident| $body:expr) => {
        measurand!($name, $unit, $dimension, false, |$s, $c| $body)
    };
    ($name:literal, $unit:literal, $dimension:ident, $wraps:expr, |$s:ident, $c:ident| $body:expr) => {
        Measurand {
            name: $name,
            unit: $unit,
            dimension: Dimension::$dimension,
            wraps: $wraps,
            value: |$s: &TruthSample, $c: &Context| $body,
        }
    };
}

/// Every quantity a recorder profile may name.
pub const MEASURANDS: &[Measurand] = &[
    measurand!("airspeed", "m/s", Speed, |s, _c| s
        .evaluation
        .air_data
        .airspeed),
    measurand!("alpha", "rad", Angle, |s, _c| s.evaluation.air_data.alpha),
    measurand!("beta", "rad", Angle, |s, _c| s.evaluation.air_data.beta),
    measurand!("mach", "-", Dimensionless, |s, _c| s
        .evaluation
        .air_data
        .mach),
    measurand!("dynamic_pressure", "Pa", Pressure, |s, _c| s
        .evaluation
        .air_data
        .dynamic_pressure),
    measurand!("calibrated_airspeed", "m/s", Speed, |s, _c| {
        calibrated_airspeed(s.evaluation.air_data.mach, s.evaluation.air.pressure)
    }),
    measurand!("p", "rad/s", AngularRate, |s, _c| s.state[state::P]),
    measurand!("q", "rad/s", AngularRate, |s, _c| s.state[state::Q]),
    measurand!("r", "rad/s", AngularRate, |s, _c| s.state[state::R]),
    measurand!("roll", "rad", Angle, |s, _c| s.euler.roll),
    measurand!("pitch", "rad", Angle, |s, _c| s.euler.pitch),
    measurand!("yaw", "rad", Angle, true, |s, _c| s.euler.yaw),
    measurand!("nx", "-", LoadFactor, |s, c| load_factor(s, c).x),
    measurand!("ny", "-", LoadFactor, |s, c| load_factor(s, c).y),
    measurand!("nz", "-", LoadFactor, |s, c| load_factor(s, c).z),
    measurand!("altitude", "m", Length, |s, _c| -s.state[DOWN]),
    measurand!("pressure_altitude", "m", Length, |s, _c| {
        Atmosphere::pressure_altitude(s.evaluation.air.pressure)
    }),
    measurand!("baro_corrected_altitude", "m", Length, |s, _c| {
        Atmosphere::pressure_altitude(s.evaluation.air.pressure)
    }),
    measurand!("climb_rate", "m/s", Speed, |s, _c| -s.evaluation.derivative
        [DOWN]),
    measurand!("north", "m", Length, |s, _c| s.state[NORTH]),
    measurand!("east", "m", Length, |s, _c| s.state[EAST]),
    measurand!("latitude", "rad", Angle, |s, c| c.origin.latitude
        + s.state[NORTH] / EARTH_RADIUS),
    measurand!("longitude", "rad", Angle, |s, c| c.origin.longitude
        + s.state[EAST] / (EARTH_RADIUS * c.origin.latitude.cos())),
    measurand!("ground_speed", "m/s", Speed, |s, _c| {
        let d = &s.evaluation.derivative;
        d[NORTH].hypot(d[EAST])
    }),
    measurand!("track", "rad", Angle, true, |s, _c| {
        let d = &s.evaluation.derivative;
        d[EAST].atan2(d[NORTH])
    }),
    measurand!("flight_path_angle", "rad", Angle, |s, _c| {
        let d = &s.evaluation.derivative;
        (-d[DOWN]).atan2(d[NORTH].hypot(d[EAST]))
    }),
    measurand!("temperature", "K", TemperatureDifference, |s, _c| s
        .evaluation
        .air
        .temperature),
    measurand!(
        "total_air_temperature",
        "K",
        TemperatureDifference,
        |s, _c| {
            let mach = s.evaluation.air_data.mach;
            s.evaluation.air.temperature * (1.0 + 0.2 * mach * mach)
        }
    ),
    measurand!("wind_speed", "m/s", Speed, |s, _c| {
        let wind = wind_ned(s);
        wind.x.hypot(wind.y)
    }),
    measurand!("wind_direction", "rad", Angle, true, |s, _c| {
        let wind = wind_ned(s);
        (-wind.y).atan2(-wind.x)
    }),
    measurand!("elevator", "rad", Angle, |s, _c| s.evaluation.controls[0]),
    measurand!("elevator_left", "rad", Angle, |s, _c| s.evaluation.controls
        [0]),
    measurand!("elevator_right", "rad", Angle, |s, _c| s
        .evaluation
        .controls[0]),
    measurand!("aileron", "rad", Angle, |s, _c| s.evaluation.controls[1]),
    measurand!("aileron_left", "rad", Angle, |s, _c| s.evaluation.controls
        [1]),
    measurand!("aileron_right", "rad", Angle, |s, _c| -s
        .evaluation
        .controls[1]),
    measurand!("rudder", "rad", Angle, |s, _c| s.evaluation.controls[2]),
    measurand!("flap", "rad", Angle, |s, _c| s.evaluation.controls[3]),
    measurand!("flap_left", "rad", Angle, |s, _c| s.evaluation.controls[3]),
    measurand!("flap_right", "rad", Angle, |s, _c| s.evaluation.controls[3]),
    measurand!("throttle", "-", Dimensionless, |s, _c| s
        .evaluation
        .controls[4]),
    measurand!("gross_weight", "kg", Mass, |_s, c| c.mass),
    measurand!("n1_left", "-", Dimensionless, |s, c| engine(s, c).n1),
    measurand!("n1_right", "-", Dimensionless, |s, c| engine(s, c).n1),
    measurand!("n2_left", "-", Dimensionless, |s, c| engine(s, c).n2),
    measurand!("n2_right", "-", Dimensionless, |s, c| engine(s, c).n2),
    measurand!("fuel_flow_left", "kg/s", MassFlow, |s, c| engine(s, c)
        .fuel_flow),
    measurand!("fuel_flow_right", "kg/s", MassFlow, |s, c| engine(s, c)
        .fuel_flow),
    measurand!(
        "exhaust_gas_temperature_left",
        "K",
        TemperatureDifference,
        |s, c| engine(s, c).exhaust_gas_temperature
    ),
    measurand!(
        "exhaust_gas_temperature_right",
        "K",
        TemperatureDifference,
        |s, c| engine(s, c).exhaust_gas_temperature
    ),
    measurand!("thrust", "N", Force, |s, _c| s.evaluation.thrust),
    measurand!("density", "kg/m3", Density, |s, _c| s
        .evaluation
        .air
        .density),
    measurand!("static_pressure", "Pa", Pressure, |s, _c| s
        .evaluation
        .air
        .pressure),
    measurand!("p_dot", "rad/s2", AngularAcceleration, |s, _c| s
        .evaluation
        .angular_acceleration
        .x),
    measurand!("q_dot", "rad/s2", AngularAcceleration, |s, _c| s
        .evaluation
        .angular_acceleration
        .y),
    measurand!("r_dot", "rad/s2", AngularAcceleration, |s, _c| s
        .evaluation
        .angular_acceleration
        .z),
];

/// The measurand with this name, if any.
pub fn measurand(name: &str) -> Option<&'static Measurand> {
    MEASURANDS.iter().find(|m| m.name == name)
}

/// Names of all measurands, for error messages.
pub(crate) fn measurand_names() -> Vec<String> {
    MEASURANDS.iter().map(|m| m.name.to_string()).collect()
}

/// Load factors (nx, ny, nz) at the context's sensor position, nz positive up.
pub fn load_factor(s: &TruthSample, context: &Context) -> Vector3<f64> {
    let omega = state::rates(&s.state);
    let arm = context.sensor_position;
    let acceleration = s.evaluation.specific_force
        + s.evaluation.angular_acceleration.cross(&arm)
        + omega.cross(&omega.cross(&arm));
    Vector3::new(acceleration.x, acceleration.y, -acceleration.z) / STANDARD_GRAVITY
}

/// Calibrated airspeed (m/s) for Mach number `mach` at static pressure `pressure` (subsonic).
pub fn calibrated_airspeed(mach: f64, pressure: f64) -> f64 {
    let impact = pressure * ((1.0 + 0.2 * mach * mach).powf(3.5) - 1.0);
    let sea_level_sound = (HEAT_CAPACITY_RATIO * GAS_CONSTANT * SEA_LEVEL_TEMPERATURE).sqrt();
    sea_level_sound * (5.0 * ((impact / SEA_LEVEL_PRESSURE + 1.0).powf(2.0 / 7.0) - 1.0)).sqrt()
}

/// The Mach number (subsonic) whose calibrated airspeed at static pressure
/// `pressure` is `calibrated` (m/s): the inverse of [`calibrated_airspeed`]
/// through the impact pressure q_c = p0·((1 + 0.2·(V_c/a0)²)^3.5 − 1),
/// M = √(5·((q_c/p + 1)^(2/7) − 1)).
pub(crate) fn mach_from_calibrated_airspeed(calibrated: f64, pressure: f64) -> f64 {
    let sea_level_sound = (HEAT_CAPACITY_RATIO * GAS_CONSTANT * SEA_LEVEL_TEMPERATURE).sqrt();
    let ratio = calibrated / sea_level_sound;
    let impact = SEA_LEVEL_PRESSURE * ((1.0 + 0.2 * ratio * ratio).powf(3.5) - 1.0);
    (5.0 * ((impact / pressure + 1.0).powf(2.0 / 7.0) - 1.0)).sqrt()
}

/// The total wind (steady plus turbulence) in NED axes.
fn wind_ned(s: &TruthSample) -> Vector3<f64> {
    s.wind.ned + state::body_to_ned(&s.state) * s.wind.body
}

fn engine(s: &TruthSample, context: &Context) -> EngineReading {
    engine::reading(
        &context.propulsion,
        s.evaluation.thrust,
        s.evaluation.air.density,
        s.evaluation.air.temperature,
    )
}
