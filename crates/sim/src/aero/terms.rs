//! What a coefficient is made of: the regressors ([`Regressor`]) a term's
//! parameter multiplies, their products ([`Monomial`], `alpha^2`,
//! `alpha*dMach`), the six coefficients and the axes their forces are
//! written in, a model's terms and the relation a tied term follows
//! ([`Tie`], θ = c·θ_master + d), and the table of the values every term
//! multiplies at one flight condition ([`TermRegressors`]).
//!
//! A coefficient is Σ C_term · regressor, the parameter named
//! `{coefficient}_{term}` (`CL_alpha`, `Cm_q`, `CD_0`); rates are normalised
//! p·b/(kV), q·c̄/(kV), r·b/(kV) (k = 2 or 1). The keys are those of
//! docs/files.md, "Aircraft (`aircraft/*.toml`)".

use aeroid_numerics::dual::Real;
use serde::{Deserialize, Serialize};

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

    pub(super) fn keys() -> String {
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
    pub fn parse(text: &str) -> Result<Monomial, TermError> {
        let mut factors = Vec::new();
        for factor in text.split('*') {
            let (key, power) = match factor.split_once('^') {
                Some((key, power)) => (key, power),
                None => (factor, "1"),
            };
            let regressor =
                Regressor::from_key(key.trim()).ok_or_else(|| TermError::UnknownRegressor {
                    key: key.trim().to_string(),
                    term: text.to_string(),
                })?;
            let power: usize = match power.trim().parse::<i64>() {
                Ok(power) if power >= 1 => power as usize,
                _ => {
                    return Err(TermError::Power {
                        power: power.trim().to_string(),
                        key: key.trim().to_string(),
                        term: text.to_string(),
                    });
                }
            };
            factors.extend(std::iter::repeat_n(regressor, power.min(MAX_DEGREE + 1)));
            if factors.len() > MAX_DEGREE {
                return Err(TermError::Degree(text.to_string()));
            }
        }
        if factors.len() > 1 && factors.contains(&Regressor::Constant) {
            return Err(TermError::ConstantFactor(text.to_string()));
        }
        let monomial = Monomial::from_factors(&factors)
            .ok_or_else(|| TermError::NoFactor(text.to_string()))?;
        let canonical = monomial.key();
        if canonical != text {
            return Err(TermError::NotCanonical {
                term: text.to_string(),
                canonical,
            });
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

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Term {
    pub(super) monomial: Monomial,
    pub(super) parameter: usize,
    /// The relation the parameter follows, when it is tied to another.
    pub(super) tie: Option<Tie>,
}

impl Term {
    /// The term's coefficient given every parameter's value: its own, or
    /// for a tied term c·θ_master + d.
    #[inline(always)]
    pub(super) fn coefficient(&self, values: &[f64]) -> f64 {
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

/// Why a coefficient-table key or value is not a term the model can take.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TermError {
    #[error(
        "unknown regressor '{key}' in term '{term}'; known: {}",
        Regressor::keys()
    )]
    UnknownRegressor { key: String, term: String },
    #[error(
        "unknown term '{key}'; known: {} and their products ('alpha^2', 'alpha*de')",
        Regressor::keys()
    )]
    UnknownTerm { key: String },
    #[error("the power '{power}' of '{key}' in term '{term}' must be an integer ≥ 1")]
    Power {
        power: String,
        key: String,
        term: String,
    },
    #[error("term '{0}' has a degree above {MAX_DEGREE}, the most a term may have")]
    Degree(String),
    #[error("term '{0}': the constant 0 cannot be a factor of a product")]
    ConstantFactor(String),
    #[error("term '{0}' has no factor")]
    NoFactor(String),
    #[error(
        "write term '{term}' as '{canonical}' (factors in the order {}, a repeated factor once with its power ^n)",
        Regressor::keys()
    )]
    NotCanonical { term: String, canonical: String },
    #[error("the constant '0' is always in the model; keys: {}", Regressor::keys())]
    Constant,
    #[error("{0} is not a finite number")]
    NotFinite(f64),
    #[error("CL2 is a drag term of a wind-axis model")]
    LiftSquaredAxes,
    #[error("CL2 cannot be a factor of a product")]
    LiftSquaredProduct,
    #[error("chi terms need model = \"stall\"")]
    SeparationNeedsStall,
}
