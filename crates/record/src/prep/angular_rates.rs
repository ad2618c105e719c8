//! Body angular rates p, q, r from the attitude kinematics, for a record
//! without rate gyros (a Quick Access Recorder). The Euler angles are
//! differentiated by the local polynomial differentiator
//! ([`crate::prep::differentiation`]; dropouts are left out of its windows)
//! after the heading is unwrapped, and the inverse kinematic equations of
//! the 3-2-1 rotation give the body rates:
//!
//! ```text
//! p = φ̇ − ψ̇·sin θ
//! q = θ̇·cos φ + ψ̇·cos θ·sin φ
//! r = −θ̇·sin φ + ψ̇·cos θ·cos φ
//! ```
//!
//! # Time base
//! The rates are computed at the derivative instants of the fastest of
//! `pitch`, `roll`, `yaw` (on a tie the first in that order), within the
//! span every derivative covers (the differentiator's first and last m
//! samples have none). The other angles and their derivatives are
//! interpolated linearly to those instants without bridging dropouts
//! ([`Channel::values_at_unbridged`]).
//!
//! # Error
//! The differentiator is linear: on a uniform grid its slope is Σ w_j·x_j
//! with fixed weights. White attitude errors of standard deviation σ give a
//! derivative error of σ·‖w‖ (‖w‖ = √Σ w_j², [`Differentiator::noise_gain`],
//! in 1/s: it grows like m^(−3/2)/Δt with the half-window m and the sample
//! interval Δt). Through the kinematic equations, with g_i = ‖w‖·σ_i:
//!
//! ```text
//! σ_p² = g_φ² + sin²θ·g_ψ²
//! σ_q² = cos²φ·g_θ² + cos²θ·sin²φ·g_ψ²
//! σ_r² = sin²φ·g_θ² + cos²θ·cos²φ·g_ψ²
//! ```
//!
//! ([`KinematicRates::predicted_sigma`]; a quantized angle contributes
//! σ_i = r_i/√12 when it crosses many steps between samples). The
//! differentiator also loses gain above its passband
//! ([`Differentiator::bandwidth`]): at 1 Hz with ±3 samples (the least a
//! quartic fit takes) the derivative is accurate to 1 % only below
//! ≈ 0.08 Hz and half as large at ≈ 0.23 Hz, so the Dutch roll (≈ 0.24 Hz)
//! and turbulence are lost; measured in `tests/simulation/angular_rates.rs`.

use crate::error::{Error, Result};
use crate::prep::differentiation::Differentiator;
use crate::{Channel, FlightRecord};

/// The differentiator the derive step applies to the attitude unless told
/// otherwise: a quartic over ±0.5 s. On 25 Hz attitude with 0.1° noise its
/// ±13 samples give 0.16°/s of rate noise (the default differentiator's
/// ±0.12 s gives 1.3°/s); its gain is within 1 % up to more than 0.4 Hz,
/// above the rigid-body modes of a transport aircraft. At 1 Hz it takes the
/// least a quartic fit needs, ±3 samples.
pub const DEFAULT_DIFFERENTIATOR: Differentiator = Differentiator {
    half_width: 0.5,
    degree: 4,
};

/// The attitude channels the rates are derived from, in the order that
/// breaks ties for the time base.
pub(crate) const ATTITUDE_CHANNELS: [&str; 3] = ["pitch", "roll", "yaw"];

/// The body rates (p, q, r) from the Euler angles φ, θ and their
/// derivatives φ̇, θ̇, ψ̇ (all rad, rad/s).
pub(crate) fn body_rates(
    roll: f64,
    pitch: f64,
    roll_dot: f64,
    pitch_dot: f64,
    yaw_dot: f64,
) -> (f64, f64, f64) {
    let (sin_roll, cos_roll) = roll.sin_cos();
    let (sin_pitch, cos_pitch) = pitch.sin_cos();
    (
        roll_dot - yaw_dot * sin_pitch,
        pitch_dot * cos_roll + yaw_dot * cos_pitch * sin_roll,
        -pitch_dot * sin_roll + yaw_dot * cos_pitch * cos_roll,
    )
}

/// The reconstructed rates of a record and what they were computed from.
#[derive(Debug, Clone)]
pub struct KinematicRates {
    /// Channels `p`, `q`, `r` (rad/s) on the derivative instants of [`Self::time_base`].
    pub p: Channel,
    pub q: Channel,
    pub r: Channel,
    /// The attitude channel whose instants the rates are at.
    pub time_base: String,
    pub differentiator: Differentiator,
    /// ‖w‖ of the differentiator at the rate of pitch, roll and yaw (1/s).
    pub noise_gains: [f64; 3],
    /// Roll and pitch at each instant (rad; NaN in a dropout).
    pub attitude: Vec<(f64, f64)>,
    /// The declared resolution of pitch, roll, yaw (0 where none).
    pub resolutions: [f64; 3],
}

impl KinematicRates {
    /// RMS over the record of the σ of (p, q, r) that white errors of
    /// standard deviation `attitude_sigma` (pitch, roll, yaw; rad) give
    /// (see the module documentation).
    pub fn predicted_sigma(&self, attitude_sigma: [f64; 3]) -> [f64; 3] {
        let g: Vec<f64> = (0..3)
            .map(|i| self.noise_gains[i] * attitude_sigma[i])
            .collect();
        let (g_pitch, g_roll, g_yaw) = (g[0], g[1], g[2]);
        let mut sum = [0.0; 3];
        let mut count = 0usize;
        for &(roll, pitch) in self
            .attitude
            .iter()
            .filter(|(a, b)| a.is_finite() && b.is_finite())
        {
            let (s_roll, c_roll) = roll.sin_cos();
            let (s_pitch, c_pitch) = pitch.sin_cos();
            sum[0] += g_roll.powi(2) + (s_pitch * g_yaw).powi(2);
            sum[1] += (c_roll * g_pitch).powi(2) + (c_pitch * s_roll * g_yaw).powi(2);
            sum[2] += (s_roll * g_pitch).powi(2) + (c_pitch * c_roll * g_yaw).powi(2);
            count += 1;
        }
        let n = count.max(1) as f64;
        sum.map(|s| (s / n).sqrt())
    }

    /// [`Self::predicted_sigma`] for the attitude channels' quantization
    /// alone (σ_i = r_i/√12).
    pub fn resolution_sigma(&self) -> [f64; 3] {
        self.predicted_sigma(self.resolutions.map(|r| r / 12f64.sqrt()))
    }
}

/// The attitude channels (pitch, roll, yaw), yaw unwrapped; an error
/// names every one the record lacks, or one not in radians.
fn attitude(record: &FlightRecord) -> Result<Vec<Channel>> {
    let missing: Vec<&str> = ATTITUDE_CHANNELS
        .iter()
        .copied()
        .filter(|name| record.channel(name).is_err())
        .collect();
    if !missing.is_empty() {
        return Err(Error::Derivation {
            reason: format!(
                "angular rates from the attitude need the channel(s) {}, which the record lacks",
                missing.join(", ")
            ),
        });
    }
    let mut angles = Vec::with_capacity(3);
    for name in ATTITUDE_CHANNELS {
        let channel = record.channel(name)?;
        if channel.unit != "rad" {
            return Err(Error::Derivation {
                reason: format!(
                    "channel '{name}' is in '{}'; angular rates read it in 'rad'",
                    channel.unit
                ),
            });
        }
        let mut channel = channel.clone();
        if name == "yaw" {
            crate::unwrap_angles(&mut channel.values);
        }
        angles.push(channel);
    }
    Ok(angles)
}

/// Computes p, q, r of a record from its attitude (see the module
/// documentation). An error names every attitude channel the record lacks,
/// or one not in radians.
pub fn kinematic_rates(
    record: &FlightRecord,
    differentiator: &Differentiator,
) -> Result<KinematicRates> {
    if let Some(problem) = differentiator.check() {
        return Err(Error::Derivation {
            reason: format!("angular rates: {problem}"),
        });
    }
    let angles = attitude(record)?;
    let derivatives: Vec<Channel> = angles
        .iter()
        .map(|c| differentiator.differentiate(c))
        .collect();
    if let Some(short) = derivatives.iter().find(|d| d.times.is_empty()) {
        return Err(Error::Derivation {
            reason: format!(
                "angular rates: channel '{}' has too few samples for the differentiator (±{} samples)",
                short.name.trim_end_matches("_dot"),
                differentiator.half_window(short.rate)
            ),
        });
    }
    let reference = (0..3).fold(0, |best, i| {
        if angles[i].rate > angles[best].rate {
            i
        } else {
            best
        }
    });
    let times = crate::shared_instants(&derivatives.iter().collect::<Vec<_>>(), reference);
    if times.is_empty() {
        return Err(Error::Derivation {
            reason: "angular rates: the derivatives of pitch, roll and yaw share no time span"
                .to_string(),
        });
    }
    let at = |c: &Channel| c.values_at_unbridged(&times);
    let (pitch, roll) = (at(&angles[0]), at(&angles[1]));
    let (pitch_dot, roll_dot, yaw_dot) = (
        at(&derivatives[0]),
        at(&derivatives[1]),
        at(&derivatives[2]),
    );
    let mut rates = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..times.len() {
        let (p, q, r) = body_rates(roll[k], pitch[k], roll_dot[k], pitch_dot[k], yaw_dot[k]);
        rates.0.push(p);
        rates.1.push(q);
        rates.2.push(r);
    }
    let rate = angles[reference].rate;
    let source = format!(
        "kinematic (p = roll_dot - yaw_dot sin(pitch), q = pitch_dot cos(roll) + yaw_dot cos(pitch) sin(roll), r = -pitch_dot sin(roll) + yaw_dot cos(pitch) cos(roll)) from pitch, roll, yaw (unwrapped), each differentiated by local polynomial (degree {}, ±{} samples), at the instants of {}",
        differentiator.degree,
        differentiator.half_window(rate),
        angles[reference].name
    );
    let channel = |name: &str, values: Vec<f64>| Channel {
        name: name.to_string(),
        unit: "rad/s".to_string(),
        rate,
        resolution: None,
        source: source.clone(),
        times: times.clone(),
        values,
    };
    Ok(KinematicRates {
        p: channel("p", rates.0),
        q: channel("q", rates.1),
        r: channel("r", rates.2),
        time_base: angles[reference].name.clone(),
        differentiator: *differentiator,
        noise_gains: std::array::from_fn(|i| differentiator.noise_gain(angles[i].rate)),
        attitude: roll.into_iter().zip(pitch).collect(),
        resolutions: std::array::from_fn(|i| angles[i].resolution.unwrap_or(0.0)),
    })
}

/// The record with the kinematic p, q, r in it, and one note per rate. A
/// rate the record lacks is added; a recorded one is kept and the kinematic
/// one added as `p_kinematic` (`q_kinematic`, `r_kinematic`), unless
/// `replace`. An added rate leaves the record's `absent` list.
pub(crate) fn with_kinematic_rates(
    record: &FlightRecord,
    differentiator: &Differentiator,
    replace: bool,
) -> Result<(FlightRecord, KinematicRates, Vec<String>)> {
    let rates = kinematic_rates(record, differentiator)?;
    let mut derived = record.clone();
    let mut notes = Vec::new();
    for channel in [&rates.p, &rates.q, &rates.r] {
        let name = channel.name.clone();
        let (target, note) = match record.channel(&name) {
            Err(_) => (name.clone(), format!("{name}: added (kinematic)")),
            Ok(_) if replace => (
                name.clone(),
                format!("{name}: the recorded channel is replaced by the kinematic one"),
            ),
            Ok(_) => (
                format!("{name}_kinematic"),
                format!(
                    "{name}: the recorded channel is kept; the kinematic one is added as {name}_kinematic"
                ),
            ),
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
    Ok((derived, rates, notes))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Wings level the body rates are the Euler rates (p = φ̇, q = θ̇,
    /// r = ψ̇); banked 90° a heading change is pitch rate; pitched 90° a
    /// heading change is −p.
    #[test]
    fn kinematic_equations_at_the_corners() {
        let half_pi = std::f64::consts::FRAC_PI_2;
        let close = |a: (f64, f64, f64), b: (f64, f64, f64)| {
            (a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12 && (a.2 - b.2).abs() < 1e-12
        };
        assert!(close(body_rates(0.0, 0.0, 0.1, 0.2, 0.3), (0.1, 0.2, 0.3)));
        assert!(close(
            body_rates(half_pi, 0.0, 0.0, 0.0, 0.3),
            (0.0, 0.3, 0.0)
        ));
        assert!(close(
            body_rates(0.0, half_pi, 0.0, 0.0, 0.3),
            (-0.3, 0.0, 0.0)
        ));
    }

    fn channel(name: &str, rate: f64, values: Vec<f64>) -> Channel {
        Channel::uniform(name, rate, values)
    }

    /// A steady coordinated turn through north (heading recorded in
    /// [0, 2π)) at a constant bank and pitch, with a heading dropout: ψ̇
    /// is constant after unwrapping, the windows around the dropout fit
    /// the samples they have, and the rates are the closed forms (to 1e-9:
    /// the differentiator is exact on a line).
    #[test]
    fn a_steady_turn_through_north() {
        let (bank, pitch, turn) = (0.4_f64, 0.05_f64, 0.03_f64);
        let n = 200;
        let mut heading: Vec<f64> = (0..n)
            .map(|k| (6.0 + turn * k as f64 / 10.0).rem_euclid(std::f64::consts::TAU))
            .collect();
        heading[50] = f64::NAN;
        let record = FlightRecord {
            channels: vec![
                channel("pitch", 10.0, vec![pitch; n]),
                channel("roll", 10.0, vec![bank; n]),
                channel("yaw", 10.0, heading),
            ],
            ..FlightRecord::default()
        };
        let rates = kinematic_rates(&record, &Differentiator::default()).unwrap();
        let expected = body_rates(bank, pitch, 0.0, 0.0, turn);
        assert_eq!(rates.time_base, "pitch");
        assert_eq!(rates.p.times.len(), n - 6);
        for k in 0..rates.p.times.len() {
            assert!((rates.p.values[k] - expected.0).abs() < 1e-9);
            assert!((rates.q.values[k] - expected.1).abs() < 1e-9);
            assert!((rates.r.values[k] - expected.2).abs() < 1e-9);
        }
    }

    /// A record without a heading is refused, naming it; so is an
    /// attitude channel in degrees.
    #[test]
    fn a_missing_attitude_channel_is_named() {
        let mut degrees = channel("yaw", 10.0, vec![0.0; 20]);
        degrees.unit = "deg".into();
        let record = FlightRecord {
            channels: vec![
                channel("pitch", 10.0, vec![0.0; 20]),
                channel("roll", 10.0, vec![0.0; 20]),
                degrees,
            ],
            ..FlightRecord::default()
        };
        let error = kinematic_rates(&record, &Differentiator::default())
            .unwrap_err()
            .to_string();
        assert!(error.contains("'yaw' is in 'deg'"), "{error}");
        let record = FlightRecord {
            channels: vec![
                channel("pitch", 10.0, vec![0.0; 20]),
                channel("roll", 10.0, vec![0.0; 20]),
            ],
            ..FlightRecord::default()
        };
        let error = kinematic_rates(&record, &Differentiator::default())
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("yaw") && !error.contains("pitch,"),
            "{error}"
        );
    }
}
