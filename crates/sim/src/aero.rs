//! Aerodynamic models: linear stability and control derivatives, and the
//! quasi-steady stall model with Kirchhoff flow separation. One
//! [`AeroModel`] evaluates both an aircraft file's truth and every
//! estimator's postulated model. The file vocabulary (regressors, products
//! such as `alpha^2`, ties, the `[stall]` variants, the moment reference
//! point) is in docs/files.md, "Aircraft (`aircraft/*.toml`)".
//!
//! **Coefficients**: each a sum of named terms `C_term · regressor`, the
//! parameter `{coefficient}_{term}` (`CL_alpha`, `Cm_q`, `CD_0`), rates
//! normalised p·b/(kV), q·c̄/(kV), r·b/(kV) (k = 2 or 1); products of
//! regressors ([`Monomial`]) and tied parameters ([`Tie`], θ = c·θ_master +
//! d) are evaluated by the same sum, so the simulator, the regressions'
//! columns and the state-space Jacobians all see them.
//!
//! **Quasi-steady stall** (Verma & Peyada 2020, Eqs. 2–4, after
//! Fischenberg):
//! `τ1·dχ/dt + χ = ½·(1 − tanh(a1·(α − τ2·α̇ − α*)))`   (Eq. 2; Eq. 3 when τ1 = 0)
//! `CL = CL0 + CLα·((1 + √χ)/2)²·α`,
//! `CD = CD0 + CL²/(e·π·Λ) + CDχ·(1 − χ)`,
//! `Cm = Cm0 + Cmα·α + Cmq·q̂ + Cmδe·δe + Cmχ·(1 − χ)`   (Eq. 4).
//! χ is a state when τ1 > 0 and algebraic when τ1 = 0. Variants: τ in c̄/V,
//! τ2 only while α̇ < 0 (sharp or smoothed switch), the induced drag of the
//! attached lift, α̇ from the state or from the measured α
//! ([`AeroInput::measured_alpha_dot`]).
//!
//! **Moment reference point**: moments given about r (body axes, from the
//! CG) are moved to the CG by `M_cg = M_ref + r × F` (Jategaonkar, "Flight
//! Vehicle System Identification", 2nd ed., ch. 3; Klein & Morelli 2006,
//! ch. 3): `Cl += (r_y·CZ − r_z·CY)/b`, `Cm += (r_z·CX − r_x·CZ)/c̄`,
//! `Cn += (r_x·CY − r_y·CX)/b` (for the pitching moment the textbook
//! `Cm_α,cg = Cm_α,ref + CL_α·(x̄_cg − x̄_ref)`, Etkin & Reid §2.3).
//!
//! **Force axes**: "wind" gives CL, CD in stability axes and CY along body
//! y: `CX = −CD·cos α + CL·sin α`, `CZ = −CD·sin α − CL·cos α`; "body"
//! gives CX, CY, CZ. Moments are body-axis, about the centre of gravity.

use crate::params::ParameterSet;
use crate::state::{Control, Controls, SinCos};
use aeroid_core::error::Problems;
use aeroid_numerics::dual::Real;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Moves one flight variable of an input by a step (for local derivatives).
type Perturbation = fn(&mut AeroInput, f64);

/// A regressor: the variable a derivative multiplies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Regressor {
    Constant,
    Alpha,
    Beta,
    RollRate,
    PitchRate,
    YawRate,
    AlphaDot,
    Elevator,
    Aileron,
    Rudder,
    Flap,
    SpeedRatio,
    Mach,
    Separation,
    LiftSquared,
}

pub const REGRESSOR_COUNT: usize = 15;

impl Regressor {
    pub const ALL: [Regressor; REGRESSOR_COUNT] = [
        Regressor::Constant,
        Regressor::Alpha,
        Regressor::Beta,
        Regressor::RollRate,
        Regressor::PitchRate,
        Regressor::YawRate,
        Regressor::AlphaDot,
        Regressor::Elevator,
        Regressor::Aileron,
        Regressor::Rudder,
        Regressor::Flap,
        Regressor::SpeedRatio,
        Regressor::Mach,
        Regressor::Separation,
        Regressor::LiftSquared,
    ];

    /// The key used in files and in parameter names.
    pub fn key(self) -> &'static str {
        match self {
            Regressor::Constant => "0",
            Regressor::Alpha => "alpha",
            Regressor::Beta => "beta",
            Regressor::RollRate => "p",
            Regressor::PitchRate => "q",
            Regressor::YawRate => "r",
            Regressor::AlphaDot => "alpha_dot",
            Regressor::Elevator => "de",
            Regressor::Aileron => "da",
            Regressor::Rudder => "dr",
            Regressor::Flap => "df",
            Regressor::SpeedRatio => "dV",
            Regressor::Mach => "dMach",
            Regressor::Separation => "chi",
            Regressor::LiftSquared => "CL2",
        }
    }

    pub fn from_key(key: &str) -> Option<Regressor> {
        Regressor::ALL.into_iter().find(|r| r.key() == key)
    }

    fn keys() -> String {
        Regressor::ALL.map(Regressor::key).join(", ")
    }
}

/// Highest total degree of a term's product of regressors (`alpha^3*de` is 4).
pub const MAX_DEGREE: usize = 4;

/// Most distinct products (terms of degree 2 or more) one model may have:
/// their values are kept in a fixed-size table ([`TermRegressors`]) so that
/// evaluation does not allocate.
pub const MAX_PRODUCTS: usize = 16;

/// What a term's parameter multiplies: one regressor, or a product of
/// regressors with integer powers (`alpha^2`, `alpha*dMach`, `alpha^2*de`).
///
/// Its key is canonical, so that one term has one parameter name whatever
/// file states it: the factors in the order of [`Regressor::ALL`] (`0`,
/// `alpha`, `beta`, `p`, `q`, `r`, `alpha_dot`, `de`, `da`, `dr`, `df`,
/// `dV`, `dMach`, `chi`, `CL2`), joined by `*`, a repeated factor written
/// once with its power `^n` (n ≥ 2), total degree at most [`MAX_DEGREE`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Monomial {
    /// The factors in [`Regressor::ALL`] order, a power repeating its regressor.
    factors: [Regressor; MAX_DEGREE],
    degree: u8,
}

impl From<Regressor> for Monomial {
    fn from(regressor: Regressor) -> Monomial {
        Monomial {
            factors: [regressor; MAX_DEGREE],
            degree: 1,
        }
    }
}

impl Monomial {
    /// Parses a coefficient-table key: a regressor key, or factors
    /// `key` / `key^n` joined by `*`, in canonical form (the error names
    /// the canonical spelling of a key that is otherwise valid).
    pub fn parse(text: &str) -> Result<Monomial, String> {
        let mut factors = Vec::new();
        for factor in text.split('*') {
            let (key, power) = match factor.split_once('^') {
                Some((key, power)) => (key, power),
                None => (factor, "1"),
            };
            let regressor = Regressor::from_key(key.trim()).ok_or_else(|| {
                format!(
                    "unknown regressor '{}' in term '{text}'; known: {}",
                    key.trim(),
                    Regressor::keys()
                )
            })?;
            let power: usize = match power.trim().parse::<i64>() {
                Ok(power) if power >= 1 => power as usize,
                _ => {
                    return Err(format!(
                        "the power '{}' of '{}' in term '{text}' must be an integer ≥ 1",
                        power.trim(),
                        key.trim()
                    ));
                }
            };
            factors.extend(std::iter::repeat_n(regressor, power.min(MAX_DEGREE + 1)));
            if factors.len() > MAX_DEGREE {
                return Err(format!(
                    "term '{text}' has a degree above {MAX_DEGREE}, the most a term may have"
                ));
            }
        }
        if factors.len() > 1 && factors.contains(&Regressor::Constant) {
            return Err(format!(
                "term '{text}': the constant 0 cannot be a factor of a product"
            ));
        }
        let monomial = Monomial::from_factors(&factors)
            .ok_or_else(|| format!("term '{text}' has no factor"))?;
        let canonical = monomial.key();
        if canonical != text {
            return Err(format!(
                "write term '{text}' as '{canonical}' (factors in the order {}, a repeated factor once with its power ^n)",
                Regressor::keys()
            ));
        }
        Ok(monomial)
    }

    /// The product of `factors` (in any order); None when there are none
    /// or more than [`MAX_DEGREE`].
    pub fn from_factors(factors: &[Regressor]) -> Option<Monomial> {
        if factors.is_empty() || factors.len() > MAX_DEGREE {
            return None;
        }
        let mut monomial = Monomial::from(factors[0]);
        monomial.factors[..factors.len()].copy_from_slice(factors);
        monomial.factors[..factors.len()].sort_by_key(|r| *r as usize);
        monomial.degree = factors.len() as u8;
        Some(monomial)
    }

    /// The canonical key (`alpha`, `alpha^2`, `alpha*dMach`).
    pub fn key(&self) -> String {
        let mut parts: Vec<String> = Vec::new();
        let factors = self.factors();
        let mut start = 0;
        while start < factors.len() {
            let regressor = factors[start];
            let power = factors[start..]
                .iter()
                .take_while(|&&r| r == regressor)
                .count();
            parts.push(match power {
                1 => regressor.key().to_string(),
                n => format!("{}^{n}", regressor.key()),
            });
            start += power;
        }
        parts.join("*")
    }

    /// The factors, a power repeating its regressor.
    pub fn factors(&self) -> &[Regressor] {
        &self.factors[..self.degree as usize]
    }

    /// The regressor of a degree-1 term; None for a product.
    pub fn single(&self) -> Option<Regressor> {
        (self.degree == 1).then_some(self.factors[0])
    }

    /// Whether `regressor` is one of the factors.
    pub fn contains(&self, regressor: Regressor) -> bool {
        self.factors().contains(&regressor)
    }

    /// The product of the factors' values (`regressors` indexed by `Regressor as usize`).
    #[inline(always)]
    pub fn value<T: Real>(&self, regressors: &[T]) -> T {
        let factors = self.factors();
        factors[1..]
            .iter()
            .fold(regressors[factors[0] as usize], |product, &r| {
                product * regressors[r as usize]
            })
    }
}

/// Which axes the force coefficients are written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ForceAxes {
    /// CD, CY, CL (stability axes for CD and CL, body y for CY).
    #[default]
    Wind,
    /// CX, CY, CZ.
    Body,
}

/// The six coefficients in evaluation order: lift-type first so that drag can use CL².
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coefficient {
    Lift,
    Side,
    Drag,
    Roll,
    Pitch,
    Yaw,
}

impl Coefficient {
    /// CL, CY or CD (not a moment).
    pub fn is_force(self) -> bool {
        matches!(
            self,
            Coefficient::Lift | Coefficient::Side | Coefficient::Drag
        )
    }

    pub const ALL: [Coefficient; 6] = [
        Coefficient::Lift,
        Coefficient::Side,
        Coefficient::Drag,
        Coefficient::Roll,
        Coefficient::Pitch,
        Coefficient::Yaw,
    ];

    /// Name in files: CL/CD in wind axes, CZ/CX in body axes.
    pub fn name(self, axes: ForceAxes) -> &'static str {
        match (self, axes) {
            (Coefficient::Lift, ForceAxes::Wind) => "CL",
            (Coefficient::Lift, ForceAxes::Body) => "CZ",
            (Coefficient::Drag, ForceAxes::Wind) => "CD",
            (Coefficient::Drag, ForceAxes::Body) => "CX",
            (Coefficient::Side, _) => "CY",
            (Coefficient::Roll, _) => "Cl",
            (Coefficient::Pitch, _) => "Cm",
            (Coefficient::Yaw, _) => "Cn",
        }
    }
}

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
struct StallOptions {
    time_unit: StallTimeUnit,
    tau2_only_while_decreasing: bool,
    induced_drag_lift: InducedDragLift,
    alpha_dot: StallAlphaDot,
    tau2_switch_band: f64,
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
    /// is driven by a record ([`AeroInput::measured_alpha_dot`]); where
    /// there is no measurement (the simulator flying a truth) the state
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
    fn offset(&self, chord: f64) -> Result<Vector3<f64>, String> {
        let offset = match (&self.offset, self.point_mac, self.cg_mac) {
            (Some(offset), None, None) => match offset[..] {
                [x, y, z] => Vector3::new(x, y, z),
                _ => return Err("offset must be three numbers [x, y, z] (m)".into()),
            },
            (None, Some(point), Some(cg)) => Vector3::new((cg - point) * chord, 0.0, 0.0),
            _ => {
                return Err(
                    "give either offset = [x, y, z] (m) or both point_mac and cg_mac (fractions of c̄)"
                        .into(),
                );
            }
        };
        match offset.iter().all(|v| v.is_finite()) {
            true => Ok(offset),
            false => Err("the offset must be finite numbers".into()),
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

#[derive(Debug, Clone, Copy, PartialEq)]
struct Term {
    monomial: Monomial,
    parameter: usize,
    /// The relation the parameter follows, when it is tied to another.
    tie: Option<Tie>,
}

impl Term {
    /// The term's coefficient given every parameter's value: its own, or
    /// for a tied term c·θ_master + d.
    #[inline(always)]
    fn coefficient(&self, values: &[f64]) -> f64 {
        match self.tie {
            None => values[self.parameter],
            Some(tie) => tie.value(values),
        }
    }
}

/// A linear relation θ = factor·θ_master + offset that a term's parameter
/// follows (a model file's `[parameters.NAME] tie`): the parameter is no
/// unknown of any estimator, and wherever the model is evaluated its term
/// takes the value the relation gives from the master's current value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tie {
    /// Index of the master parameter.
    pub master: usize,
    pub factor: f64,
    pub offset: f64,
}

impl Tie {
    /// factor·θ_master + offset.
    pub fn value(&self, values: &[f64]) -> f64 {
        self.factor * values[self.master] + self.offset
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct StallIndices {
    a1: usize,
    alpha_star: usize,
    tau1: usize,
    tau2: usize,
}

/// The flight variables a model is evaluated at (SI, rad, rad/s), over a
/// [`Real`] scalar (f64, or a [`aeroid_numerics::dual::Dual`] carrying derivatives).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AeroInput<T: Real = f64> {
    pub alpha: T,
    pub beta: T,
    pub airspeed: T,
    pub mach: T,
    pub rates: Vector3<T>,
    pub alpha_dot: T,
    /// The derivative of the measured α (rad/s), which a stall model with
    /// `alpha_dot = "measured"` takes in its separation equation instead of
    /// `alpha_dot`; None: no measurement (`alpha_dot` is used).
    pub measured_alpha_dot: Option<f64>,
    pub controls: Controls,
    /// Flow separation point χ (1 attached, 0 separated); ignored by linear models.
    pub chi: T,
}

/// Coefficients a model produced, in body axes and in wind axes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AeroCoefficients<T: Real = f64> {
    /// CX, CY, CZ.
    pub force: Vector3<T>,
    /// Cl, Cm, Cn.
    pub moment: Vector3<T>,
    pub lift: T,
    pub drag: T,
}

impl<T: Real> AeroInput<T> {
    /// The values, without derivatives.
    pub fn values(&self) -> AeroInput {
        AeroInput {
            alpha: self.alpha.value(),
            beta: self.beta.value(),
            airspeed: self.airspeed.value(),
            mach: self.mach.value(),
            rates: self.rates.map(T::value),
            alpha_dot: self.alpha_dot.value(),
            measured_alpha_dot: self.measured_alpha_dot,
            controls: self.controls,
            chi: self.chi.value(),
        }
    }
}

impl<T: Real> AeroCoefficients<T> {
    /// The values, without derivatives.
    pub fn values(&self) -> AeroCoefficients {
        AeroCoefficients {
            force: self.force.map(T::value),
            moment: self.moment.map(T::value),
            lift: self.lift.value(),
            drag: self.drag.value(),
        }
    }
}

impl<T: Real> std::ops::Add for AeroCoefficients<T> {
    type Output = AeroCoefficients<T>;
    fn add(self, other: AeroCoefficients<T>) -> AeroCoefficients<T> {
        AeroCoefficients {
            force: self.force + other.force,
            moment: self.moment + other.moment,
            lift: self.lift + other.lift,
            drag: self.drag + other.drag,
        }
    }
}

/// An aerodynamic model with named parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct AeroModel {
    pub kind: ModelKind,
    pub force_axes: ForceAxes,
    pub rate_normalization: RateNormalization,
    pub rate_speed: RateSpeed,
    pub reference_airspeed: f64,
    pub reference_mach: f64,
    pub geometry: ReferenceGeometry,
    /// From the CG to the point the moment coefficients are taken about
    /// (body axes, m); zero when they are taken about the CG.
    pub moment_reference: Vector3<f64>,
    pub parameters: ParameterSet,
    terms: [Vec<Term>; 6],
    /// The distinct products (terms of degree ≥ 2), in the order their
    /// values follow the regressors in [`TermRegressors`].
    products: Vec<Monomial>,
    oswald: Option<usize>,
    stall: Option<StallIndices>,
    /// The stall model's options (unit of τ, one-sided τ2, induced-drag
    /// lift, source of α̇).
    stall_options: StallOptions,
    /// Whether any coefficient has an α̇ term (fixed by the structure, not the values).
    has_alpha_dot_terms: bool,
    /// Added to each coefficient (in [`Coefficient`] order; the lift-type one
    /// before it enters CL² drag). Zero in flight: output error moves one by
    /// a small step to get ∂f/∂C for its sensitivity equations where the
    /// forces depend on α̇ (elsewhere [`AeroModel::offset_response`] gives
    /// it exactly).
    pub offsets: [f64; 6],
}

/// The regressor values each coefficient's terms multiply at one flight
/// condition, such that a coefficient is Σ C_term·regressor (plus its
/// offset), as one table ([`TermRegressors::slot`]): the lift-type
/// coefficient's (`alpha` carrying the Kirchhoff factor), then every other
/// coefficient's (`CL2` the lift-type coefficient squared), then 1 (at
/// [`TermRegressors::ONE`], for what enters unscaled), then the value of
/// each of the model's products (not scaled by the Kirchhoff factor).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TermRegressors {
    /// By slot: lift-type regressors, other regressors, 1, products.
    pub values: [f64; 2 * REGRESSOR_COUNT + 1 + MAX_PRODUCTS],
}

impl TermRegressors {
    /// The slot of the constant 1.
    pub const ONE: usize = 2 * REGRESSOR_COUNT;

    /// The slot of a single-regressor term's regressor: the lift-type
    /// coefficient's (`lift`) or another coefficient's.
    pub fn slot(lift: bool, regressor: Regressor) -> usize {
        regressor as usize + if lift { 0 } else { REGRESSOR_COUNT }
    }
}

impl Default for TermRegressors {
    /// Every regressor 0 (and the constant 1).
    fn default() -> Self {
        let mut values = [0.0; 2 * REGRESSOR_COUNT + 1 + MAX_PRODUCTS];
        values[TermRegressors::ONE] = 1.0;
        TermRegressors { values }
    }
}

impl AeroModel {
    /// Builds a model from its file table, collecting every problem under `prefix` (e.g. "aero").
    pub fn from_spec(
        spec: &AeroSpec,
        geometry: ReferenceGeometry,
        prefix: &str,
        problems: &mut Problems,
    ) -> AeroModel {
        let mut model = AeroModel {
            kind: spec.model,
            force_axes: spec.force_axes,
            rate_normalization: spec.rate_normalization,
            rate_speed: spec.rate_speed,
            reference_airspeed: spec.reference_airspeed.unwrap_or(f64::NAN),
            reference_mach: spec.reference_mach.unwrap_or(f64::NAN),
            geometry,
            moment_reference: Vector3::zeros(),
            parameters: ParameterSet::default(),
            terms: Default::default(),
            products: Vec::new(),
            oswald: None,
            stall: None,
            stall_options: Default::default(),
            has_alpha_dot_terms: false,
            offsets: [0.0; 6],
        };
        model.read_coefficients(spec, prefix, problems);
        model.read_extras(spec, prefix, problems);
        model.has_alpha_dot_terms = model
            .terms
            .iter()
            .flatten()
            .any(|t| t.monomial.contains(Regressor::AlphaDot));
        model
    }

    fn read_coefficients(&mut self, spec: &AeroSpec, prefix: &str, problems: &mut Problems) {
        let known: Vec<&str> = Coefficient::ALL
            .iter()
            .map(|c| c.name(self.force_axes))
            .collect();
        for (name, table) in &spec.coefficients {
            let Some(position) = known.iter().position(|k| k == name) else {
                problems.push(
                    format!("{prefix}.{name}"),
                    format!(
                        "unknown coefficient for {:?} force axes; known: {}",
                        self.force_axes,
                        known.join(", ")
                    ),
                );
                continue;
            };
            for (key, &value) in table {
                let field = format!("{prefix}.{name}.{key}");
                match self.check_term(Coefficient::ALL[position], key, value) {
                    Ok(monomial) => {
                        let parameter =
                            self.add_parameter(&format!("{name}_{key}"), value, &field, problems);
                        self.terms[position].push(Term {
                            monomial,
                            parameter,
                            tie: None,
                        });
                        self.add_product(monomial, &field, problems);
                    }
                    Err(message) => problems.push(field, message),
                }
            }
        }
    }

    fn check_term(
        &self,
        coefficient: Coefficient,
        key: &str,
        value: f64,
    ) -> Result<Monomial, String> {
        let monomial = match Regressor::from_key(key) {
            Some(regressor) => Monomial::from(regressor),
            None if key.contains(['*', '^']) => Monomial::parse(key)?,
            None => {
                return Err(format!(
                    "unknown term '{key}'; known: {} and their products ('alpha^2', 'alpha*de')",
                    Regressor::keys()
                ));
            }
        };
        if !value.is_finite() {
            return Err(format!("{value} is not a finite number"));
        }
        let lift_squared = monomial.contains(Regressor::LiftSquared);
        if lift_squared && (coefficient != Coefficient::Drag || self.force_axes != ForceAxes::Wind)
        {
            return Err("CL2 is a drag term of a wind-axis model".into());
        }
        if lift_squared && monomial.single().is_none() {
            return Err("CL2 cannot be a factor of a product".into());
        }
        if monomial.contains(Regressor::Separation) && self.kind != ModelKind::Stall {
            return Err("chi terms need model = \"stall\"".into());
        }
        Ok(monomial)
    }

    /// Registers a product's slot in [`TermRegressors`] (once per distinct product).
    fn add_product(&mut self, monomial: Monomial, field: &str, problems: &mut Problems) {
        if monomial.single().is_some() || self.products.contains(&monomial) {
            return;
        }
        if self.products.len() == MAX_PRODUCTS {
            problems.push(
                field,
                format!("more than {MAX_PRODUCTS} distinct product terms in one model"),
            );
            return;
        }
        self.products.push(monomial);
    }

    fn add_parameter(
        &mut self,
        name: &str,
        value: f64,
        field: &str,
        problems: &mut Problems,
    ) -> usize {
        self.parameters.add(name, value).unwrap_or_else(|message| {
            problems.push(field, message);
            self.parameters.index(name).unwrap_or(0)
        })
    }

    fn read_extras(&mut self, spec: &AeroSpec, prefix: &str, problems: &mut Problems) {
        if let Some(e) = spec.oswald_efficiency {
            if !(e.is_finite() && e > 0.0) || self.force_axes != ForceAxes::Wind {
                problems.push(
                    format!("{prefix}.oswald_efficiency"),
                    "must be a positive number, in a wind-axis model",
                );
            }
            self.oswald = Some(self.add_parameter("e", e, prefix, problems));
        }
        self.read_stall(spec, prefix, problems);
        self.check_references(spec, prefix, problems);
        if let Some(reference) = &spec.moment_reference {
            match reference.offset(self.geometry.chord) {
                Ok(offset) => self.moment_reference = offset,
                Err(message) => problems.push(format!("{prefix}.moment_reference"), message),
            }
        }
    }

    fn read_stall(&mut self, spec: &AeroSpec, prefix: &str, problems: &mut Problems) {
        match (self.kind, &spec.stall) {
            (ModelKind::Stall, Some(stall)) => {
                if self.force_axes != ForceAxes::Wind {
                    problems.push(
                        format!("{prefix}.force_axes"),
                        "the stall model is written in wind axes",
                    );
                }
                let field = format!("{prefix}.stall");
                for (name, value) in [
                    ("a1", stall.a1),
                    ("alpha_star", stall.alpha_star),
                    ("tau1", stall.tau1),
                    ("tau2", stall.tau2),
                ] {
                    if !value.is_finite() {
                        problems.push(
                            format!("{field}.{name}"),
                            format!("{value} is not a finite number"),
                        );
                    }
                }
                if stall.tau1 < 0.0 {
                    problems.push(format!("{field}.tau1"), "must be ≥ 0 (0 makes χ algebraic)");
                }
                let band = stall.tau2_switch_band;
                if !(band.is_finite() && band >= 0.0) {
                    problems.push(
                        format!("{field}.tau2_switch_band"),
                        "must be a rate ≥ 0 (rad/s; 0: the sharp switch)",
                    );
                } else if band > 0.0 && !stall.tau2_only_while_decreasing {
                    problems.push(
                        format!("{field}.tau2_switch_band"),
                        "needs tau2_only_while_decreasing = true",
                    );
                }
                self.stall_options = StallOptions {
                    time_unit: stall.time_unit,
                    tau2_only_while_decreasing: stall.tau2_only_while_decreasing,
                    induced_drag_lift: stall.induced_drag_lift,
                    alpha_dot: stall.alpha_dot,
                    tau2_switch_band: stall.tau2_switch_band,
                };
                self.stall = Some(StallIndices {
                    a1: self.add_parameter("a1", stall.a1, &field, problems),
                    alpha_star: self.add_parameter(
                        "alpha_star",
                        stall.alpha_star,
                        &field,
                        problems,
                    ),
                    tau1: self.add_parameter("tau1", stall.tau1, &field, problems),
                    tau2: self.add_parameter("tau2", stall.tau2, &field, problems),
                });
            }
            (ModelKind::Stall, None) => problems.push(
                format!("{prefix}.stall"),
                "model = \"stall\" needs a [stall] table",
            ),
            (ModelKind::Linear, Some(_)) => problems.push(
                format!("{prefix}.stall"),
                "a [stall] table needs model = \"stall\"",
            ),
            (ModelKind::Linear, None) => {}
        }
    }

    fn check_references(&self, spec: &AeroSpec, prefix: &str, problems: &mut Problems) {
        let uses = |regressor: Regressor| {
            self.terms
                .iter()
                .flatten()
                .any(|t| t.monomial.contains(regressor))
        };
        let needs_speed = uses(Regressor::SpeedRatio) || self.rate_speed == RateSpeed::Reference;
        match spec.reference_airspeed {
            Some(v) if !(v.is_finite() && v > 0.0) => problems.push(
                format!("{prefix}.reference_airspeed"),
                "must be a positive speed (m/s)",
            ),
            None if needs_speed => problems.push(
                format!("{prefix}.reference_airspeed"),
                "needed by dV terms and rate_speed = \"reference\"",
            ),
            _ => {}
        }
        match spec.reference_mach {
            Some(m) if !(m.is_finite() && m > 0.0) => problems.push(
                format!("{prefix}.reference_mach"),
                "must be a positive Mach number",
            ),
            None if uses(Regressor::Mach) => {
                problems.push(format!("{prefix}.reference_mach"), "needed by dMach terms")
            }
            _ => {}
        }
    }

    /// Whether `value` may replace parameter `name` in flight: a finite
    /// number, a positive Oswald factor `e`, and a `tau1` that keeps χ what
    /// it was at the start, a state (τ1 > 0) or algebraic (τ1 = 0), since
    /// the state vector cannot gain or lose χ mid-flight.
    pub fn check_replacement(&self, name: &str, value: f64) -> Result<(), String> {
        if !value.is_finite() {
            return Err(format!("{value} is not a finite number"));
        }
        let index = self.parameters.index(name);
        if index.is_some() && index == self.oswald && value <= 0.0 {
            return Err(format!("the Oswald factor e must be positive, got {value}"));
        }
        if let Some(s) = self.stall
            && index == Some(s.tau1)
            && (value > 0.0) != self.chi_is_state()
        {
            return Err(match self.chi_is_state() {
                true => {
                    format!("tau1 must stay positive (χ is a state of this aircraft), got {value}")
                }
                false => {
                    format!("tau1 must stay 0 (χ is algebraic for this aircraft), got {value}")
                }
            });
        }
        Ok(())
    }

    /// True when χ is integrated as a state (stall model with τ1 > 0).
    pub fn chi_is_state(&self) -> bool {
        self.stall
            .is_some_and(|s| self.parameters.values()[s.tau1] > 0.0)
    }

    /// True when the forces depend on the state's α̇ algebraically (α̇
    /// terms, or algebraic χ with τ2 ≠ 0), so the equations of motion must
    /// be solved for α̇, in a model driven by a record: one whose
    /// separation takes the measured α̇ (`alpha_dot = "measured"`) is given
    /// it there, and its χ does not depend on the state's α̇.
    pub fn forces_depend_on_alpha_dot(&self) -> bool {
        self.forces_depend_on_state_alpha_dot(true)
    }

    /// [`AeroModel::forces_depend_on_alpha_dot`] where a measured α̇ is
    /// given (`measured`) or not (the simulator flying a truth, whose
    /// separation then takes the state's α̇ whatever the option).
    pub fn forces_depend_on_state_alpha_dot(&self, measured: bool) -> bool {
        let values = self.parameters.values();
        let stall = self.stall.is_some_and(|s| {
            values[s.tau1] == 0.0
                && values[s.tau2] != 0.0
                && !(measured && self.takes_measured_alpha_dot())
        });
        stall || self.has_alpha_dot_terms
    }

    /// Whether the separation equation takes the measured α̇ where there is
    /// one (`alpha_dot = "measured"`).
    pub fn takes_measured_alpha_dot(&self) -> bool {
        self.stall.is_some() && self.stall_options.alpha_dot == StallAlphaDot::Measured
    }

    /// The α̇ of the separation equation: the measured one with
    /// `alpha_dot = "measured"` when there is one, else the state's
    /// `alpha_dot`.
    pub fn separation_alpha_dot<T: Real>(&self, alpha_dot: T, measured: Option<f64>) -> T {
        match measured {
            Some(rate) if self.takes_measured_alpha_dot() => T::constant(rate),
            _ => alpha_dot,
        }
    }

    /// Steady-state separation point χ∞ = ½(1 − tanh(a1·(α − τ2·α̇ − α*))) (Verma & Peyada 2020, Eq. 3); 1 without stall model.
    /// at `airspeed` (it scales τ given in units of c̄/V); τ2·α̇ acts only
    /// while α̇ < 0 when the model says so.
    pub fn separation_target<T: Real>(&self, alpha: T, alpha_dot: T, airspeed: T) -> T {
        match self.stall {
            Some(s) => {
                let v = self.parameters.values();
                let rate = self.hysteresis_rate(alpha_dot);
                let lag = match self.chord_time(airspeed) {
                    None => rate * v[s.tau2],
                    Some(scale) => rate * scale * v[s.tau2],
                };
                (T::constant(1.0) - ((alpha - lag - v[s.alpha_star]) * v[s.a1]).tanh()) * 0.5
            }
            None => T::constant(1.0),
        }
    }

    /// χ∞ at α̇ = 0 (Eq. 3 with no hysteresis lag, whatever the airspeed).
    pub fn steady_separation(&self, alpha: f64) -> f64 {
        self.separation_target(alpha, 0.0, 1.0)
    }

    /// dχ/dt = (χ∞ − χ)/τ1 (Verma & Peyada 2020, Eq. 2); 0 when χ is not a state.
    pub fn separation_rate<T: Real>(&self, alpha: T, alpha_dot: T, chi: T, airspeed: T) -> T {
        match self.stall {
            Some(s) if self.chi_is_state() => {
                let tau1 = self.parameters.values()[s.tau1];
                let lag = self.separation_target(alpha, alpha_dot, airspeed) - chi;
                match self.chord_time(airspeed) {
                    None => lag / tau1,
                    Some(scale) => lag / (scale * tau1),
                }
            }
            _ => T::zero(),
        }
    }

    /// ∂(dχ/dt)/∂α̇ = ½·a1·τ2·(1 − tanh²(a1·(α − τ2·α̇ − α*)))/τ1 (from Eqs. 2–3,
    /// τ in seconds); 0 when χ is not a state, or τ2 does not act (α̇ ≥ 0
    /// with `tau2_only_while_decreasing`), or the separation takes the
    /// measured α̇ (in a model driven by a record, which gives it).
    pub fn separation_rate_slope(&self, alpha: f64, alpha_dot: f64, airspeed: f64) -> f64 {
        match self.stall {
            Some(s) if self.chi_is_state() && !self.takes_measured_alpha_dot() => {
                let v = self.parameters.values();
                let scale = self.chord_time(airspeed).unwrap_or(1.0);
                let (tau1, tau2) = (v[s.tau1] * scale, v[s.tau2] * scale);
                let rate = self.hysteresis_rate(alpha_dot);
                let t = (v[s.a1] * (alpha - tau2 * rate - v[s.alpha_star])).tanh();
                0.5 * v[s.a1] * tau2 * (1.0 - t * t) * self.hysteresis_rate_slope(alpha_dot) / tau1
            }
            _ => 0.0,
        }
    }

    /// Seconds per unit of the stall time constants at `airspeed`: None
    /// for τ in seconds, c̄/V for τ in units of c̄/V.
    fn chord_time<T: Real>(&self, airspeed: T) -> Option<T> {
        match self.stall_options.time_unit {
            StallTimeUnit::Seconds => None,
            StallTimeUnit::ChordTimes => {
                let speed = match self.rate_speed {
                    RateSpeed::Airspeed => airspeed,
                    RateSpeed::Reference => T::constant(self.reference_airspeed),
                };
                Some(T::constant(self.geometry.chord) / speed)
            }
        }
    }

    /// The α̇ the hysteresis τ2 acts on: α̇, or with
    /// `tau2_only_while_decreasing` α̇ while it is negative and 0 otherwise.
    /// With a `tau2_switch_band` b > 0 the switch is the smooth step
    /// α̇·½(1 − tanh(α̇/b)): α̇ below −2b (within 2 %), 0 above 2b.
    fn hysteresis_rate<T: Real>(&self, alpha_dot: T) -> T {
        let band = self.stall_options.tau2_switch_band;
        match (self.stall_options.tau2_only_while_decreasing, band > 0.0) {
            (false, _) => alpha_dot,
            (true, true) => {
                alpha_dot * (T::constant(1.0) - (alpha_dot * (1.0 / band)).tanh()) * 0.5
            }
            (true, false) if alpha_dot.value() >= 0.0 => T::zero(),
            (true, false) => alpha_dot,
        }
    }

    /// d/dα̇ of [`AeroModel::hysteresis_rate`] (0 at α̇ = 0 of the sharp switch).
    fn hysteresis_rate_slope(&self, alpha_dot: f64) -> f64 {
        let band = self.stall_options.tau2_switch_band;
        match (self.stall_options.tau2_only_while_decreasing, band > 0.0) {
            (false, _) => 1.0,
            (true, true) => {
                let t = (alpha_dot / band).tanh();
                0.5 * (1.0 - t) - 0.5 * alpha_dot / band * (1.0 - t * t)
            }
            (true, false) if alpha_dot >= 0.0 => 0.0,
            (true, false) => 1.0,
        }
    }

    /// The χ the forces use: the state when τ1 > 0, Eq. 3 when τ1 = 0, 1 without stall.
    #[inline(always)]
    pub fn effective_chi<T: Real>(&self, input: &AeroInput<T>) -> T {
        if self.stall.is_none() {
            T::constant(1.0)
        } else if self.chi_is_state() {
            input.chi
        } else {
            let alpha_dot = self.separation_alpha_dot(input.alpha_dot, input.measured_alpha_dot);
            self.separation_target(input.alpha, alpha_dot, input.airspeed)
        }
    }

    /// Whether [`AeroModel::offset_response`] is the exact response of the
    /// coefficients to a coefficient's offset: not when the forces depend
    /// on α̇ (the equations are solved for it), nor when the induced drag
    /// squares the attached-flow lift (not in the coefficients it is given).
    pub fn offset_response_is_exact(&self) -> bool {
        let attached = self.stall.is_some()
            && self.stall_options.induced_drag_lift == InducedDragLift::Attached;
        !(self.forces_depend_on_alpha_dot() || attached)
    }

    /// Normalising speed for rates: the airspeed or V0, times 2 or 1.
    #[inline(always)]
    fn rate_divisor<T: Real>(&self, airspeed: T) -> T {
        let speed = match self.rate_speed {
            RateSpeed::Airspeed => airspeed,
            RateSpeed::Reference => T::constant(self.reference_airspeed),
        };
        match self.rate_normalization {
            RateNormalization::TwiceSpeed => speed * 2.0,
            RateNormalization::Speed => speed,
        }
    }

    /// The value of every regressor (indexed by `Regressor as usize`) at a
    /// flight condition; `CL2` is left 0 (it needs the lift coefficient).
    #[inline(always)]
    pub fn regressors<T: Real>(&self, input: &AeroInput<T>, chi: T) -> [T; REGRESSOR_COUNT] {
        let per_speed = T::constant(1.0) / self.rate_divisor(input.airspeed);
        let (b, c) = (self.geometry.span, self.geometry.chord);
        let u = &input.controls;
        let control = |control: Control| T::constant(u[control.index()]);
        [
            T::constant(1.0),
            input.alpha,
            input.beta,
            input.rates.x * b * per_speed,
            input.rates.y * c * per_speed,
            input.rates.z * b * per_speed,
            input.alpha_dot * c * per_speed,
            control(Control::Elevator),
            control(Control::Aileron),
            control(Control::Rudder),
            control(Control::Flap),
            input.airspeed / self.reference_airspeed - 1.0,
            input.mach - self.reference_mach,
            T::constant(1.0) - chi,
            T::zero(),
        ]
    }

    #[inline(always)]
    fn sum<T: Real>(&self, coefficient: Coefficient, regressors: &[T; REGRESSOR_COUNT]) -> T {
        self.sum_scaled(coefficient, regressors, T::constant(1.0))
    }

    /// Σ C_term·regressor + offset of `coefficient`, with the `alpha`
    /// regressor times `alpha_factor` (the Kirchhoff factor on the
    /// lift-type coefficient; 1, which changes nothing, elsewhere).
    #[inline(always)]
    fn sum_scaled<T: Real>(
        &self,
        coefficient: Coefficient,
        regressors: &[T; REGRESSOR_COUNT],
        alpha_factor: T,
    ) -> T {
        let values = self.parameters.values();
        let mut sum = T::constant(-0.0);
        for t in &self.terms[coefficient as usize] {
            let regressor = match t.monomial.single() {
                Some(Regressor::Alpha) => regressors[Regressor::Alpha as usize] * alpha_factor,
                Some(r) => regressors[r as usize],
                None => t.monomial.value(regressors),
            };
            sum += regressor * t.coefficient(values);
        }
        sum + self.offsets[coefficient as usize]
    }

    /// The factor on the lift-type `alpha` term: the Kirchhoff
    /// ((1 + √χ)/2)² of the stall model, 1 for a linear one.
    #[inline(always)]
    fn kirchhoff<T: Real>(&self, chi: T) -> T {
        match self.kind {
            ModelKind::Stall => {
                let root = (chi.max_value(0.0).sqrt() + 1.0) * 0.5;
                root * root
            }
            ModelKind::Linear => T::constant(1.0),
        }
    }

    /// The regressors of every coefficient but the lift-type one
    /// (`CL2` = CL² included) and the lift-type coefficient, at a flight
    /// condition; the lift-type `alpha` regressor is the `alpha` one times
    /// the Kirchhoff factor (also returned).
    #[inline(always)]
    fn regressors_and_lift<T: Real>(&self, input: &AeroInput<T>) -> ([T; REGRESSOR_COUNT], T, T) {
        let chi = self.effective_chi(input);
        let mut other = self.regressors(input, chi);
        let kirchhoff = self.kirchhoff(chi);
        let lift_type = self.sum_scaled(Coefficient::Lift, &other, kirchhoff);
        other[Regressor::LiftSquared as usize] = lift_type * lift_type;
        (other, lift_type, kirchhoff)
    }

    /// The regressors every term multiplies at a flight condition (the
    /// Kirchhoff factor on the lift-type `alpha` term, `CL2` = CL²).
    pub fn term_regressors(&self, input: &AeroInput) -> TermRegressors {
        let (other, _, kirchhoff) = self.regressors_and_lift(input);
        let mut regressors = TermRegressors::default();
        let (lift, rest) = regressors.values.split_at_mut(REGRESSOR_COUNT);
        lift.copy_from_slice(&other);
        lift[Regressor::Alpha as usize] *= kirchhoff;
        lift[Regressor::LiftSquared as usize] = 0.0;
        rest[..REGRESSOR_COUNT].copy_from_slice(&other);
        let products = &mut rest[REGRESSOR_COUNT + 1..];
        for (value, product) in products.iter_mut().zip(&self.products) {
            *value = product.value(&other);
        }
        regressors
    }

    /// The slot in [`TermRegressors`] of the value a term of `coefficient` multiplies.
    pub fn term_slot(&self, coefficient: Coefficient, monomial: Monomial) -> usize {
        match monomial.single() {
            Some(regressor) => TermRegressors::slot(coefficient == Coefficient::Lift, regressor),
            None => {
                let k = self.products.iter().position(|p| *p == monomial);
                TermRegressors::ONE + 1 + k.expect("every product of a term has a slot")
            }
        }
    }

    /// Ties term parameter `tied` to term parameter `master` by
    /// θ_tied = factor·θ_master + offset, and sets θ_tied so. Errors: either
    /// is not a term's parameter, they are the same, the master is tied
    /// itself, the tied one is already tied or is another's master.
    pub fn tie(&mut self, tied: usize, tie: Tie) -> Result<(), String> {
        let names = self.parameters.names();
        let name = |i: usize| names[i].clone();
        if !(tie.factor.is_finite() && tie.offset.is_finite()) {
            return Err("the factor and offset must be finite numbers".into());
        }
        if tie.master == tied {
            return Err(format!("'{}' cannot be tied to itself", name(tied)));
        }
        let is_term = |i: usize| self.terms.iter().flatten().any(|t| t.parameter == i);
        for (i, role) in [(tied, "tied"), (tie.master, "a master")] {
            if !is_term(i) {
                return Err(format!(
                    "'{}' is not a term's parameter ({{coefficient}}_{{term}}): only those can be {role}",
                    name(i)
                ));
            }
        }
        if let Some(other) = self.tie_of(tie.master) {
            return Err(format!(
                "the master '{}' is tied itself (to '{}'): tie to a free or fixed parameter",
                name(tie.master),
                name(other.master)
            ));
        }
        if let Some(other) = self.tie_of(tied) {
            return Err(format!(
                "'{}' is tied already (to '{}')",
                name(tied),
                name(other.master)
            ));
        }
        if let Some(dependent) = self.dependents(tied).next() {
            return Err(format!(
                "'{}' is the master of '{}': a master cannot be tied itself",
                name(tied),
                name(dependent)
            ));
        }
        for term in self.terms.iter_mut().flatten() {
            if term.parameter == tied {
                term.tie = Some(tie);
            }
        }
        let value = tie.value(self.parameters.values());
        self.parameters.values_mut()[tied] = value;
        Ok(())
    }

    /// The relation a parameter is tied by; None when it is not tied.
    pub fn tie_of(&self, parameter: usize) -> Option<Tie> {
        self.terms
            .iter()
            .flatten()
            .find(|t| t.parameter == parameter)
            .and_then(|t| t.tie)
    }

    /// The parameters tied to `master`.
    pub fn dependents(&self, master: usize) -> impl Iterator<Item = usize> + '_ {
        self.terms
            .iter()
            .flatten()
            .filter(move |t| t.tie.is_some_and(|tie| tie.master == master))
            .map(|t| t.parameter)
    }

    /// Whether any parameter is tied to another.
    pub fn has_ties(&self) -> bool {
        self.terms.iter().flatten().any(|t| t.tie.is_some())
    }

    /// Sets every tied parameter's value from its master's (what the
    /// evaluation uses already), e.g. after the masters were estimated.
    pub fn update_tied_values(&mut self) {
        let ties: Vec<(usize, Tie)> = (self.terms.iter().flatten())
            .filter_map(|t| t.tie.map(|tie| (t.parameter, tie)))
            .collect();
        for (tied, tie) in ties {
            let value = tie.value(self.parameters.values());
            self.parameters.values_mut()[tied] = value;
        }
    }

    /// The coefficient and term of a parameter that enters linearly
    /// (`{coefficient}_{term}`) in exactly one term, its own: None for `e`,
    /// the stall parameters, a tied parameter and the master of one (whose
    /// value moves other terms too).
    pub fn term_of(&self, parameter: usize) -> Option<(Coefficient, Monomial)> {
        if self.tie_of(parameter).is_some() || self.dependents(parameter).next().is_some() {
            return None;
        }
        Coefficient::ALL.into_iter().find_map(|coefficient| {
            self.terms[coefficient as usize]
                .iter()
                .find(|t| t.parameter == parameter)
                .map(|t| (coefficient, t.monomial))
        })
    }

    /// Evaluates all six coefficients. Allocation-free.
    pub fn coefficients(&self, input: &AeroInput) -> AeroCoefficients {
        self.coefficients_at(input, input.alpha.sin_cos())
    }

    /// As [`AeroModel::coefficients`], with sin α and cos α of `input.alpha` given.
    #[inline(always)]
    pub fn coefficients_at<T: Real>(
        &self,
        input: &AeroInput<T>,
        alpha_sin_cos: (T, T),
    ) -> AeroCoefficients<T> {
        let (regressors, lift_type, _) = self.regressors_and_lift(input);
        let mut drag_type = self.sum(Coefficient::Drag, &regressors);
        if let Some(e) = self.oswald {
            let induced = match (self.stall, self.stall_options.induced_drag_lift) {
                (Some(_), InducedDragLift::Attached) => self.sum(Coefficient::Lift, &regressors),
                _ => lift_type,
            };
            drag_type += induced * induced
                / (self.parameters.values()[e] * std::f64::consts::PI * self.geometry.aspect_ratio);
        }
        let side = self.sum(Coefficient::Side, &regressors);
        let moment = Vector3::new(
            self.sum(Coefficient::Roll, &regressors),
            self.sum(Coefficient::Pitch, &regressors),
            self.sum(Coefficient::Yaw, &regressors),
        );
        self.assemble(lift_type, side, drag_type, moment, alpha_sin_cos)
    }

    /// The coefficients from the lift-type, side, drag-type and moment
    /// coefficients at angle of attack α (its sine and cosine; linear in the four).
    #[inline(always)]
    fn assemble<T: Real>(
        &self,
        lift_type: T,
        side: T,
        drag_type: T,
        moment: Vector3<T>,
        (sin_alpha, cos_alpha): (T, T),
    ) -> AeroCoefficients<T> {
        let mut coefficients = match self.force_axes {
            ForceAxes::Wind => AeroCoefficients {
                force: Vector3::new(
                    -drag_type * cos_alpha + lift_type * sin_alpha,
                    side,
                    -drag_type * sin_alpha - lift_type * cos_alpha,
                ),
                moment,
                lift: lift_type,
                drag: drag_type,
            },
            ForceAxes::Body => AeroCoefficients {
                force: Vector3::new(drag_type, side, lift_type),
                moment,
                lift: -lift_type * cos_alpha + drag_type * sin_alpha,
                drag: -drag_type * cos_alpha - lift_type * sin_alpha,
            },
        };
        if self.moment_reference != Vector3::zeros() {
            coefficients.moment += self.moment_transfer(&coefficients.force);
        }
        coefficients
    }

    /// What the body-axis force coefficients `force` (CX, CY, CZ) add to
    /// the moment coefficients when these are taken about the reference
    /// point r (from the CG, [`AeroModel::moment_reference`]) and the
    /// moments about the CG are wanted: M_cg = M_ref + r × F, non-dimensional
    /// (r × C_F)/(b, c̄, b). Zero for r = 0.
    pub fn moment_transfer<T: Real>(&self, force: &Vector3<T>) -> Vector3<T> {
        let r = &self.moment_reference;
        let g = &self.geometry;
        Vector3::new(
            (force.z * r.y - force.y * r.z) / g.span,
            (force.x * r.z - force.z * r.x) / g.chord,
            (force.y * r.x - force.x * r.y) / g.span,
        )
    }

    /// Which body-axis force coefficients (CX, CY, CZ) the transfer of the
    /// moment `coefficient` to the CG uses ([`AeroModel::moment_transfer`]).
    pub fn transfer_uses(&self, coefficient: Coefficient) -> [bool; 3] {
        let r = self.moment_reference.map(|v| v != 0.0);
        match coefficient {
            Coefficient::Roll => [false, r.z, r.y],
            Coefficient::Pitch => [r.z, false, r.x],
            Coefficient::Yaw => [r.y, r.x, false],
            _ => [false; 3],
        }
    }

    /// ∂[`AeroModel::coefficients`]/∂(offset of `coefficient`) at a flight
    /// condition where the coefficients are `at` (sin α, cos α = `alpha_sin_cos`), exact:
    /// the offset adds to its coefficient, and a lift-type offset also moves
    /// the drag through CL² (its `CL2` terms and the Oswald term,
    /// ∂CD/∂CL = 2·CL·(Σ CD_CL2 + 1/(e·π·Λ))).
    pub fn offset_response(
        &self,
        coefficient: Coefficient,
        at: &AeroCoefficients,
        alpha_sin_cos: SinCos,
    ) -> AeroCoefficients {
        let mut unit = [0.0; 6];
        unit[coefficient as usize] = 1.0;
        if coefficient == Coefficient::Lift {
            let values = self.parameters.values();
            let mut slope: f64 = self.terms[Coefficient::Drag as usize]
                .iter()
                .filter(|t| t.monomial == Monomial::from(Regressor::LiftSquared))
                .map(|t| t.coefficient(values))
                .sum();
            if let Some(e) = self.oswald {
                slope += 1.0 / (values[e] * std::f64::consts::PI * self.geometry.aspect_ratio);
            }
            let lift_type = self.coefficient_values(at)[0];
            unit[Coefficient::Drag as usize] = 2.0 * lift_type * slope;
        }
        let [lift, side, drag, roll, pitch, yaw] = unit;
        self.assemble(
            lift,
            side,
            drag,
            Vector3::new(roll, pitch, yaw),
            alpha_sin_cos,
        )
    }

    /// The six coefficients in this model's naming order (CL/CZ, CY, CD/CX, Cl, Cm, Cn).
    pub fn coefficient_values(&self, c: &AeroCoefficients) -> [f64; 6] {
        let (lift, drag) = match self.force_axes {
            ForceAxes::Wind => (c.lift, c.drag),
            ForceAxes::Body => (c.force.z, c.force.x),
        };
        [lift, c.force.y, drag, c.moment.x, c.moment.y, c.moment.z]
    }

    /// Local linear derivatives of this model at a flight condition, named
    /// as a linear model's parameters (`CL_alpha`, `Cm_q`, `CL_0`, …): the
    /// truth that a linear postulate is scored against when this (truth)
    /// model is not linear (DESIGN.md, "Truth when the structures differ").
    /// Central differences with steps of 1e-5 in each regressor; χ takes its
    /// quasi-steady value χ∞(α) (α̇ = 0); the constant term is
    /// C(at) − Σ ∂C/∂x·x(at) so that the linear model passes through C(at).
    pub fn local_derivatives(&self, at: &AeroInput) -> Vec<(String, f64)> {
        const STEP: f64 = 1e-5;
        let divisor = self.rate_divisor(at.airspeed);
        let (b, c) = (self.geometry.span, self.geometry.chord);
        let evaluate = |input: &AeroInput| {
            let mut input = *input;
            input.chi = self.separation_target(input.alpha, input.alpha_dot, input.airspeed);
            self.coefficient_values(&self.coefficients(&input))
        };
        let perturbations: [(Regressor, f64, Perturbation); 9] = [
            (Regressor::Alpha, STEP, |i, h| i.alpha += h),
            (Regressor::Beta, STEP, |i, h| i.beta += h),
            (Regressor::RollRate, STEP * divisor / b, |i, h| {
                i.rates.x += h
            }),
            (Regressor::PitchRate, STEP * divisor / c, |i, h| {
                i.rates.y += h
            }),
            (Regressor::YawRate, STEP * divisor / b, |i, h| {
                i.rates.z += h
            }),
            (Regressor::Elevator, STEP, |i, h| {
                i.controls[Control::Elevator.index()] += h
            }),
            (Regressor::Aileron, STEP, |i, h| {
                i.controls[Control::Aileron.index()] += h
            }),
            (Regressor::Rudder, STEP, |i, h| {
                i.controls[Control::Rudder.index()] += h
            }),
            (Regressor::Flap, STEP, |i, h| {
                i.controls[Control::Flap.index()] += h
            }),
        ];
        let regressors = self.regressors(at, 1.0);
        let base = evaluate(at);
        let mut constants = base;
        let mut derivatives = Vec::new();
        for (regressor, h, perturb) in perturbations {
            let (mut plus, mut minus) = (*at, *at);
            perturb(&mut plus, h);
            perturb(&mut minus, -h);
            let (up, down) = (evaluate(&plus), evaluate(&minus));
            for (k, coefficient) in Coefficient::ALL.iter().enumerate() {
                let slope = (up[k] - down[k]) / (2.0 * STEP);
                constants[k] -= slope * regressors[regressor as usize];
                derivatives.push((
                    format!("{}_{}", coefficient.name(self.force_axes), regressor.key()),
                    slope,
                ));
            }
        }
        for (k, coefficient) in Coefficient::ALL.iter().enumerate() {
            derivatives.push((
                format!("{}_0", coefficient.name(self.force_axes)),
                constants[k],
            ));
        }
        derivatives
    }

    /// The terms of one coefficient as (what the parameter multiplies,
    /// parameter index), in file order.
    pub fn terms(&self, coefficient: Coefficient) -> impl Iterator<Item = (Monomial, usize)> + '_ {
        self.terms[coefficient as usize]
            .iter()
            .map(|t| (t.monomial, t.parameter))
    }

    /// Names of the terms of one coefficient, in file order (for reports and model-structure code).
    pub fn term_names(&self, coefficient: Coefficient) -> Vec<String> {
        self.terms[coefficient as usize]
            .iter()
            .map(|t| self.parameters.names()[t.parameter].clone())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry() -> ReferenceGeometry {
        ReferenceGeometry {
            span: 21.5,
            chord: 3.159,
            aspect_ratio: 21.5 * 21.5 / 64.0,
        }
    }

    fn parse(text: &str) -> (AeroModel, Problems) {
        let spec: AeroSpec = toml::from_str(text).unwrap();
        let mut problems = Problems::default();
        let model = AeroModel::from_spec(&spec, geometry(), "aero", &mut problems);
        (model, problems)
    }

    #[test]
    fn linear_terms_are_named_and_summed() {
        let (model, problems) = parse(
            "[CL]\n0 = 0.2\nalpha = 5.0\nq = 10.0\n[Cm]\nde = -1.0\n[CD]\n0 = 0.03\nCL2 = 0.05\n",
        );
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(model.parameters.get("CL_alpha"), Some(5.0));
        let mut input = AeroInput {
            alpha: 0.1,
            airspeed: 100.0,
            ..Default::default()
        };
        input.rates.y = 0.2;
        input.controls[Control::Elevator.index()] = 0.05;
        let c = model.coefficients(&input);
        let q_hat = 0.2 * 3.159 / 200.0;
        let lift = 0.2 + 0.5 + 10.0 * q_hat;
        assert!((c.lift - lift).abs() < 1e-15);
        assert!((c.drag - (0.03 + 0.05 * lift * lift)).abs() < 1e-15);
        assert!((c.moment.y + 0.05).abs() < 1e-15);
        let cz = -c.drag * 0.1f64.sin() - lift * 0.1f64.cos();
        assert!((c.force.z - cz).abs() < 1e-15);
    }

    #[test]
    fn products_are_canonical_and_multiply_their_factors() {
        let term = Monomial::parse("alpha^2*de").unwrap();
        assert_eq!(term.key(), "alpha^2*de");
        assert_eq!(
            term.factors(),
            [Regressor::Alpha, Regressor::Alpha, Regressor::Elevator]
        );
        let mut regressors = [0.0; REGRESSOR_COUNT];
        regressors[Regressor::Alpha as usize] = 0.1;
        regressors[Regressor::Elevator as usize] = -0.05;
        assert!((term.value(&regressors) - 0.1 * 0.1 * -0.05).abs() < 1e-18);
        assert_eq!(Monomial::parse("alpha").unwrap(), Regressor::Alpha.into());
        for bad in [
            "de*alpha",
            "alpha*alpha",
            "alpha^1",
            "alpha^2.5",
            "alpha^",
            "*alpha",
        ] {
            assert!(Monomial::parse(bad).is_err(), "{bad}");
        }
        let (model, problems) =
            parse("[CL]\nalpha = 5.0\n\"alpha^2\" = -2.0\n[Cm]\n\"alpha*de\" = -1.0\n");
        assert!(problems.is_empty(), "{problems:?}");
        let mut input = AeroInput {
            alpha: 0.1,
            airspeed: 100.0,
            ..Default::default()
        };
        input.controls[Control::Elevator.index()] = 0.05;
        let c = model.coefficients(&input);
        assert!((c.lift - (0.5 - 0.02)).abs() < 1e-15);
        assert!((c.moment.y + 0.005).abs() < 1e-15);
        let regressors = model.term_regressors(&input);
        let (coefficient, term) = model.term_of(1).unwrap();
        let slot = model.term_slot(coefficient, term);
        assert_eq!(regressors.values[slot], 0.1 * 0.1);
    }

    /// M_cg = M_ref + r × F: a reference point ahead of the CG (x > 0)
    /// with lift (CZ < 0) pitches the nose up about the CG.
    #[test]
    fn moments_are_transferred_to_the_cg() {
        let (model, problems) =
            parse("[moment_reference]\noffset = [0.5, 0.0, 0.2]\n[CL]\n0 = 1.0\n[CD]\n0 = 0.1\n");
        assert!(problems.is_empty(), "{problems:?}");
        let input = AeroInput {
            airspeed: 100.0,
            ..Default::default()
        };
        let c = model.coefficients(&input);
        // α = 0: CX = −CD = −0.1, CZ = −CL = −1: (z·CX − x·CZ)/c̄.
        let (cx, cz) = (-0.1, -1.0);
        let expected = (0.2 * cx - 0.5 * cz) / 3.159;
        assert!((c.moment.y - expected).abs() < 1e-15 && expected > 0.0);
        assert_eq!(c.moment.x, 0.0);
        assert_eq!(c.moment.z, 0.0);
    }

    fn stall(options: &str) -> AeroModel {
        let (model, problems) = parse(&format!(
            "model = \"stall\"\noswald_efficiency = 0.8\n[stall]\na1 = 20.0\nalpha_star = 0.3\ntau1 = 0.2\ntau2 = 0.5\n{options}\n[CL]\n0 = 0.1\nalpha = 4.0\n"
        ));
        assert!(problems.is_empty(), "{problems:?}");
        model
    }

    /// τ in units of c̄/V is τ·c̄/V seconds; τ2 acting only while α̇ < 0
    /// leaves χ∞ at its α̇ = 0 value while α rises; the attached-flow
    /// induced drag squares CL with χ = 1.
    #[test]
    fn stall_variants_change_what_they_say() {
        let seconds = stall("");
        let chord = stall("time_unit = \"chord/V\"");
        let (alpha, alpha_dot, airspeed) = (0.32, -0.05, 80.0);
        let scale = 3.159 / airspeed;
        let mut equivalent = seconds.clone();
        equivalent.parameters.set("tau1", 0.2 * scale).unwrap();
        equivalent.parameters.set("tau2", 0.5 * scale).unwrap();
        let target = chord.separation_target(alpha, alpha_dot, airspeed);
        assert!((target - equivalent.separation_target(alpha, alpha_dot, 1.0)).abs() < 1e-15);
        let rate = chord.separation_rate(alpha, alpha_dot, 0.5, airspeed);
        assert!((rate - equivalent.separation_rate(alpha, alpha_dot, 0.5, 1.0)).abs() < 1e-12);
        assert_ne!(
            target,
            seconds.separation_target(alpha, alpha_dot, airspeed)
        );
        let one_sided = stall("tau2_only_while_decreasing = true");
        let steady = one_sided.steady_separation(alpha);
        assert_eq!(one_sided.separation_target(alpha, 0.05, 1.0), steady);
        assert_ne!(seconds.separation_target(alpha, 0.05, 1.0), steady);
        assert_eq!(
            one_sided.separation_target(alpha, -0.05, 1.0),
            seconds.separation_target(alpha, -0.05, 1.0)
        );
        assert_eq!(one_sided.separation_rate_slope(alpha, 0.05, 1.0), 0.0);
        let attached = stall("induced_drag_lift = \"attached\"");
        let input = AeroInput {
            alpha,
            airspeed,
            chi: 0.3,
            ..Default::default()
        };
        let induced =
            |lift: f64| lift * lift / (0.8 * std::f64::consts::PI * geometry().aspect_ratio);
        let lift_attached = 0.1 + 4.0 * alpha;
        let c = attached.coefficients(&input);
        assert!(c.lift < lift_attached - 0.1);
        assert!((c.drag - induced(lift_attached)).abs() < 1e-15);
        let c = seconds.coefficients(&input);
        assert!((c.drag - induced(c.lift)).abs() < 1e-15);
        assert!(!attached.offset_response_is_exact() && seconds.offset_response_is_exact());
    }

    /// The smooth switch of the one-sided τ2 is α̇ well below −2b and 0
    /// well above 2b, and ∂χ̇/∂α̇ is its derivative (to a central
    /// difference's error); the measured α̇ replaces the state's in χ only
    /// with `alpha_dot = "measured"`, and only where one is given.
    #[test]
    fn smooth_switch_and_measured_alpha_dot() {
        let (alpha, airspeed) = (0.32, 80.0);
        let smooth = stall("tau2_only_while_decreasing = true\ntau2_switch_band = 0.01");
        let sharp = stall("tau2_only_while_decreasing = true");
        for alpha_dot in [-0.1, 0.1] {
            let (a, b) = (
                smooth.separation_target(alpha, alpha_dot, 1.0),
                sharp.separation_target(alpha, alpha_dot, 1.0),
            );
            assert!((a - b).abs() < 1e-8, "{alpha_dot}: {a} vs {b}");
        }
        for alpha_dot in [-0.02, -0.005, 0.0, 0.004, 0.03] {
            let h = 1e-6;
            let rate = |d: f64| smooth.separation_rate(alpha, d, 0.5, airspeed);
            let difference = (rate(alpha_dot + h) - rate(alpha_dot - h)) / (2.0 * h);
            let slope = smooth.separation_rate_slope(alpha, alpha_dot, airspeed);
            assert!(
                (slope - difference).abs() < 1e-6 * difference.abs().max(1.0),
                "{alpha_dot}: {slope} vs {difference}"
            );
        }
        let (_, problems) = parse(
            "model = \"stall\"\n[stall]\na1 = 20.0\nalpha_star = 0.3\ntau1 = 0.0\ntau2 = 0.5\ntau2_switch_band = 0.01\n[CL]\nalpha = 4.0\n",
        );
        let fields: Vec<&str> = problems.0.iter().map(|p| p.field.as_str()).collect();
        assert_eq!(fields, ["aero.stall.tau2_switch_band"]);
        let measured = stall("alpha_dot = \"measured\"");
        let state = stall("");
        assert!(measured.takes_measured_alpha_dot() && !state.takes_measured_alpha_dot());
        assert_eq!(measured.separation_alpha_dot(-0.05, Some(0.02)), 0.02);
        assert_eq!(measured.separation_alpha_dot(-0.05, None), -0.05);
        assert_eq!(state.separation_alpha_dot(-0.05, Some(0.02)), -0.05);
        let mut algebraic = measured.clone();
        algebraic.parameters.set("tau1", 0.0).unwrap();
        assert!(!algebraic.forces_depend_on_alpha_dot());
        assert!(algebraic.forces_depend_on_state_alpha_dot(false));
        let input = AeroInput {
            alpha,
            airspeed,
            alpha_dot: -0.05,
            measured_alpha_dot: Some(0.02),
            ..Default::default()
        };
        assert_eq!(
            algebraic.effective_chi(&input),
            algebraic.separation_target(alpha, 0.02, airspeed)
        );
    }

    #[test]
    fn every_problem_is_reported() {
        let (_, problems) =
            parse("[CL]\nalpha = nan\nbogus = 1.0\n[CQ]\n0 = 1.0\n[Cm]\nchi = 0.1\n");
        let fields: Vec<&str> = problems.0.iter().map(|p| p.field.as_str()).collect();
        assert_eq!(
            fields,
            ["aero.CL.alpha", "aero.CL.bogus", "aero.CQ", "aero.Cm.chi"],
            "{problems:?}"
        );
    }
}
