//! Combined control surfaces from split ones, by the conventions of
//! [`crate::derived`]: `aileron = (left − right)/2`, `elevator`
//! and `flap` the mean of left and right. A recorder such as a QAR stores
//! each side of a surface; the models read the combined deflection.
//!
//! The combined channel is at the instants of the left channel within the
//! span both sides cover; the right one is interpolated linearly to them
//! without bridging dropouts ([`Channel::values_at_unbridged`]). Both sides
//! quantized to the same resolution r give a combination on a grid of r/2,
//! which is its declared resolution.

use crate::error::{Error, Result};
use crate::{Channel, FlightRecord};

/// A split surface: the combined channel, its two sides, and the sign of
/// the right side in `(left ± right)/2`.
pub struct SplitSurface {
    pub combined: &'static str,
    pub left: &'static str,
    pub right: &'static str,
    pub right_sign: f64,
}

/// The split surfaces the derive step combines.
pub(crate) const SPLIT_SURFACES: [SplitSurface; 3] = [
    SplitSurface {
        combined: "aileron",
        left: "aileron_left",
        right: "aileron_right",
        right_sign: -1.0,
    },
    SplitSurface {
        combined: "elevator",
        left: "elevator_left",
        right: "elevator_right",
        right_sign: 1.0,
    },
    SplitSurface {
        combined: "flap",
        left: "flap_left",
        right: "flap_right",
        right_sign: 1.0,
    },
];

/// The combined channel of one split surface.
pub fn combine(record: &FlightRecord, surface: &SplitSurface) -> Result<Channel> {
    let (left, right) = (
        record.channel(surface.left)?,
        record.channel(surface.right)?,
    );
    for side in [left, right] {
        if side.unit != "rad" {
            return Err(Error::Derivation {
                reason: format!(
                    "channel '{}' is in '{}'; combining it into '{}' reads it in 'rad'",
                    side.name, side.unit, surface.combined
                ),
            });
        }
    }
    let span = |c: &Channel| c.times.first().zip(c.times.last()).map(|(a, b)| (*a, *b));
    let (start, end) = match (span(left), span(right)) {
        (Some((l0, l1)), Some((r0, r1))) => (l0.max(r0), l1.min(r1)),
        _ => (f64::INFINITY, f64::NEG_INFINITY),
    };
    let times: Vec<f64> = left
        .times
        .iter()
        .copied()
        .filter(|t| (start..=end).contains(t))
        .collect();
    if times.is_empty() {
        return Err(Error::Derivation {
            reason: format!(
                "'{}' and '{}' share no time span",
                surface.left, surface.right
            ),
        });
    }
    let (left_values, right_values) = (
        left.values_at_unbridged(&times),
        right.values_at_unbridged(&times),
    );
    let values = left_values
        .iter()
        .zip(&right_values)
        .map(|(l, r)| (l + surface.right_sign * r) / 2.0)
        .collect();
    let resolution = match (left.resolution, right.resolution) {
        (Some(a), Some(b)) if a == b => Some(a / 2.0),
        _ => None,
    };
    Ok(Channel {
        name: surface.combined.to_string(),
        unit: "rad".to_string(),
        rate: left.rate,
        resolution,
        source: format!(
            "combined: ({} {} {})/2 at the instants of {}, {} interpolated linearly",
            surface.left,
            if surface.right_sign < 0.0 { "-" } else { "+" },
            surface.right,
            surface.left,
            surface.right
        ),
        times,
        values,
    })
}

/// The record with every split surface combined where it lacks the
/// combined channel and has both sides, and one note per surface combined.
pub fn with_combined_surfaces(record: &FlightRecord) -> Result<(FlightRecord, Vec<String>)> {
    let mut derived = record.clone();
    let mut notes = Vec::new();
    for surface in &SPLIT_SURFACES {
        let has = |name: &str| record.channel(name).is_ok();
        if has(surface.combined) || !has(surface.left) || !has(surface.right) {
            continue;
        }
        let channel = combine(record, surface)?;
        notes.push(format!(
            "{}: added, ({} {} {})/2",
            surface.combined,
            surface.left,
            if surface.right_sign < 0.0 { "-" } else { "+" },
            surface.right
        ));
        crate::put_channel(&mut derived, channel);
    }
    Ok((derived, notes))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(name: &str, offset: f64, values: Vec<f64>) -> Channel {
        Channel {
            name: name.into(),
            unit: "rad".into(),
            rate: 1.0,
            resolution: Some(0.002),
            source: String::new(),
            times: (0..values.len()).map(|k| offset + k as f64).collect(),
            values,
        }
    }

    /// Ailerons deflected antisymmetrically combine to the left one; the
    /// right side sampled half a second later is interpolated; a record
    /// with the combined channel keeps it.
    #[test]
    fn split_surfaces_combine_by_the_conventions() {
        let ramp: Vec<f64> = (0..10).map(|k| 0.01 * k as f64).collect();
        let record = FlightRecord {
            channels: vec![
                channel("aileron_left", 0.0, ramp.clone()),
                channel("aileron_right", 0.5, ramp.iter().map(|v| -v).collect()),
                channel("elevator_left", 0.0, vec![0.02; 10]),
                channel("elevator_right", 0.0, vec![0.04; 10]),
                channel("flap", 0.0, vec![0.1; 10]),
                channel("flap_left", 0.0, vec![0.3; 10]),
                channel("flap_right", 0.0, vec![0.3; 10]),
            ],
            ..FlightRecord::default()
        };
        let (derived, notes) = with_combined_surfaces(&record).unwrap();
        assert_eq!(notes.len(), 2, "{notes:?}");
        let aileron = derived.channel("aileron").unwrap();
        assert_eq!(aileron.times[0], 1.0);
        assert_eq!(aileron.resolution, Some(0.001));
        for (t, v) in aileron.times.iter().zip(&aileron.values) {
            // (left(t) − right(t))/2 with right(t) = −(left(t − 0.5)), interpolated.
            let expected = (0.01 * t + 0.01 * (t - 0.5)) / 2.0;
            assert!((v - expected).abs() < 1e-12, "{t}: {v}");
        }
        let elevator = derived.channel("elevator").unwrap();
        assert!(elevator.values.iter().all(|v| (v - 0.03).abs() < 1e-15));
        assert_eq!(derived.channel("flap").unwrap().values[0], 0.1);
    }
}
