//! The aerodynamic model ([`AeroModel`]): its parameters and terms, built
//! from an `[aero]` table with every problem collected, and the flight
//! variables it is evaluated at ([`AeroInput`]) and the coefficients it
//! gives ([`AeroCoefficients`]), over a [`Real`] scalar (f64 or a dual
//! number carrying derivatives). Evaluation is in `evaluate`, the stall
//! model in `stall`, ties in `ties`.

use super::spec::{
    AeroSpec, ModelKind, RateNormalization, RateSpeed, ReferenceGeometry, StallOptions,
};
use super::terms::{Coefficient, ForceAxes, MAX_PRODUCTS, Monomial, Regressor, Term, TermError};
use crate::params::ParameterSet;
use crate::state::Controls;
use aeroid_core::error::FieldErrors;
use aeroid_numerics::dual::Real;
use nalgebra::Vector3;

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct StallIndices {
    pub(super) a1: usize,
    pub(super) alpha_star: usize,
    pub(super) tau1: usize,
    pub(super) tau2: usize,
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
    pub(super) terms: [Vec<Term>; 6],
    /// The distinct products (terms of degree ≥ 2), in the order their
    /// values follow the regressors in [`TermRegressors`](super::TermRegressors).
    pub(super) products: Vec<Monomial>,
    pub(super) oswald: Option<usize>,
    pub(super) stall: Option<StallIndices>,
    /// The stall model's options (unit of τ, one-sided τ2, induced-drag
    /// lift, source of α̇).
    pub(super) stall_options: StallOptions,
    /// Whether any coefficient has an α̇ term (fixed by the structure, not the values).
    pub(super) has_alpha_dot_terms: bool,
    /// Added to each coefficient (in [`Coefficient`] order; the lift-type one
    /// before it enters CL² drag). Zero in flight: output error moves one by
    /// a small step to get ∂f/∂C for its sensitivity equations where the
    /// forces depend on α̇ (elsewhere [`AeroModel::offset_response`] gives
    /// it exactly).
    pub offsets: [f64; 6],
}

impl AeroModel {
    /// Builds a model from its file table, collecting every problem under `prefix` (e.g. "aero").
    pub fn from_spec(
        spec: &AeroSpec,
        geometry: ReferenceGeometry,
        prefix: &str,
        problems: &mut FieldErrors,
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

    fn read_coefficients(&mut self, spec: &AeroSpec, prefix: &str, problems: &mut FieldErrors) {
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
    ) -> Result<Monomial, TermError> {
        let monomial = match Regressor::from_key(key) {
            Some(regressor) => Monomial::from(regressor),
            None if key.contains(['*', '^']) => Monomial::parse(key)?,
            None => {
                return Err(TermError::UnknownTerm {
                    key: key.to_string(),
                });
            }
        };
        if !value.is_finite() {
            return Err(TermError::NotFinite(value));
        }
        let lift_squared = monomial.contains(Regressor::LiftSquared);
        if lift_squared && (coefficient != Coefficient::Drag || self.force_axes != ForceAxes::Wind)
        {
            return Err(TermError::LiftSquaredAxes);
        }
        if lift_squared && monomial.single().is_none() {
            return Err(TermError::LiftSquaredProduct);
        }
        if monomial.contains(Regressor::Separation) && self.kind != ModelKind::Stall {
            return Err(TermError::SeparationNeedsStall);
        }
        Ok(monomial)
    }

    /// Registers a product's slot in [`TermRegressors`](super::TermRegressors)
    /// (once per distinct product).
    fn add_product(&mut self, monomial: Monomial, field: &str, problems: &mut FieldErrors) {
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
        problems: &mut FieldErrors,
    ) -> usize {
        self.parameters.add(name, value).unwrap_or_else(|message| {
            problems.push(field, message);
            self.parameters.index(name).unwrap_or(0)
        })
    }

    fn read_extras(&mut self, spec: &AeroSpec, prefix: &str, problems: &mut FieldErrors) {
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

    fn read_stall(&mut self, spec: &AeroSpec, prefix: &str, problems: &mut FieldErrors) {
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

    fn check_references(&self, spec: &AeroSpec, prefix: &str, problems: &mut FieldErrors) {
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
            Some(m) if !(m.is_finite() && m >= 0.0) => problems.push(
                format!("{prefix}.reference_mach"),
                "must be a Mach number, zero or more (0 for terms in Mach itself)",
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
    pub fn check_replacement(&self, name: &str, value: f64) -> Result<(), crate::error::Error> {
        if !value.is_finite() {
            return Err(aeroid_core::Error::NotFinite {
                value: value.to_string(),
            }
            .into());
        }
        let index = self.parameters.index(name);
        if index.is_some() && index == self.oswald && value <= 0.0 {
            return Err(crate::error::Error::Replacement {
                reason: "the Oswald factor e must be positive",
                value,
            });
        }
        if let Some(s) = self.stall
            && index == Some(s.tau1)
            && (value > 0.0) != self.chi_is_state()
        {
            return Err(crate::error::Error::Replacement {
                reason: match self.chi_is_state() {
                    true => "tau1 must stay positive (χ is a state of this aircraft)",
                    false => "tau1 must stay 0 (χ is algebraic for this aircraft)",
                },
                value,
            });
        }
        Ok(())
    }
}
