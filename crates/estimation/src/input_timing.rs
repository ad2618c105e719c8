//! How an estimator takes each recorded input between its samples: the
//! `interpolation` setting of the methods that integrate a model (output
//! error, filter error, the augmented filters, frequency-domain output
//! error) and of linear model files. Inside step k of length h, at stage
//! fraction θ ∈ [0, 1], input i is u_i(t_k) + w_i(θ)·(u_i(t_k+1) − u_i(t_k))
//! with its own weight: w_i = 0 held (zero-order hold), w_i = θ linear
//! (first-order hold) — one weight vector, blended by the one integrator.
//!
//! `"auto"` (the default) chooses per input from its samples. The
//! channel's fast transitions ([`transitions`]: runs of sample-to-sample
//! changes beyond 10 robust σ of the changes and 5 % of the range) are
//! found, and the changes between them tested for motion: their lag-one
//! sum S = Σ Δ_k·Δ_k+1 is −σ²·n for white noise on a constant (consecutive
//! changes share one noise sample with opposite signs) and positive where
//! the signal moves more than its noise per sample. The channel is
//! - linear when a transition holds three consecutive changes of one sign
//!   (a ramp with two or more samples inside it), or when S > 0 (a
//!   continuous signal: a multisine, a pilot's input, a quantized slow
//!   motion);
//! - held otherwise: isolated one-sample jumps between runs constant to
//!   within noise (aeroid's steps on the sample grid; a level held for one
//!   sample makes consecutive jumps of opposite signs), a ramp with one
//!   sample inside it (it lasts anywhere up to two sample intervals: linear
//!   interpolation would spread it over both), or no motion.
//!
//! Why: a step on the grid is exact under a hold and is spread over the
//! interval before it under linear interpolation (the input half a sample
//! early); a ramp or a smooth signal is within O(h²) under linear
//! interpolation and half a sample late under a hold. Sensor noise on a
//! step input (0.01° on flight-test-25hz's controls) moves neither test.
//! Measured on the ATTAS lateral multistep recorded by flight-test-25hz:
//! with the steps held and the 0.1 s-ramped twin's ramps linear, output
//! error is within 2σ of the truth; the other way round it misses by up
//! to 27σ (steps linear, Cl_p 4.1 %) and 25σ (ramps held, Cl_p 4.3 %). On
//! the QAR approach (aileron at 1 Hz, trapezoids with 0.5 s ramps: one
//! sample inside each) the held aileron leaves the lateral filter-error fit
//! converged within 1.5σ on the roll derivatives; taken linearly, spread
//! over two seconds, it ends at the iteration limit with Cl_β 5.9σ off.

use crate::error::{Error, Result};
use aeroid_record::prep::differentiation::transitions;
use aeroid_sim::integrator::Interpolation;
use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::ser::Serializer;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt;

/// One input's choice as a file writes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Choice {
    /// From the channel's samples ([`classify`]).
    #[default]
    Auto,
    /// Held over each step.
    Hold,
    /// Linear between samples.
    Linear,
}

impl Choice {
    const NAMES: [(&'static str, Choice); 3] = [
        ("auto", Choice::Auto),
        ("zoh", Choice::Hold),
        ("linear", Choice::Linear),
    ];

    fn name(self) -> &'static str {
        Choice::NAMES
            .iter()
            .find(|(_, c)| *c == self)
            .map_or("auto", |(n, _)| n)
    }

    fn parse<E: de::Error>(text: &str) -> std::result::Result<Choice, E> {
        Choice::NAMES
            .iter()
            .find(|(n, _)| *n == text)
            .map(|(_, c)| *c)
            .ok_or_else(|| {
                E::custom(format!(
                    "interpolation: \"{text}\" is not \"auto\", \"zoh\" or \"linear\" (or a table of channel = one of them)"
                ))
            })
    }
}

/// The `interpolation` setting: one choice for every input, or one per
/// channel (channels not named: auto).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum InputInterpolation {
    Every(Choice),
    PerChannel(BTreeMap<String, Choice>),
}

impl Default for InputInterpolation {
    fn default() -> Self {
        InputInterpolation::Every(Choice::Auto)
    }
}

impl From<Interpolation> for InputInterpolation {
    fn from(interpolation: Interpolation) -> Self {
        InputInterpolation::Every(match interpolation {
            Interpolation::ZeroOrderHold => Choice::Hold,
            Interpolation::Linear => Choice::Linear,
        })
    }
}

/// Why an input is taken as it is (for the notes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reason {
    Setting,
    Ramps,
    Moves,
    Steps,
    Short,
    Still,
}

impl Reason {
    fn text(self) -> &'static str {
        match self {
            Reason::Setting => "as set",
            Reason::Ramps => "ramps between samples",
            Reason::Moves => "moves between samples",
            Reason::Steps => "piecewise constant at its samples",
            Reason::Short => "ramps within two sample intervals",
            Reason::Still => "constant to within its noise",
        }
    }
}

/// One input's interpolation and the reason for it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Chosen {
    pub name: String,
    pub interpolation: Interpolation,
    pub reason: Reason,
}

/// The auto rule (module documentation) on a channel's samples, in order
/// (NaN dropouts left out).
pub fn classify(values: &[f64]) -> (Interpolation, Reason) {
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    let runs = transitions(&finite, None);
    let change = |j: usize| finite[j + 1] - finite[j];
    // Two or more samples inside one transition, moving one way: a ramp
    // the samples resolve (three consecutive changes of one sign).
    let ramps = runs.iter().any(|run| {
        (run.start..run.end.saturating_sub(2))
            .any(|j| change(j) * change(j + 1) > 0.0 && change(j + 1) * change(j + 2) > 0.0)
    });
    if ramps {
        return (Interpolation::Linear, Reason::Ramps);
    }
    let inside = |j: usize| runs.iter().any(|run| run.contains(&j));
    let lag_one: f64 = (0..finite.len().saturating_sub(2))
        .filter(|&j| !inside(j) && !inside(j + 1))
        .map(|j| change(j) * change(j + 1))
        .sum();
    if lag_one > 0.0 {
        (Interpolation::Linear, Reason::Moves)
    } else if runs.is_empty() {
        (Interpolation::ZeroOrderHold, Reason::Still)
    } else if runs
        .iter()
        .any(|run| (run.start..run.end.saturating_sub(1)).any(|j| change(j) * change(j + 1) > 0.0))
    {
        (Interpolation::ZeroOrderHold, Reason::Short)
    } else {
        (Interpolation::ZeroOrderHold, Reason::Steps)
    }
}

impl InputInterpolation {
    /// The choice for input `name`, its samples given by `values` for the
    /// auto rule.
    pub fn choose(&self, name: &str, values: &[f64]) -> Chosen {
        let choice = match self {
            InputInterpolation::Every(choice) => *choice,
            InputInterpolation::PerChannel(map) => map.get(name).copied().unwrap_or_default(),
        };
        let (interpolation, reason) = match choice {
            Choice::Auto => classify(values),
            Choice::Hold => (Interpolation::ZeroOrderHold, Reason::Setting),
            Choice::Linear => (Interpolation::Linear, Reason::Setting),
        };
        Chosen {
            name: name.to_string(),
            interpolation,
            reason,
        }
    }

    /// The setting that makes exactly `chosen` again, whatever the samples.
    pub fn fixed(chosen: &[Chosen]) -> InputInterpolation {
        InputInterpolation::PerChannel(
            chosen
                .iter()
                .map(|c| {
                    let choice = match c.interpolation {
                        Interpolation::ZeroOrderHold => Choice::Hold,
                        Interpolation::Linear => Choice::Linear,
                    };
                    (c.name.clone(), choice)
                })
                .collect(),
        )
    }

    /// [`InputInterpolation::check_channels`] for a 6-DOF model's controls,
    /// the error naming the settings table `[methods.METHOD]`.
    pub fn check_controls(&self, method: &str) -> Result<()> {
        let controls = aeroid_sim::state::Control::ALL.map(|c| c.name());
        self.check_channels(&controls)
            .map_err(|error| Error::Setting {
                method: method.to_string(),
                reason: error.to_string(),
            })
    }

    /// An error naming the channels of a per-channel table that are not
    /// among `inputs`.
    pub fn check_channels(&self, inputs: &[&str]) -> Result<()> {
        let InputInterpolation::PerChannel(map) = self else {
            return Ok(());
        };
        let unknown: Vec<&str> = map
            .keys()
            .map(String::as_str)
            .filter(|name| !inputs.contains(name))
            .collect();
        if unknown.is_empty() {
            return Ok(());
        }
        Err(Error::Method {
            reason: format!(
                "interpolation: no input named {} (the inputs: {})",
                unknown.join(", "),
                inputs.join(", ")
            ),
        })
    }
}

/// The note saying how each input is taken, e.g. "inputs between samples:
/// aileron linear (ramps between samples), rudder held (piecewise constant
/// at its samples)".
pub fn note(chosen: &[Chosen]) -> String {
    let each: Vec<String> = chosen
        .iter()
        .map(|c| {
            let how = match c.interpolation {
                Interpolation::ZeroOrderHold => "held",
                Interpolation::Linear => "linear",
            };
            format!("{} {how} ({})", c.name, c.reason.text())
        })
        .collect();
    format!("inputs between samples: {}", each.join(", "))
}

impl Serialize for InputInterpolation {
    fn serialize<S: Serializer>(&self, serializer: S) -> std::result::Result<S::Ok, S::Error> {
        match self {
            InputInterpolation::Every(choice) => serializer.serialize_str(choice.name()),
            InputInterpolation::PerChannel(map) => {
                serializer.collect_map(map.iter().map(|(k, v)| (k, v.name())))
            }
        }
    }
}

impl<'de> Deserialize<'de> for InputInterpolation {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        struct Expected;
        impl<'de> Visitor<'de> for Expected {
            type Value = InputInterpolation;

            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "interpolation: \"auto\", \"zoh\", \"linear\" or a table of channel = one of them",
                )
            }

            fn visit_str<E: de::Error>(self, text: &str) -> std::result::Result<Self::Value, E> {
                Choice::parse(text).map(InputInterpolation::Every)
            }

            fn visit_map<M: MapAccess<'de>>(
                self,
                mut access: M,
            ) -> std::result::Result<Self::Value, M::Error> {
                let mut map = BTreeMap::new();
                while let Some((name, text)) = access.next_entry::<String, String>()? {
                    map.insert(name, Choice::parse(&text)?);
                }
                Ok(InputInterpolation::PerChannel(map))
            }
        }
        deserializer.deserialize_any(Expected)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise(k: usize) -> f64 {
        1.7e-4 * (((k * 7919) % 23) as f64 / 11.0 - 1.0)
    }

    /// Steps (clean or with 0.01° noise, and a doublet whose levels last one
    /// sample each) are held, and so is a ramp with one sample inside it; a
    /// ramp through two samples, a multisine and a quantized slow sine are
    /// linear; a constant is held.
    #[test]
    fn the_auto_rule_follows_the_signal() {
        let step = |k: usize| match k {
            0..100 => 0.0,
            100..140 => 0.07,
            _ => -0.07,
        };
        let clean: Vec<f64> = (0..300).map(step).collect();
        let noisy: Vec<f64> = (0..300).map(|k| step(k) + noise(k)).collect();
        let ramp: Vec<f64> = (0..300)
            .map(|k| (k as f64 - 100.0).clamp(0.0, 3.0) * 0.02 + noise(k))
            .collect();
        let sine: Vec<f64> = (0..300).map(|k| (0.05 * k as f64).sin()).collect();
        let quantized: Vec<f64> = sine.iter().map(|v| (v * 20.0).round() / 20.0).collect();
        let constant = vec![0.3; 300];
        let doublet: Vec<f64> = (0..300)
            .map(|k| match k {
                100 => 0.07,
                101 => -0.07,
                _ => 0.0,
            })
            .collect();
        let short: Vec<f64> = (0..300)
            .map(|k| (k as f64 - 100.0).clamp(0.0, 1.5) * 0.04)
            .collect();
        let classes: Vec<(Interpolation, Reason)> = [
            clean, noisy, ramp, sine, quantized, constant, doublet, short,
        ]
        .iter()
        .map(|v| classify(v))
        .collect();
        use Interpolation::{Linear, ZeroOrderHold};
        assert_eq!(
            classes,
            [
                (ZeroOrderHold, Reason::Steps),
                (ZeroOrderHold, Reason::Steps),
                (Linear, Reason::Ramps),
                (Linear, Reason::Moves),
                (Linear, Reason::Moves),
                (ZeroOrderHold, Reason::Still),
                (ZeroOrderHold, Reason::Steps),
                (ZeroOrderHold, Reason::Short),
            ]
        );
    }

    /// The setting reads a word or a table; a bad word is named.
    #[test]
    fn the_setting_reads_words_and_tables() {
        let read = |text: &str| serde_json::from_str::<InputInterpolation>(text);
        assert_eq!(read("\"auto\"").unwrap(), InputInterpolation::default());
        assert_eq!(
            read("\"zoh\"").unwrap(),
            InputInterpolation::from(Interpolation::ZeroOrderHold)
        );
        let table = read(r#"{"aileron": "linear"}"#).unwrap();
        assert_eq!(
            table.choose("aileron", &[]).interpolation,
            Interpolation::Linear
        );
        assert_eq!(table.choose("rudder", &[0.0; 5]).reason, Reason::Still);
        assert!(table.check_channels(&["rudder"]).is_err());
        let error = read("\"cubic\"").unwrap_err().to_string();
        assert!(
            error.contains("interpolation") && error.contains("cubic"),
            "{error}"
        );
    }
}
