//! The `[aero]` table of an aircraft or model-structure file as written
//! ([`AeroSpec`]): the kind of model, force axes, rate normalisation,
//! reference airspeed and Mach number, Oswald factor, the `[stall]` table
//! and its variants ([`StallSpec`]), the moment reference point
//! ([`MomentReferenceSpec`]) and the coefficient tables, and the reference
//! geometry the model normalises with. The vocabulary is in docs/files.md,
//! "Aircraft (`aircraft/*.toml`)".

use super::terms::ForceAxes;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// How body rates are made non-dimensional.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum RateNormalization {
    /// p·b/(2V), q·c̄/(2V), r·b/(2V).
    #[default]
    #[serde(rename = "2V")]
    TwiceSpeed,
    /// p·b/V, q·c̄/V, r·b/V.
    #[serde(rename = "V")]
    Speed,
}

/// Which speed the rate normalisation divides by.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RateSpeed {
    /// The instantaneous true airspeed V.
    #[default]
    Airspeed,
    /// The constant reference airspeed V0 of the model.
    Reference,
}

/// Kind of model written in a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelKind {
    #[default]
    Linear,
    Stall,
}

/// Stall parameters of the Kirchhoff flow-separation model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StallSpec {
    /// Static stall sharpness a1 (1/rad).
    pub a1: f64,
    /// Break-point angle of attack α* (rad).
    pub alpha_star: f64,
    /// Transient time constant τ1 (s); 0 makes χ algebraic.
    pub tau1: f64,
    /// Quasi-steady hysteresis time constant τ2 (s).
    pub tau2: f64,
    /// The unit of τ1 and τ2.
    #[serde(default, skip_serializing_if = "is_default")]
    pub time_unit: StallTimeUnit,
    /// τ2 acts only while α̇ < 0 (the lag on the way down only).
    #[serde(default, skip_serializing_if = "is_default")]
    pub tau2_only_while_decreasing: bool,
    /// The width b (rad/s) of a smooth switch of the one-sided τ2:
    /// α̇·½(1 − tanh(α̇/b)) in place of min(α̇, 0); 0: the sharp switch.
    #[serde(default, skip_serializing_if = "is_default")]
    pub tau2_switch_band: f64,
    /// The lift the induced drag CL²/(e·π·Λ) is formed from.
    #[serde(default, skip_serializing_if = "is_default")]
    pub induced_drag_lift: InducedDragLift,
    /// Where the α̇ of the separation equation (Eq. 2) comes from.
    #[serde(default, skip_serializing_if = "is_default")]
    pub alpha_dot: StallAlphaDot,
}

/// The options of a stall model besides its parameters ([`StallSpec`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(super) struct StallOptions {
    pub(super) time_unit: StallTimeUnit,
    pub(super) tau2_only_while_decreasing: bool,
    pub(super) induced_drag_lift: InducedDragLift,
    pub(super) alpha_dot: StallAlphaDot,
    pub(super) tau2_switch_band: f64,
}

/// Where the α̇ in the separation equation τ1·χ̇ + χ = χ∞(α − τ2·α̇) comes
/// from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StallAlphaDot {
    /// The state derivative: the α̇ the equations of motion give (for
    /// algebraic χ, solved together with the forces it changes).
    #[default]
    State,
    /// The smoothed derivative of the measured α, an input where the model
    /// is driven by a record
    /// ([`AeroInput::measured_alpha_dot`](super::AeroInput::measured_alpha_dot));
    /// where there is no measurement (the simulator flying a truth) the state
    /// derivative.
    Measured,
}

fn is_default<T: Default + PartialEq>(value: &T) -> bool {
    *value == T::default()
}

/// The unit of the stall time constants τ1 and τ2.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum StallTimeUnit {
    /// Seconds.
    #[default]
    #[serde(rename = "s")]
    Seconds,
    /// Units of c̄/V (V the airspeed, or V0 with `rate_speed = "reference"`):
    /// τ in seconds is τ·c̄/V.
    #[serde(rename = "chord/V")]
    ChordTimes,
}

/// Which lift coefficient the Oswald induced drag CL²/(e·π·Λ) of a stall
/// model squares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InducedDragLift {
    /// The lift coefficient itself (with the Kirchhoff factor).
    #[default]
    Total,
    /// The attached-flow lift (χ = 1: the Kirchhoff factor taken as 1).
    Attached,
}

/// Where the moment coefficients of a file are taken about, when not the
/// centre of gravity: an `offset` in metres, or the reference point and the
/// CG as fractions of c̄ aft of the leading edge of the mean aerodynamic
/// chord (`point_mac`, `cg_mac`; the offset is then along body x only).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MomentReferenceSpec {
    /// From the CG to the reference point, body axes (x forward, y right, z down), m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset: Option<Vec<f64>>,
    /// The reference point, fraction of c̄ aft of the MAC leading edge.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub point_mac: Option<f64>,
    /// The CG, fraction of c̄ aft of the MAC leading edge.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cg_mac: Option<f64>,
}

impl MomentReferenceSpec {
    /// The offset from the CG to the reference point (body axes, m) for a
    /// chord `chord`, or what is wrong with the table.
    pub(super) fn offset(&self, chord: f64) -> Result<Vector3<f64>, crate::error::Error> {
        let fail = |reason| Err(crate::error::Error::MomentReference { reason });
        let offset = match (&self.offset, self.point_mac, self.cg_mac) {
            (Some(offset), None, None) => match offset[..] {
                [x, y, z] => Vector3::new(x, y, z),
                _ => return fail("offset must be three numbers [x, y, z] (m)"),
            },
            (None, Some(point), Some(cg)) => Vector3::new((cg - point) * chord, 0.0, 0.0),
            _ => {
                return fail(
                    "give either offset = [x, y, z] (m) or both point_mac and cg_mac (fractions of c̄)",
                );
            }
        };
        match offset.iter().all(|v| v.is_finite()) {
            true => Ok(offset),
            false => fail("the offset must be finite numbers"),
        }
    }
}

/// The `[aero]` table of an aircraft or model-structure file. Unknown keys
/// are taken as coefficient tables and reported as unknown coefficients.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct AeroSpec {
    #[serde(default)]
    pub model: ModelKind,
    #[serde(default)]
    pub force_axes: ForceAxes,
    #[serde(default)]
    pub rate_normalization: RateNormalization,
    #[serde(default)]
    pub rate_speed: RateSpeed,
    /// V0 (m/s): needed by `dV` terms and by `rate_speed = "reference"`.
    #[serde(default)]
    pub reference_airspeed: Option<f64>,
    /// M0: needed by `dMach` terms.
    #[serde(default)]
    pub reference_mach: Option<f64>,
    /// Oswald factor e: adds CL²/(e·π·Λ) to CD (wind axes).
    #[serde(default)]
    pub oswald_efficiency: Option<f64>,
    #[serde(default)]
    pub stall: Option<StallSpec>,
    /// The point the moment coefficients are taken about; the CG when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub moment_reference: Option<MomentReferenceSpec>,
    /// Coefficient tables, keyed by coefficient name then regressor key.
    #[serde(flatten)]
    pub coefficients: BTreeMap<String, BTreeMap<String, f64>>,
}

/// Reference geometry the model normalises with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceGeometry {
    pub span: f64,
    pub chord: f64,
    pub aspect_ratio: f64,
}
