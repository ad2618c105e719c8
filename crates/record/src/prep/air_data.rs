//! Air density from what a Quick Access Recorder has: pressure altitude,
//! and the static temperature or the total air temperature with the Mach
//! number. Pressure altitude is by definition the ISA altitude of the
//! static pressure, so p = p_ISA(h_p) exactly (ICAO Doc 7488); the static
//! temperature is T = TAT/(1 + 0.2·M²) (adiabatic recovery, recovery factor
//! 1, γ = 1.4); the density is the gas law ρ = p/(R·T). No ISA temperature
//! is assumed: a hot or cold day is in T. The Mach number comes from the
//! calibrated airspeed and p where the record has it (the air-data
//! computer's relation, `mach_from_calibrated_airspeed`: a QAR keeps the
//! airspeed at 1 Hz and the Mach number much slower, 1/36 Hz on
//! qar-seed000, too slow for a decelerating approach), else from the
//! `mach` channel.
//!
//! The channels are derived at the instants of the pressure-altitude
//! channel, the temperature and Mach number read there by linear
//! interpolation (they change slowly; a sample between two of theirs is
//! bridged). Added, each with its source: `static_pressure` (Pa), `temperature`
//! (K, when the record has only the total air temperature) and `density`
//! (kg/m³). A record that has `density` keeps it.

use crate::derived::mach_from_calibrated_airspeed;
use crate::error::Result;
use crate::{Channel, FlightRecord, put_channel};
use aeroid_sim::atmosphere::{Atmosphere, GAS_CONSTANT};

/// Adds `static_pressure`, `temperature` and `density` where the record
/// lacks them and has what they are computed from (module documentation);
/// one note per added channel. A record without pressure altitude or a
/// temperature is returned as it is, with no note.
pub(crate) fn with_air_density(record: &FlightRecord) -> Result<(FlightRecord, Vec<String>)> {
    let mut derived = record.clone();
    let mut notes = Vec::new();
    if record.channel("density").is_ok() {
        return Ok((derived, notes));
    }
    let Ok(altitude) = record.channel("pressure_altitude") else {
        return Ok((derived, notes));
    };
    let times = &altitude.times;
    let (temperature, temperature_source) = match record.channel("temperature") {
        Ok(static_temperature) => (
            static_temperature.values_at(times)?,
            "the temperature channel".to_string(),
        ),
        Err(_) => match temperature_from_total(record, altitude, &mut derived, &mut notes)? {
            Some(temperature) => temperature,
            None => return Ok((derived, notes)),
        },
    };
    let pressure: Vec<f64> = altitude
        .values
        .iter()
        .map(|&h| Atmosphere::standard(h).1)
        .collect();
    let density: Vec<f64> = pressure
        .iter()
        .zip(&temperature)
        .map(|(p, t)| p / (GAS_CONSTANT * t))
        .collect();
    put_channel(
        &mut derived,
        derived_channel(
            altitude,
            "static_pressure",
            "Pa",
            pressure,
            "derived: the ISA pressure at pressure_altitude",
        ),
    );
    put_channel(
        &mut derived,
        derived_channel(
            altitude,
            "density",
            "kg/m3",
            density,
            &format!("derived: static_pressure/(R·T), T from {temperature_source}"),
        ),
    );
    notes.push("static_pressure: added, the ISA pressure at pressure_altitude".into());
    notes.push(format!(
        "density: added, static_pressure/(R·T) with T from {temperature_source}"
    ));
    Ok((derived, notes))
}

/// The static temperature from the total air temperature and the Mach
/// number (from calibrated_airspeed and the ISA pressure, else the mach
/// channel) at the pressure altitude's instants, added to `derived` with
/// its note, and where it came from; None when the record has neither.
fn temperature_from_total(
    record: &FlightRecord,
    altitude: &Channel,
    derived: &mut FlightRecord,
    notes: &mut Vec<String>,
) -> Result<Option<(Vec<f64>, String)>> {
    let times = &altitude.times;
    let Ok(total) = record.channel("total_air_temperature") else {
        return Ok(None);
    };
    let (mach, mach_source) = match (
        record.channel("calibrated_airspeed"),
        record.channel("mach"),
    ) {
        (Ok(calibrated), _) => (
            calibrated
                .values_at(times)?
                .iter()
                .zip(&altitude.values)
                .map(|(&v, &h)| mach_from_calibrated_airspeed(v, Atmosphere::standard(h).1))
                .collect(),
            "mach from calibrated_airspeed and static_pressure",
        ),
        (Err(_), Ok(mach)) => (mach.values_at(times)?, "mach"),
        _ => return Ok(None),
    };
    let total = total.values_at(times)?;
    let values: Vec<f64> = total
        .iter()
        .zip(&mach)
        .map(|(t, m)| t / (1.0 + 0.2 * m * m))
        .collect();
    put_channel(
        derived,
        derived_channel(
            altitude,
            "temperature",
            "K",
            values.clone(),
            &format!(
                "derived: total_air_temperature/(1 + 0.2·M²), M the {mach_source}, at the pressure_altitude instants"
            ),
        ),
    );
    notes.push(format!(
        "temperature: added, total_air_temperature/(1 + 0.2·M²) (recovery factor 1), M the {mach_source}"
    ));
    Ok(Some((
        values,
        format!("total_air_temperature/(1 + 0.2·M²), M the {mach_source}"),
    )))
}

/// A channel on the instants of `base` (its rate; no resolution).
fn derived_channel(
    base: &Channel,
    name: &str,
    unit: &str,
    values: Vec<f64>,
    source: &str,
) -> Channel {
    Channel {
        name: name.into(),
        unit: unit.into(),
        rate: base.rate,
        resolution: None,
        source: source.into(),
        times: base.times.clone(),
        values,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aeroid_sim::atmosphere::Atmosphere;

    fn channel(name: &str, unit: &str, values: Vec<f64>) -> Channel {
        Channel {
            name: name.into(),
            unit: unit.into(),
            rate: 1.0,
            resolution: None,
            source: "test".into(),
            times: (0..values.len()).map(|k| k as f64).collect(),
            values,
        }
    }

    /// On a day 10 K warmer than the ISA at 4000 m pressure altitude, at
    /// Mach 0.5: the static temperature from the total one, the ISA
    /// pressure and the gas law, to rounding.
    #[test]
    fn density_from_pressure_altitude_and_total_temperature() {
        let (standard_temperature, pressure) = Atmosphere::standard(4000.0);
        let temperature = standard_temperature + 10.0;
        let mach = 0.5;
        let record = FlightRecord {
            channels: vec![
                channel("pressure_altitude", "m", vec![4000.0; 3]),
                channel("mach", "-", vec![mach; 3]),
                channel(
                    "total_air_temperature",
                    "K",
                    vec![temperature * (1.0 + 0.2 * mach * mach); 3],
                ),
            ],
            ..FlightRecord::default()
        };
        let (derived, notes) = with_air_density(&record).unwrap();
        let density = derived.channel("density").unwrap();
        let expected = pressure / (GAS_CONSTANT * temperature);
        assert!((density.values[1] / expected - 1.0).abs() < 1e-12);
        assert!((derived.channel("temperature").unwrap().values[0] - temperature).abs() < 1e-9);
        assert_eq!(notes.len(), 3, "{notes:?}");
        // With a calibrated airspeed the Mach number comes from it.
        let calibrated = crate::derived::calibrated_airspeed(mach, pressure);
        assert!((mach_from_calibrated_airspeed(calibrated, pressure) - mach).abs() < 1e-12);
        let mut with_airspeed = record.clone();
        with_airspeed.channels[1] = channel("calibrated_airspeed", "m/s", vec![calibrated; 3]);
        let (from_airspeed, _) = with_air_density(&with_airspeed).unwrap();
        let value = from_airspeed.channel("density").unwrap().values[0];
        assert!((value / expected - 1.0).abs() < 1e-12);
        // A record with density, or without a temperature, is left alone.
        let (again, notes) = with_air_density(&derived).unwrap();
        assert!(notes.is_empty());
        assert_eq!(again.channels.len(), derived.channels.len());
        let mut bare = record.clone();
        bare.channels.truncate(1);
        assert!(with_air_density(&bare).unwrap().1.is_empty());
    }
}
