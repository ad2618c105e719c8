//! Thrust from the engines' fuel flow, for records that carry no thrust or
//! throttle (a Quick Access Recorder keeps fuel flow, N2 and EGT per
//! engine: Wang et al. 2012, Table 1, who leave the axial force out because
//! "the thrust force of engine cannot be reckoned accurately from the QAR
//! data").
//!
//! The engine model is the user's, stated with the derive step: a constant
//! thrust-specific fuel consumption c (kg/(N·s)) and an idle flow ṁ₀
//! (kg/s per engine), so that each engine gives T_i = (ṁ_i − ṁ₀)/c and the
//! `thrust` channel is Σ_i T_i (N), along the aircraft's thrust line. This
//! is the first-order model of performance analysis (TSFC taken constant
//! over the segment: Torenbeek, "Synthesis of Subsonic Airplane Design",
//! 1982, §6.3 on specific fuel consumption; a real analysis would read the
//! manufacturer's engine deck at the recorded N1 or N2, Mach and altitude).
//! An error in c scales the thrust by 1/(1 + δc/c): it is a model error no
//! Cramér–Rao bound knows, and what it does to the estimates is measured in
//! docs/findings.md ("The QAR approach").
//!
//! The channel is formed at the instants of the first fuel-flow channel
//! (by name), the others read there by linear interpolation; a dropout in
//! any engine's flow is a dropout of the thrust. The resolution of the sum
//! is Σ LSB_i/c, the first-order effect of the flows' quantization.

use crate::error::{Error, Result};
use crate::{Channel, FlightRecord, put_channel};

/// The fuel-flow engine model of the derive step (module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FuelFlowThrust {
    /// Thrust-specific fuel consumption, kg/(N·s).
    pub specific_fuel_consumption: f64,
    /// Fuel flow at zero thrust, kg/s per engine.
    pub idle_fuel_flow: f64,
}

/// The record's fuel-flow channels: `fuel_flow`, or `fuel_flow_*` (one per
/// engine), in name order.
fn fuel_flow_channels(record: &FlightRecord) -> Vec<&Channel> {
    let mut channels: Vec<&Channel> = record
        .channels
        .iter()
        .filter(|c| c.name == "fuel_flow" || c.name.starts_with("fuel_flow_"))
        .collect();
    channels.sort_by(|a, b| a.name.cmp(&b.name));
    channels
}

impl FuelFlowThrust {
    /// An error unless the specific fuel consumption is positive and the
    /// idle fuel flow non-negative, both finite.
    fn check(&self) -> Result<()> {
        let (c, idle) = (self.specific_fuel_consumption, self.idle_fuel_flow);
        if !(c.is_finite() && c > 0.0) {
            return Err(Error::Derivation {
                reason: format!(
                    "thrust from fuel flow: the specific fuel consumption {c} kg/(N·s) must be a positive finite number"
                ),
            });
        }
        if !(idle.is_finite() && idle >= 0.0) {
            return Err(Error::Derivation {
                reason: format!(
                    "thrust from fuel flow: the idle fuel flow {idle} kg/s must be a non-negative finite number"
                ),
            });
        }
        Ok(())
    }
}

/// Adds the `thrust` channel from the fuel flow (module documentation); a
/// record that has `thrust` keeps it. An error names what is wrong: a model
/// constant that is not a positive (idle: non-negative) finite number, a
/// record without a fuel-flow channel, or a fuel-flow channel in another
/// unit than kg/s.
pub(crate) fn with_thrust_from_fuel_flow(
    record: &FlightRecord,
    model: &FuelFlowThrust,
) -> Result<(FlightRecord, Vec<String>)> {
    let FuelFlowThrust {
        specific_fuel_consumption: c,
        idle_fuel_flow: idle,
    } = *model;
    model.check()?;
    let mut derived = record.clone();
    if record.channel("thrust").is_ok() {
        return Ok((
            derived,
            vec!["thrust: the record has a 'thrust' channel; the fuel flow was not used".into()],
        ));
    }
    let engines = fuel_flow_channels(record);
    let Some(base) = engines.first() else {
        return Err(Error::Derivation {
            reason: format!(
                "thrust from fuel flow: the record has no 'fuel_flow' or 'fuel_flow_*' channel; channels present: {}",
                record
                    .channels
                    .iter()
                    .map(|c| c.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        });
    };
    if let Some(other) = engines.iter().find(|c| c.unit != "kg/s") {
        return Err(Error::Derivation {
            reason: format!(
                "thrust from fuel flow: channel '{}' is in '{}', not kg/s",
                other.name, other.unit
            ),
        });
    }
    let mut values = vec![0.0; base.times.len()];
    for engine in &engines {
        for (sum, flow) in values.iter_mut().zip(engine.values_at(&base.times)?) {
            *sum += (flow - idle) / c;
        }
    }
    let resolution = engines
        .iter()
        .map(|e| e.resolution.map(|r| r / c))
        .sum::<Option<f64>>();
    let names: Vec<&str> = engines.iter().map(|e| e.name.as_str()).collect();
    let source = format!(
        "derived: Σ (fuel flow − {idle} kg/s)/({c:e} kg/(N·s)) over {}, the user's engine model, at the {} instants",
        names.join(", "),
        base.name
    );
    put_channel(
        &mut derived,
        Channel {
            name: "thrust".into(),
            unit: "N".into(),
            rate: base.rate,
            resolution,
            source,
            times: base.times.clone(),
            values,
        },
    );
    let note = format!(
        "thrust: added from {} by a constant thrust-specific fuel consumption {c:e} kg/(N·s) and idle flow {idle} kg/s per engine (the user's engine model: an error in it scales the thrust)",
        names.join(" + ")
    );
    Ok((derived, vec![note]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flow(name: &str, times: Vec<f64>, values: Vec<f64>) -> Channel {
        Channel {
            name: name.into(),
            unit: "kg/s".into(),
            rate: 1.0,
            resolution: Some(0.002),
            source: "test".into(),
            times,
            values,
        }
    }

    fn record(channels: Vec<Channel>) -> FlightRecord {
        FlightRecord {
            scenario: "test".into(),
            seed: None,
            profile: "test".into(),
            absent: Vec::new(),
            channels,
            bridge_gaps: false,
        }
    }

    const MODEL: FuelFlowThrust = FuelFlowThrust {
        specific_fuel_consumption: 2.0e-5,
        idle_fuel_flow: 0.02,
    };

    /// Two engines, the right one sampled half a second later: each flow
    /// above idle over c, summed at the left channel's instants.
    #[test]
    fn engines_are_summed_at_the_first_channels_instants() {
        let left = flow(
            "fuel_flow_left",
            vec![0.0, 1.0, 2.0],
            vec![0.22, 0.32, 0.42],
        );
        let right = flow(
            "fuel_flow_right",
            vec![0.5, 1.5, 2.5],
            vec![0.12, 0.22, 0.32],
        );
        let (derived, notes) =
            with_thrust_from_fuel_flow(&record(vec![right, left]), &MODEL).unwrap();
        let thrust = derived.channel("thrust").unwrap();
        assert_eq!(thrust.times, [0.0, 1.0, 2.0]);
        // Right: held at 0.12 before its first sample, 0.17 at 1.0 s and
        // 0.27 at 2.0 s (linear); each minus the idle 0.02 kg/s.
        let expected = [
            (0.20 + 0.10) / 2e-5,
            (0.30 + 0.15) / 2e-5,
            (0.40 + 0.25) / 2e-5,
        ];
        for (got, want) in thrust.values.iter().zip(expected) {
            assert!((got - want).abs() < 1e-6 * want, "{got} {want}");
        }
        assert!((thrust.resolution.unwrap() - 200.0).abs() < 1e-9);
        assert!(
            notes[0].contains("fuel_flow_left + fuel_flow_right"),
            "{notes:?}"
        );
        assert!(thrust.source.contains("user's engine model"));
    }

    #[test]
    fn a_recorded_thrust_is_kept_and_bad_input_is_named() {
        let mut thrust = flow("thrust", vec![0.0], vec![1.0]);
        thrust.unit = "N".into();
        let (kept, notes) = with_thrust_from_fuel_flow(&record(vec![thrust]), &MODEL).unwrap();
        assert_eq!(kept.channel("thrust").unwrap().values, [1.0]);
        assert!(notes[0].contains("not used"));
        let none = with_thrust_from_fuel_flow(&record(vec![]), &MODEL).unwrap_err();
        assert!(none.to_string().contains("no 'fuel_flow'"), "{none}");
        let mut pounds = flow("fuel_flow_1", vec![0.0], vec![1.0]);
        pounds.unit = "lb/h".into();
        let unit = with_thrust_from_fuel_flow(&record(vec![pounds]), &MODEL).unwrap_err();
        assert!(unit.to_string().contains("'fuel_flow_1'"), "{unit}");
        let zero = FuelFlowThrust {
            specific_fuel_consumption: 0.0,
            ..MODEL
        };
        let bad = with_thrust_from_fuel_flow(&record(vec![]), &zero).unwrap_err();
        assert!(
            bad.to_string().contains("specific fuel consumption"),
            "{bad}"
        );
    }
}
