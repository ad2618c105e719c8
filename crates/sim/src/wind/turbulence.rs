//! The `[wind.turbulence]` table: either an `intensity` (light, moderate,
//! severe) or explicit `sigma_u, sigma_v, sigma_w`, with optional
//! `length_u, length_v, length_w`; its checks, and the σ and L of the three
//! components at an altitude ([`TurbulenceParameters`]) by the intensity and
//! altitude rules of `intensity` where not given explicitly.

use super::check::{is_not_negative, is_positive, require};
use super::intensity::{Intensity, scale_lengths};
use aeroid_core::error::FieldErrors;
use aeroid_core::units::{Dimension, FOOT, Quantity};
use serde::{Deserialize, Serialize};

/// The `[wind.turbulence]` table: an `intensity` or explicit `sigma_*`.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct TurbulenceSpec {
    /// "light", "moderate" or "severe"; excludes the `sigma_*` fields.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub intensity: Option<String>,
    /// RMS longitudinal turbulence (Speed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_u: Option<Quantity>,
    /// RMS lateral turbulence (Speed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_v: Option<Quantity>,
    /// RMS vertical turbulence (Speed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_w: Option<Quantity>,
    /// Longitudinal scale length (Length; default by the altitude rules).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub length_u: Option<Quantity>,
    /// Lateral scale length (Length; default by the altitude rules).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub length_v: Option<Quantity>,
    /// Vertical scale length (Length; default by the altitude rules).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub length_w: Option<Quantity>,
}

/// Conditions the turbulence forms depend on (frozen turbulence).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlightConditions {
    /// Trim true airspeed V, m/s.
    pub airspeed: f64,
    /// Altitude of the flight, m (the scale and intensity rules use it in ft).
    pub altitude: f64,
}

/// RMS intensities (m/s) and scale lengths (m) of the components u, v, w.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurbulenceParameters {
    pub sigma: [f64; 3],
    pub length: [f64; 3],
}

impl TurbulenceSpec {
    fn sigmas(&self) -> [(&'static str, Option<&Quantity>); 3] {
        [
            ("sigma_u", self.sigma_u.as_ref()),
            ("sigma_v", self.sigma_v.as_ref()),
            ("sigma_w", self.sigma_w.as_ref()),
        ]
    }

    fn lengths(&self) -> [(&'static str, Option<&Quantity>); 3] {
        [
            ("length_u", self.length_u.as_ref()),
            ("length_v", self.length_v.as_ref()),
            ("length_w", self.length_w.as_ref()),
        ]
    }

    /// Records the problems of this table under `path` ("wind.turbulence").
    pub fn validate(&self, path: &str, problems: &mut FieldErrors) {
        let field = |name: &str| format!("{path}.{name}");
        let given_sigmas = self
            .sigmas()
            .iter()
            .filter(|(_, sigma)| sigma.is_some())
            .count();
        match &self.intensity {
            Some(name) if Intensity::parse(name).is_none() => problems.push(
                field("intensity"),
                format!("unknown intensity '{name}'; known: light, moderate, severe"),
            ),
            Some(_) if given_sigmas > 0 => problems.push(
                path,
                "give either intensity or sigma_u, sigma_v, sigma_w, not both",
            ),
            Some(_) => {}
            None => {
                for (name, sigma) in self.sigmas() {
                    if sigma.is_none() {
                        let message = "missing: give intensity or all of sigma_u, sigma_v, sigma_w";
                        problems.push(field(name), message);
                    }
                }
            }
        }
        for (name, sigma) in self.sigmas() {
            if let Some(sigma) = sigma {
                let rule = "must not be negative";
                require(
                    problems,
                    &field(name),
                    sigma,
                    Dimension::Speed,
                    is_not_negative,
                    rule,
                );
            }
        }
        for (name, length) in self.lengths() {
            if let Some(length) = length {
                require(
                    problems,
                    &field(name),
                    length,
                    Dimension::Length,
                    is_positive,
                    "must be positive",
                );
            }
        }
    }

    /// σ and L of the three components at `altitude` (m), by the intensity or
    /// altitude rules where not given explicitly. Expects a validated table.
    pub fn parameters(&self, altitude: f64) -> Result<TurbulenceParameters, crate::error::Error> {
        let altitude_ft = altitude / FOOT;
        let sigma = match &self.intensity {
            Some(name) => Intensity::parse(name)
                .ok_or_else(|| crate::error::Error::WindName {
                    kind: "turbulence intensity",
                    name: name.clone(),
                })?
                .sigmas(altitude_ft),
            None => explicit_values(self.sigmas(), Dimension::Speed, [None; 3])?,
        };
        let default_lengths = scale_lengths(altitude_ft).map(|length| Some(length * FOOT));
        let length = explicit_values(self.lengths(), Dimension::Length, default_lengths)?;
        Ok(TurbulenceParameters { sigma, length })
    }
}

/// SI values of `fields`, each falling back to its default.
fn explicit_values(
    fields: [(&'static str, Option<&Quantity>); 3],
    dimension: Dimension,
    defaults: [Option<f64>; 3],
) -> Result<[f64; 3], crate::error::Error> {
    let mut values = [0.0; 3];
    for ((value, (name, quantity)), default) in values.iter_mut().zip(fields).zip(defaults) {
        *value = match (quantity, default) {
            (Some(quantity), _) => quantity.si(dimension)?,
            (None, Some(default)) => default,
            (None, None) => return Err(crate::error::Error::TurbulenceMissing { name }),
        };
    }
    Ok(values)
}
