//! Geometric angle of attack and sideslip from ground speed, track,
//! flight-path angle, attitude and the recorded wind: Wang Q., Wu K., Zhang
//! T., Kong Y., Qian W., "Aerodynamic modeling and parameter estimation from
//! QAR data of an airplane approaching a high-altitude airport", Chinese
//! Journal of Aeronautics 25 (2012) 361–371, §3.1, Eqs. 1–6. A Quick Access
//! Recorder often has no usable angle-of-attack vane (the paper's read only
//! 109.70° or 108.30°) and no sideslip at all; the kinematics give both.
//!
//! At one instant, with V_g the horizontal ground speed, χ the true track,
//! γ the flight-path angle (relative to the ground), φ, θ, ψ roll, pitch and
//! heading, V_w the horizontal wind speed and ψ_w the direction it blows
//! FROM (meteorological, as recorded; see [`crate::derived`]):
//! - Eq. 1, the aircraft's velocity over the ground in the aircraft-carried
//!   normal earth axes (north, east, down):
//!   `(V_g·cos χ, V_g·sin χ, −V_g·tan γ)`. The paper writes V·cos γ for the
//!   horizontal part; a recorder's ground speed is that horizontal part.
//! - Eq. 2, the wind's velocity in the same axes: `(−V_w·cos ψ_w,
//!   −V_w·sin ψ_w, 0)`. The paper's ψ_w is where the wind blows TO; the
//!   minus signs turn the recorded FROM direction into it. The vertical wind
//!   is unknown and taken as 0.
//! - Eq. 3, the velocity relative to the air: ground minus wind.
//! - Eqs. 4–5, into body axes by the 3-2-1 Euler rotation
//!   ([`aeroid_sim::state::ned_to_body`], the matrix of Eq. 5).
//! - Eq. 6, `α = atan2(w, u)`, `β = asin(v/|V|)`.
//!
//! Without the wind correction Eq. 2 is left out (wind 0): what the paper's
//! dashed lines in its Fig. 3 show.
//!
//! The angles are computed at the instants of the fastest needed channel,
//! within the span every needed channel covers, the others interpolated
//! linearly (angles after unwrapping); a dropout is not bridged.
//!
//! # Error from the channels' resolution
//! A channel quantized to a resolution r_i has an error within ±r_i/2,
//! σ_i = r_i/√12, so to first order `σ_α² = Σ_i (∂α/∂x_i)²·r_i²/12` and
//! `|δα| ≤ Σ_i |∂α/∂x_i|·r_i/2`, likewise β ([`resolution_error`]). With
//! the QAR of Wang et al. Table 1, σ_α ≈ 0.105° and σ_β ≈ 0.30°: the 1°
//! track resolution dominates β (`tests/simulation/flow_angles.rs`).

use crate::error::{Error, Result};
use crate::{Channel, FlightRecord, derived};
use aeroid_sim::state::ned_to_body;
use nalgebra::Vector3;

/// The channels Eqs. 1–6 read, in the order of [`Inputs::to_array`]; the
/// first six (attitude and flight path) break ties for the time base.
pub const INPUT_CHANNELS: [&str; 8] = [
    "pitch",
    "roll",
    "yaw",
    "flight_path_angle",
    "track",
    "ground_speed",
    "wind_speed",
    "wind_direction",
];

/// The channels a computation without wind correction needs.
const WITHOUT_WIND: usize = 6;

/// The inputs of Eqs. 1–6 at one instant (SI, angles in rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inputs {
    pub pitch: f64,
    pub roll: f64,
    pub yaw: f64,
    pub flight_path_angle: f64,
    pub track: f64,
    /// Horizontal ground speed (m/s).
    pub ground_speed: f64,
    /// Horizontal wind speed (m/s).
    pub wind_speed: f64,
    /// Where the wind blows FROM (rad, meteorological).
    pub wind_direction: f64,
}

impl Inputs {
    /// The inputs in the order of [`INPUT_CHANNELS`].
    pub fn to_array(&self) -> [f64; 8] {
        [
            self.pitch,
            self.roll,
            self.yaw,
            self.flight_path_angle,
            self.track,
            self.ground_speed,
            self.wind_speed,
            self.wind_direction,
        ]
    }

    /// Inputs from values in the order of [`INPUT_CHANNELS`].
    pub fn from_array(x: [f64; 8]) -> Inputs {
        Inputs {
            pitch: x[0],
            roll: x[1],
            yaw: x[2],
            flight_path_angle: x[3],
            track: x[4],
            ground_speed: x[5],
            wind_speed: x[6],
            wind_direction: x[7],
        }
    }
}

/// Whether the recorded wind is removed from the ground velocity (Eq. 2–3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wind {
    /// Relative to the air: the recorded horizontal wind is removed.
    Corrected,
    /// Relative to the ground (wind taken as 0); the wind channels are not needed.
    Uncorrected,
}

/// The air-relative velocity in body axes (Eqs. 1–5).
fn body_air_velocity(x: &Inputs, wind: Wind) -> Vector3<f64> {
    let (sin_track, cos_track) = x.track.sin_cos();
    let ground = Vector3::new(
        x.ground_speed * cos_track,
        x.ground_speed * sin_track,
        -x.ground_speed * x.flight_path_angle.tan(),
    );
    let air_mass = match wind {
        Wind::Corrected => {
            let (sin_from, cos_from) = x.wind_direction.sin_cos();
            Vector3::new(-x.wind_speed * cos_from, -x.wind_speed * sin_from, 0.0)
        }
        Wind::Uncorrected => Vector3::zeros(),
    };
    ned_to_body(x.roll.sin_cos(), x.pitch.sin_cos(), x.yaw.sin_cos()) * (ground - air_mass)
}

/// The true airspeed at one instant: the norm of the air-relative velocity
/// of Eq. 3 (the vertical wind taken as 0).
pub fn airspeed(x: &Inputs, wind: Wind) -> f64 {
    body_air_velocity(x, wind).norm()
}

/// Angle of attack and sideslip (rad) at one instant (Eqs. 1–6).
pub fn flow_angles(x: &Inputs, wind: Wind) -> (f64, f64) {
    let velocity = body_air_velocity(x, wind);
    let speed = velocity.norm();
    // A dropout in an input (NaN) stays a dropout; standing still relative to the air is β = 0.
    let beta = if speed == 0.0 {
        0.0
    } else {
        (velocity.y / speed).clamp(-1.0, 1.0).asin()
    };
    (velocity.z.atan2(velocity.x), beta)
}

/// Partial derivatives of (α, β) with respect to each input, in the order
/// of [`INPUT_CHANNELS`], by central differences of Eqs. 1–6.
pub fn sensitivities(x: &Inputs, wind: Wind) -> [(f64, f64); 8] {
    let base = x.to_array();
    std::array::from_fn(|i| {
        // 1e-6 rad or 1e-4 m/s: far above rounding, far below curvature.
        let h = if i == 5 || i == 6 { 1e-4 } else { 1e-6 };
        let shifted = |sign: f64| {
            let mut values = base;
            values[i] += sign * h;
            flow_angles(&Inputs::from_array(values), wind)
        };
        let (up, down) = (shifted(1.0), shifted(-1.0));
        ((up.0 - down.0) / (2.0 * h), (up.1 - down.1) / (2.0 * h))
    })
}

/// First-order effect on (α, β) of the inputs' quantization to `resolutions`
/// (in the order of [`INPUT_CHANNELS`], 0 for none).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResolutionError {
    /// `√(Σ (∂α/∂x_i)²·r_i²/12)` and the same for β (rad).
    pub sigma: (f64, f64),
    /// `Σ |∂α/∂x_i|·r_i/2` and the same for β (rad): the largest error.
    pub bound: (f64, f64),
}

/// The error of (α, β) that quantization to `resolutions` predicts at `x`.
///
/// To first order, an error δx_i in input i moves the angles by
/// `δα = Σ_i ∂α/∂x_i·δx_i` (likewise β). A channel quantized to a
/// resolution r_i has an error within ±r_i/2, uniform with standard
/// deviation `σ_i = r_i/√12` when the signal crosses many steps; the
/// partials are central differences of the exact Eqs. 1–6. An input
/// interpolated at weight w between two samples averages two independent
/// errors: its σ is √(w² + (1 − w)²)·r_i/√12 (the bound stays r_i/2).
/// Wings level with small γ and β the dominant terms are `∂α/∂θ = 1`,
/// `∂α/∂γ ≈ −V_g/V_h` and `∂β/∂ψ = −1`, `∂β/∂χ ≈ V_g/V_h` (V_h the
/// horizontal airspeed); the wind enters through the cross-track
/// component, `∂β/∂ψ_w ≈ V_w·cos(ψ_w − ψ)/V`. With the QAR of Wang et al.
/// Table 1 (θ, φ 0.1°, ψ 0.3°, γ 0.35°, χ 1°, V_g 0.5 kt, V_w 0.1 kt, ψ_w
/// 0.5°) that is σ_α ≈ √(0.029² + 0.101²) ≈ 0.105° and
/// σ_β ≈ √(0.087² + 0.289²) ≈ 0.30°. What the formula predicts and what
/// the gusts add is measured in `tests/simulation/flow_angles.rs`
/// (docs/cli.md, `derive`).
pub fn resolution_error(x: &Inputs, wind: Wind, resolutions: &[f64; 8]) -> ResolutionError {
    let partials = sensitivities(x, wind);
    let mut variance = (0.0, 0.0);
    let mut bound = (0.0, 0.0);
    for ((d_alpha, d_beta), r) in partials.iter().zip(resolutions) {
        variance.0 += (d_alpha * r).powi(2) / 12.0;
        variance.1 += (d_beta * r).powi(2) / 12.0;
        bound.0 += (d_alpha * r).abs() / 2.0;
        bound.1 += (d_beta * r).abs() / 2.0;
    }
    ResolutionError {
        sigma: (variance.0.sqrt(), variance.1.sqrt()),
        bound,
    }
}

/// The geometric angles of a record and what they were computed from.
#[derive(Debug, Clone)]
pub struct GeometricFlowAngles {
    /// Channel `alpha` (rad) on the time base of [`Self::time_base`].
    pub alpha: Channel,
    /// Channel `beta` (rad) on the same time base.
    pub beta: Channel,
    /// Channel `airspeed` (m/s, true airspeed: the norm of Eq. 3) on the
    /// same time base.
    pub airspeed: Channel,
    /// The channel whose instants the angles are computed at.
    pub time_base: String,
    /// The inputs at each instant of the time base (NaN in a dropout).
    pub inputs: Vec<Inputs>,
    /// The resolutions of the inputs as recorded (0 where none is declared).
    pub resolutions: [f64; 8],
    /// Per instant, each input's resolution scaled by √(w² + (1 − w)²), w
    /// the weight of its later sample in the interpolation: the σ of an
    /// interpolated input (two independent quantization errors averaged).
    pub interpolated_resolutions: Vec<[f64; 8]>,
    /// The RMS over the record of the per-instant σ of [`resolution_error`]
    /// with [`Self::interpolated_resolutions`] (rad).
    pub predicted_sigma: (f64, f64),
}

/// Computes α and β of a record by Eqs. 1–6 (see the module
/// documentation for the time base and dropouts). An error names every
/// needed channel the record lacks, or one in a unit other than SI.
pub fn geometric_flow_angles(record: &FlightRecord, wind: Wind) -> Result<GeometricFlowAngles> {
    let needed = match wind {
        Wind::Corrected => &INPUT_CHANNELS[..],
        Wind::Uncorrected => &INPUT_CHANNELS[..WITHOUT_WIND],
    };
    let channels = needed_channels(record, needed, wind)?;
    let reference = channels.iter().enumerate().fold(0, |best, (i, c)| {
        if c.rate > channels[best].rate {
            i
        } else {
            best
        }
    });
    let times = crate::shared_instants(&channels, reference);
    if times.is_empty() {
        return Err(Error::Derivation {
            reason: format!(
                "geometric angle of attack and sideslip: the channels {} share no time span",
                needed.join(", ")
            ),
        });
    }
    let columns: Vec<Vec<f64>> = channels
        .iter()
        .map(|c| unwrapped(c).values_at_unbridged(&times))
        .collect();
    let inputs: Vec<Inputs> = (0..times.len())
        .map(|k| {
            let mut x = [0.0; 8];
            for (slot, column) in x.iter_mut().zip(&columns) {
                *slot = column[k];
            }
            Inputs::from_array(x)
        })
        .collect();
    let mut resolutions = [0.0; 8];
    for (slot, channel) in resolutions.iter_mut().zip(&channels) {
        *slot = channel.resolution.unwrap_or(0.0);
    }
    let interpolated_resolutions = interpolated(&channels, resolutions, &times);
    let (alpha, beta): (Vec<f64>, Vec<f64>) = inputs.iter().map(|x| flow_angles(x, wind)).unzip();
    let predicted_sigma = rms_sigma(&inputs, wind, &interpolated_resolutions);
    let source = format!(
        "geometric (Wang et al. 2012, Eqs. 1-6) from {}{} at the instants of {}, the others interpolated linearly",
        needed.join(", "),
        match wind {
            Wind::Corrected => "",
            Wind::Uncorrected => " without wind correction",
        },
        channels[reference].name
    );
    let speeds: Vec<f64> = inputs.iter().map(|x| airspeed(x, wind)).collect();
    let channel = |name: &str, values: Vec<f64>| Channel {
        name: name.to_string(),
        unit: if name == "airspeed" { "m/s" } else { "rad" }.to_string(),
        rate: channels[reference].rate,
        resolution: None,
        source: source.clone(),
        times: times.clone(),
        values,
    };
    Ok(GeometricFlowAngles {
        alpha: channel("alpha", alpha),
        beta: channel("beta", beta),
        airspeed: channel("airspeed", speeds),
        time_base: channels[reference].name.clone(),
        inputs,
        resolutions,
        interpolated_resolutions,
        predicted_sigma,
    })
}

/// Per instant of `times`, each channel's resolution scaled by
/// √(w² + (1 − w)²), w the weight of its later sample in the
/// interpolation.
fn interpolated(channels: &[&Channel], resolutions: [f64; 8], times: &[f64]) -> Vec<[f64; 8]> {
    times
        .iter()
        .map(|&t| {
            let mut scaled = resolutions;
            for (slot, channel) in scaled.iter_mut().zip(channels) {
                let w = interpolation_weight(&channel.times, t);
                *slot *= (w * w + (1.0 - w) * (1.0 - w)).sqrt();
            }
            scaled
        })
        .collect()
}

/// A record with the geometric angles in it, and what was done, per channel.
#[derive(Debug, Clone)]
pub(crate) struct Derivation {
    pub record: FlightRecord,
    pub angles: GeometricFlowAngles,
    /// One line per angle: added, replaced (and why) or added beside the recorded one.
    pub notes: Vec<String>,
}

/// The record with the geometric `alpha` and `beta` in it, and the
/// geometric true `airspeed` where the record has none. Where the record
/// has no such channel the geometric one is added; where its channel is
/// unusable by the quality report ([`crate::quality`]: stuck or
/// with implausible steps) it is replaced, and the note says what was
/// wrong; a usable recorded channel is kept and the geometric one added as
/// `alpha_geometric` (`beta_geometric`), unless `replace`. An added angle
/// leaves the record's `absent` list.
pub(crate) fn with_geometric_flow_angles(
    record: &FlightRecord,
    wind: Wind,
    replace: bool,
) -> Result<Derivation> {
    let angles = geometric_flow_angles(record, wind)?;
    let mut derived = record.clone();
    let mut notes = Vec::new();
    for channel in [&angles.alpha, &angles.beta] {
        let name = channel.name.clone();
        let recorded = record.channel(&name).ok();
        let quality = recorded.map(crate::quality::assess_channel);
        let (target, note) = match quality {
            None => (name.clone(), format!("{name}: added (geometric)")),
            Some(q) if q.is_unusable() => (
                name.clone(),
                format!(
                    "{name}: the recorded channel is left out ({}); replaced by the geometric one",
                    q.flags()
                ),
            ),
            Some(_) if replace => (
                name.clone(),
                format!("{name}: the recorded channel is replaced by the geometric one"),
            ),
            Some(_) => {
                let target = format!("{name}_geometric");
                let note = format!(
                    "{name}: the recorded channel is kept (no quality flag); the geometric one is added as {target}"
                );
                (target, note)
            }
        };
        crate::put_channel(
            &mut derived,
            Channel {
                name: target,
                ..channel.clone()
            },
        );
        notes.push(note);
    }
    if record.channel("airspeed").is_err() {
        crate::put_channel(&mut derived, angles.airspeed.clone());
        notes
            .push("airspeed: added (geometric, the norm of the air-relative velocity)".to_string());
    }
    Ok(Derivation {
        record: derived,
        angles,
        notes,
    })
}

/// The needed channels of the record, or an error naming every one it lacks
/// or holds in a unit other than the SI one.
fn needed_channels<'a>(
    record: &'a FlightRecord,
    needed: &[&str],
    wind: Wind,
) -> Result<Vec<&'a Channel>> {
    let missing: Vec<&str> = needed
        .iter()
        .copied()
        .filter(|name| record.channel(name).is_err())
        .collect();
    if !missing.is_empty() {
        let hint = match wind {
            Wind::Corrected if missing.iter().all(|m| m.starts_with("wind_")) => {
                " (without wind correction they are not needed)"
            }
            _ => "",
        };
        return Err(Error::Derivation {
            reason: format!(
                "geometric angle of attack and sideslip need the channel(s) {}, which the record lacks{hint}",
                missing.join(", ")
            ),
        });
    }
    needed
        .iter()
        .map(|name| {
            let channel = record.channel(name)?;
            let unit = derived::measurand(name).map_or("", |m| m.unit);
            if channel.unit != unit {
                return Err(Error::Derivation { reason: format!(
                    "channel '{name}' is in '{}'; geometric angle of attack and sideslip read it in '{unit}'",
                    channel.unit
                ) });
            }
            Ok(channel)
        })
        .collect()
}

/// The channel with its angle unwrapped when it is a heading or direction.
fn unwrapped(channel: &Channel) -> std::borrow::Cow<'_, Channel> {
    match derived::measurand(&channel.name) {
        Some(measurand) if measurand.wraps => {
            let mut copy = channel.clone();
            crate::unwrap_angles(&mut copy.values);
            std::borrow::Cow::Owned(copy)
        }
        _ => std::borrow::Cow::Borrowed(channel),
    }
}

/// The weight of the later of the two samples around `t` in a linear
/// interpolation (0 on a sample and outside the samples).
fn interpolation_weight(times: &[f64], t: f64) -> f64 {
    let after = times.partition_point(|&time| time < t);
    if after == 0 || after == times.len() || times[after] == t {
        return 0.0;
    }
    (t - times[after - 1]) / (times[after] - times[after - 1])
}

/// RMS over the valid instants of the per-instant σ of [`resolution_error`].
fn rms_sigma(inputs: &[Inputs], wind: Wind, resolutions: &[[f64; 8]]) -> (f64, f64) {
    let mut sum = (0.0, 0.0);
    let mut count = 0usize;
    for (x, resolutions) in inputs
        .iter()
        .zip(resolutions)
        .filter(|(x, _)| x.to_array().iter().all(|v| !v.is_nan()))
    {
        let sigma = resolution_error(x, wind, resolutions).sigma;
        sum.0 += sigma.0 * sigma.0;
        sum.1 += sigma.1 * sigma.1;
        count += 1;
    }
    let n = count.max(1) as f64;
    ((sum.0 / n).sqrt(), (sum.1 / n).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use aeroid_core::units::DEG;

    fn level(yaw: f64) -> Inputs {
        Inputs {
            pitch: 3.0 * DEG,
            roll: 0.0,
            yaw,
            flight_path_angle: 0.0,
            track: yaw,
            ground_speed: 100.0,
            wind_speed: 0.0,
            wind_direction: 0.0,
        }
    }

    /// In still air on a level path the angle of attack is the pitch angle
    /// and there is no sideslip, whatever the heading.
    #[test]
    fn still_air_level_flight_has_alpha_equal_to_pitch() {
        for yaw in [0.0, 1.0, 3.0, 6.0] {
            let (alpha, beta) = flow_angles(&level(yaw), Wind::Corrected);
            assert!((alpha - 3.0 * DEG).abs() < 1e-12, "{alpha}");
            assert!(beta.abs() < 1e-12, "{beta}");
        }
    }

    /// Flying north with a wind FROM the west (270°) the aircraft must crab
    /// into it: with the nose on the track the air comes from the left, a
    /// negative sideslip of atan(V_w/V_g); uncorrected it is 0.
    #[test]
    fn crosswind_from_the_west_gives_negative_sideslip() {
        let x = Inputs {
            pitch: 0.0,
            wind_speed: 10.0,
            wind_direction: 270.0 * DEG,
            ..level(0.0)
        };
        let (alpha, beta) = flow_angles(&x, Wind::Corrected);
        assert!(alpha.abs() < 1e-12);
        assert!((beta + (10.0f64 / 100.0).atan()).abs() < 1e-12, "{beta}");
        assert_eq!(flow_angles(&x, Wind::Uncorrected).1, 0.0);
    }

    fn channel(name: &str, unit: &str, rate: f64, offset: f64, values: Vec<f64>) -> Channel {
        Channel {
            name: name.into(),
            unit: unit.into(),
            rate,
            resolution: None,
            source: String::new(),
            times: (0..values.len())
                .map(|k| offset + k as f64 / rate)
                .collect(),
            values,
        }
    }

    /// The time-base convention: 1 Hz attitude and flight path (pitch at
    /// 0.1 s into each second, the others later; heading and track at the
    /// same instants), wind at 1/4 Hz from 0 to
    /// 16 s. The angles come at pitch's instants within 0.2…16 s (the span
    /// all channels cover: the first track sample is at 0.2 s), a track
    /// dropout at 5.2 s makes the two instants around it (5.1 s, 6.1 s)
    /// dropouts, and a
    /// heading through north (359.5° → 0.5°) is interpolated through 0°.
    #[test]
    fn angles_are_at_the_fastest_channel_within_the_common_span() {
        let n = 20;
        let heading = |k: usize| ((359.5 + 0.1 * k as f64) * DEG).rem_euclid(std::f64::consts::TAU);
        let mut track: Vec<f64> = (0..n).map(heading).collect();
        track[5] = f64::NAN;
        let record = FlightRecord {
            channels: vec![
                channel("pitch", "rad", 1.0, 0.1, vec![0.05; n]),
                channel("roll", "rad", 1.0, 0.1, vec![0.0; n]),
                channel("yaw", "rad", 1.0, 0.2, (0..n).map(heading).collect()),
                channel("flight_path_angle", "rad", 1.0, 0.15, vec![0.0; n]),
                channel("track", "rad", 1.0, 0.2, track),
                channel("ground_speed", "m/s", 1.0, 0.2, vec![100.0; n]),
                channel("wind_speed", "m/s", 0.25, 0.0, vec![0.0; 5]),
                channel("wind_direction", "rad", 0.25, 0.0, vec![0.0; 5]),
            ],
            ..FlightRecord::default()
        };
        let angles = geometric_flow_angles(&record, Wind::Corrected).unwrap();
        assert_eq!(angles.time_base, "pitch");
        let expected: Vec<f64> = (1..16).map(|k| 0.1 + k as f64).collect();
        assert_eq!(angles.alpha.times, expected);
        for (t, (alpha, beta)) in expected
            .iter()
            .zip(angles.alpha.values.iter().zip(&angles.beta.values))
        {
            if (5.0..7.0).contains(t) {
                assert!(alpha.is_nan() && beta.is_nan(), "{t}");
            } else {
                // Heading and track move together, so the flow stays on the nose.
                assert!(
                    (alpha - 0.05).abs() < 1e-12 && beta.abs() < 1e-9,
                    "{t}: {alpha} {beta}"
                );
            }
        }
    }

    /// The central-difference partials match the closed forms of the module
    /// documentation where those are exact: wings level, level path, still
    /// air, ∂α/∂θ = 1, ∂α/∂γ = −1, ∂β/∂ψ = −1, ∂β/∂χ = 1 (to 1e-6, the
    /// difference quotient's truncation).
    #[test]
    fn sensitivities_match_the_closed_forms() {
        let partials = sensitivities(&level(0.5), Wind::Corrected);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-6;
        assert!(close(partials[0].0, 1.0), "{:?}", partials[0]);
        assert!(close(partials[3].0, -1.0), "{:?}", partials[3]);
        assert!(close(partials[2].1, -1.0), "{:?}", partials[2]);
        assert!(close(partials[4].1, 1.0), "{:?}", partials[4]);
    }
}
